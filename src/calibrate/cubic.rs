//! Cubic calibration: from a target (C12/C11, C44/C11[, C11]) to the spheroid scheme's
//! model, a_n, a_s, shear/normal magnitude ratio ρ and normal magnitude.
//!
//! The tensor's shape depends on (a_n, a_s, ρ) only; the magnitude scales it linearly
//! (mean field: exactly linear; relaxed: homogeneous of degree 1 in all springs). Two ratio
//! equations in three unknowns leave a curve of solutions (Truszkowska 2018 Sec. 6.3,
//! Fig. 12). Which point is returned ([`Family`]):
//! - `Nearest` (default): least microscopic heterogeneity — the point nearest a_n = a_s = 1
//!   in log space, i.e. minimising (ln a_n)² + (ln a_s)² (Sec. 6.3 "closest to one").
//! - `Equi`: on the equi-anisotropy plane a_n = a_s (Fig. 13), the root nearest a = 1.
//! - `Prolate` / `Oblate`: nearest a_n = a_s = 1 with normal-stiffness spheroids a_n > 1 /
//!   a_n < 1 (the two branches of Fig. 12).
//!
//! Mean-field level: the curve is D(ln a_n, ln a_s) = 0, the determinant of the two ratio
//! equations (each linear in ρ), located on a grid and refined by projected gradient
//! descent along it. Relaxed level: starting from the mean-field solution, a
//! minimum-norm Broyden iteration (`calibrate/broyden.rs`; Broyden 1965) on the relaxed ratios
//! of the actual packing, with the mean-field Jacobian as the initial one and a
//! warm-started relaxed solver; a point with negative bond stiffness along some direction
//! (extended models) is outside the admissible domain and shortens the step.

use super::broyden::{self, BroydenOptions, End, Evaluation, Point};
use super::kernel::{Cubic3, CubicKernel};
use super::target::CubicTarget;
use super::warm::WarmRelaxed;
use crate::bonds::BondSet;
use crate::homogenize::mean_field::mean_field_converged;
use crate::homogenize::relaxed::RelaxedOptions;
use crate::model::{Model, SchemeSpec};
use crate::packing::Packing;
use crate::schemes::cubic::{CubicModel, CubicSpheroid};
use crate::tensor::{rotate, CubicProjection, Stiffness6};
use crate::{Error, Mat3, Result};
use nalgebra::{DMatrix, DVector};

/// Which of the equivalent parameter sets to return (Truszkowska 2018 Sec. 6.3).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Family {
    /// Nearest a_n = a_s = 1: minimum of (ln a_n)² + (ln a_s)².
    #[default]
    Nearest,
    /// a_n = a_s (equi-anisotropy plane), nearest a = 1.
    Equi,
    /// Normal-stiffness spheroids prolate (a_n ≥ 1), nearest a_n = a_s = 1.
    Prolate,
    /// Normal-stiffness spheroids oblate (a_n ≤ 1), nearest a_n = a_s = 1.
    Oblate,
}

impl Family {
    /// Name as on the command line.
    pub fn as_str(self) -> &'static str {
        match self {
            Family::Nearest => "nearest",
            Family::Equi => "equi",
            Family::Prolate => "prolate",
            Family::Oblate => "oblate",
        }
    }

    /// The family named as on the command line (`nearest`, `equi`, `prolate`, `oblate`).
    pub fn from_name(name: &str) -> Result<Family> {
        [
            Family::Nearest,
            Family::Equi,
            Family::Prolate,
            Family::Oblate,
        ]
        .into_iter()
        .find(|f| f.as_str() == name)
        .ok_or_else(|| {
            Error::Invalid(format!(
                "family `{name}`: expected nearest, equi, prolate or oblate"
            ))
        })
    }

    fn allows_x(self, x: f64) -> bool {
        match self {
            Family::Prolate => x >= 0.0,
            Family::Oblate => x <= 0.0,
            _ => true,
        }
    }
}

/// The shape parameters of a cubic spheroid model.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CubicParameters {
    /// Z > 1 or Z < 1 model.
    pub model: CubicModel,
    /// With the ±½<110> terms (Sec. 6.1).
    pub extended: bool,
    /// Aspect ratio of the normal-stiffness spheroids.
    pub a_n: f64,
    /// Aspect ratio of the shear-stiffness spheroids.
    pub a_s: f64,
    /// Shear/normal magnitude ratio ρ (the paper's a_k).
    pub shear_over_normal: f64,
}

impl CubicParameters {
    /// The parameters at a point of the mean-field map: a_n = e^x, a_s = e^y, ρ.
    pub(crate) fn at(model: CubicModel, extended: bool, p: &MapPoint) -> Self {
        CubicParameters {
            model,
            extended,
            a_n: p.x.exp(),
            a_s: p.y.exp(),
            shear_over_normal: p.rho,
        }
    }

    /// Distance from a_n = a_s = 1 in log space, √((ln a_n)² + (ln a_s)²).
    pub fn log_distance(&self) -> f64 {
        self.a_n.ln().hypot(self.a_s.ln())
    }
}

