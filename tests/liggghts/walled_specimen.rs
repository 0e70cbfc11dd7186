//! A walled LIGGGHTS box as the user's finite specimen (issue 31): LIGGGHTS writes a
//! `boundary f f f` dump of a 6 × 6 × 8 simple-cubic block in the test; `anisobond validate
//! ENGINE wall.dump --free --specimen` reads the dump as written (a free cluster, from its own
//! boundary flags), bonds it with the anisotropic cubic model, and each engine — LIGGGHTS
//! (driver, np 1 and 2), LAMMPS (np 1 and 2) and YADE — loads the specimen between platens by
//! its own means; its platen force must match the specimen solve within 1e-3 (measured
//! 1.9e-7, 1.5e-7 and 8e-9).

use crate::common::lammps::lmp_with;
use crate::common::liggghts::*;
use crate::common::{cmd, tmp, write, CUBIC_MODEL};

fn wall_deck() -> String {
    format!(
        "units si\n\
         atom_style granular\n\
         atom_modify map array\n\
         boundary f f f\n\
         newton off\n\
         communicate single vel yes\n\
         region box block 0 0.012 0 0.012 0 0.016 units box\n\
         create_box 1 box\n\
         lattice sc 0.002\n\
         region fill block 0 0.0119 0 0.0119 0 0.0159 units box\n\
         create_atoms 1 region fill\n\
         displace_atoms all move 0.001 0.001 0.001 units box\n\
         {}",
        snapshot_tail("wall")
    )
}

#[test]
fn a_walled_liggghts_dump_is_validated_as_a_specimen_in_every_engine() {
    let Some(lmp) = lmp_with(&["liggghts", "yade", "mpirun", "make", "g++"]) else {
        return;
    };
    let driver = driver();
    let t = tmp();
    let d = t.path();
    let (dump, _) = write_snapshot(d, "wall", &wall_deck());
    let model = write(d, "model.toml", CUBIC_MODEL);
    let runs = [
        ("liggghts", "--np 2 --driver {x}", driver.clone()),
        ("lammps", "--np 2 --lmp {x}", lmp),
        ("yade", "", driver),
    ];
    for (engine, extra, program) in runs {
        let out = d.join(format!("out-{engine}"));
        let line =
            format!("validate {engine} {{p}} --model {{m}} --free --specimen {extra} -o {{o}}");
        let o = cmd(
            &line,
            &[("p", &dump), ("m", &model), ("o", &out), ("x", &program)],
        )
        .output()
        .unwrap();
        let log = String::from_utf8_lossy(&o.stdout).to_string();
        assert!(
            o.status.success(),
            "{engine}: {log}\n{}",
            String::from_utf8_lossy(&o.stderr)
        );
        let report: serde_json::Value = serde_json::from_str(
            &std::fs::read_to_string(out.join("specimen-validation.json")).unwrap(),
        )
        .unwrap();
        let checks = report["checks"].as_array().unwrap();
        let platen: Vec<f64> = checks
            .iter()
            .filter(|c| c["id"].as_str().unwrap().starts_with("platen-stiffness"))
            .map(|c| c["value"].as_f64().unwrap())
            .collect();
        let want = if engine == "yade" { 1 } else { 2 };
        assert_eq!(platen.len(), want, "{engine}: {log}");
        eprintln!("{engine}: platen stiffness against the specimen solve {platen:?}");
        assert!(platen.iter().all(|&v| v <= 1e-3), "{engine}: {log}");
    }
}
