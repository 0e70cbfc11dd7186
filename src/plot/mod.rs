//! PNG plots: the accessible-domain map (Truszkowska 2018 Fig. 8, Fig. C.1a), polar
//! sections of a scheme's k_n(n) and k_s(n) (Fig. 3), and stress–strain curves.
//!
//! Drawn with plotters' bitmap backend and an embedded font, so no system font library is
//! needed. The font is DejaVu Sans (`DejaVuSans.ttf`, from Debian's fonts-dejavu-core),
//! under the Bitstream Vera / DejaVu fonts licence: free to use, copy, embed and
//! redistribute. Files are written atomically (a temporary `.png` in the target's folder,
//! renamed into place when complete).

use crate::calibrate::domain::DomainSample;
use crate::schemes::cubic::CubicModel;
use crate::schemes::StiffnessScheme;
use crate::{Error, Result, Vec3};
use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::FontStyle;
use std::ops::Range;
use std::path::Path;
use std::sync::Once;

/// DejaVu Sans (Bitstream Vera / DejaVu fonts licence, permissive; see the module doc).
static FONT: &[u8] = include_bytes!("DejaVuSans.ttf");
static REGISTER: Once = Once::new();

fn register_font() {
    REGISTER.call_once(|| {
        // The embedded file is a valid TrueType font; a failure would only lose the labels.
        let _ = plotters::style::register_font("sans-serif", FontStyle::Normal, FONT);
    });
}

fn plot_error(path: &Path, e: impl std::fmt::Display) -> Error {
    Error::Invalid(format!("{}: drawing the plot failed: {e}", path.display()))
}

/// Render `draw` into a PNG of `size` pixels at `path`, atomically.
fn render<F>(path: &Path, size: (u32, u32), draw: F) -> Result<()>
where
    F: FnOnce(&DrawingArea<BitMapBackend, Shift>) -> std::result::Result<(), String>,
{
    register_font();
    let dir = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    };
    let tmp = crate::io::output_temp_file(dir, ".png", path).map_err(|e| Error::io(path, e))?;
    {
        let root = BitMapBackend::new(tmp.path(), size).into_drawing_area();
        root.fill(&WHITE).map_err(|e| plot_error(path, e))?;
        draw(&root).map_err(|e| plot_error(path, e))?;
        root.present().map_err(|e| plot_error(path, e))?;
    }
    crate::io::persist(tmp.into_temp_path(), path)
}

fn s<E: std::fmt::Display>(e: E) -> String {
    e.to_string()
}

/// The charts of this module: f64 × f64 on a bitmap.
type Chart<'a, 'b> = ChartContext<
    'a,
    BitMapBackend<'b>,
    Cartesian2d<plotters::coord::types::RangedCoordf64, plotters::coord::types::RangedCoordf64>,
>;

/// How a chart is framed (pixels): its caption's font size, its margin and the sizes of its
/// x and y label areas.
#[derive(Clone, Copy)]
struct Frame {
    caption: u32,
    margin: u32,
    labels: (u32, u32),
}

impl Frame {
    /// The chart on `area` captioned `title`, over `x` × `y`.
    fn chart<'a, 'b>(
        self,
        area: &'a DrawingArea<BitMapBackend<'b>, Shift>,
        title: &str,
        x: Range<f64>,
        y: Range<f64>,
    ) -> std::result::Result<Chart<'a, 'b>, String> {
        ChartBuilder::on(area)
            .caption(title, ("sans-serif", self.caption))
            .margin(self.margin)
            .x_label_area_size(self.labels.0)
            .y_label_area_size(self.labels.1)
            .build_cartesian_2d(x, y)
            .map_err(s)
    }
}

/// The legend of `chart` (labels at `font_size` on a translucent white box with a black
/// border) at `position`.
fn draw_legend<'a, 'b: 'a>(
    chart: &mut Chart<'a, 'b>,
    font_size: u32,
    position: SeriesLabelPosition,
) -> std::result::Result<(), String> {
    chart
        .configure_series_labels()
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .label_font(("sans-serif", font_size))
        .position(position)
        .draw()
        .map_err(s)
}

