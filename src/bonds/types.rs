//! Bond types: the per-bond springs (k_n, k_s, k_r, k_tw) quantised into at most K sets, for
//! codes that take springs per bond *type* (LAMMPS `bond_coeff`, [`crate::export::lammps`]).
//!
//! When the springs take at most K distinct values the types are those values and nothing
//! is lost ([`BondTypes::exact`]). Otherwise the bonds are clustered by Lloyd's k-means,
//! deterministically, on the error that matters for the tensor rather than on the springs'
//! scatter: a bond's springs enter its stored energy under a strain ε as k_n·(l·ε)² and
//! k_s·(l·ε)², and its rotational springs as k_r·θ², k_tw·θ², so the cost of giving bond b
//! the springs q is
//!
//! ```text
//! d_b(q)² = l_b⁴ (k_n,b − q_n)² + l_b⁴ (k_s,b − q_s)² + (k_r,b − q_r)² + (k_tw,b − q_tw)²
//! ```
//!
//! (every term in J², one energy scale per spring); k-means minimises Σ_b d_b(q_type(b))².
//! A stiff bond's relative error is kept smaller than a soft one's, because it weighs more
//! in the tensor. Each centre is the minimiser over its bonds (the l⁴-weighted mean of k_n
//! and k_s, the plain mean of k_r and k_tw).
//!
//! The final springs of a type are its bonds' means weighted by l² for k_n and k_s (plain
//! for k_r and k_tw): Σ_b l_b²·k_n,b and Σ_b l_b²·k_s,b over each type are unchanged, and
//! with them the two isotropic invariants of the Voigt sum
//! ([`crate::homogenize::voigt::voigt_tensor`]: its bulk modulus is Σ l² k_n / 9V), so the
//! quantisation error of the tensor is in its anisotropic part and in the relaxation.
//!
//! These are the affine weights w_b = (l², l², 1, 1) of d_b² = Σ_c w_b,c² Δk_c²
//! ([`affine_weights`]). [`quantise_weighted`] takes any weights; [`sensitivity_weights`]
//! gives those of the relaxed solution (V × the derivative of the tensor's trace with respect
//! to each spring), which count the relaxation too.
//!
//! Determinism: the first centre is the bond nearest the overall (weighted) centre, each next
//! one the bond farthest (largest d²) from the centres so far, ties to the lower bond index;
//! then Lloyd's iterations until no bond changes type (at most [`MAX_ITERATIONS`]). A centre
//! left without bonds is re-seeded at the bond farthest from its own centre. The result does
//! not depend on the thread count.

use super::{BondSet, BondStiffness};
use crate::{Error, Result};
use rayon::prelude::*;
use std::collections::HashMap;

/// Lloyd iterations at most (each lowers the cost; they stop when no bond changes type).
pub const MAX_ITERATIONS: usize = 200;

/// Bonds per parallel work item of the assignment step.
const CHUNK: usize = 4096;

/// Every bond's type and every type's springs.
#[derive(Clone, Debug, PartialEq)]
pub struct BondTypes {
    /// The type (0-based) of each bond.
    pub type_of: Vec<u32>,
    /// Springs of each type: `[k_n, k_s, k_r, k_tw]` (N/m, N/m, N·m/rad, N·m/rad).
    pub springs: Vec<[f64; 4]>,
    /// Distinct spring sets `[k_n, k_s, k_r, k_tw]` among the bonds (bit for bit).
    pub distinct: usize,
    /// True when every bond keeps its own springs exactly (K ≥ [`BondTypes::distinct`]).
    pub exact: bool,
    /// Lloyd iterations run (0 when exact).
    pub iterations: usize,
}

impl BondTypes {
    /// Number of types.
    pub fn len(&self) -> usize {
        self.springs.len()
    }

    /// True when there are no types (no bonds).
    pub fn is_empty(&self) -> bool {
        self.springs.is_empty()
    }

    /// The springs every bond gets: its type's (bond radii kept).
    pub fn stiffness(&self, exact: &BondStiffness) -> BondStiffness {
        let pick = |c: usize| -> Vec<f64> {
            self.type_of
                .iter()
                .map(|&t| self.springs[t as usize][c])
                .collect()
        };
        BondStiffness {
            radius: exact.radius.clone(),
            kn: pick(0),
            ks: pick(1),
            kr: pick(2),
            ktw: pick(3),
        }
    }
}

fn springs_of(k: &BondStiffness, b: usize) -> [f64; 4] {
    [k.kn[b], k.ks[b], k.kr[b], k.ktw[b]]
}

