//! Mean-field stiffness: the continuous orientation average of the bond lattice tensor
//! under uniform strain (Truszkowska 2018, App. A; Šmilauer's microplane integral,
//! Eq. 16), no packing needed.
//!
//! C = prefactor · T,  T = ⟨ C_bond(n; k_n(n), k_t(n)) ⟩_{n ∈ S²}  (uniform average),
//! with C_bond = [`bond_lattice_tensor`] and prefactor = N_c⟨l²·g⟩/V, where g is the
//! geometry factor turning a scheme's magnitude into a spring constant (k = magnitude·g).
//! For equal spheres and the `spring` convention N_c⟨l²⟩/V = 3Zφ/(2πR)
//! ([`equal_sphere_prefactor`]). For the `modulus` convention (k = E′·π̂r²/l) the prefactor
//! is N⟨l·π̂r²⟩/V = 6μ with μ Šmilauer's lattice scaling (Šmilauer Eq. 20).
//!
//! The microplane tensor of Šmilauer (Šmilauer Eq. 3) is
//! C_micro = (3/2π)∫(…)dΩ = 6·T, because (3/2π)·4π = 6.
//!
//! Bond functions of the cubic scheme have kinks along great circles (the envelope of
//! several spheroids switches branch), so a plain (θ, φ) Gauss rule converges only
//! algebraically. [`SphereQuadrature`] splits the sphere along the scheme's kink planes and
//! integrates each smooth spherical triangle with a Gauss rule, which converges
//! exponentially.

use rayon::prelude::*;

use crate::bonds::BondSet;
use crate::homogenize::bond_lattice_tensor;
use crate::packing::Packing;
use crate::schemes::{Geometry, StiffnessScheme};
use crate::tensor::Stiffness6;
use crate::{Error, Result, Vec3};

/// Gauss–Legendre order per direction (per spherical triangle, `order²` points) that gives
/// the cubic spheroid models of docs/references.md (a_n = 4.31, a_s = 10, plain and extended) to
/// better than 1e-10 relative (measured: 2–3e-11 at 18, 1.6e-10 at 16, 1e-15 at 28).
pub const DEFAULT_ORDER: usize = 18;

/// Tolerance on v·n̂ (unit vectors) under which a vertex is taken to lie on a kink plane.
const ON_PLANE_TOL: f64 = 1e-12;

/// Tolerance on |n̂_a × n̂_b| under which two kink planes are the same plane.
const SAME_PLANE_TOL: f64 = 1e-12;

/// Pieces with an edge chord longer than this (a 60° arc, plus rounding slack) are
/// subdivided in four.
const MAX_EDGE_CHORD: f64 = 1.0 + 1e-9;

/// Directions per rayon task; fixed so that sums do not depend on the thread count.
const CHUNK: usize = 1024;

/// Gauss–Legendre nodes and weights on [−1, 1] with `n` points (exact for polynomials of
/// degree ≤ 2n − 1). Nodes by Newton iteration on the three-term Legendre recurrence,
/// converged to machine precision (|Δx| ≤ 1e-15); `n = 0` gives empty vectors.
pub fn gauss_legendre(n: usize) -> (Vec<f64>, Vec<f64>) {
    let mut x = vec![0.0; n];
    let mut w = vec![0.0; n];
    let m = n.div_ceil(2);
    let nf = n as f64;
    for i in 0..m {
        // Tricomi's initial guess for the i-th largest root.
        let mut z = (std::f64::consts::PI * (i as f64 + 0.75) / (nf + 0.5)).cos();
        let mut dp = 1.0;
        for _ in 0..100 {
            let (p, d) = legendre_with_derivative(n, z);
            dp = d;
            let dz = p / d;
            z -= dz;
            if dz.abs() <= 1e-15 {
                let (_, d) = legendre_with_derivative(n, z);
                dp = d;
                break;
            }
        }
        x[i] = -z;
        x[n - 1 - i] = z;
        let wi = 2.0 / ((1.0 - z * z) * dp * dp);
        w[i] = wi;
        w[n - 1 - i] = wi;
    }
    if n % 2 == 1 {
        x[n / 2] = 0.0;
    }
    (x, w)
}

