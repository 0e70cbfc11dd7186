//! C++ bridge (the `cxx` crate, feature `ffi`): models, per-bond springs, bond tables and
//! stiffness tensors for C++ programs such as the LIGGGHTS driver in `cpp/liggghts/`.
//!
//! Every fallible function returns `Result`, which cxx turns into a C++ exception
//! (`rust::Error`, derived from `std::exception`) whose `what()` is the library's error
//! message. Build the static library and headers with `make -C cpp` (see `cpp/README.md`).
//!
//! Conventions as in the Rust library: SI units, Voigt order 11, 22, 33, 23, 13, 12,
//! engineering shear strain, tensors row-major in [`bridge::Tensor6::c`].

use crate::assembly::{Assembly, MethodKind, MethodOptions};
use crate::bonds::{self, BondSet, BondStiffness};
use crate::homogenize::mean_field;
use crate::model::Model;
use crate::packing::{Packing, PeriodicCell};
use crate::schemes::StiffnessScheme;
use crate::tensor::Stiffness6;
use crate::{Error, Result, Vec3};
use std::path::Path;

// The code cxx generates uses items newer than the crate's MSRV; the `ffi` feature needs
// the Rust version cxx itself requires.
#[allow(clippy::incompatible_msrv)]
#[cxx::bridge(namespace = "anisobond")]
/// The cxx bridge: the types and functions that C++ code sees (cpp/README.md).
pub mod bridge {
    /// Normal and shear magnitudes of a scheme along one direction (unit of the model's
    /// geometry convention).
    #[derive(Clone, Copy, Debug, PartialEq)]
    pub struct Magnitudes {
        /// Normal magnitude.
        pub normal: f64,
        /// Shear magnitude.
        pub shear: f64,
    }

    /// The four springs of a bond: k_n, k_s in N/m; k_r, k_tw in N·m/rad.
    #[derive(Clone, Copy, Debug, PartialEq)]
    pub struct BondSprings {
        /// Normal spring.
        pub kn: f64,
        /// Shear spring.
        pub ks: f64,
        /// Bending spring.
        pub kr: f64,
        /// Twisting spring.
        pub ktw: f64,
    }

    /// One row of the SPEC bond table: particles `i < j` (0-based, packing order; the
    /// LIGGGHTS atom ids are i+1, j+1), unit normal from i to the image (ix, iy, iz) of j,
    /// centre distance `length` (m), bond radius (m) and springs.
    #[derive(Clone, Copy, Debug, PartialEq)]
    pub struct BondRow {
        /// First particle (0-based).
        pub i: u32,
        /// Second particle (0-based), > i.
        pub j: u32,
        /// Normal x.
        pub nx: f64,
        /// Normal y.
        pub ny: f64,
        /// Normal z.
        pub nz: f64,
        /// Initial centre distance (m).
        pub length: f64,
        /// Bond radius R_b (m).
        pub radius: f64,
        /// Normal spring (N/m).
        pub kn: f64,
        /// Shear spring (N/m).
        pub ks: f64,
        /// Bending spring (N·m/rad).
        pub kr: f64,
        /// Twisting spring (N·m/rad).
        pub ktw: f64,
        /// Periodic image of j along x.
        pub ix: i32,
        /// Periodic image of j along y.
        pub iy: i32,
        /// Periodic image of j along z.
        pub iz: i32,
    }

    /// The box the atoms of a simulation sit in (LIGGGHTS `domain`): bounds (m), tilt
    /// factors xy, xz, yz (m) and periodicity per direction.
    #[derive(Clone, Copy, Debug, PartialEq)]
    pub struct AtomsBox {
        /// Lower bounds xlo, ylo, zlo (m).
        pub lo: [f64; 3],
        /// Upper bounds xhi, yhi, zhi (m).
        pub hi: [f64; 3],
        /// Tilt factors xy, xz, yz (m); must be 0 (the library's cell is orthorhombic).
        pub tilt: [f64; 3],
        /// Periodic along x, y, z: all three (a periodic cell) or none (a free cluster).
        pub periodic: [bool; 3],
    }

