//! Frictional contacts between spheres that are not bonded — or no longer: the contacts
//! that take over when bonds break (issue 32, items 2 and 3), so that a crushed specimen
//! does not interpenetrate.
//!
//! The law is YADE's `Law2_ScGeom_FrictPhys_CundallStrack` (Cundall & Strack 1979, read
//! from YADE's `ElasticContactLaw.cpp` and its documentation): on the overlap
//! u_n = R_i + R_j − |l| ≥ 0 a linear normal spring F_n = k_n·u_n (compression only, no
//! tension: a pair that separates loses its contact and its shear force); an incremental
//! shear force F_s ← rot(F_s) − k_s·Δu_s, rotated with the contact as ScGeom does (the
//! normal's change and the mean spin about it), capped by Coulomb |F_s| ≤ μ·F_n. The part of
//! the trial force above the cap is slip; its work ((F_trial − F_s)/k_s)·F_s is summed as
//! YADE's `plasticDissipation`. The forces act at the contact point (mid-overlap), which gives
//! the torques. The kinematics are those of the bond laws (a)–(c) (`super::laws`): contact
//! point, relative velocity at it including the periodic image's velocity L·H_prev·c.
//!
//! Candidate pairs come from a Verlet list with a skin ([`Contacts`]): pairs whose centre
//! distance is at most R_i + R_j + skin, found on a cell grid in the (possibly sheared)
//! periodic cell or in the bounding box of a free assembly, and rebuilt only when the
//! particles may have closed the skin since the last build (see [`Contacts::compute`]).
//! Pairs are kept in a canonical order (i < j, then the image), the pair loads are computed in
//! fixed chunks in parallel and gathered per particle in the list's order, so every result
//! is the same bit for bit on any number of threads.
//!
//! Hooking into the integrator: build once with [`Contacts::new`], and every step, after the
//! positions of time t are known and before the leapfrog update, call [`Contacts::compute`]
//! with the cell (after its integration), the time step and a predicate that excludes the
//! pairs held by an intact bond (e.g. a [`PairSet`] of intact bonded pairs); add
//! [`Contacts::force`]/[`Contacts::torque`] (or the slices `compute` adds to) to each
//! particle's resultant. The integrator instead gives its intact bonds' pairs once to
//! [`Contacts::set_excluded`] (a flag per listed pair, no predicate per pair and step; the
//! same bits) and [`Contacts::include_pair`]s a pair when its bond breaks. When a bond
//! breaks, stop excluding its pair and, as YADE's
//! `CohFrictPhys` keeps the bond's springs after cohesion breaks, call
//! [`Contacts::set_pair_stiffness`] with the bond's k_n, k_s; a bond whose law keeps its
//! shear force (YADE's shear break) hands it on with [`Contacts::carry_shear`].

use super::state::{deterministic_sum_mat3, DeformingCell, Particles};
use crate::{Error, Mat3, Result, Vec3};
use rayon::prelude::*;
use std::collections::BTreeMap;

/// Pairs per parallel work item (fixed, so per-chunk sums are the same on any thread count).
const PAIR_CHUNK: usize = 1024;
/// Particles per parallel work item of the neighbour search.
const PARTICLE_BLOCK: usize = 512;
/// Particles per parallel work item of the Verlet list's displacement check.
const CHECK_BLOCK: usize = 4096;
/// Relative margin on the grid's cell width, so that a pair at exactly the cutoff is not lost
/// to rounding in the fractional coordinates.
const GRID_MARGIN: f64 = 1e-9;

/// The springs and friction of the frictional contacts: the default for every new pair
/// (YADE `FrictPhys`: `kn`, `ks`, `tangensOfFrictionAngle`).
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct ContactLaw {
    /// Normal stiffness k_n (N/m), > 0.
    pub normal_stiffness: f64,
    /// Shear stiffness k_s (N/m), ≥ 0.
    pub shear_stiffness: f64,
    /// Coulomb friction coefficient μ = tan φ, ≥ 0.
    pub friction: f64,
}

impl ContactLaw {
    /// Refuse a non-finite or out-of-range value, naming it.
    pub fn check(&self) -> Result<()> {
        check_springs(self.normal_stiffness, self.shear_stiffness, "contact law")?;
        if !(self.friction.is_finite() && self.friction >= 0.0) {
            return Err(Error::Invalid(format!(
                "contact law: friction coefficient μ = tan φ must be finite and ≥ 0, got {}",
                self.friction
            )));
        }
        Ok(())
    }
}

fn check_springs(kn: f64, ks: f64, what: &str) -> Result<()> {
    if !(kn.is_finite() && kn > 0.0) {
        return Err(Error::Invalid(format!(
            "{what}: normal stiffness k_n must be finite and > 0 (N/m), got {kn}"
        )));
    }
    if !(ks.is_finite() && ks >= 0.0) {
        return Err(Error::Invalid(format!(
            "{what}: shear stiffness k_s must be finite and ≥ 0 (N/m), got {ks}"
        )));
    }
    Ok(())
}

/// A sorted set of unordered particle pairs, for the exclusion predicate of
/// [`Contacts::compute`] (the pairs held by intact bonds): `contains` is a binary search.
/// Removing marks the pair instead of shifting the sorted list (a run that breaks most of its
/// bonds would otherwise move the list once per break, quadratic in the bonds).
#[derive(Clone, Debug, Default)]
pub struct PairSet {
    pairs: Vec<(u32, u32)>,
    /// Per entry of `pairs`: removed.
    removed: Vec<bool>,
    len: usize,
}