/// P_n(z) and P_n′(z) by the recurrence (k+1)P_{k+1} = (2k+1)zP_k − kP_{k−1}.
fn legendre_with_derivative(n: usize, z: f64) -> (f64, f64) {
    let mut p0 = 1.0;
    let mut p1 = z;
    if n == 0 {
        return (1.0, 0.0);
    }
    for k in 1..n {
        let kf = k as f64;
        let p2 = ((2.0 * kf + 1.0) * z * p1 - kf * p0) / (kf + 1.0);
        p0 = p1;
        p1 = p2;
    }
    let d = n as f64 * (z * p1 - p0) / (z * z - 1.0);
    (p1, d)
}

/// A cubature rule for the uniform average over the unit sphere: ⟨f⟩ ≈ Σ wᵢ f(nᵢ), Σ wᵢ = 1.
///
/// Built by [`SphereQuadrature::new`]: the 8 octant triangles of the octahedron are cut by
/// every kink plane (great circle) they straddle, and each resulting spherical triangle
/// (v0, v1, v2) is integrated through the radial projection of the flat triangle,
/// p = v0 + s(v1−v0) + t(v2−v0), n = p/|p|, dΩ = |((v1−v0)×(v2−v0))·p|/|p|³ ds dt,
/// with a collapsed (Duffy) Gauss–Legendre product rule: s = u(1−v), t = uv, ds dt = u du dv,
/// `order` Gauss–Legendre points in each of u and v on [0, 1]. Weights are divided by 4π.
/// Pieces with an edge longer than 60° are first subdivided in four at the arc midpoints
/// (so the bare octahedron becomes 32 triangles); the 48 O_h fundamental triangles of the
/// cubic scheme are left as they are.
#[derive(Clone, Debug, Default)]
pub struct SphereQuadrature {
    /// Unit directions nᵢ.
    pub directions: Vec<Vec3>,
    /// Weights wᵢ (sum 1).
    pub weights: Vec<f64>,
}

/// A spherical triangle by its three unit vertices.
type SphericalTriangle = [Vec3; 3];

impl SphereQuadrature {
    /// The split-sphere rule for functions smooth except across the great circles with unit
    /// normals `kink_planes` (parallel or antiparallel duplicates, zero and non-finite
    /// normals are ignored), with `order` Gauss–Legendre points per direction in each
    /// spherical triangle (`order = 0` is taken as 1).
    pub fn new(kink_planes: &[Vec3], order: usize) -> SphereQuadrature {
        let triangles = split_sphere(kink_planes);
        let order = order.max(1);
        let (x, w) = gauss_legendre(order);
        // Map to [0, 1].
        let nodes: Vec<(f64, f64)> = x
            .iter()
            .zip(&w)
            .map(|(&xi, &wi)| (0.5 * (xi + 1.0), 0.5 * wi))
            .collect();
        let n_points = triangles.len() * order * order;
        let mut directions = Vec::with_capacity(n_points);
        let mut weights = Vec::with_capacity(n_points);
        let norm = 1.0 / (4.0 * std::f64::consts::PI);
        for [v0, v1, v2] in &triangles {
            let e1 = v1 - v0;
            let e2 = v2 - v0;
            let cross = e1.cross(&e2);
            for &(u, wu) in &nodes {
                for &(v, wv) in &nodes {
                    let s = u * (1.0 - v);
                    let t = u * v;
                    let p = v0 + e1 * s + e2 * t;
                    let r = p.norm();
                    let jac = cross.dot(&p).abs() / (r * r * r);
                    directions.push(p / r);
                    weights.push(wu * wv * u * jac * norm);
                }
            }
        }
        SphereQuadrature {
            directions,
            weights,
        }
    }

    /// Number of directions.
    pub fn len(&self) -> usize {
        self.directions.len()
    }

    /// True when the rule has no directions.
    pub fn is_empty(&self) -> bool {
        self.directions.is_empty()
    }

