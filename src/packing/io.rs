//! Packing files: the SPEC text format (YADE `ymport.text` / `export.text` compatible),
//! YADE `SpherePack` text and LIGGGHTS `atom_style granular` data files.
//!
//! - SPEC text: one sphere per line `x y z r`, whitespace-separated, `#` starts a comment;
//!   a header comment `# periodic Lx Ly Lz` declares the periodic cell [0,Lx)×[0,Ly)×[0,Lz)
//!   (positions outside are wrapped, and kept as given for the periodic images of bond
//!   tables and for writing); a `# free` line states a free cluster (anisobond
//!   writes it for free packings). A file with neither does not state its cell: see
//!   [`read_packing_as`] and [`CellChoice`]. YADE `export.text` / `export.textExt` files are read
//!   by their `#format` line: `x_y_z_r`, `x_y_z_r_matId` (integer matId, ignored),
//!   `x_y_z_r_attrs` (any number of attribute columns, the same on every line, ignored) and
//!   `id_x_y_z_r_matId` (body id first); any other `#format` is refused.
//! - YADE `SpherePack.save`: optional first line `##PERIODIC:: Lx Ly Lz`, then
//!   `x y z r clumpId` (or `x y z r`). A clumpId of −1 (a free sphere) is accepted; a sphere
//!   that belongs to a clump (clumpId ≥ 0) is refused, since a clump is one rigid body.
//! - LIGGGHTS / LAMMPS data files: title line, header (`N atoms`, `xlo xhi`, …), `Atoms`
//!   section of `atom_style granular` / `sphere` (`id type diameter density x y z`) or
//!   `bpm/sphere` (`id molecule type diameter density x y z`; diameter, not radius), and a
//!   `Bonds` section (`id type atom1 atom2`), returned as the file's own bond network
//!   ([`DataBonds`], [`parse_data`]).
//!
//! Particle ids are kept where the file gives them: LIGGGHTS atom ids and the body ids of
//! `#format id_x_y_z_r_matId` ([`Packing::ids`]); bond tables then carry `id_i,id_j`.
//!
//! Numbers are written in the shortest form that reads back to the same `f64`, so a
//! write–read round trip is bit-exact.
//!
//! All readers drop a leading UTF-8 byte-order mark and split lines at `\n`, `\r\n` or a
//! lone `\r`, so line numbers in errors are those an editor shows. They refuse a file with
//! no particles, and any number or derived quantity (sphere volume, cell volume, solid
//! fraction) that is not finite and positive, naming the file and line.

use super::{Packing, PeriodicCell};
use crate::{Error, Result, Vec3};
use std::fmt::Write as _;
use std::path::Path;

/// Read a packing file, detecting its format from the content: an `Atoms` section or an
/// `N atoms` header line means LIGGGHTS data (read as periodic, `boundary p p p`); a
/// `##PERIODIC::` line means YADE SpherePack text; anything else is SPEC text.
pub fn read_packing(path: &Path) -> Result<Packing> {
    let text = crate::io::read_to_string(path)?;
    parse_packing(&text, &path.display().to_string())
}

/// Parse packing text in any supported format (see [`read_packing`]); `source_name` names
/// the input in error messages.
pub fn parse_packing(text: &str, source_name: &str) -> Result<Packing> {
    match detect_format(text) {
        PackingFormat::LiggghtsData => parse_liggghts_data(text, source_name, true),
        PackingFormat::Dump => parse_dump(text, source_name),
        PackingFormat::YadeSpherePack | PackingFormat::SpecText => {
            Ok(parse_sphere_text(text, source_name)?.0)
        }
    }
}

/// What to do about the cell of a packing file that does not state it (YADE `export.text`
/// without a cell, a plain `x y z r` file, any LIGGGHTS data file). A file that states its
/// cell is read as stated, and a different choice is refused.
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub enum CellChoice {
    /// The readers' defaults: text without a cell is a free cluster, LIGGGHTS data is
    /// periodic with the box as its cell ([`CellOrigin::Assumed`]).
    #[default]
    AsStated,
    /// Periodic, the cell from the file: the box of LIGGGHTS data (text states no lengths:
    /// refused, give [`CellChoice::Cell`]).
    Periodic,
    /// Periodic with this cell [0, Lx)×[0, Ly)×[0, Lz) (m), for text files; positions are
    /// wrapped into it.
    Cell(Vec3),
    /// A free cluster: no bonds across faces; its volume is the spheres' bounding box.
    Free,
    /// For LAMMPS / LIGGGHTS data: the box periodic along the flagged axes only (LAMMPS
    /// `boundary p p f`: a settled bed); a dump's BOX BOUNDS must state the same.
    Boundary([bool; 3]),
}

/// Where the cell (or its absence) of a packing read by [`read_packing_as`] came from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CellOrigin {
    /// The file states it (`# periodic`, `##PERIODIC::`, `# free`, SpherePack.save columns).
    Stated,
    /// The file does not state it; the caller's [`CellChoice`] decided.
    Chosen,
    /// The file does not state it and the caller said nothing: the reader's default.
    Assumed,
}

/// A packing read by [`read_packing_as`], with its format and where its cell came from.
#[derive(Clone, Debug)]
pub struct PackingRead {
    /// The spheres and their cell (or none: a free cluster).
    pub packing: Packing,
    /// The format the file was read as.
    pub format: PackingFormat,
    /// Whether the cell was stated by the file, chosen by the caller, or assumed.
    pub origin: CellOrigin,
    /// The file's own bond network (a data file's `Bonds` section), to be used instead of
    /// the model's bonding rule; `None` when the file has none.
    pub bonds: Option<DataBonds>,
}

/// How a client names the [`CellChoice`] options in [`PackingRead::cell_note`].
#[derive(Clone, Copy, Debug)]
pub struct CellOptionNames {
    /// [`CellChoice::Cell`].
    pub cell: &'static str,
    /// [`CellChoice::Periodic`].
    pub periodic: &'static str,
    /// [`CellChoice::Free`].
    pub free: &'static str,
}

impl CellOptionNames {
    /// The command line's global options.
    pub const CLI: CellOptionNames = CellOptionNames {
        cell: "--cell Lx,Ly,Lz",
        periodic: "--periodic",
        free: "--free",
    };
}

impl PackingRead {
    /// What a user must be told about this packing's cell, or `None` when the file stated
    /// a periodic cell or the caller chose one: a LIGGGHTS box assumed periodic, or a free
    /// cluster (with why, and its bounding-box volume). `name` names the file; `options`
    /// how the caller spells the choices that change it.
    pub fn cell_note(&self, name: &str, options: CellOptionNames) -> Option<String> {
        let p = &self.packing;
        let CellOptionNames {
            cell,
            periodic,
            free,
        } = options;
        match (&p.cell, self.origin, self.format) {
            (Some(c), CellOrigin::Assumed, _) => Some(format!(
                "{name}: a LIGGGHTS data file does not say whether the run was periodic; read \
                 as periodic (boundary p p p) with the box {} × {} × {} m as the cell; give \
                 {free} for a walled box (no bonds across its faces), or {periodic} to say so",
                c.lengths.x, c.lengths.y, c.lengths.z
            )),
            (None, origin, format) => {
                let (lo, hi) = p.bounding_box();
                let e = hi - lo;
                let why = match (origin, format) {
                    (CellOrigin::Assumed, _) => format!(
                        "the file states no periodic cell (no `# periodic Lx Ly Lz` or \
                         `##PERIODIC::` line; YADE's export.text writes none), so it is read \
                         as a free cluster; give {cell} if it is periodic, or {free} to say \
                         so. A free cluster's"
                    ),
                    (CellOrigin::Chosen, PackingFormat::LiggghtsData) => format!(
                        "{free}: the LIGGGHTS box is walled, no bonds across its faces; the \
                         free cluster's"
                    ),
                    _ => "a free cluster:".to_string(),
                };
                Some(format!(
                    "{name}: {why} volume is the bounding box of the spheres, {:e} × {:e} × \
                     {:e} m = {:e} m³",
                    e.x,
                    e.y,
                    e.z,
                    p.volume()
                ))
            }
            _ => None,
        }
    }
}

/// Read a packing file like [`read_packing`], deciding a cell the file does not state by
/// `choice` and saying where the cell came from.
pub fn read_packing_as(path: &Path, choice: CellChoice) -> Result<PackingRead> {
    let text = crate::io::read_to_string(path)?;
    parse_packing_as(&text, &path.display().to_string(), choice)
}

/// Parse packing text like [`parse_packing`], with a [`CellChoice`] (see [`read_packing_as`]).
pub fn parse_packing_as(text: &str, source: &str, choice: CellChoice) -> Result<PackingRead> {
    let format = detect_format(text);
    let mut bonds = None;
    let (packing, origin) = match format {
        PackingFormat::LiggghtsData => {
            let (p, origin, b) = data_as(text, source, choice)?;
            bonds = b;
            (p, origin)
        }
        PackingFormat::Dump => (dump_as(text, source, choice)?, CellOrigin::Stated),
        PackingFormat::YadeSpherePack | PackingFormat::SpecText => {
            sphere_text_as(text, source, choice)?
        }
    };
    Ok(PackingRead {
        packing,
        format,
        origin,
        bonds,
    })
}

/// A refusal of the caller's [`CellChoice`] for `source` (no line: it is about the file).
fn refuse_choice(source: &str, what: String) -> Error {
    Error::parse(source, 0, what)
}

