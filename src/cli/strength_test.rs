//! `anisobond strength-test`: the virtual laboratory ([`anisobond::study::strength_test`]):
//! UCS, direct tension or the Brazilian disc on a specimen cut from a packing at a bedding
//! angle, run to failure with the integrator; peak stress, E and ν from the initial slope,
//! crack counts (JSON, CSV, PNG, VTK).

use super::run::LawArg;
use anisobond::dem::LawKind;
use anisobond::io::OutputSet;
use anisobond::model::Model;
use anisobond::packing::read_packing;
use anisobond::study::strength_sweep::{
    parse_angles, run as run_sweep_study, StrengthSweepOptions,
};
use anisobond::study::strength_test::{
    run as run_study, SpecimenShape, StrengthTestOptions, StrengthTestProgress, StrengthTestReport,
    TestKind,
};
use anisobond::study::OptionNames;
use anisobond::Result;
use indicatif::ProgressBar;
use std::path::PathBuf;
use std::sync::Mutex;

/// Which test.
#[derive(Clone, Copy, clap::ValueEnum, PartialEq, Eq, Debug)]
pub enum TestArg {
    /// Uniaxial compression between glued platens.
    Ucs,
    /// Direct tension between glued platens.
    Tension,
    /// The Brazilian disc between two flat rigid platens (spheres stick on contact):
    /// σ_t = 2P/(πDt).
    Brazilian,
}

/// Cross-section of a UCS or tension specimen.
#[derive(Clone, Copy, clap::ValueEnum, PartialEq, Eq, Debug)]
pub enum ShapeArg {
    /// A square prism.
    Prism,
    /// A circular cylinder.
    Cylinder,
}

impl From<TestKind> for TestArg {
    fn from(t: TestKind) -> Self {
        match t {
            TestKind::Ucs => TestArg::Ucs,
            TestKind::Tension => TestArg::Tension,
            TestKind::Brazilian => TestArg::Brazilian,
        }
    }
}

impl From<SpecimenShape> for ShapeArg {
    fn from(s: SpecimenShape) -> Self {
        match s {
            SpecimenShape::Prism => ShapeArg::Prism,
            SpecimenShape::Cylinder => ShapeArg::Cylinder,
        }
    }
}

/// The flag's value of a bond law.
fn law_arg(l: LawKind) -> LawArg {
    match l {
        LawKind::Yade => LawArg::Yade,
        LawKind::ParallelBond => LawArg::ParallelBond,
        LawKind::Kumar => LawArg::Kumar,
        LawKind::LammpsBpm => LawArg::LammpsBpm,
    }
}

/// The study's defaults (the library's, once).
fn d() -> StrengthTestOptions {
    StrengthTestOptions::default()
}

/// The virtual laboratory's specimen, loading and packing flags, shared by
/// `strength-test` and `calibrate-strength`.
#[derive(clap::Args)]
pub struct LabArgs {
    /// Cross-section of a UCS or tension specimen (the Brazilian specimen is a disc).
    #[arg(long, value_enum, default_value_t = ShapeArg::from(d().shape))]
    pub(super) shape: ShapeArg,
    /// Packing file the specimen is cut from (centred on its cell or bounding box); default:
    /// a generated periodic packing of --cell-particles spheres (R̄ = 1 mm).
    #[arg(long)]
    pub(super) packing: Option<PathBuf>,
    /// Bond law of the integrator.
    #[arg(long, value_enum, default_value_t = law_arg(d().law))]
    pub(super) law: LawArg,
    /// Bedding angle β (degrees): the model (its cross-anisotropic axis, crystal rotation,
    /// strength axis and planes of weakness) is turned by β about y; for a model whose axis
    /// is z, β is its angle to the loading axis z.
    #[arg(long, default_value_t = d().bedding_deg, allow_negative_numbers = true)]
    pub(super) bedding_deg: f64,
    /// Width of the prism, diameter of the cylinder or disc, in mean radii R̄.
    #[arg(long, default_value_t = d().width_particles)]
    pub(super) width_particles: f64,
    /// Length over width (UCS, tension; default 2) or thickness over diameter (Brazilian;
    /// default 0.5).
    #[arg(long)]
    pub(super) aspect: Option<f64>,
    /// Depth of the glued end layers in R̄ (UCS, tension).
    #[arg(long, default_value_t = d().end_layer)]
    pub(super) end_layer: f64,
    /// Axial strain added per wave transit time (at most 0.01; smaller is more
    /// quasi-static, and slower).
    #[arg(long, default_value_t = d().loading_rate)]
    pub(super) loading_rate: f64,
    /// The run ends at this axial strain if the stress has not dropped before.
    #[arg(long, default_value_t = d().max_strain)]
    pub(super) max_strain: f64,
    /// The run ends once bonds have broken and the stress is below this fraction of its peak.
    #[arg(long, default_value_t = d().stop_fraction)]
    pub(super) stop_fraction: f64,
    /// The reported peak is the first one: the largest stress before the stress first falls
    /// below (1 − this) × its running maximum after bonds broke (at most 1 − --stop-fraction);
    /// the whole curve's largest stress is reported apart (max_stress_pa).
    #[arg(long, default_value_t = d().peak_drop)]
    pub(super) peak_drop: f64,
    /// Cundall local damping λ in [0, 1).
    #[arg(long, default_value_t = d().local_damping)]
    pub(super) local_damping: f64,
    /// Spheres of the generated packing (without --packing).
    #[arg(long, default_value_t = d().cell_particles, conflicts_with = "packing")]
    pub(super) cell_particles: usize,
    /// Seed of the generated packing.
    #[arg(long, default_value_t = d().seed, conflicts_with = "packing")]
    pub(super) seed: u64,
    /// Recorded points of the curve up to --max-strain.
    #[arg(long, default_value_t = d().points)]
    pub(super) points: usize,
}

