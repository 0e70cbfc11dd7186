//! Linearised buckling of clamped bars: a square lattice bar against Euler (Kumar 2016
//! Eq. 14 with the bar's own EI) and Engesser's shear-corrected load; a random bar's
//! invariants (degenerate bending pair, thread-count independence).

use anisobond::assembly::Assembly;
use anisobond::homogenize::{
    clamped_bar_buckling, euler_stress, extensible_stress, mazzilli_stress, BucklingOptions,
    ClampedBar, PreBuckling,
};
use anisobond::model::Model;
use anisobond::packing::Packing;
use anisobond::packing::{cut, Region};
use anisobond::packing::{prepare, PreparationRoute, RouteOptions};
use anisobond::Vec3;
use std::f64::consts::PI;

/// Kumar 2016's bonds: interaction range κ, α = Σ_T/Σ_N, Eqs. 7–8 moments.
pub(crate) fn kumar_model(kappa: f64, alpha: f64) -> Model {
    let text = format!(
        "[bonding]\nrule = \"factor\"\nvalue = {kappa}\n[scheme]\nkind = \"isotropic\"\n\
         normal = 1e8\nshear = {}\n[geometry]\nconvention = \"kumar\"\nmoments = \"kumar\"\n",
        alpha * 1e8
    );
    Model::from_toml_str(&text, "kumar").unwrap()
}

/// A 2×2 × nz simple-cubic column of touching spheres with its clamped end layers, length
/// (m) and section area (m²).
struct LatticeBar {
    asm: Assembly,
    first: Vec<u32>,
    second: Vec<u32>,
    length: f64,
    area: f64,
}

impl LatticeBar {
    /// The column as a bar clamped on its end layers along z.
    fn bar(&self) -> ClampedBar<'_> {
        ClampedBar {
            assembly: &self.asm,
            first_end: &self.first,
            second_end: &self.second,
            axis: Vec3::z(),
            length: self.length,
            area: self.area,
        }
    }
}

fn lattice_bar(nz: usize) -> LatticeBar {
    LatticeBar::new(nz, kumar_model(1.01, 0.2))
}

impl LatticeBar {
    /// `nz` layers bonded by `model`.
    fn new(nz: usize, model: Model) -> LatticeBar {
        let rad = 1e-3;
        let mut pos = Vec::new();
        for k in 0..nz {
            for i in 0..2 {
                for j in 0..2 {
                    pos.push(Vec3::new(i as f64, j as f64, k as f64) * 2.0 * rad);
                }
            }
        }
        let n = pos.len();
        let p = Packing::new(pos, vec![rad; n], None).unwrap();
        let asm = Assembly::new(p, model).unwrap();
        let first = (0..4).collect();
        let second = (n as u32 - 4..n as u32).collect();
        LatticeBar {
            asm,
            first,
            second,
            length: (nz - 1) as f64 * 2.0 * rad,
            area: 16.0 * rad * rad,
        }
    }
}

/// Slender lattice column (80 layers, l/h = 40): λ within 3 % of Euler 4π²EI/l² with the
/// column's own pure-bending EI, and within 1 % of Engesser P_E/(1 + P_E/κGA) with its own
/// clamped–guided κGA; the two bending modes (x, y) are equal by the square's symmetry.
#[test]
fn slender_lattice_column_is_euler() {
    let lattice = lattice_bar(80);
    let l = lattice.length;
    let r = clamped_bar_buckling(&lattice.bar(), &BucklingOptions::default()).unwrap();
    let euler = r.critical_force / r.euler_force_own(l);
    let engesser = r.critical_force / r.engesser_force_own(l);
    assert!((euler - 1.0).abs() < 0.03, "P/P_Euler = {euler}");
    assert!((engesser - 1.0).abs() < 0.01, "P/P_Engesser = {engesser}");
    let [l1, l2] = r.load_factors;
    assert!((l2 - l1).abs() < 1e-6 * l1, "{l1} {l2}");
    assert!(r.residuals.iter().all(|x| *x < 1e-6) && r.reaction_imbalance < 1e-9);
}

