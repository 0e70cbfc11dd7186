//! Bonds: which pairs of spheres are glued, with the branch vector of each.
//!
//! A bond joins spheres `i < j` (0-based, packing order); its normal points from `i` to the
//! periodic image of `j` (SPEC). [`rules`] decides which pairs are bonded (gap, factor,
//! target coordination); [`stiffness`] assigns each bond its springs from a scheme;
//! [`table`] reads and writes the SPEC bond table CSV.

pub mod rules;
pub mod stiffness;
pub mod table;

use crate::packing::Packing;
use crate::Vec3;

pub use rules::BondingRule;
pub use stiffness::{assign_stiffness, BondStiffness};

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
