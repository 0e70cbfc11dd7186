//! Jaeger's single plane of weakness in a lattice (issue 32, docs/strength.md, "Jaeger's
//! single plane of weakness in a lattice"): a bonded simple-cubic bar along z, compressed by
//! its held end layers in the integrator, with one plane of weakness through its middle at
//! β from the axis. An aligned simple-cubic bar in uniaxial compression carries the load in
//! its z columns only (F = σ₁d² per column; the lateral bonds see nothing, ν = 0), so a
//! crossing z bond resolves F on the plane into F cos β (compression) and F sin β (shear).
//! With the joint's stresses on the bond's section cut by the plane (A/cos β) it slides at
//! σ₁ = (A/d²)·2c_w/((1 − μ_w cot β) sin 2β): Jaeger's formula with the plane's cohesion
//! c_w·A/d² (closed form, `jaeger::sliding_strength`); with the stresses on the bond's own
//! section A it slides at c_w A/(d²(sin β − μ_w cos β)) instead. Where β ≤ φ_w no bond
//! breaks in compression (the laws break in tension and shear only), so the intact strength
//! of the U-curve is the cap the test loads to.

use anisobond::bonds::{BondSet, BondStiffness};
use anisobond::dem::{build_law, BondCriteria, DemOptions, LawKind, PrescribedMotion, Simulation};
use anisobond::model::Model;
use anisobond::packing::Packing;
use anisobond::schemes::Geometry;
use anisobond::strength::jaeger::{minimum_strength, peak_strength, weakest_angle};
use anisobond::strength::{
    assign_strength, JointSection, Mode, PlaneFamily, Strength, StrengthSpec,
};
use anisobond::Vec3;
use std::f64::consts::PI;
use std::path::Path;

const R: f64 = 1.0e-3;
const D: f64 = 2.0 * R;
const KN: f64 = 1.0e6;
const KS: f64 = 0.5e6;
const NX: usize = 3;
const NY: usize = 3;
const NZ: usize = 12;
/// Joint cohesion c_w (Pa) and friction μ_w (φ_w = 26.57°).
const C_W: f64 = 0.2e6;
const MU_W: f64 = 0.5;
/// The load the bar is compressed to when nothing breaks: the intact strength of the
/// U-curve as this test declares it (σ₁, Pa).
const CAP: f64 = 4.0e6;

/// The 3 × 3 × 12 bar (axis z), nearest-neighbour bonds, each bond's axis (0, 1, 2).
fn bar() -> (Packing, BondSet, Vec<usize>) {
    let (packing, bonds, tags) = super::sc_bar::bar(NX, NY, NZ, R);
    (
        packing,
        bonds,
        tags.into_iter().map(|(axis, _)| axis).collect(),
    )
}

/// The plane at β (degrees) from the axis, normal (sin β, 0, cos β), through the bar's
/// centre shifted by 0.013 d along its normal (so that it passes through no sphere centre).
fn plane(beta_deg: f64, section: JointSection) -> PlaneFamily {
    let beta = beta_deg.to_radians();
    let normal = Vec3::new(beta.sin(), 0.0, beta.cos());
    let centre = Vec3::new((NX - 1) as f64, (NY - 1) as f64, (NZ - 1) as f64) * (0.5 * D);
    let joint = Strength {
        friction: MU_W,
        ..Strength::new(0.3e6, C_W)
    };
    PlaneFamily::new(normal, 1000.0 * D, normal.dot(&centre) + 0.013 * D, joint)
        .unwrap()
        .with_section(section)
}

/// What one compression run measured.
struct Run {
    /// σ₁ (Pa) at the step before the first break, or the load reached (≥ CAP) when
    /// nothing broke.
    peak: f64,
    /// Whether a bond broke.
    broke: bool,
    /// The z bonds whose two ends lie on either side of the plane (computed here).
    crossing_z: Vec<usize>,
}

