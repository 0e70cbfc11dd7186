//! LIGGGHTS' strength test, in the driver `anisobond-liggghts` (`pair_style anisobond`:
//! YADE's cohesive law in incremental form, each bond judged by YADE's CohFrict criterion,
//! the library's own, through the bridge): `strength.in` reads the free bar (`boundary f f
//! f`, `atom_style granular`, the end layers as atom types 2 bottom, 3 top) with every
//! atom's initial velocity (the `Velocities` section: the free spheres in the linear
//! velocity field, the top layer at the loading velocity), reads the bonds and their
//! adhesions from `bonds.csv` (the columns `export yade` writes, from the same
//! [`super::strength_setup`]), leaves the bottom layer out of the integration (held) and
//! freezes the top one (`fix freeze`: force and torque zeroed, it moves at its velocity; its
//! global vector is the layer's force before zeroing, printed every step). The pair style's
//! `breaks FILE` records every broken bond (step, ids, mode), gathered on rank 0 and sorted
//! by ids within a step, so the file is the same on any number of processes.
//!
//! Time stepping: LIGGGHTS' velocity Verlet (nve/sphere) and the integrator's leapfrog give
//! the same positions in exact arithmetic when nothing depends on the velocity (the
//! undamped history of [`crate::validate::liggghts`]); both run **undamped** here (no
//! viscous damping in the pair style, no Cundall damping in the integrator), so the
//! comparison is of the same law and criterion, not of two damping schemes. The test's
//! `damping_ratio` (bond dashpots of LAMMPS' law) does not apply: law (a) has none. The
//! integrator runs law (a) with *incremental* moments (the driver's convention) and the same
//! springs, adhesions and time step. LIGGGHTS' step n evaluates the forces at x_n, as the
//! integrator's iteration n, so the break steps compare one to one.
//!
//! In compression (the UCS test) both turn broken bonds into frictional contacts and let
//! spheres that come into touch make new ones: the pair style's `contacts KN KS MU` is the
//! integrator's [`crate::dem::Contacts`] law (a broken bond's pair with the bond's springs,
//! new pairs with [`super::contact_law`]'s, every contact its friction; a shear-broken bond's
//! capped trial shear force handed on), and [`Loading::contacts`] turns the integrator's on.
//! The peak is then the first peak ([`super::peak_of`]).

use super::{
    compare, order_breaks, peak_of, reference, runs_per_process, Launch, Loading, Start,
    StrengthDetails, StrengthRun, StrengthTest,
};
use crate::dem::laws::{LinearBondKernel, MomentForm};
use crate::dem::{ContactLaw, LawKind};
use crate::export::liggghts::{run_liggghts, Launch as RunLaunch};
use crate::export::yade::{adhesions_of, write_bond_table_with_adhesions};
use crate::validate::harness::{Problem, Progress, Report};
use crate::validate::specimen::{atom_lines, box_lines, num};
use crate::{Error, Result};
use std::fmt::Write as _;
use std::path::Path;

/// Sub-directory of the validation directory LIGGGHTS runs in.
pub const DIR: &str = "liggghts-strength";

/// The deck the driver runs (in [`DIR`]).
pub const DECK: &str = "strength.in";

/// The top layer's force per step, written by the deck on `np` processes.
fn force_file(np: usize) -> String {
    format!("force-np{np}.txt")
}

/// The pair style's broken bonds on `np` processes.
fn breaks_file(np: usize) -> String {
    format!("breaks-np{np}.txt")
}

/// Run the driver's strength test of `problem`'s free bar on each process count and the
/// integrator's with law (a) (incremental moments), both undamped, and compare; in
/// compression both with frictional contacts after breaking.
pub fn run(
    launch: &Launch,
    problem: &Problem,
    test: &StrengthTest,
    progress: Progress,
) -> Result<Report<StrengthDetails>> {
    let (packing, bonds, k) = (problem.packing, problem.bonds, problem.springs);
    let Start {
        strengths,
        criteria,
        loading,
        dir,
        ..
    } = Start::of("liggghts", LawKind::Yade, DIR, problem, launch, test)?;
    let dt = loading.time_step;
    let adhesions = adhesions_of(packing, bonds, &strengths);
    write_bond_table_with_adhesions(&dir.join("bonds.csv"), bonds, k, None, &adhesions)?;
    write_data(&dir, problem, test, &loading, launch.density)?;
    let max_len = bonds.length.iter().copied().fold(0.0, f64::max);
    crate::io::write_string_atomic(
        &dir.join(DECK),
        &deck(test, dt, 0.05 * max_len, loading.contacts.as_ref()),
    )?;
    let mut timings = Vec::new();
    // Law (a) with YADE's `useIncrementalForm = True` moments (the driver's convention; law
    // a's own are the total form): still YADE's law, so it keeps law a's name, which the
    // criteria of `strength_setup` are made for.
    let law = Box::new(LinearBondKernel::new(
        "yade",
        [&k.kn, &k.ks, &k.kr, &k.ktw],
        MomentForm::Incremental,
        None,
    )?);
    let reference = reference(problem, law, criteria, launch.density, 0.0, &loading, test)?;
    reference.record(&mut timings, progress);
    let (stage, who) = ("liggghts", "LIGGGHTS");
    let measured = runs_per_process(launch, stage, who, &mut timings, progress, |np| {
        for f in [force_file(np), breaks_file(np)] {
            let _ = std::fs::remove_file(dir.join(f));
        }
        let run = RunLaunch {
            program: launch.program.clone(),
            mpi_processes: (np > 1).then_some(np),
            vars: vec![
                ("force".into(), force_file(np)),
                ("breaks".into(), breaks_file(np)),
            ],
        };
        let t0 = std::time::Instant::now();
        let out = run_liggghts(&run, &dir, DECK)?;
        let seconds = t0.elapsed().as_secs_f64();
        let _ = std::fs::rename(
            dir.join("log.liggghts"),
            dir.join(format!("log-np{np}.liggghts")),
        );
        read_run(&dir, problem, test, &loading, np, &out, seconds)
    })?;
    compare(
        "liggghts", "yade", test, problem, reference, measured, dt, timings,
    )
}

