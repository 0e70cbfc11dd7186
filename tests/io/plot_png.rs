//! The PNGs are looked at, not only written: decode them, check their size and that they are
//! not blank (many distinct colours, the expected curve colours present).

use anisobond::calibrate::{sample_mean_field, DomainOptions};
use anisobond::model::Model;
use anisobond::plot::{plot_domain, plot_stiffness_sections, plot_stress_strain, History, Section};
use anisobond::Mat3;
use std::collections::HashSet;
use std::path::Path;

/// Decode a PNG: (width, height, RGB pixels).
fn decode(path: &Path) -> (u32, u32, Vec<[u8; 3]>) {
    let img = image::open(path).expect("a decodable PNG").to_rgb8();
    let (w, h) = img.dimensions();
    (w, h, img.pixels().map(|p| p.0).collect())
}

/// Fraction of non-white pixels and the number of distinct colours.
fn content(pixels: &[[u8; 3]]) -> (f64, usize) {
    let non_white = pixels.iter().filter(|p| **p != [255, 255, 255]).count();
    let colours: HashSet<[u8; 3]> = pixels.iter().copied().collect();
    (non_white as f64 / pixels.len() as f64, colours.len())
}

/// Pixels near a colour (each channel within 40).
fn near(pixels: &[[u8; 3]], c: [u8; 3]) -> usize {
    pixels
        .iter()
        .filter(|p| (0..3).all(|k| (p[k] as i32 - c[k] as i32).abs() <= 40))
        .count()
}

#[test]
fn domain_map_png_has_points_lines_and_text() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("domain.png");
    let (samples, _) = sample_mean_field(&DomainOptions {
        samples: 400,
        ..Default::default()
    })
    .unwrap();
    plot_domain(&path, &samples, "domain", Some((0.30, 0.43))).unwrap();
    let bytes = std::fs::read(&path).unwrap();
    assert_eq!(&bytes[..8], b"\x89PNG\r\n\x1a\n");
    let (w, h, px) = decode(&path);
    assert_eq!((w, h), (1000, 850));
    let (ink, colours) = content(&px);
    assert!(ink > 0.05 && ink < 0.9, "ink fraction {ink}");
    assert!(colours > 50, "{colours} colours");
    // The Cauchy line is pure red; the zener-above-1 points blue.
    assert!(near(&px, [255, 0, 0]) > 200, "red Cauchy line");
    assert!(near(&px, [31, 119, 180]) > 200, "blue points");
    // No leftover temporary file.
    let files: Vec<_> = std::fs::read_dir(dir.path()).unwrap().collect();
    assert_eq!(files.len(), 1);
}

#[test]
fn stiffness_polar_plot_shows_both_curves() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("stiffness.png");
    let model = Model::truszkowska_mrv();
    let scheme = model.build_scheme(None).unwrap();
    let sections = Section::cubic_planes(&Mat3::identity());
    plot_stiffness_sections(&path, scheme.as_ref(), &sections, "MRV model", "Pa/m").unwrap();
    let (w, h, px) = decode(&path);
    assert_eq!((w, h), (1240, 680));
    let (ink, colours) = content(&px);
    assert!(ink > 0.02, "ink {ink}");
    assert!(colours > 30);
    assert!(near(&px, [31, 119, 180]) > 500, "normal curve (blue)");
    assert!(near(&px, [214, 160, 20]) > 500, "shear curve (gold)");
}

#[test]
fn stress_strain_plot_and_bad_history() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("ss.png");
    // Uniaxial strain of an isotropic solid: σ11 = (λ + 2μ)ε, σ22 = σ33 = λε.
    let (lam, mu) = (40e9, 30e9);
    let mut hist = History::default();
    for k in 0..50 {
        let e = 1e-5 * k as f64;
        hist.time.push(k as f64);
        hist.strain.push([e, 0.0, 0.0, 0.0, 0.0, 0.0]);
        hist.stress
            .push([(lam + 2.0 * mu) * e, lam * e, lam * e, 0.0, 0.0, 0.0]);
    }
    plot_stress_strain(&path, &hist, "uniaxial strain").unwrap();
    let (w, h, px) = decode(&path);
    assert_eq!((w, h), (1000, 700));
    assert!(content(&px).0 > 0.02);
    // σ11 in the first palette colour; σ22 = σ33 (second and third colours, the latter
    // drawn over the former).
    assert!(near(&px, [31, 119, 180]) > 300);
    assert!(near(&px, [255, 127, 14]) + near(&px, [44, 160, 44]) > 300);
    // A history without variation is refused and leaves no file.
    let bad = History {
        step: vec![0, 1],
        time: vec![0.0, 1.0],
        strain: vec![[0.0; 6]; 2],
        stress: vec![[0.0; 6]; 2],
    };
    let p2 = dir.path().join("bad.png");
    assert!(plot_stress_strain(&p2, &bad, "x").is_err());
    assert!(!p2.exists());
}

#[test]
fn line_plot_of_histories_shows_every_curve() {
    use anisobond::plot::{plot_series, Series};
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("series.png");
    // A damped oscillation (line) and the same samples as dots in another colour.
    let pts: Vec<(f64, f64)> = (0..200)
        .map(|k| {
            let t = k as f64;
            (t, -1.0 + 0.5 * (-t / 30.0).exp() * (t / 5.0).cos())
        })
        .collect();
    let series = [
        Series {
            label: "line".into(),
            points: pts.clone(),
            dashed: false,
            colour: Some(0),
        },
        Series {
            label: "dots".into(),
            points: pts.iter().step_by(5).map(|&(t, y)| (t, y - 0.2)).collect(),
            dashed: true,
            colour: Some(3),
        },
    ];
    plot_series(&path, &series, "histories", "step", "stress (MPa)").unwrap();
    let (w, h, px) = decode(&path);
    assert_eq!((w, h), (1000, 700));
    let (ink, colours) = content(&px);
    assert!(ink > 0.02 && colours > 20, "ink {ink}, colours {colours}");
    assert!(near(&px, [31, 119, 180]) > 300, "line colour missing");
    assert!(near(&px, [214, 39, 40]) > 100, "dot colour missing");
    // Nothing to plot, or a NaN: refused, no file.
    let p2 = dir.path().join("bad.png");
    let nan = [Series {
        label: "x".into(),
        points: vec![(0.0, f64::NAN), (1.0, 1.0)],
        dashed: false,
        colour: None,
    }];
    assert!(plot_series(&p2, &nan, "x", "x", "y").is_err());
    assert!(plot_series(&p2, &[], "x", "x", "y").is_err());
    assert!(!p2.exists());
}
