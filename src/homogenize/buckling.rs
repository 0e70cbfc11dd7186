//! Linearised buckling of a clamped bonded bar (Kumar 2016 Sec. 5, Eqs. 14–15).
//!
//! Both end sets are clamped (translations and rotations prescribed); the second end is
//! moved along the axis by the unit strain shortening δ = L (the problem is linear, so the
//! pre-buckling state is taken per unit strain). One sparse solve of the network's
//! stiffness K (the relaxed solver's, [`super::network`]) gives the pre-buckling state: the
//! axial force P per unit strain (hence E = P/A, the bar's own axial modulus) and every
//! bond's force. The critical load factor λ is the smallest positive eigenvalue of
//! (K + λ K_g) φ = 0 with K_g the geometric stiffness of those forces
//! ([`super::geometric`]): the critical strain is λ, the critical stress σ_cr = λ·E.
//!
//! The eigenproblem K φ = λ (−K_g) φ is solved by subspace iteration with six vectors (a
//! round bar has two degenerate bending modes per order): Y = K⁻¹(−K_g)X by the supernodal
//! Cholesky of K, then Rayleigh–Ritz on span(Y). Converged when the relative residual
//! ‖Kφ − λ(−K_g)φ‖/‖Kφ‖ of the two lowest modes (the Ritz pairs reported) is below the
//! tolerance, their load factors changed by less than it over the last step, and Sylvester's
//! inertia test finds K + σK_g positive definite at σ = λ₁(1 − 10·tol) (no lower mode
//! missed); a run that does not converge is an error.

use super::cholesky::BlockCholesky;
use super::geometric::geometric_stiffness;
use super::network::{symmetric_eigen6, Block6, LeverArm, Network};
use super::sparse::BlockSparse;
use crate::assembly::Assembly;
use crate::model::Model;
use crate::packing::container::{container_particles, prepare_in_container};
use crate::packing::cut::{BoundarySets, Region};
use crate::packing::routes::{RouteOptions, RouteReport};
use crate::packing::Packing;
use crate::{Error, Result, Vec3};
use nalgebra::{Matrix6, Vector6};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// A clamped-clamped bar: an assembly with two end sets.
#[derive(Clone, Copy, Debug)]
pub struct ClampedBar<'a> {
    /// The bonded free assembly.
    pub assembly: &'a Assembly,
    /// Particles of the fixed end (indices into the packing).
    pub first_end: &'a [u32],
    /// Particles of the end moved along the axis.
    pub second_end: &'a [u32],
    /// Unit bar axis (from the first end to the second).
    pub axis: Vec3,
    /// Bar length l (m): the strain is the end displacement over l.
    pub length: f64,
    /// Cross-section area (m²) that turns the axial force into a stress (πr² for a bar of
    /// radius r).
    pub area: f64,
}

/// Solver settings.
#[derive(Clone, Copy, Debug)]
pub struct BucklingOptions {
    /// Relative residual of the two lowest modes at which the iteration stops.
    pub tolerance: f64,
    /// Subspace iterations allowed.
    pub max_iterations: usize,
    /// Contact point of the bonds (as the relaxed solver).
    pub lever_arm: LeverArm,
    /// Seed of the small random part of the start vectors.
    pub seed: u64,
    /// Where the eigenproblem is linearised: the undeformed bar, or also the bar deformed
    /// by its pre-buckling shortening (the extensible bar).
    pub pre_buckling: PreBuckling,
}

/// The geometry the buckling eigenproblem is set up on.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum PreBuckling {
    /// Small strain: K and K_g on the undeformed bar (Euler, Kumar 2016 Eq. 14; Engesser
    /// with shear flexibility).
    #[default]
    Linear,
    /// Also on the bar deformed by its pre-buckling state: positions x + ε·u₁ (u₁ the
    /// displacement per unit axial strain), bond normals, lengths and contact arms updated,
    /// axial forces ε·N₁ along the deformed bonds; ε is the fixed point ε = λ(ε). The
    /// extensible rod of Mazzilli (Kumar 2016 Eq. 15), whose σ(1 − σ/E) = σ_Euler this gives
    /// for a shear-rigid bar without lateral expansion.
    UpdatedGeometry,
}

/// The critical state of the bar on its deformed pre-buckling geometry
/// ([`PreBuckling::UpdatedGeometry`]).
#[derive(Clone, Copy, Debug, serde::Serialize)]
pub struct UpdatedGeometryResult {
    /// Critical axial strain ε (nominal: shortening over the undeformed length).
    pub critical_strain: f64,
    /// Critical axial stress ε·E (Pa, nominal: force over the undeformed section, E the
    /// linear axial modulus), comparable with Mazzilli's σ.
    #[serde(rename = "critical_stress_pa")]
    pub critical_stress: f64,
    /// Critical axial force (N).
    #[serde(rename = "critical_force_n")]
    pub critical_force: f64,
    /// Secant steps of the fixed point ε = λ(ε).
    pub fixed_point_iterations: usize,
    /// |λ(ε) − ε|/ε at the end.
    pub fixed_point_residual: f64,
    /// Subspace iterations summed over the steps.
    pub eigen_iterations: usize,
}

/// Loosest accepted [`BucklingOptions::tolerance`]. A small residual certifies an eigenpair,
/// not that it is the lowest; the inertia test at λ₁(1 − 10·tol) then certifies that no load
/// factor lies more than 10·tol below the reported λ₁, so 1e-4 bounds that to 0.1 %.
/// Measured on the 15 default bars of `anisobond buckle` (3 routes × l/r 10–120) without
/// the test: at 1e-3 all within 1e-6 of their value at 1e-10; at 3e-3 the jammed l/r = 120
/// bar stopped at step 3 on a higher mode, 8.9 % high (with the test: right, 9 steps); at
/// 1e-2 the jammed l/r = 40 bar 10 % high (within that 10·tol); at 0.5 (issue 29 A3) all
/// stopped at step 2.
pub const MAX_TOLERANCE: f64 = 1e-4;

/// Tightest accepted [`BucklingOptions::tolerance`]: measured, the default bars reach it in
/// 20–29 steps (residuals 5e-13–9e-13); much below it the residual stops at the rounding
/// level of the sparse solves and the iteration would run to its limit.
pub const MIN_TOLERANCE: f64 = 1e-12;