/// Short lattice column (20 layers, l/h = 9.5): the shear correction is large (P_E/κGA ≈
/// 0.36) and the linearised load follows Engesser within 1 %, not Euler; it lies below
/// Mazzilli (Eq. 15), whose extensibility correction a small-strain eigenproblem does not
/// contain.
#[test]
fn short_lattice_column_is_engesser() {
    let lattice = lattice_bar(20);
    let l = lattice.length;
    let r = clamped_bar_buckling(&lattice.bar(), &BucklingOptions::default()).unwrap();
    let engesser = r.critical_force / r.engesser_force_own(l);
    assert!((engesser - 1.0).abs() < 0.01, "P/P_Engesser = {engesser}");
    let shear = r.euler_force_own(l) / r.shear_stiffness(l);
    assert!(shear > 0.2, "P_E/κGA = {shear}");
    assert!(r.critical_force < 0.9 * r.euler_force_own(l));
}

/// Eqs. 14–15: Mazzilli → Euler for slender bars, σ_M(1 − σ_M/E) = σ_E exactly.
#[test]
fn euler_and_mazzilli_closed_forms() {
    let e = 7.0e9;
    for s in [10.0, 20.0, 120.0] {
        let se = euler_stress(e, s);
        assert!((se - PI * PI * e / (s * s)).abs() < 1e-12 * se);
        let sm = mazzilli_stress(e, s);
        assert!((sm * (1.0 - sm / e) - se).abs() < 1e-9 * se);
    }
    assert!((mazzilli_stress(e, 120.0) / euler_stress(e, 120.0) - 1.0).abs() < 2e-3);
    assert!(mazzilli_stress(e, 5.0).is_nan());
}

/// A random bar cut from an unjammed packing: the two bending load factors are a near pair
/// (round section), and the result is bit-identical on one and two threads.
#[test]
fn random_bar_pair_and_threads() {
    let o = RouteOptions {
        route: PreparationRoute::Unjammed,
        n_particles: 1000,
        seed: 1,
        ..RouteOptions::default()
    };
    let p = prepare(&o, &|_| {}).unwrap().0;
    let (rbar, side) = (p.mean_radius(), p.cell.unwrap().lengths.x);
    let (radius, l) = (5.0 * rbar, 150.0 * rbar);
    let region = Region::Cylinder {
        centre: Vec3::new(0.5 * side, 0.5 * side, 0.5 * l),
        axis: Vec3::z(),
        radius,
        length: l,
    };
    let c = cut(&p, &region).unwrap();
    let sets = c.boundary(rbar).unwrap();
    let asm = Assembly::new(c.packing.clone(), kumar_model(1.0, 0.2)).unwrap();
    let run = |threads: usize| {
        crate::common::on_threads(threads, || {
            let bar = ClampedBar {
                assembly: &asm,
                first_end: &sets.first_end,
                second_end: &sets.second_end,
                axis: Vec3::z(),
                length: l,
                area: PI * radius * radius,
            };
            clamped_bar_buckling(&bar, &BucklingOptions::default()).unwrap()
        })
    };
    let (a, b) = (run(1), run(2));
    assert_eq!(a.load_factors, b.load_factors);
    assert_eq!(a.modulus, b.modulus);
    let [l1, l2] = a.load_factors;
    assert!(l1 > 0.0 && l2 >= l1 && l2 < 1.2 * l1, "{l1} {l2}");
    assert!(a.static_residual < 1e-8 && a.reaction_imbalance < 1e-9);
}

