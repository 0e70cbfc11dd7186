//! Law (d): LAMMPS's `bond_style bpm/rotational` (BPM package, LAMMPS 22 Jul 2025) with
//! `break no smooth no`, reproduced from its documentation (doc/src/bond_bpm_rotational.rst:
//! Wang 2009 / Mora & Wang 2009 elastic forces, Wang, Alonso-Marroquin & Guo 2015 damping).
//!
//! The bond is ordered by atom id (here: particle index), 1 = the smaller. Its reference
//! state is stored once, at [`BondLaw::initialize`]: rest length r₀ and the unit vector
//! r̂₀ = (x₁ − x₂)/r₀ in the lab frame (with the initial orientations the identity, the
//! body frame of particle 2). At the current state, with r = x₁ − x₂ and r_b = q₂*·r·q₂
//! (the bond vector in particle 2's body frame):
//!
//! - normal: F_r = k_r (|r| − r₀) along r_b;
//! - shear from the bond's direction: γ = acos(r₀·r_b / (r₀|r|)), F_s = k_s |r| γ along
//!   r_b × (r_b × r₀) (normalised), with the torque ½|r|·F_s about r₀ × r_b;
//! - relative rotation q₂₁ = m_q*·(q₂*·q₁)·m_q, m_q the rotation of ẑ onto r_b (Mora & Wang
//!   2009's X'Y'Z' representation): twist ψ = ±2 acos(w/√(w² + z²)), bending
//!   θ = acos(w² − x² − y² + z²) in the direction φ; torques T_b = k_b θ (−sin φ, cos φ, 0),
//!   T_t = k_t ψ ẑ, and the shear of the rotation F = −½k_s|r|θ (cos φ, sin φ, 0) with its
//!   torque ¼k_s|r|²θ (sin φ, −cos φ, 0), all rotated back by m_q then by q₂ to the lab;
//! - particle 1 gets −F and T_s − T_t − T_b, particle 2 gets F and T_s + T_t + T_b;
//! - damping (optional, γ_n γ_s γ_r γ_t): normal −γ_n (v₁ − v₂)·r̂, sliding on the objective
//!   tangential velocities with its torque, rolling ½γ_r r × (ω₁ × r̂ − ω₂ × r̂), twisting
//!   ½γ_t (ω₁ − ω₂)·r̂ r̂.
//!
//! `normalize yes` divides k_r and k_s by r₀ ([`BpmNormalize`]). With anisobond's springs the
//! coefficients are k_r = k_n, k_s = k_s, k_t = k_tw, k_b = k_r (the export's mapping); the
//! shear lever arm is the bond's midpoint. The loads are bpm/rotational's, computed in the lab
//! frame with fewer operations (`bpm_bond::elastic_loads`; AVX2 lanes in `bpm_lanes`, the same bits)
//! and angles from atan2 rather than acos, which agree with LAMMPS' to its rounding (acos
//! near 1 amplifies a rounding of the cosine to ~√ε in the angle; see docs/lammps.md).

use super::{BondContext, BondLaw, BOND_CHUNK};
use crate::bonds::BondStiffness;
use crate::dem::state::{BondLoads, Particles};
use crate::strength::LocalLoads;
use crate::{Error, Result, Vec3};
use rayon::prelude::*;

use super::bpm_bond::{bond_step, BpmBond, BpmResult, StepInputs};
pub use super::bpm_bond::{BpmCoefficients, BpmNormalize};

/// LAMMPS `bpm/rotational` as a [`BondLaw`].
#[derive(Clone, Debug)]
pub struct LammpsBpmLaw {
    coeffs: Vec<BpmCoefficients>,
    normalize: BpmNormalize,
    bonds: Vec<BpmBond>,
    results: Vec<BpmResult>,
    /// Damping power per bond chunk of the last evaluation.
    chunk_sums: Vec<f64>,
    dissipated: f64,
    /// 1 + the largest particle index of any bond (usize::MAX before `initialize`): one
    /// comparison per step bounds-checks every bond for the unchecked reads of the AVX2
    /// lanes.
    index_bound: usize,
}

