//! The particle update of [`super::sim`] four particles at a time (AVX2), with exactly the
//! scalar update's IEEE operations in the same order (no fused multiply–add, selects for
//! branches), so both give the same bits; checked by `tests/dem/lanes.rs`.

use super::laws::lanes::{
    add, div, each_lane, gt, ld, le, lt, movemask, mul, ne, select, splat, sqrt, st4, sub, F,
    LANES, V,
};
use super::quat::{spin_factors, Quat, SMALL_ANGLE_LIMIT};
use super::state::{BondLoad, UpdateConsts};
use crate::{Mat3, Vec3};
use std::arch::x86_64::*;

const _: () = {
    assert!(std::mem::size_of::<BondLoad>() == 72);
    assert!(std::mem::offset_of!(BondLoad, force_i) == 0);
    assert!(std::mem::offset_of!(BondLoad, torque_i) == 24);
    assert!(std::mem::offset_of!(BondLoad, torque_j) == 48);
};

/// The bond part of a particle's resultant (`sim::Resultants::at`): starting from the force
/// `f`, f ± force_i (as f + (±1)·force_i) and t + torque_i or torque_j of each CSR entry
/// `2·bond + side` in order, one AVX2 register per 3-vector (the fourth lane unused), so the
/// same IEEE operations per component as the scalar loop and the same bits.
#[inline]
#[target_feature(enable = "avx2")]
pub(crate) fn gather_bond_loads(f: Vec3, entries: &[u32], loads: &[BondLoad]) -> (Vec3, Vec3) {
    // SAFETY: no halves are read without the term.
    let (f, t, _) = unsafe { gather::<false>(f, entries, loads, &[]) };
    (f, t)
}

/// [`gather_bond_loads`] and, in the same pass over the entries, the many-body term's force
/// Σ ±g_b from zero, g_b = half[2b] + half[2b + 1] (`dem::manybody::term_force`, the same
/// bits: one packed sum of the halves and one packed product and sum per entry): a bond's
/// two reads, its loads and its halves, issued together.
///
/// # Safety
/// `half` holds 2·`loads.len()` + 1 entries (the halves and the zero entry after them: a
/// packed load of a bond's second half reads one f64 beyond it).
#[inline]
#[target_feature(enable = "avx2")]
pub(crate) unsafe fn gather_bond_loads_and_term(
    f: Vec3,
    entries: &[u32],
    loads: &[BondLoad],
    half: &[[f64; 3]],
) -> (Vec3, Vec3, Vec3) {
    debug_assert_eq!(half.len(), 2 * loads.len() + 1);
    // SAFETY: this function's contract.
    unsafe { gather::<true>(f, entries, loads, half) }
}

/// The one loop of [`gather_bond_loads`] (`TERM` false: `half` unread, the term's sum zero)
/// and [`gather_bond_loads_and_term`].
///
/// # Safety
/// With `TERM`, `half` holds 2·`loads.len()` + 1 entries.
#[inline]
#[target_feature(enable = "avx2")]
unsafe fn gather<const TERM: bool>(
    f: Vec3,
    entries: &[u32],
    loads: &[BondLoad],
    half: &[[f64; 3]],
) -> (Vec3, Vec3, Vec3) {
    const SIGN: [f64; 2] = [1.0, -1.0];
    let mut fv = _mm256_setr_pd(f.x, f.y, f.z, 0.0);
    let mut tv = _mm256_setzero_pd();
    let mut gv = _mm256_setzero_pd();
    let three = _mm256_setr_epi64x(-1, -1, -1, 0);
    let halves = half.as_ptr().cast::<f64>();
    for &e in entries {
        let side = (e & 1) as usize;
        let b = (e >> 1) as usize;
        let p = &loads[b] as *const BondLoad as *const f64;
        // SAFETY: a BondLoad is nine f64 (checked above): force_i and torque_i.x are its
        // first four; the torque's three f64 at 3 or 6 are read under a mask (the fourth
        // lane, past the record for torque_j, is not read).
        let (force, torque) = unsafe {
            (
                _mm256_loadu_pd(p),
                _mm256_maskload_pd(p.add(3 + 3 * side), three),
            )
        };
        let sign = _mm256_set1_pd(SIGN[side]);
        fv = _mm256_add_pd(fv, _mm256_mul_pd(force, sign));
        tv = _mm256_add_pd(tv, torque);
        if TERM {
            // SAFETY: four f64 from 3·2b and from 3·(2b + 1), the two halves and one more
            // each (2b + 1 < 2·bonds, and `half` has an entry more: this function's contract).
            let g = unsafe {
                _mm256_add_pd(
                    _mm256_loadu_pd(halves.add(6 * b)),
                    _mm256_loadu_pd(halves.add(6 * b + 3)),
                )
            };
            gv = _mm256_add_pd(gv, _mm256_mul_pd(g, sign));
        }
    }
    let (f, t, g) = (st4(fv), st4(tv), st4(gv));
    (
        Vec3::new(f[0], f[1], f[2]),
        Vec3::new(t[0], t[1], t[2]),
        Vec3::new(g[0], g[1], g[2]),
    )
}

