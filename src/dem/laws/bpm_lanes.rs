//! Law (d) four bonds at a time: [`super::bpm_bond::bond_step`] (lab-frame route,
//! `normalize no`) written over AVX2 lanes of `[f64; 4]`.
//!
//! Every lane performs exactly the scalar kernel's IEEE operations in the same order (no
//! fused multiply–add, no reassociation; branches become per-lane selects), so the results
//! are bit for bit those of the scalar kernel. The lanes take the intact bonds of a chunk in
//! order, four at a time; a group with a lane off the common path (a periodic image, an
//! angle beyond the series' range, LAMMPS' zero m_q, a non-finite value) is done by the
//! scalar kernel instead, bond by bond; a zero shear angle or in-plane rotation (bonds
//! between particles that never turned, as a held layer's) stays in the lanes with the
//! scalar kernel's zero vectors selected. Broken bonds are skipped (zero loads, no damping power).
//! The chunk's damping power is summed in bond order as the scalar loop sums it; the elastic
//! energy is not computed per step (`ElasticParts::energy`, when asked).

use super::bpm_bond::{bond_step, BpmBond, BpmCoefficients, BpmResult, StepInputs};
use super::lanes::{
    abs, add, div, each_lane, gt, ld, le, lt, movemask, mul, ne, neg, select, splat, sqrt, st4,
    sub, transpose4, F, LANES, V,
};
use crate::dem::quat::{Quat, ATAN_C, SMALL_ANGLE_LIMIT};
use crate::dem::state::BondLoad;
use crate::Vec3;
use std::arch::x86_64::*;

/// Per lane: a ∧ b of two masks.
#[inline]
#[target_feature(enable = "avx2")]
fn and(a: F, b: F) -> F {
    select(a, b, splat(0.0))
}

/// `quat::atan_series` per lane: t·P(t²), Horner in the scalar order.
#[inline]
#[target_feature(enable = "avx2")]
fn atan_series(t: F) -> F {
    let u = mul(t, t);
    let mut p = splat(ATAN_C[6]);
    for c in ATAN_C[..6].iter().rev() {
        p = add(splat(*c), mul(u, p));
    }
    mul(t, p)
}

/// Lanes where `atan2_nonneg(y, x)` takes its series: x > 0 and y ≤ 2⁻⁴·x.
#[inline]
#[target_feature(enable = "avx2")]
fn series_range(y: F, x: F) -> F {
    and(gt(x, splat(0.0)), le(y, mul(splat(SMALL_ANGLE_LIMIT), x)))
}

/// Per lane: a ⊕ b, bitwise (a sign flip by −0.0, as Rust's unary minus).
#[inline]
#[target_feature(enable = "avx2")]
fn xor(a: F, b: F) -> F {
    _mm256_xor_pd(a, b)
}

/// Four rows of four values at `p[l]`, as columns.
///
/// # Safety
/// Each `p[l]` must point to four readable f64.
#[inline]
#[target_feature(enable = "avx2")]
unsafe fn load_rows(p: [*const f64; LANES]) -> [F; LANES] {
    // SAFETY: the caller's guarantee.
    transpose4(each_lane!(|l| unsafe { _mm256_loadu_pd(p[l]) }))
}

/// `s[i[l]]` of four lanes, loaded as two pairs and a single per vector (x, y) and z.
///
/// # Safety
/// Every `i[l]` must be below `s.len()`.
#[inline]
#[target_feature(enable = "avx2")]
unsafe fn gather3(s: &[Vec3], i: [usize; LANES]) -> V {
    // SAFETY: the caller guarantees the indices; Vec3 is three contiguous f64 (checked below).
    unsafe {
        let p = each_lane!(|l| {
            debug_assert!(i[l] < s.len());
            s.as_ptr().add(i[l]) as *const f64
        });
        let pair = |a: usize, b: usize| {
            _mm256_insertf128_pd::<1>(
                _mm256_castpd128_pd256(_mm_loadu_pd(p[a])),
                _mm_loadu_pd(p[b]),
            )
        };
        let single = |a: usize, b: usize| {
            _mm256_insertf128_pd::<1>(
                _mm256_castpd128_pd256(_mm_load_sd(p[a].add(2))),
                _mm_load_sd(p[b].add(2)),
            )
        };
        // [x0 y0 x2 y2], [x1 y1 x3 y3]; [z0 · z2 ·], [z1 · z3 ·].
        let (a, b) = (pair(0, 2), pair(1, 3));
        let (za, zb) = (single(0, 2), single(1, 3));
        V {
            x: _mm256_unpacklo_pd(a, b),
            y: _mm256_unpackhi_pd(a, b),
            z: _mm256_unpacklo_pd(za, zb),
        }
    }
}

