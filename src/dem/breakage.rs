//! Bonds that break in the integrator (issue 32; docs/strength.md, "Breaking in the
//! integrator"): one failure criterion per bond, chosen by the bond law as the engines define
//! it, judged after every force evaluation of [`super::Simulation::step`].
//!
//! - Law (a), YADE CohFrict: [`YadeAdhesion::of`] (a_n = σ_t·r², a_s = c·r², r = min(R_i,
//!   R_j); moments never break, as YADE 2023.02a), [`yade_cohfrict`].
//! - Law (d), LAMMPS bpm/rotational: [`BpmLimits::of`] (f_rc = σ_t·π̂R_b², …), [`lammps_bpm`]
//!   (B ≥ 1).
//! - Laws (b) parallel bond and (c) Kumar: [`ParallelBondSection::of`] (Potyondy & Cundall
//!   2004), [`parallel_bond`].
//! - Bonds crossing a plane of weakness ([`BondStrengths::joint_of`]):
//!   [`JointLimits::on_section`] (the family's joint section), the bond's force on j resolved on the plane ([`resolve_on_plane`]), [`joint`].
//!
//! R_b and π̂ are the model's `[geometry]` ([`Geometry::bond_radius`], `pi_hat`).

use super::laws::{BondLaw, BOND_CHUNK};
use super::state::Particles;
use super::LawKind;
use crate::bonds::BondSet;
use crate::packing::Packing;
use crate::schemes::Geometry;
use crate::strength::criteria::{
    joint, lammps_bpm, parallel_bond, resolve_on_plane, yade_cohfrict, BpmLimits, JointLimits,
    ParallelBondSection, YadeAdhesion, YadeMoments,
};
use crate::strength::{BondStrengths, Failure, LocalLoads, Mode};
use crate::{Error, Result, Vec3};

/// Per-thread buffers of [`BondCriteria::failed_in_chunk`]: one chunk's force norms and
/// local loads.
#[derive(Default)]
struct ChunkScratch {
    normal: Vec<f64>,
    shear_sq: Vec<f64>,
    local: Vec<LocalLoads>,
    bpm: Vec<[f64; 4]>,
    /// Bonds of the chunk that LAMMPS's quick test did not clear (AVX2 path).
    uncleared: Vec<usize>,
}

/// The quick test of LAMMPS's criterion ([`lammps_bpm`]): true when the bond with elastic
/// loads `parts` = [F_r, |F_s|², |τ_b|², |τ_t|²] and `factors` = [1/f_rc, 1/f_sc², 1/τ_bc²,
/// 1/τ_tc²] surely holds, B < 1. By Cauchy–Schwarz B ≤ X + √(3·S) with X = F_r/f_rc and
/// S = |F_s|²/f_sc² + |τ_b|²/τ_bc² + |τ_t|²/τ_tc², so 3·S < (1 − X)² (by a relative 1e-9,
/// far above the rounding of either side) is enough, without the criterion's three square
/// roots and four divisions. False for NaN factors (another criterion) or loads: judged in
/// full.
#[inline(always)]
fn bpm_clearly_holds(parts: &[f64; 4], factors: &[f64; 4]) -> bool {
    let [fr, fs2, tb2, tt2] = *parts;
    let [ir, is2, ib2, it2] = *factors;
    let head = 1.0 - fr * ir;
    let rest = 3.0 * ((fs2 * is2 + tb2 * ib2) + tt2 * it2);
    head > 0.0 && rest < head * head * (1.0 - 1e-9)
}

/// [`bpm_clearly_holds`] on four bonds at once (AVX2, the same IEEE operations per lane, so
/// the same verdicts): one bit per bond, set where it surely holds.
#[cfg(target_arch = "x86_64")]
#[inline]
#[target_feature(enable = "avx2")]
fn bpm_clearly_hold4(parts: &[[f64; 4]; 4], factors: &[[f64; 4]; 4]) -> i32 {
    use super::laws::lanes::{add, gt, ld, lt, movemask, mul, select, splat, sub, transpose4};
    let rows = |a: &[[f64; 4]; 4]| transpose4([ld(a[0]), ld(a[1]), ld(a[2]), ld(a[3])]);
    let [fr, fs2, tb2, tt2] = rows(parts);
    let [ir, is2, ib2, it2] = rows(factors);
    let head = sub(splat(1.0), mul(fr, ir));
    let rest = mul(
        splat(3.0),
        add(add(mul(fs2, is2), mul(tb2, ib2)), mul(tt2, it2)),
    );
    let positive = gt(head, splat(0.0));
    let inside = lt(rest, mul(mul(head, head), splat(1.0 - 1e-9)));
    movemask(select(positive, inside, splat(0.0)))
}

