//! The virtual laboratory (issue 32 item 4; docs/strength-test.md): uniaxial compression
//! (UCS) of a prism or cylinder between glued platens, direct tension, and the Brazilian disc
//! between two flat rigid platens, each on a specimen cut from a packing at a chosen bedding
//! angle β, run with the integrator until the stress has dropped after its peak. [`run`]
//! makes the [`StrengthTestReport`] that `anisobond strength-test` writes
//! (strength_test.json, strength_test.csv, strength_test.png, strength_test_bonds.vtu) and
//! `anisobond.strength_test` returns.
//!
//! - **Orientation**: the whole model is turned by β about y ([`rotate_model`]): the
//!   cross-anisotropic stiffness axis, a crystal's rotation, the strength scheme's axis and
//!   the planes of weakness alike, so stiffness and strength follow the same bedding. For a
//!   model whose axis (or bedding normal) is z, β is the angle between the loading axis (z)
//!   and that axis: β = 0 loads normal to the bedding.
//! - **UCS, tension**: the particles within `end_layer` R̄ of the lowest and of the highest
//!   centre along z are glued to the platens (held by a prescribed velocity, spins zero: the
//!   specimen module's bonded platens); the two platens move towards (UCS) or away from
//!   (tension) each other at ±v/2. Stress = the mean of the two platens' reactions over the
//!   area, strain = the platens' relative displacement over the gauge length; area and gauge
//!   length are those of the exact static solve of the same specimen ([`crate::specimen`],
//!   whose apparent E and ν are reported beside the fitted ones).
//! - **Brazilian disc**: a disc (axis y) between two flat rigid platens normal to z that
//!   start touching its highest and lowest sphere surfaces and close at ±v/2; a sphere whose
//!   surface reaches a platen sticks to it (moves with it, spin zero: the glued platens'
//!   hold, taken on at contact), so the platens flatten the disc over a growing strip. P is
//!   the mean of the two platens' reactions along z; σ_t = 2P/(πDt), D the disc's extent
//!   along z and t its thickness along y. (Frictionless or spring plane contacts let a disc
//!   of spheres roll out between two first contacts that are not in line.)
//! - **Rate**: the platens' relative velocity is `loading_rate` × c, c = R̄·ω_max an upper
//!   bound of the wave speed (ω_max = 2/Δt_crit, the Gershgorin bound of the integrator's
//!   critical step): `loading_rate` is the strain added per wave transit time L/c, at most
//!   (so a smaller value is more quasi-static). The velocity ramps up linearly over the
//!   first 10 transit times. The ratio of kinetic to bond elastic energy at the peak is
//!   reported.
//! - **Peak**: the first peak ([`first_peak`]): the largest stress before the stress first
//!   falls below (1 − `peak_drop`) × its running maximum after bonds have broken. Broken
//!   pairs become frictional contacts that can lock up and carry a higher stress later
//!   (re-hardening); that global maximum is reported apart (`max_stress_pa`).
//! - **E and ν**: least-squares slopes of stress and of the lateral strain (extension
//!   positive; its negative in tension) against the axial strain (in the test's sense) over
//!   the recorded points before the first peak whose stress lies between 10 % and 50 % of
//!   it ([`FIT_RANGE`]); the lateral strain is the mean least-squares slope of
//!   the lateral displacement over the lateral coordinate (x, y) of the particles in the
//!   middle third of the height. Not defined for the Brazilian disc (`null`).
//!
//! A 3 × 3 × 6 simple-cubic block of touching 1 mm spheres (springs k_n = 2e6 N/m) in
//! compression: E from the initial slope is the static solve's, k_n/(2R) = 1e9 Pa.
//! ```
//! use anisobond::{model::Model, packing::Packing, Vec3};
//! use anisobond::study::strength_test::{run, StrengthTestOptions};
//! let r = 1e-3;
//! let centres: Vec<Vec3> = (0..54)
//!     .map(|k| Vec3::new((k % 3) as f64, (k / 3 % 3) as f64, (k / 9) as f64) * 2.0 * r)
//!     .collect();
//! let packing = Packing::new(centres, vec![r; 54], None)?;
//! let model = Model::from_toml_str(
//!     "[bonding]\nrule = \"gap\"\nvalue = 0.01\n[scheme]\nkind = \"isotropic\"\n\
//!      normal = 2e6\nshear = 7e5\n[geometry]\nconvention = \"spring\"\n",
//!     "springs.toml",
//! )?;
//! let opts = StrengthTestOptions {
//!     packing: Some(packing),
//!     model: Some(model),
//!     width_particles: 6.0, // holds the three columns of centres
//!     aspect: Some(2.0),
//!     end_layer: 0.5,
//!     loading_rate: 1e-5,
//!     max_strain: 1e-3,
//!     ..StrengthTestOptions::default()
//! };
//! let report = run(&opts, &|_| {})?;
//! let e = report.modulus_pa.unwrap();
//! assert!((report.static_modulus_pa.unwrap() / 1e9 - 1.0).abs() < 1e-9);
//! assert!((e / 1e9 - 1.0).abs() < 0.01, "{e}");
//! # Ok::<(), anisobond::Error>(())
//! ```

use super::{finite, require_finite, OptionNames};
use crate::assembly::Assembly;
use crate::dem::{
    build_law, check_run_size, BondCriteria, ContactLaw, Contacts, DemOptions, LawKind,
    PrescribedMotion, Simulation,
};
use crate::grains::assign_strength_by_grain;
use crate::model::{Model, SchemeSpec};
use crate::packing::cut::Region;
use crate::packing::{generate, GenerateOptions, Packing};
use crate::specimen::{self, Platens, Selection, SpecimenOptions};
use crate::strength::Mode;
use crate::strength::{BondStrengths, StrengthScheme, StrengthSpec};
use crate::{Error, Mat3, Result, Vec3};
use serde::Serialize;

/// Which test.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum TestKind {
    /// Uniaxial compression between glued platens.
    Ucs,
    /// Direct tension between glued platens.
    Tension,
    /// The Brazilian disc between two flat rigid platens.
    Brazilian,
}

