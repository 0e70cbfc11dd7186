//! Which pairs of spheres are bonded (Truszkowska 2018 Eq. 4 gap cutoff; Kumar 2016
//! Eq. 10 interaction range κ; Šmilauer's contact radius I_R; or a target coordination).

use serde::{Deserialize, Serialize};

/// The bonding rule of a model's `[bonding]` table.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "rule", content = "value", rename_all = "kebab-case")]
pub enum BondingRule {
    /// Bond when |x_i − x_j| − (R_i + R_j) ≤ value·R̄ (Truszkowska 2018, Eq. 4).
    Gap(f64),
    /// Bond when |x_i − x_j| ≤ value·(R_i + R_j) (κ of Kumar 2016 Eq. 10, I_R of Šmilauer).
    Factor(f64),
    /// Bisect the gap cutoff until the mean bonds per particle equals the value.
    Coordination(f64),
}

impl Default for BondingRule {
    fn default() -> Self {
        BondingRule::Gap(0.17)
    }
}

use super::BondSet;
use crate::packing::neighbours::{pairs_within, pairs_within_centre_distance, Pair};
use crate::packing::Packing;
use crate::{Error, Result};
use rayon::prelude::*;

/// A pair whose centre distance is below this fraction of R_i + R_j is refused as
/// near-coincident: with equal radii one centre lies inside the other sphere. No DEM packing
/// overlaps like that (generated packings stay within a few % of R̄); such a pair is a
/// duplicated or mistyped particle, and its bond — far shorter and stiffer than the rest —
/// collapses the critical time step (a copy shifted by 1e-15 m brings it to ~1e-13 s).
pub const NEAR_COINCIDENT_FRACTION: f64 = 0.5;

/// Largest gap cutoff (in units of the mean radius R̄) that a
/// [`BondingRule::Coordination`] target may need; a target not reached with every pair
/// within this gap is refused.
pub const COORDINATION_MAX_GAP: f64 = 1.0;

/// The bonds of `packing` under `rule`, sorted canonically by `(i, j, image)`.
///
/// - `Gap(g)`: |l| − (R_i + R_j) ≤ g·R̄ with R̄ the mean radius (Truszkowska 2018, Eq. 4).
/// - `Factor(κ)`: |l| ≤ κ·(R_i + R_j) (Kumar 2016, Eq. 10; Šmilauer's contact radius I_R).
/// - `Coordination(Z)`: the gap cutoff whose bond count gives Z = 2·N_b/N as closely as
///   the discrete counts allow (see [`coordination_gap`]).
///
/// Errors on a value that is not finite and > 0, on coincident spheres (a bond needs a
/// non-zero branch vector) and on near-coincident ones (see `NEAR_COINCIDENT_FRACTION`).
pub fn build_bonds(packing: &Packing, rule: BondingRule) -> Result<BondSet> {
    let pairs = match rule {
        BondingRule::Gap(g) => {
            check_rule_value("gap", g)?;
            gap_pairs(packing, g)?
        }
        BondingRule::Factor(kappa) => {
            check_rule_value("factor", kappa)?;
            let r_max = packing.radii.iter().copied().fold(0.0, f64::max);
            pairs_within_centre_distance(packing, kappa * 2.0 * r_max, |ri, rj, dist| {
                dist <= kappa * (ri + rj)
            })?
        }
        BondingRule::Coordination(z) => {
            check_rule_value("coordination", z)?;
            coordination_selection(packing, z)?.1
        }
    };
    bonds_from_pairs(packing, &pairs)
}

