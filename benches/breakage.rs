//! The integrator with breakage and contacts on one specimen, and the same specimen written
//! for LAMMPS route (a) (issue 32, "Speed"): a free bonded prism cut from a generated packing
//! (R̄ = 1 mm, gap 0.17 R̄, isotropic springs in the spring convention so that every bond
//! and every contact has the same k_n, k_s; Weibull tensile strengths), its bottom layer
//! held and its top layer moved towards it at a constant speed (uniaxial compression, the
//! free spheres started in the linear velocity field), law (d) `lammps-bpm` with LAMMPS'
//! damping ratio 0.3 and its criterion, frictional contacts after breaking (every pair not
//! held by an intact bond). Run by `benches/lammps_breakage.py`; alone:
//!
//! `BREAKAGE_BENCH_DIR=DIR cargo bench --bench breakage`
//!
//! Environment: BREAKAGE_BENCH_DIR (required: the LAMMPS inputs and `integrator.json` are
//! written there), BREAKAGE_BENCH_PARTICLES (packing generated before the cut, 40,000; the
//! prism keeps the spheres with x, y in the first 0.7 of the cell, about half),
//! BREAKAGE_BENCH_STEPS (3,000), BREAKAGE_BENCH_STRAIN (axial strain per step, 1e-5),
//! BREAKAGE_BENCH_THREADS (comma-separated thread counts, "1,2"), BREAKAGE_BENCH_LAW=yade
//! (law (a), YADE's cohesive law and the integrator's default, instead of (d): another bond
//! law than LAMMPS', the same specimen, strengths and loading, so other breaks).
//!
//! The LAMMPS deck `in.breakage` runs the same bar, layers, velocities, time step and number
//! of steps: `bond_style bpm/rotational break yes smooth no` (one bond type per bond: springs,
//! critical loads as `export lammps` writes them, damping), contacts by `pair_style
//! granular` (Hooke normal spring k_n, `linear_history` tangential spring k_s, Coulomb
//! friction μ, no damping: the integrator's Cundall–Strack law), `special_bonds lj 0 1 1`
//! so that a pair leaves the exclusion list when its bond breaks.

mod common;

use anisobond::assembly::Assembly;
use anisobond::dem::laws::{BpmNormalize, LammpsBpmLaw};
use anisobond::dem::{
    build_law, BondCriteria, ContactLaw, Contacts, DemOptions, LawKind, MassOptions, Simulation,
};
use anisobond::export::lammps::{bond_damping, bond_limits, LammpsBreakage};
use anisobond::model::Model;
use anisobond::packing::Packing;
use anisobond::strength::{assign_strength, StrengthSpec};
use anisobond::validate::specimen::bond_lines_one_type_each;
use anisobond::validate::strength::lammps::{bond_coeff_lines, bpm_coefficients};
use anisobond::validate::strength::{Loading, StrengthTest};
use common::env;
use std::fmt::Write as _;
use std::path::Path;
use std::time::Instant;

/// Springs (N/m; spring convention: k_n, k_s per bond) and strengths of the bench's model.
const MODEL: &str = "[bonding]\nrule = \"gap\"\nvalue = 0.17\n\
    [scheme]\nkind = \"isotropic\"\nnormal = 2e6\nshear = 7e5\n\
    [geometry]\nconvention = \"spring\"\n\
    [strength]\n[strength.bond]\ntensile = 5e6\ncohesion = 1e7\nfriction = 0.5\n\
    [strength.scatter]\ndistribution = \"weibull\"\nmodulus = 5.0\nseed = 7\n";

/// Particle density (kg/m³), as the exports' default.
const DENSITY: f64 = 2650.0;
/// Damping ratio of the bonds' dashpots (`validate --strength`'s).
const DAMPING_RATIO: f64 = 0.3;
/// Verlet skin of the contacts and LAMMPS' neighbour skin, in R̄.
const SKIN: f64 = 0.2;

