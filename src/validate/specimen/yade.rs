//! YADE's specimen test: `anisobond_yade.platen_main` builds the free scene of the packing
//! and bond table (`build_scene`, `O.periodic = False`) and runs `platen_test` — the end
//! layers' `blockedDOFs`, the top layer moved at constant axial speed (YADE's shear
//! springs are incremental: a layer moved by position would strain only the normal
//! springs), Cundall damping [`DAMPING`], relaxed until the force settles. The solve uses
//! YADE's mid-gap contact point ([`LeverArm::MidGap`]).

use super::{
    compare, free_assembly, platens_name, predict_reported, EngineMeasurement, Launch,
    SpecimenDetails, SpecimenTest,
};
use crate::bonds::table;
use crate::export::yade::{files, run_yade_script, YADE_MODULE};
use crate::homogenize::network::LeverArm;
use crate::packing;
use crate::validate::harness::{reads_back_same, Problem, Progress};
use crate::validate::harness::{Report, Timing};
use crate::{Error, Result};
use std::path::Path;

/// Cundall local damping of YADE's platen test (fast relaxation; no effect on the
/// equilibrium).
pub const DAMPING: f64 = 0.8;

/// Default strain of YADE's test.
pub const STRAIN: f64 = 1e-6;

/// Sub-directory of the validation directory YADE runs in.
pub const DIR: &str = "yade-specimen";

/// The script YADE runs (in [`DIR`]).
pub const SCRIPT: &str = "platen.py";

/// YADE's result (in [`DIR`]).
pub const RESULT: &str = "yade-platen.json";

/// The `platen.py` text: `anisobond_yade.platen_main` with the directory's files and
/// `args`; arguments given to `yade -n -x platen.py …` override them.
fn script(args: &[(&str, String)]) -> String {
    let mut s = format!(
        "# Written by anisobond {}: YADE platen test of a free bonded specimen.\n\
         # Run:  yade -n -x {SCRIPT}   (writes {RESULT} here; options after the script name\n\
         #       override: --axis --depth --platens --strain --damping --density --dt --safety\n\
         #       --ramp-steps --check-every --tolerance --max-steps)\n\
         import os\nimport sys\n\n\
         sys.dont_write_bytecode = True\n\
         HERE = os.path.dirname(os.path.abspath(sys.argv[0]))  # YADE sets no __file__\n\
         sys.path.insert(0, HERE)\n\
         import anisobond_yade  # noqa: E402\n\n\
         DEFAULTS = [\n    \"--packing\", os.path.join(HERE, {:?}),\n    \"--bonds\", \
         os.path.join(HERE, {:?}),\n    \"--out\", os.path.join(HERE, {RESULT:?}),\n",
        env!("CARGO_PKG_VERSION"),
        files::PACKING,
        files::BONDS
    );
    for (flag, value) in args {
        s += &format!("    {flag:?}, {value:?},\n");
    }
    s += "]\n\nanisobond_yade.platen_main(DEFAULTS + sys.argv[1:])\n";
    s
}

/// Run YADE's platen test of `problem`'s free specimen and compare with the solve.
pub fn run(
    opts: &Launch,
    problem: &Problem,
    test: &SpecimenTest,
    progress: Progress,
) -> Result<Report<SpecimenDetails>> {
    let test = &test.resolved(STRAIN);
    let asm = free_assembly(problem, "yade")?;
    crate::export::yade::check_yade_runnable(problem.model)?;
    let dir = problem.dir.join(DIR);
    std::fs::create_dir_all(&dir).map_err(|e| Error::io(&dir, e))?;
    packing::io::write_packing(&dir.join(files::PACKING), &asm.packing)?;
    table::write_bond_table(&dir.join(files::BONDS), &asm.bonds, &asm.springs)?;
    crate::io::write_string_atomic(&dir.join(files::MODULE), YADE_MODULE)?;
    // anisobond solves what YADE reads.
    let p2 = packing::io::read_packing(&dir.join(files::PACKING))?;
    let (b2, k2) = table::read_bond_table(&dir.join(files::BONDS))?;
    if !reads_back_same((&asm.packing, &asm.bonds, &asm.springs), (&p2, &b2, &k2)) {
        return Err(Error::Invalid(
            "validate yade --specimen: the packing or bond table YADE reads does not read back \
             bit for bit; the two codes would not load the same specimen"
                .into(),
        ));
    }
    let script_path = dir.join(SCRIPT);
    crate::io::write_string_atomic(&script_path, &script(&platen_args(test, opts)))?;
    let mut timings = Vec::new();
    let predicted = predict_reported(&asm, test, LeverArm::MidGap, &mut timings, progress)?;
    let out = run_yade_script(&script_path, &[])?;
    timings.push(Timing {
        stage: "yade_process".into(),
        seconds: out.wall_seconds,
    });
    let mut measured = read_result(&dir.join(RESULT), asm.packing.len(), out.wall_seconds)?;
    measured.dir = dir;
    progress(&format!(
        "YADE: platen test done in {:.1} s ({} steps): platen stiffness {:.7e} N/m",
        out.wall_seconds,
        measured.steps,
        measured.stiffness()
    ));
    compare(
        "yade",
        test,
        LeverArm::MidGap,
        &asm,
        predicted,
        vec![measured],
        timings,
    )
}

