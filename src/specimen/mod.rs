//! The specimen solve: the exact static response of a finite bonded specimen loaded between
//! two platens, as a YADE, LIGGGHTS or LAMMPS load test measures it once it has come to rest.
//!
//! The end layers are the particles whose centres lie within `end_layer` of the lowest and of
//! the highest centre along the loading axis. The bottom layer is held, the top one moved by
//! δ along the axis. `Frictionless` platens prescribe only that axial displacement of the
//! layers' particles (every other degree of freedom free, as YADE's `blockedDOFs = 'z'`);
//! `Bonded` platens prescribe all six degrees of freedom of the layers' particles. The
//! equilibrium K u = f (Kruyt 2014 Eqs. 10–14, six DOFs per sphere, no periodic cell) is
//! solved for the free DOFs by faer's sparse Cholesky with the prescribed DOFs eliminated
//! symmetrically, so the answer is exact up to rounding.
//!
//! Frictionless platens leave the two lateral translations and the rotation about the axis
//! free; one bottom-layer particle's lateral translations and spin about the axis are held to
//! remove them. Only axial forces act on the specimen, so these supports carry no force (by
//! equilibrium); the solve checks that they carry none to 1e-9 of the platen force.

use crate::assembly::Assembly;
use crate::homogenize::cholesky::BlockCholesky;
use crate::homogenize::network::{element, prune_dangling, Block6, BondLaw, LeverArm};
use crate::homogenize::relaxed::{block_jacobi_cg, BlockSparse};
use crate::{Error, Result, Vec3};
use serde::Serialize;

/// How the platens hold the end layers.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Platens {
    /// Only the axial displacement of the layers' particles is prescribed.
    Frictionless,
    /// All six degrees of freedom of the layers' particles are prescribed (no slip, no spin).
    Bonded,
}

/// What the specimen solve is asked for.
#[derive(Clone, Copy, Debug)]
pub struct SpecimenOptions {
    /// Loading axis: 0 = x, 1 = y, 2 = z.
    pub axis: usize,
    /// Depth of each end layer (m): centres within it of the lowest / highest centre.
    pub end_layer: f64,
    /// How the platens hold the layers.
    pub platens: Platens,
    /// Axial engineering strain applied (compression positive); the response is linear, so
    /// it sets only the scale of the displacement field written out.
    pub strain: f64,
    /// Where the bond's contact point sits (YADE's mid-gap by default).
    pub lever_arm: LeverArm,
}

impl SpecimenOptions {
    /// The options for `axis` and `end_layer` (m), with frictionless platens, a compressive
    /// strain of 1e-4 and YADE's mid-gap contact point.
    pub fn new(axis: usize, end_layer: f64) -> SpecimenOptions {
        SpecimenOptions {
            axis,
            end_layer,
            platens: Platens::Frictionless,
            strain: 1e-4,
            lever_arm: LeverArm::MidGap,
        }
    }

    fn check(&self) -> Result<()> {
        if self.axis > 2 {
            return Err(Error::Invalid(format!(
                "specimen: axis {} is not x, y or z",
                self.axis
            )));
        }
        if !(self.end_layer.is_finite() && self.end_layer >= 0.0) {
            return Err(Error::Invalid(format!(
                "specimen: end layer depth must be a finite length >= 0 m, got {}",
                self.end_layer
            )));
        }
        if !(self.strain.is_finite() && self.strain > 0.0 && self.strain < 1.0) {
            return Err(Error::Invalid(format!(
                "specimen: strain must be in (0, 1), got {}",
                self.strain
            )));
        }
        Ok(())
    }
}

