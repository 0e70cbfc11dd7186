//! Bonds per particle of Kumar 2016 Table 1 for packing files: each packing is scaled
//! affinely to D = 0.65 (Sec. 3) and bonded with interaction range κ = 1.000, 1.025, 1.050,
//! 1.075 (Eq. 10).
//!
//! `cargo run --release --example kumar_coordination -- packing.txt [more.txt …]`

use anisobond::bonds::build_bonds;
use anisobond::bonds::BondingRule;
use anisobond::packing::read_packing;
use anisobond::packing::{scale_to_solid_fraction, KUMAR_2016_SOLID_FRACTION};
use std::path::Path;

fn main() -> anisobond::Result<()> {
    for path in std::env::args().skip(1) {
        let packing = read_packing(Path::new(&path))?;
        let scaled = scale_to_solid_fraction(&packing, KUMAR_2016_SOLID_FRACTION)?;
        let mut z = Vec::new();
        for kappa in [1.0, 1.025, 1.05, 1.075] {
            let bonds = build_bonds(&scaled, BondingRule::Factor(kappa))?;
            z.push(format!("{:.3}", bonds.coordination(scaled.len())));
        }
        println!(
            "{path}: bonds per particle at D = 0.65, κ = 1.000 / 1.025 / 1.050 / 1.075: {}",
            z.join(" / ")
        );
    }
    Ok(())
}
