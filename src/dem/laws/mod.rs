//! Bond laws: one trait, one file per law.
//!
//! - [`yade::yade_cohesive_law`] — law (a), YADE 2023.02a's `Ig2_Sphere_Sphere_ScGeom6D`
//!   (`avoidGranularRatcheting=False`) + `Law2_ScGeom6D_CohFrictPhys_CohesionMoment` with
//!   unbreakable stress-free bonds (`unp` = initial penetration depth) and per-bond
//!   k_n, k_s, k_r, k_tw; bending/twisting from the particle orientations (total form).
//! - [`parallel_bond::parallel_bond_law`] — law (b), Potyondy–Cundall parallel bond
//!   (Truszkowska 2018 Eq. 3): incremental forces k̄_n·A, k̄_s·A and moments k̄_n·I, k̄_s·J.
//! - [`kumar::kumar_law`] — law (c), Kumar 2016 Eqs. 2–8 with R* = R_iR_j/(R_i+R_j), the
//!   resisting moments of Eqs. 7–8 and the viscous bond damping of Eqs. 5–6.
//! - [`lammps_bpm::lammps_bpm_law`] — law (d), LAMMPS's `bond_style bpm/rotational` (BPM
//!   package, 22 Jul 2025): total forces and torques from each bond's stored rest length and
//!   direction and the particles' quaternions (Mora & Wang 2009), optional damping.
//!
//! Laws (a)–(c) share the contact kinematics of YADE's ScGeom (contact point mid-gap, the
//! shear force rotated with the contact normal and the mean spin about it, relative
//! velocity at the contact point including the periodic image's velocity L·H_prev·c);
//! they differ in the springs and in how moments accumulate.

#[cfg(target_arch = "x86_64")]
pub(crate) mod bpm_bond;
pub(crate) mod bpm_lanes;
pub(crate) mod kumar;
pub(crate) mod lammps_bpm;
#[cfg(target_arch = "x86_64")]
pub(crate) mod lanes;
pub(crate) mod parallel_bond;
pub(crate) mod yade;

pub use kumar::{kumar_law, KUMAR_DAMPING};
pub use lammps_bpm::{lammps_bpm_law, BpmCoefficients, BpmNormalize, LammpsBpmLaw};
pub use parallel_bond::parallel_bond_law;
pub use yade::yade_cohesive_law;

use super::quat::{rotation_vector_of, Quat};
use super::state::{deterministic_sum, BondLoad, BondLoads, BondTopology, Particles};
use crate::strength::LocalLoads;
use crate::{Error, Mat3, Result, Vec3};
use rayon::prelude::*;

/// What a bond law sees at the force evaluation of a step.
pub struct BondContext<'a> {
    /// Particle state (positions at t, velocities at t − dt/2).
    pub particles: &'a Particles,
    /// Bond ends, periodic images.
    pub topology: &'a BondTopology,
    /// Current cell base vectors H (zero matrix for a non-periodic assembly).
    pub h: Mat3,
    /// L·H_prev: velocity of the periodic image one cell away (zero if not periodic).
    pub shift_velocity: Mat3,
    /// Time step (s).
    pub dt: f64,
    /// Whether the AVX2 kernels may be used ([`crate::dem::DemOptions::simd`]).
    pub simd: bool,
}

