//! The explicit integrator: YADE's NewtonIntegrator (leapfrog, Cundall local damping on the
//! fluctuating velocity, the periodic cell's affine field with the one-step-late
//! `nextVelGrad`), the Love stress, energies, the critical time step and blow-up detection.

use super::breakage::{self, BondCriteria, BreakEvent};
use super::contacts::{Contacts, PairSet};
use super::laws::{BondContext, BondLaw, BOND_CHUNK};
use super::manybody::ManyBodyForces;
use super::quat::{spin_factors, Quat};
use super::state::{
    deterministic_sum, deterministic_sum_mat3, BondLoads, BondTopology, DeformingCell, MassOptions,
    Particles, UpdateConsts,
};
use crate::bonds::BondSet;
use crate::homogenize::network::{self, LeverArm};
use crate::packing::Packing;
use crate::{Error, Mat3, Result, Vec3};
use rayon::prelude::*;

/// Cundall's local damping λ of the accelerations `a` (in place) of a body of mass or
/// inertia `m` moving with `v` (the fluctuating velocity, or the spin), per component as
/// YADE's NewtonIntegrator damps translation and rotation alike. Returns the work terms
/// −dt·F_d·v̄ with F_d = −mλ·sign(s)·a and v̄ the mean of the half-step velocities.
#[inline(always)]
fn cundall_damping(a: &mut Vec3, v: &Vec3, m: f64, lambda: f64, dt: f64) -> [f64; 3] {
    let mut terms = [0.0; 3];
    for k in 0..3 {
        let s = a[k] * (v[k] + 0.5 * dt * a[k]);
        let sg = sign(s);
        let damped = a[k] * (1.0 - lambda * sg);
        terms[k] = m * lambda * sg * a[k] * (v[k] + 0.5 * dt * damped) * dt;
        a[k] = damped;
    }
    terms
}

/// One particle of YADE's NewtonIntegrator: Cundall damping on the fluctuating velocity,
/// leapfrog of translation and rotation, the periodic cell's affine terms, the spin
/// quaternion. Returns the kinetic energy at the force time and the six damping terms in
/// the order they are summed (the AVX2 path `particle_lanes::update4` repeats these
/// operations exactly).
#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn update_particle(
    c: &UpdateConsts,
    m: f64,
    inertia: f64,
    f: Vec3,
    t: Vec3,
    x: &mut Vec3,
    v: &mut Vec3,
    w: &mut Vec3,
    q: &mut Quat,
) -> (f64, [f64; 6]) {
    let (dt, lambda) = (c.dt, c.lambda);
    let mut terms = [0.0; 6];
    let fluct = if c.periodic { *v - c.prev_l * *x } else { *v };
    let inv_m = 1.0 / m;
    let mut a = f * inv_m;
    if lambda > 0.0 {
        terms[..3].copy_from_slice(&cundall_damping(&mut a, &fluct, m, lambda, dt));
    }
    let mut energy = 0.5 * m * (fluct + a * (0.5 * dt)).norm_squared();
    if c.periodic {
        a += c.prev_l * *v;
    }
    *v += a * dt;
    let inv_inertia = 1.0 / inertia;
    let mut alpha = t * inv_inertia;
    if lambda > 0.0 {
        terms[3..].copy_from_slice(&cundall_damping(&mut alpha, w, inertia, lambda, dt));
    }
    energy += 0.5 * inertia * (*w + alpha * (0.5 * dt)).norm_squared();
    *w += alpha * dt;
    if c.periodic {
        *v += c.dl * *x;
    }
    *x += *v * dt;
    if c.periodic {
        *w += c.dspin;
    }
    let angle2 = w.norm_squared();
    if angle2 != 0.0 {
        let (cos_h, sin_h_over_w) = spin_factors(angle2, 0.5 * dt);
        let dq = Quat {
            w: cos_h,
            v: *w * sin_h_over_w,
        };
        *q = dq.mul(q);
    }
    // Normalise by one reciprocal (the AVX2 path does the same).
    let norm = (q.v.x * q.v.x + q.v.y * q.v.y + q.v.z * q.v.z + q.w * q.w).sqrt();
    if norm > 0.0 {
        let inv = 1.0 / norm;
        q.w *= inv;
        q.v *= inv;
    }
    (energy, terms)
}

/// Where the resultant force and torque on a particle come from: its bond loads, in the
/// fixed CSR order of the topology (so the sum has the same bits on any thread count), and
/// the external forces if any.
struct Resultants<'a> {
    start: &'a [usize],
    entries: &'a [u32],
    loads: &'a [super::state::BondLoad],
    external: Option<&'a ExternalForces>,
    /// Contact forces and torques per particle, if contacts are on.
    contact: Option<(&'a [Vec3], &'a [Vec3])>,
    /// The many-body term's halves per bond end, if it is on: +g_b on i_b, −g_b on j_b with
    /// g_b the sum of the bond's two halves (docs/manybody.md "Integrator"), gathered here
    /// rather than in a pass of its own.
    manybody: Option<&'a [[f64; 3]]>,
    /// The AVX2 kernels run.
    lanes: bool,
}

impl Resultants<'_> {
    /// Resultant force and torque on particle `k`. Branch-free (the side of each bond is
    /// unpredictable): f ± force_i as f + (±1)·force_i, which IEEE makes bit-identical to
    /// f + x / f − x.
    #[inline(always)]
    fn at(&self, k: usize) -> (Vec3, Vec3) {
        let mut f = match self.external {
            Some(e) => e.force[k] * e.scale,
            None => Vec3::zeros(),
        };
        let entries = &self.entries[self.start[k]..self.start[k + 1]];
        #[cfg(target_arch = "x86_64")]
        let lanes = self.lanes;
        #[cfg(not(target_arch = "x86_64"))]
        let lanes = false;
        let mut t = Vec3::zeros();
        // The term's force, when summed with the bond loads.
        let mut term = None;
        if lanes {
            #[cfg(target_arch = "x86_64")]
            {
                use super::particle_lanes::{gather_bond_loads, gather_bond_loads_and_term};
                // SAFETY: `lanes` is set only where the CPU has AVX2; the halves hold
                // 2·bonds + 1 entries (asserted in `Simulation::integrate_particles`).
                (f, t) = match self.manybody {
                    Some(half) => {
                        let (f, t, g) =
                            unsafe { gather_bond_loads_and_term(f, entries, self.loads, half) };
                        term = Some(g);
                        (f, t)
                    }
                    None => unsafe { gather_bond_loads(f, entries, self.loads) },
                };
            }
        } else {
            for &e in entries {
                let load = &self.loads[(e >> 1) as usize];
                let j_side = e & 1 == 1;
                let sign = if j_side { -1.0 } else { 1.0 };
                let torque = if j_side {
                    &load.torque_j
                } else {
                    &load.torque_i
                };
                f += load.force_i * sign;
                t += torque;
            }
        }
        if let Some((cf, ct)) = self.contact {
            f += cf[k];
            t += ct[k];
        }
        if let Some(half) = self.manybody {
            f += term.unwrap_or_else(|| super::manybody::term_force(entries, half));
        }
        (f, t)
    }
}

