//! LIGGGHTS 3.8's own `dump custom` snapshots read as written (issue 31): the same deck writes
//! a dump (`id type x y z radius`, two snapshots) and a data file of the final state, in a
//! periodic and in a walled box. The dump is read as the data file is (same ids, positions,
//! radii; the periodic box as the cell, the walled box as a free cluster, from the dump's
//! own boundary flags), and bonded by the command.

use crate::common::liggghts::*;
use crate::common::{cmd, fails, missing, succeeds, tmp, write, CUBIC_MODEL};
use anisobond::packing::io::{read_packing, read_packing_as, CellChoice};

#[test]
fn liggghts_dump_custom_reads_as_its_data_file() {
    if let Some(r) = missing(&["liggghts"]) {
        assert!(std::env::var_os("CI").is_none(), "CI without liggghts: {r}");
        eprintln!("skipping: {r}");
        return;
    }
    let t = tmp();
    let d = t.path();
    for (boundary, periodic) in [("p", true), ("f", false)] {
        let (data, dump) = (
            format!("box-{boundary}.data"),
            format!("box-{boundary}.dump"),
        );
        let vars = [
            ("b", boundary),
            ("zh", "0.01"),
            ("dx", "0.0015"),
            ("name", data.as_str()),
            ("dump", dump.as_str()),
        ];
        run_stock_deck(d, "write_dump.in", &vars);
        let choice = if periodic {
            CellChoice::Periodic
        } else {
            CellChoice::Free
        };
        let from_data = read_packing_as(&d.join(&data), choice).unwrap().packing;
        let from_dump = read_packing(&d.join(&dump)).unwrap();
        assert_eq!(from_dump.cell.is_some(), periodic, "boundary {boundary}");
        assert_eq!(from_dump.ids, from_data.ids, "ids, boundary {boundary}");
        assert_eq!(from_dump.len(), from_data.len());
        let scale = 0.01;
        for k in 0..from_dump.len() {
            let dx = (from_dump.positions[k] - from_data.positions[k]).norm();
            assert!(
                dx <= 1e-14 * scale,
                "boundary {boundary}, atom {k}: {dx:e} m apart"
            );
            assert_eq!(from_dump.radii[k], from_data.radii[k]);
        }
        if periodic {
            assert_eq!(
                from_dump.cell.unwrap().lengths,
                from_data.cell.unwrap().lengths
            );
        }
        // Bonded by the command as it is, and the same bonds as the data file's.
        let m = write(d, "model.toml", CUBIC_MODEL);
        let (b1, b2) = (d.join("dump.csv"), d.join("data.csv"));
        let dump_path = d.join(&dump);
        let data_path = d.join(&data);
        succeeds(&mut cmd(
            "bonds {p} --model {m} -o {o}",
            &[("p", &dump_path), ("m", &m), ("o", &b1)],
        ));
        let flag = if periodic { "--periodic" } else { "--free" };
        let mut c = cmd(
            "bonds {p} --model {m} -o {o}",
            &[("p", &data_path), ("m", &m), ("o", &b2)],
        );
        c.arg(flag);
        succeeds(&mut c);
        let rows = |p: &std::path::Path| std::fs::read_to_string(p).unwrap().lines().count();
        assert_eq!(rows(&b1), rows(&b2), "bond rows, boundary {boundary}");
        // The dump states its boundary: a contradicting option is refused.
        let other = if periodic { "--free" } else { "--periodic" };
        let mut c = cmd(
            "bonds {p} --model {m} -o {o}",
            &[("p", &dump_path), ("m", &m), ("o", &d.join("x.csv"))],
        );
        c.arg(other);
        let err = fails(&mut c);
        assert!(err.contains("BOX BOUNDS"), "{err}");
        // The real dump cut after every line: read (a whole first snapshot) or refused with
        // a line number, never a panic; its boundary made mixed: refused by name.
        let text = std::fs::read_to_string(&dump_path).unwrap();
        let lines: Vec<&str> = text.lines().collect();
        for cut in 0..lines.len() {
            let part = lines[..cut].join("\n");
            let _ = anisobond::packing::io::parse_packing(&part, "cut.dump");
        }
        if periodic {
            let mixed = text.replace("ITEM: BOX BOUNDS pp pp pp", "ITEM: BOX BOUNDS pp pp ff");
            assert_ne!(mixed, text, "the dump's boundary line");
            let e = anisobond::packing::io::parse_packing(&mixed, "mixed.dump").unwrap_err();
            assert!(e.to_string().contains("mixed periodicity"), "{e}");
        }
    }
}
