//! The demo (`anisobond demo`): Truszkowska 2018's standard assembly (void fraction 0.40,
//! radii uniform over ΔR = R̄/6, gap cutoff 0.17 R̄) at a size that runs in seconds, her MRV
//! cubic Zener > 1 model, and the tensor by every method beside her Eq. 30; the files for
//! the other tools (YADE, LIGGGHTS, ParaView) written beside them.
//!
//! ```
//! use anisobond::study::demo::{run, static_methods, DemoOptions};
//! let r = run(&DemoOptions { particles: 200, ..Default::default() }, &|_| {}).unwrap();
//! // One report per static method, then the dynamic one (the integrator's element tests).
//! assert_eq!(r.tensors.len(), static_methods().len() + 1);
//! println!("relaxed C11 = {:.1} GPa", r.tensors[3].cubic.c11 / 1e9);
//! ```

use crate::assembly::{Assembly, Detail, Method, MethodKind, MethodOptions, TensorResult};
use crate::dem::element::{DynamicTensor, ElementTestOptions};
use crate::dem::LawKind;
use crate::homogenize::report::TensorReport;
use crate::model::Model;
use crate::packing::generate::{self, GenerateOptions};
use crate::Result;
use std::time::Instant;

/// Truszkowska 2018 Eq. 30 (DEM, symmetrised): C11, C12, C44 in GPa.
pub const PAPER_EQ30_GPA: (f64, f64, f64) = (76.0, 30.6, 28.6);

/// The demo's options.
#[derive(Clone, Copy, Debug)]
pub struct DemoOptions {
    /// Particles of the generated periodic packing (the paper's MRV is 30,700).
    pub particles: usize,
    /// Seed of the packing.
    pub seed: u64,
}

impl Default for DemoOptions {
    fn default() -> Self {
        DemoOptions {
            particles: 4000,
            seed: 1,
        }
    }
}

impl DemoOptions {
    /// Truszkowska 2018's standard assembly: solid fraction 0.60, R̄ = 1 mm, radii uniform
    /// over ΔR = R̄/6.
    pub fn generate_options(&self) -> GenerateOptions {
        GenerateOptions {
            n_particles: self.particles,
            solid_fraction: 0.60,
            mean_radius: 1e-3,
            polydispersity: generate::Polydispersity::Uniform {
                half_width: generate::TRUSZKOWSKA_2018_HALF_WIDTH,
            },
            seed: self.seed,
            ..Default::default()
        }
    }
}