/// Jammed bars (Kumar's jammed route, 1000-sphere cell, r = 5 R̄, κ = 1, α = 0.2): the
/// network's critical force follows Engesser's P_E/(1 + P_E/κGA) with the bar's own EI
/// (pure bending) and κGA (clamped–guided) within 5 % at l/r = 40 and 80 (measured 0.977
/// and 1.003). Euler's 4π²EI/l² with the pure-bending EI alone gives 0.891 at l/r = 80: the
/// random bar is softer in transverse loading than its pure-bending EI says (κGA holds
/// that), unlike the lattice column above.
#[test]
fn jammed_bars_follow_engesser_with_their_own_stiffness() {
    let o = RouteOptions {
        route: PreparationRoute::Jammed,
        n_particles: 1000,
        seed: 1,
        ..RouteOptions::default()
    };
    let p = prepare(&o, &|_| {}).unwrap().0;
    let rbar = p.mean_radius();
    for s in [40.0, 80.0] {
        let bar =
            anisobond::homogenize::RoundBar::cut(&p, kumar_model(1.0, 0.2), 5.0 * rbar, s, rbar)
                .unwrap();
        let r = bar.buckling(&BucklingOptions::default()).unwrap();
        let l = bar.length;
        let engesser = r.critical_force / r.engesser_force_own(l);
        assert!(
            (engesser - 1.0).abs() < 0.05,
            "l/r {s}: P/P_Engesser = {engesser}"
        );
    }
}

/// No silent answers: an iteration limit below what the tolerance needs is an error naming
/// the residuals; overlapping end sets and a non-unit axis are refused.
#[test]
fn non_convergence_and_bad_bars_are_errors() {
    let lattice = lattice_bar(40);
    let mut bar = lattice.bar();
    let opts = BucklingOptions {
        max_iterations: 2,
        tolerance: 1e-12,
        ..BucklingOptions::default()
    };
    let err = clamped_bar_buckling(&bar, &opts).unwrap_err();
    assert!(matches!(err, anisobond::Error::NotConverged(_)), "{err}");
    assert!(
        err.to_string().contains("did not converge in 2 iterations"),
        "{err}"
    );
    bar.second_end = &lattice.first;
    let err = clamped_bar_buckling(&bar, &BucklingOptions::default()).unwrap_err();
    assert!(err.to_string().contains("in both end sets"), "{err}");
    bar.second_end = &lattice.second;
    bar.axis = Vec3::new(0.0, 0.0, 2.0);
    let err = clamped_bar_buckling(&bar, &BucklingOptions::default()).unwrap_err();
    assert!(err.to_string().contains("unit vector"), "{err}");
}

/// Mazzilli's extensible rod (Kumar 2016 Eq. 15) on the deformed bar: short, shear-rigid
/// lattice columns (Σ_T = 100 Σ_N, no lateral expansion under axial load) solved on their
/// pre-buckling geometry satisfy σ(1 − σ/E) = σ_lin, σ_lin their own small-strain load, to
/// 0.2 % (measured 0.13 % at 10 layers, 0.003 % at 20), while the extensibility raises the
/// load 26 % and 3.7 % above σ_lin.
#[test]
fn short_shear_rigid_column_is_mazzilli_on_the_deformed_bar() {
    let opts = BucklingOptions {
        pre_buckling: PreBuckling::UpdatedGeometry,
        ..BucklingOptions::default()
    };
    for (nz, gain) in [(10, 1.2), (20, 1.03)] {
        let lattice = LatticeBar::new(nz, kumar_model(1.01, 100.0));
        let r = clamped_bar_buckling(&lattice.bar(), &opts).unwrap();
        let updated = r.updated_geometry.unwrap();
        let ratio = updated.critical_stress / extensible_stress(r.critical_stress, r.modulus);
        assert!(
            (ratio - 1.0).abs() < 2e-3,
            "{nz} layers: σ/σ_Mazzilli = {ratio}"
        );
        assert!(
            updated.critical_stress > gain * r.critical_stress,
            "{nz} layers"
        );
        assert!(updated.fixed_point_residual < 1e-6);
    }
}
