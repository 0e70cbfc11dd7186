//! The LIGGGHTS pair style breaks bonds with anisobond's strengths (issue 32, item 5): a
//! bonded simple-cubic bar (3 × 3 × 8 touching spheres, R = 1 mm, in a free `f f f` box) with
//! a `[strength]` table — bonds σ_t = 5 MPa, c = 10 MPa, a plane of weakness z = 11 mm between
//! layers 3 and 4 with σ_t = 2 MPa — run by the driver (`pair_style anisobond`) in the test:
//! bottom layer held (`fix setforce`, its reaction the measured force), top layer moved along
//! +z at a constant speed (`fix freeze`), light viscous damping. Every bond carries YADE's
//! CohFrict limits (a_n = σ_t·r², r = min radius) and is judged by the library's
//! `yade_cohfrict` through the bridge.
//!
//! Compared against: the closed form bonds per section × a_n of the joint = 9 × 2 MPa × R²
//! = 18 N for the largest force before a bond breaks; the bonds broken (LIGGGHTS' own
//! `compute reduce` of the pair style's per-atom counts) = the 9 joint bonds, the bonds left
//! 159 − 9; on one and two MPI processes (the bar split across the plane); with the bonds and
//! limits from the model bonding in place and from the bond table `anisobond export yade`
//! writes (its adhesion columns); a model without `[strength]`: nothing breaks past twice
//! the limit.

use crate::common::liggghts::*;
use crate::common::{bin, succeeds, write};
use anisobond::export::liggghts::{run_liggghts, Launch};
use std::path::Path;

const TOOLS: &[&str] = &["liggghts", "mpicxx", "mpirun", "make", "g++"];
const R: f64 = 1e-3;
const D: f64 = 2.0 * R;
const ORIGIN: f64 = 0.004;
const JOINT_TENSILE: f64 = 2.0e6;
const PER_SECTION: f64 = 9.0;
const N_BONDS: f64 = 159.0; // 3·3·7 axial + 2·(2·3·8) lateral
const DT: f64 = 2e-7;
/// Viscous damping rate (1/s) of the pair style.
const DAMP: f64 = 2e3;

const MODEL: &str = "[bonding]\nrule = \"gap\"\nvalue = 0.17\n\
    [scheme]\nkind = \"isotropic\"\nnormal = 1.0e12\nshear = 0.5e12\n";

const STRENGTH: &str = "[strength]\n[strength.bond]\ntensile = 5.0e6\ncohesion = 1.0e7\n\
    friction = 0.5\n[[strength.planes]]\nnormal = [0.0, 0.0, 1.0]\nspacing = 10.0\n\
    offset = 0.011\ntensile = 2.0e6\ncohesion = 4.0e6\nfriction = 0.6\n";

/// Atom k (1-based, in i, j, k loop order) of the bar.
fn sites() -> Vec<[f64; 3]> {
    let mut out = Vec::new();
    for i in 0..3 {
        for j in 0..3 {
            for k in 0..8 {
                let p = |n: i32| ORIGIN + n as f64 * D;
                out.push([p(i), p(j), p(k)]);
            }
        }
    }
    out
}

/// The deck: atoms created one by one, `pair_style anisobond PAIR damping`, ends held and
/// moved, the bottom force and the pair style's bond counts printed every step.
fn deck(pair: &str) -> String {
    let s = sites();
    let mut d = String::from(
        "units si\natom_style granular\natom_modify map array\nboundary f f f\nnewton on\n\
         communicate single vel yes\nregion box block 0 0.012 0 0.012 0 0.024 units box\n\
         create_box 1 box\n",
    );
    for p in &s {
        d.push_str(&format!(
            "create_atoms 1 single {:?} {:?} {:?} units box\n",
            p[0], p[1], p[2]
        ));
    }
    let layer = |z: f64| {
        (1..=s.len())
            .filter(|&k| (s[k - 1][2] - z).abs() < 0.5 * R)
            .map(|k| k.to_string())
            .collect::<Vec<_>>()
            .join(" ")
    };
    d.push_str(&format!(
        "set group all diameter {:?}\nset group all density 2600\n\
         pair_style anisobond {pair} damping {DAMP:?} {DAMP:?}\npair_coeff * *\n\
         neighbor 0.0002 bin\nneigh_modify delay 0\ntimestep {DT:?}\n\
         group bottom id {}\ngroup top id {}\ngroup mobile subtract all bottom\n\
         fix integrate mobile nve/sphere\nfix ftop top freeze\n\
         fix fbottom bottom setforce 0.0 0.0 0.0\n\
         velocity top set 0.0 0.0 ${{speed}} units box\n\
         run 0\n\
         compute nbonds all reduce sum f_anisobond_bonds[1]\n\
         compute nbroken all reduce sum f_anisobond_bonds[2]\n\
         variable st equal step\nvariable fb equal f_fbottom[3]\n\
         variable nb equal c_nbonds\nvariable nbr equal c_nbroken\n\
         thermo_style custom step v_fb v_nb v_nbr\nthermo 10000\n\
         fix hist all print 1 \"${{st}} ${{fb}} ${{nb}} ${{nbr}}\" file history.txt screen no \
         title \"# step bottom_force_N bonds broken\"\n\
         run ${{steps}}\n",
        2.0 * R,
        layer(ORIGIN),
        layer(ORIGIN + 7.0 * D)
    ));
    d
}

