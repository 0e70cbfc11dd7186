//! A pressurised circular cavity in a bonded slab (issue 22; Šmilauer's cross-anisotropy
//! report, last section: strike 270°, dip 25°).
//!
//! The slab is the annulus a ≤ ρ ≤ b + w of a periodic packing ([`cut_holed_slab`]),
//! periodic along the hole's axis z with the cell held fixed (plane strain). The spheres of
//! the outer ring ρ > b are clamped (translations and rotations), so the free material is
//! the annulus a ≤ ρ ≤ b with u(b) = 0. The bonds and springs are the model's, with the
//! cross-anisotropic lattice scaling μ of the *source* packing so that the slab's material
//! is the one whose relaxed tensor is measured on the periodic cell.
//!
//! Pressure rule (area share by ray casting): the hole wall, the cylinder ρ = a, is divided
//! into tiles of side ≈ `ray_spacing` (N_θ tiles round, N_z along the axis); the ray from the
//! axis through each tile's centre, radially outward, carries a probe sphere of radius R̄/2
//! (a thick ray, so that it cannot slip through the pores between wall spheres); the first
//! sphere it touches takes the tile's force p·a·Δθ·Δz along the ray (applied at its centre,
//! no moment). Every sphere thus carries the pressure on the part of the wall it shadows as
//! seen from the axis; the forces sum to zero over the wall, and the tiles' forces to
//! p·2πa·L_z in magnitude (a sphere's resultant is shorter than the sum of its tiles' by the
//! spread of their directions).
//!
//! `statics.rs` solves the linear equilibrium on the relaxed solver's block-sparse stiffness;
//! [`lame_wall_displacement`] is the continuum reference.

pub(crate) mod continuum;
pub(crate) mod dynamics;
pub(crate) mod statics;

pub use continuum::ContinuumCavity;
pub use continuum::{solve_annulus, AnnulusMesh};
pub use dynamics::{WaveOptions, WaveRun};
pub use statics::{StaticCavity, StaticComparison, WallBin};

use crate::assembly::Assembly;
use crate::bonds::{rules::build_bonds, BondSet, BondStiffness};
use crate::homogenize::network::{LeverArm, Network};
use crate::model::SchemeSpec;
use crate::packing::cut::{cut_holed_slab, HoledSlab, SlabCut};
use crate::{Error, Result, Vec3};

/// Geometry of the cavity problem (m).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CavityGeometry {
    /// Hole radius a (m).
    pub inner_radius: f64,
    /// Radius b of the clamped boundary (m): spheres with ρ > b are held.
    pub outer_radius: f64,
    /// Width w of the clamped ring b < ρ ≤ b + w (m); at least the longest bond, so that no
    /// free sphere loses a neighbour to the cut.
    pub clamp_width: f64,
    /// Side of the pressure tiles on the wall (m); a fraction of the mean radius.
    pub ray_spacing: f64,
}

impl CavityGeometry {
    /// The geometry for `source` with the documented defaults for what is `None`: hole
    /// radius a = 10 R̄, clamped radius b = 24 R̄, clamp width = the longest bond, tiles of
    /// R̄/4 (R̄ the source's mean radius).
    pub fn with_defaults(
        source: &Assembly,
        inner_radius: Option<f64>,
        outer_radius: Option<f64>,
        clamp_width: Option<f64>,
        ray_spacing: Option<f64>,
    ) -> CavityGeometry {
        let r = source.packing.mean_radius();
        CavityGeometry {
            inner_radius: inner_radius.unwrap_or(10.0 * r),
            outer_radius: outer_radius.unwrap_or(24.0 * r),
            clamp_width: clamp_width
                .unwrap_or_else(|| source.bonds.length.iter().copied().fold(0.0, f64::max)),
            ray_spacing: ray_spacing.unwrap_or(0.25 * r),
        }
    }
}

/// Peak memory (bytes) of the static cavity problem on a slab of `spheres` spheres, fitted:
/// 3000·N^{4/3}. The sparse Cholesky's fill grows as N^{4/3}; peak resident memory was
/// measured 0.17, 0.52, 1.08 and 2.34 GB at 4,272, 9,839, 17,542 and 31,021 spheres (slab
/// 16 R̄ thick, defaults otherwise), which 2400·N^{4/3} fits to 3 %; 3000 leaves a margin.
pub fn static_memory_estimate(spheres: f64) -> f64 {
    3000.0 * spheres.powf(4.0 / 3.0)
}