    /// The orientation average ⟨f⟩ ≈ Σ wᵢ f(nᵢ), summed in index order.
    pub fn average<F: Fn(&Vec3) -> f64>(&self, f: F) -> f64 {
        self.directions
            .iter()
            .zip(&self.weights)
            .map(|(n, w)| w * f(n))
            .sum()
    }
}

/// The octahedron's 8 octant triangles cut along every distinct kink plane: spherical
/// triangles none of which straddles a kink plane.
fn split_sphere(kink_planes: &[Vec3]) -> Vec<SphericalTriangle> {
    let planes = distinct_planes(kink_planes);
    let mut triangles = octahedron_triangles();
    for plane in &planes {
        let mut next = Vec::with_capacity(triangles.len() * 2);
        for tri in &triangles {
            split_triangle(tri, plane, &mut next);
        }
        triangles = next;
    }
    // Large smooth pieces (the bare octants) are halved along their edges until no edge
    // spans more than 60°: the radial-projection Jacobian varies less, and smooth schemes
    // converge as fast as the kinked cubic ones on their 48 fundamental triangles.
    let mut out = Vec::with_capacity(triangles.len());
    while let Some(tri) = triangles.pop() {
        let longest = (0..3)
            .map(|k| (tri[(k + 1) % 3] - tri[k]).norm())
            .fold(0.0, f64::max);
        if longest > MAX_EDGE_CHORD {
            let m = |a: &Vec3, b: &Vec3| (a + b).normalize();
            let (m01, m12, m20) = (
                m(&tri[0], &tri[1]),
                m(&tri[1], &tri[2]),
                m(&tri[2], &tri[0]),
            );
            triangles.push([tri[0], m01, m20]);
            triangles.push([m01, tri[1], m12]);
            triangles.push([m20, m12, tri[2]]);
            triangles.push([m01, m12, m20]);
        } else {
            out.push(tri);
        }
    }
    out.reverse();
    out
}

/// Normalised kink-plane normals without duplicates (n and −n are the same plane).
fn distinct_planes(kink_planes: &[Vec3]) -> Vec<Vec3> {
    let mut out: Vec<Vec3> = Vec::new();
    for p in kink_planes {
        let len = p.norm();
        if !len.is_finite() || len == 0.0 {
            continue;
        }
        let n = p / len;
        if out.iter().all(|q| q.cross(&n).norm() > SAME_PLANE_TOL) {
            out.push(n);
        }
    }
    out
}

/// The 8 octant triangles of the octahedron, vertices counter-clockwise seen from outside.
fn octahedron_triangles() -> Vec<SphericalTriangle> {
    let mut out = Vec::with_capacity(8);
    for sx in [1.0, -1.0] {
        for sy in [1.0, -1.0] {
            for sz in [1.0, -1.0] {
                out.push([
                    Vec3::new(sx, 0.0, 0.0),
                    Vec3::new(0.0, sy, 0.0),
                    Vec3::new(0.0, 0.0, sz),
                ]);
            }
        }
    }
    out
}

/// Point where the great circle with normal `n` crosses the arc a–b (sa = a·n, sb = b·n of
/// opposite signs), on the unit sphere.
fn arc_crossing(a: &Vec3, b: &Vec3, sa: f64, sb: f64) -> Vec3 {
    let t = sa / (sa - sb);
    let p = a + (b - a) * t;
    p / p.norm()
}