fn main() {
    let dir = std::path::PathBuf::from(
        std::env::var("BREAKAGE_BENCH_DIR").expect("set BREAKAGE_BENCH_DIR (an output folder)"),
    );
    std::fs::create_dir_all(&dir).expect("output folder");
    let n_gen = env("BREAKAGE_BENCH_PARTICLES", 40_000.0) as usize;
    let steps = env("BREAKAGE_BENCH_STEPS", 3000.0) as u64;
    let strain = env("BREAKAGE_BENCH_STRAIN", 1e-5);
    // Law (d) is the like-for-like comparison; BREAKAGE_BENCH_LAW=yade runs law (a) (YADE's
    // cohesive law, its adhesions from the same strengths, no bond damping) on the same
    // specimen instead: another law, so other breaks.
    let kind = match std::env::var("BREAKAGE_BENCH_LAW").as_deref() {
        Ok("yade") => LawKind::Yade,
        _ => LawKind::LammpsBpm,
    };
    let threads = common::thread_counts("BREAKAGE_BENCH_THREADS");

    let t0 = Instant::now();
    let periodic = common::packing(n_gen);
    let cell = periodic.cell.as_ref().expect("periodic").lengths;
    let keep: Vec<usize> = (0..periodic.len())
        .filter(|&k| {
            let x = periodic.positions[k];
            x.x < 0.7 * cell[0] && x.y < 0.7 * cell[1]
        })
        .collect();
    let packing = Packing::new(
        keep.iter().map(|&k| periodic.positions[k]).collect(),
        keep.iter().map(|&k| periodic.radii[k]).collect(),
        None,
    )
    .expect("prism");
    let model = Model::from_toml_str(MODEL, "<breakage bench>").expect("model");
    let asm = Assembly::new(packing, model).expect("bonds");
    let (p, b, k) = (&asm.packing, &asm.bonds, &asm.springs);
    let (n, nb) = (p.len(), b.len());
    let table = asm.model.strength.as_ref().expect("[strength]");
    let strengths =
        assign_strength(p, b, &StrengthSpec::from_table(table).expect("spec")).expect("strengths");
    let breakage = LammpsBreakage {
        strengths: strengths.clone(),
        pi_hat: asm.model.geometry.pi_hat,
        smooth: false,
    };
    let limits = bond_limits(k, &breakage).expect("limits");
    let damping: Vec<[f64; 4]> = (0..nb)
        .map(|e| bond_damping(p, b, k, e, DENSITY, DAMPING_RATIO))
        .collect();
    let dt = anisobond::export::liggghts::stable_timestep(p, b, k, DENSITY).expect("dt");
    let r_mean = p.mean_radius();
    let test = StrengthTest::new(2, r_mean, -strain, steps);
    let loading = Loading::of(p, &test, dt, "bench").expect("layers");
    let contact = ContactLaw {
        normal_stiffness: k.kn[0],
        shear_stiffness: k.ks[0],
        friction: strengths.friction.iter().sum::<f64>() / nb as f64,
    };
    assert!(
        k.kn.iter().all(|&x| x == contact.normal_stiffness)
            && k.ks.iter().all(|&x| x == contact.shear_stiffness),
        "the bench's springs are uniform (one contact law in LAMMPS)"
    );
    println!(
        "setup: {n} particles, {nb} bonds, dt {dt:.4e} s, {steps} steps, axial strain {:.2e} \
         per step, in {:.1} s",
        strain,
        t0.elapsed().as_secs_f64()
    );
    write_lammps(
        &dir, p, &asm, &limits, &damping, &loading, &contact, steps, r_mean,
    );

    let mut runs = Vec::new();
    for &t in &threads {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(t)
            .build()
            .expect("pool");
        let run = pool.install(|| {
            let coeffs = bpm_coefficients(k, &damping);
            let law: Box<dyn anisobond::dem::BondLaw> = if kind == LawKind::LammpsBpm {
                Box::new(LammpsBpmLaw::new(coeffs, BpmNormalize::Absolute).expect("law"))
            } else {
                build_law(kind, p, b, k).expect("law")
            };
            let criteria = BondCriteria::for_law(kind, &strengths, p, b, &asm.model.geometry)
                .expect("criteria");
            let opts = DemOptions {
                time_step: Some(dt),
                mass: MassOptions {
                    density: DENSITY,
                    scaling: 1.0,
                },
                check_interval: 0,
                local_damping: 0.0,
                ..Default::default()
            };
            let mut sim = Simulation::new(p, b, law, &opts).expect("sim");
            sim.set_breakage(Some(criteria)).expect("breakage");
            sim.set_contacts(Some(
                Contacts::new(contact, SKIN * r_mean).expect("contacts"),
            ))
            .expect("contacts on");
            loading.start(&mut sim, &p.positions, 2).expect("layers");
            let cpu0 = common::cpu_seconds();
            let clock = Instant::now();
            let mut peak = f64::NEG_INFINITY;
            for _ in 0..steps {
                sim.step().expect("step");
                let f: f64 = loading.top.iter().map(|&q| sim.force[q].z).sum();
                peak = peak.max(f);
            }
            let wall = clock.elapsed().as_secs_f64();
            let cpu = common::cpu_seconds() - cpu0;
            let broken = sim.break_events().len();
            let contacts = sim.contacts().map_or(0, |c| c.len());
            let rebuilds = sim.contacts().map_or(0, |c| c.rebuilds());
            let first: Vec<String> = sim
                .break_events()
                .iter()
                .take(10)
                .map(|e| format!("[{}, {}, {}]", b.i[e.bond], b.j[e.bond], e.step))
                .collect();
            println!(
                "integrator, {t} thread(s): {steps} steps in {wall:.3} s (CPU {cpu:.3} s) = \
                 {:.1} ns per particle-step; {broken} bonds broken, {contacts} contacts at \
                 the end, {rebuilds} Verlet rebuilds, peak platen force {peak:.6e} N",
                wall * 1e9 / (n as f64 * steps as f64)
            );
            format!(
                "{{\"threads\": {t}, \"wall_s\": {wall}, \"cpu_s\": {cpu}, \"broken\": {broken}, \
                 \"contacts\": {contacts}, \"rebuilds\": {rebuilds}, \"peak_force\": {peak}, \
                 \"first_breaks\": [{}]}}",
                first.join(", ")
            )
        });
        runs.push(run);
    }
    let json = format!(
        "{{\"law\": \"{kind:?}\", \"particles\": {n}, \"bonds\": {nb}, \"steps\": {steps}, \"time_step\": {dt}, \
         \"strain_per_step\": {strain}, \"generated\": {n_gen}, \"runs\": [{}]}}\n",
        runs.join(", ")
    );
    std::fs::write(dir.join("integrator.json"), json).expect("integrator.json");
}

