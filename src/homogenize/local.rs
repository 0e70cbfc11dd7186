//! The local fields of the relaxed solution: per particle the fluctuation, rotation, stress
//! and strain of a periodic cell under a macroscopic strain, per bond its force and moment,
//! and their statistics per label (e.g. per grain; docs/references.md "Local fields").
//!
//! The fluctuation is that of the relaxed solve ([`super::relaxed`], Kruyt 2014 Eqs. 10–14):
//! q = −Q·e. Particle p's stress is the Love–Weber average over its contacts,
//! σ_p = (1/V_p) Σ_{b∋p} r_p(b) sym(n_b ⊗ f_b) (Christoffersen, Mehrabadi & Nemat-Nasser
//! 1981; Bagi 1996), with r_p(b) the bond's contact arm on p's side: the two arms add
//! to |l_b|, so the bond's sym(l_b ⊗ f_b) is split between its two particles and
//! Σ_p V_p σ_p = Σ_b sym(l_b ⊗ f_b) = V σ exactly. V_p is the cell volume shared in proportion
//! to r_p³ (Σ_p V_p = V). Particle p's strain is the affine strain plus the symmetric part of
//! the least-squares gradient of its bonds' branch-vector fluctuations (the best-fit strain of
//! Liao, Chang, Young & Chang 1997; the same fit as the many-body term, docs/manybody.md "The
//! energy"), over its load-carrying bonds.
//!
//! With the many-body term ([`local_fields_with_term`], docs/manybody.md) the fluctuation is
//! that of the springs and the term together, and particle p's stress adds the term's own:
//! (V_p^D/V_p)·D_p:ε_p^D, with ε_p^D = sym(F_p − I) the term's fitted strain of p (its own
//! fit over all its bonds, linear in the fluctuation) and V_p^D its volume in the term. The
//! term's nominal stress is (1/V) Σ_b g_b ⊗ L_b = (1/V) Σ_p V_p^D P_p (Σ_b a_b ⊗ L_b = I), so
//! the same split gives Σ_p V_p σ_p = V σ with the term too (Hill's lemma for the particles).

use super::network::{csr, LeverArm};
use super::relaxed::{relaxed_solve_full, RelaxedOptions, RelaxedResult};
use crate::bonds::{BondSet, BondStiffness};
use crate::manybody::ManyBody;
use crate::packing::{Packing, PeriodicCell};
use crate::tensor::{strain_tensor, Voigt6, VOIGT_PAIRS};
use crate::{Error, Mat3, Result, Vec3};
use rayon::prelude::*;
use serde::Serialize;
use std::collections::BTreeMap;

/// What to do with a particle whose strain cannot be fitted: it carries no load (pruned from
/// the network, e.g. a particle without bonds), or has fewer than three load-carrying bonds,
/// or all of them (nearly) in one plane.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum DegenerateFit {
    /// Leave its strain out (`None`, named in [`LocalFields::unfitted`]); its stress (zero
    /// for a particle carrying no load) and volume still count.
    #[default]
    Exclude,
    /// Refuse ([`Error::Degenerate`] naming the first such particle).
    Refuse,
}

/// Options of [`local_fields`].
#[derive(Clone, Copy, Debug)]
pub struct LocalOptions {
    /// The relaxed solve (solver, tolerance, lever arm, rotations).
    pub relaxed: RelaxedOptions,
    /// Particles whose strain cannot be fitted.
    pub degenerate: DegenerateFit,
    /// Smallest accepted λ_min/λ_max of A_p = Σ_b l_b ⊗ l_b of a particle's strain fit (as
    /// the many-body term's `conditioning`).
    pub conditioning: f64,
}

impl Default for LocalOptions {
    fn default() -> Self {
        LocalOptions {
            relaxed: RelaxedOptions::default(),
            degenerate: DegenerateFit::default(),
            conditioning: 1e-6,
        }
    }
}

/// Why a particle has no fitted strain.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum UnfittedReason {
    /// Pruned from the load-carrying network (fewer than two bonds after repeated pruning,
    /// e.g. no bond at all): its displacement is free and its stress zero.
    NoLoad,
    /// Fewer than three load-carrying bonds.
    FewBonds,
    /// Its load-carrying bonds lie (nearly) in one plane (λ_min/λ_max below the option).
    Coplanar,
}

