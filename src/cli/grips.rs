//! `anisobond grips`: element tests on a free block driven through grip particles
//! (Truszkowska 2018 Sec. 4.1–4.4), stress and strain from measurement spheres, the
//! Eq. 27 tensor and the Table 3 strain-heterogeneity metric.

use super::run::{check_positive, IntegratorArgs};
use anisobond::dem::{GrippedOptions, GrippedTensor, MeasureOptions};
use anisobond::homogenize::TensorReport;
use anisobond::io::OutputSet;
use anisobond::{Error, Result};
use std::path::PathBuf;

/// Arguments of `anisobond grips`.
#[derive(clap::Args, Clone, Debug)]
pub struct GripsArgs {
    #[command(flatten)]
    pub input: super::cell::BondedInput,
    #[command(flatten)]
    pub integrator: IntegratorArgs,
    /// Grip particles: surface within this many R̄ of a face of the box.
    #[arg(long, default_value_t = 0.5)]
    pub grip_shell: f64,
    /// Steps over which the grips reach the full strain (counted in --max-steps, so fewer).
    #[arg(long, default_value_t = 50)]
    pub ramp_steps: usize,
    /// Number of measurement spheres.
    #[arg(long, default_value_t = 200)]
    pub spheres: usize,
    /// Measurement-sphere radius in units of R̄ (Truszkowska 2018: 6).
    #[arg(long, default_value_t = 6.0)]
    pub sphere_radius: f64,
    /// Seed of the measurement-sphere centres.
    #[arg(long, default_value_t = 2018)]
    pub seed: u64,
    /// Final tensor report (SPEC JSON).
    #[arg(short, long)]
    pub output: Option<PathBuf>,
}

/// Check every option before any work, with messages naming the option.
fn validate(a: &GripsArgs) -> Result<()> {
    a.integrator.validate()?;
    if !(a.grip_shell.is_finite() && a.grip_shell >= 0.0) {
        return Err(Error::Invalid(format!(
            "--grip-shell must be finite and ≥ 0, got {}",
            a.grip_shell
        )));
    }
    if a.ramp_steps == 0 || a.ramp_steps >= a.integrator.max_steps {
        return Err(Error::Invalid(format!(
            "--ramp-steps ({}) must be at least 1 and less than --max-steps ({}), the step limit \
             per path, which includes the ramp",
            a.ramp_steps, a.integrator.max_steps
        )));
    }
    if a.spheres == 0 {
        return Err(Error::Invalid("--spheres must be at least 1, got 0".into()));
    }
    check_positive("--sphere-radius", a.sphere_radius)
}

/// `anisobond grips`.
pub fn grips(a: GripsArgs) -> Result<()> {
    validate(&a)?;
    let mut out = OutputSet::new(&a.input.paths());
    let staged = out.optional_file(a.output.as_deref())?;
    let asm = a.input.assembly()?;
    let i = &a.integrator;
    let opts = gripped_options(&a);
    let bar = super::output::progress_bar("gripped element tests");
    let result = asm.gripped_tests(i.law.into(), &opts, &|f: f64| {
        bar.set_position((f.clamp(0.0, 1.0) * 1000.0) as u64)
    });
    bar.finish_and_clear();
    let t = result?;
    print_paths(&a, asm.packing.len(), &t);
    let report = TensorReport::new("gripped", t.c, Some((&asm.packing, &asm.bonds)))?;
    if let (Some(path), Some(shown)) = (&staged, &a.output) {
        // The SPEC tensor report plus the Table 3 heterogeneity and the block's set-up.
        let heterogeneity = serde_json::json!({
            "definition": "std / |mean| across measurement spheres of the loaded strain component, mean over paths 1-3 (normal) and 4-6 (shear) (Truszkowska 2018 Table 3)",
            "normal": t.heterogeneity.normal,
            "shear": t.heterogeneity.shear,
        });
        let grips = serde_json::json!({
            "grip_particles": t.grips,
            "grip_shell_mean_radii": a.grip_shell,
            "measurement_spheres": a.spheres,
            "sphere_radius_mean_radii": a.sphere_radius,
            "mean_particles_per_sphere": t.mean_members,
            "time_step_s": t.time_step,
        });
        super::output::write_json_with(
            path,
            &report,
            vec![("heterogeneity", heterogeneity), ("grips", grips)],
        )?;
        out.commit()?;
        println!("wrote {}", shown.display());
    }
    super::output::print_report(&report);
    Ok(())
}

/// The gripped tests' settings from the options.
fn gripped_options(a: &GripsArgs) -> GrippedOptions {
    let i = &a.integrator;
    GrippedOptions {
        strain: i.strain,
        grip_shell: a.grip_shell,
        ramp_steps: a.ramp_steps,
        local_damping: i.damping,
        tolerance: i.tolerance,
        unbalanced_tolerance: i.unbalanced_tolerance,
        max_steps: i.max_steps,
        dem: i.step.dem_options(i.damping),
        measure: MeasureOptions {
            count: a.spheres,
            radius: a.sphere_radius,
            seed: a.seed,
        },
        ..Default::default()
    }
}

/// Print the block's set-up, each path's convergence and strain, and the strain
/// heterogeneity (Truszkowska 2018 Table 3's metric).
fn print_paths(a: &GripsArgs, particles: usize, t: &GrippedTensor) {
    println!(
        "block: {} particles, {} bonds (boundary-crossing bonds dropped), {} grips; {} measurement \
         spheres of {} R̄ ({:.0} particles each); time step {:.4e} s",
        particles,
        t.bonds,
        t.grips,
        a.spheres,
        a.sphere_radius,
        t.mean_members,
        t.time_step
    );
    for p in &t.paths {
        println!(
            "path {}: {} steps (unbalanced force {:.2e}), mean sphere strain / imposed {:.4}, \
             spread {:.2} %",
            p.path + 1,
            p.steps,
            p.unbalance.force,
            p.strain[p.path] / p.imposed_strain[p.path],
            100.0 * p.spread
        );
    }
    println!(
        "strain heterogeneity (Truszkowska 2018 Table 3 metric): normal {:.2} %, shear {:.2} %",
        100.0 * t.heterogeneity.normal,
        100.0 * t.heterogeneity.shear
    );
}
