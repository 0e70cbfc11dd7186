//! Failure criteria, one per bond law, as pure functions of a bond's local loads.
//!
//! Each law first turns a bond's [`Strength`] (Pa) into its own limits with the law's own
//! cross-section convention (`…::of`), once per bond; the criterion then judges the loads of
//! a step without allocation, so an integrator can call it per bond in its structure-of-
//! arrays loop. Every criterion returns a [`Failure`]: whether the bond broke, in which
//! [`Mode`], and a failure index (1 at the limit).
//!
//! Sources (read, not copied):
//! - YADE 2023.02a `Law2_ScGeom6D_CohFrictPhys_CohesionMoment::go`
//!   (pkg/dem/CohesiveFrictionalContactLaw.cpp) and the documentation of
//!   `Ip2_CohFrictMat_CohFrictMat_CohFrictPhys` (a_i = C_i·min(R_1, R_2)²), checked against
//!   the installed YADE's attribute docs; the moment adhesions of later YADE
//!   (`rollingAdhesion = ¼·C_n·r³`, `twistingAdhesion = ½·C_s·r³` in `Ip2_…::setCohesion`).
//! - LAMMPS src/BPM/bond_bpm_rotational.cpp, `BondBPMRotational::elastic_forces` and
//!   `compute` (the breaking sum and its `>= 1.0` test), doc/src/bond_bpm_rotational.rst.
//! - Potyondy & Cundall (2004), Int. J. Rock Mech. Min. Sci. 41, 1329–1364: the parallel
//!   bond's maximum tensile and shear stresses on its periphery (as the brief of issue 32
//!   states them; the paper is not in /work/shared/papers, so its equation numbers are not
//!   cited here).
//! - Park & Min (2015), IJRMMS 76, 243–255 (the smooth joint): Mohr–Coulomb with a tension
//!   cut-off on the joint plane.

use super::Strength;
use crate::Vec3;

/// A bond's loads in its own frame, as a bond law reports them.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct LocalLoads {
    /// Normal force F_n (N), compression positive (YADE's convention): tension is F_n < 0.
    pub normal: f64,
    /// Magnitude of the shear force |F_s| (N).
    pub shear: f64,
    /// Magnitude of the bending moment |M_b| (N·m).
    pub bending: f64,
    /// Magnitude of the twisting moment |M_t| (N·m).
    pub twisting: f64,
}

impl LocalLoads {
    /// The loads from a bond law's vectors: normal force (N, compression positive), shear
    /// force, bending and twisting moments (their magnitudes are taken).
    pub fn from_vectors(normal: f64, shear: &Vec3, bending: &Vec3, twisting: &Vec3) -> Self {
        LocalLoads {
            normal,
            shear: shear.norm(),
            bending: bending.norm(),
            twisting: twisting.norm(),
        }
    }
}

/// How a bond fails (or, while intact, which term is nearest its limit).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Mode {
    /// The normal force (tension).
    Tension,
    /// The shear force.
    Shear,
    /// The bending moment.
    Bending,
    /// The twisting moment.
    Twisting,
}

impl Mode {
    /// Lower-case name for reports (`tension`, `shear`, `bending`, `twisting`).
    pub fn name(self) -> &'static str {
        match self {
            Mode::Tension => "tension",
            Mode::Shear => "shear",
            Mode::Bending => "bending",
            Mode::Twisting => "twisting",
        }
    }
}

/// The verdict of a criterion on one bond.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Failure {
    /// The bond breaks at these loads.
    pub broken: bool,
    /// The mode it breaks in; while intact, the mode of the largest term of `index`.
    pub mode: Mode,
    /// Failure index ≥ 0: the law's measure of load over strength, 1 at the limit (its exact
    /// form per criterion). Whether exactly 1 breaks is the law's own rule (`broken`).
    pub index: f64,
}