impl TestKind {
    /// The name in strength_test.json (`ucs`, `tension`, `brazilian`).
    pub fn as_str(self) -> &'static str {
        match self {
            TestKind::Ucs => "ucs",
            TestKind::Tension => "tension",
            TestKind::Brazilian => "brazilian",
        }
    }

    /// The test of a name (`ucs`, `tension`, `brazilian`).
    pub fn from_name(name: &str) -> Option<TestKind> {
        [TestKind::Ucs, TestKind::Tension, TestKind::Brazilian]
            .into_iter()
            .find(|t| t.as_str() == name)
    }

    /// Default length over width (UCS, tension: 2) or thickness over diameter (Brazilian:
    /// 0.5, ISRM's disc).
    pub fn default_aspect(self) -> f64 {
        match self {
            TestKind::Ucs | TestKind::Tension => 2.0,
            TestKind::Brazilian => 0.5,
        }
    }
}

/// The cross-section of a UCS or tension specimen (the Brazilian specimen is a disc).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum SpecimenShape {
    /// A square prism.
    Prism,
    /// A circular cylinder.
    Cylinder,
}

impl SpecimenShape {
    /// `prism` or `cylinder`.
    pub fn as_str(self) -> &'static str {
        match self {
            SpecimenShape::Prism => "prism",
            SpecimenShape::Cylinder => "cylinder",
        }
    }
}

/// The stress window of the E and ν fit, as fractions of the peak stress.
pub const FIT_RANGE: (f64, f64) = (0.1, 0.5);

/// Transit times over which the platen velocity ramps up.
pub const RAMP_TRANSITS: f64 = 10.0;

pub use crate::strength::peak::{first_peak, PeakPick};

/// The options of the study; [`Default`] holds the defaults of `anisobond strength-test`.
/// Lengths in mean particle radii R̄ where so named.
#[derive(Clone, Debug)]
pub struct StrengthTestOptions {
    /// Which test.
    pub test: TestKind,
    /// Prism or cylinder (UCS, tension).
    pub shape: SpecimenShape,
    /// The packing the specimen is cut from; `None`: a generated periodic packing of
    /// `cell_particles` spheres (R̄ = 1 mm).
    pub packing: Option<Packing>,
    /// The model (bonds, stiffness, `[strength]`); `None`: [`default_model`].
    pub model: Option<Model>,
    /// The integrator's bond law.
    pub law: LawKind,
    /// β (degrees): the model is turned by β about y.
    pub bedding_deg: f64,
    /// Width of the prism, diameter of the cylinder or disc, in R̄.
    pub width_particles: f64,
    /// Length over width (UCS, tension) or thickness over diameter (Brazilian); `None`: the
    /// test's default ([`TestKind::default_aspect`]).
    pub aspect: Option<f64>,
    /// Depth of the glued end layers in R̄ (UCS, tension).
    pub end_layer: f64,
    /// Axial strain per wave transit time (at most; see the module doc).
    pub loading_rate: f64,
    /// The run ends at this axial strain if the stress has not dropped before.
    pub max_strain: f64,
    /// The run ends once bonds have broken and the stress has dropped below this fraction
    /// of its peak.
    pub stop_fraction: f64,
    /// The peak reported is the first one: the largest stress before the stress first falls
    /// below (1 − `peak_drop`) × its running maximum after bonds broke ([`first_peak`]).
    pub peak_drop: f64,
    /// Cundall local damping λ.
    pub local_damping: f64,
    /// Spheres of the generated packing (when `packing` is `None`).
    pub cell_particles: usize,
    /// Seed of the generated packing.
    pub seed: u64,
    /// Recorded points of the curve up to `max_strain`.
    pub points: usize,
}

impl Default for StrengthTestOptions {
    fn default() -> Self {
        StrengthTestOptions {
            test: TestKind::Ucs,
            shape: SpecimenShape::Prism,
            packing: None,
            model: None,
            law: LawKind::Yade,
            bedding_deg: 0.0,
            width_particles: 16.0,
            aspect: None,
            end_layer: 1.0,
            loading_rate: 1e-6,
            max_strain: 0.005,
            stop_fraction: 0.5,
            peak_drop: 0.05,
            local_damping: 0.1,
            cell_particles: 1000,
            seed: 1,
            points: 1000,
        }
    }
}

/// The model of the default study: bonds within a gap of 0.17 R̄ (Truszkowska 2018), an
/// isotropic scheme of moduli (k = magnitude·A_b/L_b: normal 1e10 Pa, shear 3e9 Pa), and an
/// isotropic strength σ_t = 5 MPa, c = 10 MPa (docs/strength.md).
pub fn default_model() -> Model {
    Model::from_toml_str(
        "[bonding]\nrule = \"gap\"\nvalue = 0.17\n[scheme]\nkind = \"isotropic\"\n\
         normal = 1.0e10\nshear = 3.0e9\n[geometry]\nconvention = \"modulus\"\n\
         [strength.bond]\ntensile = 5.0e6\ncohesion = 1.0e7\n",
        "default strength-test model",
    )
    .expect("the default model is valid")
}

impl StrengthTestOptions {
    /// Length over width, or thickness over diameter.
    pub fn aspect(&self) -> f64 {
        self.aspect.unwrap_or_else(|| self.test.default_aspect())
    }