/// One chunk's particle state, updated in place, and its resultants, written out.
struct ChunkSlices<'c> {
    x: &'c mut [Vec3],
    v: &'c mut [Vec3],
    w: &'c mut [Vec3],
    q: &'c mut [Quat],
    force: &'c mut [Vec3],
    torque: &'c mut [Vec3],
}

/// Energy sums of one chunk in particle order: kinetic energy at the force time, and the
/// Cundall damping terms (summed only when λ > 0).
struct ChunkEnergy {
    damped: bool,
    kinetic: f64,
    dissipated: f64,
}

impl ChunkEnergy {
    /// Add one particle's kinetic energy and damping terms.
    #[inline(always)]
    fn add(&mut self, energy: f64, terms: &[f64; 6]) {
        if self.damped {
            for d in terms {
                self.dissipated += d;
            }
        }
        self.kinetic += energy;
    }
}

/// One step's particle update, shared by every chunk: the constants, the resultants, the
/// masses and whether the AVX2 lanes run.
struct ParticleUpdate<'a> {
    consts: &'a UpdateConsts,
    resultants: Resultants<'a>,
    mass: &'a [f64],
    inertia: &'a [f64],
    lanes: bool,
}

impl ParticleUpdate<'_> {
    /// Update the chunk whose first particle is `base` (AVX2 lanes of four where they run,
    /// then one by one); returns its [kinetic, dissipated] sums.
    fn chunk(&self, base: usize, mut s: ChunkSlices) -> [f64; 2] {
        let mut sum = ChunkEnergy {
            damped: self.consts.lambda > 0.0,
            kinetic: 0.0,
            dissipated: 0.0,
        };
        #[cfg(target_arch = "x86_64")]
        let mut l = if self.lanes {
            self.chunk_lanes(base, &mut s, &mut sum)
        } else {
            0
        };
        #[cfg(not(target_arch = "x86_64"))]
        let mut l = 0;
        while l < s.x.len() {
            let k = base + l;
            let (f, t) = self.resultants.at(k);
            s.force[l] = f;
            s.torque[l] = t;
            let (energy, terms) = update_particle(
                self.consts,
                self.mass[k],
                self.inertia[k],
                f,
                t,
                &mut s.x[l],
                &mut s.v[l],
                &mut s.w[l],
                &mut s.q[l],
            );
            sum.add(energy, &terms);
            l += 1;
        }
        [sum.kinetic, sum.dissipated]
    }

    /// The AVX2 lanes of [`Self::chunk`]: four particles at a time from the chunk's start
    /// while four remain (`particle_lanes::update4` repeats [`update_particle`] exactly);
    /// returns how many it updated.
    #[cfg(target_arch = "x86_64")]
    fn chunk_lanes(&self, base: usize, s: &mut ChunkSlices, sum: &mut ChunkEnergy) -> usize {
        use super::laws::lanes::each_lane;
        const L: usize = super::laws::lanes::LANES;
        let mut l = 0;
        while l + L <= s.x.len() {
            // Loops, not `from_fn`/`map` (see `each_lane!`).
            let (mut f, mut t) = ([Vec3::zeros(); L], [Vec3::zeros(); L]);
            for m in 0..L {
                (f[m], t[m]) = self.resultants.at(base + l + m);
                (s.force[l + m], s.torque[l + m]) = (f[m], t[m]);
            }
            // SAFETY: AVX2 is available (the caller checked); every slice has L elements
            // from l on (l + L ≤ chunk length, all chunks alike).
            let (energy, terms) = unsafe {
                super::particle_lanes::update4(
                    self.consts,
                    each_lane!(|m| self.mass[base + l + m]),
                    each_lane!(|m| self.inertia[base + l + m]),
                    f,
                    t,
                    &mut s.x[l..l + L],
                    &mut s.v[l..l + L],
                    &mut s.w[l..l + L],
                    &mut s.q[l..l + L],
                )
            };
            for m in 0..L {
                sum.add(energy[m], &terms[m]);
            }
            l += L;
        }
        l
    }
}

/// Particles per parallel work item of the integrator (fixed, so that per-chunk energy sums
/// are the same on any number of threads).
const PARTICLE_CHUNK: usize = 512;

/// Integrator settings.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DemOptions {
    /// Time step (s); `None` = `safety` × the critical estimate.
    pub time_step: Option<f64>,
    /// Safety factor on the critical time step (used when `time_step` is None, and in the
    /// time step recommended by blow-up errors).
    pub safety: f64,
    /// Cundall local damping λ ∈ [0, 1) (YADE `NewtonIntegrator.damping`).
    pub local_damping: f64,
    /// Masses from a density.
    pub mass: MassOptions,
    /// Steps between energy checks for blow-up (0 disables the check).
    pub check_interval: usize,
    /// Use the AVX2 kernels of law (a) and of the particle update where the CPU has them
    /// (default); `false` runs the scalar kernels, which give the same bits (for checking
    /// exactly that).
    pub simd: bool,
}

impl Default for DemOptions {
    fn default() -> Self {
        DemOptions {
            time_step: None,
            safety: 0.8,
            local_damping: 0.0,
            mass: MassOptions::default(),
            check_interval: 20,
            simd: true,
        }
    }
}

/// Energy ledger (J).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Energies {
    /// Kinetic energy of the fluctuating motion, translational + rotational, at the force
    /// evaluation time t (leapfrog mid-point velocities v(t−dt/2) + a·dt/2).
    pub kinetic: f64,
    /// Elastic energy stored in the bonds at t.
    pub elastic: f64,
    /// Energy removed by Cundall local damping so far: per step and component −dt·F_d·v̄,
    /// the damping force F_d = −λ·sign(F·v̄)·F against the mean v̄ of the half-step
    /// velocities (the leapfrog's discrete work, so the ledger closes to second order in dt).
    pub local_damping: f64,
    /// Energy removed by viscous bond damping so far.
    pub viscous_damping: f64,
    /// Energy released by the bonds broken so far, Σ [`BreakEvent::energy`]: each bond's
    /// elastic energy at the evaluation where it broke, plus half the work of its loads over
    /// the last step (not yet passed on by the leapfrog), less what a contact of its pair
    /// took on in that step (docs/strength.md, "Breaking in the integrator").
    pub broken_bonds: f64,
    /// Elastic energy stored in the frictional contacts at t (0 until contacts are on).
    pub contact_elastic: f64,
    /// Energy dissipated by contact friction so far (0 until contacts are on).
    pub friction: f64,
    /// Energy of the many-body term at t, Σ_p ½ V_p E_p : D : E_p (0 without it;
    /// docs/manybody.md).
    pub manybody: f64,
}

impl Energies {
    /// Kinetic + elastic.
    pub fn mechanical(&self) -> f64 {
        self.kinetic + self.elastic + self.manybody
    }

