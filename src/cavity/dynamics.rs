//! The pressurised cavity in time: the reference integrator ([`crate::dem::Simulation`],
//! undamped) on the slab, the clamped ring held still, the wall loads of [`super::Cavity`]
//! applied as external forces scaled by a smooth ramp p(t) = p·(1 − cos πt/t_r)/2 (t < t_r),
//! p after. The ramp makes the wall's velocity a half-sine pulse of duration t_r, whose
//! wavelength v·t_r is kept ≫ the particle size.
//!
//! Wave-front detection: a probe is the set of free spheres within ±`probe_half_angle` of an
//! in-plane direction and within R̄ of a radius r (all z); its signal is their mean velocity
//! along the direction. The front's arrival is the time of the signal's peak (parabola
//! through the largest sample and its neighbours), and the speed along the direction is
//! (r₂ − r₁)/(t₂ − t₁) between two probes, which cancels the source's own delay.

use super::Cavity;
use crate::dem::sim::PrescribedMotion;
use crate::dem::state::MassOptions;
use crate::dem::{build_law, DemOptions, LawKind, Simulation};
use crate::{Error, Result, Vec3};

/// Settings of a wave run.
#[derive(Clone, Debug)]
pub struct WaveOptions {
    /// Final pressure p (Pa).
    pub pressure: f64,
    /// Ramp duration t_r (s).
    pub ramp_time: f64,
    /// Simulated time (s).
    pub duration: f64,
    /// Material density of the spheres (kg/m³).
    pub material_density: f64,
    /// Bond law of the integrator.
    pub law: LawKind,
    /// In-plane directions of the probes (angle from x towards y, rad).
    pub directions: Vec<f64>,
    /// Radii of the probes along every direction (m), increasing.
    pub probe_radii: Vec<f64>,
    /// Half opening angle of a probe (rad).
    pub probe_half_angle: f64,
    /// Displacement snapshots to keep, exactly this many (evenly spaced in steps, the last
    /// at the end; 0 = none; at most one per time step).
    pub snapshots: usize,
}

/// The result of a wave run.
#[derive(Clone, Debug)]
pub struct WaveRun {
    /// Time step used (s).
    pub time_step: f64,
    /// Sample times (s), one per step.
    pub times: Vec<f64>,
    /// Probe signals: `signal[d][r][step]`, mean velocity along direction d (m/s).
    pub signal: Vec<Vec<Vec<f64>>>,
    /// Spheres in every probe.
    pub probe_sizes: Vec<Vec<usize>>,
    /// Arrival time of the front at every probe (s).
    pub arrival: Vec<Vec<f64>>,
    /// Front speed along every direction between the first and last probe (m/s).
    pub front_speed: Vec<f64>,
    /// Snapshots (time s, displacement of every sphere m).
    pub snapshots: Vec<(f64, Vec<Vec3>)>,
}

impl Cavity {
    /// The integrator on the slab: the clamped ring held still (zero prescribed velocity),
    /// the wall loads at pressure `pressure` (Pa) as external forces at scale 1 (set the
    /// scale for a ramp), Cundall local damping `local_damping` (0 for waves).
    pub fn simulation(
        &self,
        pressure: f64,
        material_density: f64,
        law: LawKind,
        local_damping: f64,
    ) -> Result<Simulation> {
        let packing = &self.cut.packing;
        let n = packing.len();
        let law = build_law(law, packing, &self.bonds, &self.springs)?;
        let mut sim = Simulation::new(
            packing,
            &self.bonds,
            law,
            &DemOptions {
                local_damping,
                mass: MassOptions {
                    density: material_density,
                    scaling: 1.0,
                },
                ..Default::default()
            },
        )?;
        let held: Vec<usize> = (0..n).filter(|&p| self.clamped[p]).collect();
        sim.set_prescribed_motion(Some(PrescribedMotion {
            velocity: vec![Vec3::zeros(); held.len()],
            particles: held,
        }))?;
        sim.set_external_forces(Some(self.unit_load.iter().map(|f| f * pressure).collect()))?;
        Ok(sim)
    }