/// Largest number of ray–sphere tests of the wall loads (rays × candidate spheres near the
/// wall) accepted: about a minute here. The defaults need some 5e7.
pub const MAX_RAY_TESTS: f64 = 1e10;

/// Largest number of nodes around the continuum's mesh ([`continuum::AnnulusMesh`] with
/// square elements needs 2π·48/ln(b/a)): 20,000 is b/a < 1.015, a free ring thinner than
/// 1.5 % of the hole's radius.
pub const MAX_MESH_AROUND: f64 = 20_000.0;

/// What a cavity geometry costs, estimated from the source packing's number density before
/// anything is cut ([`CavityGeometry::check`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CavitySize {
    /// Sphere centres in the slab a ≤ ρ ≤ b + w (expected).
    pub spheres: f64,
    /// Peak memory of the static problem (bytes), [`static_memory_estimate`].
    pub bytes: f64,
    /// Pressure tiles (rays) on the wall.
    pub rays: f64,
    /// Ray–sphere tests of the wall loads.
    pub ray_tests: f64,
}

impl CavityGeometry {
    /// Refuse a geometry `source` cannot give a result for, before anything is allocated:
    /// radii that are not 0 < a < b, a clamp width below the longest bond, a ray spacing not
    /// in (0, R̄], a slab whose spheres (estimated from the source's number density) need
    /// more memory than this machine has ([`static_memory_estimate`]) or more than 2³² − 1
    /// indices, wall loads beyond [`MAX_RAY_TESTS`], a free ring too thin for the continuum
    /// mesh ([`MAX_MESH_AROUND`]). Returns the estimate.
    pub fn check(&self, source: &Assembly) -> Result<CavitySize> {
        let g = self;
        let cell = source.packing.cell.ok_or_else(|| {
            Error::Invalid(
                "cavity: the source packing must be periodic (a `# periodic Lx Ly Lz` header)"
                    .into(),
            )
        })?;
        let r_mean = source.packing.mean_radius();
        let longest = source.bonds.length.iter().copied().fold(0.0, f64::max);
        g.check_lengths(r_mean, longest)?;
        let (a, b, w) = (g.inner_radius, g.outer_radius, g.clamp_width);
        let lz = cell.lengths.z;
        let density = source.packing.len() as f64 / source.packing.volume();
        let pi = std::f64::consts::PI;
        let spheres = density * pi * ((b + w).powi(2) - a * a) * lz;
        let bytes = static_memory_estimate(spheres);
        let slab = format!(
            "the slab {a:e} m ≤ ρ ≤ {:e} m (hole radius, clamped radius + clamp width) holds \
             about {spheres:.3e} spheres",
            b + w
        );
        if spheres.is_nan() || spheres >= u32::MAX as f64 {
            return Err(Error::Invalid(format!(
                "cavity: {slab}, more than 2³² − 1 (32-bit indices)"
            )));
        }
        crate::io::check_memory(&format!("cavity: {slab}, which"), bytes)?;
        let rays = (2.0 * pi * a / g.ray_spacing).ceil().max(8.0) * (lz / g.ray_spacing).ceil();
        // Candidates: the spheres within reach of the wall (module doc), three z images each.
        let reach = a + (7.0 + PROBE_RADIUS) * r_mean;
        let candidates = 3.0 * density * pi * (reach * reach - a * a) * lz;
        let ray_tests = rays * candidates;
        if ray_tests.is_nan() || ray_tests > MAX_RAY_TESTS {
            return Err(Error::Invalid(format!(
                "cavity: ray spacing {:e} m gives {rays:.3e} wall rays × about {candidates:.3e} \
                 candidate spheres = {ray_tests:.3e} ray tests, beyond the limit of \
                 {MAX_RAY_TESTS:e} (about a minute); a spacing of R̄/4 = {:e} m (the default) \
             is fine enough",
                g.ray_spacing,
                0.25 * r_mean
            )));
        }
        let around =
            std::f64::consts::TAU * continuum::AnnulusMesh::default().radial as f64 / (b / a).ln();
        if around.is_nan() || around > MAX_MESH_AROUND {
            return Err(Error::Invalid(format!(
                "cavity: clamped radius / hole radius = {:.6} is too close to 1: the continuum \
                 reference's square elements need {around:.3e} nodes around, more than \
                 {MAX_MESH_AROUND}",
                b / a
            )));
        }
        Ok(CavitySize {
            spheres,
            bytes,
            rays,
            ray_tests,
        })
    }

