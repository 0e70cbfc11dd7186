//! Kumar 2016's three packing preparation routes (Sec. 3), seeded and deterministic.
//!
//! All three start from the same *gas*: spheres placed one after the other at random
//! positions, each rejected and redrawn while it would touch one already placed (random
//! sequential addition), up to the gas solid fraction D₀ = 0.3. Then:
//!
//! - [`PreparationRoute::Unjammed`]: an affine (isotropic) densification of the gas to the
//!   requested solid fraction; all the overlaps this creates are kept.
//! - [`PreparationRoute::WeaklyJammed`]: quasi-static compression of frictionless,
//!   repulsive-only spheres to D₀ = 0.5 (small affine steps of the cell, each followed by an
//!   energy minimisation that removes the overlaps: the limit of Kumar's pressure-controlled
//!   compression at P_c/Σ_N = 10⁻⁷), then affine to the requested solid fraction.
//! - [`PreparationRoute::Jammed`]: the same compression to 0.55, then Kumar's
//!   pressure-controlled compression to the jamming point: FIRE on the enthalpy E + P·V with
//!   the cell as a degree of freedom (O'Hern et al. 2003), first at P = 10⁻³ Σ_N, then
//!   decompressed by decades to ½·`jamming_pressure` and force balanced there (by default
//!   YADE's unbalanced force ≤ 2·10⁻³; Kumar's own 10⁻³ N_max rule on request, see
//!   [`DEFAULT_JAMMING_BALANCE`]; Kumar reports D = 0.636, Z = 6.03); then affine to the
//!   requested solid fraction.
//!
//! The last affine step scales positions and cell together (x → s·x, L → s·L), so a
//! requested density above the current one creates overlaps: this is how Kumar builds
//! bonded samples at D = 0.65 with an interaction range κ (Eq. 10, Table 1).
//!
//! The same driver prepares a bar's spheres inside a rigid cylinder and two planes instead
//! of the periodic cell ([`super::container`], Kumar 2016 Sec. 5).
//!
//! Lengths are handled in units of R̄ with unit contact stiffness, so pressures are in
//! units of Σ_N (Kumar Eq. 2 with R* = R̄/2 gives K_N = Σ_N R̄). Every random number comes
//! from one `ChaCha8Rng` stream in a fixed order and the minimisation sums in a fixed
//! order, so the packing is bit-identical on any number of threads.

pub use super::generate::ForceBalance;
use super::generate::{
    check_radii, fire_jam_at_pressure, fire_relax, largest_radius, seeded_radii, solid_volume_of,
    spatial_order, Domain, Polydispersity, PressureOutcome, PressureTarget, RelaxOutcome,
    RelaxTarget,
};
use super::{Packing, PeriodicCell};
use crate::{Error, Result, Vec3};
use rand::Rng;
use rand_chacha::ChaCha8Rng;

/// Relative half width of Kumar 2016's "nearly monomodal" radii, R̄ ± 5 % (Sec. 3).
pub const KUMAR_2016_HALF_WIDTH: f64 = 0.05;
/// Solid fraction of Kumar 2016's initial gas, D₀ = 0.3 (Sec. 3).
pub const KUMAR_2016_GAS_SOLID_FRACTION: f64 = 0.3;
/// Solid fraction to which the weakly jammed route compresses, D₀ = 0.5 (Sec. 3).
pub const KUMAR_2016_WEAK_JAMMING_SOLID_FRACTION: f64 = 0.5;
/// Final solid fraction of Kumar 2016's samples, D = 0.65 (Sec. 3, Table 1).
pub const KUMAR_2016_SOLID_FRACTION: f64 = 0.65;

/// Pressure P/Σ_N of the first stage of the jamming search (then decades down to
/// ½·`jamming_pressure`): high enough that the cell collapses quickly, low enough that the
/// jamming point stays Kumar's (measured on 2000 spheres: 1e-3 → φ_J ≈ 0.636; 1e-2 → 0.643).
const JAMMING_FIRST_STAGE_PRESSURE: f64 = 1e-3;

/// Force balance of the stages above the target pressure: Kumar's form (largest net force
/// against the largest contact force) at 10⁻². It lets the packing compact at the higher
/// pressure, where that is fast. Stopping these stages earlier (mean net force ≤ 10⁻² of
/// the mean contact force) left the compaction to the last stage and made that stage 3–8×
/// longer; holding them to the final rule (mean ≤ 2·10⁻³) compacted too far (φ_J up to
/// 0.6401) and took 57–61 s instead of 40–41 s (30,000 spheres, session-8 measurements).
const JAMMING_UPPER_STAGE_BALANCE: ForceBalance = ForceBalance::Largest(1e-2);