impl LammpsBpmLaw {
    /// A law with per-bond coefficients; errors on a negative or non-finite value.
    pub fn new(coeffs: Vec<BpmCoefficients>, normalize: BpmNormalize) -> Result<Self> {
        for (b, c) in coeffs.iter().enumerate() {
            let all = [
                ("k_r", c.kr),
                ("k_s", c.ks),
                ("k_t", c.kt),
                ("k_b", c.kb),
                ("gamma_n", c.gamma_n),
                ("gamma_s", c.gamma_s),
                ("gamma_r", c.gamma_r),
                ("gamma_t", c.gamma_t),
            ];
            if let Some((name, v)) = all.iter().find(|(_, v)| !(v.is_finite() && *v >= 0.0)) {
                return Err(Error::Invalid(format!(
                    "bond law `lammps-bpm`: bond {b} has {name} = {v}; expected a finite value ≥ 0"
                )));
            }
        }
        let n = coeffs.len();
        Ok(LammpsBpmLaw {
            coeffs,
            normalize,
            bonds: vec![BpmBond::default(); n],
            results: vec![BpmResult::default(); n],
            chunk_sums: vec![0.0; n.div_ceil(BOND_CHUNK)],
            dissipated: 0.0,
            index_bound: if n == 0 { 0 } else { usize::MAX },
        })
    }

    /// The coefficients of bond `b`.
    pub fn coefficients(&self, b: usize) -> &BpmCoefficients {
        &self.coeffs[b]
    }
}

/// bpm/rotational undamped with anisobond's springs `k`, `normalize no`: k_r = k_n,
/// k_s = k_s, k_t = k_tw, k_b = k_r (the mapping of [`crate::export::lammps`]).
pub fn lammps_bpm_law(k: &BondStiffness) -> Result<LammpsBpmLaw> {
    let n = k.kn.len();
    if [k.ks.len(), k.kr.len(), k.ktw.len()]
        .iter()
        .any(|&l| l != n)
    {
        return Err(Error::Invalid(
            "bond law `lammps-bpm`: spring arrays of different lengths".into(),
        ));
    }
    let coeffs = (0..n)
        .map(|b| BpmCoefficients {
            kr: k.kn[b],
            ks: k.ks[b],
            kt: k.ktw[b],
            kb: k.kr[b],
            ..Default::default()
        })
        .collect();
    LammpsBpmLaw::new(coeffs, BpmNormalize::Absolute)
}

