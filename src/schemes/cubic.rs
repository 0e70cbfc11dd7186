//! Cubic spheroid scheme (Truszkowska et al. 2018, Eqs. 6–16 and the Sec. 6.1 extension).
//!
//! A bond's normal and shear stiffness are the magnitude times a dimensionless factor: the
//! outer envelope (maximum radius, Eq. 8) of a family of constant-volume spheroids whose
//! major axes lie along the <100> (3), <111> (4) or <110> (6) directions of an imagined
//! crystal (Eqs. 9–15). Z > 1 uses <111> for the normal and <100> for the shear factor; Z < 1
//! the reverse. The extended models add ±½ of the <110> envelope (Sec. 6.1, App. D), which
//! can make the shear factor negative; such models are refused by [`CubicSpheroid::new`].
//!
//! Crystal orientation: `rotation` R maps lab vectors into the crystal frame and the
//! functions are evaluated at m = R·n (docs/references.md "Conventions"; then
//! C_lab = rotate(C_crystal, Rᵀ)).

use super::{Magnitudes, StiffnessScheme};
use crate::{Error, Mat3, Result, Vec3};
use serde::{Deserialize, Serialize};

/// 1/√3: component of a unit <111> vector.
const INV_SQRT_3: f64 = 0.577_350_269_189_625_8;
/// 1/√2: component of a unit <110> vector.
const INV_SQRT_2: f64 = std::f64::consts::FRAC_1_SQRT_2;

/// Unit major axes of the three <100> spheroids (Truszkowska 2018, Eqs. 9–11).
pub const AXES_100: [[f64; 3]; 3] = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];

/// Unit major axes of the four <111> spheroids (Truszkowska 2018, Eqs. 12–15).
pub const AXES_111: [[f64; 3]; 4] = [
    [INV_SQRT_3, -INV_SQRT_3, INV_SQRT_3],
    [INV_SQRT_3, INV_SQRT_3, -INV_SQRT_3],
    [-INV_SQRT_3, INV_SQRT_3, INV_SQRT_3],
    [INV_SQRT_3, INV_SQRT_3, INV_SQRT_3],
];

/// Unit major axes of the six <110> spheroids (Truszkowska 2018, Sec. 6.1).
pub const AXES_110: [[f64; 3]; 6] = [
    [INV_SQRT_2, INV_SQRT_2, 0.0],
    [INV_SQRT_2, -INV_SQRT_2, 0.0],
    [INV_SQRT_2, 0.0, INV_SQRT_2],
    [INV_SQRT_2, 0.0, -INV_SQRT_2],
    [0.0, INV_SQRT_2, INV_SQRT_2],
    [0.0, INV_SQRT_2, -INV_SQRT_2],
];

/// Weight of the <110> envelope in the extended models (Truszkowska 2018, Sec. 6.1:
/// k_n = k_o(r_base + 0.5·r<110>), k_s = k_o(r_base − 0.5·r<110>)).
pub const EXTENSION_WEIGHT_110: f64 = 0.5;

/// Largest max-entry deviation |RᵀR − I| accepted for a rotation passed to
/// [`CubicSpheroid::new`] (an exact rotation up to round-off).
pub const ROTATION_TOLERANCE: f64 = 1e-9;

/// Largest max-entry deviation |MᵀM − I| accepted by [`orthonormalize_rotation`] (a matrix
/// printed to ~4 decimals, such as Truszkowska 2018 Eq. 31).
pub const PRINTED_ROTATION_TOLERANCE: f64 = 1e-3;

/// Radius of a constant-volume spheroid of aspect ratio `a` along a direction at cosine
/// `c = n·d` to its major axis d: a^(2/3)/√(c² + (1 − c²)a²) (Truszkowska 2018, Eqs. 9–15).
///
/// Semi-axes are a^(2/3) along d and a^(−1/3) across, so the volume is that of the unit
/// sphere for every a, and r ≡ 1 at a = 1.
pub fn spheroid_radius(c: f64, a: f64) -> f64 {
    let c2 = (c * c).min(1.0);
    a.powf(2.0 / 3.0) / (c2 + (1.0 - c2) * a * a).sqrt()
}

