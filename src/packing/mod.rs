//! Spheres and their container: positions (m), radii (m) and an optional periodic cell.
//!
//! Submodules: `io.rs` reads and writes the SPEC text format, YADE SpherePack text and
//! LIGGGHTS `atom_style granular` data files; `neighbours.rs` finds all pairs within a
//! cutoff by cell lists in O(N); `generate.rs` makes seeded periodic random packings;
//! `routes.rs` prepares them by Kumar 2016's unjammed, weakly jammed and jammed routes.
//! `cut.rs` cuts free assemblies (a bar, a block) out of them, with boundary particle sets;
//! `container.rs` prepares a bar's spheres by the same routes inside a rigid cylinder and two
//! planes (Kumar 2016 Sec. 5).

pub(crate) mod container;
pub(crate) mod cut;
mod fire;
pub(crate) mod generate;
pub(crate) mod io;
pub(crate) mod neighbours;
pub mod presets;
mod repulsion;
pub(crate) mod routes;

pub use container::{container_particles, prepare_in_container, Container, ContainerPacking};
pub use cut::cut;
pub use cut::{cut_holed_slab, HoledSlab, Region};
pub use cut::{BoundarySets, Cut, SlabCut};
pub use generate::generate;
pub use generate::GenerationReport;
pub use generate::{
    generate_with_report, ForceBalance, GenerateOptions, Polydispersity,
    TRUSZKOWSKA_2018_HALF_WIDTH,
};
pub use io::read_liggghts_data;
pub use io::{
    detect_format, format_packing, parse_data, parse_data_boundary, parse_liggghts_data,
    parse_packing, parse_packing_as, read_packing, read_packing_as, write_liggghts_data,
    write_liggghts_data_with_ids, write_packing, write_yade_spherepack, CellChoice,
    CellOptionNames, CellOrigin, DataBonds, PackingFormat, PackingRead,
};
pub use neighbours::{pairs_within, pairs_within_centre_distance, Pair};
pub use routes::{
    prepare, prepare_with_status, scale_to_solid_fraction, PreparationRoute, RouteOptions,
    RouteReport, RouteStage, RouteStatus, DEFAULT_JAMMING_BALANCE, KUMAR_2016_SOLID_FRACTION,
};

use crate::{Error, Result, Vec3};

/// Orthorhombic periodic cell [0, Lx) × [0, Ly) × [0, Lz) (lengths in m), periodic along
/// every axis or, for a box of mixed periodicity (LAMMPS `boundary p p f`: a settled bed, a
/// slab), along some ([`PeriodicCell::periodic`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PeriodicCell {
    /// Edge lengths Lx, Ly, Lz (m).
    pub lengths: Vec3,
    /// Which axes are periodic. Along a non-periodic axis the length is the box's extent
    /// only: positions are not wrapped, images are 0, no bond crosses its faces. Every
    /// homogenisation, simulation and export needs all three periodic and refuses a mixed
    /// cell ([`PeriodicCell::require_fully_periodic`]).
    pub periodic: [bool; 3],
}

impl PeriodicCell {
    /// A cell with the given edge lengths, checked by [`PeriodicCell::check_lengths`],
    /// periodic along every axis.
    pub fn new(lengths: Vec3) -> Result<Self> {
        PeriodicCell::with_periodic(lengths, [true; 3])
    }

    /// A box periodic along the axes flagged in `periodic` (at least one), with the given
    /// edge lengths (checked as in [`PeriodicCell::new`]).
    pub fn with_periodic(lengths: Vec3, periodic: [bool; 3]) -> Result<Self> {
        if let Some(problem) = PeriodicCell::check_lengths(&lengths) {
            return Err(Error::Invalid(format!("periodic cell: {problem}")));
        }
        if !periodic.iter().any(|&p| p) {
            return Err(Error::Invalid(
                "periodic cell: no periodic axis (a box periodic along no axis is a free \
                 cluster: no cell)"
                    .into(),
            ));
        }
        Ok(PeriodicCell { lengths, periodic })
    }

    /// True when some axis is not periodic.
    pub fn is_mixed(&self) -> bool {
        self.periodic.iter().any(|&p| !p)
    }

    /// The boundary as LAMMPS writes it, e.g. `p p f`.
    pub fn boundary(&self) -> String {
        self.periodic.map(|p| if p { "p" } else { "f" }).join(" ")
    }

