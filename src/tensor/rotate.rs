//! Rotating 6×6 Voigt stiffness tensors, and the rotation matrices used to do it.
//!
//! Convention (docs/references.md "Conventions"): rotate(C, Q)_ijkl = Q_ia Q_jb Q_kc Q_ld C_abcd.
//! For a crystal orientation R that maps lab vectors into the crystal frame,
//! C_lab = rotate(C_crystal, Rᵀ) (this reproduces Truszkowska 2018 Eq. 32 from Eq. 30).

use super::{Stiffness6, VOIGT_PAIRS};
use crate::{Error, Mat3, Result, Vec3};

/// The 6×6 Bond matrix M of Q for Voigt stress (order 11, 22, 33, 23, 13, 12):
/// σ' = M σ when σ'_ij = Q_ik Q_jl σ_kl. With engineering strain ε' = M⁻ᵀ ε, so a Voigt
/// stiffness transforms as C' = M C Mᵀ (Bond 1943; Auld, *Acoustic Fields and Waves*).
pub fn bond_matrix(q: &Mat3) -> Stiffness6 {
    let mut m = Stiffness6::zeros();
    for (a, &(i, j)) in VOIGT_PAIRS.iter().enumerate() {
        for (b, &(k, l)) in VOIGT_PAIRS.iter().enumerate() {
            m[(a, b)] = if k == l {
                q[(i, k)] * q[(j, k)]
            } else {
                q[(i, k)] * q[(j, l)] + q[(i, l)] * q[(j, k)]
            };
        }
    }
    m
}

/// rotate(C, Q)_ijkl = Q_ia Q_jb Q_kc Q_ld C_abcd, computed as M C Mᵀ with the Bond
/// matrix M of Q ([`bond_matrix`]). Q should be a rotation (orthogonal, det +1); for a
/// general Q this is still the 4th-order push-forward above.
pub fn rotate(c: &Stiffness6, q: &Mat3) -> Stiffness6 {
    let m = bond_matrix(q);
    m * c * m.transpose()
}

/// Active right-handed rotation by `angle` (rad) about x: `[[1,0,0],[0,c,−s],[0,s,c]]`.
pub fn rotation_x(angle: f64) -> Mat3 {
    let (s, c) = angle.sin_cos();
    Mat3::new(1.0, 0.0, 0.0, 0.0, c, -s, 0.0, s, c)
}

/// Active right-handed rotation by `angle` (rad) about y: `[[c,0,s],[0,1,0],[−s,0,c]]`.
pub fn rotation_y(angle: f64) -> Mat3 {
    let (s, c) = angle.sin_cos();
    Mat3::new(c, 0.0, s, 0.0, 1.0, 0.0, -s, 0.0, c)
}

/// Active right-handed rotation by `angle` (rad) about z: `[[c,−s,0],[s,c,0],[0,0,1]]`.
pub fn rotation_z(angle: f64) -> Mat3 {
    let (s, c) = angle.sin_cos();
    Mat3::new(c, -s, 0.0, s, c, 0.0, 0.0, 0.0, 1.0)
}

/// A rotation Q with Q·(axis/|axis|) = e_z: the smallest rotation doing so (about
/// axis × e_z), or a half turn about x when `axis` points along −z. Used to bring a
/// symmetry axis to z before a transversely isotropic projection.
pub fn rotation_to_z(axis: &Vec3) -> Result<Mat3> {
    let a = super::unit_vector(axis).ok_or_else(|| {
        Error::Invalid(format!(
            "symmetry axis ({}, {}, {}): expected a finite non-zero vector",
            axis[0], axis[1], axis[2]
        ))
    })?;
    let ez = Vec3::z();
    let cos = a.dot(&ez);
    if cos < -1.0 + 1e-12 {
        return Ok(rotation_x(std::f64::consts::PI));
    }
    // Rodrigues for the rotation taking a to e_z: R = I + [v]× + [v]×² /(1 + cos), v = a × e_z.
    let v = a.cross(&ez);
    let vx = Mat3::new(0.0, -v[2], v[1], v[2], 0.0, -v[0], -v[1], v[0], 0.0);
    Ok(Mat3::identity() + vx + vx * vx / (1.0 + cos))
}

/// The nearest proper rotation (polar factor U Vᵀ of the SVD) to a matrix that should
/// be one but was printed to finite precision (e.g. Truszkowska 2018 Eq. 31, det
/// 1.000066). Refuses `m` when max |mᵀm − I| exceeds `tolerance` or det m ≤ 0; `what`
/// names the input in the message.
pub fn orthonormalize_rotation(m: &Mat3, tolerance: f64, what: &str) -> Result<Mat3> {
    if m.iter().any(|x| !x.is_finite()) {
        return Err(Error::Invalid(format!(
            "{what}: rotation matrix has non-finite entries"
        )));
    }
    let deviation = (m.transpose() * m - Mat3::identity()).amax();
    if deviation > tolerance {
        return Err(Error::Invalid(format!(
            "{what}: not a rotation matrix: max |RᵀR − I| = {deviation:.3e} exceeds {tolerance:.1e}"
        )));
    }
    let det = m.determinant();
    if det <= 0.0 {
        return Err(Error::Invalid(format!(
            "{what}: determinant {det:.6} ≤ 0 (a reflection, not a rotation)"
        )));
    }
    let svd = m.svd(true, true);
    match (svd.u, svd.v_t) {
        (Some(u), Some(v_t)) => Ok(u * v_t),
        _ => Err(Error::Invalid(format!(
            "{what}: singular value decomposition failed"
        ))),
    }
}