impl LabArgs {
    /// The lab's options for `test` with `model` (the packing file read).
    pub fn options(&self, test: TestKind, model: Option<Model>) -> Result<StrengthTestOptions> {
        Ok(StrengthTestOptions {
            test,
            shape: match self.shape {
                ShapeArg::Prism => SpecimenShape::Prism,
                ShapeArg::Cylinder => SpecimenShape::Cylinder,
            },
            packing: self.packing.as_deref().map(read_packing).transpose()?,
            model,
            law: LawKind::from(self.law),
            bedding_deg: self.bedding_deg,
            width_particles: self.width_particles,
            aspect: self.aspect,
            end_layer: self.end_layer,
            loading_rate: self.loading_rate,
            max_strain: self.max_strain,
            stop_fraction: self.stop_fraction,
            peak_drop: self.peak_drop,
            local_damping: self.local_damping,
            cell_particles: self.cell_particles,
            seed: self.seed,
            points: self.points,
        })
    }
}

/// Options of `anisobond strength-test`.
#[derive(clap::Args)]
pub struct StrengthTestArgs {
    /// The test.
    #[arg(long, value_enum, default_value_t = TestArg::from(d().test))]
    test: TestArg,
    /// Model file (docs/formats.md; its [strength] table gives the bond strengths,
    /// docs/strength.md); default: isotropic bonds (gap 0.17 R̄, moduli 1e10 Pa and 3e9 Pa)
    /// with σ_t = 5 MPa, c = 10 MPa.
    #[arg(long)]
    model: Option<PathBuf>,
    /// The specimen, its loading and the generated packing.
    #[command(flatten)]
    lab: LabArgs,
    /// Run the bedding sweep instead of one test: UCS and Brazilian disc at each angle β of
    /// START:STEP:STOP (inclusive, e.g. 0:15:90) or a comma list (0,45,90); writes
    /// strength_sweep.json, strength_sweep.csv and strength_sweep.png (strengths over the
    /// first angle's).
    #[arg(long, conflicts_with_all = ["test", "bedding_deg"])]
    bedding_sweep: Option<String>,
    /// Output folder: strength_test.json, strength_test.csv (the curve), strength_test.png,
    /// strength_test_bonds.vtu (every bond's state, time and mode of breaking).
    #[arg(short, long, default_value = "anisobond-strength-test")]
    output: PathBuf,
}

impl StrengthTestArgs {
    /// The study's options (the packing and model files read).
    fn options(&self) -> Result<StrengthTestOptions> {
        let test = match self.test {
            TestArg::Ucs => TestKind::Ucs,
            TestArg::Tension => TestKind::Tension,
            TestArg::Brazilian => TestKind::Brazilian,
        };
        let model = self.model.as_deref().map(Model::from_path).transpose()?;
        self.lab.options(test, model)
    }

    /// The output set (its inputs: the packing and model files given) and the output
    /// folder staged in it.
    fn outputs(&self) -> Result<(OutputSet, PathBuf)> {
        let inputs: Vec<&std::path::Path> = [self.lab.packing.as_deref(), self.model.as_deref()]
            .into_iter()
            .flatten()
            .collect();
        let mut out = OutputSet::new(&inputs);
        let dir = out.dir(&self.output)?;
        Ok((out, dir))
    }
}

