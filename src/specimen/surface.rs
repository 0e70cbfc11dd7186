//! A lateral confining pressure as forces on the specimen's outermost particles.
//!
//! The lateral surface (a prism's four faces, or a cylinder's mantle) is cut into a grid of
//! cells about one mean diameter 2R̄ on a side; in every cell the particle whose surface
//! reaches farthest out (largest x·n + r over the centres that fall in the cell) carries the
//! pressure on the cell's area, pushing inwards through its centre (along the face's inward
//! normal, or radially for a cylinder). This is the principle of flexible (membrane)
//! boundaries in DEM — the pressure on the boundary surface is carried by the outermost
//! particles, each with its share of the surface's area (Kuhn 1995, "A flexible boundary for
//! three-dimensional DEM particle assemblies", Eng. Comput. 12, 175–183: triangular plates
//! between boundary particles, each plate's traction split among its corner particles) — on a
//! grid instead of a triangulation. A cell holding no centre gives its area to the nearest
//! cell that holds one, so the total force on each face is p × the face's area. The discrete
//! forces are then made self-equilibrated (a pressure on a closed surface is): the
//! least-squares correction removing their net lateral force and net moment about the axis is
//! applied and its size reported. On a simple-cubic block the grid matches the lattice and
//! every surface particle carries p (2R)², which the closed-form test checks.

use crate::{Error, Result, Vec3};
use serde::Serialize;

/// Cross-section of the specimen: it sets the area of `young` and the confining surface.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Default)]
#[serde(rename_all = "kebab-case")]
pub enum Shape {
    /// A prism: the bounding box of the spheres' surfaces across the axis.
    #[default]
    Prism,
    /// A cylinder about the axis through the middle of that box, of the radius reaching the
    /// farthest sphere surface.
    Cylinder,
}

/// The lateral confining pressure's discrete loads.
#[derive(Clone, Debug)]
pub(crate) struct SurfaceLoads {
    /// Force on every given particle (N; zero off the surface).
    pub force: Vec<Vec3>,
    /// Particles that carry a share.
    pub particles: usize,
    /// Lateral surface area (m²).
    pub area: f64,
    /// Cells of the grid, and those holding no centre.
    pub cells: usize,
    /// Cells whose area went to their nearest occupied cell.
    pub empty_cells: usize,
    /// ‖correction‖ / ‖forces before it‖ of the self-equilibration.
    pub correction: f64,
}

/// Cross-section geometry of the particles about `axis`: (lateral axes, prism box lower and
/// upper bounds of the spheres' surfaces, cylinder centre, cylinder radius).
pub(crate) struct Section {
    pub lateral: [usize; 2],
    pub lo: [f64; 2],
    pub hi: [f64; 2],
    pub centre: [f64; 2],
    pub radius: f64,
}

impl Section {
    pub(crate) fn of(centres: &[Vec3], radii: &[f64], axis: usize) -> Section {
        let lateral = [(axis + 1) % 3, (axis + 2) % 3];
        let mut lo = [f64::INFINITY; 2];
        let mut hi = [f64::NEG_INFINITY; 2];
        for (x, r) in centres.iter().zip(radii) {
            for k in 0..2 {
                lo[k] = lo[k].min(x[lateral[k]] - r);
                hi[k] = hi[k].max(x[lateral[k]] + r);
            }
        }
        let centre = [0.5 * (lo[0] + hi[0]), 0.5 * (lo[1] + hi[1])];
        let radius = centres
            .iter()
            .zip(radii)
            .map(|(x, r)| (x[lateral[0]] - centre[0]).hypot(x[lateral[1]] - centre[1]) + r)
            .fold(0.0, f64::max);
        Section {
            lateral,
            lo,
            hi,
            centre,
            radius,
        }
    }

    /// Cross-section area (m²) of `shape`.
    pub(crate) fn area(&self, shape: Shape) -> f64 {
        match shape {
            Shape::Prism => (self.hi[0] - self.lo[0]) * (self.hi[1] - self.lo[1]),
            Shape::Cylinder => std::f64::consts::PI * self.radius * self.radius,
        }
    }
}

/// Cells along a length at about `size` each (at least `min`).
fn cells_along(length: f64, size: f64, min: usize) -> usize {
    ((length / size).round() as usize).max(min)
}