/// A LAMMPS / LIGGGHTS data file read with `choice`: its box is periodic (assumed when the
/// caller says nothing), walled, or periodic along some axes; `--cell` is refused (the
/// box is the cell). Also returns the file's `Bonds` section.
fn data_as(
    text: &str,
    source: &str,
    choice: CellChoice,
) -> Result<(Packing, CellOrigin, Option<DataBonds>)> {
    let (flags, origin) = match choice {
        CellChoice::AsStated => ([true; 3], CellOrigin::Assumed),
        CellChoice::Periodic => ([true; 3], CellOrigin::Chosen),
        CellChoice::Free => ([false; 3], CellOrigin::Chosen),
        CellChoice::Boundary(flags) => (flags, CellOrigin::Chosen),
        CellChoice::Cell(_) => {
            return Err(refuse_choice(
                source,
                "a LIGGGHTS data file has its box: expected --periodic (the box is the \
                 periodic cell) or --free (a walled box), not --cell"
                    .into(),
            ))
        }
    };
    let (p, b) = parse_data_boundary(text, source, flags)?;
    Ok((p, origin, b))
}

/// A dump, which states its boundary: read as stated, `choice` refused when it
/// contradicts the BOX BOUNDS flags.
fn dump_as(text: &str, source: &str, choice: CellChoice) -> Result<Packing> {
    let p = parse_dump(text, source)?;
    let flags = p.cell.map_or([false; 3], |c| c.periodic);
    let agrees = match choice {
        CellChoice::AsStated => true,
        CellChoice::Periodic => flags == [true; 3],
        CellChoice::Free => p.cell.is_none(),
        CellChoice::Boundary(b) => flags == b,
        CellChoice::Cell(_) => false,
    };
    if !agrees {
        return Err(refuse_choice(
            source,
            format!(
                "the dump's BOX BOUNDS state {}; expected no --cell, --periodic, --free or \
                 --boundary that contradicts them",
                match &p.cell {
                    Some(c) if c.is_mixed() => format!("the boundary {}", c.boundary()),
                    Some(_) => "a periodic box (pp pp pp)".to_string(),
                    None => "a non-periodic box".to_string(),
                }
            ),
        ));
    }
    Ok(p)
}

/// SPEC / YADE text read with `choice`: a stated cell (or `# free`) must agree with it;
/// without one the choice decides (a free cluster when the caller says nothing; a
/// periodic cell needs its lengths, `--cell`).
fn sphere_text_as(text: &str, source: &str, choice: CellChoice) -> Result<(Packing, CellOrigin)> {
    let (p, stated) = parse_sphere_text(text, source)?;
    if stated {
        let agrees = match choice {
            CellChoice::AsStated => true,
            CellChoice::Periodic | CellChoice::Boundary([true, true, true]) => p.cell.is_some(),
            CellChoice::Free => p.cell.is_none(),
            CellChoice::Boundary(_) => false,
            CellChoice::Cell(l) => p.cell.is_some_and(|c| c.lengths == l),
        };
        if !agrees {
            let states = match &p.cell {
                Some(c) => format!(
                    "a periodic cell {} {} {}",
                    num(c.lengths.x),
                    num(c.lengths.y),
                    num(c.lengths.z)
                ),
                None => "a free cluster".into(),
            };
            return Err(refuse_choice(
                source,
                format!(
                    "the file states {states}; expected no --cell, --periodic or --free \
                     that contradicts it"
                ),
            ));
        }
        return Ok((p, CellOrigin::Stated));
    }
    match choice {
        CellChoice::AsStated => Ok((p, CellOrigin::Assumed)),
        CellChoice::Free => Ok((p, CellOrigin::Chosen)),
        CellChoice::Periodic => Err(refuse_choice(
            source,
            "the file states no cell lengths (no `# periodic Lx Ly Lz` or \
             `##PERIODIC::` line): expected --cell Lx,Ly,Lz for a periodic \
             packing"
                .into(),
        )),
        CellChoice::Boundary(_) => Err(refuse_choice(
            source,
            "--boundary is for LAMMPS / LIGGGHTS data files and dumps, whose \
             box it makes periodic along some axes; this text file states no \
             box"
            .into(),
        )),
        CellChoice::Cell(l) => {
            let cell = PeriodicCell::new(l)?;
            let ids = p.ids;
            let mut p = Packing::new(p.positions, p.radii, Some(cell))?;
            p.ids = ids;
            Ok((p, CellOrigin::Chosen))
        }
    }
}

/// The file formats [`parse_packing`] understands.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PackingFormat {
    /// `x y z r` lines, `# periodic Lx Ly Lz` header (also YADE `export.text`).
    SpecText,
    /// YADE `SpherePack.save`: `##PERIODIC:: Lx Ly Lz` then `x y z r clumpId` (or `x y z r`).
    YadeSpherePack,
    /// LIGGGHTS / LAMMPS data file, `atom_style granular`.
    LiggghtsData,
    /// LIGGGHTS / LAMMPS `dump custom` (or `dump atom`) snapshot: `ITEM: BOX BOUNDS` with the
    /// boundary flags per axis, `ITEM: ATOMS` with named columns (`parse_dump`).
    Dump,
}

/// The lines of `text` without a leading UTF-8 BOM, split at `\n`, `\r\n` or a lone `\r`
/// (classic Mac files), so that the k-th entry is line k + 1 as an editor counts it.
pub fn text_lines(text: &str) -> Vec<&str> {
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    let bytes = text.as_bytes();
    let mut lines = Vec::new();
    let mut start = 0;
    let mut k = 0;
    while k < bytes.len() {
        match bytes[k] {
            b'\n' => {
                lines.push(&text[start..k]);
                start = k + 1;
            }
            b'\r' => {
                lines.push(&text[start..k]);
                if bytes.get(k + 1) == Some(&b'\n') {
                    k += 1;
                }
                start = k + 1;
            }
            _ => {}
        }
        k += 1;
    }
    if start < bytes.len() {
        lines.push(&text[start..]);
    }
    lines
}

/// Guess the format of packing text from its content.
pub fn detect_format(text: &str) -> PackingFormat {
    let mut yade = false;
    for line in text_lines(text) {
        let t = line.trim();
        if t.starts_with("ITEM:") {
            return PackingFormat::Dump;
        }
        if t.starts_with("##PERIODIC::") {
            yade = true;
        }
        let body = t.split('#').next().unwrap_or("").trim();
        let words: Vec<&str> = body.split_whitespace().collect();
        if words.first() == Some(&"Atoms") {
            return PackingFormat::LiggghtsData;
        }
        if words.len() == 2 && words[1] == "atoms" && words[0].parse::<u64>().is_ok() {
            return PackingFormat::LiggghtsData;
        }
    }
    if yade {
        PackingFormat::YadeSpherePack
    } else {
        PackingFormat::SpecText
    }
}

fn parse_number(word: &str, what: &str, source: &str, line: usize) -> Result<f64> {
    let v: f64 = word.parse().map_err(|_| {
        Error::parse(
            source,
            line,
            format!("expected a number for {what}, found `{word}`"),
        )
    })?;
    if v.is_nan() {
        return Err(Error::parse(source, line, format!("{what} is NaN")));
    }
    if !v.is_finite() {
        return Err(Error::parse(
            source,
            line,
            format!("{what} must be finite, found `{word}`"),
        ));
    }
    Ok(v)
}

/// A non-negative integer, refused as "expected {what}, found `word`".
fn parse_count<T: std::str::FromStr>(
    word: &str,
    what: &str,
    source: &str,
    line: usize,
) -> Result<T> {
    word.parse()
        .map_err(|_| Error::parse(source, line, format!("expected {what}, found `{word}`")))
}

/// Refuse the `words` of `line` unless there are as many as one of `counts`; `expected`
/// words the refusal from the number found.
fn check_word_count(
    words: &[&str],
    counts: &[usize],
    source: &str,
    line: usize,
    expected: impl FnOnce(usize) -> String,
) -> Result<()> {
    if counts.contains(&words.len()) {
        Ok(())
    } else {
        Err(Error::parse(source, line, expected(words.len())))
    }
}

/// [`parse_number`], refused unless > 0 (`shown` names the value in that refusal).
fn parse_positive(word: &str, what: &str, shown: &str, source: &str, line: usize) -> Result<f64> {
    let v = parse_number(word, what, source, line)?;
    if v <= 0.0 {
        return Err(Error::parse(
            source,
            line,
            format!("{shown} must be > 0, found {v}"),
        ));
    }
    Ok(v)
}

/// "overflows" or "underflows to 0" for a derived quantity `v` that is not finite and > 0.
fn out_of_range(v: f64) -> &'static str {
    if v.is_finite() {
        "underflows to 0"
    } else {
        "overflows"
    }
}

/// Check the cell lengths of a header on `line` ([`PeriodicCell::check_lengths`], the
/// check `--cell` takes too): each finite and > 0, and their product Lx·Ly·Lz, which may
/// overflow (1e300³) or underflow while each length is fine.
fn check_cell_volume(l: &Vec3, source: &str, line: usize) -> Result<()> {
    match PeriodicCell::check_lengths(l) {
        Some(problem) => Err(Error::parse(source, line, problem)),
        None => Ok(()),
    }
}

fn parse_cell_lengths(words: &[&str], source: &str, line: usize, header: &str) -> Result<Vec3> {
    check_word_count(words, &[3], source, line, |found| {
        format!("expected `{header} Lx Ly Lz` with 3 cell lengths, found {found} value(s)")
    })?;
    let mut l = Vec3::zeros();
    for (k, w) in words.iter().enumerate() {
        let name = ["Lx", "Ly", "Lz"][k];
        l[k] = parse_number(w, &format!("cell length {name}"), source, line)?;
    }
    check_cell_volume(&l, source, line)?;
    Ok(l)
}

/// Spheres as read, each with the line it came from, and their running total volume.
#[derive(Default)]
struct Spheres {
    positions: Vec<Vec3>,
    radii: Vec<f64>,
    lines: Vec<usize>,
    solid_volume: f64,
}

