//! Independent references the tests write out themselves, never the library's code: the
//! textbook cubic tensor turned by an explicit fourth-order rotation, and the brute-force
//! nearest grain centre with the minimum image by whole cells.
#![allow(dead_code)]

use anisobond::tensor::Stiffness6;
use anisobond::{Mat3, Vec3};

/// The textbook cubic tensor in its crystal axes, D_abcd = C12 δ_ab δ_cd + C44 (δ_ac δ_bd +
/// δ_ad δ_bc) + (C11 − C12 − 2 C44) [a = b = c = d] (Voigt constants C11, C12, C44).
pub fn cubic4(c11: f64, c12: f64, c44: f64) -> impl Fn(usize, usize, usize, usize) -> f64 {
    move |a, b, c, e| {
        let delta = |x: usize, y: usize| if x == y { 1.0 } else { 0.0 };
        let mut v = c12 * delta(a, b) * delta(c, e)
            + c44 * (delta(a, c) * delta(b, e) + delta(a, e) * delta(b, c));
        if a == b && b == c && c == e {
            v += c11 - c12 - 2.0 * c44;
        }
        v
    }
}

/// The fourth-order tensor of a Voigt matrix, C_ijkl = C6[a, b] for (i, j) ↔ a and (k, l) ↔ b
/// (no factors; pairs 11, 22, 33, 23, 13, 12), so that `rotate4(voigt4(c), q)` turns `c`.
pub fn voigt4(c: &Stiffness6) -> impl Fn(usize, usize, usize, usize) -> f64 + '_ {
    let index = |i: usize, j: usize| match (i.min(j), i.max(j)) {
        (0, 0) => 0,
        (1, 1) => 1,
        (2, 2) => 2,
        (1, 2) => 3,
        (0, 2) => 4,
        _ => 5,
    };
    move |i, j, k, l| c[(index(i, j), index(k, l))]
}

/// The fourth-order tensor `d` turned by Q, D'_ijkl = Σ_abcd Q_ia Q_jb Q_kc Q_ld D_abcd,
/// written out as a Voigt matrix (engineering strain; pairs 11, 22, 33, 23, 13, 12): the
/// tests' reference for rotate(D, Q), independent of the library's rotation.
pub fn rotate4(d: impl Fn(usize, usize, usize, usize) -> f64, q: &Mat3) -> Stiffness6 {
    let pairs = [(0, 0), (1, 1), (2, 2), (1, 2), (0, 2), (0, 1)];
    Stiffness6::from_fn(|r, s| {
        let ((i, j), (k, l)) = (pairs[r], pairs[s]);
        let mut acc = 0.0;
        for a in 0..3 {
            for b in 0..3 {
                for c in 0..3 {
                    for e in 0..3 {
                        acc += q[(i, a)] * q[(j, b)] * q[(k, c)] * q[(l, e)] * d(a, b, c, e);
                    }
                }
            }
        }
        acc
    })
}

/// The nearest of `centres` to `x` by brute force, in an orthorhombic periodic cell of edges
/// `l` (each difference brought into [−L/2, L/2] by whole cells; the plain distance when `l`
/// is None), the lower index on a tie.
pub fn nearest_centre(x: &Vec3, centres: &[Vec3], l: Option<Vec3>) -> usize {
    let mut best = (f64::INFINITY, 0);
    for (g, c) in centres.iter().enumerate() {
        let mut d2 = 0.0;
        for k in 0..3 {
            let mut d = x[k] - c[k];
            if let Some(l) = l {
                while d > 0.5 * l[k] {
                    d -= l[k];
                }
                while d < -0.5 * l[k] {
                    d += l[k];
                }
            }
            d2 += d * d;
        }
        if d2 < best.0 {
            best = (d2, g);
        }
    }
    best.1
}
