//! The bedding sweep (issue 32, "a transversely isotropic rock"; docs/strength-test.md): the
//! virtual laboratory's UCS and Brazilian disc ([`super::strength_test`]) at a list of
//! bedding angles β on one packing with one model. Each angle is exactly one lab run per
//! test with `bedding_deg = β` (the sweep equals its parts); the report gives per angle the
//! UCS (first peak), E and ν of its initial slope, the Brazilian σ_t, cracks by mode, and
//! both strengths over those of the first angle of the list (the reference, normally
//! β = 0). `anisobond strength-test --bedding-sweep 0:15:90` writes strength_sweep.json,
//! strength_sweep.csv and strength_sweep.png; `anisobond.strength_sweep` returns the dict.

use super::strength_test::{
    run as run_lab, CrackCounts, StrengthTestOptions, StrengthTestReport, TestKind,
};
use super::OptionNames;
use crate::dem::LawKind;
use crate::{Error, Result};
use serde::Serialize;

/// The options: the lab's (its `test` and `bedding_deg` are set per run) and the angles.
#[derive(Clone, Debug)]
pub struct StrengthSweepOptions {
    /// The lab's options: packing, model, law, specimen size, rate, stopping, peak rule.
    pub lab: StrengthTestOptions,
    /// The bedding angles β (degrees), in the order run; the first is the reference of the
    /// ratios.
    pub angles_deg: Vec<f64>,
}

impl Default for StrengthSweepOptions {
    fn default() -> Self {
        StrengthSweepOptions {
            lab: StrengthTestOptions::default(),
            angles_deg: (0..=6).map(|k| 15.0 * k as f64).collect(),
        }
    }
}

/// Parse a list of angles: `START:STEP:STOP` (inclusive, STEP > 0, e.g. `0:15:90`) or a
/// comma list (`0,30,45,90`); refuses anything else naming `what` (the option).
pub fn parse_angles(text: &str, what: &str) -> Result<Vec<f64>> {
    let bad = |why: &str| Error::Invalid(format!("{what} `{text}`: {why}"));
    let num = |s: &str| -> Result<f64> {
        s.trim()
            .parse::<f64>()
            .ok()
            .filter(|v| v.is_finite())
            .ok_or_else(|| bad(&format!("`{s}` is not a finite angle in degrees")))
    };
    let angles = if text.contains(':') {
        let parts: Vec<&str> = text.split(':').collect();
        let [a, s, b] = parts[..] else {
            return Err(bad("expected START:STEP:STOP, e.g. 0:15:90"));
        };
        let (a, s, b) = (num(a)?, num(s)?, num(b)?);
        if s <= 0.0 || b < a {
            return Err(bad("expected STEP > 0 and STOP ≥ START"));
        }
        let n = ((b - a) / s + 1e-9).floor() as usize;
        if n > 1000 {
            return Err(bad("more than 1000 angles"));
        }
        (0..=n).map(|k| a + s * k as f64).collect()
    } else {
        text.split(',').map(num).collect::<Result<Vec<f64>>>()?
    };
    check_angles(&angles, what)?;
    Ok(angles)
}

/// Refuses an empty list, a non-finite angle, or the same angle twice, naming `what`.
fn check_angles(angles: &[f64], what: &str) -> Result<()> {
    if angles.is_empty() {
        return Err(Error::Invalid(format!(
            "{what}: expected at least one angle"
        )));
    }
    for (k, a) in angles.iter().enumerate() {
        if !a.is_finite() {
            return Err(Error::Invalid(format!(
                "{what}: angle {a} is not a finite angle in degrees"
            )));
        }
        if angles[..k].contains(a) {
            return Err(Error::Invalid(format!("{what}: angle {a} given twice")));
        }
    }
    Ok(())
}

impl StrengthSweepOptions {
    /// Refuse options that cannot give a result (the lab's checks and the angles), before
    /// any work; named as `names` does.
    pub fn check(&self, names: OptionNames) -> Result<()> {
        check_angles(&self.angles_deg, &names.name("angles_deg"))?;
        for test in [TestKind::Ucs, TestKind::Brazilian] {
            StrengthTestOptions {
                test,
                ..self.lab.clone()
            }
            .check(names)?;
        }
        Ok(())
    }
}