impl Spheres {
    /// Add a sphere read on `line`; refuses a radius whose volume 4/3·π·r³ overflows or
    /// underflows to 0, and a total sphere volume that overflows (both feed the solid
    /// fraction and every tensor). `radius_word` names the column the radius came from.
    fn push(
        &mut self,
        x: Vec3,
        r: f64,
        radius_word: &str,
        source: &str,
        line: usize,
    ) -> Result<()> {
        if r <= 0.0 {
            return Err(Error::parse(
                source,
                line,
                format!("radius must be > 0, found {r} (from {radius_word})"),
            ));
        }
        let v = 4.0 / 3.0 * std::f64::consts::PI * r * r * r;
        if !v.is_finite() || v <= 0.0 {
            return Err(Error::parse(
                source,
                line,
                format!(
                    "the sphere volume 4/3·π·r³ = {v:e} m³ of radius r = {r:e} m (from \
                     {radius_word}) {}; expected a radius between about 1e-100 and 1e100 m",
                    out_of_range(v)
                ),
            ));
        }
        let total = self.solid_volume + v;
        if !total.is_finite() {
            return Err(Error::parse(
                source,
                line,
                format!(
                    "the total sphere volume Σ 4/3·π·r³ overflows at this sphere ({:e} m³ \
                     before it, {v:e} m³ for it); expected radii whose volumes add up to a \
                     finite number",
                    self.solid_volume
                ),
            ));
        }
        self.solid_volume = total;
        self.positions.push(x);
        self.radii.push(r);
        self.lines.push(line);
        Ok(())
    }
}

/// Where a packing's periodic cell was declared, for error messages.
struct CellSource {
    lengths: Vec3,
    /// The header line (the first box-bounds line for LIGGGHTS data).
    line: usize,
    /// The periodic axes (all, but for a box of mixed periodicity).
    periodic: [bool; 3],
}

/// The checked packing: refuses a file without particles (`empty_hint` says what a
/// particle line looks like), positions too far outside the cell to be wrapped, and a
/// solid fraction (total sphere volume / cell or bounding-box volume) that is not finite
/// and > 0. Spheres are taken in the order given.
fn finish(
    source: &str,
    spheres: Spheres,
    cell: Option<CellSource>,
    empty_hint: &str,
) -> Result<Packing> {
    if spheres.radii.is_empty() {
        return Err(Error::parse(
            source,
            0,
            format!("no particles: {empty_hint}"),
        ));
    }
    let volume = match &cell {
        Some(c) => {
            // Wrapping divides by L and counts the shift in an i32: a position more than
            // 2³¹ cell lengths out has lost every digit that would place it in the cell.
            for (p, &line) in spheres.positions.iter().zip(&spheres.lines) {
                for k in (0..3).filter(|&k| c.periodic[k]) {
                    let cells = (p[k] / c.lengths[k]).abs();
                    if !cells.is_finite() || cells >= 2_147_483_647.0 {
                        return Err(Error::parse(
                            source,
                            line,
                            format!(
                                "{} = {:e} lies {cells:e} cell lengths L{} = {:e} from the \
                                 cell; expected a position within 2³¹ cell lengths",
                                ["x", "y", "z"][k],
                                p[k],
                                ["x", "y", "z"][k],
                                c.lengths[k]
                            ),
                        ));
                    }
                }
            }
            c.lengths.x * c.lengths.y * c.lengths.z
        }
        None => free_volume(source, &spheres)?,
    };
    let phi = spheres.solid_volume / volume;
    if !phi.is_finite() || phi <= 0.0 {
        let (line, what) = match &cell {
            Some(c) => (c.line, format!("the cell volume {volume:e} m³")),
            None => (0, format!("the bounding-box volume {volume:e} m³")),
        };
        return Err(Error::parse(
            source,
            line,
            format!(
                "the solid fraction (total sphere volume {:e} m³ / {what}) {}; expected \
                 cell and radii of compatible sizes",
                spheres.solid_volume,
                out_of_range(phi)
            ),
        ));
    }
    let cell = match cell {
        Some(c) => Some(
            PeriodicCell::with_periodic(c.lengths, c.periodic)
                .map_err(|e| Error::parse(source, c.line, e.to_string()))?,
        ),
        None => None,
    };
    Packing::new(spheres.positions, spheres.radii, cell)
        .map_err(|e| Error::parse(source, 0, e.to_string()))
}

/// Bounding-box volume of a free packing (spheres included), refused naming the lines of
/// the two extreme spheres when an edge or the volume overflows or underflows.
fn free_volume(source: &str, s: &Spheres) -> Result<f64> {
    let mut volume = 1.0;
    for k in 0..3 {
        let (mut lo, mut hi) = ((f64::INFINITY, 0), (f64::NEG_INFINITY, 0));
        for (i, (p, r)) in s.positions.iter().zip(&s.radii).enumerate() {
            if p[k] - r < lo.0 {
                lo = (p[k] - r, i);
            }
            if p[k] + r > hi.0 {
                hi = (p[k] + r, i);
            }
        }
        let edge = hi.0 - lo.0;
        volume *= edge;
        if !edge.is_finite() || !volume.is_finite() || volume <= 0.0 {
            let axis = ["x", "y", "z"][k];
            return Err(Error::parse(
                source,
                s.lines[lo.1],
                format!(
                    "the bounding box of the spheres (lines {} and {} are its {axis} ends, \
                     {:e} to {:e} m) has a volume that {}; expected positions and radii whose \
                     box volume is a finite number > 0",
                    s.lines[lo.1],
                    s.lines[hi.1],
                    lo.0,
                    hi.0,
                    out_of_range(if edge.is_finite() { volume } else { edge })
                ),
            ));
        }
    }
    Ok(volume)
}

/// What a particle line of SPEC / YADE text looks like (for the "no particles" error).
const SPHERE_LINE_HINT: &str = "expected lines `x y z r` (one sphere per line; `#` starts a \
                                comment, `# periodic Lx Ly Lz` declares a periodic cell)";

/// The columns of a sphere line, fixed by a `#format` line (YADE `export.textExt`) or, without
/// one, `x y z r` with an optional fifth column clumpId (YADE `SpherePack.save`).
#[derive(Clone, Copy, PartialEq, Eq, Default)]
enum SphereColumns {
    /// No `#format` line: `x y z r` or `x y z r clumpId`.
    #[default]
    Plain,
    /// `#format x_y_z_r`.
    Xyzr,
    /// `#format x_y_z_r_matId`: an integer material id after the radius (ignored).
    XyzrMatId,
    /// `#format x_y_z_r_attrs`: any number of attribute columns after the radius (ignored),
    /// the same number on every line (the first sphere line sets it).
    XyzrAttrs(Option<usize>),
    /// `#format id_x_y_z_r_matId`: body id, `x y z r`, material id.
    IdXyzrMatId,
}

/// The supported `#format` names, for the refusal of any other.
const SPHERE_FORMATS: &str = "`x_y_z_r`, `x_y_z_r_matId`, `x_y_z_r_attrs` or `id_x_y_z_r_matId` \
                              (the formats of YADE's export.textExt that give spheres)";

/// Parse an integer column (YADE clumpId, matId or body id) of a sphere line.
fn parse_integer(word: &str, what: &str, source: &str, line: usize) -> Result<i64> {
    word.parse().map_err(|_| {
        Error::parse(
            source,
            line,
            format!("expected an integer {what}, found `{word}`"),
        )
    })
}

/// Parse SPEC text or YADE SpherePack / `export.text` text; also says whether the text
/// states its cell (a `# periodic` / `##PERIODIC::` header, a `# free` line, or YADE
/// SpherePack.save's clumpId column, written with the header whenever the pack is periodic).
fn parse_sphere_text(text: &str, source: &str) -> Result<(Packing, bool)> {
    let mut s = SphereText::default();
    for (k, raw) in text_lines(text).into_iter().enumerate() {
        let line = k + 1;
        let t = raw.trim();
        if t.starts_with('#') {
            s.comment(t, source, line)?;
            continue;
        }
        let body = t.split('#').next().unwrap_or("");
        let words: Vec<&str> = body.split_whitespace().collect();
        if words.is_empty() {
            continue;
        }
        s.check_count(words.len(), source, line)?;
        let first = usize::from(s.columns == SphereColumns::IdXyzrMatId);
        if first == 1 {
            s.body_id(words[0], source, line)?;
        }
        let x = parse_number(words[first], "x", source, line)?;
        let y = parse_number(words[first + 1], "y", source, line)?;
        let z = parse_number(words[first + 2], "z", source, line)?;
        let r = parse_number(words[first + 3], "radius r", source, line)?;
        s.check_extra_columns(&words, source, line)?;
        s.spheres.push(Vec3::new(x, y, z), r, "r", source, line)?;
    }
    s.finish(source)
}

/// What [`parse_sphere_text`] has read so far.
#[derive(Default)]
struct SphereText {
    spheres: Spheres,
    /// The periodic cell's lengths and header line.
    cell: Option<(Vec3, usize)>,
    columns: SphereColumns,
    /// A SpherePack.save clumpId column was seen (it states a free pack without a header).
    stated_free: bool,
    /// The line of a `# free` comment.
    free_line: Option<usize>,
    /// Body ids (`#format id_x_y_z_r_matId`), and the line of each.
    ids: Vec<u64>,
    id_lines: std::collections::HashMap<u64, usize>,
}

