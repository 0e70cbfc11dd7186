//! Šmilauer's element tests (Šmilauer, "Evaluating the stiffness tensor"): for each axis an
//! unconfined uniaxial test — strain ε̂ prescribed along the axis, every other stress
//! component servo-controlled to zero ([`super::servo`]) — giving E_i = T_ii/ε̂ and
//! ν_ij = −ε_jj/ε̂ (Eq. 24); and three strain-controlled pure shears giving
//! G_ij = T_ij/γ_ij (Eq. 25). Relaxed quasi-statically with Cundall damping. The
//! constants give the stiffness two ways: the orthotropic compliance
//! (Eq. 23) inverted, and the cross-anisotropic (transversely
//! isotropic about z) inversion of Eq. 26 in its corrected form
//! ([`crate::tensor::elastic::cross_anisotropic_from_engineering`]).

use super::servo::{
    servo_until_converged, ComponentControl, ServoOptions, ServoOutcome, StressServo,
};
use super::sim::Simulation;
use crate::tensor::elastic::{compliance, cross_anisotropic_from_engineering};
use crate::tensor::Stiffness6;
use crate::{Error, Mat3, Result};

/// Settings of the stress-controlled element tests.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StressTestOptions {
    /// Prescribed axial strain ε̂ of the uniaxial tests, and half the engineering shear
    /// strain of the shear tests (ε_ij = ε_ji = ε̂). The paper uses −1 %; for the linear
    /// bond laws a small value keeps the geometry change negligible.
    pub strain: f64,
    /// Cundall local damping during the tests (YADE measurements use 0.4).
    pub local_damping: f64,
    /// Servo gain, tolerances (t_r, steadiness), window and step limit per test.
    pub servo: ServoOptions,
}

impl Default for StressTestOptions {
    fn default() -> Self {
        StressTestOptions {
            strain: -1e-5,
            local_damping: 0.4,
            servo: ServoOptions::default(),
        }
    }
}

/// One uniaxial (unconfined) test.
#[derive(Clone, Debug, PartialEq)]
pub struct UniaxialTest {
    /// Loaded axis 0, 1, 2 (x, y, z).
    pub axis: usize,
    /// Young's modulus E_axis = T_axis/ε̂ (Pa; Šmilauer Eq. 24).
    pub young: f64,
    /// ν_axis,j = −ε_jj/ε̂ for j = 0, 1, 2 (0 at j = axis).
    pub poisson: [f64; 3],
    /// The converged state (strain, stress, steps, residuals).
    pub outcome: ServoOutcome,
}

/// One strain-controlled pure shear.
#[derive(Clone, Debug, PartialEq)]
pub struct ShearTest {
    /// Voigt component 3, 4, 5 (yz, xz, xy).
    pub component: usize,
    /// Shear modulus G = T_ij/γ_ij (Pa; Šmilauer Eq. 25).
    pub modulus: f64,
    /// The converged state.
    pub outcome: ServoOutcome,
}

/// The stiffness from Šmilauer's six element tests.
#[derive(Clone, Debug)]
pub struct StressControlledResult {
    /// Uniaxial tests along x, y, z.
    pub uniaxial: Vec<UniaxialTest>,
    /// Pure shears yz, xz, xy.
    pub shear: Vec<ShearTest>,
    /// Orthotropic stiffness: the compliance S_ii = 1/E_i, S_ij = −½(ν_ij/E_i + ν_ji/E_j),
    /// S_44,55,66 = 1/G (symmetric couples averaged) inverted (Pa).
    pub c_orthotropic: Stiffness6,
    /// Transversely isotropic constants about z, (C11, C12, C13, C33, C44) in Pa, from the
    /// averaged couples E_x = ½(E_x + E_y), ν_xy = ½(ν_xy + ν_yx), ν_zx = ½(ν_zx + ν_zy),
    /// G_yz = ½(G_yz + G_zx), and the dependent ν_xz = (E_x/E_z)·ν_zx as the paper's table.
    pub cross_anisotropic: [f64; 5],
    /// The transversely isotropic tensor of `cross_anisotropic` (C66 = (C11 − C12)/2).
    pub c_cross_anisotropic: Stiffness6,
    /// Largest relative mismatch of the symmetric couples ν_ij/E_i vs ν_ji/E_j — a check of
    /// the tests, as in the paper.
    pub reciprocity_mismatch: f64,
    /// Time step used (s).
    pub time_step: f64,
    /// The integrator's critical time step estimate (s).
    pub critical_time_step: f64,
}