impl BondLaw for LammpsBpmLaw {
    fn name(&self) -> &'static str {
        "lammps-bpm"
    }

    fn initialize(&mut self, ctx: &BondContext) -> Result<()> {
        let topo = ctx.topology;
        if topo.len() != self.coeffs.len() {
            return Err(Error::Invalid(format!(
                "bond law `lammps-bpm` has coefficients for {} bonds but the assembly has {}",
                self.coeffs.len(),
                topo.len()
            )));
        }
        let p = ctx.particles;
        for b in 0..topo.len() {
            let (i, j) = (topo.i[b], topo.j[b]);
            let cd = topo.cell_dist[b];
            // Particle 1 = the smaller index (LAMMPS: the smaller atom id).
            let flipped = i > j;
            let (p1, p2, image2) = if flipped { (j, i, -cd) } else { (i, j, cd) };
            let r = p.position[p1 as usize] - (p.position[p2 as usize] + ctx.h * image2);
            let r0_mag = r.norm();
            if !(r0_mag > 0.0 && r0_mag.is_finite()) {
                return Err(Error::Invalid(format!(
                    "bond {b}: its two particles coincide (centre distance {r0_mag})"
                )));
            }
            let inv = 1.0 / r0_mag;
            self.bonds[b] = BpmBond {
                p1,
                p2,
                image2,
                r0_mag,
                r0: {
                    let r0 = (r * inv) * r0_mag;
                    [r0.x, r0.y, r0.z, r0_mag]
                },
                flipped,
                flip: if flipped { -0.0 } else { 0.0 },
                broken: self.bonds[b].broken,
                imaged: image2 != Vec3::zeros(),
                damped: {
                    let c = &self.coeffs[b];
                    c.gamma_n > 0.0 || c.gamma_s > 0.0 || c.gamma_r > 0.0 || c.gamma_t > 0.0
                },
            };
        }
        self.results
            .iter_mut()
            .for_each(|r| *r = BpmResult::default());
        self.chunk_sums.iter_mut().for_each(|s| *s = 0.0);
        self.dissipated = 0.0;
        self.index_bound = self
            .bonds
            .iter()
            .map(|b| b.p1.max(b.p2) as usize + 1)
            .max()
            .unwrap_or(0);
        Ok(())
    }

    fn compute(&mut self, ctx: &BondContext, loads: &mut BondLoads) {
        let inp = StepInputs {
            particles: ctx.particles,
            h: ctx.h,
            shift_velocity: ctx.shift_velocity,
            normalize: self.normalize,
        };
        #[cfg(target_arch = "x86_64")]
        let lanes = ctx.simd
            && self.normalize == BpmNormalize::Absolute
            && std::arch::is_x86_feature_detected!("avx2")
            && {
                let p = ctx.particles;
                let len = [
                    p.position.len(),
                    p.orientation.len(),
                    p.velocity.len(),
                    p.angular_velocity.len(),
                ]
                .into_iter()
                .min()
                .unwrap_or(0);
                self.index_bound <= len
            };
        (
            self.bonds.par_chunks(BOND_CHUNK),
            self.coeffs.par_chunks(BOND_CHUNK),
            self.results.par_chunks_mut(BOND_CHUNK),
            loads.per_bond.par_chunks_mut(BOND_CHUNK),
            self.chunk_sums.par_iter_mut(),
        )
            .into_par_iter()
            .for_each(|(bonds, coeffs, results, out, slot)| {
                #[cfg(target_arch = "x86_64")]
                if lanes {
                    // SAFETY: the CPU has AVX2 and every bond's particle indices are in
                    // bounds (both checked above).
                    *slot =
                        unsafe { super::bpm_lanes::chunk_avx2(&inp, bonds, coeffs, results, out) };
                    return;
                }
                let mut power = 0.0;
                for k in 0..bonds.len() {
                    bond_step(
                        &inp,
                        &bonds[k],
                        &coeffs[k],
                        &mut results[k],
                        &mut out[k],
                        &mut power,
                    );
                }
                *slot = power;
            });
        self.dissipated += ctx.dt * self.chunk_sums.iter().sum::<f64>();
    }

    /// Σ of the intact bonds' energies at the last evaluation, in bond order (computed here
    /// from their elastic parts, not per step).
    fn elastic_energy(&self) -> f64 {
        self.results
            .iter()
            .zip(&self.coeffs)
            .zip(&self.bonds)
            .filter(|(_, bd)| !bd.broken)
            .map(|((r, c), bd)| r.elastic.energy(c, self.normalize, bd.r0_mag))
            .sum()
    }

    fn viscous_dissipation(&self) -> f64 {
        self.dissipated
    }

    fn springs(&self, b: usize) -> (f64, f64, f64, f64) {
        let c = &self.coeffs[b];
        let scale = match self.normalize {
            BpmNormalize::Absolute => 1.0,
            BpmNormalize::PerRestLength => {
                let r0 = self.bonds[b].r0_mag;
                if r0 > 0.0 {
                    1.0 / r0
                } else {
                    1.0
                }
            }
        };
        (c.kr * scale, c.ks * scale, c.kb, c.kt)
    }

    fn viscosity(&self, b: usize) -> (f64, f64) {
        let c = &self.coeffs[b];
        (c.gamma_n, c.gamma_s)
    }

    fn bond_forces(&self, b: usize) -> (f64, Vec3) {
        let r = &self.results[b];
        let fn_ = r.force_j.dot(&r.normal);
        (fn_, r.force_j - r.normal * fn_)
    }

    fn bond_normal(&self, b: usize) -> Vec3 {
        self.results[b].normal
    }

    /// The elastic loads LAMMPS's criterion judges (`elastic_forces`, before damping):
    /// F_n = −F_r, |F_s|, |τ_b|, |τ_t|.
    fn local_loads(&self, _: &Particles, b: usize) -> LocalLoads {
        let e = &self.results[b].elastic;
        LocalLoads {
            normal: -e.fr,
            shear: e.fs2.sqrt(),
            bending: e.tb2.sqrt(),
            twisting: e.tt2.sqrt(),
        }
    }

    fn bpm_parts_chunk(&self, first: usize, out: &mut [[f64; 4]]) -> bool {
        for (o, r) in out.iter_mut().zip(&self.results[first..]) {
            let e = &r.elastic;
            *o = [e.fr, e.fs2, e.tb2, e.tt2];
        }
        true
    }

    /// Zero coefficients (springs and damping): the bond gives zero loads from then on, as
    /// LAMMPS drops a broken bond from its bond list.
    fn break_bond(&mut self, _: &Particles, b: usize) -> f64 {
        let energy =
            self.results[b]
                .elastic
                .energy(&self.coeffs[b], self.normalize, self.bonds[b].r0_mag);
        self.coeffs[b] = BpmCoefficients::default();
        self.bonds[b].broken = true;
        self.bonds[b].damped = false;
        self.results[b] = BpmResult {
            normal: self.results[b].normal,
            ..Default::default()
        };
        energy
    }

    fn box_clone(&self) -> Box<dyn BondLaw> {
        Box::new(self.clone())
    }
}

