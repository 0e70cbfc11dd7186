//! The many-body term (issue 33, docs/manybody.md "Integrator") in the reference integrator:
//! every step, after the bond law, each particle's fitted Green–Lagrange strain gives the
//! term's energy and its pair of forces ±g_b on every bond; the particle update adds ±g_b to
//! each particle's resultant as it gathers the bond loads (no pass of its own), the energy
//! joins the ledger ([`super::Energies::manybody`]) and Σ g_b ⊗ l_b the Love stress. Built
//! once from the intact bonds; refused with breakage.
//!
//! Two passes a step, over fixed chunks (the same bits on any number of threads), with the
//! IEEE operations of [`ManyBody::gradients_into`] in the same order (so its bits): per
//! particle, F_p = Σ_b l_b ⊗ a_b with each branch vector taken from the positions as it is
//! summed (x_j − x_i, as the bond laws take it), then V·W and V·P four particles at a time;
//! per bond, g_b = (V_i P_i) a_b^i + (V_j P_j) a_b^j. Where AVX2 runs (and
//! [`super::DemOptions::simd`]), each sum of products is one packed operation per term; the
//! scalar path is checked against it bit for bit (`tests/dem/manybody.rs`).
//!
//! Memory is what the term costs (docs/manybody.md "Integrator": without it the integrator's
//! per-step data about fill the last-level cache), so its per-step arrays are lean: a_b once,
//! per bond (the fit reads it through the topology's CSR), V·P and g_b unpadded (a packed load
//! of three components reads one f64 beyond, whose lane is never used; a packed store of g_b
//! spills into the next bond's slot, written after it, and the last bond of a chunk is
//! stored by components).

use super::state::{deterministic_sum_mat3, BondTopology, Particles};
use crate::manybody::term::Lanes4;
use crate::manybody::{ManyBody, StrainMeasure};
use crate::{Error, Mat3, Result, Vec3};
use rayon::prelude::*;

/// Particles per parallel work item of the particle pass (fixed: the same bits on any
/// number of threads; each entry is written by one item).
const PARTICLE_CHUNK: usize = 256;
/// Bonds per parallel work item of the bond pass.
const BOND_CHUNK: usize = 1024;
/// Flag of an entry's other particle when its bond crosses the cell (its branch vector needs
/// H·c).
const IMAGE_LINK: u32 = 1 << 31;

/// The term and its per-step buffers.
#[derive(Clone, Debug)]
pub(crate) struct ManyBodyForces {
    term: ManyBody,
    /// Per entry of the topology's CSR (the term's, entry for entry): the bond's other
    /// particle, | [`IMAGE_LINK`] for a bond crossing the cell.
    other: Vec<u32>,
    /// V_p·W_p of the last evaluation (J).
    energy: Vec<f64>,
    /// V_p·P_p of the last evaluation, column-major (N·m), and one zero entry after the last
    /// particle's (what a packed load of its last column reads beyond it).
    piola: Vec<[f64; 9]>,
    /// g_b = ∂U/∂l_b of the last evaluation (N): the force on the bond's i end; one zero
    /// entry after the last bond's.
    gradient: Vec<[f64; 3]>,
}

/// Branch vector of bond `b`, x_j + H·c − x_i, as [`super::Simulation::branch`] (the same
/// operations, so the term sees the bits the bond laws see; H·c is skipped for the bonds
/// inside the cell, c = 0, where adding it changes no bit but a zero's sign).
#[inline(always)]
fn branch(p: &[Vec3], t: &BondTopology, h: &Mat3, periodic: bool, b: usize) -> Vec3 {
    let (i, j) = (t.i[b] as usize, t.j[b] as usize);
    let c = t.cell_dist[b];
    if periodic && crosses(&c) {
        p[j] + h * c - p[i]
    } else {
        p[j] - p[i]
    }
}

/// Whether a bond with cell distance `c` crosses the cell.
#[inline(always)]
fn crosses(c: &Vec3) -> bool {
    c.x != 0.0 || c.y != 0.0 || c.z != 0.0
}