    /// Refuse options that cannot give a result, before any work; messages name the
    /// options as `names` does.
    pub fn check(&self, names: OptionNames) -> Result<()> {
        let n = |f: &str| names.name(f);
        names.require_positive(&[
            ("width_particles", self.width_particles),
            ("aspect", self.aspect()),
            ("end_layer", self.end_layer),
            ("loading_rate", self.loading_rate),
            ("max_strain", self.max_strain),
        ])?;
        if !self.bedding_deg.is_finite() {
            return Err(Error::Invalid(format!(
                "{} {}: expected a finite angle in degrees",
                n("bedding_deg"),
                self.bedding_deg
            )));
        }
        if self.max_strain >= 0.5 {
            return Err(Error::Invalid(format!(
                "{} {}: expected a strain below 0.5",
                n("max_strain"),
                self.max_strain
            )));
        }
        if self.loading_rate > 0.01 {
            return Err(Error::Invalid(format!(
                "{} {}: expected at most 0.01 strain per wave transit (a quasi-static test \
                 needs far less; 1e-5 is the default)",
                n("loading_rate"),
                self.loading_rate
            )));
        }
        if !(self.stop_fraction.is_finite() && self.stop_fraction > 0.0 && self.stop_fraction < 1.0)
        {
            return Err(Error::Invalid(format!(
                "{} {}: expected a fraction of the peak in (0, 1)",
                n("stop_fraction"),
                self.stop_fraction
            )));
        }
        if !(self.peak_drop.is_finite()
            && self.peak_drop > 0.0
            && self.peak_drop <= 1.0 - self.stop_fraction)
        {
            return Err(Error::Invalid(format!(
                "{} {}: expected a fraction in (0, 1 − {} = {}] (a run that stops on its \
                 drop must have found the first peak)",
                n("peak_drop"),
                self.peak_drop,
                n("stop_fraction"),
                1.0 - self.stop_fraction
            )));
        }
        if !(self.local_damping.is_finite() && (0.0..1.0).contains(&self.local_damping)) {
            return Err(Error::Invalid(format!(
                "{} {}: expected a value in [0, 1)",
                n("local_damping"),
                self.local_damping
            )));
        }
        if self.points < 10 {
            return Err(Error::Invalid(format!(
                "{} {}: expected at least 10 recorded points",
                n("points"),
                self.points
            )));
        }
        if self.packing.is_none() && self.cell_particles < 10 {
            return Err(Error::Invalid(format!(
                "{} {}: expected at least 10 spheres",
                n("cell_particles"),
                self.cell_particles
            )));
        }
        if self.test != TestKind::Brazilian
            && 2.0 * self.end_layer >= self.width_particles * self.aspect()
        {
            return Err(Error::Invalid(format!(
                "{} {}: the two end layers would meet in a specimen {} R̄ long",
                n("end_layer"),
                self.end_layer,
                self.width_particles * self.aspect()
            )));
        }
        Ok(())
    }
}

/// The rotation by `beta_deg` about y: z goes to (sin β, 0, cos β).
pub fn bedding_rotation(beta_deg: f64) -> Mat3 {
    let (s, c) = beta_deg.to_radians().sin_cos();
    Mat3::new(c, 0.0, s, 0.0, 1.0, 0.0, -s, 0.0, c)
}

/// `model` turned by the rotation `q` (lab frame): the cross-anisotropic axis a → q·a, a
/// crystal's lab → crystal rotation R → R·qᵀ. The `[strength]` table is turned with
/// [`rotate_strength`] where the strengths are assigned.
pub fn rotate_model(model: &Model, q: &Mat3) -> Model {
    let mut m = model.clone();
    match &mut m.scheme {
        SchemeSpec::CrossAnisotropic(t) => t.axis = q * t.axis,
        SchemeSpec::Cubic(c) => c.rotation *= q.transpose(),
        SchemeSpec::Isotropic { .. } => {}
    }
    m
}

/// `spec` turned by the rotation `q`: the scheme's axis a → q·a, a crystal's rotation
/// R → R·qᵀ, every plane normal n → q·n (planes n·x = d become (q·n)·(q·x) = d).
pub fn rotate_strength(spec: &StrengthSpec, q: &Mat3) -> StrengthSpec {
    let mut s = spec.clone();
    match &mut s.scheme {
        StrengthScheme::CrossAnisotropic(c) => c.axis = q * c.axis,
        StrengthScheme::Cubic(c) => c.rotation *= q.transpose(),
        StrengthScheme::Isotropic(_) => {}
    }
    for p in &mut s.planes {
        p.normal = q * p.normal;
    }
    s
}

/// What the study reports as it goes.
#[derive(Clone, Copy, Debug)]
pub enum StrengthTestProgress {
    /// The specimen is cut and bonded.
    Specimen {
        /// Particles.
        particles: usize,
        /// Bonds.
        bonds: usize,
        /// Time step (s).
        time_step: f64,
        /// Steps to reach the largest strain.
        max_steps: u64,
    },
    /// A recorded point.
    Loading {
        /// Strain over the largest strain.
        fraction: f64,
        /// The current stress (Pa).
        stress_pa: f64,
        /// Bonds broken so far.
        broken: usize,
    },
}

/// One recorded state of the curve (the rows of strength_test.csv).
#[derive(Clone, Copy, Debug, Serialize)]
pub struct CurvePoint {
    /// Time steps done.
    pub step: u64,
    /// Simulated time (s).
    pub time_s: f64,
    /// Axial strain: the platens' relative displacement over the gauge length (or over D),
    /// positive in the test's own sense (shortening for UCS and Brazilian).
    pub strain: f64,
    /// Stress in the test's own sense (Pa): compression (UCS), tension (tension), σ_t =
    /// 2P/(πDt) (Brazilian).
    pub stress_pa: f64,
    /// Lateral strain at mid-height (extension positive; UCS and tension).
    pub lateral_strain: Option<f64>,
    /// The platens' relative displacement (m).
    pub displacement_m: f64,
    /// Mean platen force (N), the test's sense positive.
    pub force_n: f64,
    /// Kinetic energy (J).
    pub kinetic_j: f64,
    /// Elastic energy of the bonds (J).
    pub elastic_j: f64,
    /// Bonds broken so far.
    pub broken: usize,
}

/// Broken bonds by mode.
#[derive(Clone, Copy, Debug, Default, Serialize, PartialEq, Eq)]
pub struct CrackCounts {
    /// Broken by the normal force (tension).
    pub tension: usize,
    /// Broken by the shear force.
    pub shear: usize,
    /// Broken by the bending moment.
    pub bending: usize,
    /// Broken by the twisting moment.
    pub twisting: usize,
    /// All broken bonds.
    pub total: usize,
}

