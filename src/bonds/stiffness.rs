//! Per-bond springs from a scheme: k = magnitude(n)·g(R_i, R_j, |l|), with the scheme's
//! magnitudes along the bond's initial normal (Truszkowska 2018 Eq. 6; Šmilauer
//! k_n = E′_N(θ)·π̂r²/(2r′)) and g from the model's [`Geometry`].

use super::BondSet;
use crate::packing::Packing;
use crate::schemes::{Geometry, StiffnessScheme};
use crate::{Error, Result};
use rayon::prelude::*;

/// The springs of every bond, structure of arrays aligned with a [`BondSet`].
#[derive(Clone, Debug, Default, PartialEq)]
pub struct BondStiffness {
    /// Bond radius R_b (m).
    pub radius: Vec<f64>,
    /// Normal spring constant k_n (N/m).
    pub kn: Vec<f64>,
    /// Shear spring constant k_s (N/m).
    pub ks: Vec<f64>,
    /// Bending spring constant k_r (N·m/rad).
    pub kr: Vec<f64>,
    /// Twisting spring constant k_tw (N·m/rad).
    pub ktw: Vec<f64>,
}

impl BondStiffness {
    /// Number of bonds.
    pub fn len(&self) -> usize {
        self.kn.len()
    }

    /// True when empty.
    pub fn is_empty(&self) -> bool {
        self.kn.is_empty()
    }
}

/// Assign every bond its springs (parallel; the result does not depend on the thread
/// count). Errors if a spring comes out negative or not finite (naming the bond).
pub fn assign_stiffness(
    packing: &Packing,
    bonds: &BondSet,
    scheme: &dyn StiffnessScheme,
    geometry: &Geometry,
) -> Result<BondStiffness> {
    let springs: Vec<_> = (0..bonds.len())
        .into_par_iter()
        .map(|b| {
            let ri = packing.radii[bonds.i[b] as usize];
            let rj = packing.radii[bonds.j[b] as usize];
            let m = scheme.magnitudes(&bonds.normal[b]);
            (
                geometry.bond_radius(ri, rj),
                geometry.springs(m, ri, rj, bonds.length[b]),
            )
        })
        .collect();
    let mut out = BondStiffness {
        radius: Vec::with_capacity(springs.len()),
        kn: Vec::with_capacity(springs.len()),
        ks: Vec::with_capacity(springs.len()),
        kr: Vec::with_capacity(springs.len()),
        ktw: Vec::with_capacity(springs.len()),
    };
    for (b, (rb, s)) in springs.into_iter().enumerate() {
        for (name, v) in [("kn", s.kn), ("ks", s.ks), ("kr", s.kr), ("ktw", s.ktw)] {
            if !v.is_finite() || v < 0.0 {
                return Err(Error::Model(format!(
                    "bond {b} ({}–{}): {name} = {v} is negative or not finite",
                    bonds.i[b], bonds.j[b]
                )));
            }
        }
        out.radius.push(rb);
        out.kn.push(s.kn);
        out.ks.push(s.ks);
        out.kr.push(s.kr);
        out.ktw.push(s.ktw);
    }
    Ok(out)
}