#[cfg(test)]
mod tests {
    use super::super::bpm_bond::*;
    use super::*;
    use crate::bonds::BondSet;
    use crate::dem::quat::Quat;
    use crate::dem::state::{BondTopology, Particles};
    use crate::homogenize::network::{element, BondLaw as LinearBond, LeverArm};
    use crate::Mat3;

    const L: f64 = 2e-3;
    const C: BpmCoefficients = BpmCoefficients {
        kr: 3.0e6,
        ks: 1.1e6,
        kt: 0.7,
        kb: 1.9,
        gamma_n: 0.0,
        gamma_s: 0.0,
        gamma_r: 0.0,
        gamma_t: 0.0,
    };

    /// Two spheres bonded along the unit `dir`, at rest, reference state stored.
    fn pair(dir: Vec3) -> (Particles, BondTopology, LammpsBpmLaw) {
        let x0 = Vec3::new(0.1, -0.2, 0.3);
        let p = Particles {
            position: vec![x0, x0 + dir * L],
            velocity: vec![Vec3::zeros(); 2],
            angular_velocity: vec![Vec3::zeros(); 2],
            orientation: vec![Quat::identity(); 2],
            radius: vec![0.5 * L; 2],
            mass: vec![1e-5; 2],
            inertia: vec![1e-11; 2],
        };
        let mut bonds = BondSet::default();
        bonds.push(0, 1, dir * L, [0, 0, 0]);
        let topo = BondTopology::new(&bonds, 2).unwrap();
        let mut law = LammpsBpmLaw::new(vec![C], BpmNormalize::Absolute).unwrap();
        law.initialize(&ctx(&p, &topo)).unwrap();
        (p, topo, law)
    }

    fn ctx<'a>(p: &'a Particles, topo: &'a BondTopology) -> BondContext<'a> {
        BondContext {
            particles: p,
            topology: topo,
            h: Mat3::zeros(),
            shift_velocity: Mat3::zeros(),
            dt: 1e-7,
            simd: false,
        }
    }

    /// (force on 0, torque on 0, force on 1, torque on 1).
    fn loads(p: &Particles, topo: &BondTopology, law: &mut LammpsBpmLaw) -> [Vec3; 4] {
        let mut out = BondLoads::zeros(1);
        law.compute(&ctx(p, topo), &mut out);
        let l = out.per_bond[0];
        [l.force_i, l.torque_i, -l.force_i, l.torque_j]
    }

    fn unit(v: Vec3) -> Vec3 {
        v / v.norm()
    }