/// [`bpm_clearly_hold4`] over the groups of four of a chunk: the positions `k` (in order)
/// of the bonds it does not clear, pushed to `out`; returns how many bonds it tested (the
/// rest, fewer than four, are left to the scalar test).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn bpm_not_clearly_held(parts: &[[f64; 4]], factors: &[[f64; 4]], out: &mut Vec<usize>) -> usize {
    let len = parts.len().min(factors.len());
    let mut k0 = 0;
    while k0 + 4 <= len {
        let p: &[[f64; 4]; 4] = parts[k0..k0 + 4].try_into().expect("four");
        let f: &[[f64; 4]; 4] = factors[k0..k0 + 4].try_into().expect("four");
        let held = bpm_clearly_hold4(p, f);
        if held != 0b1111 {
            out.extend((0..4).filter(|l| held >> l & 1 == 0).map(|l| k0 + l));
        }
        k0 += 4;
    }
    k0
}

/// One bond breaking in the integrator.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BreakEvent {
    /// The bond (index into the [`BondSet`]).
    pub bond: usize,
    /// The step it broke in: [`super::Simulation::iteration`] at that step's force
    /// evaluation (0 for the first step; after the step `iteration()` is `step + 1`).
    pub step: u64,
    /// Simulated time of that force evaluation (s).
    pub time: f64,
    /// How it broke.
    pub mode: Mode,
    /// The criterion's failure index at breaking (≥ 1 at the limit; see [`Failure::index`]).
    pub index: f64,
    /// Energy the break released (J), added to [`super::Energies::broken_bonds`]: the
    /// elastic energy the bond held at that evaluation, U(x(t)), plus ½·dt·P, P = Σ(F·v +
    /// T·ω) its loads' power at the half-step velocities v(t − dt/2) (the leapfrog passes a
    /// force's work on as F(t)·(x(t+dt) − x(t−dt))/2, so a force dropped at t leaves this
    /// half unpaid), less the same two terms of a contact its pair made in that step (which
    /// carries a compression on). Without these terms the ledger erred by O(dt) per break.
    pub energy: f64,
}

/// One bond's failure criterion, with its limits in the law's own units.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum BondCriterion {
    /// YADE CohFrict adhesions (law a).
    Yade(YadeAdhesion),
    /// LAMMPS bpm/rotational critical loads (law d).
    Bpm(BpmLimits),
    /// Potyondy & Cundall's parallel-bond section (laws b, c).
    ParallelBond(ParallelBondSection),
    /// A joint bond: Mohr–Coulomb with a tension cut-off on the plane of unit normal `plane`.
    Joint {
        /// The joint's limits.
        limits: JointLimits,
        /// Unit normal of the plane of weakness the bond crosses.
        plane: Vec3,
    },
}

impl BondCriterion {
    /// Judge bond `b` on the loads `law` computed at its last evaluation (`particles`: the
    /// state that evaluation saw).
    pub fn judge(&self, law: &dyn BondLaw, particles: &Particles, b: usize) -> Failure {
        match self {
            BondCriterion::Yade(a) if a.moments == YadeMoments::Elastic => {
                // Moments are not judged: the forces suffice.
                let (normal, shear) = law.bond_forces(b);
                let loads = LocalLoads {
                    normal,
                    shear: shear.norm(),
                    ..Default::default()
                };
                yade_cohfrict(a, &loads)
            }
            BondCriterion::Yade(a) => yade_cohfrict(a, &law.local_loads(particles, b)),
            BondCriterion::Bpm(l) => lammps_bpm(l, &law.local_loads(particles, b)),
            BondCriterion::ParallelBond(s) => parallel_bond(s, &law.local_loads(particles, b)),
            BondCriterion::Joint { limits, plane } => {
                let (normal, shear) = law.bond_forces(b);
                let n = law.bond_normal(b);
                let force_on_j = n * normal + shear;
                let (normal, shear) = resolve_on_plane(&force_on_j, &n, plane);
                let loads = LocalLoads {
                    normal,
                    shear,
                    ..Default::default()
                };
                joint(limits, &loads)
            }
        }
    }
}