/// Envelope (maximum radius, Truszkowska 2018 Eq. 8) of spheroids of aspect ratio `a` with
/// major axes `axes`, along the crystal-frame unit vector `m`.
fn envelope(axes: &[[f64; 3]], m: &Vec3, a: f64) -> f64 {
    // max_d r(m·d) = a^(2/3)/√(min_d [c_d² + (1 − c_d²)a²]): one power and one root.
    let a2 = a * a;
    let mut smallest = f64::INFINITY;
    for d in axes {
        let c = m.x * d[0] + m.y * d[1] + m.z * d[2];
        let c2 = (c * c).min(1.0);
        smallest = smallest.min(c2 + (1.0 - c2) * a2);
    }
    a.powf(2.0 / 3.0) / smallest.sqrt()
}

/// Envelope of the three <100> spheroids along crystal-frame unit `m`
/// (Truszkowska 2018, Eqs. 8–11).
pub fn envelope_100(m: &Vec3, a: f64) -> f64 {
    envelope(&AXES_100, m, a)
}

/// Envelope of the four <111> spheroids along crystal-frame unit `m`
/// (Truszkowska 2018, Eqs. 8, 12–15).
pub fn envelope_111(m: &Vec3, a: f64) -> f64 {
    envelope(&AXES_111, m, a)
}

/// Envelope of the six <110> spheroids along crystal-frame unit `m`
/// (Truszkowska 2018, Sec. 6.1).
pub fn envelope_110(m: &Vec3, a: f64) -> f64 {
    envelope(&AXES_110, m, a)
}

/// One family of spheroid axes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum AxisFamily {
    /// The three <100> axes (Eqs. 9–11).
    Axes100,
    /// The four <111> axes (Eqs. 12–15).
    Axes111,
    /// The six <110> axes (Sec. 6.1).
    Axes110,
}

impl AxisFamily {
    /// Unit major axes of the family (one per ± pair).
    pub fn axes(self) -> &'static [[f64; 3]] {
        match self {
            AxisFamily::Axes100 => &AXES_100,
            AxisFamily::Axes111 => &AXES_111,
            AxisFamily::Axes110 => &AXES_110,
        }
    }

    /// Envelope of the family's spheroids of aspect ratio `a` along crystal-frame unit `m`.
    pub fn envelope(self, m: &Vec3, a: f64) -> f64 {
        envelope(self.axes(), m, a)
    }

    /// Crystal-frame unit normals of the planes on which the envelope may switch from one
    /// spheroid to another: |m·d_a| = |m·d_b| ⇔ m·(d_a ± d_b) = 0, for every pair of axes.
    /// Deduplicated up to sign.
    pub fn switch_planes(self) -> Vec<Vec3> {
        let axes = self.axes();
        let mut planes = Vec::new();
        for (i, da) in axes.iter().enumerate() {
            for db in &axes[i + 1..] {
                let a = Vec3::new(da[0], da[1], da[2]);
                let b = Vec3::new(db[0], db[1], db[2]);
                push_unique_plane(&mut planes, a + b);
                push_unique_plane(&mut planes, a - b);
            }
        }
        planes
    }
}

/// Append the unit normal along `p` unless it (or its negative) is already present.
fn push_unique_plane(planes: &mut Vec<Vec3>, p: Vec3) {
    let norm = p.norm();
    if norm < 1e-12 {
        return;
    }
    let u = p / norm;
    if planes
        .iter()
        .all(|q| (q - u).norm() > 1e-9 && (q + u).norm() > 1e-9)
    {
        planes.push(u);
    }
}

/// Which of Truszkowska's two cubic models (Sec. 3).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum CubicModel {
    /// Zener ratio > 1: f_n on the four <111> spheroids (a_n), f_s on the three <100> (a_s).
    #[serde(rename = "zener-above-1")]
    ZenerAbove1,
    /// Zener ratio < 1: f_n on the three <100> spheroids (a_n), f_s on the four <111> (a_s).
    #[serde(rename = "zener-below-1")]
    ZenerBelow1,
}

