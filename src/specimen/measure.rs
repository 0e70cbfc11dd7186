//! The last steps of the specimen solve: what the load test measures, from the solved field —
//! the residual, the platens' forces and the load factor, the cross-section, the lateral
//! strains, the fields and bond forces — and the report.

use super::network::{Gauge, Groups, Network};
use super::system::{Boundary, Field};
use super::{
    axis_name, least_squares, surface, ConfiningReport, Load, SpecimenOptions, SpecimenReport,
    CONFINING_RULE, HOW, RESIDUAL_LIMIT, SUPPORT_LIMIT,
};
use crate::assembly::Assembly;
use crate::homogenize::network::Block6;
use crate::{Error, Mat3, Result, Vec3};
use rayon::prelude::*;

/// Whether a node's bonds hold its centre when its neighbours are fixed: the Schur
/// complement S = K_uu − K_uω K_ωω⁺ K_ωu of its 6×6 diagonal block (its spin free to follow)
/// has full rank, each eigenvalue above 1e-10 of K_uu's largest (the cut of
/// [`crate::homogenize::network::pinv_psd`]). A sphere on one bond at its contact point c
/// swings (u = −ω × c) at no energy, S its normal stiffness alone; on normal springs only,
/// K_uω = 0 and S = K_uu.
fn holds_centre(block: &Block6) -> bool {
    let kuu: Mat3 = block.fixed_view::<3, 3>(0, 0).into_owned();
    let kuw: Mat3 = block.fixed_view::<3, 3>(0, 3).into_owned();
    let kww: Mat3 = block.fixed_view::<3, 3>(3, 3).into_owned();
    let eig = kww.symmetric_eigen();
    let top = eig.eigenvalues.max();
    let mut kww_pinv = Mat3::zeros();
    for (l, v) in eig.eigenvalues.iter().zip(eig.eigenvectors.column_iter()) {
        if top > 0.0 && *l > 1e-10 * top {
            kww_pinv += v * v.transpose() / *l;
        }
    }
    let s = kuu - kuw * kww_pinv * kuw.transpose();
    let scale = kuu.symmetric_eigenvalues().max();
    let held = s.symmetric_eigenvalues();
    scale > 0.0 && held.iter().all(|&l| l > 1e-10 * scale)
}

/// The solved specimen, to be measured.
pub(super) struct Solved<'a> {
    /// The bonded packing.
    pub assembly: &'a Assembly,
    /// What was asked for.
    pub opts: &'a SpecimenOptions,
    /// The held and moved groups.
    pub groups: Groups,
    /// The loaded network and its nodes.
    pub net: Network,
    /// The gauge length and direction.
    pub gauge: Gauge,
    /// The prescribed DOFs, supports and confining loads.
    pub bc: Boundary,
    /// The solved displacements and rotations.
    pub field: Field,
}

/// Per-particle fields of the combined response (zero off the loaded part).
struct Fields {
    displacement: Vec<Vec3>,
    rotation: Vec<Vec3>,
    reaction: Vec<Vec3>,
    confining_force: Vec<Vec3>,
}

/// The measured numbers of the report.
struct Measured {
    relative_residual: f64,
    control: &'static str,
    delta: f64,
    held_reaction: Vec3,
    moved_reaction: Vec3,
    area: f64,
    young: f64,
    platen_stiffness: f64,
    poisson_lateral: [f64; 2],
    lateral_strain: [f64; 2],
}

