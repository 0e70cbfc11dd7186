//! Bond laws: one trait, one file per law.
//!
//! - [`yade::YadeCohesiveLaw`] — law (a), YADE 2023.02a's `Ig2_Sphere_Sphere_ScGeom6D`
//!   (`avoidGranularRatcheting=False`) + `Law2_ScGeom6D_CohFrictPhys_CohesionMoment` with
//!   unbreakable stress-free bonds (`unp` = initial penetration depth) and per-bond
//!   k_n, k_s, k_r, k_tw; bending/twisting from the particle orientations (total form).
//! - [`parallel_bond::ParallelBondLaw`] — law (b), Potyondy–Cundall parallel bond
//!   (Truszkowska 2018 Eq. 3): incremental forces k̄_n·A, k̄_s·A and moments k̄_n·I, k̄_s·J.
//! - [`kumar::KumarLaw`] — law (c), Kumar 2016 Eqs. 2–8 with R* = R_iR_j/(R_i+R_j), the
//!   resisting moments of Eqs. 7–8 and the viscous bond damping of Eqs. 5–6.
//!
//! All three share the contact kinematics of YADE's ScGeom (contact point mid-gap, the
//! shear force rotated with the contact normal and the mean spin about it, relative
//! velocity at the contact point including the periodic image's velocity L·H_prev·c);
//! they differ in the springs and in how moments accumulate.

pub mod kumar;
pub mod parallel_bond;
pub mod yade;

use super::quat::Quat;
use super::state::{deterministic_sum, BondLoads, BondTopology, Particles};
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

#[derive(Clone, Copy, Debug, Default)]
struct BondConst {
    kn: f64,
    ks: f64,
    kr: f64,
    ktw: f64,
    eta_n: f64,
    eta_t: f64,
    unp: f64,
    ori_i0: Quat,
    ori_j0: Quat,
}

#[derive(Clone, Copy, Debug, Default)]
struct BondDyn {
    normal: Vec3,
    shear_force: Vec3,
    moment_bending: Vec3,
    moment_twist: Vec3,
    normal_force: f64,
    dissipation_power: f64,
}

/// The shared linear bond kernel behind the three laws: springs per bond, YADE ScGeom
/// kinematics, total or incremental moments, optional viscous bond damping.
#[derive(Clone, Debug)]
pub struct LinearBondKernel {
    name: &'static str,
    moments: MomentForm,
    viscous: Option<ViscousDamping>,
    consts: Vec<BondConst>,
    dyn_state: Vec<BondDyn>,
    dissipated: f64,
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
        let consts = (0..n)
            .map(|b| BondConst {
                kn: springs[0][b],
                ks: springs[1][b],
                kr: springs[2][b],
                ktw: springs[3][b],
                ..Default::default()
            })
            .collect();
        Ok(LinearBondKernel {
            name,
            moments,
            viscous,
            consts,
            dyn_state: vec![BondDyn::default(); n],
            dissipated: 0.0,
        })
    }

    fn check_len(&self, topo: &BondTopology) -> Result<()> {
        if topo.len() != self.consts.len() {
            return Err(Error::Invalid(format!(
                "bond law `{}` has springs for {} bonds but the assembly has {}",
                self.name,
                self.consts.len(),
                topo.len()
            )));
        }
        Ok(())
    }
}

/// Current geometry of bond b: (normal, centre distance, penetration depth, contact point,
/// position of the image of j).
#[inline]
fn geometry(ctx: &BondContext, b: usize) -> (Vec3, f64, f64, Vec3, Vec3) {
    let p = ctx.particles;
    let (i, j) = (ctx.topology.i[b] as usize, ctx.topology.j[b] as usize);
    let shift2 = ctx.h * ctx.topology.cell_dist[b];
    let xi = p.position[i];
    let xj = p.position[j] + shift2;
    let mut n = xj - xi;
    let d = n.norm();
    n /= d;
    let (ri, rj) = (p.radius[i], p.radius[j]);
    let pd = ri + rj - d;
    let cp = xi + n * (ri - 0.5 * pd);
    (n, d, pd, cp, xj)
}

