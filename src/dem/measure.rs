//! Measurement spheres (Truszkowska 2018 Sec. 4.2; Potyondy & Cundall 2004): seeded random
//! spheres lying fully inside a region of a free assembly, each averaging the stress and the
//! strain rate of the particles inside it; strain is the time integral of the strain rate.
//!
//! Conventions (fixed at placement, on the reference configuration):
//! - **Members**: particles whose reference centre lies inside the sphere.
//! - **Strain rate**: the least-squares velocity gradient L of the members with at least one
//!   bond (an unbonded particle does not follow the solid): L = Σ v′X′ᵀ (Σ X′X′ᵀ)⁻¹ with X′,
//!   v′ the reference positions and velocities relative to the members' means. The fit uses
//!   the fixed reference X′, so L is linear in the velocities and its time integral is exactly
//!   the same fit applied to the displacements (leapfrog: x ← x + v·dt); [`MeasurementSpheres::
//!   displacement_gradient`] evaluates that integral in one pass, [`StrainIntegrator`] step
//!   by step as the paper does.
//! - **Stress**: Love–Potyondy–Cundall average σ_S = φ / Σ_{p∈S} V_p · Σ_{p∈S} ½ Σ_{b∋p}
//!   sym(f_b ⊗ l_b) (tension positive, the sign of [`Simulation::stress`]): each member owns
//!   half of each of its bonds, and the volume it owns is its solid volume over the
//!   assembly's solid fraction φ (the assembly's rather than the sphere's porosity: no
//!   discretisation error from the sphere cutting particles, exact on a lattice).

use super::sim::Simulation;
use crate::tensor::Voigt6;
use crate::{Error, Mat3, Result, Vec3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;

/// Where and how many measurement spheres.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MeasureOptions {
    /// Number of spheres (the paper used 5,000).
    pub count: usize,
    /// Sphere radius in units of the mean particle radius R̄ (the paper: 6).
    pub radius: f64,
    /// Seed of the centres (ChaCha8).
    pub seed: u64,
}

impl Default for MeasureOptions {
    fn default() -> Self {
        MeasureOptions {
            count: 200,
            radius: 6.0,
            seed: 2018,
        }
    }
}

/// One measurement sphere with its members.
#[derive(Clone, Debug, PartialEq)]
pub struct MeasurementSphere {
    /// Centre (m).
    pub centre: Vec3,
    /// Members (particles with the reference centre inside), ascending.
    pub members: Vec<u32>,
    /// Members that enter the strain fit (bonded ones), ascending.
    pub strain_members: Vec<u32>,
    /// Mean reference position of the strain members (m).
    reference_mean: Vec3,
    /// (Σ X′X′ᵀ)⁻¹ of the strain members (1/m²).
    inverse_gyration: Mat3,
    /// φ / Σ_{p∈S} V_p (1/m³).
    inverse_volume: f64,
}

/// A set of measurement spheres over a fixed reference configuration.
#[derive(Clone, Debug, PartialEq)]
pub struct MeasurementSpheres {
    /// The spheres.
    pub spheres: Vec<MeasurementSphere>,
    /// Sphere radius (m).
    pub radius: f64,
    /// Reference positions of all particles (m).
    pub reference: Vec<Vec3>,
}