/// Compresses the bar (bottom layer held, top layer moved down at a constant speed, the free
/// particles in the steady linear velocity field, law (a), no contacts) until a bond breaks
/// or σ₁ on the held bottom layer passes CAP; about 3,000 steps to min(`expected`, CAP).
fn compress(beta_deg: f64, section: JointSection, expected: f64) -> Run {
    let (packing, bonds, axes) = bar();
    let family = plane(beta_deg, section);
    // The crossing z bonds by the signs of the ends' distances to the plane; no centre
    // lies within 0.01 d of it.
    let side = |x: &Vec3| family.normal.dot(x) - family.offset;
    assert!(packing.positions.iter().all(|x| side(x).abs() > 0.01 * D));
    let crossing_z: Vec<usize> = (0..bonds.len())
        .filter(|&b| {
            let (i, j) = (bonds.i[b] as usize, bonds.j[b] as usize);
            axes[b] == 2 && side(&packing.positions[i]) * side(&packing.positions[j]) < 0.0
        })
        .collect();
    let spec = StrengthSpec {
        planes: vec![family],
        ..StrengthSpec::isotropic(Strength::new(1.0e6, 3.0e6)).unwrap()
    };
    let strengths = assign_strength(&packing, &bonds, &spec).unwrap();
    for &b in &crossing_z {
        assert_eq!(strengths.joint_of(b), Some(0));
    }
    let n = bonds.len();
    let k = BondStiffness {
        radius: vec![R; n],
        kn: vec![KN; n],
        ks: vec![KS; n],
        kr: vec![0.0; n],
        ktw: vec![0.0; n],
    };
    let opts = DemOptions {
        check_interval: 0,
        ..Default::default()
    };
    let law = LawKind::Yade;
    let mut sim = Simulation::new(
        &packing,
        &bonds,
        build_law(law, &packing, &bonds, &k).unwrap(),
        &opts,
    )
    .unwrap();
    let criteria =
        BondCriteria::for_law(law, &strengths, &packing, &bonds, &Geometry::default()).unwrap();
    sim.set_breakage(Some(criteria)).unwrap();
    // About 3,000 steps to `expected` (not a whole number: no step lands on it by
    // construction): per-column force σ₁d², shortening (NZ − 1)·σ₁d²/k_n.
    let target = expected.min(CAP);
    let v = -((NZ - 1) as f64) * (target * D * D / KN) / (3000.37 * sim.time_step());
    let top_z = (NZ - 1) as f64 * D;
    let (mut held, mut velocity, mut bottom) = (Vec::new(), Vec::new(), Vec::new());
    for (p, x) in packing.positions.iter().enumerate() {
        let s = x.z / top_z;
        sim.particles.velocity[p] = Vec3::new(0.0, 0.0, v * s);
        if !(1e-9..=1.0 - 1e-9).contains(&s) {
            held.push(p);
            velocity.push(sim.particles.velocity[p]);
            if s < 0.5 {
                bottom.push(p);
            }
        }
    }
    sim.set_prescribed_motion(Some(PrescribedMotion {
        particles: held,
        velocity,
    }))
    .unwrap();
    let section_area = (NX * NY) as f64 * D * D;
    let mut stresses = Vec::new();
    loop {
        sim.step().unwrap();
        // The bonds push the held bottom layer down (−z) in compression.
        let sigma1 = -bottom.iter().map(|&p| sim.force[p].z).sum::<f64>() / section_area;
        stresses.push(sigma1);
        if !sim.break_events().is_empty() {
            let first = sim.break_events();
            let step = first[0].step as usize;
            assert_eq!(step + 1, stresses.len());
            let mut broken: Vec<usize> = first.iter().map(|e| e.bond).collect();
            broken.sort_unstable();
            assert_eq!(
                broken, crossing_z,
                "β = {beta_deg}°: the first bonds to break are not the crossing z bonds"
            );
            assert!(first
                .iter()
                .all(|e| e.mode == Mode::Shear && e.step as usize == step));
            return Run {
                peak: stresses[step - 1],
                broke: true,
                crossing_z,
            };
        }
        if sigma1 > CAP {
            return Run {
                peak: sigma1,
                broke: false,
                crossing_z,
            };
        }
        assert!(stresses.len() < 20_000, "β = {beta_deg}°: no progress");
    }
}

/// A/d²: the bonded fraction of a plane normal to the columns.
fn bonded_fraction() -> f64 {
    PI * R * R / (D * D)
}

