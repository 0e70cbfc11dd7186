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

/// Groups from a file of ids and a box, force control and a confining pressure on the command
/// line: the closed forms of a simple-cubic column (δ = F/k, lateral strain −p·2R/k_n); a bad
/// group, an unknown id and two load controls are refused with nothing written.
#[test]
fn specimen_command_takes_groups_force_and_confining_pressure() {
    let t = tmp();
    let d = t.path();
    let p = write(d, "column.txt", &sc_text(3, 3, 7));
    let m = write(d, "springs.toml", SPRINGS);
    // The bottom layer by 0-based order (k = 0 of each of the 9 columns of 7), the top one by
    // a box.
    let ids: Vec<String> = (0..9).map(|c| (c * 7).to_string()).collect();
    let f = write(
        d,
        "held.txt",
        &format!("# bottom layer\n{}\n", ids.join(" ")),
    );
    let held = std::path::PathBuf::from(format!("file:{}", f.display()));
    let o = d.join("out");
    let out = succeeds(&mut cmd(
        "specimen {p} --model {m} --free --held {h} --moved box:-1,-1,0.0115,1,1,0.0125 \
         --force 3 --confining-pressure 2e5 -o {o}",
        &[("p", &p), ("m", &m), ("h", &held), ("o", &o)],
    ));
    assert!(out.contains("confining pressure"), "{out}");
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(o.join("specimen.json")).unwrap()).unwrap();
    let k = 9.0 * 2e6 / 6.0;
    let delta = json["displacement"].as_f64().unwrap();
    assert!(((delta - 3.0 / k) / (3.0 / k)).abs() < 1e-9, "{delta}");
    assert_eq!(json["control"], "force");
    assert_eq!(json["held_particles"], 9);
    assert_eq!(json["moved_particles"], 9);
    let lateral = -2e5 * 2e-3 / 2e6;
    for e in json["lateral_strain"].as_array().unwrap() {
        let e = e.as_f64().unwrap();
        assert!(((e - lateral) / lateral).abs() < 1e-9, "{e} vs {lateral}");
    }
    let csv = std::fs::read_to_string(o.join("particles.csv")).unwrap();
    assert_eq!(csv.lines().filter(|l| l.contains(",held,")).count(), 9);
    // Refusals: nothing written.
    for (args, expect) in [
        ("--held box:1,2 -o {o}", "--held"),
        ("--held ids:0,1,999 -o {o}", "id 999"),
        ("--strain 1e-4 --force 2 -o {o}", "--force"),
    ] {
        let o2 = d.join("refused");
        let err = fails(&mut cmd(
            &format!("specimen {{p}} --model {{m}} --free {args}"),
            &[("p", &p), ("m", &m), ("o", &o2)],
        ));
        assert!(err.contains(expect), "{args}: {err}");
        assert!(!o2.exists(), "{args}");
    }
}

/// `--bonds TABLE`: the table's springs replace the model's. The column's table written by
/// `anisobond bonds` with every k_n doubled doubles the closed-form platen stiffness.
#[test]
fn specimen_command_takes_the_users_bond_table() {
    let t = tmp();
    let d = t.path();
    let p = write(d, "column.txt", &sc_text(3, 3, 7));
    let m = write(d, "springs.toml", SPRINGS);
    let table = d.join("bonds.csv");
    succeeds(&mut cmd(
        "bonds {p} --model {m} --free -o {t}",
        &[("p", &p), ("m", &m), ("t", &table)],
    ));
    let text = std::fs::read_to_string(&table).unwrap();
    let mut lines = text.lines();
    let header = lines.next().unwrap();
    let kn_col = header.split(',').position(|c| c.starts_with("kn")).unwrap();
    let mut doubled = format!("{header}\n");
    for line in lines {
        let mut cells: Vec<String> = line.split(',').map(str::to_string).collect();
        let kn: f64 = cells[kn_col].parse().unwrap();
        cells[kn_col] = format!("{:e}", 2.0 * kn);
        doubled += &(cells.join(",") + "\n");
    }
    let stiff = write(d, "stiff.csv", &doubled);
    let o = d.join("out");
    succeeds(&mut cmd(
        "specimen {p} --model {m} --free --bonds {b} --platens bonded -o {o}",
        &[("p", &p), ("m", &m), ("b", &stiff), ("o", &o)],
    ));
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(o.join("specimen.json")).unwrap()).unwrap();
    let k = json["platen_stiffness"].as_f64().unwrap();
    let closed = 2.0 * 9.0 * 2e6 / 6.0;
    assert!(((k - closed) / closed).abs() < 1e-10, "{k} vs {closed}");
}