impl CubicModel {
    /// The model's name as in the model file (`zener-above-1`, `zener-below-1`).
    pub fn as_str(self) -> &'static str {
        match self {
            CubicModel::ZenerAbove1 => "zener-above-1",
            CubicModel::ZenerBelow1 => "zener-below-1",
        }
    }

    /// Spheroid family of the normal factor.
    pub fn normal_family(self) -> AxisFamily {
        match self {
            CubicModel::ZenerAbove1 => AxisFamily::Axes111,
            CubicModel::ZenerBelow1 => AxisFamily::Axes100,
        }
    }

    /// Spheroid family of the shear factor.
    pub fn shear_family(self) -> AxisFamily {
        match self {
            CubicModel::ZenerAbove1 => AxisFamily::Axes100,
            CubicModel::ZenerBelow1 => AxisFamily::Axes111,
        }
    }
}

/// The cubic spheroid scheme: k_n = normal·f_n(R·n), k_s = shear·f_s(R·n)
/// (Truszkowska 2018, Eq. 6; the magnitudes are read through the geometry convention).
#[derive(Clone, Debug, PartialEq)]
pub struct CubicSpheroid {
    /// Z > 1 or Z < 1 model.
    pub model: CubicModel,
    /// Add ±½·r<110> (Sec. 6.1).
    pub extended: bool,
    /// Aspect ratio of the normal-stiffness spheroids.
    pub a_n: f64,
    /// Aspect ratio of the shear-stiffness spheroids.
    pub a_s: f64,
    /// Normal magnitude.
    pub normal: f64,
    /// Shear magnitude.
    pub shear: f64,
    /// Lab → crystal rotation R: the factors are evaluated at R·n.
    pub rotation: Mat3,
}

impl CubicSpheroid {
    /// A checked scheme: aspect ratios finite and > 0, magnitudes finite and ≥ 0, `rotation`
    /// a proper rotation (|RᵀR − I| ≤ 1e-9, det > 0; see [`orthonormalize_rotation`] for a
    /// printed matrix), and neither stiffness negative anywhere on the sphere.
    pub fn new(
        model: CubicModel,
        extended: bool,
        a_n: f64,
        a_s: f64,
        normal: f64,
        shear: f64,
        rotation: Mat3,
    ) -> Result<Self> {
        CubicSpheroid {
            model,
            extended,
            a_n,
            a_s,
            normal,
            shear,
            rotation,
        }
        .checked()
    }

    /// This scheme as [`Self::new`] checks it (a model file's cubic scheme is read into the
    /// struct and checked when its springs are first needed).
    pub fn checked(&self) -> Result<Self> {
        let scheme = self.parameters_checked()?;
        let name = scheme.name();
        for (stiffness, label, a, magnitude, (min, dir)) in [
            (
                "normal",
                "a_n",
                self.a_n,
                self.normal,
                scheme.min_normal_factor(),
            ),
            (
                "shear",
                "a_s",
                self.a_s,
                self.shear,
                scheme.min_shear_factor(),
            ),
        ] {
            if magnitude > 0.0 && min < 0.0 {
                return Err(Error::Model(format!(
                    "{name} with {label} = {a} has negative {stiffness} stiffness: the \
                     {stiffness} factor reaches {min:.6} along crystal direction {} (it must \
                     be ≥ 0 on the whole sphere; choose {label} closer to 1)",
                    fmt_dir(&dir)
                )));
            }
        }
        Ok(scheme)
    }

    /// As [`Self::checked`] without the negativity check (mean-field studies of the extended
    /// model): only the aspect ratios, magnitudes and rotation are checked.
    pub fn parameters_checked(&self) -> Result<Self> {
        let (a_n, a_s, normal, shear, rotation) =
            (self.a_n, self.a_s, self.normal, self.shear, &self.rotation);
        for (label, a) in [("a_n", a_n), ("a_s", a_s)] {
            if !a.is_finite() || a <= 0.0 {
                return Err(Error::Model(format!(
                    "cubic scheme: {label} (spheroid aspect ratio) must be finite and > 0, got {a}"
                )));
            }
        }
        for (label, k) in [("normal", normal), ("shear", shear)] {
            if !k.is_finite() || k < 0.0 {
                return Err(Error::Model(format!(
                    "cubic scheme: {label} magnitude must be finite and ≥ 0, got {k}"
                )));
            }
        }
        check_rotation(rotation, ROTATION_TOLERANCE).map_err(|why| {
            Error::Model(format!(
                "cubic scheme: rotation is not a proper rotation matrix: {why} \
                 (re-orthonormalise a printed matrix with orthonormalize_rotation)"
            ))
        })?;
        Ok(self.clone())
    }

