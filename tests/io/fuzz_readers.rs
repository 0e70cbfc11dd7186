//! Fuzzing every reader (issue 17): SPEC text, YADE SpherePack text, LIGGGHTS data, model
//! TOML and JSON, and `--target` strings get random mutations of valid documents (lines
//! dropped, duplicated or swapped; numbers replaced by extremes such as 1e308, -0, NaN,
//! inf, huge integers; BOM, CR and garbage inserted; truncation) and arbitrary text.
//! No reader may panic, and whatever one accepts holds only finite numbers; an accepted
//! packing bonded with a valid model, and a valid packing bonded with an accepted model,
//! give through the library's entry point (`Assembly::tensor`) a finite, positive definite
//! tensor or an error with a message: never a non-finite number.
//!
//! Deterministic (fixed seed, no failure files) and bounded: see `CASES`.

use anisobond::calibrate::Target;
use anisobond::model::SchemeSpec;
use anisobond::packing::{parse_liggghts_data, parse_packing};
use anisobond::prelude::*;
use proptest::prelude::*;
use proptest::test_runner::{Config, RngAlgorithm, TestRng, TestRunner};
use std::sync::atomic::{AtomicUsize, Ordering::Relaxed};

/// Accepted packings and Voigt tensors computed from them (printed, to show the checks ran).
static ACCEPTED_PACKINGS: AtomicUsize = AtomicUsize::new(0);
static TENSORS: AtomicUsize = AtomicUsize::new(0);
static ACCEPTED_MODELS: AtomicUsize = AtomicUsize::new(0);
static ACCEPTED_TARGETS: AtomicUsize = AtomicUsize::new(0);

/// Cases per reader and input family (mutations, arbitrary text).
const CASES: u32 = 4000;

/// A 4×4×4 simple cubic lattice (spacing 1, radius 0.5) as `x y z r` lines.
fn lattice_lines() -> Vec<String> {
    let mut lines = Vec::new();
    for i in 0..4 {
        for j in 0..4 {
            for k in 0..4 {
                lines.push(format!("{}.5 {}.5 {}.5 0.5", i, j, k));
            }
        }
    }
    lines
}

fn spec_text() -> String {
    let mut s = String::from("#format x_y_z_r\n# periodic 4 4 4\n");
    for l in lattice_lines() {
        s.push_str(&l);
        s.push('\n');
    }
    s
}

fn yade_text() -> String {
    let mut s = String::from("##PERIODIC:: 4 4 4\n");
    for l in lattice_lines() {
        s.push_str(&l);
        s.push('\n');
    }
    s
}

fn liggghts_text() -> String {
    let mut s = String::from(
        "LIGGGHTS data file\n\n64 atoms\n1 atom types\n\n0 4 xlo xhi\n0 4 ylo yhi\n0 4 zlo zhi\n\nAtoms # granular\n\n",
    );
    for (id, l) in lattice_lines().iter().enumerate() {
        let w: Vec<&str> = l.split(' ').collect();
        let flags = if id % 3 == 0 { " 0 -1 2" } else { "" };
        s.push_str(&format!(
            "{} 1 1.0 2500 {} {} {}{flags}\n",
            id + 1,
            w[0],
            w[1],
            w[2]
        ));
    }
    s
}

const TOML_MODELS: [&str; 3] = [
    "[bonding]\nrule = \"gap\"\nvalue = 0.17\n[scheme]\nkind = \"cubic\"\nmodel = \"zener-above-1\"\nextended = false\na_n = 4.31\na_s = 10.0\nnormal = 1.0e13\nshear = 3.55e12\nrotation = [[1,0,0],[0,1,0],[0,0,1]]\n[geometry]\nconvention = \"area\"\nbond_radius = \"min\"\npi_hat = 3.14\n",
    "[bonding]\nrule = \"factor\"\nvalue = 1.1\n[scheme]\nkind = \"isotropic\"\nnormal = 1.0e12\nshear = 4.0e11\n[geometry]\nconvention = \"kumar\"\nmoments = \"parallel-bond\"\n",
    "[bonding]\nrule = \"factor\"\nvalue = 1.1\n[scheme]\nkind = \"cross-anisotropic\"\nC11 = 130e6\nC33 = 55e6\nC13 = 28e6\nC12 = 40e6\nstrike_deg = 30.0\ndip_deg = 45.0\npi_hat = 1.5\n",
];