impl BondCriterion {
    /// The shear force (N, acting on j, YADE's `shearForce`) that bond `b`, broken in `mode`
    /// at `law`'s last evaluation, hands on to its pair's frictional contact; None when that
    /// contact starts afresh with zero shear. YADE's fragile
    /// `Law2_ScGeom6D_CohFrictPhys_CohesionMoment` breaks a bond in shear without erasing the
    /// interaction: it keeps the trial shear force, caps it at max(0, F_n·tan φ) in the same
    /// step and carries on incrementally (a tension break erases it; the later YADE's moment
    /// breaks keep it as a shear break does). LAMMPS bpm/rotational, the parallel bond and
    /// joints drop the bond, so their pair's contact starts afresh.
    pub fn handed_on_shear(&self, law: &dyn BondLaw, b: usize, mode: Mode) -> Option<Vec3> {
        match (self, mode) {
            (BondCriterion::Yade(_), Mode::Shear | Mode::Bending | Mode::Twisting) => {
                Some(law.bond_forces(b).1)
            }
            _ => None,
        }
    }
}

/// The bond law's name ([`BondLaw::name`]) of a [`LawKind`].
pub(crate) fn law_name(kind: LawKind) -> &'static str {
    match kind {
        LawKind::Yade => "yade",
        LawKind::ParallelBond => "parallel-bond",
        LawKind::Kumar => "kumar",
        LawKind::LammpsBpm => "lammps-bpm",
    }
}

/// Every bond's failure criterion, aligned with the [`BondSet`], for one bond law.
#[derive(Clone, Debug, PartialEq)]
pub struct BondCriteria {
    law: LawKind,
    per_bond: Vec<BondCriterion>,
    /// Per bond, the limits of [`BondCriteria::failed_in_chunk`]'s quick test for YADE's criterion
    /// without moments, as arrays: a_n (NaN for any other criterion, which never passes), a_s, tan φ.
    screen_normal: Vec<f64>,
    screen_shear: Vec<f64>,
    screen_tan: Vec<f64>,
    /// Some bond has the quick test (else [`BondCriteria::failed_in_chunk`] needs no force norms).
    screens: bool,
    /// Some bond has LAMMPS's criterion (judged on the law's local loads of a whole chunk).
    bpm: bool,
    /// Per bond, the factors of [`BondCriteria::failed_in_chunk`]'s quick test for LAMMPS's
    /// criterion: [1/f_rc, 1/f_sc², 1/τ_bc², 1/τ_tc²] (NaN for any other criterion).
    bpm_screen: Vec<[f64; 4]>,
}

/// Entry `k` of a plane-family list of the strengths (`what`: the list, as the message names
/// it), or the error naming joint bond `b` that crosses family `k`.
fn family_entry<T: Copy>(list: &[T], b: usize, k: usize, what: &str) -> Result<T> {
    list.get(k).copied().ok_or_else(|| {
        Error::Invalid(format!(
            "breakage: bond {b} crosses plane family {k}, but the strengths carry {} {what}",
            list.len()
        ))
    })
}