/// Options of the cubic calibration.
#[derive(Clone, Copy, Debug)]
pub struct CubicOptions {
    /// Which solution of the non-unique set.
    pub family: Family,
    /// Use the extended (<110>) models.
    pub extended: bool,
    /// Force a model; `None` chooses by the target's Zener ratio (> 1: zener-above-1).
    pub model: Option<CubicModel>,
    /// Search box of a_n and a_s: [a_min, a_max].
    pub a_min: f64,
    /// Upper end of the a box.
    pub a_max: f64,
    /// Allowed shear/normal magnitude ratios [ratio_min, ratio_max].
    pub ratio_min: f64,
    /// Upper end of the ratio range.
    pub ratio_max: f64,
    /// Grid nodes per axis of the ln a box (odd, so that a = 1 is a node).
    pub grid: usize,
    /// Relaxed level: stop when every ratio is within this relative error of the target.
    pub tolerance: f64,
    /// Relaxed level: iteration limit (relaxed solves).
    pub max_iterations: usize,
    /// Relaxed solver options.
    pub relaxed: RelaxedOptions,
}

impl Default for CubicOptions {
    fn default() -> Self {
        CubicOptions {
            family: Family::Nearest,
            extended: false,
            model: None,
            a_min: 0.02,
            a_max: 50.0,
            ratio_min: 1e-3,
            ratio_max: 10.0,
            grid: 97,
            tolerance: 5e-4,
            max_iterations: 30,
            relaxed: RelaxedOptions::default(),
        }
    }
}

/// One relaxed iteration.
#[derive(Clone, Copy, Debug)]
pub struct IterationRecord {
    /// The parameters tried.
    pub parameters: CubicParameters,
    /// Relaxed C12/C11 reached.
    pub c12_over_c11: f64,
    /// Relaxed C44/C11 reached.
    pub c44_over_c11: f64,
    /// CG iterations of that solve (warm-started).
    pub cg_iterations: usize,
}

/// At which level the calibration was done.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Level {
    /// Mean-field orientation integral.
    MeanField,
    /// Exact relaxed tensor of a packing.
    Relaxed,
}

/// Result of a cubic calibration.
#[derive(Clone, Debug)]
pub struct CubicCalibration {
    /// The shape parameters found.
    pub parameters: CubicParameters,
    /// Normal magnitude (unit of the geometry convention).
    pub normal: f64,
    /// Shear magnitude.
    pub shear: f64,
    /// Level.
    pub level: Level,
    /// The target.
    pub target: CubicTarget,
    /// Achieved tensor in the crystal frame (Pa).
    pub achieved: Stiffness6,
    /// Its cubic projection (Truszkowska 2018 Eq. 30).
    pub achieved_cubic: CubicProjection,
    /// Relaxed level: the mean-field solution it started from.
    pub mean_field_start: Option<CubicParameters>,
    /// Relaxed level: the iterations.
    pub history: Vec<IterationRecord>,
}

impl CubicCalibration {
    /// Target constants (C11, C12, C44) in Pa; C11 is the achieved one for a ratio target.
    pub fn target_constants(&self) -> (f64, f64, f64) {
        self.target.constants(self.achieved_cubic.c11)
    }

    /// The base model with its scheme replaced by the calibrated one (rotation kept).
    pub fn model(&self, base: &Model) -> Model {
        let mut m = base.clone();
        m.scheme = SchemeSpec::Cubic(CubicSpheroid {
            model: self.parameters.model,
            extended: self.parameters.extended,
            a_n: self.parameters.a_n,
            a_s: self.parameters.a_s,
            normal: self.normal,
            shear: self.shear,
            rotation: base_rotation(base),
        });
        m
    }
}

/// Crystal rotation of a cubic base model (identity for other schemes).
pub fn base_rotation(base: &Model) -> Mat3 {
    match &base.scheme {
        SchemeSpec::Cubic(c) => c.rotation,
        _ => Mat3::identity(),
    }
}

pub use crate::homogenize::mean_field::packing_prefactor;

/// The model a target's Zener ratio calls for (Truszkowska 2018 Sec. 3).
pub fn model_for_zener(zener: f64) -> CubicModel {
    if zener >= 1.0 {
        CubicModel::ZenerAbove1
    } else {
        CubicModel::ZenerBelow1
    }
}

/// A point of the mean-field map: ln a_n, ln a_s, ρ.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MapPoint {
    /// ln a_n.
    pub x: f64,
    /// ln a_s.
    pub y: f64,
    /// ρ = shear/normal.
    pub rho: f64,
}

/// The mean-field ratio map of one model, with grid tables for the searches.
pub struct MeanFieldMap<'k> {
    kernel: &'k CubicKernel,
    /// Model.
    pub model: CubicModel,
    /// Extended.
    pub extended: bool,
    grid: Vec<f64>,
    normal: Vec<Cubic3>,
    shear: Vec<Cubic3>,
    /// Admissible ln a_n interval (non-negative normal stiffness).
    pub x_range: (f64, f64),
    /// Admissible ln a_s interval (non-negative shear stiffness).
    pub y_range: (f64, f64),
    ln_rho: (f64, f64),
}

/// The ln a interval around 0 inside [lo, hi] on which the extended `model` with
/// a_n = a_s = a keeps its normal (`normal`) or else its shear factor ≥ 0 on the whole
/// sphere (see [`admissible_interval`]).
pub(crate) fn extended_interval(model: CubicModel, lo: f64, hi: f64, normal: bool) -> (f64, f64) {
    admissible_interval(lo, hi, |x| {
        let a = x.exp();
        CubicSpheroid {
            model,
            extended: true,
            a_n: a,
            a_s: a,
            normal: 1.0,
            shear: 1.0,
            rotation: Mat3::identity(),
        }
        .parameters_checked()
        .map(|s| {
            if normal {
                s.min_normal_factor().0
            } else {
                s.min_shear_factor().0
            }
        })
        .unwrap_or(-1.0)
            >= 0.0
    })
}