    /// Pure stretch: F_r = k_r (|r| − r₀) along the bond, exactly, at any stretch; no torque.
    #[test]
    fn stretch_gives_kr_times_the_elongation_along_the_bond() {
        let dir = unit(Vec3::new(0.3, -0.5, 0.8));
        for delta in [1e-9, 1e-6, 2e-4] {
            let (mut p, topo, mut law) = pair(dir);
            p.position[1] += dir * delta;
            let [f0, t0, f1, t1] = loads(&p, &topo, &mut law);
            let expected = dir * (C.kr * delta);
            assert!(
                (f0 - expected).norm() <= 1e-6 * expected.norm(),
                "{f0} vs {expected}"
            );
            assert!((f1 + expected).norm() <= 1e-6 * expected.norm());
            // No torque but the rounding of x₁ − x₂ at positions |x| ≫ L: a shear angle of
            // ~ε|x|/L rad.
            let floor = C.ks * L * L * 4.0 * f64::EPSILON * p.position[0].norm() / L;
            let tol = 1e-9 * expected.norm() * L + floor;
            assert!(t0.norm() <= tol && t1.norm() <= tol, "{t0} {t1} vs {tol:e}");
        }
    }

    /// Pure twist by ψ about the bond: torque k_t ψ about the axis, exactly (ψ up to 1 rad,
    /// any bond direction), no force.
    #[test]
    fn twist_gives_kt_times_the_angle() {
        for dir in [-Vec3::z(), unit(Vec3::new(1.0, 2.0, -0.5)), Vec3::x()] {
            for psi in [1e-4, 0.3, 1.0] {
                let (mut p, topo, mut law) = pair(dir);
                p.orientation[1] = Quat::from_angle_axis(psi, &dir);
                let [f0, t0, _, t1] = loads(&p, &topo, &mut law);
                let expected = dir * (C.kt * psi);
                // acos of a cosine near 1 leaves a bending of ~√ε rad (k_b·3e-8 N·m).
                let tol = 1e-7 * expected.norm() + 3e-8 * C.kb;
                assert!(
                    (t1 + expected).norm() <= tol,
                    "{dir} {psi}: {t1} vs −{expected}"
                );
                assert!(
                    (t0 - expected).norm() <= tol,
                    "{dir} {psi}: {t0} vs {expected}"
                );
                assert!(f0.norm() <= 3e-8 * C.ks * L, "{f0}");
            }
        }
    }