/// A bond law of the integrator.
pub trait BondLaw: Send + Sync {
    /// Short name (`yade`, `parallel-bond`, `kumar`).
    fn name(&self) -> &'static str;
    /// Record the reference (stress-free) state of every bond at the initial configuration.
    fn initialize(&mut self, ctx: &BondContext) -> Result<()>;
    /// Compute every bond's loads at the current state (parallel, deterministic).
    fn compute(&mut self, ctx: &BondContext, loads: &mut BondLoads);
    /// Elastic energy stored in the bonds (J), ½Σ(F_n²/k_n + |F_s|²/k_s + |M_b|²/k_r +
    /// |M_t|²/k_tw) as YADE's `totalElastEnergy`.
    fn elastic_energy(&self) -> f64;
    /// Energy dissipated by viscous bond damping so far (J).
    fn viscous_dissipation(&self) -> f64;
    /// Effective springs of bond `b`: (k_n, k_s, k_r, k_tw) — used for the critical time step.
    fn springs(&self, b: usize) -> (f64, f64, f64, f64);
    /// Viscous coefficients (η_n, η_t) of bond `b` (N·s/m), zero without bond damping.
    fn viscosity(&self, b: usize) -> (f64, f64);
    /// Normal force of bond `b` (N, compression positive as YADE) and its shear force
    /// vector (N, YADE's `shearForce`, acting on j).
    fn bond_forces(&self, b: usize) -> (f64, Vec3);
    /// [`BondLaw::bond_forces`] of bonds `first..first + normal.len()` as F_n into `normal`
    /// and |F_s|² into `shear_sq` (one dynamic call per chunk for the breakage test).
    fn bond_force_norms(&self, first: usize, normal: &mut [f64], shear_sq: &mut [f64]) {
        for (k, (n, s)) in normal.iter_mut().zip(shear_sq.iter_mut()).enumerate() {
            let (f_n, f_s) = self.bond_forces(first + k);
            *n = f_n;
            *s = f_s.norm_squared();
        }
    }
    /// Unit normal of bond `b` at the last evaluation, from i towards (the image of) j:
    /// with [`BondLaw::bond_forces`], the force on j is n·F_n + F_s (joints resolve it on
    /// their plane).
    fn bond_normal(&self, b: usize) -> Vec3;
    /// Bond `b`'s loads of the last evaluation in its own frame, as the failure criteria take
    /// them ([`LocalLoads`]: F_n compression positive, |F_s|, |M_b|, |M_t|). `particles` is
    /// the state that evaluation saw (laws whose moments are not stored recompute them from
    /// the orientations).
    fn local_loads(&self, particles: &Particles, b: usize) -> LocalLoads;
    /// [`BondLaw::local_loads`] of bonds `first..first + out.len()` (one dynamic call per
    /// chunk for the breakage test).
    fn local_loads_chunk(&self, particles: &Particles, first: usize, out: &mut [LocalLoads]) {
        for (k, l) in out.iter_mut().enumerate() {
            *l = self.local_loads(particles, first + k);
        }
    }
    /// LAMMPS bpm/rotational's elastic loads of bonds `first..first + out.len()` as
    /// [F_r, |F_s|², |τ_b|², |τ_t|²] (F_r tension positive), for the quick test of its
    /// breaking criterion without square roots or divisions; false (nothing written) for a
    /// law that does not keep them (the default).
    fn bpm_parts_chunk(&self, first: usize, out: &mut [[f64; 4]]) -> bool {
        let _ = (first, out);
        false
    }
    /// Break bond `b`: from now on it carries nothing (zero springs, state and damping, so
    /// every kernel, the AVX2 lanes included, gives it zero loads) and
    /// [`BondLaw::elastic_energy`] no longer counts it. Returns the elastic energy it held at
    /// the last evaluation (J); `particles` as for [`BondLaw::local_loads`]. The AVX2 kernels
    /// skip a broken bond from then on, so its [`BondLaw::bond_normal`] may stay that of its
    /// last evaluation intact.
    fn break_bond(&mut self, particles: &Particles, b: usize) -> f64;
    /// Boxed clone (element tests restart each path from the same initial law state).
    fn box_clone(&self) -> Box<dyn BondLaw>;
}

impl Clone for Box<dyn BondLaw> {
    fn clone(&self) -> Self {
        self.box_clone()
    }
}

/// How bending and twisting moments accumulate.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MomentForm {
    /// Total form from the orientations (YADE ScGeom6D `getBending`/`getTwist`): the
    /// relative rotation quaternion (q_i q_i0*)(q_j0 q_j*), split into twist about the
    /// current normal and bending across it.
    Orientation,
    /// Incremental form: rotate the moments with the contact, then subtract
    /// k·(ω_j − ω_i)·dt split along/across the normal (YADE `useIncrementalForm=True`).
    Incremental,
}

/// Viscous bond damping as fractions of critical (Kumar 2016 Eqs. 5–6):
/// η_n = 2ξ_n·√(m k_n), η_t = 2ξ_t·√(m k_s), with m = 2m_im_j/(m_i + m_j) (= the particle
/// mass of Eq. 6 for equal spheres).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ViscousDamping {
    /// ξ_n (Kumar: 0.05).
    pub normal: f64,
    /// ξ_t (Kumar: 0.025).
    pub tangential: f64,
}

/// Marks a bond whose j end is in the same cell image as i (no periodic shift).
const NO_IMAGE: u32 = u32::MAX;

