//! Structure-of-arrays state of the integrator: particles, the deforming periodic cell,
//! and the bond topology with its particle → bond CSR used for the deterministic gather.

use super::quat::Quat;
use crate::bonds::BondSet;
use crate::packing::Packing;
use crate::{Error, Mat3, Result, Vec3};

/// Sphere masses from a density: m = ρ·(4/3)πR³·s, I = (2/5)·m·R² (solid sphere), with an
/// optional mass-scaling factor s (Truszkowska 2018 Sec. 4.1 scales the density to
/// lengthen the stable time step; quasi-static results do not depend on it).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MassOptions {
    /// Density ρ (kg/m³).
    pub density: f64,
    /// Mass-scaling factor s ≥ 0 multiplying ρ (1 = physical mass).
    pub scaling: f64,
}

impl Default for MassOptions {
    fn default() -> Self {
        MassOptions {
            density: 2600.0,
            scaling: 1.0,
        }
    }
}

/// Particle state, one entry per sphere in every vector.
#[derive(Clone, Debug, Default)]
pub struct Particles {
    /// Centre positions (m). Not wrapped back into the cell: like YADE, a particle keeps
    /// its unwrapped position and bonds carry their fixed periodic image.
    pub position: Vec<Vec3>,
    /// Velocity (m/s) at the half step t − dt/2 (leapfrog), including the cell's affine
    /// field L·x in a deforming periodic cell.
    pub velocity: Vec<Vec3>,
    /// Angular velocity (rad/s) at t − dt/2.
    pub angular_velocity: Vec<Vec3>,
    /// Orientation (unit quaternion, identity at the start).
    pub orientation: Vec<Quat>,
    /// Radius (m).
    pub radius: Vec<f64>,
    /// Mass (kg).
    pub mass: Vec<f64>,
    /// Moment of inertia (kg·m²), sphere: (2/5)·m·R².
    pub inertia: Vec<f64>,
}

impl Particles {
    /// Particles at rest at the packing's positions with masses from `mass`.
    pub fn from_packing(packing: &Packing, mass: &MassOptions) -> Result<Self> {
        if !(mass.density.is_finite() && mass.density > 0.0) {
            return Err(Error::Invalid(format!(
                "particle density must be finite and > 0 (kg/m³), got {}",
                mass.density
            )));
        }
        if !(mass.scaling.is_finite() && mass.scaling > 0.0) {
            return Err(Error::Invalid(format!(
                "mass-scaling factor must be finite and > 0, got {}",
                mass.scaling
            )));
        }
        let n = packing.len();
        let m: Vec<f64> = packing
            .radii
            .iter()
            .map(|r| 4.0 / 3.0 * std::f64::consts::PI * r * r * r * mass.density * mass.scaling)
            .collect();
        let inertia = m
            .iter()
            .zip(&packing.radii)
            .map(|(m, r)| 2.0 / 5.0 * m * r * r)
            .collect();
        Ok(Particles {
            position: packing.positions.clone(),
            velocity: vec![Vec3::zeros(); n],
            angular_velocity: vec![Vec3::zeros(); n],
            orientation: vec![Quat::identity(); n],
            radius: packing.radii.clone(),
            mass: m,
            inertia,
        })
    }

    /// Number of particles.
    pub fn len(&self) -> usize {
        self.radius.len()
    }

    /// True when there are none.
    pub fn is_empty(&self) -> bool {
        self.radius.is_empty()
    }
}

