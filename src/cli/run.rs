//! `anisobond run`: the reference integrator's element tests on a packing + model, with a
//! progress bar, the stress–strain history CSV and the final tensor JSON; and the helper
//! behind `anisobond tensor --method dynamic`.

use anisobond::assembly::Assembly;
use anisobond::dem::{DemOptions, LawKind, MassOptions};
use anisobond::dem::{DynamicTensor, ElementTestOptions};
use anisobond::homogenize::TensorReport;
use anisobond::io::OutputSet;
use anisobond::{Error, Result};
use clap::ValueEnum;
use std::fmt::Write as _;
use std::path::PathBuf;

/// Bond law of the integrator.
#[derive(Clone, Copy, ValueEnum, PartialEq, Eq, Debug)]
pub enum LawArg {
    /// (a) YADE 2023.02a cohesive law (Law2_ScGeom6D_CohFrictPhys_CohesionMoment).
    Yade,
    /// (b) Potyondy–Cundall parallel bond (Truszkowska 2018 Eq. 3).
    ParallelBond,
    /// (c) Kumar 2016 Eqs. 2–8 with viscous bond damping.
    Kumar,
    /// (d) LAMMPS bond_style bpm/rotational (BPM package), undamped, no breaking.
    LammpsBpm,
}

impl From<LawArg> for LawKind {
    fn from(a: LawArg) -> Self {
        match a {
            LawArg::Yade => LawKind::Yade,
            LawArg::ParallelBond => LawKind::ParallelBond,
            LawArg::Kumar => LawKind::Kumar,
            LawArg::LammpsBpm => LawKind::LammpsBpm,
        }
    }
}

/// Masses and time step of the integrator, shared by every command that runs it.
#[derive(clap::Args, Clone, Debug)]
pub struct StepArgs {
    /// Particle density (kg/m³).
    #[arg(long, default_value_t = 2600.0)]
    pub density: f64,
    /// Mass-scaling factor on the density.
    #[arg(long, default_value_t = 1.0)]
    pub mass_scaling: f64,
    /// Time step (s); default: --safety × the critical estimate.
    #[arg(long)]
    pub dt: Option<f64>,
    /// Safety factor on the critical time step.
    #[arg(long, default_value_t = 0.8)]
    pub safety: f64,
}

impl Default for StepArgs {
    fn default() -> Self {
        StepArgs {
            density: 2600.0,
            mass_scaling: 1.0,
            dt: None,
            safety: 0.8,
        }
    }
}

impl StepArgs {
    /// Errors naming the first option out of range.
    pub fn validate(&self) -> Result<()> {
        check_positive("--density", self.density)?;
        check_positive("--mass-scaling", self.mass_scaling)?;
        if let Some(dt) = self.dt {
            check_positive("--dt", dt)?;
        }
        check_safety(self.safety)
    }

    /// The integrator's settings with these masses and time step and Cundall damping λ.
    pub fn dem_options(&self, local_damping: f64) -> DemOptions {
        DemOptions {
            time_step: self.dt,
            safety: self.safety,
            local_damping,
            mass: MassOptions {
                density: self.density,
                scaling: self.mass_scaling,
            },
            ..Default::default()
        }
    }
}

/// Integrator settings shared by `run` and `tensor --method dynamic`.
#[derive(clap::Args, Clone, Debug)]
pub struct IntegratorArgs {
    /// Bond law.
    #[arg(long, value_enum, default_value_t = LawArg::Yade)]
    pub law: LawArg,
    /// Cundall local damping λ during the relaxation.
    #[arg(long, default_value_t = ElementTestOptions::default().local_damping)]
    pub damping: f64,
    /// Strain magnitude of each of the six paths.
    #[arg(long, default_value_t = ElementTestOptions::default().strain)]
    pub strain: f64,
    #[command(flatten)]
    pub step: StepArgs,
    /// Convergence: relative stress change over 10 steps (and --unbalanced-tolerance).
    #[arg(long, default_value_t = ElementTestOptions::default().tolerance)]
    pub tolerance: f64,
    /// Equilibrium: largest unbalanced force and torque (mean resultant over mean bond
    /// force/torque, as YADE's unbalancedForce) at which a path counts as relaxed.
    #[arg(long, default_value_t = ElementTestOptions::default().unbalanced_tolerance)]
    pub unbalanced_tolerance: f64,
    /// Step limit per path; a path not relaxed within it is an error.
    #[arg(long, default_value_t = ElementTestOptions::default().max_steps)]
    pub max_steps: usize,
}

