//! The soft-sphere repulsion of the packing minimisers ([`super::generate`]): a Verlet
//! list that survives the rescaling of the cell, and the per-sphere contact sums
//! F_i = −Σ_j max(0, R_i + R_j − |l|)·l/|l| (unit stiffness) with the overlap and virial
//! sums of the force-balance test and the pressure.
//!
//! The sums are taken over each sphere's neighbours in list order (ascending index), so
//! they are the same bits on any thread count. The AVX2 path ([`Spheres::contacts`], when
//! the CPU has it) computes four neighbours' branch vectors, distances (one packed square
//! root) and contact normals (packed divisions) at once — the divider is the bottleneck of
//! the scalar loop — and then adds the four contributions to the sums one by one in list
//! order: every IEEE operation is the scalar path's, so the results are bit-identical
//! (checked by the unit test below).

use super::neighbours::CellGrid;
use super::PeriodicCell;
use crate::{Error, Result, Vec3};
use rayon::prelude::*;

/// Full Verlet list whose periodic shifts are stored as integer images, so that it stays
/// valid while the cell is rescaled (shift = image · L). Each neighbour is one 4-byte entry:
/// the index in the low [`INDEX_BITS`] bits and the image (−1, 0 or 1 per axis) in the top
/// six, two bits per axis in two's complement; a pair inside the cell is a bare index.
/// Neighbours keep the canonical order of the pair search (ascending index), so the force
/// sums are the same bits as with one image per neighbour, on any thread count. Each
/// sphere's neighbours are padded to a multiple of [`LANES`] with entries for itself at the
/// image (−2, −2, −2): far out of reach, so they add exact zeros.
pub(super) struct ScaledVerletList {
    /// Neighbours of i: `j[start[i]..start[i + 1]]`, padding included.
    start: Vec<u32>,
    j: Vec<u32>,
}

/// Neighbours per group of the packed path.
const LANES: usize = 4;
/// Bits of a neighbour entry that hold the index.
const INDEX_BITS: u32 = 26;
const INDEX_MASK: u32 = (1 << INDEX_BITS) - 1;
/// Image code (x, y, z each −2) of a padding entry.
const PADDING_IMAGE: u32 = 0b10_10_10 << INDEX_BITS;

/// The image component of an entry on axis `axis` (sign-extended 2-bit field).
#[inline(always)]
fn image_component(entry: u32, axis: u32) -> i32 {
    ((entry << (4 - 2 * axis)) as i32) >> 30
}

/// The neighbours of sphere i (radius + `skin` + the other's radius in reach, minimum image
/// in the cell of sides `side`) appended to `found`, each as its index with the image code
/// (two bits per axis above [`INDEX_BITS`], read by [`image_component`]).
#[inline]
fn neighbours_of(
    i: usize,
    x: &[Vec3],
    radii: &[f64],
    skin: f64,
    side: Vec3,
    grid: &CellGrid,
    found: &mut Vec<u32>,
) {
    let xi = x[i];
    let reach = radii[i] + skin;
    grid.for_each_neighbour_cell(i, |cell_index| {
        for &j in grid.particles_in(cell_index) {
            if j as usize == i {
                continue;
            }
            // Minimum image: both ends lie in [0, L), so one shift at most.
            let mut d = x[j as usize] - xi;
            let mut code = 0u32;
            for k in 0..3 {
                let image = if d[k] > 0.5 * side[k] {
                    -1i32
                } else if d[k] < -0.5 * side[k] {
                    1
                } else {
                    0
                };
                if image != 0 {
                    d[k] += image as f64 * side[k];
                }
                code |= ((image as u32) & 0b11) << (INDEX_BITS + 2 * k as u32);
            }
            let limit = reach + radii[j as usize];
            if d.norm_squared() <= limit * limit {
                found.push(j | code);
            }
        }
    });
}

