//! Direct tension of a bonded simple-cubic bar (affine: every axial bond carries the same
//! force, lateral bonds none): the peak stress is the bond's tensile limit times the bonds
//! per unit area 1/d², exactly, for each law — through the strength assignment (a
//! cross-anisotropic scheme, a plane of weakness) and each law's criterion.

use anisobond::bonds::BondSet;
use anisobond::packing::Packing;
use anisobond::strength::criteria::{
    joint, lammps_bpm, parallel_bond, resolve_on_plane, yade_cohfrict, BpmLimits, Failure,
    JointLimits, LocalLoads, ParallelBondSection, YadeAdhesion,
};
use anisobond::strength::schemes::{CrossStrength, StrengthScheme};
use anisobond::strength::{assign_strength, BondStrengths, PlaneFamily, Strength, StrengthSpec};
use anisobond::{Mat3, Vec3};
use nalgebra::Rotation3;
use std::f64::consts::PI;

const R: f64 = 0.5e-3;
const D: f64 = 2.0 * R;
const NX: usize = 3;
const NY: usize = 2;
const NZ: usize = 6;
const KN: f64 = 2.0e6;
const KS: f64 = 1.0e6;

/// The bar's rotation: lattice axes to lab (bar axis t = Q·z).
fn rotation() -> Mat3 {
    *(Rotation3::from_axis_angle(&Vec3::z_axis(), 20f64.to_radians())
        * Rotation3::from_axis_angle(&Vec3::x_axis(), 35f64.to_radians()))
    .matrix()
}

/// Particles on the rotated lattice and the nearest-neighbour bonds.
fn bar() -> (Packing, BondSet) {
    let q = rotation();
    let index = |i: usize, j: usize, k: usize| (i * NY + j) * NZ + k;
    let mut positions = vec![Vec3::zeros(); NX * NY * NZ];
    for i in 0..NX {
        for j in 0..NY {
            for k in 0..NZ {
                positions[index(i, j, k)] = q * Vec3::new(i as f64, j as f64, k as f64) * D;
            }
        }
    }
    let packing = Packing::new(positions.clone(), vec![R; positions.len()], None).unwrap();
    let mut bonds = BondSet::default();
    for i in 0..NX {
        for j in 0..NY {
            for k in 0..NZ {
                let a = index(i, j, k);
                for (di, dj, dk) in [(1, 0, 0), (0, 1, 0), (0, 0, 1)] {
                    let (i2, j2, k2) = (i + di, j + dj, k + dk);
                    if i2 < NX && j2 < NY && k2 < NZ {
                        let b = index(i2, j2, k2);
                        bonds.push(a as u32, b as u32, positions[b] - positions[a], [0; 3]);
                    }
                }
            }
        }
    }
    (packing, bonds)
}

/// An affine load: displacement gradient ε·`gradient` and the traction component `dir` on
/// the cut normal to the bar's axis t that is reported as the stress.
struct Load {
    gradient: Mat3,
    dir: Vec3,
}

impl Load {
    /// Direct tension along t: gradient t⊗t, stress σ_tt.
    fn tension(t: &Vec3) -> Load {
        Load {
            gradient: t * t.transpose(),
            dir: *t,
        }
    }

    /// Pure shear in the (t, s) plane: gradient ½(s⊗t + t⊗s) (no rotation, so the particles'
    /// torques balance without turning), stress σ_ts.
    fn shear(t: &Vec3, s: &Vec3) -> Load {
        Load {
            gradient: (s * t.transpose() + t * s.transpose()) * 0.5,
            dir: *s,
        }
    }
}

/// Each bond's local loads and its force on j at the affine displacement gradient ε·G:
/// the relative displacement of j is ε·G·l, split along and across the bond normal.
fn affine_loads(bonds: &BondSet, load: &Load, eps: f64) -> Vec<(LocalLoads, Vec3)> {
    (0..bonds.len())
        .map(|b| {
            let n = bonds.normal[b];
            let delta = load.gradient * (n * bonds.length[b]) * eps;
            let dn = n.dot(&delta);
            let ds = delta - n * dn;
            let force_on_j = -(n * (KN * dn)) - ds * KS;
            let loads = LocalLoads {
                normal: -KN * dn,
                shear: KS * ds.norm(),
                ..Default::default()
            };
            (loads, force_on_j)
        })
        .collect()
}