const JSON_MODELS: [&str; 3] = [
    "{\"bonding\": {\"rule\": \"gap\", \"value\": 0.17},\n\"scheme\": {\"kind\": \"cubic\",\n\"model\": \"zener-below-1\",\n\"a_n\": 0.8,\n\"a_s\": 1.2,\n\"normal\": 1e13,\n\"shear\": 3e12,\n\"euler_zyz_deg\": [60, 30, 45]},\n\"geometry\": {\"convention\": \"modulus\"}}\n",
    "{\"scheme\": {\"kind\": \"isotropic\",\n\"normal\": 1e12,\n\"shear\": 4e11}}\n",
    "{\"bonding\": {\"rule\": \"coordination\", \"value\": 6.0},\n\"scheme\": {\"kind\": \"cross-anisotropic\",\n\"C11\": 130e6,\n\"C33\": 55e6,\n\"C13\": 28e6,\n\"C12\": 40e6,\n\"axis\": [0, 0.6, 0.8]}}\n",
];

const TARGETS: [&str; 4] = [
    "C11=246.5GPa,C12=147.3GPa,C44=124.7GPa",
    "C12/C11=0.3,C44/C11=0.43",
    "C11=130e6 C33=55e6 C13=28e6 C12=40e6",
    "C11 = 80 GPa; C12 = 30 GPa; C44 = 40 GPa",
];

/// Values a number may be replaced by.
const EXTREMES: &[&str] = &[
    "1e308",
    "-1e308",
    "1.7976931348623157e308",
    "1e309",
    "1e-320",
    "5e-324",
    "-0",
    "0",
    "-0.0",
    "NaN",
    "nan",
    "inf",
    "-inf",
    "infinity",
    "1e300",
    "3e102",
    "1e-300",
    "-1",
    "99999999999999999999999",
    "18446744073709551616",
    "4294967296",
    "2147483648",
    "-2147483649",
    "0x10",
    "1_000",
    "",
    "1e",
    ".",
    "2024-01-01",
    "\"1\"",
    "true",
    "[1, 2, 3]",
];

/// Text that may be inserted.
const GARBAGE: &[&str] = &[
    "\u{feff}",
    "\r",
    "\r\n",
    "\n",
    "\0",
    "#",
    "=",
    "\"",
    "[",
    "]",
    "{",
    "}",
    ",",
    " ",
    "\t",
    "é",
    "∞",
    "Atoms",
    " atoms",
    "##PERIODIC:: 1 1 1",
    "# periodic 1e300 1e300 1e300",
    "[scheme]",
    "kind = \"isotropic\"",
    "GPa",
    "C11=",
];

/// One edit of a document: `(operation, a, b, pick)`, indices taken modulo the sizes.
type Edit = (u8, usize, usize, usize);

/// Apply `edits` to `doc`; all index arithmetic is modulo, so every edit applies.
fn mutate(doc: &str, edits: &[Edit]) -> String {
    let mut text = doc.to_string();
    for &(op, a, b, pick) in edits {
        let mut lines: Vec<String> = text.split('\n').map(str::to_string).collect();
        let n = lines.len().max(1);
        match op % 9 {
            0 => {
                if !lines.is_empty() {
                    lines.remove(a % n);
                }
                text = lines.join("\n");
            }
            1 => {
                let l = lines[a % n].clone();
                lines.insert(b % n, l);
                text = lines.join("\n");
            }
            2 => {
                lines.swap(a % n, b % n);
                text = lines.join("\n");
            }
            3..=5 => {
                // Replace the pick-th number-like word of line a by an extreme value.
                let line = &lines[a % n];
                let spans = number_spans(line);
                if !spans.is_empty() {
                    let (s, e) = spans[b % spans.len()];
                    let mut l = line.clone();
                    l.replace_range(s..e, EXTREMES[pick % EXTREMES.len()]);
                    lines[a % n] = l;
                }
                text = lines.join("\n");
            }
            6 => {
                let pos = floor_char_boundary(&text, a % (text.len() + 1));
                text.insert_str(pos, GARBAGE[pick % GARBAGE.len()]);
            }
            7 => {
                let pos = floor_char_boundary(&text, a % (text.len() + 1));
                text.truncate(pos);
            }
            _ => {
                text = match pick % 3 {
                    0 => text.replace('\n', "\r"),
                    1 => text.replace('\n', "\r\n"),
                    _ => format!("\u{feff}{text}"),
                };
            }
        }
    }
    text
}