/// A particle without a fitted strain.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
pub struct Unfitted {
    /// Particle index.
    pub particle: u32,
    /// Its load-carrying bonds.
    pub bonds: u32,
    /// Why.
    pub reason: UnfittedReason,
}

/// The local fields of a periodic cell under a macroscopic strain (structure of arrays; the
/// stresses in Voigt order 11, 22, 33, 23, 13, 12, the strains engineering).
#[derive(Clone, Debug)]
pub struct LocalFields {
    /// The macroscopic engineering strain applied (Voigt).
    pub strain: Voigt6,
    /// The macroscopic stress (Pa): the Love stress (1/V) Σ_b sym(l_b ⊗ f_b) of the bond
    /// forces, plus the many-body term's (1/V) Σ_p V_p^D D_p:ε_p^D where there is one.
    pub stress: Voigt6,
    /// The relaxed solve: its tensor `c` (so c·strain is the stress of the exact solution),
    /// iterations, residual, null space.
    pub relaxed: RelaxedResult,
    /// Cell volume V (m³).
    pub volume: f64,
    /// Whether each particle carries load (is in the relaxed network).
    pub active: Vec<bool>,
    /// Displacement fluctuation of each particle (m; the displacement is ε·x plus it); zero
    /// for a particle carrying no load (free, indeterminate).
    pub fluctuation: Vec<Vec3>,
    /// Rotation of each particle (rad); zero for a particle carrying no load.
    pub rotation: Vec<Vec3>,
    /// V_p of each particle (m³): V·r_p³/Σ r³.
    pub particle_volume: Vec<f64>,
    /// Stress σ_p of each particle (Pa, Voigt): Love–Weber of its bonds' forces, plus the
    /// term's share `particle_term_stress[p]` where there is a term.
    pub particle_stress: Vec<Voigt6>,
    /// The many-body term's share of σ_p, (V_p^D/V_p)·D_p:ε_p^D (Pa, Voigt; already in
    /// `particle_stress`); empty without a term.
    pub particle_term_stress: Vec<Voigt6>,
    /// Fitted engineering strain ε_p of each particle (Voigt), `None` where it cannot be
    /// fitted ([`LocalFields::unfitted`]).
    pub particle_strain: Vec<Option<Voigt6>>,
    /// The particles without a fitted strain, ascending.
    pub unfitted: Vec<Unfitted>,
    /// Force on i from j of each bond (N); zero for a bond carrying no load.
    pub bond_force: Vec<Vec3>,
    /// Moment on i from j of each bond's rotational springs, k_r θ_⊥ + k_tw θ_∥ with
    /// θ = ω_j − ω_i (N·m).
    pub bond_moment: Vec<Vec3>,
}

/// Volume-weighted statistics of one group of particles.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct GroupStatistics {
    /// The group's label (absent for the whole cell).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub label: Option<u32>,
    /// Particles in the group.
    pub particles: usize,
    /// Those with a fitted strain.
    pub fitted_particles: usize,
    /// Σ V_p over the group (m³).
    pub volume_m3: f64,
    /// Σ V_p over its fitted particles (m³).
    pub fitted_volume_m3: f64,
    /// Σ V_p σ_p / Σ V_p (Pa, Voigt 11, 22, 33, 23, 13, 12).
    pub mean_stress_pa: [f64; 6],
    /// Volume-weighted standard deviation of σ_p about that mean, per component (Pa).
    pub std_stress_pa: [f64; 6],
    /// Σ V_p ε_p / Σ V_p over the fitted particles (engineering strain, Voigt); absent
    /// when none is fitted.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub mean_strain: Option<[f64; 6]>,
    /// Volume-weighted standard deviation of ε_p over the fitted particles.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub std_strain: Option<[f64; 6]>,
}