/// M·x for a matrix shared by all lanes, in nalgebra's order ((m₀·x + m₁·y) + m₂·z).
#[inline]
#[target_feature(enable = "avx2")]
fn matvec(m: &Mat3, x: V) -> V {
    let row = |i: usize| {
        add(
            add(mul(splat(m[(i, 0)]), x.x), mul(splat(m[(i, 1)]), x.y)),
            mul(splat(m[(i, 2)]), x.z),
        )
    };
    V {
        x: row(0),
        y: row(1),
        z: row(2),
    }
}

/// sign(s) per lane: 1, −1, or 0 (also for NaN), as the scalar `sign`.
#[inline]
#[target_feature(enable = "avx2")]
fn sign(s: F) -> F {
    let zero = splat(0.0);
    select(
        gt(s, zero),
        splat(1.0),
        select(lt(s, zero), splat(-1.0), zero),
    )
}

/// Cundall damping of one component (as the scalar loop): returns the damped acceleration
/// and the dissipation term mass·λ·sign(s)·a·(v + ½dt·a_damped)·dt (−dt·F_d·v̄).
#[inline]
#[target_feature(enable = "avx2")]
fn damp(a: F, vel: F, mass: F, c: &UpdateConsts) -> (F, F) {
    let s = mul(a, add(vel, mul(splat(0.5 * c.dt), a)));
    let sg = sign(s);
    let damped = mul(a, sub(splat(1.0), mul(splat(c.lambda), sg)));
    let mean = add(vel, mul(splat(0.5 * c.dt), damped));
    let term = mul(
        mul(mul(mul(mul(mass, splat(c.lambda)), sg), a), mean),
        splat(c.dt),
    );
    (damped, term)
}

/// [`damp`] on the three components of an acceleration `a` with velocity `vel`.
#[inline]
#[target_feature(enable = "avx2")]
fn damp3(a: V, vel: V, mass: F, c: &UpdateConsts) -> (V, [F; 3]) {
    let (x, tx) = damp(a.x, vel.x, mass, c);
    let (y, ty) = damp(a.y, vel.y, mass, c);
    let (z, tz) = damp(a.z, vel.z, mass, c);
    (V { x, y, z }, [tx, ty, tz])
}

/// The quaternion product a·b per lane, components (w, x, y, z): `Quat::mul`'s (Eigen's)
/// component formulas in the same operation order.
#[inline]
#[target_feature(enable = "avx2")]
fn quat_mul(a: [F; 4], b: [F; 4]) -> [F; 4] {
    let [aw, ax, ay, az] = a;
    let [bw, bx, by, bz] = b;
    [
        sub(sub(sub(mul(aw, bw), mul(ax, bx)), mul(ay, by)), mul(az, bz)),
        sub(add(add(mul(aw, bx), mul(ax, bw)), mul(ay, bz)), mul(az, by)),
        sub(add(add(mul(aw, by), mul(ay, bw)), mul(az, bx)), mul(ax, bz)),
        sub(add(add(mul(aw, bz), mul(az, bw)), mul(ax, by)), mul(ay, bx)),
    ]
}

