//! `--strength` and its options, the same for every engine of `anisobond validate`: direct
//! tension or uniaxial compression (`--load`) of the free bar to failure in the engine and
//! in the integrator with the same law (issue 32). The axis and the end layers are `--axis` and `--end-layer` of
//! [`super::validate_specimen::SpecimenFlags`].

use super::validate_specimen::SpecimenFlags;
use anisobond::validate::strength::{StrengthLoading, StrengthTest};

/// The free-specimen tests of every `validate ENGINE`, each instead of the element tests:
/// `--specimen` and `--strength` with their options.
#[derive(clap::Args, Clone, Debug)]
pub struct FreeTestFlags {
    /// The specimen test.
    #[command(flatten)]
    pub specimen: SpecimenFlags,
    /// The strength test.
    #[command(flatten)]
    pub strength: StrengthFlags,
}

/// `--load`: how the bar is loaded.
#[derive(clap::ValueEnum, Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum LoadArg {
    /// Direct tension: the top layer moves up.
    #[default]
    Tension,
    /// Uniaxial compression (UCS): the top layer moves down; broken bonds become frictional
    /// contacts where the engine makes them so; the peak is the first peak.
    Compression,
}

/// `--strength` and its options, shared by every engine.
#[derive(clap::Args, Clone, Debug)]
pub struct StrengthFlags {
    /// Run the strength test instead of the periodic element tests: the free packing pulled
    /// in direct tension to failure between held end layers (--axis, --end-layer) by the
    /// engine and by the integrator with the same bond law and limits (the model's
    /// [strength]); peak stress and the first broken bonds compared (needs --free).
    #[arg(long, conflicts_with = "specimen")]
    pub strength: bool,
    /// The strength test's loading: tension (direct tension) or compression (UCS).
    #[arg(long, value_enum, default_value_t = LoadArg::Tension)]
    pub load: LoadArg,
    /// Compression: the first peak ends where the force falls by this fraction of its
    /// running maximum after bonds broke.
    #[arg(long, default_value_t = 0.05)]
    pub peak_drop: f64,
    /// Axial strain added per time step (the top layer's speed).
    #[arg(long, default_value_t = 5e-7)]
    pub strain_per_step: f64,
    /// Time steps run, the same in the engine and the integrator.
    #[arg(long, default_value_t = 6000)]
    pub steps: u64,
    /// Damping ratio of the bonds' own dashpots (LAMMPS and the integrator's law d).
    #[arg(long, default_value_t = 0.3)]
    pub bond_damping: f64,
    /// Broken bonds compared in order.
    #[arg(long, default_value_t = 10)]
    pub compared: usize,
    /// Largest admissible relative difference of the peak stress.
    #[arg(long, default_value_t = 0.02)]
    pub strength_tolerance: f64,
}

impl StrengthFlags {
    /// The test on `asm` (axis and end layer from `specimen`'s flags; the end layer defaults
    /// to half the mean radius).
    pub fn test(
        &self,
        specimen: &SpecimenFlags,
        asm: &anisobond::assembly::Assembly,
    ) -> StrengthTest {
        let p = &asm.packing;
        let mean = p.radii.iter().sum::<f64>() / p.len().max(1) as f64;
        let mut t = StrengthTest::new(
            specimen.axis as usize,
            specimen.end_layer.unwrap_or(0.5 * mean),
            self.strain_per_step,
            self.steps,
        );
        t.damping_ratio = self.bond_damping;
        t.compared = self.compared;
        t.tolerance = self.strength_tolerance;
        t.peak_drop = self.peak_drop;
        t.loading = match self.load {
            LoadArg::Tension => StrengthLoading::Tension,
            LoadArg::Compression => StrengthLoading::Compression,
        };
        t
    }
}
