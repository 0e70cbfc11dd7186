//! The `calibrate`, `domain`, `plot stiffness` and `export vtk` commands end to end.

use crate::common::{bin, CUBIC_MODEL as MODEL};
use anisobond::model::{Model, SchemeSpec};
use anisobond::schemes::CubicModel;

#[test]
fn calibrate_writes_a_model_that_reads_back_and_nickel_with_a_term() {
    let dir = tempfile::tempdir().unwrap();
    let model = dir.path().join("m.toml");
    std::fs::write(&model, MODEL).unwrap();
    let out = dir.path().join("cal.toml");
    let o = bin()
        .args(["calibrate", "--model"])
        .arg(&model)
        .args(["--target", "C12/C11=0.20,C44/C11=0.35", "-o"])
        .arg(&out)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert!(stdout.contains("C44/C11"), "{stdout}");
    let m = Model::from_path(&out).unwrap();
    let SchemeSpec::Cubic(cubic) = &m.scheme else {
        panic!("cubic expected")
    };
    // Zener 2·0.35/0.8 = 0.875 < 1.
    assert_eq!(cubic.model, CubicModel::ZenerBelow1);

    let bad = dir.path().join("nickel.toml");
    let o = bin()
        .args(["calibrate", "--model"])
        .arg(&model)
        .args(["--target", "C11=246.5GPa,C12=147.3GPa,C44=124.7GPa", "-o"])
        .arg(&bad)
        .output()
        .unwrap();
    // Beyond the Cauchy line: the springs alone cannot, so the model gets [manybody]
    // (tests/calibrate/manybody.rs checks the tensor it reaches).
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let out = String::from_utf8_lossy(&o.stdout);
    assert!(out.contains("nearest reachable"), "{out}");
    assert!(Model::from_path(&bad).unwrap().manybody.is_some());
    // The reachable target above got none.
    assert!(m.manybody.is_none());
}

#[test]
fn domain_plot_and_vtk_commands_write_their_files() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let o = bin()
        .args(["domain", "--samples", "200", "-o"])
        .arg(d)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let csv = std::fs::read_to_string(d.join("domain.csv")).unwrap();
    assert!(
        csv.starts_with("model,extended,a_n,a_s,shear_over_normal,C12/C11,C44/C11,zener,nu_100")
    );
    assert!(csv.lines().count() > 400);
    assert!(d.join("domain.png").exists());

    let model = d.join("m.toml");
    std::fs::write(&model, MODEL).unwrap();
    let o = bin()
        .args(["plot", "stiffness", "--model"])
        .arg(&model)
        .arg("-o")
        .arg(d)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(d.join("stiffness.png").exists());

    let packing = d.join("p.txt");
    let o = bin()
        .args(["pack", "--particles", "300", "-o"])
        .arg(&packing)
        .output()
        .unwrap();
    assert!(o.status.success());
    let o = bin()
        .args(["export", "vtk"])
        .arg(&packing)
        .arg("--model")
        .arg(&model)
        .arg("-o")
        .arg(d.join("vtk"))
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    for f in ["particles.vtu", "bonds.vtu"] {
        let text = std::fs::read_to_string(d.join("vtk").join(f)).unwrap();
        assert!(text.contains("<VTKFile type=\"UnstructuredGrid\""));
    }
}
