//! Quasi-static compression of a clamped bar with the integrator (Kumar 2016 Sec. 5,
//! Figs. 7–9): the first end set held still, the second moved along the axis at constant
//! velocity (translations prescribed, rotations blocked), the axial stress from the
//! reactions on the moved end, and Kumar's normalised kinetic energy per particle
//! Ẽ_kin = E_kin/(n·max(N·R)) (Eq. 16) along the run.

use super::{build_law, DemOptions, LawKind, Simulation};
use crate::homogenize::buckling::RoundBar;
use crate::{Error, Result};

/// Settings of a compression run.
#[derive(Clone, Copy, Debug)]
pub struct CompressionOptions {
    /// Axial strain reached at the end of the run (shortening / l).
    pub max_strain: f64,
    /// Time steps to reach it (the loading rate: more steps, closer to quasi-static).
    pub steps: usize,
    /// Steps between recorded points.
    pub record_every: usize,
    /// Bond law of the integrator.
    pub law: LawKind,
    /// Time step, damping and masses.
    pub dem: DemOptions,
}

impl Default for CompressionOptions {
    fn default() -> Self {
        CompressionOptions {
            max_strain: 0.01,
            steps: 100_000,
            record_every: 500,
            law: LawKind::Kumar,
            dem: DemOptions::default(),
        }
    }
}

/// One recorded state.
#[derive(Clone, Copy, Debug, serde::Serialize)]
pub struct CompressionPoint {
    /// Axial strain (shortening / l).
    pub strain: f64,
    /// Axial stress (Pa, compression positive): the moved end's reaction over πr².
    pub stress: f64,
    /// Ẽ_kin of Kumar 2016 Eq. 16.
    pub kinetic_ratio: f64,
}

/// The stress–strain curve and its maximum.
#[derive(Clone, Debug, serde::Serialize)]
pub struct CompressionResult {
    /// Recorded states, in order.
    pub history: Vec<CompressionPoint>,
    /// Largest axial stress (Pa).
    pub max_stress: f64,
    /// Strain at the largest stress.
    pub strain_at_max: f64,
    /// Largest Ẽ_kin recorded up to the maximum (Kumar: below 1e-8 for quasi-static).
    pub max_kinetic_ratio_before_peak: f64,
    /// Time step used (s).
    pub time_step: f64,
    /// True when the maximum is the last point (the bar had not buckled by `max_strain`).
    pub peak_at_end: bool,
}

/// Compress `bar` (clamped ends) with the integrator and record σ, ε, Ẽ_kin. Refuses a
/// strain that is not finite and in (0, 0.5), zero steps or recording interval.
pub fn compress_clamped_bar(
    bar: &RoundBar,
    opts: &CompressionOptions,
) -> Result<CompressionResult> {
    if !(opts.max_strain.is_finite() && opts.max_strain > 0.0 && opts.max_strain < 0.5) {
        return Err(Error::Invalid(format!(
            "compression: the final strain must be in (0, 0.5), got {}",
            opts.max_strain
        )));
    }
    if opts.steps == 0 || opts.record_every == 0 {
        return Err(Error::Invalid(
            "compression: steps and recording interval must be > 0".into(),
        ));
    }
    let a = &bar.assembly;
    let law = build_law(opts.law, &a.packing, &a.bonds, &a.springs)?;
    let mut sim = Simulation::new(&a.packing, &a.bonds, law, &opts.dem)?;
    let dt = sim.time_step();
    let axis = bar.region.axis();
    let speed = opts.max_strain * bar.length / (opts.steps as f64 * dt);
    let first = &bar.boundary.first_end;
    let second = &bar.boundary.second_end;
    let particles: Vec<usize> = first.iter().chain(second).map(|&p| p as usize).collect();
    let velocity = first
        .iter()
        .map(|_| crate::Vec3::zeros())
        .chain(second.iter().map(|_| -axis * speed))
        .collect();
    sim.set_prescribed_motion(Some(super::sim::PrescribedMotion {
        particles,
        velocity,
    }))?;
    let area = bar.area();
    let n = a.packing.len() as f64;
    let mut history = Vec::new();
    for s in 1..=opts.steps {
        sim.step()?;
        if s % opts.record_every == 0 || s == opts.steps {
            let stress = second
                .iter()
                .map(|&p| sim.force[p as usize].dot(&axis))
                .sum::<f64>()
                / area;
            let mut max_nr: f64 = 0.0;
            for b in 0..a.bonds.len() {
                let nrm = sim.branch(b).normalize();
                let normal = sim.loads.per_bond[b].force_i.dot(&nrm).abs();
                let (i, j) = (a.bonds.i[b] as usize, a.bonds.j[b] as usize);
                let r = 0.5 * (a.packing.radii[i] + a.packing.radii[j]);
                max_nr = max_nr.max(normal * r);
            }
            let kinetic = sim.energies().kinetic;
            let kinetic_ratio = if max_nr > 0.0 {
                kinetic / (n * max_nr)
            } else {
                0.0
            };
            if !(stress.is_finite() && kinetic_ratio.is_finite()) {
                return Err(Error::Degenerate(format!(
                    "compression: non-finite stress or kinetic energy at step {s}"
                )));
            }
            history.push(CompressionPoint {
                strain: s as f64 * speed * dt / bar.length,
                stress,
                kinetic_ratio,
            });
        }
    }
    let (k, peak) = history
        .iter()
        .enumerate()
        .max_by(|x, y| x.1.stress.total_cmp(&y.1.stress))
        .map(|(k, p)| (k, *p))
        .ok_or_else(|| Error::Invalid("compression: nothing recorded".into()))?;
    let max_kinetic_ratio_before_peak = history[..=k]
        .iter()
        .map(|p| p.kinetic_ratio)
        .fold(0.0, f64::max);
    Ok(CompressionResult {
        peak_at_end: k + 1 == history.len(),
        history,
        max_stress: peak.stress,
        strain_at_max: peak.strain,
        max_kinetic_ratio_before_peak,
        time_step: dt,
    })
}
