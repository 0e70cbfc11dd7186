//! Seeded random periodic packings at a prescribed solid fraction.
//!
//! Radii are drawn, the periodic cube is sized so that Σ(4/3)πR³ / L³ equals the target
//! solid fraction φ, centres are placed uniformly at random, and the overlaps are then
//! removed by minimising the soft-sphere energy E = ½ Σ max(0, R_i + R_j − |l|)² with FIRE
//! (Bitzek et al. 2006), using Verlet lists built by cell lists. For φ below jamming
//! (≈ 0.64) the energy reaches zero: the result is an overlap-free (to a tolerance),
//! unjammed random packing whose near contacts form the bond network.
//!
//! Every random number comes from one `ChaCha8Rng` stream in a fixed order and every sum
//! is taken in a fixed order, so the packing is bit-identical on any number of threads.

use super::fire::{self, FireStep, FireSystem, FIRE_FIXED_CELL, FIRE_VARIABLE_CELL};
use super::repulsion::{lanes_available, ScaledVerletList, Spheres, Walls};
use super::{Packing, PeriodicCell};
use crate::{Error, Result, Vec3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;
use std::f64::consts::PI;

/// Relative half width of the radius distribution of Truszkowska 2018 (Sec. 4.1): radii
/// "drawn from a uniform distribution with a range ΔR = R̄/6". We read *range* as the
/// full width max − min = R̄/6, i.e. R ∈ [R̄ − R̄/12, R̄ + R̄/12]; this reproduces the
/// paper's numbers (30,700 spheres at φ = 0.60 fill a cube of side 59.98 R̄, printed
/// "60.0 R̄"; the other reading, R ∈ [R̄ ± R̄/6], would need 60.38 R̄).
pub const TRUSZKOWSKA_2018_HALF_WIDTH: f64 = 1.0 / 12.0;

/// How the radii are distributed around the mean radius R̄.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Polydispersity {
    /// All radii equal R̄.
    Monodisperse,
    /// Radii uniform in [R̄(1 − h), R̄(1 + h)] with h = `half_width` = ΔR/R̄ ∈ [0, 1)
    /// (then rescaled so that the sample mean is exactly R̄).
    /// [`TRUSZKOWSKA_2018_HALF_WIDTH`] gives the paper's distribution.
    Uniform {
        /// Relative half width h = ΔR/R̄.
        half_width: f64,
    },
}

/// What to generate.
#[derive(Clone, Debug, PartialEq)]
pub struct GenerateOptions {
    /// Number of spheres N (at least 2; a few dozen so that the cell is wider than twice
    /// the neighbour cutoff).
    pub n_particles: usize,
    /// Target solid fraction φ = Σ(4/3)πR³ / L³ (0 < φ ≤ 0.64; reliable up to 0.62).
    pub solid_fraction: f64,
    /// Mean radius R̄ (m).
    pub mean_radius: f64,
    /// Radius distribution.
    pub polydispersity: Polydispersity,
    /// Seed of the random stream (ChaCha8).
    pub seed: u64,
    /// Largest overlap R_i + R_j − |l| allowed in the result, relative to R̄.
    pub max_overlap: f64,
    /// Iteration limit of the energy minimisation; reaching it is an error.
    pub max_iterations: usize,
}

impl Default for GenerateOptions {
    /// 1000 spheres, φ = 0.6, R̄ = 1 mm, the paper's polydispersity, seed 2018.
    fn default() -> Self {
        GenerateOptions {
            n_particles: 1000,
            solid_fraction: 0.6,
            mean_radius: 1.0e-3,
            polydispersity: Polydispersity::Uniform {
                half_width: TRUSZKOWSKA_2018_HALF_WIDTH,
            },
            seed: 2018,
            max_overlap: 1.0e-4,
            max_iterations: 200_000,
        }
    }
}

/// How the generation went.
#[derive(Clone, Debug, PartialEq)]
pub struct GenerationReport {
    /// Largest overlap R_i + R_j − |l| in the result, relative to R̄ (≤ 0: none).
    pub max_overlap: f64,
    /// FIRE iterations used.
    pub iterations: usize,
    /// Verlet-list rebuilds.
    pub neighbour_rebuilds: usize,
}

/// Generate a periodic random packing (see the module doc); `progress` receives the
/// fraction done in [0, 1].
pub fn generate(opts: &GenerateOptions, progress: &(dyn Fn(f64) + Sync)) -> Result<Packing> {
    Ok(generate_with_report(opts, progress)?.0)
}

/// The refusal (without context) of a mean radius that is not finite and > 0 or a uniform
/// polydispersity half width outside [0, 1).
pub(crate) fn check_radii(
    mean_radius: f64,
    polydispersity: Polydispersity,
) -> std::result::Result<(), String> {
    if !mean_radius.is_finite() || mean_radius <= 0.0 {
        return Err(format!(
            "mean radius must be finite and > 0, got {mean_radius}"
        ));
    }
    if let Polydispersity::Uniform { half_width } = polydispersity {
        if !half_width.is_finite() || !(0.0..1.0).contains(&half_width) {
            return Err(format!(
                "polydispersity half width ΔR/R̄ must be in [0, 1), got {half_width}"
            ));
        }
    }
    Ok(())
}