impl SphereText {
    /// A comment line: the cell headers `##PERIODIC::` and `# periodic`, `# free`, and
    /// `#format` (the columns of the sphere lines); any other comment is ignored.
    fn comment(&mut self, t: &str, source: &str, line: usize) -> Result<()> {
        if let Some(rest) = t.strip_prefix("##PERIODIC::") {
            let words: Vec<&str> = rest.split_whitespace().collect();
            let l = parse_cell_lengths(&words, source, line, "##PERIODIC::")?;
            return set_cell(&mut self.cell, l, source, line);
        }
        let words: Vec<&str> = t[1..].split_whitespace().collect();
        if words
            .first()
            .is_some_and(|w| w.eq_ignore_ascii_case("periodic"))
        {
            let l = parse_cell_lengths(&words[1..], source, line, "# periodic")?;
            set_cell(&mut self.cell, l, source, line)?;
        } else if words.len() == 1 && words[0].eq_ignore_ascii_case("free") {
            self.free_line = Some(line);
        } else if t.starts_with("#format") {
            self.columns = match words.get(1).copied() {
                Some("x_y_z_r") => SphereColumns::Xyzr,
                Some("x_y_z_r_matId") => SphereColumns::XyzrMatId,
                Some("x_y_z_r_attrs") => SphereColumns::XyzrAttrs(None),
                Some("id_x_y_z_r_matId") => SphereColumns::IdXyzrMatId,
                other => {
                    return Err(Error::parse(
                        source,
                        line,
                        format!(
                            "unsupported `#format {}`: expected {SPHERE_FORMATS}",
                            other.unwrap_or("")
                        ),
                    ))
                }
            };
        }
        Ok(())
    }

    /// Check that a sphere line has the `n` columns its format asks for; the first line of
    /// `x_y_z_r_attrs` fixes the count for the others, and a fifth plain column (clumpId)
    /// states a free pack.
    fn check_count(&mut self, n: usize, source: &str, line: usize) -> Result<()> {
        let expected = match self.columns {
            SphereColumns::Plain if n == 4 || n == 5 => {
                self.stated_free |= n == 5;
                None
            }
            SphereColumns::Plain => {
                return Err(Error::parse(
                    source,
                    line,
                    format!(
                        "expected 4 numbers `x y z r`, found {n} (or 5, `x y z r clumpId`, \
                         as YADE's SpherePack.save writes)"
                    ),
                ))
            }
            SphereColumns::Xyzr if n == 4 => None,
            SphereColumns::Xyzr => Some("4 numbers `x y z r`".to_string()),
            SphereColumns::XyzrMatId if n == 5 => None,
            SphereColumns::XyzrMatId => Some("5 numbers `x y z r matId`".to_string()),
            SphereColumns::XyzrAttrs(None) if n >= 4 => {
                self.columns = SphereColumns::XyzrAttrs(Some(n));
                None
            }
            SphereColumns::XyzrAttrs(None) => {
                Some("at least 4 numbers `x y z r attrs…`".to_string())
            }
            SphereColumns::XyzrAttrs(Some(m)) if n == m => None,
            SphereColumns::XyzrAttrs(Some(m)) => Some(format!(
                "{m} numbers `x y z r` and {} attribute value(s), as on the first sphere line",
                m - 4
            )),
            SphereColumns::IdXyzrMatId if n == 6 => None,
            SphereColumns::IdXyzrMatId => Some("6 numbers `id x y z r matId`".to_string()),
        };
        match expected {
            Some(expected) => Err(Error::parse(
                source,
                line,
                format!("expected {expected}, found {n}"),
            )),
            None => Ok(()),
        }
    }

    /// The body id of column 1 (`#format id_x_y_z_r_matId`): ≥ 0 and not given twice.
    fn body_id(&mut self, word: &str, source: &str, line: usize) -> Result<()> {
        let id = parse_integer(word, "body id (column 1)", source, line)?;
        if id < 0 {
            return Err(Error::parse(
                source,
                line,
                format!("body id (column 1) must be ≥ 0, found {id}"),
            ));
        }
        if let Some(first) = self.id_lines.insert(id as u64, line) {
            return Err(Error::parse(
                source,
                line,
                format!("body id {id} appears twice (also line {first})"),
            ));
        }
        self.ids.push(id as u64);
        Ok(())
    }

    /// Check the columns after the radius: a clumpId must be −1 (a clump member is part of
    /// one rigid body, not a sphere to bond), a matId an integer, attributes numbers.
    fn check_extra_columns(&self, words: &[&str], source: &str, line: usize) -> Result<()> {
        let n = words.len();
        match self.columns {
            SphereColumns::Plain if n == 5 => {
                let clump = parse_integer(words[4], "clumpId (column 5)", source, line)?;
                if clump != -1 {
                    return Err(Error::parse(
                        source,
                        line,
                        format!(
                            "this sphere belongs to clump {clump} (column 5 of YADE's \
                             SpherePack.save is the clumpId); anisobond bonds free spheres \
                             only, expected clumpId -1 (a clump is one rigid body: save the \
                             pack without clumps, or write its spheres without column 5 to \
                             bond each member as a sphere)"
                        ),
                    ));
                }
            }
            SphereColumns::XyzrMatId | SphereColumns::IdXyzrMatId => {
                parse_integer(words[n - 1], &format!("matId (column {n})"), source, line)?;
            }
            SphereColumns::XyzrAttrs(_) => {
                for (c, w) in words.iter().enumerate().skip(4) {
                    parse_number(w, &format!("attribute (column {})", c + 1), source, line)?;
                }
            }
            _ => {}
        }
        Ok(())
    }

    /// The checked packing (see [`finish`]) with its body ids, and whether the text stated
    /// its cell; a periodic cell and `# free` in one file are refused.
    fn finish(self, source: &str) -> Result<(Packing, bool)> {
        if let (Some(free), Some((_, line))) = (self.free_line, self.cell) {
            return Err(Error::parse(
                source,
                line.max(free),
                format!(
                    "a periodic cell (line {line}) and `# free` (line {free}) in one file; \
                     expected one of them"
                ),
            ));
        }
        let stated = self.stated_free || self.free_line.is_some() || self.cell.is_some();
        let cell = self.cell.map(|(lengths, line)| CellSource {
            lengths,
            line,
            periodic: [true; 3],
        });
        let packing = finish(source, self.spheres, cell, SPHERE_LINE_HINT)?;
        let packing = if self.columns == SphereColumns::IdXyzrMatId {
            packing
                .with_ids(self.ids)
                .map_err(|e| Error::parse(source, 0, e.to_string()))?
        } else {
            packing
        };
        Ok((packing, stated))
    }
}

fn set_cell(cell: &mut Option<(Vec3, usize)>, l: Vec3, source: &str, line: usize) -> Result<()> {
    if let Some((_, first)) = cell {
        return Err(Error::parse(
            source,
            line,
            format!("second periodic cell header (the first is on line {first})"),
        ));
    }
    *cell = Some((l, line));
    Ok(())
}

/// Read a LIGGGHTS `atom_style granular` data file. With `periodic` the box is the
/// periodic cell (`boundary p p p` assumed) and positions are shifted by the box origin
/// into [0, L); without it the packing is free and positions are kept as written.
pub fn read_liggghts_data(path: &Path, periodic: bool) -> Result<Packing> {
    let text = crate::io::read_to_string(path)?;
    parse_liggghts_data(&text, &path.display().to_string(), periodic)
}

/// Words of a LAMMPS data file line after removing the `#` comment.
fn data_words(raw: &str) -> Vec<&str> {
    raw.split('#')
        .next()
        .unwrap_or("")
        .split_whitespace()
        .collect()
}

const LAMMPS_SECTIONS: &[&str] = &[
    "Atoms",
    "Velocities",
    "Masses",
    "Bonds",
    "Angles",
    "Dihedrals",
    "Impropers",
    "Ellipsoids",
    "Lines",
    "Triangles",
    "Bodies",
    "Pair",
    "PairIJ",
    "Bond",
    "Angle",
    "Dihedral",
    "Improper",
    "BondBond",
    "BondAngle",
    "MiddleBondTorsion",
    "EndBondTorsion",
    "AngleTorsion",
    "AngleAngleTorsion",
    "BondBond13",
    "AngleAngle",
];

/// What the atoms of a LAMMPS / LIGGGHTS data file look like (for the "no particles" error).
const ATOMS_HINT: &str = "expected a header line `N atoms` with N ≥ 1 and an `Atoms # granular` \
                          (or `# sphere`) section of N lines `id type diameter density x y z`, \
                          or `Atoms # bpm/sphere` with lines `id molecule type diameter density \
                          x y z` (each optionally followed by 3 integer image flags)";

/// The atom styles of a data file's `Atoms` section that anisobond reads.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum AtomStyle {
    /// LIGGGHTS `granular` or LAMMPS `sphere` (or no style comment): `id type diameter
    /// density x y z`.
    Sphere,
    /// LAMMPS `bpm/sphere`: `id molecule-ID type diameter density x y z` (the molecule id
    /// is not used).
    BpmSphere,
}

impl AtomStyle {
    /// The columns of an atom line before the optional image flags.
    fn columns(self) -> usize {
        match self {
            AtomStyle::Sphere => 7,
            AtomStyle::BpmSphere => 8,
        }
    }

    /// The column names, for refusals.
    fn names(self) -> &'static str {
        match self {
            AtomStyle::Sphere => "id type diameter density x y z",
            AtomStyle::BpmSphere => "id molecule type diameter density x y z",
        }
    }
}

/// The bond network of a data file's `Bonds` section (`id type atom1 atom2`): the user's
/// own topology, each bond between two particles of the packing read with it.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct DataBonds {
    /// First particle of each bond (index into the packing, which is sorted by atom id).
    pub i: Vec<u32>,
    /// Second particle of each bond (index), as the file lists it (not necessarily > i).
    pub j: Vec<u32>,
    /// Each bond's type (column 2, ≥ 1).
    pub types: Vec<u32>,
    /// Each bond's id (column 1).
    pub ids: Vec<u64>,
    /// The line of each bond in the file.
    pub lines: Vec<usize>,
    /// The `N bond types` of the header, if given.
    pub n_types: Option<u32>,
}