/// The study's one output schema: strength_test.json and Python's dict (the curve in
/// strength_test.csv and as arrays). Units in the keys; `None` (null) where a value is not
/// defined for the test.
#[derive(Clone, Debug, Serialize)]
pub struct StrengthTestReport {
    /// Units of the keys.
    pub units: serde_json::Value,
    /// `ucs`, `tension` or `brazilian`.
    pub test: &'static str,
    /// `prism`, `cylinder` or `disc`.
    pub shape: &'static str,
    /// The integrator's bond law.
    pub law: LawKind,
    /// β (degrees).
    pub bedding_deg: f64,
    /// Whether bonds could break (the model has a `[strength]` table and the integrator
    /// breaks bonds).
    pub breakage: bool,
    /// What is not modelled in this run, in words (empty when nothing is missing).
    pub notes: Vec<String>,
    /// Particles of the specimen.
    pub particles: usize,
    /// Bonds of the specimen.
    pub bonds: usize,
    /// Gauge length (UCS, tension) or disc diameter D (m).
    pub length_m: f64,
    /// Cross-section (UCS, tension; m²).
    pub area_m2: Option<f64>,
    /// Disc thickness t (Brazilian; m).
    pub thickness_m: Option<f64>,
    /// Time step (s).
    pub time_step_s: f64,
    /// Upper bound of the wave transit time L/c (s).
    pub transit_time_s: f64,
    /// The platens' relative velocity after the ramp (m/s).
    pub platen_velocity_m_per_s: f64,
    /// Time steps run.
    pub steps: u64,
    /// Why the run ended: `drop` (below `stop_fraction` of the peak) or `max-strain`.
    pub stop: &'static str,
    /// Peak stress (Pa): the UCS, the tensile strength or σ_t of the Brazilian disc — the
    /// first peak ([`first_peak`] with `peak_drop`).
    pub peak_stress_pa: f64,
    /// Axial strain at the (first) peak.
    pub strain_at_peak: f64,
    /// Whether the stress fell by `peak_drop` after the peak (false: the peak is the
    /// largest stress of a curve that never dropped, e.g. one stopped at `max_strain`).
    pub peak_dropped: bool,
    /// The `peak_drop` fraction that defined the first peak.
    pub peak_drop: f64,
    /// The largest stress of the whole curve (Pa), re-hardening after the first drop
    /// included; equal to `peak_stress_pa` when nothing re-hardened.
    pub max_stress_pa: f64,
    /// Axial strain at `max_stress_pa`.
    pub strain_at_max: f64,
    /// Kinetic over bond elastic energy at the peak (quasi-static: ≪ 1).
    pub kinetic_over_elastic_at_peak: f64,
    /// Young's modulus fitted on the initial slope (Pa; UCS, tension).
    pub modulus_pa: Option<f64>,
    /// Poisson's ratio fitted on the initial slope (UCS, tension).
    pub poisson: Option<f64>,
    /// Points in the fit.
    pub fit_points: usize,
    /// The static solve's apparent E of the same specimen and platens (Pa; UCS, tension).
    pub static_modulus_pa: Option<f64>,
    /// The static solve's apparent ν (UCS, tension).
    pub static_poisson: Option<f64>,
    /// Broken bonds by mode.
    pub cracks: CrackCounts,
    /// Broken bonds over all bonds.
    pub broken_fraction: f64,
    /// How E, ν and the stresses were computed.
    pub how: String,
    /// The recorded curve (strength_test.csv).
    #[serde(skip)]
    pub curve: Vec<CurvePoint>,
    /// Every bond: (i, j), its state at the end, and the time, step and mode of breaking.
    #[serde(skip)]
    pub bond_states: BondStates,
}

/// The bonds at the end of the run (strength_test_bonds.vtu).
#[derive(Clone, Debug, Default)]
pub struct BondStates {
    /// First particle of every bond.
    pub i: Vec<u32>,
    /// Second particle of every bond.
    pub j: Vec<u32>,
    /// Particle positions at the end (m).
    pub positions: Vec<Vec3>,
    /// Time of breaking (s); `None` while intact.
    pub broken_at: Vec<Option<f64>>,
    /// Mode of breaking: 1 tension, 2 shear, 3 bending, 4 twisting; 0 intact.
    pub mode: Vec<u8>,
}

/// What the fit and the stresses are, written into the report.
const HOW: &str = "stress = mean of the two platens' reactions along z over area_m2 (UCS, \
    tension; area and gauge length from the exact static solve of the same specimen) or \
    sigma_t = 2P/(pi D t) (Brazilian, P the mean platen force); strain = the platens' \
    relative displacement over length_m; peak_stress_pa = the first peak: the largest \
    stress before the stress first falls below (1 - peak_drop) x its running maximum after \
    bonds broke (max_stress_pa: the whole curve's largest); modulus_pa and poisson = \
    least-squares slopes of stress and of the lateral strain (times -1 in tension) over \
    strain on the recorded points before the first peak with stress between 10 % and 50 % \
    of it; lateral strain = mean least-squares slope of \
    the lateral displacement over x and over y on the particles of the middle third of the \
    height";

/// The specimen ready to load: its assembly, strengths and the particle groups.
struct Specimen {
    assembly: Assembly,
    strengths: Option<BondStrengths>,
    /// Bottom and top end layers (UCS, tension).
    bottom: Vec<usize>,
    top: Vec<usize>,
    /// Particles of the middle third of the height.
    middle: Vec<usize>,
}

/// The packing to cut from: the given one or a generated periodic one.
fn source_packing(opts: &StrengthTestOptions) -> Result<Packing> {
    match &opts.packing {
        Some(p) => Ok(p.clone()),
        None => generate(
            &GenerateOptions {
                n_particles: opts.cell_particles,
                seed: opts.seed,
                ..GenerateOptions::default()
            },
            &|_| {},
        ),
    }
}

/// The region of the specimen, centred on the packing's cell or bounding box.
fn region(opts: &StrengthTestOptions, packing: &Packing) -> Region {
    let centre = match &packing.cell {
        Some(c) => c.lengths * 0.5,
        None => {
            let (lo, hi) = packing.positions.iter().fold(
                (Vec3::repeat(f64::INFINITY), Vec3::repeat(f64::NEG_INFINITY)),
                |(lo, hi), x| (lo.inf(x), hi.sup(x)),
            );
            (lo + hi) * 0.5
        }
    };
    let w = opts.width_particles * packing.mean_radius();
    let l = opts.aspect() * w;
    match (opts.test, opts.shape) {
        (TestKind::Brazilian, _) => Region::Cylinder {
            centre,
            axis: Vec3::y(),
            radius: 0.5 * w,
            length: l,
        },
        (_, SpecimenShape::Prism) => {
            let half = Vec3::new(0.5 * w, 0.5 * w, 0.5 * l);
            Region::Box {
                lo: centre - half,
                hi: centre + half,
                axis: 2,
            }
        }
        (_, SpecimenShape::Cylinder) => Region::Cylinder {
            centre,
            axis: Vec3::z(),
            radius: 0.5 * w,
            length: l,
        },
    }
}

