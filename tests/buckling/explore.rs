use anisobond::assembly::Assembly;
use anisobond::homogenize::buckling::*;
use anisobond::model::Model;
use anisobond::packing::cut::{cut, Region};
use anisobond::packing::routes::{prepare, PreparationRoute, RouteOptions};
use anisobond::Vec3;
use std::f64::consts::PI;

fn kumar_model(kappa: f64, alpha: f64) -> Model {
    let text = format!(
        "[bonding]\nrule = \"factor\"\nvalue = {kappa}\n[scheme]\nkind = \"isotropic\"\n\
         normal = 1e8\nshear = {}\n[geometry]\nconvention = \"kumar\"\nmoments = \"kumar\"\n",
        alpha * 1e8
    );
    Model::from_toml_str(&text, "kumar").unwrap()
}

#[test]
#[ignore]
fn explore() {
    let n: usize = std::env::var("NP")
        .map(|s| s.parse().unwrap())
        .unwrap_or(1000);
    let rr: f64 = std::env::var("RR")
        .map(|s| s.parse().unwrap())
        .unwrap_or(5.0);
    let shrink: f64 = std::env::var("SH")
        .map(|s| s.parse().unwrap())
        .unwrap_or(1.0);
    let t0 = std::time::Instant::now();
    let o = RouteOptions {
        route: PreparationRoute::Unjammed,
        n_particles: n,
        seed: 1,
        ..RouteOptions::default()
    };
    let p = prepare(&o, &|_| {}).unwrap().0;
    let rbar = p.mean_radius();
    let side = p.cell.unwrap().lengths.x;
    println!("cell side {} R, prep {:?}", side / rbar, t0.elapsed());
    for slender in [10.0, 20.0, 40.0, 80.0] {
        let t0 = std::time::Instant::now();
        let r = rr * rbar;
        let l = slender * r;
        let region = Region::Cylinder {
            centre: Vec3::new(0.5 * side, 0.5 * side, 0.5 * l),
            axis: Vec3::z(),
            radius: r - shrink * rbar,
            length: l,
        };
        let c = cut(&p, &region).unwrap();
        let sets = c.boundary(rbar).unwrap();
        let asm = Assembly::new(c.packing.clone(), kumar_model(1.0, 0.2)).unwrap();
        let bar = ClampedBar {
            assembly: &asm,
            first_end: &sets.first_end,
            second_end: &sets.second_end,
            axis: Vec3::z(),
            length: l,
            area: PI * r * r,
        };
        let res = clamped_bar_buckling(&bar, &BucklingOptions::default()).unwrap();
        let se = euler_stress(res.modulus, slender);
        let sm = mazzilli_stress(res.modulus, slender);
        println!("l/r {slender}: N {} E {:.4e} lam {:?} it {} sig/Euler {:.4} sig/Maz {:.4} imb {:.1e} comp {}/{} {:?}",
            c.packing.len(), res.modulus, res.load_factors, res.iterations, res.critical_stress / se, res.critical_stress / sm, res.reaction_imbalance, res.compressed_bonds, res.bonds, t0.elapsed());
    }
}
