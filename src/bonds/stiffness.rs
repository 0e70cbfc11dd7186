//! Per-bond springs from a scheme: k = magnitude(n)·g(R_i, R_j, |l|), with the scheme's
//! magnitudes along the bond's initial normal (Truszkowska 2018 Eq. 6; Šmilauer
//! k_n = E′_N(θ)·π̂r²/(2r′)) and g from the model's [`Geometry`].

use super::BondSet;
use crate::grains::{BoundaryRule, Grains};
use crate::packing::Packing;
use crate::schemes::{Geometry, Springs, StiffnessScheme};
use crate::{Error, Result};
use rayon::prelude::*;

/// The springs of every bond, structure of arrays aligned with a [`BondSet`].
#[derive(Clone, Debug, Default, PartialEq)]
pub struct BondStiffness {
    /// Bond radius R_b (m).
    pub radius: Vec<f64>,
    /// Normal spring constant k_n (N/m).
    pub kn: Vec<f64>,
    /// Shear spring constant k_s (N/m).
    pub ks: Vec<f64>,
    /// Bending spring constant k_r (N·m/rad).
    pub kr: Vec<f64>,
    /// Twisting spring constant k_tw (N·m/rad).
    pub ktw: Vec<f64>,
}

impl BondStiffness {
    /// Number of bonds.
    pub fn len(&self) -> usize {
        self.kn.len()
    }

    /// True when empty.
    pub fn is_empty(&self) -> bool {
        self.kn.is_empty()
    }
}

/// Assign every bond its springs (parallel; the result does not depend on the thread
/// count). Errors if a spring comes out negative or not finite (naming the bond).
pub fn assign_stiffness(
    packing: &Packing,
    bonds: &BondSet,
    scheme: &dyn StiffnessScheme,
    geometry: &Geometry,
) -> Result<BondStiffness> {
    let radius =
        |ends: &[u32]| -> Vec<f64> { ends.iter().map(|&p| packing.radii[p as usize]).collect() };
    let (ri, rj) = (radius(&bonds.i), radius(&bonds.j));
    springs_along(
        scheme,
        geometry,
        &bonds.normal,
        &ri,
        &rj,
        &bonds.length,
        &|b| format!("bond {b} ({}–{})", bonds.i[b], bonds.j[b]),
    )
}

/// The springs of bonds given by columns — unit normals, end radii (m), lengths (m) — by
/// `scheme`'s magnitudes and `geometry` (k = magnitude(n)·g(R_i, R_j, |l|)), in parallel and
/// independent of the thread count. A spring negative or not finite is an error naming the
/// bond by `name(b)`.
pub fn springs_along(
    scheme: &dyn StiffnessScheme,
    geometry: &Geometry,
    normals: &[crate::Vec3],
    r_i: &[f64],
    r_j: &[f64],
    lengths: &[f64],
    name: &(dyn Fn(usize) -> String + Sync),
) -> Result<BondStiffness> {
    collect_springs(
        normals.len(),
        |b| {
            let (ri, rj) = (r_i[b], r_j[b]);
            let m = scheme.magnitudes(&normals[b]);
            (
                geometry.bond_radius(ri, rj),
                geometry.springs(m, ri, rj, lengths[b]),
            )
        },
        name,
    )
}

