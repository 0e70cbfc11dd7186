//! Issue 29 part A, outputs and model files: a device or FIFO given as `-o` is written into,
//! never replaced; a set of outputs lands whole or leaves every earlier file as it was; Ctrl-C
//! and SIGTERM leave no staging behind; an I/O error names the user's path; a model is written
//! in the format its extension names; a model key holding three numbers or a 3×3 matrix takes
//! exactly that many; the top-level help lists what the parsers accept.

use crate::common::*;
use anisobond::model::Model;
use std::path::Path;
use std::process::Command;
use std::time::{Duration, Instant};

/// File type of `path` without following links.
fn file_type(path: &Path) -> std::fs::FileType {
    std::fs::symlink_metadata(path).unwrap().file_type()
}

/// `bonds -o FIFO`: the table is written into the FIFO (a reader gets all of it, byte for byte
/// what a regular `-o` writes) and the FIFO is still a FIFO.
#[test]
fn a_fifo_output_is_written_into_not_replaced() {
    use std::os::unix::fs::FileTypeExt;
    let t = tmp();
    let d = t.path();
    let p = packing(d, 150);
    let m = write(d, "model.toml", CUBIC_MODEL);
    let plain = d.join("plain.csv");
    succeeds(&mut cmd(
        "bonds {p} --model {m} -o {o}",
        &[("p", &p), ("m", &m), ("o", &plain)],
    ));
    let fifo = d.join("fifo.csv");
    let made = Command::new("mkfifo").arg(&fifo).status().unwrap();
    assert!(made.success(), "mkfifo failed");
    let reader = {
        let fifo = fifo.clone();
        std::thread::spawn(move || std::fs::read(&fifo).unwrap())
    };
    succeeds(&mut cmd(
        "bonds {p} --model {m} -o {o}",
        &[("p", &p), ("m", &m), ("o", &fifo)],
    ));
    let got = reader.join().unwrap();
    assert_eq!(
        got,
        std::fs::read(&plain).unwrap(),
        "the FIFO's reader got the whole table"
    );
    assert!(
        file_type(&fifo).is_fifo(),
        "the FIFO was replaced by a regular file"
    );
    holds_exactly(d, &["fifo.csv", "model.toml", "packing.txt", "plain.csv"]);
}

/// `bonds -o` a character device (a /dev/null made with mknod in the test's folder): it stays
/// a device, nothing else is written. Needs root (mknod); skipped with a reason otherwise.
#[test]
fn a_character_device_output_stays_a_device() {
    use std::os::unix::fs::FileTypeExt;
    let t = tmp();
    let d = t.path();
    let null = d.join("null");
    let made = Command::new("mknod")
        .arg(&null)
        .args(["c", "1", "3"])
        .output()
        .unwrap();
    if !made.status.success() {
        assert!(
            std::env::var_os("CI").is_none(),
            "mknod failed under CI (it runs as root): {}",
            stderr(&made)
        );
        println!("skipped: mknod needs root ({})", stderr(&made).trim());
        return;
    }
    let p = packing(d, 150);
    let m = write(d, "model.toml", CUBIC_MODEL);
    succeeds(&mut cmd(
        "bonds {p} --model {m} -o {o}",
        &[("p", &p), ("m", &m), ("o", &null)],
    ));
    assert!(file_type(&null).is_char_device(), "the device was replaced");
    holds_exactly(d, &["model.toml", "null", "packing.txt"]);
}

/// `run -o C.json --history h.csv` where h.csv cannot be replaced (immutable, chattr +i): the
/// command fails naming h.csv, and C.json — renamed into place before h.csv in the set — is
/// put back as it was. Needs root and chattr; skipped with a reason otherwise.
#[test]
fn a_set_whose_last_target_cannot_be_replaced_leaves_every_file_as_it_was() {
    let t = tmp();
    let d = t.path();
    let p = packing(d, 120);
    let m = write(d, "model.toml", CUBIC_MODEL);
    let c = write(d, "C.json", "earlier C\n");
    let h = write(d, "h.csv", "earlier history\n");
    let locked = Command::new("chattr")
        .arg("+i")
        .arg(&h)
        .output()
        .is_ok_and(|o| o.status.success());
    if !locked {
        assert!(
            std::env::var_os("CI").is_none(),
            "chattr +i failed under CI (root on ext4)"
        );
        println!("skipped: chattr +i not available here (needs root on a filesystem with it)");
        return;
    }
    let out = cmd(
        "run {p} --model {m} -o {c} --history {h}",
        &[("p", &p), ("m", &m), ("c", &c), ("h", &h)],
    )
    .output()
    .unwrap();
    let _ = Command::new("chattr").arg("-i").arg(&h).status();
    assert!(!out.status.success(), "succeeded over an immutable file");
    let err = stderr(&out);
    assert!(err.contains("h.csv"), "the error names h.csv: {err}");
    assert!(
        !err.contains(".anisobond"),
        "the error names a staging path: {err}"
    );
    assert_eq!(std::fs::read_to_string(&c).unwrap(), "earlier C\n");
    assert_eq!(std::fs::read_to_string(&h).unwrap(), "earlier history\n");
    holds_exactly(d, &["C.json", "h.csv", "model.toml", "packing.txt"]);
}

