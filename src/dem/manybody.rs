//! The many-body term (issue 33, docs/manybody.md "Integrator") in the reference integrator:
//! every step, after the bond law, each particle's fitted Green–Lagrange strain gives the
//! term's energy and its pair of forces ±g_b on every bond; the particle update sums each
//! particle's Σ ±g_b from zero as it gathers the bond loads ([`term_force`]: evaluate's
//! force, bit for bit) and adds it after the bond and contact loads, the energy
//! joins the ledger ([`super::Energies::manybody`]) and Σ g_b ⊗ l_b the Love stress. Built
//! once from the intact bonds; refused with breakage.
//!
//! One pass a step, over fixed chunks of particles (the same bits on any number of threads),
//! with the IEEE operations of [`ManyBody::gradients_into`] in the same order (so its bits):
//! per particle, F_p = Σ_b l_b ⊗ a_b with each branch vector taken from the positions as it
//! is summed (x_j − x_i, as the bond laws take it), then V·W and V·P four particles at a
//! time, then at once, while a_b is still in cache, the half-gradient (V_p P_p) a_b^p of each
//! of its bonds, stored at the bond's end (`2·bond + side`, the topology's entry code). The
//! particle update sums g_b = (V_i P_i) a_b^i + (V_j P_j) a_b^j, the two halves side by side,
//! which is `ManyBody::gradient_in`'s sum: no pass over the bonds, no V·P array. Where AVX2
//! runs (and [`super::DemOptions::simd`]), each sum of products is one packed operation per
//! term; the scalar path is checked against it bit for bit (`passes_have_the_bits_of_gradients_into`).
//!
//! Memory is what the term costs (docs/manybody.md "Integrator": without it the integrator's
//! per-step data about fill the last-level cache), so its per-step arrays are lean: a_b per
//! entry of the topology's CSR, read in sequence by the one pass, and so are the cell
//! distances of the bonds across the cell (a list of their own, not the topology read by
//! bond); the halves unpadded (a packed load of three components reads one f64 beyond, whose
//! lane is never used; they are stored by two and one components, as another thread may
//! write the next). Packed values are built in registers, never stored narrow and loaded
//! back wide (such a load waits for the stores to retire: no store forwarding).

use super::state::{deterministic_sum_mat3, BondTopology, Particles};
use crate::manybody::term::Lanes4;
use crate::manybody::{ManyBody, StrainMeasure};
use crate::{Error, Mat3, Result, Vec3};
use rayon::prelude::*;

/// Particles per parallel work item of the particle pass (fixed: the same bits on any
/// number of threads; each entry is written by one item).
const PARTICLE_CHUNK: usize = 256;
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
    /// The cell distances c_b of the entries flagged [`IMAGE_LINK`], in CSR order: read in
    /// sequence by the particle pass (not at random from the topology by bond).
    image: Vec<Vec3>,
    /// Per particle, its first entry in `image` (and the count at the end).
    image_start: Vec<u32>,
    /// V_p·W_p of the last evaluation (J).
    energy: Vec<f64>,
    /// Per entry code `2·bond + side`, the bond's half-gradient (V_p P_p) a_b^p at that end
    /// of the last evaluation (N): g_b = half[2b] + half[2b + 1], the force on its i end;
    /// one zero entry after the last (what a packed load of the last reads beyond it).
    half: Vec<[f64; 3]>,
}

/// Where the particle pass writes the halves: every chunk writes through one pointer, each
/// entry code by the one particle that has it (checked in [`ManyBodyForces::new`]), so no
/// two chunks write one entry.
#[derive(Clone, Copy)]
struct HalfOut(*mut [f64; 3]);

// SAFETY: the chunks write disjoint entries (see `HalfOut`), and nothing reads the halves
// while the pass runs.
unsafe impl Send for HalfOut {}
// SAFETY: as above.
unsafe impl Sync for HalfOut {}

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
    /// Per entry, a_b at the particle's end (the term's `fit_layout().coef`).
    coef: &'a [Vec3],
    volume: &'a [f64],
    x: &'a [Vec3],
    /// [`ManyBodyForces`]' `image` and `image_start`.
    image: &'a [Vec3],
    image_start: &'a [u32],
    h: Mat3,
}