/// `strength.data`: atoms `id type diameter density x y z` (type 2 the bottom layer, 3 the
/// top one, 1 free) and their `Velocities` (`id vx vy vz wx wy wz`): the loading's.
fn write_data(
    dir: &Path,
    problem: &Problem,
    test: &StrengthTest,
    loading: &Loading,
    density: f64,
) -> Result<()> {
    let packing = problem.packing;
    let n = packing.len();
    let types = loading.atom_types(n);
    let max_len = problem.bonds.length.iter().copied().fold(0.0, f64::max);
    let mut s = format!(
        "LIGGGHTS data file written by anisobond {}: strength test, free bar (atom_style \
         granular)\n\n{n} atoms\n3 atom types\n\n",
        env!("CARGO_PKG_VERSION"),
    );
    s.push_str(&box_lines(packing, 2.0 * max_len));
    s.push_str("\nAtoms\n\n");
    s.push_str(&atom_lines(packing, &types, density, false));
    s.push_str("\nVelocities\n\n");
    let ax = test.axis;
    for (p, (&t, x)) in types.iter().zip(&packing.positions).enumerate() {
        let v = match t {
            2 => 0.0,
            3 => loading.velocity,
            _ => loading.velocity * (x[ax] - loading.lowest) / loading.gauge,
        };
        let mut vel = [0.0; 3];
        vel[ax] = v;
        let _ = writeln!(
            s,
            "{} {} {} {} 0 0 0",
            p + 1,
            num(vel[0]),
            num(vel[1]),
            num(vel[2])
        );
    }
    crate::io::write_string_atomic(&dir.join("strength.data"), &s)
}

/// The deck: read, bond (with `breaks ${breaks}`, and `contacts KN KS MU` when `contacts`
/// is given), hold the bottom, freeze the top, print the top layer's axial force every step
/// to `${force}`, run `test.steps`.
fn deck(test: &StrengthTest, dt: f64, skin: f64, contacts: Option<&ContactLaw>) -> String {
    let contacts = contacts.map_or(String::new(), |c| {
        format!(
            " contacts {} {} {}",
            num(c.normal_stiffness),
            num(c.shear_stiffness),
            num(c.friction)
        )
    });
    format!(
        "# anisobond → LIGGGHTS driver (pair_style anisobond) strength test: {what} along {axn}.\n\
         # Run:  anisobond-liggghts -in {DECK} -var force F -var breaks B   (or under mpirun -np N)\n\
         # Atom types: 1 free, 2 bottom layer (not integrated: held), 3 top layer (fix freeze: moves\n\
         # at its initial velocity). Undamped. Output: the top layer's axial force per step (F, the\n\
         # force on the layer before freeze zeroes it: tension negative) and the broken bonds (B).\n\
         units si\natom_style granular\natom_modify map array\nboundary f f f\nnewton on\n\
         communicate single vel yes\nread_data strength.data\n\
         pair_style anisobond table bonds.csv breaks ${{breaks}}{contacts}\npair_coeff * *\n\
         neighbor {skin} bin\nneigh_modify delay 0\ntimestep {dt}\n\
         group bottom type 2\ngroup top type 3\ngroup mobile subtract all bottom\n\
         fix integrate mobile nve/sphere\nfix ftop top freeze\n\
         variable st equal step\nvariable ft equal f_ftop[{index}]\n\
         fix hist all print 1 \"${{st}} ${{ft}}\" file ${{force}} screen no title \"# step top_force_N\"\n\
         thermo 1000\n\
         run {steps}\n",
        what = test.loading.describe(),
        axn = ["x", "y", "z"][test.axis],
        skin = num(skin),
        dt = num(dt),
        index = test.axis + 1,
        steps = test.steps,
    )
}