/// Cut, bond and assign strengths; choose the end layers and the middle third.
fn make_specimen(opts: &StrengthTestOptions, model: &Model, q: &Mat3) -> Result<Specimen> {
    let source = source_packing(opts)?;
    let region = region(opts, &source);
    let assembly = if source.cell.is_some() {
        Assembly::cut(&source, &region, model.clone())?.0
    } else {
        let cut = crate::packing::cut::cut(&source, &region)?;
        Assembly::new(cut.packing, model.clone())?
    };
    let strengths = match &model.strength {
        Some(table) => {
            let spec = rotate_strength(&StrengthSpec::from_table(table)?, q);
            let (p, b, g) = (&assembly.packing, &assembly.bonds, model.grains.as_ref());
            Some(assign_strength_by_grain(p, b, &spec, g, assembly.grains())?)
        }
        None => None,
    };
    let p = &assembly.packing;
    let depth = opts.end_layer * p.mean_radius();
    let group = |top: bool| -> Result<Vec<usize>> {
        let flags = Selection::EndLayer { top, depth }.select(p, 2)?;
        Ok((0..p.len()).filter(|&k| flags[k]).collect())
    };
    let (bottom, top) = (group(false)?, group(true)?);
    let (zlo, zhi) = p
        .positions
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), x| {
            (a.min(x.z), b.max(x.z))
        });
    let third = (zhi - zlo) / 3.0;
    let middle = (0..p.len())
        .filter(|&k| {
            let z = p.positions[k].z;
            z >= zlo + third && z <= zhi - third
        })
        .collect();
    Ok(Specimen {
        assembly,
        strengths,
        bottom,
        top,
        middle,
    })
}

/// The least-squares slope of `y` over `x`; `None` with fewer than two distinct x.
fn slope(points: impl Iterator<Item = (f64, f64)> + Clone) -> Option<f64> {
    let n = points.clone().count() as f64;
    if n < 2.0 {
        return None;
    }
    let (sx, sy) = points
        .clone()
        .fold((0.0, 0.0), |(a, b), (x, y)| (a + x, b + y));
    let (mx, my) = (sx / n, sy / n);
    let (sxx, sxy) = points.fold((0.0, 0.0), |(a, b), (x, y)| {
        (a + (x - mx) * (x - mx), b + (x - mx) * (y - my))
    });
    (sxx > 0.0).then(|| sxy / sxx)
}

/// The platens of a run: glued end layers, or the Brazilian disc's two planes.
enum Loading {
    Glued {
        /// Area (m²) and gauge length (m) of the static solve.
        area: f64,
        /// +1 compression (UCS), −1 tension.
        sense: f64,
    },
    Disc {
        /// Top and bottom plane heights at the start (m).
        top0: f64,
        bottom0: f64,
        /// Thickness (m).
        thickness: f64,
    },
}

/// The run in progress.
struct Run<'a> {
    specimen: &'a Specimen,
    sim: Simulation,
    loading: Loading,
    /// Gauge length or diameter (m).
    length: f64,
    /// Relative platen velocity after the ramp (m/s).
    speed: f64,
    /// Ramp time (s).
    ramp: f64,
    /// The platens' relative displacement so far (m).
    displacement: f64,
    /// Initial positions (m).
    start: Vec<Vec3>,
    /// The glued platens' relative velocity last set (m/s).
    set_speed: Option<f64>,
    /// The spheres stuck to the top and to the bottom Brazilian platen.
    stuck: [Vec<usize>; 2],
    /// Whether each sphere is stuck to a platen.
    is_stuck: Vec<bool>,
}

impl Run<'_> {
    /// The relative platen velocity at time `t`.
    fn speed_at(&self, t: f64) -> f64 {
        self.speed * (t / self.ramp).min(1.0)
    }

    /// Set the glued platens' velocities (each moves by half).
    fn set_glued_motion(&mut self, v: f64, sense: f64) -> Result<()> {
        let s = self.specimen;
        let half = 0.5 * v * sense;
        let particles: Vec<usize> = s.bottom.iter().chain(&s.top).copied().collect();
        let velocity = s
            .bottom
            .iter()
            .map(|_| Vec3::z() * half)
            .chain(s.top.iter().map(|_| -Vec3::z() * half))
            .collect();
        self.sim.set_prescribed_motion(Some(PrescribedMotion {
            particles,
            velocity,
        }))
    }

    /// Stick the spheres that now touch a Brazilian platen to it; true when any did.
    fn stick_disc_contacts(&mut self) -> bool {
        let Loading::Disc { top0, bottom0, .. } = self.loading else {
            unreachable!("disc loading only")
        };
        let half = 0.5 * self.displacement;
        let (top, bottom) = (top0 - half, bottom0 + half);
        let p = &self.sim.particles;
        let mut any = false;
        for i in 0..p.len() {
            if self.is_stuck[i] {
                continue;
            }
            let (z, r) = (p.position[i].z, p.radius[i]);
            let side = if z + r >= top {
                0
            } else if z - r <= bottom {
                1
            } else {
                continue;
            };
            self.stuck[side].push(i);
            self.is_stuck[i] = true;
            any = true;
        }
        any
    }

    /// Move the stuck spheres with their platens (each at half the relative velocity).
    fn set_disc_motion(&mut self, v: f64) -> Result<()> {
        let [top, bottom] = &self.stuck;
        let particles: Vec<usize> = top.iter().chain(bottom).copied().collect();
        let velocity = top
            .iter()
            .map(|_| -Vec3::z() * (0.5 * v))
            .chain(bottom.iter().map(|_| Vec3::z() * (0.5 * v)))
            .collect();
        self.sim.set_prescribed_motion(Some(PrescribedMotion {
            particles,
            velocity,
        }))
    }

    /// One step: platens moved, forces applied, the integrator stepped.
    fn step(&mut self) -> Result<()> {
        let dt = self.sim.time_step();
        let v = self.speed_at(self.sim.time() + 0.5 * dt);
        match self.loading {
            Loading::Glued { sense, .. } => {
                if self.set_speed != Some(v) {
                    self.set_glued_motion(v, sense)?;
                    self.set_speed = Some(v);
                }
            }
            Loading::Disc { .. } => {
                if self.stick_disc_contacts() || self.set_speed != Some(v) {
                    self.set_disc_motion(v)?;
                    self.set_speed = Some(v);
                }
            }
        }
        self.sim.step()?;
        self.displacement += v * dt;
        Ok(())
    }

    /// The recorded state now.
    fn point(&self, broken: usize) -> Result<CurvePoint> {
        let s = self.specimen;
        let (stress, force, lateral) = match self.loading {
            Loading::Glued { area, sense } => {
                let sum = |g: &[usize]| g.iter().map(|&p| self.sim.force[p].z).sum::<f64>();
                // Bonds push the top layer up and the bottom down in compression.
                let f = 0.5 * (sum(&s.top) - sum(&s.bottom)) * sense;
                (f / area, f, Some(self.lateral_strain()))
            }
            Loading::Disc { thickness, .. } => {
                let sum = |g: &[usize]| g.iter().map(|&p| self.sim.force[p].z).sum::<f64>();
                // Bonds push the top platen's spheres up and the bottom's down.
                let p = 0.5 * (sum(&self.stuck[0]) - sum(&self.stuck[1]));
                let d = self.length;
                (2.0 * p / (std::f64::consts::PI * d * thickness), p, None)
            }
        };
        let e = self.sim.energies();
        let point = CurvePoint {
            step: self.sim.iteration(),
            time_s: self.sim.time(),
            strain: self.displacement / self.length,
            stress_pa: stress,
            lateral_strain: lateral.flatten(),
            displacement_m: self.displacement,
            force_n: force,
            kinetic_j: e.kinetic,
            elastic_j: e.elastic,
            broken,
        };
        if !(point.stress_pa.is_finite() && e.kinetic.is_finite() && e.elastic.is_finite()) {
            return Err(Error::Degenerate(format!(
                "strength test: non-finite stress or energy at step {}",
                point.step
            )));
        }
        Ok(point)
    }

    /// The mean least-squares slope of the lateral displacement over x and over y on the
    /// middle third; `None` when the middle third has no lateral extent.
    fn lateral_strain(&self) -> Option<f64> {
        let m = &self.specimen.middle;
        let x = &self.sim.particles.position;
        let along = |a: usize| {
            slope(
                m.iter()
                    .map(move |&k| (self.start[k][a], x[k][a] - self.start[k][a])),
            )
        };
        Some(0.5 * (along(0)? + along(1)?))
    }
}

