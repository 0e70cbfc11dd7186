//! Bond strengths of a polycrystal (docs/polycrystal.md "Strength across a boundary"): a
//! bond whose particles lie in different grains gets the strengths the `[strength]` table
//! gives it (scheme along its normal, planes of weakness, scatter), times the `[grains]`
//! table's `boundary_strength_factor`.

use super::{Grains, GrainsSpec};
use crate::bonds::BondSet;
use crate::packing::Packing;
use crate::strength::{assign_strength, BondStrengths, StrengthSpec};
use crate::{Error, Result};

/// Every bond's strength by `spec` ([`assign_strength`]) with the grain-boundary rule of
/// `grains` (the model's `[grains]`, `None` for a single crystal): a bond across a grain
/// boundary has its tensile, cohesion, bending and twisting strengths (not the friction)
/// times `boundary_strength_factor`. `built` is the grain map when the caller has it
/// (`Assembly::grains`); otherwise it is built from `grains` on `packing`, only when the
/// factor is not 1. Refuses ([`Error::Invalid`]) a grain map not of this packing.
pub fn assign_strength_by_grain(
    packing: &Packing,
    bonds: &BondSet,
    spec: &StrengthSpec,
    grains: Option<&GrainsSpec>,
    built: Option<&Grains>,
) -> Result<BondStrengths> {
    let mut strengths = assign_strength(packing, bonds, spec)?;
    let Some(gs) = grains else {
        return Ok(strengths);
    };
    let factor = gs.boundary_strength_factor;
    if factor == 1.0 {
        return Ok(strengths);
    }
    let owned;
    let map = match built {
        Some(m) => m,
        None => {
            owned = gs.build(packing)?;
            &owned
        }
    };
    if map.grain.len() != packing.len() {
        return Err(Error::Invalid(format!(
            "strengths by grain: the grain map has {} particles, the packing {}",
            map.grain.len(),
            packing.len()
        )));
    }
    for b in 0..bonds.len() {
        let (i, j) = (bonds.i[b] as usize, bonds.j[b] as usize);
        if map.grain[i] != map.grain[j] {
            strengths.tensile[b] *= factor;
            strengths.cohesion[b] *= factor;
            strengths.bending[b] *= factor;
            strengths.twisting[b] *= factor;
        }
    }
    Ok(strengths)
}