impl BondCriteria {
    /// The criteria of law `law` from each bond's strength: YADE's adhesions with
    /// r = min(R_i, R_j) (law a; moments elastic as YADE 2023.02a), LAMMPS's limits (law d)
    /// or the parallel-bond section (laws b, c) with R_b and π̂ of `geometry`; a joint bond
    /// (`strengths.joint_of(b)`) takes the joint criterion on its family's plane
    /// (`strengths.plane_normals`) with its joint section (`strengths.plane_sections`, the
    /// cut one taken with the bond's initial normal). Refuses strengths or bonds that do not
    /// match the packing, a joint without its plane normal or section, and a LAMMPS limit that is not > 0 (its criterion
    /// divides by each).
    pub fn for_law(
        law: LawKind,
        strengths: &BondStrengths,
        packing: &Packing,
        bonds: &BondSet,
        geometry: &Geometry,
    ) -> Result<BondCriteria> {
        geometry.validate()?;
        if strengths.len() != bonds.len() || strengths.joint.len() != bonds.len() {
            return Err(Error::Invalid(format!(
                "breakage: {} bond strengths ({} joint tags) for {} bonds (one per bond)",
                strengths.len(),
                strengths.joint.len(),
                bonds.len()
            )));
        }
        let n = packing.len();
        let mut per_bond = Vec::with_capacity(bonds.len());
        for b in 0..bonds.len() {
            let (i, j) = (bonds.i[b] as usize, bonds.j[b] as usize);
            if i >= n || j >= n {
                return Err(Error::Invalid(format!(
                    "breakage: bond {b} joins particles {i} and {j}, but the packing has {n}"
                )));
            }
            let (ri, rj) = (packing.radii[i], packing.radii[j]);
            let rb = geometry.bond_radius(ri, rj);
            let pi_hat = geometry.pi_hat;
            let s = strengths.get(b);
            let criterion = match strengths.joint_of(b) {
                Some(k) => {
                    let plane = family_entry(
                        &strengths.plane_normals,
                        b,
                        k,
                        "plane normals (BondStrengths::plane_normals)",
                    )?;
                    let section = family_entry(
                        &strengths.plane_sections,
                        b,
                        k,
                        "joint sections (BondStrengths::plane_sections)",
                    )?;
                    BondCriterion::Joint {
                        limits: JointLimits::on_section(
                            &s,
                            rb,
                            pi_hat,
                            section,
                            &bonds.normal[b],
                            &plane,
                        ),
                        plane,
                    }
                }
                None => match law {
                    LawKind::Yade => BondCriterion::Yade(YadeAdhesion::of(&s, ri, rj, false)),
                    LawKind::LammpsBpm => {
                        let l = BpmLimits::of(&s, rb, pi_hat);
                        for (name, v) in [
                            ("f_rc", l.f_rc),
                            ("f_sc", l.f_sc),
                            ("tau_bc", l.t_bc),
                            ("tau_tc", l.t_tc),
                        ] {
                            if !(v.is_finite() && v > 0.0) {
                                return Err(Error::Model(format!(
                                    "breakage (lammps-bpm): bond {b} has {name} = {v}; LAMMPS's \
                                     criterion needs every limit > 0 (a strength of 0 Pa?)"
                                )));
                            }
                        }
                        BondCriterion::Bpm(l)
                    }
                    LawKind::ParallelBond | LawKind::Kumar => {
                        BondCriterion::ParallelBond(ParallelBondSection::of(&s, rb, pi_hat))
                    }
                },
            };
            per_bond.push(criterion);
        }
        Ok(BondCriteria::from_criteria(law, per_bond))
    }

    /// Criteria given bond by bond (for a law's criterion with limits made elsewhere).
    pub fn from_criteria(law: LawKind, per_bond: Vec<BondCriterion>) -> BondCriteria {
        let n = per_bond.len();
        let (mut screen_normal, mut screen_shear, mut screen_tan) = (
            Vec::with_capacity(n),
            Vec::with_capacity(n),
            Vec::with_capacity(n),
        );
        for c in &per_bond {
            let (a_n, a_s, tan) = match c {
                BondCriterion::Yade(a)
                    if a.moments == YadeMoments::Elastic && !a.cohesion_disables_friction =>
                {
                    (a.normal, a.shear, a.tan_friction)
                }
                _ => (f64::NAN, f64::NAN, f64::NAN),
            };
            screen_normal.push(a_n);
            screen_shear.push(a_s);
            screen_tan.push(tan);
        }
        let bpm_screen = per_bond
            .iter()
            .map(|c| match c {
                BondCriterion::Bpm(l) => {
                    let sq = |x: f64| {
                        let inv = 1.0 / x;
                        inv * inv
                    };
                    [1.0 / l.f_rc, sq(l.f_sc), sq(l.t_bc), sq(l.t_tc)]
                }
                _ => [f64::NAN; 4],
            })
            .collect();
        BondCriteria {
            law,
            bpm_screen,
            screens: screen_normal.iter().any(|a| !a.is_nan()),
            bpm: per_bond.iter().any(|c| matches!(c, BondCriterion::Bpm(_))),
            per_bond,
            screen_normal,
            screen_shear,
            screen_tan,
        }
    }

