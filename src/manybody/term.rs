//! The many-body term's reference data (each particle's bonds and fit matrix A_p⁻¹), its
//! energy, forces, nominal stress and Hessian (docs/manybody.md).
//!
//! Notation: bond b joins i_b → j_b with reference branch vector L_b and current l_b; particle
//! p's fit coefficient of bond b is a_b = A_p⁻¹ L_b, so F_p = Σ_b l_b ⊗ a_b and
//! ∂F_p/∂l_b = I ⊗ a_b. With P_p = ∂W/∂F (W the energy density) the energy's gradient with
//! respect to a branch vector is g_b = Σ_{p ∈ {i_b, j_b}} V_p P_p a_b, a pair of opposite
//! forces on the bond's ends: every force is an exact derivative of one energy.

use super::{DegenerateParticles, LocalTensor, ManyBodyOptions, StrainMeasure};
use crate::bonds::BondSet;
use crate::homogenize::network::{affine_map, Block6};
use crate::homogenize::BlockSparse;
use crate::packing::{Packing, PeriodicCell};
use crate::tensor::{to_fourth_order, Stiffness6, Tensor4, Voigt6};
use crate::{Error, Mat3, Result, Vec3};
use rayon::prelude::*;

/// Particles per parallel work item of [`ManyBody::evaluate_into`] (fixed: the same bits on
/// any number of threads).
const PARTICLE_CHUNK: usize = 256;
/// Bonds per parallel work item of [`ManyBody::evaluate_into`].
const BOND_CHUNK: usize = 1024;

/// The many-body term of one bonded packing (structure of arrays; see the module docs).
#[derive(Clone, Debug)]
pub struct ManyBody {
    /// The table of tensors D (lab-frame Voigt and fourth order): one for a single crystal,
    /// one per grain of a polycrystal (docs/polycrystal.md "Copper polycrystal").
    d6: Vec<Stiffness6>,
    d4: Vec<Tensor4>,
    /// Per particle, its entry of the table; empty when the table has one tensor (the single
    /// crystal's path, unchanged).
    phase: Vec<u32>,
    measure: StrainMeasure,
    cell: Option<PeriodicCell>,
    volume: f64,
    bond_i: Vec<u32>,
    bond_j: Vec<u32>,
    image: Vec<[i32; 3]>,
    reference: Vec<Vec3>,
    particle_volume: Vec<f64>,
    included: Vec<bool>,
    /// Per particle (CSR, n + 1 offsets): its bonds in bond order and a_b = A_p⁻¹ L_b
    /// (zero for an excluded particle).
    inc_start: Vec<usize>,
    inc_bond: Vec<u32>,
    inc_coef: Vec<Vec3>,
    /// Per included particle (CSR): the particles its F_p depends on and their
    /// coefficients, ∂F_p/∂x_n = I ⊗ c_n (p itself first; Σ_n c_n = 0).
    sten_start: Vec<usize>,
    sten_node: Vec<u32>,
    sten_coef: Vec<Vec3>,
    excluded: Vec<u32>,
    /// Per bond, its fit coefficients a_b at its i end and at its j end (copies of
    /// `inc_coef`, laid out by bond so that the per-bond pass of `evaluate` and
    /// `evaluate_into` reads them in sequence).
    bond_coef: Vec<[Vec3; 2]>,
}

/// The fit as the integrator reads it ([`ManyBody::fit_layout`]).
pub(crate) struct FitLayout<'a> {
    /// Per particle, its first entry (n + 1 offsets).
    pub(crate) start: &'a [usize],
    /// Per entry, the bond (in bond order per particle).
    pub(crate) bond: &'a [u32],
    /// Per entry, a_b = A_p⁻¹ L_b (zero for an excluded particle).
    pub(crate) coef: &'a [Vec3],
    /// Per bond, its coefficients at its i and j ends.
    pub(crate) bond_coef: &'a [[Vec3; 2]],
}

/// Caller-owned buffers of [`ManyBody::evaluate_into`] (structure of arrays, one entry per
/// particle): what a time-stepping caller reuses every step instead of allocating.
#[derive(Clone, Debug, Default)]
pub struct Workspace {
    /// V_p·W_p (J; 0 for an excluded particle).
    pub energy: Vec<f64>,
    /// V_p·P_p, P_p = ∂W/∂F the first Piola stress of particle p (N·m).
    pub piola: Vec<Mat3>,
    /// g_b = ∂U/∂l_b per bond (N): the force on its i end.
    pub gradient: Vec<Vec3>,
    /// −∂U/∂x_p (N); filled by [`ManyBody::evaluate_into`], not by
    /// [`ManyBody::gradients_into`].
    pub force: Vec<Vec3>,
    /// l_b per bond at the last evaluation (m).
    pub branch: Vec<Vec3>,
}

impl Workspace {
    /// U = Σ_p V_p W_p (J), summed in particle order (the same bits as
    /// [`Evaluation::energy`]).
    pub fn energy(&self) -> f64 {
        self.energy.iter().sum()
    }
}

/// The term at one state: energy, forces and nominal stress.
#[derive(Clone, Debug, PartialEq)]
pub struct Evaluation {
    /// U = Σ_p ½ V_p E_p : D : E_p (J).
    pub energy: f64,
    /// −∂U/∂x_p for every particle (N).
    pub forces: Vec<Vec3>,
    /// Nominal stress (1/V)·∂U/∂H = (1/V)·Σ_b g_b ⊗ L_b (Pa): the derivative of the energy with
    /// respect to the cell's deformation gradient H (l_b = x_j − x_i + H·shift_b), particles
    /// moving with it. Under a uniform small strain ε it is (Σ_p V_p / V)·D:ε.
    pub stress: Mat3,
}

impl ManyBody {
    /// The term of `bonds` on `packing` (the reference state: strain zero) loading `tensor`.
    /// Refuses ([`Error::Degenerate`], naming the particle) a particle with fewer than three
    /// bonds or bonds (nearly) in one plane unless `options.degenerate` excludes them;
    /// ([`Error::Invalid`]) volumes of the wrong count or not finite ≥ 0, bonds naming
    /// particles not in the packing, default volumes without a fully periodic cell.
    pub fn new(
        packing: &Packing,
        bonds: &BondSet,
        tensor: &LocalTensor,
        options: &ManyBodyOptions,
    ) -> Result<ManyBody> {
        let d6 = tensor.voigt()?;
        ManyBody::per_particle(packing, bonds, vec![d6], Vec::new(), options)
    }