    /// Refuse wave options before anything runs (what [`Cavity::run_waves`] refuses up
    /// front), and return the time step (s) and the number of steps: times that are not
    /// finite with 0 < ramp time < duration, no directions, fewer than two probe radii, a
    /// zero or non-finite pressure, a run beyond [`crate::dem::MAX_PARTICLE_STEPS`] (spheres ×
    /// duration / time step), more snapshots than steps (at most one per step; never fewer
    /// or more than asked), and signals and snapshots beyond the machine's memory.
    pub fn check_waves(&self, opts: &WaveOptions) -> Result<(f64, usize)> {
        if !(opts.ramp_time.is_finite()
            && opts.duration.is_finite()
            && opts.ramp_time > 0.0
            && opts.duration > opts.ramp_time)
        {
            return Err(Error::Invalid(format!(
                "wave run: need 0 < ramp time < duration, got {:e} s and {:e} s",
                opts.ramp_time, opts.duration
            )));
        }
        if opts.directions.is_empty() || opts.probe_radii.len() < 2 {
            return Err(Error::Invalid(
                "wave run: need at least one direction and two probe radii".into(),
            ));
        }
        if !(opts.pressure.is_finite() && opts.pressure != 0.0) {
            return Err(Error::Invalid(format!(
                "wave run: pressure must be finite and non-zero, got {} Pa",
                opts.pressure
            )));
        }
        let n = self.cut.packing.len();
        let dt = self
            .simulation(opts.pressure, opts.material_density, opts.law, 0.0)?
            .time_step();
        let steps = (opts.duration / dt).ceil();
        crate::dem::check_run_size(
            &format!(
                "wave run: duration {:e} s (ramp time {:e} s) at time step {dt:e} s",
                opts.duration, opts.ramp_time
            ),
            n,
            steps,
        )?;
        let steps = steps as usize;
        if opts.snapshots > steps {
            return Err(Error::Invalid(format!(
                "wave run: {} snapshots asked, but the run has {steps} time steps (at most one \
                 snapshot per step)",
                opts.snapshots
            )));
        }
        // Signals and times (f64 per step) and snapshots (a Vec3 per sphere).
        let bytes =
            steps as f64 * 8.0 * (1.0 + (opts.directions.len() * opts.probe_radii.len()) as f64)
                + opts.snapshots as f64 * n as f64 * 24.0;
        crate::io::check_memory(
            &format!(
                "wave run: {steps} steps' probe signals and {} snapshots of {n} spheres",
                opts.snapshots
            ),
            bytes,
        )?;
        Ok((dt, steps))
    }

    /// Run the ramp-loaded cavity in time and detect the wave front (module doc). Refuses
    /// what [`Cavity::check_waves`] refuses; errors on an empty probe or a signal whose peak
    /// lies at the end of the run (the front did not pass). Keeps exactly `snapshots`
    /// snapshots, the k-th (k = 1…) after step ⌊k·steps/snapshots⌋.
    pub fn run_waves(&self, opts: &WaveOptions) -> Result<WaveRun> {
        let (_, steps) = self.check_waves(opts)?;
        let mut sim = self.simulation(opts.pressure, opts.material_density, opts.law, 0.0)?;
        let probes = self.probes(opts)?;
        let dt = sim.time_step();
        let (times, signal, snapshots) = record_waves(&mut sim, &probes, opts, steps)?;
        let (arrival, front_speed) = fronts(&signal, &times, opts)?;
        Ok(WaveRun {
            time_step: dt,
            times,
            signal,
            probe_sizes: probes
                .iter()
                .map(|a| a.iter().map(|m| m.len()).collect())
                .collect(),
            arrival,
            front_speed,
            snapshots,
        })
    }

