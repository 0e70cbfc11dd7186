//! Calibration to the whole stable domain: springs plus the many-body term (issue 33 item 2,
//! docs/manybody.md "Calibration").
//!
//! Used only where the pairwise scheme cannot reach a target. The springs take a share s of
//! a tensor P they can reach (cubic: the mean-field map's point nearest the target's ratios;
//! transversely isotropic: the elliptic scheme of the target's four constants, or of an
//! isotropic tensor of Poisson's ratio 0.2 when those are out of its reach), with s half the largest value
//! for which T − s·P stays positive semidefinite. The term's D then carries the rest:
//! D = (T − s·P)/φ at the Voigt/mean-field level, where the term adds exactly φ·D
//! (φ = Σ V_p / V of the particles that carry it; docs/manybody.md "The closed form"). D is
//! positive definite (at least T/2) and so are the springs, so each part is stable on its
//! own. On the relaxed tensor the fluctuations couple springs and term, so D's independent
//! constants are iterated (Broyden 1965, `broyden.rs`) until the relaxed tensor of springs
//! plus term has the target's.

use super::broyden::{self, BroydenOptions, End, Evaluation, Point};
use super::cubic::{base_rotation, CubicOptions, CubicParameters, Level, MeanFieldMap};
use super::kernel::CubicKernel;
use super::target::CubicTarget;
use crate::dem::transversely_isotropic;
use crate::homogenize::mean_field::mean_field_converged;
use crate::manybody::{DegenerateParticles, LocalTensor, ManyBodySpec, StrainMeasure};
use crate::model::{CrossTarget, Model, SchemeSpec};
use crate::schemes::cross_anisotropic::dependent_c44;
use crate::schemes::cubic::{CubicModel, CubicSpheroid};
use crate::tensor::{CubicProjection, Stiffness6, TransverseProjection};
use crate::{Error, Mat3, Result, Vec3};
use nalgebra::{DMatrix, DVector};

/// Cubic metals at room temperature, (name, C11, C12, C44) in Pa, for the domain map and
/// docs/manybody.md's table: nickel, copper, iron and aluminium as issue 33 gives them
/// (handbook values); tungsten from Wang, Gulick & Li, J. Appl. Phys. 138, 045902 (2025).
/// All lie beyond the springs' domain (C12 > C44).
pub const CUBIC_MATERIALS: [(&str, f64, f64, f64); 5] = [
    ("Ni", 247e9, 147e9, 125e9),
    ("Cu", 168e9, 121e9, 75e9),
    ("Fe", 231.4e9, 134.7e9, 116.4e9),
    ("Al", 107.3e9, 60.9e9, 28.3e9),
    ("W", 523.5e9, 205.1e9, 160.8e9),
];

/// The symmetry of a target, and with it the frame of D and the order of its constants.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Symmetry {
    /// Cubic: (C11, C12, C44) in the crystal frame of the scheme's rotation (lab → crystal).
    Cubic {
        /// Lab → crystal rotation (the cubic scheme's).
        rotation: Mat3,
    },
    /// Transversely isotropic: (C11, C33, C13, C12, C44) about the axis.
    TransverselyIsotropic {
        /// Unit symmetry axis (lab frame).
        axis: Vec3,
    },
}