impl BucklingOptions {
    /// Refuse a tolerance outside `[MIN_TOLERANCE, MAX_TOLERANCE]` (or not a number)
    /// and a zero iteration limit, naming the range and why.
    pub fn check(&self) -> Result<()> {
        if !(MIN_TOLERANCE..=MAX_TOLERANCE).contains(&self.tolerance) {
            return Err(Error::Invalid(format!(
                "buckling: tolerance {:e} must be in [{MIN_TOLERANCE:e}, {MAX_TOLERANCE:e}] \
                 (relative residual of the eigenpairs: at a looser one the iteration can stop \
                 on a higher mode before the lowest emerges, a tighter one is below the \
                 solves' rounding)",
                self.tolerance
            )));
        }
        if self.max_iterations == 0 {
            return Err(Error::Invalid(
                "buckling: at least one subspace iteration must be allowed".into(),
            ));
        }
        Ok(())
    }
}

impl Default for BucklingOptions {
    fn default() -> Self {
        BucklingOptions {
            tolerance: 1e-6,
            max_iterations: 2000,
            lever_arm: LeverArm::MidGap,
            seed: 1,
            pre_buckling: PreBuckling::Linear,
        }
    }
}

/// The pre-buckling state and the critical load.
#[derive(Clone, Debug, Default, serde::Serialize)]
pub struct BucklingResult {
    /// Axial force per unit axial strain, P/ε (N): the bar's axial stiffness times l.
    #[serde(rename = "axial_force_per_strain_n")]
    pub axial_force_per_strain: f64,
    /// The bar's own axial modulus E = (P/A)/ε (Pa).
    #[serde(rename = "modulus_pa")]
    pub modulus: f64,
    /// The two lowest load factors λ₁ ≤ λ₂ (critical strains; for a round bar a near-equal
    /// pair of bending modes).
    pub load_factors: [f64; 2],
    /// Critical axial strain ε_cr = λ₁.
    pub critical_strain: f64,
    /// Critical axial stress σ_cr = λ₁·E (Pa, compressive).
    #[serde(rename = "critical_stress_pa")]
    pub critical_stress: f64,
    /// Critical axial force (N).
    #[serde(rename = "critical_force_n")]
    pub critical_force: f64,
    /// Subspace iterations used.
    pub iterations: usize,
    /// Final relative residuals of the two lowest modes.
    pub residuals: [f64; 2],
    /// Relative residual of the pre-buckling static solve.
    pub static_residual: f64,
    /// |R₁ + R₂|/|R₂| of the two ends' reactions (force balance of the solve).
    pub reaction_imbalance: f64,
    /// Particles free to move (connected to the clamps).
    pub free_particles: usize,
    /// Clamped particles of the network.
    pub clamped_particles: usize,
    /// Particles left out: fewer than two bonds, or not connected to the clamps.
    pub unloaded_particles: usize,
    /// Bonds of the network.
    pub bonds: usize,
    /// The bar's own bending stiffness EI (N·m²): moment × l per radian of relative end
    /// rotation under pure bending (ends clamped and rotated rigidly about their centroids).
    #[serde(rename = "bending_stiffness_n_m2")]
    pub bending_stiffness: f64,
    /// Transverse stiffness (N/m) of the clamped–guided bar (one end moved across the axis
    /// without rotation): l³/(12 EI) + l/(κGA) per newton for a Timoshenko beam.
    #[serde(rename = "transverse_stiffness_n_per_m")]
    pub transverse_stiffness: f64,
    /// Share of the axial Love stress Σ(f·a)(l·a) carried by the bonds' normal forces,
    /// Σ N(n·a)(l·a) over it: the part of the pre-stress the geometric stiffness sees (the
    /// rest, carried by shear forces, is neglected, `geometric.rs`).
    pub normal_force_share: f64,
    /// Bonds in compression in the pre-buckling state.
    pub compressed_bonds: usize,
    /// With [`PreBuckling::UpdatedGeometry`]: the critical state on the deformed bar.
    pub updated_geometry: Option<UpdatedGeometryResult>,
    /// Translation of every particle in the first buckling mode (unit max norm; zero for
    /// clamped and unloaded particles).
    #[serde(skip)]
    pub mode: Vec<Vec3>,
}

/// Two unit vectors normal to `axis` and to each other.
fn transverse(axis: &Vec3) -> (Vec3, Vec3) {
    let trial = if axis.x.abs() < 0.9 {
        Vec3::x()
    } else {
        Vec3::y()
    };
    let e1 = (trial - axis * axis.dot(&trial)).normalize();
    (e1, axis.cross(&e1))
}

/// Σ_p a_pᵀ b_p, summed in node order.
fn gram(a: &[Block6], b: &[Block6]) -> Matrix6<f64> {
    let mut s = Matrix6::zeros();
    for (x, y) in a.iter().zip(b) {
        s += x.transpose() * y;
    }
    s
}

/// Linearised buckling load of a clamped bar (see the module docs). Refuses options that
/// [`BucklingOptions::check`] refuses, an axis that is not a unit vector, a length or area that is not finite and > 0, empty or overlapping end
/// sets and ends with no load-carrying particle; errors ([`Error::Degenerate`]) when the bar
/// carries no axial force or has no positive load factor, ([`Error::NotConverged`]) when the
/// iteration does not reach the tolerance.
pub fn clamped_bar_buckling(bar: &ClampedBar, opts: &BucklingOptions) -> Result<BucklingResult> {
    let a = bar.assembly;
    let n = a.packing.len();
    let role = end_roles(bar, opts)?;
    let net = Network::build(&a.packing, &a.bonds, &a.springs, opts.lever_arm, true, None)?;
    let parts = ClampedParts::new(net, &role)?;
    let net = &parts.net;
    let frame = transverse(&bar.axis);
    let k = BlockSparse::assemble(net);
    let kff = k.restrict(&parts.free_map, 1.0);
    let chol = BlockCholesky::factor_definite(&kff)?;
    let (mut u, static_residual) = parts.solve_load_cases(bar, &k, &kff, &chol, frame)?;
    let ends = parts.end_figures(bar, &k, &u, frame)?;
    // Keep only the axial case for the bond forces.
    for uq in u.iter_mut() {
        let axial: Vector6<f64> = uq.column(0).into_owned();
        *uq = Block6::zeros();
        uq.set_column(0, &axial);
    }
    let pre = bond_forces(bar, net, &u, opts.lever_arm);
    let kg = geometric_stiffness(net, &a.bonds, &pre.forces)?;
    let aff = kg.restrict(&parts.free_map, -1.0);
    let x = parts.start_vectors(bar, frame, opts.seed);
    let nf = parts.free_nodes.len();
    let linear = lowest_load_factors(&kff, &chol, &aff, x, opts)?;
    let lambda = linear.lambda;
    let updated_geometry = match opts.pre_buckling {
        PreBuckling::Linear => None,
        PreBuckling::UpdatedGeometry => Some(
            parts
                .updated_geometry(bar, &u, &pre.forces, &linear, opts)?
                .with_force(ends.force, ends.modulus),
        ),
    };
    let mode = parts.first_mode(n, &linear.vectors);
    let critical_strain = lambda[0];
    Ok(BucklingResult {
        axial_force_per_strain: ends.force,
        modulus: ends.modulus,
        load_factors: [lambda[0], lambda[1]],
        critical_strain,
        critical_stress: critical_strain * ends.modulus,
        critical_force: critical_strain * ends.force,
        iterations: linear.iterations,
        residuals: linear.residuals,
        static_residual,
        reaction_imbalance: ends.reaction_imbalance,
        updated_geometry,
        free_particles: nf,
        clamped_particles: parts.clamped,
        unloaded_particles: n - nf - parts.clamped,
        bonds: net.ends.len(),
        bending_stiffness: ends.bending_stiffness,
        transverse_stiffness: ends.transverse_stiffness,
        compressed_bonds: pre.compressed,
        normal_force_share: pre.love_normal / pre.love_total,
        mode,
    })
}

