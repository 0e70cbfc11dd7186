//! Element tests on a free (non-periodic) block driven through grip particles (Truszkowska
//! 2018 Sec. 4.1, 4.4): the six strain paths of Eqs. 17–22 imposed as grip velocities
//! u = Ġ·(x − x_c) relative to the block centre x_c (the form of Eq. 28), quasi-static
//! relaxation with Cundall damping, stress and strain from measurement spheres
//! ([`super::measure`]), and the 21-component fit of Eq. 27.
//!
//! **The block** is the periodic packing itself with every bond that crosses the cell
//! boundary (periodic image ≠ 0) dropped: the positions are already wrapped into the cell,
//! so the block is the box [0, L) and nothing is cut or renumbered. Its surface particles
//! lose the bonds to their periodic neighbours, as if the box walls had been removed.
//!
//! **Grips** are the particles "initially bonded to box walls": those whose surface comes
//! within `grip_shell`·R̄ of a face of the box (centre distance ≤ R_i + shell·R̄). Their
//! translation is prescribed and their rotation held (YADE's blocked DOFs, see
//! [`super::sim::PrescribedMotion`]).

use super::element::{path_gradient, to_voigt};
use super::equilibrium::{self, SteadyWindow, Unbalance, DEFAULT_UNBALANCED_TOLERANCE};
use super::measure::{mean_tensor, normalised_spread, MeasureOptions, MeasurementSpheres};
use super::sim::{DemOptions, PrescribedMotion, Simulation, StabilityReport};
use super::{build_law, LawKind};
use crate::bonds::{BondSet, BondStiffness};
use crate::packing::Packing;
use crate::tensor::{fit_symmetric_eq27, Stiffness6, Voigt6};
use crate::{Error, Mat3, Result, Vec3};

/// A free bonded block cut from a periodic packing, with its grips.
#[derive(Clone, Debug)]
pub struct GrippedBlock {
    /// The particles (same order as the source packing), no periodic cell.
    pub packing: Packing,
    /// The bonds that do not cross the cell boundary.
    pub bonds: BondSet,
    /// For each kept bond, its index in the source bond set.
    pub source_bond: Vec<usize>,
    /// Grip particles, ascending.
    pub grips: Vec<usize>,
    /// `is_grip[p]` for every particle.
    pub is_grip: Vec<bool>,
    /// Box corners (m): the source cell [0, L].
    pub lo: Vec3,
    /// Upper box corner (m).
    pub hi: Vec3,
    /// Block centre x_c (m), the centre of the box (Truszkowska 2018 Eq. 28).
    pub centre: Vec3,
    /// Solid fraction φ of the box.
    pub solid_fraction: f64,
    /// Depth from the faces within which grips lie (m): max R_i + shell·R̄.
    pub grip_depth: f64,
}