/// Bonds per parallel work item: large enough that rayon's per-item cost (~µs) is small
/// against the work (~0.1 µs per bond), small enough to balance two threads. A fixed
/// number, so per-chunk partial sums are the same on any thread count.
pub(crate) const BOND_CHUNK: usize = 1024;

/// Per-bond data read every step (56 bytes): ends, periodic image slot, springs and the
/// stress-free penetration depth.
#[derive(Clone, Copy, Debug, Default)]
struct BondHot {
    i: u32,
    j: u32,
    /// Index into `LinearBondKernel::images`, or [`NO_IMAGE`].
    image: u32,
    /// Broken ([`BondLaw::break_bond`]): zero springs, so zero loads and energy; the AVX2
    /// chunk skips it (in the padding after `image`: the record stays 56 bytes).
    broken: bool,
    kn: f64,
    ks: f64,
    kr: f64,
    ktw: f64,
    /// Initial penetration depth δ₀ (YADE `unp`).
    unp: f64,
}

/// Per-bond state carried from step to step (56 bytes).
#[derive(Clone, Copy, Debug, Default)]
struct BondDyn {
    /// Contact normal of the last evaluation (ScGeom `normal`, needed for the rotation of
    /// the shear force).
    normal: Vec3,
    /// Shear force (YADE `shearForce`, acting on j).
    shear_force: Vec3,
    /// Normal force (compression positive).
    normal_force: f64,
}

/// Bending and twisting moments of the last evaluation (state of the incremental form,
/// kept for the elastic energy in the orientation form).
#[derive(Clone, Copy, Debug, Default)]
struct BondMoments {
    bending: Vec3,
    twist: Vec3,
}

/// The shared linear bond kernel behind laws (a)–(c): springs per bond, YADE ScGeom
/// kinematics, total or incremental moments, optional viscous bond damping.
///
/// Data are split hot/cold: what every step reads lives in compact per-bond records, the
/// rarely needed parts (periodic images, reference orientations other than the identity,
/// viscous coefficients) in side tables that are empty when unused.
#[derive(Clone, Debug)]
pub struct LinearBondKernel {
    name: &'static str,
    moments: MomentForm,
    viscous: Option<ViscousDamping>,
    hot: Vec<BondHot>,
    dyn_state: Vec<BondDyn>,
    moment_state: Vec<BondMoments>,
    /// Cell distance of j's image for the bonds crossing the cell boundary.
    images: Vec<Vec3>,
    /// Reference orientations (q_i0, q_j0) when any differs from the identity; empty when
    /// all are the identity (then (q_i q_i0*)(q_j0 q_j*) = q_i q_j* exactly).
    ori_ref: Vec<[Quat; 2]>,
    /// Viscous coefficients (η_n, η_t) per bond; empty without bond damping.
    eta: Vec<[f64; 2]>,
    /// (viscous dissipation power, moment elastic energy) per bond chunk of the last
    /// evaluation (fixed chunks, summed in order).
    chunk_sums: Vec<[f64; 2]>,
    dissipated: f64,
    /// 1 + the largest particle index of any bond (usize::MAX before `initialize`): one comparison
    /// per step bounds-checks every bond for the unchecked reads of the AVX2 kernel. Image
    /// indices are in bounds by construction (`initialize` pushes each image and stores its
    /// index; nothing else writes either).
    index_bound: usize,
}

