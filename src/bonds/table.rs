//! The bond table CSV of docs/formats.md, one bond per row:
//! `i,j,nx,ny,nz,length,radius,kn,ks,kr,ktw,ix,iy,iz` — length = centre distance (m),
//! radius = R_b (m), kn/ks in N/m, kr/ktw in N·m/rad, ix,iy,iz = periodic image of j;
//! then `id_i,id_j` (the particles' own ids) when the packing has them and `type` (the
//! bond's type in the user's file) when the bonds came from one, then `grain_i,grain_j` (the
//! particles' grains, docs/polycrystal.md) for a polycrystal. Readers find columns by name.
//!
//! Numbers are written in their shortest round-trip form, so a table read back gives the
//! same bits. Rows are formatted in parallel chunks and written in bond order.

use super::{BondSet, BondStiffness};
use crate::packing::Packing;
use crate::{Error, Result, Vec3};
use rayon::prelude::*;
use std::io::Write;
use std::path::Path;

/// The header row.
pub const HEADER: &str = "i,j,nx,ny,nz,length,radius,kn,ks,kr,ktw,ix,iy,iz";

const CHUNK: usize = 16384;

fn push_f64(s: &mut String, buf: &mut ryu::Buffer, v: f64) {
    s.push_str(buf.format(v));
}

fn push_int<T: itoa::Integer>(s: &mut String, buf: &mut itoa::Buffer, v: T) {
    s.push_str(buf.format(v));
}

/// Format rows `range` of the table into `s` (cleared first; its capacity is reused).
fn format_rows(
    s: &mut String,
    bonds: &BondSet,
    k: &BondStiffness,
    ids: Option<&[u64]>,
    types: Option<&[u32]>,
    grains: Option<&[u32]>,
    range: std::ops::Range<usize>,
) {
    s.clear();
    let mut fb = ryu::Buffer::new();
    let mut ib = itoa::Buffer::new();
    for b in range {
        push_int(s, &mut ib, bonds.i[b]);
        s.push(',');
        push_int(s, &mut ib, bonds.j[b]);
        let n = bonds.normal[b];
        for v in [
            n.x,
            n.y,
            n.z,
            bonds.length[b],
            k.radius[b],
            k.kn[b],
            k.ks[b],
            k.kr[b],
            k.ktw[b],
        ] {
            s.push(',');
            push_f64(s, &mut fb, v);
        }
        for v in bonds.image[b] {
            s.push(',');
            push_int(s, &mut ib, v);
        }
        if let Some(ids) = ids {
            s.push(',');
            push_int(s, &mut ib, ids[bonds.i[b] as usize]);
            s.push(',');
            push_int(s, &mut ib, ids[bonds.j[b] as usize]);
        }
        if let Some(types) = types {
            s.push(',');
            push_int(s, &mut ib, types[b]);
        }
        if let Some(grains) = grains {
            s.push(',');
            push_int(s, &mut ib, grains[bonds.i[b] as usize]);
            s.push(',');
            push_int(s, &mut ib, grains[bonds.j[b] as usize]);
        }
        s.push('\n');
    }
}

/// Write the bond table to any writer.
pub fn write_bond_table_to(
    w: &mut dyn Write,
    bonds: &BondSet,
    k: &BondStiffness,
) -> std::io::Result<()> {
    write_bond_table_ids_to(w, bonds, k, None)
}

/// Write the bond table to any writer, with the trailing columns `id_i,id_j` (the
/// particles' own ids, indexed by `i` and `j`) when `ids` is given.
pub fn write_bond_table_ids_to(
    w: &mut dyn Write,
    bonds: &BondSet,
    k: &BondStiffness,
    ids: Option<&[u64]>,
) -> std::io::Result<()> {
    write_bond_table_columns_to(w, bonds, k, ids, None)
}

/// Write the bond table to any writer, with the trailing columns `id_i,id_j` (the
/// particles' own ids, indexed by `i` and `j`) when `ids` is given and `type` (each bond's
/// type in the user's file, e.g. a LAMMPS data file's Bonds section) when `types` is.
pub fn write_bond_table_columns_to(
    w: &mut dyn Write,
    bonds: &BondSet,
    k: &BondStiffness,
    ids: Option<&[u64]>,
    types: Option<&[u32]>,
) -> std::io::Result<()> {
    write_bond_table_grains_to(w, bonds, k, ids, types, None)
}