    /// The bonds of atoms given by arrays ([`bond_atoms`]): `ids[k]` is the id of the
    /// particle that rows call `k` (the atoms sorted by id), so a row joins atoms
    /// `ids[i] < ids[j]`.
    #[derive(Clone, Debug, PartialEq)]
    pub struct AtomBonds {
        /// The bond table, `i`, `j` indexing `ids`.
        pub rows: Vec<BondRow>,
        /// The atoms' ids in ascending order.
        pub ids: Vec<u64>,
    }

    /// One bond's limits in YADE's CohFrict law (`strength::criteria::YadeAdhesion`, YADE
    /// 2023.02a: moments elastic): normalAdhesion a_n, shearAdhesion a_s (N), tan φ.
    #[derive(Clone, Copy, Debug, PartialEq)]
    pub struct YadeLimits {
        /// normalAdhesion a_n = σ_t·r² (N), r = min(R_i, R_j).
        pub normal: f64,
        /// shearAdhesion a_s = c·r² (N).
        pub shear: f64,
        /// tangensOfFrictionAngle μ.
        pub tan_friction: f64,
    }

    /// The verdict of a failure criterion on one bond (`strength::Failure`).
    #[derive(Clone, Copy, Debug, PartialEq)]
    pub struct BondVerdict {
        /// The bond breaks at these loads.
        pub broken: bool,
        /// 0 tension, 1 shear, 2 bending, 3 twisting (while intact: the largest term).
        pub mode: u8,
        /// Failure index, 1 at the limit.
        pub index: f64,
    }

    /// A 6×6 Voigt stiffness tensor (Pa), row-major: c[6·a + b] = C[a][b].
    #[derive(Clone, Copy, Debug, PartialEq)]
    pub struct Tensor6 {
        /// Components, row-major.
        pub c: [f64; 36],
    }

    /// One particle of the many-body term: atom id and volume share V_p (m³; 0 = excluded).
    #[derive(Clone, Copy, Debug, PartialEq)]
    pub struct ManyBodyParticle {
        /// Atom id.
        pub id: u64,
        /// V_p (m³).
        pub volume: f64,
        /// The entry of `ManyBodyData::d` it loads (its grain's D; 0 with one tensor).
        pub tensor: u32,
    }

    /// One bond's many-body fit coefficients a = A_p⁻¹ L_b (1/m) at its first (`coef_i`) and
    /// second (`coef_j`) particle, L_b oriented from the first to the second.
    #[derive(Clone, Copy, Debug, PartialEq)]
    pub struct ManyBodyCoef {
        /// Atom id of the first particle.
        pub id_i: u64,
        /// Atom id of the second particle.
        pub id_j: u64,
        /// A_i⁻¹ L_b.
        pub coef_i: [f64; 3],
        /// A_j⁻¹ L_b.
        pub coef_j: [f64; 3],
    }

    /// The many-body term (docs/manybody.md) for an engine: D (Voigt, row-major, Pa; one, or
    /// one per grain of a polycrystal), the measure, particle volumes and per-bond
    /// coefficients aligned with the bond rows.
    #[derive(Clone, Debug, PartialEq)]
    pub struct ManyBodyData {
        /// The tensors D, 36 entries each, row-major: d[36·t + 6·a + b] = D_t[a][b].
        pub d: Vec<f64>,
        /// Green–Lagrange (true) or small strain (false).
        pub green_lagrange: bool,
        /// Every particle.
        pub particles: Vec<ManyBodyParticle>,
        /// Every bond, in the order of the bond rows.
        pub bonds: Vec<ManyBodyCoef>,
    }