impl LinearBondKernel {
    /// A kernel with per-bond springs (N/m, N·m/rad); errors if lengths differ or a spring is
    /// negative / not finite.
    pub fn new(
        name: &'static str,
        springs: [&[f64]; 4],
        moments: MomentForm,
        viscous: Option<ViscousDamping>,
    ) -> Result<Self> {
        let n = springs[0].len();
        if springs.iter().any(|s| s.len() != n) {
            return Err(Error::Invalid(format!(
                "bond law `{name}`: spring arrays of different lengths ({}, {}, {}, {})",
                springs[0].len(),
                springs[1].len(),
                springs[2].len(),
                springs[3].len()
            )));
        }
        let names = ["kn", "ks", "kr", "ktw"];
        for (s, nm) in springs.iter().zip(names) {
            if let Some((b, v)) = s
                .iter()
                .enumerate()
                .find(|(_, v)| !(v.is_finite() && **v >= 0.0))
            {
                return Err(Error::Invalid(format!(
                    "bond law `{name}`: bond {b} has {nm} = {v}; expected a finite value ≥ 0"
                )));
            }
        }
        if let Some(v) = viscous {
            for (what, x) in [("normal", v.normal), ("tangential", v.tangential)] {
                if !(x.is_finite() && x >= 0.0) {
                    return Err(Error::Invalid(format!(
                        "bond law `{name}`: {what} damping fraction must be finite and ≥ 0, got {x}"
                    )));
                }
            }
        }
        let hot = (0..n)
            .map(|b| BondHot {
                kn: springs[0][b],
                ks: springs[1][b],
                kr: springs[2][b],
                ktw: springs[3][b],
                image: NO_IMAGE,
                ..Default::default()
            })
            .collect();
        Ok(LinearBondKernel {
            name,
            moments,
            viscous,
            hot,
            dyn_state: vec![BondDyn::default(); n],
            moment_state: if moments == MomentForm::Orientation {
                Vec::new()
            } else {
                vec![BondMoments::default(); n]
            },
            images: Vec::new(),
            ori_ref: Vec::new(),
            eta: Vec::new(),
            chunk_sums: vec![[0.0; 2]; n.div_ceil(BOND_CHUNK)],
            dissipated: 0.0,
            // Not initialised: the checked scalar kernel until `initialize`.
            index_bound: if n == 0 { 0 } else { usize::MAX },
        })
    }

    fn check_len(&self, topo: &BondTopology) -> Result<()> {
        if topo.len() != self.hot.len() {
            return Err(Error::Invalid(format!(
                "bond law `{}` has springs for {} bonds but the assembly has {}",
                self.name,
                self.hot.len(),
                topo.len()
            )));
        }
        Ok(())
    }
}

/// Current geometry of bond b: (normal, centre distance, penetration depth, contact point,
/// position of the image of j).
#[inline(always)]
fn geometry(
    p: &Particles,
    i: usize,
    j: usize,
    shift: Option<Vec3>,
) -> (Vec3, f64, f64, Vec3, Vec3) {
    let xi = p.position[i];
    let xj = match shift {
        Some(s) => p.position[j] + s,
        None => p.position[j],
    };
    let mut n = xj - xi;
    let d = n.norm();
    // One division, three products (the AVX2 lanes do the same).
    n *= 1.0 / d;
    let (ri, rj) = (p.radius[i], p.radius[j]);
    let pd = ri + rj - d;
    let cp = xi + n * (ri - 0.5 * pd);
    (n, d, pd, cp, xj)
}

/// What the bond loop needs besides the per-bond records.
struct KernelInputs<'a> {
    particles: &'a Particles,
    h: Mat3,
    shift_velocity: Mat3,
    dt: f64,
    images: &'a [Vec3],
    ori_ref: &'a [[Quat; 2]],
    eta: &'a [[f64; 2]],
    /// See `LinearBondKernel::index_bound`.
    index_bound: usize,
    /// The AVX2 lanes may be used.
    simd: bool,
}

