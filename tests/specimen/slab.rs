//! A slab as read (issue 31): a box of mixed periodicity (`p p f`) loaded along its free axis z,
//! laterally periodic along x and y as the box says, with no cut. Against the closed forms of
//! simple-cubic and FCC slabs, the periodic cell of the same spheres cut at its z faces (the
//! existing route: the same bonds once those across z are cut), the relaxed tensor's 1/S₃₃ on
//! a long random slab, and a slab LIGGGHTS writes itself (`boundary p p f`, `dump custom`).

use crate::common::{cmd, missing, succeeds, tmp, write, CUBIC_MODEL};
use anisobond::assembly::Assembly;
use anisobond::model::Model;
use anisobond::packing::{read_packing, read_packing_as, CellChoice};
use anisobond::packing::{Packing, PeriodicCell};
use anisobond::specimen::{slab_axis, solve, Lateral, Platens, SpecimenOptions, SpecimenReport};
use anisobond::{Error, Vec3};

/// Normal and shear springs only (N/m), the same on every bond.
const KN: f64 = 2e6;
const KS: f64 = 7e5;
const SPRINGS: &str = "[bonding]\nrule = \"gap\"\nvalue = 0.01\n[scheme]\nkind = \"isotropic\"\n\
                       normal = 2e6\nshear = 7e5\n[geometry]\nconvention = \"spring\"\n";

/// `centres` of spheres of radius `r` in a box of `lengths` periodic along `periodic`.
fn bonded(centres: Vec<Vec3>, r: f64, lengths: Vec3, periodic: [bool; 3]) -> Assembly {
    let n = centres.len();
    let cell = PeriodicCell::with_periodic(lengths, periodic).unwrap();
    let p = Packing::new(centres, vec![r; n], Some(cell)).unwrap();
    Assembly::new(p, Model::from_toml_str(SPRINGS, "springs.toml").unwrap()).unwrap()
}

/// The slab solved along z, laterally periodic, end layers half a radius deep.
fn slab(asm: &Assembly, r: f64, platens: Platens) -> SpecimenReport {
    let mut o = SpecimenOptions::new(2, 0.5 * r);
    o.lateral = Lateral::Periodic;
    o.platens = platens;
    solve(asm, &o).unwrap()
}

fn rel(a: f64, b: f64) -> f64 {
    ((a - b) / b).abs()
}

/// A 4 × 3 × 6 simple-cubic slab of touching spheres (R = 1 mm) periodic along x and y: each
/// z column is nz − 1 normal springs in series; a uniform axial strain moves every layer
/// rigidly, so the x and y bonds (normal and shear springs) stay unstretched and unsheared:
/// F = n_x n_y k_n δ/(n_z − 1), E = k_n/(2R) on the cell's face, ν = 0 (lateral periods
/// unchanged) for either platens, exactly.
#[test]
fn simple_cubic_slab_has_the_closed_form_e_and_nu() {
    let r = 1e-3;
    let (nx, ny, nz) = (4usize, 3usize, 6usize);
    let mut centres = Vec::new();
    for i in 0..nx {
        for j in 0..ny {
            for k in 0..nz {
                centres.push(Vec3::new(i as f64 + 0.5, j as f64 + 0.5, k as f64 + 0.5) * 2.0 * r);
            }
        }
    }
    let l = Vec3::new(nx as f64, ny as f64, nz as f64) * 2.0 * r;
    let asm = bonded(centres, r, l, [true, true, false]);
    // Bonds across the x and y faces, none across z: 3 per sphere less the top layer's z bond.
    assert_eq!(asm.bonds.len(), nx * ny * (3 * nz - 1));
    assert_eq!(slab_axis(asm.packing.cell.as_ref()), Some(2));
    for platens in [Platens::Frictionless, Platens::Bonded] {
        let rep = slab(&asm, r, platens);
        let k = (nx * ny) as f64 * KN / (nz - 1) as f64;
        assert!(
            rel(rep.platen_stiffness, k) < 1e-12,
            "{platens:?}: {}",
            rep.platen_stiffness
        );
        assert!(rel(rep.area, l.x * l.y) < 1e-15);
        assert!(
            rel(rep.young, KN / (2.0 * r)) < 1e-12,
            "{platens:?}: E {}",
            rep.young
        );
        assert!(
            rep.poisson_lateral.iter().all(|v| v.abs() < 1e-12),
            "{rep:?}"
        );
        assert_eq!(rep.loaded_particles, nx * ny * nz);
    }
}