    /// Where the work done on the assembly went: kinetic + bond and contact elastic +
    /// local and viscous damping + broken bonds + friction. Equals the initial kinetic and
    /// elastic energy plus the work of the held particles and external forces (the energy
    /// check of a run; the work summed by the trapezoid rule between force evaluations).
    /// Measured through failure with contacts at the default time step: within 1e-3
    /// (docs/strength.md, "Breaking in the integrator").
    pub fn accounted(&self) -> f64 {
        self.kinetic
            + self.elastic
            + self.contact_elastic
            + self.local_damping
            + self.viscous_damping
            + self.broken_bonds
            + self.friction
            + self.manybody
    }
}

/// Critical time step estimate and the assembly's weak spots.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct StabilityReport {
    /// Leapfrog limit 2/ω_max with ω_max² bounded above by Gershgorin's theorem on the
    /// mass-scaled 6-DOF stiffness matrix (translation and rotation; a rigorous upper bound
    /// of the highest frequency, so this critical step is a lower bound of the true one) (s).
    pub critical_time_step: f64,
    /// Particle whose Gershgorin row is largest (the stiffest/lightest).
    pub stiffest_particle: usize,
    /// Particles without bonds (they float freely).
    pub unbonded_particles: Vec<usize>,
    /// Particles with one bond: free rotations and a free swing about their partner.
    pub one_bond_particles: Vec<usize>,
    /// Particles with two bonds: a free rotation about the line through the contacts
    /// (docs/references.md, null space).
    pub two_bond_particles: Vec<usize>,
}

/// A bonded assembly being integrated.
pub struct Simulation {
    /// Particle state.
    pub particles: Particles,
    /// The periodic cell (None: a free assembly).
    pub cell: Option<DeformingCell>,
    /// Bond topology.
    pub topology: BondTopology,
    /// Bond loads of the last force evaluation.
    pub loads: BondLoads,
    /// Resultant force on each particle at the last evaluation (N).
    pub force: Vec<Vec3>,
    /// Resultant torque on each particle at the last evaluation (N·m).
    pub torque: Vec<Vec3>,
    law: Box<dyn BondLaw>,
    dt: f64,
    local_damping: f64,
    safety: f64,
    check_interval: usize,
    simd: bool,
    iteration: u64,
    time: f64,
    kinetic: f64,
    local_dissipated: f64,
    /// (kinetic energy, locally dissipated energy) per particle chunk of the last step.
    energy_scratch: Vec<[f64; 2]>,
    stability: StabilityReport,
    watch: Vec<f64>,
    free_volume: f64,
    prescribed: Option<HeldParticles>,
    external: Option<ExternalForces>,
    /// Failure criteria judged after every force evaluation (None: bonds never break).
    criteria: Option<BondCriteria>,
    /// Per bond: not broken.
    intact: Vec<bool>,
    /// Bonds broken so far, in breaking order.
    break_events: Vec<BreakEvent>,
    /// Σ of the broken bonds' elastic energies (J).
    broken_energy: f64,
    /// Frictional contacts between spheres not held by an intact bond (None: off).
    contacts: Option<Contacts>,
    /// The many-body term (None: off; [`Simulation::with_manybody`]).
    manybody: Option<ManyBodyForces>,
}

/// Per-particle external forces (N), e.g. a pressure on exposed surface particles: each
/// step adds `scale × force[k]` to particle k's resultant before the leapfrog update, so a
/// ramped or pulsed load is one vector and a scale set before every step
/// ([`Simulation::set_external_force_scale`]). Their work is not in [`Energies`].
#[derive(Clone, Debug, PartialEq)]
pub struct ExternalForces {
    /// Force on every particle at scale 1 (N), one per particle.
    pub force: Vec<Vec3>,
    /// Current multiplier (dimensionless).
    pub scale: f64,
}

/// The held particles' own state, advanced exactly (no round trip through the leapfrog).
#[derive(Clone, Debug)]
struct HeldParticles {
    motion: PrescribedMotion,
    position: Vec<Vec3>,
    orientation: Vec<Quat>,
}

/// Particles whose motion is prescribed (YADE's `blockedDOFs`): grip elements of a free
/// assembly (Truszkowska 2018 Sec. 4.1, Eqs. 17–22). After every integrator pass they are
/// moved by their prescribed velocity, with zero spin and unchanged orientation, whatever
/// the forces on them; the forces stay readable in [`Simulation::force`] (grip reactions).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct PrescribedMotion {
    /// The particles held (indices, each at most once).
    pub particles: Vec<usize>,
    /// Their translational velocity (m/s), one per entry of `particles`.
    pub velocity: Vec<Vec3>,
}

impl Clone for Simulation {
    fn clone(&self) -> Self {
        Simulation {
            particles: self.particles.clone(),
            cell: self.cell.clone(),
            topology: self.topology.clone(),
            loads: self.loads.clone(),
            force: self.force.clone(),
            torque: self.torque.clone(),
            law: self.law.box_clone(),
            dt: self.dt,
            local_damping: self.local_damping,
            safety: self.safety,
            check_interval: self.check_interval,
            simd: self.simd,
            iteration: self.iteration,
            time: self.time,
            kinetic: self.kinetic,
            local_dissipated: self.local_dissipated,
            energy_scratch: self.energy_scratch.clone(),
            stability: self.stability.clone(),
            watch: self.watch.clone(),
            free_volume: self.free_volume,
            prescribed: self.prescribed.clone(),
            external: self.external.clone(),
            criteria: self.criteria.clone(),
            intact: self.intact.clone(),
            break_events: self.break_events.clone(),
            broken_energy: self.broken_energy,
            contacts: self.contacts.clone(),
            manybody: self.manybody.clone(),
        }
    }
}

impl Simulation {
    /// Set up a bonded packing at rest: every bond is stress-free in this configuration.
    /// `law` must carry one spring set per bond of `bonds`.
    pub fn new(
        packing: &Packing,
        bonds: &BondSet,
        law: Box<dyn BondLaw>,
        opts: &DemOptions,
    ) -> Result<Self> {
        Simulation::with_manybody(packing, bonds, law, None, opts)
    }

