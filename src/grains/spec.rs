//! `[grains]` of a model file (docs/polycrystal.md): the grain map (a count or a mean size of
//! seeded Voronoi grains, or a file of grain ids), the orientations (uniform random, a fibre
//! texture, or a file of Bunge angles), the seed and the grain-boundary rule. Read and
//! checked with the model, written back with it, built on a packing by [`GrainsSpec::build`].

use super::centres::{count_for_mean_size, seeded_centres, GrainRegion};
use super::orientation::{fibre_orientation, uniform_orientation, unit};
use super::{nearest_centres, read_euler_file, read_grain_file, Grains};
use crate::keys;
use crate::packing::Packing;
use crate::{Error, Mat3, Result, Vec3};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

/// Which particle is in which grain.
#[derive(Clone, Debug, PartialEq)]
pub enum GrainMap {
    /// `count`: this many seeded Voronoi grains (centres uniform in the cell or box).
    Count(usize),
    /// `mean_size`: seeded Voronoi grains of this mean size in particle diameters
    /// ([`super::count_for_mean_size`]).
    MeanSize(f64),
    /// `file`: the grain id of every particle, one per line ([`super::read_grain_file`]).
    File(PathBuf),
}

/// The orientation of each grain.
#[derive(Clone, Debug, PartialEq)]
pub enum Orientations {
    /// `random`: uniform on SO(3), seeded ([`super::uniform_orientation`]).
    Random,
    /// `fibre`: the crystal `direction` along the sample `axis`, turned uniformly about it,
    /// tilted off it by a Gaussian `spread_deg` ([`super::fibre_orientation`]).
    Fibre {
        /// Sample axis (unit).
        axis: Vec3,
        /// Crystal direction (unit, crystal coordinates).
        direction: Vec3,
        /// Standard deviation of each tilt component (degrees, ≥ 0).
        spread_deg: f64,
    },
    /// `euler-file`: Bunge angles per grain ([`super::read_euler_file`]).
    EulerFile(PathBuf),
}

/// The `[grains]` table, checked: how the grains are made on a packing, and the boundary rule.
#[derive(Clone, Debug, PartialEq)]
pub struct GrainsSpec {
    /// The grain map.
    pub map: GrainMap,
    /// The grains' orientations.
    pub orientation: Orientations,
    /// Seed of the centres (ChaCha8 stream 0) and the orientations (stream 1); default 0.
    pub seed: u64,
    /// How a bond whose particles lie in different grains combines both grains' springs.
    pub boundary: BoundaryRule,
    /// That combination is multiplied by this factor (finite, > 0; default 1).
    pub boundary_factor: f64,
    /// A boundary bond's strengths (σ_t, c, σ_b, τ_t; not the friction) are those the
    /// `[strength]` table gives it, times this factor (finite, > 0; default 1):
    /// [`super::assign_strength_by_grain`].
    pub boundary_strength_factor: f64,
}

/// `boundary = "mean" | "series" | "contact-point"`: the springs of a bond across a grain
/// boundary, from the springs k_g, k_h the bond would have inside either grain.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Deserialize, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum BoundaryRule {
    /// ½(k_g + k_h), each spring separately: the default.
    #[default]
    Mean,
    /// 2k_g k_h/(k_g + k_h), each spring separately: the bond's two halves, each in its own
    /// grain, in series (0 when both are 0). Never stiffer than the mean; the relaxed tensor
    /// is concave in the springs, so the mean rule stiffens a network of heterogeneous
    /// springs (docs/polycrystal.md).
    Series,
    /// All springs of the one grain whose Voronoi region holds the bond's contact point (the
    /// mid-gap point, YADE's): of the two grains, the one whose centre is nearer to it
    /// (minimum image; a tie to the lower id). A sharp interface: no bond mixes two
    /// orientations. Needs the grain centres: a grain file is refused.
    ContactPoint,
}