/// Default force balance of the jammed state: YADE's unbalanced force (mean net force over
/// mean contact force) ≤ 2·10⁻³. Near jamming the net forces decay slowly, as a power of
/// the iteration count with avalanches on the way, and the largest of N of them crosses a
/// bound later the larger N is. At 30,000 spheres the whole route took 30.8k–35.8k FIRE
/// iterations with this rule (seeds 1–6) against 85.8k–212.9k under Kumar's rule
/// (`Largest(1e-3)`, seeds 1–3). The bonded network after the affine step to 0.65 is the
/// same to within 0.025 contacts per sphere at every κ of Kumar's Table 1, and φ_J to within
/// 6·10⁻⁴ (10,000 spheres, seeds 1–3, both rules).
pub const DEFAULT_JAMMING_BALANCE: ForceBalance = ForceBalance::Mean(2e-3);

/// Largest gas solid fraction accepted: random sequential addition saturates near 0.38.
pub const MAX_GAS_SOLID_FRACTION: f64 = 0.35;

/// Kumar 2016's preparation routes (Sec. 3).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PreparationRoute {
    /// Random gas, then affine densification to the requested solid fraction.
    Unjammed,
    /// Frictionless repulsive compression to D₀ = 0.5, then affine.
    WeaklyJammed,
    /// Frictionless repulsive compression to the jamming point (≈ 0.636, Z ≈ 6), then
    /// affine.
    Jammed,
}

impl PreparationRoute {
    /// The route's name as on the command line.
    pub fn as_str(self) -> &'static str {
        match self {
            PreparationRoute::Unjammed => "unjammed",
            PreparationRoute::WeaklyJammed => "weakly-jammed",
            PreparationRoute::Jammed => "jammed",
        }
    }
}

/// What to prepare.
#[derive(Clone, Debug, PartialEq)]
pub struct RouteOptions {
    /// Preparation route.
    pub route: PreparationRoute,
    /// Number of spheres N.
    pub n_particles: usize,
    /// Requested final solid fraction D (reached by the last affine step; may exceed the
    /// jamming point, then the spheres overlap).
    pub solid_fraction: f64,
    /// Mean radius R̄ (m).
    pub mean_radius: f64,
    /// Radius distribution.
    pub polydispersity: Polydispersity,
    /// Seed of the random stream (ChaCha8).
    pub seed: u64,
    /// Solid fraction of the initial random gas (Kumar: 0.3).
    pub gas_solid_fraction: f64,
    /// Where the weakly jammed compression stops (Kumar: 0.5).
    pub weak_jamming_solid_fraction: f64,
    /// Relative solid-fraction increment of one quasi-static compression step.
    pub compression_step: f64,
    /// Largest pressure P/Σ_N of the state accepted as jammed (Kumar's control pressure is
    /// 10⁻⁷; any value ≪ 10⁻³ leaves the contact network the same to the affine window of
    /// the last step).
    pub jamming_pressure: f64,
    /// Force balance of the jammed state ([`DEFAULT_JAMMING_BALANCE`];
    /// `ForceBalance::Largest(1e-3)` is Kumar's rule over the whole packing).
    pub jamming_balance: ForceBalance,
    /// Iteration limit of each energy minimisation.
    pub max_iterations: usize,
}

impl Default for RouteOptions {
    /// Kumar 2016's set-up: jammed route, 5000 spheres, D = 0.65, R̄ ± 5 %, R̄ = 1 mm.
    fn default() -> Self {
        RouteOptions {
            route: PreparationRoute::Jammed,
            n_particles: 5000,
            solid_fraction: KUMAR_2016_SOLID_FRACTION,
            mean_radius: 1.0e-3,
            polydispersity: Polydispersity::Uniform {
                half_width: KUMAR_2016_HALF_WIDTH,
            },
            seed: 2016,
            gas_solid_fraction: KUMAR_2016_GAS_SOLID_FRACTION,
            weak_jamming_solid_fraction: KUMAR_2016_WEAK_JAMMING_SOLID_FRACTION,
            compression_step: 0.01,
            jamming_pressure: 1.0e-4,
            jamming_balance: DEFAULT_JAMMING_BALANCE,
            max_iterations: 1_000_000,
        }
    }
}