/// An FCC slab (nearest neighbours d = 2R, cubic cell a = d√2, 3 × 3 cells across, N = 10
/// (001) layers) periodic along x and y. A Bravais lattice under a uniform diagonal strain
/// (ε_x = ε_y, ε_z) is in equilibrium particle by particle (neighbours in ± pairs; at an end
/// layer the four bonds to the next layer cancel laterally and in moment), so the slab is in
/// uniform strain. With f = k_n (n·Δ) n + k_s (Δ − (n·Δ) n), Δ = ε d n: the x force across
/// the x faces sums N layers of in-plane bonds (k_n ε_x d²/2 each, times n_x d) and N − 1
/// layer gaps of (±1, 0, 1)/√2 bonds ((k_n + k_s) ε_x + (k_n − k_s) ε_z) d²/4 each); free
/// lateral periods (frictionless platens) make it zero:
/// ν_N = (N − 1)(k_n − k_s) / (2N k_n + (N − 1)(k_n + k_s)) (→ (k_n − k_s)/(3k_n + k_s), the
/// bulk's C₁₂/(C₁₁ + C₁₂), as N → ∞: the surface layers lack half their out-of-plane bonds).
/// The four bonds per sphere across a layer gap give σ_zz = √2/d ((k_n + k_s) ε_z + (k_n − k_s)
/// ε_x), so E_N = √2/d ((k_n + k_s) − (k_n − k_s) ν_N). Bonded platens hold the periods:
/// uniaxial strain, E = C₁₁ = √2 (k_n + k_s)/d, ν = 0. The same spheres in a fully periodic
/// cell, cut at its z faces, give the same numbers: the bonds across z are what the cut removes.
#[test]
fn fcc_slab_has_the_closed_form_e_and_nu() {
    let r = 1e-3;
    let d = 2.0 * r;
    let a = d * 2f64.sqrt();
    let (cells, layers) = (3usize, 10usize);
    let mut centres = Vec::new();
    for k in 0..layers {
        let shift = if k % 2 == 0 { [0.0, 0.5] } else { [0.5, 0.0] };
        for i in 0..cells {
            for j in 0..cells {
                for s in shift {
                    let (x, y) = (i as f64 + s, j as f64 + s);
                    let t = if k % 2 == 0 {
                        [x, y]
                    } else {
                        [x, j as f64 + 0.5 - s]
                    };
                    centres.push(Vec3::new(t[0] + 0.25, t[1] + 0.25, 0.5 * k as f64 + 0.25) * a);
                }
            }
        }
    }
    let l = Vec3::new(cells as f64 * a, cells as f64 * a, 0.5 * layers as f64 * a);
    let asm = bonded(centres.clone(), r, l, [true, true, false]);
    // 12 neighbours per sphere, less the 4 above the top layer and below the bottom one.
    let n = centres.len();
    assert_eq!(asm.bonds.len(), 6 * n - 4 * 2 * cells * cells);
    let nl = layers as f64;
    let nu = (nl - 1.0) * (KN - KS) / (2.0 * nl * KN + (nl - 1.0) * (KN + KS));
    let e = 2f64.sqrt() / d * ((KN + KS) - (KN - KS) * nu);
    let c11 = 2f64.sqrt() * (KN + KS) / d;
    let cut = bonded(centres, r, l, [true; 3]);
    assert_eq!(cut.bonds.len(), 6 * n);
    for (platens, e, nu) in [(Platens::Frictionless, e, nu), (Platens::Bonded, c11, 0.0)] {
        let rep = slab(&asm, r, platens);
        assert!(
            rel(rep.young, e) < 1e-10,
            "{platens:?}: E {} vs {e}",
            rep.young
        );
        for v in rep.poisson_lateral {
            assert!((v - nu).abs() < 1e-10, "{platens:?}: nu {v} vs {nu}");
        }
        assert!(rel(rep.length, 0.5 * (layers - 1) as f64 * a) < 1e-14);
        let other = slab(&cut, r, platens);
        assert_eq!(other.loaded_bonds, rep.loaded_bonds);
        assert!(rel(other.platen_stiffness, rep.platen_stiffness) < 1e-12);
        assert!((other.poisson - rep.poisson).abs() < 1e-12);
    }
}