impl ScaledVerletList {
    /// Every pair of `x` (radii `radii`, positions wrapped into the cube `cell`, or free
    /// with `cell` = `None`: then no entry has an image) with |l| ≤ R_i + R_j + `skin`,
    /// found by cell lists: each sphere's neighbours in ascending index order (the order of
    /// the force sums), padded to whole groups.
    ///
    /// Only pairs in reach matter: a pair out of contact adds exact zeros, so which of
    /// them are listed does not change any sum. The list stays valid (every pair that can
    /// touch is in it) while 2·max displacement + |strain|·(2R_max + skin) ≤ skin.
    pub(super) fn build(
        x: &[Vec3],
        radii: &[f64],
        cell: Option<&PeriodicCell>,
        skin: f64,
    ) -> Result<ScaledVerletList> {
        let n = x.len();
        let r_max = radii.iter().copied().fold(0.0, f64::max);
        let cutoff = 2.0 * r_max + skin;
        // A free set has no image: an infinite side makes every shift below zero.
        let side = cell.map_or(Vec3::repeat(f64::INFINITY), |c| c.lengths);
        if (0..3).any(|k| cutoff >= 0.5 * side[k]) || skin.is_nan() || skin < 0.0 {
            return Err(Error::Invalid(format!(
                "packing preparation: neighbour cutoff {cutoff:.3} R̄ is not below half the \
                 cell side {:.3} R̄; use more particles",
                side.min()
            )));
        }
        if n > INDEX_MASK as usize {
            return Err(Error::Invalid(format!(
                "packing preparation: {n} spheres exceed the neighbour list's range (at most \
                 {INDEX_MASK})"
            )));
        }
        let grid = CellGrid::new(x, cell, cutoff);
        const BLOCK: usize = 512;
        let blocks: Vec<(Vec<u32>, Vec<u32>)> = (0..n.div_ceil(BLOCK))
            .into_par_iter()
            .map(|b| {
                let mut entries = Vec::new();
                let mut counts = Vec::with_capacity(BLOCK);
                let mut found: Vec<u32> = Vec::new();
                for i in b * BLOCK..((b + 1) * BLOCK).min(n) {
                    found.clear();
                    neighbours_of(i, x, radii, skin, side, &grid, &mut found);
                    found.sort_unstable_by_key(|e| e & INDEX_MASK);
                    let padded = found.len().next_multiple_of(LANES);
                    entries.extend_from_slice(&found);
                    entries.resize(
                        entries.len() + padded - found.len(),
                        i as u32 | PADDING_IMAGE,
                    );
                    counts.push(padded as u32);
                }
                (entries, counts)
            })
            .collect();
        ScaledVerletList::joined(n, blocks)
    }

    /// The list of `n` spheres from its blocks' (entries, per-sphere counts) in order;
    /// refuses more entries than 32-bit offsets reach.
    fn joined(n: usize, blocks: Vec<(Vec<u32>, Vec<u32>)>) -> Result<ScaledVerletList> {
        let total: usize = blocks.iter().map(|(e, _)| e.len()).sum();
        if total >= u32::MAX as usize {
            return Err(Error::Invalid(format!(
                "packing preparation: {n} spheres with {total} neighbour entries exceed the \
                 list's 32-bit range"
            )));
        }
        let mut start = Vec::with_capacity(n + 1);
        start.push(0u32);
        let mut j = Vec::with_capacity(total);
        for (entries, counts) in blocks {
            for c in counts {
                start.push(start.last().copied().unwrap_or(0) + c);
            }
            j.extend_from_slice(&entries);
        }
        Ok(ScaledVerletList { start, j })
    }

    /// Calls `pair(j, l)` for every neighbour j of i in list order (padding skipped), with
    /// the branch vector l = x_j + image·L − x_i in a cube of side L = `side`.
    #[inline(always)]
    fn for_each_neighbour(
        &self,
        i: usize,
        x: &[Vec3],
        side: f64,
        mut pair: impl FnMut(usize, Vec3),
    ) {
        for_each_entry(
            &self.j[self.start[i] as usize..self.start[i + 1] as usize],
            x[i],
            x,
            side,
            &mut pair,
        );
    }
}