/// What the particle pass reads: the term, the topology's CSR, the positions and the cell.
struct FitInputs<'a> {
    term: &'a ManyBody,
    start: &'a [usize],
    entries: &'a [u32],
    other: &'a [u32],
    coef: &'a [[Vec3; 2]],
    volume: &'a [f64],
    x: &'a [Vec3],
    t: &'a BondTopology,
    h: Mat3,
}

impl FitInputs<'_> {
    /// F_p = Σ_b l_b ⊗ a_b of an included particle, entry by entry (`ManyBody::fit`'s
    /// operations; l_b = x_j − x_i from whichever end p is).
    #[inline(always)]
    fn fit(&self, p: usize) -> Mat3 {
        let xp = self.x[p];
        let mut f = [0.0f64; 9];
        for k in self.start[p]..self.start[p + 1] {
            let (b, side) = (
                (self.entries[k] >> 1) as usize,
                (self.entries[k] & 1) as usize,
            );
            let q = self.other[k];
            let l = if q & IMAGE_LINK != 0 {
                branch(self.x, self.t, &self.h, true, b)
            } else if side == 0 {
                self.x[q as usize] - xp
            } else {
                xp - self.x[q as usize]
            };
            let a = &self.coef[b][side];
            for c in 0..3 {
                for r in 0..3 {
                    f[r + 3 * c] += l[r] * a[c];
                }
            }
        }
        Mat3::from_column_slice(&f)
    }

    /// The particle pass on the chunk from `base`, one particle at a time: V_p·W_p into
    /// `we`, V_p·P_p into `wp` (zero for an excluded particle).
    fn chunk(&self, base: usize, we: &mut [f64], wp: &mut [[f64; 9]]) {
        for (l, (e, pk)) in we.iter_mut().zip(wp.iter_mut()).enumerate() {
            let p = base + l;
            if !self.term.is_included(p) {
                (*e, *pk) = (0.0, [0.0; 9]);
                continue;
            }
            let (w, m) = self.term.energy_piola_of(p, &self.fit(p), self.volume[p]);
            (*e, *pk) = (w, flat(&m));
        }
    }

    /// [`chunk`](Self::chunk) with AVX2: F_p by columns, each entry's l_b·a_b[c] one packed
    /// product and sum per column; then V·W and V·P of four included particles at a time
    /// (`ManyBody::energy_piola4_avx2`, the one-lane bits), the rest one by one. At a bond's
    /// j end l_b is −(x_q − x_p) by a flip of the sign bit: x_j − x_i itself, but for the
    /// sign of a zero, which changes no bit of F (its sums start at +0, and +0 + −0 = +0).
    ///
    /// # Safety
    /// The CPU must have AVX2.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    unsafe fn chunk_avx2(&self, base: usize, we: &mut [f64], wp: &mut [[f64; 9]]) {
        use std::arch::x86_64::*;
        let mask = _mm256_set_epi64x(0, -1, -1, -1);
        // SAFETY: maskload reads only the three unmasked f64 of a Vec3.
        let load3 = |v: &Vec3| unsafe { _mm256_maskload_pd(v.as_ptr(), mask) };
        /// The sign bit to flip at each side.
        const FLIP: [f64; 2] = [0.0, -0.0];
        let grouped = self.term.tensors().len() == 1;
        let mut four = Lanes4::default();
        for l in 0..we.len() {
            let p = base + l;
            if !self.term.is_included(p) {
                (we[l], wp[l]) = (0.0, [0.0; 9]);
                continue;
            }
            let xp = load3(&self.x[p]);
            let mut col = [_mm256_setzero_pd(); 3];
            let span = self.start[p]..self.start[p + 1];
            for (&e, &q) in self.entries[span.clone()].iter().zip(&self.other[span]) {
                let (b, side) = ((e >> 1) as usize, (e & 1) as usize);
                let lb = if q & IMAGE_LINK == 0 {
                    let d = _mm256_sub_pd(load3(&self.x[q as usize]), xp);
                    _mm256_xor_pd(d, _mm256_broadcast_sd(&FLIP[side]))
                } else {
                    load3(&branch(self.x, self.t, &self.h, true, b))
                };
                let a = &self.coef[b][side];
                col[0] = _mm256_add_pd(col[0], _mm256_mul_pd(lb, _mm256_set1_pd(a.x)));
                col[1] = _mm256_add_pd(col[1], _mm256_mul_pd(lb, _mm256_set1_pd(a.y)));
                col[2] = _mm256_add_pd(col[2], _mm256_mul_pd(lb, _mm256_set1_pd(a.z)));
            }
            let mut cols = [[0.0f64; 4]; 3];
            for (c, out) in cols.iter_mut().enumerate() {
                // SAFETY: writes four f64 into a local array.
                unsafe { _mm256_storeu_pd(out.as_mut_ptr(), col[c]) };
            }
            let f = Mat3::from_fn(|r, c| cols[c][r]);
            if !grouped {
                let (w, m) = self.term.energy_piola_of(p, &f, self.volume[p]);
                (we[l], wp[l]) = (w, flat(&m));
                continue;
            }
            if four.push(l, &f, self.volume[p]) {
                // SAFETY: AVX2 is available (this function's contract); one tensor D
                // (checked above).
                unsafe {
                    self.term
                        .lanes4_avx2(&mut four, |at, e, m| (we[at], wp[at]) = (e, flat(&m)));
                }
            }
        }
        self.term
            .lanes_one_by_one(&mut four, base, |at, e, m| (we[at], wp[at]) = (e, flat(&m)));
    }
}