/// SIGINT (Ctrl-C) and SIGTERM (a scheduler's time limit) during a run: exit status 128 +
/// signal, and the folder holds exactly what it held (the staging files are removed).
#[test]
fn an_interrupted_command_leaves_no_staging_behind() {
    let t = tmp();
    let d = t.path();
    let p = packing(d, 3000);
    let m = write(d, "model.toml", CUBIC_MODEL);
    for (signal, number) in [("INT", 2), ("TERM", 15)] {
        let c = d.join("C.json");
        let h = d.join("h.csv");
        let mut child = cmd(
            "run {p} --model {m} --max-steps 100000 -o {c} --history {h}",
            &[("p", &p), ("m", &m), ("c", &c), ("h", &h)],
        )
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
        // Wait until the staging files exist, so the signal lands mid-run.
        let start = Instant::now();
        while !entries(d).iter().any(|e| e.starts_with(".anisobond")) {
            assert!(
                start.elapsed() < Duration::from_secs(60),
                "no staging file appeared"
            );
            assert!(
                child.try_wait().unwrap().is_none(),
                "the run ended before the signal"
            );
            std::thread::sleep(Duration::from_millis(20));
        }
        let sent = Command::new("kill")
            .arg(format!("-{signal}"))
            .arg(child.id().to_string())
            .status()
            .unwrap();
        assert!(sent.success());
        let out = child.wait_with_output().unwrap();
        assert_eq!(
            out.status.code(),
            Some(128 + number),
            "SIG{signal}: {}",
            stderr(&out)
        );
        holds_exactly(d, &["model.toml", "packing.txt"]);
    }
}

/// A write that fails (a file size limit, `ulimit -f 1`, with SIGXFSZ ignored so the write
/// returns EFBIG) is reported under the user's `-o` path, not the hidden staging name.
#[test]
fn an_io_error_names_the_users_path() {
    let t = tmp();
    let d = t.path();
    let p = packing(d, 300);
    let m = write(d, "model.toml", CUBIC_MODEL);
    let o = d.join("bonds.csv");
    let script = format!(
        "trap '' XFSZ; ulimit -f 1; exec '{}' bonds '{}' --model '{}' -o '{}'",
        env!("CARGO_BIN_EXE_anisobond"),
        p.display(),
        m.display(),
        o.display()
    );
    let err = fails(Command::new("sh").arg("-c").arg(script));
    assert!(err.contains(&format!("{}:", o.display())), "{err}");
    assert!(
        !err.contains(".anisobond"),
        "a staging name in the error: {err}"
    );
    holds_exactly(d, &["model.toml", "packing.txt"]);
}

/// `calibrate -o cal.json` writes JSON (the model read back equals the TOML one), so every
/// command reads it.
#[test]
fn a_calibrated_model_is_written_in_the_format_its_extension_names() {
    let t = tmp();
    let d = t.path();
    let m = write(
        d,
        "model.json",
        &json_model(r#""rotation": [[1,0,0],[0,1,0],[0,0,1]]"#),
    );
    let (tj, tt) = (d.join("cal.json"), d.join("cal.toml"));
    for o in [&tj, &tt] {
        succeeds(&mut cmd(
            "calibrate --model {m} --target C12/C11=0.30,C44/C11=0.45 -o {o}",
            &[("m", &m), ("o", o)],
        ));
    }
    let text = std::fs::read_to_string(&tj).unwrap();
    assert!(
        serde_json::from_str::<serde_json::Value>(&text).is_ok(),
        "cal.json is not JSON:\n{text}"
    );
    assert_eq!(
        Model::from_path(&tj).unwrap(),
        Model::from_path(&tt).unwrap()
    );
    let p = packing(d, 120);
    succeeds(&mut cmd(
        "bonds {p} --model {tj} -o {o}",
        &[("p", &p), ("tj", &tj), ("o", &d.join("b.csv"))],
    ));
}

/// An isotropic base model calibrated to a cubic target is written as `kind = "cubic"`, and
/// the command says so.
#[test]
fn a_change_of_scheme_kind_in_calibration_is_said() {
    let t = tmp();
    let d = t.path();
    let m = write(
        d,
        "iso.toml",
        "[scheme]\nkind = \"isotropic\"\nnormal = 1e13\nshear = 3e12\n",
    );
    let o = d.join("cal.toml");
    let out = succeeds(&mut cmd(
        "calibrate --model {m} --target C12/C11=0.30,C44/C11=0.45 -o {o}",
        &[("m", &m), ("o", &o)],
    ));
    assert!(
        out.contains("kind = \"isotropic\"") && out.contains("kind = \"cubic\""),
        "{out}"
    );
    assert_eq!(Model::from_path(&o).unwrap().scheme.kind_name(), "cubic");
}

/// The demo's cubic model as JSON with `extra` added to its `scheme`.
fn json_model(extra: &str) -> String {
    format!(
        r#"{{"bonding": {{"rule": "gap", "value": 0.17}},
"scheme": {{"kind": "cubic", "model": "zener-above-1", "a_n": 4.31, "a_s": 10.0,
"normal": 1e13, "shear": 3.55e12, {extra}}}}}"#
    )
}

