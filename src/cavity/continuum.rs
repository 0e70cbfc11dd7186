//! Continuum reference of the pressurised cavity for any stiffness tensor: the anisotropic
//! plane problem with out-of-plane displacement (Lekhnitskii's generalized plane strain:
//! u_x, u_y, u_z functions of x, y; ε_zz = 0, γ_yz = ∂u_z/∂y, γ_xz = ∂u_z/∂x) on the annulus
//! a ≤ ρ ≤ b, clamped at ρ = b, pressure p on ρ = a; the slab's boundary value problem with
//! the relaxed tensor in place of the bonds. Solved by linear triangles on a polar mesh graded
//! geometrically towards the hole (near-square elements), one sparse Cholesky of the
//! 3-DOF-per-node stiffness. Lamé's thick cylinder is its isotropic special case
//! (tests/cavity/continuum.rs); a tilted material axis couples the in-plane load to u_z.

use crate::homogenize::cholesky::BlockCholesky;
use crate::homogenize::network::Block6;
use crate::homogenize::sparse::BlockSparse;
use crate::tensor::Stiffness6;
use crate::{Error, Result, Vec3};
use nalgebra::SMatrix;
use std::collections::BTreeMap;

/// Mesh of the annulus: `radial` rings of elements, `around` nodes per ring (0 → about as many
/// as make the elements square: 2π·radial/ln(b/a)).
#[derive(Clone, Copy, Debug)]
pub struct AnnulusMesh {
    /// Element rings between a and b (≥ 2).
    pub radial: usize,
    /// Nodes around each ring (≥ 8; 0: square elements).
    pub around: usize,
}

impl Default for AnnulusMesh {
    fn default() -> Self {
        AnnulusMesh {
            radial: 48,
            around: 0,
        }
    }
}

/// Memory per mesh node of [`solve_annulus`] (bytes), an upper estimate: three unknowns,
/// about seven neighbours' 3×3 blocks in the sparse stiffness and its Cholesky fill.
const BYTES_PER_NODE: f64 = 4000.0;

/// The continuum solution.
#[derive(Clone, Debug)]
pub struct ContinuumCavity {
    /// Hole radius a (m).
    pub inner_radius: f64,
    /// Node positions (x, y) (m), ring by ring from ρ = a.
    pub nodes: Vec<[f64; 2]>,
    /// Displacement of every node (m).
    pub displacement: Vec<Vec3>,
    /// Nodes per ring (the first ring is the wall ρ = a).
    pub around: usize,
    /// Work-conjugate wall displacement Σ f·u/(p·perimeter) (m): the mean radial wall
    /// displacement, as [`super::Cavity::wall_displacement`].
    pub wall_displacement: f64,
    /// Relative residual ‖K u − f‖/‖f‖ of the solve.
    pub relative_residual: f64,
}

/// Strain–displacement matrix of one node of a linear triangle (shape-function gradient
/// (gx, gy)): Voigt strains (11, 22, 33, 23, 13, 12), engineering shears, from (u_x, u_y, u_z).
fn strain_node(gx: f64, gy: f64) -> SMatrix<f64, 6, 3> {
    let mut b = SMatrix::<f64, 6, 3>::zeros();
    b[(0, 0)] = gx;
    b[(1, 1)] = gy;
    b[(3, 2)] = gy;
    b[(4, 2)] = gx;
    b[(5, 0)] = gy;
    b[(5, 1)] = gx;
    b
}

/// Solve the annulus a ≤ ρ ≤ b (m), clamped at b, under pressure `pressure` (Pa, > 0 pushes the
/// wall outward) for the Voigt stiffness `c` (Pa, engineering shears, the hole along z).
/// Refuses radii that are not 0 < a < b, a non-finite pressure or stiffness, a mesh below 2
/// rings or 8 nodes around or beyond the machine's memory; errors when `c` is not positive definite on the plane problem
/// (factorisation) or the residual exceeds 1e-10.
pub fn solve_annulus(
    c: &Stiffness6,
    inner_radius: f64,
    outer_radius: f64,
    pressure: f64,
    mesh: &AnnulusMesh,
) -> Result<ContinuumCavity> {
    let (a, b) = (inner_radius, outer_radius);
    check_annulus(c, a, b, pressure)?;
    let rings = Rings::new(mesh, a, b)?;
    let nodes = rings.nodes(a, b);
    let free = rings.free();
    let k = rings.stiffness(c, &nodes);
    let (f, perimeter) = rings.wall_load(&nodes, pressure);
    let (u, relative_residual) = solve_checked(&k, &f)?;
    let mut displacement = vec![Vec3::zeros(); nodes.len()];
    let mut work = 0.0;
    for q in 0..free {
        displacement[q] = Vec3::new(u[q][(0, 0)], u[q][(1, 0)], u[q][(2, 0)]);
        work += Vec3::new(f[q][(0, 0)], f[q][(1, 0)], f[q][(2, 0)]).dot(&displacement[q]);
    }
    if displacement
        .iter()
        .any(|d| !d.iter().all(|x| x.is_finite()))
    {
        return Err(Error::Degenerate(
            "continuum cavity: non-finite displacement".into(),
        ));
    }
    Ok(ContinuumCavity {
        inner_radius: a,
        nodes,
        displacement,
        around: rings.around,
        wall_displacement: work / (pressure * perimeter),
        relative_residual,
    })
}