/// The traction along `load.dir` across the cut between layers 2 and 3 (normal to t): the
/// bonds' forces on their lower ends over the bar's section NX·NY·d².
fn stress(bonds: &BondSet, packing: &Packing, t: &Vec3, load: &Load, eps: f64) -> f64 {
    let cut = 2.5 * D;
    let loads = affine_loads(bonds, load, eps);
    let mut sum = 0.0;
    for (b, (_, force_on_j)) in loads.iter().enumerate() {
        let zi = packing.positions[bonds.i[b] as usize].dot(t);
        let zj = zi + bonds.length[b] * bonds.normal[b].dot(t);
        if (zi - cut) * (zj - cut) < 0.0 {
            let on_lower = -force_on_j * if zi < zj { 1.0 } else { -1.0 };
            sum += on_lower.dot(&load.dir);
        }
    }
    sum / (NX * NY) as f64 / (D * D)
}

/// The largest stress before the first bond breaks, by bisection on ε.
fn peak(
    bonds: &BondSet,
    packing: &Packing,
    t: &Vec3,
    load: &Load,
    judge: &dyn Fn(usize, &LocalLoads, &Vec3) -> Failure,
) -> f64 {
    let any_broken = |eps: f64| {
        affine_loads(bonds, load, eps)
            .iter()
            .enumerate()
            .any(|(b, (l, f))| judge(b, l, f).broken)
    };
    let (mut lo, mut hi) = (0.0, 1e-9);
    while !any_broken(hi) {
        lo = hi;
        hi *= 2.0;
        assert!(hi < 1.0, "nothing breaks");
    }
    for _ in 0..200 {
        let mid = 0.5 * (lo + hi);
        if mid <= lo || mid >= hi {
            break;
        }
        if any_broken(mid) {
            hi = mid;
        } else {
            lo = mid;
        }
    }
    stress(bonds, packing, t, load, lo)
}

fn close(got: f64, want: f64) {
    assert!(
        (got / want - 1.0).abs() < 1e-9,
        "peak {got} Pa, expected {want} Pa"
    );
}

/// A cross-anisotropic strength whose axis makes 60° with the bar: the axial bonds' tensile
/// strength is sin²60°·across + cos²60°·along = 0.75·4 + 0.25·2 = 3.5 MPa (by hand).
fn spec(planes: Vec<PlaneFamily>) -> StrengthSpec {
    let q = rotation();
    let (s, c) = 60f64.to_radians().sin_cos();
    StrengthSpec {
        scheme: StrengthScheme::CrossAnisotropic(CrossStrength {
            along: Strength::new(2.0e6, 3.0e6),
            across: Strength::new(4.0e6, 9.0e6),
            axis: q * Vec3::new(s, 0.0, c),
        }),
        planes,
        scatter: None,
    }
}

const AXIAL_TENSILE: f64 = 3.5e6;

#[test]
fn the_peak_is_the_bond_tensile_limit_times_bonds_per_area_for_every_law() {
    let (packing, bonds) = bar();
    let t = rotation() * Vec3::z();
    let st: BondStrengths = assign_strength(&packing, &bonds, &spec(Vec::new())).unwrap();
    let tension = Load::tension(&t);
    // YADE: a_n = σ_t·R² (its r², no π).
    let yade = |b: usize, l: &LocalLoads, _: &Vec3| {
        yade_cohfrict(&YadeAdhesion::of(&st.get(b), R, R, false), l)
    };
    close(
        peak(&bonds, &packing, &t, &tension, &yade),
        AXIAL_TENSILE * R * R / (D * D),
    );
    // LAMMPS bpm/rotational: f_rc = σ_t·πR² (the limits made once per bond, as a bond loop
    // would).
    let limits = st.map(|_, s| BpmLimits::of(&s, R, PI));
    let bpm = |b: usize, l: &LocalLoads, _: &Vec3| lammps_bpm(&limits[b], l);
    close(
        peak(&bonds, &packing, &t, &tension, &bpm),
        AXIAL_TENSILE * PI * R * R / (D * D),
    );
    // Parallel bond: σ = −F_n/A reaches σ_c.
    let pb = |b: usize, l: &LocalLoads, _: &Vec3| {
        parallel_bond(&ParallelBondSection::of(&st.get(b), R, PI), l)
    };
    close(
        peak(&bonds, &packing, &t, &tension, &pb),
        AXIAL_TENSILE * PI * R * R / (D * D),
    );
}