    /// [`ManyBody::new`] with a tensor per particle: particle p loads `tensors[phase[p]]`
    /// (lab-frame Voigt matrices, Pa), e.g. its grain's D turned into the grain
    /// (`ManyBodySpec::build_with_grains`). `phase` may be empty when `tensors` has one
    /// entry. Refuses ([`Error::Invalid`]) an empty table, a tensor that is not finite and
    /// symmetric, a `phase` of the wrong length or naming no tensor.
    pub fn per_particle(
        packing: &Packing,
        bonds: &BondSet,
        tensors: Vec<Stiffness6>,
        phase: Vec<u32>,
        options: &ManyBodyOptions,
    ) -> Result<ManyBody> {
        let n = packing.len();
        if tensors.is_empty() {
            return Err(Error::Invalid(
                "many-body term: no tensor D given (expected one, or one per phase)".into(),
            ));
        }
        for (t, d) in tensors.iter().enumerate() {
            let scale = d.amax();
            if !(scale.is_finite() && (d - d.transpose()).amax() <= 1e-12 * scale) {
                return Err(Error::Invalid(format!(
                    "many-body term: tensor {t} is not finite and symmetric (an energy's tensor is)"
                )));
            }
        }
        if !(phase.is_empty() && tensors.len() == 1) && phase.len() != n {
            return Err(Error::Invalid(format!(
                "many-body term: {} tensor indices for {n} particles",
                phase.len()
            )));
        }
        if let Some(p) = phase.iter().position(|&t| t as usize >= tensors.len()) {
            return Err(Error::Invalid(format!(
                "many-body term: particle {p} names tensor {}, but there are {}",
                phase[p],
                tensors.len()
            )));
        }
        // One tensor: every particle's, without an index (the single crystal's path).
        let phase = if tensors.len() == 1 {
            Vec::new()
        } else {
            phase
        };
        if let Some(b) =
            (0..bonds.len()).find(|&b| bonds.i[b] as usize >= n || bonds.j[b] as usize >= n)
        {
            return Err(Error::Invalid(format!(
                "many-body term: bond {b} joins particles {} and {}, but the packing has {n}",
                bonds.i[b], bonds.j[b]
            )));
        }
        if let Some(b) = (0..bonds.len()).find(|&b| {
            bonds.image[b]
                .iter()
                .enumerate()
                .any(|(k, &m)| m != 0 && !packing.cell.is_some_and(|c| c.periodic[k]))
        }) {
            return Err(Error::Invalid(format!(
                "many-body term: bond {b} has periodic image {:?} along an axis the packing's box \
                 is not periodic on",
                bonds.image[b]
            )));
        }
        if !(options.conditioning >= 0.0 && options.conditioning < 1.0) {
            return Err(Error::Invalid(format!(
                "many-body term: conditioning {} must lie in [0, 1) (λ_min/λ_max of A_p)",
                options.conditioning
            )));
        }
        let particle_volume = particle_volumes(packing, options.volumes.as_deref())?;
        let reference: Vec<Vec3> = (0..bonds.len()).map(|b| bonds.branch(b)).collect();

        // Incidence lists, in bond order.
        let mut inc_start = vec![0usize; n + 1];
        for (&i, &j) in bonds.i.iter().zip(&bonds.j) {
            inc_start[i as usize + 1] += 1;
            inc_start[j as usize + 1] += 1;
        }
        for p in 0..n {
            inc_start[p + 1] += inc_start[p];
        }
        let mut fill = inc_start.clone();
        let mut inc_bond = vec![0u32; inc_start[n]];
        let mut bond_inc = vec![[0u32; 2]; bonds.len()];
        for (b, slots) in bond_inc.iter_mut().enumerate() {
            for (end, p) in [bonds.i[b], bonds.j[b]].into_iter().enumerate() {
                let k = fill[p as usize];
                inc_bond[k] = b as u32;
                slots[end] = k as u32;
                fill[p as usize] += 1;
            }
        }

        // A_p⁻¹ of every particle, or why it has none.
        let fits: Vec<std::result::Result<Mat3, String>> = (0..n)
            .into_par_iter()
            .map(|p| {
                let own = &inc_bond[inc_start[p]..inc_start[p + 1]];
                fit_inverse(
                    own.iter().map(|&b| reference[b as usize]),
                    options.conditioning,
                )
            })
            .collect();
        let mut included = vec![true; n];
        let mut excluded = Vec::new();
        for (p, fit) in fits.iter().enumerate() {
            if let Err(why) = fit {
                if options.degenerate == DegenerateParticles::Refuse {
                    return Err(Error::Degenerate(format!(
                        "many-body term: particle {p} {why}; its local strain needs at least \
                         three bonds not in one plane (exclude such particles with \
                         DegenerateParticles::Exclude, or bond the packing more densely)"
                    )));
                }
                included[p] = false;
                excluded.push(p as u32);
            }
        }
        let mut particle_volume = particle_volume;
        for &p in &excluded {
            particle_volume[p as usize] = 0.0;
        }
        let mut inc_coef = vec![Vec3::zeros(); inc_bond.len()];
        for p in 0..n {
            if let Ok(ainv) = &fits[p] {
                for k in inc_start[p]..inc_start[p + 1] {
                    inc_coef[k] = ainv * reference[inc_bond[k] as usize];
                }
            }
        }

        // Node stencils: coefficient −a_b at i_b, +a_b at j_b, merged per node.
        let mut sten_start = vec![0usize];
        let mut sten_node = Vec::new();
        let mut sten_coef = Vec::new();
        for p in 0..n {
            if included[p] {
                let mut nodes: Vec<(u32, Vec3)> = vec![(p as u32, Vec3::zeros())];
                for k in inc_start[p]..inc_start[p + 1] {
                    let b = inc_bond[k] as usize;
                    let a = inc_coef[k];
                    for (q, c) in [(bonds.i[b], -a), (bonds.j[b], a)] {
                        match nodes.iter_mut().find(|(m, _)| *m == q) {
                            Some(entry) => entry.1 += c,
                            None => nodes.push((q, c)),
                        }
                    }
                }
                for (q, c) in nodes {
                    sten_node.push(q);
                    sten_coef.push(c);
                }
            }
            sten_start.push(sten_node.len());
        }

        let bond_coef = bond_inc
            .iter()
            .map(|&[ki, kj]| [inc_coef[ki as usize], inc_coef[kj as usize]])
            .collect();

        Ok(ManyBody {
            d4: tensors.iter().map(to_fourth_order).collect(),
            d6: tensors,
            phase,
            measure: options.measure,
            cell: packing.cell,
            volume: packing.volume(),
            bond_i: bonds.i.clone(),
            bond_j: bonds.j.clone(),
            image: bonds.image.clone(),
            reference,
            particle_volume,
            included,
            inc_start,
            inc_bond,
            inc_coef,
            sten_start,
            sten_node,
            sten_coef,
            excluded,
            bond_coef,
        })
    }