/// `data.lmp`, `bond_coeffs.lmp` and `in.breakage` for LAMMPS route (a) (module docs).
#[allow(clippy::too_many_arguments)]
fn write_lammps(
    dir: &Path,
    p: &Packing,
    asm: &Assembly,
    limits: &[[f64; 4]],
    damping: &[[f64; 4]],
    loading: &Loading,
    contact: &ContactLaw,
    steps: u64,
    r_mean: f64,
) {
    let (b, k) = (&asm.bonds, &asm.springs);
    let (n, nb) = (p.len(), b.len());
    let max_len = b.length.iter().copied().fold(0.0, f64::max);
    let (lo, hi) = p.bounding_box();
    let m = 2.0 * max_len;
    let mut s = format!(
        "LAMMPS data file written by benches/breakage.rs: {n} particles, {nb} bonds (one type \
         per bond)\n\n{n} atoms\n3 atom types\n{nb} bonds\n{nb} bond types\n\n\
         {} {} xlo xhi\n{} {} ylo yhi\n{} {} zlo zhi\n\nAtoms # bpm/sphere\n\n",
        num(lo.x - m),
        num(hi.x + m),
        num(lo.y - m),
        num(hi.y + m),
        num(lo.z - m - loading.gauge),
        num(hi.z + m),
    );
    let mut kind = vec![1u8; n];
    loading.bottom.iter().for_each(|&q| kind[q] = 2);
    loading.top.iter().for_each(|&q| kind[q] = 3);
    for (q, (x, t)) in p.positions.iter().zip(&kind).enumerate() {
        let _ = writeln!(
            s,
            "{} 0 {} {} {} {} {} {}",
            q + 1,
            t,
            num(2.0 * p.radii[q]),
            num(DENSITY),
            num(x.x),
            num(x.y),
            num(x.z)
        );
    }
    s.push_str("\nBonds\n\n");
    s.push_str(&bond_lines_one_type_each(b));
    std::fs::write(dir.join("data.lmp"), s).expect("data.lmp");
    std::fs::write(
        dir.join("bond_coeffs.lmp"),
        bond_coeff_lines(k, limits, damping),
    )
    .expect("bond_coeffs.lmp");
    let v = num(loading.velocity);
    let deck = format!(
        "# benches/breakage.rs: uniaxial compression along z with breakage and contacts.\n\
         # Atom types: 1 free, 2 bottom layer (held), 3 top layer (moved at v).\n\
         units si\ndimension 3\nboundary m m m\natom_style bpm/sphere\n\
         special_bonds lj 0 1 1 coul 1 1 1\nnewton on off\n\
         comm_modify vel yes cutoff {cut}\nread_data data.lmp\n\
         bond_style bpm/rotational break yes smooth no\n\
         include bond_coeffs.lmp\n\
         pair_style granular\n\
         pair_coeff * * hooke {kn} 0.0 tangential linear_history {kt} 0.0 {mu} damping velocity\n\
         neighbor {skin} bin\nneigh_modify every 1 delay 0 check yes\n\
         group bottom type 2\ngroup top type 3\ngroup mobile type 1\n\
         timestep {dt}\n\
         variable vfield atom {v}*(z-({lo}))/{gauge}\n\
         velocity mobile set 0 0 v_vfield units box\n\
         velocity top set 0 0 {v} units box\n\
         fix integrate mobile nve/bpm/sphere\n\
         fix pull top move linear 0 0 {v}\n\
         fix hold bottom move linear 0 0 0\n\
         compute ftop top reduce sum fz\n\
         thermo_style custom step c_ftop bonds\nthermo {thermo}\n\
         timer full\n\
         run {steps}\n",
        cut = num(1.6 * max_len),
        kn = num(contact.normal_stiffness),
        kt = num(contact.shear_stiffness),
        mu = num(contact.friction),
        skin = num(SKIN * r_mean),
        dt = num(loading.time_step),
        lo = num(loading.lowest),
        gauge = num(loading.gauge),
        thermo = steps.div_ceil(10).max(1),
    );
    std::fs::write(dir.join("in.breakage"), deck).expect("in.breakage");
}

/// A float written so that it reads back bit for bit.
fn num(x: f64) -> String {
    format!("{x:e}")
}