/// Byte spans of the numbers in `line` (a digit, sign or dot run with exponents).
fn number_spans(line: &str) -> Vec<(usize, usize)> {
    let b = line.as_bytes();
    let mut spans = Vec::new();
    let mut k = 0;
    while k < b.len() {
        let starts_number = b[k].is_ascii_digit()
            || ((b[k] == b'-' || b[k] == b'.') && b.get(k + 1).is_some_and(|c| c.is_ascii_digit()));
        let preceded_by_word = k > 0 && (b[k - 1].is_ascii_alphabetic() || b[k - 1] == b'_');
        if starts_number && !preceded_by_word {
            let s = k;
            k += 1;
            while k < b.len()
                && (b[k].is_ascii_digit()
                    || b[k] == b'.'
                    || b[k] == b'e'
                    || b[k] == b'E'
                    || ((b[k] == b'-' || b[k] == b'+') && (b[k - 1] == b'e' || b[k - 1] == b'E')))
            {
                k += 1;
            }
            spans.push((s, k));
        } else {
            k += 1;
        }
    }
    spans
}

fn floor_char_boundary(s: &str, mut pos: usize) -> usize {
    while !s.is_char_boundary(pos) {
        pos -= 1;
    }
    pos
}

fn edits() -> impl Strategy<Value = Vec<Edit>> {
    prop::collection::vec(
        (any::<u8>(), any::<usize>(), any::<usize>(), any::<usize>()),
        1..5,
    )
}

/// Arbitrary text: random characters, or random words from the formats' vocabulary.
fn arbitrary_text() -> impl Strategy<Value = String> {
    let words: Vec<&'static str> = EXTREMES
        .iter()
        .chain(GARBAGE.iter())
        .chain(
            [
                "1",
                "0.5",
                "4",
                "x",
                "y",
                "z",
                "xlo",
                "xhi",
                "ylo yhi",
                "zlo zhi",
                "1 atom types",
                "#format",
                "x_y_z_r",
                "x_y_z_r_matId",
                "kind",
                "cubic",
                "normal",
                "shear",
                "a_n",
                "C11",
                "C33",
                "C13",
                "C12",
                "C44",
                "C12/C11",
                "C44/C11",
                "{",
                "}",
                ":",
                "\"scheme\"",
                "\"kind\"",
                "[bonding]",
                "rule",
                "value",
                "gap",
                "MPa",
                "Pa",
                ";",
                "\n",
            ]
            .iter(),
        )
        .copied()
        .collect();
    prop_oneof![
        prop::collection::vec(any::<char>(), 0..300).prop_map(|c| c.into_iter().collect()),
        prop::collection::vec(prop::sample::select(words), 0..80).prop_map(|w| w.join(" ")),
    ]
}

fn runner() -> TestRunner {
    let config = Config {
        cases: CASES,
        failure_persistence: None,
        rng_algorithm: RngAlgorithm::ChaCha,
        ..Config::default()
    };
    TestRunner::new_with_rng(
        config,
        TestRng::from_seed(RngAlgorithm::ChaCha, &[17u8; 32]),
    )
}