/// Cut `tri` by the great circle with unit normal `n` if it straddles it, pushing the
/// pieces (1, 2 or 3 spherical triangles) to `out`. Vertices within [`ON_PLANE_TOL`] of the
/// plane count as on it.
fn split_triangle(tri: &SphericalTriangle, n: &Vec3, out: &mut Vec<SphericalTriangle>) {
    let s: [f64; 3] = [tri[0].dot(n), tri[1].dot(n), tri[2].dot(n)];
    let side = |x: f64| {
        if x > ON_PLANE_TOL {
            1
        } else if x < -ON_PLANE_TOL {
            -1
        } else {
            0
        }
    };
    let sides = [side(s[0]), side(s[1]), side(s[2])];
    let has_pos = sides.contains(&1);
    let has_neg = sides.contains(&-1);
    if !(has_pos && has_neg) {
        out.push(*tri);
        return;
    }
    // Rotate the vertex labels (keeping orientation) so that vertex 0 is the odd one out:
    // the one on the plane, or the one alone on its side.
    let k = if let Some(k) = sides.iter().position(|&x| x == 0) {
        k
    } else if sides.iter().filter(|&&x| x == 1).count() == 1 {
        sides.iter().position(|&x| x == 1).unwrap_or(0)
    } else {
        sides.iter().position(|&x| x == -1).unwrap_or(0)
    };
    let (a, b, c) = (tri[k], tri[(k + 1) % 3], tri[(k + 2) % 3]);
    let (sa, sb, sc) = (s[k], s[(k + 1) % 3], s[(k + 2) % 3]);
    if sides[k] == 0 {
        // The plane passes through a and crosses the opposite arc b–c.
        let m = arc_crossing(&b, &c, sb, sc);
        out.push([a, b, m]);
        out.push([a, m, c]);
    } else {
        // a alone on its side: the plane crosses arcs a–b and a–c.
        let mab = arc_crossing(&a, &b, sa, sb);
        let mac = arc_crossing(&a, &c, sa, sc);
        out.push([a, mab, mac]);
        // The quadrilateral mab, b, c, mac as two triangles, cut along its shorter diagonal.
        if (c - mab).norm() <= (b - mac).norm() {
            out.push([mab, b, c]);
            out.push([mab, c, mac]);
        } else {
            out.push([mab, b, mac]);
            out.push([b, c, mac]);
        }
    }
}

/// T = ⟨ bond_lattice_tensor(n, k_n(n), k_t(n)) ⟩ over the sphere (Truszkowska 2018,
/// App. A), with k_n, k_t the scheme's normal and shear magnitudes. Directions are processed
/// in parallel in fixed chunks whose partial sums are added in chunk order, so the result
/// does not depend on the number of threads.
pub fn orientation_average(scheme: &dyn StiffnessScheme, quad: &SphereQuadrature) -> Stiffness6 {
    let n = quad.directions.len().min(quad.weights.len());
    let partial: Vec<Stiffness6> = (0..n.div_ceil(CHUNK))
        .into_par_iter()
        .map(|c| {
            let lo = c * CHUNK;
            let hi = (lo + CHUNK).min(n);
            let mut sum = Stiffness6::zeros();
            for (dir, w) in quad.directions[lo..hi].iter().zip(&quad.weights[lo..hi]) {
                let m = scheme.magnitudes(dir);
                sum += bond_lattice_tensor(dir, m.normal, m.shear) * *w;
            }
            sum
        })
        .collect();
    partial
        .into_iter()
        .fold(Stiffness6::zeros(), |acc, part| acc + part)
}

/// Mean-field stiffness C = prefactor·T (Truszkowska 2018, App. A; Šmilauer
/// Eq. 16) with T from [`orientation_average`] on a [`SphereQuadrature`] split
/// along `scheme.kink_planes()` with `order` points per direction ([`DEFAULT_ORDER`] is a
/// good choice).
///
/// `prefactor` = N_c⟨l²·g⟩/V (bonds per volume times the mean of squared bond length times
/// the geometry factor g of k = magnitude·g). For equal spheres and the `spring` convention
/// it is 3Zφ/(2πR) ([`equal_sphere_prefactor`]); for the `modulus` convention it is 6μ
/// (Šmilauer's lattice scaling).
pub fn mean_field(scheme: &dyn StiffnessScheme, prefactor: f64, order: usize) -> Stiffness6 {
    let quad = SphereQuadrature::new(&scheme.kink_planes(), order);
    orientation_average(scheme, &quad) * prefactor
}

/// Relative accuracy [`mean_field_converged`] guarantees: successive quadrature orders agree
/// to this fraction of the largest entry.
pub const MEAN_FIELD_TOLERANCE: f64 = 1e-10;

/// Highest quadrature order [`mean_field_converged`] tries.
pub const MAX_ORDER: usize = 576;

