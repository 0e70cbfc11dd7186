//! How a scheme's magnitude becomes a spring constant (the `[geometry]` table of docs/formats.md).
//!
//! - `area`: k = magnitude·A_b, magnitude in Pa/m (PFC parallel bond, Potyondy & Cundall).
//! - `modulus`: k = magnitude·A_b/L_b, magnitude in Pa (Truszkowska 2018 Eqs. 6–7; Woo).
//! - `spring`: k = magnitude, in N/m.
//! - `kumar`: k = 2·magnitude·R*, R* = R_iR_j/(R_i+R_j), magnitude Σ in Pa (Kumar 2016 Eqs. 1–3).
//!
//! A_b = π̂·R_b² with R_b from [`BondRadius`]; L_b is the centre distance by default
//! (Woo: 2r′), or R_i + R_j (Truszkowska Eq. 7) with `bond_length = "radii-sum"`.

use serde::{Deserialize, Serialize};

/// Which formula turns a magnitude into a spring constant.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Convention {
    /// k = magnitude·A_b (Pa/m · m² = N/m).
    #[default]
    Area,
    /// k = magnitude·A_b/L_b (Pa · m = N/m).
    Modulus,
    /// k = magnitude (N/m).
    Spring,
    /// k = 2·magnitude·R* (Kumar 2016 Eq. 2).
    Kumar,
}

/// Bond radius R_b from the two sphere radii.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum BondRadius {
    /// min(R_i, R_j) (Šmilauer; PFC with λ = 1).
    #[default]
    Min,
    /// (R_i + R_j)/2.
    Mean,
    /// 2R_iR_j/(R_i + R_j).
    Harmonic,
}

/// Bond length L_b of the `modulus` convention.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum BondLength {
    /// The initial centre distance |l| (Woo's 2r′).
    #[default]
    CentreDistance,
    /// R_i + R_j (Truszkowska 2018 Eq. 7).
    RadiiSum,
}

/// Bending and twisting springs.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Moments {
    /// No rotational springs (k_r = k_tw = 0).
    #[default]
    None,
    /// Parallel bond (Potyondy & Cundall 2004): k_r = k_n·I/A = k_n·R_b²/4,
    /// k_tw = k_s·J/A = k_s·R_b²/2 (N·m/rad).
    ParallelBond,
    /// Kumar 2016 Eqs. 7–8: k_r = 2Σ_N R*³, k_tw = 4Σ_T R*³, written through k_n = 2Σ_N R*
    /// and k_s = 2Σ_T R*: k_r = k_n R*²,  k_tw = 2 k_s R*².
    Kumar,
}

/// The model's `[geometry]`: convention, bond radius, π̂, bond length and moments.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Geometry {
    /// Magnitude → spring constant.
    #[serde(deserialize_with = "crate::keys::convention")]
    pub convention: Convention,
    /// R_b rule.
    #[serde(deserialize_with = "crate::keys::bond_radius")]
    pub bond_radius: BondRadius,
    /// L_b rule (modulus convention only).
    #[serde(deserialize_with = "crate::keys::bond_length")]
    pub bond_length: BondLength,
    /// π̂ in A_b = π̂·R_b² (Šmilauer; Woo's C++ default is π).
    #[serde(deserialize_with = "crate::keys::pi_hat")]
    pub pi_hat: f64,
    /// Bending and twisting springs.
    #[serde(deserialize_with = "crate::keys::moments")]
    pub moments: Moments,
}

impl Default for Geometry {
    fn default() -> Self {
        Geometry {
            convention: Convention::Area,
            bond_radius: BondRadius::Min,
            bond_length: BondLength::CentreDistance,
            pi_hat: std::f64::consts::PI,
            moments: Moments::None,
        }
    }
}

/// The four springs of one bond.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Springs {
    /// Normal spring constant (N/m).
    pub kn: f64,
    /// Shear spring constant (N/m).
    pub ks: f64,
    /// Bending spring constant (N·m/rad).
    pub kr: f64,
    /// Twisting spring constant (N·m/rad).
    pub ktw: f64,
}

impl Geometry {
    /// Bond radius R_b (m).
    pub fn bond_radius(&self, ri: f64, rj: f64) -> f64 {
        match self.bond_radius {
            BondRadius::Min => ri.min(rj),
            BondRadius::Mean => 0.5 * (ri + rj),
            BondRadius::Harmonic => 2.0 * ri * rj / (ri + rj),
        }
    }

    /// Bond area A_b = π̂·R_b² (m²).
    pub fn bond_area(&self, ri: f64, rj: f64) -> f64 {
        let rb = self.bond_radius(ri, rj);
        self.pi_hat * rb * rb
    }

    /// The factor g with k = magnitude·g for a bond of radii `ri`, `rj` and centre
    /// distance `length` (units: m² for area, m for modulus and kumar, 1 for spring).
    pub fn factor(&self, ri: f64, rj: f64, length: f64) -> f64 {
        match self.convention {
            Convention::Area => self.bond_area(ri, rj),
            Convention::Modulus => {
                let lb = match self.bond_length {
                    BondLength::CentreDistance => length,
                    BondLength::RadiiSum => ri + rj,
                };
                self.bond_area(ri, rj) / lb
            }
            Convention::Spring => 1.0,
            Convention::Kumar => 2.0 * ri * rj / (ri + rj),
        }
    }

    /// The four springs of a bond from its magnitudes.
    pub fn springs(&self, m: super::Magnitudes, ri: f64, rj: f64, length: f64) -> Springs {
        let g = self.factor(ri, rj, length);
        let kn = m.normal * g;
        let ks = m.shear * g;
        let (kr, ktw) = match self.moments {
            Moments::None => (0.0, 0.0),
            Moments::ParallelBond => {
                let rb = self.bond_radius(ri, rj);
                (kn * rb * rb / 4.0, ks * rb * rb / 2.0)
            }
            Moments::Kumar => {
                let rs = ri * rj / (ri + rj);
                (kn * rs * rs, 2.0 * ks * rs * rs)
            }
        };
        Springs { kn, ks, kr, ktw }
    }

    /// Check π̂ is finite and positive.
    pub fn validate(&self) -> crate::Result<()> {
        if !self.pi_hat.is_finite() || self.pi_hat <= 0.0 {
            return Err(crate::Error::Model(format!(
                "[geometry] pi_hat must be > 0, got {}",
                self.pi_hat
            )));
        }
        Ok(())
    }
}