impl Default for IntegratorArgs {
    /// The library's element-test defaults ([`ElementTestOptions::default`]).
    fn default() -> Self {
        let d = ElementTestOptions::default();
        IntegratorArgs {
            law: LawArg::Yade,
            damping: d.local_damping,
            strain: d.strain,
            step: StepArgs::default(),
            tolerance: d.tolerance,
            unbalanced_tolerance: d.unbalanced_tolerance,
            max_steps: d.max_steps,
        }
    }
}

/// Errors naming the option unless `value` is finite and > 0.
pub fn check_positive(option: &str, value: f64) -> Result<()> {
    if !(value.is_finite() && value > 0.0) {
        return Err(Error::Invalid(format!(
            "{option} must be finite and > 0, got {value}"
        )));
    }
    Ok(())
}

/// Errors naming `--damping` unless λ is in [0, 1).
pub fn check_damping(value: f64) -> Result<()> {
    if !(value.is_finite() && (0.0..1.0).contains(&value)) {
        return Err(Error::Invalid(format!(
            "--damping must be in [0, 1), got {value}"
        )));
    }
    Ok(())
}

/// Errors naming `--safety` unless it is in (0, 1].
pub fn check_safety(value: f64) -> Result<()> {
    if !(value.is_finite() && value > 0.0 && value <= 1.0) {
        return Err(Error::Invalid(format!(
            "--safety must be in (0, 1], got {value}"
        )));
    }
    Ok(())
}

/// Errors naming `--max-steps` unless there is room for the loading step and at least one
/// relaxation step.
pub fn check_max_steps(value: usize) -> Result<()> {
    if value < 2 {
        return Err(Error::Invalid(format!(
            "--max-steps must be at least 2, got {value}"
        )));
    }
    Ok(())
}

impl IntegratorArgs {
    /// Check every option before any work, with messages naming the option.
    pub fn validate(&self) -> Result<()> {
        check_damping(self.damping)?;
        if !(self.strain.is_finite() && self.strain > 0.0 && self.strain < 0.1) {
            return Err(Error::Invalid(format!(
                "--strain must be in (0, 0.1), got {}",
                self.strain
            )));
        }
        self.step.validate()?;
        check_positive("--tolerance", self.tolerance)?;
        check_positive("--unbalanced-tolerance", self.unbalanced_tolerance)?;
        check_max_steps(self.max_steps)
    }
}

/// Arguments of `anisobond run`.
#[derive(clap::Args, Clone, Debug)]
pub struct RunArgs {
    #[command(flatten)]
    pub input: super::cell::BondedInput,
    #[command(flatten)]
    pub integrator: IntegratorArgs,
    /// Stress–strain history CSV (one row per step of every path).
    #[arg(long)]
    pub history: Option<PathBuf>,
    /// Final tensor report (SPEC JSON).
    #[arg(short, long)]
    pub output: Option<PathBuf>,
    /// Plot (PNG) of the loaded stress component against step for every path.
    #[arg(long)]
    pub plot: Option<PathBuf>,
}

/// The library's element-test options for the command-line integrator options.
pub fn element_options(a: &IntegratorArgs, history: bool) -> ElementTestOptions {
    ElementTestOptions {
        strain: a.strain,
        local_damping: a.damping,
        tolerance: a.tolerance,
        unbalanced_tolerance: a.unbalanced_tolerance,
        max_steps: a.max_steps,
        dem: a.step.dem_options(a.damping),
        history_every: usize::from(history),
        ..Default::default()
    }
}

/// PNG of the loaded stress component against step for every element-test path.
pub fn plot_element_tests(
    path: &std::path::Path,
    result: &DynamicTensor,
    a: &IntegratorArgs,
) -> Result<()> {
    anisobond::plot::plot_element_tests(path, result, a.strain, a.damping)
}