/// [`mean_field`] to `MEAN_FIELD_TOLERANCE`: from [`DEFAULT_ORDER`] the order is doubled
/// until two successive orders agree (sharp spheroids, a_n or a_s far from 1, need more than
/// the default: a_s = 0.03 breaks cubic symmetry by 3e-4 at order 18). Refuses, with the
/// accuracy reached, when `MAX_ORDER` is not enough.
pub fn mean_field_converged(scheme: &dyn StiffnessScheme, prefactor: f64) -> Result<Stiffness6> {
    let mut order = DEFAULT_ORDER;
    let mut c = mean_field(scheme, prefactor, order);
    loop {
        let next = mean_field(scheme, prefactor, 2 * order);
        let scale = next.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        let change = (next - c).iter().fold(0.0f64, |m, v| m.max(v.abs()));
        if change <= MEAN_FIELD_TOLERANCE * scale {
            return Ok(next);
        }
        order *= 2;
        c = next;
        if 2 * order > MAX_ORDER {
            return Err(Error::NotConverged(format!(
                "mean field: the orientation integral changes by {:.1e} of its largest entry \
                 between orders {} and {} (tolerance {MEAN_FIELD_TOLERANCE:e}); the stiffness \
                 functions are too sharp for the quadrature",
                change / scale,
                order / 2,
                order
            )));
        }
    }
}

/// Mean-field prefactor N_c⟨l²·g⟩/V of a bonded packing (g = the geometry factor, k = magnitude·g): the
/// bond density the orientation integral is scaled by (Truszkowska 2018 App. A).
pub fn packing_prefactor(packing: &Packing, bonds: &BondSet, geometry: &Geometry) -> f64 {
    let s: f64 = (0..bonds.len())
        .map(|k| {
            let ri = packing.radii[bonds.i[k] as usize];
            let rj = packing.radii[bonds.j[k] as usize];
            let l = bonds.length[k];
            l * l * geometry.factor(ri, rj, l)
        })
        .sum();
    s / packing.volume()
}