impl Symmetry {
    /// Names of the independent constants, in the order of every vector of this module.
    pub fn names(&self) -> &'static [&'static str] {
        match self {
            Symmetry::Cubic { .. } => &["C11", "C12", "C44"],
            Symmetry::TransverselyIsotropic { .. } => &["C11", "C33", "C13", "C12", "C44"],
        }
    }

    /// The Voigt matrix of constants `c` in the symmetry's own frame (crystal frame; axis
    /// along 3).
    pub fn matrix(&self, c: &[f64]) -> Stiffness6 {
        match self {
            Symmetry::Cubic { .. } => {
                let mut m = Stiffness6::zeros();
                for a in 0..3 {
                    for b in 0..3 {
                        m[(a, b)] = if a == b { c[0] } else { c[1] };
                    }
                    m[(a + 3, a + 3)] = c[2];
                }
                m
            }
            Symmetry::TransverselyIsotropic { .. } => {
                let (c11, c33, c13, c12, c44) = (c[0], c[1], c[2], c[3], c[4]);
                transversely_isotropic([c11, c12, c13, c33, c44])
            }
        }
    }

    /// The independent constants of a lab-frame tensor (its projection onto the symmetry:
    /// Truszkowska 2018 Eq. 30 for cubic, about the axis for transversely isotropic).
    pub fn constants(&self, lab: &Stiffness6) -> Result<Vec<f64>> {
        Ok(match self {
            Symmetry::Cubic { rotation } => {
                let p = CubicProjection::from_stiffness(&crate::tensor::rotate(lab, rotation));
                vec![p.c11, p.c12, p.c44]
            }
            Symmetry::TransverselyIsotropic { axis } => {
                let (p, _) = TransverseProjection::about_axis(lab, axis)?;
                vec![p.c11, p.c33, p.c13, p.c12, p.c44]
            }
        })
    }

    /// D of constants `d` in this symmetry, turned with the scheme (the cubic rotation, the
    /// transversely isotropic axis).
    pub fn local_tensor(&self, d: &[f64]) -> LocalTensor {
        match *self {
            Symmetry::Cubic { rotation } => LocalTensor::Cubic {
                c11: d[0],
                c12: d[1],
                c44: d[2],
                rotation,
            },
            Symmetry::TransverselyIsotropic { axis } => LocalTensor::TransverselyIsotropic {
                c11: d[0],
                c33: d[1],
                c13: d[2],
                c12: d[3],
                c44: d[4],
                axis,
            },
        }
    }
}

/// A calibration that needed the many-body term: the springs' share, D, and what the sum
/// achieves. Every number in it is fitted to the target.
#[derive(Clone, Debug)]
pub struct ManyBodyCalibration {
    /// Mean-field (Voigt) or relaxed.
    pub level: Level,
    /// The target's symmetry (and the frame of every constant below).
    pub symmetry: Symmetry,
    /// Target constants (Pa), in [`Symmetry::names`] order.
    pub target: Vec<f64>,
    /// The springs of the written model (pairwise scheme, kind unchanged).
    pub scheme: SchemeSpec,
    /// Cubic: the spheroid parameters of the springs.
    pub cubic_parameters: Option<CubicParameters>,
    /// The springs' share s of the reachable tensor P (half the largest s with T − s·P ⪰ 0).
    pub share: f64,
    /// The springs' constants at this level (Pa; the relaxed tensor of the springs alone
    /// on the relaxed level).
    pub pairwise: Vec<f64>,
    /// D's constants (Pa), fitted.
    pub d: Vec<f64>,
    /// φ = Σ V_p / V of the particles that carry the term (1 without a packing).
    pub volume_fraction: f64,
    /// Constants of springs + term at this level (Pa).
    pub achieved: Vec<f64>,
    /// The full tensor of springs + term (lab frame, Pa).
    pub achieved_tensor: Stiffness6,
    /// Why the springs alone could not reach the target.
    pub pairwise_refusal: String,
    /// Relaxed level: D's constants and the achieved constants of every relaxed solve.
    pub history: Vec<(Vec<f64>, Vec<f64>)>,
}

impl ManyBodyCalibration {
    /// The many-body table of the written model: D in the target's symmetry, Green–Lagrange
    /// (what the integrator needs; the static tensors use its linearisation), rattlers
    /// excluded (as the calibration assumed).
    pub fn manybody_spec(&self) -> ManyBodySpec {
        ManyBodySpec {
            tensor: self.symmetry.local_tensor(&self.d),
            measure: StrainMeasure::GreenLagrange,
            degenerate: DegenerateParticles::Exclude,
        }
    }

