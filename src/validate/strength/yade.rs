//! YADE's strength test, law (a): `export yade`'s files (packing, `bonds.csv` with each
//! bond's `normal_adhesion, shear_adhesion, tan_friction` from the model's `[strength]`,
//! the `anisobond_yade` module) and `strength.py`, which builds the scene (`build_scene`:
//! CohFrictMat, fragile CohFrictPhys with the table's adhesions, Cundall damping
//! [`DAMPING`]), holds the bottom layer and moves the top one (`blockedDOFs`, constant
//! velocity), starts the free spheres in the linear velocity field and steps, reading the
//! top layer's force every step. A broken bond is found when YADE's count of real
//! interactions drops (a bond broken in tension is erased at once: a full scan) or by its
//! `cohesionBroken` flag, read every step on the bonds' own CohFrictPhys (a bond broken in
//! shear stays a frictional contact); every [`SCAN_EVERY`] steps a full scan besides. The
//! integrator runs law (a) with the same springs, adhesions and local damping.
//!
//! In compression the integrator turns frictional contacts on ([`crate::dem::Contacts`],
//! [`super::contact_law`]), since YADE keeps a bond broken in shear as a frictional contact
//! with the bond's springs and friction. Differences that remain (docs/strength.md, "The
//! same test in the engines"): YADE's scene has no collider, so spheres that were not bonded
//! never touch in YADE (the integrator's do). A shear-broken bond's shear force, capped at
//! μ·F_n, goes on in both (`crate::dem::BondCriterion::handed_on_shear`).

use super::{
    compare, order_breaks, reference, Launch, Loading, Start, StrengthDetails, StrengthRun,
    StrengthTest,
};
use crate::dem::{build_law, LawKind};
use crate::export::yade::{
    adhesions_of, files, run_yade_script, write_bond_table_with_adhesions, YADE_MODULE,
};
use crate::validate::harness::{Problem, Progress, Report};
use crate::Result;
use std::path::Path;

/// Sub-directory of the validation directory YADE runs in.
pub const DIR: &str = "yade-strength";

/// Cundall local damping (YADE's `NewtonIntegrator.damping`, the integrator's
/// `local_damping`).
pub const DAMPING: f64 = 0.4;

/// Steps between full scans of the bonds' `cohesionBroken`.
pub const SCAN_EVERY: u64 = 50;

/// The script YADE runs (in [`DIR`]).
pub const SCRIPT: &str = "strength.py";

/// YADE's result (in [`DIR`]).
pub const RESULT: &str = "yade-strength.json";

/// `strength.py`: build, hold, move, step `steps` times, record force and broken bonds.
fn script(test: &StrengthTest, loading: &Loading, density: f64) -> String {
    let minus = if loading.sign > 0.0 { "-" } else { "" };
    let bottom: Vec<String> = loading.bottom.iter().map(|p| p.to_string()).collect();
    let top: Vec<String> = loading.top.iter().map(|p| p.to_string()).collect();
    format!(
        "# Written by anisobond {ver}: YADE strength test ({name} along axis {ax}).\n\
         # Run:  yade -n -x {SCRIPT}   (writes {RESULT} here)\n\
         import json, os, sys, time\n\
         sys.dont_write_bytecode = True\n\
         HERE = os.path.dirname(os.path.abspath(sys.argv[0]))\n\
         sys.path.insert(0, HERE)\n\
         import anisobond_yade as ay  # noqa: E402\n\
         from yade import O  # noqa: E402\n\
         import yade  # noqa: E402\n\
         packing = ay.read_packing(os.path.join(HERE, 'packing.txt'))\n\
         bonds = ay.read_bond_table(os.path.join(HERE, 'bonds.csv'), len(packing))\n\
         if not ay.has_adhesions(bonds):\n    raise SystemExit('bonds.csv has no adhesion columns')\n\
         scene = ay.build_scene(packing, bonds, density={density:e}, damping={DAMPING}, dt={dt:e})\n\
         AX, V, LO, GAUGE = {ax}, {v:e}, {lo:e}, {gauge:e}\n\
         bottom = [{bottom}]\n\
         top = [{top}]\n\
         held = set(bottom) | set(top)\n\
         for k in range(len(packing)):\n\
         \x20   s = O.bodies[k].state\n\
         \x20   vel = [0.0, 0.0, 0.0]\n\
         \x20   vel[AX] = V if k in top else (0.0 if k in held else V * (packing.positions[k][AX] - LO) / GAUGE)\n\
         \x20   s.vel = tuple(vel)\n\
         \x20   s.angVel = (0, 0, 0)\n\
         \x20   if k in held:\n\
         \x20       s.blockedDOFs = 'xyzXYZ'\n\
         intact = set(range(len(bonds)))\n\
         broken = []\n\
         phys = [I.phys for I in scene.interactions]\n\
         def scan(step):\n\
         \x20   for b in sorted(intact):\n\
         \x20       I = O.interactions[bonds.i[b], bonds.j[b]]\n\
         \x20       if I is None or not I.isReal or I.phys.cohesionBroken:\n\
         \x20           intact.discard(b)\n\
         \x20           broken.append([bonds.i[b], bonds.j[b], step])\n\
         force = []\n\
         real = O.interactions.countReal()\n\
         t0 = time.time()\n\
         for n in range({steps}):\n\
         \x20   step = O.iter\n\
         \x20   O.step()\n\
         \x20   force.append([step, {minus}sum(O.forces.f(k)[AX] for k in top)])\n\
         \x20   now = O.interactions.countReal()\n\
         \x20   if now != real or (n + 1) % {SCAN_EVERY} == 0:\n\
         \x20       scan(step)\n\
         \x20       real = now\n\
         \x20   else:\n\
         \x20       for b in [b for b in intact if phys[b].cohesionBroken]:\n\
         \x20           intact.discard(b)\n\
         \x20           broken.append([bonds.i[b], bonds.j[b], step])\n\
         with open(os.path.join(HERE, '{RESULT}'), 'w') as out:\n\
         \x20   json.dump({{'version': yade.config.version if hasattr(yade, 'config') else 'unknown',\n\
         \x20              'force': force, 'broken': broken,\n\
         \x20              'dt': O.dt, 'seconds': time.time() - t0}}, out)\n",
        ver = env!("CARGO_PKG_VERSION"),
        ax = test.axis,
        name = test.loading.describe(),
        dt = loading.time_step,
        v = loading.velocity,
        lo = loading.lowest,
        gauge = loading.gauge,
        bottom = bottom.join(", "),
        top = top.join(", "),
        steps = test.steps,
    )
}