/// An accepted packing holds only finite, positive quantities; bonded with the valid model
/// `model` its Voigt tensor is finite (or an error is returned).
fn check_packing(p: &Packing, model: &Model) -> Result<(), TestCaseError> {
    prop_assert!(!p.is_empty());
    ACCEPTED_PACKINGS.fetch_add(1, Relaxed);
    for (x, r) in p.positions.iter().zip(&p.radii) {
        prop_assert!(x.iter().all(|c| c.is_finite()), "position {x:?}");
        prop_assert!(r.is_finite() && *r > 0.0, "radius {r}");
    }
    if let Some(c) = &p.cell {
        prop_assert!(c.lengths.iter().all(|l| l.is_finite() && *l > 0.0));
        prop_assert!(c.volume().is_finite() && c.volume() > 0.0);
    }
    let v = p.volume();
    let phi = p.solid_fraction();
    prop_assert!(v.is_finite() && v > 0.0, "volume {v}");
    prop_assert!(phi.is_finite() && phi > 0.0, "solid fraction {phi}");
    if p.len() > 400 {
        return Ok(());
    }
    check_tensors(p.clone(), model.clone())
}

/// Bond `p` with `model` and ask for the Voigt and relaxed tensors through the library's
/// entry point: each is a finite report or an error that says something.
fn check_tensors(p: Packing, model: Model) -> Result<(), TestCaseError> {
    let asm = match Assembly::new(p, model) {
        Ok(a) => a,
        Err(e) => {
            prop_assert!(!e.to_string().trim().is_empty());
            return Ok(());
        }
    };
    for method in [Method::Voigt, Method::relaxed()] {
        match asm.tensor(&method) {
            Ok(t) => {
                TENSORS.fetch_add(1, Relaxed);
                let c = t.report.tensor();
                prop_assert!(
                    c.iter().all(|x| x.is_finite()),
                    "{} tensor {c}",
                    method.name()
                );
                prop_assert!(!t.report.to_json().contains("null"), "null in the report");
            }
            Err(e) => prop_assert!(!e.to_string().trim().is_empty()),
        }
    }
    Ok(())
}

/// An accepted model holds only finite parameters, is written back identically, and bonded
/// to a valid lattice gives finite tensors or a refusal.
fn check_model(m: &Model) -> Result<(), TestCaseError> {
    ACCEPTED_MODELS.fetch_add(1, Relaxed);
    let numbers: Vec<f64> = match &m.scheme {
        SchemeSpec::Cubic(c) => [c.a_n, c.a_s, c.normal, c.shear]
            .into_iter()
            .chain(c.rotation.iter().copied())
            .collect(),
        SchemeSpec::CrossAnisotropic(t) => [t.c11, t.c33, t.c13, t.c12]
            .into_iter()
            .chain(t.axis.iter().copied())
            .collect(),
        SchemeSpec::Isotropic { normal, shear } => vec![*normal, *shear],
    };
    prop_assert!(numbers.iter().all(|x| x.is_finite()), "{m:?}");
    let value = match m.bonding {
        anisobond::bonds::BondingRule::Gap(v)
        | anisobond::bonds::BondingRule::Factor(v)
        | anisobond::bonds::BondingRule::Coordination(v) => v,
    };
    prop_assert!(value.is_finite() && value > 0.0);
    prop_assert!(m.geometry.pi_hat.is_finite() && m.geometry.pi_hat > 0.0);
    let again = Model::from_toml_str(&m.to_toml_string(), "written.toml").ok();
    prop_assert_eq!(again.as_ref(), Some(m));
    let lattice = parse_packing(&spec_text(), "lattice").unwrap();
    check_tensors(lattice, m.clone())
}

fn check_target(t: &Target) -> Result<(), TestCaseError> {
    ACCEPTED_TARGETS.fetch_add(1, Relaxed);
    match *t {
        Target::Cubic(c) => {
            prop_assert!(c.c12_over_c11.is_finite() && c.c44_over_c11.is_finite());
            prop_assert!(c.c44_over_c11 > 0.0 && c.c12_over_c11 > -0.5 && c.c12_over_c11 < 1.0);
            if let Some(c11) = c.c11 {
                prop_assert!(c11.is_finite() && c11 > 0.0);
                let (a, b, d) = c.constants(0.0);
                prop_assert!(a.is_finite() && b.is_finite() && d.is_finite());
            }
        }
        Target::CrossAnisotropic {
            c11,
            c33,
            c13,
            c12,
            c44,
        } => {
            prop_assert!([c11, c33, c13, c12].iter().all(|x| x.is_finite()));
            prop_assert!(c44.is_none_or(|v| v.is_finite() && v > 0.0));
            prop_assert!(c11 > c12.abs() && c33 > 0.0 && (c11 + c12) * c33 > 2.0 * c13 * c13);
        }
    }
    Ok(())
}