/// Keys of three numbers or a 3×3 matrix take exactly that many; `null` is no value.
#[test]
fn fixed_size_model_keys_take_exactly_their_size() {
    let t = tmp();
    let d = t.path();
    let cubic = CUBIC_MODEL.to_string();
    let cross =
        "[scheme]\nkind = \"cross-anisotropic\"\nC11 = 130e6\nC33 = 55e6\nC13 = 28e6\nC12 = 40e6\n";
    let cases: Vec<(&str, String, &str)> = vec![
        (
            "m.toml",
            cubic.clone() + "rotation = [[1,0,0,5],[0,1,0],[0,0,1]]\n",
            "m.toml:12: `rotation`: expected row 1 of exactly 3 numbers, found 4",
        ),
        (
            "m.toml",
            cubic.clone() + "rotation = [[1,0,0],[0,1,0],[0,0,1],[0,0,0]]\n",
            "expected 3 rows of 3 numbers, found 4 rows",
        ),
        (
            "m.toml",
            cubic.clone() + "euler_zyz_deg = [10, 20]\n",
            "`euler_zyz_deg`: expected a list of exactly 3 numbers, found 2",
        ),
        (
            "m.toml",
            cross.to_string() + "axis = [0, 0, 1, 0]\n",
            "`axis`: expected a list of exactly 3 numbers, found 4",
        ),
        (
            "m.json",
            json_model(r#""rotation": null"#),
            "`rotation`: invalid type: null, expected a sequence",
        ),
    ];
    let p = packing(d, 100);
    for (name, text, expected) in cases {
        let m = write(d, name, &text);
        let o = d.join("b.csv");
        let err = fails(&mut cmd(
            "bonds {p} --model {m} -o {o}",
            &[("p", &p), ("m", &m), ("o", &o)],
        ));
        assert!(err.contains(expected), "{text}\n→ {err}");
        assert!(!o.exists());
    }
}

/// The one-line help of `tensor`, `export` and `validate` names every method and every code
/// the parser accepts (read from each command's own help: possible values and subcommands).
#[test]
fn the_top_level_help_lists_what_the_parsers_accept() {
    let top = succeeds(bin().arg("--help"));
    let tensor = succeeds(bin().args(["tensor", "--help"]));
    let methods: Vec<String> = tensor
        .lines()
        .skip_while(|l| !l.contains("--method"))
        .take_while(|l| !l.contains("[default"))
        .filter_map(|l| l.trim().strip_prefix("- "))
        .filter_map(|l| l.split(':').next())
        .map(|s| s.trim().to_string())
        .collect();
    assert!(
        methods.len() >= 6,
        "methods parsed from tensor --help: {methods:?}"
    );
    let line = |cmd: &str| {
        top.lines()
            .skip_while(|l| !l.starts_with("Commands:"))
            // The command's own line: indented by exactly two spaces, its first word the name (a
            // wrapped description line of another command may start with the same word).
            .skip_while(|l| {
                !(l.starts_with("  ")
                    && !l.starts_with("   ")
                    && l.split_whitespace().next() == Some(cmd))
            })
            .enumerate()
            .take_while(|(k, l)| *k == 0 || l.starts_with("               "))
            .map(|(_, l)| l)
            .collect::<Vec<_>>()
            .join(" ")
    };
    for m in &methods {
        assert!(
            line("tensor").contains(m.as_str()),
            "tensor's help misses {m}: {}",
            line("tensor")
        );
    }
    for (cmd, help) in [("export", "export"), ("validate", "validate")] {
        let sub = succeeds(bin().args([help, "--help"]));
        let codes: Vec<String> = sub
            .lines()
            .skip_while(|l| !l.starts_with("Commands:"))
            .skip(1)
            .take_while(|l| l.starts_with("  "))
            .filter(|l| l.starts_with("  ") && !l.starts_with("   "))
            .filter_map(|l| l.split_whitespace().next())
            .filter(|c| *c != "help")
            .map(str::to_string)
            .collect();
        assert!(codes.len() >= 3, "{cmd} codes: {codes:?}");
        for c in &codes {
            assert!(
                line(cmd).contains(c.as_str()),
                "{cmd}'s help misses {c}: {}",
                line(cmd)
            );
        }
    }
}
