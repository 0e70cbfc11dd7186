//! All pairs of spheres closer than a cutoff, by cell lists in O(N).
//!
//! Space (the periodic cell, or the bounding box of a free assembly) is cut into cells at
//! least one cutoff wide; each sphere is compared only with the spheres of its own and the
//! 26 adjacent cells. Work is split over particles with rayon and the result is sorted
//! canonically by `(i, j, image)`, so it is the same bit for bit on any number of threads.
//!
//! In a periodic cell the pair's branch vector is the minimum image
//! ([`PeriodicCell::minimum_image`]); this is the only image within the cutoff as long as the
//! cutoff is below half of every cell length, which is checked (error otherwise).

use super::{Packing, PeriodicCell};
use crate::{Error, Result, Vec3};
use rayon::prelude::*;

/// A pair of spheres `i < j` found by the search.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Pair {
    /// First sphere (the smaller index).
    pub i: u32,
    /// Second sphere (the larger index).
    pub j: u32,
    /// Branch vector from `x_i` to the image of `x_j`: `x_j + image ∘ L − x_i` (m).
    pub branch: Vec3,
    /// Periodic image of `j` (all zero for a free assembly).
    pub image: [i32; 3],
}

impl Pair {
    /// Centre distance |l| (m).
    pub fn distance(&self) -> f64 {
        self.branch.norm()
    }

    /// Surface gap |l| − (R_i + R_j) (m; negative = overlap).
    pub fn gap(&self, packing: &Packing) -> f64 {
        self.distance() - packing.radii[self.i as usize] - packing.radii[self.j as usize]
    }
}

/// Every pair `i < j` whose surface gap |l| − (R_i + R_j) is at most
/// `max_surface_gap_of(R_i, R_j)` (m).
///
/// `max_gap_bound` must bound `max_surface_gap_of` from above for every pair of radii in
/// the packing; it sets the cell size (cutoff = 2·R_max + `max_gap_bound`).
pub fn pairs_within(
    packing: &Packing,
    max_surface_gap_of: impl Fn(f64, f64) -> f64 + Sync,
    max_gap_bound: f64,
) -> Result<Vec<Pair>> {
    if !max_gap_bound.is_finite() {
        return Err(Error::Invalid(format!(
            "neighbour search: the gap bound must be finite, got {max_gap_bound}"
        )));
    }
    let r_max = packing.radii.iter().copied().fold(0.0, f64::max);
    let cutoff = 2.0 * r_max + max_gap_bound;
    pairs_within_centre_distance(packing, cutoff, |ri, rj, dist| {
        dist - (ri + rj) <= max_surface_gap_of(ri, rj)
    })
}

/// Every pair `i < j` with centre distance |l| ≤ `max_centre_distance` (m) for which
/// `accept(R_i, R_j, |l|)` holds.
///
/// Errors when the packing is periodic and `max_centre_distance` is not below half of
/// every cell length (the minimum image would not be unique).
pub fn pairs_within_centre_distance(
    packing: &Packing,
    max_centre_distance: f64,
    accept: impl Fn(f64, f64, f64) -> bool + Sync,
) -> Result<Vec<Pair>> {
    pairs_in(
        &packing.positions,
        &packing.radii,
        packing.cell.as_ref(),
        max_centre_distance,
        accept,
    )
}

/// The work horse of [`pairs_within_centre_distance`] on raw arrays (positions must be
/// inside the cell when periodic).
pub(crate) fn pairs_in(
    positions: &[Vec3],
    radii: &[f64],
    cell: Option<&PeriodicCell>,
    cutoff: f64,
    accept: impl Fn(f64, f64, f64) -> bool + Sync,
) -> Result<Vec<Pair>> {
    if cutoff.is_nan() || cutoff == f64::INFINITY {
        return Err(Error::Invalid(format!(
            "neighbour search: the cutoff distance must be finite, got {cutoff}"
        )));
    }
    let n = positions.len();
    if n < 2 || cutoff < 0.0 {
        return Ok(Vec::new());
    }
    if n > u32::MAX as usize {
        return Err(Error::Invalid(format!(
            "neighbour search: {n} spheres exceed the 32-bit index range"
        )));
    }
    if let Some(c) = cell {
        for k in 0..3 {
            if c.periodic[k] && cutoff >= 0.5 * c.lengths[k] {
                return Err(Error::Invalid(format!(
                    "neighbour search: cutoff distance {cutoff:e} m is not below half the \
                     periodic cell length L{} = {:e} m, so the periodic image of a pair would \
                     not be unique; use a larger cell (more particles) or a smaller cutoff",
                    ["x", "y", "z"][k],
                    c.lengths[k]
                )));
            }
        }
    }
    let grid = CellGrid::new(positions, cell, cutoff);

    const BLOCK: usize = 512;
    let blocks: Vec<Vec<Pair>> = (0..n.div_ceil(BLOCK))
        .into_par_iter()
        .map(|b| {
            let mut out = Vec::new();
            let mut start_of_i;
            for i in b * BLOCK..((b + 1) * BLOCK).min(n) {
                start_of_i = out.len();
                let xi = positions[i];
                grid.for_each_neighbour_cell(i, |cell_index| {
                    for &j in grid.particles_in(cell_index) {
                        let j = j as usize;
                        if j <= i {
                            continue;
                        }
                        let d = positions[j] - xi;
                        let (branch, image) = match cell {
                            Some(c) => c.minimum_image_near(d),
                            None => (d, [0; 3]),
                        };
                        let dist = branch.norm();
                        if dist <= cutoff && accept(radii[i], radii[j], dist) {
                            out.push(Pair {
                                i: i as u32,
                                j: j as u32,
                                branch,
                                image,
                            });
                        }
                    }
                });
                out[start_of_i..].sort_by_key(|p| (p.j, p.image));
            }
            out
        })
        .collect();
    Ok(blocks.into_iter().flatten().collect())
}