    /// The base model with the springs and `[manybody]` replaced by the calibrated ones.
    pub fn model(&self, base: &Model) -> Model {
        let mut m = base.clone();
        m.scheme = self.scheme.clone();
        m.manybody = Some(self.manybody_spec());
        m
    }
}

/// s = ½ / λ_max(P, T), λ_max the largest generalised eigenvalue of P x = λ T x: then
/// T − s·P ⪰ T/2 (refused as [`Error::Degenerate`] when P has no positive direction).
pub fn spring_share(t: &Stiffness6, p: &Stiffness6) -> Result<f64> {
    let l = t
        .cholesky()
        .ok_or_else(|| {
            Error::Invalid("many-body calibration: the target is not positive definite".into())
        })?
        .l();
    let linv = l
        .try_inverse()
        .ok_or_else(|| Error::Degenerate("many-body calibration: singular target".into()))?;
    let m = linv * p * linv.transpose();
    let m = 0.5 * (m + m.transpose());
    let lmax = m.symmetric_eigenvalues().max();
    if !(lmax > 0.0 && lmax.is_finite()) {
        return Err(Error::Degenerate(format!(
            "many-body calibration: the springs' tensor has no positive direction relative to the target (λ_max = {lmax:e})"
        )));
    }
    Ok(0.5 / lmax)
}

/// The springs a cubic target starts from: the mean-field map's point nearest the target's
/// ratios, its normal magnitude giving the target's C11 at the mean-field `prefactor` (the
/// model's default normal for a ratio target).
pub(crate) struct CubicReach {
    params: CubicParameters,
    normal: f64,
    rho: f64,
}

impl CubicReach {
    pub(crate) fn new(
        t: &CubicTarget,
        prefactor: f64,
        default_normal: f64,
        opts: &CubicOptions,
    ) -> Result<CubicReach> {
        let kernel = CubicKernel::default();
        let (model, map) = super::cubic::target_map(&kernel, t, default_normal, opts)?;
        let (p, _) = map.nearest_reachable(t);
        let unit = map.constants(&p);
        Ok(CubicReach {
            params: CubicParameters::at(model, opts.extended, &p),
            normal: t
                .c11
                .map_or(default_normal, |c11| c11 / (prefactor * unit.c11)),
            rho: p.rho,
        })
    }

    /// The springs at `share` of the normal magnitude (crystal frame).
    fn spheroid(&self, share: f64) -> Result<CubicSpheroid> {
        CubicSpheroid::new(
            self.params.model,
            self.params.extended,
            self.params.a_n,
            self.params.a_s,
            share * self.normal,
            share * self.normal * self.rho,
            Mat3::identity(),
        )
    }

    /// The scheme table of the springs at `share`, turned by the base's crystal rotation.
    pub(crate) fn scheme_at(&self, share: f64, rotation: Mat3) -> SchemeSpec {
        SchemeSpec::Cubic(CubicSpheroid {
            model: self.params.model,
            extended: self.params.extended,
            a_n: self.params.a_n,
            a_s: self.params.a_s,
            normal: share * self.normal,
            shear: share * self.normal * self.rho,
            rotation,
        })
    }
}