/// How the preparation went.
#[derive(Clone, Debug, PartialEq)]
pub struct RouteReport {
    /// The route.
    pub route: PreparationRoute,
    /// Solid fraction before the final affine step (gas, 0.5, or the jamming point).
    pub compressed_solid_fraction: f64,
    /// Mean number of touching or overlapping neighbours per sphere (all spheres) in that
    /// state; for the jammed route the contact network at jamming (Kumar: Z = 6.03).
    pub compressed_coordination: f64,
    /// Spheres with fewer than 4 contacts in that state (rattlers; Kumar: < 2 % jammed).
    pub rattlers: usize,
    /// Pressure P/Σ_N of that state (0 unless jammed).
    pub pressure: f64,
    /// Mean net force over mean contact force in that state (YADE's unbalanced force; 0
    /// unless jammed).
    pub mean_unbalanced: f64,
    /// Largest net force over largest contact force in that state (Kumar's 10⁻³ N_max
    /// rule; 0 unless jammed).
    pub largest_unbalanced: f64,
    /// Scale factor s of the final affine step x → s·x (s < 1 densifies).
    pub affine_scale: f64,
    /// Energy minimisations run.
    pub relaxations: usize,
    /// FIRE iterations over all minimisations.
    pub iterations: usize,
}

/// What a preparation is doing, for progress displays ([`prepare_with_status`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum RouteStage {
    /// Placing the random gas (random sequential addition).
    Gas,
    /// Quasi-static compression of the gas (fixed-cell energy minimisations).
    Compression {
        /// Solid fraction where the compression stops (0.5 weakly jammed, 0.55 jammed).
        target_solid_fraction: f64,
    },
    /// One stage of the pressure-controlled jamming (jammed route only).
    Jamming {
        /// Stage number, from 1.
        stage: usize,
        /// Number of stages.
        stages: usize,
        /// Imposed pressure P_t/Σ_N of this stage.
        target_pressure: f64,
        /// Virial pressure P/Σ_N now.
        pressure: f64,
        /// Stopping residual now: max(|P − P_t|/(½P_t), max|F_i|/(balance·largest contact
        /// force)); the stage ends when it is ≤ 1.
        residual: f64,
    },
    /// Finished (after the final affine step).
    Done,
}

/// A progress report of [`prepare_with_status`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RouteStatus {
    /// Fraction done in [0, 1], non-decreasing (the argument of [`prepare`]'s callback).
    pub fraction: f64,
    /// What is running.
    pub stage: RouteStage,
    /// FIRE iterations so far, over all minimisations.
    pub iterations: usize,
    /// Solid fraction of the cell now.
    pub solid_fraction: f64,
}

fn check_options(o: &RouteOptions) -> Result<()> {
    let bad = |m: String| Err(Error::Invalid(format!("packing preparation: {m}")));
    if !o.solid_fraction.is_finite() || o.solid_fraction <= 0.0 || o.solid_fraction > 0.9 {
        return bad(format!(
            "solid fraction must be in (0, 0.9], got {}",
            o.solid_fraction
        ));
    }
    check_radii(o.mean_radius, o.polydispersity).or_else(bad)?;
    let gas = o.gas_solid_fraction;
    if !gas.is_finite() || gas <= 0.0 || gas > MAX_GAS_SOLID_FRACTION {
        return bad(format!(
            "gas solid fraction must be in (0, {MAX_GAS_SOLID_FRACTION}] (random sequential \
             addition saturates near 0.38), got {gas}"
        ));
    }
    let weak = o.weak_jamming_solid_fraction;
    if o.route == PreparationRoute::WeaklyJammed && (!weak.is_finite() || weak < gas || weak > 0.6)
    {
        return bad(format!(
            "weak-jamming solid fraction must be in [gas solid fraction {gas}, 0.6], got {weak}"
        ));
    }
    if !o.compression_step.is_finite() || o.compression_step <= 0.0 || o.compression_step > 0.1 {
        return bad(format!(
            "compression step must be in (0, 0.1], got {}",
            o.compression_step
        ));
    }
    if !o.jamming_pressure.is_finite() || o.jamming_pressure <= 0.0 || o.jamming_pressure > 1e-2 {
        return bad(format!(
            "jamming pressure P/Σ_N must be in (0, 1e-2], got {}",
            o.jamming_pressure
        ));
    }
    let balance = o.jamming_balance.ratio();
    if !balance.is_finite() || balance <= 0.0 || balance > 0.1 {
        return bad(format!(
            "jamming force balance ratio must be in (0, 0.1], got {balance}"
        ));
    }
    super::check_packing_size(
        o.n_particles,
        o.mean_radius,
        o.solid_fraction,
        "packing preparation",
    )?;
    Ok(())
}