/// The entries of `m`, column-major.
#[inline(always)]
fn flat(m: &Mat3) -> [f64; 9] {
    std::array::from_fn(|k| m[k])
}

/// M·a for M column-major, as ((m₀ a_x + m₁ a_y) + m₂ a_z) per row.
#[inline(always)]
fn times(m: &[f64; 9], a: &Vec3) -> Vec3 {
    Vec3::from_fn(|r, _| m[r] * a[0] + m[3 + r] * a[1] + m[6 + r] * a[2])
}

/// g_b = (V_i P_i) a_b^i + (V_j P_j) a_b^j of the bonds from `base` into `out`, written out
/// (`ManyBody::gradient_in`'s operations).
fn bond_chunk(
    base: usize,
    out: &mut [[f64; 3]],
    coef: &[[Vec3; 2]],
    t: &BondTopology,
    piola: &[[f64; 9]],
) {
    for (l, g) in out.iter_mut().enumerate() {
        let b = base + l;
        let [ai, aj] = &coef[b];
        let (mi, mj) = (&piola[t.i[b] as usize], &piola[t.j[b] as usize]);
        *g = (times(mi, ai) + times(mj, aj)).into();
    }
}

/// [`bond_chunk`] with AVX2: each matrix–vector product three packed products of columns,
/// summed in the scalar order. `piola` has an entry after the last particle's.
///
/// # Safety
/// The CPU must have AVX2.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn bond_chunk_avx2(
    base: usize,
    out: &mut [[f64; 3]],
    coef: &[[Vec3; 2]],
    t: &BondTopology,
    piola: &[[f64; 9]],
) {
    use std::arch::x86_64::*;
    let Some(last) = out.len().checked_sub(1) else {
        return;
    };
    // Column c of particle p: four f64 from 9p + 3c (the fourth, the next column's first
    // entry or the zero after the last particle, lands in a lane never used).
    let at = |p: u32, c: usize| {
        debug_assert!((p as usize) + 1 < piola.len());
        // SAFETY: 9p + 3c + 4 ≤ 9(p + 2) ≤ 9·piola.len(): p is a particle, piola has one
        // entry more.
        unsafe { _mm256_loadu_pd(piola.as_ptr().cast::<f64>().add(9 * p as usize + 3 * c)) }
    };
    let times = |p: u32, a: &Vec3| {
        _mm256_add_pd(
            _mm256_add_pd(
                _mm256_mul_pd(at(p, 0), _mm256_set1_pd(a.x)),
                _mm256_mul_pd(at(p, 1), _mm256_set1_pd(a.y)),
            ),
            _mm256_mul_pd(at(p, 2), _mm256_set1_pd(a.z)),
        )
    };
    let span = base..base + out.len();
    let ends = t.i[span.clone()].iter().zip(&t.j[span.clone()]);
    let dst = out.as_mut_ptr().cast::<f64>();
    for (l, ([ai, aj], (&i, &j))) in coef[span].iter().zip(ends).enumerate() {
        let v = _mm256_add_pd(times(i, ai), times(j, aj));
        if l < last {
            // SAFETY: four f64 from 3l: g_l and the first of g_{l+1} (inside `out`, written
            // next).
            unsafe { _mm256_storeu_pd(dst.add(3 * l), v) };
        } else {
            let mut g = [0.0f64; 4];
            // SAFETY: writes four f64 into a local array.
            unsafe { _mm256_storeu_pd(g.as_mut_ptr(), v) };
            out[l] = [g[0], g[1], g[2]];
        }
    }
}