    extern "Rust" {
        /// A validated model (bonding rule, scheme, geometry), optionally bound to a packing.
        type ModelHandle;

        /// Read a model file (TOML, or JSON by extension).
        fn load_model(path: &str) -> Result<Box<ModelHandle>>;
        /// Parse a model from text; `format` is "toml" or "json".
        fn parse_model(text: &str, format: &str) -> Result<Box<ModelHandle>>;
        /// True when the scheme needs a bonded packing (cross-anisotropic: lattice scaling).
        fn needs_packing(self: &ModelHandle) -> bool;
        /// Bond the packing by the model's rule and build the scheme with it.
        fn bind_packing(self: &mut ModelHandle, packing_path: &str) -> Result<()>;
        /// Build the scheme with a given lattice scaling μ instead of from a packing file
        /// (cross-anisotropic; e.g. μ = π̂·Σ(½ l·min(R_i, R_j)²)/(3V) summed over all bonds
        /// by an MPI program). Ignored by the other schemes, which need no μ.
        fn set_lattice_scaling(self: &mut ModelHandle, mu: f64) -> Result<()>;
        /// The geometry's π̂ (bond cross-section π̂·R_b²), the factor of μ.
        fn pi_hat(self: &ModelHandle) -> f64;
        /// The scheme's name.
        fn scheme_name(self: &ModelHandle) -> Result<String>;
        /// The scheme's magnitudes along the lab direction (nx, ny, nz) (normalised here).
        fn magnitudes(self: &ModelHandle, nx: f64, ny: f64, nz: f64) -> Result<Magnitudes>;
        /// Springs of a bond with initial normal (nx, ny, nz), radii ri, rj (m) and centre
        /// distance `length` (m).
        fn bond_springs(
            self: &ModelHandle,
            nx: f64,
            ny: f64,
            nz: f64,
            ri: f64,
            rj: f64,
            length: f64,
        ) -> Result<BondSprings>;
        /// Mean-field tensor (Pa) for a given prefactor N_c⟨l²·g⟩/V (Truszkowska 2018
        /// App. A); with the `spring` convention and prefactor 1 it is the orientation
        /// average T of docs/references.md.
        fn mean_field_tensor(self: &ModelHandle, prefactor: f64) -> Result<Tensor6>;

        /// Read a SPEC bond table (CSV).
        fn load_bond_table(path: &str) -> Result<Vec<BondRow>>;
        /// Bond a packing file by the model's rule and assign springs.
        fn build_bond_table(packing_path: &str, model: &ModelHandle) -> Result<Vec<BondRow>>;
        /// Bond atoms given by arrays (positions `x` as x0 y0 z0 x1 …, radii, distinct ids,
        /// any order) in their box by the model's rule and assign springs, exactly as the
        /// CLI bonds the same packing read from a file (cross-anisotropic μ from these
        /// bonds). Periodic in all three directions: the box is the periodic cell; in none:
        /// a free cluster; mixed periodicity or a tilted box is refused. When
        /// `write_bonds` is not empty the table is also written there (SPEC columns, then
        /// `id_i,id_j`), as `anisobond bonds` writes it.
        fn bond_atoms(
            model: &ModelHandle,
            x: &[f64],
            radius: &[f64],
            ids: &[u64],
            domain: &AtomsBox,
            write_bonds: &str,
        ) -> Result<AtomBonds>;
        /// Write bond rows as a SPEC bond table.
        fn write_bond_table(path: &str, rows: &[BondRow]) -> Result<()>;
        /// Stiffness tensor (Pa) of a packing file + model by `method`, any name of
        /// `anisobond tensor --method` (mean-field, voigt, relaxed, prestressed, laf,
        /// dynamic) with the default options of `MethodOptions`.
        fn compute_tensor(packing_path: &str, model: &ModelHandle, method: &str)
            -> Result<Tensor6>;
        /// The library's version.
        fn library_version() -> String;

        /// True when the model has a `[strength]` table (docs/strength.md).
        fn has_strength(self: &ModelHandle) -> bool;
        /// Every bond's YADE CohFrict limits by the model's `[strength]` table, aligned with
        /// the rows of `build_bond_table(packing_path, model)`; empty without the table.
        fn packing_yade_limits(packing_path: &str, model: &ModelHandle) -> Result<Vec<YadeLimits>>;
        /// Every bond's YADE CohFrict limits, aligned with the rows of `bond_atoms` of the
        /// same atoms; empty when the model has no `[strength]` table.
        fn atoms_yade_limits(
            model: &ModelHandle,
            x: &[f64],
            radius: &[f64],
            ids: &[u64],
            domain: &AtomsBox,
        ) -> Result<Vec<YadeLimits>>;
        /// The columns `normal_adhesion,shear_adhesion,tan_friction` of a bond table (as
        /// `anisobond export yade` writes them for a model with `[strength]`), aligned with
        /// `load_bond_table`'s rows; empty when the table has none.
        fn load_yade_limits(path: &str) -> Result<Vec<YadeLimits>>;
        /// YADE's CohFrict criterion (`strength::criteria::yade_cohfrict`, fragile, moments
        /// elastic) on one bond: normal force `normal` (N, compression positive) and shear
        /// magnitude `shear` (N). Allocation-free: for a per-bond, per-step call.
        fn yade_cohfrict_check(limits: &YadeLimits, normal: f64, shear: f64) -> BondVerdict;

        /// True when the model has a `[manybody]` table (docs/manybody.md).
        fn has_manybody(self: &ModelHandle) -> bool;
        /// A many-body table as `anisobond export liggghts` writes it (`manybody.txt`).
        fn load_manybody(path: &str) -> Result<ManyBodyData>;
        /// The model's many-body term on a packing file, aligned with the rows of
        /// `build_bond_table(packing_path, model)`; refused without `[manybody]`.
        fn packing_manybody(packing_path: &str, model: &ModelHandle) -> Result<ManyBodyData>;
        /// The model's many-body term on atoms given by arrays, aligned with the rows of
        /// `bond_atoms` of the same atoms; refused without `[manybody]`.
        fn atoms_manybody(
            model: &ModelHandle,
            x: &[f64],
            radius: &[f64],
            ids: &[u64],
            domain: &AtomsBox,
        ) -> Result<ManyBodyData>;
    }
}