/// A long slab of a random packing, as read (`p p f`): the periodic cube of the prism test
/// stacked 4 and 8 times along z in a box free along z gives the same middle-copy modulus as
/// the fully periodic stack cut at its z faces, and so 1/S₃₃ of the cube's relaxed tensor by
/// Richardson's extrapolation in length (and C₃₃ with bonded platens).
#[test]
fn long_random_slab_reproduces_one_over_s33_of_the_relaxed_tensor() {
    use crate::periodic::prism_in;
    let (cube, model, c, s) = crate::periodic::cube_and_compliance();
    let e33 = 1.0 / s[(2, 2)];
    let ppf = [true, true, false];
    let (k1, k2) = (4usize, 8usize);
    let (e1, nu1) = prism_in(&cube, &model, k1, Platens::Frictionless, ppf);
    let (e2, _) = prism_in(&cube, &model, k2, Platens::Frictionless, ppf);
    let (e1_cut, nu1_cut) = prism_in(&cube, &model, k1, Platens::Frictionless, [true; 3]);
    assert!(rel(e1, e1_cut) < 1e-9, "slab {e1} vs cut cell {e1_cut}");
    assert!((nu1[0] - nu1_cut[0]).abs() < 1e-9 && (nu1[1] - nu1_cut[1]).abs() < 1e-9);
    let e_inf = (k2 as f64 * e2 - k1 as f64 * e1) / (k2 - k1) as f64;
    println!(
        "1/S33 {e33:.6e}: slab k = {k1}: {e1:.6e}, k = {k2}: {e2:.6e}, extrapolated {e_inf:.6e}"
    );
    assert!(
        rel(e_inf, e33) < 1e-4,
        "extrapolated {e_inf} vs 1/S33 {e33}"
    );
    let (c_mid, lat) = prism_in(&cube, &model, 5, Platens::Bonded, ppf);
    assert_eq!(lat, [0.0, 0.0]);
    assert!(rel(c_mid, c[(2, 2)]) < 1e-4, "{c_mid} vs C33");
}

/// What a mixed box cannot be solved as is refused by name: laterally periodic along z of a
/// box periodic along x only (a strip, free along y), or along x of a `p p f` box (a load
/// along a periodic axis); and as a free specimen when bonds cross its periodic faces.
#[test]
fn mixed_box_refusals() {
    let r = 1e-3;
    let mut centres = Vec::new();
    for (i, j, k) in (0..3).flat_map(|i| (0..3).flat_map(move |j| (0..5).map(move |k| (i, j, k)))) {
        centres.push(Vec3::new(i as f64 + 0.5, j as f64 + 0.5, k as f64 + 0.5) * 2.0 * r);
    }
    let l = Vec3::new(6.0 * r, 6.0 * r, 10.0 * r);
    let strip = bonded(centres.clone(), r, l, [true, false, false]);
    assert_eq!(slab_axis(strip.packing.cell.as_ref()), None);
    let mut o = SpecimenOptions::new(2, 0.5 * r);
    o.lateral = Lateral::Periodic;
    let e = solve(&strip, &o).unwrap_err();
    assert!(
        matches!(&e, Error::Invalid(m) if m.contains("p f f") && m.contains("strip")),
        "{e}"
    );
    let bed = bonded(centres, r, l, [true, true, false]);
    o.axis = 0;
    let e = solve(&bed, &o).unwrap_err();
    assert!(
        matches!(&e, Error::Invalid(m) if m.contains("p p f") && m.contains("axis x")),
        "{e}"
    );
    o.axis = 2;
    o.lateral = Lateral::Free;
    let e = solve(&bed, &o).unwrap_err();
    assert!(
        matches!(&e, Error::Invalid(m) if m.contains("p p f")),
        "{e}"
    );
    o.lateral = Lateral::Periodic;
    assert!(solve(&bed, &o).is_ok());
}

