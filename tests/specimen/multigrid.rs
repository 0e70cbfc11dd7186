//! The specimen solve by CG with the smoothed-aggregation multigrid V-cycle
//! (`SolverChoice::CgAmg`, `anisobond specimen --solver cg-amg`; issue 35): the same platen
//! stiffness, E and ν as the sparse Cholesky factorisation (small specimens) and as the
//! two-level CG (a laterally periodic prism of several levels), to the CG tolerance; the
//! simple-cubic column's closed form; the same bits on one and two threads; and a mechanism
//! that the load excites still refused with a typed error, not returned as an answer.

use crate::periodic::stacked_in;
use anisobond::assembly::Assembly;
use anisobond::model::Model;
use anisobond::packing::Packing;
use anisobond::specimen::{
    solve, Lateral, Platens, Shape, SolverChoice, SpecimenOptions, SpecimenReport, SpecimenSolver,
};
use anisobond::{Error, Vec3};

const R: f64 = 1e-3;

/// Isotropic springs k_n = 2·10⁶, k_s = `shear` N/m (`spring` convention), bonds between
/// touching neighbours.
fn springs(shear: f64) -> Model {
    Model::from_toml_str(
        &format!(
            "[bonding]\nrule = \"gap\"\nvalue = 0.01\n[scheme]\nkind = \"isotropic\"\n\
             normal = 2e6\nshear = {shear}\n[geometry]\nconvention = \"spring\"\n"
        ),
        "<test>",
    )
    .unwrap()
}

/// An nx × ny × nz simple-cubic block of touching spheres of radius `R` (free, no cell).
fn sc_centres(nx: usize, ny: usize, nz: usize) -> Vec<Vec3> {
    let mut pos = Vec::new();
    for i in 0..nx {
        for j in 0..ny {
            for k in 0..nz {
                pos.push(Vec3::new(i as f64, j as f64, k as f64) * 2.0 * R);
            }
        }
    }
    pos
}

fn rel(a: f64, b: f64) -> f64 {
    (a - b).abs() / b.abs().max(f64::MIN_POSITIVE)
}

/// `opts` solved by `solver`.
fn solved(asm: &Assembly, opts: &SpecimenOptions, solver: SolverChoice) -> SpecimenReport {
    let mut o = opts.clone();
    o.solver = solver;
    solve(asm, &o).unwrap()
}

/// The measured numbers of `a` and `b` agree to `tol` (relative; ν absolutely to `tol`);
/// ν too when `unique`. A free specimen's ν is the slope of the lateral displacements of the
/// particles whose bonds hold their centres: those that swing at no energy, whose
/// displacement is what a CG leaves in the zero-energy modes the load does not excite, are
/// not fitted (with them block-Jacobi and multigrid CG differed by 2e-4 on the 1,200-sphere
/// one below); a periodic prism's is its change of period.
fn same_answer(a: &SpecimenReport, b: &SpecimenReport, tol: f64, what: &str, unique: bool) {
    for (name, x, y) in [
        ("platen stiffness", a.platen_stiffness, b.platen_stiffness),
        ("E", a.young, b.young),
        ("axial force", a.axial_force, b.axial_force),
        ("held force", a.held_force, b.held_force),
    ] {
        assert!(rel(x, y) < tol, "{what}: {name} {x:e} vs {y:e}");
    }
    for d in (0..2).filter(|_| unique) {
        let (x, y) = (a.poisson_lateral[d], b.poisson_lateral[d]);
        assert!((x - y).abs() < tol, "{what}: nu {d}: {x} vs {y}");
        let (x, y) = (a.lateral_strain[d], b.lateral_strain[d]);
        assert!(
            (x - y).abs() < tol * a.strain.abs(),
            "{what}: lateral strain {d}: {x:e} vs {y:e}"
        );
    }
}

fn amg_iterations(r: &SpecimenReport) -> (usize, usize) {
    match r.solver {
        SpecimenSolver::CgAmg { iterations, levels } => (iterations, levels),
        other => panic!("expected the multigrid CG, got {other:?}"),
    }
}

