//! A YADE bond (law a) broken in shear hands its shear force on to its pair's contact, as
//! YADE 2023.02a's fragile `Law2_ScGeom6D_CohFrictPhys_CohesionMoment` keeps the interaction:
//! at the break step the contact's shear force is the bond's trial one capped at μ·F_n, and
//! it carries on from there (docs/strength.md, "Compression (UCS)").

use super::sc_bar::bonded_pair;
use anisobond::bonds::BondStiffness;
use anisobond::dem::{
    build_law, BondCriteria, BondCriterion, ContactLaw, Contacts, DemOptions, LawKind,
    PrescribedMotion, Simulation,
};
use anisobond::strength::criteria::{YadeAdhesion, YadeMoments};
use anisobond::strength::Mode;
use anisobond::Vec3;

const R: f64 = 0.5e-3;
const D: f64 = 2.0 * R;
const KN: f64 = 1.0e6;
const KS: f64 = 0.5e6;

/// One bond pressed and slid (end velocity (3v, 0, −v)) until it breaks in shear: at the
/// break step the contact's |F_s| is exactly μ·F_n with F_n = k_n·u_n (closed form, u_n =
/// 2R − |x_1|), along the bond's shear; one step later it is still μ·F_n (sliding on from
/// the handed-on force, where a fresh contact would hold one step's k_s·Δu_s); and the
/// energy closes against the held spheres' work.
#[test]
fn a_yade_bond_broken_in_shear_under_compression_continues_at_the_coulomb_cap() {
    let (packing, bonds) = bonded_pair(R);
    let k = BondStiffness {
        radius: vec![R],
        kn: vec![KN],
        ks: vec![KS],
        kr: vec![0.0],
        ktw: vec![0.0],
    };
    let opts = DemOptions {
        check_interval: 0,
        ..Default::default()
    };
    let mut sim = Simulation::new(
        &packing,
        &bonds,
        build_law(LawKind::Yade, &packing, &bonds, &k).unwrap(),
        &opts,
    )
    .unwrap();
    let mu = 0.5;
    let a_s = 1.0;
    let criterion = BondCriterion::Yade(YadeAdhesion {
        normal: 1.0e9,
        shear: a_s,
        tan_friction: mu,
        cohesion_disables_friction: false,
        moments: YadeMoments::Elastic,
    });
    sim.set_breakage(Some(BondCriteria::from_criteria(
        LawKind::Yade,
        vec![criterion],
    )))
    .unwrap();
    // The contact law's springs are replaced by the bond's at the break.
    let law = ContactLaw {
        normal_stiffness: 0.1 * KN,
        shear_stiffness: 0.1 * KS,
        friction: mu,
    };
    sim.set_contacts(Some(Contacts::new(law, 0.2 * R).unwrap()))
        .unwrap();
    let dt = sim.time_step();
    // |F_s| ≈ 3k_s·u = 1.5k_n·u against a_s + μk_n·u = a_s + 0.5k_n·u: breaks near u = a_s/k_n,
    // reached after about 1000 steps.
    let v = a_s / KN / (1000.0 * dt);
    let vel = Vec3::new(3.0 * v, 0.0, -v);
    sim.set_prescribed_motion(Some(PrescribedMotion {
        particles: vec![0, 1],
        velocity: vec![Vec3::zeros(), vel],
    }))
    .unwrap();
    let mut work = 0.0;
    let mut p_prev = 0.0;
    let mut bond_shear = Vec3::zeros();
    let mut s = 0;
    while sim.break_events().is_empty() {
        bond_shear = sim.force[1] - sim.force[1].dot(&Vec3::z()) * Vec3::z();
        sim.step().unwrap();
        let p = -sim.force[1].dot(&vel);
        if s > 0 {
            work += 0.5 * (p_prev + p) * dt;
        }
        p_prev = p;
        s += 1;
        assert!(s < 3000, "nothing broke");
    }
    let e = sim.break_events()[0];
    assert_eq!(e.mode, Mode::Shear);
    let at_break = sim.contacts().unwrap().contacts();
    assert_eq!(at_break.len(), 1);
    // Closed form at the break evaluation (after e.step moves of sphere 1).
    let x1 = Vec3::new(0.0, 0.0, D) + vel * (e.step as f64 * dt);
    let fn_closed = KN * (D - x1.norm());
    let c = at_break[0];
    let (fn_, fs) = (c.normal_force, c.shear_force);
    println!(
        "break at step {}: contact F_n {fn_:.9e} N (closed form {fn_closed:.9e}), |F_s| {:.9e} N, \
         μF_n {:.9e} N, bond's shear force the step before {:.6e} N",
        e.step,
        fs.norm(),
        mu * fn_,
        bond_shear.norm()
    );
    assert!((fn_ / fn_closed - 1.0).abs() < 1e-9);
    assert!((fs.norm() / (mu * fn_closed) - 1.0).abs() < 1e-9);
    // Handed on along the bond's shear (force on j opposes j's sliding in +x).
    assert!(fs.x < 0.0 && fs.x.abs() > 0.99 * fs.norm());
    // The bond's shear force had reached a_s + μF_n > μF_n: the cap acted.
    assert!(bond_shear.norm() > mu * fn_closed + 0.5 * a_s);
    sim.step().unwrap();
    let p = -sim.force[1].dot(&vel);
    work += 0.5 * (p_prev + p) * dt;
    let next = sim.contacts().unwrap().contacts()[0];
    let one_increment = KS * 3.0 * v * dt;
    println!(
        "next step: |F_s| {:.9e} N, μF_n {:.9e} N (a fresh contact: k_s·Δu_s = {one_increment:.3e} N)",
        next.shear_force.norm(),
        mu * next.normal_force
    );
    assert!((next.shear_force.norm() / (mu * next.normal_force) - 1.0).abs() < 1e-9);
    assert!(one_increment < 0.01 * mu * next.normal_force);
    let en = sim.energies();
    let stored = en.elastic + en.contact_elastic + en.broken_bonds + en.friction;
    println!(
        "energy: work {work:.9e} J, elastic + contact + broken + friction {stored:.9e} J \
         (broken {:.6e}, friction {:.6e})",
        en.broken_bonds, en.friction
    );
    assert!(en.local_damping == 0.0);
    assert!((stored - work).abs() < 2e-3 * work);
}