/// The deck of a `boundary p p f` slab that LIGGGHTS writes: 4 × 3 × 6 spheres of 1.9 mm on a
/// 2 mm lattice in a 8 × 6 × 12 mm box, each centre moved by up to ±20 µm along each axis
/// (seeded) so that the answer is no closed form; a `dump custom` and a data file of the state.
fn slab_deck() -> String {
    use rand::{Rng, SeedableRng};
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(4751);
    let mut atoms = String::new();
    for i in 0..4 {
        for j in 0..3 {
            for k in 0..6 {
                let x = [i, j, k].map(|c| 1e-3 + 2e-3 * c as f64 + rng.gen_range(-2e-5..2e-5));
                atoms += &format!(
                    "create_atoms 1 single {:.17e} {:.17e} {:.17e} units box\n",
                    x[0], x[1], x[2]
                );
            }
        }
    }
    format!(
        "units si\n\
         atom_style granular\n\
         atom_modify map array\n\
         boundary p p f\n\
         newton off\n\
         communicate single vel yes\n\
         region box block 0 0.008 0 0.006 0 0.012 units box\n\
         create_box 1 box\n\
         {atoms}{}",
        crate::common::liggghts::snapshot_tail("slab")
    )
}

/// LIGGGHTS' own `p p f` slab: `anisobond specimen slab.dump` with no option but the model
/// loads it along z (its one free axis), laterally periodic as the dump's BOX BOUNDS say.
/// The same problem by the existing route: the data file of the same state read as a fully
/// periodic cell (bonded across z too) and solved periodic across z, which cuts the bonds
/// across its z faces — what is left is the slab's bond set, id for id and image for image;
/// the platen stiffness, E and ν agree to round-off.
#[test]
fn liggghts_p_p_f_slab_is_solved_as_read() {
    if let Some(r) = missing(&["liggghts"]) {
        assert!(std::env::var_os("CI").is_none(), "CI without liggghts: {r}");
        eprintln!("skipping: {r}");
        return;
    }
    let t = tmp();
    let d = t.path();
    let (dump, data) = crate::common::liggghts::write_snapshot(d, "slab", &slab_deck());
    assert!(std::fs::read_to_string(&dump)
        .unwrap()
        .contains("ITEM: BOX BOUNDS pp pp ff"));
    let m = write(d, "model.toml", CUBIC_MODEL);
    let o = d.join("out");
    succeeds(&mut cmd(
        "specimen {p} --model {m} -o {o}",
        &[("p", &dump), ("m", &m), ("o", &o)],
    ));
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(o.join("specimen.json")).unwrap()).unwrap();
    assert_eq!(json["axis"], "z");
    assert_eq!(json["lateral"], "periodic");
    assert_eq!(json["loaded_particles"], 72);
    assert!(rel(json["area"].as_f64().unwrap(), 0.008 * 0.006) < 1e-12);
    // The existing route: the data file as a fully periodic cell, cut at its z faces.
    let model = Model::from_toml_str(CUBIC_MODEL, "model.toml").unwrap();
    let slab_asm = Assembly::new(read_packing(&dump).unwrap(), model.clone()).unwrap();
    let cell_packing = read_packing_as(&data, CellChoice::Periodic)
        .unwrap()
        .packing;
    assert!(!cell_packing.cell.unwrap().is_mixed());
    let cell_asm = Assembly::new(cell_packing, model).unwrap();
    let by_id = |a: &Assembly, keep_z: bool| {
        let ids = a.packing.ids.as_ref().unwrap();
        let mut v: Vec<(u64, u64, [i32; 3])> = (0..a.bonds.len())
            .filter(|&b| keep_z || a.bonds.image[b][2] == 0)
            .map(|b| {
                let (i, j) = (ids[a.bonds.i[b] as usize], ids[a.bonds.j[b] as usize]);
                let im = a.bonds.image[b];
                if i < j {
                    (i, j, im)
                } else {
                    (j, i, im.map(|v| -v))
                }
            })
            .collect();
        v.sort_unstable();
        v
    };
    // 4 × 3 columns bonded across z in the cell, not in the slab.
    assert_eq!(
        by_id(&cell_asm, true).len(),
        by_id(&slab_asm, true).len() + 12
    );
    assert_eq!(by_id(&cell_asm, false), by_id(&slab_asm, true));
    let mean_r = 0.00095;
    let mut opts = SpecimenOptions::new(2, mean_r);
    opts.lateral = Lateral::Periodic;
    let cut = solve(&cell_asm, &opts).unwrap();
    let k = json["platen_stiffness"].as_f64().unwrap();
    println!(
        "slab as read {k:.12e} N/m, cut cell {:.12e} N/m",
        cut.platen_stiffness
    );
    assert!(
        rel(k, cut.platen_stiffness) < 1e-9,
        "{k} vs {}",
        cut.platen_stiffness
    );
    assert!(rel(json["young"].as_f64().unwrap(), cut.young) < 1e-9);
    // The jitter gives a small lateral response (ν ~ 1e-5), so ν is compared, not two zeros.
    for (kk, nu) in cut.poisson_lateral.iter().enumerate() {
        let v = json["poisson_lateral"][kk].as_f64().unwrap();
        println!("nu {kk}: slab as read {v:.12e}, cut cell {nu:.12e}");
        assert!(nu.abs() > 1e-7, "nu {kk}: {nu}");
        assert!((v - nu).abs() < 1e-6 * nu.abs(), "nu {kk}: {v} vs {nu}");
    }
}

