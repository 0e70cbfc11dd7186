//! Symmetrised projections of a measured 6×6 stiffness onto cubic and transversely
//! isotropic tensors, with the uncertainty measure of Truszkowska 2018 Sec. 4.4 / 5.3
//! (Eqs. 29–30): the spread of equivalent terms and the mean size of terms that the
//! symmetry makes zero.

use super::elastic::{poisson_100, zener_ratio};
use super::rotate::{rotate, rotation_to_z};
use super::Stiffness6;
use crate::{Mat3, Result, Vec3};

/// Upper-triangle Voigt entries that vanish under cubic symmetry (axes along <100>) and
/// under transverse isotropy about z: C14, C15, C16, C24, C25, C26, C34, C35, C36, C45,
/// C46, C56 (0-based pairs).
pub const OFF_SYMMETRY_TERMS: [(usize, usize); 12] = [
    (0, 3),
    (0, 4),
    (0, 5),
    (1, 3),
    (1, 4),
    (1, 5),
    (2, 3),
    (2, 4),
    (2, 5),
    (3, 4),
    (3, 5),
    (4, 5),
];

/// Mean |C_ab| over [`OFF_SYMMETRY_TERMS`] (upper triangle only).
fn mean_off_symmetry_magnitude(c: &Stiffness6) -> f64 {
    OFF_SYMMETRY_TERMS
        .iter()
        .map(|&(a, b)| c[(a, b)].abs())
        .sum::<f64>()
        / OFF_SYMMETRY_TERMS.len() as f64
}

/// Largest |C_ab − value| over `entries`.
fn largest_deviation(c: &Stiffness6, entries: &[(usize, usize)], value: f64) -> f64 {
    entries
        .iter()
        .map(|&(a, b)| (c[(a, b)] - value).abs())
        .fold(0.0, f64::max)
}

/// Uncertainty of a [`CubicProjection`] (Pa), Truszkowska 2018 Sec. 4.4: the largest
/// absolute deviation of each group of cubically equivalent terms from its mean, and the
/// mean magnitude of the 12 upper-triangle terms that should be zero.
/// Serialised as in the tensor report (docs/formats.md): keys `C11`, `C12`, `C44`,
/// `zero_terms`.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct CubicUncertainty {
    /// max |C_ii − c11|, i = 1..3.
    #[serde(rename = "C11")]
    pub c11: f64,
    /// max |C_ij − c12| over C12, C13, C23.
    #[serde(rename = "C12")]
    pub c12: f64,
    /// max |C_ii − c44|, i = 4..6.
    #[serde(rename = "C44")]
    pub c44: f64,
    /// Mean |C_ab| over [`OFF_SYMMETRY_TERMS`].
    pub zero_terms: f64,
}

/// The cubic tensor closest to C in the tensor's axes, Truszkowska 2018 Eq. 30:
/// c11 = mean(C11, C22, C33), c12 = mean(C12, C13, C23), c44 = mean(C44, C55, C66),
/// other terms zero. This is also the least-squares projection in the Frobenius norm of
/// C6 (entries of the symmetric part are used). All moduli in Pa.
///
/// Serialised as the tensor report's `cubic` object (docs/formats.md): `C11`, `C12`, `C44`,
/// `zener`, `uncertainty`.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct CubicProjection {
    /// C11 (Pa).
    #[serde(rename = "C11")]
    pub c11: f64,
    /// C12 (Pa).
    #[serde(rename = "C12")]
    pub c12: f64,
    /// C44 (Pa).
    #[serde(rename = "C44")]
    pub c44: f64,
    /// Zener ratio 2C44/(C11 − C12).
    pub zener: f64,
    /// Poisson's ratio along <100>, C12/(C11 + C12).
    #[serde(skip)]
    pub poisson_100: f64,
    /// Spread of the equivalent terms (Truszkowska 2018 Sec. 4.4).
    pub uncertainty: CubicUncertainty,
}