/// Cut the free block out of a periodic packing and pick its grips (see the module doc).
pub fn cut_block(packing: &Packing, bonds: &BondSet, grip_shell: f64) -> Result<GrippedBlock> {
    let cell = packing.cell.ok_or_else(|| {
        Error::Invalid(
            "a gripped block is cut from a periodic packing (a `# periodic Lx Ly Lz` header)"
                .into(),
        )
    })?;
    if !(grip_shell.is_finite() && grip_shell >= 0.0) {
        return Err(Error::Invalid(format!(
            "grip shell must be finite and ≥ 0 (units of R̄), got {grip_shell}"
        )));
    }
    let n = packing.len();
    let mut kept = BondSet::default();
    let mut source_bond = Vec::new();
    for b in 0..bonds.len() {
        let (i, j) = (bonds.i[b] as usize, bonds.j[b] as usize);
        if i >= n || j >= n {
            return Err(Error::Invalid(format!(
                "bond {b} joins particles {i} and {j}; the packing has {n}"
            )));
        }
        if bonds.image[b] == [0, 0, 0] {
            let l = packing.positions[j] - packing.positions[i];
            if l.norm() == 0.0 {
                return Err(Error::Invalid(format!(
                    "bond {b} joins coincident particles {i} and {j}"
                )));
            }
            kept.push(bonds.i[b], bonds.j[b], l, [0, 0, 0]);
            source_bond.push(b);
        }
    }
    let lo = Vec3::zeros();
    let hi = cell.lengths;
    let mean_radius = packing.mean_radius();
    let shell = grip_shell * mean_radius;
    let is_grip: Vec<bool> = (0..n)
        .map(|p| {
            let x = packing.positions[p];
            let d = (0..3)
                .map(|k| (x[k] - lo[k]).min(hi[k] - x[k]))
                .fold(f64::INFINITY, f64::min);
            d <= packing.radii[p] + shell
        })
        .collect();
    let grips: Vec<usize> = (0..n).filter(|&p| is_grip[p]).collect();
    if grips.len() == n {
        return Err(Error::Invalid(format!(
            "a grip shell of {grip_shell} R̄ makes every particle a grip particle (block \
             {:.4e} × {:.4e} × {:.4e} m, R̄ = {mean_radius:.4e} m): nothing is left to deform; \
             use a thinner shell or a larger packing",
            hi.x, hi.y, hi.z
        )));
    }
    if grips.is_empty() {
        return Err(Error::Invalid(
            "the block has no grip particles; raise the grip shell".into(),
        ));
    }
    let r_max = packing.radii.iter().copied().fold(0.0, f64::max);
    let solid: f64 = packing
        .radii
        .iter()
        .map(|r| 4.0 / 3.0 * std::f64::consts::PI * r * r * r)
        .sum();
    Ok(GrippedBlock {
        packing: Packing::new(packing.positions.clone(), packing.radii.clone(), None)?,
        bonds: kept,
        source_bond,
        grips,
        is_grip,
        lo,
        hi,
        centre: (lo + hi) * 0.5,
        solid_fraction: solid / cell.volume(),
        grip_depth: r_max + shell,
    })
}

/// The springs of the kept bonds of `block` out of the source bond set's springs `k`.
pub fn block_springs(block: &GrippedBlock, k: &BondStiffness) -> Result<BondStiffness> {
    let nb = block.source_bond.iter().copied().max().map_or(0, |m| m + 1);
    if k.kn.len() < nb
        || k.ks.len() != k.kn.len()
        || k.kr.len() != k.kn.len()
        || k.ktw.len() != k.kn.len()
        || k.radius.len() != k.kn.len()
    {
        return Err(Error::Invalid(format!(
            "bond springs: {} entries (kn) do not match the source bond set",
            k.kn.len()
        )));
    }
    let pick = |v: &Vec<f64>| block.source_bond.iter().map(|&b| v[b]).collect();
    Ok(BondStiffness {
        radius: pick(&k.radius),
        kn: pick(&k.kn),
        ks: pick(&k.ks),
        kr: pick(&k.kr),
        ktw: pick(&k.ktw),
    })
}

/// Settings of the gripped element tests.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GrippedOptions {
    /// Strain magnitude e per path (signs as [`super::element::path_gradient`]).
    pub strain: f64,
    /// Grip shell in units of R̄ (see the module doc).
    pub grip_shell: f64,
    /// The grips reach the full strain at constant velocity over this many steps, then stop.
    pub ramp_steps: usize,
    /// Cundall local damping during loading and relaxation.
    pub local_damping: f64,
    /// Converged when, over the last `window` steps, the largest change of the block's Love
    /// stress and the change of the mean measurement-sphere strain, each relative to its
    /// norm, stay below this, and the free particles are in equilibrium
    /// (`unbalanced_tolerance`).
    pub tolerance: f64,
    /// Equilibrium: the unbalanced force and torque of the particles that are not grips
    /// ([`Unbalance`]) must be at most this.
    pub unbalanced_tolerance: f64,
    /// Steps of the convergence window.
    pub window: usize,
    /// Step limit per path (ramp included, so it must exceed `ramp_steps`); reaching it is
    /// an error.
    pub max_steps: usize,
    /// Integrator settings (time step, masses); damping replaced by `local_damping`.
    pub dem: DemOptions,
    /// Measurement spheres.
    pub measure: MeasureOptions,
}