impl BondLaw for LinearBondKernel {
    fn name(&self) -> &'static str {
        self.name
    }

    fn initialize(&mut self, ctx: &BondContext) -> Result<()> {
        self.check_len(ctx.topology)?;
        let p = ctx.particles;
        let viscous = self.viscous;
        for b in 0..self.consts.len() {
            let (n, d, pd, _, _) = geometry(ctx, b);
            if !(d > 0.0 && d.is_finite()) {
                return Err(Error::Invalid(format!(
                    "bond {b}: its two particles coincide (centre distance {d})"
                )));
            }
            let (i, j) = (ctx.topology.i[b] as usize, ctx.topology.j[b] as usize);
            let c = &mut self.consts[b];
            c.unp = pd;
            c.ori_i0 = p.orientation[i];
            c.ori_j0 = p.orientation[j];
            if let Some(v) = viscous {
                let m = 2.0 * p.mass[i] * p.mass[j] / (p.mass[i] + p.mass[j]);
                c.eta_n = 2.0 * v.normal * (m * c.kn).sqrt();
                c.eta_t = 2.0 * v.tangential * (m * c.ks).sqrt();
            }
            self.dyn_state[b] = BondDyn {
                normal: n,
                ..Default::default()
            };
        }
        self.dissipated = 0.0;
        Ok(())
    }

    fn compute(&mut self, ctx: &BondContext, loads: &mut BondLoads) {
        let dt = ctx.dt;
        let moments = self.moments;
        let p = ctx.particles;
        let consts = &self.consts;
        (
            self.dyn_state.par_iter_mut(),
            loads.force_i.par_iter_mut(),
            loads.torque_i.par_iter_mut(),
            loads.torque_j.par_iter_mut(),
        )
            .into_par_iter()
            .enumerate()
            .with_min_len(512)
            .for_each(|(b, (st, f_out, ti_out, tj_out))| {
                let c = &consts[b];
                let (i, j) = (ctx.topology.i[b] as usize, ctx.topology.j[b] as usize);
                let (n, _d, pd, cp, xj) = geometry(ctx, b);
                let xi = p.position[i];
                let (wi, wj) = (p.angular_velocity[i], p.angular_velocity[j]);
                // ScGeom::precompute: rotation of the contact since the last step.
                let n_old = st.normal;
                let orthonormal_axis = n_old.cross(&n);
                let twist_angle = dt * 0.5 * n_old.dot(&(wi + wj));
                let twist_axis = n_old * twist_angle;
                st.normal = n;
                // Relative velocity at the contact point (j relative to i), with the
                // velocity of j's periodic image.
                let c1x = cp - xi;
                let c2x = cp - xj;
                let mut rel_vel =
                    (p.velocity[j] + wj.cross(&c2x)) - (p.velocity[i] + wi.cross(&c1x));
                rel_vel += ctx.shift_velocity * ctx.topology.cell_dist[b];
                let rel_vel_t = rel_vel - n * n.dot(&rel_vel);
                let shear_inc = rel_vel_t * dt;
                // Rotate the shear force (and incremental moments) with the contact.
                let rotate = |v: &mut Vec3| {
                    *v -= v.cross(&orthonormal_axis);
                    *v -= v.cross(&twist_axis);
                };
                rotate(&mut st.shear_force);
                if moments == MomentForm::Incremental {
                    if c.kr > 0.0 {
                        rotate(&mut st.moment_bending);
                    }
                    if c.ktw > 0.0 {
                        rotate(&mut st.moment_twist);
                    }
                }
                // Normal (compression positive) and incremental shear.
                let fn_ = c.kn * (pd - c.unp);
                st.normal_force = fn_;
                st.shear_force -= shear_inc * c.ks;
                // Moments.
                match moments {
                    MomentForm::Orientation => {
                        if c.kr > 0.0 || c.ktw > 0.0 {
                            let mut delta = p.orientation[i]
                                .mul(&c.ori_i0.conjugate())
                                .mul(&c.ori_j0.mul(&p.orientation[j].conjugate()));
                            delta.normalize();
                            let (mut angle, axis) = delta.to_angle_axis();
                            if angle.is_nan() {
                                angle = 0.0;
                            }
                            if angle > std::f64::consts::PI {
                                angle -= 2.0 * std::f64::consts::PI;
                            }
                            let twist = angle * axis.dot(&n);
                            let bending = axis * angle - n * twist;
                            st.moment_twist = if c.ktw > 0.0 {
                                n * (twist * c.ktw)
                            } else {
                                Vec3::zeros()
                            };
                            st.moment_bending = if c.kr > 0.0 {
                                bending * c.kr
                            } else {
                                Vec3::zeros()
                            };
                        }
                    }
                    MomentForm::Incremental => {
                        let rel_ang = wj - wi;
                        if c.kr > 0.0 {
                            let bend = rel_ang - n * n.dot(&rel_ang);
                            st.moment_bending -= bend * c.kr * dt;
                        } else {
                            st.moment_bending = Vec3::zeros();
                        }
                        if c.ktw > 0.0 {
                            let tw = n * n.dot(&rel_ang);
                            st.moment_twist -= tw * dt * c.ktw;
                        } else {
                            st.moment_twist = Vec3::zeros();
                        }
                    }
                }
                // Force on i (YADE applies −normalForce − shearForce to body 1).
                let mut force = -(n * fn_) - st.shear_force;
                if c.eta_n > 0.0 || c.eta_t > 0.0 {
                    let vn = n.dot(&rel_vel);
                    force += n * (c.eta_n * vn) + rel_vel_t * c.eta_t;
                    st.dissipation_power = c.eta_n * vn * vn + c.eta_t * rel_vel_t.norm_squared();
                }
                let moment = st.moment_twist + st.moment_bending;
                *f_out = force;
                *ti_out = c1x.cross(&force) - moment;
                *tj_out = -c2x.cross(&force) + moment;
            });
        if self.viscous.is_some() {
            let st = &self.dyn_state;
            self.dissipated += dt * deterministic_sum(st.len(), |b| st[b].dissipation_power);
        }
    }

    fn elastic_energy(&self) -> f64 {
        let (c, s) = (&self.consts, &self.dyn_state);
        deterministic_sum(c.len(), |b| {
            let (c, s) = (&c[b], &s[b]);
            let mut e = 0.0;
            if c.kn > 0.0 {
                e += 0.5 * s.normal_force * s.normal_force / c.kn;
            }
            if c.ks > 0.0 {
                e += 0.5 * s.shear_force.norm_squared() / c.ks;
            }
            if c.kr > 0.0 {
                e += 0.5 * s.moment_bending.norm_squared() / c.kr;
            }
            if c.ktw > 0.0 {
                e += 0.5 * s.moment_twist.norm_squared() / c.ktw;
            }
            e
        })
    }

    fn viscous_dissipation(&self) -> f64 {
        self.dissipated
    }

    fn springs(&self, b: usize) -> (f64, f64, f64, f64) {
        let c = &self.consts[b];
        (c.kn, c.ks, c.kr, c.ktw)
    }

    fn viscosity(&self, b: usize) -> (f64, f64) {
        (self.consts[b].eta_n, self.consts[b].eta_t)
    }

    fn bond_forces(&self, b: usize) -> (f64, Vec3) {
        (
            self.dyn_state[b].normal_force,
            self.dyn_state[b].shear_force,
        )
    }

    fn box_clone(&self) -> Box<dyn BondLaw> {
        Box::new(self.clone())
    }
}