    /// The lab-frame Voigt matrix of D (Pa) of a term with one tensor. Refuses
    /// ([`Error::Model`]) a term with a tensor per grain (what reads one D, an engine's
    /// table, cannot carry it): see [`tensors`](Self::tensors).
    pub fn tensor(&self) -> Result<&Stiffness6> {
        match self.d6.as_slice() {
            [d] => Ok(d),
            many => Err(Error::Model(format!(
                "many-body term: it has {} tensors D (one per grain of a polycrystal), not one",
                many.len()
            ))),
        }
    }

    /// The table of lab-frame tensors D (Pa): one, or one per grain.
    pub fn tensors(&self) -> &[Stiffness6] {
        &self.d6
    }

    /// The entry of [`tensors`](Self::tensors) particle `p` loads.
    #[inline(always)]
    pub fn tensor_index(&self, p: usize) -> usize {
        if self.phase.is_empty() {
            0
        } else {
            self.phase[p] as usize
        }
    }

    /// D of particle `p` (lab frame, Pa).
    #[inline(always)]
    pub fn tensor_of(&self, p: usize) -> &Stiffness6 {
        &self.d6[self.tensor_index(p)]
    }

    /// The strain measure.
    pub fn measure(&self) -> StrainMeasure {
        self.measure
    }

    /// Number of particles.
    pub fn len(&self) -> usize {
        self.included.len()
    }

    /// True for a term of no particles.
    pub fn is_empty(&self) -> bool {
        self.included.is_empty()
    }

    /// V_p of every particle (m³; 0 for an excluded one).
    pub fn particle_volumes(&self) -> &[f64] {
        &self.particle_volume
    }

    /// The particles left out of the term ([`DegenerateParticles::Exclude`]), ascending.
    pub fn excluded(&self) -> &[u32] {
        &self.excluded
    }

    /// Σ_p V_p / V: the share of D the term adds under a uniform strain.
    pub fn volume_fraction(&self) -> f64 {
        self.particle_volume.iter().sum::<f64>() / self.volume
    }

    /// The closed form of the term's Voigt-level tensor, (Σ_p V_p / V)·D (Pa): the uniform
    /// strain gives F_p = F for every particle. With a tensor per grain, Σ_p V_p D_p / V, the
    /// volume-weighted average of the grains' D (summed per tensor in particle order).
    pub fn closed_form_tensor(&self) -> Stiffness6 {
        if self.d6.len() == 1 {
            return self.d6[0] * self.volume_fraction();
        }
        let mut share = vec![0.0; self.d6.len()];
        for (p, v) in self.particle_volume.iter().enumerate() {
            share[self.tensor_index(p)] += v;
        }
        self.d6
            .iter()
            .zip(&share)
            .fold(Stiffness6::zeros(), |acc, (d, v)| {
                acc + d * (v / self.volume)
            })
    }

    /// Current branch vectors l_b = x_j − x_i + H·(image ∘ L) of positions `positions` (not
    /// re-wrapped since the reference) in the cell deformed by the gradient `cell_gradient` H
    /// (identity: the reference cell).
    pub fn branch_vectors(&self, positions: &[Vec3], cell_gradient: &Mat3) -> Result<Vec<Vec3>> {
        if positions.len() != self.len() {
            return Err(Error::Invalid(format!(
                "many-body term: {} positions for {} particles",
                positions.len(),
                self.len()
            )));
        }
        Ok((0..self.reference.len())
            .map(|b| {
                let d = positions[self.bond_j[b] as usize] - positions[self.bond_i[b] as usize];
                match &self.cell {
                    Some(cell) => d + cell_gradient * cell.shift(self.image[b]),
                    None => d,
                }
            })
            .collect())
    }

    /// Particle `p`'s stencil: the particles its F_p depends on and their coefficients c_n,
    /// ∂F_p/∂x_n = I ⊗ c_n (p first; empty for an excluded particle). With
    /// [`particle_volumes`](Self::particle_volumes) and [`tensor`](Self::tensor) it gives the
    /// reference-state Hessian in factored form, Σ_p V_p B_pᵀ D B_p (the relaxed solve's CG).
    pub fn stencil(&self, p: usize) -> (&[u32], &[Vec3]) {
        let span = self.sten_start[p]..self.sten_start[p + 1];
        (&self.sten_node[span.clone()], &self.sten_coef[span])
    }

    /// The reference branch vectors L_b (m).
    pub fn reference_branches(&self) -> &[Vec3] {
        &self.reference
    }

    /// The fitted F_p of every particle at branch vectors `branch` (identity for an excluded
    /// particle).
    pub fn deformation_gradients(&self, branch: &[Vec3]) -> Result<Vec<Mat3>> {
        self.check_branch(branch)?;
        Ok((0..self.len())
            .into_par_iter()
            .map(|p| self.gradient_of(p, branch))
            .collect())
    }

    /// Energy U (J) at branch vectors `branch`.
    pub fn energy(&self, branch: &[Vec3]) -> Result<f64> {
        self.check_branch(branch)?;
        let w: Vec<f64> = (0..self.len())
            .into_par_iter()
            .map(|p| {
                if self.included[p] {
                    self.energy_piola(p, &self.fit(p, branch), self.particle_volume[p])
                        .0
                } else {
                    0.0
                }
            })
            .collect();
        Ok(w.iter().sum())
    }

    /// A workspace for [`evaluate_into`](Self::evaluate_into), sized for this term.
    pub fn workspace(&self) -> Workspace {
        let n = self.len();
        Workspace {
            energy: vec![0.0; n],
            piola: vec![Mat3::zeros(); n],
            gradient: vec![Vec3::zeros(); self.reference.len()],
            force: vec![Vec3::zeros(); n],
            branch: vec![Vec3::zeros(); self.reference.len()],
        }
    }