/// The U-curve of the lattice with the cut section against Jaeger's at β = 0°, 15°, …, 90°
/// (and 28°, just above φ_w, where sliding would need more than the cap): where the plane
/// slides the peak σ₁ is (A/d²)·Jaeger(β) to within the load step (1e-3; the step is
/// 1/3,000 of the load) and the first bonds to break are exactly the crossing z bonds, in
/// shear; elsewhere nothing breaks up to the cap, and `peak_strength` with the cap as the
/// intact strength is the measured curve.
#[test]
fn the_lattice_follows_jaegers_u_curve_with_the_cut_section() {
    let c_plane = C_W * bonded_fraction();
    let phi = MU_W.atan().to_degrees();
    println!(
        "β (deg)  measured σ1 (Pa)   Jaeger (A/d²)·… or cap (Pa)   rel. error   crossing z bonds"
    );
    for beta_deg in [0.0, 15.0, 28.0, 30.0, 45.0, 60.0, 75.0, 90.0] {
        let beta = f64::to_radians(beta_deg);
        let expected = peak_strength(c_plane, MU_W, 0.0, beta, CAP);
        let run = compress(beta_deg, JointSection::Cut, expected);
        let error = (expected - run.peak) / expected;
        println!(
            "{beta_deg:7.1}  {:.6e}       {expected:.6e}                  {error:+.2e}    {}",
            run.peak,
            run.crossing_z.len()
        );
        if expected < CAP {
            assert!(beta_deg > phi && beta_deg < 90.0);
            assert!(run.broke, "β = {beta_deg}°: nothing broke");
            assert_eq!(run.crossing_z.len(), NX * NY, "β = {beta_deg}°");
            assert!(
                (-1e-9..=1e-3).contains(&error),
                "β = {beta_deg}°: peak {} vs {expected}",
                run.peak
            );
        } else {
            assert!(!run.broke, "β = {beta_deg}°: a bond broke below the cap");
            // The load passed the cap within one step.
            assert!(
                (-1e-3..=0.0).contains(&error),
                "β = {beta_deg}°: {} vs {CAP}",
                run.peak
            );
        }
    }
}

/// Around the weakest angle 45° + φ_w/2 = 58.28°: the measured peak falls from 50° to it and
/// rises from it to 66°, and at it equals the analytic minimum (A/d²)·2c_w(√(1 + μ_w²) + μ_w)
/// (Mohr–Coulomb's UCS of the plane) to within the load step.
#[test]
fn the_minimum_is_at_45_plus_half_phi_with_mohr_coulombs_value() {
    let c_plane = C_W * bonded_fraction();
    let beta_min = weakest_angle(MU_W).to_degrees();
    let minimum = minimum_strength(c_plane, MU_W, 0.0);
    let closed = c_plane * 2.0 * ((1.0 + MU_W * MU_W).sqrt() + MU_W);
    assert!((minimum / closed - 1.0).abs() < 1e-14);
    let at_min = compress(beta_min, JointSection::Cut, minimum);
    let error = (minimum - at_min.peak) / minimum;
    println!(
        "β = {beta_min:.3}°: measured {:.6e} Pa, 2c(√(1+μ²)+μ) = {minimum:.6e} Pa, {error:+.2e}",
        at_min.peak
    );
    assert!(at_min.broke && (-1e-9..=1e-3).contains(&error));
    let mut previous = f64::INFINITY;
    for beta_deg in [50.0, 54.0, beta_min, 62.0, 66.0] {
        let expected = peak_strength(c_plane, MU_W, 0.0, f64::to_radians(beta_deg), CAP);
        let run = if beta_deg == beta_min {
            at_min.peak
        } else {
            compress(beta_deg, JointSection::Cut, expected).peak
        };
        let error = (expected - run) / expected;
        println!("β = {beta_deg:.2}°: measured {run:.6e} Pa (Jaeger {expected:.6e}, {error:+.2e})");
        assert!((-1e-9..=1e-3).contains(&error), "β = {beta_deg}°");
        assert!(run >= at_min.peak * (1.0 - 1e-9), "β = {beta_deg}°");
        if beta_deg <= beta_min {
            assert!(run <= previous, "not falling at β = {beta_deg}°");
        } else {
            assert!(run > previous, "not rising at β = {beta_deg}°");
        }
        previous = run;
    }
}