/// Cubic target at the mean-field level: the springs at the map's point nearest the target
/// (share s), D = (T − s·P)/φ. `prefactor` as in [`super::calibrate_cubic_mean_field`].
pub(crate) fn cubic_mean_field(
    base: &Model,
    t: &CubicTarget,
    prefactor: f64,
    reach: &CubicReach,
    phi: f64,
    refusal: String,
) -> Result<ManyBodyCalibration> {
    let full = mean_field_converged(&reach.spheroid(1.0)?, prefactor)?;
    let rotation = base_rotation(base);
    let symmetry = Symmetry::Cubic { rotation };
    let (t11, t12, t44) = t.constants(full[(0, 0)]);
    let target = vec![t11, t12, t44];
    let share = spring_share(&symmetry.matrix(&target), &full)?;
    let springs = mean_field_converged(&reach.spheroid(share)?, prefactor)?;
    let pairwise = crystal_constants(&springs);
    let d: Vec<f64> = target
        .iter()
        .zip(&pairwise)
        .map(|(t, p)| (t - p) / phi)
        .collect();
    let achieved_crystal = springs + phi * symmetry.matrix(&d);
    Ok(ManyBodyCalibration {
        level: Level::MeanField,
        symmetry,
        achieved: crystal_constants(&achieved_crystal),
        achieved_tensor: crate::tensor::rotate(&achieved_crystal, &rotation.transpose()),
        target,
        scheme: reach.scheme_at(share, rotation),
        cubic_parameters: Some(reach.params),
        share,
        pairwise,
        d,
        volume_fraction: phi,
        pairwise_refusal: refusal,
        history: Vec::new(),
    })
}

/// The springs of a relaxed split: the scheme table at a share s of the reachable springs.
pub(crate) enum Springs<'a> {
    /// Cubic spheroids ([`CubicReach`]).
    Cubic(&'a CubicReach),
    /// The elliptic scheme holding these four constants (C11, C33, C13, C12) at share 1.
    Elliptic([f64; 4]),
}

impl Springs<'_> {
    fn scheme(&self, base: &Model, share: f64) -> SchemeSpec {
        match self {
            Springs::Cubic(r) => r.scheme_at(share, base_rotation(base)),
            Springs::Elliptic(w) => {
                let mut s = base.scheme.clone();
                if let SchemeSpec::CrossAnisotropic(ct) = &mut s {
                    (ct.c11, ct.c33, ct.c13, ct.c12) =
                        (share * w[0], share * w[1], share * w[2], share * w[3]);
                }
                s
            }
        }
    }
}

/// Relaxed level: the relaxed tensor of the springs alone at share 1 (one solve), the share
/// s against the target, then D iterated ([`solve_d`]) from (T − s·P_relaxed)/φ until the
/// relaxed tensor of springs plus term has the target's constants. `relaxed` is the relaxed
/// tensor (lab frame) of a model on the packing, its `[manybody]` included.
#[allow(clippy::too_many_arguments)]
pub(crate) fn relaxed_split(
    base: &Model,
    symmetry: Symmetry,
    target: Vec<f64>,
    springs: Springs<'_>,
    phi: f64,
    refusal: String,
    mut relaxed: impl FnMut(&Model) -> Result<Stiffness6>,
    opts: &SolveOptions,
) -> Result<ManyBodyCalibration> {
    let mut alone = base.clone();
    alone.manybody = None;
    alone.scheme = springs.scheme(base, 1.0);
    let full = symmetry.constants(&relaxed(&alone)?)?;
    let share = spring_share(&symmetry.matrix(&target), &symmetry.matrix(&full))?;
    // The relaxed tensor is homogeneous of degree 1 in the springs.
    let pairwise: Vec<f64> = full.iter().map(|v| share * v).collect();
    let d0: Vec<f64> = target
        .iter()
        .zip(&pairwise)
        .map(|(t, p)| (t - p) / phi)
        .collect();
    let scheme = springs.scheme(base, share);
    let with_d = |d: &[f64]| {
        let mut m = base.clone();
        m.scheme = scheme.clone();
        m.manybody = Some(ManyBodySpec {
            tensor: symmetry.local_tensor(d),
            measure: StrainMeasure::GreenLagrange,
            degenerate: DegenerateParticles::Exclude,
        });
        m
    };
    let SolvedD {
        d,
        achieved,
        history,
    } = solve_d(
        &target,
        d0,
        phi,
        |d| symmetry.constants(&relaxed(&with_d(d))?),
        opts,
    )?;
    // The last evaluation need not be the accepted one: recompute the tensor of the result.
    let achieved_tensor = relaxed(&with_d(&d))?;
    Ok(ManyBodyCalibration {
        level: Level::Relaxed,
        symmetry,
        target,
        scheme,
        cubic_parameters: match springs {
            Springs::Cubic(r) => Some(r.params),
            Springs::Elliptic(_) => None,
        },
        share,
        pairwise,
        d,
        volume_fraction: phi,
        achieved,
        achieved_tensor,
        pairwise_refusal: refusal,
        history,
    })
}