fn check_options(opts: &GenerateOptions) -> Result<()> {
    let bad = |m: String| Err(Error::Invalid(format!("packing generation: {m}")));
    let phi = opts.solid_fraction;
    if !phi.is_finite() || phi <= 0.0 || phi > 0.64 {
        return bad(format!(
            "solid fraction must be in (0, 0.64] (random packings jam near 0.64), got {phi}"
        ));
    }
    check_radii(opts.mean_radius, opts.polydispersity).or_else(bad)?;
    if !opts.max_overlap.is_finite() || opts.max_overlap <= 0.0 {
        return bad(format!(
            "max_overlap must be finite and > 0, got {}",
            opts.max_overlap
        ));
    }
    super::check_packing_size(
        opts.n_particles,
        opts.mean_radius,
        opts.solid_fraction,
        "packing generation",
    )?;
    Ok(())
}

/// Repulsive harmonic forces F_i = Σ_j max(0, R_i + R_j − |l|)·(−l/|l|) (unit stiffness),
/// the largest overlap of each particle, and per particle (Σ overlap, Σ overlap·|l|,
/// number of overlapping neighbours) for the force-balance test and the virial pressure.
fn forces(spheres: Spheres, f: &mut [Vec3], overlap: &mut [f64], contact: &mut [ContactSums]) {
    let lanes = lanes_available();
    f.par_iter_mut()
        .zip(overlap.par_iter_mut())
        .zip(contact.par_iter_mut())
        .enumerate()
        .with_min_len(256)
        .for_each(|(i, ((fi, oi), ci))| {
            let c = spheres.contacts(i, lanes, (0.0, 0.0));
            *fi = c.force;
            *oi = c.worst;
            *ci = ContactSums {
                force: c.overlap_sum,
                contacts: c.contacts,
            };
        });
}

/// Per-particle contact sums of [`forces`] (each pair counted from both ends).
#[derive(Clone, Copy, Debug, Default)]
struct ContactSums {
    force: f64,
    contacts: u32,
}

/// Sum of `g(k)` over `0..n` in fixed chunks, then sequentially: the same bits on any
/// thread count.
fn ordered_sum(n: usize, g: impl Fn(usize) -> f64 + Sync) -> f64 {
    const CHUNK: usize = 4096;
    let parts: Vec<f64> = (0..n.div_ceil(CHUNK))
        .into_par_iter()
        .map(|c| (c * CHUNK..((c + 1) * CHUNK).min(n)).map(&g).sum())
        .collect();
    parts.iter().sum()
}

/// Largest entry, and 0 for no entry or no positive one (overlaps: none means 0, not −∞).
fn max_of(v: &[f64]) -> f64 {
    v.par_iter()
        .with_min_len(4096)
        .copied()
        .reduce(|| 0.0, f64::max)
}

/// Radii in units of R̄ (sample mean exactly 1, [`draw_radii`]) from a ChaCha8 generator
/// seeded with `seed`, and the generator, which goes on to place the spheres.
pub(crate) fn seeded_radii(
    n: usize,
    polydispersity: Polydispersity,
    seed: u64,
) -> (Vec<f64>, ChaCha8Rng) {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let radii = draw_radii(n, polydispersity, &mut rng);
    (radii, rng)
}

/// Radii in units of R̄ drawn from `rng` (one draw per sphere, in order), rescaled so that
/// the sample mean is exactly 1.
fn draw_radii(n: usize, polydispersity: Polydispersity, rng: &mut ChaCha8Rng) -> Vec<f64> {
    let mut radii: Vec<f64> = match polydispersity {
        Polydispersity::Monodisperse => vec![1.0; n],
        Polydispersity::Uniform { half_width } => (0..n)
            .map(|_| 1.0 + half_width * (2.0 * rng.gen::<f64>() - 1.0))
            .collect(),
    };
    let mean = radii.iter().sum::<f64>() / n as f64;
    if mean != 1.0 {
        radii.iter_mut().for_each(|r| *r /= mean);
    }
    radii
}

/// Total volume Σ (4/3)πR³ of the spheres (R in units of R̄, so in R̄³).
pub(crate) fn solid_volume_of(radii: &[f64]) -> f64 {
    radii.iter().map(|r| 4.0 / 3.0 * PI * r * r * r).sum()
}

/// The largest radius (0 for no sphere).
pub(crate) fn largest_radius(radii: &[f64]) -> f64 {
    radii.iter().copied().fold(0.0, f64::max)
}

/// Renumber the spheres in the box [lo, hi] in spatial order (cells of about 2 R̄, z then y
/// then x) so that neighbours are close in memory; radii were drawn independently of
/// position, so this does not change the distribution.
pub(crate) fn spatial_order(
    x: &[Vec3],
    radii: &[f64],
    lo: Vec3,
    hi: Vec3,
) -> (Vec<Vec3>, Vec<f64>) {
    let extent = hi - lo;
    let grid = extent.map(|e| ((e / 2.0).floor() as usize).max(1));
    let cell_key = |p: &Vec3| {
        let c =
            |k: usize| (((p[k] - lo[k]) / extent[k] * grid[k] as f64) as usize).min(grid[k] - 1);
        (c(2) * grid[1] + c(1)) * grid[0] + c(0)
    };
    let mut order: Vec<usize> = (0..x.len()).collect();
    order.sort_by_key(|&k| (cell_key(&x[k]), k));
    (
        order.iter().map(|&k| x[k]).collect(),
        order.iter().map(|&k| radii[k]).collect(),
    )
}