impl FitInputs<'_> {
    /// l_b of a bond across the cell seen from particle `p` at its end `side`, the other
    /// particle `q`, cell distance `c`: x_j + H·c − x_i with [`branch`]'s operations.
    #[inline(always)]
    fn image_branch(&self, p: usize, q: usize, side: usize, c: &Vec3) -> Vec3 {
        let hc = self.h * c;
        if side == 0 {
            self.x[q] + hc - self.x[p]
        } else {
            self.x[p] + hc - self.x[q]
        }
    }

    /// F_p = Σ_b l_b ⊗ a_b of an included particle, entry by entry (`ManyBody::fit`'s
    /// operations; l_b = x_j − x_i from whichever end p is).
    #[inline(always)]
    fn fit(&self, p: usize) -> Mat3 {
        let xp = self.x[p];
        let mut f = [0.0f64; 9];
        let mut images = self.image[self.image_start[p] as usize..].iter();
        for k in self.start[p]..self.start[p + 1] {
            let side = (self.entries[k] & 1) as usize;
            let q = self.other[k];
            let l = if q & IMAGE_LINK != 0 {
                let c = images.next().expect("an image per flagged entry");
                self.image_branch(p, (q & !IMAGE_LINK) as usize, side, c)
            } else if side == 0 {
                self.x[q as usize] - xp
            } else {
                xp - self.x[q as usize]
            };
            let a = &self.coef[k];
            for c in 0..3 {
                for r in 0..3 {
                    f[r + 3 * c] += l[r] * a[c];
                }
            }
        }
        Mat3::from_column_slice(&f)
    }

    /// The particle pass on the chunk from `base`, one particle at a time: V_p·W_p into
    /// `we`, the halves (V_p P_p) a_b^p of its entries into `half` (zero for an excluded
    /// particle).
    fn chunk(&self, base: usize, we: &mut [f64], half: HalfOut) {
        for (l, e) in we.iter_mut().enumerate() {
            let p = base + l;
            if !self.term.is_included(p) {
                *e = 0.0;
                self.put_halves(p, half, |_| [0.0; 3]);
                continue;
            }
            let (w, m) = self.term.energy_piola_of(p, &self.fit(p), self.volume[p]);
            *e = w;
            let m = flat(&m);
            self.put_halves(p, half, |a| times(&m, a).into());
        }
    }

    /// half[code] = `of(a_b)` for each entry of particle `p`, in entry order.
    #[inline(always)]
    fn put_halves(&self, p: usize, half: HalfOut, of: impl Fn(&Vec3) -> [f64; 3]) {
        let span = self.start[p]..self.start[p + 1];
        for (&code, a) in self.entries[span.clone()].iter().zip(&self.coef[span]) {
            // SAFETY: `code` < 2·bonds < the halves' length, and only particle p has it
            // (`HalfOut`).
            unsafe { *half.0.add(code as usize) = of(a) };
        }
    }

    /// [`put_halves`](Self::put_halves) with AVX2, from the columns `c` of M = V_p P_p (the
    /// fourth lane unused): each M a_b three packed products of columns, summed as `times`
    /// sums them (the same bits), stored as two and one components (the next entry may be
    /// another thread's).
    ///
    /// # Safety
    /// The CPU must have AVX2.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    unsafe fn put_halves_avx2(&self, p: usize, c: [std::arch::x86_64::__m256d; 3], half: HalfOut) {
        use std::arch::x86_64::*;
        let span = self.start[p]..self.start[p + 1];
        for (&code, a) in self.entries[span.clone()].iter().zip(&self.coef[span]) {
            let v = _mm256_add_pd(
                _mm256_add_pd(
                    _mm256_mul_pd(c[0], _mm256_set1_pd(a.x)),
                    _mm256_mul_pd(c[1], _mm256_set1_pd(a.y)),
                ),
                _mm256_mul_pd(c[2], _mm256_set1_pd(a.z)),
            );
            let dst = half.0.add(code as usize).cast::<f64>();
            // SAFETY: three f64 of entry `code` < 2·bonds, which only particle p has
            // (`HalfOut`).
            unsafe {
                _mm_storeu_pd(dst, _mm256_castpd256_pd128(v));
                _mm_store_sd(dst.add(2), _mm256_extractf128_pd::<1>(v));
            }
        }
    }

    /// [`chunk`](Self::chunk) with AVX2: F_p by columns, each entry's l_b·a_b[c] one packed
    /// product and sum per column; then V·W and V·P of four included particles at a time
    /// (`ManyBody::energy_piola4_avx2`, the one-lane bits), the rest one by one, and each
    /// particle's halves as soon as its V·P is known (its a_b still in cache). At a bond's
    /// j end l_b is −(x_q − x_p) by a flip of the sign bit: x_j − x_i itself, but for the
    /// sign of a zero, which changes no bit of F (its sums start at +0, and +0 + −0 = +0).
    ///
    /// # Safety
    /// The CPU must have AVX2.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    unsafe fn chunk_avx2(&self, base: usize, we: &mut [f64], half: HalfOut) {
        use std::arch::x86_64::*;
        let mask = _mm256_set_epi64x(0, -1, -1, -1);
        // SAFETY: maskload reads only the three unmasked f64 of a Vec3.
        let load3 = |v: &Vec3| unsafe { _mm256_maskload_pd(v.as_ptr(), mask) };
        let last = self.x.len().saturating_sub(1);
        let xbase = self.x.as_ptr().cast::<f64>();
        // SAFETY: particle q < last has a next particle, whose first component the fourth
        // lane reads (never used); the last particle is read masked.
        let load_x = |q: usize| unsafe {
            if q < last {
                _mm256_loadu_pd(xbase.add(3 * q))
            } else {
                _mm256_maskload_pd(xbase.add(3 * q), mask)
            }
        };
        /// The sign bit to flip at each side.
        const FLIP: [f64; 2] = [0.0, -0.0];
        let grouped = self.term.tensors().len() == 1;
        let mut four = Lanes4::default();
        for l in 0..we.len() {
            let p = base + l;
            if !self.term.is_included(p) {
                we[l] = 0.0;
                self.put_halves(p, half, |_| [0.0; 3]);
                continue;
            }
            let xp = load3(&self.x[p]);
            let mut col = [_mm256_setzero_pd(); 3];
            let span = self.start[p]..self.start[p + 1];
            let coef = &self.coef[span.clone()];
            let links = self.entries[span.clone()].iter().zip(&self.other[span]);
            let mut images = self.image[self.image_start[p] as usize..].iter();
            for ((&e, &q), a) in links.zip(coef) {
                let side = (e & 1) as usize;
                let lb = if q & IMAGE_LINK == 0 {
                    debug_assert!((q as usize) < self.x.len());
                    // Every other particle is below the particle count (checked in
                    // `ManyBodyForces::new`), the positions' length (checked in `compute`):
                    // `load_x` reads within them.
                    let d = _mm256_sub_pd(load_x(q as usize), xp);
                    _mm256_xor_pd(d, _mm256_broadcast_sd(&FLIP[side]))
                } else {
                    // x_j + H·c − x_i as `image_branch` forms it, lane by lane, in registers
                    // (a Vec3 stored and loaded back stalled the load on the stores).
                    let c = images.next().expect("an image per flagged entry");
                    let hc = self.h * c;
                    let q = (q & !IMAGE_LINK) as usize;
                    let (j, i) = if side == 0 { (q, p) } else { (p, q) };
                    let hc = _mm256_set_pd(0.0, hc.z, hc.y, hc.x);
                    _mm256_sub_pd(_mm256_add_pd(load_x(j), hc), load_x(i))
                };
                col[0] = _mm256_add_pd(col[0], _mm256_mul_pd(lb, _mm256_set1_pd(a.x)));
                col[1] = _mm256_add_pd(col[1], _mm256_mul_pd(lb, _mm256_set1_pd(a.y)));
                col[2] = _mm256_add_pd(col[2], _mm256_mul_pd(lb, _mm256_set1_pd(a.z)));
            }
            let mut cols = [[0.0f64; 4]; 3];
            for (c, out) in cols.iter_mut().enumerate() {
                // SAFETY: writes four f64 into a local array.
                unsafe { _mm256_storeu_pd(out.as_mut_ptr(), col[c]) };
            }
            // SAFETY (each `put_halves_avx2` below): AVX2 is available (this function's
            // contract).
            if !grouped {
                let f = Mat3::from_fn(|r, c| cols[c][r]);
                let (w, m) = self.term.energy_piola_of(p, &f, self.volume[p]);
                we[l] = w;
                unsafe { self.put_halves_avx2(p, columns(&flat(&m)), half) };
                continue;
            }
            if four.push_columns(l, &cols, self.volume[p]) {
                // SAFETY: AVX2 is available (this function's contract); one tensor D
                // (checked above).
                unsafe {
                    self.term.lanes4_avx2_in_lanes(
                        &mut four,
                        #[inline(always)]
                        |slots, e, pk| {
                            let cols = lane_columns(pk);
                            for m in 0..4 {
                                we[slots[m]] = e[m];
                                self.put_halves_avx2(base + slots[m], cols[m], half);
                            }
                        },
                    );
                }
            }
        }
        self.term.lanes_one_by_one(
            &mut four,
            base,
            #[inline(always)]
            |at, e, m| {
                we[at] = e;
                // SAFETY: AVX2 is available (this function's contract).
                unsafe { self.put_halves_avx2(base + at, columns(&flat(&m)), half) };
            },
        );
    }
}

