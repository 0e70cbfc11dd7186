//! `anisobond export liggghts PACKING --model MODEL -o DIR`: LIGGGHTS data file, bond table
//! and input decks (driver deck with the full per-bond law, stock `bond_style harmonic`
//! deck with normal springs only) for an element test of the bonded packing.

use anisobond::export::liggghts::{DeckOptions, LiggghtsInputs};
use anisobond::Result;

/// Write LIGGGHTS input decks for a packing + model.
#[derive(clap::Args, Debug)]
pub struct Args {
    #[command(flatten)]
    pub to: super::cell::ExportPaths,
    /// Particle density (kg/m³).
    #[arg(long, default_value_t = 2500.0)]
    pub density: f64,
    /// Strain increment of each load case.
    #[arg(long, default_value_t = 1e-6)]
    pub strain: f64,
    /// Steps over which each strain increment is applied.
    #[arg(long, default_value_t = 500)]
    pub deform_steps: u64,
    /// Steps held (damped relaxation) after each increment.
    #[arg(long, default_value_t = 10_000)]
    pub relax_steps: u64,
    /// Output interval of stress_history.txt (steps).
    #[arg(long, default_value_t = 100)]
    pub every: u64,
    /// Time step (s); default: 0.3 of the stiffest particle's period bound.
    #[arg(long)]
    pub timestep: Option<f64>,
    /// Viscous damping γ·dt (0 = undamped dynamics).
    #[arg(long, default_value_t = 0.02)]
    pub damping: f64,
    /// Particles follow the box affinely (no integration): the Voigt tensor.
    #[arg(long)]
    pub affine: bool,
    /// Only the normal load cases (orthogonal box; required for MPI runs, see the deck).
    #[arg(long)]
    pub no_shear: bool,
}

/// Run the command.
pub fn run(a: Args) -> Result<()> {
    let (set, staged) = a.to.stage()?;
    let asm = a.to.input.assembly()?;
    let (packing, bonds, k) = (&asm.packing, &asm.bonds, &asm.springs);
    let opts = DeckOptions {
        density: a.density,
        strain: a.strain,
        deform_steps: a.deform_steps,
        relax_steps: a.relax_steps,
        output_every: a.every,
        timestep: a.timestep,
        damping: a.damping,
        affine: a.affine,
        shear: !a.no_shear,
    };
    // A model with [strength]: breakable bonds, the limits in bonds.csv.
    let limits = anisobond::export::yade::yade_adhesions(packing, bonds, &asm.model)?;
    // A model with [manybody]: the term of these bonds, in manybody.txt for the driver deck
    // (a polycrystal's with each grain's D).
    let term = asm.manybody()?;
    let s = LiggghtsInputs {
        limits: limits.as_deref(),
        manybody: term.as_ref(),
        grains: asm.grains().map(|g| g.grain.as_slice()),
        ..LiggghtsInputs::new(packing, bonds, k, &opts)
    }
    .export(&staged)?;
    set.commit()?;
    println!(
        "wrote LIGGGHTS decks for {} particles, {} bonds (longest {:.4e} m) into {}:",
        packing.len(),
        bonds.len(),
        s.max_bond_length,
        a.to.output.display()
    );
    super::output::print_written("  ", &s.files, &staged, &a.to.output);
    if limits.is_some() {
        println!(
            "breakable bonds: the model's [strength] as YADE's CohFrict limits in bonds.csv; the driver writes breaks.txt"
        );
    }
    if let Some(t) = &term {
        println!(
            "many-body term: manybody.txt ({} of {} particles in the term, volume fraction {:.4}); the stock harmonic deck does not carry it",
            t.len() - t.excluded().len(),
            t.len(),
            t.volume_fraction()
        );
    }
    println!(
        "time step {:.4e} s, damping rate {:.4e} 1/s; load cases end at steps {:?}",
        s.timestep, s.damping_rate, s.case_end_steps
    );
    println!(
        "run: cd {} && anisobond-liggghts -in anisobond.in   (driver: make -C cpp)\n     or: stdbuf -o0 liggghts -in harmonic.in   (stock LIGGGHTS, normal springs only)",
        a.to.output.display()
    );
    Ok(())
}