/// Colour of a model variant on the domain map (paper Fig. C.1a: blue/gold plain,
/// purple/orange extended).
fn variant_colour(model: CubicModel, extended: bool) -> RGBColor {
    match (model, extended) {
        (CubicModel::ZenerAbove1, false) => RGBColor(31, 119, 180),
        (CubicModel::ZenerBelow1, false) => RGBColor(214, 160, 20),
        (CubicModel::ZenerAbove1, true) => RGBColor(128, 60, 170),
        (CubicModel::ZenerBelow1, true) => RGBColor(240, 110, 30),
    }
}

/// The accessible-domain map: C44/C11 against C12/C11 for every sample, with lines of
/// constant Zener ratio (C44/C11 = Z(1 − C12/C11)/2), of constant ν100
/// (C12/C11 = ν/(1 − ν)) and the Cauchy line C12 = C44 (Truszkowska 2018 Fig. 8,
/// Fig. C.1a). `target` marks a point (C12/C11, C44/C11).
pub fn plot_domain(
    path: &Path,
    samples: &[DomainSample],
    title: &str,
    target: Option<(f64, f64)>,
) -> Result<()> {
    plot_domain_with_materials(path, samples, title, target, &[])
}

/// [`plot_domain`] with named materials' (C12/C11, C44/C11) marked and the stable domain's
/// bounds drawn (C12/C11 = 1 and −1/2, C44/C11 = 0): with the many-body term `calibrate`
/// reaches every point between them (docs/manybody.md "Calibration").
pub fn plot_domain_with_materials(
    path: &Path,
    samples: &[DomainSample],
    title: &str,
    target: Option<(f64, f64)>,
    materials: &[(&str, f64, f64)],
) -> Result<()> {
    if samples.is_empty() {
        return Err(Error::Invalid("domain plot: no samples".into()));
    }
    let mut w = DomainWindow::new(samples, target);
    for &(_, x, y) in materials {
        w.x0 = w.x0.min(x - 0.02);
        w.x1 = w.x1.max(x + 0.02);
        w.y1 = w.y1.max(y + 0.02);
        w.y0 = w.y0.min((y - 0.02).max(0.0));
    }
    render(path, (1000, 850), |root| {
        let mut chart = Frame {
            caption: 24,
            margin: 15,
            labels: (50, 60),
        }
        .chart(root, title, w.x0..w.x1, w.y0..w.y1)?;
        chart
            .configure_mesh()
            .x_desc("C12/C11")
            .y_desc("C44/C11")
            .label_style(("sans-serif", 16))
            .axis_desc_style(("sans-serif", 20))
            .light_line_style(RGBColor(235, 235, 235))
            .draw()
            .map_err(s)?;
        draw_poisson_lines(&mut chart, &w)?;
        draw_zener_lines(&mut chart, &w)?;
        // Cauchy line C12 = C44.
        let lo = w.x0.max(w.y0);
        let hi = w.x1.min(w.y1);
        if hi > lo {
            chart
                .draw_series(LineSeries::new([(lo, lo), (hi, hi)], RED.stroke_width(2)))
                .map_err(s)?
                .label("Cauchy C12 = C44")
                .legend(|(x, y)| PathElement::new([(x, y), (x + 20, y)], RED.stroke_width(2)));
        }
        draw_domain_samples(&mut chart, samples)?;
        let green = RGBColor(0, 140, 60);
        let mut bounds: Vec<Vec<(f64, f64)>> = Vec::new();
        for x in [1.0, -0.5] {
            if x > w.x0 && x < w.x1 {
                bounds.push(vec![(x, w.y0.max(0.0)), (x, w.y1)]);
            }
        }
        if w.y0 <= 0.0 {
            bounds.push(vec![(w.x0.max(-0.5), 0.0), (w.x1.min(1.0), 0.0)]);
        }
        for (k, b) in bounds.into_iter().enumerate() {
            let series = chart
                .draw_series(LineSeries::new(b, green.stroke_width(3)))
                .map_err(s)?;
            if k == 0 {
                series
                    .label("stable-domain bound (reached with the many-body term inside)")
                    .legend(move |(x, y)| {
                        PathElement::new([(x, y), (x + 20, y)], green.stroke_width(3))
                    });
            }
        }
        for (k, &(name, x, y)) in materials.iter().enumerate() {
            let series = chart
                .draw_series(std::iter::once(TriangleMarker::new(
                    (x, y),
                    8,
                    green.filled(),
                )))
                .map_err(s)?;
            if k == 0 {
                series
                    .label("materials (calibrated with the term)")
                    .legend(move |(x, y)| TriangleMarker::new((x + 10, y), 6, green.filled()));
            }
            chart
                .draw_series(std::iter::once(Text::new(
                    name.to_string(),
                    (x + 0.005, y + 0.005),
                    ("sans-serif", 15).into_font(),
                )))
                .map_err(s)?;
        }
        if let Some((tx, ty)) = target {
            chart
                .draw_series(std::iter::once(Cross::new(
                    (tx, ty),
                    9,
                    BLACK.stroke_width(3),
                )))
                .map_err(s)?
                .label("target")
                .legend(|(x, y)| Cross::new((x + 10, y), 5, BLACK.stroke_width(2)));
        }
        draw_legend(&mut chart, 16, SeriesLabelPosition::LowerRight)?;
        Ok(())
    })
}