/// The role of every particle (0 free, 1 first end, 2 second end) after refusing the bar's
/// axis, length, area, the options and end sets that are empty, out of range or overlap.
fn end_roles(bar: &ClampedBar, opts: &BucklingOptions) -> Result<Vec<u8>> {
    let n = bar.assembly.packing.len();
    if (bar.axis.norm() - 1.0).abs() > 1e-9 {
        return Err(Error::Invalid(format!(
            "buckling: the bar axis must be a unit vector, |axis| = {}",
            bar.axis.norm()
        )));
    }
    for (what, v) in [("length", bar.length), ("area", bar.area)] {
        if !(v.is_finite() && v > 0.0) {
            return Err(Error::Invalid(format!(
                "buckling: the bar {what} must be finite and > 0, got {v:e}"
            )));
        }
    }
    opts.check()?;
    let mut role = vec![0u8; n];
    for (ends, r) in [(bar.first_end, 1u8), (bar.second_end, 2u8)] {
        if ends.is_empty() {
            return Err(Error::Invalid("buckling: an end set is empty".into()));
        }
        for &p in ends {
            let p = p as usize;
            if p >= n {
                return Err(Error::Invalid(format!(
                    "buckling: end particle {p}, but the packing has {n}"
                )));
            }
            if role[p] != 0 {
                return Err(Error::Invalid(format!(
                    "buckling: particle {p} is in both end sets (or twice in one)"
                )));
            }
            role[p] = r;
        }
    }
    Ok(role)
}

/// The bar's network split into clamped nodes and the free nodes connected to them.
struct ClampedParts {
    /// The relaxed solver's network of the bar.
    net: Network,
    /// Per network node: 0 free, 1 first end, 2 second end.
    node_role: Vec<u8>,
    /// Per network node its index among the free nodes, `u32::MAX` for the others.
    free_map: Vec<u32>,
    /// The free nodes connected to the clamps, in node order.
    free_nodes: Vec<usize>,
    /// Clamped nodes.
    clamped: usize,
}

/// The pre-buckling figures read from the clamps' reactions.
struct EndFigures {
    /// Axial force per unit strain P (N).
    force: f64,
    /// E = P/A (Pa).
    modulus: f64,
    /// |R₁ + R₂|/|R₂| of the axial case.
    reaction_imbalance: f64,
    /// EI (N·m²) of the pure-bending case.
    bending_stiffness: f64,
    /// Transverse stiffness (N/m) of the clamped–guided case.
    transverse_stiffness: f64,
}

/// The bonds' forces in the pre-buckling state per unit strain, and the figures of them.
struct BondForces {
    /// Force on every original bond (N; N > 0 in tension).
    forces: Vec<Vec3>,
    /// Bonds in compression.
    compressed: usize,
    /// Axial Love stress Σ(f·a)(l·a) (times the volume).
    love_total: f64,
    /// Its part carried by the normal forces, Σ N(n·a)(l·a).
    love_normal: f64,
}

impl ClampedParts {
    /// Roles on the network's nodes, and the part connected to the clamps (a floating
    /// cluster would be a mechanism); refuses an end with no node and a bar with no free one.
    fn new(net: Network, role: &[u8]) -> Result<ClampedParts> {
        let m = net.n_active;
        let node_role: Vec<u8> = net.original.iter().map(|&p| role[p as usize]).collect();
        for r in [1u8, 2] {
            if !node_role.contains(&r) {
                return Err(Error::Degenerate(format!(
                    "buckling: no particle of the {} end carries load (all have fewer than two bonds)",
                    if r == 1 { "first" } else { "second" }
                )));
            }
        }
        let (start, adj) = net.adjacency();
        let mut reached = vec![false; m];
        let mut stack: Vec<usize> = (0..m).filter(|&q| node_role[q] != 0).collect();
        for &q in &stack {
            reached[q] = true;
        }
        while let Some(q) = stack.pop() {
            for &o in &adj[start[q]..start[q + 1]] {
                if !reached[o as usize] {
                    reached[o as usize] = true;
                    stack.push(o as usize);
                }
            }
        }
        let mut free_map = vec![u32::MAX; m];
        let mut free_nodes = Vec::new();
        for q in 0..m {
            if node_role[q] == 0 && reached[q] {
                free_map[q] = free_nodes.len() as u32;
                free_nodes.push(q);
            }
        }
        if free_nodes.is_empty() {
            return Err(Error::Degenerate(
                "buckling: no free particle between the clamped ends".into(),
            ));
        }
        let clamped = (0..m).filter(|&q| node_role[q] != 0).count();
        Ok(ClampedParts {
            net,
            node_role,
            free_map,
            free_nodes,
            clamped,
        })
    }

    /// Position of network node `q`.
    fn position(&self, bar: &ClampedBar, q: usize) -> Vec3 {
        bar.assembly.packing.positions[self.net.original[q] as usize]
    }