    /// (f_n, f_s) at crystal-frame unit `m` (Truszkowska 2018, Eqs. 8–15; Sec. 6.1 when
    /// extended).
    pub fn factors_crystal(&self, m: &Vec3) -> (f64, f64) {
        let mut f_n = self.model.normal_family().envelope(m, self.a_n);
        let mut f_s = self.model.shear_family().envelope(m, self.a_s);
        if self.extended {
            f_n += EXTENSION_WEIGHT_110 * envelope_110(m, self.a_n);
            f_s -= EXTENSION_WEIGHT_110 * envelope_110(m, self.a_s);
        }
        (f_n, f_s)
    }

    /// (f_n, f_s) at lab-frame unit normal `n`, evaluated at m = R·n.
    pub fn factors(&self, n: &Vec3) -> (f64, f64) {
        self.factors_crystal(&(self.rotation * n))
    }

    /// Minimum of the normal factor over the sphere and a crystal-frame direction where it
    /// is reached (in the fundamental triangle 0 ≤ m_z ≤ m_y ≤ m_x).
    pub fn min_normal_factor(&self) -> (f64, Vec3) {
        minimum_on_sphere(|m| self.factors_crystal(m).0)
    }

    /// Minimum of the shear factor over the sphere and a crystal-frame direction where it
    /// is reached (in the fundamental triangle 0 ≤ m_z ≤ m_y ≤ m_x).
    pub fn min_shear_factor(&self) -> (f64, Vec3) {
        minimum_on_sphere(|m| self.factors_crystal(m).1)
    }

    /// (min f_n, min f_s) over the sphere.
    pub fn min_factors(&self) -> (f64, f64) {
        (self.min_normal_factor().0, self.min_shear_factor().0)
    }

    /// Families whose envelopes enter the factors with a non-trivial shape (a ≠ 1).
    fn non_smooth_families(&self) -> Vec<AxisFamily> {
        let mut used = Vec::new();
        let mut add = |family: AxisFamily, a: f64| {
            if a != 1.0 && !used.contains(&family) {
                used.push(family);
            }
        };
        add(self.model.normal_family(), self.a_n);
        add(self.model.shear_family(), self.a_s);
        if self.extended {
            add(AxisFamily::Axes110, self.a_n);
            add(AxisFamily::Axes110, self.a_s);
        }
        used
    }
}

impl StiffnessScheme for CubicSpheroid {
    fn name(&self) -> String {
        if self.extended {
            format!(
                "{} {} (extended)",
                super::SchemeKind::Cubic,
                self.model.as_str()
            )
        } else {
            format!("{} {}", super::SchemeKind::Cubic, self.model.as_str())
        }
    }

    fn magnitudes(&self, n: &Vec3) -> Magnitudes {
        let (f_n, f_s) = self.factors(n);
        Magnitudes {
            normal: self.normal * f_n,
            shear: self.shear * f_s,
        }
    }

    /// Planes m·(d_a ± d_b) = 0 of every family with a ≠ 1, in the lab frame: a kink of
    /// g(m) on p·m = 0 is a kink of f(n) = g(Rn) on (Rᵀp)·n = 0. The spheroid radius
    /// depends on c², so single spheroids are smooth and only pair planes are needed.
    fn kink_planes(&self) -> Vec<Vec3> {
        let mut planes = Vec::new();
        for family in self.non_smooth_families() {
            for p in family.switch_planes() {
                push_unique_plane(&mut planes, p);
            }
        }
        let rt = self.rotation.transpose();
        planes.into_iter().map(|p| (rt * p).normalize()).collect()
    }
}

/// Format a direction for error messages.
fn fmt_dir(m: &Vec3) -> String {
    format!("({:.4}, {:.4}, {:.4})", m.x, m.y, m.z)
}