use crate::strength::criteria::{yade_cohfrict, LocalLoads, YadeAdhesion, YadeMoments};
use crate::strength::Mode;
use bridge::{
    AtomBonds, AtomsBox, BondRow, BondSprings, BondVerdict, Magnitudes, ManyBodyCoef, ManyBodyData,
    ManyBodyParticle, Tensor6, YadeLimits,
};

/// Opaque model for C++: the model, and the scheme once built.
pub struct ModelHandle {
    model: Model,
    scheme: Option<Box<dyn StiffnessScheme>>,
}

impl ModelHandle {
    fn new(model: Model) -> Result<Box<ModelHandle>> {
        let scheme = if model.needs_packing() {
            None
        } else {
            Some(model.build_scheme(None)?)
        };
        Ok(Box::new(ModelHandle { model, scheme }))
    }

    fn scheme(&self) -> Result<&dyn StiffnessScheme> {
        self.scheme.as_deref().ok_or_else(|| {
            Error::Model(
                "this scheme needs a bonded packing first: call bind_packing(packing_path)".into(),
            )
        })
    }

    fn needs_packing(&self) -> bool {
        self.model.needs_packing()
    }

    fn bind_packing(&mut self, packing_path: &str) -> Result<()> {
        let asm = assembly(packing_path, self)?;
        self.scheme = Some(self.model.build_scheme(Some((&asm.packing, &asm.bonds)))?);
        Ok(())
    }

    fn set_lattice_scaling(&mut self, mu: f64) -> Result<()> {
        if !mu.is_finite() || mu <= 0.0 {
            return Err(Error::Invalid(format!(
                "set_lattice_scaling: μ must be finite and > 0, got {mu}"
            )));
        }
        if self.model.needs_packing() {
            self.scheme = Some(self.model.scheme_for(Some(mu))?);
        }
        Ok(())
    }

