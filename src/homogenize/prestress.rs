//! The tangent stiffness of a bonded assembly deformed from a loaded (pre-stressed) state.
//!
//! A DEM element test measures the Love stress σ = (1/V)Σ f⊗l of the current configuration
//! against the strain applied from the state where the test starts. When the bonds already
//! carry forces there (bonds installed on a confined packing, locked-in contact forces), the
//! bond forces turn with the bonds and the volume changes, so the measured tangent is not the
//! spring tensor. For axial preloads N_b (tension positive) with Σ_b N_b l_b n_b⊗n_b = Vσ⁰:
//!
//! - the energy tangent A (first Piola–Kirchhoff stress against the displacement gradient)
//!   is the relaxed tensor of the network with each bond's geometric element
//!   S_g = (N/l)(I − nn) ([`super::network::geometric_element`]) — affine part
//!   A_ijkl += (1/V)Σ N l (δ_ik − n_in_k) n_jn_l, and the fluctuations relax against it;
//! - the Cauchy (Love) stress increment under a symmetric strain ε follows from P = Jσ F⁻ᵀ:
//!   Δσ = sym(A:ε) − σ⁰ tr ε + sym(σ⁰ ε), which is what [`PrestressedTensor::c`] holds.
//!
//! Under an isotropic preload σ⁰ = −p I of an isotropic bond distribution the affine terms are
//! ΔC11 = −2p/5, ΔC12 = +6p/5, ΔC44 = −4p/5: a compressive preload raises C12 and lowers
//! C44, which no stress-free central-plus-shear network can (Truszkowska 2018 App. D; the
//! Eq. 30 study in docs/prestress.md).

use super::relaxed::{relaxed_solve, relaxed_solve_full, RelaxedOptions, RelaxedResult};
use crate::bonds::{BondSet, BondStiffness};
use crate::packing::Packing;
use crate::tensor::{strain_tensor, Stiffness6, Voigt6, VOIGT_PAIRS};
use crate::{Error, Mat3, Result, Vec3};

/// Every bond's axial preload N (N, tension positive), aligned with a [`BondSet`].
#[derive(Clone, Debug, PartialEq)]
pub struct Prestress {
    /// Axial force of every bond (N); negative in compression.
    pub axial_force: Vec<f64>,
}

impl Prestress {
    /// Preloads given bond by bond; refuses a non-finite entry (naming the bond).
    pub fn from_axial_forces(axial_force: Vec<f64>) -> Result<Prestress> {
        if let Some(b) = axial_force.iter().position(|f| !f.is_finite()) {
            return Err(Error::Invalid(format!(
                "prestress: axial force of bond {b} is {}",
                axial_force[b]
            )));
        }
        Ok(Prestress { axial_force })
    }

    /// The axial forces of the bonds' central springs k_n alone (a frictionless network: no
    /// shear springs, no moments) held at the uniform strain `strain` (Voigt, engineering)
    /// and relaxed: N_b = k_n n·(u_j − u_i + ε·l). Only central forces, so the preloads are
    /// self-equilibrated and their geometric terms are complete; a central network with local
    /// mechanisms (a sphere held by fewer than four bonds) cannot be preloaded and is an error.
    pub fn central_from_strain(
        packing: &Packing,
        bonds: &BondSet,
        k: &BondStiffness,
        strain: &Voigt6,
        opts: &RelaxedOptions,
    ) -> Result<Prestress> {
        let zero = vec![0.0; k.len()];
        let central = BondStiffness {
            radius: k.radius.clone(),
            kn: k.kn.clone(),
            ks: zero.clone(),
            kr: zero.clone(),
            ktw: zero,
        };
        let opts = RelaxedOptions {
            rotations: false,
            ..*opts
        };
        let sol = relaxed_solve(packing, bonds, &central, &opts, None)?;
        let mut index = vec![u32::MAX; packing.len()];
        for (a, &p) in sol.active.iter().enumerate() {
            index[p as usize] = a as u32;
        }
        // Fluctuation of particle p under the strain: −Q_p·e (translations only).
        let fluct = |p: u32| -> Vec3 {
            match index[p as usize] {
                u32::MAX => Vec3::zeros(),
                a => -(sol.q[a as usize] * strain).fixed_rows::<3>(0).into_owned(),
            }
        };
        let eps = strain_tensor(strain);
        let axial: Vec<f64> = (0..bonds.len())
            .map(|b| {
                let (i, j) = (bonds.i[b], bonds.j[b]);
                if index[i as usize] == u32::MAX || index[j as usize] == u32::MAX {
                    return 0.0;
                }
                let n = bonds.normal[b];
                k.kn[b] * n.dot(&(fluct(j) - fluct(i) + eps * (n * bonds.length[b])))
            })
            .collect();
        let prestress = Prestress { axial_force: axial };
        let unbalance = prestress.unbalance(packing, bonds);
        if unbalance > UNBALANCE_LIMIT {
            return Err(Error::Degenerate(format!(
                "prestress: the central network cannot carry the strain in equilibrium (net \
                 force on a sphere {unbalance:.2e} of the largest bond force > {UNBALANCE_LIMIT:e}: \
                 spheres held by too few bonds)"
            )));
        }
        Ok(prestress)
    }