impl MeasurementSpheres {
    /// Place `opts.count` spheres with seeded uniform random centres such that each lies
    /// fully inside the box `[lo, hi]` (Truszkowska 2018 Sec. 4.2: "constrained to exist fully
    /// within the assembly"). `degree[p]` is the number of bonds of particle p and
    /// `solid_fraction` the assembly's φ. Errors if the box cannot hold a sphere or a sphere
    /// has fewer than four non-coplanar bonded members.
    pub fn place(
        reference: &[Vec3],
        radii: &[f64],
        degree: &[usize],
        lo: Vec3,
        hi: Vec3,
        solid_fraction: f64,
        opts: &MeasureOptions,
    ) -> Result<Self> {
        let n = reference.len();
        if radii.len() != n || degree.len() != n || n == 0 {
            return Err(Error::Invalid(format!(
                "measurement spheres: {} positions, {} radii, {} degrees (need equal, > 0)",
                n,
                radii.len(),
                degree.len()
            )));
        }
        if !(opts.radius.is_finite() && opts.radius > 0.0) || opts.count == 0 {
            return Err(Error::Invalid(format!(
                "measurement spheres: need count > 0 and a finite radius > 0 R̄, got {} and {}",
                opts.count, opts.radius
            )));
        }
        if !(solid_fraction.is_finite() && solid_fraction > 0.0 && solid_fraction <= 1.0) {
            return Err(Error::Invalid(format!(
                "measurement spheres: solid fraction must be in (0, 1], got {solid_fraction}"
            )));
        }
        let mean_radius = radii.iter().sum::<f64>() / n as f64;
        let r = opts.radius * mean_radius;
        let (a, b) = (lo.add_scalar(r), hi.add_scalar(-r));
        if (0..3).any(|k| a[k] > b[k]) {
            return Err(Error::Invalid(format!(
                "measurement spheres of radius {} R̄ do not fit in the interior region \
                 ({:.3e} × {:.3e} × {:.3e} m); use smaller spheres or a larger assembly",
                opts.radius,
                hi.x - lo.x,
                hi.y - lo.y,
                hi.z - lo.z
            )));
        }
        let mut rng = ChaCha8Rng::seed_from_u64(opts.seed);
        let centres: Vec<Vec3> = (0..opts.count)
            .map(|_| Vec3::from_fn(|k, _| a[k] + (b[k] - a[k]) * rng.gen::<f64>()))
            .collect();
        let spheres = centres
            .par_iter()
            .enumerate()
            .map(|(s, c)| build_sphere(s, *c, r, reference, radii, degree, solid_fraction))
            .collect::<Result<Vec<_>>>()?;
        Ok(MeasurementSpheres {
            spheres,
            radius: r,
            reference: reference.to_vec(),
        })
    }

    /// Number of spheres.
    pub fn len(&self) -> usize {
        self.spheres.len()
    }

    /// True when there are none.
    pub fn is_empty(&self) -> bool {
        self.spheres.is_empty()
    }

    /// Per sphere, the least-squares gradient of the field `u` (one entry per particle)
    /// over the strain members (see the module doc).
    pub fn fit_gradient(&self, u: &[Vec3]) -> Result<Vec<Mat3>> {
        if u.len() != self.reference.len() {
            return Err(Error::Invalid(format!(
                "measurement spheres: field has {} entries, expected {}",
                u.len(),
                self.reference.len()
            )));
        }
        Ok(self
            .spheres
            .par_iter()
            .map(|s| {
                let m = s.strain_members.len() as f64;
                let mean_u = s
                    .strain_members
                    .iter()
                    .fold(Vec3::zeros(), |acc, &p| acc + u[p as usize])
                    / m;
                let mut a = Mat3::zeros();
                for &p in &s.strain_members {
                    let x = self.reference[p as usize] - s.reference_mean;
                    a += (u[p as usize] - mean_u) * x.transpose();
                }
                a * s.inverse_gyration
            })
            .collect())
    }

    /// Per sphere, the velocity gradient L (1/s) of the current velocities (the strain rate
    /// is its symmetric part).
    pub fn velocity_gradient(&self, sim: &Simulation) -> Result<Vec<Mat3>> {
        self.fit_gradient(&sim.particles.velocity)
    }

    /// Per sphere, the displacement gradient since the reference configuration: the exact
    /// time integral of [`MeasurementSpheres::velocity_gradient`] (see the module doc).
    pub fn displacement_gradient(&self, sim: &Simulation) -> Result<Vec<Mat3>> {
        let u: Vec<Vec3> = sim
            .particles
            .position
            .iter()
            .zip(&self.reference)
            .map(|(x, x0)| x - x0)
            .collect();
        self.fit_gradient(&u)
    }

    /// Per sphere, the symmetric Love–Potyondy–Cundall stress (Pa, tension positive) of the
    /// last force evaluation (see the module doc).
    pub fn stress(&self, sim: &Simulation) -> Result<Vec<Mat3>> {
        if sim.particles.len() != self.reference.len() {
            return Err(Error::Invalid(format!(
                "measurement spheres were placed for {} particles, the simulation has {}",
                self.reference.len(),
                sim.particles.len()
            )));
        }
        let topo = &sim.topology;
        // ½ Σ_b f⊗l per particle, each in the fixed CSR order.
        let half: Vec<Mat3> = (0..sim.particles.len())
            .into_par_iter()
            .map(|p| {
                let mut s = Mat3::zeros();
                for &e in &topo.entries[topo.start[p]..topo.start[p + 1]] {
                    let b = (e >> 1) as usize;
                    s += sim.loads.force_i(b) * sim.branch(b).transpose();
                }
                s * 0.5
            })
            .collect();
        Ok(self
            .spheres
            .par_iter()
            .map(|s| {
                let sum = s
                    .members
                    .iter()
                    .fold(Mat3::zeros(), |acc, &p| acc + half[p as usize]);
                let sym = (sum + sum.transpose()) * 0.5;
                sym * s.inverse_volume
            })
            .collect())
    }
}