/// A periodic cell deformed by a homogeneous velocity gradient L, integrated exactly as
/// YADE's `Cell::integrateAndUpdate` at the start of every step: H ← H + dt·L·H,
/// F ← F + dt·L·F. A new L set by [`DeformingCell::set_velocity_gradient`] takes effect in
/// the integrator of the next step (YADE's `nextVelGrad`), hence on the cell one step later.
#[derive(Clone, Debug)]
pub struct DeformingCell {
    /// Cell base vectors as columns (m).
    pub h: Mat3,
    /// H before the last integration.
    pub prev_h: Mat3,
    /// Deformation gradient F accumulated from L (starts at identity).
    pub trsf: Mat3,
    /// Current velocity gradient L (1/s).
    pub vel_grad: Mat3,
    /// L of the previous step (the affine field the particle velocities carry).
    pub prev_vel_grad: Mat3,
    /// L requested for the next integrator pass.
    pub next_vel_grad: Option<Mat3>,
    /// L·H_prev: the relative velocity of periodic images one cell apart (YADE
    /// `intrShiftVel`).
    pub vel_grad_times_prev_h: Mat3,
}

impl DeformingCell {
    /// An orthorhombic cell with the given edge lengths, at rest.
    pub fn new(lengths: Vec3) -> Self {
        let h = Mat3::from_diagonal(&lengths);
        DeformingCell {
            h,
            prev_h: h,
            trsf: Mat3::identity(),
            vel_grad: Mat3::zeros(),
            prev_vel_grad: Mat3::zeros(),
            next_vel_grad: None,
            vel_grad_times_prev_h: Mat3::zeros(),
        }
    }

    /// Request a new velocity gradient (1/s); see the type doc for when it acts.
    pub fn set_velocity_gradient(&mut self, l: Mat3) {
        self.next_vel_grad = Some(l);
    }

    /// Advance the cell by dt with the current L (start of a step).
    pub fn integrate(&mut self, dt: f64) {
        let inc = self.vel_grad * dt;
        self.trsf += inc * self.trsf;
        self.prev_h = self.h;
        self.vel_grad_times_prev_h = self.vel_grad * self.prev_h;
        self.h += inc * self.h;
    }

    /// Volume det H (m³).
    pub fn volume(&self) -> f64 {
        self.h.determinant()
    }

    /// Small strain ½(F + Fᵀ) − I of the cell.
    pub fn small_strain(&self) -> Mat3 {
        (self.trsf + self.trsf.transpose()) * 0.5 - Mat3::identity()
    }
}

/// Bond topology: end particles, periodic image of j (integer cell distance, as YADE's
/// `Interaction.cellDist`), and the particle → bond CSR (each entry is `2·bond + side`,
/// side 0 = the bond's i end, 1 = its j end), in bond order per particle.
#[derive(Clone, Debug, Default)]
pub struct BondTopology {
    /// First particle.
    pub i: Vec<u32>,
    /// Second particle.
    pub j: Vec<u32>,
    /// Periodic image of j as a real vector (cell units).
    pub cell_dist: Vec<Vec3>,
    /// CSR offsets, length n_particles + 1.
    pub start: Vec<usize>,
    /// CSR entries `2·bond + side`.
    pub entries: Vec<u32>,
}

impl BondTopology {
    /// Build from a bond set; errors on an index out of range or a self-bond.
    pub fn new(bonds: &BondSet, n_particles: usize) -> Result<Self> {
        let nb = bonds.len();
        if nb >= (u32::MAX / 2) as usize {
            return Err(Error::Invalid(format!(
                "too many bonds ({nb}) for the integrator"
            )));
        }
        let mut start = vec![0usize; n_particles + 1];
        for b in 0..nb {
            let (i, j) = (bonds.i[b] as usize, bonds.j[b] as usize);
            if i >= n_particles || j >= n_particles || i == j {
                return Err(Error::Invalid(format!(
                    "bond {b} joins particles {i} and {j}; expected two different indices below {n_particles}"
                )));
            }
            start[i + 1] += 1;
            start[j + 1] += 1;
        }
        for p in 0..n_particles {
            start[p + 1] += start[p];
        }
        let mut fill = start.clone();
        let mut entries = vec![0u32; start[n_particles]];
        for b in 0..nb {
            for (side, p) in [bonds.i[b], bonds.j[b]].into_iter().enumerate() {
                entries[fill[p as usize]] = (2 * b + side) as u32;
                fill[p as usize] += 1;
            }
        }
        Ok(BondTopology {
            i: bonds.i.clone(),
            j: bonds.j.clone(),
            cell_dist: bonds
                .image
                .iter()
                .map(|c| Vec3::new(c[0] as f64, c[1] as f64, c[2] as f64))
                .collect(),
            start,
            entries,
        })
    }