/// Minimum over the unit sphere of an O_h-invariant function, and where it is reached.
///
/// Searches the fundamental triangle 0 ≤ m_z ≤ m_y ≤ m_x (vertices `[100]`, `[110]`, `[111]`) on
/// a barycentric grid that contains its vertices and edges exactly, then refines the best
/// grid points with a compass search that stays inside the triangle. Suited to piecewise
/// smooth envelopes whose extrema sit at symmetry directions or on the kink planes.
pub fn minimum_on_sphere(f: impl Fn(&Vec3) -> f64) -> (f64, Vec3) {
    const DIVISIONS: usize = 160;
    const REFINED: usize = 8;
    let point = |v: f64, w: f64| -> Vec3 {
        let u = 1.0 - v - w;
        let p = Vec3::new(
            u + v * INV_SQRT_2 + w * INV_SQRT_3,
            v * INV_SQRT_2 + w * INV_SQRT_3,
            w * INV_SQRT_3,
        );
        p.normalize()
    };
    // Dense grid, in a fixed order.
    let mut samples: Vec<(f64, f64, f64)> =
        Vec::with_capacity((DIVISIONS + 1) * (DIVISIONS + 2) / 2);
    let step = 1.0 / DIVISIONS as f64;
    for i in 0..=DIVISIONS {
        for j in 0..=(DIVISIONS - i) {
            let (v, w) = (i as f64 * step, j as f64 * step);
            samples.push((f(&point(v, w)), v, w));
        }
    }
    samples.sort_by(|a, b| a.0.total_cmp(&b.0));
    // Compass search from the best few grid points, projected onto the triangle.
    let project = |v: f64, w: f64| -> (f64, f64) {
        let (mut v, mut w) = (v.max(0.0), w.max(0.0));
        let excess = v + w - 1.0;
        if excess > 0.0 {
            v = (v - 0.5 * excess).clamp(0.0, 1.0);
            w = 1.0 - v;
        }
        (v, w)
    };
    let directions = [
        (1.0, 0.0),
        (-1.0, 0.0),
        (0.0, 1.0),
        (0.0, -1.0),
        (1.0, -1.0),
        (-1.0, 1.0),
    ];
    let mut best = (f64::INFINITY, 0.0, 0.0);
    for &(start_value, v0, w0) in samples.iter().take(REFINED) {
        let (mut value, mut v, mut w) = (start_value, v0, w0);
        let mut h = step;
        while h > 1e-13 {
            let mut improved = false;
            for (dv, dw) in directions {
                let (vn, wn) = project(v + h * dv, w + h * dw);
                let candidate = f(&point(vn, wn));
                if candidate < value {
                    (value, v, w) = (candidate, vn, wn);
                    improved = true;
                    break;
                }
            }
            if !improved {
                h *= 0.5;
            }
        }
        if value < best.0 {
            best = (value, v, w);
        }
    }
    (best.0, point(best.1, best.2))
}

/// Check that `r` is finite, |RᵀR − I| ≤ `tolerance` (max entry) and det R > 0; the reason
/// when not.
fn check_rotation(r: &Mat3, tolerance: f64) -> std::result::Result<(), String> {
    if r.iter().any(|x| !x.is_finite()) {
        return Err(format!("it has a non-finite entry: {r:?}"));
    }
    let deviation = (r.transpose() * r - Mat3::identity()).amax();
    if deviation > tolerance {
        return Err(format!(
            "max |RᵀR − I| = {deviation:.3e} exceeds the tolerance {tolerance:.0e}"
        ));
    }
    let det = r.determinant();
    if det <= 0.0 {
        return Err(format!(
            "determinant {det:.6} is not positive (a reflection, not a rotation)"
        ));
    }
    Ok(())
}

