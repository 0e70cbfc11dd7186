//! Kumar 2016 Sec. 5's preparation of a bar: "instead of periodic conditions, a rigid
//! cylinder and two planes were used as boundary conditions. Once jammed, the cylinder and
//! the planes were removed and bonds were installed."
//!
//! [`prepare_in_container`] runs the three routes of [`super::routes`] (the same driver, the
//! same gas fraction, compression steps, pressure stages, force balance and final affine
//! step) in a container instead of the periodic cube: the cylinder ρ = √(x² + y²) ≤ r about
//! the z axis between the planes z = 0 and z = l, with l/r fixed. The walls are soft
//! repulsive surfaces: a sphere overlapping one by δ feels the harmonic repulsion it would
//! feel from a sphere (unit stiffness, `repulsion::Walls`). Where the periodic route scales
//! the cell, the container is scaled about the origin (its axis and its first plane) with
//! the positions, r and l together; solid fractions are Σ(4/3)πR³ over the container volume
//! πr²l, so the final one is the requested D exactly, and the pressure of the jammed route
//! is −∂E/∂V of that scaling (sphere and wall contacts). Deviations from the periodic
//! routes, forced by the walls:
//!
//! - the gas places the sphere *centres* uniformly inside the container (a sphere may cross
//!   a wall): centres kept a radius away from the walls would put the gas above random
//!   sequential addition's saturation in a bar a few spheres wide (0.3 of the container is
//!   0.42 of the volume left to the centres at r = 6.5 R̄). The addition runs over the
//!   container widened by 2·R_max, the spheres drawn in the margin dropped at the end, so
//!   that the gas is as uniform as the periodic one (without them it piles up at the walls).
//!   The unjammed route (no minimisation) keeps the crossings, so its bar is the periodic
//!   gas's cut, densified; the minimisations of the other routes push the spheres inside;
//! - coordination and rattlers count a wall that a sphere touches as one of its contacts.
//!
//! The result is a free packing (no cell) and its container; the clamped end sets are the
//! spheres in contact with the planes ([`ContainerPacking::boundary`]).

use super::cut::{BoundarySets, Region};
use super::generate::{Domain, Polydispersity};
use super::routes::{prepare_in, RouteOptions, RouteReport, RouteStatus};
use super::Packing;
use crate::{Error, Result, Vec3};
use std::f64::consts::PI;

/// The rigid container: the cylinder of radius `radius` about the z axis between the planes
/// z = 0 and z = `length` (m).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Container {
    /// Radius r (m).
    pub radius: f64,
    /// Length l (m).
    pub length: f64,
}

impl Container {
    /// Volume πr²l (m³).
    pub fn volume(&self) -> f64 {
        PI * self.radius * self.radius * self.length
    }

    /// The container as a cut [`Region`] (centre (0, 0, l/2), axis z).
    pub fn region(&self) -> Region {
        Region::Cylinder {
            centre: Vec3::new(0.0, 0.0, 0.5 * self.length),
            axis: Vec3::z(),
            radius: self.radius,
            length: self.length,
        }
    }
}

/// A packing prepared in a container.
#[derive(Clone, Debug)]
pub struct ContainerPacking {
    /// The spheres (free, no cell; m).
    pub packing: Packing,
    /// The container at the end of the preparation (after the final affine step).
    pub container: Container,
}

impl ContainerPacking {
    /// Σ(4/3)πR³ over the container volume πr²l.
    pub fn solid_fraction(&self) -> f64 {
        let solid: f64 = self
            .packing
            .radii
            .iter()
            .map(|r| 4.0 / 3.0 * PI * r * r * r)
            .sum();
        solid / self.container.volume()
    }

