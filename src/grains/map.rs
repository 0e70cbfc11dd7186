//! [`Grains`]: the grain of every particle and the crystal orientation of every grain.

use crate::{Error, Mat3, Result, Vec3};

/// A grain map of a packing: each particle's grain id and each grain's orientation.
#[derive(Clone, Debug, PartialEq)]
pub struct Grains {
    /// The grain of particle k (0-based, < the number of grains).
    pub grain: Vec<u32>,
    /// The orientation of grain g: the Bunge matrix, sample (lab) → crystal coordinates
    /// (v_crystal = g·v_lab; the cubic scheme's `rotation` sense). A proper rotation.
    pub orientation: Vec<Mat3>,
    /// The Voronoi centres the map was made from (m), one per grain; `None` for a user's map.
    pub centres: Option<Vec<Vec3>>,
}

/// Largest |gᵀg − I| entry accepted for a grain's orientation.
const ROTATION_TOLERANCE: f64 = 1e-9;

impl Grains {
    /// Grains from their parts, checked: every particle's grain is one of the orientations,
    /// every orientation a proper rotation (|gᵀg − I| ≤ 1e-9, det > 0), centres one per grain.
    pub fn new(
        grain: Vec<u32>,
        orientation: Vec<Mat3>,
        centres: Option<Vec<Vec3>>,
    ) -> Result<Self> {
        if let Some(&g) = grain.iter().find(|&&g| g as usize >= orientation.len()) {
            return Err(Error::Invalid(format!(
                "grains: a particle is in grain {g}, but there are {} orientations (grain ids \
                 0 to {})",
                orientation.len(),
                orientation.len() as i64 - 1
            )));
        }
        for (g, r) in orientation.iter().enumerate() {
            let off = (r.transpose() * r - Mat3::identity()).amax();
            if !(off <= ROTATION_TOLERANCE && r.determinant() > 0.0) {
                return Err(Error::Invalid(format!(
                    "grains: the orientation of grain {g} is not a proper rotation \
                     (|gᵀg − I| = {off:e}, det = {})",
                    r.determinant()
                )));
            }
        }
        if let Some(c) = &centres {
            if c.len() != orientation.len() {
                return Err(Error::Invalid(format!(
                    "grains: {} centres for {} grains",
                    c.len(),
                    orientation.len()
                )));
            }
        }
        Ok(Grains {
            grain,
            orientation,
            centres,
        })
    }

    /// The number of grains (orientations), particles or not.
    pub fn len(&self) -> usize {
        self.orientation.len()
    }

    /// True when there is no grain.
    pub fn is_empty(&self) -> bool {
        self.orientation.is_empty()
    }

    /// The number of particles of each grain.
    pub fn sizes(&self) -> Vec<usize> {
        let mut n = vec![0; self.len()];
        for &g in &self.grain {
            n[g as usize] += 1;
        }
        n
    }
}