    /// Three load cases in one solve (columns of the 6-column blocks), ends moved rigidly
    /// (translation + rotation about the end set's centroid c):
    /// 0: unit axial strain, the second end moved by −l·axis (the pre-buckling state);
    /// 1: pure bending, the ends rotated by ∓½ rad about e₁ (constant moment, no shear);
    /// 2: the second end moved by 1 m along e₂ without rotation (clamped–guided shear).
    /// Returns every node's displacement and the solve's relative residual (refused ≥ 1e-8).
    fn solve_load_cases(
        &self,
        bar: &ClampedBar,
        k: &BlockSparse,
        kff: &BlockSparse,
        chol: &BlockCholesky,
        (e1, e2): (Vec3, Vec3),
    ) -> Result<(Vec<Block6>, f64)> {
        let m = self.net.n_active;
        let (c1, c2) = end_centroids(bar);
        let mut u = vec![Block6::zeros(); m];
        for (q, uq) in u.iter_mut().enumerate() {
            let x = self.position(bar, q);
            let (centre, axial, half_turn, shift) = match self.node_role[q] {
                1 => (c1, Vec3::zeros(), -0.5, Vec3::zeros()),
                2 => (c2, -bar.axis * bar.length, 0.5, e2),
                _ => continue,
            };
            let phi = e1 * half_turn;
            uq.fixed_view_mut::<3, 1>(0, 0).copy_from(&axial);
            uq.fixed_view_mut::<3, 1>(0, 1)
                .copy_from(&phi.cross(&(x - centre)));
            uq.fixed_view_mut::<3, 1>(3, 1).copy_from(&phi);
            uq.fixed_view_mut::<3, 1>(0, 2).copy_from(&shift);
        }
        let mut ku = vec![Block6::zeros(); m];
        k.apply(&u, &mut ku);
        let rhs: Vec<Block6> = self.free_nodes.iter().map(|&q| -ku[q]).collect();
        let sol = chol.solve(&rhs)?;
        let static_residual = column_residual(kff, &sol, &rhs);
        if static_residual.is_nan() || static_residual >= 1e-8 {
            return Err(Error::NotConverged(format!(
                "buckling: the pre-buckling solve has relative residual {static_residual:e} (> 1e-8)"
            )));
        }
        for (f, &q) in self.free_nodes.iter().enumerate() {
            u[q] = sol[f];
        }
        Ok((u, static_residual))
    }

    /// The clamps' reactions (force, and moment about the end's centroid) of the three load
    /// cases: P and E from the axial case, EI = M·l/θ (θ = 1 rad) from pure bending, the
    /// transverse stiffness V/(1 m) from the clamped–guided case; refuses P ≤ 0, EI or k_t ≤ 0.
    fn end_figures(
        &self,
        bar: &ClampedBar,
        k: &BlockSparse,
        u: &[Block6],
        (e1, e2): (Vec3, Vec3),
    ) -> Result<EndFigures> {
        let (c1, c2) = end_centroids(bar);
        let mut ku = vec![Block6::zeros(); u.len()];
        k.apply(u, &mut ku);
        let mut react = [[Vec3::zeros(); 4]; 3];
        for (q, kq) in ku.iter().enumerate() {
            let (slot, centre) = match self.node_role[q] {
                1 => (0, c1),
                2 => (2, c2),
                _ => continue,
            };
            let x = self.position(bar, q);
            for (c, r) in react.iter_mut().enumerate() {
                let f: Vec3 = kq.fixed_view::<3, 1>(0, c).into_owned();
                let mq: Vec3 = kq.fixed_view::<3, 1>(3, c).into_owned();
                r[slot] += f;
                r[slot + 1] += (x - centre).cross(&f) + mq;
            }
        }
        let (r1, r2) = (react[0][0], react[0][2]);
        let force = -r2.dot(&bar.axis);
        if !(force.is_finite() && force > 0.0) {
            return Err(Error::Degenerate(format!(
                "buckling: the bar carries no compressive axial force under shortening (P = \
                 {force:e} N): the ends are not connected by the bond network"
            )));
        }
        // Pure bending: M = EI·θ/l with θ = 1 rad between the ends.
        let bending_stiffness = react[1][3].dot(&e1) * bar.length;
        // Clamped–guided: V = k_t·1 m.
        let transverse_stiffness = react[2][2].dot(&e2);
        if !(bending_stiffness > 0.0 && transverse_stiffness > 0.0) {
            return Err(Error::Degenerate(format!(
                "buckling: bending stiffness {bending_stiffness:e} N·m², transverse stiffness \
                 {transverse_stiffness:e} N/m: expected both > 0"
            )));
        }
        Ok(EndFigures {
            force,
            modulus: force / bar.area,
            reaction_imbalance: (r1 + r2).norm() / r2.norm(),
            bending_stiffness,
            transverse_stiffness,
        })
    }

    /// Start vectors: clamped–clamped bending shapes along two transverse directions plus a
    /// seeded 1 % perturbation of every component.
    fn start_vectors(&self, bar: &ClampedBar, (e1, e2): (Vec3, Vec3), seed: u64) -> Vec<Block6> {
        let origin = end_centroids(bar).0;
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let tau = 2.0 * std::f64::consts::PI;
        self.free_nodes
            .iter()
            .map(|&q| {
                let t = (self.position(bar, q) - origin).dot(&bar.axis) / bar.length;
                let shapes = [
                    1.0 - (tau * t).cos(),
                    (tau * t).sin(),
                    1.0 - (2.0 * tau * t).cos(),
                ];
                let mut blk = Block6::zeros();
                for (s, shape) in shapes.iter().enumerate() {
                    for (c, e) in [(2 * s, e1), (2 * s + 1, e2)] {
                        blk.fixed_view_mut::<3, 1>(0, c).copy_from(&(e * *shape));
                    }
                }
                for v in blk.iter_mut() {
                    *v += 0.01 * (rng.gen::<f64>() - 0.5);
                }
                blk
            })
            .collect()
    }

    /// [`PreBuckling::UpdatedGeometry`]: the fixed point ε = λ(ε) of the eigenproblem on the
    /// bar deformed by ε·u₁ (positions, bond normals and lengths moved, axial forces ε·N₁
    /// along the deformed bonds; Mazzilli's extensible rod, Kumar 2016 Eq. 15).
    fn updated_geometry(
        &self,
        bar: &ClampedBar,
        u: &[Block6],
        forces: &[Vec3],
        linear: &LoadFactors,
        opts: &BucklingOptions,
    ) -> Result<UpdatedGeometryResult> {
        let (a, net) = (bar.assembly, &self.net);
        let bonds = &a.bonds;
        // Axial force N₁ of every bond per unit strain, and the translations u₁.
        let axial: Vec<f64> = (0..bonds.len())
            .map(|b| forces[b].dot(&bonds.normal[b]))
            .collect();
        let shift: Vec<Vec3> = u
            .iter()
            .map(|uq| uq.fixed_view::<3, 1>(0, 0).into_owned())
            .collect();
        let deformed = |strain: f64, start: Vec<Block6>| -> Result<LoadFactors> {
            let mut moved = bonds.clone();
            for (e, &(pi, pj)) in net.ends.iter().enumerate() {
                let b = net.bond[e];
                let branch = bonds.normal[b] * bonds.length[b]
                    + (shift[pj as usize] - shift[pi as usize]) * strain;
                moved.length[b] = branch.norm();
                moved.normal[b] = branch / moved.length[b];
            }
            let net_d = Network::build(&a.packing, &moved, &a.springs, opts.lever_arm, true, None)?;
            let kff_d = BlockSparse::assemble(&net_d).restrict(&self.free_map, 1.0);
            let chol_d = BlockCholesky::factor_definite(&kff_d)?;
            let unit: Vec<Vec3> = (0..bonds.len())
                .map(|b| moved.normal[b] * axial[b])
                .collect();
            let kg_d = geometric_stiffness(&net_d, &moved, &unit)?;
            let aff_d = kg_d.restrict(&self.free_map, -1.0);
            lowest_load_factors(&kff_d, &chol_d, &aff_d, start, opts)
        };
        updated_fixed_point(linear.lambda[0], linear.vectors.clone(), deformed, opts)
    }

