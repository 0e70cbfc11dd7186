//! The pipeline in one place: a packing and a model make an [`Assembly`] — the bonds the
//! model's rule draws, the springs its scheme gives each bond — whose stiffness tensor every
//! client (the CLI, the C++ bridge, Python) asks for by [`Method`].
//!
//! The five-line path from a packing file to a relaxed tensor is in the crate docs.

use crate::bonds::{self, BondSet, BondStiffness};
use crate::dem::element::{self, DynamicTensor, ElementTestOptions};
use crate::dem::grips::{gripped_tensor, GrippedOptions, GrippedTensor};
use crate::dem::stress_tests::{
    stress_controlled_tensor, StressControlledResult, StressTestOptions,
};
use crate::dem::{build_law, DemOptions, LawKind, Simulation};
use crate::grains::Grains;
use crate::homogenize::laf::{laf_tensor, LafResult};
use crate::homogenize::local::{local_fields_with_term, LocalFields, LocalOptions};
use crate::homogenize::network::LeverArm;
use crate::homogenize::prestress::{prestressed_tensor, Prestress, PrestressedTensor};
use crate::homogenize::relaxed::{relaxed_tensor_with_term, RelaxedOptions, RelaxedResult};
use crate::homogenize::report::TensorReport;
use crate::homogenize::system::{relaxed_system, RelaxedSystem};
use crate::homogenize::{mean_field, voigt};
use crate::manybody::ManyBody;
use crate::model::Model;
use crate::packing::{self, Packing, PeriodicCell};
use crate::{Error, Result};
use std::path::Path;

/// A bonded packing: the spheres, the model, the bonds its rule draws and every bond's springs.
///
/// A generated periodic packing bonded by Truszkowska 2018's MRV model, its tensor by two
/// methods: the relaxed (static) solve lets the particles move off the affine field, so its
/// C11 never exceeds the Voigt (affine) bound of the same springs.
/// ```
/// # fn main() -> anisobond::Result<()> {
/// use anisobond::packing::{generate, GenerateOptions};
/// use anisobond::prelude::*;
/// let packing = generate(&GenerateOptions { n_particles: 300, ..Default::default() }, &|_| {})?;
/// let assembly = Assembly::new(packing, Model::truszkowska_mrv())?;
/// println!("{} bonds", assembly.bonds.len());
/// let voigt = assembly.tensor(&Method::Voigt)?.report.cubic.c11;
/// let relaxed = assembly.tensor(&Method::relaxed())?.report.cubic.c11;
/// assert!(0.0 < relaxed && relaxed <= voigt);
/// # Ok(())
/// # }
/// ```
#[derive(Clone, Debug)]
pub struct Assembly {
    /// The spheres and their cell.
    pub packing: Packing,
    /// The model the bonds and springs come from.
    pub model: Model,
    /// The bonds (i < j, branch vectors to the periodic image of j).
    pub bonds: BondSet,
    /// Each bond's springs kn, ks (N/m), kr, ktw (N·m/rad).
    pub springs: BondStiffness,
    /// Each bond's type in the user's file (a LAMMPS data file's Bonds section,
    /// [`Assembly::from_data_bonds`]), written to bond tables as `type`; `None` otherwise.
    pub bond_types: Option<Vec<u32>>,
    /// The grains of a polycrystal (the model's `[grains]`, docs/polycrystal.md), which the
    /// springs were assigned by; `None` for a single crystal.
    grains: Option<Grains>,
}

/// How to get the assembly's 6×6 stiffness tensor.
#[derive(Clone, Debug)]
pub enum Method {
    /// The orientation integral at the assembly's bond density (Truszkowska 2018 App. A).
    MeanField,
    /// The sum over the actual bonds under uniform strain.
    Voigt,
    /// Exact static equilibrium of the bond network under each unit strain.
    Relaxed(RelaxedOptions),
    /// The relaxed tangent of the assembly under an isotropic preload of its central springs
    /// (compressive `pressure`, Pa): what an element test started from that confined state
    /// measures ([`crate::homogenize::prestressed_tensor`]; symmetric part).
    Prestressed {
        /// Relaxed solver settings.
        options: RelaxedOptions,
        /// Mean compressive stress of the preload (Pa).
        pressure: f64,
    },
    /// Kruyt 2014's local adjustment field with shells of order `shell`.
    Laf {
        /// Shell order m (1–6).
        shell: usize,
        /// The energy-based estimate (an upper bound) instead of the stress-based one.
        energy: bool,
        /// Contact point of the bonds.
        lever_arm: LeverArm,
    },
    /// The reference integrator's six damped element tests (Truszkowska 2018 Eq. 27 fit).
    Dynamic {
        /// Bond law of the integrator.
        law: LawKind,
        /// Strain, damping, stop rule, time step and masses.
        options: ElementTestOptions,
    },
}

impl Method {
    /// The relaxed method with its default solver and tolerance.
    pub fn relaxed() -> Method {
        Method::Relaxed(RelaxedOptions::default())
    }

    /// Which method this is, without its options.
    pub fn kind(&self) -> MethodKind {
        match self {
            Method::MeanField => MethodKind::MeanField,
            Method::Voigt => MethodKind::Voigt,
            Method::Relaxed(_) => MethodKind::Relaxed,
            Method::Prestressed { .. } => MethodKind::Prestressed,
            Method::Laf { .. } => MethodKind::Laf,
            Method::Dynamic { .. } => MethodKind::Dynamic,
        }
    }