/// [`write_bond_table_columns_to`] with the trailing columns `grain_i,grain_j` (the grain
/// of each end, `grains` indexed by particle) when `grains` is given.
pub fn write_bond_table_grains_to(
    w: &mut dyn Write,
    bonds: &BondSet,
    k: &BondStiffness,
    ids: Option<&[u64]>,
    types: Option<&[u32]>,
    grains: Option<&[u32]>,
) -> std::io::Result<()> {
    let mut header = HEADER.to_string();
    if ids.is_some() {
        header.push_str(",id_i,id_j");
    }
    if types.is_some() {
        header.push_str(",type");
    }
    if grains.is_some() {
        header.push_str(",grain_i,grain_j");
    }
    writeln!(w, "{header}")?;
    let n = bonds.len();
    let n_chunks = n.div_ceil(CHUNK);
    // Groups of chunks are formatted in parallel into buffers that are reused from group to
    // group (fresh memory for the whole table would cost page faults that serialise the
    // threads), then written in order.
    let group = 4 * rayon::current_num_threads().max(1);
    let mut buffers: Vec<String> = (0..group.min(n_chunks))
        .map(|_| String::with_capacity(CHUNK * 170))
        .collect();
    for first in (0..n_chunks).step_by(group) {
        let count = group.min(n_chunks - first);
        buffers[..count]
            .par_iter_mut()
            .enumerate()
            .for_each(|(g, buf)| {
                let c = first + g;
                format_rows(
                    buf,
                    bonds,
                    k,
                    ids,
                    types,
                    grains,
                    c * CHUNK..((c + 1) * CHUNK).min(n),
                );
            });
        for buf in &buffers[..count] {
            w.write_all(buf.as_bytes())?;
        }
    }
    Ok(())
}

/// Write the bond table to `path` atomically.
pub fn write_bond_table(path: &Path, bonds: &BondSet, k: &BondStiffness) -> Result<()> {
    crate::io::write_atomic(path, |w| {
        write_bond_table_to(w, bonds, k).map_err(|e| Error::io(path, e))
    })
}

/// Write the bond table to `path` atomically, with `id_i,id_j` columns when `ids` is given
/// (see [`write_bond_table_ids_to`]).
pub fn write_bond_table_with_ids(
    path: &Path,
    bonds: &BondSet,
    k: &BondStiffness,
    ids: Option<&[u64]>,
) -> Result<()> {
    crate::io::write_atomic(path, |w| {
        write_bond_table_ids_to(w, bonds, k, ids).map_err(|e| Error::io(path, e))
    })
}

/// [`write_bond_table_with_ids`] with the `type` column too when `types` is given
/// ([`write_bond_table_columns_to`]).
pub fn write_bond_table_with_columns(
    path: &Path,
    bonds: &BondSet,
    k: &BondStiffness,
    ids: Option<&[u64]>,
    types: Option<&[u32]>,
) -> Result<()> {
    crate::io::write_atomic(path, |w| {
        write_bond_table_columns_to(w, bonds, k, ids, types).map_err(|e| Error::io(path, e))
    })
}

/// [`write_bond_table_with_columns`] with `grain_i,grain_j` too when `grains` is given
/// ([`write_bond_table_grains_to`]).
pub fn write_bond_table_with_grains(
    path: &Path,
    bonds: &BondSet,
    k: &BondStiffness,
    ids: Option<&[u64]>,
    types: Option<&[u32]>,
    grains: Option<&[u32]>,
) -> Result<()> {
    crate::io::write_atomic(path, |w| {
        write_bond_table_grains_to(w, bonds, k, ids, types, grains).map_err(|e| Error::io(path, e))
    })
}

/// A bond table with each bond's particles by their own ids (`id_i,id_j`) when it has them.
pub type TableWithIds = (BondSet, BondStiffness, Option<Vec<[u64; 2]>>);