/// Every bond's springs by grain (docs/polycrystal.md): a bond inside grain g gets the
/// scheme's magnitudes along its normal turned into the grain's crystal frame,
/// magnitudes(g·n) (g the grain's Bunge matrix, sample → crystal; the scheme's own
/// rotation acts after it, so an identity orientation gives the single crystal exactly); a
/// bond whose particles lie in different grains gets, times `boundary_factor`, both grains'
/// springs combined by `boundary` (their mean, or in series) or, for
/// [`BoundaryRule::ContactPoint`], the springs of the one grain of the two whose centre is
/// nearer its contact point (`boundary_grain`). Parallel, independent of the thread count;
/// refuses a grain map not of this packing, the contact-point rule without grain centres
/// (a user's grain file) and a spring negative or not finite, naming the bond.
pub fn assign_stiffness_by_grain(
    packing: &Packing,
    bonds: &BondSet,
    scheme: &dyn StiffnessScheme,
    geometry: &Geometry,
    grains: &Grains,
    boundary: BoundaryRule,
    boundary_factor: f64,
) -> Result<BondStiffness> {
    if grains.grain.len() != packing.len() {
        return Err(Error::Invalid(format!(
            "springs by grain: the grain map has {} particles, the packing {}",
            grains.grain.len(),
            packing.len()
        )));
    }
    if !(boundary_factor.is_finite() && boundary_factor > 0.0) {
        return Err(Error::Model(format!(
            "[grains] boundary_factor = {boundary_factor}: expected a finite factor > 0"
        )));
    }
    if boundary == BoundaryRule::ContactPoint && grains.centres.is_none() {
        return Err(Error::Model(
            "[grains] boundary = \"contact-point\" needs the grains' Voronoi centres, and this \
             grain map (a user's grain file) has none: use boundary = \"mean\" or \"series\""
                .into(),
        ));
    }
    let identity: Vec<bool> = grains
        .orientation
        .iter()
        .map(|g| *g == crate::Mat3::identity())
        .collect();
    let magnitudes = |g: u32, n: &crate::Vec3| {
        let g = g as usize;
        // An identity orientation takes the normal as it is: bit for bit the single crystal.
        if identity[g] {
            scheme.magnitudes(n)
        } else {
            scheme.magnitudes(&(grains.orientation[g] * n))
        }
    };
    collect_springs(
        bonds.len(),
        |b| {
            let (i, j) = (bonds.i[b] as usize, bonds.j[b] as usize);
            let (ri, rj) = (packing.radii[i], packing.radii[j]);
            let (n, l) = (&bonds.normal[b], bonds.length[b]);
            let (gi, gj) = (grains.grain[i], grains.grain[j]);
            let springs = |g| geometry.springs(magnitudes(g, n), ri, rj, l);
            let scaled = |s: Springs, f: &dyn Fn(f64, f64) -> f64, t: Springs| Springs {
                kn: f(s.kn, t.kn),
                ks: f(s.ks, t.ks),
                kr: f(s.kr, t.kr),
                ktw: f(s.ktw, t.ktw),
            };
            let s = if gi == gj {
                springs(gi)
            } else if boundary == BoundaryRule::ContactPoint {
                let s = springs(boundary_grain(packing, bonds, grains, b));
                scaled(s, &|x, _| x * boundary_factor, s)
            } else {
                let across = |x: f64, y: f64| {
                    // Mean and series always combine (`combine` is None for contact-point only).
                    boundary.combine(x, y).unwrap_or(f64::NAN) * boundary_factor
                };
                scaled(springs(gi), &across, springs(gj))
            };
            (geometry.bond_radius(ri, rj), s)
        },
        &|b| format!("bond {b} ({}–{})", bonds.i[b], bonds.j[b]),
    )
}

/// The grain whose springs bond `b` takes under [`BoundaryRule::ContactPoint`]: of the
/// grains g, h of its two particles, the one whose Voronoi centre is nearer (minimum image
/// in a periodic cell) to its contact point x_i + r_i·n, r_i = R_i + gap/2 (YADE's mid-gap
/// point, whatever lever arm a solver takes later); a tie to the lower id. Inside one grain,
/// that grain. Needs `grains.centres` (the caller checks).
fn boundary_grain(packing: &Packing, bonds: &BondSet, grains: &Grains, b: usize) -> u32 {
    let (i, j) = (bonds.i[b] as usize, bonds.j[b] as usize);
    let (gi, gj) = (grains.grain[i], grains.grain[j]);
    let Some(centres) = grains.centres.as_ref().filter(|_| gi != gj) else {
        return gi;
    };
    let (ri, rj, l) = (packing.radii[i], packing.radii[j], bonds.length[b]);
    let point = packing.positions[i] + bonds.normal[b] * (0.5 * (l + ri - rj));
    let distance2 = |g: u32| {
        let d = point - centres[g as usize];
        match &packing.cell {
            Some(cell) => cell.minimum_image(d).0.norm_squared(),
            None => d.norm_squared(),
        }
    };
    let (lo, hi) = (gi.min(gj), gi.max(gj));
    if distance2(hi) < distance2(lo) {
        hi
    } else {
        lo
    }
}

