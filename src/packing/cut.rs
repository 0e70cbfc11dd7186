//! Free (non-periodic) assemblies cut out of a packing, and their boundary particle sets.
//!
//! Kumar 2016 (Sec. 5) jams the spheres of a bar inside a rigid cylinder and two planes,
//! removes them and bonds ([`super::container`] does that); here the bar is cut from a
//! periodic packing made by the same route: the periodic images are unwrapped (the cell is tiled as often as the region
//! needs), so the cut is contiguous, and every sphere whose centre lies inside the region
//! is kept. A region longer than the cell therefore repeats the cell's structure along the
//! bar (period = the cell length). The cut keeps, for every sphere, the index of the
//! periodic sphere it copies and the image it came from, so ids and bonds can follow.
//!
//! [`cut_holed_slab`]: a slab with a circular hole whose axis is z, periodic along z — the
//! annulus a ≤ ρ ≤ b of sphere centres (ρ the distance from the hole's axis) cut from the
//! periodic packing tiled in x and y as often as the annulus needs. The result keeps a
//! periodic cell (the tiled x, y lengths and the source's L_z), so bonds cross only its z
//! faces: the static network and the integrator then treat it as periodic along z with
//! empty space around it in x and y, and a fixed cell means plane strain along the axis.

use super::{Packing, PeriodicCell};
use crate::{Error, Result, Vec3};

/// A region of space (lengths in m).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Region {
    /// A circular cylinder of axis `axis` (unit vector) through `centre`, radius `radius`
    /// and length `length` (the end faces at ±length/2 from `centre` along the axis).
    Cylinder {
        /// Centre of the cylinder (m).
        centre: Vec3,
        /// Unit axis.
        axis: Vec3,
        /// Radius (m).
        radius: f64,
        /// Length (m).
        length: f64,
    },
    /// The axis-aligned box [lo, hi] (m); its "ends" are the two faces normal to `axis`
    /// (0 = x, 1 = y, 2 = z).
    Box {
        /// Lower corner (m).
        lo: Vec3,
        /// Upper corner (m).
        hi: Vec3,
        /// Index of the loading axis (0, 1 or 2).
        axis: usize,
    },
}

impl Region {
    /// Refuse a region that is empty, not finite, or whose axis is not a unit vector.
    pub fn check(&self) -> Result<()> {
        match *self {
            Region::Cylinder {
                centre,
                axis,
                radius,
                length,
            } => {
                if centre.iter().any(|c| !c.is_finite()) {
                    return Err(Error::Invalid("cylinder: centre is not finite".into()));
                }
                if !(radius.is_finite() && radius > 0.0 && length.is_finite() && length > 0.0) {
                    return Err(Error::Invalid(format!(
                        "cylinder: radius and length must be finite and > 0, got {radius:e} m \
                         and {length:e} m"
                    )));
                }
                if (axis.norm() - 1.0).abs() > 1e-9 {
                    return Err(Error::Invalid(format!(
                        "cylinder: the axis must be a unit vector, |axis| = {}",
                        axis.norm()
                    )));
                }
            }
            Region::Box { lo, hi, axis } => {
                if axis > 2 {
                    return Err(Error::Invalid(format!(
                        "box: axis must be 0 (x), 1 (y) or 2 (z), got {axis}"
                    )));
                }
                if (0..3).any(|k| !(lo[k].is_finite() && hi[k].is_finite() && hi[k] > lo[k])) {
                    return Err(Error::Invalid(format!(
                        "box: need finite lo < hi on every axis, got lo = ({}, {}, {}) m, \
                         hi = ({}, {}, {}) m",
                        lo.x, lo.y, lo.z, hi.x, hi.y, hi.z
                    )));
                }
            }
        }
        Ok(())
    }

    /// Unit loading axis.
    pub fn axis(&self) -> Vec3 {
        match *self {
            Region::Cylinder { axis, .. } => axis,
            Region::Box { axis, .. } => {
                let mut a = Vec3::zeros();
                a[axis] = 1.0;
                a
            }
        }
    }

    /// Length along the loading axis (m).
    pub fn length(&self) -> f64 {
        match *self {
            Region::Cylinder { length, .. } => length,
            Region::Box { lo, hi, axis } => hi[axis] - lo[axis],
        }
    }