    /// Translation of every particle in the first mode (column 0 of `x` on the free nodes),
    /// scaled to a unit largest norm; zero for clamped and unloaded particles.
    fn first_mode(&self, n: usize, x: &[Block6]) -> Vec<Vec3> {
        let mut mode = vec![Vec3::zeros(); n];
        let mut peak: f64 = 0.0;
        for (f, &q) in self.free_nodes.iter().enumerate() {
            let v = Vec3::new(x[f][(0, 0)], x[f][(1, 0)], x[f][(2, 0)]);
            peak = peak.max(v.norm());
            mode[self.net.original[q] as usize] = v;
        }
        if peak > 0.0 {
            for v in &mut mode {
                *v /= peak;
            }
        }
        mode
    }
}

/// Centroids of the first and the second end set: the centres the ends rotate about.
fn end_centroids(bar: &ClampedBar) -> (Vec3, Vec3) {
    let centroid = |set: &[u32]| {
        set.iter()
            .map(|&p| bar.assembly.packing.positions[p as usize])
            .sum::<Vec3>()
            / set.len() as f64
    };
    (centroid(bar.first_end), centroid(bar.second_end))
}

/// Largest relative residual ‖K x − b‖/‖b‖ over the three load-case columns.
fn column_residual(kff: &BlockSparse, sol: &[Block6], rhs: &[Block6]) -> f64 {
    let mut check = vec![Block6::zeros(); sol.len()];
    kff.apply(sol, &mut check);
    let mut residual: f64 = 0.0;
    for c in 0..3 {
        let rnorm: f64 = check
            .iter()
            .zip(rhs)
            .map(|(x, b)| (x - b).column(c).norm_squared())
            .sum::<f64>()
            .sqrt();
        let bnorm: f64 = rhs
            .iter()
            .map(|b| b.column(c).norm_squared())
            .sum::<f64>()
            .sqrt();
        residual = residual.max(rnorm / bnorm.max(f64::MIN_POSITIVE));
    }
    residual
}

/// Bond forces f = S Δ (N > 0 in tension) of the axial case (column 0 of `u`), per original
/// bond, with the count in compression and the axial Love stress and its normal part.
fn bond_forces(bar: &ClampedBar, net: &Network, u: &[Block6], lever_arm: LeverArm) -> BondForces {
    let a = bar.assembly;
    let bonds = &a.bonds;
    let mut out = BondForces {
        forces: vec![Vec3::zeros(); bonds.len()],
        compressed: 0,
        love_total: 0.0,
        love_normal: 0.0,
    };
    for (e, &(pi, pj)) in net.ends.iter().enumerate() {
        let b = net.bond[e];
        let (i, j) = (bonds.i[b] as usize, bonds.j[b] as usize);
        let nrm = bonds.normal[b];
        let (ri, rj) = lever_arm.arms(a.packing.radii[i], a.packing.radii[j], bonds.length[b]);
        let ui: Vector6<f64> = u[pi as usize].column(0).into_owned();
        let uj: Vector6<f64> = u[pj as usize].column(0).into_owned();
        let wi = Vec3::new(ui[3], ui[4], ui[5]);
        let wj = Vec3::new(uj[3], uj[4], uj[5]);
        let delta = Vec3::new(uj[0] - ui[0], uj[1] - ui[1], uj[2] - ui[2])
            + (nrm * ri).cross(&wi)
            + (nrm * rj).cross(&wj);
        let (kn, ks) = (a.springs.kn[b], a.springs.ks[b]);
        let f = delta * ks + nrm * ((kn - ks) * nrm.dot(&delta));
        if f.dot(&nrm) < 0.0 {
            out.compressed += 1;
        }
        let la = bonds.length[b] * nrm.dot(&bar.axis);
        out.love_total += f.dot(&bar.axis) * la;
        out.love_normal += f.dot(&nrm) * nrm.dot(&bar.axis) * la;
        out.forces[b] = f;
    }
    out
}

/// The two lowest load factors of K φ = λ(−K_g)φ, their Ritz vectors and residuals.
struct LoadFactors {
    lambda: [f64; 6],
    residuals: [f64; 2],
    iterations: usize,
    vectors: Vec<Block6>,
}

/// K − σA in block storage, written in the basis of K's diagonal blocks' eigenvectors with
/// the directions K holds no stiffness in (local mechanisms, dropped by the factorisation and
/// so absent from the eigenproblem) replaced by decoupled unit entries. K and A are on the
/// same nodes, rows sorted by column. Also returns whether a diagonal block is already
/// indefinite on K's range.
fn shifted_on_range(k: &BlockSparse, a: &BlockSparse, sigma: f64) -> (BlockSparse, bool) {
    // Per node: eigenvectors of K_pp, the columns of the null directions zeroed.
    let basis: Vec<(Block6, [bool; 6])> = (0..k.rows())
        .map(|p| {
            let (values, mut t) = symmetric_eigen6(&k.diagonal(p));
            let max = values.iter().copied().fold(0.0_f64, f64::max);
            let mut keep = [false; 6];
            for (c, kept) in keep.iter_mut().enumerate() {
                *kept = max > 0.0 && values[c] > 1e-10 * max;
                if !*kept {
                    t.column_mut(c).fill(0.0);
                }
            }
            (t, keep)
        })
        .collect();
    let mut indefinite = false;
    let rows = (0..k.rows())
        .map(|p| {
            let mut row: Vec<(u32, Block6)> = k.row(p).map(|(c, b)| (c as u32, *b)).collect();
            for (c, b) in a.row(p) {
                match row.binary_search_by_key(&(c as u32), |e| e.0) {
                    Ok(i) => row[i].1 -= b * sigma,
                    Err(i) => row.insert(i, (c as u32, -b * sigma)),
                }
            }
            for (c, b) in row.iter_mut() {
                *b = basis[p].0.transpose() * *b * basis[*c as usize].0;
                if *c as usize == p {
                    let (values, _) = symmetric_eigen6(b);
                    let max = values.iter().copied().fold(0.0_f64, f64::max);
                    if values.iter().any(|&e| e < -1e-10 * max) {
                        indefinite = true;
                    }
                    for d in 0..6 {
                        if !basis[p].1[d] {
                            b[(d, d)] = 1.0;
                        }
                    }
                }
            }
            row
        })
        .collect();
    (BlockSparse::from_rows(rows), indefinite)
}