/// The transversely isotropic Voigt tensor about z from (C11, C12, C13, C33, C44).
pub fn transversely_isotropic(c: [f64; 5]) -> Stiffness6 {
    let [c11, c12, c13, c33, c44] = c;
    let mut t = Stiffness6::zeros();
    t[(0, 0)] = c11;
    t[(1, 1)] = c11;
    t[(2, 2)] = c33;
    t[(0, 1)] = c12;
    t[(1, 0)] = c12;
    for (a, b) in [(0, 2), (2, 0), (1, 2), (2, 1)] {
        t[(a, b)] = c13;
    }
    t[(3, 3)] = c44;
    t[(4, 4)] = c44;
    t[(5, 5)] = 0.5 * (c11 - c12);
    t
}

/// Stiffness from the engineering constants of the six tests: the orthotropic inversion,
/// the transversely isotropic one (see [`StressControlledResult`]) and the reciprocity
/// mismatch. `young[i]` = E_i, `poisson[(i, j)]` = ν_ij = −ε_j/ε_i under stress along i,
/// `shear` = (G_yz, G_xz, G_xy) in Pa.
pub fn stiffness_from_tests(
    young: [f64; 3],
    poisson: &Mat3,
    shear: [f64; 3],
) -> Result<(Stiffness6, [f64; 5], f64)> {
    for (name, v) in [
        ("E_x", young[0]),
        ("E_y", young[1]),
        ("E_z", young[2]),
        ("G_yz", shear[0]),
        ("G_xz", shear[1]),
        ("G_xy", shear[2]),
    ] {
        if !(v.is_finite() && v > 0.0) {
            return Err(Error::Invalid(format!(
                "element tests gave {name} = {v} Pa; a stable bonded assembly has a positive \
                 modulus (wrong sign of the response?)"
            )));
        }
    }
    let mut s = Stiffness6::zeros();
    let mut mismatch: f64 = 0.0;
    for i in 0..3 {
        s[(i, i)] = 1.0 / young[i];
        s[(i + 3, i + 3)] = 1.0 / shear[i];
        for j in (i + 1)..3 {
            let a = poisson[(i, j)] / young[i];
            let b = poisson[(j, i)] / young[j];
            let scale = a.abs().max(b.abs());
            if scale > 0.0 {
                mismatch = mismatch.max((a - b).abs() / scale);
            }
            s[(i, j)] = -0.5 * (a + b);
            s[(j, i)] = s[(i, j)];
        }
    }
    let c_orthotropic = compliance(&s, "orthotropic compliance of the element tests")?;
    let e_x = 0.5 * (young[0] + young[1]);
    let e_z = young[2];
    let nu_xy = 0.5 * (poisson[(0, 1)] + poisson[(1, 0)]);
    let nu_zx = 0.5 * (poisson[(2, 0)] + poisson[(2, 1)]);
    let nu_xz = e_x / e_z * nu_zx;
    let g_yz = 0.5 * (shear[0] + shear[1]);
    let ti = cross_anisotropic_from_engineering(e_x, e_z, nu_xy, nu_xz, g_yz)?;
    Ok((c_orthotropic, ti, mismatch))
}

