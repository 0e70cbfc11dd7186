//! The static cavity against Lamé's thick cylinder (plane strain, clamped outer radius),
//! with λ and μ from the source packing's own relaxed tensor.

use anisobond::bonds::BondingRule;
use anisobond::cavity::{isotropic_lame_constants, lame_wall_displacement, Cavity, CavityGeometry};
use anisobond::model::{Model, SchemeSpec};
use anisobond::prelude::*;
use anisobond::schemes::Geometry;

/// An isotropic model (constant magnitudes) bonded with gap 0.17 R̄.
pub fn isotropic_model() -> Model {
    Model {
        bonding: BondingRule::Gap(0.17),
        scheme: SchemeSpec::Isotropic {
            normal: 1.0e13,
            shear: 0.4e13,
        },
        geometry: Geometry::default(),
        strength: None,
        manybody: None,
        grains: None,
    }
}

pub fn source(n: usize, seed: u64, model: Model) -> Assembly {
    let p = crate::common::bonded::generated(n, seed);
    Assembly::new(p, model).unwrap()
}

/// The cavity geometry a = `a`·R̄, b = `b`·R̄ with the library's defaults for the rest
/// (clamp width the longest bond, tiles of R̄/4).
pub fn geometry(src: &Assembly, a: f64, b: f64) -> CavityGeometry {
    let r = src.packing.mean_radius();
    CavityGeometry::with_defaults(src, Some(a * r), Some(b * r), None, None)
}

#[test]
fn wall_loads_balance_and_add_up_to_the_wall_area() {
    let src = source(1000, 7, isotropic_model());
    let cav = Cavity::new(&src, geometry(&src, 10.0, 14.0)).unwrap();
    let lz = cav.cut.packing.cell.unwrap().lengths.z;
    let area = 2.0 * std::f64::consts::PI * 10.0 * src.packing.mean_radius() * lz;
    let total: f64 = cav.unit_load.iter().map(|f| f.norm()).sum();
    let net: anisobond::Vec3 = cav.unit_load.iter().sum();
    // the tile forces add up to p·area; a sphere's resultant is shorter than the sum of its
    // tiles' forces by the spread of their directions (a few degrees)
    assert!(
        total <= area * (1.0 + 1e-12) && total > 0.99 * area,
        "{total} vs {area}"
    );
    assert!(net.norm() < 1e-12 * area, "net force {net:?}");
    // every wall force is radial and points away from the axis, and sits near the hole
    for &p in &cav.wall {
        let f = cav.unit_load[p as usize];
        assert!(f.z == 0.0 && f.dot(&cav.radial_unit(p as usize)) > 0.0);
        let rho = cav.cut.radial_distance(p as usize);
        assert!(rho < 10.0 * src.packing.mean_radius() + 6.0 * src.packing.mean_radius());
        assert!(!cav.clamped[p as usize]);
    }
}

#[test]
fn wall_displacement_matches_lame() {
    let src = source(1000, 7, isotropic_model());
    let c = src.tensor(&Method::relaxed()).unwrap().report.tensor();
    let (lambda, mu) = isotropic_lame_constants(&c);
    let (a, b) = (10.0, 24.0);
    let cav = Cavity::new(&src, geometry(&src, a, b)).unwrap();
    let p = 1e6;
    let s = cav.solve_static(p).unwrap();
    let r = src.packing.mean_radius();
    let lame = lame_wall_displacement(p, a * r, b * r, lambda, mu);
    let ratio = s.wall_displacement / lame;
    // measured: 0.9885 (5069 spheres, 4073 free, 389 on the wall)
    assert!((ratio - 1.0).abs() < 0.04, "DEM/Lamé = {ratio}");
    // the continuum with the full relaxed tensor (not its isotropic projection)
    let fe = anisobond::cavity::solve_annulus(
        &c,
        a * r,
        b * r,
        p,
        &anisobond::cavity::AnnulusMesh::default(),
    )
    .unwrap();
    // measured: continuum/Lamé 1.0016 (the tensor's small anisotropy), DEM/continuum 0.9869
    assert!((fe.wall_displacement / lame - 1.0).abs() < 0.01);
    let dem = s.wall_displacement / fe.wall_displacement;
    assert!((dem - 1.0).abs() < 0.04, "DEM/continuum = {dem}");
    assert!(s.relative_residual < 1e-10);
    // isotropic: no mean axial motion (plane strain)
    assert!(s.wall_axial_displacement.abs() < 0.01 * s.wall_displacement);
    // the clamped ring does not move, and the solution is linear in p
    for (k, u) in s.displacement.iter().enumerate() {
        if cav.clamped[k] {
            assert_eq!(*u, anisobond::Vec3::zeros());
        }
    }
    let s2 = cav.solve_static(-2.0 * p).unwrap();
    assert!((s2.wall_displacement + 2.0 * s.wall_displacement).abs() < 1e-9 * s.wall_displacement);
}