/// The specimen solve's answer: what the load test measures, and the field.
#[derive(Clone, Debug, Serialize)]
pub struct SpecimenReport {
    /// Loading axis (`x`, `y` or `z`).
    pub axis: &'static str,
    /// How the platens held the layers.
    pub platens: Platens,
    /// Particles of the packing.
    pub n_particles: usize,
    /// Particles that take part (joined by bonds to both end layers).
    pub loaded_particles: usize,
    /// Particles left out: not joined to both end layers, so they carry no load.
    pub unloaded_particles: usize,
    /// Bonds that take part.
    pub loaded_bonds: usize,
    /// Particles of the held bottom layer.
    pub bottom_layer: usize,
    /// Particles of the moved top layer.
    pub top_layer: usize,
    /// Distance between the layers' mean centres along the axis (m): the gauge length.
    pub length: f64,
    /// Cross-section (m²): the lateral extent of the loaded spheres' surfaces, one lateral
    /// axis times the other (a prism's face; a cylinder's bounding square).
    pub area: f64,
    /// Applied shortening δ of the top layer (m).
    pub displacement: f64,
    /// Axial force on the moved layer (N, compression positive).
    pub axial_force: f64,
    /// Axial force on the bottom layer (N, compression positive): equal to `axial_force` by
    /// equilibrium.
    pub bottom_force: f64,
    /// Platen stiffness F/δ (N/m).
    pub platen_stiffness: f64,
    /// Apparent Young's modulus (F/A)/(δ/L) (Pa).
    pub young: f64,
    /// Apparent Poisson's ratios −ε_lat/ε_axial along the two lateral axes (in x, y, z order
    /// without the loading axis), each the slope of a least-squares fit
    /// u_lat = c₀ + c₁·lat + c₂·other + c₃·axial over the particles of the middle third.
    pub poisson_lateral: [f64; 2],
    /// Their mean.
    pub poisson: f64,
    /// How `young` and `poisson` were computed, in words.
    pub how: &'static str,
    /// Relative residual ‖K u − f‖/‖f‖ of the solve at the free DOFs.
    pub relative_residual: f64,
    /// Unknowns after removing local mechanisms (Cholesky), or 6 per particle (CG).
    pub unknowns: usize,
    /// How the equilibrium was solved.
    pub solver: SpecimenSolver,
    /// Displacement of every particle (m; zero for the unloaded ones).
    #[serde(skip)]
    pub displacement_field: Vec<Vec3>,
    /// Rotation of every particle (rad).
    #[serde(skip)]
    pub rotation_field: Vec<Vec3>,
    /// Force the platens exert on every particle (N; zero off the layers).
    #[serde(skip)]
    pub reaction: Vec<Vec3>,
    /// Layer of every particle: 0 none, 1 bottom (held), 2 top (moved).
    #[serde(skip)]
    pub layer: Vec<u8>,
    /// Force on i from j of every bond of the packing (N; zero for unloaded bonds):
    /// f = SΔ with Δ = (u_j + ω_j × (−r_j n)) − (u_i + ω_i × (r_i n)).
    #[serde(skip)]
    pub bond_force: Vec<Vec3>,
    /// Whether each bond of the packing takes part (false: it hangs off the loaded network
    /// or belongs to a part not joined to both layers, and carries no force).
    #[serde(skip)]
    pub bond_loaded: Vec<bool>,
}

/// What `young` and `poisson` mean, written into the report.
const HOW: &str =
    "young = (axial_force / area) / (displacement / length), area = lateral extent of \
    the loaded spheres' surfaces (bounding box), length = distance between the end layers' mean \
    centres; poisson_lateral = -(slope of the lateral displacement over the lateral coordinate) / \
    (displacement / length), least squares over the particles of the middle third";

/// How the specimen's equilibrium was solved.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case", tag = "method")]
pub enum SpecimenSolver {
    /// Sparse Cholesky (the held specimen is positive definite).
    Cholesky,
    /// Block-Jacobi CG: the held specimen has zero-energy modes that the load does not
    /// excite (they carry no force; the field is the one orthogonal to them).
    Cg {
        /// Iterations to [`CG_TOLERANCE`].
        iterations: usize,
    },
}

/// Relative residual the CG solve of a specimen with zero-energy modes is taken to.
pub const CG_TOLERANCE: f64 = 1e-12;

/// Largest relative residual accepted from the direct solve.
pub const RESIDUAL_LIMIT: f64 = 1e-8;

/// Largest force the lateral supports of frictionless platens may carry, relative to the
/// platen force (they carry none by equilibrium).
pub const SUPPORT_LIMIT: f64 = 1e-9;

/// Union–find root with path halving.
fn root(parent: &mut [u32], mut p: u32) -> u32 {
    while parent[p as usize] != p {
        parent[p as usize] = parent[parent[p as usize] as usize];
        p = parent[p as usize];
    }
    p
}