/// The axes' ranges of the domain map.
struct DomainWindow {
    /// Lowest C12/C11.
    x0: f64,
    /// Highest C12/C11.
    x1: f64,
    /// Lowest C44/C11.
    y0: f64,
    /// Highest C44/C11.
    y1: f64,
}

impl DomainWindow {
    /// At least [0, 0.5] × [0.2, 0.6], grown to hold every finite sample and the target,
    /// with a 5 % margin (C44/C11 not below 0).
    fn new(samples: &[DomainSample], target: Option<(f64, f64)>) -> DomainWindow {
        let finite = samples
            .iter()
            .filter(|p| p.c12_over_c11.is_finite() && p.c44_over_c11.is_finite());
        let (mut x0, mut x1, mut y0, mut y1) = (0.0f64, 0.5f64, 0.2f64, 0.6f64);
        for p in finite {
            x0 = x0.min(p.c12_over_c11);
            x1 = x1.max(p.c12_over_c11);
            y0 = y0.min(p.c44_over_c11);
            y1 = y1.max(p.c44_over_c11);
        }
        if let Some((tx, ty)) = target {
            x0 = x0.min(tx);
            x1 = x1.max(tx);
            y0 = y0.min(ty);
            y1 = y1.max(ty);
        }
        let (dx, dy) = (0.05 * (x1 - x0), 0.05 * (y1 - y0));
        DomainWindow {
            x0: x0 - dx,
            x1: x1 + dx,
            y0: (y0 - dy).max(0.0),
            y1: y1 + dy,
        }
    }
}

/// Lines of constant Poisson ratio ν100 = C12/(C11 + C12) on the domain map: vertical at
/// C12/C11 = ν/(1 − ν), labelled.
fn draw_poisson_lines<'a, 'b: 'a>(
    chart: &mut Chart<'a, 'b>,
    w: &DomainWindow,
) -> std::result::Result<(), String> {
    let poisson = RGBColor(120, 170, 220);
    for nu in [0.0, 0.1, 0.2, 0.3, 0.4] {
        let x = nu / (1.0 - nu);
        if x > w.x0 && x < w.x1 {
            let label_at = (x, w.y1 - 0.02 * (w.y1 - w.y0));
            let line = [(x, w.y0), (x, w.y1)];
            draw_labelled_line(chart, line, poisson, 1, format!("ν={nu:.1}"), label_at)?;
        }
    }
    Ok(())
}

/// Lines of constant Zener ratio on the domain map, C44/C11 = Z(1 − C12/C11)/2, labelled;
/// Z = 1 (isotropy) thicker.
fn draw_zener_lines<'a, 'b: 'a>(
    chart: &mut Chart<'a, 'b>,
    w: &DomainWindow,
) -> std::result::Result<(), String> {
    let grey = RGBColor(130, 130, 130);
    for z in [0.5, 0.6, 0.8, 1.0, 1.25, 1.5, 2.0, 2.5, 3.0] {
        let line: Vec<(f64, f64)> = (0..=50)
            .map(|k| {
                let x = w.x0 + (w.x1 - w.x0) * k as f64 / 50.0;
                (x, z * (1.0 - x) / 2.0)
            })
            .filter(|&(_, y)| y >= w.y0 && y <= w.y1)
            .collect();
        if line.len() < 2 {
            continue;
        }
        let width = if z == 1.0 { 2 } else { 1 };
        let label_at = line[line.len() / 5];
        draw_labelled_line(chart, line, grey, width, format!("Z={z}"), label_at)?;
    }
    Ok(())
}