impl PartialEq for PairSet {
    fn eq(&self, other: &Self) -> bool {
        self.len == other.len && self.live().eq(other.live())
    }
}

impl Eq for PairSet {}

impl PairSet {
    /// The set of the given pairs (either order; duplicates and self-pairs are dropped).
    pub fn new(pairs: impl IntoIterator<Item = (usize, usize)>) -> Self {
        let mut pairs: Vec<(u32, u32)> = pairs
            .into_iter()
            .filter(|(i, j)| i != j)
            .map(|(i, j)| key(i, j))
            .collect();
        pairs.sort_unstable();
        pairs.dedup();
        let len = pairs.len();
        PairSet {
            removed: vec![false; len],
            pairs,
            len,
        }
    }

    /// The pairs in the set, in order.
    fn live(&self) -> impl Iterator<Item = &(u32, u32)> {
        self.pairs
            .iter()
            .zip(&self.removed)
            .filter(|(_, r)| !**r)
            .map(|(p, _)| p)
    }

    /// Whether the pair {i, j} is in the set.
    pub fn contains(&self, i: usize, j: usize) -> bool {
        self.pairs
            .binary_search(&key(i, j))
            .is_ok_and(|k| !self.removed[k])
    }

    /// Remove {i, j} (a bond broke); returns whether it was there.
    pub fn remove(&mut self, i: usize, j: usize) -> bool {
        match self.pairs.binary_search(&key(i, j)) {
            Ok(k) if !self.removed[k] => {
                self.removed[k] = true;
                self.len -= 1;
                true
            }
            _ => false,
        }
    }

    /// Number of pairs.
    pub fn len(&self) -> usize {
        self.len
    }

    /// True when empty.
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }
}

/// The canonical key (min, max) of an unordered pair.
fn key(i: usize, j: usize) -> (u32, u32) {
    (i.min(j) as u32, i.max(j) as u32)
}

/// One contact in touch at the last [`Contacts::compute`] (a copy, for output and tests).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Contact {
    /// First particle (the smaller index).
    pub i: usize,
    /// Second particle.
    pub j: usize,
    /// Periodic image of j, in cells, relative to the unwrapped positions: the branch vector is
    /// x_j + H·image − x_i (all zero in a free assembly).
    pub image: [i32; 3],
    /// Unit normal from i to j's image.
    pub normal: Vec3,
    /// Overlap u_n = R_i + R_j − |l| ≥ 0 (m).
    pub overlap: f64,
    /// Normal force k_n·u_n (N, compression positive, never negative).
    pub normal_force: f64,
    /// Shear force (N, YADE's `shearForce`, acting on j; i receives its opposite).
    pub shear_force: Vec3,
    /// The pair's springs (k_n, k_s) (N/m).
    pub stiffness: (f64, f64),
}

/// A pair's key in the Verlet list's order: (i, j, image of j), i < j.
type PairKey = (u32, u32, [i32; 3]);

/// A candidate pair of the Verlet list.
#[derive(Clone, Copy, Debug)]
struct Candidate {
    i: u32,
    j: u32,
    image: [i32; 3],
    kn: f64,
    ks: f64,
}

impl Candidate {
    fn key(&self) -> (u32, u32, [i32; 3]) {
        (self.i, self.j, self.image)
    }
}

/// State of a candidate pair carried from step to step.
#[derive(Clone, Copy, Debug, Default)]
struct PairState {
    /// Normal of the last evaluation (for the rotation of the shear force).
    normal: Vec3,
    shear_force: Vec3,
    normal_force: f64,
    overlap: f64,
    /// In touch at the last evaluation.
    active: bool,
    /// `shear_force` is a broken bond's, handed on in this step ([`Contacts::carry_shear`]):
    /// cap it, do not rotate or increment it.
    carried: bool,
}

/// Loads of one pair: the force on i (j receives its opposite) and the torques.
#[derive(Clone, Copy, Debug, Default)]
struct PairLoad {
    force_i: Vec3,
    torque_i: Vec3,
    torque_j: Vec3,
}

/// The configuration the Verlet list was built at.
#[derive(Clone, Debug)]
struct Reference {
    position: Vec<Vec3>,
    /// H⁻¹ of the cell at the build (None: free assembly).
    h_inv: Option<Mat3>,
    r_max: f64,
}

/// Frictional contacts with their Verlet list (see the module docs).
#[derive(Clone, Debug)]
pub struct Contacts {
    law: ContactLaw,
    skin: f64,
    /// Springs of pairs that differ from the law (broken bonds), keyed (min, max).
    stiffness: BTreeMap<(u32, u32), (f64, f64)>,
    list: Vec<Candidate>,
    /// Per listed pair: in `excluded` (held by an intact bond), so skipped by the pair loop
    /// and the gather (its state and loads stay zero).
    held: Vec<bool>,
    /// Pairs that have no contact ([`Contacts::set_excluded`]).
    excluded: PairSet,
    state: Vec<PairState>,
    loads: Vec<PairLoad>,
    reference: Option<Reference>,
    /// (elastic energy, dissipation, contacts in touch) per pair chunk of the last evaluation.
    chunk_sums: Vec<[f64; 3]>,
    /// Per pair chunk, the listed pairs in touch at the last evaluation, in list order: the
    /// only pairs with loads (every other pair's are zero), which the gather adds.
    touching: Vec<Vec<u32>>,
    dissipated: f64,
    rebuilds: u64,
    force: Vec<Vec3>,
    torque: Vec<Vec3>,
    /// Shear forces handed on by bonds broken in this step, keyed (i, j, image) canonical,
    /// set into the pairs' state at the next [`Contacts::update`].
    handed_on: Vec<(PairKey, Vec3)>,
}