impl Default for GrippedOptions {
    fn default() -> Self {
        GrippedOptions {
            strain: 1e-5,
            grip_shell: 0.5,
            ramp_steps: 50,
            local_damping: 0.4,
            tolerance: 1e-7,
            unbalanced_tolerance: DEFAULT_UNBALANCED_TOLERANCE,
            window: 20,
            max_steps: 100_000,
            dem: DemOptions::default(),
            measure: MeasureOptions::default(),
        }
    }
}

/// One gripped strain path.
#[derive(Clone, Debug, PartialEq)]
pub struct GrippedPath {
    /// Path 0..6 (Voigt component loaded).
    pub path: usize,
    /// Imposed strain (Voigt, engineering shear).
    pub imposed_strain: Voigt6,
    /// Mean measurement-sphere strain (Voigt, engineering shear).
    pub strain: Voigt6,
    /// Mean measurement-sphere stress (Voigt, Pa).
    pub stress: Voigt6,
    /// Per-sphere strains (Voigt, engineering shear).
    pub sphere_strains: Vec<Voigt6>,
    /// Normalised spread of the loaded component across spheres (std / |mean|).
    pub spread: f64,
    /// Steps used.
    pub steps: usize,
    /// Unbalanced force and torque of the free particles reached.
    pub unbalance: Unbalance,
}

/// Table 3 heterogeneity metric (Truszkowska 2018): mean normalised standard deviation of
/// the measurement-sphere strains, for the loaded component of each path.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Heterogeneity {
    /// Mean over the uniaxial paths 1–3 of std(ε_kk)/|mean ε_kk| (Table 3 column ε_1).
    pub normal: f64,
    /// Mean over the shear paths 4–6 of std(γ_k)/|mean γ_k| (Table 3 column ε_4).
    pub shear: f64,
}

/// The gripped tensor and how it was obtained.
#[derive(Clone, Debug)]
pub struct GrippedTensor {
    /// C from Truszkowska Eq. 27 with measurement-sphere stress and strain (Pa).
    pub c: Stiffness6,
    /// The six paths.
    pub paths: Vec<GrippedPath>,
    /// Strain heterogeneity (Table 3).
    pub heterogeneity: Heterogeneity,
    /// Grip particles.
    pub grips: usize,
    /// Bonds of the block (source bonds crossing the boundary dropped).
    pub bonds: usize,
    /// Mean members per measurement sphere (the paper: 165).
    pub mean_members: f64,
    /// Time step (s).
    pub time_step: f64,
    /// Critical time step and weakly bonded particles of the block.
    pub stability: StabilityReport,
}

/// A prepared gripped test: block, simulation at rest and measurement spheres.
#[derive(Clone)]
pub struct GrippedSetup {
    /// The block.
    pub block: GrippedBlock,
    /// The simulation at rest.
    pub sim: Simulation,
    /// The measurement spheres, placed inside the box less the grip layer.
    pub spheres: MeasurementSpheres,
}

/// Cut the block, build the law `kind` for the kept bonds' springs, the simulation and the
/// measurement spheres.
pub fn gripped_setup(
    packing: &Packing,
    bonds: &BondSet,
    springs: &BondStiffness,
    kind: LawKind,
    opts: &GrippedOptions,
) -> Result<GrippedSetup> {
    let block = cut_block(packing, bonds, opts.grip_shell)?;
    let k = block_springs(&block, springs)?;
    let law = build_law(kind, &block.packing, &block.bonds, &k)?;
    let dem = DemOptions {
        local_damping: opts.local_damping,
        ..opts.dem
    };
    let sim = Simulation::new(&block.packing, &block.bonds, law, &dem)?;
    let degree: Vec<usize> = (0..block.packing.len())
        .map(|p| sim.topology.degree(p))
        .collect();
    let margin = Vec3::repeat(block.grip_depth);
    let spheres = MeasurementSpheres::place(
        &block.packing.positions,
        &block.packing.radii,
        &degree,
        block.lo + margin,
        block.hi - margin,
        block.solid_fraction,
        &opts.measure,
    )?;
    Ok(GrippedSetup {
        block,
        sim,
        spheres,
    })
}