/// A reference line through `points`, `width` pixels of `colour`, labelled `label` at
/// `label_at` in 14-pixel text of the same colour.
fn draw_labelled_line<'a, 'b: 'a>(
    chart: &mut Chart<'a, 'b>,
    points: impl IntoIterator<Item = (f64, f64)>,
    colour: RGBColor,
    width: u32,
    label: String,
    label_at: (f64, f64),
) -> std::result::Result<(), String> {
    chart
        .draw_series(LineSeries::new(points, colour.stroke_width(width)))
        .map_err(s)?;
    chart
        .draw_series(std::iter::once(Text::new(
            label,
            label_at,
            ("sans-serif", 14).into_font().color(&colour),
        )))
        .map_err(s)?;
    Ok(())
}

/// The samples of every model variant as dots in its colour, with a legend entry counting
/// them (non-finite samples left out).
fn draw_domain_samples<'a, 'b: 'a>(
    chart: &mut Chart<'a, 'b>,
    samples: &[DomainSample],
) -> std::result::Result<(), String> {
    for model in [CubicModel::ZenerAbove1, CubicModel::ZenerBelow1] {
        for extended in [false, true] {
            let colour = variant_colour(model, extended);
            let pts: Vec<(f64, f64)> = samples
                .iter()
                .filter(|p| p.model == model && p.extended == extended)
                .map(|p| (p.c12_over_c11, p.c44_over_c11))
                .filter(|(x, y)| x.is_finite() && y.is_finite())
                .collect();
            if pts.is_empty() {
                continue;
            }
            let label = format!(
                "{}{} ({} samples)",
                model.as_str(),
                if extended { " extended" } else { "" },
                pts.len()
            );
            chart
                .draw_series(
                    pts.into_iter()
                        .map(|c| Circle::new(c, 2, colour.mix(0.6).filled())),
                )
                .map_err(s)?
                .label(label)
                .legend(move |(x, y)| Circle::new((x + 10, y), 4, colour.filled()));
        }
    }
    Ok(())
}

/// A plane section for [`plot_stiffness_sections`]: directions n(t) = cos t·u + sin t·v.
#[derive(Clone, Debug)]
pub struct Section {
    /// Title, e.g. "(100) plane".
    pub name: String,
    /// First in-plane unit vector (lab frame), t = 0.
    pub u: Vec3,
    /// Second in-plane unit vector (lab frame), t = 90°.
    pub v: Vec3,
}

impl Section {
    /// The (100) and (1̄10) planes of a crystal with lab → crystal rotation `r` (vectors
    /// mapped to the lab frame by Rᵀ): (100) is spanned by `[010]` and `[001]`; (1̄10) by
    /// `[110]`/√2 and `[001]`, so it contains <100>, <110> and <111>, the symmetry directions
    /// of Truszkowska 2018 Fig. 3.
    pub fn cubic_planes(r: &crate::Mat3) -> Vec<Section> {
        let rt = r.transpose();
        let s2 = std::f64::consts::FRAC_1_SQRT_2;
        vec![
            Section {
                name: "(100) plane: [010] → [001]".into(),
                u: rt * Vec3::new(0.0, 1.0, 0.0),
                v: rt * Vec3::new(0.0, 0.0, 1.0),
            },
            Section {
                name: "(1-10) plane: [110] → [001]".into(),
                u: rt * Vec3::new(s2, s2, 0.0),
                v: rt * Vec3::new(0.0, 0.0, 1.0),
            },
        ]
    }

    /// Two planes containing an axis: (axis⊥, axis) for the cross-anisotropic scheme, and the
    /// plane normal to the axis.
    pub fn axis_planes(axis: &Vec3) -> Vec<Section> {
        let a = axis.normalize();
        let helper = if a.x.abs() < 0.9 {
            Vec3::x()
        } else {
            Vec3::y()
        };
        let p = (helper - a * a.dot(&helper)).normalize();
        let q = a.cross(&p);
        vec![
            Section {
                name: "plane containing the axis".into(),
                u: p,
                v: a,
            },
            Section {
                name: "plane normal to the axis".into(),
                u: p,
                v: q,
            },
        ]
    }
}