/// The cubic projection's (C11, C12, C44) of a crystal-frame tensor.
fn crystal_constants(c: &Stiffness6) -> Vec<f64> {
    let p = CubicProjection::from_stiffness(c);
    vec![p.c11, p.c12, p.c44]
}

/// The Voigt-level constants (C11, C33, C13, C12, C44) of the elliptic scheme holding the
/// four constants `w` (exact under uniform strain, C44 dependent: Šmilauer Eq. 12).
pub fn elliptic_voigt(w: &[f64; 4]) -> Vec<f64> {
    vec![w[0], w[1], w[2], w[3], dependent_c44(w[0], w[1], w[2])]
}

/// The four constants the elliptic scheme takes as its reachable tensor P for target
/// (C11, C33, C13, C12): the target's own when the scheme reproduces them on a packing of
/// lattice scaling `mu`, else the isotropic tensor of Poisson's ratio 0.2 (C12/C11 = 1/4; the
/// Cauchy value 0.25 would need zero tangential springs) of the same C11.
pub(crate) fn elliptic_reach(target: &[f64], axis: Vec3, mu: f64) -> [f64; 4] {
    let own = [target[0], target[1], target[2], target[3]];
    let ct = CrossTarget {
        c11: own[0],
        c33: own[1],
        c13: own[2],
        c12: own[3],
        axis,
    };
    if ct.scheme(mu).is_ok() {
        own
    } else {
        let c = target[0];
        [c, c, 0.25 * c, 0.25 * c]
    }
}

/// Transversely isotropic five-constant target at the Voigt level: springs s·P
/// ([`elliptic_reach`]), D = (T − s·P)/φ.
pub(crate) fn transverse_voigt(
    base: &Model,
    target: [f64; 5],
    axis: Vec3,
    mu: f64,
    phi: f64,
    refusal: String,
) -> Result<ManyBodyCalibration> {
    let symmetry = Symmetry::TransverselyIsotropic { axis };
    let tm = symmetry.matrix(&target);
    let reach = elliptic_reach(&target, axis, mu);
    let share = spring_share(&tm, &symmetry.matrix(&elliptic_voigt(&reach)))?;
    let w = reach.map(|v| share * v);
    CrossTarget {
        c11: w[0],
        c33: w[1],
        c13: w[2],
        c12: w[3],
        axis,
    }
    .scheme(mu)?;
    let pairwise = elliptic_voigt(&w);
    let d: Vec<f64> = target
        .iter()
        .zip(&pairwise)
        .map(|(t, p)| (t - p) / phi)
        .collect();
    let achieved: Vec<f64> = pairwise.iter().zip(&d).map(|(p, d)| p + phi * d).collect();
    let q = crate::tensor::rotation_to_z(&axis)?;
    let mut model_scheme = base.scheme.clone();
    if let SchemeSpec::CrossAnisotropic(ct) = &mut model_scheme {
        (ct.c11, ct.c33, ct.c13, ct.c12) = (w[0], w[1], w[2], w[3]);
    }
    Ok(ManyBodyCalibration {
        level: Level::MeanField,
        symmetry,
        achieved_tensor: crate::tensor::rotate(&symmetry.matrix(&achieved), &q.transpose()),
        achieved,
        target: target.to_vec(),
        scheme: model_scheme,
        cubic_parameters: None,
        share,
        pairwise,
        d,
        volume_fraction: phi,
        pairwise_refusal: refusal,
        history: Vec::new(),
    })
}