    /// [`evaluate`](Self::evaluate) into the caller's buffers, allocating nothing: per
    /// bond l_b and g_b, per particle V_p·W_p, V_p·P_p and the forces (the same operations in
    /// the same order as `evaluate`, so the same bits; the energy and stress follow from the
    /// workspace by [`Workspace::energy`] and [`bond_gradient`](Self::bond_gradient)).
    /// `branch(b)` gives the current branch vector of bond b (the caller's bookkeeping of
    /// images and cell); it is not checked here. Parallel passes over fixed chunks, each
    /// entry written by one item: the same bits on any number of threads.
    pub fn evaluate_into(&self, branch: impl Fn(usize) -> Vec3 + Sync, ws: &mut Workspace) {
        self.gradients_into(branch, ws);
        ws.force.resize(self.len(), Vec3::zeros());
        let gradient = &ws.gradient;
        ws.force
            .par_chunks_mut(PARTICLE_CHUNK)
            .enumerate()
            .for_each(|(c, out)| {
                for (l, fo) in out.iter_mut().enumerate() {
                    *fo = self.force_on(c * PARTICLE_CHUNK + l, gradient);
                }
            });
    }

    /// [`evaluate_into`](Self::evaluate_into) without its last pass, the per-particle forces
    /// (`ws.force` is left as it was): for a caller that gathers f_p = Σ_b ±g_b itself, as
    /// the integrator does in its particle update (+g_b at i_b, −g_b at j_b). Three passes:
    /// l_b per bond, F_p → V_p·W_p and V_p·P_p per particle, g_b per bond.
    pub fn gradients_into(&self, branch: impl Fn(usize) -> Vec3 + Sync, ws: &mut Workspace) {
        let n = self.len();
        let nb = self.reference.len();
        ws.energy.resize(n, 0.0);
        ws.piola.resize(n, Mat3::zeros());
        ws.gradient.resize(nb, Vec3::zeros());
        ws.branch.resize(nb, Vec3::zeros());
        ws.branch
            .par_chunks_mut(BOND_CHUNK)
            .enumerate()
            .for_each(|(c, out)| {
                for (l, o) in out.iter_mut().enumerate() {
                    *o = branch(c * BOND_CHUNK + l);
                }
            });
        let br = &ws.branch;
        ws.energy
            .par_chunks_mut(PARTICLE_CHUNK)
            .zip(ws.piola.par_chunks_mut(PARTICLE_CHUNK))
            .enumerate()
            .for_each(|(c, (we, wp))| self.particle_pass(c * PARTICLE_CHUNK, br, we, wp));
        let piola = &ws.piola;
        ws.gradient
            .par_chunks_mut(BOND_CHUNK)
            .enumerate()
            .for_each(|(c, out)| {
                for (l, g) in out.iter_mut().enumerate() {
                    *g = self.gradient_in(c * BOND_CHUNK + l, piola);
                }
            });
    }

    /// f_p = −∂U/∂x_p = Σ_b (+g_b at i_b, −g_b at j_b), in the particle's bond order.
    #[inline(always)]
    fn force_on(&self, p: usize, gradient: &[Vec3]) -> Vec3 {
        let mut f = Vec3::zeros();
        for &b in &self.inc_bond[self.inc_start[p]..self.inc_start[p + 1]] {
            let b = b as usize;
            if self.bond_i[b] as usize == p {
                f += gradient[b];
            } else {
                f -= gradient[b];
            }
        }
        f
    }

    /// F_p = Σ_b l_b ⊗ a_b of an included particle, written out entry by entry (the
    /// arithmetic of `evaluate`, `energy` and `evaluate_into`).
    #[inline(always)]
    fn fit(&self, p: usize, branch: &[Vec3]) -> Mat3 {
        let span = self.inc_start[p]..self.inc_start[p + 1];
        let mut f = [0.0f64; 9];
        for (&b, a) in self.inc_bond[span.clone()].iter().zip(&self.inc_coef[span]) {
            let l = branch[b as usize];
            for c in 0..3 {
                for r in 0..3 {
                    f[r + 3 * c] += l[r] * a[c];
                }
            }
        }
        Mat3::from_column_slice(&f)
    }

    /// (V·W, V·P) of particle `p` (its D) of volume `v` at gradient F: energy density
    /// W = ½ E:D:E and
    /// first Piola stress P = ∂W/∂F (F·S for Green–Lagrange, S for the small strain): the one
    /// lane of [`energy_piola_lanes`], the arithmetic `evaluate`, `energy` and
    /// `evaluate_into` share.
    #[inline(always)]
    fn energy_piola(&self, p: usize, f: &Mat3, v: f64) -> (f64, Mat3) {
        let lanes: [[f64; 1]; 9] = std::array::from_fn(|k| [f[k]]);
        let (e, pk) = energy_piola_lanes::<1>(self.tensor_of(p), self.measure, &lanes, &[v]);
        (e[0], Mat3::from_fn(|r, c| pk[r + 3 * c][0]))
    }

    /// Pass 2 of [`gradients_into`](Self::gradients_into) on one chunk of particles from
    /// `base`: V_p·W_p into `we`, V_p·P_p into `wp`. Where AVX2 runs, the fitted F of four
    /// included particles at a time go through [`energy_piola_avx2`] (the same operations
    /// as the one-lane [`energy_piola`](Self::energy_piola), so the same bits); the rest one
    /// by one. With a tensor per grain every particle goes one by one (the lanes share one D;
    /// the bits are the same either way).
    #[allow(clippy::needless_range_loop)] // `l` indexes both outputs and names the slot
    fn particle_pass(&self, base: usize, br: &[Vec3], we: &mut [f64], wp: &mut [Mat3]) {
        #[cfg(target_arch = "x86_64")]
        let lanes = self.d6.len() == 1 && std::arch::is_x86_feature_detected!("avx2");
        #[cfg(not(target_arch = "x86_64"))]
        let lanes = false;
        let mut four = Lanes4::default();
        for l in 0..we.len() {
            let p = base + l;
            if !self.included[p] {
                (we[l], wp[l]) = (0.0, Mat3::zeros());
                continue;
            }
            let f = self.fit(p, br);
            if !lanes {
                (we[l], wp[l]) = self.energy_piola(p, &f, self.particle_volume[p]);
                continue;
            }
            if four.push(l, &f, self.particle_volume[p]) {
                #[cfg(target_arch = "x86_64")]
                {
                    // SAFETY: AVX2 is available (checked above).
                    unsafe { self.lanes4_avx2(&mut four, |at, e, pk| (we[at], wp[at]) = (e, pk)) };
                }
            }
        }
        self.lanes_one_by_one(&mut four, base, |at, e, pk| (we[at], wp[at]) = (e, pk));
    }