    /// [`Simulation::new`] with the many-body term `manybody` built on the same packing
    /// and bonds (Green–Lagrange; docs/manybody.md "Integrator"): its forces join the
    /// resultants every step, its energy [`Energies::manybody`], its virial the stress, its
    /// Hessian the critical time step's Gershgorin bound. Refused ([`Error::Invalid`]) with
    /// the small-strain measure or a term of other bonds or another state.
    pub fn with_manybody(
        packing: &Packing,
        bonds: &BondSet,
        law: Box<dyn BondLaw>,
        manybody: Option<crate::manybody::ManyBody>,
        opts: &DemOptions,
    ) -> Result<Self> {
        if !(opts.local_damping.is_finite() && (0.0..1.0).contains(&opts.local_damping)) {
            return Err(Error::Invalid(format!(
                "local damping must be in [0, 1), got {}",
                opts.local_damping
            )));
        }
        if !(opts.safety.is_finite() && opts.safety > 0.0 && opts.safety <= 1.0) {
            return Err(Error::Invalid(format!(
                "time-step safety factor must be in (0, 1], got {}",
                opts.safety
            )));
        }
        let particles = Particles::from_packing(packing, &opts.mass)?;
        let topology = BondTopology::new(bonds, packing.len())?;
        let cell = packing.cell.map(|c| DeformingCell::new(c.lengths));
        let n = particles.len();
        let mut sim = Simulation {
            particles,
            cell,
            loads: BondLoads::zeros(topology.len()),
            topology,
            force: vec![Vec3::zeros(); n],
            torque: vec![Vec3::zeros(); n],
            law: Box::new(NoLaw),
            dt: 0.0,
            local_damping: opts.local_damping,
            safety: opts.safety,
            check_interval: opts.check_interval,
            simd: opts.simd,
            iteration: 0,
            time: 0.0,
            kinetic: 0.0,
            local_dissipated: 0.0,
            energy_scratch: vec![[0.0; 2]; n.div_ceil(PARTICLE_CHUNK)],
            stability: StabilityReport::default(),
            watch: Vec::new(),
            free_volume: packing.volume(),
            prescribed: None,
            external: None,
            criteria: None,
            intact: vec![true; bonds.len()],
            break_events: Vec::new(),
            broken_energy: 0.0,
            contacts: None,
            manybody: None,
        };
        if let Some(term) = manybody {
            let h = sim.cell.as_ref().map(|c| c.h);
            sim.manybody = Some(ManyBodyForces::new(
                term,
                &sim.particles,
                &sim.topology,
                h.as_ref(),
            )?);
        }
        let mut law = law;
        law.initialize(
            &sim.context_parts()
                .as_context(&sim.particles, &sim.topology),
        )?;
        sim.law = law;
        sim.stability = sim.compute_stability()?;
        sim.dt = match opts.time_step {
            Some(dt) if dt.is_finite() && dt > 0.0 => dt,
            Some(dt) => {
                return Err(Error::Invalid(format!(
                    "time step must be finite and > 0 s, got {dt}"
                )));
            }
            None => {
                if !sim.stability.critical_time_step.is_finite() {
                    return Err(Error::Invalid(
                        "no time step given and none can be estimated: the assembly has no stiff bond"
                            .into(),
                    ));
                }
                sim.safety * sim.stability.critical_time_step
            }
        };
        Ok(sim)
    }

    /// The bond law.
    pub fn law(&self) -> &dyn BondLaw {
        self.law.as_ref()
    }

    /// Time step (s).
    pub fn time_step(&self) -> f64 {
        self.dt
    }

    /// Change the time step (s).
    pub fn set_time_step(&mut self, dt: f64) -> Result<()> {
        if !(dt.is_finite() && dt > 0.0) {
            return Err(Error::Invalid(format!(
                "time step must be finite and > 0 s, got {dt}"
            )));
        }
        self.dt = dt;
        Ok(())
    }

    /// Change the Cundall local damping λ ∈ [0, 1).
    pub fn set_local_damping(&mut self, lambda: f64) -> Result<()> {
        if !(lambda.is_finite() && (0.0..1.0).contains(&lambda)) {
            return Err(Error::Invalid(format!(
                "local damping must be in [0, 1), got {lambda}"
            )));
        }
        self.local_damping = lambda;
        Ok(())
    }

    /// Steps done.
    pub fn iteration(&self) -> u64 {
        self.iteration
    }

    /// Simulated time (s).
    pub fn time(&self) -> f64 {
        self.time
    }

    /// Critical time step and weakly bonded particles.
    pub fn stability(&self) -> &StabilityReport {
        &self.stability
    }

    /// Request a velocity gradient L (1/s) for the periodic cell, with YADE's timing: the
    /// particles' affine velocity changes in this coming step's integrator, the cell (and
    /// the periodic shift) follows in the step after. Errors on a free assembly.
    pub fn set_velocity_gradient(&mut self, l: Mat3) -> Result<()> {
        match &mut self.cell {
            Some(c) => {
                c.set_velocity_gradient(l);
                Ok(())
            }
            None => Err(Error::Invalid(
                "a velocity gradient needs a periodic cell; this assembly is not periodic".into(),
            )),
        }
    }

    /// Hold particles at a prescribed velocity (None releases them). Errors on an index out
    /// of range, a repeated index, a non-finite velocity or mismatched lengths. The
    /// particles' current velocities and spins are set at once (kinetic-energy and damping
    /// ledgers still include what the integrator computed for them before the overwrite).
    pub fn set_prescribed_motion(&mut self, motion: Option<PrescribedMotion>) -> Result<()> {
        if let Some(m) = &motion {
            let n = self.particles.len();
            if m.particles.len() != m.velocity.len() {
                return Err(Error::Invalid(format!(
                    "prescribed motion: {} particles but {} velocities",
                    m.particles.len(),
                    m.velocity.len()
                )));
            }
            let mut seen = vec![false; n];
            for (&p, v) in m.particles.iter().zip(&m.velocity) {
                if p >= n || seen[p] {
                    return Err(Error::Invalid(format!(
                        "prescribed motion: particle {p} is out of range (< {n}) or repeated"
                    )));
                }
                seen[p] = true;
                if v.iter().any(|c| !c.is_finite()) {
                    return Err(Error::Invalid(format!(
                        "prescribed motion: particle {p} has a non-finite velocity"
                    )));
                }
            }
            for (&p, v) in m.particles.iter().zip(&m.velocity) {
                self.particles.velocity[p] = *v;
                self.particles.angular_velocity[p] = Vec3::zeros();
            }
        }
        let p = &self.particles;
        self.prescribed = motion.map(|m| HeldParticles {
            position: m.particles.iter().map(|&k| p.position[k]).collect(),
            orientation: m.particles.iter().map(|&k| p.orientation[k]).collect(),
            motion: m,
        });
        Ok(())
    }

    /// Apply external forces (N, one per particle, at scale 1; None removes them). Errors on
    /// a wrong length or a non-finite force.
    pub fn set_external_forces(&mut self, force: Option<Vec<Vec3>>) -> Result<()> {
        if let Some(f) = &force {
            if f.len() != self.particles.len() {
                return Err(Error::Invalid(format!(
                    "external forces: {} given for {} particles",
                    f.len(),
                    self.particles.len()
                )));
            }
            if let Some(k) = f.iter().position(|v| v.iter().any(|c| !c.is_finite())) {
                return Err(Error::Invalid(format!(
                    "external forces: particle {k} has a non-finite force"
                )));
            }
        }
        self.external = force.map(|force| ExternalForces { force, scale: 1.0 });
        Ok(())
    }