    /// The name used in reports and on the command line.
    pub fn name(&self) -> &'static str {
        self.kind().name()
    }
}

crate::names::named! {
    /// The tensor methods by name, without their options: the one list the CLI's `--method`
    /// and its help, Python's `method=` and the C++ bridge's `compute_tensor` accept.
    pub enum MethodKind ("method") {
        /// [`Method::MeanField`].
        MeanField = "mean-field", "Continuous orientation integral (needs no packing)";
        /// [`Method::Voigt`].
        Voigt = "voigt", "Sum over the actual bonds (uniform strain)";
        /// [`Method::Relaxed`].
        Relaxed = "relaxed",
            "Exact quasi-static equilibrium of the periodic bond network (sparse solve)";
        /// [`Method::Prestressed`].
        Prestressed = "prestressed",
            "Relaxed tangent under an isotropic preload of the central springs (--prestress \
             Pa): what an element test from that confined state measures (docs/prestress.md)";
        /// [`Method::Laf`].
        Laf = "laf", "Kruyt's local-adjustment-field estimate with shells of order --shell";
        /// [`Method::Dynamic`].
        Dynamic = "dynamic",
            "Element tests with the reference DEM integrator (needs a periodic packing)";
    }
}

/// The options of every method with their defaults: the one set of defaults the CLI's
/// `tensor`, Python's `Assembly.tensor` and the C++ bridge start from.
#[derive(Clone, Copy, Debug)]
pub struct MethodOptions {
    /// Relaxed and prestressed: solver, tolerance, lever arm (also the LAF's lever arm).
    pub relaxed: RelaxedOptions,
    /// Prestressed: mean compressive stress of the preload (Pa).
    pub prestress: f64,
    /// LAF: shell order m (1–6).
    pub shell: usize,
    /// LAF: the energy-based estimate (an upper bound) instead of the stress-based one.
    pub energy: bool,
    /// Dynamic: the integrator's bond law.
    pub law: LawKind,
    /// Dynamic: strain, damping, stop rule, time step and masses.
    pub element: ElementTestOptions,
}

impl Default for MethodOptions {
    fn default() -> Self {
        MethodOptions {
            relaxed: RelaxedOptions::default(),
            prestress: 0.0,
            shell: 2,
            energy: false,
            law: LawKind::default(),
            element: ElementTestOptions::default(),
        }
    }
}

impl MethodOptions {
    /// The method `kind` with these options.
    pub fn method(&self, kind: MethodKind) -> Method {
        match kind {
            MethodKind::MeanField => Method::MeanField,
            MethodKind::Voigt => Method::Voigt,
            MethodKind::Relaxed => Method::Relaxed(self.relaxed),
            MethodKind::Prestressed => Method::Prestressed {
                options: self.relaxed,
                pressure: self.prestress,
            },
            MethodKind::Laf => Method::Laf {
                shell: self.shell,
                energy: self.energy,
                lever_arm: self.relaxed.lever_arm,
            },
            MethodKind::Dynamic => Method::Dynamic {
                law: self.law,
                options: self.element,
            },
        }
    }
}

/// What a method computed beyond the tensor.
#[derive(Clone, Debug)]
pub enum Detail {
    /// Nothing more (mean field, Voigt).
    None,
    /// The relaxed solve: residual, iterations, null space.
    Relaxed(Box<RelaxedResult>),
    /// The pre-stressed tangent: energy and Cauchy forms, the preload stress, the solve.
    Prestressed(Box<PrestressedTensor>),
    /// Both LAF estimates and the shell size.
    Laf(Box<LafResult>),
    /// The six element-test paths, time step and stability.
    Dynamic(Box<DynamicTensor>),
}

/// A checked tensor (finite, positive definite) with its report and the method's details.
#[derive(Clone, Debug)]
pub struct TensorResult {
    /// The SPEC tensor report (Pa), with the relaxed residual where there is one.
    pub report: TensorReport,
    /// What the method computed besides.
    pub detail: Detail,
}

impl Assembly {
    /// Bond `packing` by the model's rule and assign every bond its springs. Refuses a
    /// packing the rule leaves without bonds ([`Error::Degenerate`]).
    pub fn new(packing: Packing, model: Model) -> Result<Assembly> {
        let bonds = bonds::rules::build_bonds(&packing, model.bonding)?;
        if bonds.is_empty() {
            return Err(Error::Degenerate(format!(
                "the bonding rule bonds no pair of the {} particles: increase the gap/factor value",
                packing.len()
            )));
        }
        Assembly::springs_of(packing, model, bonds)
    }