/// The local fields' statistics: the whole cell and each label (ascending).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct LocalReport {
    /// The macroscopic engineering strain applied (Voigt).
    pub strain: [f64; 6],
    /// The macroscopic Love stress of the bond forces (Pa, Voigt).
    pub stress_pa: [f64; 6],
    /// The relaxed tensor times the strain (Pa, Voigt): equals `stress_pa` at equilibrium.
    pub tensor_stress_pa: [f64; 6],
    /// Cell volume (m³).
    pub volume_m3: f64,
    /// Particles without a fitted strain.
    pub unfitted: Vec<Unfitted>,
    /// Every particle.
    pub cell: GroupStatistics,
    /// Each label's particles.
    pub groups: Vec<GroupStatistics>,
}

impl LocalReport {
    /// The report as JSON, refused if a number is not finite.
    pub fn to_json(&self) -> Result<String> {
        crate::io::finite_json(self, "local fields report")
    }
}

/// The symmetric part of a 3×3 tensor in Voigt order (a stress: no factors of 2).
fn stress_voigt(m: &Mat3) -> Voigt6 {
    Voigt6::from_fn(|a, _| {
        let (i, j) = VOIGT_PAIRS[a];
        0.5 * (m[(i, j)] + m[(j, i)])
    })
}

/// The symmetric part of a displacement gradient as an engineering strain (γ = 2ε).
fn strain_voigt(m: &Mat3) -> Voigt6 {
    Voigt6::from_fn(|a, _| {
        let (i, j) = VOIGT_PAIRS[a];
        if i == j {
            m[(i, i)]
        } else {
            m[(i, j)] + m[(j, i)]
        }
    })
}

/// The local fields of a fully periodic bonded packing under the macroscopic engineering
/// strain `strain` (Voigt; finite, every |e| ≤ 0.1: a small-strain solution), from one relaxed
/// solve (see the module docs for the stress, strain and volume definitions). Refuses
/// ([`Error::Invalid`]) a packing without a fully periodic cell and such a strain;
/// ([`Error::Degenerate`]) a particle without a fitted strain when `options.degenerate` is
/// [`DegenerateFit::Refuse`]. The same bits on any thread count.
pub fn local_fields(
    packing: &Packing,
    bonds: &BondSet,
    springs: &BondStiffness,
    strain: &Voigt6,
    options: &LocalOptions,
) -> Result<LocalFields> {
    local_fields_with_term(packing, bonds, springs, None, strain, options)
}