impl CubicProjection {
    /// Cubic projection of C (of its symmetric part when C is not symmetric).
    pub fn from_stiffness(c: &Stiffness6) -> Self {
        let c = &(0.5 * (c + c.transpose()));
        const DIAG: [(usize, usize); 3] = [(0, 0), (1, 1), (2, 2)];
        const OFF: [(usize, usize); 3] = [(0, 1), (0, 2), (1, 2)];
        const SHEAR: [(usize, usize); 3] = [(3, 3), (4, 4), (5, 5)];
        let mean = |e: &[(usize, usize)]| e.iter().map(|&ab| c[ab]).sum::<f64>() / 3.0;
        let (c11, c12, c44) = (mean(&DIAG), mean(&OFF), mean(&SHEAR));
        Self {
            c11,
            c12,
            c44,
            zener: zener_ratio(c11, c12, c44),
            poisson_100: poisson_100(c11, c12),
            uncertainty: CubicUncertainty {
                c11: largest_deviation(c, &DIAG, c11),
                c12: largest_deviation(c, &OFF, c12),
                c44: largest_deviation(c, &SHEAR, c44),
                zero_terms: mean_off_symmetry_magnitude(c),
            },
        }
    }

    /// The full symmetrised 6×6 cubic tensor (Truszkowska 2018 Eq. 30).
    pub fn to_matrix(&self) -> Stiffness6 {
        cubic_tensor(self.c11, self.c12, self.c44)
    }
}

/// Uncertainty of a [`TransverseProjection`] (Pa), defined like [`CubicUncertainty`]:
/// the largest |C_ab − projected_ab| over each group of equivalent entries, and the mean
/// magnitude of the 12 upper-triangle terms that should be zero.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TransverseUncertainty {
    /// max over C11, C22.
    pub c11: f64,
    /// |C33 − c33| (always 0: C33 has no equivalent term).
    pub c33: f64,
    /// max over C13, C23.
    pub c13: f64,
    /// |C12 − c12| (non-zero when C66 ≠ (C11 − C12)/2).
    pub c12: f64,
    /// max over C44, C55.
    pub c44: f64,
    /// |C66 − c66|.
    pub c66: f64,
    /// Mean |C_ab| over [`OFF_SYMMETRY_TERMS`].
    pub zero_terms: f64,
}

/// The transversely isotropic (about z) tensor closest to C: the least-squares
/// projection onto the 5-dimensional subspace {C11 = C22, C13 = C23, C44 = C55,
/// C66 = (C11 − C12)/2, zeros elsewhere} in the **Frobenius norm of the Voigt matrix
/// C6** (all 36 entries weighted 1; no Mandel factors). Closed form, with A = mean(C11,
/// C22), B = C12, D = C66: c11 + c12 = A + B, c11 − c12 = (4(A − B) + 2D)/5; c33 = C33,
/// c13 = mean(C13, C23), c44 = mean(C44, C55). Symmetric-part entries are used, so an
/// asymmetric C is projected through its symmetric part. Moduli in Pa.
///
/// Serialised as the tensor report's `transverse` object (docs/formats.md): `C11`, `C33`,
/// `C13`, `C12`, `C44`.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct TransverseProjection {
    /// C11 = C22 (Pa).
    #[serde(rename = "C11")]
    pub c11: f64,
    /// C33 (Pa).
    #[serde(rename = "C33")]
    pub c33: f64,
    /// C13 = C23 (Pa).
    #[serde(rename = "C13")]
    pub c13: f64,
    /// C12 (Pa).
    #[serde(rename = "C12")]
    pub c12: f64,
    /// C44 = C55 (Pa).
    #[serde(rename = "C44")]
    pub c44: f64,
    /// C66 = (C11 − C12)/2 (Pa).
    #[serde(skip)]
    pub c66: f64,
    /// Spread of the equivalent terms.
    #[serde(skip)]
    pub uncertainty: TransverseUncertainty,
}