/// Largest interval around ln a = 0 inside [lo, hi] on which `ok` holds (bisection; `ok(0)`
/// is assumed).
pub(crate) fn admissible_interval(lo: f64, hi: f64, ok: impl Fn(f64) -> bool) -> (f64, f64) {
    let edge = |end: f64| -> f64 {
        if ok(end) {
            return end;
        }
        let (mut good, mut bad) = (0.0, end);
        for _ in 0..30 {
            let mid = 0.5 * (good + bad);
            if ok(mid) {
                good = mid;
            } else {
                bad = mid;
            }
        }
        good
    };
    (edge(lo), edge(hi))
}

impl<'k> MeanFieldMap<'k> {
    /// Tables of the model's normal and shear parts on the ln a grid of `opts`.
    pub fn new(
        kernel: &'k CubicKernel,
        model: CubicModel,
        extended: bool,
        opts: &CubicOptions,
    ) -> Result<Self> {
        if !(opts.a_min > 0.0 && opts.a_min < 1.0 && opts.a_max > 1.0 && opts.a_max.is_finite()) {
            return Err(Error::Invalid(format!(
                "calibration: the a box [{}, {}] must contain 1 and have a_min > 0",
                opts.a_min, opts.a_max
            )));
        }
        if !(opts.ratio_min > 0.0 && opts.ratio_max > opts.ratio_min && opts.ratio_max.is_finite())
        {
            return Err(Error::Invalid(format!(
                "calibration: the shear/normal range [{}, {}] must satisfy 0 < min < max",
                opts.ratio_min, opts.ratio_max
            )));
        }
        let (lo, hi) = (opts.a_min.ln(), opts.a_max.ln());
        let half = (opts.grid.max(9) / 2) as i64;
        // Nodes: half on each side of 0, so that a = 1 is a node.
        let mut grid = Vec::new();
        for k in -half..=half {
            let t = k as f64 / half as f64;
            grid.push(if t < 0.0 { -t * lo } else { t * hi });
        }
        let (x_range, y_range) = if extended {
            (
                extended_interval(model, lo, hi, true),
                extended_interval(model, lo, hi, false),
            )
        } else {
            ((lo, hi), (lo, hi))
        };
        let normal = grid
            .iter()
            .map(|&x| kernel.normal_part(model, extended, x.exp()))
            .collect();
        let shear = grid
            .iter()
            .map(|&y| kernel.shear_part(model, extended, y.exp()))
            .collect();
        Ok(MeanFieldMap {
            kernel,
            model,
            extended,
            grid,
            normal,
            shear,
            x_range,
            y_range,
            ln_rho: (opts.ratio_min.ln(), opts.ratio_max.ln()),
        })
    }

    fn admissible(&self, p: &MapPoint) -> bool {
        p.x >= self.x_range.0 - 1e-12
            && p.x <= self.x_range.1 + 1e-12
            && p.y >= self.y_range.0 - 1e-12
            && p.y <= self.y_range.1 + 1e-12
            && p.rho.is_finite()
            && p.rho.ln() >= self.ln_rho.0 - 1e-12
            && p.rho.ln() <= self.ln_rho.1 + 1e-12
    }

    /// Exact mean-field constants per unit prefactor and unit normal magnitude.
    pub fn constants(&self, p: &MapPoint) -> Cubic3 {
        self.kernel
            .constants(self.model, self.extended, p.x.exp(), p.y.exp(), p.rho)
    }

    /// Mean-field ratios (C12/C11, C44/C11).
    pub fn ratios(&self, p: &MapPoint) -> (f64, f64) {
        self.constants(p).ratios()
    }

    /// Coefficients (a1, b1, a2, b2) of the ratio equations a_i + ρ·b_i = 0.
    fn equations(n: &Cubic3, s: &Cubic3, t: &CubicTarget) -> [f64; 4] {
        let (r12, r44) = (t.c12_over_c11, t.c44_over_c11);
        [
            n.c12 - r12 * n.c11,
            s.c12 - r12 * s.c11,
            n.c44 - r44 * n.c11,
            s.c44 - r44 * s.c11,
        ]
    }

    fn determinant(e: &[f64; 4]) -> f64 {
        e[0] * e[3] - e[2] * e[1]
    }

    /// ρ solving the better conditioned of the two equations.
    fn rho_of(e: &[f64; 4]) -> f64 {
        if e[1].abs() >= e[3].abs() {
            -e[0] / e[1]
        } else {
            -e[2] / e[3]
        }
    }

    /// Exact (D, ρ) at (x, y).
    fn curve(&self, t: &CubicTarget, x: f64, y: f64) -> (f64, f64) {
        let n = self.kernel.normal_part(self.model, self.extended, x.exp());
        let s = self.kernel.shear_part(self.model, self.extended, y.exp());
        let e = Self::equations(&n, &s, t);
        (Self::determinant(&e), Self::rho_of(&e))
    }