/// Grip velocities u = Ġ·(x − x_c) for the displacement gradient `g` reached in `steps`
/// steps of `dt`: the form of Truszkowska 2018 Eqs. 17–22 and 28 (velocity linear in the
/// grip's position relative to the centre x_c). With `g` from [`path_gradient`] the shear
/// paths carry engineering strain −e (Eq. 20 as written, u = γ̇[0 z y], would be +2γ̇): the
/// sign and magnitude convention of the periodic element tests, so that Eq. 27 sees the
/// same six paths.
pub fn grip_motion(
    block: &GrippedBlock,
    sim: &Simulation,
    g: &Mat3,
    steps: usize,
) -> PrescribedMotion {
    let rate = g / (steps.max(1) as f64 * sim.time_step());
    PrescribedMotion {
        particles: block.grips.clone(),
        velocity: block
            .grips
            .iter()
            .map(|&p| rate * (sim.particles.position[p] - block.centre))
            .collect(),
    }
}

/// Errors unless the step limit exceeds the ramp (the limit includes the ramp).
fn check_budget(opts: &GrippedOptions) -> Result<()> {
    if opts.ramp_steps == 0 || opts.ramp_steps >= opts.max_steps {
        return Err(Error::Invalid(format!(
            "gripped element tests: the ramp ({} steps, --ramp-steps) must be at least 1 step and \
             shorter than the step limit per path ({} steps, --max-steps), which includes the \
             ramp",
            opts.ramp_steps, opts.max_steps
        )));
    }
    equilibrium::check_tolerance(opts.unbalanced_tolerance)
}

/// Impose the displacement gradient `g` through the grips (ramp, then hold) and relax until
/// the block's Love stress and mean sphere strain settle and the free particles are in
/// equilibrium; returns the steps used (ramp included) and the unbalance reached. Errors if
/// the ramp does not fit in the step limit or the limit is reached first.
pub fn relax_gripped(
    setup: &mut GrippedSetup,
    path: usize,
    g: &Mat3,
    opts: &GrippedOptions,
    progress: &mut dyn FnMut(usize),
) -> Result<(usize, Unbalance)> {
    check_budget(opts)?;
    let ramp = opts.ramp_steps;
    let sim = &mut setup.sim;
    sim.set_local_damping(opts.local_damping)?;
    let motion = grip_motion(&setup.block, sim, g, ramp);
    sim.set_prescribed_motion(Some(motion.clone()))?;
    for s in 0..ramp {
        sim.step()?;
        progress(s + 1);
    }
    sim.set_prescribed_motion(Some(PrescribedMotion {
        velocity: vec![Vec3::zeros(); motion.particles.len()],
        particles: motion.particles,
    }))?;
    let mut steady = SteadyWindow::new(opts.window);
    let window = steady.steps();
    let mut steps = ramp;
    let mut last_change = f64::INFINITY;
    let mut last_strain: Option<Voigt6> = None;
    loop {
        sim.step()?;
        steps += 1;
        let stress = to_voigt(&sim.stress(), false);
        if let Some(spread) = steady.push(stress) {
            last_change = spread.relative();
        }
        // Every `window` steps, also the change of the mean measurement-sphere strain and,
        // once both are steady, the equilibrium of the free particles.
        if steps.is_multiple_of(window) {
            let strain = to_voigt(
                &mean_tensor(&setup.spheres.displacement_gradient(sim)?),
                true,
            );
            let strain_change = last_strain.map_or(f64::INFINITY, |prev| {
                let norm = strain.norm();
                if norm > 0.0 {
                    (strain - prev).norm() / norm
                } else {
                    f64::INFINITY
                }
            });
            last_strain = Some(strain);
            if last_change < opts.tolerance && strain_change < opts.tolerance {
                let u = Unbalance::of(sim);
                if u.within(opts.unbalanced_tolerance) {
                    return Ok((steps, u));
                }
            }
            last_change = last_change.max(strain_change);
        }
        if steps >= opts.max_steps {
            return Err(Error::NotConverged(format!(
                "gripped path {path}: not relaxed after {steps} steps (ramp included): {}, \
                 relative stress or sphere-strain change {last_change:.3e} over {window} steps \
                 (tolerance {:.1e}); {}",
                Unbalance::of(sim).describe(opts.unbalanced_tolerance),
                opts.tolerance,
                equilibrium::budget_advice(sim)
            )));
        }
        progress(steps);
    }
}