/// Sylvester's inertia test of the pencil K φ = λ A φ (K positive definite on its range):
/// true when K − σA is positive definite on the range of K, i.e. no load factor lies in
/// (0, σ]. A diagonal block with a negative eigenvalue already makes it indefinite (the
/// factorisation would drop that direction with the null space); otherwise the Cholesky
/// factorisation decides (any failure counts as "not definite").
fn no_load_factor_below(k: &BlockSparse, a: &BlockSparse, sigma: f64) -> bool {
    let (m, indefinite) = shifted_on_range(k, a, sigma);
    !indefinite && BlockCholesky::factor_definite(&m).is_ok()
}

/// Relative margin of the inertia check below a converged λ₁: 10 × the tolerance (the Ritz
/// value's error is at most about the residual), at least 1e-6.
fn sturm_margin(tolerance: f64) -> f64 {
    (10.0 * tolerance).max(1e-6)
}

/// Subspace iteration for the lowest load factors of K φ = λ(−K_g)φ: `k` is K and `chol`
/// its factor, `aff` is −K_g (all restricted to the free nodes), `x` holds six start vectors
/// per node. Once the residuals are below the tolerance and the load factors settled, the
/// inertia test ([`no_load_factor_below`]) at λ₁(1 − 10·tol) confirms that no lower mode
/// was missed (a mode weak in the start vectors can still be emerging while a higher one's
/// residual is small); when it finds one the iteration goes on until λ₁ drops below it.
fn lowest_load_factors(
    k: &BlockSparse,
    chol: &BlockCholesky,
    aff: &BlockSparse,
    mut x: Vec<Block6>,
    opts: &BucklingOptions,
) -> Result<LoadFactors> {
    let nf = x.len();
    let mut ax = vec![Block6::zeros(); nf];
    let mut kx: Vec<Block6> = Vec::new();
    let mut lambda = [f64::INFINITY; 6];
    // The two lowest load factors of the Ritz step before (for the settling test).
    let mut previous = [f64::INFINITY; 2];
    let mut residuals = [f64::INFINITY; 2];
    let mut ay = vec![Block6::zeros(); nf];
    let mut iterations = 0;
    let mut converged = false;
    // A load factor below this exists (the inertia test said so) but is not yet found.
    let mut hidden: Option<f64> = None;
    for it in 0..=opts.max_iterations {
        aff.apply(&x, &mut ax);
        if it > 0 {
            residuals = ritz_residuals(&kx, &ax, &lambda);
            iterations = it;
            // Converged: the reported pairs' residuals below the tolerance, and their load
            // factors settled (changed by less than the tolerance over the last step).
            let settled =
                (0..2).all(|c| (lambda[c] - previous[c]).abs() < opts.tolerance * lambda[c]);
            if settled
                && residuals.iter().all(|r| *r < opts.tolerance)
                && hidden.is_none_or(|h| lambda[0] < h)
            {
                let sigma = lambda[0] * (1.0 - sturm_margin(opts.tolerance));
                if no_load_factor_below(k, aff, sigma) {
                    converged = true;
                    break;
                }
                hidden = Some(sigma);
            }
            if it == opts.max_iterations {
                break;
            }
        }
        previous = [lambda[0], lambda[1]];
        (x, kx) = ritz_step(chol, aff, &ax, &mut ay, &mut lambda)?;
    }
    if !lambda[0].is_finite() {
        return Err(Error::Degenerate(
            "buckling: no positive load factor (the geometric stiffness does not soften the \
             bar under compression)"
                .into(),
        ));
    }
    if !converged {
        return Err(not_converged(opts, &lambda, &residuals, hidden));
    }
    Ok(LoadFactors {
        lambda,
        residuals,
        iterations,
        vectors: x,
    })
}

/// Relative residuals ‖Kφ − λ(−K_g)φ‖/‖Kφ‖ of the two lowest Ritz pairs (`kx` = Kφ,
/// `ax` = −K_g φ per node).
fn ritz_residuals(kx: &[Block6], ax: &[Block6], lambda: &[f64; 6]) -> [f64; 2] {
    let mut residuals = [0.0; 2];
    for (c, res) in residuals.iter_mut().enumerate() {
        let (mut num, mut den) = (0.0, 0.0);
        for (kp, ap) in kx.iter().zip(ax) {
            num += (kp.column(c) - ap.column(c) * lambda[c]).norm_squared();
            den += kp.column(c).norm_squared();
        }
        *res = (num / den.max(f64::MIN_POSITIVE)).sqrt();
    }
    residuals
}

/// One subspace step: Y = K⁻¹ A X (`ax` = A X), then Rayleigh–Ritz on span(Y) with the
/// 6×6 projections Yᵀ A X and Yᵀ A Y. Writes the load factors 1/μ (∞ for μ ≤ 0) into
/// `lambda` in increasing order and returns the Ritz vectors and K times them (= A X · Z).
fn ritz_step(
    chol: &BlockCholesky,
    aff: &BlockSparse,
    ax: &[Block6],
    ay: &mut [Block6],
    lambda: &mut [f64; 6],
) -> Result<(Vec<Block6>, Vec<Block6>)> {
    let y = chol.solve(ax)?;
    let kr = gram(&y, ax);
    let kr = (kr + kr.transpose()) * 0.5;
    aff.apply(&y, ay);
    let ar = gram(&y, ay);
    let ar = (ar + ar.transpose()) * 0.5;
    let l = kr.cholesky().ok_or_else(|| {
        Error::Degenerate(
            "buckling: the iterated subspace collapsed (−K_g maps the start vectors to \
             zero: no bond carries force in the free part)"
                .into(),
        )
    })?;
    let linv = l
        .l()
        .try_inverse()
        .ok_or_else(|| Error::Degenerate("buckling: singular Ritz basis".into()))?;
    let c = linv * ar * linv.transpose();
    let eig = nalgebra::SymmetricEigen::new((c + c.transpose()) * 0.5);
    let mut order: Vec<usize> = (0..6).collect();
    order.sort_by(|&p, &q| eig.eigenvalues[q].total_cmp(&eig.eigenvalues[p]));
    let mut z = Matrix6::zeros();
    for (col, &o) in order.iter().enumerate() {
        z.set_column(col, &(linv.transpose() * eig.eigenvectors.column(o)));
        let mu = eig.eigenvalues[o];
        lambda[col] = if mu > 0.0 { 1.0 / mu } else { f64::INFINITY };
    }
    Ok((
        y.iter().map(|yp| yp * z).collect(),
        ax.iter().map(|ap| ap * z).collect(),
    ))
}