impl DataBonds {
    /// Number of bonds.
    pub fn len(&self) -> usize {
        self.i.len()
    }

    /// True when the section lists no bond.
    pub fn is_empty(&self) -> bool {
        self.i.is_empty()
    }

    /// Number of distinct bond types used.
    pub fn distinct_types(&self) -> usize {
        let mut t = self.types.clone();
        t.sort_unstable();
        t.dedup();
        t.len()
    }
}

/// One atom line of a data file.
struct Atom {
    id: u64,
    atom_type: u64,
    position: Vec3,
    diameter: f64,
    line: usize,
}

/// Parse one atom line of the Atoms section of `style` (optionally followed by 3 image
/// flags).
fn parse_atom(words: &[&str], style: AtomStyle, source: &str, line: usize) -> Result<Atom> {
    let c = style.columns();
    check_word_count(words, &[c, c + 3], source, line, |found| {
        format!(
            "expected {c} values `{}` (optionally followed by 3 image flags), found {found}",
            style.names()
        )
    })?;
    let id: u64 = parse_count(words[0], "a positive integer atom id", source, line)?;
    // LAMMPS/LIGGGHTS atom ids and types start at 1 (read_data refuses 0).
    if id == 0 {
        return Err(Error::parse(
            source,
            line,
            "atom id (column 1) must be ≥ 1 (LAMMPS/LIGGGHTS ids start at 1), found 0",
        ));
    }
    // bpm/sphere: column 2 is the molecule id (an integer, 0 for none), not used.
    let t = usize::from(style == AtomStyle::BpmSphere);
    if t == 1 {
        parse_count::<u64>(words[1], "an integer molecule id (column 2)", source, line)?;
    }
    let atom_type: u64 = parse_count(
        words[t + 1],
        &format!("a positive integer atom type (column {})", t + 2),
        source,
        line,
    )?;
    if atom_type == 0 {
        return Err(Error::parse(
            source,
            line,
            format!(
                "atom type (column {}) must be ≥ 1 (LAMMPS/LIGGGHTS types start at 1), found 0",
                t + 2
            ),
        ));
    }
    let d = parse_positive(words[t + 2], "diameter", "diameter", source, line)?;
    parse_positive(
        words[t + 3],
        "density",
        &format!("density (column {})", t + 4),
        source,
        line,
    )?;
    let x = parse_number(words[t + 4], "x", source, line)?;
    let y = parse_number(words[t + 5], "y", source, line)?;
    let z = parse_number(words[t + 6], "z", source, line)?;
    for (k, w) in words.iter().enumerate().skip(c) {
        if w.parse::<i32>().is_err() {
            return Err(Error::parse(
                source,
                line,
                format!(
                    "image flag {} (column {}) must be an integer, found `{w}`",
                    ["ix", "iy", "iz"][k - c],
                    k + 1
                ),
            ));
        }
    }
    Ok(Atom {
        id,
        atom_type,
        position: Vec3::new(x, y, z),
        diameter: d,
        line,
    })
}

/// One line `id type atom1 atom2` of the Bonds section: (id, type, atom1, atom2, line).
type BondLine = (u64, u64, u64, u64, usize);

fn parse_bond_line(words: &[&str], source: &str, line: usize) -> Result<BondLine> {
    check_word_count(words, &[4], source, line, |found| {
        format!("expected 4 values `id type atom1 atom2` in the Bonds section, found {found}")
    })?;
    let names = [
        "bond id (column 1)",
        "bond type (column 2)",
        "atom1 (column 3)",
        "atom2 (column 4)",
    ];
    let mut v = [0u64; 4];
    for k in 0..4 {
        v[k] = parse_count(
            words[k],
            &format!("a positive integer {}", names[k]),
            source,
            line,
        )?;
        if v[k] == 0 {
            return Err(Error::parse(
                source,
                line,
                format!(
                    "{} must be ≥ 1 (LAMMPS numbers them from 1), found 0",
                    names[k]
                ),
            ));
        }
    }
    Ok((v[0], v[1], v[2], v[3], line))
}

/// Parse LIGGGHTS data text (see [`read_liggghts_data`]). Atoms are sorted by id. A
/// `Bonds` section is checked but not returned (see [`parse_data`]).
pub fn parse_liggghts_data(text: &str, source: &str, periodic: bool) -> Result<Packing> {
    Ok(parse_data(text, source, periodic)?.0)
}

/// Parse a LAMMPS / LIGGGHTS data file: `Atoms # granular`, `# sphere` (or no style
/// comment: `id type diameter density x y z`) or `# bpm/sphere` (`id molecule type diameter
/// density x y z`), each with optional image flags; atoms sorted by id, their ids kept. With
/// `periodic` the box is the periodic cell and positions are shifted by the box origin into
/// [0, L); without it the packing is free and positions are kept as written. A `Bonds`
/// section (`id type atom1 atom2`) is returned as the file's bond network ([`DataBonds`]),
/// checked: its count against the header's `N bonds`, types from 1 to `N bond types`, atoms
/// that exist, no atom bonded to itself, no pair twice; in a free packing, a bond spanning
/// more than half the box along an axis (it crosses a periodic face) is refused.
pub fn parse_data(
    text: &str,
    source: &str,
    periodic: bool,
) -> Result<(Packing, Option<DataBonds>)> {
    parse_data_boundary(text, source, [periodic; 3])
}

/// [`parse_data`] with the box periodic along the axes flagged in `periodic` (LAMMPS
/// `boundary p p f`: a settled bed); along the others the box is a wall: positions are
/// not wrapped and no bond crosses its faces. All false: a free packing.
pub fn parse_data_boundary(
    text: &str,
    source: &str,
    periodic: [bool; 3],
) -> Result<(Packing, Option<DataBonds>)> {
    let lines = text_lines(text);
    // The lines that are not blank after their comment: (line number, text, words). Line 1
    // is the title and always skipped (LAMMPS rule).
    let mut rows = lines
        .iter()
        .enumerate()
        .skip(1)
        .map(|(k, raw)| (k + 1, *raw, data_words(raw)))
        .filter(|(_, _, words)| !words.is_empty())
        .peekable();
    let header = data_header(&mut rows, source)?;
    let mut sections = data_sections(&mut rows, source)?;
    check_atoms(&header, &mut sections, source)?;
    let atoms = &sections.atoms;
    let data_bonds = data_bonds(
        &sections.bond_rows,
        sections.bonds_line,
        header.n_bonds,
        header.n_bond_types,
        atoms,
        source,
    )?;
    let cell = data_cell(&header.bounds, periodic, source)?;
    if let Some(b) = &data_bonds {
        check_bonds_in_box(b, atoms, &header.bounds, periodic, source)?;
    }
    let mut spheres = Spheres::default();
    for a in atoms {
        let mut p = a.position;
        if let Some((lo, _)) = &cell {
            p -= lo;
            if p.iter().any(|c| !c.is_finite()) {
                return Err(Error::parse(
                    source,
                    a.line,
                    format!(
                        "the position shifted by the box origin, ({:e}, {:e}, {:e}) − ({:e}, \
                         {:e}, {:e}), overflows; expected atoms near the box",
                        a.position.x, a.position.y, a.position.z, lo.x, lo.y, lo.z
                    ),
                ));
            }
        }
        spheres.push(p, 0.5 * a.diameter, "diameter / 2", source, a.line)?;
    }
    let packing = finish(source, spheres, cell.map(|c| c.1), ATOMS_HINT)?
        .with_ids(atoms.iter().map(|a| a.id).collect())
        .map_err(|e| Error::parse(source, 0, e.to_string()))?;
    Ok((packing, data_bonds))
}

/// A line of a data file that is not blank after its comment: (line number, text, words).
type DataRow<'a> = (usize, &'a str, Vec<&'a str>);

/// True for a row that does not start a section (a header line or a section's body line).
fn not_section(row: &DataRow) -> bool {
    !LAMMPS_SECTIONS.contains(&row.2[0])
}

/// The header of a data file, each count or bound with the line that gave it.
#[derive(Default)]
struct DataHeader {
    n_atoms: Option<(usize, usize)>,
    n_types: Option<(u64, usize)>,
    n_bonds: Option<(usize, usize)>,
    n_bond_types: Option<(u64, usize)>,
    /// `lo hi xlo xhi` (and y, z): (lo, hi, line).
    bounds: [Option<(f64, f64, usize)>; 3],
}

/// Read the header lines up to the first section name: the counts anisobond checks the
/// sections against and the box (other header lines, e.g. `extra bond per atom`, are
/// irrelevant and skipped).
fn data_header<'a, I: Iterator<Item = DataRow<'a>>>(
    rows: &mut std::iter::Peekable<I>,
    source: &str,
) -> Result<DataHeader> {
    let mut h = DataHeader::default();
    while let Some((line, _, words)) = rows.next_if(not_section) {
        let n_words = words.len();
        if n_words == 2 && words[1] == "atoms" {
            h.n_atoms = Some((header_count(&words, "an atom count", source, line)?, line));
        } else if n_words == 2 && words[1] == "bonds" {
            h.n_bonds = Some((header_count(&words, "a bond count", source, line)?, line));
        } else if n_words == 3 && words[1..] == ["bond", "types"] {
            h.n_bond_types = Some((
                header_count(&words, "a bond type count", source, line)?,
                line,
            ));
        } else if n_words == 4 && words[2].ends_with("lo") && words[3].ends_with("hi") {
            let (axis, lo, hi) = data_box_bounds(&words, source, line)?;
            h.bounds[axis] = Some((lo, hi, line));
        } else if n_words == 6 && words[3..] == ["xy", "xz", "yz"] {
            for w in &words[..3] {
                let t = parse_number(w, "tilt factor", source, line)?;
                if t != 0.0 {
                    return Err(Error::parse(
                        source,
                        line,
                        "triclinic boxes are not supported: expected tilt factors 0 0 0",
                    ));
                }
            }
        } else if n_words == 3 && words[1..] == ["atom", "types"] {
            h.n_types = Some((
                header_count(&words, "an atom type count", source, line)?,
                line,
            ));
        }
    }
    Ok(h)
}