    fn has_strength(&self) -> bool {
        self.model.strength.is_some()
    }

    fn pi_hat(&self) -> f64 {
        self.model.geometry.pi_hat
    }

    fn scheme_name(&self) -> Result<String> {
        Ok(self.scheme()?.name())
    }

    fn magnitudes(&self, nx: f64, ny: f64, nz: f64) -> Result<Magnitudes> {
        let n = unit(nx, ny, nz)?;
        let m = self.scheme()?.magnitudes(&n);
        Ok(Magnitudes {
            normal: m.normal,
            shear: m.shear,
        })
    }

    fn bond_springs(
        &self,
        nx: f64,
        ny: f64,
        nz: f64,
        ri: f64,
        rj: f64,
        length: f64,
    ) -> Result<BondSprings> {
        let n = unit(nx, ny, nz)?;
        for (name, v) in [("ri", ri), ("rj", rj), ("length", length)] {
            if !v.is_finite() || v <= 0.0 {
                return Err(Error::Invalid(format!(
                    "bond_springs: {name} must be finite and > 0, got {v}"
                )));
            }
        }
        let m = self.scheme()?.magnitudes(&n);
        let s = self.model.geometry.springs(m, ri, rj, length);
        Ok(BondSprings {
            kn: s.kn,
            ks: s.ks,
            kr: s.kr,
            ktw: s.ktw,
        })
    }

    fn mean_field_tensor(&self, prefactor: f64) -> Result<Tensor6> {
        if !prefactor.is_finite() || prefactor <= 0.0 {
            return Err(Error::Invalid(format!(
                "mean_field_tensor: prefactor must be finite and > 0, got {prefactor}"
            )));
        }
        let c = mean_field::mean_field(self.scheme()?, prefactor, mean_field::DEFAULT_ORDER);
        Ok(tensor6(&c))
    }
}

fn unit(nx: f64, ny: f64, nz: f64) -> Result<Vec3> {
    let v = Vec3::new(nx, ny, nz);
    let n = v.norm();
    if !n.is_finite() || n == 0.0 {
        return Err(Error::Invalid(format!(
            "bond normal ({nx}, {ny}, {nz}) must be a finite non-zero vector"
        )));
    }
    Ok(v / n)
}

fn tensor6(c: &Stiffness6) -> Tensor6 {
    let mut out = [0.0; 36];
    for a in 0..6 {
        for b in 0..6 {
            out[6 * a + b] = c[(a, b)];
        }
    }
    Tensor6 { c: out }
}

/// The library's assembly of a packing file under the handle's model (the same entry point
/// as every other client).
fn assembly(packing_path: &str, handle: &ModelHandle) -> Result<Assembly> {
    Assembly::from_packing_file(
        Path::new(packing_path),
        handle.model.clone(),
        Path::new("model"),
    )
}

fn rows(bonds: &BondSet, k: &BondStiffness) -> Vec<BondRow> {
    (0..bonds.len())
        .map(|b| {
            let n = bonds.normal[b];
            let im = bonds.image[b];
            BondRow {
                i: bonds.i[b],
                j: bonds.j[b],
                nx: n.x,
                ny: n.y,
                nz: n.z,
                length: bonds.length[b],
                radius: k.radius[b],
                kn: k.kn[b],
                ks: k.ks[b],
                kr: k.kr[b],
                ktw: k.ktw[b],
                ix: im[0],
                iy: im[1],
                iz: im[2],
            }
        })
        .collect()
}

fn load_model(path: &str) -> Result<Box<ModelHandle>> {
    ModelHandle::new(Model::from_path(Path::new(path))?)
}

