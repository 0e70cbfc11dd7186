//! Law (a) four bonds at a time: the scalar kernel of [`super::bond_kernel`] (orientation
//! moments, identity reference orientations, no viscous damping) written over lanes of
//! `[f64; 4]` so that the compiler emits packed SIMD arithmetic (AVX2 when the CPU has it,
//! detected at run time, SSE2 otherwise).
//!
//! Every lane performs exactly the scalar kernel's IEEE operations in the same order (no
//! fused multiply–add, no reassociation; branches become per-lane selects), so the results
//! are bit-for-bit those of the scalar kernel — and hence still YADE's to rounding. The
//! bond's rotation vector uses the scalar kernel's small-angle form
//! ([`crate::dem::quat::rotation_vector_of`]: one division, no square root) on all lanes, and
//! that function per lane when any lane's rotation is too large for it.

use super::{BondDyn, BondHot, BondMoments, KernelInputs, NO_IMAGE};
use crate::dem::quat::{rotation_vector_of, Quat, ATAN_C, SMALL_ANGLE_LIMIT};
use crate::dem::state::BondLoad;
use crate::Vec3;

/// Bonds per lane group.
pub(crate) const LANES: usize = 4;

/// `[e(0), e(1), e(2), e(3)]` for `each_lane!(|l| e(l))`: an array over the [`LANES`] lanes
/// written out in place. `map` and `from_fn` carry no target features, so where the compiler
/// does not inline them their closures run as calls outside the AVX2 kernels (it happened to
/// the particle update: 10 % of the integrator's time).
macro_rules! each_lane {
    (|$l:ident| $e:expr) => {
        [
            {
                let $l = 0usize;
                $e
            },
            {
                let $l = 1usize;
                $e
            },
            {
                let $l = 2usize;
                $e
            },
            {
                let $l = 3usize;
                $e
            },
        ]
    };
}
pub(crate) use each_lane;
const _: () = assert!(LANES == 4, "each_lane! writes four lanes");

use std::arch::x86_64::*;

pub(crate) type F = __m256d;

#[inline]
#[target_feature(enable = "avx2")]
pub(crate) fn ld(a: [f64; LANES]) -> F {
    // SAFETY: reads four f64 from a local array (unaligned load).
    unsafe { _mm256_loadu_pd(a.as_ptr()) }
}

#[inline]
#[target_feature(enable = "avx2")]
pub(crate) fn st4(a: F) -> [f64; LANES] {
    let mut out = [0.0; LANES];
    // SAFETY: writes four f64 into a local array (unaligned store).
    unsafe { _mm256_storeu_pd(out.as_mut_ptr(), a) };
    out
}