/// Polar plots of the scheme's normal (blue) and shear (gold) magnitudes along the
/// directions of each section (Truszkowska 2018 Fig. 3 in cross-section), one panel per
/// section, all on the same scale; `unit` labels the magnitudes (e.g. "Pa/m").
pub fn plot_stiffness_sections(
    path: &Path,
    scheme: &dyn StiffnessScheme,
    sections: &[Section],
    title: &str,
    unit: &str,
) -> Result<()> {
    if sections.is_empty() {
        return Err(Error::Invalid("stiffness plot: no sections".into()));
    }
    let curves: Vec<(Curve, Curve)> = sections
        .iter()
        .map(|sec| polar_curves(scheme, sec))
        .collect();
    let rmax = curves
        .iter()
        .flat_map(|(a, b)| a.iter().chain(b.iter()))
        .map(|(x, y)| x.hypot(*y))
        .filter(|r| r.is_finite())
        .fold(0.0, f64::max);
    if rmax <= 0.0 {
        return Err(Error::Invalid(
            "stiffness plot: the scheme's magnitudes are zero everywhere".into(),
        ));
    }
    let r = 1.08 * rmax;
    let panel = 620u32;
    let width = panel * sections.len() as u32;
    render(path, (width, panel + 60), |root| {
        let root = root.titled(title, ("sans-serif", 24)).map_err(s)?;
        let panels = root.split_evenly((1, sections.len()));
        for ((area, sec), (normal, shear)) in panels.iter().zip(sections).zip(&curves) {
            let mut chart = Frame {
                caption: 18,
                margin: 10,
                labels: (35, 70),
            }
            .chart(area, &sec.name, -r..r, -r..r)?;
            chart
                .configure_mesh()
                .x_labels(5)
                .y_labels(5)
                .x_label_formatter(&|v| format!("{v:.2e}"))
                .y_label_formatter(&|v| format!("{v:.2e}"))
                .label_style(("sans-serif", 12))
                .light_line_style(RGBColor(240, 240, 240))
                .draw()
                .map_err(s)?;
            draw_reference_circles(&mut chart, rmax)?;
            let blue = RGBColor(31, 119, 180);
            let gold = RGBColor(214, 160, 20);
            for (curve, colour, name) in [(normal, blue, "k_n"), (shear, gold, "k_s")] {
                chart
                    .draw_series(LineSeries::new(curve.clone(), colour.stroke_width(3)))
                    .map_err(s)?
                    .label(format!("{name} magnitude ({unit})"))
                    .legend(move |(x, y)| {
                        PathElement::new([(x, y), (x + 20, y)], colour.stroke_width(3))
                    });
            }
            draw_legend(&mut chart, 14, SeriesLabelPosition::UpperRight)?;
        }
        Ok(())
    })
}

/// A polar curve: points (x, y) of a magnitude along the directions of a section.
type Curve = Vec<(f64, f64)>;

/// The polar curves of k_n(n) and k_s(n) (negative magnitudes as 0) over the directions
/// n(t) = cos t·u + sin t·v of `sec`, 720 steps around.
fn polar_curves(scheme: &dyn StiffnessScheme, sec: &Section) -> (Curve, Curve) {
    const STEPS: usize = 720;
    let mut normal = Vec::with_capacity(STEPS + 1);
    let mut shear = Vec::with_capacity(STEPS + 1);
    for k in 0..=STEPS {
        let t = 2.0 * std::f64::consts::PI * k as f64 / STEPS as f64;
        let (st, ct) = t.sin_cos();
        let n = (sec.u * ct + sec.v * st).normalize();
        let m = scheme.magnitudes(&n);
        normal.push((m.normal.max(0.0) * ct, m.normal.max(0.0) * st));
        shear.push((m.shear.max(0.0) * ct, m.shear.max(0.0) * st));
    }
    (normal, shear)
}