    /// The free assembly of the spheres of `packing` whose centres lie in `region`
    /// ([`packing::cut::cut`]: periodic images unwrapped), bonded by the model's rule as in
    /// [`Assembly::new`]; returns the cut too (where each sphere came from, boundary sets).
    /// A scheme that depends on the packing (cross-anisotropic: Šmilauer's lattice scaling
    /// μ, Eq. 20) takes it from the source `packing`, the material the bar is cut from — the
    /// cut's own volume would be its bounding box.
    pub fn cut(
        packing: &Packing,
        region: &packing::cut::Region,
        model: Model,
    ) -> Result<(Assembly, packing::cut::Cut)> {
        PeriodicCell::require_fully_periodic(packing.cell.as_ref(), "cutting a specimen")?;
        let cut = packing::cut::cut(packing, region)?;
        if !model.needs_packing() {
            let assembly = Assembly::new(cut.packing.clone(), model)?;
            return Ok((assembly, cut));
        }
        let source_bonds = bonds::rules::build_bonds(packing, model.bonding)?;
        let scheme = model.crystal_scheme_of(Some((packing, &source_bonds)))?;
        let bonds = bonds::rules::build_bonds(&cut.packing, model.bonding)?;
        if bonds.is_empty() {
            return Err(Error::Degenerate(format!(
                "the bonding rule bonds no pair of the {} particles of the cut",
                cut.packing.len()
            )));
        }
        let assembly = Assembly::springs_by(cut.packing.clone(), model, bonds, scheme.as_ref())?;
        Ok((assembly, cut))
    }

    /// An assembly of given bonds (a scene's own interactions, [`BondSet::from_pairs`])
    /// instead of the model's bonding rule; the springs are assigned as in [`Assembly::new`].
    pub fn with_bonds(packing: Packing, model: Model, bonds: BondSet) -> Result<Assembly> {
        if bonds.is_empty() {
            return Err(Error::Invalid(format!(
                "no bonds given for the {} particles",
                packing.len()
            )));
        }
        Assembly::springs_of(packing, model, bonds)
    }

    /// Every bond's springs by the model's scheme and geometry.
    fn springs_of(packing: Packing, model: Model, bonds: BondSet) -> Result<Assembly> {
        let scheme = model.crystal_scheme_of(Some((&packing, &bonds)))?;
        Assembly::springs_by(packing, model, bonds, scheme.as_ref())
    }

    /// Every bond's springs by `scheme` (the model's crystal) and the model's geometry: for a
    /// model with `[grains]` the grains are built on `packing` and each bond gets its grain's
    /// springs ([`bonds::assign_stiffness_by_grain`], docs/polycrystal.md).
    fn springs_by(
        packing: Packing,
        model: Model,
        bonds: BondSet,
        scheme: &dyn crate::schemes::StiffnessScheme,
    ) -> Result<Assembly> {
        let (springs, grains) = match &model.grains {
            None => (
                bonds::assign_stiffness(&packing, &bonds, scheme, &model.geometry)?,
                None,
            ),
            Some(spec) => {
                let grains = spec.build(&packing)?;
                let springs = bonds::assign_stiffness_by_grain(
                    &packing,
                    &bonds,
                    scheme,
                    &model.geometry,
                    &grains,
                    spec.boundary,
                    spec.boundary_factor,
                )?;
                (springs, Some(grains))
            }
        };
        let mut assembly = Assembly::of_parts(packing, model, bonds, springs);
        assembly.grains = grains;
        Ok(assembly)
    }

    /// The assembly of these parts as they are, without bond types (those come only from a
    /// data file's `Bonds` section, [`Assembly::from_data_bonds`]) or grains.
    pub(crate) fn of_parts(
        packing: Packing,
        model: Model,
        bonds: BondSet,
        springs: BondStiffness,
    ) -> Assembly {
        Assembly {
            packing,
            model,
            bonds,
            springs,
            bond_types: None,
            grains: None,
        }
    }

    /// The grains the springs were assigned by (a model with `[grains]`,
    /// docs/polycrystal.md), or `None`: a single crystal, or bonds and springs taken from a
    /// bond table ([`Assembly::from_table_file`]).
    pub fn grains(&self) -> Option<&Grains> {
        self.grains.as_ref()
    }

    /// An assembly of a data file's own bond network ([`packing::io::DataBonds`], the
    /// `Bonds` section read with `packing`) instead of the model's bonding rule, the bonds'
    /// types kept; springs as in [`Assembly::new`]. Each bond joins the nearest periodic
    /// images of its atoms, as LAMMPS takes them. Refuses, naming the file (`source`) and the
    /// line, a bond whose atoms are at the same place.
    pub fn from_data_bonds(
        packing: Packing,
        model: Model,
        bonds: &packing::io::DataBonds,
        source: &str,
    ) -> Result<Assembly> {
        let set =
            BondSet::from_pairs_at(&packing, &bonds.i, &bonds.j, None).map_err(|refused| {
                match refused {
                    // The refused pair's line of the Bonds section.
                    (Some(b), Error::Invalid(m)) => {
                        Error::parse(source, bonds.lines.get(b).copied().unwrap_or(0), m)
                    }
                    (_, e) => e,
                }
            })?;
        let mut asm = Assembly::with_bonds(packing, model, set)?;
        asm.bond_types = Some(bonds.types.clone());
        Ok(asm)
    }

