//! The .vtu files parse as XML with the expected arrays, and the strained state satisfies
//! equilibrium: the Love stress (1/V)Σ f⊗l of the written forces equals C·ε of the relaxed
//! tensor, and the net force on every load-carrying particle vanishes.

use crate::common::bonded::gap_bonded;
use anisobond::bonds::assign_stiffness;
use anisobond::export::vtk::{strained_state, write_bonds_vtu, write_particles_vtu};
use anisobond::homogenize::{relaxed_tensor, RelaxedOptions};
use anisobond::model::Model;
use anisobond::tensor::Voigt6;
use anisobond::Vec3;
use quick_xml::events::Event;
use quick_xml::Reader;
use std::collections::HashMap;

/// Every DataArray: name → (NumberOfComponents, number of values).
fn arrays(path: &std::path::Path) -> (HashMap<String, (usize, usize)>, usize, usize) {
    let text = std::fs::read_to_string(path).unwrap();
    let mut reader = Reader::from_str(&text);
    let mut out = HashMap::new();
    let (mut points, mut cells) = (0, 0);
    let mut current: Option<(String, usize)> = None;
    loop {
        match reader.read_event().expect("well-formed XML") {
            Event::Start(e) if e.name().as_ref() == b"DataArray" => {
                let mut name = String::new();
                let mut comps = 1;
                for a in e.attributes() {
                    let a = a.unwrap();
                    let v = a.unescape_value().unwrap().to_string();
                    match a.key.as_ref() {
                        b"Name" => name = v,
                        b"NumberOfComponents" => comps = v.parse().unwrap(),
                        _ => {}
                    }
                }
                current = Some((name, comps));
            }
            Event::Start(e) if e.name().as_ref() == b"Piece" => {
                for a in e.attributes() {
                    let a = a.unwrap();
                    let v: usize = a.unescape_value().unwrap().parse().unwrap();
                    match a.key.as_ref() {
                        b"NumberOfPoints" => points = v,
                        b"NumberOfCells" => cells = v,
                        _ => {}
                    }
                }
            }
            Event::Text(t) => {
                if let Some((name, comps)) = current.take() {
                    let n = t.unescape().unwrap().split_whitespace().count();
                    out.insert(name, (comps, n));
                }
            }
            Event::Eof => break,
            _ => {}
        }
    }
    (out, points, cells)
}

#[test]
fn vtu_files_have_the_arrays_and_forces_are_in_equilibrium() {
    let (p, b) = gap_bonded(400, 11);
    let model = Model::truszkowska_mrv();
    let scheme = model.build_scheme(None).unwrap();
    let k = assign_stiffness(&p, &b, scheme.as_ref(), &model.geometry).unwrap();
    let strain = Voigt6::new(1e-3, 0.0, 0.0, 0.0, 0.0, 2e-4);
    let opts = RelaxedOptions {
        tolerance: 1e-10,
        ..Default::default()
    };
    let state = strained_state(&p, &b, &k, &strain, &opts).unwrap();

    // Love stress of the bond forces (force on i from j; σ = (1/V)Σ f⊗l, tension positive
    // when f points along l) equals C·ε of the independent relaxed solve.
    let mut sigma = anisobond::Mat3::zeros();
    for bi in 0..b.len() {
        sigma += state.force[bi] * b.branch(bi).transpose();
    }
    sigma /= p.volume();
    let c = relaxed_tensor(&p, &b, &k, &opts).unwrap().c;
    let expected = c * strain;
    let got = Voigt6::new(
        sigma[(0, 0)],
        sigma[(1, 1)],
        sigma[(2, 2)],
        0.5 * (sigma[(1, 2)] + sigma[(2, 1)]),
        0.5 * (sigma[(0, 2)] + sigma[(2, 0)]),
        0.5 * (sigma[(0, 1)] + sigma[(1, 0)]),
    );
    let scale = expected.amax();
    assert!(
        (got - expected).amax() < 1e-6 * scale,
        "Love stress {got:?} vs C·ε {expected:?}"
    );
    // Net force on every particle with at least two bonds vanishes (equilibrium).
    let mut net = vec![Vec3::zeros(); p.len()];
    let mut deg = vec![0; p.len()];
    for bi in 0..b.len() {
        let (i, j) = (b.i[bi] as usize, b.j[bi] as usize);
        net[i] += state.force[bi];
        net[j] -= state.force[bi];
        deg[i] += 1;
        deg[j] += 1;
    }
    let fmax = state.force.iter().map(|f| f.norm()).fold(0.0, f64::max);
    let worst = (0..p.len())
        .filter(|&i| deg[i] >= 2)
        .map(|i| net[i].norm())
        .fold(0.0, f64::max);
    assert!(
        worst < 1e-6 * fmax,
        "net force {worst} vs bond force {fmax}"
    );

    let dir = tempfile::tempdir().unwrap();
    let pp = dir.path().join("particles.vtu");
    let bp = dir.path().join("bonds.vtu");
    write_particles_vtu(&pp, &p, Some(&state)).unwrap();
    write_bonds_vtu(&bp, &p, &b, &k, Some(&state)).unwrap();

    let (a, points, cells) = arrays(&pp);
    assert_eq!((points, cells), (p.len(), p.len()));
    assert_eq!(a["radius"], (1, p.len()));
    assert_eq!(a["displacement"], (3, 3 * p.len()));
    assert_eq!(a["rotation"], (3, 3 * p.len()));
    assert_eq!(a["Points"], (3, 3 * p.len()));
    assert_eq!(a["types"], (1, p.len()));

    let periodic = b.image.iter().filter(|im| **im != [0, 0, 0]).count();
    assert!(periodic > 0);
    let (a, points, cells) = arrays(&bp);
    assert_eq!(points, p.len() + periodic);
    assert_eq!(cells, b.len());
    for name in ["kn", "ks", "kr", "ktw", "length", "normal_force"] {
        assert_eq!(a[name], (1, b.len()), "{name}");
    }
    assert_eq!(a["force"], (3, 3 * b.len()));
    assert_eq!(a["normal"], (3, 3 * b.len()));
    assert_eq!(a["connectivity"], (1, 2 * b.len()));
    assert_eq!(a["offsets"], (1, b.len()));
}