#[test]
fn a_weak_plane_across_the_bar_sets_the_peak_by_its_joint_strength() {
    let (packing, bonds) = bar();
    let t = rotation() * Vec3::z();
    for (joint_tensile, expected) in [(1.0e6, 1.0e6), (8.0e6, AXIAL_TENSILE)] {
        // One plane between layers 2 and 3 (offset 2.5 d along t, spacing far beyond the bar).
        let family = PlaneFamily::new(
            t,
            100.0 * D,
            2.5 * D,
            Strength {
                friction: 0.6,
                ..Strength::new(joint_tensile, 1.0e7)
            },
        )
        .unwrap();
        let sp = spec(vec![family.clone()]);
        let st = assign_strength(&packing, &bonds, &sp).unwrap();
        // Exactly the NX·NY axial bonds between layers 2 and 3 are joint bonds.
        let joints: Vec<usize> = (0..bonds.len())
            .filter(|&b| st.joint_of(b) == Some(0))
            .collect();
        assert_eq!(joints.len(), NX * NY);
        for &b in &joints {
            let zi = packing.positions[bonds.i[b] as usize].dot(&t);
            assert!((zi - 2.0 * D).abs() < 1e-12 && (bonds.normal[b].dot(&t) - 1.0).abs() < 1e-12);
            assert_eq!(st.tensile[b], joint_tensile);
        }
        // Joint bonds by the joint criterion on the plane, the others by the parallel bond.
        let judge = |b: usize, l: &LocalLoads, f: &Vec3| match st.joint_of(b) {
            Some(k) => {
                let (fn_, fs) = resolve_on_plane(f, &bonds.normal[b], &sp.planes[k].normal);
                let on_plane = LocalLoads {
                    normal: fn_,
                    shear: fs,
                    ..Default::default()
                };
                joint(&JointLimits::of(&st.get(b), R, PI), &on_plane)
            }
            None => parallel_bond(&ParallelBondSection::of(&st.get(b), R, PI), l),
        };
        close(
            peak(&bonds, &packing, &t, &Load::tension(&t), &judge),
            expected * PI * R * R / (D * D),
        );
    }
}

/// The cohesion of the bonds along s = Q·x, at 30° from the axis (sin²θ = ¼):
/// 0.25·9 + 0.75·3 = 4.5 MPa, below the 7.5 MPa of the axial bonds (0.75·9 + 0.25·3) that
/// carry the same shear force: they set the peak (by hand).
const TRANSVERSE_COHESION: f64 = 4.5e6;

#[test]
fn pure_shear_peaks_at_the_weakest_loaded_bonds_shear_limit_times_bonds_per_area() {
    let (packing, bonds) = bar();
    let q = rotation();
    let (t, s) = (q * Vec3::z(), q * Vec3::x());
    let shear = Load::shear(&t, &s);
    let st = assign_strength(&packing, &bonds, &spec(Vec::new())).unwrap();
    // No normal force in pure shear: YADE's limit is a_s = c·R² (its friction term is 0).
    let yade = |b: usize, l: &LocalLoads, _: &Vec3| {
        yade_cohfrict(&YadeAdhesion::of(&st.get(b), R, R, false), l)
    };
    let want = TRANSVERSE_COHESION * R * R / (D * D);
    close(peak(&bonds, &packing, &t, &shear, &yade), want);
    let limits = st.map(|_, s| BpmLimits::of(&s, R, PI));
    let bpm = |b: usize, l: &LocalLoads, _: &Vec3| lammps_bpm(&limits[b], l);
    let want = TRANSVERSE_COHESION * PI * R * R / (D * D);
    close(peak(&bonds, &packing, &t, &shear, &bpm), want);
    let pb = |b: usize, l: &LocalLoads, _: &Vec3| {
        parallel_bond(&ParallelBondSection::of(&st.get(b), R, PI), l)
    };
    close(peak(&bonds, &packing, &t, &shear, &pb), want);
}