/// Where the spheres of a minimisation live (lengths in units of R̄). The "side" L of the
/// minimisers is the cube root of the volume in both cases, and scaling it scales the
/// domain about the origin with the positions.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) enum Domain {
    /// The periodic cube [0, L)³.
    Periodic,
    /// A rigid container, free space with soft repulsive walls ([`Walls`]): the cylinder of
    /// radius `radius`·L about the z axis between the planes z = 0 and z = `length`·L
    /// (π·radius²·length = 1, so that its volume is L³).
    Container {
        /// Container radius over L.
        radius: f64,
        /// Container length over L.
        length: f64,
    },
}

impl Domain {
    /// The container of slenderness (length over radius) `aspect`, of volume L³.
    pub(crate) fn container(aspect: f64) -> Domain {
        let radius = (1.0 / (PI * aspect)).cbrt();
        Domain::Container {
            radius,
            length: aspect * radius,
        }
    }

    /// The box [lo, hi] the sphere centres are drawn in: the periodic cube, or the
    /// container's bounding box.
    pub(crate) fn bounds(self, side: f64) -> (Vec3, Vec3) {
        match self {
            Domain::Periodic => (Vec3::zeros(), Vec3::repeat(side)),
            Domain::Container { radius, length } => {
                let r = radius * side;
                (Vec3::new(-r, -r, 0.0), Vec3::new(r, r, length * side))
            }
        }
    }

    /// The periodic cube of side `side`, or `None` in a container.
    pub(crate) fn cell(self, side: f64) -> Result<Option<PeriodicCell>> {
        match self {
            Domain::Periodic => Ok(Some(PeriodicCell::new(Vec3::repeat(side))?)),
            Domain::Container { .. } => Ok(None),
        }
    }

    /// The container's walls at side `side` (`None` when periodic).
    pub(super) fn walls(self, side: f64) -> Option<Walls> {
        match self {
            Domain::Periodic => None,
            Domain::Container { radius, length } => Some(Walls {
                radius: radius * side,
                length: length * side,
            }),
        }
    }

    /// Wrap the positions into the cube of side `side` (periodic; nothing in a container).
    fn wrap(self, x: &mut [Vec3], side: f64) -> Result<()> {
        if let Some(cell) = self.cell(side)? {
            x.iter_mut().for_each(|p| *p = cell.wrap(*p).0);
        }
        Ok(())
    }
}

/// When [`fire_relax`] stops (lengths in units of R̄, unit contact stiffness).
#[derive(Clone, Copy, Debug)]
pub(crate) struct RelaxTarget {
    /// Stop when the largest overlap R_i + R_j − |l| is below this: an overlap-free state.
    pub max_overlap: f64,
    /// Also stop when force balanced, max_i |F_i| ≤ this × the mean contact force (a
    /// jammed state; Kumar 2016 Sec. 3 uses 10⁻³ of the largest contact force).
    pub force_balance: Option<f64>,
    /// Iteration limit (not an error here: see [`RelaxOutcome::converged`]).
    pub max_iterations: usize,
}

/// How a [`fire_relax`] call ended.
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct RelaxOutcome {
    /// FIRE iterations used.
    pub iterations: usize,
    /// Verlet-list rebuilds.
    pub rebuilds: usize,
    /// Largest overlap at the end (R̄).
    pub max_overlap: f64,
    /// Stopped on the overlap criterion.
    pub overlap_free: bool,
    /// Stopped on the force-balance criterion.
    pub force_balanced: bool,
}

impl RelaxOutcome {
    /// True when a stopping criterion was met (not the iteration limit).
    pub fn converged(&self) -> bool {
        self.overlap_free || self.force_balanced
    }
}