    /// An assembly whose bonds and springs are a bond table's (docs/formats.md; e.g. a YADE
    /// scene's own bond network written by `anisobond_yade.bond_table`), not the model's
    /// rule and scheme; the model still serves the mean field. Refuses, naming the table and
    /// line, a particle index the packing does not have and a row whose normal, length or
    /// image is not the packing's ([`bonds::table::check_against_packing`]).
    pub fn from_table_file(packing: Packing, model: Model, table_path: &Path) -> Result<Assembly> {
        let (bonds, springs) = bonds::table::read_bond_table_of(table_path, &packing)?;
        Ok(Assembly::of_parts(packing, model, bonds, springs))
    }

    /// Read the packing file (every format [`packing::io::read_packing`] knows) and bond it
    /// by `model` — or, for a data file with a `Bonds` section, take those bonds
    /// ([`Assembly::from_data_bonds`]); a refusal that comes from the model names
    /// `model_path`, one of a packing without bonds names both files.
    pub fn from_packing_file(packing_path: &Path, model: Model, model_path: &Path) -> Result<Self> {
        let read = packing::io::read_packing_as(packing_path, Default::default())?;
        match &read.bonds {
            Some(b) => Assembly::from_data_bonds(
                read.packing,
                model,
                b,
                &packing_path.display().to_string(),
            ),
            None => Assembly::from_packing_read(read.packing, packing_path, model, model_path),
        }
    }

    /// Bond a packing already read from `packing_path` (e.g. by
    /// [`packing::io::read_packing_as`]) by `model`, naming the files in refusals as
    /// [`Assembly::from_packing_file`] does.
    pub fn from_packing_read(
        packing: packing::Packing,
        packing_path: &Path,
        model: Model,
        model_path: &Path,
    ) -> Result<Self> {
        Assembly::new(packing, model).map_err(|e| match e {
            Error::Model(m) => Error::Model(format!("{}: {m}", model_path.display())),
            Error::Degenerate(m) => Error::Degenerate(format!(
                "{}: {m} (bonding rule of {})",
                packing_path.display(),
                model_path.display()
            )),
            other => other,
        })
    }

    /// Read both files, then [`Assembly::from_packing_file`].
    pub fn from_files(packing_path: &Path, model_path: &Path) -> Result<Self> {
        let model = Model::from_path(model_path)?;
        Assembly::from_packing_file(packing_path, model, model_path)
    }

    /// Mean bonds per particle Z = 2N_b/N.
    pub fn coordination(&self) -> f64 {
        self.bonds.coordination(self.packing.len())
    }

    /// The mean-field prefactor N_c⟨l²·g⟩/V of these bonds (g: the geometry factor), V the
    /// [`Assembly::affine_volume`].
    pub fn mean_field_prefactor(&self) -> f64 {
        // packing_prefactor divides by the packing's volume; rescaled to the affine volume
        // (the same for every packing but a box of mixed periodicity).
        mean_field::packing_prefactor(&self.packing, &self.bonds, &self.model.geometry)
            * (self.packing.volume() / self.affine_volume())
    }

    /// The volume V (m³) of the affine estimates (Voigt, mean field: σ = (1/V) Σ f ⊗ l,
    /// Truszkowska 2018 Eq. 11): the cell's for a periodic packing, the spheres' bounding box
    /// for a free cluster, and for a box of mixed periodicity the cell's edges along its
    /// periodic axes times the spheres' extent (surfaces included) along the free ones. A
    /// free axis's box is a container of any height (a bed's box may be twice the bed): the
    /// material is where the spheres are, as for a free cluster.
    pub fn affine_volume(&self) -> f64 {
        match &self.packing.cell {
            Some(c) if c.is_mixed() => {
                let (lo, hi) = self.packing.bounding_box();
                (0..3)
                    .map(|k| match c.periodic[k] {
                        true => c.lengths[k],
                        false => hi[k] - lo[k],
                    })
                    .product()
            }
            _ => self.packing.volume(),
        }
    }

    /// The stiffness tensor by `method`, checked (finite, positive definite: see
    /// `crate::homogenize::report::check_result_tensor`).
    pub fn tensor(&self, method: &Method) -> Result<TensorResult> {
        self.tensor_with_progress(method, &|_| {})
    }