/// Where w and v sit in a [`Quat`] (in f64): the lanes load a quaternion as one row.
const QUAT_W: usize = std::mem::offset_of!(Quat, w) / 8;
const QUAT_V: usize = std::mem::offset_of!(Quat, v) / 8;
const _: () = {
    assert!(std::mem::size_of::<Vec3>() == 24);
    assert!(std::mem::size_of::<Quat>() == 32);
    assert!((QUAT_W == 0 && QUAT_V == 1) || (QUAT_W == 3 && QUAT_V == 0));
    assert!(std::mem::size_of::<BondLoad>() == 72);
    assert!(std::mem::offset_of!(BondLoad, force_i) == 0);
    assert!(std::mem::offset_of!(BondLoad, torque_i) == 24);
    assert!(std::mem::offset_of!(BondLoad, torque_j) == 48);
    assert!(std::mem::size_of::<BpmResult>() == 80);
    assert!(std::mem::size_of::<BpmCoefficients>() == 64);
};

/// (w, x, y, z) of `s[i[l]]`.
///
/// # Safety
/// Every `i[l]` must be below `s.len()`.
#[inline]
#[target_feature(enable = "avx2")]
unsafe fn gather_quat(s: &[Quat], i: [usize; LANES]) -> [F; LANES] {
    // SAFETY: the caller guarantees the indices; a Quat is four f64 (checked above).
    let c = unsafe { load_rows(each_lane!(|l| s.as_ptr().add(i[l]) as *const f64)) };
    [c[QUAT_W], c[QUAT_V], c[QUAT_V + 1], c[QUAT_V + 2]]
}

