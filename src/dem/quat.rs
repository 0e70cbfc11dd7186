//! Unit quaternions for particle orientations, with the exact operation order of YADE's
//! (Eigen's) quaternion product, angle–axis conversions and normalisation, so that the
//! orientation-based bending/twisting of [`super::laws::yade`] matches YADE to rounding.

use crate::Vec3;

/// Largest argument for which the series below are used (2⁻⁴). Bond and particle
/// rotations per step are orders of magnitude smaller, so libm is only a fallback.
pub(crate) const SMALL_ANGLE_LIMIT: f64 = 0.0625;

/// atan(t) for 0 ≤ t ≤ [`SMALL_ANGLE_LIMIT`]: Taylor series through t¹³ in Horner form
/// (the first omitted term is below t·2⁻⁵⁶/15, under half an ulp). Within an ulp or two of
/// libm's correctly rounded atan2, at a fraction of its cost; the AVX2 lanes of law (a)
/// repeat these exact operations so both paths give the same bits.
#[inline(always)]
pub(crate) fn atan_series(t: f64) -> f64 {
    t * atan_over_t(t * t)
}

/// atan(t)/t as a polynomial in u = t² (Horner, the order the AVX2 lanes repeat).
#[inline(always)]
fn atan_over_t(u: f64) -> f64 {
    let p = ATAN_C[6];
    let p = ATAN_C[5] + u * p;
    let p = ATAN_C[4] + u * p;
    let p = ATAN_C[3] + u * p;
    let p = ATAN_C[2] + u * p;
    let p = ATAN_C[1] + u * p;
    ATAN_C[0] + u * p
}

/// Taylor coefficients of atan(t)/t in powers of t²: (−1)ᵏ/(2k+1).
pub(crate) const ATAN_C: [f64; 7] = [
    1.0,
    -1.0 / 3.0,
    1.0 / 5.0,
    -1.0 / 7.0,
    1.0 / 9.0,
    -1.0 / 11.0,
    1.0 / 13.0,
];

/// (sin x, cos x) for |x| ≤ [`SMALL_ANGLE_LIMIT`] by Taylor series (sin through x⁹, cos
/// through x⁸; omitted terms below 2⁻⁶⁰ relative), else libm.
#[inline(always)]
pub(crate) fn sin_cos_small(x: f64) -> (f64, f64) {
    if x.abs() <= SMALL_ANGLE_LIMIT {
        let u = x * x;
        (x * sin_over_x(u), cos_series(u))
    } else {
        x.sin_cos()
    }
}

/// sin(x)/x through x⁸ as a polynomial in u = x² (Horner; the AVX2 lanes repeat it).
#[inline(always)]
fn sin_over_x(u: f64) -> f64 {
    1.0 + u * (-1.0 / 6.0 + u * (1.0 / 120.0 + u * (-1.0 / 5040.0 + u * (1.0 / 362_880.0))))
}

/// cos(x) through x⁸ as a polynomial in u = x² (Horner; the AVX2 lanes repeat it).
#[inline(always)]
fn cos_series(u: f64) -> f64 {
    1.0 + u * (-0.5 + u * (1.0 / 24.0 + u * (-1.0 / 720.0 + u * (1.0 / 40_320.0))))
}

/// (cos h, sin h / |ω|) with h = ½|ω|·dt, from |ω|² and ½dt: the spin quaternion of one
/// step is (cos h, ω·sin h/|ω|). For |h| ≤ [`SMALL_ANGLE_LIMIT`] the series of
/// [`sin_cos_small`] in h² = |ω|²·(½dt)², with no square root or division; libm beyond.
/// The AVX2 particle update repeats these operations bit for bit.
#[inline(always)]
pub(crate) fn spin_factors(angle2: f64, half_dt: f64) -> (f64, f64) {
    let u = angle2 * (half_dt * half_dt);
    if u <= SMALL_ANGLE_LIMIT * SMALL_ANGLE_LIMIT {
        (cos_series(u), half_dt * sin_over_x(u))
    } else {
        let angle = angle2.sqrt();
        let (s, c) = (half_dt * angle).sin_cos();
        (c, s / angle)
    }
}

/// 2·atan2(y, x) for y ≥ 0 (the rotation angle of a quaternion with |v| = y, |w| = x): the
/// series when y ≤ [`SMALL_ANGLE_LIMIT`]·x, libm otherwise (and for NaN).
#[inline(always)]
pub(crate) fn double_atan2(y: f64, x: f64) -> f64 {
    if y <= SMALL_ANGLE_LIMIT * x {
        2.0 * atan_series(y / x)
    } else {
        2.0 * y.atan2(x)
    }
}