/// [`local_fields`] of the springs together with the many-body term `term` (built on the
/// same packing and bonds, [`crate::manybody::ManyBodySpec::build_with_grains`]): the
/// fluctuation minimises the total energy (as [`super::relaxed_tensor_with_term`]) and each
/// particle's stress adds the term's (module docs), so the per-particle stresses still add up
/// to V times the macroscopic stress, c·ε at equilibrium. `None` is [`local_fields`].
pub fn local_fields_with_term(
    packing: &Packing,
    bonds: &BondSet,
    springs: &BondStiffness,
    term: Option<&ManyBody>,
    strain: &Voigt6,
    options: &LocalOptions,
) -> Result<LocalFields> {
    PeriodicCell::require_fully_periodic(packing.cell.as_ref(), "local fields")?;
    if packing.cell.is_none() {
        return Err(Error::Invalid(
            "local fields: the relaxed solve needs a periodic packing (a `# periodic Lx Ly Lz` \
             header)"
                .into(),
        ));
    }
    if let Some(x) = strain.iter().find(|x| !x.is_finite() || x.abs() > 0.1) {
        return Err(Error::Invalid(format!(
            "local fields: strain component {x} is not a small strain: the solution is linear \
             (small-strain), expected finite |ε| ≤ 0.1"
        )));
    }
    if !(options.conditioning >= 0.0 && options.conditioning < 1.0) {
        return Err(Error::Invalid(format!(
            "local fields: conditioning {} must lie in [0, 1) (λ_min/λ_max of a particle's \
             Σ l⊗l)",
            options.conditioning
        )));
    }
    let ropts = &options.relaxed;
    let sol = relaxed_solve_full(packing, bonds, springs, ropts, None, None, term)?;
    let n = packing.len();
    let nb = bonds.len();
    let eps = strain_tensor(strain);

    // Fluctuation and rotation q = −Q·e of every active particle.
    let mut active = vec![false; n];
    let mut fluctuation = vec![Vec3::zeros(); n];
    let mut rotation = vec![Vec3::zeros(); n];
    for (q, &p) in sol.q.iter().zip(&sol.active) {
        let g = -(q * strain);
        active[p as usize] = true;
        fluctuation[p as usize] = Vec3::new(g[0], g[1], g[2]);
        if ropts.rotations {
            rotation[p as usize] = Vec3::new(g[3], g[4], g[5]);
        }
    }

    // Bond forces f = S·Δ and moments (Kruyt 2014 Eqs. 10–14, as `network::element`).
    let carries = |b: usize| active[bonds.i[b] as usize] && active[bonds.j[b] as usize];
    let arms = |b: usize| arms_of(packing, bonds, ropts.lever_arm, b);
    let (bond_force, bond_moment): (Vec<Vec3>, Vec<Vec3>) = (0..nb)
        .into_par_iter()
        .map(|b| {
            if !carries(b) {
                return (Vec3::zeros(), Vec3::zeros());
            }
            let (i, j) = (bonds.i[b] as usize, bonds.j[b] as usize);
            let nrm = bonds.normal[b];
            let (ri, rj) = arms(b);
            let delta = fluctuation[j] - fluctuation[i]
                + (nrm * ri).cross(&rotation[i])
                + (nrm * rj).cross(&rotation[j])
                + eps * (nrm * bonds.length[b]);
            let nn = nrm * nrm.transpose();
            let s = Mat3::identity() * springs.ks[b] + nn * (springs.kn[b] - springs.ks[b]);
            let theta = rotation[j] - rotation[i];
            let r = (Mat3::identity() - nn) * springs.kr[b] + nn * springs.ktw[b];
            (s * delta, r * theta)
        })
        .unzip();

    // Macroscopic Love stress, summed in bond order.
    let volume = packing.volume();
    let mut love = Mat3::zeros();
    for (b, f) in bond_force.iter().enumerate() {
        love += bonds.branch(b) * f.transpose();
    }
    let mut stress = stress_voigt(&love) / volume;

    // Particle volumes V·r³/Σr³ (summed in particle order).
    let r3: Vec<f64> = packing.radii.iter().map(|r| r * r * r).collect();
    let total: f64 = r3.iter().sum();
    let particle_volume: Vec<f64> = r3.iter().map(|x| volume * x / total).collect();

    // The term's stress V_p^D D_p:ε_p^D of each particle, and its sum in particle order.
    let term_stress: Vec<Voigt6> = match term {
        Some(t) => {
            let own = term_particle_stress(t, &eps, &fluctuation);
            let mut sum = Voigt6::zeros();
            for s in &own {
                sum += s;
            }
            stress += sum / volume;
            own.iter()
                .zip(&particle_volume)
                .map(|(s, v)| s / *v)
                .collect()
        }
        None => Vec::new(),
    };

    // Every particle's bonds, in bond order.
    let (start, inc) = csr(
        n,
        bonds
            .i
            .iter()
            .zip(&bonds.j)
            .map(|(&i, &j)| (i as usize, j as usize)),
        |b, _| b as u32,
    );
    let per_particle: Vec<(Voigt6, std::result::Result<Voigt6, Unfitted>)> = (0..n)
        .into_par_iter()
        .map(|p| {
            let own = &inc[start[p]..start[p + 1]];
            let mut s = Mat3::zeros();
            for &b in own {
                let b = b as usize;
                let (ri, rj) = arms(b);
                let arm = if bonds.i[b] as usize == p { ri } else { rj };
                s += (bonds.normal[b] * arm) * bond_force[b].transpose();
            }
            let mut sigma = stress_voigt(&s) / particle_volume[p];
            if let Some(t) = term_stress.get(p) {
                sigma += t;
            }
            let fit = fitted_strain(p, own, bonds, &fluctuation, &active, options.conditioning)
                .map(|g| strain + strain_voigt(&g));
            (sigma, fit)
        })
        .collect();
    let mut particle_stress = Vec::with_capacity(n);
    let mut particle_strain = Vec::with_capacity(n);
    let mut unfitted = Vec::new();
    for (sigma, fit) in per_particle {
        particle_stress.push(sigma);
        match fit {
            Ok(e) => particle_strain.push(Some(e)),
            Err(u) => {
                if options.degenerate == DegenerateFit::Refuse {
                    return Err(Error::Degenerate(format!(
                        "local fields: particle {} {}; its strain fit needs at least three \
                         load-carrying bonds not in one plane (DegenerateFit::Exclude leaves \
                         such particles out of the strain statistics)",
                        u.particle,
                        describe(&u)
                    )));
                }
                particle_strain.push(None);
                unfitted.push(u);
            }
        }
    }
    Ok(LocalFields {
        strain: *strain,
        stress,
        relaxed: sol.result,
        volume,
        active,
        fluctuation,
        rotation,
        particle_volume,
        particle_stress,
        particle_term_stress: term_stress,
        particle_strain,
        unfitted,
        bond_force,
        bond_moment,
    })
}

