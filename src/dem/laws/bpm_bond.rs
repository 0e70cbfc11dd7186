//! One bond of law (d), LAMMPS's `bond_style bpm/rotational` (docs in [`super::lammps_bpm`]):
//! its coefficients and records, and the per-bond step in the lab frame ([`bond_step`]:
//! Wang 2009 / Mora & Wang 2009 elastic loads, Wang, Alonso-Marroquin & Guo 2015 damping),
//! shared by the law's scalar path and its AVX2 lanes (`bpm_lanes`), which both sit above it.

use crate::dem::quat::{atan_series, Quat, SMALL_ANGLE_LIMIT};
use crate::dem::state::{BondLoad, Particles};
use crate::{Mat3, Vec3};

/// bpm/rotational's `normalize` setting.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum BpmNormalize {
    /// `normalize no` (LAMMPS default): F_r = k_r Δr, k_r and k_s in N/m.
    #[default]
    Absolute,
    /// `normalize yes`: k_r and k_s are divided by each bond's rest length r₀ (k in N).
    PerRestLength,
}

/// One bond's `bond_coeff` values of bpm/rotational (SI): springs k_r, k_s (N/m, or N with
/// [`BpmNormalize::PerRestLength`]), k_t, k_b (N·m/rad), damping γ_n, γ_s (N·s/m), γ_r (N·s/m,
/// torque ½γ_r l Δv_roll), γ_t (N·m·s/rad, torque ½γ_t Δω). In this order in memory (the
/// AVX2 lanes load four coefficients of a bond at once).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
#[repr(C)]
pub struct BpmCoefficients {
    /// k_r, normal spring.
    pub kr: f64,
    /// k_s, shear spring.
    pub ks: f64,
    /// k_t, twisting spring.
    pub kt: f64,
    /// k_b, bending spring.
    pub kb: f64,
    /// γ_n, normal damping.
    pub gamma_n: f64,
    /// γ_s, sliding damping.
    pub gamma_s: f64,
    /// γ_r, rolling damping.
    pub gamma_r: f64,
    /// γ_t, twisting damping.
    pub gamma_t: f64,
}

/// A bond's reference and current results.
#[derive(Clone, Copy, Debug, Default)]
pub(super) struct BpmBond {
    /// Particle 1 (smaller index) and 2.
    pub(super) p1: u32,
    pub(super) p2: u32,
    /// Cell distance of particle 2's image relative to particle 1 (integer, as the topology's).
    pub(super) image2: Vec3,
    /// Rest length r₀ (m).
    pub(super) r0_mag: f64,
    /// r₀·r̂₀ (r̂₀ = (x₁ − x₂)/r₀ the unit reference direction, lab frame; the product
    /// computed once at `initialize`) and r₀: the four values the AVX2 lanes load at once.
    pub(super) r0: [f64; 4],
    /// The topology's i end is particle 2.
    pub(super) flipped: bool,
    /// −0.0 when `flipped`, +0.0 otherwise: the AVX2 lanes' sign flip (exclusive or) and
    /// blend mask (sign bit) for the flipped ends.
    pub(super) flip: f64,
    /// Broken ([`BondLaw::break_bond`]): its coefficients are zero, so its loads are zero;
    /// the AVX2 lanes skip it, the scalar kernel only keeps its normal current (no one reads
    /// a broken bond's record).
    pub(super) broken: bool,
    /// `image2` is not zero (set by `initialize`; the AVX2 lanes test this byte per bond
    /// and step instead of three coordinates).
    pub(super) imaged: bool,
    /// Some damping coefficient is > 0 (set with the coefficients by `initialize`; the AVX2
    /// lanes read it instead of comparing four coefficients per bond and step).
    pub(super) damped: bool,
}

/// Per-bond results of the last evaluation: force on the topology's j end and its normal,
/// and the elastic parts the breaking criterion reads (LAMMPS judges the elastic loads,
/// before damping). In this order in memory, ten values (the AVX2 lanes store a bond's
/// record as two rows of four and a pair).
#[derive(Clone, Copy, Debug, Default)]
#[repr(C)]
pub(super) struct BpmResult {
    pub(super) elastic: ElasticParts,
    pub(super) force_j: Vec3,
    pub(super) normal: Vec3,
}

