//! The engines' `--specimen` validations (YADE, LAMMPS, LIGGGHTS) set up and judged the same
//! way: one free bonded specimen, and the platen-stiffness checks of each process count.

use anisobond::assembly::Assembly;
use anisobond::model::Model;
use anisobond::schemes::Moments;
use anisobond::specimen::Platens;
use anisobond::validate::specimen::SpecimenDetails;
use anisobond::validate::Report;

/// The free 1,000-sphere specimen (a generated packing, seed 3, with its cell removed),
/// bonded by the anisotropic cubic model (Truszkowska 2018 MRV) with parallel-bond moments.
pub fn free_cubic_specimen() -> Assembly {
    let mut packing = super::bonded::generated(1000, 3);
    packing.cell = None;
    let mut model = Model::truszkowska_mrv();
    model.geometry.moments = Moments::ParallelBond;
    Assembly::new(packing, model).expect("bonded")
}

/// Each process count's platen-stiffness check of `r` (run by `engine`, e.g. "LAMMPS"):
/// printed, settled and within 1e-3 of the specimen solve; one run per process count.
pub fn check_platen_stiffness(
    test: &str,
    engine: &str,
    platens: Platens,
    r: &Report<SpecimenDetails>,
) {
    for (c, m) in r
        .checks
        .iter()
        .filter(|c| c.id.starts_with("platen-stiffness"))
        .zip(&r.measured)
    {
        eprintln!(
            "{test}: {platens:?} platens, np {}: {engine} {:.7e} N/m, solve {:.7e} N/m, \
             relative difference {:.3e}, {} steps, {:.1} s",
            m.processes,
            m.stiffness(),
            r.predicted.platen_stiffness,
            c.value,
            m.steps,
            m.seconds
        );
        assert!(c.not_converged.is_none(), "{engine} did not settle: {c:?}");
        assert!(c.value <= 1e-3, "{c:?}");
    }
}