/// load/limit, with a zero limit giving +∞ for a positive load and 0 otherwise; never
/// below 0 (a compressive normal load is no tensile load).
#[inline(always)]
fn ratio(load: f64, limit: f64) -> f64 {
    if limit > 0.0 {
        (load / limit).max(0.0)
    } else if load > 0.0 {
        f64::INFINITY
    } else {
        0.0
    }
}

/// The mode of the largest of the terms (the first on ties) and that term.
#[inline(always)]
fn largest(terms: [(Mode, f64); 4]) -> (Mode, f64) {
    let mut best = terms[0];
    for t in &terms[1..] {
        if t.1 > best.1 {
            best = *t;
        }
    }
    best
}

// ---------------------------------------------------------------------------------------
// YADE CohFrict
// ---------------------------------------------------------------------------------------

/// Moment limits of YADE's cohesive law.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum YadeMoments {
    /// YADE 2023.02a: moments never break a bond (its `maxRollPl`/`maxTwistPl` are rolling
    /// friction, a plastic cap, not cohesion). Moments are not judged.
    Elastic,
    /// Later YADE's moment adhesions (N·m): the bond breaks when |M_b| > `rolling` or
    /// |M_t| > `twisting` (a zero adhesion disables that check, as YADE's `> 0` guard).
    Adhesion {
        /// `rollingAdhesion` (N·m).
        rolling: f64,
        /// `twistingAdhesion` (N·m).
        twisting: f64,
    },
}

/// One bond's limits in YADE's `CohFrictPhys`, with `fragile = True` (cohesion breaks).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct YadeAdhesion {
    /// `normalAdhesion` a_n (N).
    pub normal: f64,
    /// `shearAdhesion` a_s (N).
    pub shear: f64,
    /// `tangensOfFrictionAngle` tan φ.
    pub tan_friction: f64,
    /// `cohesionDisablesFriction`: while cohesive, the shear limit is a_s alone.
    pub cohesion_disables_friction: bool,
    /// Moment limits.
    pub moments: YadeMoments,
}

impl YadeAdhesion {
    /// YADE's adhesions from stresses, as `Ip2_CohFrictMat_CohFrictMat_CohFrictPhys` forms
    /// them with r = min(R_1, R_2): a_n = σ_t·r², a_s = c·r² (YADE's convention: r², no π),
    /// tan φ = μ; with `moments`, the later YADE's rollingAdhesion = ¼·σ_b·r³ and
    /// twistingAdhesion = ½·τ_t·r³ (its pure-bending and pure-twisting stresses with the
    /// same r² "area").
    pub fn of(s: &Strength, r1: f64, r2: f64, moments: bool) -> YadeAdhesion {
        let r = r1.min(r2);
        YadeAdhesion {
            normal: s.tensile * r * r,
            shear: s.cohesion * r * r,
            tan_friction: s.friction,
            cohesion_disables_friction: false,
            moments: if moments {
                YadeMoments::Adhesion {
                    rolling: 0.25 * s.bending * r * r * r,
                    twisting: 0.5 * s.twisting * r * r * r,
                }
            } else {
                YadeMoments::Elastic
            },
        }
    }

    /// The shear limit at normal force `fn_` (compression positive): a_s, plus F_n·tan φ
    /// unless cohesion disables friction (YADE adds it also when a_s = 0), at least 0.
    pub fn max_shear(&self, fn_: f64) -> f64 {
        let mut max_fs = self.shear;
        if !self.cohesion_disables_friction || max_fs == 0.0 {
            max_fs += fn_ * self.tan_friction;
        }
        max_fs.max(0.0)
    }
}