impl BoundaryRule {
    /// The boundary bond's spring from the two grains' springs `a`, `b` (≥ 0), for the rules
    /// that combine both; `None` for [`BoundaryRule::ContactPoint`], which takes one grain's
    /// springs whole (chosen by geometry, `bonds::assign_stiffness_by_grain`).
    pub fn combine(self, a: f64, b: f64) -> Option<f64> {
        match self {
            BoundaryRule::Mean => Some(0.5 * (a + b)),
            BoundaryRule::Series if a + b > 0.0 => Some(2.0 * a * b / (a + b)),
            BoundaryRule::Series => Some(0.0),
            BoundaryRule::ContactPoint => None,
        }
    }
}

/// `orientation = "random" | "fibre" | "euler-file"`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Deserialize, Serialize)]
#[serde(rename_all = "kebab-case")]
pub(crate) enum RawOrientation {
    #[default]
    Random,
    Fibre,
    EulerFile,
}

keys::table! {
    /// `[grains]` as written; every value read by [`crate::keys`], which names the key.
    #[derive(Clone, Debug, Default, Deserialize, Serialize)]
    #[serde(deny_unknown_fields)]
    pub(crate) struct RawGrains {
        count: Option<u64> = "keys::count",
        mean_size: Option<f64> = "keys::mean_size",
        file: Option<String> = "keys::file",
        orientation: RawOrientation = "keys::orientation",
        axis: Option<[f64; 3]> = "keys::axis",
        direction: Option<[f64; 3]> = "keys::direction",
        spread_deg: Option<f64> = "keys::spread_deg",
        euler_file: Option<String> = "keys::euler_file",
        seed: Option<u64> = "keys::seed",
        boundary: BoundaryRule = "keys::boundary",
        boundary_factor: Option<f64> = "keys::boundary_factor",
        boundary_strength_factor: Option<f64> = "keys::boundary_strength_factor",
    }
}

impl keys::Absent for RawOrientation {}
impl keys::Absent for BoundaryRule {}

/// `[grains]` read and checked (the refusal at the table's position): what the model reader
/// keeps until it resolves the table's file paths ([`GrainsSpec::from_raw`]).
pub(crate) fn checked<'de, D: serde::Deserializer<'de>>(
    d: D,
) -> std::result::Result<Option<RawGrains>, D::Error> {
    let raw = RawGrains::deserialize(d)?;
    match GrainsSpec::from_raw(&raw, None) {
        Ok(_) => Ok(Some(raw)),
        Err(Error::Model(m)) => Err(serde::de::Error::custom(m)),
        Err(other) => Err(serde::de::Error::custom(other)),
    }
}

/// A unit vector as written: kept bit for bit when of unit length to rounding (so a written
/// model reads back identically), else normalised.
fn unit_as_written(v: [f64; 3], key: &str) -> Result<Vec3> {
    let u = unit(v, key)?;
    let w = Vec3::new(v[0], v[1], v[2]);
    Ok(if (w.norm() - 1.0).abs() <= 4.0 * f64::EPSILON {
        w
    } else {
        u
    })
}

/// A file key's path: relative paths resolve against `base` (the model file's folder) when
/// given, and are made absolute, so the model written anywhere reads the same file.
fn resolve(path: &str, key: &str, base: Option<&Path>) -> Result<PathBuf> {
    if path.is_empty() {
        return Err(Error::Model(format!(
            "[grains] {key} = \"\": expected a file path"
        )));
    }
    let p = Path::new(path);
    match base {
        Some(dir) if p.is_relative() => {
            std::path::absolute(dir.join(p)).map_err(|e| Error::io(dir.join(p), e))
        }
        _ => Ok(p.to_path_buf()),
    }
}