/// Four intact bonds without periodic images (`idx` into the chunk); returns false, having
/// written nothing, when a lane is off the common path (module docs).
///
/// # Safety
/// Every particle index of the bonds must be below the length of every particle array, and
/// every `idx` below the length of `bonds`, `coeffs`, `results` and `out` (unchecked reads
/// and writes).
#[inline]
#[target_feature(enable = "avx2")]
unsafe fn kernel4(
    inp: &StepInputs,
    bonds: &[BpmBond],
    coeffs: &[BpmCoefficients],
    idx: [usize; LANES],
    results: &mut [BpmResult],
    out: &mut [BondLoad],
    sum: &mut f64,
) -> bool {
    let p = inp.particles;
    // SAFETY (every unchecked index below): the caller's `idx` are below the length of
    // `bonds`, `coeffs`, `results` and `out` (checked once per chunk).
    let bd = each_lane!(|l| unsafe { bonds.get_unchecked(idx[l]) });
    let ia = each_lane!(|l| bd[l].p1 as usize);
    let ib = each_lane!(|l| bd[l].p2 as usize);
    let zero = splat(0.0);
    let one = splat(1.0);
    let half = splat(0.5);
    // SAFETY (the gathers): the caller guarantees every particle index in bounds.
    let x1 = unsafe { gather3(&p.position, ia) };
    let x2 = unsafe { gather3(&p.position, ib) };
    let r = x1.sub(x2);
    let r_mag = sqrt(r.dot(r));
    let r_mag_inv = div(one, r_mag);
    let rhat = r.scale(r_mag_inv);
    // SAFETY: `r0` is four f64.
    let [r0x, r0y, r0z, r0_mag] = unsafe { load_rows(each_lane!(|l| bd[l].r0.as_ptr())) };
    let r0b = V {
        x: r0x,
        y: r0y,
        z: r0z,
    };
    // Rotation matrix of q₂ (`rotation_matrix`).
    let [w, x, y, z] = unsafe { gather_quat(&p.orientation, ib) };
    let (x2_, y2_, z2_) = (add(x, x), add(y, y), add(z, z));
    let (xx, yy, zz) = (mul(x, x2_), mul(y, y2_), mul(z, z2_));
    let (xy, xz, yz) = (mul(x, y2_), mul(x, z2_), mul(y, z2_));
    let (wx, wy, wz) = (mul(w, x2_), mul(w, y2_), mul(w, z2_));
    let m0 = V {
        x: sub(one, add(yy, zz)),
        y: sub(xy, wz),
        z: add(xz, wy),
    };
    let m1 = V {
        x: add(xy, wz),
        y: sub(one, add(xx, zz)),
        z: sub(yz, wx),
    };
    let m2 = V {
        x: sub(xz, wy),
        y: add(yz, wx),
        z: sub(one, add(xx, yy)),
    };
    let r0 = V {
        x: m0.dot(r0b),
        y: m1.dot(r0b),
        z: m2.dot(r0b),
    };
    let cp = each_lane!(
        |l| unsafe { coeffs.get_unchecked(idx[l]) } as *const BpmCoefficients as *const f64
    );
    // SAFETY: BpmCoefficients is eight f64 (repr(C), k_r k_s k_t k_b then the dampings).
    let [kr, ks, kt, kb] = unsafe { load_rows(cp) };
    let fr = mul(kr, sub(r_mag, r0_mag));
    let mut force = rhat.scale(fr);
    let cross = r0.cross(r);
    let cross_mag = sqrt(cross.dot(cross));
    let dot0 = r0.dot(r);
    // A lane with |r₀ × r| = 0 takes the scalar kernel's t = 0 (selected below).
    let mut ok = series_range(cross_mag, dot0);
    let rb_x = add(add(mul(m0.x, r.x), mul(m1.x, r.y)), mul(m2.x, r.z));
    let rb_y = add(add(mul(m0.y, r.x), mul(m1.y, r.y)), mul(m2.y, r.z));
    ok = and(ok, select(ne(rb_x, zero), ne(rb_x, zero), ne(rb_y, zero)));
    // Relative rotation q₁q₂* (Eigen's product, q₂'s vector negated).
    let [aw, ax, ay, az] = unsafe { gather_quat(&p.orientation, ia) };
    let (bw, bx, by, bz) = (w, neg(x), neg(y), neg(z));
    let qw = sub(sub(sub(mul(aw, bw), mul(ax, bx)), mul(ay, by)), mul(az, bz));
    let v = V {
        x: sub(add(add(mul(aw, bx), mul(ax, bw)), mul(ay, bz)), mul(az, by)),
        y: sub(add(add(mul(aw, by), mul(ay, bw)), mul(az, bx)), mul(ax, bz)),
        z: sub(add(add(mul(aw, bz), mul(az, bw)), mul(ax, by)), mul(ay, bx)),
    };
    let zt = v.dot(rhat);
    let vp = v.sub(rhat.scale(zt));
    let in_plane = vp.dot(vp);
    let out_plane = add(mul(qw, qw), mul(zt, zt));
    let abs_z = abs(zt);
    let d = sqrt(mul(out_plane, in_plane));
    // z = 0 gives ψ = +0 through the series as the scalar kernel's 0.0, and |v⊥|² = 0 (no
    // relative rotation off the axis, as between two particles that never turned) takes the
    // scalar kernel's u = r̂ × u = 0 (selected below); θ = +0 through the series either way.
    ok = and(ok, series_range(abs_z, qw));
    ok = and(ok, series_range(d, out_plane));
    if movemask(ok) != 0b1111 {
        return false;
    }
    let zero_v = V::splat(0.0, 0.0, 0.0);
    let gamma = atan_series(div(cross_mag, dot0));
    let t = V::select(
        gt(cross_mag, zero),
        cross.scale(div(one, cross_mag)),
        zero_v,
    );
    let s = rhat.cross(t).neg();
    let mut fs = s.scale(mul(mul(ks, r_mag), gamma));
    let mut ts = t.scale(mul(mul(mul(mul(half, r_mag), ks), r_mag), gamma));
    let two = splat(2.0);
    let psi_mag = mul(two, atan_series(div(abs_z, qw)));
    let psi = select(lt(zt, zero), neg(psi_mag), psi_mag);
    let theta = mul(two, atan_series(div(d, out_plane)));
    let e = rhat.cross(v);
    let inv = div(one, d);
    let turned = ne(in_plane, zero);
    let u = V::select(turned, vp.scale(zt).sub(e.scale(qw)).scale(inv), zero_v);
    let bend = V::select(turned, e.scale(zt).add(vp.scale(qw)).scale(inv), zero_v);
    fs = fs.add(u.scale(mul(mul(mul(splat(-0.5), ks), r_mag), theta)));
    ts = ts.add(bend.scale(mul(mul(mul(mul(splat(-0.25), ks), r_mag), r_mag), theta)));
    let tb = bend.scale(mul(kb, theta));
    let tt = rhat.scale(mul(kt, psi));
    force = force.add(fs);
    let mut t12 = ts.add(tt).add(tb);
    let mut t21 = ts.sub(tt).sub(tb);
    let (fs2, tb2, tt2) = (fs.dot(fs), tb.dot(tb), tt.dot(tt));
    // Damping (`damping_loads`), where a lane has any coefficient.
    let damped = each_lane!(|l| bd[l].damped);
    let mut power = [0.0; LANES];
    if damped.iter().any(|&d| d) {
        // SAFETY: as above (the dampings are the coefficients' last four f64).
        let [gn, gs, gr, gt_] = unsafe { load_rows(each_lane!(|l| cp[l].add(4))) };
        let v1 = unsafe { gather3(&p.velocity, ia) };
        let v2 = unsafe { gather3(&p.velocity, ib) };
        let w1 = unsafe { gather3(&p.angular_velocity, ia) };
        let w2 = unsafe { gather3(&p.angular_velocity, ib) };
        let vn1 = rhat.scale(v1.dot(rhat));
        let vn2 = rhat.scale(v2.dot(rhat));
        let mut df = vn1.sub(vn2).scale(gn);
        let vt1 = v1.sub(vn1);
        let vt2 = v2.sub(vn2);
        let half_dvt = vt2.sub(vt1).scale(half);
        let s1 = w1.cross(r).scale(splat(-0.5)).sub(half_dvt);
        let s2 = w2.cross(r).scale(half).add(half_dvt);
        let slide = s1.sub(s2).scale(gs);
        df = df.add(slide);
        let tdamp = r.cross(slide).scale(half);
        let mut dt12 = zero_v.add(tdamp);
        let mut dt21 = zero_v.add(tdamp);
        let vroll = w1.cross(rhat).sub(w2.cross(rhat));
        let troll = r.cross(vroll).scale(mul(half, gr));
        dt12 = dt12.add(troll);
        dt21 = dt21.sub(troll);
        let ttw = rhat
            .scale(w1.dot(rhat))
            .sub(rhat.scale(w2.dot(rhat)))
            .scale(mul(half, gt_));
        dt12 = dt12.add(ttw);
        dt21 = dt21.sub(ttw);
        let pw = add(
            add(add(df.neg().dot(v1), df.dot(v2)), dt21.dot(w1)),
            dt12.dot(w2),
        );
        if damped.iter().all(|&d| d) {
            force = force.add(df);
            t12 = t12.add(dt12);
            t21 = t21.add(dt21);
            power = st4(pw);
        } else {
            let mask = ld(each_lane!(|l| if damped[l] {
                f64::from_bits(u64::MAX)
            } else {
                0.0
            }));
            force = V::select(mask, force.add(df), force);
            t12 = V::select(mask, t12.add(dt12), t12);
            t21 = V::select(mask, t21.add(dt21), t21);
            // An undamped lane adds −0 (x − 0 = x): the scalar kernel adds nothing there.
            power = st4(select(mask, pw, zero));
        }
    }
    // The flipped ends (topology i = particle 2): a sign flip by −0.0 and a blend on its
    // sign bit, as the scalar kernel's branch.
    let flip = ld(each_lane!(|l| bd[l].flip));
    let force_j = V {
        x: xor(force.x, flip),
        y: xor(force.y, flip),
        z: xor(force.z, flip),
    };
    let normal = rhat.neg();
    let normal = V {
        x: xor(normal.x, flip),
        y: xor(normal.y, flip),
        z: xor(normal.z, flip),
    };
    let force_i = force_j.neg();
    let torque_i = V::select(flip, t12, t21);
    let torque_j = V::select(flip, t21, t12);
    // Rows of the records: BondLoad (force_i, torque_i, torque_j) and BpmResult (F_r, |F_s|²,
    // |τ_b|², |τ_t|², force_j, normal), repr(C)/checked layouts; each set of rows stored as
    // soon as it is transposed (four registers live at a time).
    let (ob, rb) = (out.as_mut_ptr(), results.as_mut_ptr());
    // SAFETY: every index is in bounds (the caller's guarantee); a BondLoad is nine f64 and
    // a BpmResult ten (layouts checked above); the four bonds are distinct.
    let o = each_lane!(|l| unsafe { ob.add(idx[l]) } as *mut f64);
    let rp = each_lane!(|l| unsafe { rb.add(idx[l]) } as *mut f64);
    // SAFETY: as above.
    unsafe {
        let rows = transpose4([force_i.x, force_i.y, force_i.z, torque_i.x]);
        for l in 0..LANES {
            _mm256_storeu_pd(o[l], rows[l]);
        }
        let rows = transpose4([torque_i.y, torque_i.z, torque_j.x, torque_j.y]);
        for l in 0..LANES {
            _mm256_storeu_pd(o[l].add(4), rows[l]);
        }
        let tz = st4(torque_j.z);
        for l in 0..LANES {
            *o[l].add(8) = tz[l];
        }
        let rows = transpose4([fr, fs2, tb2, tt2]);
        for l in 0..LANES {
            _mm256_storeu_pd(rp[l], rows[l]);
        }
        let rows = transpose4([force_j.x, force_j.y, force_j.z, normal.x]);
        for l in 0..LANES {
            _mm256_storeu_pd(rp[l].add(4), rows[l]);
        }
        // (n_y, n_z) of lanes 0, 2 and of lanes 1, 3.
        let c02 = _mm256_unpacklo_pd(normal.y, normal.z);
        let c13 = _mm256_unpackhi_pd(normal.y, normal.z);
        _mm_storeu_pd(rp[0].add(8), _mm256_castpd256_pd128(c02));
        _mm_storeu_pd(rp[1].add(8), _mm256_castpd256_pd128(c13));
        _mm_storeu_pd(rp[2].add(8), _mm256_extractf128_pd::<1>(c02));
        _mm_storeu_pd(rp[3].add(8), _mm256_extractf128_pd::<1>(c13));
    }
    for p in power {
        *sum -= p;
    }
    true
}

