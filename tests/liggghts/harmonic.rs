//! The stock-LIGGGHTS deck (`bond_style harmonic`, K = k_n/2, one bond type per bond):
//! with the particles following the box it must give the Voigt tensor of the same bonds
//! with k_s = 0 (an independent sum in Rust). Skipped only when LIGGGHTS is absent and CI
//! is unset.

use crate::common::liggghts::*;
use anisobond::export::liggghts::{
    columns_from_cases, export_liggghts, read_stress_history, run_liggghts, DeckOptions, Launch,
};
use anisobond::homogenize::voigt_tensor;

#[test]
fn stock_harmonic_deck_gives_the_normal_spring_voigt_tensor() {
    if let Some(r) = missing(&["liggghts"]) {
        eprintln!("skipping: {r}");
        return;
    }
    let b = bonded(
        300,
        3,
        "[bonding]\nrule = \"gap\"\nvalue = 0.17\n[scheme]\nkind = \"cubic\"\nmodel = \"zener-above-1\"\n\
         a_n = 4.31\na_s = 10.0\nnormal = 1.0e13\nshear = 3.55e12\n",
    );
    let dir = fresh_dir("harmonic");
    let opts = DeckOptions {
        affine: true,
        deform_steps: 20,
        relax_steps: 0,
        output_every: 20,
        ..DeckOptions::default()
    };
    let sum = export_liggghts(&dir, &b.packing, &b.bonds, &b.k, &opts).unwrap();
    run_liggghts(
        &Launch {
            program: "liggghts".into(),
            mpi_processes: None,
            vars: vec![],
        },
        &dir,
        "harmonic.in",
    )
    .unwrap();
    let h = read_stress_history(&dir.join("stress_history.txt")).unwrap();
    // The stock deck runs the normal cases only (columns 1–3); normal stresses compared.
    let cols = columns_from_cases(&h, &sum.case_end_steps[..3]).unwrap();
    let mut k0 = b.k.clone();
    k0.ks.iter_mut().for_each(|v| *v = 0.0);
    let v = voigt_tensor(&b.bonds, &k0, b.packing.volume());
    let full = voigt_tensor(&b.bonds, &b.k, b.packing.volume());
    let scale = v.abs().max();
    let (mut d, mut d_full) = (0.0f64, 0.0f64);
    for (a, col) in cols.iter().enumerate() {
        for r in 0..3 {
            d = d.max((col[r] - v[(r, a)]).abs() / scale);
            d_full = d_full.max((col[r] - full[(r, a)]).abs() / scale);
        }
    }
    eprintln!("harmonic deck vs Voigt(k_s = 0): {d:.3e}; vs Voigt with k_s: {d_full:.3e}");
    assert!(
        d < 1e-4,
        "harmonic deck vs Voigt(k_s = 0): {d:.3e}\n{cols:?}\n{v:.4e}"
    );
    // k_s matters for this model: the full Voigt tensor is clearly different.
    assert!(d_full > 0.05);
}

#[test]
fn liggghts_error_message_is_surfaced() {
    if let Some(r) = missing(&["liggghts"]) {
        eprintln!("skipping: {r}");
        return;
    }
    let dir = fresh_dir("harmonic_error");
    std::fs::write(
        dir.join("bad.in"),
        "units si\natom_style granular\nread_data no_such_file.data\n",
    )
    .unwrap();
    let e = run_liggghts(
        &Launch {
            program: "liggghts".into(),
            mpi_processes: None,
            vars: vec![],
        },
        &dir,
        "bad.in",
    )
    .unwrap_err()
    .to_string();
    assert!(
        e.contains("ERROR") && e.contains("no_such_file.data"),
        "message: {e}"
    );
}