/// d_b(q)² = Σ_c w_c² (k_c − q_c)² of the module doc.
fn cost<const N: usize>(s: &[f64; N], w: &[f64; N], q: &[f64; N]) -> f64 {
    (0..N).map(|c| (w[c] * (s[c] - q[c])).powi(2)).sum()
}

/// The affine weights of the module doc: `[l², l², 1, 1]` per bond.
pub fn affine_weights(bonds: &BondSet) -> Vec<[f64; 4]> {
    bonds
        .length
        .iter()
        .map(|l| [l * l, l * l, 1.0, 1.0])
        .collect()
}

/// Quantise the springs `k` of `bonds` into at most `max_types` types (module doc). Refuses
/// `max_types` = 0, no bonds, and a spring that is negative or not finite (naming the bond).
pub fn quantise(bonds: &BondSet, k: &BondStiffness, max_types: usize) -> Result<BondTypes> {
    quantise_weighted(bonds, k, max_types, &affine_weights(bonds))
}

/// [`quantise`] with each bond's weights w_b = `[w_n, w_s, w_r, w_tw]` (≥ 0, finite) in
/// d_b(q)² = Σ_c w_b,c² (k_b,c − q_c)², and a type's springs the w-weighted means of its
/// bonds' (plain means where its weights are all 0). With w_b,c = V·∂(trace C)/∂k_b,c
/// ([`sensitivity_weights`]) every type keeps the first-order trace of the tensor.
pub fn quantise_weighted(
    bonds: &BondSet,
    k: &BondStiffness,
    max_types: usize,
    weights: &[[f64; 4]],
) -> Result<BondTypes> {
    check_quantise_inputs(bonds, k, max_types, weights)?;
    let rows: Vec<[f64; 4]> = (0..bonds.len()).map(|b| springs_of(k, b)).collect();
    let t = quantise_rows(&rows, weights, max_types);
    Ok(BondTypes {
        type_of: t.type_of,
        springs: t.centres,
        distinct: t.distinct,
        exact: t.exact,
        iterations: t.iterations,
    })
}

/// Rows of N values per bond quantised into types: the clustering of [`quantise_weighted`]
/// for any number of columns (the springs, or springs and strengths jointly,
/// [`quantise_joint`]).
struct RowTypes<const N: usize> {
    type_of: Vec<u32>,
    centres: Vec<[f64; N]>,
    distinct: usize,
    exact: bool,
    iterations: usize,
}

/// The clustering of the module doc on `rows` (one per bond, checked by the caller) with
/// the weights `w`: exact when at most `max_types` distinct rows, else Lloyd's k-means, the
/// final centres the w-weighted means, empty types dropped and the rest renumbered.
fn quantise_rows<const N: usize>(
    rows: &[[f64; N]],
    w: &[[f64; N]],
    max_types: usize,
) -> RowTypes<N> {
    let (distinct, of_distinct) = distinct_rows(rows);
    if distinct.len() <= max_types {
        return RowTypes {
            type_of: of_distinct,
            distinct: distinct.len(),
            centres: distinct,
            exact: true,
            iterations: 0,
        };
    }
    let s = rows;
    let mut centres = farthest_first_centres(s, w, max_types);
    let iterations = refine_centres(s, w, &mut centres);
    let type_of = assign(s, w, &centres);

    // Final springs: w-weighted means (w, not w²: the first-order sum Σ w·Δk over a type
    // is 0); types left empty are dropped and the rest renumbered in order.
    let members = members_of(&type_of, centres.len());
    let mut renumber = vec![u32::MAX; centres.len()];
    let mut finals = Vec::new();
    for (t, m) in members.iter().enumerate() {
        if !m.is_empty() {
            renumber[t] = finals.len() as u32;
            finals.push(centre(s, w, m.iter().copied(), 1));
        }
    }
    RowTypes {
        type_of: type_of.iter().map(|&t| renumber[t as usize]).collect(),
        centres: finals,
        distinct: distinct.len(),
        exact: false,
        iterations,
    }
}