/// One bond's elastic loads, as squares where the energy needs them anyway (no square root
/// per bond and step unless breakage asks).
#[derive(Clone, Copy, Debug, Default)]
#[repr(C)]
pub(super) struct ElasticParts {
    /// F_r = k_r(|r| − r₀) (N, tension positive).
    pub(super) fr: f64,
    /// |F_s|² (N²), the whole shear force (bond direction and bending rotation).
    pub(super) fs2: f64,
    /// |τ_b|² (N²·m²).
    pub(super) tb2: f64,
    /// |τ_t|² (N²·m²).
    pub(super) tt2: f64,
}

impl ElasticParts {
    /// The elastic energy (J) of these loads, Σ ½ load²/k over the springs k > 0 (k_r and
    /// k_s divided by r₀ under `normalize yes`, as [`elastic_loads`] scales them). Computed
    /// when asked (the energies, a break), not per bond and step.
    pub(super) fn energy(&self, c: &BpmCoefficients, normalize: BpmNormalize, r0_mag: f64) -> f64 {
        let (mut kr, mut ks) = (c.kr, c.ks);
        if normalize == BpmNormalize::PerRestLength {
            let r0_mag_inv = 1.0 / r0_mag;
            kr *= r0_mag_inv;
            ks *= r0_mag_inv;
        }
        let mut energy = 0.0;
        for (load2, k) in [
            (self.fr * self.fr, kr),
            (self.fs2, ks),
            (self.tb2, c.kb),
            (self.tt2, c.kt),
        ] {
            if k > 0.0 {
                energy += 0.5 * load2 / k;
            }
        }
        energy
    }
}

/// atan2(y, x) for y ≥ 0: the series of [`atan_series`] when y ≤ 2⁻⁴·x (within an ulp
/// or two of libm), libm beyond (and for x ≤ 0 or NaN).
#[inline(always)]
pub(super) fn atan2_nonneg(y: f64, x: f64) -> f64 {
    if x > 0.0 && y <= SMALL_ANGLE_LIMIT * x {
        atan_series(y / x)
    } else {
        y.atan2(x)
    }
}

/// Rotation matrix (rows) of the unit quaternion q: R·v = q·v·q*.
#[inline(always)]
pub(super) fn rotation_matrix(q: &Quat) -> [Vec3; 3] {
    let (w, x, y, z) = (q.w, q.v.x, q.v.y, q.v.z);
    let (x2, y2, z2) = (x + x, y + y, z + z);
    let (xx, yy, zz) = (x * x2, y * y2, z * z2);
    let (xy, xz, yz) = (x * y2, x * z2, y * z2);
    let (wx, wy, wz) = (w * x2, w * y2, w * z2);
    [
        Vec3::new(1.0 - (yy + zz), xy - wz, xz + wy),
        Vec3::new(xy + wz, 1.0 - (xx + zz), yz - wx),
        Vec3::new(xz - wy, yz + wx, 1.0 - (xx + yy)),
    ]
}