impl Solved<'_> {
    /// Measure the solved specimen and write the report; refused when the solve's residual is
    /// too large, the response is not a positive finite stiffness, the lateral supports carry
    /// force, or the lateral strain cannot be measured.
    pub fn measure(self) -> Result<SpecimenReport> {
        // K u formed row by row after the solve, K never stored beside the solve's matrix
        // and work vectors (at a million particles 2.5 GB; issue 35). The same bits.
        let (ku, diagonal) = self
            .net
            .stiffness_times(self.assembly, self.opts, &self.field.u);
        let relative_residual = self.residual(&ku)?;
        let (force_a, alpha, control) = self.platen_load(&ku)?;
        let (ax, sign) = (self.opts.axis, self.gauge.sign);
        let held_reaction = self.reaction_total(&ku, alpha, 1);
        let moved_reaction = self.reaction_total(&ku, alpha, 2);
        let axial_force = -sign * moved_reaction[ax];
        self.check_supports(&ku, axial_force, force_a)?;
        let area = self.area();
        let (delta0, length) = (self.bc.delta0, self.gauge.length);
        let strain0 = delta0 / length;
        let middle = self.middle(&diagonal);
        let eps0 = self.lateral_strains(&middle, &|a, d| self.field.u[a][(d, 0)]);
        let eps = self.lateral_strains(&middle, &|a, d| self.combine(alpha, &self.field.u[a], d));
        // ν = −ε_lat/ε_axial with the axial strain −δ/L (compression) and the lateral ones
        // signed (extension positive).
        let poisson_lateral = [eps0[0] / strain0, eps0[1] / strain0];
        if !poisson_lateral.iter().chain(&eps).all(|v| v.is_finite()) {
            return Err(Error::Degenerate(format!(
                "specimen: the middle third holds {} loaded particles whose bonds hold their \
                 centres, too few to measure the lateral strain",
                middle.len()
            )));
        }
        let fields = self.fields(&ku, alpha);
        let measured = Measured {
            relative_residual,
            control,
            delta: alpha * delta0,
            held_reaction,
            moved_reaction,
            area,
            young: force_a / area / strain0,
            platen_stiffness: force_a / delta0,
            poisson_lateral,
            lateral_strain: eps,
        };
        let report = self.report(measured, fields, alpha);
        let finite = [
            report.young,
            report.poisson,
            report.platen_stiffness,
            report.axial_force,
            report.displacement,
        ];
        if !finite.iter().all(|v| v.is_finite()) || report.platen_stiffness <= 0.0 {
            return Err(Error::Degenerate(format!(
                "specimen: platen stiffness {:.3e} N/m, Young's modulus {:.3e} Pa: not a \
                 positive finite response",
                report.platen_stiffness, report.young
            )));
        }
        Ok(report)
    }

    /// Relative residual of the solve at the free DOFs, against the load (reactions and
    /// external forces), the worst load case; refused above [`RESIDUAL_LIMIT`].
    fn residual(&self, ku: &[Block6]) -> Result<f64> {
        let bc = &self.bc;
        let mut relative_residual: f64 = 0.0;
        for case in 0..bc.cases {
            let (mut rr, mut ff) = (0.0, 0.0);
            for (a, kua) in ku.iter().enumerate() {
                for d in 0..6 {
                    let f = kua[(d, case)] - bc.external(a, d, case);
                    if bc.prescribed[a][d].is_none() {
                        rr += f * f;
                        ff += bc.external(a, d, case).powi(2);
                    } else {
                        ff += f * f;
                    }
                }
            }
            relative_residual = relative_residual.max((rr / ff).sqrt());
        }
        if relative_residual.is_nan() || relative_residual > RESIDUAL_LIMIT {
            return Err(Error::NotConverged(format!(
                "specimen: static solve residual {relative_residual:.3e} > {RESIDUAL_LIMIT:e}: \
                 the bonded specimen is too ill-conditioned or has a mechanism"
            )));
        }
        Ok(relative_residual)
    }

    /// Reaction of the platens on group `which` (1 held, 2 moved) in load case `case`:
    /// K u − f_ext summed over the group.
    fn reaction_of(&self, ku: &[Block6], which: u8, case: usize) -> Vec3 {
        let mut r = Vec3::zeros();
        for (a, &p) in self.net.original.iter().enumerate() {
            if self.groups.layer[p] == which {
                for d in 0..3 {
                    r[d] += ku[a][(d, case)] - self.bc.external(a, d, case);
                }
            }
        }
        r
    }

    /// The reaction on group `which` under the whole load: case 0 scaled by `alpha`, plus
    /// the confinement's case.
    fn reaction_total(&self, ku: &[Block6], alpha: f64, which: u8) -> Vec3 {
        let r0 = self.reaction_of(ku, which, 0) * alpha;
        if self.bc.cases > 1 {
            r0 + self.reaction_of(ku, which, 1)
        } else {
            r0
        }
    }

    /// The axial force of the trial shortening (K u is the force the platens exert;
    /// compression pushes the moved group towards the held one, −sign along the axis), and
    /// the load factor of case 0 with the control: 1 under displacement control, under
    /// force control the shortening that makes the moved group's axial force F.
    fn platen_load(&self, ku: &[Block6]) -> Result<(f64, f64, &'static str)> {
        let (ax, sign) = (self.opts.axis, self.gauge.sign);
        let force_a = -sign * self.reaction_of(ku, 2, 0)[ax];
        let force_b = if self.bc.cases > 1 {
            -sign * self.reaction_of(ku, 2, 1)[ax]
        } else {
            0.0
        };
        if !(force_a.is_finite() && force_a > 0.0) {
            return Err(Error::Degenerate(format!(
                "specimen: platen force {force_a:.3e} N for a shortening {:.3e} m: not a \
                 positive finite response",
                self.bc.delta0
            )));
        }
        Ok(match self.opts.load {
            Load::Force(f) => (force_a, (f - force_b) / force_a, "force"),
            Load::Strain(_) | Load::Displacement(_) => (force_a, 1.0, "displacement"),
        })
    }

    /// DOF `d` of a node's block under the whole load: case 0 scaled by `alpha`, plus the
    /// confinement's case.
    fn combine(&self, alpha: f64, blk: &Block6, d: usize) -> f64 {
        alpha * blk[(d, 0)] + if self.bc.cases > 1 { blk[(d, 1)] } else { 0.0 }
    }

    /// Refuse a field whose frictionless lateral supports carry force (more than
    /// [`SUPPORT_LIMIT`] of the axial and confining forces): the specimen would not be held
    /// by axial forces alone.
    fn check_supports(&self, ku: &[Block6], axial_force: f64, force_a: f64) -> Result<()> {
        let bc = &self.bc;
        let confining_total: f64 = bc
            .confining
            .as_ref()
            .map(|c| c.force.iter().map(|f| f.norm()).sum())
            .unwrap_or(0.0);
        for &(a, d) in &bc.supports {
            let scale = if d >= 3 { self.gauge.length } else { 1.0 };
            let allowed = SUPPORT_LIMIT * axial_force.abs().max(force_a).max(confining_total);
            let worst = (0..bc.cases)
                .map(|c| ((ku[a][(d, c)] - bc.external(a, d, c)) / scale).abs())
                .fold(0.0, f64::max);
            if worst.is_nan() || worst > allowed {
                return Err(Error::Degenerate(format!(
                    "specimen: the lateral support of a frictionless platen carries {worst:.3e} \
                     (N or N·m/m) against an axial force {axial_force:.3e} N; the specimen is \
                     not held by axial forces alone"
                )));
            }
        }
        Ok(())
    }

    /// Cross-section (m²): the cell's lateral face when periodic across the axis, else the
    /// loaded spheres' section of the chosen shape.
    fn area(&self) -> f64 {
        let packing = &self.assembly.packing;
        let lateral = [(self.opts.axis + 1) % 3, (self.opts.axis + 2) % 3];
        match self.net.periods {
            Some(l) => l[lateral[0]] * l[lateral[1]],
            None => {
                let original = &self.net.original;
                let centres: Vec<Vec3> = original.iter().map(|&q| packing.positions[q]).collect();
                let radii: Vec<f64> = original.iter().map(|&q| packing.radii[q]).collect();
                surface::Section::of(&centres, &radii, self.opts.axis).area(self.opts.shape)
            }
        }
    }

    /// The loaded nodes off the groups whose centres lie in the middle third of the gauge and
    /// whose bonds hold their centre ([`holds_centre`] of their `diagonal` block of K).
    /// Without bending springs a sphere on one bond, or two, swings about its contacts at no
    /// energy: its displacement is whatever the solver left in that mode (it moved the free
    /// 100,000-sphere cluster's ν by 1.0e-5 between two preconditioners), not the specimen's
    /// strain.
    fn middle(&self, diagonal: &[Block6]) -> Vec<usize> {
        let (original, layer, g) = (&self.net.original, &self.groups.layer, &self.gauge);
        let x = &self.assembly.packing.positions;
        (0..original.len())
            .into_par_iter()
            .filter(|&a| {
                let c = g.sign * (x[original[a]][self.opts.axis] - g.held_mean);
                layer[original[a]] == 0
                    && c >= g.length / 3.0
                    && c <= 2.0 * g.length / 3.0
                    && holds_centre(&diagonal[a])
            })
            .collect()
    }

    /// Lateral strains of a field (`field(a, d)`: DOF d of node a) along the two lateral
    /// axes: the change of the lateral period, or the least-squares slope of the lateral
    /// displacement over the lateral coordinate on the `middle` nodes (NaN if too few).
    fn lateral_strains(&self, middle: &[usize], field: &dyn Fn(usize, usize) -> f64) -> [f64; 2] {
        let ax = self.opts.axis;
        let lateral = [(ax + 1) % 3, (ax + 2) % 3];
        let (x, m) = (&self.assembly.packing.positions, self.net.original.len());
        let mut out = [f64::NAN; 2];
        for (kk, &d) in lateral.iter().enumerate() {
            if let Some(l) = self.net.periods {
                out[kk] = field(m, 3 * kk + d) / l[d];
                continue;
            }
            let rows: Vec<([f64; 4], f64)> = middle
                .iter()
                .map(|&a| {
                    let xa = x[self.net.original[a]];
                    ([1.0, xa[d], xa[lateral[1 - kk]], xa[ax]], field(a, d))
                })
                .collect();
            if let Some(c) = least_squares(&rows) {
                out[kk] = c[1];
            }
        }
        out
    }

    /// Displacement, rotation, platen force and confining force of every particle under the
    /// whole load.
    fn fields(&self, ku: &[Block6], alpha: f64) -> Fields {
        let n = self.assembly.packing.len();
        let (u, bc) = (&self.field.u, &self.bc);
        let mut f = Fields {
            displacement: vec![Vec3::zeros(); n],
            rotation: vec![Vec3::zeros(); n],
            reaction: vec![Vec3::zeros(); n],
            confining_force: vec![Vec3::zeros(); n],
        };
        let c = |a: usize, d: usize| self.combine(alpha, &u[a], d);
        for (a, &p) in self.net.original.iter().enumerate() {
            f.displacement[p] = Vec3::new(c(a, 0), c(a, 1), c(a, 2));
            f.rotation[p] = Vec3::new(c(a, 3), c(a, 4), c(a, 5));
            if let Some(conf) = &bc.confining {
                f.confining_force[p] = conf.force[a];
            }
            if self.groups.layer[p] != 0 {
                let mut r = Vec3::zeros();
                for d in 0..3 {
                    r[d] = alpha * ku[a][(d, 0)]
                        + if bc.cases > 1 {
                            ku[a][(d, 1)] - bc.external(a, d, 1)
                        } else {
                            0.0
                        };
                }
                f.reaction[p] = r;
            }
        }
        f
    }

    /// Force on i from j of every bond of the packing (zero for unloaded bonds): f = SΔ with
    /// Δ = (u_j + ω_j × (−r_j n)) − (u_i + ω_i × (r_i n)), the image of j displaced by the
    /// lateral periods' changes.
    fn bond_forces(&self, fields: &Fields, alpha: f64) -> Vec<Vec3> {
        let (packing, bonds, k) = (
            &self.assembly.packing,
            &self.assembly.bonds,
            &self.assembly.springs,
        );
        let lateral = [(self.opts.axis + 1) % 3, (self.opts.axis + 2) % 3];
        let m = self.net.original.len();
        let c = |d: usize| self.combine(alpha, &self.field.u[m], d);
        let period_change: Option<[Vec3; 2]> = (self.net.periods.is_some())
            .then(|| [Vec3::new(c(0), c(1), c(2)), Vec3::new(c(3), c(4), c(5))]);
        let (u, w) = (&fields.displacement, &fields.rotation);
        let mut bond_force = vec![Vec3::zeros(); bonds.len()];
        for &b in &self.net.loaded_bonds {
            let (i, j) = (bonds.i[b] as usize, bonds.j[b] as usize);
            let nrm = bonds.normal[b];
            let (ri, rj) =
                self.opts
                    .lever_arm
                    .arms(packing.radii[i], packing.radii[j], bonds.length[b]);
            let mut uj = u[j];
            if let Some(pc) = &period_change {
                for (c, &d) in lateral.iter().enumerate() {
                    uj += pc[c] * f64::from(bonds.image[b][d]);
                }
            }
            let delta = (uj + w[j].cross(&(-nrm * rj))) - (u[i] + w[i].cross(&(nrm * ri)));
            bond_force[b] = delta * k.ks[b] + nrm * ((k.kn[b] - k.ks[b]) * nrm.dot(&delta));
        }
        bond_force
    }

    /// The report of the measured numbers and the fields.
    fn report(self, m: Measured, fields: Fields, alpha: f64) -> SpecimenReport {
        let bond_force = self.bond_forces(&fields, alpha);
        let (opts, g, sign, ax) = (self.opts, &self.gauge, self.gauge.sign, self.opts.axis);
        let n = self.assembly.packing.len();
        let v = |r: Vec3| [r.x, r.y, r.z];
        SpecimenReport {
            axis: axis_name(ax),
            platens: opts.platens,
            lateral: opts.lateral,
            shape: opts.shape,
            control: m.control,
            n_particles: n,
            loaded_particles: self.net.original.len(),
            unloaded_particles: n - self.net.original.len(),
            loaded_bonds: self.net.loaded_bonds.len(),
            held_group: self.groups.held.describe(),
            moved_group: self.groups.moved.describe(),
            held_particles: g.n_held,
            moved_particles: g.n_moved,
            length: g.length,
            area: m.area,
            displacement: m.delta,
            strain: m.delta / g.length,
            axial_force: -sign * m.moved_reaction[ax],
            held_force: sign * m.held_reaction[ax],
            held_reaction: v(m.held_reaction),
            moved_reaction: v(m.moved_reaction),
            platen_stiffness: m.platen_stiffness,
            young: m.young,
            poisson_lateral: m.poisson_lateral,
            poisson: 0.5 * (m.poisson_lateral[0] + m.poisson_lateral[1]),
            lateral_strain: m.lateral_strain,
            confining: self.bc.confining.as_ref().map(|c| ConfiningReport {
                pressure: opts.confining_pressure.unwrap_or(0.0),
                area: c.area,
                particles: c.particles,
                cells: c.cells,
                empty_cells: c.empty_cells,
                correction: c.correction,
                rule: CONFINING_RULE,
            }),
            how: HOW,
            relative_residual: m.relative_residual,
            unknowns: self.field.unknowns,
            solver: self.field.solver,
            displacement_field: fields.displacement,
            rotation_field: fields.rotation,
            reaction: fields.reaction,
            confining_force: fields.confining_force,
            layer: self.groups.layer,
            bond_force,
            bond_loaded: self.net.active,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The diagonal block Bᵀ D B of springs at contact points c = r n (outward unit n) of one
    /// sphere: the contact's motion u + ω × c = B (u, ω), D = k_n nnᵀ + k_s (I − nnᵀ).
    fn block(normals: &[Vec3], k_n: f64, k_s: f64) -> Block6 {
        let r = 1.0e-3;
        let mut k = Block6::zeros();
        for n in normals {
            let n = n.normalize();
            let c = n * r;
            let d = n * n.transpose() * k_n + (Mat3::identity() - n * n.transpose()) * k_s;
            // ω × c = −[c]× ω.
            let mut b = nalgebra::SMatrix::<f64, 3, 6>::zeros();
            b.fixed_view_mut::<3, 3>(0, 0).copy_from(&Mat3::identity());
            b.fixed_view_mut::<3, 3>(0, 3)
                .copy_from(&(-c.cross_matrix()));
            k += b.transpose() * d * b;
        }
        k
    }

    /// One bond, or two, leave the centre free to swing about the contacts (S of rank 1, 2);
    /// three non-collinear contacts hold it, with shear springs or with normal springs alone
    /// (then K_uω = 0, S = K_uu).
    #[test]
    fn a_centre_is_held_by_three_non_collinear_contacts() {
        let (x, y, z) = (Vec3::x(), Vec3::y(), Vec3::z());
        let tilted = Vec3::new(0.3, -0.8, 0.52);
        assert!(!holds_centre(&block(&[x], 1e8, 3e7)));
        assert!(!holds_centre(&block(&[x, tilted], 1e8, 3e7)));
        assert!(holds_centre(&block(&[x, y, tilted], 1e8, 3e7)));
        assert!(holds_centre(&block(&[x, y, z], 1e8, 0.0)));
        assert!(!holds_centre(&block(&[x, y], 1e8, 0.0)));
        assert!(!holds_centre(&Block6::zeros()));
    }
}