/// The command's and Python's defaults, held once in the library: a `p f p` slab is loaded
/// along its free axis y, laterally periodic, end layers one mean radius deep; a fully
/// periodic cell along z, laterally free; an axis or a depth given is kept.
#[test]
fn defaults_follow_the_box_as_read() {
    let r = 1e-3;
    let mut centres = Vec::new();
    for i in 0..3 {
        for j in 0..5 {
            for k in 0..3 {
                centres.push(Vec3::new(i as f64 + 0.5, j as f64 + 0.5, k as f64 + 0.5) * 2.0 * r);
            }
        }
    }
    let l = Vec3::new(3.0, 5.0, 3.0) * 2.0 * r;
    let slab_y = bonded(centres.clone(), r, l, [true, false, true]);
    let o = SpecimenOptions::defaults_for(&slab_y.packing, None, None);
    assert_eq!((o.axis, o.lateral), (1, Lateral::Periodic));
    assert!(rel(o.end_layer, r) < 1e-12, "{}", o.end_layer);
    // Solved with the defaults: the closed form of the simple-cubic column along y,
    // n_x n_z k_n / (n_y − 1) with k_n = 2e6 N/m.
    let k = solve(&slab_y, &o).unwrap().platen_stiffness;
    assert!(rel(k, 9.0 * 2e6 / 4.0) < 1e-12, "{k}");
    let cube = bonded(centres, r, l, [true; 3]);
    let o = SpecimenOptions::defaults_for(&cube.packing, None, None);
    assert_eq!((o.axis, o.lateral), (2, Lateral::Free));
    let o = SpecimenOptions::defaults_for(&cube.packing, Some(0), Some(0.25 * r));
    assert_eq!((o.axis, o.end_layer), (0, 0.25 * r));
}