/// N_c⟨l²⟩/V = 3Zφ/(2πR) for equal spheres of radius R with bond length 2R, coordination Z
/// and solid fraction φ (N_c = ZN/2 bonds, N = φV/(4πR³/3) spheres; docs/references.md
/// "Cubic mean field").
pub fn equal_sphere_prefactor(coordination: f64, solid_fraction: f64, radius: f64) -> f64 {
    3.0 * coordination * solid_fraction / (2.0 * std::f64::consts::PI * radius)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gauss_legendre_small_orders_closed_form() {
        let (x, w) = gauss_legendre(2);
        assert!((x[1] - 1.0 / 3f64.sqrt()).abs() < 1e-15);
        assert!((x[0] + 1.0 / 3f64.sqrt()).abs() < 1e-15);
        assert!((w[0] - 1.0).abs() < 1e-15 && (w[1] - 1.0).abs() < 1e-15);
        let (x, w) = gauss_legendre(3);
        assert!((x[2] - (0.6f64).sqrt()).abs() < 1e-15);
        assert_eq!(x[1], 0.0);
        assert!((w[1] - 8.0 / 9.0).abs() < 1e-15);
        assert!((w[0] - 5.0 / 9.0).abs() < 1e-15);
    }

    #[test]
    fn gauss_legendre_integrates_degree_2n_minus_1_exactly() {
        for n in [5usize, 17, 40] {
            let (x, w) = gauss_legendre(n);
            // ∫_{-1}^{1} x^k dx = 2/(k+1) for even k, 0 for odd k.
            for k in 0..(2 * n) {
                let q: f64 = x
                    .iter()
                    .zip(&w)
                    .map(|(xi, wi)| wi * xi.powi(k as i32))
                    .sum();
                let exact = if k % 2 == 0 {
                    2.0 / (k as f64 + 1.0)
                } else {
                    0.0
                };
                assert!((q - exact).abs() < 1e-14, "n={n} k={k}: {q} vs {exact}");
            }
            // Nodes are roots of P_n to 1e-15 (scaled by the derivative).
            for xi in &x {
                let (p, d) = legendre_with_derivative(n, *xi);
                assert!((p / d).abs() < 1e-15, "n={n}: root {xi} residual {}", p / d);
            }
        }
    }

    /// The 9 mirror planes of O_h, in an order where some cuts cross arcs away from vertices.
    fn cubic_mirror_planes() -> Vec<Vec3> {
        let mut planes = vec![Vec3::x(), Vec3::y(), Vec3::z()];
        for (a, b) in [(0, 1), (0, 2), (1, 2)] {
            for sign in [1.0, -1.0] {
                let mut v = Vec3::zeros();
                v[a] = 1.0;
                v[b] = sign;
                planes.push(v);
            }
        }
        planes
    }

    #[test]
    fn no_piece_straddles_a_kink_plane_and_pieces_tile_the_sphere() {
        let mut planes = cubic_mirror_planes();
        planes.push(Vec3::new(0.3, -1.1, 0.7));
        planes.push(Vec3::new(-2.0, 0.5, 1.0));
        let tris = split_sphere(&planes);
        for tri in &tris {
            for p in &planes {
                let n = p / p.norm();
                let s: Vec<f64> = tri.iter().map(|v| v.dot(&n)).collect();
                let pos = s.iter().any(|&x| x > 1e-12);
                let neg = s.iter().any(|&x| x < -1e-12);
                assert!(!(pos && neg), "piece {tri:?} straddles {n}");
            }
            // Pieces are non-degenerate spherical triangles, vertices on the sphere.
            assert!((tri[1] - tri[0]).cross(&(tri[2] - tri[0])).norm() > 1e-6);
            for v in tri {
                assert!((v.norm() - 1.0).abs() < 1e-15);
            }
        }
        // Total solid angle 4π: weights sum to 1.
        let q = SphereQuadrature::new(&planes, 12);
        let sum: f64 = q.weights.iter().sum();
        assert!((sum - 1.0).abs() < 1e-14, "weights sum {sum}");
        assert!(q.weights.iter().all(|&w| w > 0.0));
    }

    #[test]
    fn duplicate_and_degenerate_planes_are_ignored() {
        let a = SphereQuadrature::new(&cubic_mirror_planes(), 2);
        let mut planes = cubic_mirror_planes();
        planes.extend(cubic_mirror_planes().iter().map(|p| -2.0 * p));
        planes.push(Vec3::zeros());
        planes.push(Vec3::new(f64::NAN, 0.0, 1.0));
        let b = SphereQuadrature::new(&planes, 2);
        assert_eq!(a.len(), b.len());
    }

    #[test]
    fn octant_is_cut_in_three_two_or_not_at_all() {
        let octant = [Vec3::x(), Vec3::y(), Vec3::z()];
        let count = |n: Vec3| {
            let mut out = Vec::new();
            split_triangle(&octant, &n.normalize(), &mut out);
            out
        };
        // z alone on the negative side: a triangle and a quadrilateral (two triangles).
        let pieces = count(Vec3::new(1.0, 2.0, -3.0));
        assert_eq!(pieces.len(), 3);
        // The plane x = y passes through vertex z: two triangles meeting at (1,1,0)/√2.
        let pieces = count(Vec3::new(1.0, -1.0, 0.0));
        assert_eq!(pieces.len(), 2);
        let mid = Vec3::new(1.0, 1.0, 0.0).normalize();
        assert!(pieces
            .iter()
            .all(|t| t.iter().any(|v| (v - mid).norm() < 1e-15)));
        // Planes that only touch the octant (an edge or a vertex) or miss it leave it whole.
        assert_eq!(count(Vec3::x()).len(), 1);
        assert_eq!(count(Vec3::new(1.0, 1.0, 0.0)).len(), 1);
        // A vertex within the tolerance of the plane counts as on it: no sliver triangle.
        assert_eq!(count(Vec3::new(1e-14, 1.0, -1.0)).len(), 2);
        assert_eq!(count(Vec3::new(1e-9, 1.0, -1.0)).len(), 3);
        assert_eq!(count(Vec3::new(1.0, 1.0, 1.0)).len(), 1);
    }
}
