//! Shared set-ups of the group's integrator tests: the bonded simple-cubic bar and the
//! bonded pair of touching spheres.

use anisobond::bonds::BondSet;
use anisobond::packing::Packing;
use anisobond::Vec3;

/// A simple-cubic bar of nx × ny × nz touching spheres of radius `r` (axis z, free), bonds
/// between nearest neighbours; returns it with each bond's (axis 0/1/2, layer k of its
/// lower end).
pub fn bar(nx: usize, ny: usize, nz: usize, r: f64) -> (Packing, BondSet, Vec<(usize, usize)>) {
    let d = 2.0 * r;
    let index = |i: usize, j: usize, k: usize| (k * ny + j) * nx + i;
    let mut positions = vec![Vec3::zeros(); nx * ny * nz];
    for k in 0..nz {
        for j in 0..ny {
            for i in 0..nx {
                positions[index(i, j, k)] = Vec3::new(i as f64, j as f64, k as f64) * d;
            }
        }
    }
    let packing = Packing::new(positions.clone(), vec![r; positions.len()], None).unwrap();
    let mut bonds = BondSet::default();
    let mut tags = Vec::new();
    for k in 0..nz {
        for j in 0..ny {
            for i in 0..nx {
                let a = index(i, j, k);
                for (axis, (di, dj, dk)) in [(1, 0, 0), (0, 1, 0), (0, 0, 1)].iter().enumerate() {
                    let (i2, j2, k2) = (i + di, j + dj, k + dk);
                    if i2 < nx && j2 < ny && k2 < nz {
                        let b = index(i2, j2, k2);
                        bonds.push(a as u32, b as u32, positions[b] - positions[a], [0; 3]);
                        tags.push((axis, k));
                    }
                }
            }
        }
    }
    (packing, bonds, tags)
}

/// Two touching spheres of radius `r`, one above the other along z, and their bond.
pub fn bonded_pair(r: f64) -> (Packing, BondSet) {
    let d = 2.0 * r;
    let packing = Packing::new(
        vec![Vec3::zeros(), Vec3::new(0.0, 0.0, d)],
        vec![r; 2],
        None,
    )
    .unwrap();
    let mut bonds = BondSet::default();
    bonds.push(0, 1, Vec3::new(0.0, 0.0, d), [0; 3]);
    (packing, bonds)
}