/// Random sequential addition of spheres with radii `radii` (R̄ = 1) into `domain` of side
/// `side`: each sphere is placed at a uniformly random position, redrawn while it would
/// overlap a sphere already placed. Errors when a sphere needs more than `max_attempts`
/// draws (the fraction is too close to saturation).
///
/// In a container the centres lie anywhere inside it (a sphere may cross a wall), and the
/// addition runs over the container widened by 2·R_max on every side: a draw that falls in
/// the margin places a *ghost* (radii taken in turn from `radii`) that excludes like a
/// sphere and is dropped at the end. The gas inside is then as uniform as the periodic
/// one: with nothing outside the walls, near saturation the draws would be accepted far
/// more often next to a wall, and the gas would pile up there (measured: centre density
/// 0.74 within R̄ of the mantle against 0.52–0.60 inside, 0.3 on average, r = 6.5 R̄).
fn random_sequential_addition(
    radii: &[f64],
    domain: Domain,
    side: f64,
    rng: &mut ChaCha8Rng,
    max_attempts: usize,
) -> Result<Vec<Vec3>> {
    let n = radii.len();
    let r_max = largest_radius(radii);
    let cell = domain.cell(side)?;
    let (lo, hi) = domain.bounds(side);
    let margin = if cell.is_some() { 0.0 } else { 2.0 * r_max };
    let (grid_lo, grid_hi) = (lo.add_scalar(-margin), hi.add_scalar(margin));
    let extent = grid_hi - grid_lo;
    let dims = extent.map(|e| ((e / (2.0 * r_max)).floor() as usize).max(1));
    let width = extent.component_div(&dims.map(|d| d as f64));
    let mut members: Vec<Vec<u32>> = vec![Vec::new(); dims.product()];
    let index = |c: [usize; 3]| (c[2] * dims[1] + c[1]) * dims[0] + c[0];
    let cell_of = |p: &Vec3| {
        let c = |k: usize| (((p[k] - grid_lo[k]) / width[k]) as usize).min(dims[k] - 1);
        [c(0), c(1), c(2)]
    };
    // The grid cells next to cell `ck` on axis `k` (as many as the first of the pair says):
    // periodic, every cell of a grid narrower than 3 cells; free, those inside the grid.
    let near = |k: usize, ck: usize| -> ([usize; 3], usize) {
        let d = dims[k];
        match (&cell, d < 3) {
            (Some(_), true) => ([0, 1, 2], d),
            (Some(_), false) => ([(ck + d - 1) % d, ck, (ck + 1) % d], 3),
            (None, _) => {
                let first = ck.saturating_sub(1);
                (
                    [first, first + 1, first + 2],
                    (ck + 1).min(d - 1) + 1 - first,
                )
            }
        }
    };
    // Every sphere placed (ghosts too), and the spheres of the domain in order.
    let mut placed: Vec<(Vec3, f64)> = Vec::with_capacity(n);
    let mut x: Vec<Vec3> = Vec::with_capacity(n);
    let mut ghosts = 0usize;
    let mut attempts = 0usize;
    while x.len() < n {
        let k = x.len();
        attempts += 1;
        if attempts > max_attempts {
            return Err(Error::Invalid(format!(
                "packing preparation: random gas: sphere {k} found no free place in \
                 {max_attempts} draws (gas solid fraction too close to saturation)"
            )));
        }
        let (p, rk, inside) = match &cell {
            Some(cell) => {
                let p = Vec3::new(
                    rng.gen::<f64>() * side,
                    rng.gen::<f64>() * side,
                    rng.gen::<f64>() * side,
                );
                (cell.wrap(p).0, radii[k], true)
            }
            None => {
                // Uniform in the widened disc by rejection from its square, then along the
                // widened axis.
                let r = hi.x + margin;
                let (px, py) = loop {
                    let px = (2.0 * rng.gen::<f64>() - 1.0) * r;
                    let py = (2.0 * rng.gen::<f64>() - 1.0) * r;
                    if px * px + py * py <= r * r {
                        break (px, py);
                    }
                };
                let p = Vec3::new(px, py, grid_lo.z + rng.gen::<f64>() * extent.z);
                if px.hypot(py) <= hi.x && p.z >= 0.0 && p.z <= hi.z {
                    (p, radii[k], true)
                } else {
                    (p, radii[ghosts % n], false)
                }
            }
        };
        let c = cell_of(&p);
        let (nz, ny, nx) = (near(2, c[2]), near(1, c[1]), near(0, c[0]));
        let mut free = true;
        'search: for &cz in &nz.0[..nz.1] {
            for &cy in &ny.0[..ny.1] {
                for &cx in &nx.0[..nx.1] {
                    for &j in &members[index([cx, cy, cz])] {
                        let (xj, rj) = placed[j as usize];
                        let d = match &cell {
                            Some(cell) => cell.minimum_image(xj - p).0,
                            None => xj - p,
                        };
                        let reach = rj + rk;
                        if d.norm_squared() < reach * reach {
                            free = false;
                            break 'search;
                        }
                    }
                }
            }
        }
        if free {
            members[index(c)].push(placed.len() as u32);
            placed.push((p, rk));
            if inside {
                x.push(p);
                attempts = 0;
            } else {
                ghosts += 1;
            }
        }
    }
    Ok(x)
}

