//! Unit quaternions for particle orientations, with the exact operation order of YADE's
//! (Eigen's) quaternion product, angle–axis conversions and normalisation, so that the
//! orientation-based bending/twisting of [`super::laws::yade`] matches YADE to rounding.

use crate::Vec3;

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
        let ha = 0.5 * angle;
        let s = ha.sin();
        Quat {
            w: ha.cos(),
            v: axis * s,
        }
    }

    /// Angle in [0, π] and unit axis of the rotation (Eigen's `AngleAxis` from a
    /// quaternion: angle = 2·atan2(|v|, |w|), axis = ±v/|v|; identity → (0, x̂)).
    #[inline]
    pub fn to_angle_axis(&self) -> (f64, Vec3) {
        let n = self.v.norm();
        if n != 0.0 {
            let angle = 2.0 * n.atan2(self.w.abs());
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

    /// Rotate a vector.
    pub fn rotate(&self, x: &Vec3) -> Vec3 {
        let p = Quat { w: 0.0, v: *x };
        self.mul(&p).mul(&self.conjugate()).v
    }
}

#[cfg(test)]
mod tests {
    use super::*;

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