/// Grey reference circles at quarter radii of `rmax`.
fn draw_reference_circles<'a, 'b: 'a>(
    chart: &mut Chart<'a, 'b>,
    rmax: f64,
) -> std::result::Result<(), String> {
    for frac in [0.25, 0.5, 0.75, 1.0] {
        let rr = frac * rmax;
        chart
            .draw_series(LineSeries::new(
                (0..=180).map(|k| {
                    let t = 2.0 * std::f64::consts::PI * k as f64 / 180.0;
                    (rr * t.cos(), rr * t.sin())
                }),
                RGBColor(210, 210, 210),
            ))
            .map_err(s)?;
    }
    Ok(())
}

/// A loading history (the shared [`crate::history::StressHistory`]): `time`, `strain` and
/// `stress` are plotted.
pub type History = crate::history::StressHistory;

const VOIGT_NAMES: [&str; 6] = ["11", "22", "33", "23", "13", "12"];

/// Stress–strain curves of a history: every stress component that is not negligible
/// (in MPa) against the strain component that varies most (the loading direction).
pub fn plot_stress_strain(path: &Path, history: &History, title: &str) -> Result<()> {
    let n = history.time.len();
    if n < 2 || history.strain.len() != n || history.stress.len() != n {
        return Err(Error::Invalid(format!(
            "stress–strain plot: need at least 2 steps with time, strain and stress each (got {}, {}, {})",
            n,
            history.strain.len(),
            history.stress.len()
        )));
    }
    let range = |k: usize, v: &[[f64; 6]]| {
        let (lo, hi) = v
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), e| {
                (lo.min(e[k]), hi.max(e[k]))
            });
        hi - lo
    };
    let driver = (0..6)
        .max_by(|&a, &b| range(a, &history.strain).total_cmp(&range(b, &history.strain)))
        .unwrap_or(0);
    let stress_span = (0..6)
        .map(|k| range(k, &history.stress))
        .fold(0.0, f64::max);
    let shown: Vec<usize> = (0..6)
        .filter(|&k| range(k, &history.stress) > 1e-3 * stress_span)
        .collect();
    let xs: Vec<f64> = history.strain.iter().map(|e| e[driver]).collect();
    let (x0, x1) = xs
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &x| {
            (a.min(x), b.max(x))
        });
    let (mut y0, mut y1) = (0.0f64, 0.0f64);
    for st in &history.stress {
        for &k in &shown {
            y0 = y0.min(st[k] / 1e6);
            y1 = y1.max(st[k] / 1e6);
        }
    }
    if x1.partial_cmp(&x0) != Some(std::cmp::Ordering::Greater)
        || !x0.is_finite()
        || !y0.is_finite()
        || !y1.is_finite()
    {
        return Err(Error::Invalid(
            "stress–strain plot: the strain does not vary (or is not finite)".into(),
        ));
    }
    if y1 <= y0 {
        y1 = y0 + 1.0;
    }
    let x_label = format!("strain ε{} (engineering)", VOIGT_NAMES[driver]);
    let series: Vec<Series> = shown
        .iter()
        .map(|&k| Series {
            label: format!("σ{}", VOIGT_NAMES[k]),
            points: xs
                .iter()
                .zip(&history.stress)
                .map(|(&x, st)| (x, st[k] / 1e6))
                .collect(),
            dashed: false,
            colour: Some(k),
        })
        .collect();
    let plot = LinePlot {
        title,
        x: (x0, x1),
        y: (y0, y1),
        x_label: &x_label,
        y_label: "stress (MPa)",
        y_label_area: 70,
        x_ticks: Some(&|v| format!("{v:.1e}")),
        y_ticks: None,
        legend: SeriesLabelPosition::UpperLeft,
    };
    draw_lines(path, plot, &series)
}

/// One named curve of [`plot_series`]: (x, y) points.
#[derive(Clone, Debug, Default)]
pub struct Series {
    /// Legend label.
    pub label: String,
    /// The points.
    pub points: Vec<(f64, f64)>,
    /// Draw as dots instead of a line (e.g. a second code's curve over the first).
    pub dashed: bool,
    /// Palette index; `None` takes the curve's position.
    pub colour: Option<usize>,
}