impl GrainsSpec {
    /// The spec of a parsed table, checked: exactly one of `count`, `mean_size`, `file`;
    /// each orientation's own keys only; finite values in range. File paths resolve against
    /// `base` ([`resolve`]).
    pub(crate) fn from_raw(raw: &RawGrains, base: Option<&Path>) -> Result<GrainsSpec> {
        let map = match (raw.count, raw.mean_size, &raw.file) {
            (Some(n), None, None) => {
                if n == 0 || n > u32::MAX as u64 - 1 {
                    return Err(Error::Model(format!(
                        "[grains] count = {n}: expected a number of grains from 1 to {}",
                        u32::MAX - 1
                    )));
                }
                GrainMap::Count(n as usize)
            }
            (None, Some(s), None) => {
                if !(s.is_finite() && s > 0.0) {
                    return Err(Error::Model(format!(
                        "[grains] mean_size = {s}: expected a finite grain size > 0 (particle \
                         diameters)"
                    )));
                }
                GrainMap::MeanSize(s)
            }
            (None, None, Some(f)) => GrainMap::File(resolve(f, "file", base)?),
            _ => {
                return Err(Error::Model(
                    "[grains] give exactly one of `count` (a number of grains), `mean_size` \
                     (particle diameters) or `file` (grain ids per particle)"
                        .into(),
                ))
            }
        };
        let kind = raw.orientation;
        let foreign = |keys: &[(&str, bool)], name: &str| -> Result<()> {
            match keys.iter().find(|(_, given)| *given) {
                Some((key, _)) => Err(Error::Model(format!(
                    "[grains] `{key}` does not apply to orientation = \"{name}\" (fibre: axis, \
                     direction, spread_deg; euler-file: euler_file)"
                ))),
                None => Ok(()),
            }
        };
        let fibre_keys = [
            ("axis", raw.axis.is_some()),
            ("direction", raw.direction.is_some()),
            ("spread_deg", raw.spread_deg.is_some()),
        ];
        let orientation = match kind {
            RawOrientation::Random => {
                foreign(&fibre_keys, "random")?;
                foreign(&[("euler_file", raw.euler_file.is_some())], "random")?;
                Orientations::Random
            }
            RawOrientation::Fibre => {
                foreign(&[("euler_file", raw.euler_file.is_some())], "fibre")?;
                let spread_deg = raw.spread_deg.unwrap_or(0.0);
                if !(spread_deg.is_finite() && spread_deg >= 0.0) {
                    return Err(Error::Model(format!(
                        "[grains] spread_deg = {spread_deg}: expected a finite angle ≥ 0 (degrees)"
                    )));
                }
                Orientations::Fibre {
                    axis: unit_as_written(raw.axis.unwrap_or([0.0, 0.0, 1.0]), "axis")?,
                    direction: unit_as_written(
                        raw.direction.unwrap_or([0.0, 0.0, 1.0]),
                        "direction",
                    )?,
                    spread_deg,
                }
            }
            RawOrientation::EulerFile => {
                foreign(&fibre_keys, "euler-file")?;
                let Some(f) = &raw.euler_file else {
                    return Err(Error::Model(
                        "[grains] orientation = \"euler-file\" needs `euler_file` (Bunge angles \
                         phi1 Phi phi2 in degrees, one line per grain)"
                            .into(),
                    ));
                };
                Orientations::EulerFile(resolve(f, "euler_file", base)?)
            }
        };
        let seed = raw.seed.unwrap_or(0);
        if seed > i64::MAX as u64 {
            return Err(Error::Model(format!(
                "[grains] seed = {seed}: expected an integer from 0 to {} (a TOML integer)",
                i64::MAX
            )));
        }
        if raw.boundary == BoundaryRule::ContactPoint && matches!(map, GrainMap::File(_)) {
            return Err(Error::Model(
                "[grains] boundary = \"contact-point\" needs Voronoi grains (`count` or \
                 `mean_size`): a grain file has no grain regions to hold a contact point; use \
                 boundary = \"mean\" or \"series\" with `file`"
                    .into(),
            ));
        }
        let factor = |value: Option<f64>, key: &str| -> Result<f64> {
            let f = value.unwrap_or(1.0);
            if f.is_finite() && f > 0.0 {
                Ok(f)
            } else {
                Err(Error::Model(format!(
                    "[grains] {key} = {f}: expected a finite factor > 0"
                )))
            }
        };
        Ok(GrainsSpec {
            map,
            orientation,
            seed,
            boundary: raw.boundary,
            boundary_factor: factor(raw.boundary_factor, "boundary_factor")?,
            boundary_strength_factor: factor(
                raw.boundary_strength_factor,
                "boundary_strength_factor",
            )?,
        })
    }