/// Minimise the soft-sphere energy E = ½ Σ max(0, R_i + R_j − |l|)² over the positions `x`
/// (R̄ = 1, cube of side `side`, or the container of that volume, `domain`, whose walls
/// repel as spheres do) with FIRE (Bitzek et al. 2006), semi-implicit Euler steps,
/// unit masses and stiffness, Verlet lists rebuilt when a sphere has moved half the skin.
/// `on_check(iterations, largest overlap)` is called at the start and every 25 iterations.
/// Positions are wrapped into the cell on return.
///
/// The loop runs on a rayon worker thread, so that the many small parallel loops of one
/// iteration do not each pay the cost of entering the pool (large for small packings).
pub(crate) fn fire_relax(
    x: &mut [Vec3],
    radii: &[f64],
    side: f64,
    domain: Domain,
    target: &RelaxTarget,
    on_check: &mut (dyn FnMut(usize, f64) + Send),
) -> Result<RelaxOutcome> {
    rayon::scope(|_| {
        let n = x.len();
        let r_max = largest_radius(radii);
        // Verlet skin: 0.3 R̄, less if the cell is small (cutoff must stay below L/2).
        let skin = match domain {
            Domain::Periodic => 0.3f64.min(0.49 * side - 2.0 * r_max),
            Domain::Container { .. } => 0.3,
        };
        if skin < 0.05 {
            return Err(Error::Invalid(format!(
                "packing generation: {n} spheres give a periodic cell of side {side:.3} R̄, too \
             small for a unique minimum image (need more than 4.1·R_max); use more particles"
            )));
        }
        let cell = domain.cell(side)?;
        domain.wrap(x, side)?;

        let list = ScaledVerletList::build(x, radii, cell.as_ref(), skin)?;
        let x_ref = x.to_vec();
        let mut system = FixedCell {
            x,
            radii,
            side,
            cell,
            walls: domain.walls(side),
            skin,
            target,
            on_check,
            v: vec![Vec3::zeros(); n],
            f: vec![Vec3::zeros(); n],
            overlap: vec![0.0; n],
            contact: vec![ContactSums::default(); n],
            list,
            rebuilds: 1,
            x_ref,
            worst: 0.0,
            force_balanced: false,
        };
        system.force_pass();
        let run = fire::minimise(&FIRE_FIXED_CELL, &mut system, target.max_iterations)?;
        let FixedCell {
            x,
            rebuilds,
            worst,
            force_balanced,
            ..
        } = system;
        domain.wrap(x, side)?;
        Ok(RelaxOutcome {
            iterations: run.iterations,
            rebuilds,
            max_overlap: worst,
            overlap_free: worst < target.max_overlap,
            force_balanced,
        })
    })
}

/// The soft-sphere energy in a fixed cube or container, as the [`FireSystem`] of
/// [`fire_relax`].
struct FixedCell<'a> {
    x: &'a mut [Vec3],
    radii: &'a [f64],
    side: f64,
    /// The periodic cube (`None` in a container).
    cell: Option<PeriodicCell>,
    walls: Option<Walls>,
    skin: f64,
    target: &'a RelaxTarget,
    on_check: &'a mut (dyn FnMut(usize, f64) + Send),
    v: Vec<Vec3>,
    f: Vec<Vec3>,
    overlap: Vec<f64>,
    contact: Vec<ContactSums>,
    list: ScaledVerletList,
    rebuilds: usize,
    /// Positions at the last Verlet-list build.
    x_ref: Vec<Vec3>,
    /// Largest overlap now.
    worst: f64,
    force_balanced: bool,
}

impl FixedCell<'_> {
    /// Forces and the largest overlap at the current positions.
    fn force_pass(&mut self) {
        let spheres = Spheres {
            list: &self.list,
            x: self.x,
            radii: self.radii,
            side: self.side,
            walls: self.walls,
        };
        forces(spheres, &mut self.f, &mut self.overlap, &mut self.contact);
        self.worst = max_of(&self.overlap);
    }

    /// max_i |F_i| ≤ `ratio` × the mean contact force (false with no contact).
    fn balanced(&self, ratio: f64) -> bool {
        let (f, contact) = (&self.f, &self.contact);
        let n_contacts: u64 = contact.iter().map(|c| c.contacts as u64).sum();
        if n_contacts == 0 {
            return false;
        }
        let mean_force = ordered_sum(f.len(), |k| contact[k].force) / n_contacts as f64;
        let f_max = f
            .par_iter()
            .with_min_len(4096)
            .map(|g| g.norm_squared())
            .reduce(|| 0.0, f64::max)
            .sqrt();
        f_max <= ratio * mean_force
    }
}

impl FireSystem for FixedCell<'_> {
    /// Overlap-free (largest overlap below the target), or force balanced (checked every 10
    /// iterations); reports to `on_check` at the start and every 25 iterations.
    fn converged(&mut self, iterations: usize) -> bool {
        if iterations.is_multiple_of(25) {
            (self.on_check)(iterations, self.worst);
        }
        if self.worst < self.target.max_overlap {
            return true;
        }
        if let Some(ratio) = self.target.force_balance {
            if iterations.is_multiple_of(10) && self.balanced(ratio) {
                self.force_balanced = true;
                return true;
            }
        }
        false
    }

    fn power(&self) -> f64 {
        let (f, v) = (&self.f, &self.v);
        ordered_sum(f.len(), |k| f[k].dot(&v[k]))
    }

    /// Semi-implicit Euler with unit masses; the Verlet list is rebuilt when a sphere has
    /// moved half the skin since the last build.
    fn advance(&mut self, step: &FireStep) -> Result<()> {
        let n = self.x.len();
        let dt = step.dt;
        if step.reset {
            let back = step.back();
            self.x
                .par_iter_mut()
                .zip(self.v.par_iter_mut())
                .with_min_len(1024)
                .for_each(|(xk, vk)| {
                    *xk -= *vk * back;
                    *vk = Vec3::zeros();
                });
        }
        self.v
            .par_iter_mut()
            .zip(self.f.par_iter())
            .with_min_len(1024)
            .for_each(|(vk, fk)| *vk += fk * dt);
        let (f, v) = (&self.f, &self.v);
        let v_norm = ordered_sum(n, |k| v[k].norm_squared()).sqrt();
        let f_norm = ordered_sum(n, |k| f[k].norm_squared()).sqrt();
        let mix = step.mix(v_norm, f_norm);
        let alpha = step.alpha;
        self.x
            .par_iter_mut()
            .zip(self.v.par_iter_mut())
            .zip(self.f.par_iter())
            .with_min_len(1024)
            .for_each(|((xk, vk), fk)| {
                *vk = *vk * (1.0 - alpha) + fk * mix;
                *xk += *vk * dt;
            });
        let moved = self
            .x
            .par_iter()
            .zip(self.x_ref.par_iter())
            .with_min_len(4096)
            .map(|(a, b)| (a - b).norm())
            .reduce(|| 0.0, f64::max);
        if 2.0 * moved > self.skin {
            if let Some(cell) = &self.cell {
                self.x.iter_mut().for_each(|p| *p = cell.wrap(*p).0);
            }
            self.list = ScaledVerletList::build(self.x, self.radii, self.cell.as_ref(), self.skin)?;
            self.rebuilds += 1;
            self.x_ref.copy_from_slice(self.x);
        }
        self.force_pass();
        Ok(())
    }
}