    /// Multiply the external forces by `scale` from the next step on (a ramp or pulse);
    /// errors when none are set or the scale is not finite.
    pub fn set_external_force_scale(&mut self, scale: f64) -> Result<()> {
        if !scale.is_finite() {
            return Err(Error::Invalid(format!(
                "external force scale must be finite, got {scale}"
            )));
        }
        match &mut self.external {
            Some(e) => {
                e.scale = scale;
                Ok(())
            }
            None => Err(Error::Invalid(
                "external force scale: no external forces are set".into(),
            )),
        }
    }

    /// The external forces in force, if any.
    pub fn external_forces(&self) -> Option<&ExternalForces> {
        self.external.as_ref()
    }

    /// The prescribed motion in force, if any.
    pub fn prescribed_motion(&self) -> Option<&PrescribedMotion> {
        self.prescribed.as_ref().map(|h| &h.motion)
    }

    /// Let bonds break by `criteria` from the next step on (None: no more breaking; bonds
    /// broken so far stay broken). Refuses criteria for another number of bonds or for
    /// another bond law than this simulation's.
    pub fn set_breakage(&mut self, criteria: Option<BondCriteria>) -> Result<()> {
        if criteria.is_some() && self.manybody.is_some() {
            return Err(Error::Invalid(
                "breakage with the many-body term: not supported yet (the term's fits are built \
                 once from the intact bonds, and a broken bond would have to leave them); run \
                 the breaking test without [manybody]"
                    .into(),
            ));
        }
        if let Some(c) = &criteria {
            if c.len() != self.topology.len() {
                return Err(Error::Invalid(format!(
                    "breakage: criteria for {} bonds, but the assembly has {}",
                    c.len(),
                    self.topology.len()
                )));
            }
            let want = breakage::law_name(c.law());
            if want != self.law.name() {
                return Err(Error::Invalid(format!(
                    "breakage: criteria made for bond law `{want}`, but the simulation runs `{}`",
                    self.law.name()
                )));
            }
        }
        self.criteria = criteria;
        Ok(())
    }

    /// Turn frictional contacts on (None: off) between the spheres that no intact bond
    /// holds: broken bonds' pairs (with the bond's k_n, k_s from the moment it breaks, as
    /// YADE keeps a broken cohesive bond's springs; bonds broken before this call take the
    /// contact law's) and any spheres that come into touch. Their forces are added to the
    /// resultants from the next step on; [`Energies::contact_elastic`] and
    /// [`Energies::friction`] count them, [`Simulation::stress`] includes them. The critical
    /// time step is not re-estimated: contact springs stiffer than the bonds need a smaller
    /// [`Simulation::set_time_step`].
    pub fn set_contacts(&mut self, mut contacts: Option<Contacts>) -> Result<()> {
        let t = &self.topology;
        if let Some(c) = &mut contacts {
            // The pairs of intact bonds, excluded by a flag per listed pair.
            c.set_excluded(PairSet::new(
                (0..t.len())
                    .filter(|&b| self.intact[b])
                    .map(|b| (t.i[b] as usize, t.j[b] as usize)),
            ));
        }
        self.contacts = contacts;
        Ok(())
    }

    /// The contacts, if on.
    pub fn contacts(&self) -> Option<&Contacts> {
        self.contacts.as_ref()
    }

    /// The many-body term, if on.
    pub fn manybody(&self) -> Option<&crate::manybody::ManyBody> {
        self.manybody.as_ref().map(|m| m.term())
    }

    /// The many-body term's force g_b on bond `b`'s i end at the last evaluation (N; −g_b on
    /// its j end), if the term is on: its share of the bond's virial.
    pub(crate) fn manybody_bond_force(&self, b: usize) -> Option<Vec3> {
        self.manybody.as_ref().map(|m| m.bond_force(b))
    }

    /// The failure criteria in force, if any.
    pub fn breakage(&self) -> Option<&BondCriteria> {
        self.criteria.as_ref()
    }

    /// The bonds broken so far, in breaking order (by step, then bond index).
    pub fn break_events(&self) -> &[BreakEvent] {
        &self.break_events
    }

    /// Whether bond `b` is not broken (panics if `b` is out of range).
    pub fn is_intact(&self, b: usize) -> bool {
        self.intact[b]
    }

    /// Number of bonds not broken.
    pub fn intact_count(&self) -> usize {
        self.intact.len() - self.break_events.len()
    }

    /// Judge every intact bond on the loads just computed, in parallel over fixed chunks of
    /// bonds (the verdicts do not depend on the thread count), then break the failed ones in
    /// bond order: [`BondLaw::break_bond`], their loads zeroed for this step's update, an
    /// event each.
    ///
    /// Timing as LAMMPS's `bpm/rotational`: a bond whose loads meet its criterion at this
    /// evaluation applies nothing in this step (LAMMPS skips it in `compute` and drops it
    /// from the bond list). YADE differs (`Law2_ScGeom6D_CohFrictPhys_CohesionMoment`): a
    /// bond broken in tension stops at once too, but one broken in shear keeps its
    /// compression and its shear force capped at the Coulomb limit in that step, as a
    /// frictional contact. Without contacts both give nothing here.
    fn break_failed_bonds(&mut self) -> Result<()> {
        let Some(criteria) = &self.criteria else {
            return Ok(());
        };
        let n = self.topology.len();
        let law = self.law.as_ref();
        let particles = &self.particles;
        let intact = &self.intact;
        let failed: Vec<Vec<(usize, crate::strength::Failure)>> = (0..n.div_ceil(BOND_CHUNK))
            .into_par_iter()
            .map(|c| {
                let first = c * BOND_CHUNK;
                let mut out = Vec::new();
                let len = BOND_CHUNK.min(n - first);
                criteria.failed_in_chunk(law, particles, first, len, intact, &mut out);
                out
            })
            .collect();
        for (b, f) in failed.into_iter().flatten() {
            if let Some(c) = &mut self.contacts {
                // The pair becomes a frictional contact with the bond's springs (YADE's
                // CohFrictPhys keeps them after cohesion breaks), unless another intact
                // bond (another periodic image) still holds it.
                let (i, j) = (self.topology.i[b] as usize, self.topology.j[b] as usize);
                let (kn, ks, _, _) = self.law.springs(b);
                let held_elsewhere = (self.topology.start[i]..self.topology.start[i + 1])
                    .map(|e| (self.topology.entries[e] >> 1) as usize)
                    .any(|o| {
                        o != b
                            && self.intact[o]
                            && (self.topology.i[o] as usize).max(self.topology.j[o] as usize)
                                == i.max(j)
                            && (self.topology.i[o] as usize).min(self.topology.j[o] as usize)
                                == i.min(j)
                    });
                if !held_elsewhere {
                    c.include_pair(i, j);
                }
                c.set_pair_stiffness(i, j, kn, ks)?;
                // YADE keeps a bond broken in shear as a contact with its shear force, capped
                // at μ·F_n in this step (`BondCriterion::handed_on_shear`).
                let handed = criteria
                    .get(b)
                    .handed_on_shear(self.law.as_ref(), b, f.mode);
                if let (Some(shear), false) = (handed, held_elsewhere) {
                    let d = self.topology.cell_dist[b];
                    let image = [d.x, d.y, d.z].map(|v| v.round() as i32);
                    c.carry_shear(i, j, image, shear)?;
                }
            }
            let elastic = self.law.break_bond(&self.particles, b);
            let energy = elastic + 0.5 * self.dt * self.bond_load_power(b);
            self.loads.per_bond[b] = Default::default();
            self.intact[b] = false;
            self.broken_energy += energy;
            self.break_events.push(BreakEvent {
                bond: b,
                step: self.iteration,
                time: self.time,
                mode: f.mode,
                index: f.index,
                energy,
            });
        }
        Ok(())
    }