/// Verlet skin of the contacts after breaking, in mean radii: the list is rebuilt when a
/// sphere may have moved a tenth of a radius, a few hundred steps of a quasi-static run.
const CONTACT_SKIN: f64 = 0.2;

/// The frictional contacts that broken bonds and newly touching spheres become
/// (`dem::Contacts`, YADE's Cundall–Strack law): springs the median bond k_n and k_s (a broken
/// bond's own pair keeps its own springs), friction the mean of the bonds' μ.
fn contact_law(springs: &crate::bonds::BondStiffness, strengths: &BondStrengths) -> ContactLaw {
    let median = |v: &[f64]| {
        let mut v = v.to_vec();
        v.sort_by(f64::total_cmp);
        v.get(v.len() / 2).copied().unwrap_or(0.0)
    };
    let n = strengths.friction.len().max(1) as f64;
    ContactLaw {
        normal_stiffness: median(&springs.kn),
        shear_stiffness: median(&springs.ks),
        friction: strengths.friction.iter().sum::<f64>() / n,
    }
}

/// Run the study (see the module doc). Refuses what [`StrengthTestOptions::check`] refuses
/// (named as flags) before any work.
pub fn run(
    opts: &StrengthTestOptions,
    progress: &(dyn Fn(StrengthTestProgress) + Sync),
) -> Result<StrengthTestReport> {
    opts.check(OptionNames::Flags)?;
    let q = bedding_rotation(opts.bedding_deg);
    let model = rotate_model(&opts.model.clone().unwrap_or_else(default_model), &q);
    let specimen = make_specimen(opts, &model, &q)?;
    let a = &specimen.assembly;
    a.refuse_manybody("the strength test")?;
    let mut notes = Vec::new();
    if specimen.strengths.is_none() {
        notes.push("the model has no [strength] table: no bond breaks".into());
    }
    // The static solve of the same specimen and platens: area, gauge length, E, ν.
    let static_report = match opts.test {
        TestKind::Brazilian => None,
        _ => {
            let mut so = SpecimenOptions::new(2, opts.end_layer * a.packing.mean_radius());
            so.platens = Platens::Bonded;
            so.shape = match opts.shape {
                SpecimenShape::Prism => specimen::Shape::Prism,
                SpecimenShape::Cylinder => specimen::Shape::Cylinder,
            };
            Some(specimen::solve(a, &so)?)
        }
    };
    let law = build_law(opts.law, &a.packing, &a.bonds, &a.springs)?;
    let dem = DemOptions {
        local_damping: opts.local_damping,
        ..DemOptions::default()
    };
    let mut sim = Simulation::new(&a.packing, &a.bonds, law, &dem)?;
    if let Some(strengths) = &specimen.strengths {
        let criteria =
            BondCriteria::for_law(opts.law, strengths, &a.packing, &a.bonds, &model.geometry)?;
        sim.set_breakage(Some(criteria))?;
        sim.set_contacts(Some(Contacts::new(
            contact_law(&a.springs, strengths),
            CONTACT_SKIN * a.packing.mean_radius(),
        )?))?;
    }
    let critical = sim.stability().critical_time_step;
    let p = &a.packing;
    let (loading, length) = match &static_report {
        Some(r) => (
            Loading::Glued {
                area: r.area,
                sense: if opts.test == TestKind::Ucs {
                    1.0
                } else {
                    -1.0
                },
            },
            r.length,
        ),
        None => {
            let ext = |axis: usize, sign: f64| {
                (0..p.len())
                    .map(|k| sign * p.positions[k][axis] + p.radii[k])
                    .fold(f64::NEG_INFINITY, f64::max)
            };
            let (top0, bottom0) = (ext(2, 1.0), -ext(2, -1.0));
            let thickness = ext(1, 1.0) + ext(1, -1.0);
            (
                Loading::Disc {
                    top0,
                    bottom0,
                    thickness,
                },
                top0 - bottom0,
            )
        }
    };
    let wave_speed = p.mean_radius() * 2.0 / critical;
    let transit = length / wave_speed;
    let speed = opts.loading_rate * length / transit;
    let ramp = RAMP_TRANSITS * transit;
    let dt = sim.time_step();
    let max_steps = ((opts.max_strain * length / speed + 0.5 * ramp) / dt).ceil();
    check_run_size(
        "strength test (--max-strain over --loading-rate)",
        p.len(),
        max_steps,
    )?;
    let max_steps = max_steps as u64;
    progress(StrengthTestProgress::Specimen {
        particles: p.len(),
        bonds: a.bonds.len(),
        time_step: dt,
        max_steps,
    });
    let record_every = (max_steps / opts.points as u64).max(1);
    let mut run = Run {
        specimen: &specimen,
        start: sim.particles.position.clone(),
        sim,
        loading,
        length,
        speed,
        ramp,
        displacement: 0.0,
        set_speed: None,
        stuck: [Vec::new(), Vec::new()],
        is_stuck: vec![false; p.len()],
    };
    let mut curve = vec![run.point(0)?];
    // The running maximum (the stop rule's); the first peak is picked after the run.
    let (mut running_max, mut stop) = (0usize, "max-strain");
    while run.displacement < opts.max_strain * length {
        run.step()?;
        if !run.sim.iteration().is_multiple_of(record_every) {
            continue;
        }
        let broken = run.sim.break_events().len();
        let pt = run.point(broken)?;
        curve.push(pt);
        if pt.stress_pa > curve[running_max].stress_pa {
            running_max = curve.len() - 1;
        }
        progress(StrengthTestProgress::Loading {
            fraction: pt.strain / opts.max_strain,
            stress_pa: pt.stress_pa,
            broken,
        });
        if broken > 0 && pt.stress_pa < opts.stop_fraction * curve[running_max].stress_pa {
            stop = "drop";
            break;
        }
    }
    let last = run.point(run.sim.break_events().len())?;
    if curve.last().is_none_or(|p| p.step != last.step) {
        curve.push(last);
    }
    let series: Vec<(f64, usize)> = curve.iter().map(|c| (c.stress_pa, c.broken)).collect();
    let pick = first_peak(&series, opts.peak_drop).expect("the curve has its first point");
    let peak = pick.first;
    let (pk, mx) = (curve[peak], curve[pick.max]);
    if pk.stress_pa <= 0.0 {
        return Err(Error::Degenerate(format!(
            "strength test: the stress never rose above zero (largest {:e} Pa by strain {:e})",
            pk.stress_pa, pk.strain
        )));
    }
    let (lo, hi) = (FIT_RANGE.0 * pk.stress_pa, FIT_RANGE.1 * pk.stress_pa);
    let fit: Vec<&CurvePoint> = curve[..=peak]
        .iter()
        .filter(|c| c.stress_pa >= lo && c.stress_pa <= hi)
        .collect();
    let glued = static_report.is_some();
    let (modulus, poisson) = if glued {
        if fit.len() < 5 {
            return Err(Error::Degenerate(format!(
                "strength test: {} recorded points between 10 % and 50 % of the peak, need 5 \
                 for E and ν: give more --points or a smaller --loading-rate",
                fit.len()
            )));
        }
        let e = slope(fit.iter().map(|c| (c.strain, c.stress_pa)));
        // Lateral extension per axial shortening (UCS), lateral contraction per axial
        // extension (tension): both positive for a positive ν.
        let sense = match run.loading {
            Loading::Glued { sense, .. } => sense,
            Loading::Disc { .. } => 1.0,
        };
        let nu = slope(
            fit.iter()
                .filter_map(|c| c.lateral_strain.map(|l| (c.strain, sense * l))),
        );
        (
            Some(require_finite(e.unwrap_or(f64::NAN), "the fitted E")?),
            nu.and_then(finite),
        )
    } else {
        (None, None)
    };
    let bonds = a.bonds.len();
    let mut cracks = CrackCounts::default();
    let mut bond_states = BondStates {
        i: a.bonds.i.clone(),
        j: a.bonds.j.clone(),
        positions: run.sim.particles.position.clone(),
        broken_at: vec![None; bonds],
        mode: vec![0; bonds],
    };
    for ev in run.sim.break_events() {
        let (count, code) = match ev.mode {
            Mode::Tension => (&mut cracks.tension, 1),
            Mode::Shear => (&mut cracks.shear, 2),
            Mode::Bending => (&mut cracks.bending, 3),
            Mode::Twisting => (&mut cracks.twisting, 4),
        };
        *count += 1;
        cracks.total += 1;
        bond_states.broken_at[ev.bond] = Some(ev.time);
        bond_states.mode[ev.bond] = code;
    }
    let kinetic_ratio = if pk.elastic_j > 0.0 {
        pk.kinetic_j / pk.elastic_j
    } else {
        f64::NAN
    };
    Ok(StrengthTestReport {
        units: serde_json::json!({
            "*_pa": "Pa", "*_m": "m", "*_m2": "m²", "*_s": "s",
            "*_m_per_s": "m/s", "bedding_deg": "degrees", "strain": "1", "poisson": "1",
            "kinetic_over_elastic_at_peak": "1", "broken_fraction": "1"
        }),
        test: opts.test.as_str(),
        shape: match opts.test {
            TestKind::Brazilian => "disc",
            _ => opts.shape.as_str(),
        },
        law: opts.law,
        bedding_deg: opts.bedding_deg,
        breakage: specimen.strengths.is_some(),
        notes,
        particles: p.len(),
        bonds,
        length_m: length,
        area_m2: static_report.as_ref().map(|r| r.area),
        thickness_m: match run.loading {
            Loading::Disc { thickness, .. } => Some(thickness),
            Loading::Glued { .. } => None,
        },
        time_step_s: dt,
        transit_time_s: transit,
        platen_velocity_m_per_s: speed,
        steps: run.sim.iteration(),
        stop,
        peak_stress_pa: pk.stress_pa,
        strain_at_peak: pk.strain,
        peak_dropped: pick.dropped,
        peak_drop: opts.peak_drop,
        max_stress_pa: mx.stress_pa,
        strain_at_max: mx.strain,
        kinetic_over_elastic_at_peak: require_finite(kinetic_ratio, "kinetic/elastic at the peak")?,
        modulus_pa: modulus,
        poisson,
        fit_points: if glued { fit.len() } else { 0 },
        static_modulus_pa: static_report.as_ref().map(|r| r.young),
        static_poisson: static_report.as_ref().and_then(|r| finite(r.poisson)),
        broken_fraction: cracks.total as f64 / bonds as f64,
        cracks,
        how: HOW.to_string(),
        curve,
        bond_states,
    })
}

