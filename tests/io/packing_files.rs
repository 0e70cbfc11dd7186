//! Packing files: parsing, errors with line numbers, bit-exact round trips.

use anisobond::packing::{
    detect_format, parse_liggghts_data, parse_packing, read_packing, write_liggghts_data,
    write_packing, write_yade_spherepack, PackingFormat,
};
use anisobond::packing::{Packing, PeriodicCell};
use anisobond::{Error, Vec3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

fn parse_err(text: &str) -> (usize, String) {
    match parse_packing(text, "in.txt") {
        Err(Error::Parse {
            path,
            line,
            message,
        }) => {
            assert_eq!(path, "in.txt");
            (line, message)
        }
        other => panic!("expected a parse error, got {other:?}"),
    }
}

#[test]
fn spec_text_with_comments_and_periodic_header() {
    let text = "# a comment\n# periodic 10 20 30\n\n1 2 3 0.5  # trailing comment\n\
                -1 25 31 0.25\n";
    let p = parse_packing(text, "in.txt").unwrap();
    assert_eq!(p.len(), 2);
    assert_eq!(p.cell.unwrap().lengths, Vec3::new(10.0, 20.0, 30.0));
    assert_eq!(p.positions[0], Vec3::new(1.0, 2.0, 3.0));
    // Wrapped into the cell: −1 → 9, 25 → 5, 31 → 1.
    assert!((p.positions[1] - Vec3::new(9.0, 5.0, 1.0)).norm() < 1e-12);
    assert_eq!(p.radii, vec![0.5, 0.25]);
    // No header: free packing.
    let p = parse_packing("0 0 0 1\n3 0 0 1\n", "x").unwrap();
    assert!(p.cell.is_none());
}

#[test]
fn yade_formats() {
    let text = "##PERIODIC:: 4 4 4\n1 1 1 0.5\n5 1 1 0.5\n";
    assert_eq!(detect_format(text), PackingFormat::YadeSpherePack);
    let p = parse_packing(text, "pack.txt").unwrap();
    assert_eq!(p.cell.unwrap().lengths, Vec3::repeat(4.0));
    assert_eq!(p.positions[1], Vec3::new(1.0, 1.0, 1.0));
    // YADE export.text.
    let text = "#format x_y_z_r\n0.1 0.2 0.3 0.05\n";
    assert_eq!(detect_format(text), PackingFormat::SpecText);
    assert_eq!(parse_packing(text, "e.txt").unwrap().radii, vec![0.05]);
    let text = "#format x_y_z_r_matId\n0.1 0.2 0.3 0.05 1\n";
    assert_eq!(parse_packing(text, "e.txt").unwrap().len(), 1);
    let (line, msg) = parse_err("#format x_y_z\n0 0 0\n");
    assert_eq!(line, 1);
    assert!(msg.contains("x_y_z_r"), "{msg}");
}

#[test]
fn yade_columns_clump_ids_and_formats() {
    // SpherePack.save's fifth column: clumpId −1 is a free sphere; a clump member is refused.
    let p = parse_packing("##PERIODIC:: 4 4 4\n1 1 1 0.5 -1\n5 1 1 0.5 -1\n", "s").unwrap();
    assert_eq!(p.len(), 2);
    let (line, msg) = parse_err("1 1 1 0.5 -1\n2 1 1 0.5 0\n");
    assert_eq!(line, 2);
    assert!(msg.contains("belongs to clump 0"), "{msg}");
    let (line, msg) = parse_err("1 1 1 0.5 -1.5\n");
    assert_eq!(line, 1);
    assert!(
        msg.contains("expected an integer clumpId (column 5)"),
        "{msg}"
    );
    let (_, msg) = parse_err("1 1 1 0.5 -1 7\n");
    assert!(msg.contains("or 5, `x y z r clumpId`"), "{msg}");
    // textExt formats: matId an integer, attrs the same count on every line, id first.
    let (line, msg) = parse_err("#format x_y_z_r_matId\n0 0 0 1 0.5\n");
    assert_eq!(line, 2);
    assert!(msg.contains("integer matId (column 5)"), "{msg}");
    let p = parse_packing(
        "#format x_y_z_r_attrs\n# x y z r m\n0 0 0 1 2\n3 0 0 1 2\n",
        "a",
    )
    .unwrap();
    assert_eq!(p.radii, vec![1.0, 1.0]);
    let (line, msg) = parse_err("#format x_y_z_r_attrs\n0 0 0 1 2\n3 0 0 1\n");
    assert_eq!(line, 3);
    assert!(
        msg.contains("5 numbers `x y z r` and 1 attribute value(s)"),
        "{msg}"
    );
    let p = parse_packing("#format id_x_y_z_r_matId\n7 0 0 0 1 0\n", "i").unwrap();
    assert_eq!(p.positions[0], Vec3::zeros());
    assert_eq!(p.ids, Some(vec![7]));
    let (line, msg) = parse_err("#format id_x_y_z_r_matId\n7 0 0 0 1 0\n7 3 0 0 1 0\n");
    assert_eq!(line, 3);
    assert!(
        msg.contains("body id 7 appears twice (also line 2)"),
        "{msg}"
    );
    let (_, msg) = parse_err("#format id_x_y_z_r_matId\n-7 0 0 0 1 0\n");
    assert!(msg.contains("body id (column 1) must be ≥ 0"), "{msg}");
    let (line, msg) = parse_err("#format jointedPM\n");
    assert_eq!(line, 1);
    assert!(msg.contains("unsupported `#format jointedPM`"), "{msg}");
}

#[test]
fn malformed_lines_report_line_and_expectation() {
    let (line, msg) = parse_err("# periodic 5 5 5\n1 1 1 0.5\n1 2 3\n");
    assert_eq!(line, 3);
    assert!(
        msg.contains("expected 4 numbers `x y z r`, found 3"),
        "{msg}"
    );
    let (line, msg) = parse_err("1 1 1 0.5\n1 1 x 0.5\n");
    assert_eq!(line, 2);
    assert!(msg.contains("expected a number for z, found `x`"), "{msg}");
    let (line, msg) = parse_err("1 1 1 0.5\n\n1 NaN 1 0.5\n");
    assert_eq!(line, 3);
    assert!(msg.contains("NaN"), "{msg}");
    let (line, msg) = parse_err("1 1 1 0\n");
    assert_eq!(line, 1);
    assert!(msg.contains("radius must be > 0"), "{msg}");
    let (line, msg) = parse_err("1 1 1 -2\n");
    assert_eq!(line, 1);
    assert!(msg.contains("radius must be > 0"), "{msg}");
    let (_, msg) = parse_err("1 1 inf 1\n");
    assert!(msg.contains("finite"), "{msg}");
}

#[test]
fn bad_periodic_headers() {
    let (line, msg) = parse_err("1 1 1 0.5\n# periodic 5 5\n");
    assert_eq!(line, 2);
    assert!(msg.contains("3 cell lengths, found 2"), "{msg}");
    let (line, msg) = parse_err("# periodic 5 -5 5\n");
    assert_eq!(line, 1);
    assert!(msg.contains("Ly must be > 0"), "{msg}");
    let (_, msg) = parse_err("# periodic 5 five 5\n");
    assert!(
        msg.contains("expected a number for cell length Ly"),
        "{msg}"
    );
    let (line, msg) = parse_err("# periodic 5 5 5\n# periodic 6 6 6\n");
    assert_eq!(line, 2);
    assert!(msg.contains("second periodic cell header"), "{msg}");
    let (line, _) = parse_err("##PERIODIC:: 1 2 nan\n");
    assert_eq!(line, 1);
}

const LIGGGHTS: &str = "LIGGGHTS data file\n\n3 atoms\n1 atom types\n\n\
-1.0 1.0 xlo xhi\n-2 2 ylo yhi\n0 3 zlo zhi\n\nAtoms # granular\n\n\
3 1 0.5 2500 0.5 1.5 2.0\n1 1 0.2 2500 -0.5 0.0 0.5\n2 1 0.4 2500 0.0 -1.5 1.0\n";

#[test]
fn liggghts_data_sorted_by_id_shifted_and_diameters_halved() {
    assert_eq!(detect_format(LIGGGHTS), PackingFormat::LiggghtsData);
    let p = parse_packing(LIGGGHTS, "in.data").unwrap();
    assert_eq!(p.cell.unwrap().lengths, Vec3::new(2.0, 4.0, 3.0));
    assert_eq!(p.radii, vec![0.1, 0.2, 0.25]);
    assert_eq!(p.positions[0], Vec3::new(0.5, 2.0, 0.5));
    assert_eq!(p.positions[1], Vec3::new(1.0, 0.5, 1.0));
    assert_eq!(p.positions[2], Vec3::new(1.5, 3.5, 2.0));
    // Non-periodic choice keeps the coordinates as written.
    assert_eq!(p.ids, Some(vec![1, 2, 3]));
    let q = parse_liggghts_data(LIGGGHTS, "in.data", false).unwrap();
    assert!(q.cell.is_none());
    assert_eq!(q.positions[0], Vec3::new(-0.5, 0.0, 0.5));
}

#[test]
fn liggghts_errors() {
    let text = LIGGGHTS.replace("3 atoms", "4 atoms");
    match parse_packing(&text, "in.data") {
        Err(Error::Parse { line, message, .. }) => {
            assert_eq!(line, 10); // the Atoms line
            assert!(
                message.contains("declares 4 atoms but the Atoms section has 3"),
                "{message}"
            );
        }
        other => panic!("{other:?}"),
    }
    let text = LIGGGHTS.replace("2 1 0.4 2500 0.0 -1.5 1.0", "2 1 0.4 2500 0.0 -1.5");
    match parse_packing(&text, "in.data") {
        Err(Error::Parse { line, message, .. }) => {
            assert_eq!(line, 14);
            assert!(
                message.contains("id type diameter density x y z"),
                "{message}"
            );
        }
        other => panic!("{other:?}"),
    }
    let text = LIGGGHTS.replace("3 1 0.5", "3 1 -0.5");
    let err = parse_packing(&text, "in.data").unwrap_err().to_string();
    assert!(err.contains("in.data:12: diameter must be > 0"), "{err}");
    let text = LIGGGHTS.replace("3 1 0.5", "1 1 0.5");
    let err = parse_packing(&text, "in.data").unwrap_err().to_string();
    assert!(err.contains("atom id 1 appears twice"), "{err}");
    // LAMMPS `atom_style sphere` has granular's columns (issue 31): read the same; another
    // style is refused by name.
    let text = LIGGGHTS.replace("Atoms # granular", "Atoms # sphere");
    let sphere = parse_packing(&text, "in.data").unwrap();
    let granular = parse_packing(LIGGGHTS, "in.data").unwrap();
    assert_eq!(sphere.positions, granular.positions);
    assert_eq!(sphere.radii, granular.radii);
    let text = LIGGGHTS.replace("Atoms # granular", "Atoms # full");
    let err = parse_packing(&text, "in.data").unwrap_err().to_string();
    assert!(err.contains("found atom style `full`"), "{err}");
    let text = LIGGGHTS.replace("0 3 zlo zhi\n", "");
    let err = parse_packing(&text, "in.data").unwrap_err().to_string();
    assert!(err.contains("zlo zhi"), "{err}");
}

fn random_packing(periodic: bool) -> Packing {
    let mut rng = ChaCha8Rng::seed_from_u64(99);
    let l = Vec3::new(0.0123, 0.0456, 7.89e-3);
    let pos: Vec<Vec3> = (0..500)
        .map(|_| {
            Vec3::new(
                rng.gen::<f64>() * l.x,
                rng.gen::<f64>() * l.y,
                rng.gen::<f64>() * l.z,
            )
        })
        .collect();
    let rad: Vec<f64> = (0..500).map(|_| rng.gen_range(1e-5..3e-4)).collect();
    let cell = periodic.then(|| PeriodicCell::new(l).unwrap());
    Packing::new(pos, rad, cell).unwrap()
}

fn assert_bit_identical(a: &Packing, b: &Packing) {
    assert_eq!(a.len(), b.len());
    for (x, y) in a.positions.iter().zip(&b.positions) {
        assert_eq!(x.map(f64::to_bits), y.map(f64::to_bits));
    }
    for (x, y) in a.radii.iter().zip(&b.radii) {
        assert_eq!(x.to_bits(), y.to_bits());
    }
    assert_eq!(
        a.cell.map(|c| c.lengths.map(f64::to_bits)),
        b.cell.map(|c| c.lengths.map(f64::to_bits))
    );
}

#[test]
fn round_trips_are_bit_exact() {
    let dir = tempfile::tempdir().unwrap();
    for periodic in [true, false] {
        let p = random_packing(periodic);
        let f = dir.path().join("p.txt");
        write_packing(&f, &p).unwrap();
        assert_bit_identical(&p, &read_packing(&f).unwrap());
        let f = dir.path().join("p.spherepack");
        write_yade_spherepack(&f, &p).unwrap();
        assert_bit_identical(&p, &read_packing(&f).unwrap());
        let f = dir.path().join("p.data");
        write_liggghts_data(&f, &p, 2650.0).unwrap();
        let text = std::fs::read_to_string(&f).unwrap();
        let q = parse_liggghts_data(&text, "p.data", periodic).unwrap();
        assert_bit_identical(&p, &q);
    }
    // Extreme magnitudes survive too (a subnormal coordinate; radii near the ends of the
    // range whose sphere volume 4/3·π·r³ is still a finite number > 0).
    let p = Packing::new(
        vec![
            Vec3::new(1e-300, 12345678.9, 0.1),
            Vec3::new(-0.0, 1e22, 5e-310),
        ],
        vec![1.5e-100, 3e100],
        None,
    )
    .unwrap();
    let f = dir.path().join("x.txt");
    write_packing(&f, &p).unwrap();
    assert_bit_identical(&p, &read_packing(&f).unwrap());
    // Bad density refused, nothing written.
    let f = dir.path().join("bad.data");
    assert!(write_liggghts_data(&f, &p, -1.0).is_err());
    assert!(!f.exists());
}

#[test]
fn missing_file_is_an_io_error_naming_it() {
    let err = read_packing(std::path::Path::new("/nonexistent/p.txt")).unwrap_err();
    assert!(matches!(err, Error::Io { .. }));
    assert!(err.to_string().contains("/nonexistent/p.txt"));
}

/// The error text of a refused packing (`path:line: message`, or `path: message`).
fn refused(text: &str) -> String {
    parse_packing(text, "in.txt").unwrap_err().to_string()
}

#[test]
fn byte_order_mark_is_ignored() {
    let p = parse_packing("\u{feff}#format x_y_z_r\n0 0 0 1\n", "in.txt").unwrap();
    assert_eq!(p.len(), 1);
    let p = parse_packing("\u{feff}0 0 0 1\n3 0 0 1\n", "in.txt").unwrap();
    assert_eq!(p.len(), 2);
    let text = "\u{feff}##PERIODIC:: 4 4 4\n1 1 1 0.5\n";
    assert_eq!(detect_format(text), PackingFormat::YadeSpherePack);
    assert_eq!(
        parse_packing(text, "in.txt").unwrap().cell.unwrap().lengths,
        Vec3::repeat(4.0)
    );
    let p = parse_packing(&format!("\u{feff}{LIGGGHTS}"), "in.data").unwrap();
    assert_eq!(p.len(), 3);
}

#[test]
fn cr_only_and_crlf_line_endings_are_lines() {
    for eol in ["\r", "\r\n"] {
        let text = [
            "#format x_y_z_r",
            "# periodic 10 10 10",
            "1 1 1 0.5",
            "2 2 2 0.5",
            "",
        ]
        .join(eol);
        let p = parse_packing(&text, "in.txt").unwrap();
        assert_eq!(p.len(), 2, "{eol:?}");
        assert_eq!(p.cell.unwrap().lengths, Vec3::repeat(10.0));
        // Lines are counted as an editor shows them.
        let (line, msg) = parse_err(&["# c", "1 1 1 0.5", "1 2 3"].join(eol));
        assert_eq!(line, 3, "{eol:?}: {msg}");
        let data = LIGGGHTS.replace('\n', eol);
        assert_eq!(detect_format(&data), PackingFormat::LiggghtsData);
        assert_eq!(parse_packing(&data, "in.data").unwrap().len(), 3);
        let bad = LIGGGHTS.replace("3 1 0.5", "3 1 -0.5").replace('\n', eol);
        let err = parse_packing(&bad, "in.data").unwrap_err().to_string();
        assert!(err.contains("in.data:12: diameter must be > 0"), "{err}");
    }
    // Mixed endings.
    let p = parse_packing("0 0 0 1\r3 0 0 1\r\n6 0 0 1\n", "in.txt").unwrap();
    assert_eq!(p.len(), 3);
}

#[test]
fn files_without_particles_are_refused_by_name() {
    for text in [
        "",
        "\n\n",
        "   \r\n",
        "# only a comment\n",
        "#format x_y_z_r\n# periodic 5 5 5\n",
        "\u{feff}",
        "##PERIODIC:: 4 4 4\n",
    ] {
        let e = refused(text);
        assert!(
            e.starts_with("in.txt: no particles: expected lines `x y z r`"),
            "{text:?}: {e}"
        );
    }
    let zero = "LIGGGHTS data\n\n0 atoms\n1 atom types\n\n0 1 xlo xhi\n0 1 ylo yhi\n0 1 zlo zhi\n";
    for text in [zero.to_string(), format!("{zero}\nAtoms # granular\n\n")] {
        let e = parse_packing(&text, "in.data").unwrap_err().to_string();
        assert!(
            e.starts_with("in.data: no particles: line 3 declares `0 atoms`")
                && e.contains("id type diameter density x y z"),
            "{e}"
        );
    }
}

#[test]
fn liggghts_image_flags_and_density_are_checked() {
    let ok = LIGGGHTS.replace("0.5 1.5 2.0\n", "0.5 1.5 2.0 0 -1 2\n");
    assert_eq!(parse_packing(&ok, "in.data").unwrap().len(), 3);
    for (flags, column, name) in [
        ("0.5 0 0", 8, "ix"),
        ("0 x 0", 9, "iy"),
        ("0 0 1e3", 10, "iz"),
    ] {
        let text = LIGGGHTS.replace("0.5 1.5 2.0\n", &format!("0.5 1.5 2.0 {flags}\n"));
        let e = parse_packing(&text, "in.data").unwrap_err().to_string();
        assert!(
            e.contains(&format!(
                "in.data:12: image flag {name} (column {column}) must be an integer"
            )),
            "{e}"
        );
    }
    for density in ["-2500", "0"] {
        let text = LIGGGHTS.replace("3 1 0.5 2500", &format!("3 1 0.5 {density}"));
        let e = parse_packing(&text, "in.data").unwrap_err().to_string();
        assert!(
            e.contains("in.data:12: density (column 4) must be > 0"),
            "{e}"
        );
    }
    let text = LIGGGHTS.replace("3 1 0.5 2500", "3 1 0.5 nan");
    let e = parse_packing(&text, "in.data").unwrap_err().to_string();
    assert!(e.contains("in.data:12: density is NaN"), "{e}");
}

#[test]
fn cell_volume_overflow_is_refused_at_the_header() {
    let (line, msg) = parse_err("# periodic 1e300 1e300 1e300\n1 1 1 0.5\n");
    assert_eq!(line, 1);
    assert!(
        msg.contains("cell volume") && msg.contains("overflows"),
        "{msg}"
    );
    let (line, msg) = parse_err("0 0 0 1\n##PERIODIC:: 1e-200 1e-200 1e-200\n");
    assert_eq!(line, 2);
    assert!(
        msg.contains("cell volume") && msg.contains("underflows to 0"),
        "{msg}"
    );
    // LIGGGHTS box: each length finite but the volume not, or a length that overflows.
    let text = LIGGGHTS
        .replace("-1.0 1.0 xlo", "-1e300 1e300 xlo")
        .replace("-2 2 ylo", "-1e300 1e300 ylo")
        .replace("0 3 zlo", "0 1e300 zlo");
    let e = parse_packing(&text, "in.data").unwrap_err().to_string();
    assert!(e.contains("in.data:6: the cell volume"), "{e}");
    let text = LIGGGHTS.replace("-2 2 ylo", "-1e308 1e308 ylo");
    let e = parse_packing(&text, "in.data").unwrap_err().to_string();
    assert!(e.contains("in.data:7: box length yhi − ylo"), "{e}");
}

#[test]
fn radii_whose_volumes_are_not_finite_are_refused_at_their_line() {
    let (line, msg) = parse_err("0 0 0 1\n5 5 5 1e200\n");
    assert_eq!(line, 2);
    assert!(
        msg.contains("sphere volume") && msg.contains("overflows"),
        "{msg}"
    );
    let (line, msg) = parse_err("0 0 0 1\n5 5 5 1e-200\n");
    assert_eq!(line, 2);
    assert!(
        msg.contains("sphere volume") && msg.contains("underflows"),
        "{msg}"
    );
    // Each volume finite, their sum not.
    let (line, msg) = parse_err("0 0 0 3e102\n1e103 0 0 3e102\n");
    assert_eq!(line, 2);
    assert!(msg.contains("total sphere volume"), "{msg}");
    let text = LIGGGHTS.replace("3 1 0.5 2500", "3 1 1e300 2500");
    let e = parse_packing(&text, "in.data").unwrap_err().to_string();
    assert!(e.contains("in.data:12: the sphere volume"), "{e}");
    // Solid fraction: a huge sphere in a tiny cell, or tiny spheres in a huge free box.
    let (line, msg) = parse_err("# periodic 1e-100 1e-100 1e-100\n0 0 0 1e90\n");
    assert_eq!(line, 1);
    assert!(
        msg.contains("solid fraction") && msg.contains("overflows"),
        "{msg}"
    );
    let e = refused("0 0 0 1e-100\n1e100 1e100 1e100 1e-100\n");
    assert!(
        e.starts_with("in.txt: the solid fraction") && e.contains("underflows"),
        "{e}"
    );
}

#[test]
fn positions_must_give_a_finite_box() {
    let (line, msg) = parse_err("-1e308 0 0 1\n1e308 0 0 1\n");
    assert_eq!(line, 1);
    assert!(msg.contains("lines 1 and 2 are its x ends"), "{msg}");
    let (line, msg) = parse_err("# periodic 1 1 1\n0.5 0.5 0.5 0.1\n1e300 0 0 0.1\n");
    assert_eq!(line, 3);
    assert!(msg.contains("cell lengths"), "{msg}");
}

#[test]
fn cell_stated_chosen_or_assumed() {
    use anisobond::packing::{parse_packing_as, CellChoice, CellOrigin};
    let read = |text: &str, c: CellChoice| parse_packing_as(text, "in.txt", c);
    // Stated: a cell header, `# free`, or SpherePack.save's clumpId column.
    let r = read("# periodic 4 4 4\n1 1 1 0.5\n", CellChoice::AsStated).unwrap();
    assert_eq!(r.origin, CellOrigin::Stated);
    let r = read("# free\n1 1 1 0.5\n", CellChoice::Free).unwrap();
    assert_eq!((r.origin, r.packing.cell), (CellOrigin::Stated, None));
    let r = read("1 1 1 0.5 -1\n", CellChoice::AsStated).unwrap();
    assert_eq!(r.origin, CellOrigin::Stated);
    // Not stated: assumed free, or as the caller chooses; a given cell wraps the positions.
    let r = read("#format x_y_z_r\n5 1 1 0.5\n", CellChoice::AsStated).unwrap();
    assert_eq!((r.origin, r.packing.cell), (CellOrigin::Assumed, None));
    let r = read(
        "#format x_y_z_r\n5 1 1 0.5\n",
        CellChoice::Cell(Vec3::repeat(4.0)),
    )
    .unwrap();
    assert_eq!(r.origin, CellOrigin::Chosen);
    assert_eq!(r.packing.positions[0], Vec3::new(1.0, 1.0, 1.0));
    let e = read("1 1 1 0.5\n", CellChoice::Periodic)
        .unwrap_err()
        .to_string();
    assert!(e.contains("expected --cell Lx,Ly,Lz"), "{e}");
    // A choice that contradicts the file is refused.
    let e = read("# periodic 4 4 4\n1 1 1 0.5\n", CellChoice::Free)
        .unwrap_err()
        .to_string();
    assert!(e.contains("the file states a periodic cell 4 4 4"), "{e}");
    let e = read(
        "# periodic 4 4 4\n1 1 1 0.5\n",
        CellChoice::Cell(Vec3::repeat(5.0)),
    )
    .unwrap_err()
    .to_string();
    assert!(e.contains("in.txt"), "{e}");
    let (line, msg) = parse_err("# free\n# periodic 4 4 4\n1 1 1 0.5\n");
    assert_eq!(line, 2);
    assert!(msg.contains("`# free` (line 1)"), "{msg}");
    // LIGGGHTS data never states its boundary: periodic assumed, or free / periodic chosen.
    let r = read(LIGGGHTS, CellChoice::AsStated).unwrap();
    assert_eq!(r.origin, CellOrigin::Assumed);
    assert!(r.packing.cell.is_some());
    let r = read(LIGGGHTS, CellChoice::Free).unwrap();
    assert_eq!((r.origin, r.packing.cell), (CellOrigin::Chosen, None));
    assert!(read(LIGGGHTS, CellChoice::Cell(Vec3::repeat(5.0))).is_err());
    // anisobond writes `# free` for a free packing: read back as stated.
    let p = parse_packing("0 0 0 1\n3 0 0 1\n", "x").unwrap();
    let r = read(
        &anisobond::packing::format_packing(&p),
        CellChoice::AsStated,
    )
    .unwrap();
    assert_eq!(r.origin, CellOrigin::Stated);
}