    /// Axial coordinate of `x` measured from the first end face (0 … length inside).
    pub fn axial(&self, x: &Vec3) -> f64 {
        match *self {
            Region::Cylinder {
                centre,
                axis,
                length,
                ..
            } => (x - centre).dot(&axis) + 0.5 * length,
            Region::Box { lo, axis, .. } => x[axis] - lo[axis],
        }
    }

    /// Distance from `x` (inside) to the nearest lateral face (the cylinder's mantle; the
    /// four box faces parallel to the axis).
    pub fn lateral_depth(&self, x: &Vec3) -> f64 {
        match *self {
            Region::Cylinder {
                centre,
                axis,
                radius,
                ..
            } => {
                let d = x - centre;
                radius - (d - axis * d.dot(&axis)).norm()
            }
            Region::Box { lo, hi, axis } => (0..3)
                .filter(|&k| k != axis)
                .map(|k| (x[k] - lo[k]).min(hi[k] - x[k]))
                .fold(f64::INFINITY, f64::min),
        }
    }

    /// True when `x` lies inside the region (faces included).
    pub fn contains(&self, x: &Vec3) -> bool {
        let t = self.axial(x);
        t >= 0.0 && t <= self.length() && self.lateral_depth(x) >= 0.0
    }

    /// Axis-aligned bounding box of the region (m).
    pub fn bounding_box(&self) -> (Vec3, Vec3) {
        match *self {
            Region::Cylinder {
                centre,
                axis,
                radius,
                length,
            } => {
                // Extent of a disc of radius r normal to a: r·sqrt(1 − a_k²) per axis.
                let mut half = Vec3::zeros();
                for k in 0..3 {
                    half[k] = 0.5 * length * axis[k].abs()
                        + radius * (1.0 - axis[k] * axis[k]).max(0.0).sqrt();
                }
                (centre - half, centre + half)
            }
            Region::Box { lo, hi, .. } => (lo, hi),
        }
    }
}

/// A free assembly cut from a packing, with where every sphere came from.
#[derive(Clone, Debug)]
pub struct Cut {
    /// The free packing (no cell): positions unwrapped, in m.
    pub packing: Packing,
    /// For every kept sphere, the index of the sphere of the source packing it copies.
    pub source: Vec<u32>,
    /// For every kept sphere, the periodic image it came from (position = source position
    /// + image ∘ L); all zero for a free source.
    pub image: Vec<[i32; 3]>,
    /// The region it was cut with.
    pub region: Region,
}

/// The spheres of `packing` copied to the periodic images `images` (all at the origin for a
/// free packing) whose shifted centres `keep` accepts, ordered by image, then by index.
struct Copies {
    positions: Vec<Vec3>,
    radii: Vec<f64>,
    source: Vec<u32>,
    image: Vec<[i32; 3]>,
}

impl Copies {
    /// The kept spheres as a packing in `cell` (`None`: free), with their sources and images;
    /// fewer than two is refused ([`Error::Degenerate`]) by `refusal(count)`.
    fn into_packing(
        self,
        cell: Option<PeriodicCell>,
        refusal: impl FnOnce(usize) -> String,
    ) -> Result<(Packing, Vec<u32>, Vec<[i32; 3]>)> {
        if self.positions.len() < 2 {
            return Err(Error::Degenerate(refusal(self.positions.len())));
        }
        let packing = Packing::new(self.positions, self.radii, cell)?;
        Ok((packing, self.source, self.image))
    }
}

fn copies(
    packing: &Packing,
    images: impl Iterator<Item = [i32; 3]>,
    keep: impl Fn(&Vec3) -> bool,
) -> Copies {
    let mut c = Copies {
        positions: Vec::new(),
        radii: Vec::new(),
        source: Vec::new(),
        image: Vec::new(),
    };
    for s in images {
        let shift = packing.cell.map_or(Vec3::zeros(), |cell| cell.shift(s));
        for (p, (x, &r)) in packing.positions.iter().zip(&packing.radii).enumerate() {
            let y = x + shift;
            if keep(&y) {
                c.positions.push(y);
                c.radii.push(r);
                c.source.push(p as u32);
                c.image.push(s);
            }
        }
    }
    c
}