/// Elastic loads (Wang 2009; Mora & Wang 2009) of one bond: (force on 2, torque on 2,
/// torque on 1, the elastic parts). `r` = x₁ − x₂ (lab frame) of length `r_mag`,
/// `r0` = r₀·r̂₀ in particle 2's body frame, q₁, q₂ the orientations (unit).
///
/// bpm/rotational's quantities computed in the lab frame, with fewer operations than its
/// body-frame route and the same values in exact arithmetic (the unit test
/// `fast_route_matches_lammps_operations` compares the two): r₀ turned to the lab by q₂
/// once instead of r into the body frame and three loads back; the relative rotation
/// q₁q₂* (= q₂·(q₂*q₁)·q₂*) split about r̂ directly — its twist component z = v·r̂ and
/// in-plane part v⊥ = v − z r̂ are m_q's frame without building m_q: (cos φ, sin φ, 0)
/// turned by m_q is u = (z v⊥ − w r̂×v)/√(|v⊥|²(w² + z²)), the bending direction r̂×u, the
/// twist axis r̂; the angles from atan2 of a sine and a cosine (γ = atan2(|r₀×r|, r₀·r),
/// ψ = 2 atan2(|z|, w), θ = 2 atan2(|v⊥|, √(w² + z²))) instead of acos, which agree with
/// LAMMPS' acos(cos) to its rounding (~√ε rad where the angle is ~0, ε/θ relative above).
/// LAMMPS' zero m_q (x₁ − x₂ exactly along −ẑ in 2's frame: no bending or twisting torque,
/// no bending shear) is kept (docs/lammps.md).
#[allow(clippy::too_many_arguments)]
#[inline(always)]
pub(super) fn elastic_loads(
    c: &BpmCoefficients,
    normalize: BpmNormalize,
    r_mag: f64,
    r0_mag: f64,
    r_mag_inv: f64,
    r: &Vec3,
    r0: &Vec3,
    q1: &Quat,
    q2: &Quat,
) -> (Vec3, Vec3, Vec3, ElasticParts) {
    let (mut kr, mut ks) = (c.kr, c.ks);
    if normalize == BpmNormalize::PerRestLength {
        let r0_mag_inv = 1.0 / r0_mag;
        kr *= r0_mag_inv;
        ks *= r0_mag_inv;
    }
    let m = rotation_matrix(q2);
    // r₀ in the lab frame; the bond vector in 2's frame only for LAMMPS' zero m_q.
    let r0 = Vec3::new(m[0].dot(r0), m[1].dot(r0), m[2].dot(r0));
    let rhat = r * r_mag_inv;
    let fr = kr * (r_mag - r0_mag);
    let mut force = rhat * fr;
    // Shear from the change of the bond's direction: γ, s = unit(r × (r × r₀)) = −r̂ × t,
    // t = unit(r₀ × r).
    let cross = r0.cross(r);
    let cross_mag = cross.dot(&cross).sqrt();
    let gamma = atan2_nonneg(cross_mag, r0.dot(r));
    let t = if cross_mag > 0.0 {
        cross * (1.0 / cross_mag)
    } else {
        Vec3::zeros()
    };
    let s = -rhat.cross(&t);
    let mut fs = s * (ks * r_mag * gamma);
    let mut ts = t * (0.5 * r_mag * ks * r_mag * gamma);
    let (mut tb, mut tt) = (Vec3::zeros(), Vec3::zeros());
    let rb_x = m[0][0] * r.x + m[1][0] * r.y + m[2][0] * r.z;
    let rb_y = m[0][1] * r.x + m[1][1] * r.y + m[2][1] * r.z;
    let zero_mq = rb_x == 0.0 && rb_y == 0.0 && {
        let rb_z = m[0][2] * r.x + m[1][2] * r.y + m[2][2] * r.z;
        r_mag + rb_z <= 0.0
    };
    if !zero_mq {
        // Particle 1's rotation relative to 2, lab frame: q₁q₂* = (w, v).
        let qd = q1.mul(&q2.conjugate());
        let (w, v) = (qd.w, qd.v);
        let z = v.dot(&rhat);
        let vp = v - rhat * z;
        let in_plane = vp.dot(&vp);
        let out_plane = w * w + z * z;
        let psi = if z == 0.0 {
            0.0
        } else {
            let a = 2.0 * atan2_nonneg(z.abs(), w);
            if z < 0.0 {
                -a
            } else {
                a
            }
        };
        let d = (out_plane * in_plane).sqrt();
        let theta = if out_plane > 0.0 {
            2.0 * atan2_nonneg(d, out_plane)
        } else {
            acos_limit(out_plane - in_plane)
        };
        // u = m_q·(cos φ, sin φ, 0) and the bending direction r̂ × u.
        let (u, bend) = if in_plane == 0.0 {
            (Vec3::zeros(), Vec3::zeros())
        } else if out_plane == 0.0 {
            let inv = 1.0 / in_plane.sqrt();
            (-rhat.cross(&vp) * inv, vp * inv)
        } else {
            let e = rhat.cross(&v);
            let inv = 1.0 / d;
            ((vp * z - e * w) * inv, (e * z + vp * w) * inv)
        };
        fs += u * (-0.5 * ks * r_mag * theta);
        ts += bend * (-0.25 * ks * r_mag * r_mag * theta);
        tb = bend * (c.kb * theta);
        tt = rhat * (c.kt * psi);
    }
    force += fs;
    let torque1on2 = ts + tt + tb;
    let torque2on1 = ts - tt - tb;
    let (fs2, tb2, tt2) = (fs.dot(&fs), tb.dot(&tb), tt.dot(&tt));
    let parts = ElasticParts { fr, fs2, tb2, tt2 };
    (force, torque1on2, torque2on1, parts)
}

/// acos with its argument clamped to [−1, 1] (bpm/rotational's `acos_limit`).
#[inline(always)]
pub(super) fn acos_limit(c: f64) -> f64 {
    c.clamp(-1.0, 1.0).acos()
}

