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
//! summed (no pass over the bonds to store them; a bond inside the cell as (x_q − x_p) ⊗ (±a_b),
//! exactly l_b ⊗ a_b), then V·W and V·P four particles at a time; per bond,
//! g_b = (V_i P_i) a_b^i + (V_j P_j) a_b^j. Where AVX2 runs (and [`super::DemOptions::simd`]),
//! three-component vectors are padded to four and each sum of products is one packed
//! operation per term; the scalar path is checked against it bit for bit
//! (`tests/dem/manybody.rs`).

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
/// Flag of a link naming a bond that crosses the cell (its branch vector needs H·c): the
/// rest of the link is the bond's index; without it, the link is the bond's other particle.
const IMAGE_LINK: u32 = 1 << 31;

/// Three components padded to four and aligned to 32 bytes: one AVX2 load or store.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
#[repr(C, align(32))]
pub(crate) struct Lane3(pub(crate) [f64; 4]);

impl Lane3 {
    #[inline(always)]
    fn vec(&self) -> Vec3 {
        Vec3::new(self.0[0], self.0[1], self.0[2])
    }
}

/// The term and its per-step buffers.
#[derive(Clone, Debug)]
pub(crate) struct ManyBodyForces {
    term: ManyBody,
    /// Per entry of the term's particle → bond CSR: the bond's other particle, or
    /// [`IMAGE_LINK`] | bond for a bond crossing the cell.
    link: Vec<u32>,
    /// Per entry: the fit coefficient a_b, negated at the bond's j end for a link to a
    /// particle ((x_i − x_j) ⊗ (−a) is l_b ⊗ a bit for bit: IEEE products are symmetric in
    /// sign), as is for an image link.
    coef: Vec<Vec3>,
    /// V_p·W_p of the last evaluation (J).
    energy: Vec<f64>,
    /// V_p·P_p of the last evaluation, by columns (N·m).
    piola: Vec<[Lane3; 3]>,
    /// g_b = ∂U/∂l_b of the last evaluation (N): the force on the bond's i end.
    gradient: Vec<Lane3>,
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

/// What the particle pass reads: the term, its links, the positions and the cell.
struct FitInputs<'a> {
    term: &'a ManyBody,
    start: &'a [usize],
    link: &'a [u32],
    coef: &'a [Vec3],
    volume: &'a [f64],
    x: &'a [Vec3],
    t: &'a BondTopology,
    h: Mat3,
}

