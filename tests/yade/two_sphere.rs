//! Two-sphere checks in YADE: one exported bond (crossing the periodic boundary with
//! x_j − x_i < −L/2, so the image correction is exercised), a prescribed relative
//! displacement or rotation, one undamped step; YADE's force and torque must equal the
//! exported springs' closed form k·δ to 1e-10 relative: normal k_n·δ, shear k_s·u (with
//! the torque of the shear force about each centre through the mid-gap contact point),
//! bending k_r·θ, twisting k_tw·θ. A fifth case checks NewtonIntegrator's Cundall damping
//! per component, v₁ = v₀ + a·dt·(1 − λ·sgn(a_k(v₀_k + a_k·dt/2))), against the forces.

use crate::common::yade::yade_available;
use anisobond::bonds::{BondSet, BondStiffness};
use anisobond::export::yade::{run_yade_script, write_yade_export, YadeRunOptions};
use anisobond::packing::{Packing, PeriodicCell};
use anisobond::Vec3;

const SCRIPT: &str = r#"
import json, os, sys
HERE = os.path.dirname(os.path.abspath(sys.argv[0]))
sys.path.insert(0, HERE)
import anisobond_yade as ab
from yade import O
from yade.minieigenHP import Vector3, Quaternion

packing = ab.read_packing(os.path.join(HERE, "packing.txt"))
bonds = ab.read_bond_table(os.path.join(HERE, "bonds.csv"))
DT = 1e-7
out = {}
def v(x):
    return [float(x[0]), float(x[1]), float(x[2])]
for mode in ("normal", "shear", "bending", "twisting", "damping"):
    damping = 0.4 if mode == "damping" else 0.0
    sc = ab.build_scene(packing, bonds, density=1000.0, damping=damping, dt=DT)
    I = sc.interactions[0]
    j = O.bodies[1]
    built = {"normal": v(I.geom.normal), "branch": v(ab.branch_vector(I)),
             "cellDist": [I.cellDist[k] for k in range(3)], "id1": I.id1}
    n = Vector3(bonds.nx[0], bonds.ny[0], bonds.nz[0])
    t = n.cross(Vector3(0, 0, 1)).normalized()
    L = bonds.length[0]
    if mode == "normal":
        amount = 1e-4 * L
        j.state.pos = j.state.pos + n * amount
        direction = n
    elif mode == "shear":
        amount = 1e-4 * L
        j.state.vel = t * (amount / O.dt)
        direction = t
    elif mode == "bending":
        amount = 1e-3
        j.state.ori = Quaternion(t, amount)
        direction = t
    elif mode == "twisting":
        amount = 1e-3
        j.state.ori = Quaternion(n, amount)
        direction = n
    else:
        # Cundall damping: stretch the bond and give j a velocity against the force in x.
        amount = 1e-4 * L
        j.state.pos = j.state.pos + n * amount
        j.state.vel = Vector3(1.0, 0.0, 0.0)
        direction = n
    vel0, angvel0 = v(j.state.vel), v(j.state.angVel)
    O.step()
    out[mode] = {
        "amount": amount, "direction": v(direction), "dt": O.dt,
        "built": built, "damping": damping, "mass": j.state.mass,
        "inertia": v(j.state.inertia), "vel0": vel0, "angvel0": angvel0,
        "vel1": v(j.state.vel), "angvel1": v(j.state.angVel),
        "force_i": v(O.forces.f(0)), "force_j": v(O.forces.f(1)),
        "torque_i": v(O.forces.t(0)), "torque_j": v(O.forces.t(1)),
        "normalForce": v(I.phys.normalForce), "shearForce": v(I.phys.shearForce),
        "moment_bending": v(I.phys.moment_bending), "moment_twist": v(I.phys.moment_twist),
    }
ab._write_atomic(os.path.join(HERE, "two-sphere.json"), json.dumps(out, indent=1))
"#;

fn vec3(j: &serde_json::Value) -> Vec3 {
    Vec3::new(
        j[0].as_f64().unwrap(),
        j[1].as_f64().unwrap(),
        j[2].as_f64().unwrap(),
    )
}

/// |a − b| / scale.
fn rel(a: &Vec3, b: &Vec3, scale: f64) -> f64 {
    (a - b).norm() / scale
}