    /// [`Assembly::tensor`] with the fraction done (0–1) reported to `progress` by the
    /// methods that take long (dynamic).
    pub fn tensor_with_progress(
        &self,
        method: &Method,
        progress: &(dyn Fn(f64) + Sync),
    ) -> Result<TensorResult> {
        refuse_mixed_equilibrium(self.packing.cell.as_ref(), method)?;
        let (p, b, k) = (&self.packing, &self.bonds, &self.springs);
        let term = self.manybody()?;
        if term.is_some() {
            refuse_without_term(method)?;
        }
        // The term's exact Voigt-level share (Σ V_p/V)·D, added to the affine estimates.
        let affine_term = term
            .as_ref()
            .map_or_else(crate::tensor::Stiffness6::zeros, |t| t.closed_form_tensor());
        let (c, detail) = match method {
            Method::MeanField => {
                if self.grains.is_some() {
                    return Err(Error::Invalid(
                        "tensor method mean-field: the model has [grains], and the mean field \
                         integrates one orientation's scheme over the bond directions; a \
                         polycrystal's springs differ by grain: use voigt (the sum over its \
                         bonds), relaxed or laf (docs/polycrystal.md)"
                            .into(),
                    ));
                }
                let scheme = self.model.build_scheme(Some((p, b)))?;
                let pre = self.mean_field_prefactor();
                let c = mean_field::mean_field_converged(scheme.as_ref(), pre)?;
                (c + affine_term, Detail::None)
            }
            Method::Voigt => (
                voigt::voigt_tensor(b, k, self.affine_volume()) + affine_term,
                Detail::None,
            ),
            Method::Relaxed(opts) => {
                let r = relaxed_tensor_with_term(p, b, k, term.as_ref(), opts)?;
                check_relaxed_scale(&r.c, p, b, k, "relaxed")?;
                (r.c, Detail::Relaxed(Box::new(r)))
            }
            Method::Prestressed { options, pressure } => {
                let pre = Prestress::isotropic(p, b, k, *pressure, options)?;
                let t = prestressed_tensor(p, b, k, &pre, options)?;
                check_relaxed_scale(&t.relaxed.c, p, b, k, "prestressed")?;
                (
                    (t.c + t.c.transpose()) * 0.5,
                    Detail::Prestressed(Box::new(t)),
                )
            }
            Method::Laf {
                shell,
                energy,
                lever_arm,
            } => {
                let r = laf_tensor(p, b, k, *lever_arm, *shell)?;
                let c = if *energy { r.c_energy } else { r.c_stress };
                (c, Detail::Laf(Box::new(r)))
            }
            Method::Dynamic { law, options } => {
                let d = self.element_tests(*law, options, progress)?;
                (d.c, Detail::Dynamic(Box::new(d)))
            }
        };
        let mut report = TensorReport::new(method.name(), c, Some((p, b)))?;
        // The volume the stresses are per (the box's but along a mixed box's free axes).
        report.volume = Some(self.affine_volume());
        report.manybody_volume_fraction = term.as_ref().map(|t| t.volume_fraction());
        match &detail {
            Detail::Relaxed(r) => report.relative_residual = Some(r.relative_residual),
            Detail::Prestressed(t) => report.relative_residual = Some(t.relaxed.relative_residual),
            Detail::Laf(r) if !matches!(method, Method::Laf { energy: true, .. }) => {
                report.asymmetry = Some(r.stress_asymmetry)
            }
            _ => {}
        }
        Ok(TensorResult { report, detail })
    }

    /// The relaxed solve's linear system (K, G, H, V: [`crate::homogenize::RelaxedSystem`]) of this
    /// assembly with `opts`' lever arm and rotations, the many-body term included: for
    /// solving C = (H − Gᵀ K⁺ G)/V with another code. Refuses a box that is not fully
    /// periodic, as the relaxed tensor does.
    pub fn relaxed_system(&self, opts: &RelaxedOptions) -> Result<RelaxedSystem> {
        PeriodicCell::require_fully_periodic(self.packing.cell.as_ref(), "relaxed system")?;
        let term = self.manybody()?;
        relaxed_system(
            &self.packing,
            &self.bonds,
            &self.springs,
            term.as_ref(),
            opts,
        )
    }

    /// The many-body term of the model's `[manybody]` on these bonds (docs/manybody.md), or
    /// `None` for a model without one; a polycrystal's particles load their grain's D
    /// ([`crate::manybody::ManyBodySpec::build_with_grains`]).
    pub fn manybody(&self) -> Result<Option<ManyBody>> {
        self.model
            .manybody
            .as_ref()
            .map(|spec| spec.build_with_grains(&self.packing, &self.bonds, self.grains.as_ref()))
            .transpose()
    }

    /// The reference integrator on this assembly with bond law `law` and settings `dem`.
    pub fn simulation(&self, law: LawKind, dem: &DemOptions) -> Result<Simulation> {
        PeriodicCell::require_fully_periodic(self.packing.cell.as_ref(), "the integrator")?;
        let law = build_law(law, &self.packing, &self.bonds, &self.springs)?;
        // The model's [manybody] term, built on the same bonds (docs/manybody.md "Integrator").
        let term = self.manybody()?;
        Simulation::with_manybody(&self.packing, &self.bonds, law, term, dem)
    }

    /// Refuse ([`Error::Model`]) a model with `[manybody]` in `what`, an integrator run on a
    /// free specimen that does not apply the term: its default volume shares need a periodic
    /// cell, and a free specimen's per-particle volumes are not given yet (docs/manybody.md
    /// "Integrator"). Without the table: Ok.
    pub fn refuse_manybody(&self, what: &str) -> Result<()> {
        if self.model.manybody.is_some() {
            return Err(Error::Model(format!(
                "the model has a [manybody] term, which {what} does not apply yet (a free \
                 specimen needs per-particle volumes for it); the periodic element and stress \
                 tests (`run`, `stress-test`) apply it; or remove [manybody] from the model"
            )));
        }
        Ok(())
    }

    /// The six strain-controlled element tests of the reference integrator (Truszkowska 2018
    /// Eqs. 17–22, fitted by Eq. 27), with histories if `options.history_every` > 0.
    pub fn element_tests(
        &self,
        law: LawKind,
        options: &ElementTestOptions,
        progress: &(dyn Fn(f64) + Sync),
    ) -> Result<DynamicTensor> {
        element::dynamic_tensor(&self.simulation(law, &options.dem)?, options, progress)
    }