/// The count N of a header line `N atoms`, `N bond types`, …, refused as "expected {what}
/// in `N …`" (the line's own words).
fn header_count<T: std::str::FromStr>(
    words: &[&str],
    what: &str,
    source: &str,
    line: usize,
) -> Result<T> {
    let expected = format!("{what} in `N {}`", words[1..].join(" "));
    parse_count(words[0], &expected, source, line)
}

/// A header line `lo hi xlo xhi` (or y, z): the axis and its bounds, refused unless
/// hi > lo by a finite length (the box length is the periodic cell's).
fn data_box_bounds(words: &[&str], source: &str, line: usize) -> Result<(usize, f64, f64)> {
    let axis = match (words[2], words[3]) {
        ("xlo", "xhi") => 0,
        ("ylo", "yhi") => 1,
        ("zlo", "zhi") => 2,
        _ => {
            return Err(Error::parse(
                source,
                line,
                format!(
                    "expected `lo hi xlo xhi` (or ylo yhi, zlo zhi), found `{} {}`",
                    words[2], words[3]
                ),
            ))
        }
    };
    let name = ["x", "y", "z"][axis];
    let lo = parse_number(words[0], &format!("{name}lo"), source, line)?;
    let hi = parse_number(words[1], &format!("{name}hi"), source, line)?;
    if hi <= lo {
        return Err(Error::parse(
            source,
            line,
            format!("box bound {name}hi = {hi} must exceed {name}lo = {lo}"),
        ));
    }
    if !(hi - lo).is_finite() {
        return Err(Error::parse(
            source,
            line,
            format!(
                "box length {name}hi − {name}lo = {hi:e} − ({lo:e}) overflows; \
                 expected bounds whose difference is finite"
            ),
        ));
    }
    Ok((axis, lo, hi))
}

/// The `Atoms` and `Bonds` sections of a data file as read (other sections are skipped),
/// with the line of each section name.
#[derive(Default)]
struct DataSections {
    atoms: Vec<Atom>,
    atoms_line: Option<usize>,
    bond_rows: Vec<BondLine>,
    bonds_line: Option<usize>,
}

/// Read the sections after the header: each must start with a LAMMPS section name; the
/// `Atoms` and `Bonds` bodies are parsed line by line, each section at most once.
fn data_sections<'a, I: Iterator<Item = DataRow<'a>>>(
    rows: &mut std::iter::Peekable<I>,
    source: &str,
) -> Result<DataSections> {
    let mut s = DataSections::default();
    let mut style = AtomStyle::Sphere;
    while let Some((line, raw, words)) = rows.next() {
        if !LAMMPS_SECTIONS.contains(&words[0]) {
            return Err(Error::parse(
                source,
                line,
                format!(
                    "expected a section name such as `Atoms`, found `{}`",
                    raw.trim()
                ),
            ));
        }
        let is_atoms = words[0] == "Atoms";
        let is_bonds = words == ["Bonds"];
        if is_atoms {
            first_section(&mut s.atoms_line, "Atoms", source, line)?;
            if let Some(comment) = raw.split('#').nth(1).map(str::trim) {
                style = atom_style(comment, source, line)?;
            }
        }
        if is_bonds {
            first_section(&mut s.bonds_line, "Bonds", source, line)?;
        }
        // Section body: lines up to the next section name.
        while let Some((line, _, words)) = rows.next_if(not_section) {
            if is_atoms {
                s.atoms.push(parse_atom(&words, style, source, line)?);
            } else if is_bonds {
                s.bond_rows.push(parse_bond_line(&words, source, line)?);
            }
        }
    }
    Ok(s)
}

/// Note the line of section `name` in `slot`, refusing a second section of that name.
fn first_section(slot: &mut Option<usize>, name: &str, source: &str, line: usize) -> Result<()> {
    if let Some(first) = slot {
        return Err(Error::parse(
            source,
            line,
            format!("second `{name}` section (the first is on line {first})"),
        ));
    }
    *slot = Some(line);
    Ok(())
}

/// The atom style named by the comment of the `Atoms` line (`Atoms # bpm/sphere`).
fn atom_style(comment: &str, source: &str, line: usize) -> Result<AtomStyle> {
    match comment {
        "" | "granular" | "sphere" => Ok(AtomStyle::Sphere),
        "bpm/sphere" => Ok(AtomStyle::BpmSphere),
        other => Err(Error::parse(
            source,
            line,
            format!(
                "expected `Atoms # granular`, `Atoms # sphere` or `Atoms # \
                 bpm/sphere`, found atom style `{other}`"
            ),
        )),
    }
}

/// Check the atoms against the header (an `N atoms` line, that many atom lines, types
/// within `N atom types`) and sort them by id, refusing an id given twice.
fn check_atoms(h: &DataHeader, s: &mut DataSections, source: &str) -> Result<()> {
    let atoms = &mut s.atoms;
    let (n, n_line) = h.n_atoms.ok_or_else(|| {
        Error::parse(
            source,
            0,
            format!("data file: missing header line `N atoms`; {ATOMS_HINT}"),
        )
    })?;
    if n == 0 && atoms.is_empty() {
        return Err(Error::parse(
            source,
            0,
            format!("no particles: line {n_line} declares `0 atoms`; {ATOMS_HINT}"),
        ));
    }
    let Some(atoms_first) = s.atoms_line else {
        return Err(Error::parse(
            source,
            0,
            "data file: missing `Atoms` section",
        ));
    };
    if atoms.len() != n {
        return Err(Error::parse(
            source,
            atoms_first,
            format!(
                "the header (line {n_line}) declares {n} atoms but the Atoms section has {}",
                atoms.len()
            ),
        ));
    }
    if let Some((t, t_line)) = h.n_types {
        if let Some(a) = atoms.iter().find(|a| a.atom_type > t) {
            return Err(Error::parse(
                source,
                a.line,
                format!(
                    "atom type {} exceeds the {t} atom types of the header (line {t_line}): \
                     expected a type from 1 to {t}",
                    a.atom_type
                ),
            ));
        }
    }
    atoms.sort_by_key(|a| a.id);
    for w in atoms.windows(2) {
        if w[0].id == w[1].id {
            return Err(Error::parse(
                source,
                w[1].line,
                format!(
                    "atom id {} appears twice (also line {})",
                    w[1].id, w[0].line
                ),
            ));
        }
    }
    Ok(())
}

/// The periodic cell of a data file read periodic along the flagged axes: the box's lower
/// corner (positions are shifted by it into [0, L)) and its lengths; `None` when no axis
/// is periodic. Every axis needs its bounds line.
fn data_cell(
    bounds: &[Option<(f64, f64, usize)>; 3],
    periodic: [bool; 3],
    source: &str,
) -> Result<Option<(Vec3, CellSource)>> {
    if !periodic.iter().any(|&p| p) {
        return Ok(None);
    }
    let mut lo = Vec3::zeros();
    let mut len = Vec3::zeros();
    let mut first_line = usize::MAX;
    for axis in 0..3 {
        let name = ["x", "y", "z"][axis];
        let (l, h, line) = bounds[axis].ok_or_else(|| {
            Error::parse(
                source,
                0,
                format!("data file: missing header line `{name}lo {name}hi`"),
            )
        })?;
        lo[axis] = l;
        len[axis] = h - l;
        first_line = first_line.min(line);
    }
    check_cell_volume(&len, source, first_line)?;
    Ok(Some((
        lo,
        CellSource {
            lengths: len,
            line: first_line,
            periodic,
        },
    )))
}

/// Along a non-periodic axis a bond must not reach across the box: the file's bonds
/// across a periodic face would become bonds through the whole specimen.
fn check_bonds_in_box(
    b: &DataBonds,
    atoms: &[Atom],
    bounds: &[Option<(f64, f64, usize)>; 3],
    periodic: [bool; 3],
    source: &str,
) -> Result<()> {
    for k in 0..b.len() {
        let (ai, aj) = (&atoms[b.i[k] as usize], &atoms[b.j[k] as usize]);
        let d = aj.position - ai.position;
        for (axis, bound) in bounds.iter().enumerate() {
            if periodic[axis] {
                continue;
            }
            let Some((lo, hi, _)) = bound else { continue };
            if d[axis].abs() > 0.5 * (hi - lo) {
                let name = ["x", "y", "z"][axis];
                return Err(Error::parse(
                    source,
                    b.lines[k],
                    format!(
                        "bond {} between atoms {} and {} spans {:e} m along {name}, more \
                         than half the box ({:e} m): it crosses a periodic face of the \
                         box; expected the file read as periodic along {name} \
                         (--periodic, or --boundary with p for {name})",
                        b.ids[k],
                        ai.id,
                        aj.id,
                        d[axis].abs(),
                        hi - lo
                    ),
                ));
            }
        }
    }
    Ok(())
}

/// Check a Bonds section against the header's `N bonds`: each needs the other, with as
/// many rows as declared. False when there are no bonds to read (neither, or `0 bonds`).
fn bonds_declared(
    section: Option<usize>,
    n_bonds: Option<(usize, usize)>,
    n_rows: usize,
    source: &str,
) -> Result<bool> {
    match (section, n_bonds) {
        (None, None) | (None, Some((0, _))) => Ok(false),
        (None, Some((n, line))) => Err(Error::parse(
            source,
            line,
            format!("the header declares {n} bonds but the file has no `Bonds` section"),
        )),
        (Some(s), None) => Err(Error::parse(
            source,
            s,
            "a `Bonds` section without the header line `N bonds`",
        )),
        (Some(s), Some((n, line))) if n != n_rows => Err(Error::parse(
            source,
            s,
            format!(
                "the header (line {line}) declares {n} bonds but the Bonds section has {}",
                n_rows
            ),
        )),
        _ => Ok(true),
    }
}