/// Cut the spheres whose centres lie inside `region` out of `packing`. A periodic packing is
/// tiled by its images as far as the region reaches (so the region may be larger than the
/// cell); a free one is filtered. The kept spheres are ordered by image, then by source
/// index; the source's particle ids follow only where each is kept once (no id is
/// duplicated: ids are dropped when the region holds two images of one sphere). Refuses an
/// invalid region and a region that holds fewer than two spheres.
pub fn cut(packing: &Packing, region: &Region) -> Result<Cut> {
    region.check()?;
    let (lo, hi) = region.bounding_box();
    let ranges: [(i32, i32); 3] = match &packing.cell {
        Some(cell) => {
            let mut r = [(0, 0); 3];
            for (k, rk) in r.iter_mut().enumerate() {
                let l = cell.lengths[k];
                // Wrapped positions are in [0, L): images s with s·L + [0, L) meeting [lo, hi].
                *rk = (
                    (lo[k] / l).floor() as i32 - 1,
                    (hi[k] / l).floor() as i32 + 1,
                );
            }
            let count: f64 = r.iter().map(|(a, b)| (b - a + 1) as f64).product();
            if count * packing.len() as f64 > 4.0e9 {
                return Err(Error::Invalid(format!(
                    "cut: the region spans {count} periodic images of a {}-sphere cell: too \
                     large",
                    packing.len()
                )));
            }
            r
        }
        None => [(0, 0); 3],
    };
    let images = (ranges[0].0..=ranges[0].1).flat_map(|sx| {
        (ranges[1].0..=ranges[1].1)
            .flat_map(move |sy| (ranges[2].0..=ranges[2].1).map(move |sz| [sx, sy, sz]))
    });
    let (mut free, source, image) = copies(packing, images, |y| region.contains(y))
        .into_packing(None, |n| {
            format!("cut: the region holds {n} sphere centres, need at least 2")
        })?;
    if let Some(ids) = &packing.ids {
        let mut seen = vec![false; packing.len()];
        let unique = source
            .iter()
            .all(|&p| !std::mem::replace(&mut seen[p as usize], true));
        if unique {
            free = free.with_ids(source.iter().map(|&p| ids[p as usize]).collect())?;
        }
    }
    Ok(Cut {
        packing: free,
        source,
        image,
        region: *region,
    })
}

/// Boundary particle sets of a cut assembly (indices into its packing, increasing).
#[derive(Clone, Debug, PartialEq)]
pub struct BoundarySets {
    /// Spheres of the first end (axial coordinate t ≤ depth).
    pub first_end: Vec<u32>,
    /// Spheres of the second end (t ≥ length − depth).
    pub second_end: Vec<u32>,
    /// Spheres within `depth` of a lateral face (the cylinder's mantle).
    pub surface: Vec<u32>,
    /// The depth used (m).
    pub depth: f64,
}

impl Cut {
    /// The spheres whose centres lie within `depth` (m) of each end face, and of the lateral
    /// surface. With depth = R̄ the end sets are, as in Kumar 2016 Sec. 5, the spheres that
    /// touch (cross) the end planes, which are clamped there. Refuses a depth that is not
    /// finite and > 0 or an end set that is empty.
    pub fn boundary(&self, depth: f64) -> Result<BoundarySets> {
        if !(depth.is_finite() && depth > 0.0) {
            return Err(Error::Invalid(format!(
                "boundary depth must be finite and > 0, got {depth:e} m"
            )));
        }
        let l = self.region.length();
        if 2.0 * depth >= l {
            return Err(Error::Invalid(format!(
                "boundary depth {depth:e} m leaves nothing between the two ends of a region of \
                 length {l:e} m"
            )));
        }
        let mut sets = BoundarySets {
            first_end: Vec::new(),
            second_end: Vec::new(),
            surface: Vec::new(),
            depth,
        };
        for (p, x) in self.packing.positions.iter().enumerate() {
            let t = self.region.axial(x);
            if t <= depth {
                sets.first_end.push(p as u32);
            } else if t >= l - depth {
                sets.second_end.push(p as u32);
            }
            if self.region.lateral_depth(x) <= depth {
                sets.surface.push(p as u32);
            }
        }
        if sets.first_end.is_empty() || sets.second_end.is_empty() {
            return Err(Error::Degenerate(format!(
                "no sphere centre within {depth:e} m of an end face ({} and {} found): give a \
                 larger depth",
                sets.first_end.len(),
                sets.second_end.len()
            )));
        }
        Ok(sets)
    }
}