/// What the pair loop needs besides the per-pair records.
struct PairInputs<'a> {
    particles: &'a Particles,
    h: Mat3,
    shift_velocity: Mat3,
    dt: f64,
    friction: f64,
    excluded: &'a (dyn Fn(usize, usize) -> bool + Sync),
}

impl Contacts {
    /// Contacts with the default `law` for new pairs and a Verlet skin `skin` (m, > 0; e.g.
    /// a fifth of the mean radius: larger rebuilds less often but lists more pairs).
    pub fn new(law: ContactLaw, skin: f64) -> Result<Self> {
        law.check()?;
        if !(skin.is_finite() && skin > 0.0) {
            return Err(Error::Invalid(format!(
                "contacts: the Verlet skin must be finite and > 0 (m), got {skin}"
            )));
        }
        Ok(Contacts {
            law,
            skin,
            stiffness: BTreeMap::new(),
            list: Vec::new(),
            held: Vec::new(),
            excluded: PairSet::default(),
            state: Vec::new(),
            loads: Vec::new(),
            reference: None,
            chunk_sums: Vec::new(),
            touching: Vec::new(),
            dissipated: 0.0,
            rebuilds: 0,
            force: Vec::new(),
            torque: Vec::new(),
            handed_on: Vec::new(),
        })
    }

    /// The default law of new pairs.
    pub fn law(&self) -> &ContactLaw {
        &self.law
    }

    /// The Verlet skin (m).
    pub fn skin(&self) -> f64 {
        self.skin
    }

    /// Give the pair {i, j} the springs k_n, k_s (N/m) instead of the law's — a broken bond's
    /// pair keeps the bond's springs, as YADE's `CohFrictPhys` does after cohesion breaks.
    /// Takes effect at once (also on a contact in touch).
    pub fn set_pair_stiffness(&mut self, i: usize, j: usize, kn: f64, ks: f64) -> Result<()> {
        check_springs(kn, ks, &format!("contacts: pair ({i}, {j})"))?;
        if i == j || i.max(j) >= u32::MAX as usize {
            return Err(Error::Invalid(format!(
                "contacts: pair ({i}, {j}) must join two different particles"
            )));
        }
        let k = key(i, j);
        self.stiffness.insert(k, (kn, ks));
        let lo = self.list.partition_point(|c| (c.i, c.j) < k);
        for c in self.list[lo..].iter_mut().take_while(|c| (c.i, c.j) == k) {
            c.kn = kn;
            c.ks = ks;
        }
        Ok(())
    }

    /// The pairs that have no contact whatever their overlap (the integrator's intact bonds),
    /// judged by a flag per listed pair instead of a predicate asked every step; their
    /// contact state is dropped. [`Contacts::update`]'s predicate still applies on top.
    pub fn set_excluded(&mut self, pairs: PairSet) {
        self.excluded = pairs;
        for k in 0..self.list.len() {
            let c = &self.list[k];
            self.held[k] = self.excluded.contains(c.i as usize, c.j as usize);
            if self.held[k] {
                self.state[k] = PairState::default();
                self.loads[k] = PairLoad::default();
            }
        }
    }

    /// Let the pair {i, j} touch again (its bond broke): removed from the excluded pairs.
    pub fn include_pair(&mut self, i: usize, j: usize) {
        let k = key(i, j);
        if self.excluded.remove(i, j) {
            let lo = self.list.partition_point(|c| (c.i, c.j) < k);
            for (c, h) in self.list[lo..].iter().zip(&mut self.held[lo..]) {
                if (c.i, c.j) != k {
                    break;
                }
                *h = false;
            }
        }
    }

    /// Make the pair {i, j} with j's periodic image `image` (cells, as [`Contact::image`])
    /// continue from the shear force `shear` (N, acting on j) at the next
    /// [`Contacts::update`]: a bond broken in shear in this step hands on the trial shear force
    /// its law computed (YADE's fragile CohFrict keeps the interaction, docs/strength.md
    /// "Compression (UCS)"). That evaluation caps it at μ·F_n with the contact's own
    /// F_n — the excess is released by the break, not friction's slip — and neither rotates
    /// nor increments it (the bond law did, this step); later ones carry it on incrementally.
    /// A pair not in touch then starts afresh as usual (YADE erases it in tension).
    pub fn carry_shear(&mut self, i: usize, j: usize, image: [i32; 3], shear: Vec3) -> Result<()> {
        if i == j || i.max(j) >= u32::MAX as usize {
            return Err(Error::Invalid(format!(
                "contacts: pair ({i}, {j}) must join two different particles"
            )));
        }
        if !(shear.x.is_finite() && shear.y.is_finite() && shear.z.is_finite()) {
            return Err(Error::Invalid(format!(
                "contacts: pair ({i}, {j}): the shear force handed on must be finite, got {shear:?}"
            )));
        }
        // Canonical order i < j: seen from the other end, the image and the force on j flip.
        let (a, b, image, shear) = if i < j {
            (i, j, image, shear)
        } else {
            (j, i, image.map(|c| -c), -shear)
        };
        self.handed_on.push(((a as u32, b as u32, image), shear));
        Ok(())
    }

    /// Put the handed-on shear forces into their pairs' state (a pair not listed is beyond
    /// the skin: not in touch, nothing to carry).
    fn apply_handed_on(&mut self) {
        for (k, shear) in std::mem::take(&mut self.handed_on) {
            if let Ok(n) = self.list.binary_search_by(|c| c.key().cmp(&k)) {
                self.state[n] = PairState {
                    shear_force: shear,
                    carried: true,
                    ..Default::default()
                };
            }
        }
    }