fn parse_model(text: &str, format: &str) -> Result<Box<ModelHandle>> {
    let model = match format {
        "toml" => Model::from_toml_str(text, "<model text>")?,
        "json" => Model::from_json_str(text, "<model text>")?,
        other => {
            return Err(Error::Invalid(format!(
                "parse_model: format \"{other}\": expected \"toml\" or \"json\""
            )))
        }
    };
    ModelHandle::new(model)
}

/// The table's rows as the engines' plugins key them, by atom id − 1: a table with
/// `id_i,id_j` columns (a packing with its own atom ids) gives i = id_i − 1, j = id_j − 1,
/// so that the plugins find the user's atoms; else the packing indices (ids 1…N).
fn load_bond_table(path: &str) -> Result<Vec<BondRow>> {
    let (bonds, k, ids) = bonds::table::read_bond_table_atom_ids(Path::new(path))?;
    let mut rows = rows(&bonds, &k);
    if let Some(ids) = ids {
        for (r, [a, b]) in rows.iter_mut().zip(ids) {
            let fit = |id: u64| {
                u32::try_from(id.wrapping_sub(1)).map_err(|_| {
                    Error::Invalid(format!(
                        "{path}: atom id {id} exceeds 2^32, the largest the bridge carries"
                    ))
                })
            };
            (r.i, r.j) = (fit(a)?, fit(b)?);
        }
    }
    Ok(rows)
}

/// The bonds of a packing file by the model (or a data file's own Bonds section), keyed
/// as [`load_bond_table`] keys them: by atom id − 1 when the file gives atom ids (all ≥ 1,
/// as the exports write them: `crate::export::engine_ids`).
fn build_bond_table(packing_path: &str, model: &ModelHandle) -> Result<Vec<BondRow>> {
    let asm = assembly(packing_path, model)?;
    let mut rows = rows(&asm.bonds, &asm.springs);
    if let Some(ids) = crate::export::engine_ids(&asm.packing) {
        let fit = |p: u32| {
            let id = ids[p as usize];
            u32::try_from(id.wrapping_sub(1)).map_err(|_| {
                Error::Invalid(format!(
                    "{packing_path}: atom id {id} is outside 1 to 2^32, the ids the bridge carries"
                ))
            })
        };
        for r in &mut rows {
            (r.i, r.j) = (fit(r.i)?, fit(r.j)?);
        }
    }
    Ok(rows)
}

/// The packing of atoms given by arrays (see the bridge's `bond_atoms`), sorted by id.
fn atoms_packing(x: &[f64], radius: &[f64], ids: &[u64], domain: &AtomsBox) -> Result<Packing> {
    let n = ids.len();
    if n == 0 {
        return Err(Error::Invalid("bond_atoms: no atoms to bond".into()));
    }
    if x.len() != 3 * n || radius.len() != n {
        return Err(Error::Invalid(format!(
            "bond_atoms: {n} ids need {} position components and {n} radii, got {} and {}",
            3 * n,
            x.len(),
            radius.len()
        )));
    }
    if let Some(t) = domain.tilt.iter().find(|t| **t != 0.0) {
        return Err(Error::Invalid(format!(
            "bond_atoms: the box is tilted (tilt factor {t} m): the library's periodic cell is \
             orthorhombic; bond the atoms before `change_box ... triclinic` tilts the box"
        )));
    }
    let cell = match domain.periodic {
        [true, true, true] => {
            let l = Vec3::new(
                domain.hi[0] - domain.lo[0],
                domain.hi[1] - domain.lo[1],
                domain.hi[2] - domain.lo[2],
            );
            Some(PeriodicCell::new(l)?)
        }
        [false, false, false] => None,
        p => {
            return Err(Error::Invalid(format!(
                "bond_atoms: the box is periodic along {} only: the library bonds a periodic \
                 cell (periodic along x, y and z) or a free cluster (periodic along none), \
                 not mixed periodicity",
                ["x", "y", "z"]
                    .iter()
                    .zip(p)
                    .filter(|(_, q)| *q)
                    .map(|(a, _)| *a)
                    .collect::<Vec<_>>()
                    .join(" and ")
            )))
        }
    };
    // Name a bad atom by its id (Packing::new would name its place in the sorted order).
    for k in 0..n {
        let (p, r) = (&x[3 * k..3 * k + 3], radius[k]);
        if p.iter().any(|c| !c.is_finite()) || !r.is_finite() || r <= 0.0 {
            return Err(Error::Invalid(format!(
                "bond_atoms: atom {}: expected a finite position and a radius > 0, got \
                 ({}, {}, {}) and {r}",
                ids[k], p[0], p[1], p[2]
            )));
        }
    }
    let mut order: Vec<usize> = (0..n).collect();
    order.sort_unstable_by_key(|&k| ids[k]);
    // Periodic: positions relative to the box origin, wrapped into the cell by
    // Packing::new (as a LIGGGHTS data file is read); free: as given.
    let origin = match cell {
        Some(_) => Vec3::new(domain.lo[0], domain.lo[1], domain.lo[2]),
        None => Vec3::zeros(),
    };
    let positions = order
        .iter()
        .map(|&k| Vec3::new(x[3 * k], x[3 * k + 1], x[3 * k + 2]) - origin)
        .collect();
    let radii = order.iter().map(|&k| radius[k]).collect();
    Packing::new(positions, radii, cell)?.with_ids(order.iter().map(|&k| ids[k]).collect())
}