/// Refuse radii that are not 0 < a < b, a non-finite pressure or stiffness, and a stiffness
/// not positive definite on the plane problem's strains (11, 22, 23, 13, 12): a displacement
/// component without stiffness would be dropped, not solved for.
fn check_annulus(c: &Stiffness6, a: f64, b: f64, pressure: f64) -> Result<()> {
    if !(a.is_finite() && b.is_finite() && a > 0.0 && b > a) {
        return Err(Error::Invalid(format!(
            "continuum cavity: radii must be 0 < a < b, got a = {a:e} m, b = {b:e} m"
        )));
    }
    if !(pressure.is_finite() && c.iter().all(|x| x.is_finite())) {
        return Err(Error::Invalid(
            "continuum cavity: pressure and stiffness must be finite".into(),
        ));
    }
    let plane = [0usize, 1, 3, 4, 5];
    let c5 = nalgebra::SMatrix::<f64, 5, 5>::from_fn(|i, j| c[(plane[i], plane[j])]);
    if c5.cholesky().is_none() {
        return Err(Error::Invalid(
            "continuum cavity: the stiffness tensor is not positive definite on the plane \
             problem's strains (11, 22, 23, 13, 12)"
                .into(),
        ));
    }
    Ok(())
}

/// The polar mesh: `radial` rings of elements, `around` nodes per ring, ring 0 the wall and
/// ring `radial` clamped; nodes numbered ring by ring.
struct Rings {
    /// Element rings.
    radial: usize,
    /// Nodes per ring.
    around: usize,
}

impl Rings {
    /// The mesh's size (`around` = 0: square elements, 2π·radial/ln(b/a)); refuses fewer than
    /// 2 rings or 8 nodes around, and a mesh beyond the machine's memory.
    fn new(mesh: &AnnulusMesh, a: f64, b: f64) -> Result<Rings> {
        let radial = mesh.radial;
        let around = if mesh.around == 0 {
            (std::f64::consts::TAU * radial as f64 / (b / a).ln()).round() as usize
        } else {
            mesh.around
        };
        if radial < 2 || around < 8 {
            return Err(Error::Invalid(format!(
                "continuum cavity: the mesh needs ≥ 2 rings and ≥ 8 nodes around, got {radial} × \
                 {around}"
            )));
        }
        let nodes_total = (radial as f64 + 1.0) * around as f64;
        crate::io::check_memory(
            &format!("continuum cavity: the mesh of {radial} × {around} elements"),
            nodes_total * BYTES_PER_NODE,
        )?;
        Ok(Rings { radial, around })
    }

    /// Node `j` (mod `around`) of ring `i`.
    fn node(&self, i: usize, j: usize) -> usize {
        i * self.around + j % self.around
    }

    /// Free nodes: rings 0..radial, numbered as the nodes.
    fn free(&self) -> usize {
        self.radial * self.around
    }

    /// Node positions, radii graded geometrically from a to b (near-square elements).
    fn nodes(&self, a: f64, b: f64) -> Vec<[f64; 2]> {
        let mut nodes = Vec::with_capacity((self.radial + 1) * self.around);
        for i in 0..=self.radial {
            let rho = a * (b / a).powf(i as f64 / self.radial as f64);
            for j in 0..self.around {
                let th = std::f64::consts::TAU * j as f64 / self.around as f64;
                nodes.push([rho * th.cos(), rho * th.sin()]);
            }
        }
        nodes
    }

    /// The stiffness of the free nodes: two linear triangles per quad, the diagonal
    /// alternated so the mesh has no preferred shear direction (3×3 blocks in 6×6 storage).
    fn stiffness(&self, c: &Stiffness6, nodes: &[[f64; 2]]) -> BlockSparse {
        let free = self.free();
        let mut rows: Vec<BTreeMap<u32, Block6>> = vec![BTreeMap::new(); free];
        for i in 0..self.radial {
            for j in 0..self.around {
                let quad = [
                    self.node(i, j),
                    self.node(i + 1, j),
                    self.node(i + 1, j + 1),
                    self.node(i, j + 1),
                ];
                let tris = if (i + j) % 2 == 0 {
                    [[quad[0], quad[1], quad[2]], [quad[0], quad[2], quad[3]]]
                } else {
                    [[quad[0], quad[1], quad[3]], [quad[1], quad[2], quad[3]]]
                };
                for t in tris {
                    add_triangle(&mut rows, c, nodes, t, free);
                }
            }
        }
        BlockSparse::from_rows(rows.into_iter().map(|r| r.into_iter().collect()).collect())
    }