impl TransverseProjection {
    /// Transversely isotropic projection of C about z (see the struct doc).
    pub fn from_stiffness(c: &Stiffness6) -> Self {
        let s = 0.5 * (c + c.transpose());
        let a = 0.5 * (s[(0, 0)] + s[(1, 1)]);
        let b = s[(0, 1)];
        let d = s[(5, 5)];
        let sum = a + b;
        let difference = (4.0 * (a - b) + 2.0 * d) / 5.0;
        let c11 = 0.5 * (sum + difference);
        let c12 = 0.5 * (sum - difference);
        let c66 = 0.5 * difference;
        let c33 = s[(2, 2)];
        let c13 = 0.5 * (s[(0, 2)] + s[(1, 2)]);
        let c44 = 0.5 * (s[(3, 3)] + s[(4, 4)]);
        Self {
            c11,
            c33,
            c13,
            c12,
            c44,
            c66,
            uncertainty: TransverseUncertainty {
                c11: largest_deviation(&s, &[(0, 0), (1, 1)], c11),
                c33: largest_deviation(&s, &[(2, 2)], c33),
                c13: largest_deviation(&s, &[(0, 2), (1, 2)], c13),
                c12: largest_deviation(&s, &[(0, 1)], c12),
                c44: largest_deviation(&s, &[(3, 3), (4, 4)], c44),
                c66: largest_deviation(&s, &[(5, 5)], c66),
                zero_terms: mean_off_symmetry_magnitude(&s),
            },
        }
    }

    /// Transversely isotropic projection about an arbitrary `axis`: C is first rotated
    /// into a frame whose z is the axis, C' = rotate(C, Q) with Q = [`rotation_to_z`]
    /// (Q·axis = e_z), then projected; the result is in that rotated frame, and Q is
    /// returned with it (the lab tensor is rotate(p.to_matrix(), Qᵀ)). Error for a zero
    /// or non-finite axis.
    pub fn about_axis(c: &Stiffness6, axis: &Vec3) -> Result<(Self, Mat3)> {
        let q = rotation_to_z(axis)?;
        Ok((Self::from_stiffness(&rotate(c, &q)), q))
    }

    /// The full symmetrised 6×6 transversely isotropic tensor (axis z).
    pub fn to_matrix(&self) -> Stiffness6 {
        transverse_tensor([self.c11, self.c33, self.c13, self.c12, self.c44], self.c66)
    }
}

/// The cubic Voigt tensor in its own axes (Pa): `c11` on the diagonal of the normal block,
/// `c12` off it, `c44` on the shear diagonal, zeros elsewhere.
pub(crate) fn cubic_tensor(c11: f64, c12: f64, c44: f64) -> Stiffness6 {
    let mut m = Stiffness6::zeros();
    for i in 0..3 {
        for j in 0..3 {
            m[(i, j)] = if i == j { c11 } else { c12 };
        }
        m[(i + 3, i + 3)] = c44;
    }
    m
}

/// The transversely isotropic Voigt tensor about z (Pa) of `[c11, c33, c13, c12, c44]` and
/// `c66` (C66 = (C11 − C12)/2 for a true transversely isotropic tensor; given, so a
/// projection's own value is kept), zeros elsewhere.
pub(crate) fn transverse_tensor(c: [f64; 5], c66: f64) -> Stiffness6 {
    let [c11, c33, c13, c12, c44] = c;
    let mut m = Stiffness6::zeros();
    m[(0, 0)] = c11;
    m[(1, 1)] = c11;
    m[(2, 2)] = c33;
    for (a, b, v) in [(0, 1, c12), (0, 2, c13), (1, 2, c13)] {
        m[(a, b)] = v;
        m[(b, a)] = v;
    }
    m[(3, 3)] = c44;
    m[(4, 4)] = c44;
    m[(5, 5)] = c66;
    m
}