    /// (V·W, V·P) of the four particles gathered in `four` (full) through the AVX2 lanes
    /// ([`energy_piola_avx2`], the one-lane bits), for a term with one tensor D: `put(slot,
    /// V·W, V·P)` lane by lane; `four` emptied.
    ///
    /// # Safety
    /// The CPU must have AVX2.
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    pub(crate) unsafe fn lanes4_avx2(
        &self,
        four: &mut Lanes4,
        mut put: impl FnMut(usize, f64, Mat3),
    ) {
        debug_assert!(four.filled == 4 && self.d6.len() == 1);
        // SAFETY: the caller guarantees AVX2.
        let (e, pk) = unsafe { energy_piola_avx2(&self.d6[0], self.measure, &four.f, &four.v) };
        for (m, &at) in four.slot.iter().enumerate() {
            put(at, e[m], Mat3::from_fn(|r, c| pk[r + 3 * c][m]));
        }
        four.filled = 0;
    }

    /// [`lanes4_avx2`](Self::lanes4_avx2) handing the four particles' V·P as the lanes hold
    /// it: `put(slots, V·W, pk)` once, with lane m's entry (r, c) of V·P at `pk[r + 3c][m]`
    /// (no matrix built per particle); `four` emptied.
    ///
    /// # Safety
    /// The CPU must have AVX2.
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    pub(crate) unsafe fn lanes4_avx2_in_lanes(
        &self,
        four: &mut Lanes4,
        put: impl FnOnce(&[usize; 4], &[f64; 4], &[[f64; 4]; 9]),
    ) {
        debug_assert!(four.filled == 4 && self.d6.len() == 1);
        // SAFETY: the caller guarantees AVX2.
        let (e, pk) = unsafe { energy_piola_avx2(&self.d6[0], self.measure, &four.f, &four.v) };
        put(&four.slot, &e, &pk);
        four.filled = 0;
    }

    /// (V·W, V·P) of the particles left in `four` (fewer than four), one lane at a time
    /// ([`energy_piola`](Self::energy_piola); particle `base` + slot): `put(slot, V·W, V·P)`;
    /// `four` emptied.
    #[inline(always)]
    pub(crate) fn lanes_one_by_one(
        &self,
        four: &mut Lanes4,
        base: usize,
        mut put: impl FnMut(usize, f64, Mat3),
    ) {
        for m in 0..four.filled {
            let f = Mat3::from_fn(|r, c| four.f[r + 3 * c][m]);
            let at = four.slot[m];
            let (e, pk) = self.energy_piola(base + at, &f, four.v[m]);
            put(at, e, pk);
        }
        four.filled = 0;
    }

    /// g_b = ∂U/∂l_b (N) of bond `b` from a workspace filled by
    /// [`evaluate_into`](Self::evaluate_into): the force on the bond's i end (−g_b on its j
    /// end), as `evaluate` computes it.
    pub fn bond_gradient(&self, b: usize, ws: &Workspace) -> Vec3 {
        ws.gradient[b]
    }

    /// g_b = (V_i P_i) a_b^i + (V_j P_j) a_b^j, written out (the arithmetic `evaluate` and
    /// `evaluate_into` share).
    #[inline(always)]
    fn gradient_in(&self, b: usize, piola: &[Mat3]) -> Vec3 {
        let [ai, aj] = &self.bond_coef[b];
        let (mi, mj) = (
            &piola[self.bond_i[b] as usize],
            &piola[self.bond_j[b] as usize],
        );
        Vec3::from_fn(|r, _| {
            (mi[(r, 0)] * ai[0] + mi[(r, 1)] * ai[1] + mi[(r, 2)] * ai[2])
                + (mj[(r, 0)] * aj[0] + mj[(r, 1)] * aj[1] + mj[(r, 2)] * aj[2])
        })
    }