    /// Small displacements and rotations of both ends (stretch, shear, bending, twist at
    /// once): the loads are −K·d of the linear bond element with springs k_n = k_r,
    /// k_s = k_s, k_r = k_b, k_tw = k_t and the lever arm at the midpoint (an independent
    /// implementation, crate::homogenize::network), to O(|d|) = 1e-5 (tolerance 2e-4 of the
    /// largest load); and force and moment balance.
    #[test]
    fn small_motions_follow_the_midpoint_linear_element() {
        let mut seed = 7u64;
        let mut rnd = || {
            seed = seed
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            ((seed >> 11) as f64 / (1u64 << 53) as f64) * 2.0 - 1.0
        };
        for _ in 0..20 {
            let dir = unit(Vec3::new(rnd(), rnd(), rnd()));
            let (mut p, topo, mut law) = pair(dir);
            // Large enough that acos's rounding (ε/θ relative) stays below the tolerance.
            let eps = 1e-5;
            let d: Vec<Vec3> = (0..4)
                .map(|k| {
                    let s = if k % 2 == 0 { eps * L } else { eps };
                    Vec3::new(rnd(), rnd(), rnd()) * s
                })
                .collect();
            p.position[0] += d[0];
            p.position[1] += d[2];
            for (k, e) in [(0, 1), (1, 3)] {
                let a = d[e].norm();
                p.orientation[k] = Quat::from_angle_axis(a, &(d[e] / a));
            }
            let got = loads(&p, &topo, &mut law);
            let e = element(
                &LinearBond {
                    normal: dir,
                    length: L,
                    arms: LeverArm::HalfLength.arms(0.5 * L, 0.5 * L, L),
                    kn: C.kr,
                    ks: C.ks,
                    kr: C.kb,
                    ktw: C.kt,
                },
                true,
            );
            let mut dv = nalgebra::SVector::<f64, 12>::zeros();
            for (k, v) in d.iter().enumerate() {
                dv.fixed_rows_mut::<3>(3 * k).copy_from(v);
            }
            let mut k12 = nalgebra::SMatrix::<f64, 12, 12>::zeros();
            k12.fixed_view_mut::<6, 6>(0, 0).copy_from(&e.kii);
            k12.fixed_view_mut::<6, 6>(0, 6).copy_from(&e.kij);
            k12.fixed_view_mut::<6, 6>(6, 0)
                .copy_from(&e.kij.transpose());
            k12.fixed_view_mut::<6, 6>(6, 6).copy_from(&e.kjj);
            let want = -(k12 * dv);
            let scale_f = want
                .fixed_rows::<3>(0)
                .norm()
                .max(want.fixed_rows::<3>(6).norm());
            let scale_t = want
                .fixed_rows::<3>(3)
                .norm()
                .max(want.fixed_rows::<3>(9).norm());
            for (k, g) in got.iter().enumerate() {
                let w: Vec3 = want.fixed_rows::<3>(3 * k).into();
                let scale = if k % 2 == 0 { scale_f } else { scale_t };
                assert!(
                    (g - w).norm() <= 2e-4 * scale,
                    "dir {:?}, block {k}: {:?} vs {:?}",
                    dir.as_slice(),
                    g.as_slice(),
                    w.as_slice()
                );
            }
            // Balance: no net force; no net moment about the origin.
            let [f0, t0, f1, t1] = got;
            assert!((f0 + f1).norm() <= 1e-12 * scale_f);
            let m = p.position[0].cross(&f0) + p.position[1].cross(&f1) + t0 + t1;
            assert!(m.norm() <= 1e-9 * (scale_t + scale_f * L), "moment {m}");
        }
    }

    /// bpm/rotational's `elastic_forces` transcribed operation by operation (body frame of
    /// particle 2, m_q built, three acos): the reference the lab-frame route is held to.
    #[allow(clippy::too_many_arguments)]
    fn lammps_operations(
        c: &BpmCoefficients,
        r_mag: f64,
        r0_mag: f64,
        r: &Vec3,
        r0: &Vec3,
        q1: &Quat,
        q2: &Quat,
    ) -> (Vec3, Vec3, Vec3, [f64; 4]) {
        let unit_or_zero = |v: Vec3| {
            let n = v.norm();
            if n > 0.0 {
                v * (1.0 / n)
            } else {
                v
            }
        };
        let r_mag_inv = 1.0 / r_mag;
        let r0_mag_inv = 1.0 / r0_mag;
        let (kr, ks) = (c.kr, c.ks);
        let q2inv = q2.conjugate();
        let rb = q2inv.rotate(r);
        let fr = kr * (r_mag - r0_mag);
        let mut f_rot = rb * (fr * r_mag_inv);
        let c0 = r0.dot(&rb) * r_mag_inv * r0_mag_inv;
        let gamma = acos_limit(c0);
        let s = unit_or_zero(rb.cross(&rb.cross(r0)));
        let mut fs = s * (ks * r_mag * gamma);
        let t = unit_or_zero(r0.cross(&rb));
        let mut ts = t * (0.5 * r_mag * ks * r_mag * gamma);
        let h = std::f64::consts::SQRT_2 * 0.5;
        let mq0 = h * ((r_mag + rb.z).max(0.0) * r_mag_inv).sqrt();
        let rxy = (rb.x * rb.x + rb.y * rb.y).sqrt();
        let (mq1, mq2) = if rxy != 0.0 {
            let a = -h / rxy * ((r_mag - rb.z).max(0.0) * r_mag_inv).sqrt();
            (a * rb.y, -a * rb.x)
        } else {
            (0.0, 0.0)
        };
        let mq = Quat {
            w: mq0,
            v: Vec3::new(mq1, mq2, 0.0),
        };
        let q21 = mq.conjugate().mul(&q2inv.mul(q1)).mul(&mq);
        let (w, x, y, z) = (q21.w, q21.v.x, q21.v.y, q21.v.z);
        let wz = (w * w + z * z).sqrt();
        let mut psi = if wz != 0.0 {
            2.0 * acos_limit(w / wz)
        } else {
            0.0
        };
        if z < 0.0 {
            psi = -psi;
        }
        if z == 0.0 {
            psi = 0.0;
        }
        let theta = acos_limit(w * w - x * x - y * y + z * z);
        let (out_plane, in_plane) = (w * w + z * z, x * x + y * y);
        let (cos_phi, sin_phi) = if in_plane == 0.0 {
            (0.0, 0.0)
        } else if out_plane == 0.0 {
            (y / in_plane.sqrt(), -x / in_plane.sqrt())
        } else {
            let d = (out_plane * in_plane).sqrt();
            ((x * z + w * y) / d, (y * z - w * x) / d)
        };
        let tbp = Vec3::new(-c.kb * theta * sin_phi, c.kb * theta * cos_phi, 0.0);
        let ttp = Vec3::new(0.0, 0.0, c.kt * psi);
        let fsp = Vec3::new(
            -0.5 * ks * r_mag * theta * cos_phi,
            -0.5 * ks * r_mag * theta * sin_phi,
            0.0,
        );
        let tsp = Vec3::new(
            0.25 * ks * r_mag * r_mag * theta * sin_phi,
            -0.25 * ks * r_mag * r_mag * theta * cos_phi,
            0.0,
        );
        fs += mq.rotate(&fsp);
        ts += mq.rotate(&tsp);
        let tb = mq.rotate(&tbp);
        let tt = mq.rotate(&ttp);
        f_rot += fs;
        (
            q2.rotate(&f_rot),
            q2.rotate(&(ts + tt + tb)),
            q2.rotate(&(ts - tt - tb)),
            [fr, fs.norm(), tb.norm(), tt.norm()],
        )
    }