/// Read a bond table file with its `id_i,id_j` columns, when it has them: each bond's
/// particles by their own ids (LAMMPS / LIGGGHTS atom ids), each ≥ 1.
pub fn read_bond_table_atom_ids(path: &Path) -> Result<TableWithIds> {
    let text = crate::io::read_to_string(path)?;
    let name = path.display().to_string();
    let (bonds, k, lines) = parse_bond_table_lines(&text, &name)?;
    let mut rows = text
        .lines()
        .enumerate()
        .filter(|(_, l)| !l.trim().is_empty());
    let header: Vec<&str> = rows
        .next()
        .map(|(_, h)| h.split(',').map(str::trim).collect())
        .unwrap_or_default();
    let col = |n: &str| header.iter().position(|c| *c == n);
    let (Some(ci), Some(cj)) = (col("id_i"), col("id_j")) else {
        return Ok((bonds, k, None));
    };
    let mut ids = Vec::with_capacity(bonds.len());
    for ((ln, line), &want) in rows.zip(&lines) {
        debug_assert_eq!(ln + 1, want);
        let f: Vec<&str> = line.split(',').map(str::trim).collect();
        let id = |c: usize, n: &str| -> Result<u64> {
            match f[c].parse::<u64>() {
                Ok(v) if v >= 1 => Ok(v),
                _ => Err(Error::parse(
                    &name,
                    ln + 1,
                    format!("column `{n}`: expected an atom id ≥ 1, found `{}`", f[c]),
                )),
            }
        };
        ids.push([id(ci, "id_i")?, id(cj, "id_j")?]);
    }
    Ok((bonds, k, Some(ids)))
}

/// Read a bond table file.
pub fn read_bond_table(path: &Path) -> Result<(BondSet, BondStiffness)> {
    let text = crate::io::read_to_string(path)?;
    parse_bond_table(&text, &path.display().to_string())
}

/// Parse a bond table; `name` is used in error messages. Columns are found by header
/// name, so extra columns are allowed; every SPEC column is required.
pub fn parse_bond_table(text: &str, name: &str) -> Result<(BondSet, BondStiffness)> {
    parse_bond_table_lines(text, name).map(|(b, k, _)| (b, k))
}

/// Read a bond table that must be of `packing` ([`check_against_packing`]); its images
/// are returned among the packing's stored (wrapped) positions.
pub fn read_bond_table_of(path: &Path, packing: &Packing) -> Result<(BondSet, BondStiffness)> {
    let text = crate::io::read_to_string(path)?;
    let name = path.display().to_string();
    let (mut bonds, k, lines) = parse_bond_table_lines(&text, &name)?;
    check_against_packing(&mut bonds, &lines, packing, &name)?;
    Ok((bonds, k))
}

/// Relative tolerance of a table row's branch vector n·length against the packing's.
pub const BRANCH_TOLERANCE: f64 = 1e-6;

/// Check every row (on `lines` of the table `name`) against `packing`: the particle
/// indices exist, and the branch vector n·length equals the one from i to the image
/// (ix,iy,iz) of j among the packing's positions as given ([`Packing::given_positions`])
/// within `BRANCH_TOLERANCE`·length, so that normals (direction and sign), lengths and
/// images are those of this packing. The images are then converted to the stored
/// (wrapped) positions. Refusals name the file, the line and what was expected.
pub fn check_against_packing(
    bonds: &mut BondSet,
    lines: &[usize],
    packing: &Packing,
    name: &str,
) -> Result<()> {
    let n = packing.len();
    if bonds.is_empty() {
        return Err(Error::Invalid(format!(
            "{name}: the bond table holds no bonds"
        )));
    }
    for (b, &line) in lines.iter().enumerate().take(bonds.len()) {
        let (i, j) = (bonds.i[b] as usize, bonds.j[b] as usize);
        if j >= n {
            return Err(Error::parse(
                name,
                line,
                format!(
                    "bond {b} joins particles {i} and {j} but the packing has {n} (0 to {})",
                    n.saturating_sub(1)
                ),
            ));
        }
        let (img, branch) = branch_of_given_image(packing, b, (i, j), bonds.image[b])
            .map_err(|m| Error::parse(name, line, m))?;
        let l = bonds.length[b];
        let off = (branch - bonds.normal[b] * l).norm();
        if off.is_nan() || off > BRANCH_TOLERANCE * l {
            let message = mismatch_message(bonds, b, packing, branch);
            return Err(Error::parse(name, line, message));
        }
        bonds.image[b] = img;
    }
    Ok(())
}

