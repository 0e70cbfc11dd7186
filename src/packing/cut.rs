//! Assemblies cut out of a periodic packing (issue 22).
//!
//! [`cut_holed_slab`]: a slab with a circular hole whose axis is z, periodic along z — the
//! annulus a ≤ ρ ≤ b of sphere centres (ρ the distance from the hole's axis) cut from the
//! periodic packing tiled in x and y as often as the annulus needs. The result keeps a
//! periodic cell (the tiled x, y lengths and the source's L_z), so bonds cross only its z
//! faces: the static network and the integrator then treat it as periodic along z with
//! empty space around it in x and y, and a fixed cell means plane strain along the axis.

use super::{Packing, PeriodicCell};
use crate::{Error, Result, Vec3};

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
    let mut positions = Vec::new();
    let mut radii = Vec::new();
    let mut source = Vec::new();
    let mut image = Vec::new();
    for sx in 0..nx {
        for sy in 0..ny {
            let s = [sx, sy, 0];
            let shift = cell.shift(s);
            for (p, (x, &r)) in packing.positions.iter().zip(&packing.radii).enumerate() {
                let y = x + shift;
                let rho = (y.x - axis[0]).hypot(y.y - axis[1]);
                if rho >= a && rho <= b {
                    positions.push(y);
                    radii.push(r);
                    source.push(p as u32);
                    image.push(s);
                }
            }
        }
    }
    if positions.len() < 2 {
        return Err(Error::Degenerate(format!(
            "holed slab: the annulus {a:e} m ≤ ρ ≤ {b:e} m holds {} sphere centres, need at \
             least 2",
            positions.len()
        )));
    }
    let packing = Packing::new(positions, radii, Some(PeriodicCell::new(lengths)?))?;
    Ok(SlabCut {
        packing,
        source,
        image,
        axis,
        slab: *slab,
    })
}