impl FitInputs<'_> {
    /// l_b of entry `k` of particle p at `xp`, and its coefficient: (x_q − x_p, ±a_b) for a
    /// link to particle q, (l_b, a_b) for an image link.
    #[inline(always)]
    fn branch_of(&self, k: usize, xp: &Vec3) -> Vec3 {
        let q = self.link[k];
        if q & IMAGE_LINK == 0 {
            self.x[q as usize] - xp
        } else {
            branch(self.x, self.t, &self.h, true, (q & !IMAGE_LINK) as usize)
        }
    }

    /// F_p = Σ_b l_b ⊗ a_b of an included particle, entry by entry (`ManyBody::fit`'s
    /// operations).
    #[inline(always)]
    fn fit(&self, p: usize) -> Mat3 {
        let xp = self.x[p];
        let mut f = [0.0f64; 9];
        for k in self.start[p]..self.start[p + 1] {
            let l = self.branch_of(k, &xp);
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
    /// `we`, V_p·P_p into `wp` (zero for an excluded particle).
    fn chunk(&self, base: usize, we: &mut [f64], wp: &mut [[Lane3; 3]]) {
        for (l, (e, pk)) in we.iter_mut().zip(wp.iter_mut()).enumerate() {
            let p = base + l;
            if !self.term.is_included(p) {
                (*e, *pk) = (0.0, [Lane3::default(); 3]);
                continue;
            }
            let (w, m) = self.term.energy_piola_of(p, &self.fit(p), self.volume[p]);
            (*e, *pk) = (w, columns(&m));
        }
    }

    /// [`chunk`](Self::chunk) with AVX2: F_p by columns, each entry's l_b·a_b[c] one packed
    /// product and sum per column; then V·W and V·P of four included particles at a time
    /// (`ManyBody::energy_piola4_avx2`, the one-lane bits), the rest one by one.
    ///
    /// # Safety
    /// The CPU must have AVX2.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    unsafe fn chunk_avx2(&self, base: usize, we: &mut [f64], wp: &mut [[Lane3; 3]]) {
        use std::arch::x86_64::*;
        let mask = _mm256_set_epi64x(0, -1, -1, -1);
        // SAFETY: maskload reads only the three unmasked f64 of a Vec3.
        let load3 = |v: &Vec3| unsafe { _mm256_maskload_pd(v.as_ptr(), mask) };
        let grouped = self.term.tensors().len() == 1;
        let mut four = Lanes4::default();
        for l in 0..we.len() {
            let p = base + l;
            if !self.term.is_included(p) {
                (we[l], wp[l]) = (0.0, [Lane3::default(); 3]);
                continue;
            }
            let xp = load3(&self.x[p]);
            let mut col = [_mm256_setzero_pd(); 3];
            let span = self.start[p]..self.start[p + 1];
            for (&q, a) in self.link[span.clone()].iter().zip(&self.coef[span]) {
                let lb = if q & IMAGE_LINK == 0 {
                    _mm256_sub_pd(load3(&self.x[q as usize]), xp)
                } else {
                    let b = (q & !IMAGE_LINK) as usize;
                    load3(&branch(self.x, self.t, &self.h, true, b))
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
            let f = Mat3::from_fn(|r, c| cols[c][r]);
            if !grouped {
                let (w, m) = self.term.energy_piola_of(p, &f, self.volume[p]);
                (we[l], wp[l]) = (w, columns(&m));
                continue;
            }
            if four.push(l, &f, self.volume[p]) {
                // SAFETY: AVX2 is available (this function's contract); one tensor D
                // (checked above).
                unsafe {
                    self.term
                        .lanes4_avx2(&mut four, |at, e, m| (we[at], wp[at]) = (e, columns(&m)));
                }
            }
        }
        self.term.lanes_one_by_one(&mut four, base, |at, e, m| {
            (we[at], wp[at]) = (e, columns(&m))
        });
    }
}

/// The columns of `m`, padded.
#[inline(always)]
fn columns(m: &Mat3) -> [Lane3; 3] {
    std::array::from_fn(|c| Lane3([m[(0, c)], m[(1, c)], m[(2, c)], 0.0]))
}

/// g_b = (V_i P_i) a_b^i + (V_j P_j) a_b^j of the bonds from `base` into `out`, written out
/// (`ManyBody::gradient_in`'s operations).
fn bond_chunk(
    base: usize,
    out: &mut [Lane3],
    coef: &[[Vec3; 2]],
    t: &BondTopology,
    piola: &[[Lane3; 3]],
) {
    for (l, g) in out.iter_mut().enumerate() {
        let b = base + l;
        let [ai, aj] = &coef[b];
        let (mi, mj) = (&piola[t.i[b] as usize], &piola[t.j[b] as usize]);
        *g = Lane3(std::array::from_fn(|r| {
            if r == 3 {
                return 0.0;
            }
            (mi[0].0[r] * ai[0] + mi[1].0[r] * ai[1] + mi[2].0[r] * ai[2])
                + (mj[0].0[r] * aj[0] + mj[1].0[r] * aj[1] + mj[2].0[r] * aj[2])
        }));
    }
}

/// [`bond_chunk`] with AVX2: each matrix–vector product three packed products of columns,
/// summed in the scalar order.
///
/// # Safety
/// The CPU must have AVX2.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn bond_chunk_avx2(
    base: usize,
    out: &mut [Lane3],
    coef: &[[Vec3; 2]],
    t: &BondTopology,
    piola: &[[Lane3; 3]],
) {
    use std::arch::x86_64::*;
    // SAFETY: a Lane3 is four f64, 32-byte aligned.
    let ld = |v: &Lane3| unsafe { _mm256_load_pd(v.0.as_ptr()) };
    let times = |m: &[Lane3; 3], a: &Vec3| {
        _mm256_add_pd(
            _mm256_add_pd(
                _mm256_mul_pd(ld(&m[0]), _mm256_set1_pd(a.x)),
                _mm256_mul_pd(ld(&m[1]), _mm256_set1_pd(a.y)),
            ),
            _mm256_mul_pd(ld(&m[2]), _mm256_set1_pd(a.z)),
        )
    };
    let span = base..base + out.len();
    let ends = t.i[span.clone()].iter().zip(&t.j[span.clone()]);
    for ((g, [ai, aj]), (&i, &j)) in out.iter_mut().zip(&coef[span]).zip(ends) {
        let (mi, mj) = (&piola[i as usize], &piola[j as usize]);
        let v = _mm256_add_pd(times(mi, ai), times(mj, aj));
        // SAFETY: a Lane3 is four f64, 32-byte aligned.
        unsafe { _mm256_store_pd(g.0.as_mut_ptr(), v) };
    }
}

/// `f` + Σ (±g_b) over the particle's CSR `entries` (`2·bond + side`: +g_b at the bond's
/// i end, −g_b at its j end), in entry order: the term's share of a resultant, added as
/// the particle update gathers the bond loads. `simd`: AVX2 is available.
#[inline(always)]
pub(crate) fn gather(f: Vec3, entries: &[u32], g: &[Lane3], simd: bool) -> Vec3 {
    #[cfg(target_arch = "x86_64")]
    if simd {
        // SAFETY: the caller checked AVX2.
        return unsafe { gather_avx2(f, entries, g) };
    }
    let _ = simd;
    let mut f = f;
    for &e in entries {
        let sign = if e & 1 == 1 { -1.0 } else { 1.0 };
        f += g[(e >> 1) as usize].vec() * sign;
    }
    f
}

/// [`gather`] with AVX2 (each ±g_b one packed product and sum: the same bits).
///
/// # Safety
/// The CPU must have AVX2.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn gather_avx2(f: Vec3, entries: &[u32], g: &[Lane3]) -> Vec3 {
    use std::arch::x86_64::*;
    const SIGN: [f64; 2] = [1.0, -1.0];
    let mut acc = _mm256_set_pd(0.0, f.z, f.y, f.x);
    for &e in entries {
        let sign = _mm256_set1_pd(SIGN[(e & 1) as usize]);
        // SAFETY: a Lane3 is four f64, 32-byte aligned.
        let v = unsafe { _mm256_load_pd(g[(e >> 1) as usize].0.as_ptr()) };
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
        // The links of the particle pass, in the term's CSR order.
        let fit = term.fit_layout();
        let (start, inc_bond, inc_coef) = (fit.start, fit.bond, fit.coef);
        let mut link = Vec::with_capacity(inc_bond.len());
        let mut coef = Vec::with_capacity(inc_bond.len());
        for p in 0..particles.len() {
            for k in start[p]..start[p + 1] {
                let b = inc_bond[k] as usize;
                let a = inc_coef[k];
                let (i, j) = (topology.i[b] as usize, topology.j[b] as usize);
                if periodic && crosses(&topology.cell_dist[b]) {
                    link.push(IMAGE_LINK | b as u32);
                    coef.push(a);
                } else if i == p {
                    link.push(j as u32);
                    coef.push(a);
                } else {
                    link.push(i as u32);
                    coef.push(-a);
                }
            }
        }
        let n = particles.len();
        Ok(ManyBodyForces {
            term,
            link,
            coef,
            energy: vec![0.0; n],
            piola: vec![[Lane3::default(); 3]; n],
            gradient: vec![Lane3::default(); topology.len()],
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
            link,
            coef,
            energy,
            piola,
            gradient,
        } = self;
        let layout = term.fit_layout();
        let (start, bond_coef) = (layout.start, layout.bond_coef);
        let fit = FitInputs {
            term,
            start,
            link,
            coef,
            volume: term.particle_volumes(),
            x: &p.position,
            t,
            h: h.copied().unwrap_or_else(Mat3::zeros),
        };
        const PC: usize = PARTICLE_CHUNK;
        energy
            .par_chunks_mut(PC)
            .zip(piola.par_chunks_mut(PC))
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
        gradient
            .par_chunks_mut(BOND_CHUNK)
            .enumerate()
            .for_each(|(c, out)| {
                #[cfg(target_arch = "x86_64")]
                if lanes {
                    // SAFETY: AVX2 is available (checked above).
                    return unsafe { bond_chunk_avx2(c * BOND_CHUNK, out, bond_coef, t, piola) };
                }
                bond_chunk(c * BOND_CHUNK, out, bond_coef, t, piola)
            });
    }

    /// g_b = ∂U/∂l_b of every bond at the last [`compute`](Self::compute) (N), padded: the
    /// term's force on particle p is Σ_b (+g_b at i_b, −g_b at j_b) ([`gather`]).
    pub(crate) fn bond_gradients(&self) -> &[Lane3] {
        &self.gradient
    }

    /// g_b = ∂U/∂l_b of bond `b` at the last [`compute`](Self::compute) (N): the term's force
    /// on the bond's i end (−g_b on its j end).
    pub(crate) fn bond_force(&self, b: usize) -> Vec3 {
        self.gradient[b].vec()
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
            self.gradient[b].vec() * branch(&p.position, t, &hm, periodic, b).transpose()
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