/// The checked bond network of a data file's Bonds section (see [`parse_data`]), atoms
/// sorted by id; `None` without a Bonds section and with `0 bonds`.
fn data_bonds(
    rows: &[BondLine],
    section: Option<usize>,
    n_bonds: Option<(usize, usize)>,
    n_types: Option<(u64, usize)>,
    atoms: &[Atom],
    source: &str,
) -> Result<Option<DataBonds>> {
    if !bonds_declared(section, n_bonds, rows.len(), source)? {
        return Ok(None);
    }
    let index = |id: u64| atoms.binary_search_by_key(&id, |a| a.id).ok();
    let mut out = DataBonds {
        n_types: n_types.map(|t| t.0.min(u32::MAX as u64) as u32),
        ..Default::default()
    };
    let mut seen: std::collections::HashMap<(u32, u32), usize> = std::collections::HashMap::new();
    for &(id, t, a1, a2, line) in rows {
        if let Some((nt, nt_line)) = n_types {
            if t > nt {
                return Err(Error::parse(
                    source,
                    line,
                    format!(
                        "bond type {t} exceeds the {nt} bond types of the header (line \
                         {nt_line}): expected a type from 1 to {nt}"
                    ),
                ));
            }
        }
        if t > u32::MAX as u64 {
            return Err(Error::parse(
                source,
                line,
                format!("bond type {t} exceeds 2^32 − 1"),
            ));
        }
        let missing = |a: u64| {
            Error::parse(
                source,
                line,
                format!("bond {id} names atom {a}, which is not in the Atoms section"),
            )
        };
        let i = index(a1).ok_or_else(|| missing(a1))? as u32;
        let j = index(a2).ok_or_else(|| missing(a2))? as u32;
        if i == j {
            return Err(Error::parse(
                source,
                line,
                format!("bond {id} joins atom {a1} to itself"),
            ));
        }
        if let Some(first) = seen.insert((i.min(j), i.max(j)), line) {
            return Err(Error::parse(
                source,
                line,
                format!("atoms {a1} and {a2} are bonded twice (also line {first})"),
            ));
        }
        out.i.push(i);
        out.j.push(j);
        out.types.push(t as u32);
        out.ids.push(id);
        out.lines.push(line);
    }
    Ok((!out.is_empty()).then_some(out))
}

/// A dump's box: (lo, hi) per axis, the boundary flags per axis, the `ITEM: BOX BOUNDS` line.
type DumpBox = ([(f64, f64); 3], [String; 3], usize);

/// What a dump's `ITEM: ATOMS` line offers: the columns anisobond reads.
struct DumpColumns {
    id: Option<usize>,
    /// Positions: (x, y, z) columns and whether they are scaled (xs ys zs).
    position: ([usize; 3], bool),
    /// Radius or diameter column, and the factor that makes it a radius.
    radius: (usize, f64),
    count: usize,
}

/// The columns of `ITEM: ATOMS <names>`: `id` (optional), positions `x y z`, `xu yu zu`
/// (unwrapped) or `xs ys zs` (scaled by the box), and `radius` or `diameter`.
fn dump_columns(words: &[&str], source: &str, line: usize) -> Result<DumpColumns> {
    let find = |name: &str| words.iter().position(|w| *w == name);
    let position = [
        ("x", "y", "z", false),
        ("xu", "yu", "zu", false),
        ("xs", "ys", "zs", true),
    ]
    .iter()
    .find_map(|&(a, b, c, scaled)| Some(([find(a)?, find(b)?, find(c)?], scaled)))
    .ok_or_else(|| {
        Error::parse(
            source,
            line,
            format!(
                "`ITEM: ATOMS {}` has no positions: expected columns x y z, xu yu zu or \
                     xs ys zs",
                words.join(" ")
            ),
        )
    })?;
    let radius = match (find("radius"), find("diameter")) {
        (Some(r), _) => (r, 1.0),
        (None, Some(d)) => (d, 0.5),
        (None, None) => {
            return Err(Error::parse(
                source,
                line,
                format!(
                    "`ITEM: ATOMS {}` has no radius: expected a `radius` or `diameter` column \
                     (dump custom ... id type x y z radius)",
                    words.join(" ")
                ),
            ))
        }
    };
    Ok(DumpColumns {
        id: find("id"),
        position,
        radius,
        count: words.len(),
    })
}

/// Parse a LIGGGHTS / LAMMPS dump snapshot (`dump custom` or `dump atom` style, text).
///
/// With several snapshots the last is read (the state the run ended in). `ITEM: BOX BOUNDS`
/// gives the box; its boundary flags decide the cell: `pp pp pp` is a periodic cell (the
/// box, positions taken relative to its lower corner), any non-periodic flag on every axis
/// (`ff`, `fs`, `ss`, `fm`, …) a free cluster, mixed flags (`pp pp ff`: a settled bed) a
/// cell periodic along the `pp` axes only ([`PeriodicCell::periodic`]); triclinic boxes are
/// refused by name. Columns are found by name (`ITEM: ATOMS id type x y z radius`): `id`
/// (kept as the particles' ids, atoms sorted by it: dumps from several MPI ranks are not in
/// order), `x y z` / `xu yu zu` / `xs ys zs`, `radius` or `diameter`.
pub fn parse_dump(text: &str, source: &str) -> Result<Packing> {
    let lines = text_lines(text);
    // The last snapshot: from its last `ITEM: TIMESTEP` (or the start).
    let start = lines
        .iter()
        .rposition(|l| l.trim() == "ITEM: TIMESTEP")
        .unwrap_or(0);
    let mut k = start;
    let mut n_atoms: Option<(usize, usize)> = None;
    let mut bounds: Option<DumpBox> = None;
    let mut atoms: Vec<DumpAtom> = Vec::new();
    let mut columns: Option<(DumpColumns, usize)> = None;
    while k < lines.len() {
        let line = k + 1;
        let t = lines[k].trim();
        k += 1;
        if t.is_empty() {
            continue;
        }
        let Some(item) = t.strip_prefix("ITEM:") else {
            return Err(Error::parse(
                source,
                line,
                format!("expected an `ITEM:` line of a dump, found `{t}`"),
            ));
        };
        let words: Vec<&str> = item.split_whitespace().collect();
        match words.as_slice() {
            ["TIMESTEP"] => k += 1,
            ["NUMBER", "OF", "ATOMS"] => {
                let w = lines.get(k).map(|l| l.trim()).unwrap_or("");
                n_atoms = Some((
                    parse_count(w, "the number of atoms", source, line + 1)?,
                    line + 1,
                ));
                k += 1;
            }
            ["BOX", "BOUNDS", flags @ ..] => {
                let b = dump_box(flags, &lines[k..], line, source)?;
                k += 3;
                bounds = Some((b, [0, 1, 2].map(|a| flags[a].to_string()), line));
            }
            ["ATOMS", names @ ..] => {
                let c = dump_columns(names, source, line)?;
                let (n, n_line) = n_atoms.ok_or_else(|| {
                    Error::parse(source, line, "expected `ITEM: NUMBER OF ATOMS` before `ITEM: ATOMS`")
                })?;
                let box_lengths = bounds.as_ref().map(|(b, _, _)| b.map(|(lo, hi)| (lo, hi - lo)));
                atoms.extend(dump_atoms(&lines[k..], &c, (n, n_line), line, box_lengths, source)?);
                k += n;
                columns = Some((c, line));
            }
            _ => {
                return Err(Error::parse(
                    source,
                    line,
                    format!("expected ITEM: TIMESTEP, NUMBER OF ATOMS, BOX BOUNDS or ATOMS, found `ITEM:{item}`"),
                ))
            }
        }
    }
    let Some((columns, _)) = columns else {
        return Err(Error::parse(source, 0, "dump: no `ITEM: ATOMS` section"));
    };
    let Some(bounds) = bounds else {
        return Err(Error::parse(source, 0, "dump: no `ITEM: BOX BOUNDS`"));
    };
    dump_packing(atoms, &columns, bounds, source)
}

/// The `n` atom rows after `ITEM: ATOMS` on `line` (`rest` starts with the first row),
/// each with the columns `c` of that line (`n_line` declared the count).
fn dump_atoms(
    rest: &[&str],
    c: &DumpColumns,
    (n, n_line): (usize, usize),
    line: usize,
    box_lengths: Option<[(f64, f64); 3]>,
    source: &str,
) -> Result<Vec<DumpAtom>> {
    let mut atoms = Vec::with_capacity(n.min(rest.len()));
    for r in 0..n {
        let l = line + 1 + r;
        let w: Vec<&str> = rest
            .get(r)
            .map(|s| s.split_whitespace().collect())
            .unwrap_or_default();
        if w.len() != c.count {
            return Err(Error::parse(
                source,
                l,
                format!(
                    "expected {} values (the columns of line {line}), found {}; \
                     line {n_line} declares {n} atoms",
                    c.count,
                    w.len()
                ),
            ));
        }
        atoms.push(dump_atom(&w, c, box_lengths, r, l, source)?);
    }
    Ok(atoms)
}

/// One atom of a dump: (id, position, radius, line).
type DumpAtom = (u64, Vec3, f64, usize);