    /// Power of bond `b`'s loads of this evaluation, Σ(f·v + t·ω) over its two ends with the
    /// half-step velocities v(t − dt/2) (j's periodic image moving at v_j + L·H_prev·c): the
    /// loads' work over the last step, x(t) − x(t − dt) = dt·v(t − dt/2), is dt times this.
    fn bond_load_power(&self, b: usize) -> f64 {
        let (i, j) = (self.topology.i[b] as usize, self.topology.j[b] as usize);
        let p = &self.particles;
        let load = &self.loads.per_bond[b];
        let shift = self.cell.as_ref().map_or(Vec3::zeros(), |c| {
            c.vel_grad_times_prev_h * self.topology.cell_dist[b]
        });
        load.force_i.dot(&(p.velocity[i] - p.velocity[j] - shift))
            + load.torque_i.dot(&p.angular_velocity[i])
            + load.torque_j.dot(&p.angular_velocity[j])
    }

    /// One step: cell update, bond forces, gather, leapfrog (YADE's step order).
    pub fn step(&mut self) -> Result<()> {
        let dt = self.dt;
        if let Some(c) = &mut self.cell {
            c.integrate(dt);
        }
        {
            let ctx = self.context_parts();
            let mut loads = std::mem::take(&mut self.loads);
            self.law
                .compute(&ctx.as_context(&self.particles, &self.topology), &mut loads);
            self.loads = loads;
        }
        if let Some(m) = &mut self.manybody {
            let h = self.cell.as_ref().map(|c| c.h);
            m.compute(&self.particles, &self.topology, h.as_ref(), self.simd);
        }
        let first_new = self.break_events.len();
        if self.criteria.is_some() {
            self.break_failed_bonds()?;
        }
        if let Some(c) = &mut self.contacts {
            // Intact bonds' pairs are excluded by flags (Contacts::set_excluded).
            c.update(&self.particles, self.cell.as_ref(), dt, &|_, _| false)?;
            // A pair whose bond broke in this step and that touches carries on part of the
            // bond's energy as a contact (its compression, with the bond's k_n): the break
            // released only the rest.
            for e in &mut self.break_events[first_new..] {
                let b = e.bond;
                let (i, j) = (self.topology.i[b] as usize, self.topology.j[b] as usize);
                let taken = c.pair_ledger(i, j, &self.particles, self.cell.as_ref(), dt);
                e.energy -= taken;
                self.broken_energy -= taken;
            }
        }
        let consts = self.integrate_particles();
        if let Some(held) = &mut self.prescribed {
            let (kinetic, dissipated) =
                held_ledger_correction(&consts, &self.particles, held, &self.force, &self.torque);
            self.kinetic += kinetic;
            if consts.lambda > 0.0 {
                self.local_dissipated += dissipated;
            }
            apply_prescribed_motion(&mut self.particles, held, dt);
        }
        self.iteration += 1;
        self.time += dt;
        if self.check_interval > 0 && self.iteration.is_multiple_of(self.check_interval as u64) {
            self.watchdog()?;
        }
        Ok(())
    }

    fn context_parts(&self) -> ContextParts {
        let (h, sv) = match &self.cell {
            Some(c) => (c.h, c.vel_grad_times_prev_h),
            None => (Mat3::zeros(), Mat3::zeros()),
        };
        ContextParts {
            h,
            sv,
            dt: self.dt,
            simd: self.simd,
        }
    }

    /// Run `steps` steps, reporting the fraction done to `progress` every 1 %.
    pub fn run(&mut self, steps: usize, progress: &(dyn Fn(f64) + Sync)) -> Result<()> {
        let every = (steps / 100).max(1);
        for s in 0..steps {
            self.step()?;
            if (s + 1) % every == 0 {
                progress((s + 1) as f64 / steps as f64);
            }
        }
        Ok(())
    }

    /// The leapfrog pass over all particles (YADE's NewtonIntegrator), in fixed chunks of
    /// [`PARTICLE_CHUNK`] whose energy sums are added in chunk order; returns the constants
    /// it used.
    fn integrate_particles(&mut self) -> UpdateConsts {
        let consts = self.update_consts();
        #[cfg(target_arch = "x86_64")]
        let lanes = self.simd && std::arch::is_x86_feature_detected!("avx2");
        #[cfg(not(target_arch = "x86_64"))]
        let lanes = false;
        let p = &mut self.particles;
        let halves = self.manybody.as_ref().map(|m| m.bond_halves());
        // The lanes' gather reads a bond's halves four f64 wide (`Resultants::at`).
        assert!(halves.is_none_or(|h| h.len() == 2 * self.loads.per_bond.len() + 1));
        let update = ParticleUpdate {
            consts: &consts,
            resultants: Resultants {
                start: &self.topology.start[..],
                entries: &self.topology.entries[..],
                loads: &self.loads.per_bond[..],
                external: self.external.as_ref(),
                contact: self.contacts.as_ref().map(|c| (c.force(), c.torque())),
                manybody: halves,
                lanes,
            },
            mass: &p.mass[..],
            inertia: &p.inertia[..],
            lanes,
        };
        const PC: usize = PARTICLE_CHUNK;
        (
            p.position.par_chunks_mut(PC),
            p.velocity.par_chunks_mut(PC),
            p.angular_velocity.par_chunks_mut(PC),
            p.orientation.par_chunks_mut(PC),
            self.force.par_chunks_mut(PC),
            self.torque.par_chunks_mut(PC),
            self.energy_scratch.par_iter_mut(),
        )
            .into_par_iter()
            .enumerate()
            .for_each(|(chunk, (x, v, w, q, force, torque, partial))| {
                let slices = ChunkSlices {
                    x,
                    v,
                    w,
                    q,
                    force,
                    torque,
                };
                *partial = update.chunk(chunk * PC, slices);
            });
        if let Some(c) = &mut self.cell {
            c.prev_vel_grad = c.vel_grad;
        }
        self.add_chunk_energies(consts.lambda);
        consts
    }