    /// Pressure on the wall chords: p·L along the chord's normal away from the axis, half to
    /// each end node. Returns the loads of the free nodes and the wall's perimeter.
    fn wall_load(&self, nodes: &[[f64; 2]], pressure: f64) -> (Vec<Block6>, f64) {
        let mut f = vec![Block6::zeros(); self.free()];
        let mut perimeter = 0.0;
        for j in 0..self.around {
            let (n0, n1) = (self.node(0, j), self.node(0, j + 1));
            let (p0, p1) = (nodes[n0], nodes[n1]);
            let (dx, dy) = (p1[0] - p0[0], p1[1] - p0[1]);
            let len = dx.hypot(dy);
            perimeter += len;
            // (dy, −dx)/len points away from the axis for a counter-clockwise wall.
            let force = Vec3::new(dy, -dx, 0.0) * (pressure * 0.5);
            for nn in [n0, n1] {
                let mut col = f[nn].fixed_view_mut::<3, 1>(0, 0);
                col += force;
            }
        }
        (f, perimeter)
    }
}

/// Add the stiffness Bᵀ C B·area of the linear triangle `t` to the rows of its free nodes
/// (nodes ≥ `free` are clamped).
fn add_triangle(
    rows: &mut [BTreeMap<u32, Block6>],
    c: &Stiffness6,
    nodes: &[[f64; 2]],
    t: [usize; 3],
    free: usize,
) {
    let [p0, p1, p2] = t.map(|k| nodes[k]);
    let det = (p1[0] - p0[0]) * (p2[1] - p0[1]) - (p2[0] - p0[0]) * (p1[1] - p0[1]);
    let area = 0.5 * det;
    let pts = [p0, p1, p2];
    let bs: Vec<SMatrix<f64, 6, 3>> = (0..3)
        .map(|k| {
            let (q1, q2) = (pts[(k + 1) % 3], pts[(k + 2) % 3]);
            strain_node((q1[1] - q2[1]) / det, (q2[0] - q1[0]) / det)
        })
        .collect();
    for (ka, &na) in t.iter().enumerate() {
        if na >= free {
            continue;
        }
        let cb = c * bs[ka];
        for (kb, &nb) in t.iter().enumerate() {
            if nb >= free {
                continue;
            }
            let kab = bs[kb].transpose() * cb * area.abs();
            let blk = rows[nb].entry(na as u32).or_insert_with(Block6::zeros);
            let mut view = blk.fixed_view_mut::<3, 3>(0, 0);
            view += kab;
        }
    }
}

/// One sparse Cholesky solve K u = f; refuses a K that is not positive definite, one with
/// unknowns that carry no stiffness, and a relative residual ‖K u − f‖/‖f‖ ≥ 1e-10.
fn solve_checked(k: &BlockSparse, f: &[Block6]) -> Result<(Vec<Block6>, f64)> {
    let free = f.len();
    let chol = BlockCholesky::factor_definite(k).map_err(|e| {
        e.in_context("continuum cavity: the stiffness tensor is not positive definite")
    })?;
    if chol.unknowns() != 3 * free {
        return Err(Error::Degenerate(format!(
            "continuum cavity: {} of {} displacement unknowns carry stiffness",
            chol.unknowns(),
            3 * free
        )));
    }
    let u = chol.solve(f)?;
    let mut ku = vec![Block6::zeros(); free];
    k.apply(&u, &mut ku);
    let (mut rn, mut fn_) = (0.0, 0.0);
    for (x, y) in ku.iter().zip(f) {
        rn += (x - y).column(0).norm_squared();
        fn_ += y.column(0).norm_squared();
    }
    let relative_residual = (rn / fn_.max(f64::MIN_POSITIVE)).sqrt();
    if relative_residual.is_nan() || relative_residual >= 1e-10 {
        return Err(Error::NotConverged(format!(
            "continuum cavity: the direct solve has relative residual {relative_residual:e} \
             (> 1e-10)"
        )));
    }
    Ok((u, relative_residual))
}

/// True when the point (x, y) lies within ±`half_width` degrees of the direction
/// `direction` (degrees from x towards y) seen from the axis.
pub fn in_bin(x: f64, y: f64, direction: f64, half_width: f64) -> bool {
    let d = ((y.atan2(x).to_degrees() - direction + 540.0) % 360.0) - 180.0;
    d.abs() <= half_width
}

impl ContinuumCavity {
    /// Mean (radial, axial) displacement (m) of the wall nodes within ±`half_width` (degrees)
    /// of the direction `direction` (degrees from x towards y): the continuum counterpart of
    /// [`super::Cavity::wall_bin`].
    pub fn wall_bin(&self, direction: f64, half_width: f64) -> (f64, f64) {
        let (mut ur, mut uz, mut n) = (0.0, 0.0, 0.0);
        for q in 0..self.around {
            let [x, y] = self.nodes[q];
            if in_bin(x, y, direction, half_width) {
                let u = self.displacement[q];
                ur += (u.x * x + u.y * y) / self.inner_radius;
                uz += u.z;
                n += 1.0;
            }
        }
        (ur / n, uz / n)
    }
}