    /// Springs (k_n, k_s) of the pair {i, j}: its own if set, else the law's.
    pub fn pair_stiffness(&self, i: usize, j: usize) -> (f64, f64) {
        self.stiffness
            .get(&key(i, j))
            .copied()
            .unwrap_or((self.law.normal_stiffness, self.law.shear_stiffness))
    }

    /// Compute the contact loads at the current state and add each particle's contact force
    /// and torque to `force[k]`, `torque[k]` (N, N·m).
    ///
    /// `particles`: positions at t, velocities at t − dt/2 (as the bond laws see them);
    /// `cell`: the periodic cell after its integration for this step (None: free assembly);
    /// `excluded(i, j)` (i < j): true for the pairs that must have no contact (intact bonds),
    /// asked at every call for each listed pair in touch; an excluded pair loses its contact
    /// state.
    ///
    /// The Verlet list is rebuilt first when needed: on the first call, when the assembly
    /// changed between free and periodic, or when 2·max_p |u_p| + ‖F − I‖·(2R_max + skin) ≥
    /// skin, with u_p = x_p − F·x_p⁰ the displacement since the build apart from the cell's
    /// homogeneous deformation F = H·H⁰⁻¹ — the bound under which no pair outside the list can
    /// have come into touch. Errors: slices or particle count that do not match, a time step
    /// that is not finite and ≥ 0, a position that is not finite, or a periodic cell less than
    /// twice the cutoff 2R_max + skin across (a pair would touch more than one image).
    pub fn compute(
        &mut self,
        particles: &Particles,
        cell: Option<&DeformingCell>,
        dt: f64,
        excluded: &(dyn Fn(usize, usize) -> bool + Sync),
        force: &mut [Vec3],
        torque: &mut [Vec3],
    ) -> Result<()> {
        let n = particles.len();
        if force.len() != n || torque.len() != n {
            return Err(Error::Invalid(format!(
                "contacts: {n} particles but {} forces and {} torques to add to",
                force.len(),
                torque.len()
            )));
        }
        self.update(particles, cell, dt, excluded)?;
        force
            .par_iter_mut()
            .zip(torque.par_iter_mut())
            .zip(self.force.par_iter().zip(self.torque.par_iter()))
            .for_each(|((f, t), (cf, ct))| {
                *f += cf;
                *t += ct;
            });
        Ok(())
    }

    /// [`Contacts::compute`] without adding: the per-particle contact loads are left in
    /// [`Contacts::force`] and [`Contacts::torque`] (for an integrator that gathers them
    /// itself). Same arguments and errors.
    pub fn update(
        &mut self,
        particles: &Particles,
        cell: Option<&DeformingCell>,
        dt: f64,
        excluded: &(dyn Fn(usize, usize) -> bool + Sync),
    ) -> Result<()> {
        if !(dt.is_finite() && dt >= 0.0) {
            return Err(Error::Invalid(format!(
                "contacts: the time step must be finite and ≥ 0, got {dt}"
            )));
        }
        if self.needs_rebuild(particles, cell)? {
            self.rebuild(particles, cell)?;
        }
        if !self.handed_on.is_empty() {
            self.apply_handed_on();
        }
        self.evaluate(particles, cell, dt, excluded);
        self.gather(particles.len());
        Ok(())
    }

    /// Σ f_i ⊗ l over the contacts in touch at the last evaluation (N·m), with f_i the force
    /// on i and l = x_j + H·c − x_i the branch vector at `particles`' positions: the contacts'
    /// part of the Love stress σ = (1/V) Σ f_i ⊗ l (tension positive; Kumar 2016 Eq. 9),
    /// as `Simulation::stress` sums the bonds'. Summed in fixed chunks in order.
    pub fn stress_sum(&self, particles: &Particles, cell: Option<&DeformingCell>) -> Mat3 {
        let h = cell.map_or(Mat3::zeros(), |c| c.h);
        let x = &particles.position;
        deterministic_sum_mat3(self.list.len(), |k| {
            if !self.state[k].active {
                return Mat3::zeros();
            }
            let c = &self.list[k];
            let cd = Vec3::new(c.image[0] as f64, c.image[1] as f64, c.image[2] as f64);
            let l = x[c.j as usize] + h * cd - x[c.i as usize];
            self.loads[k].force_i * l.transpose()
        })
    }

    /// Contact force on each particle at the last [`Contacts::compute`] (N).
    pub fn force(&self) -> &[Vec3] {
        &self.force
    }

    /// Contact torque on each particle at the last [`Contacts::compute`] (N·m).
    pub fn torque(&self) -> &[Vec3] {
        &self.torque
    }

    /// Elastic energy in the contacts at the last evaluation (J):
    /// Σ ½(F_n²/k_n + |F_s|²/k_s), YADE's `elastPotential` of this law.
    pub fn elastic_energy(&self) -> f64 {
        self.chunk_sums.iter().map(|s| s[0]).sum()
    }