/// Calls `pair(j, l)` for every neighbour entry of `entries` (padding skipped), with the
/// branch vector l = x_j + image·L − `xi` (l = x_j − x_i for image 0, as written).
#[inline(always)]
fn for_each_entry(
    entries: &[u32],
    xi: Vec3,
    x: &[Vec3],
    side: f64,
    pair: &mut impl FnMut(usize, Vec3),
) {
    for &entry in entries {
        let j = (entry & INDEX_MASK) as usize;
        if entry == j as u32 {
            pair(j, x[j] - xi);
        } else if entry & !INDEX_MASK != PADDING_IMAGE {
            let image = Vec3::new(
                image_component(entry, 0) as f64,
                image_component(entry, 1) as f64,
                image_component(entry, 2) as f64,
            );
            pair(j, x[j] + image * side - xi);
        }
    }
}

/// Force −n·δ on sphere i from neighbour j at branch vector l (distance |l| = `dist`) with
/// overlap δ = `ov` ≥ 0 (unit stiffness; δ = 0 gives exact zeros): n = l/|l|, or ±x for
/// coincident centres (opposite at the two ends, so the pair stays balanced).
#[inline(always)]
fn repulsion(i: usize, j: usize, l: Vec3, dist: f64, ov: f64) -> Vec3 {
    let n = if dist > 0.0 {
        l / dist
    } else if i < j {
        Vec3::x()
    } else {
        -Vec3::x()
    };
    -(n * ov)
}

/// One sphere's contact sums over its Verlet neighbours.
#[derive(Clone, Copy, Debug)]
pub(super) struct ParticleContacts {
    /// Repulsive force F_i (unit stiffness).
    pub force: Vec3,
    /// Σ overlaps δ (the contact force magnitudes).
    pub overlap_sum: f64,
    /// Σ δ·|l| (the pair virial, from this end).
    pub virial: f64,
    /// Neighbours in contact (δ > 0).
    pub contacts: u32,
    /// Largest R_i + R_j − |l| over the neighbours (negative when none touches; −∞ with no
    /// neighbours).
    pub worst: f64,
}

impl Default for ParticleContacts {
    fn default() -> Self {
        ParticleContacts {
            force: Vec3::zeros(),
            overlap_sum: 0.0,
            virial: 0.0,
            contacts: 0,
            worst: f64::NEG_INFINITY,
        }
    }
}

impl ParticleContacts {
    /// Add neighbour j's contribution (branch vector l, distance `dist`, reach R_i + R_j).
    /// Branch-free over contact / no contact (about half the neighbours touch, so a branch
    /// would be mispredicted often): a neighbour out of contact adds exact zeros, which
    /// leaves every sum's bits unchanged.
    #[inline(always)]
    fn add(&mut self, i: usize, j: usize, l: Vec3, dist: f64, reach: f64) {
        let gap = reach - dist;
        self.worst = self.worst.max(gap);
        let ov = gap.max(0.0);
        self.force += repulsion(i, j, l, dist, ov);
        self.overlap_sum += ov;
        self.virial += ov * dist;
        self.contacts += u32::from(ov > 0.0);
    }
}

/// The rigid container of a packing prepared for a bar (Kumar 2016 Sec. 5): the cylinder
/// ρ = √(x² + y²) = `radius` about the z axis and the planes z = 0 and z = `length`
/// (units of R̄). Each is a soft repulsive surface: a sphere overlapping it by δ is pushed
/// back by δ along its normal, as by a sphere (unit stiffness).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct Walls {
    pub radius: f64,
    pub length: f64,
}

impl ParticleContacts {
    /// Add the container's contacts of a sphere at `x` of radius `r`. A wall contact has one
    /// end but is counted as two, like a pair summed from both ends: 2δ to the overlap sum,
    /// two contacts, and 2δ·d to the virial with d = R − δ the centre's distance from the wall,
    /// so that half the virial sum is −∂E/∂ln s when positions and container scale by s
    /// about the origin. The wall's gap δ also enters the largest gap.
    fn add_walls(&mut self, x: Vec3, r: f64, walls: &Walls) {
        let rho = x.x.hypot(x.y);
        let mantle = if rho > 0.0 {
            Vec3::new(x.x / rho, x.y / rho, 0.0)
        } else {
            Vec3::x()
        };
        // (gap δ, outward normal, distance of the centre from the wall).
        for (gap, outward, d) in [
            (rho + r - walls.radius, mantle, walls.radius - rho),
            (r - x.z, -Vec3::z(), x.z),
            (x.z + r - walls.length, Vec3::z(), walls.length - x.z),
        ] {
            self.worst = self.worst.max(gap);
            if gap > 0.0 {
                self.force -= outward * gap;
                self.overlap_sum += 2.0 * gap;
                self.virial += 2.0 * gap * d;
                self.contacts += 2;
            }
        }
    }
}