/// The exact static response of `assembly`'s bonded specimen (see the module doc).
pub fn solve(assembly: &Assembly, opts: &SpecimenOptions) -> Result<SpecimenReport> {
    opts.check()?;
    let packing = &assembly.packing;
    let bonds = &assembly.bonds;
    let k = &assembly.springs;
    let n = packing.len();
    let ax = opts.axis;
    if let Some(b) = bonds.image.iter().position(|im| *im != [0, 0, 0]) {
        return Err(Error::Invalid(format!(
            "specimen: bond {b} ({} – {}) crosses the periodic cell; a specimen is a finite \
             packing (read it with --free, or cut one from the cell)",
            bonds.i[b], bonds.j[b]
        )));
    }
    if bonds.is_empty() {
        return Err(Error::Degenerate(
            "specimen: the packing has no bonds (check the model's bonding rule)".into(),
        ));
    }
    // End layers.
    let coord = |p: usize| packing.positions[p][ax];
    let lo = (0..n).map(coord).fold(f64::INFINITY, f64::min);
    let hi = (0..n).map(coord).fold(f64::NEG_INFINITY, f64::max);
    let mut layer = vec![0u8; n];
    for (p, l) in layer.iter_mut().enumerate() {
        let c = coord(p);
        if c <= lo + opts.end_layer {
            *l = 1;
        } else if c >= hi - opts.end_layer {
            *l = 2;
        }
    }
    if hi - lo <= 2.0 * opts.end_layer {
        return Err(Error::Invalid(format!(
            "specimen: the end layers ({} m deep each) overlap: the specimen is {:.6e} m long \
             along {}",
            opts.end_layer,
            hi - lo,
            axis_name(ax)
        )));
    }
    // Connected components joined to both layers carry the load; the rest is left out.
    let mut parent: Vec<u32> = (0..n as u32).collect();
    for (&i, &j) in bonds.i.iter().zip(&bonds.j) {
        let (a, b) = (root(&mut parent, i), root(&mut parent, j));
        if a != b {
            parent[a.max(b) as usize] = a.min(b);
        }
    }
    let roots: Vec<u32> = (0..n as u32).map(|p| root(&mut parent, p)).collect();
    let mut touches = vec![0u8; n];
    for p in 0..n {
        if layer[p] != 0 {
            touches[roots[p] as usize] |= layer[p];
        }
    }
    // Dangling chains (particles off the layers left with one bond, repeatedly) carry no
    // load and would swing freely: prune them, as the periodic network does.
    let in_loaded_component = |p: usize| touches[roots[p] as usize] == 3;
    let (active, degree) = prune_dangling(
        n,
        bonds,
        (0..bonds.len())
            .map(|b| in_loaded_component(bonds.i[b] as usize))
            .collect(),
        |p| layer[p] != 0,
    );
    let loaded: Vec<bool> = (0..n)
        .map(|p| in_loaded_component(p) && degree[p] > 0)
        .collect();
    let mut index = vec![u32::MAX; n];
    let mut original: Vec<usize> = Vec::new();
    for p in 0..n {
        if loaded[p] {
            index[p] = original.len() as u32;
            original.push(p);
        }
    }
    if original.is_empty() {
        return Err(Error::Degenerate(format!(
            "specimen: no bonded path joins the bottom and top layers along {} (layers {} m \
             deep); the specimen falls apart under load",
            axis_name(ax),
            opts.end_layer
        )));
    }
    let m = original.len();
    // Elements of the loaded bonds.
    let loaded_bonds: Vec<usize> = (0..bonds.len()).filter(|&b| active[b]).collect();
    let ends: Vec<(u32, u32)> = loaded_bonds
        .iter()
        .map(|&b| (index[bonds.i[b] as usize], index[bonds.j[b] as usize]))
        .collect();
    let elements: Vec<_> = loaded_bonds
        .iter()
        .map(|&b| element(&BondLaw::of(packing, bonds, k, b, opts.lever_arm), true))
        .collect();
    let kfull = BlockSparse::assemble_blocks(m, &ends, |e| {
        let el = &elements[e];
        (el.kii, el.kjj, el.kij)
    });
    // Gauge length and prescribed values.
    let mean_of = |which: u8| {
        let (s, c) = original
            .iter()
            .filter(|&&p| layer[p] == which)
            .fold((0.0, 0usize), |(s, c), &p| (s + coord(p), c + 1));
        (s / c.max(1) as f64, c)
    };
    let ((bottom_mean, n_bottom), (top_mean, n_top)) = (mean_of(1), mean_of(2));
    let length = top_mean - bottom_mean;
    let delta = opts.strain * length;
    // prescribed[a][d]: Some(value) for a prescribed DOF.
    let mut prescribed: Vec<[Option<f64>; 6]> = vec![[None; 6]; m];
    for (a, &p) in original.iter().enumerate() {
        let value = if layer[p] == 2 { -delta } else { 0.0 };
        match (layer[p], opts.platens) {
            (0, _) => {}
            (_, Platens::Frictionless) => prescribed[a][ax] = Some(value),
            (_, Platens::Bonded) => {
                prescribed[a] = [Some(0.0); 6];
                prescribed[a][ax] = Some(value);
            }
        }
    }
    let lateral = [(ax + 1) % 3, (ax + 2) % 3];
    let mut supports: Vec<(usize, usize)> = Vec::new();
    if opts.platens == Platens::Frictionless {
        // One held bottom particle per loaded component: lateral translations and spin.
        let mut seen: Vec<u32> = Vec::new();
        for (a, &p) in original.iter().enumerate() {
            if layer[p] == 1 && !seen.contains(&roots[p]) {
                seen.push(roots[p]);
                for d in [lateral[0], lateral[1], 3 + ax] {
                    prescribed[a][d] = Some(0.0);
                    supports.push((a, d));
                }
            }
        }
    }
    // Symmetric elimination: prescribed rows and columns keep only their diagonal; the
    // right-hand side moves the prescribed values' coupling to the free rows.
    let value_block = |a: usize| {
        let mut v = Block6::zeros();
        for d in 0..6 {
            v[(d, 0)] = prescribed[a][d].unwrap_or(0.0);
        }
        v
    };
    let mut rhs = vec![Block6::zeros(); m];
    let rows: Vec<Vec<(u32, Block6)>> = (0..m)
        .map(|a| {
            kfull
                .row(a)
                .map(|(c, blk)| {
                    let mut b = *blk;
                    for r in 0..6 {
                        for s in 0..6 {
                            if prescribed[a][r].is_some() || prescribed[c][s].is_some() {
                                b[(r, s)] = if a == c && r == s { blk[(r, s)] } else { 0.0 };
                            }
                        }
                    }
                    (c as u32, b)
                })
                .collect()
        })
        .collect();
    for (a, r) in rhs.iter_mut().enumerate() {
        let mut acc = Block6::zeros();
        for (c, blk) in kfull.row(a) {
            acc -= blk * value_block(c);
        }
        let diag = kfull.diagonal(a);
        for d in 0..6 {
            r[(d, 0)] = match prescribed[a][d] {
                Some(v) => diag[(d, d)] * v,
                None => acc[(d, 0)],
            };
        }
    }
    // Rotations in units of the mean radius (R̄·ω, m) so that translational (N/m) and
    // rotational (N·m/rad) stiffnesses are of one size: the null directions of each diagonal
    // block are then told from soft ones well above rounding (with ω in rad and spheres of
    // 1 mm the two differ by R̄² = 1e-6, and rounding of the translational part polluted the
    // rotational one).
    let mean_radius = packing.radii.iter().sum::<f64>() / n as f64;
    let dof_scale = |d: usize| if d < 3 { 1.0 } else { 1.0 / mean_radius };
    let rows: Vec<Vec<(u32, Block6)>> = rows
        .into_iter()
        .map(|row| {
            row.into_iter()
                .map(|(c, mut b)| {
                    for r in 0..6 {
                        for q in 0..6 {
                            b[(r, q)] *= dof_scale(r) * dof_scale(q);
                        }
                    }
                    (c, b)
                })
                .collect()
        })
        .collect();
    for r in rhs.iter_mut() {
        for d in 0..6 {
            r[(d, 0)] *= dof_scale(d);
        }
    }
    let kmod = BlockSparse::from_rows(rows);
    // Direct solve where the held specimen is definite; CG where it has zero-energy modes
    // the load does not excite (e.g. counter-rotating neighbours without bending springs).
    let (x, unknowns, solver) = match BlockCholesky::factor_definite(&kmod) {
        Ok(chol) => (chol.solve(&rhs)?, chol.unknowns(), SpecimenSolver::Cholesky),
        Err(_) => {
            let (x, iterations, _) = block_jacobi_cg(&kmod, &rhs, CG_TOLERANCE, 2 * m + 1000)
                .map_err(|e| {
                    e.in_context(
                        "specimen: the bonded specimen held by its platens has a mechanism that \
                         the load excites, or the solve did not converge",
                    )
                })?;
            (x, 6 * m, SpecimenSolver::Cg { iterations })
        }
    };
    let x: Vec<Block6> = x
        .into_iter()
        .map(|mut b| {
            for d in 0..6 {
                b[(d, 0)] *= dof_scale(d);
            }
            b
        })
        .collect();
    // Prescribed DOFs take their values exactly; a DOF removed as a local mechanism is 0.
    let mut u = x.clone();
    for (a, ua) in u.iter_mut().enumerate() {
        for d in 0..6 {
            if let Some(v) = prescribed[a][d] {
                ua[(d, 0)] = v;
            }
        }
    }
    let mut ku = vec![Block6::zeros(); m];
    kfull.apply(&u, &mut ku);
    // Residual at the free DOFs, relative to the largest reaction.
    let (mut rr, mut ff) = (0.0, 0.0);
    for a in 0..m {
        for d in 0..6 {
            let f = ku[a][(d, 0)];
            if prescribed[a][d].is_none() {
                rr += f * f;
            } else {
                ff += f * f;
            }
        }
    }
    let relative_residual = (rr / ff).sqrt();
    if relative_residual.is_nan() || relative_residual > RESIDUAL_LIMIT {
        return Err(Error::NotConverged(format!(
            "specimen: static solve residual {relative_residual:.3e} > {RESIDUAL_LIMIT:e}: the \
             bonded specimen is too ill-conditioned or has a mechanism"
        )));
    }
    let force_on = |which: u8| -> f64 {
        original
            .iter()
            .enumerate()
            .filter(|(_, &p)| layer[p] == which)
            .map(|(a, _)| ku[a][(ax, 0)])
            .sum()
    };
    // K u is the force the platens exert; compression pushes the top layer down.
    let axial_force = -force_on(2);
    let bottom_force = force_on(1);
    for &(a, d) in &supports {
        let f = ku[a][(d, 0)];
        let scale = if d >= 3 { length } else { 1.0 };
        let allowed = SUPPORT_LIMIT * axial_force.abs();
        if (f / scale).is_nan() || (f / scale).abs() > allowed {
            return Err(Error::Degenerate(format!(
                "specimen: the lateral support of a frictionless platen carries {f:.3e} (N or \
                 N·m) against an axial force {axial_force:.3e} N; the specimen is not held by \
                 axial forces alone"
            )));
        }
    }
    // Cross-section: lateral extent of the loaded spheres' surfaces.
    let extent = |d: usize| {
        let lo = original
            .iter()
            .map(|&p| packing.positions[p][d] - packing.radii[p])
            .fold(f64::INFINITY, f64::min);
        let hi = original
            .iter()
            .map(|&p| packing.positions[p][d] + packing.radii[p])
            .fold(f64::NEG_INFINITY, f64::max);
        hi - lo
    };
    let area = extent(lateral[0]) * extent(lateral[1]);
    let strain = delta / length;
    let young = axial_force / area / strain;
    let platen_stiffness = axial_force / delta;
    // Lateral strains: least squares over the middle third.
    let middle: Vec<usize> = (0..m)
        .filter(|&a| {
            let c = coord(original[a]) - bottom_mean;
            layer[original[a]] == 0 && c >= length / 3.0 && c <= 2.0 * length / 3.0
        })
        .collect();
    let mut poisson_lateral = [f64::NAN; 2];
    for (k, &d) in lateral.iter().enumerate() {
        let rows: Vec<([f64; 4], f64)> = middle
            .iter()
            .map(|&a| {
                let x = packing.positions[original[a]];
                ([1.0, x[d], x[lateral[1 - k]], x[ax]], u[a][(d, 0)])
            })
            .collect();
        if let Some(c) = least_squares(&rows) {
            poisson_lateral[k] = c[1] / strain;
        }
    }
    if !poisson_lateral.iter().all(|v| v.is_finite()) {
        return Err(Error::Degenerate(format!(
            "specimen: the middle third holds {} loaded particles, too few to measure the \
             lateral strain",
            middle.len()
        )));
    }
    let mut displacement_field = vec![Vec3::zeros(); n];
    let mut rotation_field = vec![Vec3::zeros(); n];
    let mut reaction = vec![Vec3::zeros(); n];
    for (a, &p) in original.iter().enumerate() {
        displacement_field[p] = Vec3::new(u[a][(0, 0)], u[a][(1, 0)], u[a][(2, 0)]);
        rotation_field[p] = Vec3::new(u[a][(3, 0)], u[a][(4, 0)], u[a][(5, 0)]);
        if layer[p] != 0 {
            reaction[p] = Vec3::new(ku[a][(0, 0)], ku[a][(1, 0)], ku[a][(2, 0)]);
        }
    }
    let mut bond_force = vec![Vec3::zeros(); bonds.len()];
    for &b in &loaded_bonds {
        let (i, j) = (bonds.i[b] as usize, bonds.j[b] as usize);
        let nrm = bonds.normal[b];
        let (ri, rj) = opts
            .lever_arm
            .arms(packing.radii[i], packing.radii[j], bonds.length[b]);
        let delta = (displacement_field[j] + rotation_field[j].cross(&(-nrm * rj)))
            - (displacement_field[i] + rotation_field[i].cross(&(nrm * ri)));
        bond_force[b] = delta * k.ks[b] + nrm * ((k.kn[b] - k.ks[b]) * nrm.dot(&delta));
    }
    let report = SpecimenReport {
        axis: axis_name(ax),
        platens: opts.platens,
        n_particles: n,
        loaded_particles: m,
        unloaded_particles: n - m,
        loaded_bonds: loaded_bonds.len(),
        bottom_layer: n_bottom,
        top_layer: n_top,
        length,
        area,
        displacement: delta,
        axial_force,
        bottom_force,
        platen_stiffness,
        young,
        poisson_lateral,
        poisson: 0.5 * (poisson_lateral[0] + poisson_lateral[1]),
        how: HOW,
        relative_residual,
        unknowns,
        solver,
        displacement_field,
        rotation_field,
        reaction,
        layer,
        bond_force,
        bond_loaded: active,
    };
    let finite = [
        report.young,
        report.poisson,
        report.platen_stiffness,
        report.axial_force,
    ];
    if !finite.iter().all(|v| v.is_finite()) || report.platen_stiffness <= 0.0 {
        return Err(Error::Degenerate(format!(
            "specimen: platen stiffness {:.3e} N/m, Young's modulus {:.3e} Pa: not a positive \
             finite response",
            report.platen_stiffness, report.young
        )));
    }
    Ok(report)
}

/// `x`, `y` or `z`.
fn axis_name(axis: usize) -> &'static str {
    ["x", "y", "z"][axis.min(2)]
}

/// Least-squares coefficients of `y ≈ Σ c_k x_k` (normal equations, 4 unknowns); `None` when
/// the fit is singular or has fewer than 8 rows (twice the unknowns).
fn least_squares(rows: &[([f64; 4], f64)]) -> Option<[f64; 4]> {
    if rows.len() < 8 {
        return None;
    }
    // Centre the columns (except the constant) for conditioning.
    let mean: [f64; 4] =
        std::array::from_fn(|k| rows.iter().map(|(x, _)| x[k]).sum::<f64>() / rows.len() as f64);
    let mut ata = nalgebra::Matrix4::<f64>::zeros();
    let mut aty = nalgebra::Vector4::<f64>::zeros();
    for (x, y) in rows {
        let v = nalgebra::Vector4::from_fn(|k, _| if k == 0 { 1.0 } else { x[k] - mean[k] });
        ata += v * v.transpose();
        aty += v * *y;
    }
    let c = ata.cholesky()?.solve(&aty);
    Some([c[0], c[1], c[2], c[3]])
}