/// Run YADE's strength test of `problem`'s free bar and the integrator's with law (a), and
/// compare.
pub fn run(
    launch: &Launch,
    problem: &Problem,
    test: &StrengthTest,
    progress: Progress,
) -> Result<Report<StrengthDetails>> {
    let (packing, bonds, k) = (problem.packing, problem.bonds, problem.springs);
    crate::export::yade::check_yade_runnable(problem.model)?;
    let start = Start::of("yade", LawKind::Yade, DIR, problem, launch, test)?;
    let (loading, dir) = (&start.loading, &start.dir);
    // The free bar's files as `export yade` writes them (it exports periodic packings only):
    // the packing, the bond table with each bond's adhesions, the module.
    let adhesions = adhesions_of(packing, bonds, &start.strengths);
    crate::packing::io::write_packing(&dir.join(files::PACKING), packing)?;
    write_bond_table_with_adhesions(&dir.join(files::BONDS), bonds, k, None, &adhesions)?;
    crate::io::write_string_atomic(&dir.join(files::MODULE), YADE_MODULE)?;
    let script_path = dir.join(SCRIPT);
    crate::io::write_string_atomic(&script_path, &script(test, loading, launch.density))?;
    let mut timings = Vec::new();
    let law = build_law(LawKind::Yade, packing, bonds, k)?;
    let (criteria, density) = (start.criteria, launch.density);
    let reference = reference(problem, law, criteria, density, DAMPING, loading, test)?;
    reference.record(&mut timings, progress);
    let out = run_yade_script(&script_path, &[])?;
    let m = read_result(&dir.join(RESULT), problem, test, out.wall_seconds)?;
    m.record_stage("yade_process".into(), "YADE:", &mut timings, progress);
    let dt = loading.time_step;
    compare(
        "yade",
        "yade",
        test,
        problem,
        reference,
        vec![m],
        dt,
        timings,
    )
}

/// The rows of the JSON array `v[key]`, each an array read by `row`; `None` when the key is
/// not an array or any row is refused.
fn json_rows<T>(
    v: &serde_json::Value,
    key: &str,
    row: impl Fn(&[serde_json::Value]) -> Option<T>,
) -> Option<Vec<T>> {
    v[key]
        .as_array()?
        .iter()
        .map(|r| row(r.as_array()?))
        .collect()
}

/// Read `strength.py`'s JSON (body ids are the packing's indices).
fn read_result(
    path: &Path,
    problem: &Problem,
    test: &StrengthTest,
    seconds: f64,
) -> Result<StrengthRun> {
    let (v, bad) = crate::export::yade::read_result_json(path)?;
    let n = problem.packing.len() as u64;
    let raw = json_rows(&v, "broken", |r| {
        let (i, j, s) = (
            r.first()?.as_u64()?,
            r.get(1)?.as_u64()?,
            r.get(2)?.as_u64()?,
        );
        (i < n && j < n).then_some((i as usize, j as usize, s))
    })
    .ok_or_else(|| bad("broken"))?;
    let curve = json_rows(&v, "force", |r| {
        let f = r.get(1)?.as_f64()?;
        f.is_finite().then_some((r.first()?.as_u64()?, f))
    })
    .ok_or_else(|| bad("force"))?;
    let breaks = order_breaks("YADE", problem.bonds, &raw)?;
    let (peak_force, peak_step) =
        super::peak_of(test, &curve, &breaks).ok_or_else(|| bad("force"))?;
    Ok(StrengthRun {
        program: format!("YADE ({})", v["version"].as_str().unwrap_or("unknown")),
        processes: 1,
        peak_force,
        peak_step,
        breaks,
        seconds,
    })
}