/// Six gripped strain paths from the same block at rest → measurement-sphere stress and
/// strain → Truszkowska 2018 Eq. 27 → C, with the Table 3 heterogeneity metric.
/// `progress` receives the fraction done.
pub fn gripped_tensor(
    packing: &Packing,
    bonds: &BondSet,
    springs: &BondStiffness,
    kind: LawKind,
    opts: &GrippedOptions,
    progress: &(dyn Fn(f64) + Sync),
) -> Result<GrippedTensor> {
    super::element::check_path_strain(opts.strain, "gripped element-test")?;
    check_budget(opts)?;
    let setup = gripped_setup(packing, bonds, springs, kind, opts)?;
    gripped_tensor_from(&setup, opts, progress)
}

/// As [`gripped_tensor`] from a prepared setup (the simulation must be at rest).
pub fn gripped_tensor_from(
    setup: &GrippedSetup,
    opts: &GrippedOptions,
    progress: &(dyn Fn(f64) + Sync),
) -> Result<GrippedTensor> {
    let paths = super::element::run_six_paths(opts.max_steps, progress, |k, path_progress| {
        let mut run = setup.clone();
        let g = path_gradient(k, opts.strain);
        let (steps, unbalance) = relax_gripped(&mut run, k, &g, opts, path_progress)?;
        let grads = run.spheres.displacement_gradient(&run.sim)?;
        let stresses = run.spheres.stress(&run.sim)?;
        let sphere_strains: Vec<Voigt6> = grads.iter().map(|g| to_voigt(g, true)).collect();
        Ok(GrippedPath {
            path: k,
            imposed_strain: to_voigt(&g, true),
            strain: to_voigt(&mean_tensor(&grads), true),
            stress: to_voigt(&mean_tensor(&stresses), false),
            spread: normalised_spread(&sphere_strains, k),
            sphere_strains,
            steps,
            unbalance,
        })
    })?;
    let strains: Vec<Voigt6> = paths.iter().map(|p| p.strain).collect();
    let stresses: Vec<Voigt6> = paths.iter().map(|p| p.stress).collect();
    let c = fit_symmetric_eq27(&strains, &stresses)?;
    let heterogeneity = Heterogeneity {
        normal: paths[..3].iter().map(|p| p.spread).sum::<f64>() / 3.0,
        shear: paths[3..].iter().map(|p| p.spread).sum::<f64>() / 3.0,
    };
    let s = &setup.spheres;
    Ok(GrippedTensor {
        c,
        paths,
        heterogeneity,
        grips: setup.block.grips.len(),
        bonds: setup.block.bonds.len(),
        mean_members: s.spheres.iter().map(|x| x.members.len()).sum::<usize>() as f64
            / s.len().max(1) as f64,
        time_step: setup.sim.time_step(),
        stability: setup.sim.stability().clone(),
    })
}
