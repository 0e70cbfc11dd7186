//! The LIGGGHTS pair style's frictional contacts (`pair_style anisobond … contacts KN KS MU`,
//! issue 32: the integrator's contact law, src/dem/contacts.rs) against closed forms, in the
//! driver: two pairs of 1 mm spheres, the lower sphere of each held (`fix setforce`: its
//! reaction is the pair's force), the upper one moved at a constant velocity with a
//! tangential part twice the normal one (`fix freeze`), so that each contact slides from its
//! first step.
//!
//! - Pair A (atoms 1, 2) starts touching and bonded (k_n = 1e6, k_s = 5e5 N/m, a_s ≈ 0): the
//!   bond breaks in shear at step 1 and becomes a contact with the bond's own springs:
//!   F_n = k_n·u_n with u_n = 2R − |l| from the positions, |F_s| = μ·F_n (μ = MU, not the
//!   bond's tan φ).
//! - Pair B (atoms 3, 4) was never bonded and starts apart by a gap: no force until the gap
//!   closes, then a new contact with KN, KS (3e6, 1e6 N/m): F_n = KN·u_n, |F_s| = μ·F_n.
//!
//! The positions are the test's own (x₀ + n·dt·v), so the closed forms are independent of
//! the pair style; the pair style's record has exactly one break (1-2, shear, step 1).

use crate::common::liggghts::*;
use crate::common::write;
use anisobond::export::liggghts::{run_liggghts, Launch};

const TOOLS: &[&str] = &["liggghts", "mpicxx", "mpirun", "make", "g++"];
const R: f64 = 1e-3;
const DT: f64 = 1e-7;
const STEPS: u64 = 2_000;
/// The moved spheres' velocity: tangential (x) and approaching (−z), m/s.
const VX: f64 = 0.2;
const VZ: f64 = 0.1;
/// Pair B's initial gap (m): closed along z at step GAP / (VZ·DT) = 600.5.
const GAP: f64 = 6.005e-6;
const BOND_KN: f64 = 1e6;
const BOND_KS: f64 = 5e5;
const KN: f64 = 3e6;
const KS: f64 = 1e6;
const MU: f64 = 0.5;

/// Atoms 1–4: pair A at x = 5 mm (touching), pair B at x = 15 mm (apart by GAP).
fn sites() -> [[f64; 3]; 4] {
    [
        [0.005, 0.005, 0.005],
        [0.005, 0.005, 0.005 + 2.0 * R],
        [0.015, 0.005, 0.005],
        [0.015, 0.005, 0.005 + 2.0 * R + GAP],
    ]
}

fn deck() -> String {
    let mut d = String::from(
        "units si\natom_style granular\natom_modify map array\nboundary f f f\nnewton on\n\
         communicate single vel yes\nregion box block 0 0.02 0 0.01 0 0.012 units box\n\
         create_box 1 box\n",
    );
    for p in sites() {
        d.push_str(&format!(
            "create_atoms 1 single {:?} {:?} {:?} units box\n",
            p[0], p[1], p[2]
        ));
    }
    d.push_str(&format!(
        "set group all diameter {:?}\nset group all density 2600\n\
         pair_style anisobond table bonds.csv breaks breaks.txt contacts {KN:?} {KS:?} {MU:?}\n\
         pair_coeff * *\nneighbor 0.0002 bin\nneigh_modify delay 0\ntimestep {DT:?}\n\
         group a1 id 1\ngroup a3 id 3\ngroup moved id 2 4\n\
         group mobile subtract all a1 a3\n\
         fix integrate mobile nve/sphere\nfix fmoved moved freeze\n\
         fix f1 a1 setforce 0.0 0.0 0.0\nfix f3 a3 setforce 0.0 0.0 0.0\n\
         velocity moved set {VX:?} 0.0 {:?} units box\n\
         variable st equal step\n\
         variable ax equal f_f1[1]\nvariable ay equal f_f1[2]\nvariable az equal f_f1[3]\n\
         variable bx equal f_f3[1]\nvariable by equal f_f3[2]\nvariable bz equal f_f3[3]\n\
         fix hist all print 1 \"${{st}} ${{ax}} ${{ay}} ${{az}} ${{bx}} ${{by}} ${{bz}}\" \
         file history.txt screen no title \"# step F1 F3\"\n\
         thermo 1000\nrun {STEPS}\n",
        2.0 * R,
        -VZ
    ));
    d
}

