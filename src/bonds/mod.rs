//! Bonds: which pairs of spheres are glued, with the branch vector of each.
//!
//! A bond joins spheres `i < j` (0-based, packing order); its normal points from `i` to the
//! periodic image of `j` (SPEC). `rules.rs` decides which pairs are bonded (gap, factor,
//! target coordination); `stiffness.rs` assigns each bond its springs from a scheme;
//! `table.rs` reads and writes the SPEC bond table CSV.

pub(crate) mod rules;
pub(crate) mod stiffness;
pub(crate) mod table;
pub(crate) mod types;

use crate::packing::Packing;
use crate::{Error, Result, Vec3};

pub use rules::BondingRule;
pub use rules::{build_bonds, coordination_gap, COORDINATION_MAX_GAP};
pub use stiffness::{assign_stiffness, assign_stiffness_by_grain, lattice_scaling, BondStiffness};
pub use table::{
    check_against_packing, parse_bond_table, parse_bond_table_lines, read_bond_table,
    read_bond_table_atom_ids, read_bond_table_of, write_bond_table, write_bond_table_columns_to,
    write_bond_table_grains_to, write_bond_table_ids_to, write_bond_table_to,
    write_bond_table_with_columns, write_bond_table_with_grains, write_bond_table_with_ids,
    TableWithIds,
};
pub use types::sensitivity_weights;
pub use types::{
    affine_weights, quantise, quantise_joint, quantise_weighted, spring_errors, BondTypes,
};

/// The bonds of a packing, structure of arrays (one entry per bond in every vector).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct BondSet {
    /// First sphere (the smaller index).
    pub i: Vec<u32>,
    /// Second sphere (the larger index).
    pub j: Vec<u32>,
    /// Unit normal from `i` to the image of `j`.
    pub normal: Vec<Vec3>,
    /// Centre distance |l| (m).
    pub length: Vec<f64>,
    /// Periodic image of `j`: the branch vector is `x_j + image ∘ L − x_i`.
    pub image: Vec<[i32; 3]>,
}

impl BondSet {
    /// Number of bonds.
    pub fn len(&self) -> usize {
        self.i.len()
    }

    /// True when there are no bonds.
    pub fn is_empty(&self) -> bool {
        self.i.is_empty()
    }

    /// Append a bond. `i < j` is the caller's duty; the branch vector `l` must be non-zero.
    pub fn push(&mut self, i: u32, j: u32, branch: Vec3, image: [i32; 3]) {
        let len = branch.norm();
        self.i.push(i);
        self.j.push(j);
        self.normal.push(branch / len);
        self.length.push(len);
        self.image.push(image);
    }

    /// The bonds between given pairs (i, j) of `packing`, e.g. the interactions of a YADE or
    /// LIGGGHTS scene: `image` is the periodic image of j seen from i among the positions as
    /// given ([`Packing::given_positions`]: YADE's `cellDist` is of its unwrapped positions;
    /// the minimum image of a periodic cell when `None`; zero for a free cluster). Each pair
    /// is stored with i < j (the image negated when swapped). Refuses, naming the row, an
    /// index out of range, a self-bond, a pair given twice, an image in a cluster, a zero
    /// branch vector and an image that is not the nearest one of j (a branch vector longer
    /// than the particles' minimum-image distance: the image is of other positions).
    pub fn from_pairs(
        packing: &Packing,
        i: &[u32],
        j: &[u32],
        image: Option<&[[i32; 3]]>,
    ) -> Result<BondSet> {
        BondSet::from_pairs_at(packing, i, j, image).map_err(|(_, e)| e)
    }

    /// [`BondSet::from_pairs`], a refusal carrying the index of the pair it names (`None`
    /// for lists of different lengths), so that a reader can name its own file and line.
    pub fn from_pairs_at(
        packing: &Packing,
        i: &[u32],
        j: &[u32],
        image: Option<&[[i32; 3]]>,
    ) -> std::result::Result<BondSet, (Option<usize>, Error)> {
        let n = packing.len();
        if i.len() != j.len() || image.is_some_and(|m| m.len() != i.len()) {
            return Err((
                None,
                Error::Invalid(format!(
                    "bonds: {} i, {} j and {} images (one of each per bond)",
                    i.len(),
                    j.len(),
                    image.map_or(i.len(), |m| m.len())
                )),
            ));
        }
        let mut set = BondSet::default();
        let mut seen = std::collections::HashSet::new();
        for b in 0..i.len() {
            let (a, c) = (i[b], j[b]);
            if a as usize >= n || c as usize >= n || a == c {
                return Err((
                    Some(b),
                    Error::Invalid(format!(
                        "bond {b}: particles {a} and {c}, expected two different indices below {n}"
                    )),
                ));
            }
            let (branch, img) =
                pair_branch(packing, b, (a, c), image.map(|m| m[b])).map_err(|e| (Some(b), e))?;
            let (lo, hi, branch, img) = if a < c {
                (a, c, branch, img)
            } else {
                (c, a, -branch, [-img[0], -img[1], -img[2]])
            };
            if !seen.insert((lo, hi, img)) {
                return Err((
                    Some(b),
                    Error::Invalid(format!(
                        "bond {b}: particles {lo}–{hi} (image {img:?}) are bonded twice"
                    )),
                ));
            }
            if branch.norm() <= 0.0 || branch.norm().is_nan() {
                return Err((
                    Some(b),
                    Error::Invalid(format!(
                        "bond {b}: particles {lo} and {hi} are at the same place"
                    )),
                ));
            }
            set.push(lo, hi, branch, img);
        }
        Ok(set)
    }

