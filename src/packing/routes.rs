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

/// The bucket grid of [`random_sequential_addition`]: cells at least 2·R_max wide over the
/// (widened) domain, each listing the spheres placed in it, so that a draw is tested
/// against the spheres of the 27 cells around it only.
struct GasGrid {
    /// Lower corner of the grid.
    lo: Vec3,
    /// Cells along each axis.
    dims: nalgebra::Vector3<usize>,
    /// Width of one cell along each axis.
    width: Vec3,
    /// Periodic grid (wraps at the faces) or free one.
    periodic: bool,
    /// Indices (into the placed spheres) of the spheres in each cell.
    members: Vec<Vec<u32>>,
}

impl GasGrid {
    /// A grid over [lo, hi] with cells no narrower than 2·`r_max`.
    fn new(lo: Vec3, hi: Vec3, r_max: f64, periodic: bool) -> Self {
        let extent = hi - lo;
        let dims = extent.map(|e| ((e / (2.0 * r_max)).floor() as usize).max(1));
        let width = extent.component_div(&dims.map(|d| d as f64));
        GasGrid {
            lo,
            dims,
            width,
            periodic,
            members: vec![Vec::new(); dims.product()],
        }
    }

    /// Flat index of grid cell `c`.
    fn index(&self, c: [usize; 3]) -> usize {
        (c[2] * self.dims[1] + c[1]) * self.dims[0] + c[0]
    }

    /// The grid cell holding point `p`.
    fn cell_of(&self, p: &Vec3) -> [usize; 3] {
        let c = |k: usize| (((p[k] - self.lo[k]) / self.width[k]) as usize).min(self.dims[k] - 1);
        [c(0), c(1), c(2)]
    }

    /// The grid cells next to cell `ck` on axis `k` (as many as the second of the pair says):
    /// periodic, every cell of a grid narrower than 3 cells; free, those inside the grid.
    fn near(&self, k: usize, ck: usize) -> ([usize; 3], usize) {
        let d = self.dims[k];
        match (self.periodic, d < 3) {
            (true, true) => ([0, 1, 2], d),
            (true, false) => ([(ck + d - 1) % d, ck, (ck + 1) % d], 3),
            (false, _) => {
                let first = ck.saturating_sub(1);
                (
                    [first, first + 1, first + 2],
                    (ck + 1).min(d - 1) + 1 - first,
                )
            }
        }
    }

    /// Whether a sphere of radius `rk` at `p` (in grid cell `c`) overlaps none of `placed`
    /// (minimum image in a periodic `cell`).
    fn is_free(
        &self,
        p: Vec3,
        rk: f64,
        c: [usize; 3],
        placed: &[(Vec3, f64)],
        cell: Option<&PeriodicCell>,
    ) -> bool {
        let (nz, ny, nx) = (self.near(2, c[2]), self.near(1, c[1]), self.near(0, c[0]));
        for &cz in &nz.0[..nz.1] {
            for &cy in &ny.0[..ny.1] {
                for &cx in &nx.0[..nx.1] {
                    for &j in &self.members[self.index([cx, cy, cz])] {
                        let (xj, rj) = placed[j as usize];
                        let d = match cell {
                            Some(cell) => cell.minimum_image(xj - p).0,
                            None => xj - p,
                        };
                        let reach = rj + rk;
                        if d.norm_squared() < reach * reach {
                            return false;
                        }
                    }
                }
            }
        }
        true
    }
}