/// The normal (along the branch, repulsive positive) and tangential magnitude of the force
/// `f` on the held sphere, for the branch `l` from it to the moved one.
fn split(f: [f64; 3], l: [f64; 3]) -> (f64, f64) {
    let d = (l[0] * l[0] + l[1] * l[1] + l[2] * l[2]).sqrt();
    let n = l.map(|c| c / d);
    let fn_ = -(f[0] * n[0] + f[1] * n[1] + f[2] * n[2]);
    let t = [0, 1, 2].map(|k| f[k] + fn_ * n[k]);
    (fn_, (t[0] * t[0] + t[1] * t[1] + t[2] * t[2]).sqrt())
}

#[test]
fn broken_bond_and_new_pair_are_coulomb_contacts_with_their_own_springs() {
    if let Some(r) = missing(TOOLS) {
        eprintln!("skipping: {r}");
        return;
    }
    let dir = fresh_dir("strength_contacts");
    // The SPEC bond table with adhesions: one bond 1-2 along z, a_n 1 N, a_s 1e-9 N (breaks
    // in shear at once), the bond's own tan φ 0.3 (the contact takes MU).
    write(
        &dir,
        "bonds.csv",
        &format!(
            "i,j,nx,ny,nz,length,radius,kn,ks,kr,ktw,ix,iy,iz,normal_adhesion,shear_adhesion,\
             tan_friction\n0,1,0,0,1,{:?},{R:?},{BOND_KN:?},{BOND_KS:?},0,0,0,0,0,1.0,1e-9,0.3\n",
            2.0 * R
        ),
    );
    write(&dir, "contacts.in", &deck());
    run_liggghts(
        &Launch {
            program: driver(),
            mpi_processes: None,
            vars: vec![],
        },
        &dir,
        "contacts.in",
    )
    .expect("driver run");
    let breaks = std::fs::read_to_string(dir.join("breaks.txt")).unwrap();
    let lines: Vec<&str> = breaks.lines().filter(|l| !l.starts_with('#')).collect();
    assert_eq!(lines, ["1 1 2 shear"], "{breaks}");

    let text = std::fs::read_to_string(dir.join("history.txt")).unwrap();
    let s = sites();
    let (mut checked_a, mut checked_b, mut apart_b) = (0, 0, 0);
    for line in text.lines().filter(|l| !l.starts_with('#')) {
        let w: Vec<f64> = line
            .split_whitespace()
            .map(|x| x.parse().unwrap())
            .collect();
        let n = w[0];
        if n < 1.0 {
            continue;
        }
        let shift = [n * DT * VX, 0.0, -n * DT * VZ];
        for (pair, f, k, lo, hi) in [
            ("A", [w[1], w[2], w[3]], BOND_KN, s[0], s[1]),
            ("B", [w[4], w[5], w[6]], KN, s[2], s[3]),
        ] {
            let l = [0, 1, 2].map(|c| hi[c] + shift[c] - lo[c]);
            let overlap = 2.0 * R - (l[0] * l[0] + l[1] * l[1] + l[2] * l[2]).sqrt();
            let (fn_, ft) = split(f, l);
            if overlap < 0.0 {
                assert_eq!(f, [0.0; 3], "pair {pair} apart at step {n}: force {f:?}");
                apart_b += usize::from(pair == "B");
                continue;
            }
            if overlap < 2e-8 {
                continue; // within two steps of touching: the positions' rounding shows
            }
            let want = k * overlap;
            assert!(
                ((fn_ - want) / want).abs() < 1e-6,
                "pair {pair} step {n}: F_n {fn_} vs k_n·u_n {want}"
            );
            assert!(
                ((ft - MU * want) / (MU * want)).abs() < 1e-6,
                "pair {pair} step {n}: |F_s| {ft} vs μ·F_n {}",
                MU * want
            );
            if pair == "A" {
                checked_a += 1;
            } else {
                checked_b += 1;
            }
        }
    }
    // Pair B closes its normal gap after step 600 (later: the tangential offset).
    assert!(apart_b >= 600, "{apart_b}");
    assert!(
        checked_a > 1_900 && checked_b > 1_300,
        "{checked_a} {checked_b}"
    );
}