    /// Number of bonds.
    pub fn len(&self) -> usize {
        self.i.len()
    }

    /// True when there are no bonds.
    pub fn is_empty(&self) -> bool {
        self.i.is_empty()
    }

    /// Number of bonds of particle `p`.
    pub fn degree(&self, p: usize) -> usize {
        self.start[p + 1] - self.start[p]
    }
}

/// Loads of one bond written by a bond law: the force on the i end (the j end receives its
/// opposite) and the torques on both ends. Kept together so that the gather reads one
/// record per bond end.
#[derive(Clone, Copy, Debug, Default)]
pub struct BondLoad {
    /// Force on particle i (N); particle j receives −force_i.
    pub force_i: Vec3,
    /// Torque on particle i (N·m).
    pub torque_i: Vec3,
    /// Torque on particle j (N·m).
    pub torque_j: Vec3,
}

/// Per-bond loads of the last force evaluation.
#[derive(Clone, Debug, Default)]
pub struct BondLoads {
    /// One record per bond, in bond order.
    pub per_bond: Vec<BondLoad>,
}

impl BondLoads {
    /// Zero loads for `n` bonds.
    pub fn zeros(n: usize) -> Self {
        BondLoads {
            per_bond: vec![BondLoad::default(); n],
        }
    }

    /// Force on the i end of bond `b` (N).
    pub fn force_i(&self, b: usize) -> Vec3 {
        self.per_bond[b].force_i
    }
}

/// Deterministic parallel sum of `f(k)` for k in 0..n: fixed chunks of 4096 summed in
/// order, then the chunk sums in order — the same bits on any thread count.
pub fn deterministic_sum<F: Fn(usize) -> f64 + Sync>(n: usize, f: F) -> f64 {
    use rayon::prelude::*;
    const CHUNK: usize = 4096;
    let chunks = n.div_ceil(CHUNK);
    let parts: Vec<f64> = (0..chunks)
        .into_par_iter()
        .map(|c| {
            let mut s = 0.0;
            for k in c * CHUNK..((c + 1) * CHUNK).min(n) {
                s += f(k);
            }
            s
        })
        .collect();
    parts.into_iter().sum()
}

/// Deterministic parallel sum of 3×3 matrices, as [`deterministic_sum`].
pub fn deterministic_sum_mat3<F: Fn(usize) -> Mat3 + Sync>(n: usize, f: F) -> Mat3 {
    use rayon::prelude::*;
    const CHUNK: usize = 4096;
    let chunks = n.div_ceil(CHUNK);
    let parts: Vec<Mat3> = (0..chunks)
        .into_par_iter()
        .map(|c| {
            let mut s = Mat3::zeros();
            for k in c * CHUNK..((c + 1) * CHUNK).min(n) {
                s += f(k);
            }
            s
        })
        .collect();
    parts.into_iter().fold(Mat3::zeros(), |a, b| a + b)
}

/// Per-step constants of the particle update.
#[derive(Clone, Copy, Debug)]
pub(crate) struct UpdateConsts {
    pub(crate) dt: f64,
    /// Cundall local damping λ.
    pub(crate) lambda: f64,
    pub(crate) periodic: bool,
    /// The cell's previous velocity gradient (YADE `prevVelGrad`).
    pub(crate) prev_l: Mat3,
    /// Change of the velocity gradient since the last step.
    pub(crate) dl: Mat3,
    /// Spin increment from the antisymmetric part of `dl`.
    pub(crate) dspin: Vec3,
}
