//! `anisobond specimen` end to end: a simple-cubic column written as a free packing file gives
//! the closed-form platen stiffness in specimen.json; overlapping end layers are refused with
//! nothing written.

use crate::common::*;

/// An nx × ny × nz simple-cubic block of touching spheres of radius 1 mm as SPEC text.
fn sc_text(nx: usize, ny: usize, nz: usize) -> String {
    let mut t = String::from("# x y z r (m), no cell: a free specimen\n");
    for i in 0..nx {
        for j in 0..ny {
            for k in 0..nz {
                t += &format!(
                    "{} {} {} 1e-3\n",
                    2e-3 * i as f64,
                    2e-3 * j as f64,
                    2e-3 * k as f64
                );
            }
        }
    }
    t
}

const SPRINGS: &str = "[bonding]\nrule = \"gap\"\nvalue = 0.01\n[scheme]\nkind = \"isotropic\"\n\
                       normal = 2e6\nshear = 7e5\n[geometry]\nconvention = \"spring\"\n";

#[test]
fn specimen_command_writes_the_closed_form_platen_stiffness() {
    let t = tmp();
    let d = t.path();
    let p = write(d, "column.txt", &sc_text(3, 3, 7));
    let m = write(d, "springs.toml", SPRINGS);
    let o = d.join("out");
    let out = succeeds(&mut cmd(
        "specimen {p} --model {m} --free --axis z --platens bonded -o {o}",
        &[("p", &p), ("m", &m), ("o", &o)],
    ));
    assert!(out.contains("platen stiffness"), "{out}");
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(o.join("specimen.json")).unwrap()).unwrap();
    let k = json["platen_stiffness"].as_f64().unwrap();
    let closed = 9.0 * 2e6 / 6.0;
    assert!(((k - closed) / closed).abs() < 1e-10, "{k} vs {closed}");
    let e = json["young"].as_f64().unwrap();
    assert!(((e - 2e6 / 2e-3) / (2e6 / 2e-3)).abs() < 1e-10, "E = {e}");
    assert_eq!(json["platens"], "bonded");
    for f in ["particles.csv", "particles.vtu", "bonds.vtu"] {
        assert!(o.join(f).is_file(), "{f} missing");
    }
    // End layers deeper than half the column overlap: refused, nothing written.
    let o2 = d.join("out2");
    let err = fails(&mut cmd(
        "specimen {p} --model {m} --free --end-layer 0.01 -o {o}",
        &[("p", &p), ("m", &m), ("o", &o2)],
    ));
    assert!(
        err.contains("--end-layer") && err.contains("overlap"),
        "{err}"
    );
    assert!(!o2.exists());
    assert_eq!(entries(d), ["column.txt", "out", "springs.toml"]);
}