    /// Refuse a hole radius that is not finite and > 0, a clamped radius not above it, a
    /// clamp width below the longest bond `longest` and a ray spacing outside (0, R̄].
    fn check_lengths(&self, r_mean: f64, longest: f64) -> Result<()> {
        let g = self;
        if !(g.inner_radius.is_finite() && g.inner_radius > 0.0) {
            return Err(Error::Invalid(format!(
                "cavity: hole radius {:e} m must be finite and > 0",
                g.inner_radius
            )));
        }
        if !(g.outer_radius.is_finite() && g.outer_radius > g.inner_radius) {
            return Err(Error::Invalid(format!(
                "cavity: need hole radius < clamped radius, got {:e} m and {:e} m",
                g.inner_radius, g.outer_radius
            )));
        }
        if !(g.clamp_width.is_finite() && g.clamp_width >= longest) {
            return Err(Error::Invalid(format!(
                "cavity: clamp width {:e} m must be at least the longest bond, {longest:e} m",
                g.clamp_width
            )));
        }
        if !(g.ray_spacing.is_finite() && g.ray_spacing > 0.0 && g.ray_spacing <= r_mean) {
            return Err(Error::Invalid(format!(
                "cavity: ray spacing {:e} m must be in (0, R̄ = {r_mean:e} m]",
                g.ray_spacing
            )));
        }
        Ok(())
    }
}

/// The bonded holed slab with its supports and its wall loads per unit pressure.
pub struct Cavity {
    /// The cut (packing with its z-periodic cell, sources, the axis).
    pub cut: SlabCut,
    /// Bonds of the cut, drawn by the model's rule (none crosses an x or y face).
    pub bonds: BondSet,
    /// Their springs (the source packing's lattice scaling μ).
    pub springs: BondStiffness,
    /// Geometry.
    pub geometry: CavityGeometry,
    /// Load-carrying network (spheres with fewer than two bonds pruned).
    pub network: Network,
    /// Clamped flag of every sphere of the cut (ρ > b).
    pub clamped: Vec<bool>,
    /// Force per unit pressure on every sphere (m², i.e. N/Pa); zero off the wall.
    pub unit_load: Vec<Vec3>,
    /// Spheres that carry a wall load, increasing.
    pub wall: Vec<u32>,
    /// Wall area 2πa·L_z the loads add up to (m²).
    pub wall_area: f64,
}

impl Cavity {
    /// Cut the slab from the periodic `source` assembly, bond it by the source's model, and
    /// find the wall loads. Refuses what [`CavityGeometry::check`] refuses (before anything
    /// is allocated), a bond crossing an x or y face, a wall ray that meets no sphere within
    /// 6 R̄ of the wall, and a clamped ring that holds nothing.
    pub fn new(source: &Assembly, geometry: CavityGeometry) -> Result<Cavity> {
        source.refuse_manybody("the cavity study (a slab cut free)")?;
        geometry.check(source)?;
        let g = geometry;
        let r_mean = source.packing.mean_radius();
        let longest = source.bonds.length.iter().copied().fold(0.0, f64::max);
        let slab = HoledSlab {
            inner_radius: g.inner_radius,
            outer_radius: g.outer_radius + g.clamp_width,
        };
        let cut = cut_holed_slab(&source.packing, &slab, longest)?;
        let bonds = build_bonds(&cut.packing, source.model.bonding)?;
        if let Some(b) =
            (0..bonds.len()).find(|&b| bonds.image[b][0] != 0 || bonds.image[b][1] != 0)
        {
            return Err(Error::Invalid(format!(
                "cavity: bond {b} crosses an x or y face of the slab's cell (image {:?})",
                bonds.image[b]
            )));
        }
        let lattice_scaling = match source.model.scheme {
            SchemeSpec::CrossAnisotropic(_) => Some(crate::bonds::lattice_scaling(
                &source.packing,
                &source.bonds,
                source.model.geometry.pi_hat,
            )?),
            _ => None,
        };
        let radius = |ends: &[u32]| -> Vec<f64> {
            ends.iter()
                .map(|&p| cut.packing.radii[p as usize])
                .collect()
        };
        let springs = source.model.springs_for(
            &bonds.normal,
            &radius(&bonds.i),
            &radius(&bonds.j),
            &bonds.length,
            lattice_scaling,
        )?;
        let n = cut.packing.len();
        let clamped: Vec<bool> = (0..n)
            .map(|p| cut.radial_distance(p) > g.outer_radius)
            .collect();
        let source_degree = source.bonds.degrees(source.packing.len());
        let degree = bonds.degrees(n);
        let cut_surface: Vec<bool> = (0..n)
            .map(|p| degree[p] < source_degree[cut.source[p] as usize])
            .collect();
        let (bonds, springs) = supported_bonds(n, bonds, springs, &clamped, cut_surface);
        let network = Network::build(&cut.packing, &bonds, &springs, LeverArm::MidGap, true, None)?;
        if !(0..n).any(|p| clamped[p] && network.index[p] != u32::MAX) {
            return Err(Error::Degenerate(
                "cavity: the clamped ring holds no bonded sphere".into(),
            ));
        }
        let (unit_load, wall_area) = wall_loads(&cut, &network, &clamped, g, r_mean)?;
        let wall = (0..n as u32)
            .filter(|&p| unit_load[p as usize] != Vec3::zeros())
            .collect();
        Ok(Cavity {
            cut,
            bonds,
            springs,
            geometry,
            network,
            clamped,
            unit_load,
            wall,
            wall_area,
        })
    }