/// One bond: YADE's ScGeom6D kinematics and the cohesive law (see the module docs);
/// `ORIENTATION` selects the total (orientation) or incremental moments, `REF` the
/// reference orientations other than the identity, `VISCOUS` the bond damping. Returns the
/// viscous dissipation power and, in the orientation form (whose moments are not kept), the
/// elastic energy of the moments ½|M_b|²/k_r + ½|M_t|²/k_tw. Every expression keeps the operation order of YADE's
/// formulas (law (a) is checked against YADE to rounding).
#[inline(always)]
fn bond_kernel<const ORIENTATION: bool, const REF: bool, const VISCOUS: bool>(
    inp: &KernelInputs,
    b: usize,
    c: &BondHot,
    st: &mut BondDyn,
    mom: &mut BondMoments,
    out: &mut BondLoad,
) -> [f64; 2] {
    let p = inp.particles;
    let dt = inp.dt;
    let (i, j) = (c.i as usize, c.j as usize);
    let cell_dist = if c.image == NO_IMAGE {
        None
    } else {
        Some(inp.images[c.image as usize])
    };
    let (n, _d, pd, cp, xj) = geometry(p, i, j, cell_dist.map(|cd| inp.h * cd));
    let xi = p.position[i];
    let (wi, wj) = (p.angular_velocity[i], p.angular_velocity[j]);
    // ScGeom::precompute: rotation of the contact since the last step.
    let n_old = st.normal;
    let orthonormal_axis = n_old.cross(&n);
    let twist_angle = dt * 0.5 * n_old.dot(&(wi + wj));
    let twist_axis = n_old * twist_angle;
    st.normal = n;
    // Relative velocity at the contact point (j relative to i), with the velocity of j's
    // periodic image.
    let c1x = cp - xi;
    let c2x = cp - xj;
    let mut rel_vel = (p.velocity[j] + wj.cross(&c2x)) - (p.velocity[i] + wi.cross(&c1x));
    if let Some(cd) = cell_dist {
        rel_vel += inp.shift_velocity * cd;
    }
    let rel_vel_t = rel_vel - n * n.dot(&rel_vel);
    let shear_inc = rel_vel_t * dt;
    // Rotate the shear force (and incremental moments) with the contact.
    let rotate = |v: &mut Vec3| {
        *v -= v.cross(&orthonormal_axis);
        *v -= v.cross(&twist_axis);
    };
    rotate(&mut st.shear_force);
    if !ORIENTATION {
        if c.kr > 0.0 {
            rotate(&mut mom.bending);
        }
        if c.ktw > 0.0 {
            rotate(&mut mom.twist);
        }
    }
    // Normal (compression positive) and incremental shear.
    let fn_ = c.kn * (pd - c.unp);
    st.normal_force = fn_;
    st.shear_force -= shear_inc * c.ks;
    // Moments.
    let moment_elastic = if ORIENTATION {
        orientation_moments::<REF>(inp, b, c, n, mom)
    } else {
        incremental_moments(c, n, wj - wi, dt, mom);
        0.0
    };
    // Force on i (YADE applies −normalForce − shearForce to body 1).
    let mut force = -(n * fn_) - st.shear_force;
    let mut power = 0.0;
    if VISCOUS {
        let [eta_n, eta_t] = inp.eta[b];
        if eta_n > 0.0 || eta_t > 0.0 {
            let vn = n.dot(&rel_vel);
            force += n * (eta_n * vn) + rel_vel_t * eta_t;
            power = eta_n * vn * vn + eta_t * rel_vel_t.norm_squared();
        }
    }
    let moment = mom.twist + mom.bending;
    out.force_i = force;
    out.torque_i = c1x.cross(&force) - moment;
    out.torque_j = -c2x.cross(&force) + moment;
    [power, moment_elastic]
}

/// The orientation form's moments (YADE's `CohFrictPhys` with total moments): from the
/// rotation vector of q_i q_j* (relative to the reference orientations if `REF`), split
/// into twist about `n` and bending, M_t = k_tw θ_t n, M_b = k_r θ_b. Returns their elastic
/// energy ½k_r|θ_b|² + ½k_tw θ_t² (= ½|M_b|²/k_r + ½|M_t|²/k_tw, without the divisions).
#[inline(always)]
fn orientation_moments<const REF: bool>(
    inp: &KernelInputs,
    b: usize,
    c: &BondHot,
    n: Vec3,
    mom: &mut BondMoments,
) -> f64 {
    let mut moment_elastic = 0.0;
    if c.kr > 0.0 || c.ktw > 0.0 {
        let p = inp.particles;
        let (i, j) = (c.i as usize, c.j as usize);
        let (qi, qj) = (p.orientation[i], p.orientation[j]);
        let delta = if REF {
            let [qi0, qj0] = inp.ori_ref[b];
            qi.mul(&qi0.conjugate()).mul(&qj0.mul(&qj.conjugate()))
        } else {
            qi.mul(&qj.conjugate())
        };
        // Rotation vector of q_i q_j* (YADE: normalise, AngleAxis; angle in [0, π]).
        let rotation = rotation_vector_of(&delta);
        let twist = rotation.dot(&n);
        let bending = rotation - n * twist;
        if c.kr > 0.0 {
            moment_elastic += 0.5 * c.kr * bending.norm_squared();
        }
        if c.ktw > 0.0 {
            moment_elastic += 0.5 * c.ktw * (twist * twist);
        }
        mom.twist = if c.ktw > 0.0 {
            n * (twist * c.ktw)
        } else {
            Vec3::zeros()
        };
        mom.bending = if c.kr > 0.0 {
            bending * c.kr
        } else {
            Vec3::zeros()
        };
    }
    moment_elastic
}