    /// The probes, `[direction][radius]`: the free spheres within R̄ of the radius and within
    /// ±`probe_half_angle` of the direction (module doc); refuses an empty probe.
    fn probes(&self, opts: &WaveOptions) -> Result<Vec<Vec<Vec<usize>>>> {
        let n = self.cut.packing.len();
        let r_mean = self.cut.packing.mean_radius();
        let mut probes: Vec<Vec<Vec<usize>>> = Vec::new();
        for &phi in &opts.directions {
            let dir = Vec3::new(phi.cos(), phi.sin(), 0.0);
            let mut along = Vec::new();
            for &r in &opts.probe_radii {
                let members: Vec<usize> = (0..n)
                    .filter(|&p| {
                        if self.clamped[p] || self.network.index[p] == u32::MAX {
                            return false;
                        }
                        let rel = self.relative_position(p);
                        let rho = rel.x.hypot(rel.y);
                        let cosang = (rel.x * dir.x + rel.y * dir.y) / rho;
                        (rho - r).abs() <= r_mean && cosang >= opts.probe_half_angle.cos()
                    })
                    .collect();
                if members.is_empty() {
                    return Err(Error::Degenerate(format!(
                        "wave run: no free sphere within R̄ of radius {r:e} m at {:.1}°",
                        phi.to_degrees()
                    )));
                }
                along.push(members);
            }
            probes.push(along);
        }
        Ok(probes)
    }
}

/// Sample times, probe signals and displacement snapshots of a wave run.
type Recording = (Vec<f64>, Vec<Vec<Vec<f64>>>, Vec<(f64, Vec<Vec3>)>);

/// Step `sim` `steps` times under the ramp p(t) = p·(1 − cos πt/t_r)/2 (module doc),
/// recording every probe's mean velocity along its direction after each step and the
/// snapshots; refuses positions that became non-finite.
fn record_waves(
    sim: &mut Simulation,
    probes: &[Vec<Vec<usize>>],
    opts: &WaveOptions,
    steps: usize,
) -> Result<Recording> {
    let n = sim.particles.position.len();
    // Step after which snapshot k (0-based) is taken: ⌊(k+1)·steps/snapshots⌋, strictly
    // increasing as snapshots ≤ steps, the last the final step.
    let snapshot_after =
        |k: usize| ((k as u128 + 1) * steps as u128 / opts.snapshots as u128) as usize;
    let mut next_snapshot = 0;
    let start = sim.particles.position.clone();
    let mut times = Vec::with_capacity(steps);
    let mut signal =
        vec![vec![Vec::with_capacity(steps); opts.probe_radii.len()]; opts.directions.len()];
    let mut snapshots = Vec::new();
    for s in 0..steps {
        let t = sim.time();
        let scale = if t < opts.ramp_time {
            0.5 * (1.0 - (std::f64::consts::PI * t / opts.ramp_time).cos())
        } else {
            1.0
        };
        sim.set_external_force_scale(scale)?;
        sim.step()?;
        times.push(sim.time());
        for (d, &phi) in opts.directions.iter().enumerate() {
            let dir = Vec3::new(phi.cos(), phi.sin(), 0.0);
            for (k, members) in probes[d].iter().enumerate() {
                let v: f64 = members
                    .iter()
                    .map(|&p| sim.particles.velocity[p].dot(&dir))
                    .sum::<f64>()
                    / members.len() as f64;
                signal[d][k].push(v);
            }
        }
        if next_snapshot < opts.snapshots && s + 1 == snapshot_after(next_snapshot) {
            next_snapshot += 1;
            let u: Vec<Vec3> = (0..n)
                .map(|p| sim.particles.position[p] - start[p])
                .collect();
            snapshots.push((sim.time(), u));
        }
    }
    if sim
        .particles
        .position
        .iter()
        .any(|x| x.iter().any(|c| !c.is_finite()))
    {
        return Err(Error::Degenerate(
            "wave run: positions became non-finite (unstable time step?)".into(),
        ));
    }
    Ok((times, signal, snapshots))
}

