//! Gripped element tests on a simple cubic lattice, where the affine field is the
//! equilibrium (every non-grip particle is a centre of inversion with its six neighbours):
//! the measurement-sphere strain must equal the imposed strain and the tensor must be the
//! closed form of docs/references.md (SC, bond length 2R: C11 = k_n/(2R), C12 = 0,
//! C44 = k_t/(4R)); the Table 3 heterogeneity metric must vanish.

use anisobond::bonds::{build_bonds, BondStiffness, BondingRule};
use anisobond::dem::LawKind;
use anisobond::dem::MeasureOptions;
use anisobond::dem::{gripped_tensor, GrippedOptions};
use anisobond::packing::{Packing, PeriodicCell};
use anisobond::tensor::Stiffness6;
use anisobond::Vec3;

const R: f64 = 1e-3;
const KN: f64 = 1e6;
const KS: f64 = 0.4e6;

fn sc_lattice(n: usize) -> Packing {
    let a = 2.0 * R;
    let mut x = Vec::new();
    for i in 0..n {
        for j in 0..n {
            for k in 0..n {
                x.push(Vec3::new(i as f64 + 0.5, j as f64 + 0.5, k as f64 + 0.5) * a);
            }
        }
    }
    let cell = PeriodicCell::new(Vec3::repeat(n as f64 * a)).unwrap();
    Packing::new(x, vec![R; n * n * n], Some(cell)).unwrap()
}

#[test]
fn sc_lattice_gripped_strain_is_affine_and_tensor_is_closed_form() {
    let p = sc_lattice(10);
    let b = build_bonds(&p, BondingRule::Gap(0.01)).unwrap();
    assert_eq!(b.len(), 3 * 1000, "SC nearest-neighbour bonds only");
    let nb = b.len();
    let k = BondStiffness {
        radius: vec![R; nb],
        kn: vec![KN; nb],
        ks: vec![KS; nb],
        kr: vec![0.0; nb],
        ktw: vec![0.0; nb],
    };
    // Strain 1e-7: the Love stress uses the current branch vectors, an O(ε) geometric term.
    let opts = GrippedOptions {
        strain: 1e-7,
        tolerance: 1e-10,
        local_damping: 0.6,
        measure: MeasureOptions {
            count: 40,
            radius: 3.0,
            seed: 5,
        },
        ..Default::default()
    };
    let t0 = std::time::Instant::now();
    let t = gripped_tensor(&p, &b, &k, LawKind::Yade, &opts, &|_| {}).unwrap();
    let steps: Vec<usize> = t.paths.iter().map(|p| p.steps).collect();
    // Strain of every sphere against the imposed strain.
    let mut worst_strain: f64 = 0.0;
    for path in &t.paths {
        let e = path.imposed_strain;
        for s in &path.sphere_strains {
            worst_strain = worst_strain.max((s - e).amax() / e.amax());
        }
    }
    let mut expected = Stiffness6::zeros();
    for i in 0..3 {
        expected[(i, i)] = KN / (2.0 * R);
        expected[(i + 3, i + 3)] = KS / (4.0 * R);
    }
    let dc = (t.c - expected).amax() / expected.amax();
    println!(
        "SC 10³: {} grips, {} bonds, {:.1} members/sphere; worst sphere strain error {worst_strain:.2e}, \
         tensor error {dc:.2e}, heterogeneity normal {:.2e} shear {:.2e}; steps {steps:?}; {:.1} s",
        t.grips,
        t.bonds,
        t.mean_members,
        t.heterogeneity.normal,
        t.heterogeneity.shear,
        t0.elapsed().as_secs_f64()
    );
    assert_eq!(t.grips, 1000 - 8 * 8 * 8, "the outer layer grips");
    assert!(
        worst_strain < 1e-6,
        "sphere strain off the affine field by {worst_strain:.2e}"
    );
    assert!(
        dc < 1e-6,
        "tensor differs from the SC closed form by {dc:.2e}"
    );
    assert!(t.heterogeneity.normal < 1e-6 && t.heterogeneity.shear < 1e-6);
}