    /// Šmilauer's stress-controlled element tests (uniaxial strain with the other stresses
    /// servo-held at zero, three pure shears) with the integrator's `dem` settings.
    pub fn stress_tests(
        &self,
        law: LawKind,
        dem: &DemOptions,
        options: &StressTestOptions,
        progress: &(dyn Fn(f64) + Sync),
    ) -> Result<StressControlledResult> {
        stress_controlled_tensor(&self.simulation(law, dem)?, options, progress)
    }

    /// Truszkowska 2018's element tests on the free block cut from the periodic packing,
    /// driven through grip particles (Sec. 4.1–4.4, Eqs. 17–22 and 27).
    pub fn gripped_tests(
        &self,
        law: LawKind,
        options: &GrippedOptions,
        progress: &(dyn Fn(f64) + Sync),
    ) -> Result<GrippedTensor> {
        PeriodicCell::require_fully_periodic(self.packing.cell.as_ref(), "the gripped tests")?;
        self.refuse_manybody("the gripped tests (a free block)")?;
        gripped_tensor(
            &self.packing,
            &self.bonds,
            &self.springs,
            law,
            options,
            progress,
        )
    }

    /// ParaView files `particles.vtu` and `bonds.vtu` in `dir` (a polycrystal's grain ids as
    /// the point field `grain` and the cell fields `grain_i`, `grain_j`): the assembly unloaded, or
    /// under a small macroscopic `strain` (Voigt, engineering, every |ε| ≤ 0.1; periodic
    /// packings only) its quasi-static state from the relaxed solve. Returns that state.
    pub fn write_vtk(
        &self,
        dir: &Path,
        strain: Option<&crate::tensor::Voigt6>,
    ) -> Result<Option<crate::export::vtk::StrainedState>> {
        use crate::export::vtk::{
            strained_state, write_bonds_vtu_grains, write_particles_vtu_grains,
        };
        if let Some(e) = strain {
            PeriodicCell::require_fully_periodic(self.packing.cell.as_ref(), "a strained state")?;
            if let Some(x) = e.iter().find(|x| x.abs() > 0.1 || x.is_nan()) {
                return Err(Error::Invalid(format!(
                    "strain component {x} is not a small strain: the state is linear \
                     (small-strain), expected |ε| ≤ 0.1"
                )));
            }
            if self.packing.cell.is_none() {
                return Err(Error::Invalid(
                    "a strained state needs a periodic packing (the strain deforms the cell)"
                        .into(),
                ));
            }
        }
        let (p, b, k) = (&self.packing, &self.bonds, &self.springs);
        let state = match strain {
            Some(e) if e.iter().any(|&x| x != 0.0) => {
                Some(strained_state(p, b, k, e, &RelaxedOptions::default())?)
            }
            _ => None,
        };
        let grains = self.grains.as_ref().map(|g| g.grain.as_slice());
        write_particles_vtu_grains(&dir.join("particles.vtu"), p, state.as_ref(), grains)?;
        write_bonds_vtu_grains(&dir.join("bonds.vtu"), p, b, k, state.as_ref(), grains)?;
        Ok(state)
    }

    /// Write the bond-stiffness table (CSV, SPEC columns, then `id_i,id_j` when the packing
    /// has particle ids, `type` when the bonds came from a data file and `grain_i,grain_j`
    /// for a polycrystal) atomically.
    pub fn write_bonds(&self, path: &Path) -> Result<()> {
        bonds::table::write_bond_table_with_grains(
            path,
            &self.bonds_as_given(),
            &self.springs,
            self.packing.ids.as_deref(),
            self.bond_types.as_deref(),
            self.grains.as_ref().map(|g| g.grain.as_slice()),
        )
    }

    /// The bonds with their periodic images among the positions as given
    /// ([`Packing::given_positions`]), as bond tables carry them.
    pub fn bonds_as_given(&self) -> BondSet {
        let mut b = self.bonds.clone();
        if self.packing.given_positions.is_some() {
            for k in 0..b.len() {
                let (i, j) = (b.i[k] as usize, b.j[k] as usize);
                b.image[k] = self.packing.image_to_given(i, j, b.image[k]);
            }
        }
        b
    }
}

impl Assembly {
    /// The local fields of the relaxed solution under the macroscopic engineering strain
    /// `strain` (Voigt, every |e| ≤ 0.1): per particle the fluctuation, rotation, Love–Weber
    /// stress and fitted strain, per bond the force and moment
    /// ([`crate::homogenize::local_fields`]; docs/references.md "Local fields"). Refuses as
    /// [`Method::Relaxed`] does (a box of mixed periodicity, a network carrying no load
    /// across the cell). With the model's many-body term, the fluctuation and each
    /// particle's stress include it ([`crate::homogenize::local_fields_with_term`]).
    pub fn local_fields(
        &self,
        strain: &crate::tensor::Voigt6,
        options: &LocalOptions,
    ) -> Result<LocalFields> {
        refuse_mixed_equilibrium(
            self.packing.cell.as_ref(),
            &Method::Relaxed(options.relaxed),
        )?;
        // The model's [manybody] term, each particle its grain's D: its share of each
        // particle's stress joins the springs' (homogenize::local_fields_with_term).
        let term = self.manybody()?;
        let (p, b, k) = (&self.packing, &self.bonds, &self.springs);
        let fields = local_fields_with_term(p, b, k, term.as_ref(), strain, options)?;
        check_relaxed_scale(&fields.relaxed.c, p, b, k, "relaxed")?;
        Ok(fields)
    }
}