    /// Bonds `first..first + len` (one chunk of at most [`BOND_CHUNK`] bonds) that break on
    /// the loads `law` just computed, skipping those not `intact`, pushed to `out` in bond
    /// order: [`BondCriterion::judge`] bond by bond. For YADE's criterion without moments, a
    /// bond clearly inside both limits (−F_n ≤ a_n and |F_s|² below max F_s² by a relative
    /// 1e-9, far above the rounding of |F_s|) holds without the square root and the index's
    /// divisions, on the law's [`BondLaw::bond_force_norms`] and limits read from arrays; any
    /// other is judged in full, so the verdict is the criterion's (LAMMPS's on the chunk's
    /// [`BondLaw::local_loads_chunk`], the loads [`BondCriterion::judge`] would take one call
    /// at a time). The chunk's loads go to per-thread scratch buffers, overwritten before they
    /// are read (no zeroing per chunk and step).
    pub(crate) fn failed_in_chunk(
        &self,
        law: &dyn BondLaw,
        particles: &Particles,
        first: usize,
        len: usize,
        intact: &[bool],
        out: &mut Vec<(usize, Failure)>,
    ) {
        thread_local! {
            static SCRATCH: std::cell::RefCell<ChunkScratch> =
                std::cell::RefCell::new(ChunkScratch::default());
        }
        SCRATCH.with(|s| {
            let s = &mut *s.borrow_mut();
            let end = first + len;
            let screens = self.screens;
            if screens {
                s.normal.resize(len.max(s.normal.len()), 0.0);
                s.shear_sq.resize(len.max(s.shear_sq.len()), 0.0);
                law.bond_force_norms(first, &mut s.normal[..len], &mut s.shear_sq[..len]);
            }
            // LAMMPS's criterion: the quick test `bpm_clearly_holds` on the law's elastic
            // parts, the full criterion on the bonds it does not clear.
            let quick = self.bpm && {
                s.bpm.resize(len.max(s.bpm.len()), [0.0; 4]);
                law.bpm_parts_chunk(first, &mut s.bpm[..len])
            };
            let chunk_loads = self.bpm && !quick && len <= BOND_CHUNK;
            if chunk_loads {
                s.local
                    .resize(len.max(s.local.len()), LocalLoads::default());
                law.local_loads_chunk(particles, first, &mut s.local[..len]);
            }
            let an = &self.screen_normal[first..end];
            let as_ = &self.screen_shear[first..end];
            let tan = &self.screen_tan[first..end];
            let mut k0 = 0;
            #[cfg(target_arch = "x86_64")]
            if quick && !screens && std::arch::is_x86_feature_detected!("avx2") {
                // LAMMPS's quick test four bonds at a time; the bonds it does not clear
                // judged in full, in bond order (as the loop below).
                s.uncleared.clear();
                // SAFETY: the CPU has AVX2 (checked above).
                k0 = unsafe {
                    bpm_not_clearly_held(
                        &s.bpm[..len],
                        &self.bpm_screen[first..end],
                        &mut s.uncleared,
                    )
                };
                for &k in &s.uncleared {
                    let b = first + k;
                    if intact[b] {
                        let f = self.per_bond[b].judge(law, particles, b);
                        if f.broken {
                            out.push((b, f));
                        }
                    }
                }
            }
            for k in k0..len {
                let b = first + k;
                if !intact[b] {
                    continue;
                }
                if screens {
                    // YadeAdhesion::max_shear without cohesionDisablesFriction (NaN limits of
                    // any other criterion never pass).
                    let (normal, shear_sq) = (s.normal[k], s.shear_sq[k]);
                    let max_fs = (as_[k] + normal * tan[k]).max(0.0);
                    if -normal <= an[k] && shear_sq < max_fs * max_fs * (1.0 - 1e-9) {
                        continue;
                    }
                }
                if quick && bpm_clearly_holds(&s.bpm[k], &self.bpm_screen[b]) {
                    continue;
                }
                let f = match &self.per_bond[b] {
                    BondCriterion::Bpm(l) if chunk_loads => lammps_bpm(l, &s.local[k]),
                    c => c.judge(law, particles, b),
                };
                if f.broken {
                    out.push((b, f));
                }
            }
        });
    }

    /// The bond law these criteria are for.
    pub fn law(&self) -> LawKind {
        self.law
    }

    /// Number of bonds.
    pub fn len(&self) -> usize {
        self.per_bond.len()
    }

    /// True when there are no bonds.
    pub fn is_empty(&self) -> bool {
        self.per_bond.is_empty()
    }