/// V_p^D·D_p:ε_p^D of every particle of the term `t` (Pa·m³, Voigt; zero for a particle the
/// term leaves out): ε_p^D = sym(F_p − I) of the term's own fit, linear in the displacement,
/// F_p − I = ε + Σ_n w_n ⊗ c_n over p's stencil (Σ_b L_b ⊗ a_b = I takes the affine part to
/// ε exactly, the same fit as the relaxed solve's term at the reference state).
fn term_particle_stress(t: &ManyBody, eps: &Mat3, fluctuation: &[Vec3]) -> Vec<Voigt6> {
    let volumes = t.particle_volumes();
    (0..t.len())
        .into_par_iter()
        .map(|p| {
            let (nodes, coef) = t.stencil(p);
            if volumes[p] == 0.0 || nodes.is_empty() {
                return Voigt6::zeros();
            }
            let mut grad = *eps;
            for (&n, c) in nodes.iter().zip(coef) {
                grad += fluctuation[n as usize] * c.transpose();
            }
            (t.tensor_of(p) * strain_voigt(&grad)) * volumes[p]
        })
        .collect()
}

/// Contact arms (r_i, r_j) of bond `b` (they add to its length).
fn arms_of(packing: &Packing, bonds: &BondSet, lever_arm: LeverArm, b: usize) -> (f64, f64) {
    let (i, j) = (bonds.i[b] as usize, bonds.j[b] as usize);
    lever_arm.arms(packing.radii[i], packing.radii[j], bonds.length[b])
}

/// Why a particle is unfitted, for a refusal.
fn describe(u: &Unfitted) -> String {
    match u.reason {
        UnfittedReason::NoLoad => "carries no load (it has fewer than two bonds after \
                                   pruning the dangling ones)"
            .into(),
        UnfittedReason::FewBonds => format!("has {} load-carrying bonds", u.bonds),
        UnfittedReason::Coplanar => {
            format!("has {} load-carrying bonds (nearly) in one plane", u.bonds)
        }
    }
}

/// The least-squares gradient Σ_b Δw_b ⊗ A_p⁻¹ l_b of particle p's load-carrying bonds
/// `own` (A_p = Σ_b l_b ⊗ l_b, Δw_b = w_j − w_i the branch vector's fluctuation), or why it
/// has none.
fn fitted_strain(
    p: usize,
    own: &[u32],
    bonds: &BondSet,
    fluctuation: &[Vec3],
    active: &[bool],
    conditioning: f64,
) -> std::result::Result<Mat3, Unfitted> {
    let unfitted = |count: usize, reason| Unfitted {
        particle: p as u32,
        bonds: count as u32,
        reason,
    };
    // A bond carries load iff both its ends do (pruning removes a dangling particle's bonds).
    let carrying = || {
        own.iter()
            .map(|&b| b as usize)
            .filter(|&b| active[bonds.i[b] as usize] && active[bonds.j[b] as usize])
    };
    let count = carrying().count();
    if !active[p] {
        return Err(unfitted(count, UnfittedReason::NoLoad));
    }
    if count < 3 {
        return Err(unfitted(count, UnfittedReason::FewBonds));
    }
    let mut a = Mat3::zeros();
    for b in carrying() {
        let l = bonds.branch(b);
        a += l * l.transpose();
    }
    let eig = nalgebra::SymmetricEigen::new(a).eigenvalues;
    let ratio = eig.min() / eig.max();
    let ainv = match a.try_inverse() {
        Some(inv) if ratio >= conditioning && ratio > 0.0 => inv,
        _ => return Err(unfitted(count, UnfittedReason::Coplanar)),
    };
    let mut g = Mat3::zeros();
    for b in carrying() {
        let dw = fluctuation[bonds.j[b] as usize] - fluctuation[bonds.i[b] as usize];
        g += dw * (ainv * bonds.branch(b)).transpose();
    }
    Ok(g)
}

