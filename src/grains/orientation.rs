//! Grain orientations as Bunge matrices g (sample → crystal coordinates, v_c = g·v_s):
//! from Bunge Euler angles, uniform on SO(3) (Shoemake's quaternions) and fibre textures.

use crate::{Error, Mat3, Result, Vec3};
use rand::Rng;
use std::f64::consts::PI;

/// The Bunge matrix of Euler angles φ1, Φ, φ2 (radians; ZXZ, passive): g = Z(φ2)·X(Φ)·Z(φ1)
/// with Z(θ) = [[cos θ, sin θ, 0], [−sin θ, cos θ, 0], [0, 0, 1]] and
/// X(θ) = [[1, 0, 0], [0, cos θ, sin θ], [0, −sin θ, cos θ]]: the crystal frame is the
/// sample frame turned by φ1 about z, then Φ about the new x, then φ2 about the new z, and
/// g maps sample coordinates to crystal ones (Bunge 1982, Eq. 2.39). Its rows are the
/// crystal axes in sample coordinates.
pub fn bunge_matrix(phi1: f64, big_phi: f64, phi2: f64) -> Mat3 {
    let z = |t: f64| {
        let (s, c) = t.sin_cos();
        Mat3::new(c, s, 0.0, -s, c, 0.0, 0.0, 0.0, 1.0)
    };
    let (s, c) = big_phi.sin_cos();
    let x = Mat3::new(1.0, 0.0, 0.0, 0.0, c, s, 0.0, -s, c);
    z(phi2) * x * z(phi1)
}

/// [`bunge_matrix`] of angles in degrees.
pub fn bunge_deg(phi1: f64, big_phi: f64, phi2: f64) -> Mat3 {
    bunge_matrix(phi1.to_radians(), big_phi.to_radians(), phi2.to_radians())
}

/// The rotation matrix (active) of the unit quaternion w + xi + yj + zk.
fn quaternion_matrix(w: f64, x: f64, y: f64, z: f64) -> Mat3 {
    let n = (w * w + x * x + y * y + z * z).sqrt();
    let (w, x, y, z) = (w / n, x / n, y / n, z / n);
    Mat3::new(
        1.0 - 2.0 * (y * y + z * z),
        2.0 * (x * y - w * z),
        2.0 * (x * z + w * y),
        2.0 * (x * y + w * z),
        1.0 - 2.0 * (x * x + z * z),
        2.0 * (y * z - w * x),
        2.0 * (x * z - w * y),
        2.0 * (y * z + w * x),
        1.0 - 2.0 * (x * x + y * y),
    )
}

/// A rotation uniform on SO(3) (Haar measure) by Shoemake's method (Graphics Gems III,
/// 1992): u1, u2, u3 uniform in [0, 1) give the unit quaternion
/// (√(1−u1) sin 2πu2, √(1−u1) cos 2πu2, √u1 sin 2πu3, √u1 cos 2πu3). Three draws.
pub fn uniform_orientation<R: Rng>(rng: &mut R) -> Mat3 {
    let (u1, u2, u3): (f64, f64, f64) = (rng.gen(), rng.gen(), rng.gen());
    let (a, b) = ((1.0 - u1).sqrt(), u1.sqrt());
    let (s2, c2) = (2.0 * PI * u2).sin_cos();
    let (s3, c3) = (2.0 * PI * u3).sin_cos();
    quaternion_matrix(a * s2, a * c2, b * s3, b * c3)
}

/// Rotation by `angle` (radians) about the unit `axis` (Rodrigues), active.
fn axis_angle(axis: &Vec3, angle: f64) -> Mat3 {
    let k = Mat3::new(
        0.0, -axis.z, axis.y, axis.z, 0.0, -axis.x, -axis.y, axis.x, 0.0,
    );
    let (s, c) = angle.sin_cos();
    Mat3::identity() + k * s + k * k * (1.0 - c)
}

/// A unit vector perpendicular to the unit `v`.
fn perpendicular(v: &Vec3) -> Vec3 {
    let other = if v.x.abs() < 0.9 {
        Vec3::x()
    } else {
        Vec3::y()
    };
    v.cross(&other).normalize()
}

/// The active rotation taking unit `from` to unit `to` (the shortest; π about a
/// perpendicular axis for opposite vectors).
fn rotation_between(from: &Vec3, to: &Vec3) -> Mat3 {
    let v = from.cross(to);
    let (s, c) = (v.norm(), from.dot(to));
    if s <= 1e-12 {
        if c > 0.0 {
            Mat3::identity()
        } else {
            axis_angle(&perpendicular(from), PI)
        }
    } else {
        axis_angle(&(v / s), s.atan2(c))
    }
}

/// A unit vector from a model's `[x, y, z]`, or the refusal naming `key`.
pub(crate) fn unit(v: [f64; 3], key: &str) -> Result<Vec3> {
    let v = Vec3::new(v[0], v[1], v[2]);
    let n = v.norm();
    if !(n.is_finite() && n > 0.0) {
        return Err(Error::Model(format!(
            "[grains] {key} = {v:?}: expected a non-zero finite vector"
        )));
    }
    Ok(v / n)
}

/// A fibre-textured orientation: the crystal direction `direction` (crystal coordinates,
/// unit) along the sample `axis` (unit), turned uniformly about the axis and tilted off it
/// by a Gaussian spread: the tilt's two components across the axis are independent normal
/// with standard deviation `spread_deg` (so the tilt angle is Rayleigh distributed, mode
/// `spread_deg`); 0 puts the direction exactly on the axis. As the active rotation crystal →
/// sample, R = T(tilt)·A(ω)·R₀ with R₀ taking `direction` to `axis`, A(ω) the turn about
/// the axis; the Bunge matrix returned is g = Rᵀ, so gᵀ·direction is the tilted axis.
/// Three draws (ω, the tilt's azimuth, its size), whatever the spread.
pub fn fibre_orientation<R: Rng>(
    rng: &mut R,
    axis: &Vec3,
    direction: &Vec3,
    spread_deg: f64,
) -> Mat3 {
    let (u_turn, u_azimuth, u_size): (f64, f64, f64) = (rng.gen(), rng.gen(), rng.gen());
    let r0 = rotation_between(direction, axis);
    let turn = axis_angle(axis, 2.0 * PI * u_turn);
    let mut r = turn * r0;
    if spread_deg > 0.0 {
        let e1 = perpendicular(axis);
        let e2 = axis.cross(&e1);
        let (s, c) = (2.0 * PI * u_azimuth).sin_cos();
        let tilt_axis = e1 * c + e2 * s;
        let tilt = spread_deg.to_radians() * (-2.0 * (1.0 - u_size).ln()).sqrt();
        r = axis_angle(&tilt_axis, tilt) * r;
    }
    r.transpose()
}