/// The image (of the stored, wrapped positions) and branch vector from particle i to the
/// image `given` of particle j (`pair` = (i, j)) among the packing's positions as given;
/// refused, with the message, when `given` crosses a face that is not periodic.
fn branch_of_given_image(
    packing: &Packing,
    b: usize,
    pair: (usize, usize),
    given: [i32; 3],
) -> std::result::Result<([i32; 3], Vec3), String> {
    let (i, j) = pair;
    let d = packing.positions[j] - packing.positions[i];
    match &packing.cell {
        Some(cell) => {
            if let Some(k) = (0..3).find(|&k| !cell.periodic[k] && given[k] != 0) {
                return Err(format!(
                    "bond {b} ({i}–{j}): image ix,iy,iz = {given:?}, but the packing's \
                     box is not periodic along {} (boundary {}): expected 0 there",
                    ["x", "y", "z"][k],
                    cell.boundary()
                ));
            }
            let img = packing.image_from_given(i, j, given);
            Ok((img, d + cell.shift(img)))
        }
        None if given != [0, 0, 0] => Err(format!(
            "bond {b} ({i}–{j}): image ix,iy,iz = {given:?} in a packing without a \
             periodic cell: expected 0,0,0"
        )),
        None => Ok(([0; 3], d)),
    }
}

/// Why bond `b`'s n·length is not the packing's `branch` vector (of its given image): the
/// image alone (n·length reaches another image of j, named), or the normal and length.
fn mismatch_message(bonds: &BondSet, b: usize, packing: &Packing, branch: Vec3) -> String {
    let v = |x: Vec3| format!("({:e}, {:e}, {:e})", x.x, x.y, x.z);
    let (i, j) = (bonds.i[b] as usize, bonds.j[b] as usize);
    let (given, l) = (bonds.image[b], bonds.length[b]);
    let table_branch = bonds.normal[b] * l;
    let d = packing.positions[j] - packing.positions[i];
    let nearest = match &packing.cell {
        Some(cell) => cell.minimum_image(d),
        None => (d, [0; 3]),
    };
    let right_image = (nearest.0 - table_branch).norm() <= BRANCH_TOLERANCE * l;
    if right_image {
        format!(
            "bond {b} ({i}–{j}): image ix,iy,iz = {given:?}, but n·length = {} m \
             reaches the image {:?} of particle {j} among the packing's positions as \
             given: expected ix,iy,iz = {:?}; the bond table is not of this packing \
             (or its images are of other positions)",
            v(table_branch),
            packing.image_to_given(i, j, nearest.1),
            packing.image_to_given(i, j, nearest.1)
        )
    } else {
        let len = branch.norm();
        format!(
            "bond {b} ({i}–{j}): nx,ny,nz = {} and length {l:e} m, but the packing \
             puts the image {given:?} of particle {j} at {} m from particle {i}: \
             expected nx,ny,nz = {} and length {len:e} m (within {BRANCH_TOLERANCE:e} \
             of the length): the bond table is not of this packing",
            v(bonds.normal[b]),
            v(branch),
            v(branch / len)
        )
    }
}

/// [`parse_bond_table`], with the line of every bond.
pub fn parse_bond_table_lines(
    text: &str,
    name: &str,
) -> Result<(BondSet, BondStiffness, Vec<usize>)> {
    let mut lines = text
        .lines()
        .enumerate()
        .filter(|(_, l)| !l.trim().is_empty());
    let (_, header) = lines.next().ok_or_else(|| {
        Error::parse(
            name,
            1,
            format!("empty file: expected the header `{HEADER}`"),
        )
    })?;
    let (n_cols, idx) = header_columns(header, name)?;
    let mut bonds = BondSet::default();
    let mut k = BondStiffness::default();
    let mut rows = Vec::new();
    for (ln, line) in lines {
        let row = TableRow {
            name,
            line_no: ln + 1,
            fields: line.split(',').map(str::trim).collect(),
            idx: &idx,
        };
        if row.fields.len() != n_cols {
            return Err(Error::parse(
                name,
                row.line_no,
                format!(
                    "expected {} comma-separated fields, found {}",
                    n_cols,
                    row.fields.len()
                ),
            ));
        }
        row.push_bond(&mut bonds, &mut k)?;
        rows.push(row.line_no);
    }
    Ok((bonds, k, rows))
}

