//! Mean-field cubic constants of the spheroid scheme as 1-D orientation integrals.
//!
//! The mean-field tensor (Truszkowska 2018 App. A) is C = P·⟨C_bond(n; k_n, k_s)⟩ with
//! C_bond the lattice tensor of one bond. For a scheme with the cubic symmetry its cubic
//! constants follow from the O_h-averaged integrands, with q = n₁²n₂² + n₂²n₃² + n₃²n₁²:
//!
//! C11 = P⟨k_n(1 − 2q)/3 + k_s·2q/3⟩,  C12 = P⟨(k_n − k_s)q/3⟩,  C44 = P⟨k_n q/3 + k_s(1/6 − q/3)⟩
//!
//! (average C1111, C2222, C3333 etc. of C_ijkl = k_n nnnn + k_s[sym(δnn) − nnnn]; with
//! k_s ≡ 0 this is the Cauchy relation C12 = C44). The tensor is linear in the two
//! magnitudes, so C = P·normal·(N(a_n) + ρ·S(a_s)) with ρ = shear/normal, and N depends on
//! a_n only, S on a_s only. Integrals are taken over one of the 48 fundamental triangles
//! 0 ≤ n_z ≤ n_y ≤ n_x (weight ×48), split along every plane where an envelope may kink.

use crate::homogenize::mean_field::{SphereQuadrature, DEFAULT_ORDER};
use crate::schemes::cubic::{AxisFamily, CubicModel, EXTENSION_WEIGHT_110};
use crate::Vec3;

/// Cubic constants (C11, C12, C44) of an orientation integral, per unit prefactor and unit
/// magnitude.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Cubic3 {
    /// C11.
    pub c11: f64,
    /// C12.
    pub c12: f64,
    /// C44.
    pub c44: f64,
}

impl Cubic3 {
    /// self + ρ·other.
    pub fn plus_scaled(&self, rho: f64, other: &Cubic3) -> Cubic3 {
        Cubic3 {
            c11: self.c11 + rho * other.c11,
            c12: self.c12 + rho * other.c12,
            c44: self.c44 + rho * other.c44,
        }
    }

    /// self − other.
    pub fn minus(&self, other: &Cubic3) -> Cubic3 {
        Cubic3 {
            c11: self.c11 - other.c11,
            c12: self.c12 - other.c12,
            c44: self.c44 - other.c44,
        }
    }

    /// (C12/C11, C44/C11).
    pub fn ratios(&self) -> (f64, f64) {
        (self.c12 / self.c11, self.c44 / self.c11)
    }
}

/// Quadrature of the fundamental triangle with q precomputed.
#[derive(Clone, Debug)]
pub struct CubicKernel {
    /// The split-sphere rule restricted to the fundamental triangle, weights ×48 (they sum
    /// to 1 over the fundamental triangle).
    rule: SphereQuadrature,
    q: Vec<f64>,
}

impl Default for CubicKernel {
    fn default() -> Self {
        Self::new(DEFAULT_ORDER)
    }
}

impl CubicKernel {
    /// The kernel with `order` Gauss points per direction in every smooth piece.
    pub fn new(order: usize) -> CubicKernel {
        let mut planes = Vec::new();
        for family in [
            AxisFamily::Axes100,
            AxisFamily::Axes111,
            AxisFamily::Axes110,
        ] {
            planes.extend(family.switch_planes());
        }
        let full = SphereQuadrature::new(&planes, order);
        let mut directions = Vec::new();
        let mut weights = Vec::new();
        let mut q = Vec::new();
        for (n, w) in full.directions.iter().zip(&full.weights) {
            // Gauss points lie strictly inside pieces, and no piece straddles a mirror plane
            // (the {100} and {110} planes are among the <111> switch planes).
            if n.x > n.y && n.y > n.z && n.z > 0.0 {
                directions.push(*n);
                weights.push(48.0 * w);
                let (x2, y2, z2) = (n.x * n.x, n.y * n.y, n.z * n.z);
                q.push(x2 * y2 + y2 * z2 + z2 * x2);
            }
        }
        CubicKernel {
            rule: SphereQuadrature {
                directions,
                weights,
            },
            q,
        }
    }