/// Scale positions and cell side by `s` (affine isotropic deformation).
fn scale_affinely(x: &mut [Vec3], side: &mut f64, s: f64) {
    x.iter_mut().for_each(|p| *p *= s);
    *side *= s;
}

/// Contacts per sphere (pairs with |l| ≤ R_i + R_j counted from both ends) and rattlers
/// (spheres with fewer than 4 contacts) of a configuration in R̄ units.
/// In a container, a wall that a sphere touches or crosses counts as one of its contacts.
fn contact_statistics(
    x: &[Vec3],
    radii: &[f64],
    domain: Domain,
    side: f64,
) -> Result<(f64, usize)> {
    let cell = domain.cell(side)?;
    let r_max = largest_radius(radii);
    let pairs = super::neighbours::pairs_in(x, radii, cell.as_ref(), 2.0 * r_max, |ri, rj, d| {
        d <= ri + rj
    })?;
    let mut degree = vec![0u32; x.len()];
    for p in &pairs {
        degree[p.i as usize] += 1;
        degree[p.j as usize] += 1;
    }
    if let Some(w) = domain.walls(side) {
        for ((p, r), d) in x.iter().zip(radii).zip(degree.iter_mut()) {
            let touching = [
                p.x.hypot(p.y) + r >= w.radius,
                p.z <= *r,
                p.z + r >= w.length,
            ];
            *d += touching.iter().filter(|&&t| t).count() as u32;
        }
    }
    let rattlers = degree.iter().filter(|&&d| d < 4).count();
    let total: u32 = degree.iter().sum();
    Ok((total as f64 / x.len() as f64, rattlers))
}

/// Prepare a packing by one of Kumar 2016's routes (see the module doc); `progress`
/// receives the fraction done in [0, 1].
pub fn prepare(
    opts: &RouteOptions,
    progress: &(dyn Fn(f64) + Sync),
) -> Result<(Packing, RouteReport)> {
    prepare_with_status(opts, &|s: &RouteStatus| progress(s.fraction))
}

/// [`prepare`], reporting what runs: the stage, the iterations so far and the solid fraction,
/// and in the jamming stages the pressure and the stopping residual (every 25 FIRE
/// iterations and at the end of each stage). The final jamming stage of a large packing
/// can run for minutes with its fraction nearly still; this shows that it is working.
pub fn prepare_with_status(
    opts: &RouteOptions,
    status: &(dyn Fn(&RouteStatus) + Sync),
) -> Result<(Packing, RouteReport)> {
    prepare_in(Domain::Periodic, opts, status).map(|(packing, _, report)| (packing, report))
}