/// The `n` items sorted by their cell `cell_of(p)` < `n_cells` (a counting sort): the items
/// of cell c are `members[start[c]..start[c + 1]]`, in ascending order.
pub(crate) fn bucket_by_cell(
    n_cells: usize,
    n: usize,
    cell_of: impl Fn(usize) -> usize,
) -> (Vec<usize>, Vec<u32>) {
    let mut start = vec![0usize; n_cells + 1];
    for p in 0..n {
        start[cell_of(p) + 1] += 1;
    }
    for k in 0..n_cells {
        start[k + 1] += start[k];
    }
    let mut fill = start.clone();
    let mut members = vec![0u32; n];
    for p in 0..n {
        let f = cell_of(p);
        members[fill[f]] = p as u32;
        fill[f] += 1;
    }
    (start, members)
}

/// Cells at least one cutoff wide, with the spheres of each (counting sort by cell).
pub(crate) struct CellGrid {
    dims: [usize; 3],
    periodic: [bool; 3],
    cell_of: Vec<[usize; 3]>,
    start: Vec<usize>,
    members: Vec<u32>,
}

impl CellGrid {
    pub(crate) fn new(positions: &[Vec3], cell: Option<&PeriodicCell>, cutoff: f64) -> Self {
        let n = positions.len();
        // Periodic axes span the cell [0, L); the others the particles' extent.
        let periodic = cell.map_or([false; 3], |c| c.periodic);
        let mut lo = Vec3::repeat(f64::INFINITY);
        let mut hi = Vec3::repeat(f64::NEG_INFINITY);
        for p in positions {
            for k in 0..3 {
                lo[k] = lo[k].min(p[k]);
                hi[k] = hi[k].max(p[k]);
            }
        }
        let mut origin = lo;
        let mut extent = hi - lo;
        if let Some(c) = cell {
            for k in (0..3).filter(|&k| periodic[k]) {
                origin[k] = 0.0;
                extent[k] = c.lengths[k];
            }
        }
        // Cells per dimension: as many as fit with width ≥ cutoff, capped so that empty
        // space does not cost more than a few cells per particle.
        let mut dims = [1usize; 3];
        for k in 0..3 {
            let fit = if cutoff > 0.0 {
                (extent[k] / cutoff).floor()
            } else {
                f64::INFINITY
            };
            dims[k] = if fit.is_finite() && fit >= 1.0 {
                fit.min(1.0e6) as usize
            } else if fit.is_finite() {
                1
            } else {
                1_000_000
            };
        }
        let limit = (8 * n).max(27);
        while dims.iter().product::<usize>() > limit {
            let k = (0..3).max_by_key(|&k| dims[k]).unwrap_or(0);
            dims[k] -= (dims[k] / 8).max(1);
        }
        let width: Vec3 = Vec3::new(
            extent.x / dims[0] as f64,
            extent.y / dims[1] as f64,
            extent.z / dims[2] as f64,
        );
        let cell_of: Vec<[usize; 3]> = positions
            .iter()
            .map(|p| {
                let mut c = [0usize; 3];
                for k in 0..3 {
                    let s = if width[k] > 0.0 {
                        ((p[k] - origin[k]) / width[k]).floor()
                    } else {
                        0.0
                    };
                    c[k] = if s.is_nan() || s < 0.0 {
                        0
                    } else {
                        (s as usize).min(dims[k] - 1)
                    };
                }
                c
            })
            .collect();
        let n_cells = dims[0] * dims[1] * dims[2];
        let flat = |c: &[usize; 3]| (c[2] * dims[1] + c[1]) * dims[0] + c[0];
        let (start, members) = bucket_by_cell(n_cells, n, |p| flat(&cell_of[p]));
        CellGrid {
            dims,
            periodic,
            cell_of,
            start,
            members,
        }
    }

    /// The spheres in cell `flat`, in ascending index order.
    pub(crate) fn particles_in(&self, flat: usize) -> &[u32] {
        &self.members[self.start[flat]..self.start[flat + 1]]
    }

    /// Call `f` once for every distinct cell adjacent to (or equal to) particle `p`'s cell.
    pub(crate) fn for_each_neighbour_cell(&self, p: usize, mut f: impl FnMut(usize)) {
        let c = self.cell_of[p];
        let mut per_dim: [([usize; 3], usize); 3] = [([0; 3], 0); 3];
        for k in 0..3 {
            let n = self.dims[k] as i64;
            let (list, len) = &mut per_dim[k];
            for o in -1i64..=1 {
                let mut q = c[k] as i64 + o;
                if self.periodic[k] {
                    q = q.rem_euclid(n);
                } else if q < 0 || q >= n {
                    continue;
                }
                let q = q as usize;
                if !list[..*len].contains(&q) {
                    list[*len] = q;
                    *len += 1;
                }
            }
        }
        for &z in &per_dim[2].0[..per_dim[2].1] {
            for &y in &per_dim[1].0[..per_dim[1].1] {
                for &x in &per_dim[0].0[..per_dim[0].1] {
                    f((z * self.dims[1] + y) * self.dims[0] + x);
                }
            }
        }
    }
}