    /// Number of quadrature directions.
    pub fn len(&self) -> usize {
        self.rule.len()
    }

    /// True when empty (never, for order ≥ 1).
    pub fn is_empty(&self) -> bool {
        self.rule.is_empty()
    }

    /// Sum of the weights (1 up to rounding).
    pub fn total_weight(&self) -> f64 {
        self.rule.weights.iter().sum()
    }

    /// Normal factor f_n(m) of the model (Truszkowska 2018 Eqs. 8–15; Sec. 6.1 extended).
    pub fn normal_factor(model: CubicModel, extended: bool, m: &Vec3, a: f64) -> f64 {
        let mut f = model.normal_family().envelope(m, a);
        if extended {
            f += EXTENSION_WEIGHT_110 * AxisFamily::Axes110.envelope(m, a);
        }
        f
    }

    /// Shear factor f_s(m) of the model.
    pub fn shear_factor(model: CubicModel, extended: bool, m: &Vec3, a: f64) -> f64 {
        let mut f = model.shear_family().envelope(m, a);
        if extended {
            f -= EXTENSION_WEIGHT_110 * AxisFamily::Axes110.envelope(m, a);
        }
        f
    }

    /// The quadrature sums Σ w·f(m) and Σ w·f(m)·q(m) of a factor f over the directions.
    fn moments(&self, factor: impl Fn(&Vec3) -> f64) -> (f64, f64) {
        let (mut s0, mut s1) = (0.0, 0.0);
        for ((m, w), q) in self
            .rule
            .directions
            .iter()
            .zip(&self.rule.weights)
            .zip(&self.q)
        {
            let f = w * factor(m);
            s0 += f;
            s1 += f * q;
        }
        (s0, s1)
    }

    /// N(a_n): the cubic constants of the normal springs alone (unit magnitude, unit
    /// prefactor).
    pub fn normal_part(&self, model: CubicModel, extended: bool, a_n: f64) -> Cubic3 {
        let (s0, s1) = self.moments(|m| Self::normal_factor(model, extended, m, a_n));
        Cubic3 {
            c11: (s0 - 2.0 * s1) / 3.0,
            c12: s1 / 3.0,
            c44: s1 / 3.0,
        }
    }

    /// S(a_s): the cubic constants of the shear springs alone (unit magnitude, unit
    /// prefactor).
    pub fn shear_part(&self, model: CubicModel, extended: bool, a_s: f64) -> Cubic3 {
        let (s0, s1) = self.moments(|m| Self::shear_factor(model, extended, m, a_s));
        Cubic3 {
            c11: 2.0 * s1 / 3.0,
            c12: -s1 / 3.0,
            c44: s0 / 6.0 - s1 / 3.0,
        }
    }

    /// The mean-field constants per unit prefactor and unit normal magnitude,
    /// N(a_n) + ρ·S(a_s).
    pub fn constants(
        &self,
        model: CubicModel,
        extended: bool,
        a_n: f64,
        a_s: f64,
        shear_over_normal: f64,
    ) -> Cubic3 {
        self.normal_part(model, extended, a_n)
            .plus_scaled(shear_over_normal, &self.shear_part(model, extended, a_s))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn isotropic_moments() {
        // a = 1: f ≡ 1; ⟨n₁⁴⟩ = 1/5, ⟨n₁²n₂²⟩ = 1/15.
        let k = CubicKernel::default();
        assert!((k.total_weight() - 1.0).abs() < 1e-12);
        let n = k.normal_part(CubicModel::ZenerAbove1, false, 1.0);
        assert!((n.c11 - 0.2).abs() < 1e-12, "{n:?}");
        assert!((n.c12 - 1.0 / 15.0).abs() < 1e-12, "{n:?}");
        let s = k.shear_part(CubicModel::ZenerBelow1, false, 1.0);
        // ⟨n₁² − n₁⁴⟩ = 2/15, −⟨n₁²n₂²⟩, ⟨(n₂² + n₃²)/4 − n₂²n₃²⟩ = 1/10.
        assert!((s.c11 - 2.0 / 15.0).abs() < 1e-12);
        assert!((s.c12 + 1.0 / 15.0).abs() < 1e-12);
        assert!((s.c44 - 0.1).abs() < 1e-12);
    }
}