/// One run's result: the peak of the top layer's load (sign × −F: tensile in tension, the
/// first compressive peak in compression, [`peak_of`]) and the broken bonds (ids → packing
/// indices).
fn read_run(
    dir: &Path,
    problem: &Problem,
    test: &StrengthTest,
    loading: &Loading,
    np: usize,
    out: &str,
    seconds: f64,
) -> Result<StrengthRun> {
    let bad = |m: String| Error::engine("LIGGGHTS", format!("on {np} process(es): {m}"));
    let fpath = dir.join(force_file(np));
    let text = crate::io::read_to_string(&fpath)?;
    let mut curve = Vec::new();
    for (ln, line) in text.lines().enumerate() {
        if line.starts_with('#') || line.trim().is_empty() {
            continue;
        }
        let w: Vec<&str> = line.split_whitespace().collect();
        let parsed = match w[..] {
            [s, f] => s.parse::<f64>().ok().zip(f.parse::<f64>().ok()),
            _ => None,
        };
        let (s, f) = parsed.ok_or_else(|| {
            bad(format!(
                "{} line {}: expected `step force`, got `{line}`",
                fpath.display(),
                ln + 1
            ))
        })?;
        curve.push((s as u64, loading.sign * -f));
    }
    if curve.is_empty() {
        return Err(bad(format!("{}: no force recorded", fpath.display())));
    }
    let bpath = dir.join(breaks_file(np));
    let text = crate::io::read_to_string(&bpath)?;
    let n = problem.packing.len() as u64;
    let mut raw = Vec::new();
    for (ln, line) in text.lines().enumerate() {
        if line.starts_with('#') || line.trim().is_empty() {
            continue;
        }
        let w: Vec<&str> = line.split_whitespace().collect();
        raw.push(parse_break(&w, n).ok_or_else(|| {
            bad(format!(
                "{} line {}: expected `step id_i id_j tension|shear` with ids 1…{n}, got `{line}`",
                bpath.display(),
                ln + 1
            ))
        })?);
    }
    let version = crate::export::liggghts::liggghts_version(out);
    let breaks = order_breaks("LIGGGHTS", problem.bonds, &raw)?;
    let (peak_force, peak_step) = peak_of(test, &curve, &breaks)
        .filter(|p| p.0.is_finite())
        .ok_or_else(|| bad(format!("{}: no finite force recorded", fpath.display())))?;
    Ok(StrengthRun {
        program: format!("LIGGGHTS driver ({version})"),
        processes: np,
        peak_force,
        peak_step,
        breaks,
        seconds,
    })
}

/// A line `step id_i id_j tension|shear` of the pair style's record as packing indices and
/// the step; `None` when malformed or an id is outside 1…`n`.
fn parse_break(w: &[&str], n: u64) -> Option<(usize, usize, u64)> {
    let [s, i, j, "tension" | "shear"] = w[..] else {
        return None;
    };
    let (s, i, j) = (
        s.parse::<u64>().ok()?,
        i.parse::<u64>().ok()?,
        j.parse::<u64>().ok()?,
    );
    (i >= 1 && j >= 1 && i <= n && j <= n).then(|| ((i - 1) as usize, (j - 1) as usize, s))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn break_lines_are_read_as_indices_and_bad_ones_refused() {
        let w = |l: &'static str| l.split_whitespace().collect::<Vec<_>>();
        assert_eq!(parse_break(&w("12 3 7 tension"), 8), Some((2, 6, 12)));
        assert_eq!(parse_break(&w("5 1 8 shear"), 8), Some((0, 7, 5)));
        for bad in [
            "12 0 7 tension",
            "12 3 9 tension",
            "12 3 7 bending",
            "12 3 tension",
            "x 3 7 shear",
        ] {
            assert_eq!(parse_break(&w(bad), 8), None, "{bad}");
        }
    }

    #[test]
    fn the_deck_names_the_record_and_the_axis() {
        let t = StrengthTest::new(1, 1e-4, 1e-6, 300);
        let d = deck(&t, 1e-7, 1e-5, None);
        assert!(d.contains("pair_style anisobond table bonds.csv breaks ${breaks}\n"));
        assert!(d.contains("variable ft equal f_ftop[2]"));
        assert!(d.contains("run 300\n"));
        assert!(d.contains("direct tension along y"));
        assert!(!d.contains("damping"));
        assert!(!d.contains("contacts"));
        let c = ContactLaw {
            normal_stiffness: 2e6,
            shear_stiffness: 7e5,
            friction: 0.5,
        };
        let d = deck(&t.compression(), 1e-7, 1e-5, Some(&c));
        assert!(
            d.contains("breaks ${breaks} contacts 2e6 7e5 5e-1\n"),
            "{d}"
        );
        assert!(d.contains("uniaxial compression along y"));
    }
}