    /// The table as written back: every key explicit, paths as resolved.
    pub(crate) fn to_raw(&self) -> RawGrains {
        let path = |p: &Path| p.to_string_lossy().into_owned();
        let mut raw = RawGrains {
            seed: Some(self.seed),
            boundary: self.boundary,
            boundary_factor: Some(self.boundary_factor),
            boundary_strength_factor: Some(self.boundary_strength_factor),
            ..RawGrains::default()
        };
        match &self.map {
            GrainMap::Count(n) => raw.count = Some(*n as u64),
            GrainMap::MeanSize(s) => raw.mean_size = Some(*s),
            GrainMap::File(p) => raw.file = Some(path(p)),
        }
        match &self.orientation {
            Orientations::Random => raw.orientation = RawOrientation::Random,
            Orientations::Fibre {
                axis,
                direction,
                spread_deg,
            } => {
                raw.orientation = RawOrientation::Fibre;
                raw.axis = Some([axis.x, axis.y, axis.z]);
                raw.direction = Some([direction.x, direction.y, direction.z]);
                raw.spread_deg = Some(*spread_deg);
            }
            Orientations::EulerFile(p) => {
                raw.orientation = RawOrientation::EulerFile;
                raw.euler_file = Some(path(p));
            }
        }
        raw
    }

    /// The grains of `packing`: the map (seeded centres and the nearest-centre rule, or the
    /// file), then one orientation per grain. Refuses a file that cannot be read or does not
    /// fit the packing (naming file and line), more grains than particles, and an Euler
    /// file whose grain count is not the map's (grain ids 0 to G − 1: G the count, or the
    /// largest id + 1 of a grain file).
    pub fn build(&self, packing: &Packing) -> Result<Grains> {
        let seeded = |count: usize| -> Result<(Vec<u32>, Option<Vec<Vec3>>)> {
            if count > packing.len() {
                return Err(Error::Model(format!(
                    "[grains] count = {count} grains for {} particles: expected at most one \
                     grain per particle",
                    packing.len()
                )));
            }
            let centres = seeded_centres(&GrainRegion::of(packing), count, self.seed);
            Ok((nearest_centres(packing, &centres)?, Some(centres)))
        };
        let (grain, centres) = match &self.map {
            GrainMap::Count(n) => seeded(*n)?,
            GrainMap::MeanSize(s) => seeded(count_for_mean_size(packing, *s)?)?,
            GrainMap::File(p) => (read_grain_file(p, packing.len())?, None),
        };
        let count = match &centres {
            Some(c) => c.len(),
            None => grain.iter().max().map_or(0, |&g| g as usize + 1),
        };
        let mut rng = ChaCha8Rng::seed_from_u64(self.seed);
        rng.set_stream(1);
        let orientation: Vec<Mat3> = match &self.orientation {
            Orientations::Random => (0..count).map(|_| uniform_orientation(&mut rng)).collect(),
            Orientations::Fibre {
                axis,
                direction,
                spread_deg,
            } => (0..count)
                .map(|_| fibre_orientation(&mut rng, axis, direction, *spread_deg))
                .collect(),
            Orientations::EulerFile(p) => {
                let o = read_euler_file(p)?;
                if o.len() != count {
                    return Err(Error::parse(
                        p,
                        0,
                        format!(
                            "{} grains (lines of Bunge angles), but the grain map has {count} \
                             (grain ids 0 to {})",
                            o.len(),
                            count as i64 - 1
                        ),
                    ));
                }
                o
            }
        };
        Grains::new(grain, orientation, centres)
    }
}