/// `f` + Σ (±g_b) over the particle's CSR `entries` (`2·bond + side`: +g_b at the bond's i
/// end, −g_b at its j end), in entry order: the term's share of a resultant, added as the
/// particle update gathers the bond loads. `g` has an entry after the last bond's; `simd`:
/// AVX2 is available.
#[inline(always)]
pub(crate) fn gather(f: Vec3, entries: &[u32], g: &[[f64; 3]], simd: bool) -> Vec3 {
    #[cfg(target_arch = "x86_64")]
    if simd {
        // SAFETY: the caller checked AVX2.
        return unsafe { gather_avx2(f, entries, g) };
    }
    let _ = simd;
    let mut f = f;
    for &e in entries {
        let sign = if e & 1 == 1 { -1.0 } else { 1.0 };
        f += Vec3::from(g[(e >> 1) as usize]) * sign;
    }
    f
}

/// [`gather`] with AVX2 (each ±g_b one packed product and sum: the same bits).
///
/// # Safety
/// The CPU must have AVX2.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn gather_avx2(f: Vec3, entries: &[u32], g: &[[f64; 3]]) -> Vec3 {
    use std::arch::x86_64::*;
    const SIGN: [f64; 2] = [1.0, -1.0];
    let mut acc = _mm256_set_pd(0.0, f.z, f.y, f.x);
    let base = g.as_ptr().cast::<f64>();
    for &e in entries {
        let b = (e >> 1) as usize;
        debug_assert!(b + 1 < g.len());
        let sign = _mm256_set1_pd(SIGN[(e & 1) as usize]);
        // SAFETY: four f64 from 3b: g_b and one more (b is a bond, g has an entry more).
        let v = unsafe { _mm256_loadu_pd(base.add(3 * b)) };
        acc = _mm256_add_pd(acc, _mm256_mul_pd(v, sign));
    }
    let mut out = [0.0f64; 4];
    // SAFETY: writes four f64 into a local array.
    unsafe { _mm256_storeu_pd(out.as_mut_ptr(), acc) };
    Vec3::new(out[0], out[1], out[2])
}