impl StrengthTestReport {
    /// strength_test.json: the report as pretty JSON; refuses a non-finite number.
    pub fn to_json(&self) -> Result<String> {
        crate::io::finite_json(self, "strength_test.json")
    }

    /// strength_test.csv: the curve, units in the header.
    pub fn to_csv(&self) -> String {
        let mut csv = String::from(
            "step,time [s],strain,stress [Pa],lateral_strain,displacement [m],force [N],\
             kinetic_energy [J],elastic_energy [J],broken_bonds\n",
        );
        for c in &self.curve {
            csv += &format!(
                "{},{:e},{:e},{:e},{},{:e},{:e},{:e},{:e},{}\n",
                c.step,
                c.time_s,
                c.strain,
                c.stress_pa,
                c.lateral_strain
                    .map(|l| format!("{l:e}"))
                    .unwrap_or_default(),
                c.displacement_m,
                c.force_n,
                c.kinetic_j,
                c.elastic_j,
                c.broken
            );
        }
        csv
    }

    /// strength_test_bonds.vtu: every bond as a line between the particles' final
    /// positions, with `state` (1 intact, 0 broken), `break_time` (s; −1 while intact) and
    /// `mode` (0 intact, 1 tension, 2 shear, 3 bending, 4 twisting).
    pub fn write_bonds_vtu(&self, path: &std::path::Path) -> Result<()> {
        let s = &self.bond_states;
        let state: Vec<f64> = s
            .broken_at
            .iter()
            .map(|b| f64::from(u8::from(b.is_none())))
            .collect();
        let time: Vec<f64> = s.broken_at.iter().map(|b| b.unwrap_or(-1.0)).collect();
        let mode: Vec<f64> = s.mode.iter().map(|&m| f64::from(m)).collect();
        crate::export::vtk::write_bond_fields_vtu(
            path,
            &s.positions,
            &s.i,
            &s.j,
            &[("state", state), ("break_time", time), ("mode", mode)],
        )
    }