/// A simple-cubic column between either platens: the closed-form platen stiffness
/// n_x n_y k_n/(n_z − 1) and E = k_n/(2R), ν = 0; under a confining pressure (two load
/// cases) the direct solve's numbers.
#[test]
fn cg_amg_gives_the_simple_cubic_closed_form() {
    let (nx, ny, nz) = (3, 4, 9);
    let centres = sc_centres(nx, ny, nz);
    let n = centres.len();
    let packing = Packing::new(centres, vec![R; n], None).unwrap();
    let asm = Assembly::new(packing, springs(7e5)).unwrap();
    for platens in [Platens::Frictionless, Platens::Bonded] {
        let mut o = SpecimenOptions::new(2, 0.5 * R);
        o.platens = platens;
        let r = solved(&asm, &o, SolverChoice::CgAmg);
        amg_iterations(&r);
        let k_closed = (nx * ny) as f64 * 2e6 / (nz - 1) as f64;
        assert!(
            rel(r.platen_stiffness, k_closed) < 1e-10,
            "{platens:?}: {} vs {k_closed}",
            r.platen_stiffness
        );
        assert!(rel(r.young, 2e6 / (2.0 * R)) < 1e-10, "E = {}", r.young);
        assert!(r.poisson_lateral.iter().all(|v| v.abs() < 1e-10));
    }
    // A confining pressure (the second load case) on the cylinder: as the direct solve (here
    // block-Jacobi CG: the spins are zero-energy modes).
    let mut o = SpecimenOptions::new(2, 0.5 * R);
    o.confining_pressure = Some(1e5);
    o.shape = Shape::Cylinder;
    let amg = solved(&asm, &o, SolverChoice::CgAmg);
    let direct = solved(&asm, &o, SolverChoice::Cholesky);
    amg_iterations(&amg);
    same_answer(&amg, &direct, 1e-8, "confined simple-cubic cylinder", true);
    // The two-level CG on the two load cases alone (its coarse solve in halves of one).
    let two_level = solved(&asm, &o, SolverChoice::Cg);
    same_answer(&two_level, &direct, 1e-8, "confined, two-level CG", true);
}

/// A random free specimen (1,200 generated spheres read as free, Truszkowska's MRV model)
/// between frictionless and bonded platens; and a periodic cube stacked four times, periodic across z
/// (the period-change node), between both platens: the multigrid CG and the two-level CG
/// (its coarse space zero on the prescribed DOFs, the period-change node its own aggregate)
/// give the sparse Cholesky factorisation's platen stiffness, E, forces and ν to 1e-8 (CG relative residual 1e-12; where the free specimen's zero-energy spins stop the
/// factorisation, the block-Jacobi CG's).
#[test]
fn cg_amg_and_two_level_cg_equal_the_direct_solve_free_and_periodic() {
    let p = crate::common::bonded::generated(1200, 3);
    let free = Packing::new(p.positions.clone(), p.radii.clone(), None).unwrap();
    let mean_r = free.radii.iter().sum::<f64>() / free.len() as f64;
    let asm = Assembly::new(free, Model::truszkowska_mrv()).unwrap();
    let base = SpecimenOptions::new(2, mean_r);
    let mut cases = Vec::new();
    for platens in [Platens::Frictionless, Platens::Bonded] {
        let mut o = base.clone();
        o.platens = platens;
        cases.push((format!("free, {platens:?}"), o));
    }
    for (what, o) in &cases {
        let direct = solved(&asm, o, SolverChoice::Cholesky);
        let amg = solved(&asm, o, SolverChoice::CgAmg);
        let (iterations, levels) = amg_iterations(&amg);
        println!(
            "{what}: cg-amg {iterations} iterations, {levels} levels; direct: {:?}",
            direct.solver
        );
        same_answer(&amg, &direct, 1e-8, what, true);
        let two_level = solved(&asm, o, SolverChoice::Cg);
        println!("{what}: two-level CG {:?}", two_level.solver);
        same_answer(&two_level, &direct, 1e-8, what, true);
    }
    let cube = crate::common::bonded::generated(400, 5);
    let prism = stacked_in(&cube, 4, [true; 3]);
    let mean_r = cube.radii.iter().sum::<f64>() / cube.len() as f64;
    let asm = Assembly::new(prism, Model::truszkowska_mrv()).unwrap();
    for platens in [Platens::Frictionless, Platens::Bonded] {
        let mut o = SpecimenOptions::new(2, mean_r);
        o.lateral = Lateral::Periodic;
        o.platens = platens;
        let direct = solved(&asm, &o, SolverChoice::Cholesky);
        let amg = solved(&asm, &o, SolverChoice::CgAmg);
        let (iterations, levels) = amg_iterations(&amg);
        println!("periodic prism, {platens:?}: cg-amg {iterations} iterations, {levels} levels");
        same_answer(
            &amg,
            &direct,
            1e-8,
            &format!("periodic prism, {platens:?}"),
            true,
        );
        let two_level = solved(&asm, &o, SolverChoice::Cg);
        println!(
            "periodic prism, {platens:?}: two-level CG {:?}",
            two_level.solver
        );
        same_answer(
            &two_level,
            &direct,
            1e-8,
            &format!("periodic prism, {platens:?}, two-level"),
            true,
        );
    }
}