    /// Move (x, y) onto D = 0 by Newton steps along ∇D; `None` if that fails.
    fn project(&self, t: &CubicTarget, mut x: f64, mut y: f64) -> Option<MapPoint> {
        const H: f64 = 1e-6;
        for _ in 0..30 {
            let (d, rho) = self.curve(t, x, y);
            let (dxp, _) = self.curve(t, x + H, y);
            let (dxm, _) = self.curve(t, x - H, y);
            let (dyp, _) = self.curve(t, x, y + H);
            let (dym, _) = self.curve(t, x, y - H);
            let (gx, gy) = ((dxp - dxm) / (2.0 * H), (dyp - dym) / (2.0 * H));
            let g2 = gx * gx + gy * gy;
            if !g2.is_finite() || g2 == 0.0 {
                return None;
            }
            let scale = g2.sqrt();
            if (d / scale).abs() < 1e-13 {
                return Some(MapPoint { x, y, rho });
            }
            let (sx, sy) = (d * gx / g2, d * gy / g2);
            if sx.hypot(sy) > 1.0 {
                return None;
            }
            x -= sx;
            y -= sy;
        }
        None
    }

    /// Gradient of D at p by central differences.
    fn gradient(&self, t: &CubicTarget, p: &MapPoint) -> (f64, f64) {
        const H: f64 = 1e-6;
        let gx = (self.curve(t, p.x + H, p.y).0 - self.curve(t, p.x - H, p.y).0) / (2.0 * H);
        let gy = (self.curve(t, p.x, p.y + H).0 - self.curve(t, p.x, p.y - H).0) / (2.0 * H);
        (gx, gy)
    }

    /// Slide along D = 0 towards the origin (projected gradient descent of x² + y²).
    fn slide_to_nearest(&self, t: &CubicTarget, start: MapPoint, family: Family) -> MapPoint {
        let mut p = start;
        let mut h = 0.5;
        for _ in 0..300 {
            let (gx, gy) = self.gradient(t, &p);
            let g = gx.hypot(gy);
            if g == 0.0 || !g.is_finite() {
                break;
            }
            let (tx, ty) = (-gy / g, gx / g);
            let slope = p.x * tx + p.y * ty; // ½ d(x² + y²)/ds along the tangent
            if slope.abs() < 1e-10 || h < 1e-9 {
                break;
            }
            let step = -h * slope;
            let moved = self.project(t, p.x + step * tx, p.y + step * ty);
            match moved {
                Some(q)
                    if self.admissible(&q)
                        && family.allows_x(q.x)
                        && q.x * q.x + q.y * q.y < p.x * p.x + p.y * p.y =>
                {
                    p = q;
                    h = (h * 1.5).min(1.0);
                }
                _ => h *= 0.5,
            }
        }
        p
    }

    /// The solution of the target's two ratio equations chosen by `family`, if one exists
    /// in the box.
    pub fn solve(&self, t: &CubicTarget, family: Family) -> Option<MapPoint> {
        let n = self.grid.len();
        let d: Vec<Vec<f64>> = (0..n)
            .map(|i| {
                (0..n)
                    .map(|j| {
                        Self::determinant(&Self::equations(&self.normal[i], &self.shear[j], t))
                    })
                    .collect()
            })
            .collect();
        if family == Family::Equi {
            return self.solve_equi(t, &d);
        }
        let mut candidates: Vec<MapPoint> = Vec::new();
        for (x, y) in self.edge_guesses(t, &d, family) {
            if let Some(p) = self.project(t, x, y) {
                if self.admissible(&p) && family.allows_x(p.x) {
                    candidates.push(p);
                }
            }
        }
        candidates
            .into_iter()
            .map(|p| self.slide_to_nearest(t, p, family))
            .min_by(|a, b| (a.x * a.x + a.y * a.y).total_cmp(&(b.x * b.x + b.y * b.y)))
    }

    /// [`Self::solve`] on the equi-anisotropy plane x = y: bisection on the grid's diagonal
    /// wherever the determinant `d` changes sign, the admissible root nearest x = 0.
    fn solve_equi(&self, t: &CubicTarget, d: &[Vec<f64>]) -> Option<MapPoint> {
        let mut candidates: Vec<MapPoint> = Vec::new();
        for i in 0..self.grid.len() - 1 {
            let (d0, d1) = (d[i][i], d[i + 1][i + 1]);
            if d0 * d1 <= 0.0 {
                let (mut lo, mut hi, mut dlo) = (self.grid[i], self.grid[i + 1], d0);
                for _ in 0..60 {
                    let mid = 0.5 * (lo + hi);
                    let (dm, _) = self.curve(t, mid, mid);
                    if dm * dlo <= 0.0 {
                        hi = mid;
                    } else {
                        lo = mid;
                        dlo = dm;
                    }
                }
                let x = 0.5 * (lo + hi);
                let (_, rho) = self.curve(t, x, x);
                let p = MapPoint { x, y: x, rho };
                if self.admissible(&p) {
                    candidates.push(p);
                }
            }
        }
        candidates
            .into_iter()
            .min_by(|a, b| a.x.abs().total_cmp(&b.x.abs()))
    }