/// A chunk of law-(d) bonds (`normalize no`): the intact bonds without periodic images four
/// at a time through [`kernel4`], every other bond and group through the scalar
/// [`bond_step`], the damping power summed in bond order, which it returns.
///
/// # Safety
/// The CPU must support AVX2, and every particle index of `bonds` must be below the length
/// of every particle array of `inp` (as [`kernel4`]).
#[target_feature(enable = "avx2")]
pub(super) unsafe fn chunk_avx2(
    inp: &StepInputs,
    bonds: &[BpmBond],
    coeffs: &[BpmCoefficients],
    results: &mut [BpmResult],
    out: &mut [BondLoad],
) -> f64 {
    let mut sum = 0.0;
    let mut group = [0usize; LANES];
    let mut n = 0;
    let scalar = |k: usize, results: &mut [BpmResult], out: &mut [BondLoad], sum: &mut f64| {
        bond_step(
            inp,
            &bonds[k],
            &coeffs[k],
            &mut results[k],
            &mut out[k],
            sum,
        )
    };
    let n_bonds = bonds.len();
    assert!(coeffs.len() == n_bonds && results.len() == n_bonds && out.len() == n_bonds);
    for (k, b) in bonds.iter().enumerate() {
        if b.broken {
            // Zero loads (left by the break) and nothing to the sums; its record is not read
            // again (the criteria skip broken bonds).
            continue;
        }
        if b.imaged {
            // In order: the pending group first, then this bond.
            for &g in &group[..n] {
                scalar(g, results, out, &mut sum);
            }
            n = 0;
            scalar(k, results, out, &mut sum);
            continue;
        }
        group[n] = k;
        n += 1;
        if n == LANES {
            n = 0;
            // SAFETY: the caller's guarantee covers these bonds' particles; every index of
            // `group` is below the four lengths (equal, asserted above).
            if !unsafe { kernel4(inp, bonds, coeffs, group, results, out, &mut sum) } {
                for &g in &group {
                    scalar(g, results, out, &mut sum);
                }
            }
        }
    }
    for &g in &group[..n] {
        scalar(g, results, out, &mut sum);
    }
    sum
}