    /// The fit as the integrator reads it (`dem::manybody`): per particle (CSR, n + 1
    /// offsets) its bonds in bond order and their coefficients a_b (zero for an excluded
    /// particle), and per bond its coefficients at its i and j ends.
    pub(crate) fn fit_layout(&self) -> FitLayout<'_> {
        FitLayout {
            start: &self.inc_start,
            bond: &self.inc_bond,
            coef: &self.inc_coef,
            bond_coef: &self.bond_coef,
        }
    }

    /// Whether particle `p` is in the term (not excluded as degenerate).
    #[inline(always)]
    pub(crate) fn is_included(&self, p: usize) -> bool {
        self.included[p]
    }

    /// (V·W, V·P) of particle `p` of volume `v` at gradient `f`: the one-lane arithmetic of
    /// `evaluate` and `gradients_into`, for the integrator's own passes.
    #[inline(always)]
    pub(crate) fn energy_piola_of(&self, p: usize, f: &Mat3, v: f64) -> (f64, Mat3) {
        self.energy_piola(p, f, v)
    }

    /// Number of bonds.
    pub fn bond_count(&self) -> usize {
        self.reference.len()
    }

    /// Bond `b`'s particles and the periodic image of its j end.
    pub fn bond(&self, b: usize) -> (u32, u32, [i32; 3]) {
        (self.bond_i[b], self.bond_j[b], self.image[b])
    }

    /// Energy, forces and nominal stress at branch vectors `branch` (one per bond, in the
    /// bond order of the reference). Summed in a fixed order: the same bits on any number of
    /// threads.
    pub fn evaluate(&self, branch: &[Vec3]) -> Result<Evaluation> {
        self.check_branch(branch)?;
        let n = self.len();
        // Pass 1: V_p·W_p and V_p·P_p.
        let per_particle: Vec<(f64, Mat3)> = (0..n)
            .into_par_iter()
            .map(|p| {
                if !self.included[p] {
                    return (0.0, Mat3::zeros());
                }
                self.energy_piola(p, &self.fit(p, branch), self.particle_volume[p])
            })
            .collect();
        let piola: Vec<Mat3> = per_particle.iter().map(|e| e.1).collect();
        // Pass 2: g_b = ∂U/∂l_b.
        let g: Vec<Vec3> = (0..self.reference.len())
            .into_par_iter()
            .map(|b| self.gradient_in(b, &piola))
            .collect();
        // Pass 3: f_p = −∂U/∂x_p = Σ_b (+g_b at i_b, −g_b at j_b).
        let forces: Vec<Vec3> = (0..n)
            .into_par_iter()
            .map(|p| self.force_on(p, &g))
            .collect();
        let energy = per_particle.iter().map(|e| e.0).sum();
        let mut stress = Mat3::zeros();
        for (gb, lb) in g.iter().zip(&self.reference) {
            stress += gb * lb.transpose();
        }
        Ok(Evaluation {
            energy,
            forces,
            stress: stress / self.volume,
        })
    }

    /// Per particle, its fitted F_p and S_p = D:E_p at `branch` (identity and zero for an
    /// excluded particle): the state the Hessian and the load are linearised about.
    fn particle_states(&self, branch: &[Vec3]) -> Vec<(Mat3, Mat3)> {
        (0..self.len())
            .into_par_iter()
            .map(|p| {
                if !self.included[p] {
                    return (Mat3::identity(), Mat3::zeros());
                }
                let f = self.gradient_of(p, branch);
                (f, self.particle_state(p, &f).2)
            })
            .collect()
    }

    /// The particles whose stencil can hold particle `r`: r itself and its bonded
    /// neighbours, sorted, each once (the fixed order the Hessian and load rows sum in).
    fn stencil_owners(&self, r: usize) -> Vec<u32> {
        let mut owners: Vec<u32> = vec![r as u32];
        for k in self.inc_start[r]..self.inc_start[r + 1] {
            let b = self.inc_bond[k] as usize;
            owners.push(self.bond_i[b] + self.bond_j[b] - r as u32);
        }
        owners.sort_unstable();
        owners.dedup();
        owners
    }

    /// The included particles whose stencil holds particle `r`, in
    /// [`stencil_owners`](Self::stencil_owners)' order, each with r's coefficient a_r in
    /// that stencil: the terms of row r of the Hessian and of the load.
    fn owners_holding(&self, r: usize) -> impl Iterator<Item = (usize, Vec3)> + '_ {
        self.stencil_owners(r).into_iter().filter_map(move |p| {
            let p = p as usize;
            if !self.included[p] {
                return None;
            }
            let span = self.sten_start[p]..self.sten_start[p + 1];
            let kr = span.clone().find(|&k| self.sten_node[k] as usize == r)?;
            Some((p, self.sten_coef[kr]))
        })
    }

    /// The Hessian ∂²U/∂x∂x (N/m) at branch vectors `branch`, over every particle, in 6×6
    /// blocks of the relaxed solver's DOFs (translation first; the rotation rows are zero):
    /// particles sharing a bonded neighbour are coupled. Each block row is summed in a fixed
    /// order (the same bits on any number of threads).
    pub fn hessian(&self, branch: &[Vec3]) -> Result<BlockSparse> {
        self.check_branch(branch)?;
        let n = self.len();
        let states = self.particle_states(branch);
        let rows: Vec<Vec<(u32, Block6)>> = (0..n)
            .into_par_iter()
            .map(|r| {
                let mut entries: Vec<(u32, Mat3)> = Vec::new();
                for (p, cr) in self.owners_holding(r) {
                    let (f, s) = &states[p];
                    for k in self.sten_start[p]..self.sten_start[p + 1] {
                        let blk = self.pair_block(p, &cr, &self.sten_coef[k], f, s)
                            * self.particle_volume[p];
                        entries.push((self.sten_node[k], blk));
                    }
                }
                entries.sort_by_key(|e| e.0); // stable: sums in a fixed order
                let mut row: Vec<(u32, Block6)> = Vec::new();
                for (c, blk) in entries {
                    if row.last().map(|e| e.0) != Some(c) {
                        row.push((c, Block6::zeros()));
                    }
                    let mut v = row.last_mut().unwrap().1.fixed_view_mut::<3, 3>(0, 0);
                    v += blk;
                }
                row
            })
            .collect();
        Ok(BlockSparse::from_rows(rows))
    }

    /// The load G_r = ∂²U/∂x_r∂e (N per unit engineering strain; 6×6 blocks of the relaxed
    /// solver: translation rows, strain columns, rotation rows zero) at branch vectors
    /// `branch`, for a uniform strain increment δl_b = δε·L_b: with the Hessian and
    /// [`affine_tensor`](Self::affine_tensor) it is the term's share of the relaxed solve's
    /// [[K, G], [Gᵀ, H]] (Kruyt 2014 Eqs. 10–14). Zero on a centro-symmetric lattice.
    pub fn load(&self, branch: &[Vec3]) -> Result<Vec<Block6>> {
        self.check_branch(branch)?;
        let n = self.len();
        let states = self.particle_states(branch);
        Ok((0..n)
            .into_par_iter()
            .map(|r| {
                let mut g = nalgebra::Matrix3x6::<f64>::zeros();
                for (p, cr) in self.owners_holding(r) {
                    let (f, s) = &states[p];
                    for k in self.inc_start[p]..self.inc_start[p + 1] {
                        let mb = affine_map(&self.reference[self.inc_bond[k] as usize]);
                        g += self.pair_block(p, &cr, &self.inc_coef[k], f, s)
                            * mb
                            * self.particle_volume[p];
                    }
                }
                let mut blk = Block6::zeros();
                blk.fixed_view_mut::<3, 6>(0, 0).copy_from(&g);
                blk
            })
            .collect())
    }

    /// The term's tensor (Pa) under a uniform strain increment δl_b = δε·L_b from the state
    /// `branch`, summed from the Hessian blocks in bond space, (1/V)·Σ_p Σ_{b,c ∈ p}
    /// M_bᵀ K^p_bc M_c with M_b the affine map of L_b: the Voigt-level (affine) part the
    /// relaxed tensor starts from. At the reference state it equals
    /// [`closed_form_tensor`](Self::closed_form_tensor) by the fit's construction.
    pub fn affine_tensor(&self, branch: &[Vec3]) -> Result<Stiffness6> {
        self.check_branch(branch)?;
        let parts: Vec<Stiffness6> = (0..self.len())
            .into_par_iter()
            .map(|p| {
                let mut acc = Stiffness6::zeros();
                if !self.included[p] {
                    return acc;
                }
                let f = self.gradient_of(p, branch);
                let s = self.particle_state(p, &f).2;
                let span = self.inc_start[p]..self.inc_start[p + 1];
                for kb in span.clone() {
                    let mb = affine_map(&self.reference[self.inc_bond[kb] as usize]);
                    for kc in span.clone() {
                        let mc = affine_map(&self.reference[self.inc_bond[kc] as usize]);
                        let blk =
                            self.pair_block(p, &self.inc_coef[kb], &self.inc_coef[kc], &f, &s);
                        acc += mb.transpose() * blk * mc;
                    }
                }
                acc * self.particle_volume[p]
            })
            .collect();
        Ok(parts.iter().fold(Stiffness6::zeros(), |a, b| a + b) / self.volume)
    }

    /// ∂²W/∂F∂F contracted with coefficient vectors u (row) and v (column), per unit
    /// volume: (u·S v) I + F B(u, v) Fᵀ for Green–Lagrange, B(u, v) for small strain, with
    /// B(u, v)_ac = Σ_jl u_j D_ajcl v_l (D of particle `p`).
    fn pair_block(&self, p: usize, u: &Vec3, v: &Vec3, f: &Mat3, s: &Mat3) -> Mat3 {
        let d4 = &self.d4[self.tensor_index(p)];
        let mut bm = Mat3::zeros();
        for a in 0..3 {
            for c in 0..3 {
                let mut acc = 0.0;
                for j in 0..3 {
                    for l in 0..3 {
                        acc += u[j] * d4[a][j][c][l] * v[l];
                    }
                }
                bm[(a, c)] = acc;
            }
        }
        match self.measure {
            StrainMeasure::Small => bm,
            StrainMeasure::GreenLagrange => {
                Mat3::identity() * u.dot(&(s * v)) + f * bm * f.transpose()
            }
        }
    }

    /// F_p = Σ_b l_b ⊗ a_b (identity for an excluded particle).
    fn gradient_of(&self, p: usize, branch: &[Vec3]) -> Mat3 {
        if !self.included[p] {
            return Mat3::identity();
        }
        let mut f = Mat3::zeros();
        for k in self.inc_start[p]..self.inc_start[p + 1] {
            f += branch[self.inc_bond[k] as usize] * self.inc_coef[k].transpose();
        }
        f
    }

    /// Energy density W, first Piola stress P = ∂W/∂F and the stress S = D:E conjugate to
    /// the measure's strain E, at gradient F (D of particle `p`).
    fn particle_state(&self, p: usize, f: &Mat3) -> (f64, Mat3, Mat3) {
        let e = match self.measure {
            StrainMeasure::Small => (f + f.transpose()) * 0.5 - Mat3::identity(),
            StrainMeasure::GreenLagrange => (f.transpose() * f - Mat3::identity()) * 0.5,
        };
        let ev = Voigt6::new(
            e[(0, 0)],
            e[(1, 1)],
            e[(2, 2)],
            2.0 * e[(1, 2)],
            2.0 * e[(0, 2)],
            2.0 * e[(0, 1)],
        );
        let sv = self.tensor_of(p) * ev;
        let s = Mat3::new(
            sv[0], sv[5], sv[4], sv[5], sv[1], sv[3], sv[4], sv[3], sv[2],
        );
        let w = 0.5 * ev.dot(&sv);
        let pk = match self.measure {
            StrainMeasure::Small => s,
            StrainMeasure::GreenLagrange => f * s,
        };
        (w, pk, s)
    }

    /// Refuse branch vectors of the wrong count or not finite.
    fn check_branch(&self, branch: &[Vec3]) -> Result<()> {
        if branch.len() != self.reference.len() {
            return Err(Error::Invalid(format!(
                "many-body term: {} branch vectors for {} bonds",
                branch.len(),
                self.reference.len()
            )));
        }
        if let Some(b) = branch.iter().position(|l| !l.iter().all(|v| v.is_finite())) {
            return Err(Error::Invalid(format!(
                "many-body term: branch vector of bond {b} is not finite"
            )));
        }
        Ok(())
    }
}