    /// First guesses on the solution curve: where the determinant `d` changes sign along a
    /// grid edge (linear interpolation), with an admissible interpolated ρ in the family;
    /// the four nearest the origin, nearest first.
    fn edge_guesses(&self, t: &CubicTarget, d: &[Vec<f64>], family: Family) -> Vec<(f64, f64)> {
        let n = self.grid.len();
        let mut guesses: Vec<(f64, f64, f64)> = Vec::new();
        for i in 0..n {
            for j in 0..n {
                for (i2, j2) in [(i + 1, j), (i, j + 1)] {
                    if i2 >= n || j2 >= n {
                        continue;
                    }
                    let (d0, d1) = (d[i][j], d[i2][j2]);
                    if d0 * d1 > 0.0 || (d0 == 0.0 && d1 == 0.0) {
                        continue;
                    }
                    let s = d0 / (d0 - d1);
                    let x = self.grid[i] + s * (self.grid[i2] - self.grid[i]);
                    let y = self.grid[j] + s * (self.grid[j2] - self.grid[j]);
                    let (n0, s0) = (self.normal[i], self.shear[j]);
                    let nn = n0.plus_scaled(s, &self.normal[i2].minus(&n0));
                    let ss = s0.plus_scaled(s, &self.shear[j2].minus(&s0));
                    let rho = Self::rho_of(&Self::equations(&nn, &ss, t));
                    let p = MapPoint { x, y, rho };
                    if !(self.admissible(&p) && family.allows_x(x)) {
                        continue;
                    }
                    guesses.push((x * x + y * y, x, y));
                }
            }
        }
        guesses.sort_by(|a, b| a.0.total_cmp(&b.0));
        guesses.iter().take(4).map(|&(_, x, y)| (x, y)).collect()
    }

    /// The admissible point whose ratios come nearest the target's (Euclidean distance in
    /// the (C12/C11, C44/C11) plane), and that distance.
    pub fn nearest_reachable(&self, t: &CubicTarget) -> (MapPoint, f64) {
        let dist = |c: &Cubic3| {
            let (r12, r44) = c.ratios();
            (r12 - t.c12_over_c11).hypot(r44 - t.c44_over_c11)
        };
        let n = self.grid.len();
        let n_rho = 41;
        let mut best = (
            f64::INFINITY,
            MapPoint {
                x: 0.0,
                y: 0.0,
                rho: 1.0,
            },
        );
        for i in 0..n {
            for j in 0..n {
                for k in 0..n_rho {
                    let s = self.ln_rho.0 + (self.ln_rho.1 - self.ln_rho.0) * k as f64 / 40.0;
                    let p = MapPoint {
                        x: self.grid[i],
                        y: self.grid[j],
                        rho: s.exp(),
                    };
                    if !self.admissible(&p) {
                        continue;
                    }
                    let dd = dist(&self.normal[i].plus_scaled(p.rho, &self.shear[j]));
                    if dd < best.0 {
                        best = (dd, p);
                    }
                }
            }
        }
        // Compass search in (x, y, ln ρ).
        let (mut value, mut p) = best;
        let mut h = (self.grid[1] - self.grid[0]).abs().max(0.05);
        while h > 1e-7 {
            let mut improved = false;
            for (dx, dy, ds) in [
                (1.0, 0.0, 0.0),
                (-1.0, 0.0, 0.0),
                (0.0, 1.0, 0.0),
                (0.0, -1.0, 0.0),
                (0.0, 0.0, 1.0),
                (0.0, 0.0, -1.0),
            ] {
                let q = MapPoint {
                    x: p.x + h * dx,
                    y: p.y + h * dy,
                    rho: (p.rho.ln() + h * ds).exp(),
                };
                if !self.admissible(&q) {
                    continue;
                }
                let v = dist(&self.constants(&q));
                if v < value {
                    (value, p) = (v, q);
                    improved = true;
                    break;
                }
            }
            if !improved {
                h *= 0.5;
            }
        }
        (p, value)
    }

    /// Jacobian of the ratios with respect to (ln a_n, ln a_s, ln ρ), central differences.
    pub fn jacobian(&self, p: &MapPoint) -> [[f64; 3]; 2] {
        const H: f64 = 1e-4;
        let mut j = [[0.0; 3]; 2];
        let [row12, row44] = &mut j;
        for (k, (d12, d44)) in row12.iter_mut().zip(row44.iter_mut()).enumerate() {
            let shift = |sign: f64| {
                let mut q = *p;
                match k {
                    0 => q.x += sign * H,
                    1 => q.y += sign * H,
                    _ => q.rho *= (sign * H).exp(),
                }
                self.ratios(&q)
            };
            let (p12, p44) = shift(1.0);
            let (m12, m44) = shift(-1.0);
            *d12 = (p12 - m12) / (2.0 * H);
            *d44 = (p44 - m44) / (2.0 * H);
        }
        j
    }
}

/// Format (C12/C11, C44/C11) with the derived Zener and Poisson ratios.
fn describe_ratios(r12: f64, r44: f64, c11: Option<f64>) -> String {
    let zener = 2.0 * r44 / (1.0 - r12);
    let nu = r12 / (1.0 + r12);
    match c11 {
        Some(c11) => format!(
            "C11 = {:.4} GPa, C12 = {:.4} GPa, C44 = {:.4} GPa (C12/C11 = {r12:.4}, C44/C11 = {r44:.4}, Zener {zener:.4}, ν100 {nu:.4})",
            c11 / 1e9,
            r12 * c11 / 1e9,
            r44 * c11 / 1e9
        ),
        None => format!(
            "C12/C11 = {r12:.4}, C44/C11 = {r44:.4} (Zener {zener:.4}, ν100 {nu:.4})"
        ),
    }
}