/// A laterally periodic prism large enough for three levels (a 2,000-sphere cube stacked
/// three times): the multigrid CG against the two-level CG (another preconditioner, the
/// same tolerance), in fewer iterations; and the same bits on one and two threads.
#[test]
fn cg_amg_equals_two_level_cg_on_a_multilevel_prism_and_is_deterministic() {
    let cube = crate::common::bonded::generated(2000, 7);
    let prism = stacked_in(&cube, 3, [true; 3]);
    let mean_r = cube.radii.iter().sum::<f64>() / cube.len() as f64;
    let asm = Assembly::new(prism, Model::truszkowska_mrv()).unwrap();
    let mut o = SpecimenOptions::new(2, mean_r);
    o.lateral = Lateral::Periodic;
    let pool = |threads: usize| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap()
    };
    let two_level = solved(&asm, &o, SolverChoice::Cg);
    let SpecimenSolver::Cg {
        iterations: tl_iterations,
        two_level: true,
    } = two_level.solver
    else {
        panic!("expected the two-level CG, got {:?}", two_level.solver);
    };
    let one = pool(1).install(|| solved(&asm, &o, SolverChoice::CgAmg));
    let two = pool(2).install(|| solved(&asm, &o, SolverChoice::CgAmg));
    let (iterations, levels) = amg_iterations(&one);
    println!(
        "{} loaded particles: cg-amg {iterations} iterations, {levels} levels; two-level CG \
         {tl_iterations}",
        one.loaded_particles
    );
    assert!(levels >= 3, "{levels} levels");
    assert!(
        iterations < tl_iterations,
        "{iterations} vs {tl_iterations}"
    );
    same_answer(
        &one,
        &two_level,
        1e-7,
        "periodic prism, multigrid vs two-level",
        true,
    );
    assert_eq!(one.solver, two.solver);
    let bits = |r: &SpecimenReport| -> Vec<u64> {
        r.displacement_field
            .iter()
            .chain(&r.rotation_field)
            .flat_map(|v| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>())
            .chain([r.platen_stiffness.to_bits(), r.poisson.to_bits()])
            .collect()
    };
    assert!(bits(&one) == bits(&two), "1 and 2 threads differ");
}

/// Normal springs only (k_s = 0) on a simple-cubic block, with a "bump" sphere bonded into
/// the groove between two surface spheres of one column: both its bonds lie in the xz
/// plane, so it slides along y at no cost, and the confining pressure on a cylinder (radial,
/// with a y component at the bump) pushes it along y (and the block's layers, free to slide
/// on each other, along x and y): no equilibrium exists. Every solver refuses it with a typed
/// error (not converged), the multigrid CG too; without the pressure (the platens'
/// displacement alone, which excites no zero-energy mode) the same block is solved.
#[test]
fn a_mechanism_the_load_excites_is_refused_by_every_solver() {
    let mut centres = sc_centres(4, 4, 6);
    // Between (0, 0, 4R) and (0, 0, 6R), outside the x = 0 face.
    centres.push(Vec3::new(-(3.0f64).sqrt() * R, 0.0, 5.0 * R));
    let n = centres.len();
    let packing = Packing::new(centres.clone(), vec![R; n], None).unwrap();
    let bumped = Assembly::new(packing, springs(0.0)).unwrap();
    let mut o = SpecimenOptions::new(2, 0.5 * R);
    for solver in [SolverChoice::Auto, SolverChoice::CgAmg] {
        o.solver = solver;
        let r = solve(&bumped, &o);
        assert!(r.is_ok(), "{solver:?}: {:?}", r.err());
    }
    o.confining_pressure = Some(1e5);
    o.shape = Shape::Cylinder;
    let bump = centres.len() - 1;
    let bump_bonds = (0..bumped.bonds.len())
        .filter(|&b| bumped.bonds.i[b] as usize == bump || bumped.bonds.j[b] as usize == bump)
        .count();
    assert_eq!(bump_bonds, 2);
    for solver in [
        SolverChoice::Auto,
        SolverChoice::Cholesky,
        SolverChoice::Cg,
        SolverChoice::CgAmg,
    ] {
        let mut oo = o.clone();
        oo.solver = solver;
        match solve(&bumped, &oo) {
            Err(Error::NotConverged(_)) => {}
            other => panic!(
                "{solver:?}: expected a typed refusal, got {:?}",
                other.map(|r| r.platen_stiffness)
            ),
        }
    }
}