/// Lane operations, each one AVX2 intrinsic: `name(args) -> type = body`, with docs.
macro_rules! lane_ops {
    ($($(#[$doc:meta])* $name:ident($($arg:ident: $ty:ty),*) -> $ret:ty = $body:expr;)*) => {$(
        $(#[$doc])*
        #[inline]
        #[target_feature(enable = "avx2")]
        pub(crate) fn $name($($arg: $ty),*) -> $ret {
            $body
        }
    )*};
}

lane_ops! {
    add(a: F, b: F) -> F = _mm256_add_pd(a, b);
    sub(a: F, b: F) -> F = _mm256_sub_pd(a, b);
    mul(a: F, b: F) -> F = _mm256_mul_pd(a, b);
    div(a: F, b: F) -> F = _mm256_div_pd(a, b);
    splat(a: f64) -> F = _mm256_set1_pd(a);
    /// Exact sign flip (as Rust's unary minus).
    neg(a: F) -> F = _mm256_xor_pd(a, _mm256_set1_pd(-0.0));
    /// Per lane: `mask ? a : b` (mask lanes all-ones or all-zeros).
    select(mask: F, a: F, b: F) -> F = _mm256_blendv_pd(b, a, mask);
    sqrt(a: F) -> F = _mm256_sqrt_pd(a);
    /// Mask of lanes with a > b (false for NaN, as Rust's `>`).
    gt(a: F, b: F) -> F = _mm256_cmp_pd::<_CMP_GT_OQ>(a, b);
    /// Mask of lanes with a < b (false for NaN, as Rust's `<`).
    lt(a: F, b: F) -> F = _mm256_cmp_pd::<_CMP_LT_OQ>(a, b);
    /// Mask of lanes with a <= b (false for NaN, as Rust's `<=`).
    le(a: F, b: F) -> F = _mm256_cmp_pd::<_CMP_LE_OQ>(a, b);
    /// |a| per lane (clears the sign bit, as `f64::abs`).
    abs(a: F) -> F = _mm256_andnot_pd(_mm256_set1_pd(-0.0), a);
    /// One bit per lane: set where the mask lane is true.
    movemask(mask: F) -> i32 = _mm256_movemask_pd(mask);
    /// Mask of lanes with a != b (true for NaN, as Rust's `!=`).
    ne(a: F, b: F) -> F = _mm256_cmp_pd::<_CMP_NEQ_UQ>(a, b);
}

/// 4×4 transpose: four rows (a lane's four values in memory order) to four columns (one
/// value of the four lanes), and back (it is its own inverse).
#[inline]
#[target_feature(enable = "avx2")]
pub(crate) fn transpose4(r: [F; LANES]) -> [F; LANES] {
    let t0 = _mm256_unpacklo_pd(r[0], r[1]);
    let t1 = _mm256_unpackhi_pd(r[0], r[1]);
    let t2 = _mm256_unpacklo_pd(r[2], r[3]);
    let t3 = _mm256_unpackhi_pd(r[2], r[3]);
    [
        _mm256_permute2f128_pd::<0x20>(t0, t2),
        _mm256_permute2f128_pd::<0x20>(t1, t3),
        _mm256_permute2f128_pd::<0x31>(t0, t2),
        _mm256_permute2f128_pd::<0x31>(t1, t3),
    ]
}

#[derive(Clone, Copy)]
pub(crate) struct V {
    pub(crate) x: F,
    pub(crate) y: F,
    pub(crate) z: F,
}

impl V {
    #[inline]
    #[target_feature(enable = "avx2")]
    pub(crate) fn add(self, o: V) -> V {
        V {
            x: add(self.x, o.x),
            y: add(self.y, o.y),
            z: add(self.z, o.z),
        }
    }
    #[inline]
    #[target_feature(enable = "avx2")]
    pub(crate) fn sub(self, o: V) -> V {
        V {
            x: sub(self.x, o.x),
            y: sub(self.y, o.y),
            z: sub(self.z, o.z),
        }
    }
    #[inline]
    #[target_feature(enable = "avx2")]
    pub(crate) fn scale(self, s: F) -> V {
        V {
            x: mul(self.x, s),
            y: mul(self.y, s),
            z: mul(self.z, s),
        }
    }
    #[inline]
    #[target_feature(enable = "avx2")]
    pub(crate) fn neg(self) -> V {
        V {
            x: neg(self.x),
            y: neg(self.y),
            z: neg(self.z),
        }
    }
    /// nalgebra's order: (x·x' + y·y') + z·z'.
    #[inline]
    #[target_feature(enable = "avx2")]
    pub(crate) fn dot(self, o: V) -> F {
        add(add(mul(self.x, o.x), mul(self.y, o.y)), mul(self.z, o.z))
    }
    /// nalgebra's cross product formulas.
    #[inline]
    #[target_feature(enable = "avx2")]
    pub(crate) fn cross(self, o: V) -> V {
        V {
            x: sub(mul(self.y, o.z), mul(self.z, o.y)),
            y: sub(mul(self.z, o.x), mul(self.x, o.z)),
            z: sub(mul(self.x, o.y), mul(self.y, o.x)),
        }
    }
    #[inline]
    #[target_feature(enable = "avx2")]
    pub(crate) fn select(mask: F, a: V, b: V) -> V {
        V {
            x: select(mask, a.x, b.x),
            y: select(mask, a.y, b.y),
            z: select(mask, a.z, b.z),
        }
    }
    #[inline]
    #[target_feature(enable = "avx2")]
    pub(crate) fn splat(x: f64, y: f64, z: f64) -> V {
        V {
            x: splat(x),
            y: splat(y),
            z: splat(z),
        }
    }
    #[inline]
    #[target_feature(enable = "avx2")]
    pub(crate) fn gather(v: [Vec3; LANES]) -> V {
        V {
            x: ld([v[0].x, v[1].x, v[2].x, v[3].x]),
            y: ld([v[0].y, v[1].y, v[2].y, v[3].y]),
            z: ld([v[0].z, v[1].z, v[2].z, v[3].z]),
        }
    }
    #[inline]
    #[target_feature(enable = "avx2")]
    pub(crate) fn lanes(self) -> [Vec3; LANES] {
        let (x, y, z) = (st4(self.x), st4(self.y), st4(self.z));
        each_lane!(|l| Vec3::new(x[l], y[l], z[l]))
    }
}

/// `slice[k]` without the bounds check.
///
/// Callers guarantee `k < slice.len()`: [`law_a_chunk`] (and law (d)'s
/// `LammpsBpmLaw::compute`) checks every index of its chunk before it takes the unchecked
/// path.
#[inline(always)]
pub(crate) unsafe fn at<T: Copy>(slice: &[T], k: usize) -> T {
    debug_assert!(k < slice.len());
    // SAFETY: the caller guarantees k < slice.len().
    unsafe { *slice.get_unchecked(k) }
}

/// Four bonds of law (a); see the module docs. `st`, `out` have length 4. Returns the
/// moments' elastic energy per lane (as [`super::moment_energy`]).
///
/// # Safety
/// Every particle index of `hot` must be below the length of every particle array, and
/// every image index below `inp.images.len()`.
#[inline]
#[target_feature(enable = "avx2")]
unsafe fn kernel4(
    inp: &KernelInputs,
    hot: &[BondHot],
    idx: [usize; LANES],
    st: &mut [BondDyn],
    out: &mut [BondLoad],
) -> [f64; LANES] {
    let p = inp.particles;
    let hot = each_lane!(|l| hot[idx[l]]);
    let dt = splat(inp.dt);
    let ii = each_lane!(|l| hot[l].i as usize);
    let jj = each_lane!(|l| hot[l].j as usize);
    let has_image = each_lane!(|l| hot[l].image != NO_IMAGE);
    let any_image = has_image.iter().any(|&h| h);
    let cell_dist: [Vec3; LANES] = each_lane!(|l| {
        if has_image[l] {
            at(inp.images, hot[l].image as usize)
        } else {
            Vec3::zeros()
        }
    });
    // Geometry (the scalar `geometry`, the image shift added only where there is one).
    let xi = V::gather(each_lane!(|l| at(&p.position, ii[l])));
    let xj = V::gather(each_lane!(|l| {
        if has_image[l] {
            at(&p.position, jj[l]) + inp.h * cell_dist[l]
        } else {
            at(&p.position, jj[l])
        }
    }));
    let n_raw = xj.sub(xi);
    let d = sqrt(n_raw.dot(n_raw));
    let n = n_raw.scale(div(splat(1.0), d));
    let ri = ld(each_lane!(|l| at(&p.radius, ii[l])));
    let rj = ld(each_lane!(|l| at(&p.radius, jj[l])));
    let pd = sub(add(ri, rj), d);
    let cp = xi.add(n.scale(sub(ri, mul(splat(0.5), pd))));
    let wi = V::gather(each_lane!(|l| at(&p.angular_velocity, ii[l])));
    let wj = V::gather(each_lane!(|l| at(&p.angular_velocity, jj[l])));
    // ScGeom::precompute.
    let n_old = V::gather(each_lane!(|l| st[idx[l]].normal));
    let orthonormal_axis = n_old.cross(n);
    let twist_angle = mul(mul(dt, splat(0.5)), n_old.dot(wi.add(wj)));
    let twist_axis = n_old.scale(twist_angle);
    // Relative velocity at the contact point.
    let c1x = cp.sub(xi);
    let c2x = cp.sub(xj);
    let vi = V::gather(each_lane!(|l| at(&p.velocity, ii[l])));
    let vj = V::gather(each_lane!(|l| at(&p.velocity, jj[l])));
    let mut rel_vel = vj.add(wj.cross(c2x)).sub(vi.add(wi.cross(c1x)));
    if any_image {
        let shift_vel = V::gather(each_lane!(|l| inp.shift_velocity * cell_dist[l]));
        let mask = ld(each_lane!(|l| if has_image[l] {
            f64::from_bits(u64::MAX)
        } else {
            0.0
        }));
        rel_vel = V::select(mask, rel_vel.add(shift_vel), rel_vel);
    }
    let rel_vel_t = rel_vel.sub(n.scale(n.dot(rel_vel)));
    let shear_inc = rel_vel_t.scale(dt);
    // Rotate the shear force with the contact.
    let mut shear = V::gather(each_lane!(|l| st[idx[l]].shear_force));
    shear = shear.sub(shear.cross(orthonormal_axis));
    shear = shear.sub(shear.cross(twist_axis));
    // Normal and incremental shear.
    let kn = ld(each_lane!(|l| hot[l].kn));
    let ks = ld(each_lane!(|l| hot[l].ks));
    let kr = ld(each_lane!(|l| hot[l].kr));
    let ktw = ld(each_lane!(|l| hot[l].ktw));
    let fn_ = mul(kn, sub(pd, ld(each_lane!(|l| hot[l].unp))));
    shear = shear.sub(shear_inc.scale(ks));
    // Relative rotation q_i q_j* (identity references), normalised.
    let qi = each_lane!(|l| at(&p.orientation, ii[l]));
    let qj = each_lane!(|l| at(&p.orientation, jj[l]));
    let (aw, ax, ay, az) = (
        ld(each_lane!(|l| qi[l].w)),
        ld(each_lane!(|l| qi[l].v.x)),
        ld(each_lane!(|l| qi[l].v.y)),
        ld(each_lane!(|l| qi[l].v.z)),
    );
    let (bw, bx, by, bz) = (
        ld(each_lane!(|l| qj[l].w)),
        ld(each_lane!(|l| -qj[l].v.x)),
        ld(each_lane!(|l| -qj[l].v.y)),
        ld(each_lane!(|l| -qj[l].v.z)),
    );
    let qw = sub(sub(sub(mul(aw, bw), mul(ax, bx)), mul(ay, by)), mul(az, bz));
    let qv = V {
        x: sub(add(add(mul(aw, bx), mul(ax, bw)), mul(ay, bz)), mul(az, by)),
        y: sub(add(add(mul(aw, by), mul(ay, bw)), mul(az, bx)), mul(ax, bz)),
        z: sub(add(add(mul(aw, bz), mul(az, bw)), mul(ax, by)), mul(ay, bx)),
    };
    // Rotation vector (`quat::rotation_vector_of`): v·2·P(|v|²/w²)/|w| on all lanes when
    // every lane is a small rotation, else that function per lane.
    let zero = splat(0.0);
    let vv = qv.dot(qv);
    let ww = mul(qw, qw);
    let small = select(
        gt(ww, zero),
        le(vv, mul(splat(SMALL_ANGLE_LIMIT * SMALL_ANGLE_LIMIT), ww)),
        zero,
    );
    // Lanes without moment springs (broken bonds) do not use their rotation (their moments
    // and energy are selected out, as the scalar kernel skips them): the series for them too,
    // never libm.
    let ones = splat(f64::from_bits(u64::MAX));
    let used = select(gt(kr, zero), ones, gt(ktw, zero));
    let small = select(used, small, ones);
    let rotation = if movemask(small) == 0b1111 {
        let inv = div(splat(1.0), abs(qw));
        let u = mul(mul(vv, inv), inv);
        let mut poly = splat(ATAN_C[6]);
        for c in ATAN_C[..6].iter().rev() {
            poly = add(splat(*c), mul(u, poly));
        }
        let f = mul(mul(splat(2.0), poly), inv);
        qv.scale(select(lt(qw, zero), neg(f), f))
    } else {
        let (w, v, used) = (st4(qw), qv.lanes(), movemask(used));
        V::gather(each_lane!(|l| {
            if used & (1 << l) != 0 {
                rotation_vector_of(&Quat { w: w[l], v: v[l] })
            } else {
                Vec3::zeros()
            }
        }))
    };
    let twist = rotation.dot(n);
    let bending = rotation.sub(n.scale(twist));
    let zero_v = V::splat(0.0, 0.0, 0.0);
    let moment_twist = V::select(gt(ktw, zero), n.scale(mul(twist, ktw)), zero_v);
    let moment_bending = V::select(gt(kr, zero), bending.scale(kr), zero_v);
    // Loads.
    let force = n.scale(fn_).neg().sub(shear);
    let moment = moment_twist.add(moment_bending);
    let torque_i = c1x.cross(force).sub(moment);
    let torque_j = c2x.cross(force).neg().add(moment);
    let (n, shear, fn_) = (n.lanes(), shear.lanes(), st4(fn_));
    // ½k_r|θ_b|² + ½k_tw θ_t² in the scalar order (0 + bending term, + twist term).
    let half = splat(0.5);
    let e_bending = select(
        gt(kr, zero),
        add(zero, mul(mul(half, kr), bending.dot(bending))),
        zero,
    );
    let energy = select(
        gt(ktw, zero),
        add(e_bending, mul(mul(half, ktw), mul(twist, twist))),
        e_bending,
    );
    let (force, torque_i, torque_j) = (force.lanes(), torque_i.lanes(), torque_j.lanes());
    for (l, &k) in idx.iter().enumerate() {
        st[k] = BondDyn {
            normal: n[l],
            shear_force: shear[l],
            normal_force: fn_[l],
        };
        out[k] = BondLoad {
            force_i: force[l],
            torque_i: torque_i[l],
            torque_j: torque_j[l],
        };
    }
    st4(energy)
}

/// A chunk of law-(a) bonds: groups of four through [`kernel4`], the rest through the
/// scalar kernel. Returns the chunk's moment energy summed in bond order.
///
/// # Safety
/// As [`kernel4`], for every bond of `hot`.
#[target_feature(enable = "avx2")]
unsafe fn chunk_avx2(
    inp: &KernelInputs,
    base: usize,
    hot: &[BondHot],
    st: &mut [BondDyn],
    out: &mut [BondLoad],
) -> f64 {
    // The intact bonds in order, four at a time. A broken bond is skipped: its springs are
    // zero, so the kernel would give it zero loads (those the break left) and add +0 to the
    // energy (a no-op on a sum of non-negative terms), and no one reads its state.
    let mut energy = 0.0;
    let mut group = [0usize; LANES];
    let mut n = 0;
    for (k, c) in hot.iter().enumerate() {
        if c.broken {
            continue;
        }
        group[n] = k;
        n += 1;
        if n == LANES {
            n = 0;
            // SAFETY: the caller's guarantee covers these bonds.
            for x in unsafe { kernel4(inp, hot, group, st, out) } {
                energy += x;
            }
        }
    }
    for &g in &group[..n] {
        energy = scalar_chunk_from(
            energy,
            inp,
            base + g,
            &hot[g..g + 1],
            &mut st[g..g + 1],
            &mut out[g..g + 1],
        );
    }
    energy
}

/// The scalar kernel over bonds; returns their moment energy summed in bond order, added
/// to `start`.
fn scalar_chunk_from(
    start: f64,
    inp: &KernelInputs,
    base: usize,
    hot: &[BondHot],
    st: &mut [BondDyn],
    out: &mut [BondLoad],
) -> f64 {
    let mut energy = start;
    for k in 0..hot.len() {
        let mut mom = BondMoments::default();
        let [_, e] = super::bond_kernel::<true, false, false>(
            inp,
            base + k,
            &hot[k],
            &mut st[k],
            &mut mom,
            &mut out[k],
        );
        energy += e;
    }
    energy
}

/// Law (a) on one chunk of bonds: four lanes with AVX2 when the CPU has it, else the
/// scalar kernel (the same bits either way). Returns the chunk's moment energy.
pub(super) fn law_a_chunk(
    inp: &KernelInputs,
    base: usize,
    hot: &[BondHot],
    st: &mut [BondDyn],
    out: &mut [BondLoad],
) -> f64 {
    let p = inp.particles;
    let len = [
        p.position.len(),
        p.velocity.len(),
        p.angular_velocity.len(),
        p.orientation.len(),
        p.radius.len(),
    ]
    .into_iter()
    .min()
    .unwrap_or(0);
    // Every bond's particle indices are below `index_bound`; image indices are valid by
    // construction (see `LinearBondKernel::index_bound`).
    let in_bounds = inp.index_bound <= len;
    if in_bounds && inp.simd && std::arch::is_x86_feature_detected!("avx2") {
        // SAFETY: the CPU supports AVX2 (checked just above), and every particle and
        // image index of the chunk is in bounds (the unchecked reads of `kernel4`).
        return unsafe { chunk_avx2(inp, base, hot, st, out) };
    }
    scalar_chunk_from(0.0, inp, base, hot, st, out)
}