/// YADE's CohFrict criterion (`Law2_ScGeom6D_CohFrictPhys_CohesionMoment::go`, fragile):
/// tension breaks when −F_n > a_n; else shear when |F_s| > max(0, a_s + F_n·tan φ); then,
/// with moment adhesions, bending when |M_b| > rollingAdhesion and twisting when
/// |M_t| > twistingAdhesion — in that order, all strict (exactly at a limit holds). Index:
/// the largest of −F_n/a_n, |F_s|/max F_s and the moment ratios.
pub fn yade_cohfrict(a: &YadeAdhesion, l: &LocalLoads) -> Failure {
    let max_fs = a.max_shear(l.normal);
    let tension = (Mode::Tension, ratio(-l.normal, a.normal));
    let shear = (Mode::Shear, ratio(l.shear, max_fs));
    let (bending, twisting) = match a.moments {
        YadeMoments::Elastic => ((Mode::Bending, 0.0), (Mode::Twisting, 0.0)),
        YadeMoments::Adhesion { rolling, twisting } => (
            (
                Mode::Bending,
                if rolling > 0.0 {
                    ratio(l.bending, rolling)
                } else {
                    0.0
                },
            ),
            (
                Mode::Twisting,
                if twisting > 0.0 {
                    ratio(l.twisting, twisting)
                } else {
                    0.0
                },
            ),
        ),
    };
    let broken_by = if -l.normal > a.normal {
        Some(Mode::Tension)
    } else if l.shear > max_fs {
        Some(Mode::Shear)
    } else {
        match a.moments {
            YadeMoments::Adhesion { rolling, .. } if rolling > 0.0 && l.bending > rolling => {
                Some(Mode::Bending)
            }
            YadeMoments::Adhesion { twisting: t, .. } if t > 0.0 && l.twisting > t => {
                Some(Mode::Twisting)
            }
            _ => None,
        }
    };
    let (top, index) = largest([tension, shear, bending, twisting]);
    Failure {
        broken: broken_by.is_some(),
        mode: broken_by.unwrap_or(top),
        index,
    }
}

// ---------------------------------------------------------------------------------------
// LAMMPS bpm/rotational
// ---------------------------------------------------------------------------------------

/// One bond's critical loads of LAMMPS `bond_style bpm/rotational` (its `bond_coeff`
/// `f_rc f_sc τ_bc τ_tc`), all > 0.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BpmLimits {
    /// f_rc: critical normal (tensile) force (N).
    pub f_rc: f64,
    /// f_sc: critical shear force (N).
    pub f_sc: f64,
    /// τ_bc: critical bending torque (N·m).
    pub t_bc: f64,
    /// τ_tc: critical twisting torque (N·m).
    pub t_tc: f64,
}

impl BpmLimits {
    /// The critical loads of a bond of radius R_b (the model's `[geometry]` bond radius)
    /// with A = π̂R_b², I = π̂R_b⁴/4, J = π̂R_b⁴/2 (as the parallel-bond springs):
    /// f_rc = σ_t·A, f_sc = c·A, τ_bc = σ_b·I/R_b = σ_b·π̂R_b³/4, τ_tc = τ_t·J/R_b =
    /// τ_t·π̂R_b³/2.
    pub fn of(s: &Strength, rb: f64, pi_hat: f64) -> BpmLimits {
        let area = pi_hat * rb * rb;
        BpmLimits {
            f_rc: s.tensile * area,
            f_sc: s.cohesion * area,
            t_bc: s.bending * area * rb / 4.0,
            t_tc: s.twisting * area * rb / 2.0,
        }
    }
}

/// LAMMPS bpm/rotational's breaking criterion (`BondBPMRotational::elastic_forces`): the
/// sum B = F_r/f_rc + |F_s|/f_sc + |τ_b|/τ_bc + |τ_t|/τ_tc with F_r = k_r(r − r₀) signed
/// (tension positive, so here F_r = −F_n: compression lowers B), B clamped at 0; the bond
/// breaks when B ≥ 1 (`compute`). |F_s| is LAMMPS's whole shear force (from the bond's
/// direction and from the bending rotation). Index: B; mode: its largest term.
pub fn lammps_bpm(lim: &BpmLimits, l: &LocalLoads) -> Failure {
    let normal = -l.normal / lim.f_rc;
    let shear = l.shear / lim.f_sc;
    let bending = l.bending / lim.t_bc;
    let twisting = l.twisting / lim.t_tc;
    let breaking = (normal + shear + bending + twisting).max(0.0);
    let (mode, _) = largest([
        (Mode::Tension, normal),
        (Mode::Shear, shear),
        (Mode::Bending, bending),
        (Mode::Twisting, twisting),
    ]);
    Failure {
        broken: breaking >= 1.0,
        mode,
        index: breaking,
    }
}