/// One face's grid: per particle a cell index and a score (larger is farther out); returns the
/// winner of every cell after giving empty cells to their nearest occupied one, as
/// (winner, cells won). `dist(a, b)` is the distance between the centres of cells a and b.
fn winners(
    n_cells: usize,
    members: impl Iterator<Item = (usize, usize, f64)>,
    dist: impl Fn(usize, usize) -> f64,
) -> (Vec<Option<usize>>, usize) {
    let mut best: Vec<Option<(usize, f64)>> = vec![None; n_cells];
    for (p, c, score) in members {
        match best[c] {
            Some((_, s)) if s >= score => {}
            _ => best[c] = Some((p, score)),
        }
    }
    let occupied: Vec<usize> = (0..n_cells).filter(|&c| best[c].is_some()).collect();
    let mut empty = 0;
    let out = (0..n_cells)
        .map(|c| match best[c] {
            Some((p, _)) => Some(p),
            None => {
                empty += 1;
                occupied
                    .iter()
                    .min_by(|&&a, &&b| dist(c, a).total_cmp(&dist(c, b)))
                    .map(|&o| best[o].unwrap().0)
            }
        })
        .collect();
    (out, empty)
}

/// The confining loads of `pressure` (Pa, compression positive) on the particles `centres`,
/// `radii` of a specimen loaded along `axis` (see the module doc).
pub(crate) fn lateral_loads(
    centres: &[Vec3],
    radii: &[f64],
    axis: usize,
    shape: Shape,
    pressure: f64,
) -> Result<SurfaceLoads> {
    let n = centres.len();
    if n == 0 {
        return Err(Error::Degenerate("confining pressure: no particles".into()));
    }
    let size = 2.0 * radii.iter().sum::<f64>() / n as f64;
    let surface = Surface {
        centres,
        radii,
        sec: Section::of(centres, radii, axis),
        grid: AxialGrid::of(centres, radii, axis, size),
        size,
        pressure,
    };
    let mut raw = match shape {
        Shape::Prism => surface.prism(),
        Shape::Cylinder => surface.cylinder()?,
    };
    let (particles, correction) = self_equilibrate(&mut raw.force, centres, surface.sec.lateral);
    Ok(SurfaceLoads {
        force: raw.force,
        particles,
        area: raw.area,
        cells: raw.cells,
        empty_cells: raw.empty_cells,
        correction,
    })
}

/// The cells along the axis, about one mean diameter each, over the spheres' extent.
struct AxialGrid {
    axis: usize,
    /// Lowest sphere surface along the axis (m).
    lo: f64,
    /// Extent of the spheres' surfaces along the axis (m).
    height: f64,
    /// Cells along the axis.
    cells: usize,
    /// Cell length (m).
    h: f64,
}

impl AxialGrid {
    fn of(centres: &[Vec3], radii: &[f64], axis: usize, size: f64) -> AxialGrid {
        let lo = centres
            .iter()
            .zip(radii)
            .map(|(x, r)| x[axis] - r)
            .fold(f64::INFINITY, f64::min);
        let hi = centres
            .iter()
            .zip(radii)
            .map(|(x, r)| x[axis] + r)
            .fold(f64::NEG_INFINITY, f64::max);
        let height = hi - lo;
        let cells = cells_along(height, size, 1);
        AxialGrid {
            axis,
            lo,
            height,
            cells,
            h: height / cells as f64,
        }
    }

    /// The axial cell of a centre.
    fn cell(&self, x: &Vec3) -> usize {
        (((x[self.axis] - self.lo) / self.h) as usize).min(self.cells - 1)
    }
}

/// The surface's forces before self-equilibration, with its grid's counts and area.
struct RawLoads {
    force: Vec<Vec3>,
    cells: usize,
    empty_cells: usize,
    area: f64,
}

/// The lateral surface of the particles `centres`, `radii` under `pressure` (Pa): its section
/// and axial grid, cells of about `size` (m) on a side.
struct Surface<'a> {
    centres: &'a [Vec3],
    radii: &'a [f64],
    sec: Section,
    grid: AxialGrid,
    size: f64,
    pressure: f64,
}