/// The smallest ratio max|C_relaxed| / max|C_Voigt| taken as a result. The relaxed tensor
/// lies below the Voigt (affine) one of the same bonds; orders of magnitude below it, the
/// network carries no load across the cell (`check_relaxed_scale`).
pub const RELAXED_TO_VOIGT_MIN: f64 = 1e-6;

/// Refuse ([`Error::Degenerate`]) a relaxed tensor `c` whose largest entry is below
/// [`RELAXED_TO_VOIGT_MIN`] times the Voigt tensor's of the same bonds: a periodic packing
/// whose bonds do not cross the cell faces (a finite specimen, e.g. a walled LIGGGHTS box,
/// read as periodic) relaxes almost freely, and its tiny "tensor" is no stiffness.
fn check_relaxed_scale(
    c: &crate::tensor::Stiffness6,
    p: &Packing,
    b: &BondSet,
    k: &BondStiffness,
    method: &str,
) -> Result<()> {
    let affine = voigt::voigt_tensor(b, k, p.volume()).amax();
    let relaxed = c.amax();
    if affine > 0.0 && affine.is_finite() && relaxed < RELAXED_TO_VOIGT_MIN * affine {
        let Some(_) = &p.cell else {
            return Err(Error::Degenerate(format!(
                "the {method} tensor (largest entry {relaxed:.3e} Pa) is below \
                 {RELAXED_TO_VOIGT_MIN:e} of the Voigt tensor of the same bonds ({affine:.3e} \
                 Pa): the bond network carries no load"
            )));
        };
        let crossing = b.image.iter().filter(|m| **m != [0, 0, 0]).count();
        return Err(Error::Degenerate(format!(
            "the {method} tensor (largest entry {relaxed:.3e} Pa) is below {RELAXED_TO_VOIGT_MIN:e} \
             of the Voigt tensor of the same bonds ({affine:.3e} Pa): the network carries no \
             load across the periodic cell ({crossing} of {} bonds cross its faces); a finite \
             specimen (e.g. a walled LIGGGHTS box) read as periodic? Give --free (Python: \
             free=True) or the specimen's own periodic packing",
            b.len()
        )));
    }
    Ok(())
}

/// A bond density given by numbers instead of a packing: equal spheres of radius R at solid
/// fraction φ with Z bonds each, bond length 2R (the mean field's assembly without a packing).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EqualSpheres {
    /// Mean bonds per particle Z.
    pub coordination: f64,
    /// Solid fraction φ, in [0.01, 1).
    pub solid_fraction: f64,
    /// Sphere radius R (m).
    pub radius: f64,
}

impl EqualSpheres {
    /// The mean-field prefactor N_c⟨l²⟩/V·g = 3Zφ/(2πR)·g(R, R, 2R) (Truszkowska 2018
    /// App. A), refused when an input is out of range or the product leaves double precision.
    pub fn prefactor(&self, geometry: &crate::schemes::Geometry) -> Result<f64> {
        let (z, phi, r) = (self.coordination, self.solid_fraction, self.radius);
        let positive = z > 0.0 && r > 0.0 && z.is_finite() && r.is_finite();
        if !positive || !(0.01..1.0).contains(&phi) {
            return Err(Error::Invalid(format!(
                "equal spheres: expected coordination Z > 0, solid fraction φ in [0.01, 1) and \
                 radius R > 0 m, got Z = {z}, φ = {phi}, R = {r} m"
            )));
        }
        let g = geometry.factor(r, r, 2.0 * r);
        let pre = mean_field::equal_sphere_prefactor(z, phi, r) * g;
        if !(pre.is_finite() && pre > 0.0) {
            return Err(Error::Invalid(format!(
                "equal spheres: Z = {z:e}, φ = {phi}, R = {r:e} m give a bond-density prefactor \
                 of {pre:e}, out of the range of double precision (radius in metres, e.g. 1e-3)"
            )));
        }
        Ok(pre)
    }

    /// The mean-field tensor of `model` at this bond density, checked. The cross-anisotropic
    /// scheme takes its lattice scaling μ from actual bonds, so it needs an [`Assembly`].
    pub fn mean_field(&self, model: &Model) -> Result<TensorReport> {
        if model.needs_packing() {
            return Err(Error::Invalid(
                "the cross-anisotropic scheme needs a packing (its lattice scaling μ comes from \
                 the bonds)"
                    .into(),
            ));
        }
        let pre = self.prefactor(&model.geometry)?;
        let scheme = model.build_scheme(None)?;
        let mut c = mean_field::mean_field_converged(scheme.as_ref(), pre)?;
        // Every equal sphere fits its strain (Z isotropic bonds, none degenerate), so a uniform
        // strain gives F_p = F everywhere and the term adds D itself (docs/manybody.md).
        let fraction = match &model.manybody {
            Some(spec) => {
                c += spec.voigt()?;
                Some(1.0)
            }
            None => None,
        };
        let mut report = TensorReport::new("mean-field", c, None)?;
        report.coordination = Some(self.coordination);
        report.manybody_volume_fraction = fraction;
        Ok(report)
    }
}