/// LAMMPS bpm/rotational's smoothing factor w = 1 − B⁴ (`smooth yes`, its default): the
/// bond's forces and torques are multiplied by w, so they fade to zero as B → 1
/// (doc/src/bond_bpm_rotational.rst; `BondBPMRotational::compute`).
pub fn bpm_smoothing(breaking: f64) -> f64 {
    let b2 = breaking * breaking;
    1.0 - b2 * b2
}

// ---------------------------------------------------------------------------------------
// Parallel bond (Potyondy & Cundall 2004)
// ---------------------------------------------------------------------------------------

/// A parallel bond's section and strengths (Potyondy & Cundall 2004).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ParallelBondSection {
    /// Bond radius R̄ (m).
    pub radius: f64,
    /// A = π̂R̄² (m²).
    pub area: f64,
    /// I = π̂R̄⁴/4 (m⁴).
    pub inertia: f64,
    /// J = π̂R̄⁴/2 (m⁴).
    pub polar: f64,
    /// Tensile strength σ̄_c (Pa).
    pub sigma_c: f64,
    /// Shear strength τ̄_c (Pa).
    pub tau_c: f64,
}

impl ParallelBondSection {
    /// The section of bond radius R̄ (the springs' [`crate::bonds::BondStiffness::radius`])
    /// with π̂ of the model's geometry (π by default), σ̄_c = σ_t, τ̄_c = c.
    pub fn of(s: &Strength, rb: f64, pi_hat: f64) -> ParallelBondSection {
        let area = pi_hat * rb * rb;
        ParallelBondSection {
            radius: rb,
            area,
            inertia: area * rb * rb / 4.0,
            polar: area * rb * rb / 2.0,
            sigma_c: s.tensile,
            tau_c: s.cohesion,
        }
    }
}

/// Potyondy & Cundall 2004's parallel-bond criterion: the maximum tensile and shear stresses
/// on the bond's periphery σ̄ = −F_n/A + |M_b|·R̄/I and τ̄ = |F_s|/A + |M_t|·R̄/J (F_n
/// compression positive); the bond breaks when σ̄ ≥ σ̄_c (mode tension or bending, by the
/// larger of its two terms) or τ̄ ≥ τ̄_c (shear or twisting). Index max(σ̄/σ̄_c, τ̄/τ̄_c).
pub fn parallel_bond(sec: &ParallelBondSection, l: &LocalLoads) -> Failure {
    let axial = -l.normal / sec.area;
    let flexural = l.bending * sec.radius / sec.inertia;
    let direct = l.shear / sec.area;
    let torsional = l.twisting * sec.radius / sec.polar;
    let sigma = axial + flexural;
    let tau = direct + torsional;
    let sigma_index = ratio(sigma, sec.sigma_c);
    let tau_index = ratio(tau, sec.tau_c);
    let sigma_mode = if axial >= flexural {
        Mode::Tension
    } else {
        Mode::Bending
    };
    let tau_mode = if direct >= torsional {
        Mode::Shear
    } else {
        Mode::Twisting
    };
    let tensile_breaks = sigma >= sec.sigma_c && sigma > 0.0;
    let shear_breaks = tau >= sec.tau_c && tau > 0.0;
    let mode = match (tensile_breaks, shear_breaks) {
        (true, false) => sigma_mode,
        (false, true) => tau_mode,
        _ if sigma_index >= tau_index => sigma_mode,
        _ => tau_mode,
    };
    Failure {
        broken: tensile_breaks || shear_breaks,
        mode,
        index: sigma_index.max(tau_index),
    }
}

