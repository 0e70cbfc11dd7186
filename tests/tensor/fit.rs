//! The symmetric 21-component fit (Truszkowska 2018 Eqs. 23–27).

use anisobond::tensor::{
    fit_symmetric, fit_symmetric_eq27, relative_difference, Stiffness6, Voigt6,
};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

fn random_spd(rng: &mut ChaCha8Rng) -> Stiffness6 {
    let a = Stiffness6::from_fn(|_, _| rng.gen_range(-1.0..1.0));
    (a * a.transpose() + Stiffness6::identity()) * 3e10
}

fn random_paths(rng: &mut ChaCha8Rng, k: usize) -> Vec<Voigt6> {
    (0..k)
        .map(|_| Voigt6::from_fn(|_, _| rng.gen_range(-0.2..0.2)))
        .collect()
}

/// Independent reference: the normal equations of min Σ_p |C ε_p − σ_p|² over symmetric
/// C = Σ_u x_u B_u, with B_u the 21 symmetric basis matrices (E_ab + E_ba, or E_aa):
/// Σ_v (Σ_p (B_u ε_p)·(B_v ε_p)) x_v = Σ_p (B_u ε_p)·σ_p, solved by Cholesky.
fn normal_equation_fit(strains: &[Voigt6], stresses: &[Voigt6]) -> Stiffness6 {
    let mut basis = Vec::new();
    for a in 0..6 {
        for b in a..6 {
            let mut m = Stiffness6::zeros();
            m[(a, b)] = 1.0;
            m[(b, a)] = 1.0;
            basis.push(m);
        }
    }
    let n = basis.len();
    let mut g = nalgebra::DMatrix::<f64>::zeros(n, n);
    let mut r = nalgebra::DVector::<f64>::zeros(n);
    for (e, s) in strains.iter().zip(stresses) {
        let images: Vec<Voigt6> = basis.iter().map(|b| b * e).collect();
        for u in 0..n {
            r[u] += images[u].dot(s);
            for v in 0..n {
                g[(u, v)] += images[u].dot(&images[v]);
            }
        }
    }
    let x = g.cholesky().unwrap().solve(&r);
    basis
        .iter()
        .zip(x.iter())
        .fold(Stiffness6::zeros(), |acc, (b, xv)| acc + b * *xv)
}

#[test]
fn exact_data_recovers_the_tensor() {
    let mut rng = ChaCha8Rng::seed_from_u64(21);
    for k in [6, 9] {
        let c = random_spd(&mut rng);
        let strains = random_paths(&mut rng, k);
        let stresses: Vec<Voigt6> = strains.iter().map(|e| c * e).collect();
        let fitted = fit_symmetric(&strains, &stresses).unwrap();
        assert!(relative_difference(&fitted, &c) < 1e-10);
        if k == 6 {
            let eq27 = fit_symmetric_eq27(&strains, &stresses).unwrap();
            assert!(relative_difference(&eq27, &c) < 1e-10);
        }
    }
}

#[test]
fn noisy_data_gives_the_least_squares_solution() {
    let mut rng = ChaCha8Rng::seed_from_u64(22);
    let c = random_spd(&mut rng);
    for k in [6, 12] {
        let strains = random_paths(&mut rng, k);
        let stresses: Vec<Voigt6> = strains
            .iter()
            .map(|e| c * e + Voigt6::from_fn(|_, _| rng.gen_range(-1e8..1e8)))
            .collect();
        let fitted = fit_symmetric(&strains, &stresses).unwrap();
        let reference = normal_equation_fit(&strains, &stresses);
        assert!(relative_difference(&fitted, &reference) < 1e-10);
        assert!(relative_difference(&fitted, &c) > 1e-6); // the noise is really there
        assert_eq!(fitted, fitted.transpose());
    }
}

#[test]
fn identity_strains_give_the_symmetric_part() {
    // The paper's six paths with unit strain rates: stress slopes A (column k = path k);
    // least squares and Eq. 27 both give sym(A).
    let mut rng = ChaCha8Rng::seed_from_u64(23);
    let a = Stiffness6::from_fn(|_, _| rng.gen_range(-1e9..1e9)) + Stiffness6::identity() * 1e10;
    let rate = 0.2;
    let strains: Vec<Voigt6> = (0..6).map(|k| Voigt6::ith(k, rate)).collect();
    let stresses: Vec<Voigt6> = (0..6).map(|k| a.column(k) * rate).collect();
    let sym = 0.5 * (a + a.transpose());
    let fitted = fit_symmetric(&strains, &stresses).unwrap();
    assert!(relative_difference(&fitted, &sym) < 1e-12);
    let eq27 = fit_symmetric_eq27(&strains, &stresses).unwrap();
    assert!(relative_difference(&eq27, &sym) < 1e-12);
}

#[test]
fn too_few_or_degenerate_paths_are_refused() {
    let mut rng = ChaCha8Rng::seed_from_u64(24);
    let c = random_spd(&mut rng);
    let strains = random_paths(&mut rng, 5);
    let stresses: Vec<Voigt6> = strains.iter().map(|e| c * e).collect();
    let msg = fit_symmetric(&strains, &stresses).unwrap_err().to_string();
    assert!(msg.contains("at least 6"), "{msg}");
    // Seven paths that never shear in 12: rank 5.
    let mut flat = random_paths(&mut rng, 7);
    for e in &mut flat {
        e[5] = 0.0;
    }
    let stresses: Vec<Voigt6> = flat.iter().map(|e| c * e).collect();
    let msg = fit_symmetric(&flat, &stresses).unwrap_err().to_string();
    assert!(msg.contains("span"), "{msg}");
    assert!(fit_symmetric(&flat, &stresses[..6]).is_err());
}

#[test]
fn eq27_differs_from_least_squares_for_general_noisy_paths() {
    // Documented in fit_symmetric: Eq. 27 zeroes the symmetric part of the residual
    // sym(C B − A) instead of the least-squares gradient sym((C B − A) Bᵀ).
    let mut rng = ChaCha8Rng::seed_from_u64(25);
    let c = random_spd(&mut rng);
    let strains = random_paths(&mut rng, 6);
    let stresses: Vec<Voigt6> = strains
        .iter()
        .map(|e| c * e + Voigt6::from_fn(|_, _| rng.gen_range(-1e8..1e8)))
        .collect();
    let ls = fit_symmetric(&strains, &stresses).unwrap();
    let eq27 = fit_symmetric_eq27(&strains, &stresses).unwrap();
    // Eq. 27 residual: sym(C B − A) = 0 holds for eq27, not for ls.
    let b = Stiffness6::from_fn(|i, k| strains[k][i]);
    let a = Stiffness6::from_fn(|i, k| stresses[k][i]);
    let sym_residual = |m: &Stiffness6| {
        let r = m * b - a;
        (r + r.transpose()).amax()
    };
    assert!(sym_residual(&eq27) < 1e-6 * a.amax());
    assert!(sym_residual(&ls) > 1e-4 * a.amax());
    assert!(relative_difference(&ls, &eq27) > 1e-6);
}