/// The number of columns of the bond table's `header` line and where each column of
/// [`HEADER`] stands in it (any order); a missing column is a parse error on line 1.
fn header_columns(header: &str, name: &str) -> Result<(usize, [usize; 14])> {
    let cols: Vec<&str> = header.split(',').map(str::trim).collect();
    let mut idx = [0usize; 14];
    for (k, want) in HEADER.split(',').enumerate() {
        idx[k] = cols.iter().position(|c| *c == want).ok_or_else(|| {
            Error::parse(
                name,
                1,
                format!("header lacks column `{want}`: expected `{HEADER}`"),
            )
        })?;
    }
    Ok((cols.len(), idx))
}

/// One data line of a bond table: its fields, and where each column of [`HEADER`] is.
struct TableRow<'a> {
    name: &'a str,
    line_no: usize,
    fields: Vec<&'a str>,
    idx: &'a [usize; 14],
}

impl TableRow<'_> {
    /// Name of column `c` of [`HEADER`].
    fn column(c: usize) -> &'static str {
        HEADER.split(',').nth(c).unwrap_or("?")
    }

    /// Column `c` as an integer.
    fn int(&self, c: usize) -> Result<i64> {
        let f = self.fields[self.idx[c]];
        f.parse::<i64>().map_err(|_| {
            Error::parse(
                self.name,
                self.line_no,
                format!(
                    "column `{}`: expected an integer, found `{f}`",
                    Self::column(c)
                ),
            )
        })
    }

    /// Column `c` as a finite number.
    fn num(&self, c: usize) -> Result<f64> {
        let f = self.fields[self.idx[c]];
        let col = Self::column(c);
        let v = f.parse::<f64>().map_err(|_| {
            Error::parse(
                self.name,
                self.line_no,
                format!("column `{col}`: expected a number, found `{f}`"),
            )
        })?;
        if !v.is_finite() {
            return Err(Error::parse(
                self.name,
                self.line_no,
                format!("column `{col}`: {f} is not finite"),
            ));
        }
        Ok(v)
    }

    /// A parse error on this line.
    fn error(&self, message: impl Into<String>) -> Error {
        Error::parse(self.name, self.line_no, message)
    }

    /// Read the bond of this line (0 ≤ i < j, unit normal, length > 0, image) and its
    /// springs (radius > 0, kn, ks, kr, ktw ≥ 0) onto `bonds` and `k`.
    fn push_bond(&self, bonds: &mut BondSet, k: &mut BondStiffness) -> Result<()> {
        let (i, j) = (self.int(0)?, self.int(1)?);
        if i < 0 || j < 0 || i >= j || j > u32::MAX as i64 {
            return Err(self.error(format!(
                "expected particle indices 0 ≤ i < j, found i = {i}, j = {j}"
            )));
        }
        let n = Vec3::new(self.num(2)?, self.num(3)?, self.num(4)?);
        let length = self.num(5)?;
        if length <= 0.0 {
            return Err(self.error(format!("bond length must be > 0, found {length}")));
        }
        let nn = n.norm();
        if (nn - 1.0).abs() > 1e-6 {
            return Err(self.error(format!("normal must be a unit vector, |n| = {nn}")));
        }
        let image = [self.int(11)?, self.int(12)?, self.int(13)?].map(|v| v as i32);
        bonds.i.push(i as u32);
        bonds.j.push(j as u32);
        bonds.normal.push(n);
        bonds.length.push(length);
        bonds.image.push(image);
        let radius = self.num(6)?;
        let springs = [self.num(7)?, self.num(8)?, self.num(9)?, self.num(10)?];
        if radius <= 0.0 || springs.iter().any(|v| *v < 0.0) {
            return Err(self.error("radius must be > 0 and kn, ks, kr, ktw ≥ 0"));
        }
        k.radius.push(radius);
        k.kn.push(springs[0]);
        k.ks.push(springs[1]);
        k.kr.push(springs[2]);
        k.ktw.push(springs[3]);
        Ok(())
    }
}