    /// This step's update constants: the time step, λ and, in a periodic cell, the velocity
    /// gradient taken from YADE's one-step-late `nextVelGrad`, its change since the last
    /// step and the spin increment of that change's antisymmetric part.
    fn update_consts(&mut self) -> UpdateConsts {
        let (periodic, prev_l, dl, dspin) = match &mut self.cell {
            Some(c) => {
                if let Some(next) = c.next_vel_grad.take() {
                    c.vel_grad = next;
                }
                let dl = c.vel_grad - c.prev_vel_grad;
                let r = (dl - dl.transpose()) * 0.5;
                let dspin = Vec3::new(-r[(1, 2)], r[(0, 2)], -r[(0, 1)]);
                (true, c.prev_vel_grad, dl, dspin)
            }
            None => (false, Mat3::zeros(), Mat3::zeros(), Vec3::zeros()),
        };
        UpdateConsts {
            dt: self.dt,
            lambda: self.local_damping,
            periodic,
            prev_l,
            dl,
            dspin,
        }
    }

    /// Kinetic energy and Cundall dissipation (counted only when λ = `lambda` > 0) from the
    /// chunk sums, added in chunk order: the same bits on any number of threads.
    fn add_chunk_energies(&mut self, lambda: f64) {
        let (mut kinetic, mut dissipated) = (0.0, 0.0);
        for [k, d] in &self.energy_scratch {
            kinetic += k;
            dissipated += d;
        }
        self.kinetic = kinetic;
        if lambda > 0.0 {
            self.local_dissipated += dissipated;
        }
    }

    /// Energies at the last force evaluation.
    pub fn energies(&self) -> Energies {
        Energies {
            kinetic: self.kinetic,
            elastic: self.law.elastic_energy(),
            local_damping: self.local_dissipated,
            viscous_damping: self.law.viscous_dissipation(),
            broken_bonds: self.broken_energy,
            contact_elastic: self.contacts.as_ref().map_or(0.0, |c| c.elastic_energy()),
            friction: self
                .contacts
                .as_ref()
                .map_or(0.0, |c| c.friction_dissipation()),
            manybody: self.manybody.as_ref().map_or(0.0, |m| m.energy()),
        }
    }

    /// Volume (m³): det H of the cell, or the initial packing's bounding box if free.
    pub fn volume(&self) -> f64 {
        match &self.cell {
            Some(c) => c.volume(),
            None => self.free_volume,
        }
    }

    /// Branch vector of bond b at the current positions: x_j + H·c − x_i (m).
    pub fn branch(&self, b: usize) -> Vec3 {
        let (i, j) = (self.topology.i[b] as usize, self.topology.j[b] as usize);
        let shift = match &self.cell {
            Some(c) => c.h * self.topology.cell_dist[b],
            None => Vec3::zeros(),
        };
        self.particles.position[j] + shift - self.particles.position[i]
    }

    /// Love stress σ = (1/V) Σ f_i ⊗ l (Pa, tension positive; Kumar 2016 Eq. 9) over the bonds
    /// and, when on, the contacts ([`Contacts::stress_sum`]), with the
    /// bond forces of the last evaluation and the current branch vectors — what YADE's
    /// `utils.getStress()` returns after `O.step()`. Not symmetrised.
    pub fn stress(&self) -> Mat3 {
        let mut s = deterministic_sum_mat3(self.topology.len(), |b| {
            self.loads.force_i(b) * self.branch(b).transpose()
        });
        if let Some(c) = &self.contacts {
            s += c.stress_sum(&self.particles, self.cell.as_ref());
        }
        if let Some(m) = &self.manybody {
            let h = self.cell.as_ref().map(|c| c.h);
            s += m.stress_sum(&self.particles, &self.topology, h.as_ref());
        }
        s / self.volume()
    }

    /// Small strain of the cell ½(F + Fᵀ) − I (zero for a free assembly).
    pub fn strain(&self) -> Mat3 {
        self.cell
            .as_ref()
            .map_or(Mat3::zeros(), |c| c.small_strain())
    }

    /// YADE's unbalanced force (`utils.unbalancedForce()`): mean resultant force on the
    /// bonded, free particles over the mean force magnitude of the intact bonds (0 when
    /// there is no bond force; broken bonds carry none and are not counted; contacts are
    /// not in either mean yet). Held particles ([`PrescribedMotion`]) are left out, as YADE leaves out bodies
    /// that are not dynamic: their resultant is the grip reaction, not an imbalance. The
    /// measure of static equilibrium the damped relaxations stop on.
    pub fn unbalanced_force(&self) -> f64 {
        let topo = &self.topology;
        let free = self.free_bonded_particles();
        let fsum = deterministic_sum(free.len(), |k| self.force[free[k]].norm());
        let bsum = deterministic_sum(topo.len(), |b| self.loads.force_i(b).norm());
        if bsum == 0.0 {
            0.0
        } else {
            (fsum / free.len().max(1) as f64) / (bsum / self.intact_count().max(1) as f64)
        }
    }

    /// The rotational analogue of [`Simulation::unbalanced_force`]: mean resultant torque
    /// on the bonded, free particles over the mean torque a bond applies to one of its
    /// particles, ½(|T_i| + |T_j|) (moments of the shear force about the centres, and of
    /// the bending and twisting springs); 0 when no bond applies a torque.
    pub fn unbalanced_torque(&self) -> f64 {
        let topo = &self.topology;
        let free = self.free_bonded_particles();
        let tsum = deterministic_sum(free.len(), |k| self.torque[free[k]].norm());
        let loads = &self.loads.per_bond;
        let bsum = deterministic_sum(topo.len(), |b| {
            0.5 * (loads[b].torque_i.norm() + loads[b].torque_j.norm())
        });
        if bsum == 0.0 {
            0.0
        } else {
            (tsum / free.len().max(1) as f64) / (bsum / self.intact_count().max(1) as f64)
        }
    }

    /// Particles with at least one bond whose motion is not prescribed, ascending.
    fn free_bonded_particles(&self) -> Vec<usize> {
        let n = self.particles.len();
        let mut held = vec![false; n];
        if let Some(h) = &self.prescribed {
            for &p in &h.motion.particles {
                held[p] = true;
            }
        }
        (0..n)
            .filter(|&p| self.topology.degree(p) > 0 && !held[p])
            .collect()
    }

