//! `--specimen` and its options, the same for every engine of `anisobond validate`: below
//! `validate.rs` and the engines' argument files, which all take it.

use super::specimen::{AxisArg, PlatensArg};
use anisobond::specimen::Platens;
use anisobond::validate::specimen::SpecimenTest;

/// `--specimen` and its options, shared by every engine.
#[derive(clap::Args, Clone, Debug)]
pub struct SpecimenFlags {
    /// Run the specimen test instead of the periodic element tests: the free packing's
    /// bonded specimen loaded between platens by the engine, quasi-statically to rest, its
    /// platen stiffness against `anisobond specimen`'s (needs a free packing: --free).
    #[arg(long)]
    pub specimen: bool,
    /// Loading axis of the specimen test.
    #[arg(long, value_enum, default_value_t = AxisArg::Z)]
    pub axis: AxisArg,
    /// Depth of each end layer (m), as `anisobond specimen --end-layer`; default the mean
    /// radius.
    #[arg(long)]
    pub end_layer: Option<f64>,
    /// How the platens hold the end layers.
    #[arg(long, value_enum, default_value_t = PlatensArg::Frictionless)]
    pub platens: PlatensArg,
    /// Axial compressive strain the engine applies to the specimen; default the engine's
    /// (YADE 1e-6, LAMMPS 1e-5).
    #[arg(long)]
    pub specimen_strain: Option<f64>,
    /// Largest admissible relative difference of the platen stiffness.
    #[arg(long, default_value_t = 1e-3)]
    pub specimen_tolerance: f64,
    /// The engine's relaxation stops when its platen force's estimated remaining relative
    /// change is below this.
    #[arg(long, default_value_t = 1e-6)]
    pub settle: f64,
    /// Most steps of the engine's relaxation.
    #[arg(long, default_value_t = 400_000)]
    pub max_steps: u64,
}

impl SpecimenFlags {
    /// The test on `asm` (the end layer defaults to its mean radius).
    pub fn test(&self, asm: &anisobond::assembly::Assembly) -> SpecimenTest {
        let p = &asm.packing;
        let mean = p.radii.iter().sum::<f64>() / p.len().max(1) as f64;
        let mut t = SpecimenTest::new(
            self.axis as usize,
            self.end_layer.unwrap_or(mean),
            match self.platens {
                PlatensArg::Frictionless => Platens::Frictionless,
                PlatensArg::Bonded => Platens::Bonded,
            },
        );
        t.strain = self.specimen_strain;
        t.tolerance = self.specimen_tolerance;
        t.settle = self.settle;
        t.max_steps = self.max_steps;
        t
    }
}