/// Rotation vector angle·axis (rad, angle in [0, π]) of the rotation that the quaternion
/// `q` represents, `q` not necessarily of unit norm. For the small relative rotations of
/// bonds (|v| ≤ [`SMALL_ANGLE_LIMIT`]·|w|) it is v·2·P(|v|²/w²)/|w|, with P the series of
/// [`atan_series`] divided by t: the normalisation cancels, so one division replaces the
/// normalisation, the two square roots and the axis division of `normalize` +
/// [`Quat::to_angle_axis`] (the same value to an ulp or two). Larger rotations take that
/// exact route. The AVX2 lanes of law (a) repeat these operations bit for bit.
#[inline(always)]
pub(crate) fn rotation_vector_of(q: &Quat) -> Vec3 {
    let vv = q.v.x * q.v.x + q.v.y * q.v.y + q.v.z * q.v.z;
    let ww = q.w * q.w;
    if ww > 0.0 && vv <= SMALL_ANGLE_LIMIT * SMALL_ANGLE_LIMIT * ww {
        let inv = 1.0 / q.w.abs();
        let u = vv * inv * inv;
        let f = 2.0 * atan_over_t(u) * inv;
        q.v * if q.w < 0.0 { -f } else { f }
    } else {
        let mut unit = *q;
        unit.normalize();
        let (angle, axis) = unit.to_angle_axis();
        if angle.is_nan() {
            Vec3::zeros()
        } else {
            axis * angle
        }
    }
}

/// A quaternion w + xi + yj + zk (unit when it represents an orientation).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Quat {
    /// Scalar part.
    pub w: f64,
    /// Vector part.
    pub v: Vec3,
}

impl Default for Quat {
    fn default() -> Self {
        Quat::identity()
    }
}

impl Quat {
    /// The identity rotation.
    pub fn identity() -> Self {
        Quat {
            w: 1.0,
            v: Vec3::zeros(),
        }
    }

    /// Hamilton product `self · b` (Eigen's component formulas).
    #[inline]
    pub fn mul(&self, b: &Quat) -> Quat {
        let (aw, ax, ay, az) = (self.w, self.v.x, self.v.y, self.v.z);
        let (bw, bx, by, bz) = (b.w, b.v.x, b.v.y, b.v.z);
        Quat {
            w: aw * bw - ax * bx - ay * by - az * bz,
            v: Vec3::new(
                aw * bx + ax * bw + ay * bz - az * by,
                aw * by + ay * bw + az * bx - ax * bz,
                aw * bz + az * bw + ax * by - ay * bx,
            ),
        }
    }

    /// Conjugate (the inverse of a unit quaternion).
    #[inline]
    pub fn conjugate(&self) -> Quat {
        Quat {
            w: self.w,
            v: -self.v,
        }
    }

    /// Divide by the 4-norm (no-op on the zero quaternion).
    #[inline]
    pub fn normalize(&mut self) {
        let n = (self.v.x * self.v.x + self.v.y * self.v.y + self.v.z * self.v.z + self.w * self.w)
            .sqrt();
        if n > 0.0 {
            self.w /= n;
            self.v /= n;
        }
    }

    /// Rotation by `angle` (rad) about the unit `axis`.
    #[inline]
    pub fn from_angle_axis(angle: f64, axis: &Vec3) -> Quat {
        let (s, c) = sin_cos_small(0.5 * angle);
        Quat { w: c, v: axis * s }
    }

    /// Angle in [0, π] and unit axis of the rotation (Eigen's `AngleAxis` from a
    /// quaternion: angle = 2·atan2(|v|, |w|), axis = ±v/|v|; identity → (0, x̂)).
    #[inline]
    pub fn to_angle_axis(&self) -> (f64, Vec3) {
        let n = self.v.norm();
        if n != 0.0 {
            let angle = double_atan2(n, self.w.abs());
            let axis = if self.w < 0.0 {
                -self.v / n
            } else {
                self.v / n
            };
            (angle, axis)
        } else {
            (0.0, Vec3::new(1.0, 0.0, 0.0))
        }
    }

    /// Rotation vector angle·axis (rad).
    pub fn rotation_vector(&self) -> Vec3 {
        let (a, ax) = self.to_angle_axis();
        ax * a
    }