    /// Refuse ([`Error::Invalid`]) a cell of mixed periodicity for `what` (a tensor, a
    /// simulation, an export): those strain or deform a fully periodic cell; a box with a
    /// non-periodic axis is read and bonded (bonds across its periodic faces only) but has
    /// no such strain along that axis.
    pub fn require_fully_periodic(cell: Option<&PeriodicCell>, what: &str) -> Result<()> {
        match cell {
            Some(c) if c.is_mixed() => Err(Error::Invalid(format!(
                "{what}: the packing's box is periodic along some axes only (boundary {}); \
                 expected a fully periodic cell (p p p) or a free cluster: a mixed box is read \
                 and bonded (`anisobond bonds`) but not yet strained, simulated or exported",
                c.boundary()
            ))),
            _ => Ok(()),
        }
    }

    /// What is wrong with cell lengths `l`, if anything: each must be finite and > 0, and
    /// so must their product Lx·Ly·Lz (1e300³ overflows, 1e-300³ underflows). The one check
    /// of every way a cell is given (file headers, `--cell`, Python `cell=`).
    pub fn check_lengths(l: &Vec3) -> Option<String> {
        for (k, name) in ["Lx", "Ly", "Lz"].iter().enumerate() {
            if l[k] <= 0.0 || l[k].is_nan() {
                return Some(format!("cell length {name} must be > 0, found {}", l[k]));
            }
            if !l[k].is_finite() {
                return Some(format!("cell length {name} must be finite, found {}", l[k]));
            }
        }
        let v = l.x * l.y * l.z;
        if !v.is_finite() || v <= 0.0 {
            return Some(format!(
                "the cell volume Lx·Ly·Lz = {:e}·{:e}·{:e} m³ {}; expected cell lengths whose \
                 product is a finite number > 0",
                l.x,
                l.y,
                l.z,
                if v.is_finite() {
                    "underflows to 0"
                } else {
                    "overflows"
                }
            ));
        }
        None
    }

    /// Cell volume (m³).
    pub fn volume(&self) -> f64 {
        self.lengths.x * self.lengths.y * self.lengths.z
    }

    /// Wrap a position into the cell; returns the wrapped position and the integer shift
    /// that was removed (`p = wrapped + shift ∘ L`).
    pub fn wrap(&self, p: Vec3) -> (Vec3, [i32; 3]) {
        self.along_periodic_axes(p, |x, l| {
            let s = (x / l).floor();
            let mut w = x - s * l;
            let mut s = s as i32;
            // Guard against w == l from rounding.
            if w >= l {
                w -= l;
                s += 1;
            }
            if w < 0.0 {
                w = 0.0;
            }
            (w, s)
        })
    }

    /// Minimum-image branch vector for a raw difference `d = x_j − x_i` of wrapped
    /// positions: returns `(d + image ∘ L, image)` with every component in [−L/2, L/2]
    /// (along the periodic axes; a non-periodic one keeps `d`, image 0).
    pub fn minimum_image(&self, d: Vec3) -> (Vec3, [i32; 3]) {
        self.along_periodic_axes(d, |x, l| {
            let s = -(x / l).round();
            (x + s * l, s as i32)
        })
    }

    /// [`Self::minimum_image`] of the difference of two positions inside the cell (every
    /// |d_k| < 1.5 L_k, so the image shift is −1, 0 or 1): the same result, by comparisons
    /// instead of a rounding call (the neighbour search's inner loop).
    #[inline]
    pub fn minimum_image_near(&self, d: Vec3) -> (Vec3, [i32; 3]) {
        self.along_periodic_axes(d, |x, l| {
            let q = x / l;
            debug_assert!(
                q.abs() < 1.5,
                "minimum_image_near: |d| = {x} m ≥ 1.5 L = {l} m"
            );
            // round(q) for |q| < 1.5, halves away from zero as f64::round.
            let s = if q >= 0.5 {
                -1.0
            } else if q <= -0.5 {
                1.0
            } else {
                0.0
            };
            (x + s * l, s as i32)
        })
    }

    /// `v` with `f(v_k, L_k)` = (new component, image) applied along every periodic axis k;
    /// a non-periodic axis keeps its component, image 0.
    fn along_periodic_axes(&self, v: Vec3, f: impl Fn(f64, f64) -> (f64, i32)) -> (Vec3, [i32; 3]) {
        let mut out = v;
        let mut image = [0i32; 3];
        for k in (0..3).filter(|&k| self.periodic[k]) {
            (out[k], image[k]) = f(v[k], self.lengths[k]);
        }
        (out, image)
    }

