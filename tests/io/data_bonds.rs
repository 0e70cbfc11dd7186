//! LAMMPS data files of `atom_style bpm/sphere` with a `Bonds` section (issue 31): the
//! columns read by name of the style, the bonds mapped to the atoms by id, and every
//! inconsistency of the section refused naming its line. (A file LAMMPS wrote itself is
//! read in tests/lammps/user_data.rs.)

use anisobond::packing::{parse_data, parse_data_boundary, parse_packing_as, CellChoice};
use anisobond::Error;

/// Four atoms (ids 10, 17, 24, 31 listed out of order) on a line along x in a 4 m periodic
/// box, bonded as a ring: 10–17, 17–24 (type 2), 24–31 and 31–10 across the x faces.
const BPM: &str = "LAMMPS data file via write_data\n\n4 atoms\n1 atom types\n4 bonds\n\
2 bond types\n\n0 4 xlo xhi\n0 4 ylo yhi\n0 4 zlo zhi\n\nPair Coeffs # zero\n\n1\n\n\
Atoms # bpm/sphere\n\n24 0 1 1.0 2600 2.5 1 1 0 0 0\n10 0 1 1.0 2600 0.5 1 1 0 0 0\n\
17 3 1 1.0 2600 1.5 1 1 0 0 0\n31 0 1 1.0 2600 3.5 1 1 0 0 0\n\nVelocities\n\n\
10 0 0 0 0 0 0\n17 0 0 0 0 0 0\n24 0 0 0 0 0 0\n31 0 0 0 0 0 0\n\nBonds\n\n\
1 1 10 17\n2 2 24 17\n3 1 24 31\n4 1 31 10\n";

#[test]
fn bpm_sphere_columns_and_bonds_by_atom_id() {
    let (p, b) = parse_data(BPM, "ring.data", true).unwrap();
    assert_eq!(p.ids, Some(vec![10, 17, 24, 31]));
    assert_eq!(p.radii, vec![0.5; 4]);
    assert_eq!(p.positions[1].x, 1.5);
    let b = b.expect("the Bonds section");
    // Indices of the atoms sorted by id: 10 → 0, 17 → 1, 24 → 2, 31 → 3.
    assert_eq!(b.i, vec![0, 2, 2, 3]);
    assert_eq!(b.j, vec![1, 1, 3, 0]);
    assert_eq!(b.types, vec![1, 2, 1, 1]);
    assert_eq!(b.lines, vec![32, 33, 34, 35]);
    assert_eq!(b.distinct_types(), 2);
    // The same file through the format detection keeps its bonds.
    let r = parse_packing_as(BPM, "ring.data", CellChoice::AsStated).unwrap();
    assert_eq!(r.bonds.unwrap().len(), 4);
    // Periodic along x only: the bond 31–10 still crosses the x faces; along y, z nothing.
    let (q, _) = parse_data_boundary(BPM, "ring.data", [true, false, false]).unwrap();
    assert_eq!(q.cell.unwrap().periodic, [true, false, false]);
}

fn refused(text: &str, periodic: bool) -> String {
    match parse_data(text, "ring.data", periodic) {
        Err(e @ Error::Parse { .. }) => e.to_string(),
        other => panic!("expected a parse error, got {other:?}"),
    }
}

#[test]
fn inconsistent_bonds_sections_are_refused_with_their_line() {
    let cases = [
        (
            BPM.replace("4 bonds", "5 bonds"),
            "declares 5 bonds but the Bonds section has 4",
        ),
        (
            BPM.replace("2 24 17", "2 24 18"),
            "ring.data:33: bond 2 names atom 18, which is not in the Atoms section",
        ),
        (
            BPM.replace("2 24 17", "2 24 24"),
            "ring.data:33: bond 2 joins atom 24 to itself",
        ),
        (
            BPM.replace("3 1 24 31", "3 1 17 10"),
            "ring.data:34: atoms 17 and 10 are bonded twice (also line 32)",
        ),
        (
            BPM.replace("2 2 24 17", "2 3 24 17"),
            "ring.data:33: bond type 3 exceeds the 2 bond types",
        ),
        (
            BPM.replace("1 1 10 17", "1 1 10"),
            "ring.data:32: expected 4 values `id type atom1 atom2`",
        ),
        (
            BPM.replace("\nBonds\n", "\nAngles\n"),
            "declares 4 bonds but the file has no `Bonds` section",
        ),
        (
            BPM.replace("Atoms # bpm/sphere", "Atoms # full"),
            "found atom style `full`",
        ),
        (
            BPM.replace("17 3 1 1.0 2600 1.5 1 1 0 0 0", "17 1 1.0 2600 1.5 1 1"),
            "ring.data:20: expected 8 values `id molecule type diameter density x y z`",
        ),
    ];
    for (text, want) in cases {
        let e = refused(&text, true);
        assert!(e.contains(want), "expected `{want}` in: {e}");
    }
    // Read as a walled box, the bond 31–10 spans 3 m of the 4 m box: across its x faces.
    let e = refused(BPM, false);
    assert!(
        e.contains("ring.data:35: bond 4 between atoms 31 and 10 spans 3e0 m along x"),
        "{e}"
    );
    assert!(e.contains("crosses a periodic face"), "{e}");
}

/// A bond whose two atoms sit at the same place (refused by the bond set, not the parser) is
/// named by its own line of the Bonds section: the bond set gives the refused pair's index
/// as data, not in its message.
#[test]
fn bond_between_coincident_atoms_names_its_line() {
    let text = BPM.replace("17 3 1 1.0 2600 1.5 1 1", "17 3 1 1.0 2600 2.5 1 1");
    let (p, b) = parse_data(&text, "ring.data", true).unwrap();
    let model = anisobond::model::Model::truszkowska_mrv();
    let e = anisobond::assembly::Assembly::from_data_bonds(p, model, &b.unwrap(), "ring.data")
        .unwrap_err();
    assert!(matches!(e, Error::Parse { .. }), "{e:?}");
    // Bond 2 (24–17, line 33) is the first whose atoms coincide.
    assert!(e.to_string().starts_with("ring.data:33: bond 1"), "{e}");
}