/// Options of [`solve_d`].
#[derive(Clone, Copy, Debug)]
pub struct SolveOptions {
    /// Converged when every constant is within this relative error of the target's.
    pub tolerance: f64,
    /// Evaluations (relaxed solves) allowed, the start's included.
    pub max_evaluations: usize,
}

/// What [`solve_d`] found.
#[derive(Clone, Debug)]
pub struct SolvedD {
    /// D's constants.
    pub d: Vec<f64>,
    /// The achieved constants at `d` (the accepted evaluation's).
    pub achieved: Vec<f64>,
    /// Every evaluation: (d, achieved).
    pub history: Vec<(Vec<f64>, Vec<f64>)>,
}

/// Solve achieved(d) = target for D's constants by Broyden's method from `d0`, with φ·I as
/// the initial Jacobian (the closed form at the Voigt level; the relaxed contribution lies
/// below it). `achieved` is one relaxed solve of springs plus a term with D = d. The
/// tolerance is relative to
/// each target constant (to 1e-3 of the largest one for a constant near zero).
pub fn solve_d(
    target: &[f64],
    d0: Vec<f64>,
    phi: f64,
    mut achieved: impl FnMut(&[f64]) -> Result<Vec<f64>>,
    opts: &SolveOptions,
) -> Result<SolvedD> {
    super::check_iteration_options(opts.tolerance, opts.max_evaluations)?;
    let n = target.len();
    let goal = DVector::from_column_slice(target);
    let big = goal.amax();
    let scale = goal.map(|v| v.abs().max(1e-3 * big));
    let mut history: Vec<(Vec<f64>, Vec<f64>)> = Vec::new();
    let x0 = DVector::from_vec(d0);
    let a0 = achieved(x0.as_slice())?;
    history.push((x0.as_slice().to_vec(), a0.clone()));
    let start = Point {
        f: DVector::from_vec(a0.clone()) - &goal,
        x: x0,
        data: a0,
    };
    let jac = DMatrix::<f64>::identity(n, n) * phi;
    let result = broyden::solve(
        start,
        jac.clone(),
        |d| {
            let a = achieved(d.as_slice())?;
            history.push((d.as_slice().to_vec(), a.clone()));
            Ok(Evaluation::Admissible(
                DVector::from_vec(a.clone()) - &goal,
                a,
            ))
        },
        |_| {},
        |_| jac.clone(),
        &BroydenOptions {
            tolerance: opts.tolerance,
            scale,
            max_evaluations: opts.max_evaluations,
            max_step: f64::INFINITY,
            max_trials: 6,
        },
    )?;
    if !matches!(result.end, End::Converged) {
        let last = &result.point.data;
        return Err(Error::NotConverged(format!(
            "many-body calibration: the relaxed tensor did not reach the target within {} relaxed solves (largest relative error {:.2e} > tolerance {:.1e}); achieved {:?} Pa vs target {:?} Pa",
            result.evaluations, result.best_error, opts.tolerance, last, target
        )));
    }
    Ok(SolvedD {
        d: result.point.x.as_slice().to_vec(),
        achieved: result.point.data,
        history,
    })
}

/// Whether the springs alone reach the cubic target at the mean-field level: Err(why) with
/// the pairwise calibration's own refusal when they do not.
pub(crate) fn mean_field_reaches(
    t: &CubicTarget,
    default_normal: f64,
    opts: &CubicOptions,
) -> Result<std::result::Result<(), String>> {
    let kernel = CubicKernel::default();
    let (_, map): (CubicModel, MeanFieldMap) =
        super::cubic::target_map(&kernel, t, default_normal, opts)?;
    Ok(match map.solve(t, opts.family) {
        Some(_) => Ok(()),
        None => {
            Err(super::cubic::unreachable_error(&kernel, &map, t, opts, "mean-field").to_string())
        }
    })
}