/// Refuse ([`Error::Invalid`]) a method that does not include a model's many-body term
/// (docs/manybody.md): the prestressed tangent (its preload state is the springs' alone), the
/// LAF (its shells hold first neighbours; the term couples second ones) and the integrator's
/// element tests (the reference integrator does not evaluate the term yet). Mean field and
/// Voigt add the term's exact closed form, the relaxed solve its Hessian.
fn refuse_without_term(method: &Method) -> Result<()> {
    let why = match method {
        // The integrator evaluates the term (Assembly::simulation builds it; src/dem/manybody.rs).
        Method::MeanField | Method::Voigt | Method::Relaxed(_) | Method::Dynamic { .. } => {
            return Ok(())
        }
        Method::Prestressed { .. } => "its preloaded state is that of the springs alone",
        Method::Laf { .. } => {
            "its shells relax first neighbours, and the term couples particles that share a \
             bonded neighbour"
        }
    };
    Err(Error::Invalid(format!(
        "tensor method {}: the model has a many-body term ([manybody]) and {why}; use \
         --method relaxed (exact), dynamic, or voigt / mean-field (its closed form added)",
        method.name()
    )))
}

/// Refuse ([`Error::Invalid`]) `method` on a box of mixed periodicity unless it is an
/// affine estimate (Voigt, mean field: [`Assembly::affine_volume`]): the relaxed,
/// prestressed, LAF and dynamic tensors are equilibria of a fully periodic cell, which a box
/// with free faces has not; its response is that of a specimen (`anisobond specimen`).
fn refuse_mixed_equilibrium(cell: Option<&PeriodicCell>, method: &Method) -> Result<()> {
    match cell {
        Some(c) if c.is_mixed() && !matches!(method, Method::Voigt | Method::MeanField) => {
            Err(Error::Invalid(format!(
                "tensor method {}: the packing's box is periodic along some axes only \
                 (boundary {}): the {} tensor is the equilibrium of a fully periodic cell, and \
                 a box with free faces has none; use `anisobond specimen` for the response of \
                 this slab under its load test, or the affine estimates voigt and mean-field",
                method.name(),
                c.boundary(),
                method.name()
            )))
        }
        _ => Ok(()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Vec3;

    /// A simple-cubic slab of 4 × 4 × 3 spheres (spacing 1 m, radius 0.475 m) in a box of
    /// 4 × 4 × 6 m periodic along x and y only (`p p f`, the box twice the slab's height).
    fn slab() -> Assembly {
        let mut positions = Vec::new();
        for (i, j, k) in
            (0..4).flat_map(|i| (0..4).flat_map(move |j| (0..3).map(move |k| (i, j, k))))
        {
            positions.push(Vec3::new(i as f64 + 0.5, j as f64 + 0.5, k as f64 + 0.5));
        }
        let n = positions.len();
        let cell = PeriodicCell::with_periodic(Vec3::new(4.0, 4.0, 6.0), [true, true, false]);
        let packing = Packing::new(positions, vec![0.475; n], Some(cell.unwrap())).unwrap();
        let model = Model::from_toml_str(
            "[bonding]\nrule = \"gap\"\nvalue = 0.17\n[scheme]\nkind = \"cubic\"\n\
             model = \"zener-above-1\"\na_n = 4.31\na_s = 10.0\nnormal = 1.0e13\nshear = 3.55e12\n",
            "<test>",
        )
        .unwrap();
        Assembly::new(packing, model).unwrap()
    }

    /// On a `p p f` box the Voigt tensor divides by the slab's volume (4 × 4 × the spheres'
    /// extent 2.95 m), not the box's: C11 = Σ over the 48 x bonds of k_n l² / V by hand;
    /// the equilibrium tensors are refused by the error's kind, naming the method.
    #[test]
    fn a_mixed_box_gives_the_affine_tensors_per_the_slab_and_refuses_the_equilibria() {
        let a = slab();
        assert_eq!(a.bonds.len(), 48 + 48 + 32);
        let v = 4.0 * 4.0 * (2.5 + 0.475 - (0.5 - 0.475));
        assert!((a.affine_volume() - v).abs() < 1e-12 * v);
        let sum: f64 = (0..a.bonds.len())
            .filter(|&b| a.bonds.normal[b].x.abs() > 0.5)
            .map(|b| a.springs.kn[b] * a.bonds.length[b].powi(2))
            .sum();
        let r = a.tensor(&Method::Voigt).unwrap();
        let c11 = r.report.c[0][0];
        assert!((c11 - sum / v).abs() < 1e-12 * c11, "{c11} vs {}", sum / v);
        assert_eq!(r.report.volume, Some(a.affine_volume()));
        a.tensor(&Method::MeanField).unwrap();
        for m in [
            Method::relaxed(),
            Method::Laf {
                shell: 1,
                energy: false,
                lever_arm: LeverArm::default(),
            },
        ] {
            match a.tensor(&m) {
                Err(Error::Invalid(e)) => assert!(e.contains(m.name()), "{e}"),
                other => panic!("{}: expected Error::Invalid, got {other:?}", m.name()),
            }
        }
    }
}