    /// Rotate a vector. Inlined: law (d) rotates eight vectors per bond and step, and the
    /// call (with the unused scalar part of the second product) cost a quarter of its time.
    #[inline]
    pub fn rotate(&self, x: &Vec3) -> Vec3 {
        let p = Quat { w: 0.0, v: *x };
        self.mul(&p).mul(&self.conjugate()).v
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The series agree with libm to within two ulps over their whole range and switch
    /// over to libm beyond it.
    #[test]
    fn small_angle_series_match_libm() {
        let ulp =
            |a: f64, b: f64| ((a - b) / (f64::EPSILON * a.abs().max(f64::MIN_POSITIVE))).abs();
        let mut worst = [0.0f64; 3];
        for k in 0..=20_000 {
            let x = SMALL_ANGLE_LIMIT * (k as f64 / 20_000.0).powi(3);
            if x > 0.0 {
                worst[0] = worst[0].max(ulp(2.0 * x.atan(), double_atan2(x, 1.0)));
                worst[0] =
                    worst[0].max(ulp(2.0 * (0.3 * x).atan2(0.3), double_atan2(0.3 * x, 0.3)));
                let (s, c) = sin_cos_small(x);
                worst[1] = worst[1].max(ulp(x.sin(), s));
                worst[2] = worst[2].max(ulp(x.cos(), c));
                let (s, _) = sin_cos_small(-x);
                worst[1] = worst[1].max(ulp((-x).sin(), s));
            }
        }
        assert!(worst.iter().all(|&w| w <= 2.0), "worst ulps {worst:?}");
        assert_eq!(double_atan2(0.0, 1.0), 0.0);
        assert_eq!(double_atan2(1.0, 1.0), 2.0 * 1f64.atan2(1.0));
        assert!(double_atan2(f64::NAN, 1.0).is_nan());
        assert_eq!(sin_cos_small(0.5), 0.5f64.sin_cos());
    }

    #[test]
    fn spin_factors_match_libm_inside_and_outside_the_series_range() {
        let half_dt = 0.5e-3;
        let mut worst: f64 = 0.0;
        for k in 0..300 {
            // |ω| from 1e-6 to 1e3 rad/s: h = ½|ω|dt from 2.5e-10 to 0.25 (range ends at 2⁻⁴).
            let omega = 1e-6 * 10f64.powf(9.0 * k as f64 / 299.0);
            let (c, s) = spin_factors(omega * omega, half_dt);
            let h = half_dt * omega;
            worst = worst
                .max((c - h.cos()).abs())
                .max((s - h.sin() / omega).abs() / half_dt);
        }
        assert!(worst < 4e-16, "worst difference {worst:e}");
    }

    #[test]
    fn rotation_vector_of_unnormalised_quaternions_matches_libm_angle_axis() {
        // Reference: angle 2·atan2(|v|, |w|) by libm on the normalised quaternion, axis ±v/|v|.
        let reference = |q: &Quat| -> Vec3 {
            let n = (q.w * q.w + q.v.norm_squared()).sqrt();
            let (w, v) = (q.w / n, q.v / n);
            let angle = 2.0 * v.norm().atan2(w.abs());
            let axis = if w < 0.0 { -v / v.norm() } else { v / v.norm() };
            axis * angle
        };
        let mut worst: f64 = 0.0;
        for k in 1..400 {
            let t = k as f64;
            // Angles from 1e-8 rad to 3.1 rad, norms from 0.5 to 2, both signs of w.
            let angle = 1e-8 * (1.0 + t * 0.37).powi(4) % 3.1;
            let axis =
                Vec3::new((t * 1.3).sin(), (t * 0.7).cos(), (t * 2.1).sin() + 0.1).normalize();
            let scale = 0.5 + 1.5 * ((t * 0.91).sin() * 0.5 + 0.5);
            let sign = if k % 3 == 0 { -1.0 } else { 1.0 };
            let q = Quat {
                w: sign * scale * (0.5 * angle).cos(),
                v: axis * (sign * scale * (0.5 * angle).sin()),
            };
            let r = rotation_vector_of(&q);
            let e = reference(&q);
            worst = worst.max((r - e).norm() / e.norm());
        }
        assert!(worst < 1e-15, "worst relative difference {worst:e}");
        assert_eq!(rotation_vector_of(&Quat::identity()), Vec3::zeros());
        assert_eq!(
            rotation_vector_of(&Quat {
                w: 2.0,
                v: Vec3::zeros()
            }),
            Vec3::zeros()
        );
    }

    #[test]
    fn angle_axis_round_trip_and_composition() {
        let axis = Vec3::new(1.0, 2.0, -0.5).normalize();
        let q = Quat::from_angle_axis(0.7, &axis);
        let (a, ax) = q.to_angle_axis();
        assert!((a - 0.7).abs() < 1e-14);
        assert!((ax - axis).norm() < 1e-14);
        // Two quarter turns about z make a half turn: x̂ → −x̂.
        let z = Vec3::z();
        let q90 = Quat::from_angle_axis(std::f64::consts::FRAC_PI_2, &z);
        let r = q90.mul(&q90).rotate(&Vec3::x());
        assert!((r + Vec3::x()).norm() < 1e-15);
        // q·q* = identity.
        let e = q.mul(&q.conjugate());
        assert!((e.w - 1.0).abs() < 1e-15 && e.v.norm() < 1e-15);
    }
}