/// Line plot of several curves on common axes (e.g. stress histories against step, or
/// two codes' histories over each other), written atomically as PNG.
pub fn plot_series(
    path: &Path,
    series: &[Series],
    title: &str,
    x_label: &str,
    y_label: &str,
) -> Result<()> {
    let pts = || series.iter().flat_map(|c| c.points.iter());
    if series.is_empty()
        || pts().count() < 2
        || pts().any(|(x, y)| !x.is_finite() || !y.is_finite())
    {
        return Err(Error::Invalid(
            "line plot: need at least two finite points".into(),
        ));
    }
    let (x0, mut x1, mut y0, mut y1) = pts().fold(
        (
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::INFINITY,
            f64::NEG_INFINITY,
        ),
        |(a, b, c, d), &(x, y)| (a.min(x), b.max(x), c.min(y), d.max(y)),
    );
    if x1 <= x0 {
        x1 = x0 + 1.0;
    }
    if y1 <= y0 {
        (y0, y1) = (y0 - 1.0, y1 + 1.0);
    }
    let plot = LinePlot {
        title,
        x: (x0, x1),
        y: (y0, y1),
        x_label,
        y_label,
        y_label_area: 80,
        x_ticks: None,
        y_ticks: Some(&|v| format!("{v:.3e}")),
        legend: SeriesLabelPosition::UpperRight,
    };
    draw_lines(path, plot, series)
}

/// The six curve colours (matplotlib's first six).
const PALETTE: [RGBColor; 6] = [
    RGBColor(31, 119, 180),
    RGBColor(255, 127, 14),
    RGBColor(44, 160, 44),
    RGBColor(214, 39, 40),
    RGBColor(148, 103, 189),
    RGBColor(140, 86, 75),
];

/// Axes, labels and legend of a line plot.
struct LinePlot<'a> {
    title: &'a str,
    /// x range.
    x: (f64, f64),
    /// y range, padded by 5 % on both sides when drawn.
    y: (f64, f64),
    x_label: &'a str,
    y_label: &'a str,
    /// Width of the y label area (pixels).
    y_label_area: u32,
    /// Tick label formats (`None`: plotters' own).
    x_ticks: Option<&'a dyn Fn(&f64) -> String>,
    y_ticks: Option<&'a dyn Fn(&f64) -> String>,
    legend: SeriesLabelPosition,
}

/// The curves `series` on the axes of `plot`, 1000 × 700 pixels, written atomically as PNG.
fn draw_lines(path: &Path, plot: LinePlot, series: &[Series]) -> Result<()> {
    let ((x0, x1), (y0, y1)) = (plot.x, plot.y);
    let pad = 0.05 * (y1 - y0);
    render(path, (1000, 700), |root| {
        let mut chart = Frame {
            caption: 24,
            margin: 15,
            labels: (50, plot.y_label_area),
        }
        .chart(root, plot.title, x0..x1, (y0 - pad)..(y1 + pad))?;
        let mut mesh = chart.configure_mesh();
        mesh.x_desc(plot.x_label).y_desc(plot.y_label);
        if let Some(f) = plot.x_ticks {
            mesh.x_label_formatter(f);
        }
        if let Some(f) = plot.y_ticks {
            mesh.y_label_formatter(f);
        }
        mesh.label_style(("sans-serif", 14))
            .axis_desc_style(("sans-serif", 18))
            .draw()
            .map_err(s)?;
        for (k, c) in series.iter().enumerate() {
            let colour = PALETTE[c.colour.unwrap_or(k) % PALETTE.len()];
            let style = colour.stroke_width(if c.dashed { 1 } else { 2 });
            let drawn = if c.dashed {
                chart
                    .draw_series(c.points.iter().map(|&p| Circle::new(p, 2, colour.filled())))
                    .map_err(s)?
            } else {
                chart
                    .draw_series(LineSeries::new(c.points.iter().copied(), style))
                    .map_err(s)?
            };
            drawn.label(c.label.clone()).legend(move |(x, y)| {
                PathElement::new([(x, y), (x + 20, y)], colour.stroke_width(2))
            });
        }
        draw_legend(&mut chart, 16, plot.legend)?;
        Ok(())
    })
}