/// The springs of `n` bonds, bond b's radius and springs by `each(b)`, computed in parallel
/// and gathered in bond order; a spring negative or not finite is an error naming the bond.
fn collect_springs(
    n: usize,
    each: impl Fn(usize) -> (f64, crate::schemes::Springs) + Sync + Send,
    name: &(dyn Fn(usize) -> String + Sync),
) -> Result<BondStiffness> {
    let springs: Vec<_> = (0..n).into_par_iter().map(each).collect();
    let mut out = BondStiffness {
        radius: Vec::with_capacity(springs.len()),
        kn: Vec::with_capacity(springs.len()),
        ks: Vec::with_capacity(springs.len()),
        kr: Vec::with_capacity(springs.len()),
        ktw: Vec::with_capacity(springs.len()),
    };
    for (b, (rb, s)) in springs.into_iter().enumerate() {
        for (spring, v) in [("kn", s.kn), ("ks", s.ks), ("kr", s.kr), ("ktw", s.ktw)] {
            if !v.is_finite() || v < 0.0 {
                return Err(Error::Model(format!(
                    "{}: {spring} = {v} is negative or not finite",
                    name(b)
                )));
            }
        }
        out.radius.push(rb);
        out.kn.push(s.kn);
        out.ks.push(s.ks);
        out.kr.push(s.kr);
        out.ktw.push(s.ktw);
    }
    Ok(out)
}

/// Refuse bond columns [`springs_along`] cannot take, naming the bond: columns of different
/// lengths, a normal not of unit length (within 1e-9), a radius or length not finite and > 0.
pub fn check_bond_columns(
    normals: &[crate::Vec3],
    r_i: &[f64],
    r_j: &[f64],
    lengths: &[f64],
) -> Result<()> {
    let n = normals.len();
    if r_i.len() != n || r_j.len() != n || lengths.len() != n {
        return Err(Error::Invalid(format!(
            "springs: {n} normals but {} r_i, {} r_j and {} lengths (one of each per bond)",
            r_i.len(),
            r_j.len(),
            lengths.len()
        )));
    }
    for b in 0..n {
        let norm = normals[b].norm();
        if (norm - 1.0).abs() > 1e-9 || norm.is_nan() {
            return Err(Error::Invalid(format!(
                "springs: normal {b} has length {norm}, expected a unit vector"
            )));
        }
        for (name, v) in [("r_i", r_i[b]), ("r_j", r_j[b]), ("length", lengths[b])] {
            if !(v.is_finite() && v > 0.0) {
                return Err(Error::Invalid(format!(
                    "springs: {name}[{b}] = {v}, expected a finite value > 0 m"
                )));
            }
        }
    }
    Ok(())
}

/// Šmilauer's lattice scaling μ = (1/3)·N_b·π̂·mean(r′·r²)/V (Šmilauer Eq. 20; Woo's
/// `muStiffnessScaling`), with r′ = half each bond's centre distance, r = the smaller radius
/// of its two spheres, N_b the number of bonds and V = [`Packing::volume`]. The lattice
/// tensor is then μ·C_micro(𝓔′). Woo's C++ default π̂ is π (its Python binding's π/2).
pub fn lattice_scaling(packing: &Packing, bonds: &BondSet, pi_hat: f64) -> Result<f64> {
    if !pi_hat.is_finite() || pi_hat <= 0.0 {
        return Err(Error::Invalid(format!(
            "lattice scaling: pi_hat must be finite and > 0, got {pi_hat}"
        )));
    }
    if bonds.is_empty() {
        return Err(Error::Invalid(
            "lattice scaling: the packing has no bonds (μ needs at least one)".into(),
        ));
    }
    let n_spheres = packing.len();
    let mut sum = 0.0;
    for b in 0..bonds.len() {
        let (i, j) = (bonds.i[b] as usize, bonds.j[b] as usize);
        if i >= n_spheres || j >= n_spheres {
            return Err(Error::Invalid(format!(
                "lattice scaling: bond {b} joins spheres {i} and {j}, but the packing has {n_spheres}"
            )));
        }
        let length = bonds.length[b];
        if !length.is_finite() || length <= 0.0 {
            return Err(Error::Invalid(format!(
                "lattice scaling: bond {b} has centre distance {length}, expected finite and > 0"
            )));
        }
        let r = packing.radii[i].min(packing.radii[j]);
        sum += 0.5 * length * r * r;
    }
    let volume = packing.volume();
    if !volume.is_finite() || volume <= 0.0 {
        return Err(Error::Invalid(format!(
            "lattice scaling: packing volume must be finite and > 0, got {volume}"
        )));
    }
    // (1/3)·N·π̂·mean(r′r²)/V = (1/3)·π̂·Σ(r′r²)/V.
    Ok(pi_hat * sum / (3.0 * volume))
}