/// The kn of the model's axial bonds, from `anisobond bonds` of the same bar.
fn axial_kn(dir: &Path, model: &Path) -> f64 {
    let bonds = dir.join("kn-bonds.csv");
    succeeds(
        bin()
            .args(["bonds"])
            .arg(dir.join("bar.txt"))
            .arg("--model")
            .arg(model)
            .arg("-o")
            .arg(&bonds),
    );
    let text = std::fs::read_to_string(&bonds).unwrap();
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let kn = header.iter().position(|c| *c == "kn").unwrap();
    lines
        .next()
        .unwrap()
        .split(',')
        .nth(kn)
        .unwrap()
        .parse()
        .unwrap()
}

struct Run {
    /// The largest bottom force (N) before the first bond broke.
    peak: f64,
    first_break: Option<u64>,
    left: f64,
    broken: f64,
    log: String,
}

/// Run the deck in `dir` on `np` processes and read its history.
fn run(dir: &Path, np: usize, speed: f64, steps: u64) -> Run {
    let log = run_liggghts(
        &Launch {
            program: driver(),
            mpi_processes: (np > 1).then_some(np),
            vars: vec![
                ("speed".into(), format!("{speed:?}")),
                ("steps".into(), steps.to_string()),
            ],
        },
        dir,
        "bar.in",
    )
    .expect("driver run");
    let text = std::fs::read_to_string(dir.join("history.txt")).unwrap();
    let rows: Vec<Vec<f64>> = text
        .lines()
        .filter(|l| !l.starts_with('#'))
        .map(|l| l.split_whitespace().map(|w| w.parse().unwrap()).collect())
        .collect();
    assert_eq!(rows.len() as u64, steps); // steps 1…steps
    let first_break = rows.iter().find(|r| r[3] > 0.0).map(|r| r[0] as u64);
    let peak = rows
        .iter()
        .filter(|r| r[3] == 0.0)
        .map(|r| r[1])
        .fold(f64::MIN, f64::max);
    let last = rows.last().unwrap();
    Run {
        peak,
        first_break,
        left: last[2],
        broken: last[3],
        log,
    }
}

#[test]
fn bar_in_direct_tension_breaks_the_joint_bonds_on_one_and_two_processes() {
    if let Some(r) = missing(TOOLS) {
        eprintln!("skipping: {r}");
        return;
    }
    let dir = fresh_dir("strength_tension");
    let mut bar = String::from("# periodic 0.1 0.1 0.1\n");
    for p in sites() {
        bar.push_str(&format!("{:?} {:?} {:?} {R:?}\n", p[0], p[1], p[2]));
    }
    write(&dir, "bar.txt", &bar);
    let strong = write(&dir, "strong.toml", &format!("{MODEL}{STRENGTH}"));
    write(&dir, "plain.toml", MODEL);
    let kn = axial_kn(&dir, &strong);
    let closed = PER_SECTION * JOINT_TENSILE * R * R;
    // A column of 7 bonds in series reaches twice the joint's limit in 80,000 steps.
    let speed = 2.0 * JOINT_TENSILE * R * R * 7.0 / kn / (80_000.0 * DT);
    let steps = 60_000;

    // The bond table of `export yade` (the same atoms in the same order: ids 1…72), with
    // the adhesion columns.
    succeeds(
        bin()
            .args(["export", "yade"])
            .arg(dir.join("bar.txt"))
            .arg("--model")
            .arg(&strong)
            .arg("-o")
            .arg(dir.join("yade")),
    );
    std::fs::copy(dir.join("yade/bonds.csv"), dir.join("table.csv")).unwrap();

    let mut peaks = Vec::new();
    for (pair, np) in [
        ("model strong.toml", 1),
        ("model strong.toml", 2),
        ("table table.csv", 1),
    ] {
        write(&dir, "bar.in", &deck(pair));
        let r = run(&dir, np, speed, steps);
        let err = (r.peak - closed).abs() / closed;
        println!(
            "{pair}, np {np}: peak {:.9} N before the first break (step {:?}) vs 9 × a_n = {closed} N: \
             relative error {err:.2e}; {} bonds left, {} broken",
            r.peak, r.first_break, r.left, r.broken
        );
        if np == 2 {
            assert!(
                r.log.contains("1 by 1 by 2 MPI processor grid"),
                "{}",
                r.log
            );
        }
        assert!(
            err <= 1e-3,
            "{pair} np {np}: peak {} N vs {closed} N",
            r.peak
        );
        assert_eq!(r.broken, PER_SECTION, "{pair} np {np}");
        assert_eq!(r.left, N_BONDS - PER_SECTION, "{pair} np {np}");
        peaks.push(r.peak);
    }
    assert!((peaks[0] - peaks[1]).abs() <= 1e-9 * closed, "{peaks:?}");

    // Without [strength]: unbreakable, the force goes on past the joint's limit.
    write(&dir, "bar.in", &deck("model plain.toml"));
    let r = run(&dir, 1, speed, steps);
    println!(
        "plain model: {:.6} N reached, {} bonds broken",
        r.peak, r.broken
    );
    assert_eq!(r.first_break, None);
    assert_eq!((r.left, r.broken), (N_BONDS, 0.0));
    assert!(r.peak > 1.4 * closed, "{}", r.peak);
}