/// What a force pass reads: the Verlet list, the positions and radii (units of R̄), the
/// side of the periodic cube (for a free list only the padding entries use it: it keeps
/// them out of reach) and the container's walls, if any.
#[derive(Clone, Copy)]
pub(super) struct Spheres<'a> {
    pub list: &'a ScaledVerletList,
    pub x: &'a [Vec3],
    pub radii: &'a [f64],
    pub side: f64,
    pub walls: Option<Walls>,
}

/// Whether [`Spheres::contacts`] may take the AVX2 path (checked once per force pass).
pub(super) fn lanes_available() -> bool {
    std::arch::is_x86_feature_detected!("avx2")
}

impl Spheres<'_> {
    /// Contact sums of sphere i (cube of side `side`), on the AVX2 lanes when `lanes` (from
    /// [`lanes_available`]), else scalar; both give the same bits. The overlap and virial sums
    /// continue from `sums` (so that a caller can run them across many spheres in one chain);
    /// the force, contact count and worst gap start afresh.
    #[inline(always)]
    pub(super) fn contacts(&self, i: usize, lanes: bool, sums: (f64, f64)) -> ParticleContacts {
        let start = ParticleContacts {
            overlap_sum: sums.0,
            virial: sums.1,
            ..Default::default()
        };
        let mut c = if lanes {
            // SAFETY: `lanes` comes from `lanes_available`, so the CPU supports AVX2.
            unsafe { self.contacts_avx2(i, start) }
        } else {
            self.contacts_scalar(i, start)
        };
        if let Some(walls) = &self.walls {
            c.add_walls(self.x[i], self.radii[i], walls);
        }
        c
    }

    /// The scalar reference of [`Self::contacts`].
    fn contacts_scalar(&self, i: usize, start: ParticleContacts) -> ParticleContacts {
        let ri = self.radii[i];
        let mut c = start;
        self.list.for_each_neighbour(i, self.x, self.side, |j, l| {
            let dist = l.norm_squared().sqrt();
            c.add(i, j, l, dist, ri + self.radii[j]);
        });
        c
    }

    /// [`Self::contacts`] four neighbours at a time: the neighbours' positions and radii
    /// packed into lanes, then the branch vectors (x_j + image·L − x_i; image 0 adds exact zeros),
    /// |l|² (as nalgebra's `(x² + y²) + z²`), |l|, the gap, the overlap, n = l/|l| and −n·δ
    /// for four lanes in packed AVX2 arithmetic (every lane the scalar operations, in the same
    /// order), then the four contributions added to the running sums one by one in list order
    /// (a 4×4 transpose makes (F_x, F_y, F_z, δ) of one neighbour one packed add). Padding
    /// lanes add exact zeros: no sum here is ever −0, so x + (±0) = x bit for bit. A group
    /// with coincident centres (|l| = 0) takes the scalar path.
    #[target_feature(enable = "avx2")]
    unsafe fn contacts_avx2(&self, i: usize, start: ParticleContacts) -> ParticleContacts {
        use std::arch::x86_64::*;
        let Spheres {
            list,
            x,
            radii,
            side,
            ..
        } = *self;
        let xi = x[i];
        let ri = radii[i];
        let (begin, end) = (list.start[i] as usize, list.start[i + 1] as usize);
        let entries = &list.j[begin..end];
        let (xi_x, xi_y, xi_z) = (
            _mm256_set1_pd(xi.x),
            _mm256_set1_pd(xi.y),
            _mm256_set1_pd(xi.z),
        );
        let ri_v = _mm256_set1_pd(ri);
        let side_v = _mm256_set1_pd(side);
        let zero = _mm256_setzero_pd();
        let sign = _mm256_set1_pd(-0.0);
        let image_bits = _mm_set1_epi32(!INDEX_MASK as i32);
        let mut worst = _mm256_set1_pd(f64::NEG_INFINITY);
        // (F_x, F_y, F_z, Σδ), lane by lane the scalar chains.
        let mut acc = _mm256_set_pd(start.overlap_sum, 0.0, 0.0, 0.0);
        let mut c = start;
        for group in entries.chunks_exact(LANES) {
            // SAFETY: `group` holds LANES entries (the list is padded to whole groups).
            let e = unsafe { _mm_loadu_si128(group.as_ptr() as *const __m128i) };
            // Scalar loads and packing beat the AVX2 gathers here (measured).
            let k = [0, 1, 2, 3].map(|lane| (group[lane] & INDEX_MASK) as usize);
            let (a0, a1, a2, a3) = (x[k[0]], x[k[1]], x[k[2]], x[k[3]]);
            let mut px = _mm256_set_pd(a3.x, a2.x, a1.x, a0.x);
            let mut py = _mm256_set_pd(a3.y, a2.y, a1.y, a0.y);
            let mut pz = _mm256_set_pd(a3.z, a2.z, a1.z, a0.z);
            let rj = _mm256_set_pd(radii[k[3]], radii[k[2]], radii[k[1]], radii[k[0]]);
            if _mm_testz_si128(e, image_bits) == 0 {
                let ix = _mm256_cvtepi32_pd(_mm_srai_epi32::<30>(_mm_slli_epi32::<4>(e)));
                let iy = _mm256_cvtepi32_pd(_mm_srai_epi32::<30>(_mm_slli_epi32::<2>(e)));
                let iz = _mm256_cvtepi32_pd(_mm_srai_epi32::<30>(e));
                px = _mm256_add_pd(px, _mm256_mul_pd(ix, side_v));
                py = _mm256_add_pd(py, _mm256_mul_pd(iy, side_v));
                pz = _mm256_add_pd(pz, _mm256_mul_pd(iz, side_v));
            }
            let lx = _mm256_sub_pd(px, xi_x);
            let ly = _mm256_sub_pd(py, xi_y);
            let lz = _mm256_sub_pd(pz, xi_z);
            let d2 = _mm256_add_pd(
                _mm256_add_pd(_mm256_mul_pd(lx, lx), _mm256_mul_pd(ly, ly)),
                _mm256_mul_pd(lz, lz),
            );
            let dist = _mm256_sqrt_pd(d2);
            if _mm256_movemask_pd(_mm256_cmp_pd::<_CMP_GT_OQ>(dist, zero)) != 0b1111 {
                // Coincident centres (or a NaN): this group on the scalar path.
                let mut f = [0.0; LANES];
                _mm256_storeu_pd(f.as_mut_ptr(), acc);
                c.force = Vec3::new(f[0], f[1], f[2]);
                c.overlap_sum = f[3];
                for_each_entry(group, xi, x, side, &mut |j, l| {
                    c.add(i, j, l, l.norm_squared().sqrt(), ri + radii[j]);
                });
                acc = _mm256_set_pd(c.overlap_sum, c.force.z, c.force.y, c.force.x);
                continue;
            }
            let gap = _mm256_sub_pd(_mm256_add_pd(ri_v, rj), dist);
            // max(new, acc) returns acc for a NaN gap, as f64::max ignores NaN.
            worst = _mm256_max_pd(gap, worst);
            let ov = _mm256_max_pd(gap, zero);
            let fx = _mm256_xor_pd(_mm256_mul_pd(_mm256_div_pd(lx, dist), ov), sign);
            let fy = _mm256_xor_pd(_mm256_mul_pd(_mm256_div_pd(ly, dist), ov), sign);
            let fz = _mm256_xor_pd(_mm256_mul_pd(_mm256_div_pd(lz, dist), ov), sign);
            let vir = _mm256_mul_pd(ov, dist);
            c.contacts += _mm256_movemask_pd(_mm256_cmp_pd::<_CMP_GT_OQ>(ov, zero)).count_ones();
            // Transpose to one (F_x, F_y, F_z, δ) per neighbour and add them in list order.
            let a = _mm256_unpacklo_pd(fx, fy);
            let b = _mm256_unpackhi_pd(fx, fy);
            let cz = _mm256_unpacklo_pd(fz, ov);
            let d = _mm256_unpackhi_pd(fz, ov);
            acc = _mm256_add_pd(acc, _mm256_permute2f128_pd::<0x20>(a, cz));
            acc = _mm256_add_pd(acc, _mm256_permute2f128_pd::<0x20>(b, d));
            acc = _mm256_add_pd(acc, _mm256_permute2f128_pd::<0x31>(a, cz));
            acc = _mm256_add_pd(acc, _mm256_permute2f128_pd::<0x31>(b, d));
            let lo = _mm256_castpd256_pd128(vir);
            let hi = _mm256_extractf128_pd::<1>(vir);
            c.virial += _mm_cvtsd_f64(lo);
            c.virial += _mm_cvtsd_f64(_mm_unpackhi_pd(lo, lo));
            c.virial += _mm_cvtsd_f64(hi);
            c.virial += _mm_cvtsd_f64(_mm_unpackhi_pd(hi, hi));
        }
        let mut f = [0.0; LANES];
        _mm256_storeu_pd(f.as_mut_ptr(), acc);
        c.force = Vec3::new(f[0], f[1], f[2]);
        c.overlap_sum = f[3];
        let mut w = [0.0; LANES];
        _mm256_storeu_pd(w.as_mut_ptr(), worst);
        for lane_worst in w {
            c.worst = c.worst.max(lane_worst);
        }
        c
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    /// The AVX2 lanes give the scalar path's bits on a dense random configuration with
    /// face-crossing pairs, varied neighbour counts and a pair of coincident centres.
    #[test]
    fn lanes_match_the_scalar_path_bit_for_bit() {
        if !lanes_available() {
            eprintln!("skipped: this CPU has no AVX2 (the scalar path is the only one)");
            return;
        }
        let mut rng = ChaCha8Rng::seed_from_u64(7);
        let n = 600;
        let side = 9.0;
        let mut x: Vec<Vec3> = (0..n)
            .map(|_| Vec3::new(rng.gen(), rng.gen(), rng.gen()) * side)
            .collect();
        x[5] = x[4];
        let radii: Vec<f64> = (0..n).map(|_| 0.9 + 0.2 * rng.gen::<f64>()).collect();
        let cell = PeriodicCell::new(Vec3::repeat(side)).unwrap();
        let list = ScaledVerletList::build(&x, &radii, Some(&cell), 0.4).unwrap();
        assert!(
            list.j
                .iter()
                .any(|&e| e & !INDEX_MASK != 0 && e & !INDEX_MASK != PADDING_IMAGE),
            "the test needs face-crossing pairs"
        );
        // Rescale the cell after the build, as the pressure-controlled minimiser does.
        let scaled = 0.97 * side;
        let x: Vec<Vec3> = x.iter().map(|p| p * 0.97).collect();
        let mut touching = 0;
        for i in 0..n {
            let start = ParticleContacts {
                overlap_sum: 0.125 * i as f64,
                virial: 0.5,
                ..Default::default()
            };
            let spheres = Spheres {
                list: &list,
                x: &x,
                radii: &radii,
                side: scaled,
                walls: None,
            };
            let a = spheres.contacts_scalar(i, start);
            let b = spheres.contacts(i, true, (0.125 * i as f64, 0.5));
            touching += a.contacts;
            for k in 0..3 {
                assert_eq!(a.force[k].to_bits(), b.force[k].to_bits(), "sphere {i}");
            }
            assert_eq!(
                a.overlap_sum.to_bits(),
                b.overlap_sum.to_bits(),
                "sphere {i}"
            );
            assert_eq!(a.virial.to_bits(), b.virial.to_bits(), "sphere {i}");
            assert_eq!(a.contacts, b.contacts, "sphere {i}");
            assert_eq!(a.worst.to_bits(), b.worst.to_bits(), "sphere {i}");
        }
        assert!(touching > n as u32, "the test needs many contacts");
    }
}