/// [`generate`], also returning how the minimisation went.
pub fn generate_with_report(
    opts: &GenerateOptions,
    progress: &(dyn Fn(f64) + Sync),
) -> Result<(Packing, GenerationReport)> {
    check_options(opts)?;
    let n = opts.n_particles;
    let (radii, mut rng) = seeded_radii(n, opts.polydispersity, opts.seed);
    let solid_volume = solid_volume_of(&radii);
    let side = (solid_volume / opts.solid_fraction).cbrt();
    let r_max = largest_radius(&radii);
    if 0.3f64.min(0.49 * side - 2.0 * r_max) < 0.05 {
        return Err(Error::Invalid(format!(
            "packing generation: {n} spheres give a periodic cell of side {side:.3} R̄, too \
             small for a unique minimum image (need more than 4.1·R_max); use more particles"
        )));
    }
    let cell = PeriodicCell::new(Vec3::repeat(side))?;
    let x: Vec<Vec3> = (0..n)
        .map(|_| {
            Vec3::new(
                rng.gen::<f64>() * side,
                rng.gen::<f64>() * side,
                rng.gen::<f64>() * side,
            )
        })
        .map(|p| cell.wrap(p).0)
        .collect();
    let (mut x, radii) = spatial_order(&x, &radii, Vec3::zeros(), Vec3::repeat(side));

    let tol = opts.max_overlap;
    let mut initial = 2.0 * tol;
    let mut done = 0.0f64;
    progress(0.0);
    let outcome = fire_relax(
        &mut x,
        &radii,
        side,
        Domain::Periodic,
        &RelaxTarget {
            max_overlap: tol,
            force_balance: None,
            max_iterations: opts.max_iterations,
        },
        &mut |iterations, worst| {
            if iterations == 0 {
                initial = worst.max(2.0 * tol);
            } else if worst > 0.0 {
                let frac = ((initial / worst).ln() / (initial / tol).ln()).clamp(0.0, 0.999);
                if frac > done {
                    done = frac;
                    progress(done);
                }
            }
        },
    )?;
    if !outcome.overlap_free {
        return Err(Error::NotConverged(format!(
            "packing generation did not converge in {} iterations: largest overlap \
             {:.3e} R̄ > {tol:.1e} R̄ (solid fraction {} too close to jamming?)",
            opts.max_iterations, outcome.max_overlap, opts.solid_fraction
        )));
    }
    progress(1.0);

    let scale = opts.mean_radius;
    let positions: Vec<Vec3> = x.iter().map(|p| *p * scale).collect();
    let radii: Vec<f64> = radii.iter().map(|r| r * scale).collect();
    let cell = PeriodicCell::new(Vec3::repeat(side * scale))?;
    let packing = Packing::new(positions, radii, Some(cell))?;
    Ok((
        packing,
        GenerationReport {
            max_overlap: outcome.max_overlap,
            iterations: outcome.iterations,
            neighbour_rebuilds: outcome.rebuilds,
        },
    ))
}

/// When [`fire_jam_at_pressure`] stops (lengths in units of R̄, unit contact stiffness, so
/// pressures are in units of Σ_N as in Kumar 2016 Eq. 2).
#[derive(Clone, Copy, Debug)]
pub(crate) struct PressureTarget {
    /// Imposed pressure P_t of the enthalpy H = E + P_t·V (O'Hern et al. 2003 protocol).
    pub pressure: f64,
    /// Accept a virial pressure P with |P − P_t| ≤ this × P_t.
    pub pressure_tolerance: f64,
    /// And force balance, as [`ForceBalance`] measures it.
    pub force_balance: ForceBalance,
    /// Iteration limit (not an error here: see [`PressureOutcome::converged`]).
    pub max_iterations: usize,
}

