//! The relaxed CG's two-level coarse space when a many-body term is present.
//!
//! A term whose D is stiff in one strain direction (the calibrated metals: copper's D has
//! C11 + 2C12 ≈ 44 (C11 − C12)) makes the smooth, nearly volume-preserving fluctuations the
//! slow modes of the CG: a rigid motion per aggregate approximates them with jumps between
//! aggregates whose fitted strains the term's stiff direction penalises. Adding the six
//! uniform-strain modes of every aggregate (u = ε·d, ω = 0; the piecewise-affine coarse
//! space of smoothed/strain aggregation) leaves jumps of second order in the aggregate's size.
//! The coarse operator is PᵀKP with K the springs' assembled blocks plus the term's Hessian
//! applied in factored form ([`TermOperator::times_prolongation`]), built once per solve.

use super::network::Block6;
use super::sparse::BlockSparse;
use super::term_operator::TermOperator;
use super::two_level::{CoarseLayer, TwoLevel};
use crate::tensor::Stiffness6;
use crate::{Result, Vec3};

/// Fewest nodes an aggregate needs to keep its strain modes: with fewer, the six modes on
/// 3 translations per node are (nearly) dependent on the rigid ones; they are dropped there
/// (zero prolongation, a null coarse node the factorisation removes).
const MIN_STRAIN_MEMBERS: usize = 12;

/// The uniform-strain modes at arm `d` (in units of the cells' edge): u = E d with E the
/// symmetric strain of the engineering Voigt vector (ε11, ε22, ε33, γ23, γ13, γ12); ω = 0.
pub(crate) fn strain_modes(d: &Vec3, members: usize) -> Block6 {
    let mut p = Block6::zeros();
    if members < MIN_STRAIN_MEMBERS {
        return p;
    }
    let h = 0.5;
    // u_x = ε11 dx + γ12/2 dy + γ13/2 dz
    p[(0, 0)] = d.x;
    p[(0, 5)] = h * d.y;
    p[(0, 4)] = h * d.z;
    // u_y = γ12/2 dx + ε22 dy + γ23/2 dz
    p[(1, 5)] = h * d.x;
    p[(1, 1)] = d.y;
    p[(1, 3)] = h * d.z;
    // u_z = γ13/2 dx + γ23/2 dy + ε33 dz
    p[(2, 4)] = h * d.x;
    p[(2, 3)] = h * d.y;
    p[(2, 2)] = d.z;
    p
}

/// Kelvin-form contrast of the term's D at and above which the strain modes are added.
/// Measured (docs/manybody.md, "Cost of the relaxed solve"): an isotropic D of contrast 5
/// (K' = 10, G' = 3 GPa, 30,700 particles) converges in 54 instead of 86 iterations with
/// them but takes 1.8× the time; nickel's D (contrast 14, 8,000 particles) 240 instead of
/// 584 iterations for 28 % less CPU time on one thread. The threshold lies between the two.
pub(crate) const STRAIN_MODES_CONTRAST: f64 = 10.0;

/// The ratio of the largest to the smallest eigenvalue of D in Kelvin (Mandel) form, where
/// the shear rows and columns of the engineering Voigt matrix are scaled by √2 so that the
/// eigenvalues are the stiffnesses of the eigen-strains (cubic: C11 + 2C12, C11 − C12 and
/// 2C44). Infinite for a D that is not positive definite.
pub(crate) fn kelvin_contrast(d: &Stiffness6) -> f64 {
    let s = [1.0, 1.0, 1.0, 2f64.sqrt(), 2f64.sqrt(), 2f64.sqrt()];
    let kelvin = Stiffness6::from_fn(|i, j| s[i] * d[(i, j)] * s[j]);
    let eig = kelvin.symmetric_eigenvalues();
    let (lo, hi) = (eig.min(), eig.max());
    if lo > 0.0 {
        hi / lo
    } else {
        f64::INFINITY
    }
}

/// The two-level coarse space of K = springs + term. Where a D is stiff in one strain
/// direction ([`kelvin_contrast`] ≥ [`STRAIN_MODES_CONTRAST`]): rigid and uniform-strain
/// modes on aggregates of about a quarter of `per_aggregate` nodes (at least
/// `per_aggregate` or 12, whichever is fewer); otherwise the rigid modes alone on
/// aggregates of `per_aggregate`, with the term's K'P (`positions` inside the periodic box
/// `box_lengths`).
pub(crate) fn coarse_space(
    springs: &BlockSparse,
    term: &TermOperator,
    positions: &[Vec3],
    box_lengths: Vec3,
    rotations: bool,
    per_aggregate: usize,
) -> Result<TwoLevel> {
    // Smaller aggregates than the springs' (a quarter: 32 by default) with the strain modes:
    // measured on 8,000 particles with nickel's D, 240 iterations against 584 of the rigid
    // modes on aggregates of 128, for 28 % less CPU time (docs/manybody.md).
    let contrast = term
        .tensors()
        .iter()
        .map(kelvin_contrast)
        .fold(0.0, f64::max);
    if contrast < STRAIN_MODES_CONTRAST {
        return TwoLevel::with_extra(
            springs,
            positions,
            box_lengths,
            rotations,
            per_aggregate,
            |aggregate, prolongation| Some(term.times_prolongation(aggregate, prolongation)),
        );
    }
    let per_aggregate = (per_aggregate / 4).max(per_aggregate.min(MIN_STRAIN_MEMBERS));
    let strain_layer: CoarseLayer = &strain_modes;
    TwoLevel::with_layers(
        springs,
        positions,
        box_lengths,
        (rotations, per_aggregate),
        &[strain_layer],
        |aggregate, prolongation| Some(term.times_prolongation(aggregate, prolongation)),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A cubic D's Kelvin eigenvalues are C11 + 2C12, C11 − C12 and 2C44 (closed form).
    #[test]
    fn kelvin_contrast_of_cubic_tensors_is_the_closed_form() {
        for (c11, c12, c44) in [
            (195.41, 182.64, 68.13),
            (175.92, 143.33, 103.72),
            (13.0, 7.0, 3.0),
        ] {
            let mut d = Stiffness6::zeros();
            for i in 0..3 {
                for j in 0..3 {
                    d[(i, j)] = if i == j { c11 } else { c12 };
                }
                d[(i + 3, i + 3)] = c44;
            }
            let eig = [c11 + 2.0 * c12, c11 - c12, 2.0 * c44];
            let want = eig.iter().cloned().fold(0.0, f64::max)
                / eig.iter().cloned().fold(f64::INFINITY, f64::min);
            let got = kelvin_contrast(&d);
            assert!((got - want).abs() <= 1e-12 * want, "{got} vs {want}");
        }
        // Isotropic K' = 10, G' = 3: 3K'/2G' = 5, below the threshold; copper's D above it.
        let (k, g) = (10.0, 3.0);
        let iso = (k + 4.0 * g / 3.0, k - 2.0 * g / 3.0, g);
        let mut d = Stiffness6::zeros();
        for i in 0..3 {
            for j in 0..3 {
                d[(i, j)] = if i == j { iso.0 } else { iso.1 };
            }
            d[(i + 3, i + 3)] = iso.2;
        }
        assert!((kelvin_contrast(&d) - 5.0).abs() < 1e-12);
        assert!(kelvin_contrast(&d) < STRAIN_MODES_CONTRAST);
        let mut neg = d;
        neg[(0, 0)] = -1.0;
        assert!(kelvin_contrast(&neg).is_infinite());
    }
}
