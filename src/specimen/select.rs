//! Particle groups of a specimen (held, moved) chosen by region or by the user's ids.

use crate::packing::Packing;
use crate::{Error, Result, Vec3};

/// How a group of particles is chosen. Regions test the particle's centre (closed bounds).
#[derive(Clone, Debug, PartialEq)]
pub enum Selection {
    /// Centres within `depth` (m) of the lowest (`top = false`) or highest (`top = true`)
    /// centre along the loading axis: a platen's end layer.
    EndLayer {
        /// The highest end instead of the lowest.
        top: bool,
        /// Depth (m).
        depth: f64,
    },
    /// Centres inside the box `lo ≤ x ≤ hi` (m).
    Box {
        /// Lower corner.
        lo: Vec3,
        /// Upper corner.
        hi: Vec3,
    },
    /// Centres inside a cylinder ([`Cylinder`]).
    Cylinder(Cylinder),
    /// The particles with these ids: the packing's own ids when its file gave them (LAMMPS or
    /// LIGGGHTS atom ids, YADE body ids), else the 0-based order in the file.
    Ids(Vec<u64>),
}

/// A cylinder whose axis is parallel to `dim` (0 = x, 1 = y, 2 = z) and passes through
/// `(c1, c2)` in the other two axes (in x, y, z order), of `radius`, between `lo` and `hi`
/// along `dim` (m): LAMMPS's `region cylinder dim c1 c2 radius lo hi`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Cylinder {
    /// Axis direction.
    pub dim: usize,
    /// First transverse coordinate of the axis.
    pub c1: f64,
    /// Second transverse coordinate of the axis.
    pub c2: f64,
    /// Radius.
    pub radius: f64,
    /// Lower bound along `dim`.
    pub lo: f64,
    /// Upper bound along `dim`.
    pub hi: f64,
}

impl Cylinder {
    /// Why the cylinder's numbers are refused, if they are.
    fn refusal(&self) -> Option<&'static str> {
        let c = self;
        if c.dim > 2 {
            Some("cylinder axis must be x, y or z")
        } else if ![c.c1, c.c2, c.radius, c.lo, c.hi]
            .iter()
            .all(|v| v.is_finite())
        {
            Some("cylinder numbers must be finite")
        } else if c.radius <= 0.0 || c.lo > c.hi {
            Some("cylinder radius must be > 0 and lo <= hi")
        } else {
            None
        }
    }

    /// Whether the point `p` is inside (closed bounds).
    fn contains(&self, p: &Vec3) -> bool {
        let (a1, a2) = match self.dim {
            0 => (1, 2),
            1 => (0, 2),
            _ => (0, 1),
        };
        let (d1, d2) = (p[a1] - self.c1, p[a2] - self.c2);
        p[self.dim] >= self.lo
            && p[self.dim] <= self.hi
            && d1 * d1 + d2 * d2 <= self.radius * self.radius
    }

    /// A short description for reports and errors.
    fn describe(&self) -> String {
        let Cylinder {
            c1,
            c2,
            radius,
            lo,
            hi,
            ..
        } = self;
        format!(
            "cylinder along {} through ({c1:e}, {c2:e}), radius {radius:e} m, from {lo:e} \
             to {hi:e} m",
            ["x", "y", "z"][self.dim.min(2)]
        )
    }
}

impl Selection {
    /// A group as the CLI and Python write it — `box:XLO,YLO,ZLO,XHI,YHI,ZHI`,
    /// `cylinder:DIM,C1,C2,RADIUS,LO,HI` (LAMMPS' `region cylinder` order), `ids:ID,ID,…` or
    /// `file:PATH` (ids, one or more per line) — checked; `option` names it in errors.
    pub fn parse(text: &str, option: &str) -> Result<Selection> {
        let bad = |what: String| {
            Error::Invalid(format!(
                "{option} {text:?}: {what}; expected box:XLO,YLO,ZLO,XHI,YHI,ZHI, \
                 cylinder:DIM,C1,C2,RADIUS,LO,HI, ids:ID,ID,… or file:PATH"
            ))
        };
        let (kind, rest) = text
            .split_once(':')
            .ok_or_else(|| bad("no kind before ':'".into()))?;
        // `count` finite numbers separated by commas (`after`: where they start, for errors).
        let numbers = |text: &str, count: usize, after: &str| -> Result<Vec<f64>> {
            let v: Vec<&str> = text.split(',').map(str::trim).collect();
            if v.len() != count {
                return Err(bad(format!("{} numbers{after}, expected {count}", v.len())));
            }
            v.iter()
                .map(|t| {
                    t.parse::<f64>()
                        .ok()
                        .filter(|x| x.is_finite())
                        .ok_or_else(|| bad(format!("{t:?} is not a finite number")))
                })
                .collect()
        };
        let sel = match kind {
            "box" => {
                let v = numbers(rest, 6, "")?;
                Selection::Box {
                    lo: Vec3::new(v[0], v[1], v[2]),
                    hi: Vec3::new(v[3], v[4], v[5]),
                }
            }
            "cylinder" => {
                let (dim, rest) = rest
                    .split_once(',')
                    .ok_or_else(|| bad("no axis before the numbers".into()))?;
                let dim = match dim.trim() {
                    "x" => 0,
                    "y" => 1,
                    "z" => 2,
                    other => return Err(bad(format!("axis {other:?} is not x, y or z"))),
                };
                let w = numbers(rest, 5, " after the axis")?;
                Selection::Cylinder(Cylinder {
                    dim,
                    c1: w[0],
                    c2: w[1],
                    radius: w[2],
                    lo: w[3],
                    hi: w[4],
                })
            }
            "ids" => Selection::Ids(parse_ids(rest, option)?),
            "file" => {
                let path = std::path::Path::new(rest);
                let body = std::fs::read_to_string(path).map_err(|e| Error::io(path, e))?;
                Selection::Ids(parse_ids(&body, rest)?)
            }
            other => return Err(bad(format!("unknown kind {other:?}"))),
        };
        sel.check().map_err(|e| match e {
            Error::Invalid(m) => bad(m),
            other => other,
        })?;
        Ok(sel)
    }