fn bond_atoms(
    model: &ModelHandle,
    x: &[f64],
    radius: &[f64],
    ids: &[u64],
    domain: &AtomsBox,
    write_bonds: &str,
) -> Result<AtomBonds> {
    let packing = atoms_packing(x, radius, ids, domain)?;
    let asm = Assembly::new(packing, model.model.clone())?;
    if !write_bonds.is_empty() {
        asm.write_bonds(Path::new(write_bonds))?;
    }
    Ok(AtomBonds {
        rows: rows(&asm.bonds, &asm.springs),
        ids: asm.packing.ids.clone().unwrap_or_default(),
    })
}

fn write_bond_table(path: &str, rows: &[BondRow]) -> Result<()> {
    let mut bonds = BondSet::default();
    let mut k = BondStiffness::default();
    for (b, r) in rows.iter().enumerate() {
        if r.i >= r.j || r.length.is_nan() || r.length <= 0.0 {
            return Err(Error::Invalid(format!(
                "write_bond_table: row {b}: need i < j and length > 0, got i = {}, j = {}, length = {}",
                r.i, r.j, r.length
            )));
        }
        let n = unit(r.nx, r.ny, r.nz)?;
        bonds.push(r.i, r.j, n * r.length, [r.ix, r.iy, r.iz]);
        k.radius.push(r.radius);
        k.kn.push(r.kn);
        k.ks.push(r.ks);
        k.kr.push(r.kr);
        k.ktw.push(r.ktw);
    }
    bonds::table::write_bond_table(Path::new(path), &bonds, &k)
}

fn compute_tensor(packing_path: &str, model: &ModelHandle, method: &str) -> Result<Tensor6> {
    let kind: MethodKind = method
        .parse()
        .map_err(|e: Error| e.in_context("compute_tensor"))?;
    let method = MethodOptions::default().method(kind);
    let result = assembly(packing_path, model)?.tensor(&method)?;
    Ok(tensor6(&result.report.tensor()))
}

fn library_version() -> String {
    env!("CARGO_PKG_VERSION").to_string()
}

/// The bridge's record of a library limit.
fn limits_of(a: &YadeAdhesion) -> YadeLimits {
    YadeLimits {
        normal: a.normal,
        shear: a.shear,
        tan_friction: a.tan_friction,
    }
}

/// The YADE limits of an assembly's bonds (empty without `[strength]`).
fn assembly_limits(asm: &Assembly) -> Result<Vec<YadeLimits>> {
    Ok(
        crate::export::yade::yade_adhesions(&asm.packing, &asm.bonds, &asm.model)?
            .map(|a| a.iter().map(limits_of).collect())
            .unwrap_or_default(),
    )
}

