//! A user's grain files (docs/formats.md "Grain files"): grain ids per particle, Bunge
//! Euler angles per grain. Text; `#` starts a comment; blank lines are skipped; every
//! refusal names the file and the line.

use super::orientation::bunge_deg;
use crate::{Error, Mat3, Result};
use std::path::Path;

/// The data lines of `text`: (1-based line number, content without comment), blank ones left out.
fn data_lines(text: &str) -> impl Iterator<Item = (usize, &str)> {
    text.lines().enumerate().filter_map(|(k, line)| {
        let content = line.split('#').next().unwrap_or("").trim();
        (!content.is_empty()).then_some((k + 1, content))
    })
}

/// Read a grain-id file: one grain id per data line (an integer 0 ≤ id < 2³² − 1), the
/// particles in the packing's order, exactly `particles` lines. Refuses, naming the file
/// and line, a line that is not one such integer, and a count that is not the packing's.
pub fn read_grain_file(path: &Path, particles: usize) -> Result<Vec<u32>> {
    let text = crate::io::read_to_string(path)?;
    parse_grain_ids(&text, &path.display().to_string(), particles)
}

/// [`read_grain_file`] of text; `name` is used in refusals.
pub fn parse_grain_ids(text: &str, name: &str, particles: usize) -> Result<Vec<u32>> {
    let mut ids = Vec::with_capacity(particles);
    for (line, content) in data_lines(text) {
        let id = content
            .parse::<u32>()
            .ok()
            .filter(|&g| g < u32::MAX)
            .ok_or_else(|| {
                Error::parse(
                    name,
                    line,
                    format!(
                        "`{content}`: expected one grain id per line, an integer from 0 to {}",
                        u32::MAX - 1
                    ),
                )
            })?;
        ids.push(id);
    }
    if ids.len() != particles {
        return Err(Error::parse(
            name,
            0,
            format!(
                "{} grain ids, but the packing has {particles} particles (one id per particle, \
                 in the packing's order)",
                ids.len()
            ),
        ));
    }
    Ok(ids)
}

/// Read a Bunge Euler-angle file: one grain per data line, `phi1 Phi phi2` in degrees
/// (ZXZ, [`super::bunge_matrix`]), separated by spaces, tabs or commas; line k (of the data
/// lines, from 0) is grain k. Refuses, naming the file and line, a line that is not three
/// finite numbers, and a file without grains.
pub fn read_euler_file(path: &Path) -> Result<Vec<Mat3>> {
    let text = crate::io::read_to_string(path)?;
    parse_euler_angles(&text, &path.display().to_string())
}

/// [`read_euler_file`] of text; `name` is used in refusals.
pub fn parse_euler_angles(text: &str, name: &str) -> Result<Vec<Mat3>> {
    let mut out = Vec::new();
    for (line, content) in data_lines(text) {
        let fields: Vec<&str> = content
            .split(|c: char| c.is_whitespace() || c == ',')
            .filter(|f| !f.is_empty())
            .collect();
        let angles: Option<Vec<f64>> = fields
            .iter()
            .map(|f| f.parse::<f64>().ok().filter(|x| x.is_finite()))
            .collect();
        match angles.as_deref() {
            Some(&[phi1, big_phi, phi2]) => out.push(bunge_deg(phi1, big_phi, phi2)),
            _ => {
                return Err(Error::parse(
                    name,
                    line,
                    format!(
                        "`{content}`: expected three finite Bunge Euler angles `phi1 Phi phi2` \
                         (degrees)"
                    ),
                ))
            }
        }
    }
    if out.is_empty() {
        return Err(Error::parse(
            name,
            0,
            "no grains: expected one line `phi1 Phi phi2` (degrees) per grain",
        ));
    }
    Ok(out)
}