    /// The lab-frame route gives bpm/rotational's loads and criterion terms, computed
    /// operation by operation in its body frame, to 1e-12 of each load's scale: random
    /// orientations of particle 2, random bond directions, stretch, shear angles and relative
    /// rotations from 1e-4 to 0.5 rad (twist and bending, both signs); and a bond exactly
    /// along −ẑ in 2's frame (LAMMPS' zero m_q) transmits no bending or twisting torque.
    #[test]
    fn fast_route_matches_lammps_operations() {
        let mut seed = 11u64;
        let mut rnd = || {
            seed = seed
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            ((seed >> 11) as f64 / (1u64 << 53) as f64) * 2.0 - 1.0
        };
        let unit = |v: Vec3| v / v.norm();
        let across = |v: &Vec3, w: Vec3| unit(v.cross(&w));
        for scale in [1e-4, 1e-3, 1e-2, 0.1, 0.5] {
            // Every angle (shear γ, bending θ, twist ψ) of size in [scale/2, scale]: LAMMPS'
            // acos of a cosine rounded by a few ε is off by ~ε/θ, i.e. ε/θ² relative.
            let angle = |x: f64| scale * (0.5 + 0.5 * x.abs()) * x.signum();
            let tol = 1e-12 + 100.0 * f64::EPSILON / (0.5 * scale * 0.5 * scale);
            let mut worst: f64 = 0.0;
            for _ in 0..100 {
                let q2 = Quat::from_angle_axis(3.0 * rnd(), &unit(Vec3::new(rnd(), rnd(), rnd())));
                let r0_body = unit(Vec3::new(rnd(), rnd(), rnd())) * L;
                // The current bond: r₀ turned into the lab by q₂, then by γ about an axis
                // across it, and stretched.
                let r_lab0 = q2.rotate(&r0_body);
                let shear_axis = across(&r_lab0, Vec3::new(rnd(), rnd(), rnd()));
                let shear = Quat::from_angle_axis(angle(rnd()), &shear_axis);
                let r = shear.rotate(&r_lab0) * (1.0 + 1e-3 * rnd());
                // Particle 1 turned from 2 by a bending across r and a twist about it.
                let bend_axis = across(&r, Vec3::new(rnd(), rnd(), rnd()));
                let bend = Quat::from_angle_axis(angle(rnd()), &bend_axis);
                let twist = Quat::from_angle_axis(angle(rnd()), &unit(r));
                let q1 = twist.mul(&bend).mul(&q2);
                let r_mag = r.norm();
                let (f, t12, t21, parts) = elastic_loads(
                    &C,
                    BpmNormalize::Absolute,
                    r_mag,
                    L,
                    1.0 / r_mag,
                    &r,
                    &r0_body,
                    &q1,
                    &q2,
                );
                let (fw, t12w, t21w, terms) =
                    lammps_operations(&C, r_mag, L, &r, &r0_body, &q1, &q2);
                let sf = fw.norm();
                let st = t12w.norm().max(t21w.norm());
                worst = worst
                    .max((f - fw).norm() / sf)
                    .max((t12 - t12w).norm() / st)
                    .max((t21 - t21w).norm() / st)
                    .max((parts.fr - terms[0]).abs() / sf)
                    .max((parts.fs2.sqrt() - terms[1]).abs() / sf)
                    .max((parts.tb2.sqrt() - terms[2]).abs() / st)
                    .max((parts.tt2.sqrt() - terms[3]).abs() / st);
            }
            assert!(
                worst < tol,
                "angles ~{scale}: worst relative difference {worst:e}"
            );
        }
        // LAMMPS' zero m_q: x₁ − x₂ along −ẑ of particle 2 (identity), particle 1 turned.
        let r = Vec3::new(0.0, 0.0, -L);
        let q1 = Quat::from_angle_axis(0.01, &Vec3::new(0.6, 0.0, 0.8));
        let q2 = Quat::identity();
        let (f, t12, t21, parts) =
            elastic_loads(&C, BpmNormalize::Absolute, L, L, 1.0 / L, &r, &r, &q1, &q2);
        let (fw, t12w, t21w, _) = lammps_operations(&C, L, L, &r, &r, &q1, &q2);
        assert_eq!((parts.tb2, parts.tt2), (0.0, 0.0));
        assert_eq!((f, t12, t21), (fw, t12w, t21w));
    }