    /// The central preloads ([`Prestress::central_from_strain`]) of an isotropic compression,
    /// scaled to the mean stress −`pressure` (Pa; positive in compression).
    pub fn isotropic(
        packing: &Packing,
        bonds: &BondSet,
        k: &BondStiffness,
        pressure: f64,
        opts: &RelaxedOptions,
    ) -> Result<Prestress> {
        if !pressure.is_finite() {
            return Err(Error::Invalid(format!(
                "prestress: the pressure must be finite, got {pressure}"
            )));
        }
        let unit = Voigt6::new(-1e-3, -1e-3, -1e-3, 0.0, 0.0, 0.0);
        let pre = Prestress::central_from_strain(packing, bonds, k, &unit, opts)?;
        let p0 = -pre.stress(bonds, packing.volume()).trace() / 3.0;
        if p0.is_nan() || p0 <= 0.0 {
            return Err(Error::Degenerate(
                "prestress: the central network carries no pressure under compression".into(),
            ));
        }
        Ok(pre.scaled(pressure / p0))
    }

    /// The Love stress σ⁰ = (1/V)Σ N l n⊗n of the preloads (Pa).
    pub fn stress(&self, bonds: &BondSet, volume: f64) -> Mat3 {
        let mut s = Mat3::zeros();
        for b in 0..bonds.len() {
            let n = bonds.normal[b];
            s += n * n.transpose() * (self.axial_force[b] * bonds.length[b]);
        }
        s / volume
    }

    /// The same preloads times `factor`.
    pub fn scaled(&self, factor: f64) -> Prestress {
        Prestress {
            axial_force: self.axial_force.iter().map(|f| f * factor).collect(),
        }
    }

    /// Largest net axial force on a particle, |Σ ±N n|, relative to the largest |N|: zero for
    /// a self-equilibrated set of central preloads.
    pub fn unbalance(&self, packing: &Packing, bonds: &BondSet) -> f64 {
        let mut net = vec![Vec3::zeros(); packing.len()];
        let mut largest = 0.0f64;
        for b in 0..bonds.len() {
            let f = bonds.normal[b] * self.axial_force[b];
            net[bonds.i[b] as usize] += f;
            net[bonds.j[b] as usize] -= f;
            largest = largest.max(self.axial_force[b].abs());
        }
        if largest == 0.0 {
            return 0.0;
        }
        net.iter().map(|v| v.norm()).fold(0.0, f64::max) / largest
    }
}

/// Largest [`Prestress::unbalance`] accepted for preloads derived from a strain.
pub const UNBALANCE_LIMIT: f64 = 1e-4;

/// The tangent of a pre-stressed assembly.
#[derive(Clone, Debug)]
pub struct PrestressedTensor {
    /// Love (Cauchy) stress increment per unit engineering strain (Pa): what an element test
    /// started from the loaded state measures.
    pub c: Stiffness6,
    /// The energy tangent A (relaxed, with the geometric elements), in Voigt form (Pa).
    pub c_energy: Stiffness6,
    /// The preload stress σ⁰ (Pa).
    pub stress: Mat3,
    /// The relaxed solve (its `c` is `c_energy`; `c_affine` the affine energy tangent).
    pub relaxed: RelaxedResult,
}

/// The relaxed tangent of the assembly under the preloads (module doc). The linearisation is
/// about a rest state: preloads that are not self-equilibrated ([`Prestress::unbalance`])
/// make the result the quadratic part only; a preload that makes the network unstable is an
/// error (the CG meets negative curvature).
pub fn prestressed_tensor(
    packing: &Packing,
    bonds: &BondSet,
    k: &BondStiffness,
    prestress: &Prestress,
    opts: &RelaxedOptions,
) -> Result<PrestressedTensor> {
    if prestress.axial_force.len() != bonds.len() {
        return Err(Error::Invalid(format!(
            "prestress: {} bonds but {} axial forces",
            bonds.len(),
            prestress.axial_force.len()
        )));
    }
    let preload = Some(prestress.axial_force.as_slice());
    let sol = relaxed_solve_full(packing, bonds, k, opts, None, preload, None)?;
    let stress = prestress.stress(bonds, packing.volume());
    let c = sol.result.c + stress_measure_correction(&stress);
    Ok(PrestressedTensor {
        c,
        c_energy: sol.result.c,
        stress,
        relaxed: sol.result,
    })
}

/// The terms that turn the energy tangent into the Cauchy-stress tangent under a symmetric
/// strain: Δσ − sym(A:ε) = −σ⁰ tr ε + sym(σ⁰ ε), as a Voigt 6×6 (engineering strain).
pub fn stress_measure_correction(stress: &Mat3) -> Stiffness6 {
    let mut c = Stiffness6::zeros();
    for b in 0..6 {
        let e = strain_tensor(&Voigt6::from_fn(|a, _| if a == b { 1.0 } else { 0.0 }));
        let se = stress * e;
        let d = -stress * e.trace() + (se + se.transpose()) * 0.5;
        for (a, &(i, j)) in VOIGT_PAIRS.iter().enumerate() {
            c[(a, b)] = d[(i, j)];
        }
    }
    c
}