#[test]
fn bad_geometry_is_refused() {
    let src = source(300, 3, isotropic_model());
    let r = src.packing.mean_radius();
    let g = geometry(&src, 4.0, 8.0);
    let e = Cavity::new(
        &src,
        CavityGeometry {
            clamp_width: 0.5 * r,
            ..g
        },
    )
    .err()
    .unwrap();
    assert!(e.to_string().contains("clamp width"), "{e}");
    let e = Cavity::new(
        &src,
        CavityGeometry {
            ray_spacing: 2.0 * r,
            ..g
        },
    )
    .err()
    .unwrap();
    assert!(e.to_string().contains("ray spacing"), "{e}");
    let e = Cavity::new(
        &src,
        CavityGeometry {
            outer_radius: 3.0 * r,
            ..g
        },
    )
    .err()
    .unwrap();
    assert!(e.to_string().contains("hole radius"), "{e}");
    let cav = Cavity::new(&src, g).unwrap();
    assert!(cav.solve_static(f64::NAN).is_err());
    assert!(cav.solve_static(0.0).is_err());
}

#[test]
fn static_and_wave_results_do_not_depend_on_the_thread_count() {
    let src = source(300, 5, isotropic_model());
    let r = src.packing.mean_radius();
    let cav = Cavity::new(&src, geometry(&src, 4.0, 10.0)).unwrap();
    let opts = anisobond::cavity::WaveOptions {
        pressure: 1e6,
        ramp_time: 2e-6,
        duration: 6e-6,
        material_density: 2600.0,
        law: anisobond::dem::LawKind::Yade,
        directions: vec![0.0],
        probe_radii: vec![5.0 * r, 8.0 * r],
        probe_half_angle: 0.5,
        snapshots: 1,
    };
    let run = |threads: usize| {
        crate::common::on_threads(threads, || {
            let s = cav.solve_static(1e6).unwrap();
            let w = cav.run_waves(&opts).map(|w| w.snapshots[0].1.clone());
            (s.displacement, w)
        })
    };
    let (a, b) = (run(1), run(2));
    assert_eq!(a.0, b.0);
    // the wave run's snapshot, bit for bit
    assert_eq!(a.1.unwrap(), b.1.unwrap());
}

#[test]
fn damped_integrator_settles_on_the_static_solution() {
    // the integrator (YADE's law, external wall forces, clamped ring held) against the
    // direct solve of the same network
    let src = source(300, 5, isotropic_model());
    let cav = Cavity::new(&src, geometry(&src, 4.0, 9.0)).unwrap();
    let p = 1e6;
    let s = cav.solve_static(p).unwrap();
    let mut sim = cav
        .simulation(p, 2600.0, anisobond::dem::LawKind::Yade, 0.3)
        .unwrap();
    let start = sim.particles.position.clone();
    let mut last = f64::NAN;
    for k in 0..200 {
        for _ in 0..100 {
            sim.step().unwrap();
        }
        let u: Vec<anisobond::Vec3> = (0..start.len())
            .map(|q| sim.particles.position[q] - start[q])
            .collect();
        last = cav.wall_displacement(&u);
        if sim.energies().kinetic < 1e-12 * p * 1e-9 && k > 5 {
            break;
        }
    }
    let ratio = last / s.wall_displacement;
    // measured: 1.0000376 after 1300 steps
    assert!(
        (ratio - 1.0).abs() < 1e-3,
        "dynamic/static wall displacement {ratio}"
    );
}