impl ManyBodyForces {
    /// The term of an integrator whose particles, bonds and cell are `particles`,
    /// `topology`, `h` (`None`: free). Refuses ([`Error::Invalid`]) the small-strain
    /// measure (not rotation invariant: a rigidly turning particle would store energy of
    /// order θ⁴ and feel spurious forces), a term of other particles or bonds, and a term
    /// whose reference is not this state (the bonds are stress-free here, so must it be).
    pub(crate) fn new(
        term: ManyBody,
        particles: &Particles,
        topology: &BondTopology,
        h: Option<&Mat3>,
    ) -> Result<Self> {
        if term.measure() == StrainMeasure::Small {
            return Err(Error::Invalid(
                "many-body term in the integrator: the small-strain measure is not rotation \
                 invariant (a rigid rotation by θ strains every particle by O(θ²) and stores \
                 energy); particles and cell rotate in a dynamic run, so use the Green–Lagrange \
                 measure (`measure = \"green-lagrange\"` in [manybody])"
                    .into(),
            ));
        }
        if term.len() != particles.len() || term.bond_count() != topology.len() {
            return Err(Error::Invalid(format!(
                "many-body term in the integrator: the term has {} particles and {} bonds, the \
                 assembly {} and {}",
                term.len(),
                term.bond_count(),
                particles.len(),
                topology.len()
            )));
        }
        let periodic = h.is_some();
        let hm = h.copied().unwrap_or_else(Mat3::zeros);
        for b in 0..topology.len() {
            let (i, j, image) = term.bond(b);
            let d = topology.cell_dist[b];
            let same_image = (0..3).all(|k| image[k] as f64 == d[k]);
            if i != topology.i[b] || j != topology.j[b] || !same_image {
                return Err(Error::Invalid(format!(
                    "many-body term in the integrator: bond {b} joins {i}–{j} (image {image:?}) \
                     in the term but {}–{} in the assembly: build the term from the same bonds",
                    topology.i[b], topology.j[b]
                )));
            }
            let l = branch(&particles.position, topology, &hm, periodic, b);
            let r = term.reference_branches()[b];
            if (l - r).norm() > 1e-9 * r.norm() {
                return Err(Error::Invalid(format!(
                    "many-body term in the integrator: bond {b}'s branch vector differs from the \
                     term's reference by {:.3e} m: the term must be built on the state the \
                     integrator starts from (where its bonds are stress-free)",
                    (l - r).norm()
                )));
            }
        }
        if particles.len() >= IMAGE_LINK as usize {
            return Err(Error::Invalid(format!(
                "many-body term in the integrator: too many particles ({})",
                particles.len()
            )));
        }
        // Each entry's other particle, in the topology's CSR order, which must be the
        // term's (both list each particle's bonds in bond order).
        let fit = term.fit_layout();
        let same_csr = fit.start == &topology.start[..]
            && fit.bond.len() == topology.entries.len()
            && fit
                .bond
                .iter()
                .zip(&topology.entries)
                .all(|(&b, &e)| b == e >> 1);
        let same_coef = topology.entries.iter().enumerate().all(|(k, &e)| {
            let c = fit.bond_coef[(e >> 1) as usize][(e & 1) as usize];
            c.map(f64::to_bits) == fit.coef[k].map(f64::to_bits)
        });
        if !same_csr || !same_coef {
            return Err(Error::Invalid(
                "many-body term in the integrator: the term lists the particles' bonds in \
                 another order than the integrator's topology"
                    .into(),
            ));
        }
        let other = topology
            .entries
            .iter()
            .map(|&e| {
                let b = (e >> 1) as usize;
                let q = if e & 1 == 0 {
                    topology.j[b]
                } else {
                    topology.i[b]
                };
                if periodic && crosses(&topology.cell_dist[b]) {
                    q | IMAGE_LINK
                } else {
                    q
                }
            })
            .collect();
        let n = particles.len();
        Ok(ManyBodyForces {
            term,
            other,
            energy: vec![0.0; n],
            piola: vec![[0.0; 9]; n + 1],
            gradient: vec![[0.0; 3]; topology.len() + 1],
        })
    }

    /// The term.
    pub(crate) fn term(&self) -> &ManyBody {
        &self.term
    }