    /// The spheres in contact with the planes and the mantle, as Kumar's clamped end sets
    /// ("the particles in contact with the two planes"): a sphere of radius R is in the
    /// first end set when its centre lies within R of the plane z = 0 (touching or crossing
    /// it), else in the second when within R of z = l, and in the surface set when within R
    /// of the mantle. `depth` of the result is the largest radius (every sphere is tested
    /// against its own). Refuses a container shorter than two diameters and an empty end set.
    pub fn boundary(&self) -> Result<BoundarySets> {
        let Container { radius, length } = self.container;
        let depth = self.packing.radii.iter().copied().fold(0.0, f64::max);
        if 2.0 * depth >= length {
            return Err(Error::Invalid(format!(
                "container of length {length:e} m: no room between the end sets of spheres \
                 of radius up to {depth:e} m"
            )));
        }
        let mut sets = BoundarySets {
            first_end: Vec::new(),
            second_end: Vec::new(),
            surface: Vec::new(),
            depth,
        };
        for (p, (x, r)) in self
            .packing
            .positions
            .iter()
            .zip(&self.packing.radii)
            .enumerate()
        {
            if x.z <= *r {
                sets.first_end.push(p as u32);
            } else if x.z >= length - r {
                sets.second_end.push(p as u32);
            }
            if x.x.hypot(x.y) >= radius - r {
                sets.surface.push(p as u32);
            }
        }
        if sets.first_end.is_empty() || sets.second_end.is_empty() {
            return Err(Error::Degenerate(format!(
                "no sphere in contact with an end plane of the container ({} and {} found)",
                sets.first_end.len(),
                sets.second_end.len()
            )));
        }
        Ok(sets)
    }
}

/// The number of spheres that fill a container of radius `radius` (m) and slenderness
/// l/r = `slenderness` at the solid fraction of `opts` (their mean volume from the radius
/// distribution, R̄ = `opts.mean_radius`): N = D·πr²l / ⟨(4/3)πR³⟩, rounded. A periodic
/// cell at D holds as many spheres per unit volume, so a bar cut from it of centres within
/// r has the same number per unit length on average.
pub fn container_particles(radius: f64, slenderness: f64, opts: &RouteOptions) -> usize {
    let relative_cube = match opts.polydispersity {
        Polydispersity::Monodisperse => 1.0,
        // ⟨(1 + h·u)³⟩ for u uniform in [−1, 1].
        Polydispersity::Uniform { half_width } => 1.0 + half_width * half_width,
    };
    let sphere = 4.0 / 3.0 * PI * opts.mean_radius.powi(3) * relative_cube;
    let volume = PI * radius * radius * slenderness * radius;
    (opts.solid_fraction * volume / sphere).round() as usize
}

/// Prepare `opts.n_particles` spheres by `opts.route` in a container of slenderness
/// l/r = `slenderness` (see the module doc); the container's size follows from the spheres'
/// volume and `opts.solid_fraction`. `status` as [`super::routes::prepare_with_status`]
/// (solid fractions of the container). Refuses a slenderness that is not finite and ≥ 2
/// and a container narrower than two mean diameters.
pub fn prepare_in_container(
    opts: &RouteOptions,
    slenderness: f64,
    status: &(dyn Fn(&RouteStatus) + Sync),
) -> Result<(ContainerPacking, RouteReport)> {
    if !(slenderness.is_finite() && slenderness >= 2.0) {
        return Err(Error::Invalid(format!(
            "container: slenderness l/r must be finite and ≥ 2, got {slenderness}"
        )));
    }
    let domain = Domain::container(slenderness);
    let Domain::Container { radius, length } = domain else {
        unreachable!("Domain::container makes a container")
    };
    // The final radius in R̄ from the volume N⟨(4/3)πR³⟩/D, before drawing the radii.
    let mean_sphere = 4.0 / 3.0 * PI;
    let final_radius =
        radius * (opts.n_particles as f64 * mean_sphere / opts.solid_fraction).cbrt();
    if final_radius.is_nan() || final_radius < 4.0 {
        return Err(Error::Invalid(format!(
            "container: {} spheres at solid fraction {} give a container of radius {:.2} R̄ at \
             l/r = {slenderness}; need at least 4 R̄ (two diameters): use more spheres",
            opts.n_particles, opts.solid_fraction, final_radius
        )));
    }
    let (packing, side, report) = prepare_in(domain, opts, status)?;
    let container = Container {
        radius: radius * side,
        length: length * side,
    };
    Ok((ContainerPacking { packing, container }, report))
}