impl Surface<'_> {
    /// A prism's four faces: on each, cells of about `size` across and along the axis; each
    /// cell's outermost particle carries pressure × cell area along the face's inward normal.
    fn prism(&self) -> RawLoads {
        let (centres, sec, grid) = (self.centres, &self.sec, &self.grid);
        let (n, na, ha) = (centres.len(), grid.cells, grid.h);
        let [l0, l1] = sec.lateral;
        let mut out = RawLoads {
            force: vec![Vec3::zeros(); n],
            cells: 0,
            empty_cells: 0,
            area: 0.0,
        };
        for (k, d) in [(0usize, l0), (1, l1)] {
            let e = [l0, l1][1 - k];
            let ext_e = sec.hi[1 - k] - sec.lo[1 - k];
            let ne = cells_along(ext_e, self.size, 1);
            let he = ext_e / ne as f64;
            let cell_area = he * ha;
            for s in [1.0, -1.0] {
                let members = (0..n).map(|p| {
                    let x = &centres[p];
                    let ie = (((x[e] - sec.lo[1 - k]) / he) as usize).min(ne - 1);
                    (p, ie * na + grid.cell(x), s * x[d] + self.radii[p])
                });
                let dist = |a: usize, b: usize| {
                    let (ea, aa) = ((a / na) as f64, (a % na) as f64);
                    let (eb, ab) = ((b / na) as f64, (b % na) as f64);
                    ((ea - eb) * he).hypot((aa - ab) * ha)
                };
                let (win, empty) = winners(ne * na, members, dist);
                for p in win.into_iter().flatten() {
                    out.force[p][d] -= s * self.pressure * cell_area;
                }
                out.cells += ne * na;
                out.empty_cells += empty;
                out.area += ext_e * grid.height;
            }
        }
        out
    }

    /// A cylinder's mantle: cells of about `size` around and along the axis; each cell's
    /// outermost particle carries pressure × cell area radially inwards. Refused when that
    /// particle lies on the axis (a specimen one particle thick).
    fn cylinder(&self) -> Result<RawLoads> {
        let (centres, sec, na, ha) = (self.centres, &self.sec, self.grid.cells, self.grid.h);
        let ([l0, l1], rc) = (sec.lateral, sec.radius);
        let nt = cells_along(2.0 * std::f64::consts::PI * rc, self.size, 3);
        let ht = 2.0 * std::f64::consts::PI / nt as f64;
        let cell_area = ht * rc * ha;
        let polar = |x: &Vec3| {
            let (a, b) = (x[l0] - sec.centre[0], x[l1] - sec.centre[1]);
            (
                a.hypot(b),
                b.atan2(a).rem_euclid(2.0 * std::f64::consts::PI),
            )
        };
        let members = (0..centres.len()).map(|p| {
            let (rho, th) = polar(&centres[p]);
            let it = ((th / ht) as usize).min(nt - 1);
            (
                p,
                it * na + self.grid.cell(&centres[p]),
                rho + self.radii[p],
            )
        });
        let dist = |a: usize, b: usize| {
            let dt = (a / na).abs_diff(b / na);
            let dt = dt.min(nt - dt) as f64;
            let da = (a % na).abs_diff(b % na) as f64;
            (dt * ht * rc).hypot(da * ha)
        };
        let (win, empty) = winners(nt * na, members, dist);
        let mut force = vec![Vec3::zeros(); centres.len()];
        for p in win.into_iter().flatten() {
            let (rho, _) = polar(&centres[p]);
            if rho <= 0.0 {
                return Err(Error::Degenerate(
                    "confining pressure: a particle on the cylinder's axis is its outermost \
                     one (the specimen is one particle thick)"
                        .into(),
                ));
            }
            let mut dir = Vec3::zeros();
            dir[l0] = (centres[p][l0] - sec.centre[0]) / rho;
            dir[l1] = (centres[p][l1] - sec.centre[1]) / rho;
            force[p] -= dir * (self.pressure * cell_area);
        }
        Ok(RawLoads {
            force,
            cells: nt * na,
            empty_cells: empty,
            area: 2.0 * std::f64::consts::PI * rc * self.grid.height,
        })
    }
}

/// Self-equilibrate the surface forces: remove, least squares, their net lateral force and
/// their net moment about the axis (the rigid-body modes frictionless platens leave free).
/// Returns the particles that carry a force and ‖correction‖/‖forces before it‖.
fn self_equilibrate(force: &mut [Vec3], centres: &[Vec3], lateral: [usize; 2]) -> (usize, f64) {
    let [l0, l1] = lateral;
    let loaded: Vec<usize> = (0..force.len())
        .filter(|&p| force[p].norm() > 0.0)
        .collect();
    let raw = loaded
        .iter()
        .map(|&p| force[p].norm_squared())
        .sum::<f64>()
        .sqrt();
    let m = loaded.len() as f64;
    let mean_f = loaded.iter().map(|&p| force[p]).sum::<Vec3>() / m;
    let mut centroid = [0.0; 2];
    for &p in &loaded {
        centroid[0] += centres[p][l0] / m;
        centroid[1] += centres[p][l1] / m;
    }
    let arm = |p: usize| {
        let mut t = Vec3::zeros(); // e_axis × ρ
        let (a, b) = (centres[p][l0] - centroid[0], centres[p][l1] - centroid[1]);
        t[l0] = -b;
        t[l1] = a;
        t
    };
    let (mut num, mut den) = (0.0, 0.0);
    for &p in &loaded {
        let t = arm(p);
        num += t.dot(&(force[p] - mean_f));
        den += t.norm_squared();
    }
    let w = if den > 0.0 { num / den } else { 0.0 };
    let mut corr = 0.0;
    for &p in &loaded {
        let c = mean_f + arm(p) * w;
        corr += c.norm_squared();
        force[p] -= c;
    }
    (loaded.len(), corr.sqrt() / raw)
}