/// With the joint's stresses on the bond's own section the same runs slide at
/// c_w A/(d²(sin β − μ_w cos β)) (Jaeger's with a plane cohesion c_w A cos β/d² that falls
/// with β): no minimum at 45° + φ_w/2 — the strength keeps falling to 75° where the cut
/// section's rises. Why the cut section is needed.
#[test]
fn with_the_bond_section_the_lattice_departs_from_jaeger() {
    let area = PI * R * R;
    let mut measured = Vec::new();
    for beta_deg in [45.0f64, 75.0] {
        let beta = beta_deg.to_radians();
        let expected = C_W * area / (D * D * (beta.sin() - MU_W * beta.cos()));
        let run = compress(beta_deg, JointSection::Bond, expected);
        let error = (expected - run.peak) / expected;
        let jaeger = peak_strength(C_W * bonded_fraction(), MU_W, 0.0, beta, CAP);
        println!(
            "bond section, β = {beta_deg}°: measured {:.6e} Pa, c_w A/(d²(sin β − μ cos β)) = \
             {expected:.6e} Pa ({error:+.2e}); Jaeger with c_w A/d²: {jaeger:.6e} Pa",
            run.peak
        );
        assert!(run.broke && (-1e-9..=1e-3).contains(&error));
        assert!((run.peak / jaeger - 1.0).abs() > 0.05, "β = {beta_deg}°");
        measured.push(run.peak);
    }
    assert!(measured[1] < measured[0]);
    let cut_45 = compress(45.0, JointSection::Cut, 1.0e6).peak;
    let cut_75 = compress(75.0, JointSection::Cut, 1.0e6).peak;
    assert!(cut_75 > cut_45, "{cut_75} vs {cut_45}");
}

const ELASTIC: &str = "[bonding]\nrule = \"gap\"\nvalue = 0.01\n\
    [scheme]\nkind = \"isotropic\"\nnormal = 2e6\nshear = 7e5\n\
    [geometry]\nconvention = \"spring\"\n";

/// `section = "cut" | "bond"` of a `[[strength.planes]]` family: read, refused otherwise
/// naming the file and line, written back; omitted is the bond section; the engines' exports
/// refuse a cut family by name.
#[test]
fn the_joint_section_is_read_refused_and_written_back() {
    let path = Path::new("rock.toml");
    let table = |section: &str| {
        format!(
            "{ELASTIC}[strength.bond]\ntensile = 5e6\ncohesion = 1e7\n\
             [[strength.planes]]\nnormal = [0, 0, 1]\nspacing = 2e-3\ntensile = 5e5\n\
             cohesion = 1e6\nfriction = 0.6\n{section}"
        )
    };
    let read = |text: &str| Model::strength_from_str_for(text, path);
    let sections = |text: &str| -> Vec<JointSection> {
        read(text)
            .unwrap()
            .unwrap()
            .planes
            .iter()
            .map(|p| p.section)
            .collect()
    };
    assert_eq!(sections(&table("")), [JointSection::Bond]);
    assert_eq!(
        sections(&table("section = \"bond\"\n")),
        [JointSection::Bond]
    );
    let cut = table("section = \"cut\"\n");
    assert_eq!(sections(&cut), [JointSection::Cut]);
    // Refused: an unknown section, at its line (19 of the file).
    let bad = table("section = \"oblique\"\n");
    let e = Model::from_str_for(&bad, path).unwrap_err();
    assert!(
        matches!(&e, anisobond::Error::Parse { line: 19, .. }),
        "{e:?}"
    );
    let e = e.to_string();
    assert!(
        e.contains("rock.toml:19") && e.contains("oblique") && e.contains("cut"),
        "{e}"
    );
    // Written back (TOML and JSON), and the bond section stays unwritten when omitted.
    let model = Model::from_str_for(&cut, path).unwrap();
    let toml = model.to_toml_string();
    assert!(toml.contains("section = \"cut\""), "{toml}");
    assert_eq!(sections(&toml), [JointSection::Cut]);
    let json = model.to_json_string();
    let from_json = Model::strength_from_str_for(&json, Path::new("rock.json"))
        .unwrap()
        .unwrap();
    assert_eq!(from_json.planes[0].section, JointSection::Cut);
    let plain = Model::from_str_for(&table(""), path).unwrap();
    assert!(!plain.to_toml_string().contains("section"));
    // The engines have no plane criterion: a cut family is refused by name.
    let spec = read(&cut).unwrap().unwrap();
    let e = spec.refuse_cut_sections("export lammps").unwrap_err();
    assert!(matches!(e, anisobond::Error::Model(_)));
    let e = e.to_string();
    assert!(
        e.contains("export lammps") && e.contains("#1") && e.contains("cut"),
        "{e}"
    );
    read(&table(""))
        .unwrap()
        .unwrap()
        .refuse_cut_sections("x")
        .unwrap();
}