/// Four particles of the leapfrog update (see `sim::update_particle`): returns their
/// kinetic energies and the six damping terms each, in the scalar summation order.
///
/// Arrays over the lanes are written out ([`each_lane!`](super::laws::lanes::each_lane)), never
/// by `map` or `from_fn` (a build that did not inline two of them ran 10 % slower).
///
/// # Safety
/// The CPU must support AVX2; `x`, `v`, `w`, `q` have length [`LANES`].
#[target_feature(enable = "avx2")]
#[allow(clippy::too_many_arguments)]
pub(crate) unsafe fn update4(
    c: &UpdateConsts,
    mass: [f64; LANES],
    inertia: [f64; LANES],
    f: [Vec3; LANES],
    t: [Vec3; LANES],
    xs: &mut [Vec3],
    vs: &mut [Vec3],
    ws: &mut [Vec3],
    qs: &mut [Quat],
) -> ([f64; LANES], [[f64; 6]; LANES]) {
    let dt = splat(c.dt);
    let half_dt = splat(0.5 * c.dt);
    let (m, inertia) = (ld(mass), ld(inertia));
    let mut x = V::gather(each_lane!(|l| xs[l]));
    let mut v = V::gather(each_lane!(|l| vs[l]));
    let mut w = V::gather(each_lane!(|l| ws[l]));
    let fluct = if c.periodic {
        v.sub(matvec(&c.prev_l, x))
    } else {
        v
    };
    let mut a = V::gather(f).scale(div(splat(1.0), m));
    let mut terms = [splat(0.0); 6];
    if c.lambda > 0.0 {
        (a, [terms[0], terms[1], terms[2]]) = damp3(a, fluct, m, c);
    }
    let u = fluct.add(a.scale(half_dt));
    let mut energy = mul(mul(splat(0.5), m), u.dot(u));
    if c.periodic {
        a = a.add(matvec(&c.prev_l, v));
    }
    v = v.add(a.scale(dt));
    let mut alpha = V::gather(t).scale(div(splat(1.0), inertia));
    if c.lambda > 0.0 {
        (alpha, [terms[3], terms[4], terms[5]]) = damp3(alpha, w, inertia, c);
    }
    let r = w.add(alpha.scale(half_dt));
    energy = add(energy, mul(mul(splat(0.5), inertia), r.dot(r)));
    w = w.add(alpha.scale(dt));
    if c.periodic {
        v = v.add(matvec(&c.dl, x));
    }
    x = x.add(v.scale(dt));
    if c.periodic {
        w = w.add(V::splat(c.dspin.x, c.dspin.y, c.dspin.z));
    }
    // Spin quaternion dq = (cos h, ω·sin h/|ω|), h = ½·|ω|·dt (`quat::spin_factors`: series
    // in h² on all lanes, that function per lane where a lane leaves the series' range),
    // then q ← dq·q, normalised.
    let zero = splat(0.0);
    let angle2 = w.dot(w);
    let spinning = ne(angle2, zero);
    let u = mul(angle2, mul(half_dt, half_dt));
    let sin_poly = add(
        splat(1.0),
        mul(
            u,
            add(
                splat(-1.0 / 6.0),
                mul(
                    u,
                    add(
                        splat(1.0 / 120.0),
                        mul(u, add(splat(-1.0 / 5040.0), mul(u, splat(1.0 / 362_880.0)))),
                    ),
                ),
            ),
        ),
    );
    let mut sin_over_w = mul(half_dt, sin_poly);
    let mut cos_h = add(
        splat(1.0),
        mul(
            u,
            add(
                splat(-0.5),
                mul(
                    u,
                    add(
                        splat(1.0 / 24.0),
                        mul(u, add(splat(-1.0 / 720.0), mul(u, splat(1.0 / 40_320.0)))),
                    ),
                ),
            ),
        ),
    );
    let in_range = le(u, splat(SMALL_ANGLE_LIMIT * SMALL_ANGLE_LIMIT));
    if movemask(in_range) != 0b1111 {
        let (a2, fast) = (st4(angle2), movemask(in_range));
        let (mut s_l, mut c_l) = (st4(sin_over_w), st4(cos_h));
        for l in 0..LANES {
            if fast & (1 << l) == 0 {
                (c_l[l], s_l[l]) = spin_factors(a2[l], 0.5 * c.dt);
            }
        }
        cos_h = ld(c_l);
        sin_over_w = ld(s_l);
    }
    let b = [
        ld(each_lane!(|l| qs[l].w)),
        ld(each_lane!(|l| qs[l].v.x)),
        ld(each_lane!(|l| qs[l].v.y)),
        ld(each_lane!(|l| qs[l].v.z)),
    ];
    let dq = [
        cos_h,
        mul(w.x, sin_over_w),
        mul(w.y, sin_over_w),
        mul(w.z, sin_over_w),
    ];
    // dq·q, kept only on spinning lanes.
    let product = quat_mul(dq, b);
    let q: [F; 4] = each_lane!(|k| select(spinning, product[k], b[k]));
    // Quat::normalize.
    let [qw, qx, qy, qz] = q;
    let n = sqrt(add(
        add(add(mul(qx, qx), mul(qy, qy)), mul(qz, qz)),
        mul(qw, qw),
    ));
    let positive = gt(n, zero);
    let inv = div(splat(1.0), n);
    let [qw, qx, qy, qz] = each_lane!(|k| st4(select(positive, mul(q[k], inv), q[k])));
    let (x, v, w) = (x.lanes(), v.lanes(), w.lanes());
    for l in 0..LANES {
        xs[l] = x[l];
        vs[l] = v[l];
        ws[l] = w[l];
        qs[l] = Quat {
            w: qw[l],
            v: Vec3::new(qx[l], qy[l], qz[l]),
        };
    }
    let mut by_lane = [[0.0; 6]; LANES];
    for (k, term) in terms.iter().enumerate() {
        let t = st4(*term);
        for l in 0..LANES {
            by_lane[l][k] = t[l];
        }
    }
    (st4(energy), by_lane)
}