fn packing_yade_limits(packing_path: &str, model: &ModelHandle) -> Result<Vec<YadeLimits>> {
    assembly_limits(&assembly(packing_path, model)?)
}

fn atoms_yade_limits(
    model: &ModelHandle,
    x: &[f64],
    radius: &[f64],
    ids: &[u64],
    domain: &AtomsBox,
) -> Result<Vec<YadeLimits>> {
    let packing = atoms_packing(x, radius, ids, domain)?;
    assembly_limits(&Assembly::new(packing, model.model.clone())?)
}

fn load_yade_limits(path: &str) -> Result<Vec<YadeLimits>> {
    let cols = crate::export::yade::read_adhesion_columns(Path::new(path))?;
    Ok(cols.iter().map(limits_of).collect())
}

fn yade_cohfrict_check(limits: &YadeLimits, normal: f64, shear: f64) -> BondVerdict {
    let a = YadeAdhesion {
        normal: limits.normal,
        shear: limits.shear,
        tan_friction: limits.tan_friction,
        cohesion_disables_friction: false,
        moments: YadeMoments::Elastic,
    };
    let f = yade_cohfrict(
        &a,
        &LocalLoads {
            normal,
            shear,
            bending: 0.0,
            twisting: 0.0,
        },
    );
    BondVerdict {
        broken: f.broken,
        mode: match f.mode {
            Mode::Tension => 0,
            Mode::Shear => 1,
            Mode::Bending => 2,
            Mode::Twisting => 3,
        },
        index: f.index,
    }
}

impl ModelHandle {
    fn has_manybody(&self) -> bool {
        self.model.manybody.is_some()
    }
}

fn manybody_data(t: &crate::export::liggghts::ManyBodyTable) -> ManyBodyData {
    let d = t
        .tensors
        .iter()
        .flat_map(|d| (0..36).map(move |k| d[(k / 6, k % 6)]))
        .collect();
    ManyBodyData {
        d,
        green_lagrange: t.measure == crate::manybody::StrainMeasure::GreenLagrange,
        particles: t
            .volumes
            .iter()
            .zip(&t.tensor)
            .map(|(&(id, volume), &tensor)| ManyBodyParticle { id, volume, tensor })
            .collect(),
        bonds: t
            .bonds
            .iter()
            .map(|b| ManyBodyCoef {
                id_i: b.ids[0],
                id_j: b.ids[1],
                coef_i: [b.coef_i.x, b.coef_i.y, b.coef_i.z],
                coef_j: [b.coef_j.x, b.coef_j.y, b.coef_j.z],
            })
            .collect(),
    }
}

fn load_manybody(path: &str) -> Result<ManyBodyData> {
    Ok(manybody_data(
        &crate::export::liggghts::read_manybody_table(Path::new(path))?,
    ))
}

/// The term of an assembly's bonds by its model's `[manybody]`, as the engines read it.
fn assembly_manybody(asm: &Assembly) -> Result<ManyBodyData> {
    let term = asm.manybody()?.ok_or_else(|| {
        Error::Model("the model has no [manybody] table (docs/manybody.md)".into())
    })?;
    Ok(manybody_data(&crate::export::liggghts::manybody_table(
        &asm.packing,
        &asm.bonds,
        &term,
    )?))
}

fn packing_manybody(packing_path: &str, model: &ModelHandle) -> Result<ManyBodyData> {
    assembly_manybody(&assembly(packing_path, model)?)
}

fn atoms_manybody(
    model: &ModelHandle,
    x: &[f64],
    radius: &[f64],
    ids: &[u64],
    domain: &AtomsBox,
) -> Result<ManyBodyData> {
    let packing = atoms_packing(x, radius, ids, domain)?;
    assembly_manybody(&Assembly::new(packing, model.model.clone())?)
}
