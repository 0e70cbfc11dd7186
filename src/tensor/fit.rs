//! The symmetric 21-component stiffness fitted to strain paths (Truszkowska 2018,
//! Eqs. 23–27): each path p gives a strain-rate vector ε̇_p (Voigt, engineering shear
//! strain, 1/s) and the stress-rate vector σ̇_p (Voigt, Pa/s) it produced.

use super::{Stiffness6, Voigt6};
use crate::{Error, Result};

/// Upper-triangle entry (a, b), a ≤ b, of unknown number `u` (row-major, 21 in all).
fn unknowns() -> [(usize, usize); 21] {
    let mut list = [(0, 0); 21];
    let mut u = 0;
    for a in 0..6 {
        for b in a..6 {
            list[u] = (a, b);
            u += 1;
        }
    }
    list
}

fn symmetric_from_unknowns(x: &nalgebra::DVector<f64>) -> Stiffness6 {
    let mut c = Stiffness6::zeros();
    for (u, &(a, b)) in unknowns().iter().enumerate() {
        c[(a, b)] = x[u];
        c[(b, a)] = x[u];
    }
    c
}

/// Checks path counts, finiteness, and that the strain rates span all 6 Voigt
/// directions (smallest singular value of the 6×k strain matrix > 1e-10 × largest).
fn check_paths(strain_rates: &[Voigt6], stress_rates: &[Voigt6]) -> Result<()> {
    if strain_rates.len() != stress_rates.len() {
        return Err(Error::Invalid(format!(
            "stiffness fit: {} strain-rate vectors but {} stress-rate vectors; expected one \
             of each per strain path",
            strain_rates.len(),
            stress_rates.len()
        )));
    }
    let k = strain_rates.len();
    if k < 6 {
        return Err(Error::Invalid(format!(
            "stiffness fit: {k} strain paths, expected at least 6 (21 unknowns)"
        )));
    }
    for (p, (e, s)) in strain_rates.iter().zip(stress_rates).enumerate() {
        if e.iter().chain(s.iter()).any(|x| !x.is_finite()) {
            return Err(Error::Invalid(format!(
                "stiffness fit: strain path {p} has non-finite strain or stress rates"
            )));
        }
    }
    let strains = nalgebra::DMatrix::from_fn(6, k, |i, p| strain_rates[p][i]);
    let sv = strains.singular_values();
    let largest = sv.max();
    let smallest = sv.min();
    if smallest.is_nan() || smallest <= 1e-10 * largest {
        return Err(Error::Invalid(format!(
            "stiffness fit: the strain rates of the {k} paths do not span all 6 strain \
             components (singular values {largest:.3e} … {smallest:.3e}); add independent \
             paths"
        )));
    }
    Ok(())
}

/// Least-squares symmetric stiffness from k ≥ 6 strain paths:
/// the symmetric C (21 unknowns) minimising Σ_p |C ε̇_p − σ̇_p|² (Euclidean norm of the
/// Voigt stress-rate residual, all six components weighted 1, in Pa/s).
///
/// Relation to Truszkowska 2018 Eq. 27: for the paper's six paths with ε̇ ∝ identity
/// (or any set with Σ_p ε̇_p ε̇_pᵀ ∝ I) both give C = sym(A) with A the stress slopes, and
/// for noise-free data both recover the true C; otherwise Eq. 27 (symmetric part of the
/// residual set to zero, [`fit_symmetric_eq27`]) is a different, non-least-squares
/// estimate. Error on fewer than 6 paths, mismatched lengths, non-finite rates, or
/// strain rates that do not span all six components.
pub fn fit_symmetric(strain_rates: &[Voigt6], stress_rates: &[Voigt6]) -> Result<Stiffness6> {
    check_paths(strain_rates, stress_rates)?;
    let k = strain_rates.len();
    let mut design = nalgebra::DMatrix::<f64>::zeros(6 * k, 21);
    let mut rhs = nalgebra::DVector::<f64>::zeros(6 * k);
    for (p, (e, s)) in strain_rates.iter().zip(stress_rates).enumerate() {
        for i in 0..6 {
            rhs[6 * p + i] = s[i];
        }
        for (u, &(a, b)) in unknowns().iter().enumerate() {
            design[(6 * p + a, u)] += e[b];
            if a != b {
                design[(6 * p + b, u)] += e[a];
            }
        }
    }
    // Full column rank is guaranteed by check_paths (C ε̇_p = 0 for spanning ε̇ ⇒ C = 0);
    // the SVD tolerance only guards round-off.
    let svd = design.svd(true, true);
    let tol = 1e-13 * svd.singular_values.max();
    let x = svd
        .solve(&rhs, tol)
        .map_err(|m| Error::Invalid(format!("stiffness fit: least-squares solve failed: {m}")))?;
    Ok(symmetric_from_unknowns(&x))
}

/// Truszkowska 2018 Eq. 27 exactly, for the paper's six paths: the 21 equations
/// a_i^(k) + a_k^(i) = C_ij b_j^(k) + C_kj b_j^(i), i ≤ k, with a^(k) = σ̇ and b^(k) = ε̇ of
/// path k (paths numbered like the Voigt components they load). Needs exactly 6 paths;
/// error if the system is singular. See [`fit_symmetric`] for how the two differ.
pub fn fit_symmetric_eq27(strain_rates: &[Voigt6], stress_rates: &[Voigt6]) -> Result<Stiffness6> {
    check_paths(strain_rates, stress_rates)?;
    if strain_rates.len() != 6 {
        return Err(Error::Invalid(format!(
            "stiffness fit (Truszkowska Eq. 27): {} strain paths, expected exactly 6",
            strain_rates.len()
        )));
    }
    let list = unknowns();
    let unknown_of = |a: usize, b: usize| {
        let (a, b) = if a <= b { (a, b) } else { (b, a) };
        list.iter().position(|&ab| ab == (a, b)).unwrap_or(0)
    };
    let mut m = nalgebra::DMatrix::<f64>::zeros(21, 21);
    let mut rhs = nalgebra::DVector::<f64>::zeros(21);
    for (row, &(i, k)) in list.iter().enumerate() {
        rhs[row] = stress_rates[k][i] + stress_rates[i][k];
        for j in 0..6 {
            m[(row, unknown_of(i, j))] += strain_rates[k][j];
            m[(row, unknown_of(k, j))] += strain_rates[i][j];
        }
    }
    let x = m.lu().solve(&rhs).ok_or_else(|| {
        Error::Invalid(
            "stiffness fit (Truszkowska Eq. 27): the 21 equations are singular for these \
             strain paths"
                .into(),
        )
    })?;
    if x.iter().any(|v| !v.is_finite()) {
        return Err(Error::Invalid(
            "stiffness fit (Truszkowska Eq. 27): solution is not finite (singular system)".into(),
        ));
    }
    Ok(symmetric_from_unknowns(&x))
}