/// One bedding angle's results.
#[derive(Clone, Debug, Serialize)]
pub struct SweepRow {
    /// β (degrees).
    pub bedding_deg: f64,
    /// UCS (Pa): the first peak of the UCS run.
    pub ucs_pa: f64,
    /// Whether the UCS stress fell after that peak (false: the largest stress reached).
    pub ucs_peak_dropped: bool,
    /// Axial strain at the UCS peak.
    pub ucs_strain_at_peak: f64,
    /// The UCS run's largest stress (Pa), re-hardening included.
    pub ucs_max_stress_pa: f64,
    /// E fitted on the UCS initial slope (Pa).
    pub modulus_pa: Option<f64>,
    /// ν fitted on the UCS initial slope.
    pub poisson: Option<f64>,
    /// Broken bonds of the UCS run by mode.
    pub ucs_cracks: CrackCounts,
    /// Brazilian σ_t = 2P/(πDt) at the first peak (Pa).
    pub brazilian_pa: f64,
    /// Whether the disc's stress fell after that peak.
    pub brazilian_peak_dropped: bool,
    /// Broken bonds of the Brazilian run by mode.
    pub brazilian_cracks: CrackCounts,
    /// UCS over the reference angle's.
    pub ucs_ratio: f64,
    /// Brazilian σ_t over the reference angle's.
    pub brazilian_ratio: f64,
}

/// What the sweep reports as it goes: one lab run done.
#[derive(Clone, Copy, Debug)]
pub struct StrengthSweepProgress {
    /// Runs done (this one included).
    pub run: usize,
    /// Runs in all (2 per angle).
    pub runs: usize,
    /// `ucs` or `brazilian`.
    pub test: &'static str,
    /// β (degrees).
    pub bedding_deg: f64,
    /// The run's (first) peak (Pa).
    pub peak_pa: f64,
}

/// strength_sweep.json and Python's dict.
#[derive(Clone, Debug, Serialize)]
pub struct StrengthSweepReport {
    /// Units of the keys.
    pub units: serde_json::Value,
    /// The integrator's bond law.
    pub law: LawKind,
    /// The first angle of the list: the ratios' reference (degrees).
    pub reference_deg: f64,
    /// Particles and bonds of the UCS specimen (the same at every β: the model turns, the
    /// specimen does not).
    pub ucs_particles: usize,
    /// Bonds of the UCS specimen.
    pub ucs_bonds: usize,
    /// Particles of the disc.
    pub brazilian_particles: usize,
    /// Bonds of the disc.
    pub brazilian_bonds: usize,
    /// The lab's `peak_drop` (the first-peak rule).
    pub peak_drop: f64,
    /// One row per angle, in the order run.
    pub rows: Vec<SweepRow>,
    /// The UCS lab reports, one per angle.
    #[serde(skip)]
    pub ucs: Vec<StrengthTestReport>,
    /// The Brazilian lab reports, one per angle.
    #[serde(skip)]
    pub brazilian: Vec<StrengthTestReport>,
}

/// Run the sweep: for each angle a UCS and a Brazilian lab run with `bedding_deg = β` (the
/// lab's aspect left at each test's default unless given). Refuses what
/// [`StrengthSweepOptions::check`] refuses, before any work.
pub fn run(
    opts: &StrengthSweepOptions,
    progress: &(dyn Fn(StrengthSweepProgress) + Sync),
) -> Result<StrengthSweepReport> {
    opts.check(OptionNames::Flags)?;
    let runs = 2 * opts.angles_deg.len();
    let (mut ucs, mut brazilian) = (Vec::new(), Vec::new());
    for &beta in &opts.angles_deg {
        for test in [TestKind::Ucs, TestKind::Brazilian] {
            let lab = StrengthTestOptions {
                test,
                bedding_deg: beta,
                ..opts.lab.clone()
            };
            let r = run_lab(&lab, &|_| {})?;
            let peak_pa = r.peak_stress_pa;
            if test == TestKind::Ucs {
                ucs.push(r);
            } else {
                brazilian.push(r);
            }
            progress(StrengthSweepProgress {
                run: ucs.len() + brazilian.len(),
                runs,
                test: test.as_str(),
                bedding_deg: beta,
                peak_pa,
            });
        }
    }
    let (u0, b0) = (ucs[0].peak_stress_pa, brazilian[0].peak_stress_pa);
    let rows = opts
        .angles_deg
        .iter()
        .zip(ucs.iter().zip(&brazilian))
        .map(|(&beta, (u, b))| SweepRow {
            bedding_deg: beta,
            ucs_pa: u.peak_stress_pa,
            ucs_peak_dropped: u.peak_dropped,
            ucs_strain_at_peak: u.strain_at_peak,
            ucs_max_stress_pa: u.max_stress_pa,
            modulus_pa: u.modulus_pa,
            poisson: u.poisson,
            ucs_cracks: u.cracks,
            brazilian_pa: b.peak_stress_pa,
            brazilian_peak_dropped: b.peak_dropped,
            brazilian_cracks: b.cracks,
            ucs_ratio: u.peak_stress_pa / u0,
            brazilian_ratio: b.peak_stress_pa / b0,
        })
        .collect();
    Ok(StrengthSweepReport {
        units: serde_json::json!({
            "*_pa": "Pa", "*_deg": "degrees", "*_ratio": "1", "*_strain_at_peak": "1",
            "poisson": "1", "peak_drop": "1"
        }),
        law: opts.lab.law,
        reference_deg: opts.angles_deg[0],
        ucs_particles: ucs[0].particles,
        ucs_bonds: ucs[0].bonds,
        brazilian_particles: brazilian[0].particles,
        brazilian_bonds: brazilian[0].bonds,
        peak_drop: opts.lab.peak_drop,
        rows,
        ucs,
        brazilian,
    })
}