    /// Energy and bond gradients g_b at the current positions and cell `h` (`None`: free):
    /// the particle pass, then the bond pass (see the module docs); `simd`: the AVX2 kernels
    /// may run (the same bits).
    pub(crate) fn compute(
        &mut self,
        p: &Particles,
        t: &BondTopology,
        h: Option<&Mat3>,
        simd: bool,
    ) {
        #[cfg(target_arch = "x86_64")]
        let lanes = simd && std::arch::is_x86_feature_detected!("avx2");
        #[cfg(not(target_arch = "x86_64"))]
        let lanes = {
            let _ = simd;
            false
        };
        let ManyBodyForces {
            term,
            other,
            energy,
            piola,
            gradient,
        } = self;
        let bond_coef = term.fit_layout().bond_coef;
        let fit = FitInputs {
            term,
            start: &t.start,
            entries: &t.entries,
            other,
            coef: bond_coef,
            volume: term.particle_volumes(),
            x: &p.position,
            t,
            h: h.copied().unwrap_or_else(Mat3::zeros),
        };
        const PC: usize = PARTICLE_CHUNK;
        let n = energy.len();
        energy
            .par_chunks_mut(PC)
            .zip(piola[..n].par_chunks_mut(PC))
            .enumerate()
            .for_each(|(c, (we, wp))| {
                #[cfg(target_arch = "x86_64")]
                if lanes {
                    // SAFETY: AVX2 is available (checked above).
                    return unsafe { fit.chunk_avx2(c * PC, we, wp) };
                }
                fit.chunk(c * PC, we, wp)
            });
        let piola = &piola[..];
        let nb = gradient.len() - 1;
        gradient[..nb]
            .par_chunks_mut(BOND_CHUNK)
            .enumerate()
            .for_each(|(c, out)| {
                #[cfg(target_arch = "x86_64")]
                if lanes {
                    // SAFETY: AVX2 is available (checked above); piola has its extra entry.
                    return unsafe { bond_chunk_avx2(c * BOND_CHUNK, out, bond_coef, t, piola) };
                }
                bond_chunk(c * BOND_CHUNK, out, bond_coef, t, piola)
            });
    }

    /// g_b = ∂U/∂l_b of every bond at the last [`compute`](Self::compute) (N), and a zero
    /// entry after them: the term's force on particle p is Σ_b (+g_b at i_b, −g_b at j_b)
    /// ([`gather`]).
    pub(crate) fn bond_gradients(&self) -> &[[f64; 3]] {
        &self.gradient
    }

    /// g_b = ∂U/∂l_b of bond `b` at the last [`compute`](Self::compute) (N): the term's force
    /// on the bond's i end (−g_b on its j end).
    pub(crate) fn bond_force(&self, b: usize) -> Vec3 {
        self.gradient[b].into()
    }

    /// U of the last [`compute`](Self::compute) (J), summed in particle order (the bits of
    /// `manybody::Workspace::energy`).
    pub(crate) fn energy(&self) -> f64 {
        self.energy.iter().sum()
    }

    /// Σ_b g_b ⊗ l_b (N·m) with g_b of the last evaluation and the current branch vectors:
    /// the term's share of the Love stress times V, as the bonds' Σ f_i ⊗ l (the virial of
    /// the pair of forces ±g_b; at the reference it is the nominal stress V·∂U/∂H).
    pub(crate) fn stress_sum(&self, p: &Particles, t: &BondTopology, h: Option<&Mat3>) -> Mat3 {
        let periodic = h.is_some();
        let hm = h.copied().unwrap_or_else(Mat3::zeros);
        deterministic_sum_mat3(t.len(), |b| {
            self.bond_force(b) * branch(&p.position, t, &hm, periodic, b).transpose()
        })
    }