/// A cross-section map: one dot per particle at `points` (m, in-plane coordinates),
/// coloured by `values` on a diverging blue–white–red scale symmetric about zero (saturated
/// at the 99th percentile of |value|, so that a few outliers do not wash the map out), e.g. the radial displacement of the cavity's snapshots.
/// 800 × 800 pixels, equal axis scales, written atomically as PNG.
pub fn plot_particle_map(
    path: &Path,
    points: &[(f64, f64)],
    values: &[f64],
    title: &str,
) -> Result<()> {
    if points.is_empty() || points.len() != values.len() {
        return Err(Error::Invalid(format!(
            "particle map: {} points and {} values (need the same, at least one)",
            points.len(),
            values.len()
        )));
    }
    if values
        .iter()
        .chain(points.iter().flat_map(|p| [&p.0, &p.1]))
        .any(|v| !v.is_finite())
    {
        return Err(Error::Invalid(
            "particle map: non-finite point or value".into(),
        ));
    }
    let (x0, x1, y0, y1) = square_window(points);
    let mut mags: Vec<f64> = values.iter().map(|v| v.abs()).collect();
    mags.sort_by(f64::total_cmp);
    let vmax = mags[((mags.len() - 1) as f64 * 0.99) as usize];
    let colour = |v: f64| diverging_colour(v, vmax);
    render(path, (800, 800), |root| {
        let mut chart = Frame {
            caption: 20,
            margin: 15,
            labels: (40, 70),
        }
        .chart(root, title, x0..x1, y0..y1)?;
        chart
            .configure_mesh()
            .x_desc("x (m)")
            .y_desc("y (m)")
            .light_line_style(WHITE)
            .x_label_formatter(&|v| format!("{v:.3e}"))
            .y_label_formatter(&|v| format!("{v:.3e}"))
            .label_style(("sans-serif", 12))
            .draw()
            .map_err(s)?;
        chart
            .draw_series(
                points
                    .iter()
                    .zip(values)
                    .map(|(&p, &v)| Circle::new(p, 2, colour(v).filled())),
            )
            .map_err(s)?;
        Ok(())
    })
}

/// The square window (x0, x1, y0, y1) centred on the points' bounding box with 2 % margin:
/// equal scales, the larger extent on both axes.
fn square_window(points: &[(f64, f64)]) -> (f64, f64, f64, f64) {
    let (x0, x1, y0, y1) = points.iter().fold(
        (
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::INFINITY,
            f64::NEG_INFINITY,
        ),
        |(a, b, c, d), &(x, y)| (a.min(x), b.max(x), c.min(y), d.max(y)),
    );
    let half = 0.5 * (x1 - x0).max(y1 - y0).max(f64::MIN_POSITIVE) * 1.02;
    let (cx, cy) = (0.5 * (x0 + x1), 0.5 * (y0 + y1));
    (cx - half, cx + half, cy - half, cy + half)
}

/// Blue–white–red colour of `v` on a scale symmetric about zero, saturated at ±`vmax`
/// (white for `vmax` ≤ 0).
fn diverging_colour(v: f64, vmax: f64) -> RGBColor {
    let t = if vmax > 0.0 {
        (v / vmax).clamp(-1.0, 1.0)
    } else {
        0.0
    };
    let f = |a: f64| (255.0 * (1.0 - a)).round() as u8;
    if t >= 0.0 {
        RGBColor(255, f(t), f(t))
    } else {
        RGBColor(f(-t), f(-t), 255)
    }
}

/// PNG of the loaded stress component (MPa) against step for every element-test path, the
/// title naming the path strain and the Cundall damping λ.
pub fn plot_element_tests(
    path: &Path,
    result: &crate::dem::element::DynamicTensor,
    strain: f64,
    damping: f64,
) -> Result<()> {
    const NAMES: [&str; 6] = ["11", "22", "33", "23", "13", "12"];
    let series: Vec<Series> = result
        .paths
        .iter()
        .map(|p| Series {
            label: format!("path {}: σ{}", NAMES[p.path], NAMES[p.path]),
            points: p
                .history
                .iter()
                .map(|h| (h.step as f64, h.stress[p.path] / 1e6))
                .collect(),
            dashed: false,
            colour: Some(p.path),
        })
        .collect();
    plot_series(
        path,
        &series,
        &format!("element tests: strain {strain:e} in one step, Cundall damping {damping}"),
        "step",
        "stress in the loaded direction (MPa)",
    )
}