    /// What the contacts of the pair {i, j} (every image in touch) took on at the last
    /// evaluation, in the integrator's ledger (J): their elastic energy plus half the work
    /// their loads do over the last step, ½·dt·Σ(f·v + t·ω) with the half-step velocities
    /// of `particles` (the leapfrog's discrete work, as for a breaking bond, docs/strength.md
    /// "Breaking in the integrator"). For a contact made by a bond breaking in that step.
    pub(crate) fn pair_ledger(
        &self,
        i: usize,
        j: usize,
        particles: &Particles,
        cell: Option<&DeformingCell>,
        dt: f64,
    ) -> f64 {
        let k = key(i, j);
        let sv = cell.map_or(Mat3::zeros(), |c| c.vel_grad_times_prev_h);
        let lo = self.list.partition_point(|c| (c.i, c.j) < k);
        let mut sum = 0.0;
        for (n, c) in self.list[lo..].iter().enumerate() {
            if (c.i, c.j) != k {
                break;
            }
            let (s, l) = (&self.state[lo + n], &self.loads[lo + n]);
            if !s.active {
                continue;
            }
            let (a, b) = (c.i as usize, c.j as usize);
            let cd = Vec3::new(c.image[0] as f64, c.image[1] as f64, c.image[2] as f64);
            let vi = particles.velocity[a];
            let vj = particles.velocity[b] + sv * cd;
            let power = l.force_i.dot(&(vi - vj))
                + l.torque_i.dot(&particles.angular_velocity[a])
                + l.torque_j.dot(&particles.angular_velocity[b]);
            let mut elastic = 0.5 * s.normal_force * s.normal_force / c.kn;
            if c.ks > 0.0 {
                elastic += 0.5 * s.shear_force.norm_squared() / c.ks;
            }
            sum += elastic + 0.5 * dt * power;
        }
        sum
    }

    /// Energy dissipated by frictional slip since the start (J), YADE's
    /// `plasticDissipation`: Σ over slipping steps ((F_trial − F_s)/k_s)·F_s.
    pub fn friction_dissipation(&self) -> f64 {
        self.dissipated
    }

    /// Number of contacts in touch at the last evaluation.
    pub fn len(&self) -> usize {
        self.chunk_sums.iter().map(|s| s[2]).sum::<f64>() as usize
    }

    /// True when no contact is in touch.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Number of pairs in the Verlet list (in touch or within the skin).
    pub fn candidate_count(&self) -> usize {
        self.list.len()
    }

    /// The Verlet list's pairs (i, j, image), in canonical order.
    pub fn candidates(&self) -> Vec<(usize, usize, [i32; 3])> {
        self.list
            .iter()
            .map(|c| (c.i as usize, c.j as usize, c.image))
            .collect()
    }

    /// How many times the Verlet list has been built.
    pub fn rebuilds(&self) -> u64 {
        self.rebuilds
    }

    /// The contacts in touch at the last evaluation, in canonical order.
    pub fn contacts(&self) -> Vec<Contact> {
        self.list
            .iter()
            .zip(&self.state)
            .filter(|(_, s)| s.active)
            .map(|(c, s)| Contact {
                i: c.i as usize,
                j: c.j as usize,
                image: c.image,
                normal: s.normal,
                overlap: s.overlap,
                normal_force: s.normal_force,
                shear_force: s.shear_force,
                stiffness: (c.kn, c.ks),
            })
            .collect()
    }

    /// Whether the Verlet list must be (re)built before evaluating (see [`Contacts::compute`]).
    fn needs_rebuild(&self, p: &Particles, cell: Option<&DeformingCell>) -> Result<bool> {
        let Some(r) = &self.reference else {
            return Ok(true);
        };
        if r.position.len() != p.len() {
            return Err(Error::Invalid(format!(
                "contacts: the Verlet list was built for {} particles, now there are {}",
                r.position.len(),
                p.len()
            )));
        }
        let f = match (cell, r.h_inv) {
            (Some(c), Some(h_inv)) => c.h * h_inv,
            (None, None) => Mat3::identity(),
            _ => return Ok(true),
        };
        let strain = (f - Mat3::identity()).norm();
        // Blocks of particles scanned in order, the blocks' maxima reduced in parallel: a
        // maximum is exact in any order (NaN kept by `nan_max`), without rayon's per-item
        // cost on every particle of every step.
        let blocks = p
            .position
            .par_chunks(CHECK_BLOCK)
            .zip(r.position.par_chunks(CHECK_BLOCK));
        let u_max = if r.h_inv.is_none() {
            // F = I: x − I·x⁰ is x − x⁰ to the bit (x⁰ finite), and the largest |u| is the
            // root of the largest |u|² (the root is monotonic), so the same bound.
            blocks
                .map(|(x, x0)| {
                    x.iter()
                        .zip(x0)
                        .fold(0.0, |m, (x, x0)| nan_max(m, (x - x0).norm_squared()))
                })
                .reduce(|| 0.0, nan_max)
                .sqrt()
        } else {
            blocks
                .map(|(x, x0)| {
                    x.iter()
                        .zip(x0)
                        .fold(0.0, |m, (x, x0)| nan_max(m, (x - f * x0).norm()))
                })
                .reduce(|| 0.0, nan_max)
        };
        if !u_max.is_finite() {
            return Err(non_finite(p));
        }
        Ok(2.0 * u_max + strain * (2.0 * r.r_max + self.skin) >= self.skin)
    }

