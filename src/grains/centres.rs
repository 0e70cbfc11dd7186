//! Grain centres: seeded, uniform in the packing's region — the periodic cell, or the box of
//! the spheres along free axes — and the grain count a mean grain size gives.

use crate::packing::Packing;
use crate::{Error, Result, Vec3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// Where grain centres are drawn: [0, L_k) along a periodic axis k of the cell, the spheres'
/// bounding box (surfaces included, [`Packing::bounding_box`]) along a free axis and for a
/// free specimen.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GrainRegion {
    /// Lower corner (m).
    pub lo: Vec3,
    /// Upper corner (m).
    pub hi: Vec3,
}

impl GrainRegion {
    /// The region of `packing` (see the type's doc).
    pub fn of(packing: &Packing) -> GrainRegion {
        let (mut lo, mut hi) = packing.bounding_box();
        if let Some(c) = &packing.cell {
            for k in (0..3).filter(|&k| c.periodic[k]) {
                lo[k] = 0.0;
                hi[k] = c.lengths[k];
            }
        }
        GrainRegion { lo, hi }
    }

    /// Its volume (m³): the cell's for a periodic packing, [`Packing::volume`] for a free one.
    pub fn volume(&self) -> f64 {
        (self.hi - self.lo).iter().product()
    }
}

/// The grain count of a mean grain size: count = round(V / (size·2R̄)³), at least 1, with V
/// the [`GrainRegion`]'s volume and R̄ the mean radius (`size` in particle diameters: a grain
/// of size 4 is a cube four mean diameters across, on average). Refuses a size that is not
/// finite and > 0 and a count above the number of particles (grains without particles).
pub fn count_for_mean_size(packing: &Packing, size: f64) -> Result<usize> {
    if !(size.is_finite() && size > 0.0) {
        return Err(Error::Model(format!(
            "[grains] mean_size = {size}: expected a finite grain size > 0 (particle diameters)"
        )));
    }
    let edge = size * 2.0 * packing.mean_radius();
    let count = (GrainRegion::of(packing).volume() / (edge * edge * edge)).round();
    let count = if count.is_finite() {
        count.max(1.0)
    } else {
        f64::INFINITY
    };
    if count > packing.len() as f64 {
        return Err(Error::Model(format!(
            "[grains] mean_size = {size} particle diameters gives {count} grains for {} \
             particles: expected grains of at least one particle (a larger mean_size)",
            packing.len()
        )));
    }
    Ok(count as usize)
}

/// `count` grain centres uniform in `region`, from a ChaCha8 stream seeded with `seed`
/// (the generator of `packing::generate`), drawn x, y, z centre after centre.
pub fn seeded_centres(region: &GrainRegion, count: usize, seed: u64) -> Vec<Vec3> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let span = region.hi - region.lo;
    (0..count)
        .map(|_| {
            let u = Vec3::new(rng.gen::<f64>(), rng.gen::<f64>(), rng.gen::<f64>());
            region.lo + span.component_mul(&u)
        })
        .collect()
}