    /// Position of sphere `p` relative to the hole's axis (m; z as in the cell).
    pub fn relative_position(&self, p: usize) -> Vec3 {
        let x = self.cut.packing.positions[p];
        Vec3::new(x.x - self.cut.axis[0], x.y - self.cut.axis[1], x.z)
    }

    /// Unit radial direction of sphere `p` (from the axis, in the x–y plane).
    pub fn radial_unit(&self, p: usize) -> Vec3 {
        let r = self.relative_position(p);
        Vec3::new(r.x, r.y, 0.0) / r.x.hypot(r.y)
    }

    /// Mean radial wall displacement weighted by the wall loads, Σ f_i·u_i / (p·2πa·L_z)
    /// (m): the displacement work-conjugate to the pressure, ½p·2πa·L_z·ū being the work.
    pub fn wall_displacement(&self, displacement: &[Vec3]) -> f64 {
        let work: f64 = self
            .wall
            .iter()
            .map(|&p| self.unit_load[p as usize].dot(&displacement[p as usize]))
            .sum();
        work / self.wall_area
    }

    /// Mean (radial, axial) displacement (m) of the wall spheres within ±`half_width`
    /// (degrees) of the direction `direction` (degrees from x towards y); NaN when the bin
    /// holds no wall sphere. The continuum's counterpart is
    /// [`continuum::ContinuumCavity::wall_bin`].
    pub fn wall_bin(&self, displacement: &[Vec3], direction: f64, half_width: f64) -> (f64, f64) {
        let (mut ur, mut uz, mut n) = (0.0, 0.0, 0.0);
        for &p in &self.wall {
            let rel = self.relative_position(p as usize);
            if continuum::in_bin(rel.x, rel.y, direction, half_width) {
                let u = displacement[p as usize];
                ur += u.dot(&self.radial_unit(p as usize));
                uz += u.z;
                n += 1.0;
            }
        }
        (ur / n, uz / n)
    }
}