/// How the force balance of a jammed state is measured: the net forces F_i on the spheres
/// against the contact forces (each a ratio; R̄ units, unit stiffness).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ForceBalance {
    /// YADE's unbalanced force (`unbalancedForce()`): mean_i |F_i| over all spheres ≤ this
    /// × the mean contact force. Intensive: the time to reach it does not grow with N.
    Mean(f64),
    /// Kumar 2016 Sec. 3 ("total force on particles smaller than 10⁻³ N_max"), taken over
    /// the whole packing: max_i |F_i| ≤ this × the largest contact force. Extensive near
    /// jamming: the largest of N fluctuating net forces falls below the bound later, the
    /// larger N.
    Largest(f64),
}

impl ForceBalance {
    /// The ratio bound.
    pub fn ratio(self) -> f64 {
        match self {
            ForceBalance::Mean(r) | ForceBalance::Largest(r) => r,
        }
    }
}

/// How a [`fire_jam_at_pressure`] call ended.
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct PressureOutcome {
    /// FIRE iterations used.
    pub iterations: usize,
    /// Virial pressure P = (1/3V) Σ_contacts f·|l| at the end.
    pub pressure: f64,
    /// Mean net force over mean contact force at the end (YADE's unbalanced force).
    pub mean_unbalanced: f64,
    /// Largest net force over largest contact force at the end (Kumar's N_max ratio).
    pub largest_unbalanced: f64,
    /// Both criteria of the [`PressureTarget`] met.
    pub converged: bool,
}

/// What [`fire_jam_at_pressure`] reports to its `on_check` callback (R̄ units, pressures
/// in Σ_N).
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct JamCheck {
    /// FIRE iterations of this minimisation so far.
    pub iterations: usize,
    /// max(|P − P_t|/(tol·P_t), force-balance measure / its bound); done when ≤ 1.
    pub residual: f64,
    /// Virial pressure P.
    pub pressure: f64,
    /// Cell side L.
    pub side: f64,
}

/// Per-chunk sums of one force pass of [`fire_jam_at_pressure`]; chunks have a fixed size
/// and are summed in order, so the totals are the same bits on any thread count.
#[derive(Clone, Copy, Debug, Default)]
struct ChunkSums {
    /// Σ F_i·v_i.
    power: f64,
    /// Σ |F_i|².
    f2: f64,
    /// Σ |v_i|².
    v2: f64,
    /// max |F_i|².
    f_max2: f64,
    /// Largest overlap (= largest contact force, unit stiffness).
    overlap_max: f64,
    /// Σ overlaps, each contact counted from both ends.
    force: f64,
    /// Σ overlap·|l|, each contact counted from both ends.
    virial: f64,
    /// Contacts, counted from both ends.
    contacts: u64,
    /// Σ |F_i|.
    f_abs: f64,
}

impl ChunkSums {
    fn add(mut self, o: &ChunkSums) -> ChunkSums {
        self.power += o.power;
        self.f2 += o.f2;
        self.v2 += o.v2;
        self.f_max2 = self.f_max2.max(o.f_max2);
        self.overlap_max = self.overlap_max.max(o.overlap_max);
        self.force += o.force;
        self.virial += o.virial;
        self.contacts += o.contacts;
        self.f_abs += o.f_abs;
        self
    }
}

/// Particles per chunk of the fused parallel passes (fixed: determinism).
const PASS_CHUNK: usize = 512;

/// Repulsive harmonic forces (as [`forces`]) in a cube of side `side`, fused with the sums
/// FIRE needs (power, norms, largest force, contact force and virial sums) per chunk.
fn forces_and_sums(spheres: Spheres, v: &[Vec3], f: &mut [Vec3]) -> ChunkSums {
    let lanes = lanes_available();
    let parts: Vec<ChunkSums> = f
        .par_chunks_mut(PASS_CHUNK)
        .enumerate()
        .map(|(c, fc)| {
            let mut s = ChunkSums::default();
            for (k, fi) in fc.iter_mut().enumerate() {
                let i = c * PASS_CHUNK + k;
                // The overlap and virial sums run on across the chunk's spheres.
                let pc = spheres.contacts(i, lanes, (s.force, s.virial));
                s.force = pc.overlap_sum;
                s.virial = pc.virial;
                s.contacts += u64::from(pc.contacts);
                s.overlap_max = s.overlap_max.max(pc.worst);
                let sum = pc.force;
                *fi = sum;
                let f2 = sum.norm_squared();
                s.power += sum.dot(&v[i]);
                s.f2 += f2;
                s.f_abs += f2.sqrt();
                s.v2 += v[i].norm_squared();
                s.f_max2 = s.f_max2.max(f2);
            }
            s
        })
        .collect();
    parts.iter().fold(ChunkSums::default(), |acc, p| acc.add(p))
}

