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
//! scalar kernel's zero vectors selected. Broken bonds are skipped (zero loads, no sums).
//! The chunk's sums are added in bond order as the scalar loop adds them.

use super::bpm_bond::{bond_step, BpmBond, BpmCoefficients, BpmResult, ElasticParts, StepInputs};
use super::lanes::{
    abs, add, at, div, gt, ld, le, lt, movemask, mul, ne, neg, select, splat, sqrt, st4, sub, F,
    LANES, V,
};
use crate::dem::quat::{ATAN_C, SMALL_ANGLE_LIMIT};
use crate::dem::state::BondLoad;
use crate::Vec3;

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

/// Four intact bonds without periodic images (`idx` into the chunk); returns false, having
/// written nothing, when a lane is off the common path (module docs).
///
/// # Safety
/// Every particle index of the bonds must be below the length of every particle array
/// (unchecked reads).
#[inline]
#[target_feature(enable = "avx2")]
unsafe fn kernel4(
    inp: &StepInputs,
    bonds: &[BpmBond],
    coeffs: &[BpmCoefficients],
    idx: [usize; LANES],
    results: &mut [BpmResult],
    out: &mut [BondLoad],
    sums: &mut [f64; 2],
) -> bool {
    let p = inp.particles;
    let bd = idx.map(|k| bonds[k]);
    let c = idx.map(|k| coeffs[k]);
    let ia = bd.map(|b| b.p1 as usize);
    let ib = bd.map(|b| b.p2 as usize);
    let zero = splat(0.0);
    let one = splat(1.0);
    let half = splat(0.5);
    let x1 = V::gather(ia.map(|i| at(&p.position, i)));
    let x2 = V::gather(ib.map(|i| at(&p.position, i)));
    let r = x1.sub(x2);
    let r_mag = sqrt(r.dot(r));
    let r_mag_inv = div(one, r_mag);
    let rhat = r.scale(r_mag_inv);
    let r0_mag = ld(bd.map(|b| b.r0_mag));
    let r0b = V::gather(bd.map(|b| b.r0_hat)).scale(r0_mag);
    // Rotation matrix of q₂ (`rotation_matrix`).
    let q2 = ib.map(|i| at(&p.orientation, i));
    let (w, x, y, z) = (
        ld(q2.map(|q| q.w)),
        ld(q2.map(|q| q.v.x)),
        ld(q2.map(|q| q.v.y)),
        ld(q2.map(|q| q.v.z)),
    );
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
    let kr = ld(c.map(|c| c.kr));
    let ks = ld(c.map(|c| c.ks));
    let kt = ld(c.map(|c| c.kt));
    let kb = ld(c.map(|c| c.kb));
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
    let q1 = ia.map(|i| at(&p.orientation, i));
    let (aw, ax, ay, az) = (
        ld(q1.map(|q| q.w)),
        ld(q1.map(|q| q.v.x)),
        ld(q1.map(|q| q.v.y)),
        ld(q1.map(|q| q.v.z)),
    );
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
    let mut energy = zero;
    for (load2, k) in [(mul(fr, fr), kr), (fs2, ks), (tb2, kb), (tt2, kt)] {
        energy = select(gt(k, zero), add(energy, div(mul(half, load2), k)), energy);
    }
    // Damping (`damping_loads`), where a lane has any coefficient.
    let damped = bd.map(|b| b.damped);
    let mut power = [0.0; LANES];
    if damped.iter().any(|&d| d) {
        let gn = ld(c.map(|c| c.gamma_n));
        let gs = ld(c.map(|c| c.gamma_s));
        let gr = ld(c.map(|c| c.gamma_r));
        let gt_ = ld(c.map(|c| c.gamma_t));
        let v1 = V::gather(ia.map(|i| at(&p.velocity, i)));
        let v2 = V::gather(ib.map(|i| at(&p.velocity, i)));
        let w1 = V::gather(ia.map(|i| at(&p.angular_velocity, i)));
        let w2 = V::gather(ib.map(|i| at(&p.angular_velocity, i)));
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
        let mask = ld(damped.map(|d| if d { f64::from_bits(u64::MAX) } else { 0.0 }));
        force = V::select(mask, force.add(df), force);
        t12 = V::select(mask, t12.add(dt12), t12);
        t21 = V::select(mask, t21.add(dt21), t21);
        let pw = add(
            add(add(df.neg().dot(v1), df.dot(v2)), dt21.dot(w1)),
            dt12.dot(w2),
        );
        power = st4(pw);
    }
    let (f12, t12, t21, rh) = (force.lanes(), t12.lanes(), t21.lanes(), rhat.lanes());
    let (fr, fs2, tb2, tt2, energy) = (st4(fr), st4(fs2), st4(tb2), st4(tt2), st4(energy));
    for l in 0..LANES {
        if damped[l] {
            sums[0] -= power[l];
        }
        sums[1] += energy[l];
        let elastic = ElasticParts {
            fr: fr[l],
            fs2: fs2[l],
            tb2: tb2[l],
            tt2: tt2[l],
            energy: energy[l],
        };
        let o = &mut out[idx[l]];
        if bd[l].flipped {
            o.force_i = f12[l];
            o.torque_i = t12[l];
            o.torque_j = t21[l];
            results[idx[l]] = BpmResult {
                force_j: -f12[l],
                normal: rh[l],
                elastic,
            };
        } else {
            o.force_i = -f12[l];
            o.torque_i = t21[l];
            o.torque_j = t12[l];
            results[idx[l]] = BpmResult {
                force_j: f12[l],
                normal: -rh[l],
                elastic,
            };
        }
    }
    true
}

/// A chunk of law-(d) bonds (`normalize no`): the intact bonds without periodic images four
/// at a time through [`kernel4`], every other bond and group through the scalar
/// [`bond_step`], the sums in bond order. Returns (damping power, elastic energy).
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
) -> [f64; 2] {
    let mut sums = [0.0, 0.0];
    let mut group = [0usize; LANES];
    let mut n = 0;
    let scalar =
        |k: usize, results: &mut [BpmResult], out: &mut [BondLoad], sums: &mut [f64; 2]| {
            bond_step(
                inp,
                &bonds[k],
                &coeffs[k],
                &mut results[k],
                &mut out[k],
                sums,
            )
        };
    for k in 0..bonds.len() {
        let b = &bonds[k];
        if b.broken {
            // Zero loads (left by the break) and nothing to the sums; its record is not read
            // again (the criteria skip broken bonds).
            continue;
        }
        if b.image2 != Vec3::zeros() {
            // In order: the pending group first, then this bond.
            for &g in &group[..n] {
                scalar(g, results, out, &mut sums);
            }
            n = 0;
            scalar(k, results, out, &mut sums);
            continue;
        }
        group[n] = k;
        n += 1;
        if n == LANES {
            n = 0;
            // SAFETY: the caller's guarantee covers these bonds.
            if !unsafe { kernel4(inp, bonds, coeffs, group, results, out, &mut sums) } {
                for &g in &group {
                    scalar(g, results, out, &mut sums);
                }
            }
        }
    }
    for &g in &group[..n] {
        scalar(g, results, out, &mut sums);
    }
    sums
}