/// The bonds that can carry load to the clamped ring: those of the spheres connected to a
/// clamped sphere without crossing a bridge (a bond whose removal disconnects the network).
/// Clusters the cut leaves floating near the hole, or hanging by a single bond (which
/// without rotational springs is a hinge about its contact point), are rigid-body
/// mechanisms of the slab and are dropped; when every bond has rotational springs only
/// floating clusters are dropped.
fn supported_bonds(
    n: usize,
    bonds: BondSet,
    springs: BondStiffness,
    clamped: &[bool],
    mut cut_surface: Vec<bool>,
) -> (BondSet, BondStiffness) {
    let moments = (0..springs.len()).all(|b| springs.kr[b] > 0.0 && springs.ktw[b] > 0.0);
    let mut alive = vec![true; bonds.len()];
    if !moments {
        // Surface layer of the cut: a sphere that lost bonds to the cut (or to this pruning)
        // keeps at least three bonds or goes; two-bond spheres next to each other there form
        // hinges (12 DOFs, 9 constraints, 2 local rotations).
        let (start, adj) = bond_adjacency(n, &bonds);
        let mut degree = bonds.degrees(n);
        let mut stack: Vec<usize> = (0..n)
            .filter(|&p| cut_surface[p] && degree[p] > 0 && degree[p] < 3 && !clamped[p])
            .collect();
        while let Some(p) = stack.pop() {
            if degree[p] == 0 || degree[p] >= 3 {
                continue;
            }
            for &(b, q) in &adj[start[p]..start[p + 1]] {
                if alive[b] {
                    alive[b] = false;
                    degree[p] -= 1;
                    degree[q] -= 1;
                    cut_surface[q] = true;
                    if degree[q] > 0 && degree[q] < 3 && !clamped[q] {
                        stack.push(q);
                    }
                }
            }
        }
    }
    let (bonds, springs) = subset(&bonds, &springs, &alive);
    let bridge = if moments {
        vec![false; bonds.len()]
    } else {
        bridges(n, &bonds)
    };
    let mut parent: Vec<usize> = (0..n).collect();
    fn root(parent: &mut [usize], mut x: usize) -> usize {
        while parent[x] != x {
            parent[x] = parent[parent[x]];
            x = parent[x];
        }
        x
    }
    for b in (0..bonds.len()).filter(|&b| !bridge[b]) {
        let (i, j) = (
            root(&mut parent, bonds.i[b] as usize),
            root(&mut parent, bonds.j[b] as usize),
        );
        if i != j {
            parent[i.max(j)] = i.min(j);
        }
    }
    let mut held = vec![false; n];
    for (p, _) in clamped.iter().enumerate().filter(|(_, &c)| c) {
        {
            let r = root(&mut parent, p);
            held[r] = true;
        }
    }
    let keep: Vec<bool> = (0..bonds.len())
        .map(|b| {
            let ri = root(&mut parent, bonds.i[b] as usize);
            let rj = root(&mut parent, bonds.j[b] as usize);
            held[ri] && held[rj]
        })
        .collect();
    subset(&bonds, &springs, &keep)
}

/// The bonds (and springs) flagged in `keep`.
fn subset(bonds: &BondSet, springs: &BondStiffness, keep: &[bool]) -> (BondSet, BondStiffness) {
    let mut out = BondSet::default();
    let mut k = BondStiffness::default();
    for b in (0..bonds.len()).filter(|&b| keep[b]) {
        out.push(bonds.i[b], bonds.j[b], bonds.branch(b), bonds.image[b]);
        k.radius.push(springs.radius[b]);
        k.kn.push(springs.kn[b]);
        k.ks.push(springs.ks[b]);
        k.kr.push(springs.kr[b]);
        k.ktw.push(springs.ktw[b]);
    }
    (out, k)
}

/// Every sphere's (bond, neighbour) pairs in CSR form: start offsets and the list.
fn bond_adjacency(n: usize, bonds: &BondSet) -> (Vec<usize>, Vec<(usize, usize)>) {
    let ends = bonds.i.iter().zip(&bonds.j);
    crate::homogenize::network::csr(
        n,
        ends.map(|(&i, &j)| (i as usize, j as usize)),
        |b, other| (b, other),
    )
}

/// Bridges of the bond graph (Tarjan's low-link, iterative depth-first search): flag per bond.
fn bridges(n: usize, bonds: &BondSet) -> Vec<bool> {
    let (start, adj) = bond_adjacency(n, bonds);
    let mut order = vec![usize::MAX; n];
    let mut low = vec![0usize; n];
    let mut is_bridge = vec![false; bonds.len()];
    let mut counter = 0;
    for s in 0..n {
        if order[s] != usize::MAX {
            continue;
        }
        // (node, bond it was reached by, next adjacency slot)
        let mut stack: Vec<(usize, usize, usize)> = vec![(s, usize::MAX, start[s])];
        order[s] = counter;
        low[s] = counter;
        counter += 1;
        while let Some(&mut (v, via, ref mut slot)) = stack.last_mut() {
            if *slot < start[v + 1] {
                let (b, w) = adj[*slot];
                *slot += 1;
                if b == via {
                    continue;
                }
                if order[w] == usize::MAX {
                    order[w] = counter;
                    low[w] = counter;
                    counter += 1;
                    stack.push((w, b, start[w]));
                } else {
                    low[v] = low[v].min(order[w]);
                }
            } else {
                stack.pop();
                if let Some(&(u, _, _)) = stack.last() {
                    low[u] = low[u].min(low[v]);
                    if low[v] > order[u] {
                        is_bridge[via] = true;
                    }
                }
            }
        }
    }
    is_bridge
}

/// Radius of the probe carried by each wall ray, relative to R̄ (module doc).
pub const PROBE_RADIUS: f64 = 0.5;