fn build_sphere(
    index: usize,
    centre: Vec3,
    r: f64,
    reference: &[Vec3],
    radii: &[f64],
    degree: &[usize],
    solid_fraction: f64,
) -> Result<MeasurementSphere> {
    let r2 = r * r;
    let members: Vec<u32> = (0..reference.len())
        .filter(|&p| (reference[p] - centre).norm_squared() <= r2)
        .map(|p| p as u32)
        .collect();
    let strain_members: Vec<u32> = members
        .iter()
        .copied()
        .filter(|&p| degree[p as usize] > 0)
        .collect();
    let bad = || {
        Error::Invalid(format!(
            "measurement sphere {index} (centre {:.3e} {:.3e} {:.3e} m, radius {:.3e} m) holds \
             {} bonded particles, not enough non-coplanar ones for a strain fit; use larger \
             spheres",
            centre.x,
            centre.y,
            centre.z,
            r,
            strain_members.len()
        ))
    };
    if strain_members.len() < 4 {
        return Err(bad());
    }
    let m = strain_members.len() as f64;
    let reference_mean = strain_members
        .iter()
        .fold(Vec3::zeros(), |a, &p| a + reference[p as usize])
        / m;
    let mut g = Mat3::zeros();
    for &p in &strain_members {
        let x = reference[p as usize] - reference_mean;
        g += x * x.transpose();
    }
    // Reject a (nearly) coplanar set: smallest eigenvalue tiny against the largest.
    let eig = g.symmetric_eigenvalues();
    let (emin, emax) = (eig.min(), eig.max());
    if !(emax > 0.0 && emin > 1e-9 * emax) {
        return Err(bad());
    }
    let inverse_gyration = g.try_inverse().ok_or_else(bad)?;
    let solid: f64 = members
        .iter()
        .map(|&p| 4.0 / 3.0 * std::f64::consts::PI * radii[p as usize].powi(3))
        .sum();
    Ok(MeasurementSphere {
        centre,
        members,
        strain_members,
        reference_mean,
        inverse_gyration,
        inverse_volume: solid_fraction / solid,
    })
}

/// Strain by time integration of the spheres' strain rates, as Truszkowska 2018 Sec. 4.2:
/// call [`StrainIntegrator::accumulate`] after every step.
#[derive(Clone, Debug, PartialEq)]
pub struct StrainIntegrator {
    /// Integrated displacement gradient per sphere (∫ L dt).
    pub gradient: Vec<Mat3>,
}

impl StrainIntegrator {
    /// Zero strain for every sphere of `spheres`.
    pub fn new(spheres: &MeasurementSpheres) -> Self {
        StrainIntegrator {
            gradient: vec![Mat3::zeros(); spheres.len()],
        }
    }

    /// Add L·dt with the velocities of the step just done (leapfrog velocities at t − dt/2,
    /// the ones that moved the particles).
    pub fn accumulate(&mut self, spheres: &MeasurementSpheres, sim: &Simulation) -> Result<()> {
        let l = spheres.velocity_gradient(sim)?;
        let dt = sim.time_step();
        for (g, l) in self.gradient.iter_mut().zip(&l) {
            *g += l * dt;
        }
        Ok(())
    }
}

/// Mean over spheres of per-sphere tensors (fixed order).
pub fn mean_tensor(per_sphere: &[Mat3]) -> Mat3 {
    let n = per_sphere.len().max(1) as f64;
    per_sphere.iter().fold(Mat3::zeros(), |a, b| a + b) / n
}

/// Normalised spread of one Voigt component across spheres: population standard deviation
/// over |mean| (Truszkowska 2018 Table 3, "normalized measurement sphere noise"). Infinite
/// when the mean is zero and the spread is not; zero when both are.
pub fn normalised_spread(values: &[Voigt6], component: usize) -> f64 {
    let n = values.len().max(1) as f64;
    let c = component.min(5);
    let mean = values.iter().map(|v| v[c]).sum::<f64>() / n;
    let var = values.iter().map(|v| (v[c] - mean).powi(2)).sum::<f64>() / n;
    let sd = var.sqrt();
    if sd == 0.0 {
        0.0
    } else {
        sd / mean.abs()
    }
}