/// The summary printed after the run.
fn print_summary(r: &StrengthTestReport) {
    let opt = |v: Option<f64>, f: &dyn Fn(f64) -> String| v.map_or("-".to_string(), f);
    println!(
        "{} test ({}), β = {}°: {} particles, {} bonds, {} steps of {:.3e} s (ended: {})",
        r.test, r.shape, r.bedding_deg, r.particles, r.bonds, r.steps, r.time_step_s, r.stop
    );
    println!(
        "  peak stress {:.4e} Pa at strain {:.4e} ({}); kinetic/elastic energy at the peak {:.2e}",
        r.peak_stress_pa,
        r.strain_at_peak,
        if r.peak_dropped {
            format!(
                "first peak: the stress then fell by {} %",
                100.0 * r.peak_drop
            )
        } else {
            "the largest stress; it never fell after".to_string()
        },
        r.kinetic_over_elastic_at_peak
    );
    if r.max_stress_pa > r.peak_stress_pa {
        println!(
            "  largest stress of the whole curve {:.4e} Pa at strain {:.4e} (after the first peak)",
            r.max_stress_pa, r.strain_at_max
        );
    }
    println!(
        "  E = {} Pa, ν = {} (fit on {} points, 10–50 % of the peak); static solve: E = {} Pa, ν = {}",
        opt(r.modulus_pa, &|x| format!("{x:.4e}")),
        opt(r.poisson, &|x| format!("{x:.4}")),
        r.fit_points,
        opt(r.static_modulus_pa, &|x| format!("{x:.4e}")),
        opt(r.static_poisson, &|x| format!("{x:.4}")),
    );
    let c = &r.cracks;
    println!(
        "  cracks: {} (tension {}, shear {}, bending {}, twisting {}); broken fraction {:.4}",
        c.total, c.tension, c.shear, c.bending, c.twisting, r.broken_fraction
    );
    for n in &r.notes {
        println!("  note: {n}");
    }
}

/// `anisobond strength-test --bedding-sweep`: the sweep study, a line per lab run, its files.
fn run_sweep(a: &StrengthTestArgs, angles: &str) -> Result<()> {
    let angles_deg = parse_angles(angles, "--bedding-sweep")?;
    let opts = StrengthSweepOptions {
        lab: a.options()?,
        angles_deg,
    };
    opts.check(OptionNames::Flags)?;
    let (out, dir) = a.outputs()?;
    let report = run_sweep_study(&opts, &|p| {
        println!(
            "[{}/{}] {} at β = {}°: peak {:.4e} Pa",
            p.run, p.runs, p.test, p.bedding_deg, p.peak_pa
        );
    })?;
    report.write(&dir)?;
    out.commit()?;
    println!(
        "UCS specimen {} particles, {} bonds; disc {} particles, {} bonds",
        report.ucs_particles, report.ucs_bonds, report.brazilian_particles, report.brazilian_bonds
    );
    println!("  β (°)   UCS (Pa)     /ref    E (Pa)      ν       Brazilian (Pa) /ref   cracks UCS (t/s)  disc (t/s)");
    let opt = |v: Option<f64>, f: &dyn Fn(f64) -> String| v.map_or("-".to_string(), f);
    for r in &report.rows {
        println!(
            "  {:>5}   {:.4e}  {:.3}  {:>10}  {:>6}  {:.4e}     {:.3}  {}/{}  {}/{}",
            r.bedding_deg,
            r.ucs_pa,
            r.ucs_ratio,
            opt(r.modulus_pa, &|x| format!("{x:.3e}")),
            opt(r.poisson, &|x| format!("{x:.3}")),
            r.brazilian_pa,
            r.brazilian_ratio,
            r.ucs_cracks.tension,
            r.ucs_cracks.shear,
            r.brazilian_cracks.tension,
            r.brazilian_cracks.shear
        );
    }
    println!(
        "wrote {}/strength_sweep.json, strength_sweep.csv, strength_sweep.png",
        a.output.display()
    );
    Ok(())
}

/// Run `anisobond strength-test`: the library's study with a progress bar, then its files.
pub fn run(a: StrengthTestArgs) -> Result<()> {
    if let Some(angles) = a.bedding_sweep.clone() {
        return run_sweep(&a, &angles);
    }
    let opts = a.options()?;
    opts.check(OptionNames::Flags)?;
    let (out, dir) = a.outputs()?;
    let bar: Mutex<Option<ProgressBar>> = Mutex::new(None);
    let report = run_study(&opts, &|p| match p {
        StrengthTestProgress::Specimen {
            particles,
            bonds,
            time_step,
            max_steps,
        } => {
            println!(
                "specimen: {particles} particles, {bonds} bonds; time step {time_step:.3e} s, \
                 at most {max_steps} steps"
            );
            *bar.lock().unwrap_or_else(|e| e.into_inner()) =
                Some(super::output::progress_bar(a.test.name()));
        }
        StrengthTestProgress::Loading { fraction, .. } => {
            if let Some(b) = bar.lock().unwrap_or_else(|e| e.into_inner()).as_ref() {
                b.set_position((fraction.clamp(0.0, 1.0) * 1000.0) as u64);
            }
        }
    });
    if let Some(b) = bar.lock().unwrap_or_else(|e| e.into_inner()).take() {
        b.finish_and_clear();
    }
    let report = report?;
    report.write(&dir)?;
    out.commit()?;
    print_summary(&report);
    println!(
        "wrote {}/strength_test.json, strength_test.csv, strength_test.png, strength_test_bonds.vtu",
        a.output.display()
    );
    Ok(())
}

impl TestArg {
    /// The progress bar's label.
    fn name(self) -> &'static str {
        match self {
            TestArg::Ucs => "UCS",
            TestArg::Tension => "tension",
            TestArg::Brazilian => "Brazilian disc",
        }
    }
}