/// The error of an iteration that ran out of steps: with a load factor known to lie below
/// its λ₁ (the inertia test's σ), or with its residuals above the tolerance.
fn not_converged(
    opts: &BucklingOptions,
    lambda: &[f64; 6],
    residuals: &[f64; 2],
    hidden: Option<f64>,
) -> Error {
    Error::NotConverged(match hidden {
        Some(h) => format!(
            "buckling: subspace iteration did not converge in {} iterations: its λ₁ = {:e} \
             has residual {:e}, but K + σK_g is not positive definite at σ = {h:e}, so a \
             lower load factor exists that the iteration has not found",
            opts.max_iterations, lambda[0], residuals[0]
        ),
        None => format!(
            "buckling: subspace iteration did not converge in {} iterations (residuals \
             {:e}, {:e} > {:e}; λ₁ = {:e})",
            opts.max_iterations, residuals[0], residuals[1], opts.tolerance, lambda[0]
        ),
    })
}

/// The fixed point ε = λ(ε) of [`PreBuckling::UpdatedGeometry`] by secant steps from
/// (0, λ_lin): `deformed(ε, start)` solves the eigenproblem on the bar deformed by ε.
/// Converged when |λ(ε) − ε| < tolerance·ε; an error when it leaves (0, 1) or does not
/// converge in 50 steps.
fn updated_fixed_point(
    linear: f64,
    start: Vec<Block6>,
    deformed: impl Fn(f64, Vec<Block6>) -> Result<LoadFactors>,
    opts: &BucklingOptions,
) -> Result<UpdatedGeometryResult> {
    let (mut e0, mut h0) = (0.0, linear);
    let mut e1 = linear;
    let mut step = deformed(e1, start)?;
    let mut eigen_iterations = step.iterations;
    let mut h1 = step.lambda[0] - e1;
    let mut iterations = 1;
    while h1.abs() >= opts.tolerance * e1 {
        if iterations == 50 {
            return Err(Error::NotConverged(format!(
                "buckling on the deformed bar: the fixed point ε = λ(ε) did not converge in \
                 50 steps (ε = {e1:e}, |λ(ε) − ε|/ε = {:e})",
                h1.abs() / e1
            )));
        }
        let e2 = e1 - h1 * (e1 - e0) / (h1 - h0);
        if !(e2.is_finite() && e2 > 0.0 && e2 < 1.0) {
            return Err(Error::Degenerate(format!(
                "buckling on the deformed bar: no critical strain in (0, 1) (the secant step \
                 from ε = {e1:e} gives {e2:e}; linear ε_cr = {linear:e})"
            )));
        }
        (e0, h0, e1) = (e1, h1, e2);
        step = deformed(e1, step.vectors)?;
        eigen_iterations += step.iterations;
        h1 = step.lambda[0] - e1;
        iterations += 1;
    }
    Ok(UpdatedGeometryResult {
        critical_strain: e1,
        critical_stress: f64::NAN,
        critical_force: f64::NAN,
        fixed_point_iterations: iterations,
        fixed_point_residual: h1.abs() / e1,
        eigen_iterations,
    })
}

impl UpdatedGeometryResult {
    /// Fill the stress and force from the linear axial force per strain and modulus.
    fn with_force(mut self, force_per_strain: f64, modulus: f64) -> Self {
        self.critical_stress = self.critical_strain * modulus;
        self.critical_force = self.critical_strain * force_per_strain;
        self
    }
}

/// Euler's critical stress of a clamped–clamped round bar, Kumar 2016 Eq. 14:
/// σ = π²E / (4 (k l/r)²) with k = 0.5 (Pa, for E in Pa).
pub fn euler_stress(modulus: f64, slenderness: f64) -> f64 {
    let kl = 0.5 * slenderness;
    std::f64::consts::PI.powi(2) * modulus / (4.0 * kl * kl)
}

/// Mazzilli's critical stress of an extensible clamped–clamped round bar, Kumar 2016 Eq. 15:
/// σ = (1 − √(1 − π²/(k l/r)²))·E/2 with k = 0.5; NaN when k·l/r < π (no real root).
pub fn mazzilli_stress(modulus: f64, slenderness: f64) -> f64 {
    extensible_stress(euler_stress(modulus, slenderness), modulus)
}

/// The extensible rod's critical stress for a given inextensible (Euler) one: the smaller
/// root of σ(1 − σ/E) = σ_E, σ = (1 − √(1 − 4σ_E/E))·E/2 (Kumar 2016 Eq. 15 with any
/// σ_E, e.g. a bar's own); NaN when 4σ_E > E (no real root).
pub fn extensible_stress(euler: f64, modulus: f64) -> f64 {
    let d = 1.0 - 4.0 * euler / modulus;
    if d < 0.0 {
        return f64::NAN;
    }
    (1.0 - d.sqrt()) * modulus / 2.0
}

impl BucklingResult {
    /// The bar's shear stiffness κGA (N) of a Timoshenko beam, from the clamped–guided
    /// stiffness k_t and EI: 1/k_t = l³/(12 EI) + l/(κGA); infinite when the bar bends like
    /// an Euler–Bernoulli beam to rounding.
    pub fn shear_stiffness(&self, length: f64) -> f64 {
        let shear_compliance =
            1.0 / self.transverse_stiffness - length.powi(3) / (12.0 * self.bending_stiffness);
        if shear_compliance > 0.0 {
            length / shear_compliance
        } else {
            f64::INFINITY
        }
    }

    /// Euler's clamped–clamped critical force with the bar's own bending stiffness,
    /// P = 4π²EI/l² (N) (Kumar 2016 Eq. 14 with EI instead of E·πr⁴/4).
    pub fn euler_force_own(&self, length: f64) -> f64 {
        4.0 * std::f64::consts::PI.powi(2) * self.bending_stiffness / (length * length)
    }

    /// Engesser's shear-corrected critical force P_E/(1 + P_E/κGA) (N) with the bar's own
    /// EI and κGA: the continuum value a linearised (small-strain) network tends to for a
    /// short bar.
    pub fn engesser_force_own(&self, length: f64) -> f64 {
        let pe = self.euler_force_own(length);
        pe / (1.0 + pe / self.shear_stiffness(length))
    }

    /// The bar's bending stiffness over E·πr⁴/4 of a solid round bar of the area's radius,
    /// (EI)/(E·A·r²/4) with r² = A/π: below 1 when the outer layer is less stiff (the cut
    /// surface's broken bonds). σ_cr/σ_Euler of a slender bar tends to this ratio.
    pub fn bending_ratio(&self, area: f64) -> f64 {
        let r2 = area / std::f64::consts::PI;
        self.bending_stiffness / (self.modulus * area * r2 / 4.0)
    }
}