/// The error for a target outside the mean-field domain of `map`, with the nearest reachable
/// tensor and, when the extended model reaches it, that suggestion.
pub(super) fn unreachable_error(
    kernel: &CubicKernel,
    map: &MeanFieldMap,
    t: &CubicTarget,
    opts: &CubicOptions,
    level: &str,
) -> Error {
    let (p, dist) = map.nearest_reachable(t);
    let (r12, r44) = map.ratios(&p);
    let name = |ext: bool| {
        format!(
            "{}{}",
            map.model.as_str(),
            if ext { " (extended)" } else { "" }
        )
    };
    let mut msg = format!(
        "target {} is outside the domain the {} model reaches at the {level} level{}.\n  nearest reachable: {} with a_n = {:.4}, a_s = {:.4}, shear/normal = {:.4} (distance {dist:.4} in the C12/C11–C44/C11 plane)",
        describe_ratios(t.c12_over_c11, t.c44_over_c11, t.c11),
        name(map.extended),
        if opts.family != Family::Nearest {
            format!(" on the `{}` family", opts.family.as_str())
        } else {
            String::new()
        },
        describe_ratios(r12, r44, t.c11),
        p.x.exp(),
        p.y.exp(),
        p.rho
    );
    if t.c12_over_c11 > t.c44_over_c11 {
        msg.push_str("\n  C12 > C44: beyond the Cauchy line, which no model reaches under uniform strain (Truszkowska 2018 App. D); only non-affine relaxation on a packing (--on relaxed PACKING) can cross it, and only a little");
    }
    if !map.extended {
        if let Ok(ext) = MeanFieldMap::new(kernel, map.model, true, opts) {
            if ext.solve(t, opts.family).is_some() {
                msg.push_str(&format!(
                    "\n  the extended <110> model reaches this target: set `extended = true` in the model file (or pass --extended), model {}",
                    name(true)
                ));
            } else {
                let (q, d2) = ext.nearest_reachable(t);
                if d2 < dist {
                    let (e12, e44) = ext.ratios(&q);
                    msg.push_str(&format!(
                        "\n  the extended <110> model comes nearer ({}, distance {d2:.4}; `extended = true`)",
                        describe_ratios(e12, e44, t.c11)
                    ));
                }
            }
        }
    }
    Error::Invalid(msg)
}

fn check_magnitude(name: &str, v: f64) -> Result<()> {
    if !v.is_finite() || v <= 0.0 {
        return Err(Error::Invalid(format!(
            "calibration: {name} must be finite and > 0, got {v}"
        )));
    }
    Ok(())
}

/// The model both calibrations solve in (`opts.model`, else the one for the target's Zener
/// ratio) and its mean-field map, after checking `default_normal`.
pub(super) fn target_map<'k>(
    kernel: &'k CubicKernel,
    target: &CubicTarget,
    default_normal: f64,
    opts: &CubicOptions,
) -> Result<(CubicModel, MeanFieldMap<'k>)> {
    check_magnitude("the default normal magnitude", default_normal)?;
    let model = opts.model.unwrap_or(model_for_zener(target.zener()));
    Ok((
        model,
        MeanFieldMap::new(kernel, model, opts.extended, opts)?,
    ))
}

/// Mean-field calibration (no packing).
///
/// `prefactor` = N_c⟨l²·g⟩/V of the assembly (`packing_prefactor`, or
/// [`crate::homogenize::mean_field::equal_sphere_prefactor`] × g); `default_normal` is the
/// normal magnitude used when the target gives ratios only. The achieved tensor is
/// recomputed with the general mean-field integral ([`crate::homogenize::mean_field()`]) as a check.
pub fn calibrate_cubic_mean_field(
    target: &CubicTarget,
    prefactor: f64,
    default_normal: f64,
    opts: &CubicOptions,
) -> Result<CubicCalibration> {
    check_magnitude("the mean-field prefactor", prefactor)?;
    let kernel = CubicKernel::default();
    let (model, map) = target_map(&kernel, target, default_normal, opts)?;
    let p = map
        .solve(target, opts.family)
        .ok_or_else(|| unreachable_error(&kernel, &map, target, opts, "mean-field"))?;
    let unit = map.constants(&p);
    let normal = match target.c11 {
        Some(c11) => c11 / (prefactor * unit.c11),
        None => default_normal,
    };
    let parameters = CubicParameters::at(model, opts.extended, &p);
    let scheme = CubicSpheroid::new(
        model,
        opts.extended,
        parameters.a_n,
        parameters.a_s,
        normal,
        normal * p.rho,
        Mat3::identity(),
    )?;
    let achieved = mean_field_converged(&scheme, prefactor)?;
    Ok(CubicCalibration {
        parameters,
        normal,
        shear: normal * p.rho,
        level: Level::MeanField,
        target: *target,
        achieved_cubic: CubicProjection::from_stiffness(&achieved),
        achieved,
        mean_field_start: None,
        history: Vec::new(),
    })
}