/// The gap cutoff g (in units of R̄, Truszkowska 2018 Eq. 4) at which the bonded packing
/// reaches the mean coordination `target_z` = 2·N_b/N as closely as the discrete bond
/// counts allow. The value returned lies midway between the gap of the last pair bonded
/// and the next one, so `BondingRule::Gap(g)` rebuilds the same bonds.
///
/// The candidate pairs are found within a gap of 0.3·R̄ and sorted by gap, and again
/// within [`COORDINATION_MAX_GAP`]·R̄ only when those do not settle the count. Errors if
/// the target exceeds the coordination reached with every candidate by more than one
/// bond.
pub fn coordination_gap(packing: &Packing, target_z: f64) -> Result<f64> {
    check_rule_value("coordination", target_z)?;
    Ok(coordination_selection(packing, target_z)?.0)
}

fn check_rule_value(name: &str, value: f64) -> Result<()> {
    if !value.is_finite() || value <= 0.0 {
        return Err(Error::Model(format!(
            "bonding rule `{name}`: value must be finite and > 0, got {value}"
        )));
    }
    Ok(())
}

fn gap_pairs(packing: &Packing, g: f64) -> Result<Vec<Pair>> {
    let max_gap = g * packing.mean_radius();
    pairs_within(packing, |_, _| max_gap, max_gap)
}

/// The coordination rule's first candidate search reaches gaps up to this · R̄: enough for
/// the coordinations of bonded-particle models on dense packings (Z = 7.5 needs 0.16 R̄ on
/// the standard assembly, whose candidates within [`COORDINATION_MAX_GAP`] are 1.6 times as
/// many), widened to [`COORDINATION_MAX_GAP`] when the count it gives could differ.
const COORDINATION_FIRST_GAP: f64 = 0.3;

/// (gap cutoff / R̄, selected pairs) for a coordination target: the first `k` pairs by gap,
/// `k` the count nearest the target N·Z/2 at which the gap strictly increases. Found among
/// the candidates within [`COORDINATION_FIRST_GAP`] when they settle it, else among all
/// within [`COORDINATION_MAX_GAP`]: the same pairs and cutoff either way.
fn coordination_selection(packing: &Packing, target_z: f64) -> Result<(f64, Vec<Pair>)> {
    let n = packing.len();
    if n < 2 {
        return Err(Error::Model(format!(
            "bonding rule `coordination`: a packing of {n} sphere(s) cannot reach Z = {target_z}"
        )));
    }
    let target_bonds = target_z * n as f64 / 2.0;
    if let Ok(ranked) = ranked_candidates(packing, COORDINATION_FIRST_GAP) {
        // Every pair outside this search has a gap > FIRST·R̄, so it sorts after the pairs
        // below FIRST·(1 − 1e-9): those begin the complete ranking too.
        let settled = ranked.partition_point(|(g, _)| *g < COORDINATION_FIRST_GAP * (1.0 - 1e-9));
        let (k, miss) = nearest_count(&ranked[..settled], target_bonds, false);
        // Any count at or past `settled` misses by at least settled − target.
        if k > 0 && miss < settled as f64 - target_bonds {
            return Ok(selected(ranked, k, false));
        }
    }
    let ranked = ranked_candidates(packing, COORDINATION_MAX_GAP)?;
    let m = ranked.len();
    if (m as f64) < target_bonds - 1.0 {
        return Err(Error::Model(format!(
            "bonding rule `coordination`: target Z = {target_z} is unreachable; bonding every \
             pair with a gap up to {COORDINATION_MAX_GAP}·R̄ gives only Z = {:.4}",
            2.0 * m as f64 / n as f64
        )));
    }
    let (k, _) = nearest_count(&ranked, target_bonds, true);
    Ok(selected(ranked, k, true))
}

/// The pairs with a gap up to `g`·R̄, each with its gap / R̄, sorted by gap; ties broken by
/// the canonical order (each pair's (i, j, image) is its own), so the order is unique: a
/// parallel unstable sort gives it on any thread count.
fn ranked_candidates(packing: &Packing, g: f64) -> Result<Vec<(f64, Pair)>> {
    let r_mean = packing.mean_radius();
    let candidates = gap_pairs(packing, g)?;
    let mut ranked: Vec<(f64, Pair)> = candidates
        .into_par_iter()
        .map(|p| (p.gap(packing) / r_mean, p))
        .collect();
    ranked.par_sort_unstable_by(|a, b| {
        a.0.total_cmp(&b.0)
            .then((a.1.i, a.1.j, a.1.image).cmp(&(b.1.i, b.1.j, b.1.image)))
    });
    Ok(ranked)
}