    /// Build the Verlet list at the current configuration, keeping the state of the pairs
    /// that were already listed.
    fn rebuild(&mut self, p: &Particles, cell: Option<&DeformingCell>) -> Result<()> {
        let n = p.len();
        if n > (u32::MAX / 2) as usize {
            return Err(Error::Invalid(format!(
                "contacts: {n} particles exceed the index range"
            )));
        }
        if p.position
            .iter()
            .any(|x| !(x.x.is_finite() && x.y.is_finite() && x.z.is_finite()))
        {
            return Err(non_finite(p));
        }
        let r_max = p.radius.iter().copied().fold(0.0, f64::max);
        let cutoff = 2.0 * r_max + self.skin;
        let h = cell.map(|c| c.h);
        let found = candidate_pairs(&p.position, &p.radius, h, cutoff, self.skin)?;
        // New list: carried state for pairs already listed (both lists are sorted).
        let mut list = Vec::with_capacity(found.len());
        let mut held = Vec::with_capacity(found.len());
        let mut state = Vec::with_capacity(found.len());
        let mut old = 0;
        for (i, j, image) in found {
            let k = (i, j, image);
            while old < self.list.len() && self.list[old].key() < k {
                old += 1;
            }
            let (kn, ks) = self.pair_stiffness(i as usize, j as usize);
            list.push(Candidate {
                i,
                j,
                image,
                kn,
                ks,
            });
            let h = self.excluded.contains(i as usize, j as usize);
            held.push(h);
            state.push(
                if !h && old < self.list.len() && self.list[old].key() == k {
                    self.state[old]
                } else {
                    PairState::default()
                },
            );
        }
        // Pairs dropped from the list are beyond the skin: not in touch, nothing to keep.
        if list.len() >= (u32::MAX / 2) as usize {
            return Err(Error::Invalid(format!(
                "contacts: {} candidate pairs exceed the index range",
                list.len()
            )));
        }
        self.loads = vec![PairLoad::default(); list.len()];
        self.chunk_sums = vec![[0.0; 3]; list.len().div_ceil(PAIR_CHUNK)];
        self.touching = vec![Vec::new(); list.len().div_ceil(PAIR_CHUNK)];
        self.list = list;
        self.held = held;
        self.state = state;
        self.reference = Some(Reference {
            position: p.position.clone(),
            h_inv: match h {
                Some(h) => Some(h.try_inverse().ok_or_else(|| {
                    Error::Degenerate("contacts: the periodic cell matrix H is singular".into())
                })?),
                None => None,
            },
            r_max,
        });
        self.rebuilds += 1;
        Ok(())
    }

    /// The pair loop over fixed chunks of [`PAIR_CHUNK`] pairs.
    fn evaluate(
        &mut self,
        p: &Particles,
        cell: Option<&DeformingCell>,
        dt: f64,
        excluded: &(dyn Fn(usize, usize) -> bool + Sync),
    ) {
        let (h, shift_velocity) = match cell {
            Some(c) => (c.h, c.vel_grad_times_prev_h),
            None => (Mat3::zeros(), Mat3::zeros()),
        };
        let inp = PairInputs {
            particles: p,
            h,
            shift_velocity,
            dt,
            friction: self.law.friction,
            excluded,
        };
        (
            self.list.par_chunks(PAIR_CHUNK),
            self.state.par_chunks_mut(PAIR_CHUNK),
            self.loads.par_chunks_mut(PAIR_CHUNK),
            self.chunk_sums.par_iter_mut(),
            self.held.par_chunks(PAIR_CHUNK),
            self.touching.par_iter_mut(),
        )
            .into_par_iter()
            .enumerate()
            .for_each(|(chunk, (list, state, loads, slot, held, touching))| {
                let mut sum = [0.0; 3];
                touching.clear();
                for (k, (((c, s), l), &h)) in list
                    .iter()
                    .zip(state.iter_mut())
                    .zip(loads.iter_mut())
                    .zip(held)
                    .enumerate()
                {
                    if h {
                        // Held by a bond: state and loads stay zero (set_excluded, rebuild).
                        continue;
                    }
                    let [e, d, a] = pair_kernel(&inp, c, s, l);
                    if s.active {
                        touching.push((chunk * PAIR_CHUNK + k) as u32);
                    }
                    sum[0] += e;
                    sum[1] += d;
                    sum[2] += a;
                }
                *slot = sum;
            });
        self.dissipated += self.chunk_sums.iter().map(|s| s[1]).sum::<f64>();
    }

    /// Sum each particle's contact loads in the list's order into `self.force`/`self.torque`:
    /// the pairs in touch, in list order, each added to both its particles (a particle's
    /// sum takes its pairs in list order, as a gather over its pairs would; every other pair's
    /// loads are zero, and adding +0 to a sum started at +0 changes no bit). Sequential: the
    /// same bits on any number of threads, and O(contacts) rather than O(listed pairs).
    fn gather(&mut self, n: usize) {
        self.force.resize(n, Vec3::zeros());
        self.torque.resize(n, Vec3::zeros());
        self.force.fill(Vec3::zeros());
        self.torque.fill(Vec3::zeros());
        for &k in self.touching.iter().flatten() {
            let (c, load) = (&self.list[k as usize], &self.loads[k as usize]);
            let (i, j) = (c.i as usize, c.j as usize);
            self.force[i] += load.force_i;
            self.torque[i] += load.torque_i;
            self.force[j] -= load.force_i;
            self.torque[j] += load.torque_j;
        }
    }
}

/// Max that propagates NaN (so a diverged position is noticed, not skipped).
fn nan_max(a: f64, b: f64) -> f64 {
    if a.is_nan() || b.is_nan() {
        f64::NAN
    } else {
        a.max(b)
    }
}

fn non_finite(p: &Particles) -> Error {
    let k = p
        .position
        .iter()
        .position(|x| !(x.x.is_finite() && x.y.is_finite() && x.z.is_finite()))
        .unwrap_or(0);
    Error::Degenerate(format!(
        "contacts: particle {k} has a position that is not finite ({:?}); the run diverged",
        p.position.get(k)
    ))
}