/// The columns of a matrix of column-major entries `m`, the fourth lane zero. Written out
/// without closures: a closure the compiler does not inline is compiled without AVX2 (the
/// `map` this replaced was a call per column, with SSE–AVX transitions and a stalled
/// reload of its result, about 15 % of the particle pass's samples).
///
/// # Safety
/// The CPU must have AVX2.
#[cfg(target_arch = "x86_64")]
#[inline]
#[target_feature(enable = "avx2")]
unsafe fn columns(m: &[f64; 9]) -> [std::arch::x86_64::__m256d; 3] {
    use std::arch::x86_64::*;
    [
        _mm256_set_pd(0.0, m[2], m[1], m[0]),
        _mm256_set_pd(0.0, m[5], m[4], m[3]),
        _mm256_set_pd(0.0, m[8], m[7], m[6]),
    ]
}

/// The columns of each of four particles' matrices from their lanes `pk` (lane m's entry
/// (r, c) at `pk[r + 3c][m]`), the fourth lane zero: three 4×4 transposes in registers
/// (`lanes::transpose4`).
/// Gathering a lane's nine entries into memory and reading them back as columns stalled each
/// wide load on the narrow stores it spanned (no store forwarding): about a fifth of the
/// particle pass's samples.
///
/// # Safety
/// The CPU must have AVX2.
#[cfg(target_arch = "x86_64")]
#[inline]
#[target_feature(enable = "avx2")]
unsafe fn lane_columns(pk: &[[f64; 4]; 9]) -> [[std::arch::x86_64::__m256d; 3]; 4] {
    use super::laws::lanes::transpose4;
    use std::arch::x86_64::*;
    let mut rows = [_mm256_setzero_pd(); 9];
    for (r, p) in rows.iter_mut().zip(pk) {
        // SAFETY: four f64 of one entry's lanes.
        *r = unsafe { _mm256_loadu_pd(p.as_ptr()) };
    }
    let z = _mm256_setzero_pd();
    let c0 = transpose4([rows[0], rows[1], rows[2], z]);
    let c1 = transpose4([rows[3], rows[4], rows[5], z]);
    let c2 = transpose4([rows[6], rows[7], rows[8], z]);
    [
        [c0[0], c1[0], c2[0]],
        [c0[1], c1[1], c2[1]],
        [c0[2], c1[2], c2[2]],
        [c0[3], c1[3], c2[3]],
    ]
}

