//! `[manybody]` in a model file (docs/manybody.md): each kind read into the tensor it names,
//! the cubic rotation and transversely isotropic axis taken from the scheme when left out,
//! written back and read again to the same model, refused with the key at fault.

use anisobond::manybody::{DegenerateParticles, LocalTensor, StrainMeasure};
use anisobond::model::Model;
use anisobond::schemes::rotation_from_euler_zyz_deg;
use anisobond::tensor::rotate;
use anisobond::Error;

const CUBIC_SCHEME: &str =
    "[scheme]\nkind = \"cubic\"\nmodel = \"zener-above-1\"\na_n = 1.0\na_s = 1.0\n\
normal = 1.0e9\nshear = 0.3e9\neuler_zyz_deg = [10.0, 20.0, 30.0]\n";

const CROSS_SCHEME: &str = "[scheme]\nkind = \"cross-anisotropic\"\nC11 = 60e9\nC33 = 40e9\n\
C13 = 12e9\nC12 = 15e9\naxis = [0.0, 0.6, 0.8]\n";

fn read(text: &str) -> anisobond::Result<Model> {
    Model::from_toml_str(text, "m.toml")
}

#[test]
fn each_kind_reads_into_its_tensor_with_the_schemes_frame_by_default() {
    // Cubic D without a rotation turns with the cubic scheme's crystal.
    let m = read(&format!(
        "{CUBIC_SCHEME}[manybody]\nkind = \"cubic\"\nc11 = 5e9\nc12 = 3e9\nc44 = 1e9\n"
    ))
    .unwrap();
    let spec = m.manybody.as_ref().unwrap();
    let r = rotation_from_euler_zyz_deg(10.0, 20.0, 30.0);
    assert_eq!(
        spec.tensor,
        LocalTensor::Cubic {
            c11: 5e9,
            c12: 3e9,
            c44: 1e9,
            rotation: r
        }
    );
    // Defaults: Green–Lagrange, rattlers excluded.
    assert_eq!(spec.measure, StrainMeasure::GreenLagrange);
    assert_eq!(spec.degenerate, DegenerateParticles::Exclude);
    // The lab tensor is the crystal one rotated back (independent: explicit rotate of the
    // textbook cubic matrix).
    let mut crystal = anisobond::tensor::Stiffness6::zeros();
    for a in 0..3 {
        for b in 0..3 {
            crystal[(a, b)] = if a == b { 5e9 } else { 3e9 };
        }
        crystal[(a + 3, a + 3)] = 1e9;
    }
    let want = rotate(&crystal, &r.transpose());
    assert!((spec.voigt().unwrap() - want).amax() <= 1e-6 * 5e9);

    // Transversely isotropic D without an axis takes the cross-anisotropic scheme's.
    let m = read(&format!(
        "{CROSS_SCHEME}[manybody]\nkind = \"transversely-isotropic\"\nc11 = 5e9\nc33 = 4e9\n\
         c13 = 1e9\nc12 = 2e9\nc44 = 3e9\nmeasure = \"small\"\ndegenerate = \"refuse\"\n"
    ))
    .unwrap();
    let spec = m.manybody.as_ref().unwrap();
    match &spec.tensor {
        LocalTensor::TransverselyIsotropic { axis, c44, .. } => {
            assert!((axis - anisobond::Vec3::new(0.0, 0.6, 0.8)).norm() < 1e-15);
            assert_eq!(c44, &3e9);
        }
        other => panic!("read as {other:?}"),
    }
    assert_eq!(spec.measure, StrainMeasure::Small);
    assert_eq!(spec.degenerate, DegenerateParticles::Refuse);

    // Isotropic and a general Voigt matrix.
    let m = read(&format!(
        "{CUBIC_SCHEME}[manybody]\nkind = \"isotropic\"\nbulk = 2e9\nshear = 0.0\n"
    ))
    .unwrap();
    let d = m.manybody.as_ref().unwrap().voigt().unwrap();
    assert_eq!((d[(0, 0)], d[(0, 1)], d[(3, 3)]), (2e9, 2e9, 0.0));
    let rows: Vec<String> = (0..6)
        .map(|i| {
            let row: Vec<String> = (0..6)
                .map(|j| format!("{:e}", 1e9 * (1.0 + (i.min(j) * 7 + i.max(j)) as f64)))
                .collect();
            format!("[{}]", row.join(", "))
        })
        .collect();
    let m = read(&format!(
        "{CUBIC_SCHEME}[manybody]\nkind = \"voigt\"\nmatrix = [{}]\n",
        rows.join(", ")
    ))
    .unwrap();
    let d = m.manybody.as_ref().unwrap().voigt().unwrap();
    assert_eq!(d[(2, 4)], 1e9 * (1.0 + (2 * 7 + 4) as f64));
    assert_eq!(d[(4, 2)], d[(2, 4)]);
}

#[test]
fn written_model_reads_back_identically_in_both_formats() {
    for text in [
        format!("{CUBIC_SCHEME}[manybody]\nkind = \"cubic\"\nc11 = 5e9\nc12 = 3e9\nc44 = 1e9\n"),
        format!(
            "{CROSS_SCHEME}[manybody]\nkind = \"transversely-isotropic\"\nc11 = 5e9\n\
             c33 = 4e9\nc13 = 1e9\nc12 = 2e9\nc44 = 3e9\n"
        ),
        format!("{CUBIC_SCHEME}[manybody]\nkind = \"isotropic\"\nbulk = 2e9\nshear = 1e9\n"),
    ] {
        let m = read(&text).unwrap();
        assert_eq!(read(&m.to_toml_string()).unwrap(), m);
        assert_eq!(
            Model::from_json_str(&m.to_json_string(), "m.json").unwrap(),
            m
        );
    }
    // A model without the table writes none.
    let m = read(CUBIC_SCHEME).unwrap();
    assert!(m.manybody.is_none());
    assert!(!m.to_toml_string().contains("manybody"));
}

#[test]
fn bad_tables_are_refused_naming_the_key() {
    let cases = [
        (
            "kind = \"hexagonal\"\nbulk = 1.0\nshear = 1.0\n",
            "hexagonal",
        ),
        ("kind = \"isotropic\"\nbulk = 1.0\n", "shear"),
        (
            "kind = \"isotropic\"\nbulk = 1.0\nshear = 1.0\nc11 = 2.0\n",
            "c11",
        ),
        (
            "kind = \"cubic\"\nc11 = 5e9\nc12 = 3e9\nc44 = 1e9\neuler_zyz_deg = [0.0, 0.0, 0.0]\n\
             rotation = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]\n",
            "not both",
        ),
        (
            "kind = \"cubic\"\nc11 = 5e9\nc12 = 3e9\nc44 = 1e9\n\
             rotation = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 2.0]]\n",
            "rotation",
        ),
        (
            "kind = \"transversely-isotropic\"\nc11 = 5e9\nc33 = 4e9\nc13 = 1e9\nc12 = 2e9\n\
             c44 = 3e9\naxis = [0.0, 0.0, 0.0]\n",
            "axis",
        ),
        (
            "kind = \"isotropic\"\nbulk = 1.0\nshear = 1.0\nmeasure = \"linear\"\n",
            "linear",
        ),
    ];
    for (table, word) in cases {
        let text = format!("{CUBIC_SCHEME}[manybody]\n{table}");
        match read(&text) {
            Err(e @ (Error::Model(_) | Error::Parse { .. })) => {
                let m = e.to_string();
                assert!(m.contains(word), "{table:?}: {m}");
                eprintln!("{m}");
            }
            other => panic!("{table:?}: expected a refusal, got {other:?}"),
        }
    }
}
