//! The virtual laboratory (`study::strength_test`, `anisobond strength-test`): E from the
//! initial slope of a UCS against the exact static solve and the simple-cubic closed form,
//! the bedding rotation, the Brazilian disc's σ_t = 2P/(πDt) from its own force, the
//! command's files and refusals. See tests/README.md.

#[path = "../common/mod.rs"]
mod common;

mod breakage;
mod cli;
mod elastic;
mod sweep;

use anisobond::model::Model;
use anisobond::packing::Packing;
use anisobond::Vec3;

/// Radius of the lattice spheres (m).
pub const R: f64 = 1e-3;

/// A free simple-cubic block of touching spheres of radius [`R`], `n` × `n` × `nz`.
pub fn simple_cubic(n: usize, nz: usize) -> Packing {
    let mut x = Vec::new();
    for k in 0..nz {
        for j in 0..n {
            for i in 0..n {
                x.push(Vec3::new(i as f64, j as f64, k as f64) * 2.0 * R);
            }
        }
    }
    let len = x.len();
    Packing::new(x, vec![R; len], None).unwrap()
}

/// Nearest-neighbour bonds (gap 0.01 R̄) with springs k_n = `kn`, k_s = 0.35 k_n (N/m, the
/// `spring` convention), and an optional `[strength]` table.
pub fn spring_model(kn: f64, strength: &str) -> Model {
    Model::from_toml_str(
        &format!(
            "[bonding]\nrule = \"gap\"\nvalue = 0.01\n[scheme]\nkind = \"isotropic\"\n\
             normal = {kn:e}\nshear = {:e}\n[geometry]\nconvention = \"spring\"\n{strength}",
            0.35 * kn
        ),
        "lattice.toml",
    )
    .unwrap()
}