/// The routes in `domain`: the periodic packing (with its cell), or the free packing of
/// a container ([`super::container`]), with the final side (m; the cube root of the cell's
/// or container's volume) and the report.
pub(super) fn prepare_in(
    domain: Domain,
    opts: &RouteOptions,
    status: &(dyn Fn(&RouteStatus) + Sync),
) -> Result<(Packing, f64, RouteReport)> {
    check_options(opts)?;
    let n = opts.n_particles;
    let (radii, mut rng) = seeded_radii(n, opts.polydispersity, opts.seed);
    let solid_volume = solid_volume_of(&radii);
    let phi_of = |side: f64| solid_volume / (side * side * side);
    let side_of = |phi: f64| (solid_volume / phi).cbrt();
    let r_max = largest_radius(&radii);
    // The final cell must stay wider than 4.1 R_max for a unique minimum image.
    let smallest_side = side_of(opts.solid_fraction.max(0.66));
    if domain == Domain::Periodic && 0.49 * smallest_side - 2.0 * r_max < 0.05 {
        return Err(Error::Invalid(format!(
            "packing preparation: {n} spheres give a periodic cell of side \
             {smallest_side:.3} R̄, too small for a unique minimum image; use more particles"
        )));
    }

    let report = |fraction: f64, stage: RouteStage, iterations: usize, solid_fraction: f64| {
        status(&RouteStatus {
            fraction,
            stage,
            iterations,
            solid_fraction,
        })
    };
    report(0.0, RouteStage::Gas, 0, opts.gas_solid_fraction);
    let mut side = side_of(opts.gas_solid_fraction);
    let gas = random_sequential_addition(&radii, domain, side, &mut rng, 1_000_000)?;
    let (lo, hi) = domain.bounds(side);
    let (mut x, radii) = spatial_order(&gas, &radii, lo, hi);
    report(0.02, RouteStage::Gas, 0, phi_of(side));

    let mut relaxations = 0usize;
    let mut iterations = 0usize;
    let mut pressure = 0.0;
    let mut mean_unbalanced = 0.0;
    let mut largest_unbalanced = 0.0;
    let max_iterations = opts.max_iterations;
    let relax = |x: &mut Vec<Vec3>,
                 side: f64,
                 target: RelaxTarget,
                 relaxations: &mut usize,
                 iterations: &mut usize|
     -> Result<RelaxOutcome> {
        let out = fire_relax(x, &radii, side, domain, &target, &mut |_, _| {})?;
        *relaxations += 1;
        *iterations += out.iterations;
        if !out.converged() {
            return Err(Error::NotConverged(format!(
                "packing preparation: energy minimisation at solid fraction {:.5} did not \
                 converge in {max_iterations} iterations (largest overlap {:.2e} R̄)",
                solid_volume / (side * side * side),
                out.max_overlap
            )));
        }
        Ok(out)
    };
    // Overlap-free target of the compression steps (residual overlaps ≪ any bonding
    // window).
    let free_target = RelaxTarget {
        max_overlap: 1e-6,
        force_balance: None,
        max_iterations,
    };

    if opts.route != PreparationRoute::Unjammed {
        let stop = match opts.route {
            PreparationRoute::WeaklyJammed => opts.weak_jamming_solid_fraction,
            _ => 0.55,
        };
        // Quasi-static compression of the gas to `stop`.
        let phi_start = phi_of(side);
        let mut phi = phi_start;
        while phi < stop {
            let next = (phi * (1.0 + opts.compression_step)).min(stop);
            let new_side = side_of(next);
            let s = new_side / side;
            scale_affinely(&mut x, &mut side, s);
            side = new_side;
            relax(&mut x, side, free_target, &mut relaxations, &mut iterations)?;
            phi = next;
            let done = (phi / phi_start).ln() / (stop / phi_start).ln();
            report(
                0.02 + 0.5 * done.clamp(0.0, 1.0),
                RouteStage::Compression {
                    target_solid_fraction: stop,
                },
                iterations,
                phi,
            );
        }
        if opts.route == PreparationRoute::Jammed {
            // From the unjammed state at 0.55, minimise the enthalpy E + P_t·V with the cell
            // as one more degree of freedom (O'Hern et al. 2003; Kumar's pressure-controlled
            // compression): the cell shrinks until the spheres are force balanced at
            // P ≈ P_t = ½·`jamming_pressure`, just above the jamming point.
            // Stages: jam fast at a high pressure (the cell collapses in a few thousand
            // iterations), then decompress by decades to the target, loosely force balanced
            // on the way; only the last stage is held to `jamming_balance`. Creeping to the
            // jamming point at the final small pressure directly is ~10× slower.
            let final_pressure = 0.5 * opts.jamming_pressure;
            let mut stages: Vec<(f64, ForceBalance)> = Vec::new();
            let mut p_stage: f64 = JAMMING_FIRST_STAGE_PRESSURE;
            while p_stage > 2.0 * final_pressure {
                stages.push((p_stage, JAMMING_UPPER_STAGE_BALANCE));
                p_stage *= 0.1;
            }
            stages.push((final_pressure, opts.jamming_balance));
            let n_stages = stages.len();
            let mut out = Default::default();
            for (k, &(p_t, balance)) in stages.iter().enumerate() {
                let target = PressureTarget {
                    pressure: p_t,
                    pressure_tolerance: 0.5,
                    force_balance: balance,
                    max_iterations,
                };
                let mut first = None;
                let mut done = 0.0f64;
                let before = iterations;
                let stage_out: PressureOutcome =
                    fire_jam_at_pressure(&mut x, &radii, &mut side, domain, &target, &mut |c| {
                        // Fraction of the way (logarithmic) from the first residual to 1.
                        let r = c.residual;
                        let r0 = *first.get_or_insert(r.max(10.0));
                        if r.is_finite() && r0.is_finite() {
                            let frac = ((r0 / r.max(1.0)).ln() / r0.ln()).clamp(0.0, 0.999);
                            done = done.max(frac);
                        }
                        report(
                            0.52 + 0.47 * (k as f64 + done) / n_stages as f64,
                            RouteStage::Jamming {
                                stage: k + 1,
                                stages: n_stages,
                                target_pressure: p_t,
                                pressure: c.pressure,
                                residual: r,
                            },
                            before + c.iterations,
                            phi_of(c.side),
                        );
                    })?;
                relaxations += 1;
                iterations += stage_out.iterations;
                if !stage_out.converged {
                    return Err(Error::NotConverged(format!(
                        "packing preparation: no force-balanced jammed state at pressure {p_t:e} \
                         found in {max_iterations} iterations (reached P = {:.3e} at solid \
                         fraction {:.5})",
                        stage_out.pressure,
                        phi_of(side)
                    )));
                }
                out = stage_out;
            }
            pressure = out.pressure;
            mean_unbalanced = out.mean_unbalanced;
            largest_unbalanced = out.largest_unbalanced;
        }
    }

    let compressed = phi_of(side);
    let (compressed_coordination, rattlers) = contact_statistics(&x, &radii, domain, side)?;
    // Final affine step to the requested solid fraction.
    let final_side = side_of(opts.solid_fraction);
    let affine_scale = final_side / side;
    scale_affinely(&mut x, &mut side, affine_scale);
    let scale = opts.mean_radius;
    let cell = domain.cell(final_side * scale)?;
    let positions: Vec<Vec3> = x.iter().map(|p| *p * scale).collect();
    let radii: Vec<f64> = radii.iter().map(|r| r * scale).collect();
    let packing = Packing::new(positions, radii, cell)?;
    report(1.0, RouteStage::Done, iterations, phi_of(side));
    Ok((
        packing,
        final_side * scale,
        RouteReport {
            route: opts.route,
            compressed_solid_fraction: compressed,
            compressed_coordination,
            rattlers,
            pressure,
            mean_unbalanced,
            largest_unbalanced,
            affine_scale,
            relaxations,
            iterations,
        },
    ))
}

/// The packing scaled affinely (positions and cell) to solid fraction `solid_fraction`:
/// x → s·x, L → s·L with s = (φ/φ_target)^(1/3). Overlaps appear when densifying; this is
/// Kumar 2016's last preparation step (Sec. 3). Errors on a free (non-periodic) packing or
/// a target that is not finite and > 0.
pub fn scale_to_solid_fraction(packing: &Packing, solid_fraction: f64) -> Result<Packing> {
    if !solid_fraction.is_finite() || solid_fraction <= 0.0 {
        return Err(Error::Invalid(format!(
            "affine scaling: target solid fraction must be finite and > 0, got {solid_fraction}"
        )));
    }
    let cell = packing.cell.ok_or_else(|| {
        Error::Invalid("affine scaling needs a periodic packing (a cell to scale)".into())
    })?;
    let s = (packing.solid_fraction() / solid_fraction).cbrt();
    let positions = packing.positions.iter().map(|p| p * s).collect();
    Packing::new(
        positions,
        packing.radii.clone(),
        Some(PeriodicCell::new(cell.lengths * s)?),
    )
}