/// (V·W, V·P) of `L` particles at once (lane l: gradient entries `f[k][l]`, column-major k,
/// volume `v[l]`): W = ½ E:D:E with E the measure's strain of F, S = D:E, P = F·S
/// (Green–Lagrange) or S (small strain). Every lane performs the same IEEE operations in the
/// same order (no fused multiply–add), so any `L` gives the one-lane bits.
#[inline(always)]
#[allow(clippy::needless_range_loop)] // lane arithmetic: one index over every lane array
fn energy_piola_lanes<const L: usize>(
    d6: &Stiffness6,
    measure: StrainMeasure,
    f: &[[f64; L]; 9],
    v: &[f64; L],
) -> ([f64; L], [[f64; L]; 9]) {
    let fm = |r: usize, c: usize| &f[r + 3 * c];
    let zero = [0.0f64; L];
    // Voigt strain [e11, e22, e33, 2e23, 2e13, 2e12].
    let mut ev = [zero; 6];
    match measure {
        StrainMeasure::GreenLagrange => {
            let c = |r: usize, s: usize| {
                let (a, b, d) = (fm(0, r), fm(1, r), fm(2, r));
                let (x, y, z) = (fm(0, s), fm(1, s), fm(2, s));
                let mut out = zero;
                for l in 0..L {
                    out[l] = a[l] * x[l] + b[l] * y[l] + d[l] * z[l];
                }
                out
            };
            for (k, &(r, s2)) in [(0, 0), (1, 1), (2, 2)].iter().enumerate() {
                let cc = c(r, s2);
                for l in 0..L {
                    ev[k][l] = (cc[l] - 1.0) * 0.5;
                }
            }
            ev[3] = c(1, 2);
            ev[4] = c(0, 2);
            ev[5] = c(0, 1);
        }
        StrainMeasure::Small => {
            for k in 0..3 {
                for l in 0..L {
                    ev[k][l] = fm(k, k)[l] - 1.0;
                }
            }
            for (k, &(r, c)) in [(1, 2), (0, 2), (0, 1)].iter().enumerate() {
                for l in 0..L {
                    ev[3 + k][l] = fm(r, c)[l] + fm(c, r)[l];
                }
            }
        }
    }
    let mut sv = [zero; 6];
    for (r, out) in sv.iter_mut().enumerate() {
        for l in 0..L {
            let mut acc = d6[(r, 0)] * ev[0][l];
            for (k, e) in ev.iter().enumerate().skip(1) {
                acc += d6[(r, k)] * e[l];
            }
            out[l] = acc;
        }
    }
    let mut energy = zero;
    for l in 0..L {
        let mut w = ev[0][l] * sv[0][l];
        for k in 1..6 {
            w += ev[k][l] * sv[k][l];
        }
        energy[l] = v[l] * (0.5 * w);
    }
    // S row by row from its Voigt entries.
    let s = [[0, 5, 4], [5, 1, 3], [4, 3, 2]];
    let mut pk = [zero; 9];
    match measure {
        StrainMeasure::GreenLagrange => {
            for c in 0..3 {
                for r in 0..3 {
                    for l in 0..L {
                        pk[r + 3 * c][l] = (fm(r, 0)[l] * sv[s[0][c]][l]
                            + fm(r, 1)[l] * sv[s[1][c]][l]
                            + fm(r, 2)[l] * sv[s[2][c]][l])
                            * v[l];
                    }
                }
            }
        }
        StrainMeasure::Small => {
            for c in 0..3 {
                for r in 0..3 {
                    for l in 0..L {
                        pk[r + 3 * c][l] = sv[s[r][c]][l] * v[l];
                    }
                }
            }
        }
    }
    (energy, pk)
}