/// Run the six element tests of `asm` (with a progress bar), recording histories if asked.
pub fn run_element_tests(
    asm: &Assembly,
    a: &IntegratorArgs,
    history: bool,
) -> Result<DynamicTensor> {
    a.validate()?;
    let opts = element_options(a, history);
    let bar = super::output::progress_bar("element tests");
    let result = asm.element_tests(a.law.into(), &opts, &|f: f64| {
        bar.set_position((f.clamp(0.0, 1.0) * 1000.0) as u64)
    });
    bar.finish_and_clear();
    let result = result?;
    print_stability(&result);
    Ok(result)
}

/// The time step used and the weakly bonded particles of an element-test run (stderr).
pub fn print_stability(result: &DynamicTensor) {
    let st = &result.stability;
    if !st.one_bond_particles.is_empty() || !st.two_bond_particles.is_empty() {
        eprintln!(
            "note: {} particles with one bond and {} with two (zero-stiffness modes, held by damping); {} without bonds",
            st.one_bond_particles.len(),
            st.two_bond_particles.len(),
            st.unbonded_particles.len()
        );
    }
    eprintln!(
        "time step {:.4e} s (critical estimate {:.4e} s)",
        result.time_step, st.critical_time_step
    );
}

/// `anisobond run`.
pub fn run(a: RunArgs) -> Result<()> {
    a.integrator.validate()?;
    let mut out = OutputSet::new(&a.input.paths());
    let staged_output = out.optional_file(a.output.as_deref())?;
    let staged_history = out.optional_file(a.history.as_deref())?;
    let staged_plot = out.optional_file(a.plot.as_deref())?;
    let asm = a.input.assembly()?;
    let want_history = a.history.is_some() || a.plot.is_some();
    let result = run_element_tests(&asm, &a.integrator, want_history)?;
    let report = TensorReport::new("dynamic", result.c, Some((&asm.packing, &asm.bonds)))?;
    if let Some(path) = &staged_plot {
        plot_element_tests(path, &result, &a.integrator)?;
    }
    if let Some(path) = &staged_history {
        let mut csv = String::from(
            "path,step,time_s,e11,e22,e33,e23,e13,e12,s11_Pa,s22_Pa,s33_Pa,s23_Pa,s13_Pa,s12_Pa,kinetic_J,elastic_J,local_damping_J,viscous_damping_J,unbalanced_force\n",
        );
        for p in &result.paths {
            for h in &p.history {
                let _ = write!(csv, "{},{},{:e}", p.path, h.step, h.time);
                for v in h.strain.iter().chain(h.stress.iter()) {
                    let _ = write!(csv, ",{v:e}");
                }
                let e = &h.energies;
                let values = [e.kinetic, e.elastic, e.local_damping, e.viscous_damping];
                let mut all = h.strain.iter().chain(h.stress.iter()).chain(values.iter());
                if !h.time.is_finite()
                    || !h.unbalanced_force.is_finite()
                    || all.any(|v| !v.is_finite())
                {
                    return Err(anisobond::Error::Invalid(format!(
                        "element test path {}: non-finite state at step {} (the run diverged); \
                         nothing was written",
                        p.path, h.step
                    )));
                }
                let _ = writeln!(
                    csv,
                    ",{:e},{:e},{:e},{:e},{:e}",
                    e.kinetic, e.elastic, e.local_damping, e.viscous_damping, h.unbalanced_force
                );
            }
        }
        anisobond::io::write_string_atomic(path, &csv)?;
    }
    if let Some(path) = &staged_output {
        anisobond::io::write_string_atomic(path, &(report.to_json() + "\n"))?;
    }
    out.commit()?;
    for p in &result.paths {
        println!(
            "path {}: relaxed in {} steps (unbalanced force {:.2e}, torque {:.2e})",
            p.path, p.steps, p.unbalance.force, p.unbalance.torque
        );
    }
    for path in [&a.plot, &a.history, &a.output].into_iter().flatten() {
        println!("wrote {}", path.display());
    }
    println!("stiffness tensor, method dynamic (GPa; Voigt order 11 22 33 23 13 12):");
    for row in &report.c {
        let cells: Vec<String> = row.iter().map(|v| format!("{:10.4}", v / 1e9)).collect();
        println!("  {}", cells.join(" "));
    }
    Ok(())
}