/// Rz(α)·Ry(β)·Rz(γ) (angles in degrees) with the active right-handed elementary rotations
/// Rz(θ) = [[cos θ, −sin θ, 0], [sin θ, cos θ, 0], [0, 0, 1]] and
/// Ry(θ) = [[cos θ, 0, sin θ], [0, 1, 0], [−sin θ, 0, cos θ]].
/// (60°, 30°, 45°) gives Truszkowska 2018 Eq. 31.
pub fn rotation_from_euler_zyz_deg(alpha: f64, beta: f64, gamma: f64) -> Mat3 {
    let rz = |t: f64| {
        let (s, c) = t.to_radians().sin_cos();
        Mat3::new(c, -s, 0.0, s, c, 0.0, 0.0, 0.0, 1.0)
    };
    let ry = |t: f64| {
        let (s, c) = t.to_radians().sin_cos();
        Mat3::new(c, 0.0, s, 0.0, 1.0, 0.0, -s, 0.0, c)
    };
    rz(alpha) * ry(beta) * rz(gamma)
}

/// The rotation nearest to a near-orthogonal matrix `m` (polar decomposition m = R·P via
/// SVD, R = U·Vᵀ), for matrices printed to a few decimals such as Truszkowska 2018 Eq. 31
/// (det 1.000066). Refuses a matrix with a non-finite entry, with max |MᵀM − I| > 1e-3, or
/// with det ≤ 0.
pub fn orthonormalize_rotation(m: Mat3) -> Result<Mat3> {
    check_rotation(&m, PRINTED_ROTATION_TOLERANCE).map_err(|why| {
        Error::Model(format!(
            "rotation matrix is not orthogonal (not even a rotation printed to a few decimals): {why}"
        ))
    })?;
    let svd = m.svd(true, true);
    let (Some(u), Some(v_t)) = (svd.u, svd.v_t) else {
        return Err(Error::Model(
            "rotation matrix: singular value decomposition failed".to_string(),
        ));
    };
    let r = u * v_t;
    check_rotation(&r, ROTATION_TOLERANCE).map_err(|why| {
        Error::Model(format!(
            "rotation matrix could not be re-orthonormalised: {why}"
        ))
    })?;
    Ok(r)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn closed_forms_match_max_over_axes() {
        // docs/references.md: for a > 1, r100 = r(max|n_i|), r111 = r(Σ|n_i|/√3),
        // r110 = r((Σ|n_i| − min|n_i|)/√2); for a < 1, r100 = r(min|n_i|).
        let dirs = [
            Vec3::new(0.3, -0.5, 0.81),
            Vec3::new(-0.9, 0.1, 0.2),
            Vec3::new(0.05, 0.7, -0.7),
        ];
        for m in dirs.map(|d| d.normalize()) {
            let abs = m.abs();
            let (mx, mn, sum) = (abs.max(), abs.min(), abs.sum());
            for a in [1.7, 4.31, 10.0] {
                assert!((envelope_100(&m, a) - spheroid_radius(mx, a)).abs() < 1e-14);
                let r111 = spheroid_radius(sum * INV_SQRT_3, a);
                assert!((envelope_111(&m, a) - r111).abs() < 1e-14);
                let r110 = spheroid_radius((sum - mn) * INV_SQRT_2, a);
                assert!((envelope_110(&m, a) - r110).abs() < 1e-14);
            }
            assert!((envelope_100(&m, 0.3) - spheroid_radius(mn, 0.3)).abs() < 1e-14);
        }
    }

    #[test]
    fn switch_plane_counts() {
        // <100> pairs: the six {110} planes; <111> pairs: {100} ∪ {110} = 9;
        // <110> pairs: {100} ∪ {110} ∪ {211} = 3 + 6 + 12 = 21.
        assert_eq!(AxisFamily::Axes100.switch_planes().len(), 6);
        assert_eq!(AxisFamily::Axes111.switch_planes().len(), 9);
        assert_eq!(AxisFamily::Axes110.switch_planes().len(), 21);
    }

    #[test]
    fn minimum_finds_vertex_and_interior_minima() {
        // Smooth function with its minimum inside the triangle: −(m·p)² with p in the
        // triangle has its minimum −1 at m = p.
        let p = Vec3::new(0.8, 0.5, 0.2).normalize();
        let (v, m) = minimum_on_sphere(|m| -(m.dot(&p)).powi(2));
        assert!((v + 1.0).abs() < 1e-12, "{v}");
        assert!((m - p).norm() < 1e-5);
    }
}
