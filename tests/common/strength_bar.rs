//! The bar of the engines' strength validations (`validate ENGINE --strength`, issue 32):
//! an n × n × n simple-cubic block of touching spheres of R = 1 mm, free (no cell), gap
//! bonded (3n²(n − 1) bonds), isotropic springs (k_n = 2e6 N/m, k_s = 7e5 N/m), Weibull
//! tensile strengths (mean 5 MPa, modulus 5, seeded) so that bonds break one by one.

use anisobond::assembly::Assembly;
use anisobond::model::Model;
use anisobond::packing::Packing;
use anisobond::Vec3;

/// Sphere radius (m).
pub const R: f64 = 1e-3;

/// The model: springs and the `[strength]` table.
pub const MODEL: &str = "[bonding]\nrule = \"gap\"\nvalue = 0.01\n\
    [scheme]\nkind = \"isotropic\"\nnormal = 2e6\nshear = 7e5\n\
    [geometry]\nconvention = \"spring\"\n\
    [strength]\n[strength.bond]\ntensile = 5e6\ncohesion = 1e7\n\
    [strength.scatter]\ndistribution = \"weibull\"\nmodulus = 5.0\nseed = 7\n";

/// The bonded n × n × n bar.
pub fn cubic_bar(n: usize) -> Assembly {
    let mut pos = Vec::new();
    for k in 0..n {
        for j in 0..n {
            for i in 0..n {
                pos.push(Vec3::new(i as f64, j as f64, k as f64) * 2.0 * R);
            }
        }
    }
    let count = pos.len();
    let packing = Packing::new(pos, vec![R; count], None).unwrap();
    let model = Model::from_toml_str(MODEL, "<strength test>").unwrap();
    let asm = Assembly::new(packing, model).unwrap();
    assert_eq!(asm.bonds.len(), 3 * n * n * (n - 1));
    asm
}