// ---------------------------------------------------------------------------------------
// Joint (plane of weakness)
// ---------------------------------------------------------------------------------------

/// A joint bond's limits on its plane (the smooth joint, Park & Min 2015).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct JointLimits {
    /// The joint's area A (m²): stresses are forces over A.
    pub area: f64,
    /// Tensile strength σ_t (Pa), the tension cut-off.
    pub tensile: f64,
    /// Cohesion c_w (Pa).
    pub cohesion: f64,
    /// Friction μ_w = tan φ_w.
    pub friction: f64,
}

impl JointLimits {
    /// The limits of a joint bond of radius R_b: A = π̂R_b², the strength's tensile,
    /// cohesion and friction.
    pub fn of(s: &Strength, rb: f64, pi_hat: f64) -> JointLimits {
        JointLimits {
            area: pi_hat * rb * rb,
            tensile: s.tensile,
            cohesion: s.cohesion,
            friction: s.friction,
        }
    }

    /// The limits of a joint bond of radius R_b and unit normal `bond_normal` across a plane
    /// of unit normal `plane_normal`, its stresses taken on `section`: A = π̂R_b² (Bond, as
    /// [`JointLimits::of`]) or the bond's section cut by the plane, π̂R_b²/|n·p| (Cut).
    pub fn on_section(
        s: &Strength,
        rb: f64,
        pi_hat: f64,
        section: super::planes::JointSection,
        bond_normal: &Vec3,
        plane_normal: &Vec3,
    ) -> JointLimits {
        let lim = JointLimits::of(s, rb, pi_hat);
        JointLimits {
            area: section.area(lim.area, bond_normal, plane_normal),
            ..lim
        }
    }
}

/// The bond force on j resolved on a joint plane: (normal force, compression positive;
/// shear force magnitude), in N. `force_on_j` is the bond's force on particle j,
/// `bond_normal` the unit vector from i to j, `plane_normal` the plane's unit normal (its
/// sign is irrelevant: it is oriented along the bond here, so that a bond pulled apart has a
/// negative normal force whichever way it crosses the plane).
pub fn resolve_on_plane(force_on_j: &Vec3, bond_normal: &Vec3, plane_normal: &Vec3) -> (f64, f64) {
    let p = if plane_normal.dot(bond_normal) < 0.0 {
        -plane_normal
    } else {
        *plane_normal
    };
    let fn_ = force_on_j.dot(&p);
    let shear = (force_on_j - p * fn_).norm();
    (fn_, shear)
}

/// Mohr–Coulomb with a tension cut-off on the joint plane: σ_n = F_n/A (compression
/// positive), τ = |F_s|/A with A the joint's area (the bond's section, or that section cut
/// by the plane, [`JointLimits::on_section`]); tension failure when −σ_n ≥ σ_t, shear failure when
/// τ ≥ max(0, c_w + μ_w·σ_n) (tension lowers the shear limit until the cut-off). `l.normal`
/// and `l.shear` are the loads resolved on the plane ([`resolve_on_plane`]); moments are not
/// judged. Index max(−σ_n/σ_t, τ/τ_max); tension wins a tie.
pub fn joint(lim: &JointLimits, l: &LocalLoads) -> Failure {
    let sigma_n = l.normal / lim.area;
    let tau = l.shear / lim.area;
    let tau_max = (lim.cohesion + lim.friction * sigma_n).max(0.0);
    let tension = ratio(-sigma_n, lim.tensile);
    let shear = ratio(tau, tau_max);
    let tension_breaks = -sigma_n >= lim.tensile && -sigma_n > 0.0;
    let shear_breaks = tau >= tau_max && tau > 0.0;
    let mode = match (tension_breaks, shear_breaks) {
        (true, _) => Mode::Tension,
        (false, true) => Mode::Shear,
        _ if tension >= shear => Mode::Tension,
        _ => Mode::Shear,
    };
    Failure {
        broken: tension_breaks || shear_breaks,
        mode,
        index: tension.max(shear),
    }
}