    /// The criterion of bond `b`.
    pub fn get(&self, b: usize) -> &BondCriterion {
        &self.per_bond[b]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A fixed pseudo-random sequence (xorshift64 from `seed`; no dependency), uniform in
    /// [0, 1).
    fn uniform_sequence(mut state: u64) -> impl FnMut() -> f64 {
        move || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 11) as f64 / (1u64 << 53) as f64
        }
    }

    /// The quick test never clears a bond that LAMMPS's criterion breaks, on loads drawn
    /// around the failure surface (B from 0.2 to 2 with every mix of the four terms, tension
    /// and compression) and on the surface itself (B = 1 to rounding); it clears every bond
    /// in tension with B ≤ ½.
    #[test]
    fn bpm_quick_test_clears_only_bonds_that_hold() {
        let lim = BpmLimits {
            f_rc: 3.0e3,
            f_sc: 7.0e3,
            t_bc: 2.0,
            t_tc: 5.0,
        };
        let factors = {
            let sq = |x: f64| (1.0 / x) * (1.0 / x);
            [1.0 / lim.f_rc, sq(lim.f_sc), sq(lim.t_bc), sq(lim.t_tc)]
        };
        let mut uniform = uniform_sequence(0x2545_f491_4f6c_dd1d);
        let (mut inside, mut cleared_inside) = (0, 0);
        for n in 0..200_000 {
            // Terms (X, Y, Z, W) with Y, Z, W ≥ 0 summing to B (X may be negative).
            let b = if n % 4 == 0 {
                1.0
            } else {
                0.2 + 1.8 * uniform()
            };
            let w = [uniform() - 0.3, uniform(), uniform() * uniform(), uniform()];
            let total: f64 = w.iter().sum();
            let t = w.map(|x| x / total * b);
            if t[1..].iter().any(|&x| x < 0.0) {
                continue;
            }
            let fr = t[0] * lim.f_rc;
            let (fs, tb, tt) = (t[1] * lim.f_sc, t[2] * lim.t_bc, t[3] * lim.t_tc);
            let parts = [fr, fs * fs, tb * tb, tt * tt];
            let exact = lammps_bpm(
                &lim,
                &LocalLoads {
                    normal: -fr,
                    shear: parts[1].sqrt(),
                    bending: parts[2].sqrt(),
                    twisting: parts[3].sqrt(),
                },
            );
            let cleared = bpm_clearly_holds(&parts, &factors);
            assert!(
                !(cleared && exact.broken),
                "cleared a bond that breaks: B = {}, terms {t:?}",
                exact.index
            );
            // In tension with B ≤ ½ the bound is at most X + √3·(B − X) ≤ √3/2 < 1: cleared.
            if exact.index <= 0.5 && t[0] >= 0.0 {
                inside += 1;
                cleared_inside += cleared as usize;
            }
        }
        assert!(inside > 1000, "{inside} bonds drawn well inside");
        assert_eq!(
            cleared_inside, inside,
            "cleared {cleared_inside} of {inside} bonds in tension with B ≤ 0.5"
        );
        // NaN factors (another criterion) and NaN loads are never cleared.
        assert!(!bpm_clearly_holds(&[0.0; 4], &[f64::NAN; 4]));
        assert!(!bpm_clearly_holds(&[f64::NAN, 0.0, 0.0, 0.0], &factors));
    }

    /// The AVX2 quick test gives the scalar test's verdict on every bond (the same IEEE
    /// operations per lane): loads and factors near the test's boundary, NaN factors and
    /// loads, in groups of four and over a chunk whose length is not a multiple of four.
    #[cfg(target_arch = "x86_64")]
    #[test]
    fn bpm_quick_test_in_lanes_is_the_scalar_test() {
        if !std::arch::is_x86_feature_detected!("avx2") {
            eprintln!("skipped: no AVX2 on this CPU");
            return;
        }
        let mut uniform = uniform_sequence(0x9e37_79b9_7f4a_7c15);
        let n = 40_003;
        let mut parts = Vec::with_capacity(n);
        let mut factors = Vec::with_capacity(n);
        for k in 0..n {
            let mut p = [2.0 * uniform() - 0.5, uniform(), uniform(), uniform()];
            let mut f = [1.0, 0.1 * uniform(), 0.1 * uniform(), 0.1 * uniform()];
            match k % 97 {
                0 => f = [f64::NAN; 4],
                1 => p[0] = f64::NAN,
                2 => p = [0.0; 4],
                _ => {}
            }
            // Some bonds exactly at 3·S = (1 − X)², where the margin decides.
            if k % 5 == 0 {
                let head = 1.0 - p[0] * f[0];
                p[3] = 0.0;
                p[2] = 0.0;
                f[1] = 1.0;
                p[1] = head * head / 3.0;
            }
            parts.push(p);
            factors.push(f);
        }
        let mut uncleared = Vec::new();
        // SAFETY: AVX2 checked above.
        let tested = unsafe { bpm_not_clearly_held(&parts, &factors, &mut uncleared) };
        assert_eq!(tested, n - n % 4);
        let expected: Vec<usize> = (0..tested)
            .filter(|&k| !bpm_clearly_holds(&parts[k], &factors[k]))
            .collect();
        assert!(expected.len() > 1000 && expected.len() < tested - 1000);
        assert_eq!(uncleared, expected);
    }
}