/// Minimise the enthalpy H = ½ Σ max(0, R_i + R_j − |l|)² + P_t·V over the positions `x`
/// and the (cubic) cell side `side` (or the scale of the container of volume `side`³,
/// `domain`: its walls' overlaps join E, and their virial δ·d, d the centre's distance from
/// the wall, the pressure) with FIRE (Bitzek et al. 2006): the cell's log-strain
/// ε = ln L is one more degree of freedom with generalised force −∂H/∂ε = 3V(P − P_t)
/// (virial pressure P) and mass 2N, so the cell and the particles relax on the same time
/// scale. This is O'Hern et al. (2003)'s route to the jamming point, used by Kumar 2016
/// (Sec. 3: compression at a small controlled pressure): starting below jamming, the cell
/// shrinks until the spheres carry P_t, then stops at a force-balanced jammed state with
/// φ ≈ φ_J + P_t/(dP/dφ).
///
/// One iteration is two fused parallel passes over fixed-size chunks (velocity/position
/// update, forces with sums) with Verlet lists (skin 0.3 R̄) that stay valid under the
/// affine rescaling (rebuilt when 2·max displacement + |ΔL/L|·cutoff exceeds the skin), so
/// the result is the same bit for bit on any thread count.
/// `on_check` is called at the start, every 25 iterations and once at the end with the
/// iteration count, the residual max(|P − P_t|/(tol·P_t), balance measure / its bound)
/// (converged when ≤ 1), the pressure and the cell side. Positions are wrapped into
/// the cell on return.
pub(crate) fn fire_jam_at_pressure(
    x: &mut [Vec3],
    radii: &[f64],
    side: &mut f64,
    domain: Domain,
    target: &PressureTarget,
    on_check: &mut (dyn FnMut(&JamCheck) + Send),
) -> Result<PressureOutcome> {
    rayon::scope(|_| {
        let n = x.len();
        let r_max = largest_radius(radii);
        let cutoff = 2.0 * r_max + JAM_SKIN;
        if domain == Domain::Periodic && cutoff >= 0.49 * *side {
            return Err(cell_too_small(n, *side));
        }
        domain.wrap(x, *side)?;

        // Mass of the mass-weighted cell coordinate η = √M·ε.
        let mass = 2.0 * n as f64;
        let v = vec![Vec3::zeros(); n];
        let mut f = vec![Vec3::zeros(); n];
        let list = ScaledVerletList::build(x, radii, domain.cell(*side)?.as_ref(), JAM_SKIN)?;
        // Reference positions in units of the cell side (displacements exclude the affine part).
        let u_ref: Vec<Vec3> = x.iter().map(|p| p / *side).collect();
        let spheres = Spheres {
            list: &list,
            x,
            radii,
            side: *side,
            walls: domain.walls(*side),
        };
        let sums = forces_and_sums(spheres, &v, &mut f);
        let mut system = VariableCell {
            domain,
            side_ref: *side,
            x,
            radii,
            side,
            target,
            on_check,
            cutoff,
            sqrt_mass: mass.sqrt(),
            v,
            v_eta: 0.0,
            f,
            list,
            u_ref,
            sums,
            moved: vec![0.0f64; n.div_ceil(PASS_CHUNK)],
            f_eta: 0.0,
            pressure: 0.0,
            mean_unbalanced: 0.0,
            largest_unbalanced: 0.0,
        };
        let run = fire::minimise(&FIRE_VARIABLE_CELL, &mut system, target.max_iterations)?;
        let VariableCell {
            x,
            side,
            pressure,
            mean_unbalanced,
            largest_unbalanced,
            ..
        } = system;
        domain.wrap(x, *side)?;
        Ok(PressureOutcome {
            iterations: run.iterations,
            pressure,
            mean_unbalanced,
            largest_unbalanced,
            converged: run.converged,
        })
    })
}

/// Verlet skin of [`fire_jam_at_pressure`] (R̄).
const JAM_SKIN: f64 = 0.3;

fn cell_too_small(n: usize, side: f64) -> Error {
    Error::Invalid(format!(
        "packing preparation: {n} spheres give a periodic cell of side {side:.3} R̄, too \
         small for a unique minimum image (need more than 4.1·R_max); use more particles"
    ))
}

/// The enthalpy with the cell side as a degree of freedom, as the [`FireSystem`] of
/// [`fire_jam_at_pressure`].
struct VariableCell<'a> {
    domain: Domain,
    x: &'a mut [Vec3],
    radii: &'a [f64],
    side: &'a mut f64,
    target: &'a PressureTarget,
    on_check: &'a mut (dyn FnMut(&JamCheck) + Send),
    /// Neighbour cutoff 2·R_max + skin.
    cutoff: f64,
    /// √M of the cell coordinate η = √M·ε.
    sqrt_mass: f64,
    v: Vec<Vec3>,
    /// Velocity of η.
    v_eta: f64,
    f: Vec<Vec3>,
    list: ScaledVerletList,
    /// Cell side at the last Verlet-list build.
    side_ref: f64,
    /// Positions at the last build, in units of the cell side.
    u_ref: Vec<Vec3>,
    /// Sums of the last force pass.
    sums: ChunkSums,
    /// Largest displacement since the last build, per chunk.
    moved: Vec<f64>,
    /// Generalised force on η, −∂H/∂η = (3V(P − P_t))/√M, of the current state.
    f_eta: f64,
    pressure: f64,
    mean_unbalanced: f64,
    largest_unbalanced: f64,
}