/// Run `check` on mutations of each seed document and on arbitrary text.
fn fuzz(seeds: &[String], check: impl Fn(&str) -> Result<(), TestCaseError>) {
    let mut r = runner();
    let seeds = seeds.to_vec();
    r.run(&(prop::sample::select(seeds), edits()), |(doc, e)| {
        check(&mutate(&doc, &e))
    })
    .unwrap();
    let mut r = runner();
    r.run(&arbitrary_text(), |text| check(&text)).unwrap();
}

#[test]
fn packing_readers() {
    let model = Model::truszkowska_mrv();
    let seeds = [spec_text(), yade_text(), liggghts_text()];
    for s in &seeds {
        check_packing(&parse_packing(s, "seed").unwrap(), &model).unwrap();
    }
    fuzz(&seeds, |text| {
        if let Ok(p) = parse_packing(text, "fuzz.txt") {
            check_packing(&p, &model)?;
        }
        for periodic in [true, false] {
            if let Ok(p) = parse_liggghts_data(text, "fuzz.data", periodic) {
                check_packing(&p, &model)?;
            }
        }
        Ok(())
    });
    eprintln!(
        "packing readers: {} texts (each read as SPEC/YADE and as LIGGGHTS data), {} accepted \
         packings, {} tensors (Voigt and relaxed, counted over the packing and model tests)",
        2 * CASES,
        ACCEPTED_PACKINGS.load(Relaxed),
        TENSORS.load(Relaxed)
    );
}

#[test]
fn model_readers() {
    let toml: Vec<String> = TOML_MODELS.iter().map(|s| s.to_string()).collect();
    let json: Vec<String> = JSON_MODELS.iter().map(|s| s.to_string()).collect();
    for s in &toml {
        check_model(&Model::from_toml_str(s, "seed.toml").unwrap()).unwrap();
    }
    for s in &json {
        check_model(&Model::from_json_str(s, "seed.json").unwrap()).unwrap();
    }
    // A model with finite but huge magnitudes (normal = 1e300) is accepted by the reader;
    // its tensors overflow and are refused by `Assembly::tensor` (checked in check_model).
    let check = |m: Model| check_model(&m);
    fuzz(&toml, |text| {
        match Model::from_toml_str(text, "fuzz.toml") {
            Ok(m) => check(m),
            Err(e) => {
                prop_assert!(
                    !e.to_string().trim_end().ends_with(':'),
                    "empty message: {e}"
                );
                Ok(())
            }
        }
    });
    fuzz(&json, |text| {
        match Model::from_json_str(text, "fuzz.json") {
            Ok(m) => check(m),
            Err(e) => {
                prop_assert!(
                    !e.to_string().trim_end().ends_with(':'),
                    "empty message: {e}"
                );
                Ok(())
            }
        }
    });
    eprintln!(
        "model readers: {} texts, {} accepted models",
        4 * CASES,
        ACCEPTED_MODELS.load(Relaxed)
    );
}

#[test]
fn target_parser() {
    let seeds: Vec<String> = TARGETS.iter().map(|s| s.to_string()).collect();
    for s in &seeds {
        check_target(&Target::parse(s).unwrap()).unwrap();
    }
    fuzz(&seeds, |text| {
        if let Ok(t) = Target::parse(text) {
            check_target(&t)?;
        }
        Ok(())
    });
    eprintln!(
        "target parser: {} texts, {} accepted targets",
        2 * CASES,
        ACCEPTED_TARGETS.load(Relaxed)
    );
}