/// Springs and breaking limits quantised jointly into at most `max_types` types (LAMMPS
/// `bond_coeff` carries both per type): each bond's row is its four springs and its four
/// limits `limits[b]` (any unit, each > 0), with the cost
///
/// ```text
/// d_b(q)² = Σ_springs (w_b,c Δk_c)² / S + Σ_limits (Δf_c / f̄_c)²
/// ```
///
/// S = the mean over the bonds of Σ_c (w_b,c k_b,c)² (the springs' energy scale, with the
/// spring weights `spring_weights`, e.g. [`affine_weights`]) and f̄_c the mean of limit c:
/// both parts are relative errors, a spring's as in [`quantise_weighted`] and a limit's
/// against its mean. A type's springs are its bonds' w-weighted means (as
/// [`quantise_weighted`]), its limits their plain means. Returns the types (springs per
/// type) and each type's limits. Exact when the bonds have at most `max_types` distinct rows.
pub fn quantise_joint(
    bonds: &BondSet,
    k: &BondStiffness,
    limits: &[[f64; 4]],
    max_types: usize,
    spring_weights: &[[f64; 4]],
) -> Result<(BondTypes, Vec<[f64; 4]>)> {
    check_quantise_inputs(bonds, k, max_types, spring_weights)?;
    let n = bonds.len();
    if limits.len() != n {
        return Err(Error::Invalid(format!(
            "bond types: {n} bonds with {} sets of breaking limits",
            limits.len()
        )));
    }
    for (b, f) in limits.iter().enumerate() {
        if f.iter().any(|v| !(v.is_finite() && *v > 0.0)) {
            return Err(Error::Invalid(format!(
                "bond types: bond {b} has breaking limits {f:?}; each must be finite and > 0"
            )));
        }
    }
    let scale = (0..n)
        .map(|b| {
            let s = springs_of(k, b);
            (0..4)
                .map(|c| (spring_weights[b][c] * s[c]).powi(2))
                .sum::<f64>()
        })
        .sum::<f64>()
        / n as f64;
    let spring_norm = if scale > 0.0 && scale.is_finite() {
        1.0 / scale.sqrt()
    } else {
        0.0
    };
    let mean: [f64; 4] =
        std::array::from_fn(|c| limits.iter().map(|f| f[c]).sum::<f64>() / n as f64);
    let rows: Vec<[f64; 8]> = (0..n)
        .map(|b| {
            let s = springs_of(k, b);
            std::array::from_fn(|c| if c < 4 { s[c] } else { limits[b][c - 4] })
        })
        .collect();
    let w: Vec<[f64; 8]> = spring_weights
        .iter()
        .map(|sw| {
            std::array::from_fn(|c| {
                if c < 4 {
                    sw[c] * spring_norm
                } else {
                    1.0 / mean[c - 4]
                }
            })
        })
        .collect();
    let t = quantise_rows(&rows, &w, max_types);
    let springs = t.centres.iter().map(|r| [r[0], r[1], r[2], r[3]]).collect();
    let type_limits = t.centres.iter().map(|r| [r[4], r[5], r[6], r[7]]).collect();
    Ok((
        BondTypes {
            type_of: t.type_of,
            springs,
            distinct: t.distinct,
            exact: t.exact,
            iterations: t.iterations,
        },
        type_limits,
    ))
}

/// Refuse what [`quantise_weighted`] cannot type: no types, no bonds, counts of springs or
/// weights that differ from the bonds', a spring or weight that is negative or not finite.
fn check_quantise_inputs(
    bonds: &BondSet,
    k: &BondStiffness,
    max_types: usize,
    weights: &[[f64; 4]],
) -> Result<()> {
    if max_types == 0 {
        return Err(Error::Invalid(
            "bond types: the number of types must be at least 1, got 0".into(),
        ));
    }
    let n = bonds.len();
    if n == 0 || k.len() != n {
        return Err(Error::Invalid(format!(
            "bond types: {n} bonds with {} spring sets",
            k.len()
        )));
    }
    if weights.len() != n {
        return Err(Error::Invalid(format!(
            "bond types: {n} bonds with {} weights",
            weights.len()
        )));
    }
    for (b, &w) in weights.iter().enumerate() {
        let s = springs_of(k, b);
        if s.iter().chain(&w).any(|v| !(v.is_finite() && *v >= 0.0)) {
            return Err(Error::Invalid(format!(
                "bond types: bond {b} has springs {s:?} and weights {w:?}; each must be \
                 finite and ≥ 0"
            )));
        }
    }
    Ok(())
}

/// The distinct rows in order of first appearance (−0 and +0 the same, otherwise bit for
/// bit), and each bond's index among them.
fn distinct_rows<const N: usize>(rows: &[[f64; N]]) -> (Vec<[f64; N]>, Vec<u32>) {
    let mut index: HashMap<[u64; N], u32> = HashMap::new();
    let mut distinct: Vec<[f64; N]> = Vec::new();
    let mut of_distinct = Vec::with_capacity(rows.len());
    for s in rows {
        let key = s.map(|v| (v + 0.0).to_bits());
        let t = *index.entry(key).or_insert_with(|| {
            distinct.push(*s);
            (distinct.len() - 1) as u32
        });
        of_distinct.push(t);
    }
    (distinct, of_distinct)
}