    /// The shift vector `image ∘ L` (m).
    pub fn shift(&self, image: [i32; 3]) -> Vec3 {
        Vec3::new(
            image[0] as f64 * self.lengths.x,
            image[1] as f64 * self.lengths.y,
            image[2] as f64 * self.lengths.z,
        )
    }
}

/// A set of spheres, stored as structure of arrays.
#[derive(Clone, Debug, Default)]
pub struct Packing {
    /// Sphere centres (m); wrapped into the cell when the packing is periodic.
    pub positions: Vec<Vec3>,
    /// Sphere radii (m), all > 0.
    pub radii: Vec<f64>,
    /// The periodic cell, or `None` for a free (non-periodic) assembly.
    pub cell: Option<PeriodicCell>,
    /// The particles' own ids when the file gave them (LIGGGHTS atom ids, YADE body ids of
    /// `#format id_x_y_z_r_matId`), one per particle, distinct; written to bond tables as
    /// `id_i,id_j`. `None`: the particles are known by their index only.
    pub ids: Option<Vec<u64>>,
    /// The centres as given to [`Packing::new`] when wrapping moved any of them (YADE keeps
    /// periodic positions outside the cell), else `None`. Periodic images read or written
    /// (bond tables, [`crate::bonds::BondSet::from_pairs`]) are of these positions.
    pub given_positions: Option<Vec<Vec3>>,
}

impl Packing {
    /// Build a packing, checking finite positions and positive radii, and wrapping positions
    /// into the cell.
    pub fn new(positions: Vec<Vec3>, radii: Vec<f64>, cell: Option<PeriodicCell>) -> Result<Self> {
        if positions.len() != radii.len() {
            return Err(Error::Invalid(format!(
                "packing has {} positions but {} radii",
                positions.len(),
                radii.len()
            )));
        }
        for (k, (p, r)) in positions.iter().zip(&radii).enumerate() {
            if p.iter().any(|c| !c.is_finite()) {
                return Err(Error::Invalid(format!(
                    "sphere {k}: position is not finite"
                )));
            }
            if !r.is_finite() || *r <= 0.0 {
                return Err(Error::Invalid(format!(
                    "sphere {k}: radius must be finite and > 0, got {r}"
                )));
            }
        }
        let (positions, given_positions) = match &cell {
            Some(c) => {
                let wrapped: Vec<Vec3> = positions.iter().map(|p| c.wrap(*p).0).collect();
                let moved = wrapped.iter().zip(&positions).any(|(w, p)| w != p);
                (wrapped, moved.then_some(positions))
            }
            None => (positions, None),
        };
        Ok(Packing {
            positions,
            radii,
            cell,
            ids: None,
            given_positions,
        })
    }

    /// The cell shift s of sphere `i` that wrapping removed: position as given = stored
    /// position + s∘L ([`Packing::given_positions`]); zero when nothing was wrapped (or the
    /// stored position was changed since).
    pub fn given_shift(&self, i: usize) -> [i32; 3] {
        match (&self.cell, &self.given_positions) {
            (Some(c), Some(g)) => {
                let (w, s) = c.wrap(g[i]);
                if w == self.positions[i] {
                    s
                } else {
                    [0; 3]
                }
            }
            _ => [0; 3],
        }
    }

    /// The periodic image of j seen from i among the stored (wrapped) positions for an image
    /// `m` given among the positions as given: x_j + m∘L − x_i is the same branch vector when
    /// m' = m + s_j − s_i (s: [`Packing::given_shift`]).
    pub fn image_from_given(&self, i: usize, j: usize, m: [i32; 3]) -> [i32; 3] {
        let (si, sj) = (self.given_shift(i), self.given_shift(j));
        [0, 1, 2].map(|k| m[k] + sj[k] - si[k])
    }

    /// The inverse of [`Packing::image_from_given`]: the image among the positions as given.
    pub fn image_to_given(&self, i: usize, j: usize, m: [i32; 3]) -> [i32; 3] {
        let (si, sj) = (self.given_shift(i), self.given_shift(j));
        [0, 1, 2].map(|k| m[k] - sj[k] + si[k])
    }