/// The orientation form's moment vectors (M_b, M_t) of bond `b` at the orientations of
/// `p` and the normal `n`: the operations of [`orientation_moments`] (which the AVX2 lanes
/// repeat), for a bond whose moments are not kept; also their elastic energy.
fn orientation_moment_vectors(
    p: &Particles,
    ori_ref: &[[Quat; 2]],
    b: usize,
    c: &BondHot,
    n: Vec3,
) -> (BondMoments, f64) {
    let mut mom = BondMoments::default();
    if !(c.kr > 0.0 || c.ktw > 0.0) {
        return (mom, 0.0);
    }
    let (i, j) = (c.i as usize, c.j as usize);
    let (qi, qj) = (p.orientation[i], p.orientation[j]);
    let delta = match ori_ref.get(b) {
        Some([qi0, qj0]) => qi.mul(&qi0.conjugate()).mul(&qj0.mul(&qj.conjugate())),
        None => qi.mul(&qj.conjugate()),
    };
    let rotation = rotation_vector_of(&delta);
    let twist = rotation.dot(&n);
    let bending = rotation - n * twist;
    let mut energy = 0.0;
    if c.kr > 0.0 {
        energy += 0.5 * c.kr * bending.norm_squared();
        mom.bending = bending * c.kr;
    }
    if c.ktw > 0.0 {
        energy += 0.5 * c.ktw * (twist * twist);
        mom.twist = n * (twist * c.ktw);
    }
    (mom, energy)
}

/// The incremental form's moments (YADE's `Law2_ScGeom6D_CohFrictPhys_CohesionMoment`):
/// the relative angular velocity `rel_ang` = ω_j − ω_i split into bending and twist about
/// `n`, each integrated over `dt` with its stiffness (M −= k·Δθ); a zero stiffness zeroes
/// its moment.
#[inline(always)]
fn incremental_moments(c: &BondHot, n: Vec3, rel_ang: Vec3, dt: f64, mom: &mut BondMoments) {
    if c.kr > 0.0 {
        let bend = rel_ang - n * n.dot(&rel_ang);
        mom.bending -= bend * c.kr * dt;
    } else {
        mom.bending = Vec3::zeros();
    }
    if c.ktw > 0.0 {
        let tw = n * n.dot(&rel_ang);
        mom.twist -= tw * dt * c.ktw;
    } else {
        mom.twist = Vec3::zeros();
    }
}

/// ½|M_b|²/k_r + ½|M_t|²/k_tw of one bond (J), YADE's `totalElastEnergy` moment terms.
#[inline(always)]
fn moment_energy(c: &BondHot, mom: &BondMoments) -> f64 {
    let mut e = 0.0;
    if c.kr > 0.0 {
        e += 0.5 * mom.bending.norm_squared() / c.kr;
    }
    if c.ktw > 0.0 {
        e += 0.5 * mom.twist.norm_squared() / c.ktw;
    }
    e
}

/// The bond loop over fixed chunks of [`BOND_CHUNK`] bonds; each chunk's (dissipation
/// power, moment energy) goes to its slot of `sums` (summed in order by the caller).
/// `moment_state` is empty in the orientation form (its moments are recomputed each step).
fn bond_loop<const ORIENTATION: bool, const REF: bool, const VISCOUS: bool>(
    inp: &KernelInputs,
    hot: &[BondHot],
    dyn_state: &mut [BondDyn],
    moment_state: &mut [BondMoments],
    loads: &mut [BondLoad],
    sums: &mut [[f64; 2]],
) {
    let work = |chunk: usize,
                hot: &[BondHot],
                st: &mut [BondDyn],
                mut mom: Option<&mut [BondMoments]>,
                out: &mut [BondLoad],
                slot: &mut [f64; 2]| {
        let base = chunk * BOND_CHUNK;
        #[cfg(target_arch = "x86_64")]
        if ORIENTATION && !REF && !VISCOUS {
            *slot = [0.0, lanes::law_a_chunk(inp, base, hot, st, out)];
            return;
        }
        let mut sum = [0.0, 0.0];
        let mut scratch;
        for k in 0..hot.len() {
            let m = match mom.as_deref_mut() {
                Some(m) => &mut m[k],
                None => {
                    scratch = BondMoments::default();
                    &mut scratch
                }
            };
            let [p, e] = bond_kernel::<ORIENTATION, REF, VISCOUS>(
                inp,
                base + k,
                &hot[k],
                &mut st[k],
                m,
                &mut out[k],
            );
            sum[0] += p;
            sum[1] += e;
        }
        *slot = sum;
    };
    if ORIENTATION {
        (
            hot.par_chunks(BOND_CHUNK),
            dyn_state.par_chunks_mut(BOND_CHUNK),
            loads.par_chunks_mut(BOND_CHUNK),
            sums.par_iter_mut(),
        )
            .into_par_iter()
            .enumerate()
            .for_each(|(chunk, (hot, st, out, slot))| work(chunk, hot, st, None, out, slot));
    } else {
        (
            hot.par_chunks(BOND_CHUNK),
            dyn_state.par_chunks_mut(BOND_CHUNK),
            moment_state.par_chunks_mut(BOND_CHUNK),
            loads.par_chunks_mut(BOND_CHUNK),
            sums.par_iter_mut(),
        )
            .into_par_iter()
            .enumerate()
            .for_each(|(chunk, (hot, st, mom, out, slot))| {
                work(chunk, hot, st, Some(mom), out, slot)
            });
    }
}