/// Farthest-first seeding of at most `max_types` centres, from the bond nearest the
/// overall centre: each next centre the bond farthest (in d_b) from all chosen so far.
fn farthest_first_centres<const N: usize>(
    s: &[[f64; N]],
    w: &[[f64; N]],
    max_types: usize,
) -> Vec<[f64; N]> {
    let n = s.len();
    let mut centres = vec![centre(s, w, 0..n, 2)];
    let first = argmax(n, |b| -cost(&s[b], &w[b], &centres[0]));
    centres[0] = s[first];
    let mut near: Vec<f64> = (0..n).map(|b| cost(&s[b], &w[b], &centres[0])).collect();
    while centres.len() < max_types {
        let far = argmax(n, |b| near[b]);
        if near[far] <= 0.0 {
            break; // cannot happen with more distinct sets than types; kept for safety
        }
        let c = s[far];
        for b in 0..n {
            near[b] = near[b].min(cost(&s[b], &w[b], &c));
        }
        centres.push(c);
    }
    centres
}

/// The bonds of each of `types` types, by `type_of`.
fn members_of(type_of: &[u32], types: usize) -> Vec<Vec<usize>> {
    let mut members: Vec<Vec<usize>> = vec![Vec::new(); types];
    for (b, &t) in type_of.iter().enumerate() {
        members[t as usize].push(b);
    }
    members
}

/// Lloyd iterations on `centres` (at most [`MAX_ITERATIONS`]): assign each bond to its
/// nearest centre, move each centre to the minimiser of its bonds' cost (an empty one
/// re-seeded at the bond farthest from its own centre), until nothing changes. Returns
/// the iterations run.
fn refine_centres<const N: usize>(
    s: &[[f64; N]],
    w: &[[f64; N]],
    centres: &mut [[f64; N]],
) -> usize {
    let n = s.len();
    let mut type_of = vec![u32::MAX; n];
    let mut iterations = 0;
    for it in 1..=MAX_ITERATIONS {
        iterations = it;
        let next = assign(s, w, centres);
        let changed = next != type_of;
        type_of = next;
        let members = members_of(&type_of, centres.len());
        let mut reseeded = false;
        for (t, m) in members.iter().enumerate() {
            if m.is_empty() {
                let far = argmax(n, |b| cost(&s[b], &w[b], &centres[type_of[b] as usize]));
                centres[t] = s[far];
                reseeded = true;
            } else {
                centres[t] = centre(s, w, m.iter().copied(), 2);
            }
        }
        if !changed && !reseeded {
            break;
        }
    }
    iterations
}

/// The index of the largest `f(b)`, ties to the lowest index.
fn argmax(n: usize, f: impl Fn(usize) -> f64) -> usize {
    let mut best = 0;
    let mut value = f64::NEG_INFINITY;
    for b in 0..n {
        let v = f(b);
        if v > value {
            best = b;
            value = v;
        }
    }
    best
}

/// The means of the springs over `members` weighted by w^`power` (power 2: the minimiser of
/// Σ d_b(q)²; power 1: the final springs), a plain mean where the weights are all 0.
fn centre<const N: usize>(
    s: &[[f64; N]],
    w: &[[f64; N]],
    members: impl Iterator<Item = usize>,
    power: i32,
) -> [f64; N] {
    let mut num = [0.0f64; N];
    let mut den = [0.0f64; N];
    let mut plain = [0.0f64; N];
    let mut count = 0.0;
    for b in members {
        for c in 0..N {
            let wc = w[b][c].powi(power);
            num[c] += wc * s[b][c];
            den[c] += wc;
            plain[c] += s[b][c];
        }
        count += 1.0;
    }
    std::array::from_fn(|c| {
        if den[c] > 0.0 {
            num[c] / den[c]
        } else {
            plain[c] / count
        }
    })
}

/// Each bond's nearest centre (ties to the lower index), in parallel chunks.
fn assign<const N: usize>(s: &[[f64; N]], w: &[[f64; N]], centres: &[[f64; N]]) -> Vec<u32> {
    let mut out = vec![0u32; s.len()];
    out.par_chunks_mut(CHUNK).enumerate().for_each(|(c, o)| {
        for (i, t) in o.iter_mut().enumerate() {
            let b = c * CHUNK + i;
            let mut best = 0;
            let mut d = f64::INFINITY;
            for (j, q) in centres.iter().enumerate() {
                let v = cost(&s[b], &w[b], q);
                if v < d {
                    d = v;
                    best = j;
                }
            }
            *t = best as u32;
        }
    });
    out
}