    /// Add the term's Gershgorin row sums of its Hessian at the current state, mass-scaled
    /// as the bonds' (translation rows only: the term applies no torque), to `rows`.
    pub(crate) fn add_gershgorin(
        &self,
        rows: &mut [[f64; 6]],
        p: &Particles,
        t: &BondTopology,
        h: Option<&Mat3>,
    ) -> Result<()> {
        let periodic = h.is_some();
        let hm = h.copied().unwrap_or_else(Mat3::zeros);
        let l: Vec<Vec3> = (0..t.len())
            .map(|b| branch(&p.position, t, &hm, periodic, b))
            .collect();
        self.term.add_gershgorin_rows(&l, &p.mass, rows)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bonds::{build_bonds, BondingRule};
    use crate::dem::MassOptions;
    use crate::manybody::{DegenerateParticles, LocalTensor, ManyBodyOptions};
    use crate::packing::{generate, GenerateOptions};
    use crate::tensor::{rotation_x, rotation_z};

    /// The integrator's passes give `ManyBody::gradients_into`'s energy and g_b bit for bit,
    /// AVX2 and scalar, one tensor and one per grain, at a strained, perturbed state of a
    /// periodic packing (bonds across the cell, rattlers excluded); the padded gather gives
    /// the scalar Σ ±g_b's bits.
    #[test]
    fn passes_have_the_bits_of_gradients_into() {
        let p = generate(
            &GenerateOptions {
                n_particles: 400,
                seed: 5,
                ..Default::default()
            },
            &|_| {},
        )
        .unwrap();
        let b = build_bonds(&p, BondingRule::Gap(0.17)).unwrap();
        // A strict conditioning leaves particles out (their path is tested too).
        let options = ManyBodyOptions {
            degenerate: DegenerateParticles::Exclude,
            conditioning: 0.2,
            ..Default::default()
        };
        let d = LocalTensor::Cubic {
            c11: 2e9,
            c12: 1.2e9,
            c44: 0.5e9,
            rotation: rotation_z(0.3) * rotation_x(1.1),
        };
        let one = ManyBody::new(&p, &b, &d, &options).unwrap();
        assert!(
            !one.excluded().is_empty(),
            "the test needs excluded particles"
        );
        let d6 = one.tensor().unwrap();
        let phase = (0..p.len() as u32).map(|k| k % 3).collect();
        let grains =
            ManyBody::per_particle(&p, &b, vec![*d6, d6 * 0.5, d6 * 1.7], phase, &options).unwrap();
        let particles = Particles::from_packing(&p, &MassOptions::default()).unwrap();
        let t = BondTopology::new(&b, p.len()).unwrap();
        let h0 = Mat3::from_diagonal(&p.cell.unwrap().lengths);
        let g = Mat3::identity() + Mat3::new(1.0, 0.3, -0.2, 0.3, -0.5, 0.1, -0.2, 0.1, 0.7) * 0.01;
        let h = g * h0;
        let mut moved = particles.clone();
        for (i, x) in moved.position.iter_mut().enumerate() {
            *x = g * *x + Vec3::new((i as f64).sin(), (1.7 * i as f64).cos(), 0.3) * 1e-6;
        }
        assert!((0..t.len()).any(|k| crosses(&t.cell_dist[k])));
        for mb in [one, grains] {
            let mut ws = mb.workspace();
            let x = &moved.position;
            mb.gradients_into(|k| branch(x, &t, &h, true, k), &mut ws);
            let mut forces = ManyBodyForces::new(mb.clone(), &particles, &t, Some(&h0)).unwrap();
            let bits = |v: Vec3| v.map(f64::to_bits);
            #[cfg(target_arch = "x86_64")]
            let avx2 = std::arch::is_x86_feature_detected!("avx2");
            #[cfg(not(target_arch = "x86_64"))]
            let avx2 = false;
            for simd in [false, avx2] {
                forces.compute(&moved, &t, Some(&h), simd);
                assert_eq!(forces.energy().to_bits(), ws.energy().to_bits());
                for (k, gk) in ws.gradient.iter().enumerate() {
                    assert_eq!(bits(forces.bond_force(k)), bits(*gk), "bond {k}, {simd}");
                }
                for q in 0..p.len() {
                    let entries = &t.entries[t.start[q]..t.start[q + 1]];
                    let f0 = Vec3::new(1e-3, -2e-3, 0.5e-3);
                    let mut expect = f0;
                    for &e in entries {
                        let sign = if e & 1 == 1 { -1.0 } else { 1.0 };
                        expect += ws.gradient[(e >> 1) as usize] * sign;
                    }
                    let got = gather(f0, entries, forces.bond_gradients(), simd);
                    assert_eq!(bits(got), bits(expect), "particle {q}, simd {simd}");
                }
            }
        }
    }
}