/// The options of `platen_main` for `test` (flag, value): the end layers, the platens, the
/// strain, the damping, the density, the time step, the settling rule.
fn platen_args(test: &SpecimenTest, opts: &Launch) -> Vec<(&'static str, String)> {
    let mut args = vec![
        ("--axis", test.axis.to_string()),
        ("--depth", format!("{:e}", test.end_layer)),
        ("--platens", platens_name(test.platens).into()),
        ("--strain", format!("{:e}", test.strain())),
        ("--damping", DAMPING.to_string()),
        ("--density", format!("{:e}", opts.density)),
        ("--safety", opts.safety.to_string()),
        ("--tolerance", format!("{:e}", test.settle)),
        ("--max-steps", test.max_steps.to_string()),
    ];
    if let Some(dt) = opts.time_step {
        args.push(("--dt", format!("{dt:e}")));
    }
    args
}

/// The `remaining` of `platen_main`'s JSON `v` (read from `path`): the estimated remaining
/// relative change of the force when the run stopped. `null` is YADE's "no estimate": the
/// last changes were not decaying, so the run ended at `--max-steps` without settling
/// ([`Error::NotConverged`]); a result without the key, or not a number, is
/// [`Error::EngineFailed`]. Never a stand-in number that would then be judged.
fn remaining(v: &serde_json::Value, path: &Path) -> Result<f64> {
    match v.get("remaining") {
        Some(serde_json::Value::Null) => Err(Error::NotConverged(format!(
            "validate yade --specimen: YADE's platen test stopped after {} steps without \
             settling: {} gives no estimate of the remaining change of the force (`remaining` \
             is null: the force was not decaying); relax longer (--max-steps) or loosen \
             --settle",
            v["steps"].as_u64().map_or("?".into(), |n| n.to_string()),
            path.display()
        ))),
        Some(r) => r.as_f64().filter(|r| r.is_finite()).ok_or_else(|| {
            Error::engine(
                "YADE",
                format!(
                    "{}: `remaining` is {r}, expected the estimated remaining relative change \
                     (a number)",
                    path.display()
                ),
            )
        }),
        None => Err(Error::engine(
            "YADE",
            format!(
                "{}: no `remaining` in YADE's result (the estimated remaining relative change \
                 of the force): the two cannot be compared without knowing the run settled",
                path.display()
            ),
        )),
    }
}

/// Read `platen_main`'s JSON; body ids are the packing's indices (`build_scene` appends
/// the spheres in order).
fn read_result(path: &Path, n: usize, seconds: f64) -> Result<EngineMeasurement> {
    let (v, bad) = crate::export::yade::read_result_json(path)?;
    let num = |k: &str| v[k].as_f64().ok_or_else(|| bad(k));
    let ids = |k: &str| -> Result<Vec<usize>> {
        let mut out = v[k]
            .as_array()
            .ok_or_else(|| bad(k))?
            .iter()
            .map(|x| x.as_u64().map(|i| i as usize).filter(|&i| i < n))
            .collect::<Option<Vec<usize>>>()
            .ok_or_else(|| bad(k))?;
        out.sort_unstable();
        Ok(out)
    };
    Ok(EngineMeasurement {
        version: v["yade"]["version"]
            .as_str()
            .unwrap_or("unknown")
            .to_string(),
        processes: 1,
        bottom: ids("bottom")?,
        top: ids("top")?,
        displacement: num("displacement")?,
        force_top: num("force_top")?,
        force_bottom: num("force_bottom")?,
        time_step: num("dt")?,
        steps: v["steps"].as_u64().ok_or_else(|| bad("steps"))?,
        remaining: remaining(&v, path)?,
        how: format!(
            "blockedDOFs on the end layers, the top layer moved at constant axial speed over \
             {} steps, Cundall damping {}, relaxed until the force settled",
            v["ramp_steps"].as_u64().unwrap_or(0),
            num("damping")?
        ),
        seconds,
        dir: Default::default(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A `platen_main` result of 4 spheres, with `remaining` as given (`None`: no key).
    fn result(remaining: Option<&str>) -> String {
        let mut s = String::from(
            "{\"yade\": {\"version\": \"2023.02a\"}, \"bottom\": [0, 1], \"top\": [2, 3], \
             \"displacement\": 1e-9, \"force_top\": 2e-3, \"force_bottom\": 2e-3, \"dt\": 1e-7, \
             \"steps\": 5000, \"ramp_steps\": 200, \"damping\": 0.8",
        );
        if let Some(r) = remaining {
            s += &format!(", \"remaining\": {r}");
        }
        s + "}"
    }

    fn read(remaining: Option<&str>) -> Result<EngineMeasurement> {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join(RESULT);
        std::fs::write(&path, result(remaining)).unwrap();
        read_result(&path, 4, 1.0)
    }

    #[test]
    fn a_settled_result_keeps_its_remaining_change() {
        let m = read(Some("3e-7")).unwrap();
        assert_eq!(m.remaining, 3e-7);
        assert_eq!((m.force_top / m.displacement, m.steps), (2e6, 5000));
    }

    #[test]
    fn a_missing_remaining_change_is_an_engine_failure_not_a_number() {
        for (r, named) in [(None, "no `remaining`"), (Some("\"x\""), "`remaining` is")] {
            let e = read(r).unwrap_err();
            assert!(matches!(e, Error::EngineFailed { .. }), "{e}");
            assert!(e.to_string().contains(named), "{e}");
        }
    }

    #[test]
    fn no_estimate_from_yade_is_not_converged() {
        let e = read(Some("null")).unwrap_err();
        assert!(matches!(e, Error::NotConverged(_)), "{e}");
        assert!(e.to_string().contains("5000 steps"), "{e}");
    }
}