/// The front's arrival at every probe (the signal's peak) and its speed along every
/// direction, (r₂ − r₁)/(t₂ − t₁) between the first and the last probe; refuses a signal
/// peaking at the end of the run and a front that does not reach the outer probe later.
fn fronts(
    signal: &[Vec<Vec<f64>>],
    times: &[f64],
    opts: &WaveOptions,
) -> Result<(Vec<Vec<f64>>, Vec<f64>)> {
    let mut arrival = Vec::new();
    let mut front_speed = Vec::new();
    for (d, &phi) in opts.directions.iter().enumerate() {
        let mut at = Vec::new();
        for (k, sig) in signal[d].iter().enumerate() {
            at.push(peak_time(sig, times).ok_or_else(|| {
                Error::NotConverged(format!(
                    "wave run: at {:.1}°, radius {:e} m the signal peaks at the end of the \
                     run: the front did not pass it; run longer",
                    phi.to_degrees(),
                    opts.probe_radii[k]
                ))
            })?);
        }
        let (r1, r2) = (
            opts.probe_radii[0],
            opts.probe_radii[opts.probe_radii.len() - 1],
        );
        let dt_front = at[at.len() - 1] - at[0];
        if dt_front.is_nan() || dt_front <= 0.0 {
            return Err(Error::Degenerate(format!(
                "wave run: at {:.1}° the front reaches {r2:e} m no later than {r1:e} m",
                phi.to_degrees()
            )));
        }
        front_speed.push((r2 - r1) / dt_front);
        arrival.push(at);
    }
    Ok((arrival, front_speed))
}

/// Time of the largest sample of `sig`, refined by the parabola through it and its two
/// neighbours; None when the largest sample is the first or the last.
fn peak_time(sig: &[f64], times: &[f64]) -> Option<f64> {
    let k = (0..sig.len()).max_by(|&a, &b| sig[a].total_cmp(&sig[b]))?;
    if k == 0 || k + 1 >= sig.len() {
        return None;
    }
    let (a, b, c) = (sig[k - 1], sig[k], sig[k + 1]);
    let denom = a - 2.0 * b + c;
    let shift = if denom != 0.0 {
        0.5 * (a - c) / denom
    } else {
        0.0
    };
    let h = times[k + 1] - times[k];
    Some(times[k] + shift * h)
}

impl WaveRun {
    /// Write the snapshots as a VTK time series into `dir`: `cavity_NNNN.vtu` (particles with
    /// `radius` m, `displacement` m) and `cavity.pvd` (ParaView's collection, times in s).
    pub fn write_vtk_series(&self, cavity: &Cavity, dir: &std::path::Path) -> Result<()> {
        let mut pvd = String::from(
            "<?xml version=\"1.0\"?>\n<VTKFile type=\"Collection\" version=\"0.1\">\n<Collection>\n",
        );
        for (k, (t, u)) in self.snapshots.iter().enumerate() {
            let name = format!("cavity_{k:04}.vtu");
            let state = crate::export::vtk::StrainedState {
                strain: crate::tensor::Voigt6::zeros(),
                displacement: u.clone(),
                rotation: vec![Vec3::zeros(); u.len()],
                force: Vec::new(),
            };
            crate::export::vtk::write_particles_vtu(
                &dir.join(&name),
                &cavity.cut.packing,
                Some(&state),
            )?;
            pvd.push_str(&format!(
                "<DataSet timestep=\"{t:e}\" group=\"\" part=\"0\" file=\"{name}\"/>\n"
            ));
        }
        pvd.push_str("</Collection>\n</VTKFile>\n");
        crate::io::write_string_atomic(&dir.join("cavity.pvd"), &pvd)
    }
}