    fn compute_stability(&self) -> Result<StabilityReport> {
        let p = &self.particles;
        let n = p.len();
        let mut rows = vec![[0.0f64; 6]; n];
        for b in 0..self.topology.len() {
            let (i, j) = (self.topology.i[b] as usize, self.topology.j[b] as usize);
            let l = self.branch(b);
            let len = l.norm();
            let (kn, ks, kr, ktw) = self.law.springs(b);
            let (eta_n, eta_t) = self.law.viscosity(b);
            let _ = (eta_n, eta_t);
            let e = network::element(
                &network::BondLaw {
                    normal: l / len,
                    length: len,
                    arms: LeverArm::MidGap.arms(p.radius[i], p.radius[j], len),
                    kn,
                    ks,
                    kr,
                    ktw,
                },
                true,
            );
            let mi = [
                p.mass[i],
                p.mass[i],
                p.mass[i],
                p.inertia[i],
                p.inertia[i],
                p.inertia[i],
            ];
            let mj = [
                p.mass[j],
                p.mass[j],
                p.mass[j],
                p.inertia[j],
                p.inertia[j],
                p.inertia[j],
            ];
            for r in 0..6 {
                for c in 0..6 {
                    rows[i][r] += e.kii[(r, c)].abs() / (mi[r] * mi[c]).sqrt()
                        + e.kij[(r, c)].abs() / (mi[r] * mj[c]).sqrt();
                    rows[j][r] += e.kjj[(r, c)].abs() / (mj[r] * mj[c]).sqrt()
                        + e.kij[(c, r)].abs() / (mj[r] * mi[c]).sqrt();
                }
            }
        }
        if let Some(m) = &self.manybody {
            let h = self.cell.as_ref().map(|c| c.h);
            m.add_gershgorin(&mut rows, p, &self.topology, h.as_ref())?;
        }
        let mut worst = 0.0;
        let mut stiffest = 0;
        for (k, r) in rows.iter().enumerate() {
            let m = r.iter().cloned().fold(0.0, f64::max);
            if m > worst {
                worst = m;
                stiffest = k;
            }
        }
        let by_degree = |d: usize| {
            (0..n)
                .filter(|&k| self.topology.degree(k) == d)
                .collect::<Vec<_>>()
        };
        Ok(StabilityReport {
            critical_time_step: if worst > 0.0 {
                2.0 / worst.sqrt()
            } else {
                f64::INFINITY
            },
            stiffest_particle: stiffest,
            unbonded_particles: by_degree(0),
            one_bond_particles: by_degree(1),
            two_bond_particles: by_degree(2),
        })
    }

    /// The time step recommended after a blow-up: safety × critical estimate (s).
    pub fn recommended_time_step(&self) -> f64 {
        self.safety * self.stability.critical_time_step
    }

    fn watchdog(&mut self) -> Result<()> {
        let e = self.energies();
        let total = e.mechanical();
        let finite = total.is_finite()
            && self
                .particles
                .position
                .iter()
                .all(|x| x.iter().all(|c| c.is_finite()));
        if !finite || {
            self.watch.push(total);
            let w = &self.watch;
            let k = w.len();
            k >= 4 && w[k - 4] > 0.0 && (1..4).all(|s| w[k - s] > 10.0 * w[k - s - 1])
        } {
            return Err(Error::Degenerate(format!(
                "the run blew up at step {} (time step {:.4e} s): {}. Use a time step ≤ {:.4e} s \
                 (the critical estimate {:.4e} s × safety {})",
                self.iteration,
                self.dt,
                if finite {
                    format!(
                        "the kinetic + elastic energy grew more than 1000× in {} steps",
                        3 * self.check_interval
                    )
                } else {
                    "positions or energies became non-finite".to_string()
                },
                self.recommended_time_step(),
                self.stability.critical_time_step,
                self.safety
            )));
        }
        if self.watch.len() > 8 {
            self.watch.remove(0);
        }
        Ok(())
    }
}

/// Overwrite the integrator's update of the held particles: x ← x_held + v_prescribed·dt,
/// zero spin, orientation as when they were taken hold of.
/// (kinetic, dissipated) corrections for the held particles after an integrator pass: the
/// pass integrated them like free particles (their kinetic energy at the force time included
/// the acceleration by the grip reaction, and Cundall damping worked on it), but they move
/// at their prescribed velocity with no spin and no damping. Their pre-pass state is known
/// exactly (prescribed velocity, zero spin, held position and orientation), so the pass's
/// terms are recomputed with the same operations and replaced by ½m|v − L·x|² and zero.
fn held_ledger_correction(
    consts: &UpdateConsts,
    p: &Particles,
    held: &HeldParticles,
    force: &[Vec3],
    torque: &[Vec3],
) -> (f64, f64) {
    let (mut kinetic, mut dissipated) = (0.0, 0.0);
    let m = &held.motion;
    for (h, (&k, v)) in m.particles.iter().zip(&m.velocity).enumerate() {
        let (mut x, mut vel, mut w, mut q) =
            (held.position[h], *v, Vec3::zeros(), held.orientation[h]);
        let (energy, terms) = update_particle(
            consts,
            p.mass[k],
            p.inertia[k],
            force[k],
            torque[k],
            &mut x,
            &mut vel,
            &mut w,
            &mut q,
        );
        let fluct = if consts.periodic {
            *v - consts.prev_l * held.position[h]
        } else {
            *v
        };
        kinetic += 0.5 * p.mass[k] * fluct.norm_squared() - energy;
        dissipated -= terms.iter().sum::<f64>();
    }
    (kinetic, dissipated)
}

fn apply_prescribed_motion(p: &mut Particles, held: &mut HeldParticles, dt: f64) {
    let m = &held.motion;
    for (h, (&k, v)) in m.particles.iter().zip(&m.velocity).enumerate() {
        held.position[h] += v * dt;
        p.position[k] = held.position[h];
        p.velocity[k] = *v;
        p.angular_velocity[k] = Vec3::zeros();
        p.orientation[k] = held.orientation[h];
    }
}

struct ContextParts {
    h: Mat3,
    sv: Mat3,
    dt: f64,
    simd: bool,
}

impl ContextParts {
    fn as_context<'a>(
        &self,
        particles: &'a Particles,
        topology: &'a BondTopology,
    ) -> BondContext<'a> {
        BondContext {
            particles,
            topology,
            h: self.h,
            shift_velocity: self.sv,
            dt: self.dt,
            simd: self.simd,
        }
    }
}

#[inline]
fn sign(x: f64) -> f64 {
    if x > 0.0 {
        1.0
    } else if x < 0.0 {
        -1.0
    } else {
        0.0
    }
}

/// Placeholder law used only while the real one is being initialised.
struct NoLaw;

impl BondLaw for NoLaw {
    fn name(&self) -> &'static str {
        "none"
    }
    fn initialize(&mut self, _: &BondContext) -> Result<()> {
        Ok(())
    }
    fn compute(&mut self, _: &BondContext, _: &mut BondLoads) {}
    fn elastic_energy(&self) -> f64 {
        0.0
    }
    fn viscous_dissipation(&self) -> f64 {
        0.0
    }
    fn springs(&self, _: usize) -> (f64, f64, f64, f64) {
        (0.0, 0.0, 0.0, 0.0)
    }
    fn viscosity(&self, _: usize) -> (f64, f64) {
        (0.0, 0.0)
    }
    fn bond_forces(&self, _: usize) -> (f64, Vec3) {
        (0.0, Vec3::zeros())
    }
    fn bond_normal(&self, _: usize) -> Vec3 {
        Vec3::zeros()
    }
    fn local_loads(&self, _: &Particles, _: usize) -> crate::strength::LocalLoads {
        Default::default()
    }
    fn break_bond(&mut self, _: &Particles, _: usize) -> f64 {
        0.0
    }
    fn box_clone(&self) -> Box<dyn BondLaw> {
        Box::new(NoLaw)
    }
}