impl FireSystem for VariableCell<'_> {
    /// Residual max(|P − P_t|/(tol·P_t), force-balance measure / its bound) ≤ 1; reports
    /// to `on_check` at the start, every 25 iterations and at the end.
    fn converged(&mut self, iterations: usize) -> bool {
        let (sums, side, target) = (&self.sums, *self.side, self.target);
        let n = self.x.len();
        let p_t = target.pressure;
        let volume = side * side * side;
        let pair_virial = 0.5 * sums.virial;
        self.pressure = pair_virial / (3.0 * volume);
        self.f_eta = (pair_virial - 3.0 * p_t * volume) / self.sqrt_mass;
        // Net forces against contact forces (both NaN, so the residual infinite, with no
        // contact).
        self.mean_unbalanced = (sums.f_abs / n as f64) / (sums.force / sums.contacts as f64);
        self.largest_unbalanced = sums.f_max2.sqrt() / sums.overlap_max;
        let residual = if sums.contacts == 0 {
            f64::INFINITY
        } else {
            let r_p = (self.pressure - p_t).abs() / (target.pressure_tolerance * p_t);
            let r_f = match target.force_balance {
                ForceBalance::Mean(ratio) => self.mean_unbalanced / ratio,
                ForceBalance::Largest(ratio) => self.largest_unbalanced / ratio,
            };
            r_p.max(r_f)
        };
        let check = JamCheck {
            iterations,
            residual,
            pressure: self.pressure,
            side,
        };
        if iterations.is_multiple_of(25) || residual <= 1.0 || iterations >= target.max_iterations {
            (self.on_check)(&check);
        }
        residual <= 1.0
    }

    fn power(&self) -> f64 {
        self.sums.power + self.f_eta * self.v_eta
    }

    /// Semi-implicit Euler of the particles and of η in one fused pass: the cell is rescaled
    /// affinely by exp(Δε) with the particles; the Verlet list is rebuilt when
    /// 2·max displacement + |ΔL/L|·cutoff exceeds the skin.
    fn advance(&mut self, step: &FireStep) -> Result<()> {
        let (dt, alpha, reset) = (step.dt, step.alpha, step.reset);
        let power = self.power();
        let f_eta = self.f_eta;
        let f2 = self.sums.f2 + f_eta * f_eta;
        let back = step.back();
        // |v|² after the kick, from the sums of the force pass: |v + Δt·F|².
        let v2_new = if reset {
            dt * dt * f2
        } else {
            (self.sums.v2 + self.v_eta * self.v_eta + 2.0 * dt * power + dt * dt * f2).max(0.0)
        };
        let mix = step.mix(v2_new.sqrt(), f2.sqrt());
        let eta_back = back * self.v_eta;
        if reset {
            self.v_eta = 0.0;
        }
        self.v_eta = (self.v_eta + dt * f_eta) * (1.0 - alpha) + mix * f_eta;
        let d_eps = (dt * self.v_eta - eta_back) / self.sqrt_mass;
        let scale = d_eps.exp();
        let new_side = *self.side * scale;
        if self.domain == Domain::Periodic && self.cutoff >= 0.49 * new_side {
            return Err(cell_too_small(self.x.len(), new_side));
        }
        *self.side = new_side;
        let u_ref = &self.u_ref;
        self.x
            .par_chunks_mut(PASS_CHUNK)
            .zip(self.v.par_chunks_mut(PASS_CHUNK))
            .zip(self.f.par_chunks(PASS_CHUNK))
            .zip(self.moved.par_iter_mut())
            .enumerate()
            .for_each(|(c, (((xc, vc), fc), mc))| {
                let mut worst = 0.0f64;
                for (k, ((xk, vk), fk)) in xc.iter_mut().zip(vc.iter_mut()).zip(fc).enumerate() {
                    if reset {
                        *xk -= *vk * back;
                        *vk = Vec3::zeros();
                    }
                    *vk = (*vk + fk * dt) * (1.0 - alpha) + fk * mix;
                    *xk = (*xk + *vk * dt) * scale;
                    let d = (*xk - u_ref[c * PASS_CHUNK + k] * new_side).norm_squared();
                    worst = worst.max(d);
                }
                *mc = worst.sqrt();
            });
        let moved_max = self.moved.iter().copied().fold(0.0, f64::max);
        let strain = (*self.side / self.side_ref - 1.0).abs();
        if 2.0 * moved_max + strain * self.cutoff > JAM_SKIN {
            let cell = self.domain.cell(*self.side)?;
            self.domain.wrap(self.x, *self.side)?;
            self.list = ScaledVerletList::build(self.x, self.radii, cell.as_ref(), JAM_SKIN)?;
            self.side_ref = *self.side;
            let s = *self.side;
            self.u_ref
                .iter_mut()
                .zip(self.x.iter())
                .for_each(|(u, p)| *u = p / s);
        }
        let spheres = Spheres {
            list: &self.list,
            x: self.x,
            radii: self.radii,
            side: *self.side,
            walls: self.domain.walls(*self.side),
        };
        self.sums = forces_and_sums(spheres, &self.v, &mut self.f);
        Ok(())
    }
}