    #[cfg(feature = "plot")]
    /// strength_test.png: stress against strain, with the broken bonds (scaled to the peak
    /// stress) beside it.
    pub fn plot(&self, path: &std::path::Path) -> Result<()> {
        use crate::plot::{plot_series, Series};
        let mut series = vec![Series {
            label: "stress".into(),
            points: self.curve.iter().map(|c| (c.strain, c.stress_pa)).collect(),
            dashed: false,
            colour: Some(0),
        }];
        let scale = self.peak_stress_pa / self.bonds.max(1) as f64;
        series.push(Series {
            label: format!(
                "broken bonds × {scale:.3e} Pa (all {} bonds = the peak stress); {} broken",
                self.bonds, self.cracks.total
            ),
            points: self
                .curve
                .iter()
                .map(|c| (c.strain, c.broken as f64 * scale))
                .collect(),
            dashed: true,
            colour: Some(3),
        });
        plot_series(
            path,
            &series,
            &format!(
                "{} test, β = {}°: peak {:.4e} Pa",
                self.test, self.bedding_deg, self.peak_stress_pa
            ),
            "axial strain (1)",
            "stress (Pa)",
        )
    }

    #[cfg(feature = "plot")]
    /// Write strength_test.json, strength_test.csv, strength_test.png and
    /// strength_test_bonds.vtu into `dir`.
    pub fn write(&self, dir: &std::path::Path) -> Result<()> {
        crate::io::write_string_atomic(&dir.join("strength_test.json"), &self.to_json()?)?;
        crate::io::write_string_atomic(&dir.join("strength_test.csv"), &self.to_csv())?;
        self.write_bonds_vtu(&dir.join("strength_test_bonds.vtu"))?;
        self.plot(&dir.join("strength_test.png"))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bedding_rotation_turns_z_to_beta_from_the_axis() {
        let q = bedding_rotation(30.0);
        let a = q * Vec3::z();
        assert!((a.z - 30f64.to_radians().cos()).abs() < 1e-15);
        assert!((a.x - 30f64.to_radians().sin()).abs() < 1e-15);
        assert!((q.determinant() - 1.0).abs() < 1e-15);
    }

    #[test]
    fn first_peak_is_before_the_first_drop_not_the_global_maximum() {
        // Rises to 5, breaks bonds and falls 10 % (below 0.95 × 5), then re-hardens to 6.
        let curve = [
            (0.0, 0),
            (2.0, 0),
            (4.0, 0),
            (5.0, 3),
            (4.9, 5),
            (4.4, 9),
            (5.5, 12),
            (6.0, 15),
            (3.0, 40),
        ];
        let p = first_peak(&curve, 0.05).unwrap();
        assert_eq!(
            p,
            PeakPick {
                first: 3,
                max: 7,
                dropped: true
            }
        );
        // A 2 % dip (4.9 against 5) is not a drop at 5 %, but is at 1 %.
        assert!(!first_peak(&curve[..5], 0.05).unwrap().dropped);
        assert_eq!(first_peak(&curve[..5], 0.01).unwrap().first, 3);
        // A fall before any bond broke (dynamics, not failure) is not a drop.
        let elastic_dip = [(0.0, 0), (3.0, 0), (1.0, 0), (5.0, 1), (2.0, 8)];
        assert_eq!(first_peak(&elastic_dip, 0.05).unwrap().first, 3);
    }

    #[test]
    fn first_peak_of_a_curve_without_a_drop_is_its_maximum_flagged() {
        let curve = [(0.0, 0), (1.0, 0), (3.0, 2), (2.9, 4), (3.5, 6), (3.4, 7)];
        let p = first_peak(&curve, 0.05).unwrap();
        assert_eq!(
            p,
            PeakPick {
                first: 4,
                max: 4,
                dropped: false
            }
        );
        assert!(first_peak(&[], 0.05).is_none());
    }

    #[test]
    fn slope_of_a_line_is_exact() {
        let pts = [(0.0, 1.0), (1.0, 3.0), (2.0, 5.0)];
        assert!((slope(pts.iter().copied()).unwrap() - 2.0).abs() < 1e-15);
        assert!(slope([(1.0, 1.0)].iter().copied()).is_none());
    }
}