#[test]
fn two_sphere_bond_forces_and_torques_match_springs() {
    if !yade_available("two_sphere_bond_forces_and_torques_match_springs") {
        return;
    }
    // Cell 10 mm; sphere 0 near x = L, sphere 1 near x = 0: x_1 − x_0 < −L/2, the bond
    // goes to the +x image of sphere 1. Unequal radii and a gap, so the mid-gap contact
    // point differs from the radius-proportional one.
    let l = 0.01;
    let (r0, r1) = (1.0e-3, 0.8e-3);
    let x0 = Vec3::new(l - 1.1e-3, 5.0e-3, 5.0e-3);
    let x1 = Vec3::new(0.75e-3, 5.3e-3, 4.8e-3);
    let packing = Packing::new(
        vec![x0, x1],
        vec![r0, r1],
        Some(PeriodicCell::new(Vec3::repeat(l)).unwrap()),
    )
    .unwrap();
    let image = [1, 0, 0];
    let branch = x1 + Vec3::new(l, 0.0, 0.0) - x0;
    let mut bonds = BondSet::default();
    bonds.push(0, 1, branch, image);
    let springs = BondStiffness {
        radius: vec![0.8e-3],
        kn: vec![3.3e7],
        ks: vec![1.1e7],
        kr: vec![7.0],
        ktw: vec![5.0],
    };
    let (kn, ks, kr, ktw) = (3.3e7, 1.1e7, 7.0, 5.0);
    let dir = tempfile::tempdir().unwrap();
    let export = write_yade_export(
        dir.path(),
        &packing,
        &bonds,
        &springs,
        None,
        &YadeRunOptions::default(),
    )
    .unwrap();
    let script = dir.path().join("two_sphere.py");
    std::fs::write(&script, SCRIPT).unwrap();
    run_yade_script(&script, &[]).expect("yade run");
    let text = std::fs::read_to_string(dir.path().join("two-sphere.json")).unwrap();
    let res: serde_json::Value = serde_json::from_str(&text).unwrap();
    assert_eq!(export.n_bonds, 1);

    let n = branch.normalize();
    let len = branch.norm();
    let gap = len - r0 - r1;
    // Mid-gap contact arms (YADE ScGeom): R + gap/2.
    let (arm0, arm1) = (r0 + 0.5 * gap, r1 + 0.5 * gap);
    let tol = 1e-10;
    for mode in ["normal", "shear", "bending", "twisting", "damping"] {
        let m = &res[mode];
        // The image fix: YADE's bond is the table's bond.
        let b = &m["built"];
        assert_eq!(b["id1"].as_i64(), Some(0));
        assert_eq!(
            b["cellDist"],
            serde_json::json!([1, 0, 0]),
            "{mode}: cellDist"
        );
        assert!(
            rel(&vec3(&b["branch"]), &branch, len) < 1e-12,
            "{mode}: branch vector"
        );
        assert!(rel(&vec3(&b["normal"]), &n, 1.0) < 1e-12, "{mode}: normal");
        let a = m["amount"].as_f64().unwrap();
        let d = vec3(&m["direction"]);
        let (fi, fj) = (vec3(&m["force_i"]), vec3(&m["force_j"]));
        let (ti, tj) = (vec3(&m["torque_i"]), vec3(&m["torque_j"]));
        // Newton's update of j: v₁ = v₀ + (F/m)·dt·(1 − λ·sgn(F_k(v₀_k + F_k/m·dt/2))) per
        // component (Cundall), the same for ω with T/I; m = ρ(4/3)πR³, I = (2/5)mR².
        let mass = 1000.0 * 4.0 / 3.0 * std::f64::consts::PI * r1.powi(3);
        let inertia = 0.4 * mass * r1 * r1;
        assert!(
            (m["mass"].as_f64().unwrap() - mass).abs() < 1e-14 * mass,
            "{mode}: mass"
        );
        assert!(rel(&vec3(&m["inertia"]), &Vec3::repeat(inertia), inertia) < 1e-14);
        let lambda = m["damping"].as_f64().unwrap();
        let dt = m["dt"].as_f64().unwrap();
        let cundall = |x0: Vec3, acc: Vec3| {
            Vec3::from_fn(|k, _| {
                let s = (acc[k] * (x0[k] + 0.5 * acc[k] * dt)).signum();
                let s = if acc[k] * (x0[k] + 0.5 * acc[k] * dt) == 0.0 {
                    0.0
                } else {
                    s
                };
                x0[k] + acc[k] * dt * (1.0 - lambda * s)
            })
        };
        let want_v1 = cundall(vec3(&m["vel0"]), fj / mass);
        let want_w1 = cundall(vec3(&m["angvel0"]), tj / inertia);
        let v_scale = want_v1.norm().max(1e-300);
        assert!(
            rel(&vec3(&m["vel1"]), &want_v1, v_scale) < 1e-12,
            "{mode}: velocity update"
        );
        let w1 = vec3(&m["angvel1"]);
        assert!(
            (w1 - want_w1).norm() <= 1e-12 * want_w1.norm(),
            "{mode}: angular velocity {w1} vs {want_w1}"
        );
        let (want_fj, want_ti, want_tj) = match mode {
            // j moved by a·n away from i: tension k_n·a pulls j back (also in the damping
            // check, where the velocity of j adds a shear force, checked separately below).
            "normal" => (-kn * a * n, Vec3::zeros(), Vec3::zeros()),
            "damping" => {
                let v0 = vec3(&m["vel0"]);
                let shear = -ks * (v0 - n * n.dot(&v0)) * dt;
                let f = -kn * a * n + shear;
                // The contact point is mid-gap of the current (stretched) gap.
                let (c0, c1) = (arm0 + 0.5 * a, arm1 + 0.5 * a);
                (f, (c0 * n).cross(&(-f)), (-c1 * n).cross(&f))
            }
            // j moved by a·t (tangential): shear force −k_s·a·t on j, applied at the
            // contact point, which is −arm1·n from j's centre and +arm0·n from i's.
            "shear" => {
                let f = -ks * a * d;
                (f, (arm0 * n).cross(&(-f)), (-arm1 * n).cross(&f))
            }
            // j rotated by a about t ⟂ n: restoring moment −k_r·a·t on j.
            "bending" => (Vec3::zeros(), kr * a * d, -kr * a * d),
            // j rotated by a about n: restoring moment −k_tw·a·n on j.
            _ => (Vec3::zeros(), ktw * a * d, -ktw * a * d),
        };
        let f_scale = want_fj.norm().max(1e-300);
        let t_scale = want_tj.norm().max(want_ti.norm());
        eprintln!(
            "{mode}: |F_j| = {:.12e} N (closed form {:.12e}), |T_j| = {:.12e} N·m (closed form {:.12e})",
            fj.norm(),
            want_fj.norm(),
            tj.norm(),
            want_tj.norm()
        );
        if mode == "normal" || mode == "shear" || mode == "damping" {
            assert!(
                rel(&fj, &want_fj, f_scale) < tol,
                "{mode}: force on j {fj} vs {want_fj}"
            );
            assert!(
                rel(&fi, &(-want_fj), f_scale) < tol,
                "{mode}: force on i {fi}"
            );
        } else {
            assert!(
                fj.norm() == 0.0 && fi.norm() == 0.0,
                "{mode}: forces should vanish"
            );
        }
        if mode == "normal" {
            assert!(ti.norm() < 1e-12 * f_scale * len && tj.norm() < 1e-12 * f_scale * len);
        } else {
            assert!(
                rel(&tj, &want_tj, t_scale) < tol,
                "{mode}: torque on j {tj} vs {want_tj}"
            );
            assert!(
                rel(&ti, &want_ti, t_scale) < tol,
                "{mode}: torque on i {ti} vs {want_ti}"
            );
        }
    }
    // The magnitudes, spelled out: YADE's spring force is exactly the exported k·δ.
    let fs = vec3(&res["shear"]["shearForce"]).norm();
    let want_fs = ks * res["shear"]["amount"].as_f64().unwrap();
    assert!(
        (fs - want_fs).abs() < tol * want_fs,
        "shear {fs} vs k_s·u = {want_fs}"
    );
    let fnorm = vec3(&res["normal"]["normalForce"]).norm();
    let want_fn = kn * res["normal"]["amount"].as_f64().unwrap();
    assert!(
        (fnorm - want_fn).abs() < tol * want_fn,
        "normal {fnorm} vs k_n·δ = {want_fn}"
    );
}