impl BondLaw for LinearBondKernel {
    fn name(&self) -> &'static str {
        self.name
    }

    fn initialize(&mut self, ctx: &BondContext) -> Result<()> {
        self.check_len(ctx.topology)?;
        let p = ctx.particles;
        let topo = ctx.topology;
        let viscous = self.viscous;
        self.images.clear();
        self.eta.clear();
        let mut ori_ref = Vec::with_capacity(self.hot.len());
        for b in 0..self.hot.len() {
            let (i, j) = (topo.i[b] as usize, topo.j[b] as usize);
            let cd = topo.cell_dist[b];
            let (n, d, pd, _, _) = geometry(p, i, j, Some(ctx.h * cd));
            if !(d > 0.0 && d.is_finite()) {
                return Err(Error::Invalid(format!(
                    "bond {b}: its two particles coincide (centre distance {d})"
                )));
            }
            let c = &mut self.hot[b];
            c.i = topo.i[b];
            c.j = topo.j[b];
            c.image = if cd == Vec3::zeros() {
                NO_IMAGE
            } else {
                self.images.push(cd);
                (self.images.len() - 1) as u32
            };
            c.unp = pd;
            ori_ref.push([p.orientation[i], p.orientation[j]]);
            if let Some(v) = viscous {
                let m = 2.0 * p.mass[i] * p.mass[j] / (p.mass[i] + p.mass[j]);
                self.eta.push([
                    2.0 * v.normal * (m * c.kn).sqrt(),
                    2.0 * v.tangential * (m * c.ks).sqrt(),
                ]);
            }
            self.dyn_state[b] = BondDyn {
                normal: n,
                ..Default::default()
            };
            if let Some(m) = self.moment_state.get_mut(b) {
                *m = BondMoments::default();
            }
        }
        let identity = Quat::identity();
        self.ori_ref = if ori_ref.iter().all(|q| q[0] == identity && q[1] == identity) {
            Vec::new()
        } else {
            ori_ref
        };
        self.dissipated = 0.0;
        self.chunk_sums.iter_mut().for_each(|s| *s = [0.0; 2]);
        self.index_bound = self
            .hot
            .iter()
            .map(|c| c.i.max(c.j) as usize + 1)
            .max()
            .unwrap_or(0);
        Ok(())
    }

    fn compute(&mut self, ctx: &BondContext, loads: &mut BondLoads) {
        let inp = KernelInputs {
            particles: ctx.particles,
            h: ctx.h,
            shift_velocity: ctx.shift_velocity,
            dt: ctx.dt,
            images: &self.images,
            ori_ref: &self.ori_ref,
            eta: &self.eta,
            index_bound: self.index_bound,
            simd: ctx.simd,
        };
        let orientation = self.moments == MomentForm::Orientation;
        let with_ref = !self.ori_ref.is_empty();
        let viscous = !self.eta.is_empty();
        let args = (
            &self.hot[..],
            &mut self.dyn_state[..],
            &mut self.moment_state[..],
            &mut loads.per_bond[..],
            &mut self.chunk_sums[..],
        );
        let (h, s, m, l, pw) = args;
        match (orientation, with_ref, viscous) {
            (true, false, false) => bond_loop::<true, false, false>(&inp, h, s, m, l, pw),
            (true, false, true) => bond_loop::<true, false, true>(&inp, h, s, m, l, pw),
            (true, true, false) => bond_loop::<true, true, false>(&inp, h, s, m, l, pw),
            (true, true, true) => bond_loop::<true, true, true>(&inp, h, s, m, l, pw),
            (false, _, false) => bond_loop::<false, false, false>(&inp, h, s, m, l, pw),
            (false, _, true) => bond_loop::<false, false, true>(&inp, h, s, m, l, pw),
        }
        if viscous {
            self.dissipated += ctx.dt * self.chunk_sums.iter().map(|s| s[0]).sum::<f64>();
        }
    }

    fn elastic_energy(&self) -> f64 {
        let (c, s, m) = (&self.hot, &self.dyn_state, &self.moment_state);
        let forces_and_kept_moments = deterministic_sum(c.len(), |b| {
            let (c, s) = (&c[b], &s[b]);
            let mut e = 0.0;
            if c.kn > 0.0 {
                e += 0.5 * s.normal_force * s.normal_force / c.kn;
            }
            if c.ks > 0.0 {
                e += 0.5 * s.shear_force.norm_squared() / c.ks;
            }
            if let Some(m) = m.get(b) {
                e += moment_energy(c, m);
            }
            e
        });
        // Orientation form: the moment energies were summed per chunk by the bond loop.
        let recomputed_moments = if self.moments == MomentForm::Orientation {
            self.chunk_sums.iter().map(|s| s[1]).sum::<f64>()
        } else {
            0.0
        };
        forces_and_kept_moments + recomputed_moments
    }

    fn viscous_dissipation(&self) -> f64 {
        self.dissipated
    }

    fn springs(&self, b: usize) -> (f64, f64, f64, f64) {
        let c = &self.hot[b];
        (c.kn, c.ks, c.kr, c.ktw)
    }

    fn viscosity(&self, b: usize) -> (f64, f64) {
        match self.eta.get(b) {
            Some(&[n, t]) => (n, t),
            None => (0.0, 0.0),
        }
    }

    fn bond_forces(&self, b: usize) -> (f64, Vec3) {
        (
            self.dyn_state[b].normal_force,
            self.dyn_state[b].shear_force,
        )
    }

    fn bond_force_norms(&self, first: usize, normal: &mut [f64], shear_sq: &mut [f64]) {
        let states = &self.dyn_state[first..first + normal.len()];
        for ((n, s), d) in normal.iter_mut().zip(shear_sq.iter_mut()).zip(states) {
            *n = d.normal_force;
            *s = d.shear_force.norm_squared();
        }
    }

    fn bond_normal(&self, b: usize) -> Vec3 {
        self.dyn_state[b].normal
    }

    fn local_loads(&self, particles: &Particles, b: usize) -> LocalLoads {
        let s = &self.dyn_state[b];
        let mom = match self.moment_state.get(b) {
            Some(m) => *m,
            None => {
                orientation_moment_vectors(particles, &self.ori_ref, b, &self.hot[b], s.normal).0
            }
        };
        LocalLoads::from_vectors(s.normal_force, &s.shear_force, &mom.bending, &mom.twist)
    }

    fn break_bond(&mut self, particles: &Particles, b: usize) -> f64 {
        let c = self.hot[b];
        let s = self.dyn_state[b];
        let mut energy = 0.0;
        if c.kn > 0.0 {
            energy += 0.5 * s.normal_force * s.normal_force / c.kn;
        }
        if c.ks > 0.0 {
            energy += 0.5 * s.shear_force.norm_squared() / c.ks;
        }
        match self.moment_state.get_mut(b) {
            Some(m) => {
                energy += moment_energy(&c, m);
                *m = BondMoments::default();
            }
            None => {
                // Orientation form: the bond loop summed this bond's moment energy into its
                // chunk; take it out so that elastic_energy no longer counts it.
                let (_, e) = orientation_moment_vectors(particles, &self.ori_ref, b, &c, s.normal);
                energy += e;
                if let Some(sum) = self.chunk_sums.get_mut(b / BOND_CHUNK) {
                    sum[1] -= e;
                }
            }
        }
        let h = &mut self.hot[b];
        (h.kn, h.ks, h.kr, h.ktw) = (0.0, 0.0, 0.0, 0.0);
        h.broken = true;
        let st = &mut self.dyn_state[b];
        st.normal_force = 0.0;
        st.shear_force = Vec3::zeros();
        if let Some(e) = self.eta.get_mut(b) {
            *e = [0.0, 0.0];
        }
        energy
    }

    fn box_clone(&self) -> Box<dyn BondLaw> {
        Box::new(self.clone())
    }
}
