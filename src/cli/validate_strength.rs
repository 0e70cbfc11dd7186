//! `--strength` and its options, the same for every engine of `anisobond validate`: direct
//! tension of the free bar to failure in the engine and in the integrator with the same
//! law (issue 32). The axis and the end layers are `--axis` and `--end-layer` of
//! [`super::validate_specimen::SpecimenFlags`].

use super::validate_specimen::SpecimenFlags;
use anisobond::validate::strength::StrengthTest;

/// `--strength` and its options, shared by every engine.
#[derive(clap::Args, Clone, Debug)]
pub struct StrengthFlags {
    /// Run the strength test instead of the periodic element tests: the free packing pulled
    /// in direct tension to failure between held end layers (--axis, --end-layer) by the
    /// engine and by the integrator with the same bond law and limits (the model's
    /// [strength]); peak stress and the first broken bonds compared (needs --free).
    #[arg(long, conflicts_with = "specimen")]
    pub strength: bool,
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
        t
    }
}