/// One pair: ScGeom kinematics and `Law2_ScGeom_FrictPhys_CundallStrack` (module docs).
/// Returns (elastic energy, dissipation of this step, 1 if in touch).
#[inline(always)]
fn pair_kernel(
    inp: &PairInputs,
    c: &Candidate,
    st: &mut PairState,
    out: &mut PairLoad,
) -> [f64; 3] {
    let p = inp.particles;
    let (i, j) = (c.i as usize, c.j as usize);
    let periodic = c.image != [0; 3];
    let cd = Vec3::new(c.image[0] as f64, c.image[1] as f64, c.image[2] as f64);
    let xi = p.position[i];
    let xj = if periodic {
        p.position[j] + inp.h * cd
    } else {
        p.position[j]
    };
    let l = xj - xi;
    let (ri, rj) = (p.radius[i], p.radius[j]);
    let d2 = l.norm_squared();
    let reach = ri + rj;
    // Clearly apart (|l|² above (R_i + R_j)² by far more than rounding): no square root; any
    // other pair takes the exact test below.
    let apart = d2 > reach * reach * (1.0 + 1e-9);
    let d = if apart { f64::INFINITY } else { d2.sqrt() };
    let pd = reach - d;
    if apart || pd < 0.0 || d.is_nan() || d == 0.0 || (inp.excluded)(i, j) {
        // Apart (YADE erases the interaction) or held by a bond: no contact, no memory. A
        // pair neither active nor carrying a broken bond's shear already has both zero.
        if st.active || st.carried {
            *st = PairState::default();
            *out = PairLoad::default();
        }
        return [0.0; 3];
    }
    let n = l * (1.0 / d);
    // ScGeom::precompute: rotation of the contact since the last step (none when new).
    let n_old = if st.active { st.normal } else { n };
    let (wi, wj) = (p.angular_velocity[i], p.angular_velocity[j]);
    let orthonormal_axis = n_old.cross(&n);
    let twist_axis = n_old * (inp.dt * 0.5 * n_old.dot(&(wi + wj)));
    let cp = xi + n * (ri - 0.5 * pd);
    let c1x = cp - xi;
    let c2x = cp - xj;
    let mut rel_vel = (p.velocity[j] + wj.cross(&c2x)) - (p.velocity[i] + wi.cross(&c1x));
    if periodic {
        rel_vel += inp.shift_velocity * cd;
    }
    let shear_inc = (rel_vel - n * n.dot(&rel_vel)) * inp.dt;
    let mut fs = st.shear_force;
    let fn_ = c.kn * pd;
    if !st.carried {
        fs -= fs.cross(&orthonormal_axis);
        fs -= fs.cross(&twist_axis);
        fs -= shear_inc * c.ks;
    }
    // Coulomb: |F_s| ≤ μ F_n; the excess is slip.
    let max_fs2 = (fn_ * fn_) * (inp.friction * inp.friction);
    let mut dissipated = 0.0;
    if fs.norm_squared() > max_fs2 {
        let ratio = max_fs2.sqrt() / fs.norm();
        let trial = fs;
        fs *= ratio;
        if c.ks > 0.0 && !st.carried {
            dissipated = ((trial - fs) / c.ks).dot(&fs);
        }
    }
    *st = PairState {
        normal: n,
        shear_force: fs,
        normal_force: fn_,
        overlap: pd,
        active: true,
        carried: false,
    };
    // Force on i (YADE applies −normalForce − shearForce to body 1), at the contact point.
    let force = -(n * fn_) - fs;
    *out = PairLoad {
        force_i: force,
        torque_i: c1x.cross(&force),
        torque_j: -c2x.cross(&force),
    };
    let mut elastic = 0.5 * fn_ * fn_ / c.kn;
    if c.ks > 0.0 {
        elastic += 0.5 * fs.norm_squared() / c.ks;
    }
    [elastic, dissipated, 1.0]
}

/// Every pair i < j (with j's periodic image, in cells relative to the unwrapped positions)
/// whose centre distance is at most R_i + R_j + `skin`, in canonical order (i, j, image).
/// `cutoff` ≥ 2R_max + skin sets the grid; with a cell H, the grid is in fractional
/// coordinates and `cutoff` must be below half of every cell height (so one image at most).
fn candidate_pairs(
    x: &[Vec3],
    r: &[f64],
    h: Option<Mat3>,
    cutoff: f64,
    skin: f64,
) -> Result<Vec<(u32, u32, [i32; 3])>> {
    let n = x.len();
    if n < 2 {
        return Ok(Vec::new());
    }
    let grid = Grid::new(x, h, cutoff)?;
    let blocks: Vec<Vec<(u32, u32, [i32; 3])>> = (0..n.div_ceil(PARTICLE_BLOCK))
        .into_par_iter()
        .map(|b| {
            let mut out = Vec::new();
            for i in b * PARTICLE_BLOCK..((b + 1) * PARTICLE_BLOCK).min(n) {
                let first = out.len();
                grid.for_each_neighbour(i, |j, m| {
                    if j <= i {
                        return;
                    }
                    let (image, branch) = match h {
                        Some(h) => {
                            let si = grid.shift[i];
                            let sj = grid.shift[j];
                            let cd = [
                                m[0] - sj[0] + si[0],
                                m[1] - sj[1] + si[1],
                                m[2] - sj[2] + si[2],
                            ];
                            let v = Vec3::new(cd[0] as f64, cd[1] as f64, cd[2] as f64);
                            let image = cd.map(|c| c as i32);
                            (image, x[j] + h * v - x[i])
                        }
                        None => ([0; 3], x[j] - x[i]),
                    };
                    // Clearly beyond the cutoff (|l|² above its square by far more than
                    // rounding): no square root; any other pair takes the exact test.
                    let reach = r[i] + r[j] + skin;
                    let d2 = branch.norm_squared();
                    if d2 <= reach * reach * (1.0 + 1e-9) && d2.sqrt() <= reach {
                        out.push((i as u32, j as u32, image));
                    }
                });
                out[first..].sort_unstable();
            }
            out
        })
        .collect();
    Ok(blocks.into_iter().flatten().collect())
}