    /// Branch vector l of bond `b` (m).
    pub fn branch(&self, b: usize) -> Vec3 {
        self.normal[b] * self.length[b]
    }

    /// Mean number of bonds per particle, Z = 2·N_bonds / N_particles.
    pub fn coordination(&self, n_particles: usize) -> f64 {
        2.0 * self.len() as f64 / n_particles.max(1) as f64
    }

    /// Number of bonds of each particle.
    pub fn degrees(&self, n_particles: usize) -> Vec<u32> {
        let mut d = vec![0u32; n_particles];
        for (&i, &j) in self.i.iter().zip(&self.j) {
            d[i as usize] += 1;
            d[j as usize] += 1;
        }
        d
    }

    /// Sort bonds by (i, j, image) so that the set is canonical whatever order it was
    /// found in (determinism across thread counts).
    pub fn sort_canonical(&mut self) {
        let mut idx: Vec<usize> = (0..self.len()).collect();
        idx.sort_by(|&a, &b| {
            (self.i[a], self.j[a], self.image[a]).cmp(&(self.i[b], self.j[b], self.image[b]))
        });
        self.i = idx.iter().map(|&k| self.i[k]).collect();
        self.j = idx.iter().map(|&k| self.j[k]).collect();
        self.normal = idx.iter().map(|&k| self.normal[k]).collect();
        self.length = idx.iter().map(|&k| self.length[k]).collect();
        self.image = idx.iter().map(|&k| self.image[k]).collect();
    }

    /// Gap of bond `b`: centre distance minus the sum of radii (m; negative = overlap).
    pub fn gap(&self, packing: &Packing, b: usize) -> f64 {
        self.length[b] - packing.radii[self.i[b] as usize] - packing.radii[self.j[b] as usize]
    }
}

/// Branch vector and image of bond `b` between particles `a` and `c` (`pair.0`, `pair.1`),
/// from i to the image of j: the `given` image, checked against the cell's periodic axes
/// and refused if not the nearest image of j; the minimum image if none is given; the plain
/// difference in a cluster (where only image 0 is accepted).
fn pair_branch(
    packing: &Packing,
    b: usize,
    pair: (u32, u32),
    given: Option<[i32; 3]>,
) -> Result<(Vec3, [i32; 3])> {
    let (a, c) = pair;
    let d = packing.positions[c as usize] - packing.positions[a as usize];
    match (&packing.cell, given) {
        (Some(cell), Some(m)) => {
            if let Some(k) = (0..3).find(|&k| !cell.periodic[k] && m[k] != 0) {
                return Err(Error::Invalid(format!(
                    "bond {b}: particles {a} and {c} with image {:?}, but the box is \
                     not periodic along {} (boundary {}): expected image 0 there",
                    m,
                    ["x", "y", "z"][k],
                    cell.boundary()
                )));
            }
            let img = packing.image_from_given(a as usize, c as usize, m);
            let branch = d + cell.shift(img);
            let nearest = cell.minimum_image(d).0.norm();
            if branch.norm() > nearest * (1.0 + 1e-9) + 1e-12 * cell.lengths.max() {
                return Err(Error::Invalid(format!(
                    "bond {b}: particles {a} and {c} with image {:?} are {:e} m \
                     apart, but their nearest images are {nearest:e} m apart: expected \
                     the image of j seen from i among the positions as given (a \
                     scene's own, e.g. YADE's cellDist with its body positions)",
                    m,
                    branch.norm()
                )));
            }
            Ok((branch, img))
        }
        (Some(cell), None) => Ok(cell.minimum_image(d)),
        (None, Some(m)) if m != [0, 0, 0] => Err(Error::Invalid(format!(
            "bond {b}: periodic image {:?} in a packing without a cell",
            m
        ))),
        (None, _) => Ok((d, [0, 0, 0])),
    }
}