/// Relaxed calibration on a periodic bonded packing: the cubic projection of the exact
/// relaxed tensor (in the crystal frame of `base`'s rotation) matches the target.
///
/// `base` gives the geometry convention and the crystal rotation; `bonds` must be the bonds
/// of `packing` under `base`'s bonding rule. Starts from the mean-field solution (or, for a
/// target outside the mean-field domain, from the nearest mean-field point) and iterates
/// minimum-norm Broyden steps, each one warm-started relaxed solve.
pub fn calibrate_cubic_relaxed(
    packing: &Packing,
    bonds: &BondSet,
    base: &Model,
    target: &CubicTarget,
    default_normal: f64,
    opts: &CubicOptions,
) -> Result<CubicCalibration> {
    super::check_iteration_options(opts.tolerance, opts.max_iterations)?;
    let kernel = CubicKernel::default();
    let (model, map) = target_map(&kernel, target, default_normal, opts)?;
    let start = map
        .solve(target, opts.family)
        .unwrap_or_else(|| map.nearest_reachable(target).0);
    let vars = CubicVariables {
        map: &map,
        equi: opts.family == Family::Equi,
    };
    let mut eval = RelaxedCubicEvaluator {
        base,
        model,
        extended: opts.extended,
        rotation: base_rotation(base),
        solver: WarmRelaxed::new(packing, bonds, opts.relaxed),
        history: Vec::new(),
    };
    let goal = DVector::from_vec(vec![target.c12_over_c11, target.c44_over_c11]);
    let u0 = vars.start(&start);
    let p0 = vars.point(&u0);
    let (_, proj0) = eval.admissible(&p0, default_normal)?;
    let result = broyden::solve(
        Point {
            f: ratio_residual(&proj0, &goal),
            x: u0,
            data: proj0,
        },
        vars.jacobian(&p0),
        |u| {
            Ok(match eval.evaluate(&vars.point(u), default_normal)? {
                Some((_, proj)) => Evaluation::Admissible(ratio_residual(&proj, &goal), proj),
                None => Evaluation::Inadmissible,
            })
        },
        |u| vars.clamp(u),
        |u| vars.jacobian(&vars.point(u)),
        &relaxed_broyden_options(target, opts),
    )?;
    let p = vars.point(&result.point.x);
    let proj = result.point.data;
    if !matches!(result.end, End::Converged) {
        let nearest = nearest_record(&eval.history, &goal);
        return Err(relaxed_not_converged(
            (&map, target, opts),
            &result,
            nearest,
        ));
    }
    // The relaxed tensor is homogeneous of degree 1 in the springs: scale to the target C11,
    // then confirm with one more (warm, hence nearly free) solve.
    let normal = target
        .c11
        .map_or(default_normal, |c11| default_normal * c11 / proj.c11);
    let (achieved, achieved_cubic) = eval.admissible(&p, normal)?;
    eval.history.pop();
    Ok(CubicCalibration {
        parameters: CubicParameters::at(model, opts.extended, &p),
        normal,
        shear: normal * p.rho,
        level: Level::Relaxed,
        target: *target,
        achieved,
        achieved_cubic,
        mean_field_start: Some(CubicParameters::at(model, opts.extended, &start)),
        history: eval.history,
    })
}

/// The residual of the relaxed calibration: the projection's (C12/C11, C44/C11) minus the
/// target's `goal`.
fn ratio_residual(proj: &CubicProjection, goal: &DVector<f64>) -> DVector<f64> {
    DVector::from_vec(vec![proj.c12 / proj.c11, proj.c44 / proj.c11]) - goal
}

/// Broyden's options of the relaxed calibration: the ratios' errors scaled by the target
/// ratios (at least 0.02), log-space steps of at most a factor e^0.7 ≈ 2 in a_n, a_s or ρ.
fn relaxed_broyden_options(target: &CubicTarget, opts: &CubicOptions) -> BroydenOptions {
    BroydenOptions {
        tolerance: opts.tolerance,
        scale: DVector::from_vec(vec![
            target.c12_over_c11.abs().max(0.02),
            target.c44_over_c11.abs().max(0.02),
        ]),
        max_evaluations: opts.max_iterations,
        max_step: 0.7,
        max_trials: 4,
    }
}

/// The free variables of the relaxed cubic calibration: (x, y, ln ρ), or (x, ln ρ) with
/// y = x on the equi-anisotropy plane, kept inside the mean-field map's box.
struct CubicVariables<'m> {
    /// The mean-field map (its box, its Jacobian).
    map: &'m MeanFieldMap<'m>,
    /// On the equi-anisotropy plane a_n = a_s.
    equi: bool,
}

impl CubicVariables<'_> {
    /// The variables of a map point.
    fn start(&self, p: &MapPoint) -> DVector<f64> {
        if self.equi {
            DVector::from_vec(vec![p.x, p.rho.ln()])
        } else {
            DVector::from_vec(vec![p.x, p.y, p.rho.ln()])
        }
    }

    /// The map point of the variables `u`.
    fn point(&self, u: &DVector<f64>) -> MapPoint {
        if self.equi {
            MapPoint {
                x: u[0],
                y: u[0],
                rho: u[1].exp(),
            }
        } else {
            MapPoint {
                x: u[0],
                y: u[1],
                rho: u[2].exp(),
            }
        }
    }

    /// Clamp `u` into the map's box.
    fn clamp(&self, u: &mut DVector<f64>) {
        let map = self.map;
        u[0] = u[0].clamp(map.x_range.0, map.x_range.1);
        if self.equi {
            u[0] = u[0].clamp(map.y_range.0, map.y_range.1);
        } else {
            u[1] = u[1].clamp(map.y_range.0, map.y_range.1);
        }
        let last = if self.equi { 1 } else { 2 };
        u[last] = u[last].clamp(map.ln_rho.0, map.ln_rho.1);
    }

    /// The mean-field Jacobian of the two ratios in the variables (the Broyden start and
    /// restart).
    fn jacobian(&self, p: &MapPoint) -> DMatrix<f64> {
        let j = self.map.jacobian(p);
        if self.equi {
            DMatrix::from_row_slice(
                2,
                2,
                &[j[0][0] + j[0][1], j[0][2], j[1][0] + j[1][1], j[1][2]],
            )
        } else {
            DMatrix::from_row_slice(
                2,
                3,
                &[j[0][0], j[0][1], j[0][2], j[1][0], j[1][1], j[1][2]],
            )
        }
    }
}

