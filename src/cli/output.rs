//! Printing and file helpers of the CLI: tables in GPa, JSON files, progress bars.

use anisobond::homogenize::{CubicSummary, TensorReport};
use anisobond::tensor::CubicUncertainty;
use anisobond::Result;
use indicatif::{ProgressBar, ProgressStyle};
use std::path::{Path, PathBuf};

/// The input files of a command that reads an optional packing and a model, for
/// [`anisobond::io::OutputSet::new`].
pub fn inputs<'a>(packing: Option<&'a Path>, model: &'a Path) -> Vec<&'a Path> {
    packing.into_iter().chain([model]).collect()
}

pub use anisobond::io::check_json_numbers;

/// Write a JSON report atomically.
pub fn write_json(path: &Path, report: &TensorReport) -> Result<()> {
    anisobond::io::write_string_atomic(path, &(report.to_json() + "\n"))
}

/// Write a tensor report with a command's own sections added (`sections`: key and JSON
/// value) atomically, refusing a non-finite number in any added section
/// ([`check_json_numbers`]).
pub fn write_json_with(
    path: &Path,
    report: &TensorReport,
    sections: Vec<(&str, serde_json::Value)>,
) -> Result<()> {
    let tensor_report_error =
        |e: serde_json::Error| anisobond::Error::Invalid(format!("tensor report: {e}"));
    let mut json = serde_json::to_value(report).map_err(tensor_report_error)?;
    for (key, value) in sections {
        check_json_numbers(&value, key)?;
        json[key] = value;
    }
    let text = serde_json::to_string_pretty(&json).map_err(tensor_report_error)?;
    anisobond::io::write_string_atomic(path, &(text + "\n"))
}

/// Where `file`, written into the staging folder `staged`, lands in the final folder `output`.
pub fn final_path(file: &Path, staged: &Path, output: &Path) -> PathBuf {
    output.join(file.strip_prefix(staged).unwrap_or(file))
}

/// Print the files a command wrote into the staging folder `staged` under their final
/// folder `output` ([`final_path`]), one a line after `prefix`.
pub fn print_written(prefix: &str, files: &[PathBuf], staged: &Path, output: &Path) {
    for f in files {
        println!("{prefix}{}", final_path(f, staged, output).display());
    }
}

/// Print a tensor report as a human-readable table (GPa).
pub fn print_report(r: &TensorReport) {
    println!(
        "stiffness tensor, method {} (GPa; Voigt order 11 22 33 23 13 12):",
        r.method
    );
    for row in &r.c {
        let cells: Vec<String> = row.iter().map(|v| format!("{:10.4}", v / 1e9)).collect();
        println!("  {}", cells.join(" "));
    }
    if let (Some(n), Some(nb), Some(z)) = (r.n_particles, r.n_bonds, r.coordination) {
        println!("particles {n}, bonds {nb}, coordination Z = {z:.3}");
    } else if let Some(z) = r.coordination {
        println!("equal-sphere mean field at coordination Z = {z:.3}");
    }
    if let Some(f) = r.manybody_volume_fraction {
        println!("many-body term included: volume fraction Σ V_p / V = {f:.6}");
    }
    let [c11, c12, c44, r12, r44, zener] = cubic_row(&r.cubic);
    println!(
        "cubic projection: C11 = {c11:.4} GPa, C12 = {c12:.4} GPa, C44 = {c44:.4} GPa; C12/C11 = {r12:.4}, C44/C11 = {r44:.4}, Zener = {zener:.4}"
    );
    println!(
        "  uncertainty (GPa): {}, terms that should be zero {:.3e}",
        spread_gpa(&r.cubic.uncertainty),
        r.cubic.uncertainty.zero_terms / 1e9
    );
}

/// A cubic projection as printed: C11, C12, C44 (GPa), C12/C11, C44/C11, Zener.
pub fn cubic_row(c: &CubicSummary) -> [f64; 6] {
    [
        c.c11 / 1e9,
        c.c12 / 1e9,
        c.c44 / 1e9,
        c.c12 / c.c11,
        c.c44 / c.c11,
        c.zener,
    ]
}

/// The spread of each group of cubically equivalent terms, "C11 … C12 … C44 …" in GPa.
pub fn spread_gpa(u: &CubicUncertainty) -> String {
    format!(
        "C11 {:.3e}, C12 {:.3e}, C44 {:.3e}",
        u.c11 / 1e9,
        u.c12 / 1e9,
        u.c44 / 1e9
    )
}

/// A progress bar on stderr over the fraction done (0–1 mapped to 1000 ticks).
pub fn progress_bar(what: &str) -> ProgressBar {
    let bar = ProgressBar::new(1000);
    bar.set_style(
        ProgressStyle::with_template(&format!("{what} [{{bar:40}}] {{percent:>3}}% {{elapsed}}"))
            .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    bar
}