/// A slab with a circular hole, axis along z through the centre of the cut's cell.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HoledSlab {
    /// Hole radius a (m): sphere centres with ρ ≥ a are kept.
    pub inner_radius: f64,
    /// Outer radius b (m): sphere centres with ρ ≤ b are kept.
    pub outer_radius: f64,
}

/// A holed slab cut from a periodic packing, with where every sphere came from.
#[derive(Clone, Debug)]
pub struct SlabCut {
    /// The kept spheres, with the periodic cell (tiled L_x, L_y; the source's L_z).
    pub packing: Packing,
    /// For every kept sphere, the index of the source sphere it copies.
    pub source: Vec<u32>,
    /// For every kept sphere, the tile it came from (x, y image; z always 0).
    pub image: Vec<[i32; 3]>,
    /// The hole's axis (x, y) in the cell (m): the cell's centre.
    pub axis: [f64; 2],
    /// The slab cut.
    pub slab: HoledSlab,
}

impl SlabCut {
    /// Distance of sphere `p`'s centre from the hole's axis (m).
    pub fn radial_distance(&self, p: usize) -> f64 {
        let x = self.packing.positions[p];
        (x.x - self.axis[0]).hypot(x.y - self.axis[1])
    }
}

/// Cut the holed slab out of the periodic `packing`, tiled n × n in x and y with n the
/// smallest number of tiles that leaves at least `margin` (m; e.g. the longest bond) of
/// empty space between the annulus and the x and y faces of the new cell, so that no bond
/// crosses them. Refuses a free packing, radii that are not 0 < a < b, and a result with
/// fewer than two spheres.
pub fn cut_holed_slab(packing: &Packing, slab: &HoledSlab, margin: f64) -> Result<SlabCut> {
    let cell = packing.cell.ok_or_else(|| {
        Error::Invalid(
            "holed slab: the packing must be periodic (a `# periodic Lx Ly Lz` header)".into(),
        )
    })?;
    let (a, b) = (slab.inner_radius, slab.outer_radius);
    if !(a.is_finite() && b.is_finite() && a > 0.0 && b > a) {
        return Err(Error::Invalid(format!(
            "holed slab: need 0 < inner radius < outer radius, got {a:e} m and {b:e} m"
        )));
    }
    if !(margin.is_finite() && margin >= 0.0) {
        return Err(Error::Invalid(format!(
            "holed slab: margin must be finite and ≥ 0, got {margin:e} m"
        )));
    }
    let need = 2.0 * (b + margin);
    let tiles = |l: f64| ((need / l).ceil() as i32).max(1);
    let (nx, ny) = (tiles(cell.lengths.x), tiles(cell.lengths.y));
    if (nx as f64) * (ny as f64) * packing.len() as f64 > 2.0e8 {
        return Err(Error::Invalid(format!(
            "holed slab: outer radius {b:e} m needs {nx} × {ny} tiles of the {}-sphere cell: \
             too large",
            packing.len()
        )));
    }
    let lengths = Vec3::new(
        nx as f64 * cell.lengths.x,
        ny as f64 * cell.lengths.y,
        cell.lengths.z,
    );
    let axis = [0.5 * lengths.x, 0.5 * lengths.y];
    let images = (0..nx).flat_map(|sx| (0..ny).map(move |sy| [sx, sy, 0]));
    let in_annulus = |y: &Vec3| {
        let rho = (y.x - axis[0]).hypot(y.y - axis[1]);
        rho >= a && rho <= b
    };
    let (packing, source, image) = copies(packing, images, in_annulus).into_packing(
        Some(PeriodicCell::new(lengths)?),
        |n| {
            format!(
                "holed slab: the annulus {a:e} m ≤ ρ ≤ {b:e} m holds {n} sphere centres, need \
                 at least 2"
            )
        },
    )?;
    Ok(SlabCut {
        packing,
        source,
        image,
        axis,
        slab: *slab,
    })
}