/// Up to four included particles waiting for the AVX2 lanes of a term with one D: their
/// fitted F (entry k = r + 3c, column-major, lane by lane), volumes, and slots in the
/// caller's chunk. The set-up [`ManyBody::gradients_into`]'s particle pass and the
/// integrator's (`dem::manybody`) share: [`push`](Self::push) each particle, then
/// [`ManyBody::lanes4_avx2`] when full and [`ManyBody::lanes_one_by_one`] for the rest.
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct Lanes4 {
    slot: [usize; 4],
    f: [[f64; 4]; 9],
    v: [f64; 4],
    filled: usize,
}

impl Lanes4 {
    /// The particle of slot `at`, its F and volume `v` into the next lane; true when the four
    /// lanes are full.
    #[inline(always)]
    pub(crate) fn push(&mut self, at: usize, f: &Mat3, v: f64) -> bool {
        let m = self.filled;
        self.slot[m] = at;
        for (k, lane) in self.f.iter_mut().enumerate() {
            lane[m] = f[k];
        }
        self.v[m] = v;
        self.filled += 1;
        self.filled == 4
    }

    /// [`push`](Self::push) with F given by columns: entry (r, c) is `cols[c][r]` (the
    /// fourth of each column unused).
    #[inline(always)]
    pub(crate) fn push_columns(&mut self, at: usize, cols: &[[f64; 4]; 3], v: f64) -> bool {
        let m = self.filled;
        self.slot[m] = at;
        for (c, col) in cols.iter().enumerate() {
            for (r, x) in col[..3].iter().enumerate() {
                self.f[r + 3 * c][m] = *x;
            }
        }
        self.v[m] = v;
        self.filled += 1;
        self.filled == 4
    }
}

/// [`energy_piola_lanes`] of four particles compiled for AVX2 (the same bits as one lane).
///
/// # Safety
/// The CPU must have AVX2.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn energy_piola_avx2(
    d6: &Stiffness6,
    measure: StrainMeasure,
    f: &[[f64; 4]; 9],
    v: &[f64; 4],
) -> ([f64; 4], [[f64; 4]; 9]) {
    energy_piola_lanes::<4>(d6, measure, f, v)
}

/// A_p⁻¹ of the branch vectors `ls` of one particle, or why it has none: fewer than three
/// bonds, or λ_min/λ_max of A_p = Σ L ⊗ L below `conditioning` (bonds (nearly) in one plane).
fn fit_inverse(
    ls: impl Iterator<Item = Vec3>,
    conditioning: f64,
) -> std::result::Result<Mat3, String> {
    let mut a = Mat3::zeros();
    let mut count = 0;
    for l in ls {
        a += l * l.transpose();
        count += 1;
    }
    if count < 3 {
        return Err(format!(
            "has {count} bond{}",
            if count == 1 { "" } else { "s" }
        ));
    }
    let eig = nalgebra::SymmetricEigen::new(a).eigenvalues;
    let ratio = eig.min() / eig.max();
    if !(ratio >= conditioning && ratio > 0.0) {
        return Err(format!(
            "has {count} bonds (nearly) in one plane: λ_min/λ_max of Σ L⊗L is {ratio:e}, below \
             the accepted {conditioning:e}"
        ));
    }
    a.try_inverse()
        .ok_or_else(|| format!("has {count} bonds whose Σ L⊗L cannot be inverted"))
}

/// V_p: given (count and values checked), or the fully periodic cell's volume shared in
/// proportion to r³.
fn particle_volumes(packing: &Packing, given: Option<&[f64]>) -> Result<Vec<f64>> {
    let n = packing.len();
    match given {
        Some(v) => {
            if v.len() != n {
                return Err(Error::Invalid(format!(
                    "many-body term: {} particle volumes for {n} particles",
                    v.len()
                )));
            }
            if let Some(p) = v.iter().position(|x| !(x.is_finite() && *x >= 0.0)) {
                return Err(Error::Invalid(format!(
                    "many-body term: volume of particle {p} is {}, expected a finite number ≥ 0 (m³)",
                    v[p]
                )));
            }
            Ok(v.to_vec())
        }
        None => {
            match &packing.cell {
                Some(c) if !c.is_mixed() => {}
                _ => {
                    return Err(Error::Invalid(
                        "many-body term: the particle volumes default to shares of a fully \
                         periodic cell, but this packing has none (a free cluster or a mixed \
                         box); give ManyBodyOptions::volumes"
                            .into(),
                    ))
                }
            }
            let r3: Vec<f64> = packing.radii.iter().map(|r| r * r * r).collect();
            let total: f64 = r3.iter().sum();
            let v = packing.volume();
            Ok(r3.iter().map(|x| v * x / total).collect())
        }
    }
}