    /// The positions as given (see [`Packing::given_positions`]): stored + shift∘L.
    pub fn given_position(&self, i: usize) -> Vec3 {
        match (&self.given_positions, &self.cell) {
            (Some(g), Some(_)) if self.given_shift(i) != [0; 3] => g[i],
            _ => self.positions[i],
        }
    }

    /// The packing with these particle ids (one per particle, all distinct).
    pub fn with_ids(mut self, ids: Vec<u64>) -> Result<Self> {
        if ids.len() != self.len() {
            return Err(Error::Invalid(format!(
                "packing has {} particles but {} ids",
                self.len(),
                ids.len()
            )));
        }
        let mut sorted = ids.clone();
        sorted.sort_unstable();
        if let Some(w) = sorted.windows(2).find(|w| w[0] == w[1]) {
            return Err(Error::Invalid(format!(
                "particle id {} appears twice",
                w[0]
            )));
        }
        self.ids = Some(ids);
        Ok(self)
    }

    /// Number of spheres.
    pub fn len(&self) -> usize {
        self.radii.len()
    }

    /// True when there are no spheres.
    pub fn is_empty(&self) -> bool {
        self.radii.is_empty()
    }

    /// Mean radius R̄ (m).
    pub fn mean_radius(&self) -> f64 {
        self.radii.iter().sum::<f64>() / self.len().max(1) as f64
    }

    /// Volume (m³): the cell's when periodic, else the axis-aligned bounding box of the
    /// spheres (surfaces included).
    pub fn volume(&self) -> f64 {
        match &self.cell {
            Some(c) => c.volume(),
            None => {
                let (lo, hi) = self.bounding_box();
                (hi - lo).iter().product()
            }
        }
    }

    /// Axis-aligned bounding box of the spheres including their radii.
    pub fn bounding_box(&self) -> (Vec3, Vec3) {
        let mut lo = Vec3::repeat(f64::INFINITY);
        let mut hi = Vec3::repeat(f64::NEG_INFINITY);
        for (p, r) in self.positions.iter().zip(&self.radii) {
            for k in 0..3 {
                lo[k] = lo[k].min(p[k] - r);
                hi[k] = hi[k].max(p[k] + r);
            }
        }
        (lo, hi)
    }

    /// Solid fraction φ = Σ(4/3)πR³ / V (overlaps counted twice).
    pub fn solid_fraction(&self) -> f64 {
        let vs: f64 = self
            .radii
            .iter()
            .map(|r| 4.0 / 3.0 * std::f64::consts::PI * r * r * r)
            .sum();
        vs / self.volume()
    }
}

/// Peak memory of packing preparation per particle (bytes), an upper estimate: the jammed
/// route measured 57 MB at 100,000 particles and 21–25 MB at 30,000 (positions, radii,
/// velocities, forces, Verlet lists of about 13 neighbours), so 1 kB per particle leaves
/// room for the neighbour lists of denser states.
pub const BYTES_PER_PARTICLE: f64 = 1000.0;

/// Refuse a packing size that cannot be made here: fewer than 2 or more than 2³² − 1
/// particles (indices are 32-bit), more memory than the machine has ([`BYTES_PER_PARTICLE`]),
/// or a mean radius whose cell volume N·(4/3)πR̄³/φ over- or underflows double precision.
pub fn check_packing_size(
    n_particles: usize,
    mean_radius: f64,
    solid_fraction: f64,
    what: &str,
) -> Result<()> {
    if !(2..=u32::MAX as usize).contains(&n_particles) {
        return Err(Error::Invalid(format!(
            "{what}: the number of particles must be between 2 and {} (32-bit indices), got \
             {n_particles}",
            u32::MAX
        )));
    }
    crate::io::check_memory(
        &format!("{what} of {n_particles} particles"),
        n_particles as f64 * BYTES_PER_PARTICLE,
    )?;
    let volume = n_particles as f64 * 4.0 / 3.0 * std::f64::consts::PI * mean_radius.powi(3)
        / solid_fraction;
    if !(volume.is_normal() && volume > 0.0) {
        return Err(Error::Invalid(format!(
            "{what}: mean radius {mean_radius:e} m gives a cell volume of {volume:e} m³, out \
             of the range of double precision; give the radius in metres (e.g. 1e-3)"
        )));
    }
    Ok(())
}