impl StrengthSweepReport {
    /// strength_sweep.json: the report as pretty JSON; refuses a non-finite number.
    pub fn to_json(&self) -> Result<String> {
        crate::io::finite_json(self, "strength_sweep.json")
    }

    /// strength_sweep.csv: one row per angle, units in the header.
    pub fn to_csv(&self) -> String {
        let mut csv = String::from(
            "bedding [deg],ucs [Pa],ucs_ratio,ucs_peak_dropped,ucs_strain_at_peak,\
             ucs_max_stress [Pa],E [Pa],nu,ucs_cracks_tension,ucs_cracks_shear,\
             ucs_cracks_total,brazilian [Pa],brazilian_ratio,brazilian_peak_dropped,\
             brazilian_cracks_tension,brazilian_cracks_shear,brazilian_cracks_total\n",
        );
        let opt = |v: Option<f64>| v.map(|x| format!("{x:e}")).unwrap_or_default();
        for r in &self.rows {
            csv += &format!(
                "{},{:e},{:e},{},{:e},{:e},{},{},{},{},{},{:e},{:e},{},{},{},{}\n",
                r.bedding_deg,
                r.ucs_pa,
                r.ucs_ratio,
                r.ucs_peak_dropped,
                r.ucs_strain_at_peak,
                r.ucs_max_stress_pa,
                opt(r.modulus_pa),
                opt(r.poisson),
                r.ucs_cracks.tension,
                r.ucs_cracks.shear,
                r.ucs_cracks.total,
                r.brazilian_pa,
                r.brazilian_ratio,
                r.brazilian_peak_dropped,
                r.brazilian_cracks.tension,
                r.brazilian_cracks.shear,
                r.brazilian_cracks.total,
            );
        }
        csv
    }

    #[cfg(feature = "plot")]
    /// strength_sweep.png: UCS and Brazilian σ_t against β, each over its value at the
    /// reference angle (given in the legend), so both fit one axis.
    pub fn plot(&self, path: &std::path::Path) -> Result<()> {
        use crate::plot::{plot_series, Series};
        let first = &self.rows[0];
        let series = vec![
            Series {
                label: format!(
                    "UCS / UCS(β = {}°) = {:.3e} Pa",
                    self.reference_deg, first.ucs_pa
                ),
                points: self
                    .rows
                    .iter()
                    .map(|r| (r.bedding_deg, r.ucs_ratio))
                    .collect(),
                dashed: false,
                colour: Some(0),
            },
            Series {
                label: format!(
                    "Brazilian σ_t / σ_t(β = {}°) = {:.3e} Pa",
                    self.reference_deg, first.brazilian_pa
                ),
                points: self
                    .rows
                    .iter()
                    .map(|r| (r.bedding_deg, r.brazilian_ratio))
                    .collect(),
                dashed: false,
                colour: Some(3),
            },
        ];
        plot_series(
            path,
            &series,
            &format!(
                "bedding sweep: UCS ({} particles) and Brazilian disc ({} particles)",
                self.ucs_particles, self.brazilian_particles
            ),
            "bedding angle β (degrees)",
            "strength over the reference angle's (1)",
        )
    }

    #[cfg(feature = "plot")]
    /// Write strength_sweep.json, strength_sweep.csv and strength_sweep.png into `dir`.
    pub fn write(&self, dir: &std::path::Path) -> Result<()> {
        crate::io::write_string_atomic(&dir.join("strength_sweep.json"), &self.to_json()?)?;
        crate::io::write_string_atomic(&dir.join("strength_sweep.csv"), &self.to_csv())?;
        self.plot(&dir.join("strength_sweep.png"))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn angles_parse_as_a_range_or_a_list_and_refuse_by_name() {
        assert_eq!(
            parse_angles("0:15:90", "--bedding-sweep").unwrap(),
            vec![0.0, 15.0, 30.0, 45.0, 60.0, 75.0, 90.0]
        );
        assert_eq!(
            parse_angles("0, 45,90", "--bedding-sweep").unwrap(),
            vec![0.0, 45.0, 90.0]
        );
        for bad in ["0:0:90", "90:15:0", "0:15", "a,b", "", "0,0", "0:nan:9"] {
            let e = parse_angles(bad, "--bedding-sweep").unwrap_err();
            assert!(matches!(e, Error::Invalid(_)), "{bad}");
            assert!(e.to_string().contains("--bedding-sweep"), "{bad}: {e}");
        }
    }
}
