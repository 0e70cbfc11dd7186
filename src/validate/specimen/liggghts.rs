//! LIGGGHTS' specimen test, in the driver `anisobond-liggghts` (`pair_style anisobond`:
//! YADE's cohesive law in incremental form, mid-gap contact points): `specimen.in` reads the
//! free specimen (`boundary f f f`, `atom_style granular`, the end layers as atom types: 2
//! bottom, 3 top, 4 and 5 the bottom's lateral supports), holds the layers — `bonded`:
//! the top one `fix freeze` (force and torque zeroed), the bottom one not integrated,
//! `frictionless`: `fix setforce` on the axial force
//! only (and the supports' lateral forces) — and moves the top layer by its velocity over a
//! ramp (the shear springs are incremental: a layer moved by position would strain only the
//! normal springs; only the axial component is set and reset), then relaxes with the pair
//! style's viscous damping in chunks until the platen force settles. The platen force is
//! the fix's global vector: the force on the group before it was zeroed. The solve uses the
//! mid-gap contact point ([`LeverArm::MidGap`]).

use super::{
    atom_lines, box_lines, num, platens_name, relax_in_chunks, remaining_change, DeckPlan,
    DeckStart, EngineMeasurement, Launch, ScriptDeck, SpecimenTest,
};
use crate::assembly::Assembly;
use crate::bonds::table;
use crate::export::liggghts::{run_liggghts, Launch as RunLaunch};
use crate::homogenize::network::LeverArm;
use crate::specimen::Platens;
use crate::{Error, Result};
use std::fmt::Write as _;
use std::path::Path;

/// Default strain of LIGGGHTS' test.
pub const STRAIN: f64 = 1e-6;

/// Sub-directory of the validation directory LIGGGHTS runs in.
pub const DIR: &str = "liggghts-specimen";

/// Steps of the top layer's ramp.
pub const RAMP_STEPS: u64 = 200;

/// Steps between two readings of the platen force.
pub const CHUNK_STEPS: u64 = 500;

/// `specimen.data` in `dir`: atoms `id type diameter density x y z` in a box a margin
/// larger than the spheres; and the driver's bond table `bonds.csv`.
fn write_data(dir: &Path, asm: &Assembly, types: &[u8], density: f64, margin: f64) -> Result<()> {
    let packing = &asm.packing;
    let mut s = format!(
        "LIGGGHTS data file written by anisobond {}: free specimen (atom_style granular)\n\n\
         {} atoms\n5 atom types\n\n",
        env!("CARGO_PKG_VERSION"),
        packing.len()
    );
    s.push_str(&box_lines(packing, margin));
    s.push_str("\nAtoms\n\n");
    s.push_str(&atom_lines(packing, types, density, false));
    crate::io::write_string_atomic(&dir.join("specimen.data"), &s)?;
    table::write_bond_table(&dir.join("bonds.csv"), &asm.bonds, &asm.springs)
}

/// The deck's comment header: the test, how to run it, the atom types, how it loads and
/// relaxes.
fn deck_header(test: &SpecimenTest) -> String {
    let ax = test.axis;
    format!(
        "# anisobond → LIGGGHTS driver (pair_style anisobond) specimen test, {} platens along {}.\n\
         # Run:  anisobond-liggghts -in specimen.in   (or mpirun -np N anisobond-liggghts -in specimen.in)\n\
         # Atom types: 1 free, 2 bottom layer (held), 3 top layer (moved), 4 and 5 bottom supports.\n\
         # The top layer moves towards the bottom at `speed` for `ramp` steps, then is held; the\n\
         # pair style's viscous damping relaxes the specimen in chunks until the platen force's\n\
         # estimated remaining relative change and |F_top - F_bottom| / F_top are below `settle`.\n",
        platens_name(test.platens),
        ["x", "y", "z"][ax]
    )
}

/// The deck.
#[allow(clippy::too_many_arguments)]
fn deck(
    test: &SpecimenTest,
    speed: f64,
    dt: f64,
    damping: f64,
    skin: f64,
    far_block: usize,
    max_chunks: u64,
) -> String {
    let ax = test.axis;
    let along = |v: &str, other: &str| {
        let mut c = [other; 3];
        c[ax] = v;
        c.join(" ")
    };
    let mut support_a = ["0.0"; 3];
    support_a[ax] = "NULL";
    let mut support_far = ["NULL"; 3];
    support_far[far_block] = "0.0";
    let index = ax + 1;
    // LIGGGHTS allows one fix freeze: bonded platens freeze the moved top layer (its force
    // and torque zeroed, it moves with its velocity) and leave the bottom one out of the
    // integration (fix setforce only reads its reaction).
    let integrated = match test.platens {
        Platens::Bonded => "mobile",
        Platens::Frictionless => "all",
    };
    let mut s = deck_header(test);
    let _ = write!(
        s,
        "variable dt index {}\nvariable damp index {}\nvariable speed index {}\n\
         variable ramp index {RAMP_STEPS}\nvariable settle index {}\n\
         variable chunk_steps index {CHUNK_STEPS}\nvariable max_chunks index {max_chunks}\n\
         units si\natom_style granular\natom_modify map array\nboundary f f f\nnewton on\n\
         communicate single vel yes\nread_data specimen.data\n\
         pair_style anisobond table bonds.csv damping ${{damp}} ${{damp}}\npair_coeff * *\n\
         neighbor {} bin\nneigh_modify delay 0\ntimestep ${{dt}}\n\
         group bottom type 2 4 5\ngroup top type 3\ngroup support_a type 4\n\
         group support_far type 5\ngroup mobile subtract all bottom\n\
         fix integrate {integrated} nve/sphere\n\
         run 0\n",
        num(dt),
        num(damping),
        num(speed),
        num(test.settle),
        num(skin)
    );
    match test.platens {
        Platens::Bonded => {
            s.push_str("fix ftop top freeze\nfix fbottom bottom setforce 0.0 0.0 0.0\n")
        }
        Platens::Frictionless => {
            let f = along("0.0", "NULL");
            let _ = write!(
                s,
                "fix ftop top setforce {f}\nfix fbottom bottom setforce {f}\n\
                 fix fsupport_a support_a setforce {}\nfix fsupport_far support_far setforce {}\n",
                support_a.join(" "),
                support_far.join(" ")
            );
        }
    }
    let _ = write!(
        s,
        "velocity top set {} units box\nrun ${{ramp}}\nvelocity top set {} units box\n\
         variable ft equal f_ftop[{index}]\nvariable fb equal -f_fbottom[{index}]\n\
         variable st equal step\n",
        along(&num(-speed), "NULL"),
        along("0.0", "NULL")
    );
    relax_in_chunks(&mut s, "${ft}", "${fb}");
    s.push_str("print \"SPECIMEN ${f3} ${b3} ${f1} ${f2} ${st}\"\n");
    s
}