/// Run the three unconfined uniaxial tests and the three pure shears, each from a clone of
/// `initial`, and derive the stiffness (Šmilauer Eqs. 24, 25,
/// 23, 26). `progress` receives the fraction
/// done (tests counted equally, each by its share of the step limit).
pub fn stress_controlled_tensor(
    initial: &Simulation,
    opts: &StressTestOptions,
    progress: &(dyn Fn(f64) + Sync),
) -> Result<StressControlledResult> {
    let e = opts.strain;
    if !(e.is_finite() && e != 0.0 && e.abs() < 0.1) {
        return Err(Error::Invalid(format!(
            "element-test strain ε̂ must be non-zero with |ε̂| < 0.1, got {e}"
        )));
    }
    if initial.cell.is_none() {
        return Err(Error::Invalid(
            "stress-controlled element tests need a periodic packing (a `# periodic Lx Ly Lz` \
             header)"
                .into(),
        ));
    }
    let max = opts.servo.max_steps.max(1) as f64;
    let run = |test: usize, controls: [ComponentControl; 6]| -> Result<ServoOutcome> {
        let mut sim = initial.clone();
        sim.set_local_damping(opts.local_damping)?;
        let servo = StressServo::new(&sim, controls, &opts.servo)?;
        servo_until_converged(&mut sim, &servo, &opts.servo, &mut |s| {
            progress((test as f64 + (s as f64 / max).min(1.0)) / 6.0)
        })
        .map_err(|err| err.in_context(format_args!("element test {test}")))
    };
    let mut uniaxial = Vec::with_capacity(3);
    for axis in 0..3 {
        let mut controls = [ComponentControl::Stress(0.0); 6];
        controls[axis] = ComponentControl::Strain(e);
        let outcome = run(axis, controls)?;
        let eps = outcome.strain[axis];
        let young = outcome.stress[axis] / eps;
        let mut poisson = [0.0; 3];
        for (j, p) in poisson.iter_mut().enumerate() {
            if j != axis {
                *p = -outcome.strain[j] / eps;
            }
        }
        uniaxial.push(UniaxialTest {
            axis,
            young,
            poisson,
            outcome,
        });
    }
    let mut shear = Vec::with_capacity(3);
    for component in 3..6 {
        let mut controls = [ComponentControl::Strain(0.0); 6];
        controls[component] = ComponentControl::Strain(2.0 * e);
        let outcome = run(component, controls)?;
        let modulus = outcome.stress[component] / outcome.strain[component];
        shear.push(ShearTest {
            component,
            modulus,
            outcome,
        });
    }
    progress(1.0);
    let young = [uniaxial[0].young, uniaxial[1].young, uniaxial[2].young];
    let poisson = Mat3::from_fn(|i, j| uniaxial[i].poisson[j]);
    let g = [shear[0].modulus, shear[1].modulus, shear[2].modulus];
    let (c_orthotropic, cross_anisotropic, reciprocity_mismatch) =
        stiffness_from_tests(young, &poisson, g)?;
    Ok(StressControlledResult {
        uniaxial,
        shear,
        c_orthotropic,
        c_cross_anisotropic: transversely_isotropic(cross_anisotropic),
        cross_anisotropic,
        reciprocity_mismatch,
        time_step: initial.time_step(),
        critical_time_step: initial.stability().critical_time_step,
    })
}

/// What the six tests give for an exact stiffness `c` (Pa): E_i = 1/S_ii and
/// ν_ij = −S_ij·E_i from S = C⁻¹ (all other stresses zero), G = C_44, C_55, C_66 (all other
/// strains zero). The reference the DEM tests are compared with.
pub fn expected_test_constants(c: &Stiffness6) -> Result<([f64; 3], Mat3, [f64; 3])> {
    let s = compliance(c, "stiffness for the expected element-test constants")?;
    let young = [1.0 / s[(0, 0)], 1.0 / s[(1, 1)], 1.0 / s[(2, 2)]];
    let poisson = Mat3::from_fn(|i, j| if i == j { 0.0 } else { -s[(i, j)] * young[i] });
    Ok((young, poisson, [c[(3, 3)], c[(4, 4)], c[(5, 5)]]))
}