impl LocalFields {
    /// The volume-weighted mean, standard deviation and counts of the particles' stress and
    /// strain per label (`labels`: one per particle, e.g. its grain) and over the whole cell.
    /// Refuses ([`Error::Invalid`]) a label count that is not the particle count.
    pub fn statistics(&self, labels: &[u32]) -> Result<LocalReport> {
        let n = self.particle_stress.len();
        if labels.len() != n {
            return Err(Error::Invalid(format!(
                "local fields: {} labels for {n} particles (expected one per particle)",
                labels.len()
            )));
        }
        let mut members: BTreeMap<u32, Vec<usize>> = BTreeMap::new();
        for (p, &l) in labels.iter().enumerate() {
            members.entry(l).or_default().push(p);
        }
        let all: Vec<usize> = (0..n).collect();
        let c = &self.relaxed.c;
        Ok(LocalReport {
            strain: self.strain.into(),
            stress_pa: self.stress.into(),
            tensor_stress_pa: (c * self.strain).into(),
            volume_m3: self.volume,
            unfitted: self.unfitted.clone(),
            cell: self.group(None, &all),
            groups: members
                .iter()
                .map(|(&l, m)| self.group(Some(l), m))
                .collect(),
        })
    }

    /// The whole cell's statistics ([`LocalFields::statistics`] with one label).
    pub fn cell_statistics(&self) -> GroupStatistics {
        let all: Vec<usize> = (0..self.particle_stress.len()).collect();
        self.group(None, &all)
    }

    /// Statistics of the particles `members`, summed in their order.
    fn group(&self, label: Option<u32>, members: &[usize]) -> GroupStatistics {
        let v = &self.particle_volume;
        let stress = weighted(members.iter().map(|&p| (v[p], &self.particle_stress[p])));
        let fitted = members
            .iter()
            .filter_map(|&p| self.particle_strain[p].as_ref().map(|e| (v[p], e)));
        let strain = weighted(fitted.clone());
        GroupStatistics {
            label,
            particles: members.len(),
            fitted_particles: fitted.count(),
            volume_m3: stress.0,
            fitted_volume_m3: strain.0,
            mean_stress_pa: stress.1,
            std_stress_pa: stress.2,
            mean_strain: (strain.0 > 0.0).then_some(strain.1),
            std_strain: (strain.0 > 0.0).then_some(strain.2),
        }
    }
}

/// Σ w, the w-weighted mean and standard deviation (population, √(Σ w (x − m)² / Σ w)) per
/// component, in the iterator's order; zeros when Σ w = 0.
fn weighted<'a>(
    items: impl Iterator<Item = (f64, &'a Voigt6)> + Clone,
) -> (f64, [f64; 6], [f64; 6]) {
    let mut w = 0.0;
    let mut sum = Voigt6::zeros();
    for (wp, x) in items.clone() {
        w += wp;
        sum += x * wp;
    }
    if w <= 0.0 {
        return (w, [0.0; 6], [0.0; 6]);
    }
    let mean = sum / w;
    let mut var = Voigt6::zeros();
    for (wp, x) in items {
        var += (x - mean).component_mul(&(x - mean)) * wp;
    }
    (w, mean.into(), (var / w).map(f64::sqrt).into())
}