/// The entries of `m`, column-major.
#[inline(always)]
fn flat(m: &Mat3) -> [f64; 9] {
    let mut out = [0.0; 9];
    out.copy_from_slice(m.as_slice());
    out
}

/// M·a for M column-major, as ((m₀ a_x + m₁ a_y) + m₂ a_z) per row.
#[inline(always)]
fn times(m: &[f64; 9], a: &Vec3) -> Vec3 {
    Vec3::from_fn(|r, _| m[r] * a[0] + m[3 + r] * a[1] + m[6 + r] * a[2])
}

/// The term's force on a particle, Σ (±g_b) from zero over its CSR `entries`
/// (`2·bond + side`: +g_b at the bond's i end, −g_b at its j end), in entry order, with
/// g_b = half[2b] + half[2b + 1]: `ManyBody::evaluate_into`'s per-particle force, bit for
/// bit. The particle update adds it to the resultant after the bond and contact loads; with
/// AVX2 it is summed in the bond loads' pass (`particle_lanes::gather_bond_loads_and_term`,
/// the same bits).
#[inline(always)]
pub(crate) fn term_force(entries: &[u32], half: &[[f64; 3]]) -> Vec3 {
    let mut f = Vec3::zeros();
    for &e in entries {
        let sign = if e & 1 == 1 { -1.0 } else { 1.0 };
        let b2 = (e & !1) as usize;
        f += (Vec3::from(half[b2]) + Vec3::from(half[b2 + 1])) * sign;
    }
    f
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
        // Each bond end (entry code 2·bond + side) once in the CSR: the particle pass's
        // chunks write the halves without overlap (`HalfOut`).
        let mut seen = vec![false; 2 * topology.len()];
        let mut once = topology.entries.len() == seen.len();
        for &e in &topology.entries {
            match seen.get_mut(e as usize) {
                Some(s) if !*s => *s = true,
                _ => once = false,
            }
        }
        if !once {
            return Err(Error::Invalid(
                "many-body term in the integrator: the topology does not list each bond end \
                 once"
                    .into(),
            ));
        }
        let other: Vec<u32> = topology
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
        let mut image = Vec::new();
        let mut image_start = Vec::with_capacity(n + 1);
        for p in 0..n {
            image_start.push(image.len() as u32);
            let span = topology.start[p]..topology.start[p + 1];
            for (&q, &e) in other[span.clone()].iter().zip(&topology.entries[span]) {
                if q & IMAGE_LINK != 0 {
                    image.push(topology.cell_dist[(e >> 1) as usize]);
                }
            }
        }
        image_start.push(image.len() as u32);
        // The AVX2 fit reads the positions of these particles unchecked.
        if other.iter().any(|&q: &u32| (q & !IMAGE_LINK) as usize >= n) {
            return Err(Error::Invalid(
                "many-body term in the integrator: a bond names a particle beyond the count".into(),
            ));
        }
        Ok(ManyBodyForces {
            term,
            other,
            image,
            image_start,
            energy: vec![0.0; n],
            half: vec![[0.0; 3]; 2 * topology.len() + 1],
        })
    }

    /// The term.
    pub(crate) fn term(&self) -> &ManyBody {
        &self.term
    }

    /// Energy and the bonds' halves at the current positions and cell `h` (`None`: free):
    /// the one particle pass (see the module docs); `simd`: the AVX2 kernels may run (the
    /// same bits).
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
            image,
            image_start,
            energy,
            half,
        } = self;
        // The AVX2 fit reads positions unchecked below the particle count.
        assert_eq!(
            p.position.len(),
            energy.len(),
            "many-body term: particle count"
        );
        let fit = FitInputs {
            term,
            start: &t.start,
            entries: &t.entries,
            other,
            coef: term.fit_layout().coef,
            volume: term.particle_volumes(),
            x: &p.position,
            image,
            image_start,
            h: h.copied().unwrap_or_else(Mat3::zeros),
        };
        let out = HalfOut(half.as_mut_ptr());
        const PC: usize = PARTICLE_CHUNK;
        energy.par_chunks_mut(PC).enumerate().for_each(|(c, we)| {
            #[cfg(target_arch = "x86_64")]
            if lanes {
                // SAFETY: AVX2 is available (checked above).
                return unsafe { fit.chunk_avx2(c * PC, we, out) };
            }
            fit.chunk(c * PC, we, out)
        });
    }

    /// The bonds' halves of the last [`compute`](Self::compute) (N), per entry code
    /// `2·bond + side`, and a zero entry after them: g_b = half[2b] + half[2b + 1], and the
    /// term's force on particle p is Σ_b (+g_b at i_b, −g_b at j_b) ([`gather`]).
    pub(crate) fn bond_halves(&self) -> &[[f64; 3]] {
        &self.half
    }

    /// g_b = ∂U/∂l_b of bond `b` at the last [`compute`](Self::compute) (N): the term's force
    /// on the bond's i end (−g_b on its j end).
    pub(crate) fn bond_force(&self, b: usize) -> Vec3 {
        Vec3::from(self.half[2 * b]) + Vec3::from(self.half[2 * b + 1])
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
    use crate::dem::state::BondLoad;
    use crate::dem::MassOptions;
    use crate::manybody::{DegenerateParticles, LocalTensor, ManyBodyOptions};
    use crate::packing::{generate, GenerateOptions};
    use crate::tensor::{rotation_x, rotation_z};

    /// The integrator's passes give `ManyBody::gradients_into`'s energy and g_b bit for bit,
    /// AVX2 and scalar, one tensor and one per grain, at a strained, perturbed state of a
    /// periodic packing (bonds across the cell, rattlers excluded); each particle's term force
    /// is Σ ±g_b from zero, alone and gathered with the bond loads by the lanes.
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
                // Each particle's term force: evaluate's Σ ±g_b from zero, and the same bits
                // from the lanes' gather that sums it beside (arbitrary) bond loads.
                let loads: Vec<BondLoad> = (0..t.len())
                    .map(|k| {
                        let v = |s: f64| Vec3::new((s * k as f64).sin(), s, -(s * k as f64).cos());
                        BondLoad {
                            force_i: v(1.3),
                            torque_i: v(0.7) * 1e-6,
                            torque_j: v(-2.1) * 1e-6,
                        }
                    })
                    .collect();
                for q in 0..p.len() {
                    let entries = &t.entries[t.start[q]..t.start[q + 1]];
                    let mut expect = Vec3::zeros();
                    for &e in entries {
                        let sign = if e & 1 == 1 { -1.0 } else { 1.0 };
                        expect += ws.gradient[(e >> 1) as usize] * sign;
                    }
                    let got = term_force(entries, forces.bond_halves());
                    assert_eq!(bits(got), bits(expect), "particle {q}, simd {simd}");
                    #[cfg(target_arch = "x86_64")]
                    if simd {
                        use crate::dem::particle_lanes::{
                            gather_bond_loads, gather_bond_loads_and_term,
                        };
                        let f0 = Vec3::new(1e-3, -2e-3, 0.5e-3);
                        // SAFETY: AVX2 (`avx2`); the halves hold 2·bonds + 1 entries.
                        let (f, tq, g) = unsafe {
                            gather_bond_loads_and_term(f0, entries, &loads, forces.bond_halves())
                        };
                        // SAFETY: AVX2.
                        let (f1, t1) = unsafe { gather_bond_loads(f0, entries, &loads) };
                        assert_eq!((bits(f), bits(tq)), (bits(f1), bits(t1)), "particle {q}");
                        assert_eq!(bits(g), bits(expect), "particle {q}");
                    }
                }
            }
        }
    }
}