/// The relaxed tensor of the packing at points of the cubic map (warm-started solves), each
/// recorded in the calibration's history.
struct RelaxedCubicEvaluator<'a> {
    /// The model whose geometry convention the springs follow.
    base: &'a Model,
    /// The cubic model calibrated.
    model: CubicModel,
    /// Extended <110> models.
    extended: bool,
    /// The crystal rotation of `base`.
    rotation: Mat3,
    /// The warm-started relaxed solver.
    solver: WarmRelaxed<'a>,
    /// Every evaluation so far.
    history: Vec<IterationRecord>,
}

impl RelaxedCubicEvaluator<'_> {
    /// The scheme at a point with normal magnitude `normal`, or `None` when it is not
    /// admissible (negative normal or shear stiffness along some direction: extended models).
    fn scheme_at(&self, p: &MapPoint, normal: f64) -> Result<Option<CubicSpheroid>> {
        let (a_n, a_s, shear) = (p.x.exp(), p.y.exp(), normal * p.rho);
        let scheme = CubicSpheroid {
            model: self.model,
            extended: self.extended,
            a_n,
            a_s,
            normal,
            shear,
            rotation: self.rotation,
        }
        .parameters_checked()?;
        let negative = (normal > 0.0 && scheme.min_normal_factor().0 < 0.0)
            || (shear > 0.0 && scheme.min_shear_factor().0 < 0.0);
        Ok((!negative).then_some(scheme))
    }

    /// The error of an inadmissible point (as `CubicSpheroid::new` words it).
    fn refusal(&self, p: &MapPoint, normal: f64) -> Error {
        CubicSpheroid::new(
            self.model,
            self.extended,
            p.x.exp(),
            p.y.exp(),
            normal,
            normal * p.rho,
            self.rotation,
        )
        .err()
        .unwrap_or_else(|| Error::Model("cubic scheme: inadmissible parameters".into()))
    }

    /// Relaxed tensor (crystal frame) and cubic projection at a point; `None` outside the
    /// admissible domain.
    fn evaluate(
        &mut self,
        p: &MapPoint,
        normal: f64,
    ) -> Result<Option<(Stiffness6, CubicProjection)>> {
        let Some(scheme) = self.scheme_at(p, normal)? else {
            return Ok(None);
        };
        let sol = self.solver.solve_scheme(&scheme, &self.base.geometry)?;
        // Lab → crystal: C_crystal = rotate(C_lab, R).
        let c = rotate(&sol.c, &self.rotation);
        let proj = CubicProjection::from_stiffness(&c);
        self.history.push(IterationRecord {
            parameters: CubicParameters::at(self.model, self.extended, p),
            c12_over_c11: proj.c12 / proj.c11,
            c44_over_c11: proj.c44 / proj.c11,
            cg_iterations: sol.iterations,
        });
        Ok(Some((c, proj)))
    }

    /// [`Self::evaluate`] at a point that must be admissible (refused otherwise).
    fn admissible(&mut self, p: &MapPoint, normal: f64) -> Result<(Stiffness6, CubicProjection)> {
        self.evaluate(p, normal)?
            .ok_or_else(|| self.refusal(p, normal))
    }
}

/// The evaluation of `history` nearest the goal ratios (Euclidean in the two ratios).
fn nearest_record(history: &[IterationRecord], goal: &DVector<f64>) -> Option<IterationRecord> {
    history
        .iter()
        .min_by(|a, b| {
            let ea = (a.c12_over_c11 - goal[0]).hypot(a.c44_over_c11 - goal[1]);
            let eb = (b.c12_over_c11 - goal[0]).hypot(b.c44_over_c11 - goal[1]);
            ea.total_cmp(&eb)
        })
        .copied()
}

/// The error of a relaxed calibration that did not reach the target: the best error, the
/// nearest point reached on this packing and, for a target outside the mean-field domain,
/// why it is not reachable there.
fn relaxed_not_converged<T>(
    (map, target, opts): (&MeanFieldMap, &CubicTarget, &CubicOptions),
    result: &broyden::BroydenResult<T>,
    nearest: Option<IterationRecord>,
) -> Error {
    let stop = match result.end {
        End::Pinned => format!(
            "after {} relaxed solve{}: the step toward it leaves the scheme's parameter box",
            result.evaluations,
            if result.evaluations == 1 { "" } else { "s" }
        ),
        _ => format!("within {} relaxed solves", result.evaluations),
    };
    let mut msg = format!(
        "relaxed calibration did not reach the target {} {stop} (relative ratio error {:.2e} > tolerance {:.1e}).",
        describe_ratios(target.c12_over_c11, target.c44_over_c11, target.c11),
        result.best_error,
        opts.tolerance
    );
    if let Some(r) = nearest {
        msg.push_str(&format!(
            "\n  nearest reached on this packing: {} with a_n = {:.4}, a_s = {:.4}, shear/normal = {:.4}",
            describe_ratios(r.c12_over_c11, r.c44_over_c11, target.c11),
            r.parameters.a_n,
            r.parameters.a_s,
            r.parameters.shear_over_normal
        ));
    }
    if map.solve(target, opts.family).is_none() {
        msg.push('\n');
        msg.push_str(
            &unreachable_error(map.kernel, map, target, opts, "mean-field")
                .to_string()
                .replace('\n', "\n  "),
        );
    }
    Error::NotConverged(msg)
}