/// Largest relative error of each spring `[k_n, k_s, k_r, k_tw]` when the bonds get
/// `quantised` instead of `exact`: max_b |q_b − k_b| / k_b over bonds with k_b > 0, and for a
/// bond with k_b = 0, |q_b| relative to the largest k of that spring (0 when all are 0).
pub fn spring_errors(exact: &BondStiffness, quantised: &BondStiffness) -> [f64; 4] {
    let cols = |k: &BondStiffness| [k.kn.clone(), k.ks.clone(), k.kr.clone(), k.ktw.clone()];
    let (e, q) = (cols(exact), cols(quantised));
    let mut out = [0.0f64; 4];
    for c in 0..4 {
        let max = e[c].iter().fold(0.0f64, |m, v| m.max(v.abs()));
        for (x, y) in e[c].iter().zip(&q[c]) {
            let d = (y - x).abs();
            let r = if *x > 0.0 {
                d / x
            } else if max > 0.0 {
                d / max
            } else {
                0.0
            };
            out[c] = out[c].max(r);
        }
    }
    out
}

/// Each bond's weights from the relaxed solution of the exact network: w_b,c = Σ_a δ_b,c,a²,
/// the squared deformation of spring c of bond b (normal and shear relative displacement at
/// the contact point, bending and twisting relative rotation) under unit engineering strain
/// a of the six load cases, with the particles at equilibrium. By the minimum property of
/// the relaxed tensor (envelope theorem), V·∂C_aa/∂k_b,c = δ_b,c,a², so w is V times the
/// derivative of the trace of C: the first-order change of C that counts, relaxation
/// included (a bond that the relaxation unloads weighs little; a pruned one nothing).
/// Also returns the relaxed tensor (Pa).
pub fn sensitivity_weights(
    packing: &crate::packing::Packing,
    bonds: &BondSet,
    k: &BondStiffness,
    opts: &crate::homogenize::relaxed::RelaxedOptions,
) -> Result<(Vec<[f64; 4]>, crate::tensor::Stiffness6)> {
    use crate::homogenize::network::affine_map;
    use crate::{Mat3, Vec3};
    let sol = crate::homogenize::relaxed::relaxed_solve(packing, bonds, k, opts, None)?;
    let mut index = vec![u32::MAX; packing.len()];
    for (a, &p) in sol.active.iter().enumerate() {
        index[p as usize] = a as u32;
    }
    let skew = |a: Vec3| Mat3::new(0.0, -a.z, a.y, a.z, 0.0, -a.x, -a.y, a.x, 0.0);
    let mut w = vec![[0.0f64; 4]; bonds.len()];
    w.par_iter_mut().enumerate().for_each(|(b, wb)| {
        let (i, j) = (bonds.i[b] as usize, bonds.j[b] as usize);
        let (ai, aj) = (index[i], index[j]);
        if ai == u32::MAX || aj == u32::MAX {
            return; // pruned: carries no load
        }
        let (qi, qj) = (&sol.q[ai as usize], &sol.q[aj as usize]);
        let n = bonds.normal[b];
        let l = bonds.length[b];
        let (ri, rj) = opts.lever_arm.arms(packing.radii[i], packing.radii[j], l);
        let lmap = affine_map(&(n * l));
        for a in 0..6 {
            // Fluctuation u = −Q e_a: displacements (rows 0–2) and rotations (3–5).
            let (di, oi) = (-qi.fixed_view::<3, 1>(0, a), -qi.fixed_view::<3, 1>(3, a));
            let (dj, oj) = (-qj.fixed_view::<3, 1>(0, a), -qj.fixed_view::<3, 1>(3, a));
            let (oi, oj): (Vec3, Vec3) = if opts.rotations {
                (oi, oj)
            } else {
                (Vec3::zeros(), Vec3::zeros())
            };
            // Relative displacement at the contact: L e_a + B_i u_i + B_j u_j (network.rs).
            let delta: Vec3 = lmap.column(a) - di + skew(n * ri) * oi + dj + skew(n * rj) * oj;
            let dn = n.dot(&delta);
            let rot = oj - oi;
            let tw = n.dot(&rot);
            wb[0] += dn * dn;
            wb[1] += (delta - n * dn).norm_squared();
            wb[2] += (rot - n * tw).norm_squared();
            wb[3] += tw * tw;
        }
    });
    Ok((w, sol.result.c))
}