/// (k, |k − target|) for the admissible count k nearest `target` (the first on a tie; 0
/// when none is nearer than none at all): a cutoff can separate the first k pairs of
/// `ranked` from the rest only where the gap strictly increases, and past the last one
/// only when `ranked` holds every candidate (`complete`).
fn nearest_count(ranked: &[(f64, Pair)], target: f64, complete: bool) -> (usize, f64) {
    let m = ranked.len();
    let mut best = (0usize, target);
    for k in 1..=m {
        let admissible = if k < m {
            ranked[k - 1].0 < ranked[k].0
        } else {
            complete
        };
        let miss = (k as f64 - target).abs();
        if admissible && miss < best.1 {
            best = (k, miss);
        }
    }
    best
}

/// (cutoff / R̄, the first `k` pairs of `ranked` in canonical order): the cutoff midway
/// between the last pair bonded and the next ([`COORDINATION_MAX_GAP`] past the last of a
/// `complete` ranking; below the first pair when k = 0).
fn selected(mut ranked: Vec<(f64, Pair)>, k: usize, complete: bool) -> (f64, Vec<Pair>) {
    let gap = if k == ranked.len() && complete {
        COORDINATION_MAX_GAP
    } else if k == 0 {
        ranked[0].0 - 0.5 * ranked[0].0.abs().max(1e-12)
    } else {
        0.5 * (ranked[k - 1].0 + ranked[k].0)
    };
    ranked.truncate(k);
    let mut pairs: Vec<Pair> = ranked.into_iter().map(|(_, p)| p).collect();
    pairs.par_sort_unstable_by_key(|p| (p.i, p.j, p.image));
    (gap, pairs)
}

/// Turn found pairs into bonds, refusing zero-length branch vectors and near-coincident
/// spheres ([`NEAR_COINCIDENT_FRACTION`]), naming both (0-based index, position, radius).
fn bonds_from_pairs(packing: &Packing, pairs: &[Pair]) -> Result<BondSet> {
    let describe = |k: u32| {
        let (x, r) = (packing.positions[k as usize], packing.radii[k as usize]);
        format!(
            "sphere {k} at ({:e}, {:e}, {:e}) m, radius {r:e} m",
            x.x, x.y, x.z
        )
    };
    let mut bonds = BondSet::default();
    for p in pairs {
        let len = p.distance();
        if len == 0.0 || !len.is_finite() {
            return Err(Error::Invalid(format!(
                "spheres {} and {} are coincident (centre distance {len}): a bond needs a \
                 non-zero branch vector ({}; {}; indices 0-based)",
                p.i,
                p.j,
                describe(p.i),
                describe(p.j)
            )));
        }
        let radii = packing.radii[p.i as usize] + packing.radii[p.j as usize];
        if len < NEAR_COINCIDENT_FRACTION * radii {
            return Err(Error::Invalid(format!(
                "spheres {} and {} are near-coincident: centre distance {len:.3e} m is less than \
                 {NEAR_COINCIDENT_FRACTION} × the sum of their radii ({radii:.3e} m), so one \
                 centre lies (nearly) inside the other sphere ({}; {}; indices 0-based). No DEM \
                 packing overlaps like that — a duplicated or mistyped particle? Its bond would \
                 be far shorter and stiffer than the others and collapse the critical time step",
                p.i,
                p.j,
                describe(p.i),
                describe(p.j)
            )));
        }
        bonds.push(p.i, p.j, p.branch, p.image);
    }
    bonds.sort_canonical();
    Ok(bonds)
}