/// The three bounds lines after `ITEM: BOX BOUNDS <flags>` (on `line`; `rest` starts with
/// the line after it): (lo, hi) per axis, refused unless hi > lo by a finite length;
/// triclinic boxes (more than three flags) are refused by name.
fn dump_box(flags: &[&str], rest: &[&str], line: usize, source: &str) -> Result<[(f64, f64); 3]> {
    if flags.len() != 3 {
        return Err(Error::parse(
            source,
            line,
            format!(
                "`ITEM: BOX BOUNDS {}`: triclinic boxes are not supported; \
                 expected three boundary flags (pp pp pp, ff ff ff, …)",
                flags.join(" ")
            ),
        ));
    }
    let mut b = [(0.0, 0.0); 3];
    for (axis, slot) in b.iter_mut().enumerate() {
        let l = line + 1 + axis;
        let w: Vec<&str> = rest
            .get(axis)
            .map(|s| s.split_whitespace().collect())
            .unwrap_or_default();
        let name = ["x", "y", "z"][axis];
        if w.len() != 2 {
            return Err(Error::parse(
                source,
                l,
                format!("expected the box bounds `{name}lo {name}hi`"),
            ));
        }
        let lo = parse_number(w[0], &format!("{name}lo"), source, l)?;
        let hi = parse_number(w[1], &format!("{name}hi"), source, l)?;
        if !(hi > lo && (hi - lo).is_finite()) {
            return Err(Error::parse(
                source,
                l,
                format!("box bound {name}hi = {hi} must exceed {name}lo = {lo} by a finite length"),
            ));
        }
        *slot = (lo, hi);
    }
    Ok(b)
}

/// The `r`-th atom row `w` (on line `l`) of an `ITEM: ATOMS` section with columns `c`:
/// scaled positions are mapped through the box (lo, length) per axis, which must come
/// first; without an `id` column atoms are numbered from 1 in the order given.
fn dump_atom(
    w: &[&str],
    c: &DumpColumns,
    box_lengths: Option<[(f64, f64); 3]>,
    r: usize,
    l: usize,
    source: &str,
) -> Result<DumpAtom> {
    let mut x = Vec3::zeros();
    for a in 0..3 {
        let v = parse_number(w[c.position.0[a]], ["x", "y", "z"][a], source, l)?;
        x[a] = match (c.position.1, box_lengths) {
            (true, Some(bl)) => bl[a].0 + v * bl[a].1,
            (true, None) => {
                return Err(Error::parse(
                    source,
                    l,
                    "scaled positions need `ITEM: BOX BOUNDS` first",
                ))
            }
            (false, _) => v,
        };
    }
    let size = parse_number(w[c.radius.0], "radius", source, l)?;
    let id = match c.id {
        Some(i) => {
            let id: u64 = parse_count(w[i], "an atom id", source, l)?;
            if id == 0 {
                return Err(Error::parse(source, l, "atom id 0: LAMMPS ids start at 1"));
            }
            id
        }
        None => r as u64 + 1,
    };
    Ok((id, x, size * c.radius.1, l))
}

/// The packing of a dump's last snapshot: the cell from the boundary flags (periodic
/// along the `pp` axes, positions then taken relative to the box's lower corner), atoms
/// sorted by id (ranks write out of order), an id given twice refused.
fn dump_packing(
    mut atoms: Vec<DumpAtom>,
    columns: &DumpColumns,
    (b, flags, box_line): DumpBox,
    source: &str,
) -> Result<Packing> {
    let periodic = [0, 1, 2].map(|k| flags[k] == "pp");
    let cell = if periodic.iter().any(|&p| p) {
        let lengths = Vec3::new(b[0].1 - b[0].0, b[1].1 - b[1].0, b[2].1 - b[2].0);
        check_cell_volume(&lengths, source, box_line)?;
        Some(CellSource {
            lengths,
            line: box_line,
            periodic,
        })
    } else {
        None
    };
    let origin = Vec3::new(b[0].0, b[1].0, b[2].0);
    atoms.sort_by_key(|a| a.0);
    for w in atoms.windows(2) {
        if w[0].0 == w[1].0 {
            return Err(Error::parse(
                source,
                w[1].3,
                format!("atom id {} appears twice (also line {})", w[1].0, w[0].3),
            ));
        }
    }
    let mut spheres = Spheres::default();
    for (_, x, r, l) in &atoms {
        let p = if cell.is_some() { x - origin } else { *x };
        spheres.push(
            p,
            *r,
            if columns.radius.1 == 1.0 {
                "radius"
            } else {
                "diameter / 2"
            },
            source,
            *l,
        )?;
    }
    let hint = "expected `ITEM: ATOMS id type x y z radius` rows";
    let packing = finish(source, spheres, cell, hint)?;
    match columns.id {
        Some(_) => packing
            .with_ids(atoms.iter().map(|a| a.0).collect())
            .map_err(|e| Error::parse(source, 0, e.to_string())),
        None => Ok(packing),
    }
}

/// Shortest text that parses back to exactly `v`.
fn num(v: f64) -> String {
    let a = v.abs();
    if v == 0.0 || (1e-4..1e7).contains(&a) {
        format!("{v}")
    } else {
        format!("{v:e}")
    }
}

fn io_err(path: &Path) -> impl Fn(std::io::Error) -> Error + '_ {
    move |e| Error::io(path, e)
}

/// Write `p` in the SPEC text format (readable by YADE `ymport.text`), atomically, with
/// every number written so that it reads back bit-identical.
pub fn write_packing(path: &Path, p: &Packing) -> Result<()> {
    let text = format_packing(p);
    crate::io::write_string_atomic(path, &text)
}

/// The SPEC text of `p` (see [`write_packing`]).
pub fn format_packing(p: &Packing) -> String {
    let mut s = String::with_capacity(64 * p.len() + 128);
    s.push_str("#format x_y_z_r\n");
    let _ = writeln!(
        s,
        "# anisobond packing: {} spheres, one per line `x y z r` (m)",
        p.len()
    );
    match &p.cell {
        Some(c) => {
            let l = c.lengths;
            let _ = writeln!(s, "# periodic {} {} {}", num(l.x), num(l.y), num(l.z));
        }
        None => s.push_str("# free\n"),
    }
    // The positions as given (YADE's outside the cell included), so that the periodic
    // images of a bond table written with this packing read back the same.
    for (i, r) in p.radii.iter().enumerate() {
        let x = p.given_position(i);
        let _ = writeln!(s, "{} {} {} {}", num(x.x), num(x.y), num(x.z), num(*r));
    }
    s
}

/// Write `p` as a YADE `SpherePack` text file (`SpherePack.load`): `##PERIODIC:: Lx Ly Lz`
/// when periodic, then `x y z r` lines.
pub fn write_yade_spherepack(path: &Path, p: &Packing) -> Result<()> {
    write_lines(path, |w| {
        if let Some(c) = &p.cell {
            let l = c.lengths;
            writeln!(w, "##PERIODIC:: {} {} {}", num(l.x), num(l.y), num(l.z))?;
        }
        for (x, r) in p.positions.iter().zip(&p.radii) {
            writeln!(w, "{} {} {} {}", num(x.x), num(x.y), num(x.z), num(*r))?;
        }
        Ok(())
    })
}

/// Write `p` as a LIGGGHTS `atom_style granular` data file (ids 1…N in packing order, one
/// atom type, `density` in kg/m³). A periodic packing's box is its cell (use
/// `boundary p p p`); a free packing's box is its bounding box.
pub fn write_liggghts_data(path: &Path, p: &Packing, density: f64) -> Result<()> {
    write_liggghts_data_ids(path, p, density, false)
}

/// [`write_liggghts_data`] with the packing's own ids ([`Packing::ids`], each ≥ 1) as atom
/// ids when it has them (`anisobond convert`), else 1…N.
pub fn write_liggghts_data_with_ids(path: &Path, p: &Packing, density: f64) -> Result<()> {
    if let Some(ids) = &p.ids {
        if ids.contains(&0) {
            return Err(Error::Invalid(
                "LIGGGHTS data: atom ids must be ≥ 1, the packing has id 0".into(),
            ));
        }
    }
    write_liggghts_data_ids(path, p, density, true)
}

fn write_liggghts_data_ids(path: &Path, p: &Packing, density: f64, own_ids: bool) -> Result<()> {
    if !density.is_finite() || density <= 0.0 {
        return Err(Error::Invalid(format!(
            "LIGGGHTS data: density must be finite and > 0, got {density}"
        )));
    }
    let (lo, hi) = match &p.cell {
        Some(c) => (Vec3::zeros(), c.lengths),
        None if p.is_empty() => (Vec3::zeros(), Vec3::repeat(1.0)),
        None => p.bounding_box(),
    };
    let boundary = if p.cell.is_some() {
        "boundary p p p"
    } else {
        "non-periodic"
    };
    write_lines(path, |w| {
        writeln!(
            w,
            "LIGGGHTS data file written by anisobond (atom_style granular, {boundary})"
        )?;
        writeln!(w)?;
        writeln!(w, "{} atoms", p.len())?;
        writeln!(w, "1 atom types")?;
        writeln!(w)?;
        for (k, name) in ["x", "y", "z"].iter().enumerate() {
            writeln!(w, "{} {} {name}lo {name}hi", num(lo[k]), num(hi[k]))?;
        }
        writeln!(w)?;
        writeln!(w, "Atoms # granular")?;
        writeln!(w)?;
        for (k, (x, r)) in p.positions.iter().zip(&p.radii).enumerate() {
            writeln!(
                w,
                "{} 1 {} {} {} {} {}",
                match (&p.ids, own_ids) {
                    (Some(ids), true) => ids[k],
                    _ => k as u64 + 1,
                },
                num(2.0 * r),
                num(density),
                num(x.x),
                num(x.y),
                num(x.z)
            )?;
        }
        Ok(())
    })
}

fn write_lines(
    path: &Path,
    fill: impl FnOnce(&mut dyn std::io::Write) -> std::io::Result<()>,
) -> Result<()> {
    crate::io::write_atomic(path, |w| fill(w).map_err(io_err(path)))
}