/// The driver's specimen test (one process, and `processes` when more): the deck
/// `write_deck` writes, run by `run_driver` and read by `read_result`.
pub(in crate::validate) const DECK: ScriptDeck = ScriptDeck {
    engine: "liggghts",
    shown: "LIGGGHTS",
    strain: STRAIN,
    lever_arm: LeverArm::MidGap,
    dir: DIR,
    deck_file: "specimen.in",
    write: write_deck,
    run_once: |start, launch, plan, np| {
        let (out, seconds) = run_driver(&launch.program, &start.dir, np)?;
        let (delta, dt) = (plan.delta, plan.dt);
        read_result(&out, np, &start.layers, delta, dt, seconds, &start.dir)
    },
};

/// Write the test's `specimen.data` into its directory; returns the deck `specimen.in`
/// with the plan's time step and damping rate and the top layer's speed.
fn write_deck(start: &DeckStart, launch: &Launch, plan: &DeckPlan) -> Result<String> {
    let DeckStart { test, asm, .. } = start;
    let (types, far_block) = &start.types;
    let max_len = asm.bonds.length.iter().copied().fold(0.0, f64::max);
    write_data(&start.dir, asm, types, launch.density, 2.0 * max_len)?;
    let speed = plan.delta / (RAMP_STEPS as f64 * plan.dt);
    Ok(deck(
        test,
        speed,
        plan.dt,
        plan.damping_rate,
        0.05 * max_len,
        *far_block,
        test.relax_chunks(CHUNK_STEPS),
    ))
}

/// Run `specimen.in` with the driver in `dir` on `np` processes, its log kept as
/// `log-npN.liggghts`; returns its output and wall time (s).
fn run_driver(driver: &Path, dir: &Path, np: usize) -> Result<(String, f64)> {
    let launch = RunLaunch {
        program: driver.to_path_buf(),
        mpi_processes: (np > 1).then_some(np),
        vars: Vec::new(),
    };
    let t0 = std::time::Instant::now();
    let out = run_liggghts(&launch, dir, "specimen.in")?;
    let seconds = t0.elapsed().as_secs_f64();
    let _ = std::fs::rename(
        dir.join("log.liggghts"),
        dir.join(format!("log-np{np}.liggghts")),
    );
    Ok((out, seconds))
}

/// The `SPECIMEN F_top F_bottom F_1 F_2 STEP` line the deck prints (the last three force
/// readings give the remaining change).
fn read_result(
    out: &str,
    np: usize,
    layers: &(Vec<usize>, Vec<usize>),
    delta: f64,
    dt: f64,
    seconds: f64,
    dir: &Path,
) -> Result<EngineMeasurement> {
    let bad = |m: &str| Error::engine("LIGGGHTS", format!("on {np} process(es): {m}"));
    let line = out
        .lines()
        .rev()
        .find_map(|l| l.trim().strip_prefix("SPECIMEN "))
        .ok_or_else(|| bad("no SPECIMEN line in its output"))?;
    let words: Vec<f64> = line
        .split_whitespace()
        .map(|w| w.parse::<f64>())
        .collect::<std::result::Result<_, _>>()
        .map_err(|e| bad(&format!("SPECIMEN line `{line}`: {e}")))?;
    let [f3, b3, f1, f2, steps] = words[..] else {
        return Err(bad(&format!("SPECIMEN line `{line}`: expected 5 numbers")));
    };
    let remaining = remaining_change(f1, f2, f3);
    let version = crate::export::liggghts::liggghts_version(out);
    Ok(EngineMeasurement {
        version,
        processes: np,
        bottom: layers.0.clone(),
        top: layers.1.clone(),
        displacement: delta,
        force_top: f3,
        force_bottom: b3,
        time_step: dt,
        steps: steps as u64,
        remaining,
        how: format!(
            "end layers as atom types; bonded: fix freeze, frictionless: fix setforce on the \
             axial force; the top layer moved by velocity over {RAMP_STEPS} steps; the pair \
             style's viscous damping, chunks of {CHUNK_STEPS} steps"
        ),
        seconds,
        dir: dir.to_path_buf(),
    })
}