/// Damping loads (Wang, Alonso-Marroquin & Guo 2015) added to (force on 2, torque on 2,
/// torque on 1); returns them as deltas.
#[allow(clippy::too_many_arguments)]
pub(super) fn damping_loads(
    c: &BpmCoefficients,
    rhat: &Vec3,
    r: &Vec3,
    v1: &Vec3,
    v2: &Vec3,
    w1: &Vec3,
    w2: &Vec3,
) -> (Vec3, Vec3, Vec3) {
    let vn1 = rhat * v1.dot(rhat);
    let vn2 = rhat * v2.dot(rhat);
    let mut f = (vn1 - vn2) * c.gamma_n;
    let (mut t12, mut t21) = (Vec3::zeros(), Vec3::zeros());
    // Sliding on the objective tangential velocities.
    let vt1 = v1 - vn1;
    let vt2 = v2 - vn2;
    let half_dvt = (vt2 - vt1) * 0.5;
    let s1 = w1.cross(r) * -0.5 - half_dvt;
    let s2 = w2.cross(r) * 0.5 + half_dvt;
    let slide = (s1 - s2) * c.gamma_s;
    f += slide;
    let tdamp = r.cross(&slide) * 0.5;
    t12 += tdamp;
    t21 += tdamp;
    // Rolling.
    let vroll = w1.cross(rhat) - w2.cross(rhat);
    let troll = r.cross(&vroll) * (0.5 * c.gamma_r);
    t12 += troll;
    t21 -= troll;
    // Twisting.
    let ttw = (rhat * w1.dot(rhat) - rhat * w2.dot(rhat)) * (0.5 * c.gamma_t);
    t12 += ttw;
    t21 -= ttw;
    (f, t12, t21)
}

/// What every bond of a step reads besides its own records.
pub(super) struct StepInputs<'a> {
    pub(super) particles: &'a Particles,
    pub(super) h: Mat3,
    pub(super) shift_velocity: Mat3,
    pub(super) normalize: BpmNormalize,
}

/// One bond of a step: its loads into `out`, its results and its damping power subtracted
/// from `power` (the AVX2 lanes of `bpm_lanes` repeat these operations exactly).
#[inline(always)]
pub(super) fn bond_step(
    inp: &StepInputs,
    bd: &BpmBond,
    c: &BpmCoefficients,
    result: &mut BpmResult,
    o: &mut BondLoad,
    power: &mut f64,
) {
    let p = inp.particles;
    let (a, b) = (bd.p1 as usize, bd.p2 as usize);
    let imaged = bd.image2 != Vec3::zeros();
    let x2 = if imaged {
        p.position[b] + inp.h * bd.image2
    } else {
        p.position[b]
    };
    let r = p.position[a] - x2;
    let r_mag = r.dot(&r).sqrt();
    let r_mag_inv = 1.0 / r_mag;
    let rhat = r * r_mag_inv;
    if bd.broken {
        // Zero coefficients give zero loads and energy: skip the kernel (the break left zero
        // loads, as LAMMPS drops the bond), keep the normal.
        *o = Default::default();
        *result = BpmResult {
            normal: if bd.flipped { rhat } else { -rhat },
            ..Default::default()
        };
        return;
    }
    let r0 = Vec3::new(bd.r0[0], bd.r0[1], bd.r0[2]);
    let (q1, q2) = (&p.orientation[a], &p.orientation[b]);
    let (mut f12, mut t12, mut t21, elastic) = elastic_loads(
        c,
        inp.normalize,
        r_mag,
        bd.r0_mag,
        r_mag_inv,
        &r,
        &r0,
        q1,
        q2,
    );
    let damped = c.gamma_n > 0.0 || c.gamma_s > 0.0 || c.gamma_r > 0.0 || c.gamma_t > 0.0;
    if damped {
        let v1 = p.velocity[a];
        let v2 = if imaged {
            p.velocity[b] + inp.shift_velocity * bd.image2
        } else {
            p.velocity[b]
        };
        let (w1, w2) = (p.angular_velocity[a], p.angular_velocity[b]);
        let (df, dt12, dt21) = damping_loads(c, &rhat, &r, &v1, &v2, &w1, &w2);
        f12 += df;
        t12 += dt12;
        t21 += dt21;
        // Power removed: −(loads on 1 and 2 · their velocities).
        *power -= (-df).dot(&v1) + df.dot(&v2) + dt21.dot(&w1) + dt12.dot(&w2);
    }
    if bd.flipped {
        // Topology i = particle 2.
        o.force_i = f12;
        o.torque_i = t12;
        o.torque_j = t21;
        *result = BpmResult {
            force_j: -f12,
            normal: rhat,
            elastic,
        };
    } else {
        o.force_i = -f12;
        o.torque_i = t21;
        o.torque_j = t12;
        *result = BpmResult {
            force_j: f12,
            normal: -rhat,
            elastic,
        };
    }
}