    /// Damping: a normal approach speed v gives γ_n v against it, nothing else; the power
    /// removed is γ_n v².
    #[test]
    fn normal_damping_opposes_the_approach() {
        let dir = unit(Vec3::new(0.2, 0.4, -1.0));
        let (mut p, topo, _) = pair(dir);
        let mut c = C;
        c.gamma_n = 0.3;
        let mut law = LammpsBpmLaw::new(vec![c], BpmNormalize::Absolute).unwrap();
        law.initialize(&ctx(&p, &topo)).unwrap();
        let v = 0.01;
        p.velocity[1] = -dir * v;
        let [f0, _, f1, _] = loads(&p, &topo, &mut law);
        assert!((f1 - dir * (0.3 * v)).norm() <= 1e-12 * 0.3 * v, "{f1}");
        assert!((f0 + f1).norm() == 0.0);
        assert!(
            (law.viscous_dissipation() - 1e-7 * 0.3 * v * v).abs() <= 1e-12 * 0.3 * v * v * 1e-7
        );
    }

    /// `normalize yes` divides k_r by the rest length.
    #[test]
    fn normalize_divides_the_force_springs_by_the_rest_length() {
        let dir = Vec3::x();
        let (mut p, topo, _) = pair(dir);
        let mut law = LammpsBpmLaw::new(vec![C], BpmNormalize::PerRestLength).unwrap();
        law.initialize(&ctx(&p, &topo)).unwrap();
        p.position[1] += dir * 1e-7;
        let [_, _, f1, _] = loads(&p, &topo, &mut law);
        let expected = C.kr / L * 1e-7;
        assert!((f1.x + expected).abs() <= 1e-6 * expected, "{f1}");
        assert!((law.springs(0).0 - C.kr / L).abs() <= 1e-15 * C.kr / L);
    }
}