/// The static methods of the demo, in order, with the name printed for each: mean field,
/// Voigt, LAF (shell 2, stress), relaxed (two-level CG, 1e-6); the dynamic one follows.
/// (Each with the library's default options, [`MethodOptions::default`].)
pub fn static_methods() -> [(&'static str, Method); 4] {
    let o = MethodOptions::default();
    [
        (
            MethodKind::MeanField.name(),
            o.method(MethodKind::MeanField),
        ),
        (MethodKind::Voigt.name(), o.method(MethodKind::Voigt)),
        ("laf (m = 2, stress)", o.method(MethodKind::Laf)),
        (MethodKind::Relaxed.name(), o.method(MethodKind::Relaxed)),
    ]
}

/// The element tests of the dynamic method: YADE's law, the library's defaults (strain
/// 1e-5, Cundall damping 0.4 also in the integrator), every step recorded for the plot.
pub fn element_test_options() -> ElementTestOptions {
    let mut o = ElementTestOptions {
        history_every: 1,
        ..Default::default()
    };
    o.dem.local_damping = o.local_damping;
    o
}

/// What [`run`] reports as it goes.
pub enum DemoProgress<'a> {
    /// The packing's generation advances (fraction 0–1).
    Generating(f64),
    /// The packing is bonded.
    Bonded(&'a Assembly),
    /// The element tests advance (fraction 0–1).
    ElementTests(f64),
    /// The element tests are done (time step, weakly bonded particles).
    ElementTestsDone(&'a DynamicTensor),
    /// A method is done.
    Method {
        /// Its printed name.
        name: &'static str,
        /// Its report.
        report: &'a TensorReport,
        /// What the method says of its solution (static methods).
        detail: Option<&'a Detail>,
        /// Seconds it took.
        seconds: f64,
    },
}

/// The demo's results: the model, the bonded packing, the five tensor reports (mean field,
/// Voigt, LAF, relaxed, dynamic) and the element tests.
pub struct DemoReport {
    /// Truszkowska's MRV model.
    pub model: Model,
    /// The bonded packing.
    pub assembly: Assembly,
    /// The tensor reports in the order of the methods.
    pub tensors: Vec<TensorReport>,
    /// The dynamic method's element tests (with their histories).
    pub element_tests: DynamicTensor,
}

/// Generate and bond the packing, then the tensor by every method.
pub fn run(o: &DemoOptions, progress: &(dyn Fn(DemoProgress) + Sync)) -> Result<DemoReport> {
    let model = Model::truszkowska_mrv();
    let p = generate::generate(&o.generate_options(), &|f| {
        progress(DemoProgress::Generating(f))
    })?;
    let b = Assembly::new(p, model.clone())?;
    progress(DemoProgress::Bonded(&b));
    let mut tensors = Vec::new();
    for (name, m) in static_methods() {
        let t = Instant::now();
        let TensorResult { report, detail } = b.tensor(&m)?;
        progress(DemoProgress::Method {
            name,
            report: &report,
            detail: Some(&detail),
            seconds: t.elapsed().as_secs_f64(),
        });
        tensors.push(report);
    }
    let t = Instant::now();
    let element_tests = b.element_tests(LawKind::Yade, &element_test_options(), &|f| {
        progress(DemoProgress::ElementTests(f))
    })?;
    progress(DemoProgress::ElementTestsDone(&element_tests));
    let report = TensorReport::new("dynamic", element_tests.c, Some((&b.packing, &b.bonds)))?;
    progress(DemoProgress::Method {
        name: "dynamic",
        report: &report,
        detail: None,
        seconds: t.elapsed().as_secs_f64(),
    });
    tensors.push(report);
    Ok(DemoReport {
        model,
        assembly: b,
        tensors,
        element_tests,
    })
}

#[cfg(feature = "plot")]
impl DemoReport {
    /// Write the demo's files into `dir`; returns their names (relative to `dir`) in the
    /// order they are listed: the packing, model and bond table, a tensor report per method,
    /// plots, ParaView files of the relaxed state under e11 = −1e-4, the YADE and LIGGGHTS
    /// runs.
    pub fn write(&self, dir: &std::path::Path) -> Result<Vec<String>> {
        use crate::export::{liggghts, yade};
        let (b, model) = (&self.assembly, &self.model);
        crate::packing::io::write_packing(&dir.join("packing.txt"), &b.packing)?;
        crate::io::write_string_atomic(&dir.join("model.toml"), &model.to_toml_string())?;
        crate::bonds::table::write_bond_table(&dir.join("bonds.csv"), &b.bonds, &b.springs)?;
        let mut written: Vec<String> = ["packing.txt", "model.toml", "bonds.csv"]
            .map(String::from)
            .into();
        for r in &self.tensors {
            let name = format!("tensor-{}.json", r.method);
            crate::io::write_string_atomic(&dir.join(&name), &(r.to_json() + "\n"))?;
            written.push(name);
        }
        written.extend(self.write_plots(dir)?);
        // The relaxed state under e11 = −1e-4 (with the grain fields of a polycrystal).
        let strain = crate::tensor::Voigt6::new(-1e-4, 0.0, 0.0, 0.0, 0.0, 0.0);
        b.write_vtk(dir, Some(&strain))?;
        written.extend(["particles.vtu", "bonds.vtu"].map(String::from));
        let yade_opts = yade::YadeRunOptions::default();
        let (p, k) = (&b.packing, &b.springs);
        yade::write_yade_export(&dir.join("yade"), p, &b.bonds, k, Some(model), &yade_opts)?;
        written.push("yade/run.py".into());
        let deck = liggghts::DeckOptions::default();
        liggghts::export_liggghts(&dir.join("liggghts"), p, &b.bonds, k, &deck)?;
        written.extend(["liggghts/anisobond.in", "liggghts/harmonic.in"].map(String::from));
        Ok(written)
    }

    /// stiffness.png (the scheme's normal and shear magnitudes in the cube's planes) and
    /// element-tests.png.
    fn write_plots(&self, dir: &std::path::Path) -> Result<[String; 2]> {
        let b = &self.assembly;
        let scheme = self.model.build_scheme(Some((&b.packing, &b.bonds)))?;
        crate::plot::plot_stiffness_sections(
            &dir.join("stiffness.png"),
            scheme.as_ref(),
            &crate::plot::Section::cubic_planes(&crate::Mat3::identity()),
            "cubic zener-above-1 (Truszkowska MRV): normal (blue) and shear (gold) magnitudes",
            "Pa/m",
        )?;
        let o = element_test_options();
        crate::plot::plot_element_tests(
            &dir.join("element-tests.png"),
            &self.element_tests,
            o.strain,
            o.local_damping,
        )?;
        Ok(["stiffness.png".into(), "element-tests.png".into()])
    }
}