/// A cell grid at least one cutoff wide per cell: in fractional coordinates of a periodic
/// cell (wrapped into [0, 1), each particle's wrap recorded in `shift`), or over the bounding
/// box of a free assembly.
struct Grid {
    dims: [i64; 3],
    periodic: bool,
    cell_of: Vec<[i64; 3]>,
    /// floor of the fractional coordinates (periodic only).
    shift: Vec<[i64; 3]>,
    start: Vec<usize>,
    members: Vec<u32>,
}

impl Grid {
    fn new(x: &[Vec3], h: Option<Mat3>, cutoff: f64) -> Result<Self> {
        let n = x.len();
        let width = cutoff * (1.0 + GRID_MARGIN);
        let mut dims = [1i64; 3];
        let mut coords: Vec<Vec3> = Vec::with_capacity(n);
        let mut shift = Vec::new();
        match h {
            Some(h) => {
                let h_inv = h.try_inverse().ok_or_else(|| {
                    Error::Degenerate("contacts: the periodic cell matrix H is singular".into())
                })?;
                let vol = h.determinant().abs();
                for (k, dim) in dims.iter_mut().enumerate() {
                    let (a, b) = (h.column((k + 1) % 3), h.column((k + 2) % 3));
                    let height = vol / a.cross(&b).norm();
                    if height.is_nan() || cutoff >= 0.5 * height {
                        return Err(Error::Invalid(format!(
                            "contacts: the neighbour cutoff 2·R_max + skin = {cutoff:e} m is not \
                             below half the periodic cell's height {height:e} m across its \
                             face {k}, so a pair could touch two images; use a larger cell or a \
                             smaller skin"
                        )));
                    }
                    *dim = ((height / width).floor() as i64).max(1);
                }
                shift.reserve(n);
                for p in x {
                    let s = h_inv * p;
                    let f = s.map(f64::floor);
                    shift.push([f.x as i64, f.y as i64, f.z as i64]);
                    coords.push(s - f);
                }
            }
            None => {
                let mut lo = Vec3::repeat(f64::INFINITY);
                let mut hi = Vec3::repeat(f64::NEG_INFINITY);
                for p in x {
                    lo = lo.inf(p);
                    hi = hi.sup(p);
                }
                let extent = hi - lo;
                for (dim, e) in dims.iter_mut().zip(extent.iter()) {
                    *dim = ((e / width).floor().min(1e6) as i64).max(1);
                }
                coords.extend(x.iter().map(|p| {
                    Vec3::from_fn(|k, _| {
                        if extent[k] > 0.0 {
                            (p[k] - lo[k]) / extent[k]
                        } else {
                            0.0
                        }
                    })
                }));
            }
        }
        // At most a few cells per particle (cells only grow wider: still ≥ one cutoff).
        let limit = (8 * n).max(27) as i64;
        while dims.iter().product::<i64>() > limit {
            let k = (0..3).max_by_key(|&k| dims[k]).unwrap_or(0);
            dims[k] -= (dims[k] / 8).max(1);
        }
        let cell_of: Vec<[i64; 3]> = coords
            .iter()
            .map(|g| {
                std::array::from_fn(|k| {
                    ((g[k] * dims[k] as f64).floor() as i64).clamp(0, dims[k] - 1)
                })
            })
            .collect();
        let flat = |c: &[i64; 3]| ((c[2] * dims[1] + c[1]) * dims[0] + c[0]) as usize;
        let n_cells = (dims[0] * dims[1] * dims[2]) as usize;
        let (start, members) =
            crate::packing::neighbours::bucket_by_cell(n_cells, n, |p| flat(&cell_of[p]));
        Ok(Grid {
            dims,
            periodic: h.is_some(),
            cell_of,
            shift,
            start,
            members,
        })
    }

    /// Call `f(j, m)` for every particle j of the 27 cells around particle `i`'s, with the
    /// image m (in cells) of the wrapped copy of j it is met in (zero when free). Distinct
    /// offsets give distinct (cell, image), so no (j, m) is met twice.
    fn for_each_neighbour(&self, i: usize, mut f: impl FnMut(usize, [i64; 3])) {
        let c = self.cell_of[i];
        let d = self.dims;
        for oz in -1..=1i64 {
            for oy in -1..=1i64 {
                for ox in -1..=1i64 {
                    let o = [ox, oy, oz];
                    let mut q = [0i64; 3];
                    let mut m = [0i64; 3];
                    let mut inside = true;
                    for k in 0..3 {
                        let v = c[k] + o[k];
                        if self.periodic {
                            m[k] = v.div_euclid(d[k]);
                            q[k] = v.rem_euclid(d[k]);
                        } else if v < 0 || v >= d[k] {
                            inside = false;
                        } else {
                            q[k] = v;
                        }
                    }
                    if !inside {
                        continue;
                    }
                    let flat = ((q[2] * d[1] + q[1]) * d[0] + q[0]) as usize;
                    for &j in &self.members[self.start[flat]..self.start[flat + 1]] {
                        f(j as usize, m);
                    }
                }
            }
        }
    }
}
