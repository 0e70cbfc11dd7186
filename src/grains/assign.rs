//! Each particle to its nearest grain centre: the Voronoi tessellation of the centres.

use crate::packing::Packing;
use crate::{Error, Result, Vec3};
use rayon::prelude::*;

/// The grain of every particle of `packing`: the index of its nearest centre, by the
/// minimum-image distance along the periodic axes of its cell (plain distance along free
/// ones); a tie goes to the lower index. O(N·G) distance evaluations, parallel over the
/// particles: each particle's answer is its own, so the result does not depend on the
/// thread count. Refuses no centres, a non-finite centre and more than 2³² centres.
pub fn nearest_centres(packing: &Packing, centres: &[Vec3]) -> Result<Vec<u32>> {
    if centres.is_empty() {
        return Err(Error::Invalid("grains: no grain centres".into()));
    }
    if centres.len() > u32::MAX as usize {
        return Err(Error::Invalid(format!(
            "grains: {} centres, at most 2³² − 1 (grain ids are 32-bit)",
            centres.len()
        )));
    }
    if let Some(c) = centres
        .iter()
        .position(|c| !c.iter().all(|x| x.is_finite()))
    {
        return Err(Error::Invalid(format!(
            "grains: centre {c} is not finite: {:?}",
            centres[c]
        )));
    }
    let cell = packing.cell.as_ref();
    Ok(packing
        .positions
        .par_iter()
        .map(|x| {
            let mut best = (f64::INFINITY, 0u32);
            for (g, c) in centres.iter().enumerate() {
                let d = x - c;
                let d = match cell {
                    Some(cell) => cell.minimum_image(d).0,
                    None => d,
                };
                let r2 = d.norm_squared();
                // Strictly less: the lower index keeps a tie.
                if r2 < best.0 {
                    best = (r2, g as u32);
                }
            }
            best.1
        })
        .collect())
}