    /// A short description for reports and errors.
    pub fn describe(&self) -> String {
        match self {
            Selection::EndLayer { top, depth } => format!(
                "the {} end layer ({depth:e} m deep)",
                if *top { "highest" } else { "lowest" }
            ),
            Selection::Box { lo, hi } => format!(
                "box [{:e}, {:e}] × [{:e}, {:e}] × [{:e}, {:e}] m",
                lo.x, hi.x, lo.y, hi.y, lo.z, hi.z
            ),
            Selection::Cylinder(c) => c.describe(),
            Selection::Ids(ids) => format!("{} listed ids", ids.len()),
        }
    }

    /// Check the numbers of the selection.
    pub fn check(&self) -> Result<()> {
        let bad = |what: &str| Err(Error::Invalid(format!("specimen group: {what}")));
        match self {
            Selection::EndLayer { depth, .. } => {
                if !(depth.is_finite() && *depth >= 0.0) {
                    return bad(&format!(
                        "end layer depth must be a finite length >= 0 m, got {depth}"
                    ));
                }
            }
            Selection::Box { lo, hi } => {
                if lo.iter().chain(hi.iter()).any(|v| !v.is_finite()) {
                    return bad("box corners must be finite");
                }
                if (0..3).any(|a| lo[a] > hi[a]) {
                    return bad("box lower corner above its upper corner");
                }
            }
            Selection::Cylinder(c) => {
                if let Some(why) = c.refusal() {
                    return bad(why);
                }
            }
            Selection::Ids(ids) => {
                if ids.is_empty() {
                    return bad("an empty list of ids");
                }
            }
        }
        Ok(())
    }

    /// The flag of every particle of `packing`: selected or not. `axis` is the loading axis
    /// (for end layers). A listed id that the packing does not have is refused.
    pub fn select(&self, packing: &Packing, axis: usize) -> Result<Vec<bool>> {
        self.check()?;
        let n = packing.len();
        let x = &packing.positions;
        Ok(match self {
            Selection::EndLayer { top, depth } => {
                let c = |p: usize| x[p][axis];
                let lo = (0..n).map(c).fold(f64::INFINITY, f64::min);
                let hi = (0..n).map(c).fold(f64::NEG_INFINITY, f64::max);
                (0..n)
                    .map(|p| {
                        if *top {
                            c(p) >= hi - depth
                        } else {
                            c(p) <= lo + depth
                        }
                    })
                    .collect()
            }
            Selection::Box { lo, hi } => x
                .iter()
                .map(|p| (0..3).all(|a| p[a] >= lo[a] && p[a] <= hi[a]))
                .collect(),
            Selection::Cylinder(c) => x.iter().map(|p| c.contains(p)).collect(),
            Selection::Ids(ids) => {
                let mut flag = vec![false; n];
                match &packing.ids {
                    Some(own) => {
                        let mut sorted: Vec<(u64, usize)> =
                            own.iter().enumerate().map(|(p, &id)| (id, p)).collect();
                        sorted.sort_unstable();
                        for &id in ids {
                            let k = sorted.binary_search_by_key(&id, |e| e.0).map_err(|_| {
                                Error::Invalid(format!(
                                    "specimen group: id {id} is not one of the packing's ids"
                                ))
                            })?;
                            flag[sorted[k].1] = true;
                        }
                    }
                    None => {
                        for &id in ids {
                            if id as usize >= n || id >= u64::from(u32::MAX) {
                                return Err(Error::Invalid(format!(
                                    "specimen group: id {id}: the packing gives no ids, so ids \
                                     are the 0-based order of its {n} particles"
                                )));
                            }
                            flag[id as usize] = true;
                        }
                    }
                }
                flag
            }
        })
    }
}

/// Ids read from text: integers separated by white space or commas, `#` to the end of a line
/// a comment. `source` names the text in errors (a file name, or the option).
pub fn parse_ids(text: &str, source: &str) -> Result<Vec<u64>> {
    let mut ids = Vec::new();
    for (k, line) in text.lines().enumerate() {
        let line = line.split('#').next().unwrap_or("");
        for tok in line
            .split(|c: char| c.is_whitespace() || c == ',')
            .filter(|t| !t.is_empty())
        {
            ids.push(tok.parse::<u64>().map_err(|_| Error::Parse {
                path: source.to_string(),
                line: k + 1,
                message: format!("{tok:?} is not a particle id (a non-negative integer)"),
            })?);
        }
    }
    if ids.is_empty() {
        return Err(Error::Parse {
            path: source.to_string(),
            line: 0,
            message: "no particle ids".into(),
        });
    }
    Ok(ids)
}