/// One draw of the container's addition: uniform in the container widened by `margin`
/// (in the widened disc by rejection from its square, then along the widened axis), and
/// whether it fell inside the container itself (else it is a ghost).
fn draw_in_container(
    rng: &mut ChaCha8Rng,
    hi: Vec3,
    margin: f64,
    z_lo: f64,
    z_extent: f64,
) -> (Vec3, bool) {
    let r = hi.x + margin;
    let (px, py) = loop {
        let px = (2.0 * rng.gen::<f64>() - 1.0) * r;
        let py = (2.0 * rng.gen::<f64>() - 1.0) * r;
        if px * px + py * py <= r * r {
            break (px, py);
        }
    };
    let p = Vec3::new(px, py, z_lo + rng.gen::<f64>() * z_extent);
    let inside = px.hypot(py) <= hi.x && p.z >= 0.0 && p.z <= hi.z;
    (p, inside)
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
    let mut grid = GasGrid::new(grid_lo, grid_hi, r_max, cell.is_some());
    let z_extent = grid_hi.z - grid_lo.z;
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
        let (p, inside) = match &cell {
            Some(cell) => {
                let p = Vec3::new(
                    rng.gen::<f64>() * side,
                    rng.gen::<f64>() * side,
                    rng.gen::<f64>() * side,
                );
                (cell.wrap(p).0, true)
            }
            None => draw_in_container(rng, hi, margin, grid_lo.z, z_extent),
        };
        let rk = if inside { radii[k] } else { radii[ghosts % n] };
        let c = grid.cell_of(&p);
        if grid.is_free(p, rk, c, &placed, cell.as_ref()) {
            let slot = grid.index(c);
            grid.members[slot].push(placed.len() as u32);
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

/// A preparation in progress (R̄ units): the spheres, the side of the cell or container,
/// and the minimisations and FIRE iterations run so far.
struct RouteRun<'a> {
    domain: Domain,
    opts: &'a RouteOptions,
    status: &'a (dyn Fn(&RouteStatus) + Sync),
    radii: Vec<f64>,
    solid_volume: f64,
    x: Vec<Vec3>,
    side: f64,
    relaxations: usize,
    iterations: usize,
}

impl<'a> RouteRun<'a> {
    /// Seeded radii and the random gas at the gas solid fraction (Kumar 2016 Sec. 3),
    /// in spatial order; refuses a periodic cell too small for a unique minimum image.
    fn gas(
        domain: Domain,
        opts: &'a RouteOptions,
        status: &'a (dyn Fn(&RouteStatus) + Sync),
    ) -> Result<Self> {
        let n = opts.n_particles;
        let (radii, mut rng) = seeded_radii(n, opts.polydispersity, opts.seed);
        let solid_volume = solid_volume_of(&radii);
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
        let mut run = RouteRun {
            domain,
            opts,
            status,
            radii: Vec::new(),
            solid_volume,
            x: Vec::new(),
            side: side_of(opts.gas_solid_fraction),
            relaxations: 0,
            iterations: 0,
        };
        run.report(0.0, RouteStage::Gas, 0, opts.gas_solid_fraction);
        let gas = random_sequential_addition(&radii, domain, run.side, &mut rng, 1_000_000)?;
        let (lo, hi) = domain.bounds(run.side);
        (run.x, run.radii) = spatial_order(&gas, &radii, lo, hi);
        run.report(0.02, RouteStage::Gas, 0, run.phi_of(run.side));
        Ok(run)
    }

    /// Solid fraction of a cell or container of side `side`.
    fn phi_of(&self, side: f64) -> f64 {
        self.solid_volume / (side * side * side)
    }

    /// Side at which the spheres fill solid fraction `phi`.
    fn side_of(&self, phi: f64) -> f64 {
        (self.solid_volume / phi).cbrt()
    }

    /// Pass a progress report to the caller's `status`.
    fn report(&self, fraction: f64, stage: RouteStage, iterations: usize, solid_fraction: f64) {
        (self.status)(&RouteStatus {
            fraction,
            stage,
            iterations,
            solid_fraction,
        })
    }

    /// Remove the overlaps at the current side by energy minimisation (residual overlaps
    /// ≤ 10⁻⁶ R̄, ≪ any bonding window); not converging is an error.
    fn relax_overlap_free(&mut self) -> Result<RelaxOutcome> {
        let max_iterations = self.opts.max_iterations;
        let target = RelaxTarget {
            max_overlap: 1e-6,
            force_balance: None,
            max_iterations,
        };
        let (domain, side) = (self.domain, self.side);
        let out = fire_relax(
            &mut self.x,
            &self.radii,
            side,
            domain,
            &target,
            &mut |_, _| {},
        )?;
        self.relaxations += 1;
        self.iterations += out.iterations;
        if !out.converged() {
            return Err(Error::NotConverged(format!(
                "packing preparation: energy minimisation at solid fraction {:.5} did not \
                 converge in {max_iterations} iterations (largest overlap {:.2e} R̄)",
                self.phi_of(side),
                out.max_overlap
            )));
        }
        Ok(out)
    }

    /// Quasi-static compression of the gas to solid fraction `stop`: affine steps of
    /// `compression_step`, each followed by an overlap-free minimisation (the limit of
    /// Kumar's pressure-controlled compression at P_c/Σ_N = 10⁻⁷).
    fn compress_to(&mut self, stop: f64) -> Result<()> {
        let phi_start = self.phi_of(self.side);
        let mut phi = phi_start;
        while phi < stop {
            let next = (phi * (1.0 + self.opts.compression_step)).min(stop);
            let new_side = self.side_of(next);
            let s = new_side / self.side;
            scale_affinely(&mut self.x, &mut self.side, s);
            self.side = new_side;
            self.relax_overlap_free()?;
            phi = next;
            let done = (phi / phi_start).ln() / (stop / phi_start).ln();
            self.report(
                0.02 + 0.5 * done.clamp(0.0, 1.0),
                RouteStage::Compression {
                    target_solid_fraction: stop,
                },
                self.iterations,
                phi,
            );
        }
        Ok(())
    }

    /// From the unjammed state at 0.55, minimise the enthalpy E + P_t·V with the cell as one
    /// more degree of freedom (O'Hern et al. 2003; Kumar's pressure-controlled compression):
    /// the cell shrinks until the spheres are force balanced at P ≈ P_t =
    /// ½·`jamming_pressure`, just above the jamming point. Stages: jam fast at a high
    /// pressure (the cell collapses in a few thousand iterations), then decompress by decades
    /// to the target, loosely force balanced on the way; only the last stage is held to
    /// `jamming_balance`. Creeping to the jamming point at the final small pressure directly
    /// is ~10× slower. Returns the last stage's outcome.
    fn jam(&mut self) -> Result<PressureOutcome> {
        let final_pressure = 0.5 * self.opts.jamming_pressure;
        let mut stages: Vec<(f64, ForceBalance)> = Vec::new();
        let mut p_stage: f64 = JAMMING_FIRST_STAGE_PRESSURE;
        while p_stage > 2.0 * final_pressure {
            stages.push((p_stage, JAMMING_UPPER_STAGE_BALANCE));
            p_stage *= 0.1;
        }
        stages.push((final_pressure, self.opts.jamming_balance));
        let mut out = Default::default();
        for (k, &(p_t, balance)) in stages.iter().enumerate() {
            out = self.jam_stage(k, stages.len(), p_t, balance)?;
        }
        Ok(out)
    }

    /// Stage `k` of `n_stages` of [`Self::jam`]: FIRE on the enthalpy at pressure `p_t`
    /// until |P − P_t| ≤ ½P_t and `balance` holds; not converging is an error.
    fn jam_stage(
        &mut self,
        k: usize,
        n_stages: usize,
        p_t: f64,
        balance: ForceBalance,
    ) -> Result<PressureOutcome> {
        let max_iterations = self.opts.max_iterations;
        let target = PressureTarget {
            pressure: p_t,
            pressure_tolerance: 0.5,
            force_balance: balance,
            max_iterations,
        };
        let mut first = None;
        let mut done = 0.0f64;
        let before = self.iterations;
        let (status, solid_volume) = (self.status, self.solid_volume);
        let stage_out: PressureOutcome = fire_jam_at_pressure(
            &mut self.x,
            &self.radii,
            &mut self.side,
            self.domain,
            &target,
            &mut |c| {
                // Fraction of the way (logarithmic) from the first residual to 1.
                let r = c.residual;
                let r0 = *first.get_or_insert(r.max(10.0));
                if r.is_finite() && r0.is_finite() {
                    let frac = ((r0 / r.max(1.0)).ln() / r0.ln()).clamp(0.0, 0.999);
                    done = done.max(frac);
                }
                status(&RouteStatus {
                    fraction: 0.52 + 0.47 * (k as f64 + done) / n_stages as f64,
                    stage: RouteStage::Jamming {
                        stage: k + 1,
                        stages: n_stages,
                        target_pressure: p_t,
                        pressure: c.pressure,
                        residual: r,
                    },
                    iterations: before + c.iterations,
                    solid_fraction: solid_volume / (c.side * c.side * c.side),
                });
            },
        )?;
        self.relaxations += 1;
        self.iterations += stage_out.iterations;
        if !stage_out.converged {
            return Err(Error::NotConverged(format!(
                "packing preparation: no force-balanced jammed state at pressure {p_t:e} \
                 found in {max_iterations} iterations (reached P = {:.3e} at solid \
                 fraction {:.5})",
                stage_out.pressure,
                self.phi_of(self.side)
            )));
        }
        Ok(stage_out)
    }

    /// The contact statistics of the compressed state, then the final affine step to the
    /// requested solid fraction (Kumar Eq. 10's overlaps), scaled to metres: the packing,
    /// its side (m) and the report (`jammed`: the jamming outcome, if any).
    fn finish(mut self, jammed: PressureOutcome) -> Result<(Packing, f64, RouteReport)> {
        let compressed = self.phi_of(self.side);
        let (compressed_coordination, rattlers) =
            contact_statistics(&self.x, &self.radii, self.domain, self.side)?;
        let final_side = self.side_of(self.opts.solid_fraction);
        let affine_scale = final_side / self.side;
        scale_affinely(&mut self.x, &mut self.side, affine_scale);
        let scale = self.opts.mean_radius;
        let cell = self.domain.cell(final_side * scale)?;
        let positions: Vec<Vec3> = self.x.iter().map(|p| *p * scale).collect();
        let radii: Vec<f64> = self.radii.iter().map(|r| r * scale).collect();
        let packing = Packing::new(positions, radii, cell)?;
        self.report(
            1.0,
            RouteStage::Done,
            self.iterations,
            self.phi_of(self.side),
        );
        Ok((
            packing,
            final_side * scale,
            RouteReport {
                route: self.opts.route,
                compressed_solid_fraction: compressed,
                compressed_coordination,
                rattlers,
                pressure: jammed.pressure,
                mean_unbalanced: jammed.mean_unbalanced,
                largest_unbalanced: jammed.largest_unbalanced,
                affine_scale,
                relaxations: self.relaxations,
                iterations: self.iterations,
            },
        ))
    }
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
    let mut run = RouteRun::gas(domain, opts, status)?;
    let mut jammed = PressureOutcome::default();
    match opts.route {
        PreparationRoute::Unjammed => {}
        PreparationRoute::WeaklyJammed => run.compress_to(opts.weak_jamming_solid_fraction)?,
        PreparationRoute::Jammed => {
            run.compress_to(0.55)?;
            jammed = run.jam()?;
        }
    }
    run.finish(jammed)
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
