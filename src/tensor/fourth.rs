//! Conversion between the 6×6 Voigt matrix and the full 4th-order stiffness tensor
//! C_ijkl (`C6[a,b] = C_ijkl` with `(i,j) = VOIGT_PAIRS[a]`, `(k,l) = VOIGT_PAIRS[b]`, no
//! factors of 2 or √2; docs/references.md "Conventions"), and the explicit 4th-order rotation.

use super::{Stiffness6, VOIGT_PAIRS};
use crate::Mat3;

/// A full 4th-order tensor C_ijkl (indices 0..3), e.g. a stiffness in Pa.
pub type Tensor4 = [[[[f64; 3]; 3]; 3]; 3];

/// The 4th-order tensor of a Voigt matrix: `C_ijkl = C6[voigt(i,j), voigt(k,l)]`, which has
/// the minor symmetries C_ijkl = C_jikl = C_ijlk by construction.
pub fn to_fourth_order(c: &Stiffness6) -> Tensor4 {
    let mut t = [[[[0.0; 3]; 3]; 3]; 3];
    for (i, ti) in t.iter_mut().enumerate() {
        for (j, tij) in ti.iter_mut().enumerate() {
            for (k, tijk) in tij.iter_mut().enumerate() {
                for (l, v) in tijk.iter_mut().enumerate() {
                    *v = c[(super::voigt_index(i, j), super::voigt_index(k, l))];
                }
            }
        }
    }
    t
}

/// The Voigt matrix of a 4th-order tensor: `C6[a,b] = C_ijkl`, averaged over the four
/// minor-symmetric index orders (ij|ji, kl|lk) so a tensor lacking the minor symmetries
/// is mapped to its minor-symmetric part. Exact inverse of [`to_fourth_order`].
pub fn from_fourth_order(t: &Tensor4) -> Stiffness6 {
    let mut c = Stiffness6::zeros();
    for (a, &(i, j)) in VOIGT_PAIRS.iter().enumerate() {
        for (b, &(k, l)) in VOIGT_PAIRS.iter().enumerate() {
            c[(a, b)] = 0.25 * (t[i][j][k][l] + t[j][i][k][l] + t[i][j][l][k] + t[j][i][l][k]);
        }
    }
    c
}

/// Explicit rotation of a 4th-order tensor, C'_ijkl = Q_ia Q_jb Q_kc Q_ld C_abcd
/// (docs/references.md "Conventions"). O(3⁸) — the reference that [`rotate`](super::rotate::rotate) is tested
/// against; use [`rotate`](super::rotate::rotate) in practice.
pub fn rotate_fourth_order(t: &Tensor4, q: &Mat3) -> Tensor4 {
    let mut out = [[[[0.0; 3]; 3]; 3]; 3];
    for (i, oi) in out.iter_mut().enumerate() {
        for (j, oij) in oi.iter_mut().enumerate() {
            for (k, oijk) in oij.iter_mut().enumerate() {
                for (l, v) in oijk.iter_mut().enumerate() {
                    let mut s = 0.0;
                    for (a, ta) in t.iter().enumerate() {
                        for (b, tab) in ta.iter().enumerate() {
                            let qab = q[(i, a)] * q[(j, b)];
                            for (cc, tabc) in tab.iter().enumerate() {
                                let qabc = qab * q[(k, cc)];
                                for (d, &x) in tabc.iter().enumerate() {
                                    s += qabc * q[(l, d)] * x;
                                }
                            }
                        }
                    }
                    *v = s;
                }
            }
        }
    }
    out
}
