//! The all-or-nothing output set (`anisobond::io::OutputSet`): staged files and folders
//! appear only on commit, never over an input, and vanish when the set is dropped.

use crate::common::{entries, tmp};
use anisobond::io::OutputSet;

#[test]
fn nothing_appears_before_commit_and_nothing_stays_after_a_drop() {
    let t = tmp();
    let d = t.path();
    {
        let mut set = OutputSet::new(&[]);
        let f = set.file(&d.join("a.csv")).unwrap();
        anisobond::io::write_string_atomic(&f, "1,2\n").unwrap();
        let dir = set.dir(&d.join("out")).unwrap();
        anisobond::io::write_string_atomic(&dir.join("x.txt"), "x").unwrap();
        assert!(!d.join("a.csv").exists() && !d.join("out").exists());
        // dropped here: an error on the way
    }
    assert_eq!(entries(d), Vec::<String>::new(), "staging left behind");
}

#[test]
fn commit_places_files_and_merges_folders() {
    let t = tmp();
    let d = t.path();
    std::fs::create_dir(d.join("out")).unwrap();
    std::fs::write(d.join("out").join("old.txt"), "old").unwrap();
    std::fs::write(d.join("out").join("x.txt"), "previous").unwrap();
    let mut set = OutputSet::new(&[]);
    let f = set.file(&d.join("a.csv")).unwrap();
    assert_eq!(
        f.extension().unwrap(),
        "csv",
        "staged names keep the extension"
    );
    anisobond::io::write_string_atomic(&f, "1,2\n").unwrap();
    let dir = set.dir(&d.join("out")).unwrap();
    std::fs::create_dir(dir.join("sub")).unwrap();
    anisobond::io::write_string_atomic(&dir.join("x.txt"), "new").unwrap();
    anisobond::io::write_string_atomic(&dir.join("sub").join("y.txt"), "y").unwrap();
    set.commit().unwrap();
    assert_eq!(entries(d), ["a.csv", "out"]);
    assert_eq!(entries(&d.join("out")), ["old.txt", "sub", "x.txt"]);
    assert_eq!(std::fs::read_to_string(d.join("out/x.txt")).unwrap(), "new");
    assert_eq!(
        std::fs::read_to_string(d.join("out/old.txt")).unwrap(),
        "old"
    );
    assert_eq!(
        std::fs::read_to_string(d.join("out/sub/y.txt")).unwrap(),
        "y"
    );
    assert_eq!(std::fs::read_to_string(d.join("a.csv")).unwrap(), "1,2\n");
}

#[test]
fn inputs_are_never_targets_even_inside_an_output_folder() {
    let t = tmp();
    let d = t.path();
    let input = d.join("packing.txt");
    std::fs::write(&input, "data").unwrap();
    let mut set = OutputSet::new(&[&input]);
    assert!(set.file(&input).is_err());
    assert!(set.file(&d.join(".").join("packing.txt")).is_err());
    // A folder output whose staged content would land on the input: refused at commit,
    // before anything moves.
    let mut set = OutputSet::new(&[&input]);
    let other = set.file(&d.join("other.txt")).unwrap();
    anisobond::io::write_string_atomic(&other, "o").unwrap();
    let dir = set.dir(d).unwrap();
    anisobond::io::write_string_atomic(&dir.join("packing.txt"), "overwritten").unwrap();
    let err = set.commit().unwrap_err().to_string();
    assert!(err.contains("also an input"), "{err}");
    assert_eq!(std::fs::read_to_string(&input).unwrap(), "data");
    assert_eq!(
        entries(d),
        ["packing.txt"],
        "nothing else moved, no staging left"
    );
}

#[test]
fn the_same_target_twice_and_kind_mismatches_are_refused() {
    let t = tmp();
    let d = t.path();
    std::fs::create_dir(d.join("folder")).unwrap();
    std::fs::write(d.join("file.txt"), "f").unwrap();
    let mut set = OutputSet::new(&[]);
    set.file(&d.join("a.json")).unwrap();
    assert!(set.file(&d.join("a.json")).is_err());
    assert!(set.file(&d.join("folder")).is_err());
    assert!(set.dir(&d.join("file.txt")).is_err());
    assert!(set.file(&d.join("missing").join("x.csv")).is_err());
}