/// The cut section's area: A/|n·p| for a bond at θ to the plane's normal (A at θ = 0), the
/// bond's own section unchanged, and the joint limits built by the integrator's criteria
/// for a crossing bond.
#[test]
fn the_cut_section_is_the_oblique_ellipse() {
    use anisobond::strength::criteria::JointLimits;
    let a = PI * R * R;
    let p = Vec3::z();
    for theta_deg in [0.0f64, 30.0, 60.0, 85.0] {
        let t = theta_deg.to_radians();
        let n = Vec3::new(t.sin(), 0.0, t.cos());
        let cut = JointSection::Cut.area(a, &n, &p);
        // The ellipse: semi-axes R and R/cos θ.
        assert!(
            (cut / (PI * R * (R / t.cos())) - 1.0).abs() < 1e-12,
            "θ = {theta_deg}"
        );
        assert_eq!(JointSection::Bond.area(a, &n, &p), a);
        assert_eq!(JointSection::Cut.area(a, &-n, &p), cut);
        let s = Strength::new(1.0, 2.0);
        let lim = JointLimits::on_section(&s, R, PI, JointSection::Cut, &n, &p);
        assert_eq!(lim.area, cut);
        assert_eq!(
            JointLimits::on_section(&s, R, PI, JointSection::Bond, &n, &p),
            JointLimits::of(&s, R, PI)
        );
    }
}

/// `anisobond export lammps` and the YADE export refuse a model with a cut family (a model
/// error, exit code 1, naming the family; no output left), and export the same model with the
/// bond section.
#[test]
fn the_exports_refuse_a_cut_family_and_leave_nothing() {
    use anisobond::export::yade::{write_yade_export, YadeRunOptions};
    use std::process::Command;
    let dir = tempfile::tempdir().unwrap();
    let bin = || Command::new(env!("CARGO_BIN_EXE_anisobond"));
    let packing = dir.path().join("packing.txt");
    let out = bin()
        .args(["pack", "--quiet", "--seed", "4", "--particles", "40", "-o"])
        .arg(&packing)
        .output()
        .unwrap();
    assert!(out.status.success());
    let model = |section: &str| {
        format!(
            "{}[strength.bond]\ntensile = 5e6\ncohesion = 1e7\n\
             [[strength.planes]]\nnormal = [0, 0, 1]\nspacing = 0.7\ntensile = 5e5\n\
             cohesion = 1e6\nfriction = 0.6\n{section}",
            ELASTIC.replace("0.01", "0.17")
        )
    };
    let cut = dir.path().join("cut.toml");
    std::fs::write(&cut, model("section = \"cut\"\n")).unwrap();
    let bond = dir.path().join("bond.toml");
    std::fs::write(&bond, model("section = \"bond\"\n")).unwrap();
    let export = |m: &Path, out: &Path| {
        bin()
            .args(["export", "lammps"])
            .arg(&packing)
            .arg("--model")
            .arg(m)
            .arg("-o")
            .arg(out)
            .output()
            .unwrap()
    };
    let refused = dir.path().join("refused");
    let r = export(&cut, &refused);
    let err = String::from_utf8_lossy(&r.stderr);
    assert_eq!(r.status.code(), Some(1), "{err}");
    assert!(
        err.contains("export lammps") && err.contains("#1") && err.contains("cut"),
        "{err}"
    );
    assert!(!refused.exists());
    let exported = dir.path().join("exported");
    let r = export(&bond, &exported);
    assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
    assert!(exported.join("breakage.lmp").exists());
    // YADE: the library's export, from the bar of the lattice tests.
    let (p, b, _) = bar();
    let n = b.len();
    let k = BondStiffness {
        radius: vec![R; n],
        kn: vec![KN; n],
        ks: vec![KS; n],
        kr: vec![0.0; n],
        ktw: vec![0.0; n],
    };
    let m = Model::from_str_for(&model("section = \"cut\"\n"), Path::new("cut.toml")).unwrap();
    let yade_dir = dir.path().join("yade");
    let e =
        write_yade_export(&yade_dir, &p, &b, &k, Some(&m), &YadeRunOptions::default()).unwrap_err();
    assert!(matches!(e, anisobond::Error::Model(_)), "{e:?}");
    assert!(e.to_string().contains("YADE export"), "{e}");
    assert!(!yade_dir.exists());
}