/// A round bar cut from a packing or prepared in a container (Kumar 2016 Sec. 5): the
/// bonded assembly, its clamped end sets and its dimensions.
#[derive(Clone, Debug)]
pub struct RoundBar {
    /// The bonded bar.
    pub assembly: Assembly,
    /// End and surface sets.
    pub boundary: BoundarySets,
    /// The region the bar was cut with (the container, for [`RoundBar::in_container`]).
    pub region: Region,
    /// Radius r (m) of the cylinder holding the sphere centres (the container's).
    pub radius: f64,
    /// Length l (m).
    pub length: f64,
}

impl RoundBar {
    /// Cut the bar of radius `radius` (m) and slenderness l/r = `slenderness` along z out of
    /// `packing` (centred on the cell's axis when periodic, the cell tiled along z as far as
    /// the length needs), bond it by `model` and clamp the spheres within `clamp_depth` (m)
    /// of each end face (Kumar: the spheres touching the end planes, depth = R̄).
    pub fn cut(
        packing: &Packing,
        model: Model,
        radius: f64,
        slenderness: f64,
        clamp_depth: f64,
    ) -> Result<RoundBar> {
        if !(slenderness.is_finite() && slenderness > 0.0) {
            return Err(Error::Invalid(format!(
                "bar: slenderness l/r must be finite and > 0, got {slenderness}"
            )));
        }
        let length = slenderness * radius;
        let centre = match &packing.cell {
            Some(c) => Vec3::new(0.5 * c.lengths.x, 0.5 * c.lengths.y, 0.5 * length),
            None => {
                let (lo, hi) = packing.bounding_box();
                let mid = (lo + hi) * 0.5;
                Vec3::new(mid.x, mid.y, lo.z + 0.5 * length)
            }
        };
        let region = Region::Cylinder {
            centre,
            axis: Vec3::z(),
            radius,
            length,
        };
        let (assembly, cut) = Assembly::cut(packing, &region, model)?;
        let boundary = cut.boundary(clamp_depth)?;
        Ok(RoundBar {
            assembly,
            boundary,
            region,
            radius,
            length,
        })
    }

    /// Kumar 2016 Sec. 5's own preparation: the spheres of a bar of radius `radius` (m) and
    /// slenderness l/r = `slenderness` packed by `route` (its route, radius distribution,
    /// solid fraction and seed; the number of spheres is
    /// [`container_particles`]: as many per unit length as a cut bar's) inside a rigid
    /// cylinder and two planes ([`prepare_in_container`]), the container removed, the
    /// spheres bonded by `model` and the spheres in contact with the planes clamped. The
    /// bar's radius and length are the container's (its radius within a fraction of a
    /// percent of `radius`: the volume follows the drawn radii). Also returns how the
    /// preparation went.
    pub fn in_container(
        route: &RouteOptions,
        model: Model,
        radius: f64,
        slenderness: f64,
    ) -> Result<(RoundBar, RouteReport)> {
        let opts = RouteOptions {
            n_particles: container_particles(radius, slenderness, route),
            ..route.clone()
        };
        let (prepared, report) = prepare_in_container(&opts, slenderness, &|_| {})?;
        let boundary = prepared.boundary()?;
        let region = prepared.container.region();
        let assembly = Assembly::new(prepared.packing, model)?;
        let bar = RoundBar {
            assembly,
            boundary,
            region,
            radius: prepared.container.radius,
            length: prepared.container.length,
        };
        Ok((bar, report))
    }

    /// The same bar with its sphere centres moved by `amplitude` (m) × `mode` (one vector per
    /// sphere with unit largest norm, e.g. [`BucklingResult::mode`]): a stress-free geometric
    /// imperfection in the shape of the buckling mode. Bonds and springs are kept; their
    /// lengths and normals follow the moved centres (the integrator takes them as the rest
    /// state). Refuses a mode of the wrong length, a non-finite or negative amplitude and a
    /// periodic bar.
    pub fn imperfect(&self, mode: &[Vec3], amplitude: f64) -> Result<RoundBar> {
        let p = &self.assembly.packing;
        if mode.len() != p.len() {
            return Err(Error::Invalid(format!(
                "imperfection: {} mode vectors for {} spheres",
                mode.len(),
                p.len()
            )));
        }
        if !(amplitude.is_finite() && amplitude >= 0.0) {
            return Err(Error::Invalid(format!(
                "imperfection: the amplitude must be finite and ≥ 0 m, got {amplitude:e}"
            )));
        }
        if p.cell.is_some() {
            return Err(Error::Invalid(
                "imperfection: the bar must be a free assembly (no periodic cell)".into(),
            ));
        }
        let mut bar = self.clone();
        for (x, m) in bar.assembly.packing.positions.iter_mut().zip(mode) {
            *x += m * amplitude;
        }
        let (positions, bonds) = (&bar.assembly.packing.positions, &mut bar.assembly.bonds);
        for b in 0..bonds.len() {
            let branch = positions[bonds.j[b] as usize] - positions[bonds.i[b] as usize];
            bonds.length[b] = branch.norm();
            bonds.normal[b] = branch / bonds.length[b];
        }
        Ok(bar)
    }

    /// Cross-section area πr² (m²).
    pub fn area(&self) -> f64 {
        std::f64::consts::PI * self.radius * self.radius
    }

    /// Linearised buckling of the bar clamped at both end sets ([`clamped_bar_buckling`]).
    pub fn buckling(&self, opts: &BucklingOptions) -> Result<BucklingResult> {
        let bar = ClampedBar {
            assembly: &self.assembly,
            first_end: &self.boundary.first_end,
            second_end: &self.boundary.second_end,
            axis: self.region.axis(),
            length: self.length,
            area: self.area(),
        };
        clamped_bar_buckling(&bar, opts)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The inertia test on a pencil with closed-form load factors: two nodes, K = 2I and
    /// 3I, A diagonal with entries 1, 0.5 (node 0) and 1, −1 (node 1): λ = 2, 4, 3 (and a
    /// negative one, which no σ > 0 sees). No load factor below σ exactly for σ < 2.
    #[test]
    fn inertia_test_counts_the_closed_form_load_factors() {
        let diag = |v: [f64; 6]| Block6::from_diagonal(&Vector6::from(v));
        let k = BlockSparse::from_rows(vec![vec![(0, diag([2.0; 6]))], vec![(1, diag([3.0; 6]))]]);
        let a = BlockSparse::from_rows(vec![
            vec![(0, diag([1.0, 0.5, 0.0, 0.0, 0.0, 0.0]))],
            vec![(1, diag([1.0, -1.0, 0.0, 0.0, 0.0, 0.0]))],
        ]);
        for (sigma, none_below) in [(0.5, true), (1.999, true), (2.001, false), (3.5, false)] {
            assert_eq!(
                no_load_factor_below(&k, &a, sigma),
                none_below,
                "σ = {sigma}"
            );
        }
    }
}