/// The area-share wall loads per unit pressure (module doc) and the wall area 2πa·L_z.
fn wall_loads(
    cut: &SlabCut,
    network: &Network,
    clamped: &[bool],
    g: CavityGeometry,
    r_mean: f64,
) -> Result<(Vec<Vec3>, f64)> {
    let a = g.inner_radius;
    let lz = cut.packing.cell.map(|c| c.lengths.z).unwrap_or(0.0);
    let n_theta = ((2.0 * std::f64::consts::PI * a / g.ray_spacing).ceil() as usize).max(8);
    let n_z = ((lz / g.ray_spacing).ceil() as usize).max(1);
    let (dtheta, dz) = (2.0 * std::f64::consts::PI / n_theta as f64, lz / n_z as f64);
    let tile = a * dtheta * dz;
    let reach = a + 6.0 * r_mean;
    let probe = PROBE_RADIUS * r_mean;
    // Candidates: bonded, free spheres near the wall, with their z images.
    let mut cand: Vec<(usize, Vec3, f64)> = Vec::new();
    for (p, &held) in clamped.iter().enumerate() {
        if network.index[p] == u32::MAX || held {
            continue;
        }
        let rho = cut.radial_distance(p);
        let r = cut.packing.radii[p] + probe;
        if rho - r > reach {
            continue;
        }
        let x = cut.packing.positions[p];
        for s in [-1.0, 0.0, 1.0] {
            let c = Vec3::new(x.x - cut.axis[0], x.y - cut.axis[1], x.z + s * lz);
            cand.push((p, c, r));
        }
    }
    let mut load = vec![Vec3::zeros(); cut.packing.len()];
    for m in 0..n_theta {
        let th = (m as f64 + 0.5) * dtheta;
        let e = Vec3::new(th.cos(), th.sin(), 0.0);
        for k in 0..n_z {
            let z = (k as f64 + 0.5) * dz;
            let mut best: Option<(f64, usize)> = None;
            for &(p, c, r) in &cand {
                let w = Vec3::new(c.x, c.y, c.z - z);
                let s = w.dot(&e);
                if s <= 0.0 {
                    continue;
                }
                let d2 = w.norm_squared() - s * s;
                if d2 >= r * r {
                    continue;
                }
                let t = s - (r * r - d2).sqrt();
                if best.is_none_or(|(bt, _)| t < bt) {
                    best = Some((t, p));
                }
            }
            let (_, p) = best.ok_or_else(|| {
                Error::Degenerate(format!(
                    "cavity: the wall ray at θ = {:.1}°, z = {z:e} m meets no bonded free sphere \
                     within 6 R̄ of the hole: the wall is not closed",
                    th.to_degrees()
                ))
            })?;
            load[p] += e * tile;
        }
    }
    Ok((load, 2.0 * std::f64::consts::PI * a * lz))
}

/// Lamé's thick cylinder in plane strain, inner radius `a` under pressure `p` (Pa), outer
/// radius `b` clamped (u(b) = 0), Lamé constants λ, μ (Pa): u(r) = A r + B/r with
/// A = −B/b², B = p / (2(λ+μ)/b² + 2μ/a²); returns the wall displacement u(a) (m),
/// positive outward (Timoshenko & Goodier, Theory of Elasticity, Sec. 28).
pub fn lame_wall_displacement(p: f64, a: f64, b: f64, lambda: f64, mu: f64) -> f64 {
    let bb = p / (2.0 * (lambda + mu) / (b * b) + 2.0 * mu / (a * a));
    bb * (1.0 / a - a / (b * b))
}

/// The Lamé constants (λ, μ) of the isotropic projection of C by group means:
/// λ = mean(C12, C13, C23), μ = mean(C44, C55, C66) (Pa); exact for an isotropic C.
pub fn isotropic_lame_constants(c: &crate::tensor::Stiffness6) -> (f64, f64) {
    (
        (c[(0, 1)] + c[(0, 2)] + c[(1, 2)]) / 3.0,
        (c[(3, 3)] + c[(4, 4)] + c[(5, 5)]) / 3.0,
    )
}

/// Bulk density of a packing of spheres of material density `material_density` (kg/m³):
/// ρ_s·Σ(4/3)πR³/V (kg/m³), the density of the continuum its waves see.
pub fn bulk_density(packing: &crate::packing::Packing, material_density: f64) -> f64 {
    let solid: f64 = packing
        .radii
        .iter()
        .map(|r| 4.0 / 3.0 * std::f64::consts::PI * r * r * r)
        .sum();
    material_density * solid / packing.volume()
}
