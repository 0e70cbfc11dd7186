//! VTK XML unstructured grids (`.vtu`) for ParaView, written with quick-xml.
//!
//! - particles: one vertex cell per sphere; point data `radius` (m), `displacement` (m),
//!   `rotation` (rad).
//! - bonds: one line cell per bond; a bond to a periodic image of j ends at that image
//!   (an extra point outside the cell) so that no line spans the box. Cell data `kn`, `ks`
//!   (N/m), `kr`, `ktw` (N·m/rad), `length` (m), `normal`, `force` (N, on i from j) and
//!   `normal_force` (N, n·f, tension positive).
//!
//! [`strained_state`] gives the displacements and bond forces of a periodic packing under a
//! macroscopic strain at quasi-static equilibrium (the relaxed solver's fluctuation field,
//! Kruyt 2014 Eqs. 10–14).

use crate::bonds::{BondSet, BondStiffness};
use crate::homogenize::relaxed::{relaxed_solve, RelaxedOptions};
use crate::packing::Packing;
use crate::tensor::Voigt6;
use crate::{Error, Mat3, Result, Vec3};
use quick_xml::events::{BytesDecl, BytesText, Event};
use quick_xml::Writer;
use std::io::Write;
use std::path::Path;

/// Displacements, rotations and bond forces of a strained packing.
#[derive(Clone, Debug)]
pub struct StrainedState {
    /// Engineering strain applied (Voigt order).
    pub strain: Voigt6,
    /// Displacement of every particle (m): affine ε·x plus the fluctuation.
    pub displacement: Vec<Vec3>,
    /// Rotation of every particle (rad).
    pub rotation: Vec<Vec3>,
    /// Force on i from j of every bond (N).
    pub force: Vec<Vec3>,
}

/// The symmetric strain tensor of a Voigt engineering strain.
pub fn strain_tensor(e: &Voigt6) -> Mat3 {
    Mat3::new(
        e[0],
        0.5 * e[5],
        0.5 * e[4],
        0.5 * e[5],
        e[1],
        0.5 * e[3],
        0.5 * e[4],
        0.5 * e[3],
        e[2],
    )
}

/// Quasi-static state of a periodic bonded packing under the macroscopic engineering strain
/// `strain`: fluctuation q = −Q·e from the relaxed solve (particles that carry no load keep
/// the affine displacement and their bonds no force), bond force f = S·Δ with
/// Δ = u_j − u_i + (r_i n)×ω_i + (r_j n)×ω_j + ε·l and S = k_s I + (k_n − k_s) nn.
pub fn strained_state(
    packing: &Packing,
    bonds: &BondSet,
    k: &BondStiffness,
    strain: &Voigt6,
    opts: &RelaxedOptions,
) -> Result<StrainedState> {
    let sol = relaxed_solve(packing, bonds, k, opts, None)?;
    let eps = strain_tensor(strain);
    let n = packing.len();
    let mut fluct = vec![Vec3::zeros(); n];
    let mut rotation = vec![Vec3::zeros(); n];
    let mut active = vec![false; n];
    for (q, &orig) in sol.q.iter().zip(&sol.active) {
        active[orig as usize] = true;
        let g = -(q * strain);
        fluct[orig as usize] = Vec3::new(g[0], g[1], g[2]);
        rotation[orig as usize] = Vec3::new(g[3], g[4], g[5]);
    }
    let displacement = (0..n)
        .map(|i| eps * packing.positions[i] + fluct[i])
        .collect();
    let force = (0..bonds.len())
        .map(|b| {
            let (i, j) = (bonds.i[b] as usize, bonds.j[b] as usize);
            if !(active[i] && active[j]) {
                // A bond of a pruned (dangling) particle carries no load.
                return Vec3::zeros();
            }
            let nrm = bonds.normal[b];
            let l = bonds.length[b];
            let (ri, rj) = opts.lever_arm.arms(packing.radii[i], packing.radii[j], l);
            let delta = fluct[j] - fluct[i]
                + (nrm * ri).cross(&rotation[i])
                + (nrm * rj).cross(&rotation[j])
                + eps * (nrm * l);
            let s = Mat3::identity() * k.ks[b] + nrm * nrm.transpose() * (k.kn[b] - k.ks[b]);
            s * delta
        })
        .collect();
    Ok(StrainedState {
        strain: *strain,
        displacement,
        rotation,
        force,
    })
}

type XmlResult = std::io::Result<()>;

/// The text `put` writes for each value (each ending in one space), formatted in parallel
/// chunks ([`crate::io::format_in_chunks`]) and joined in order, the last space dropped (a
/// 1,000,000-particle specimen's files hold ~40 million numbers).
fn join_by<T: Sync>(values: &[T], put: impl Fn(&mut String, &T) + Sync) -> String {
    let mut s = crate::io::format_in_chunks(values, put).concat();
    s.pop();
    s
}

/// The values' `Display` forms separated by single spaces ([`join_by`]).
fn join<T: std::fmt::Display + Sync>(values: &[T]) -> String {
    use std::fmt::Write as _;
    // Writing to a String cannot fail.
    join_by(values, |s, v| {
        let _ = write!(s, "{v} ");
    })
}

fn data_array<W: Write>(
    w: &mut Writer<W>,
    kind: &str,
    name: Option<&str>,
    components: usize,
    text: &str,
) -> XmlResult {
    let mut el = w.create_element("DataArray").with_attribute(("type", kind));
    if let Some(name) = name {
        el = el.with_attribute(("Name", name));
    }
    let comps = components.to_string();
    if components > 1 {
        el = el.with_attribute(("NumberOfComponents", comps.as_str()));
    }
    // Numbers only (digits, sign, point, exponent): nothing to escape, so not scanned.
    el.with_attribute(("format", "ascii"))
        .write_text_content(BytesText::from_escaped(text))?;
    Ok(())
}

/// The vectors' components x y z, all separated by single spaces ([`join_by`]).
fn vectors(v: &[Vec3]) -> String {
    use std::fmt::Write as _;
    join_by(v, |s, p| {
        let _ = write!(s, "{} {} {} ", p.x, p.y, p.z);
    })
}

/// An unstructured grid: points, cells (connectivity, offsets, VTK types) and data arrays
/// (name, components, ascii values).
struct Grid {
    points: Vec<Vec3>,
    connectivity: Vec<usize>,
    offsets: Vec<usize>,
    types: Vec<u8>,
    point_data: Vec<(String, usize, String)>,
    cell_data: Vec<(String, usize, String)>,
}

fn write_grid(path: &Path, grid: &Grid) -> Result<()> {
    // Rust writes non-finite f64 as `NaN`, `inf`, `-inf`: refuse them rather than give
    // ParaView a field it would plot as if it were data.
    let arrays = grid.point_data.iter().chain(&grid.cell_data);
    for (name, _, text) in arrays {
        // The fields hold numbers only: `NaN` and `inf` appear in no finite value's text.
        if text.contains("NaN") || text.contains("inf") {
            return Err(Error::Invalid(format!(
                "{}: the field `{name}` has non-finite values (an overflow: check the strain \
                 and the model's magnitudes); nothing was written",
                path.display()
            )));
        }
    }
    if grid.points.iter().any(|p| !p.iter().all(|x| x.is_finite())) {
        return Err(Error::Invalid(format!(
            "{}: non-finite particle positions; nothing was written",
            path.display()
        )));
    }
    crate::io::write_atomic(path, |out| {
        let mut w = Writer::new_with_indent(out, b' ', 1);
        let xml = (|| -> XmlResult {
            w.write_event(Event::Decl(BytesDecl::new("1.0", None, None)))?;
            w.create_element("VTKFile")
                .with_attribute(("type", "UnstructuredGrid"))
                .with_attribute(("version", "1.0"))
                .with_attribute(("byte_order", "LittleEndian"))
                .with_attribute(("header_type", "UInt64"))
                .write_inner_content(|w| {
                    w.create_element("UnstructuredGrid")
                        .write_inner_content(|w| {
                            let np = grid.points.len().to_string();
                            let nc = grid.types.len().to_string();
                            w.create_element("Piece")
                                .with_attribute(("NumberOfPoints", np.as_str()))
                                .with_attribute(("NumberOfCells", nc.as_str()))
                                .write_inner_content(|w| {
                                    for (element, fields) in [
                                        ("PointData", &grid.point_data),
                                        ("CellData", &grid.cell_data),
                                    ] {
                                        w.create_element(element).write_inner_content(|w| {
                                            for (name, c, text) in fields {
                                                data_array(w, "Float64", Some(name), *c, text)?;
                                            }
                                            Ok(())
                                        })?;
                                    }
                                    w.create_element("Points").write_inner_content(|w| {
                                        data_array(
                                            w,
                                            "Float64",
                                            Some("Points"),
                                            3,
                                            &vectors(&grid.points),
                                        )
                                    })?;
                                    w.create_element("Cells").write_inner_content(|w| {
                                        for (kind, name, text) in [
                                            ("Int64", "connectivity", join(&grid.connectivity)),
                                            ("Int64", "offsets", join(&grid.offsets)),
                                            ("UInt8", "types", join(&grid.types)),
                                        ] {
                                            data_array(w, kind, Some(name), 1, &text)?;
                                        }
                                        Ok(())
                                    })?;
                                    Ok(())
                                })?;
                            Ok(())
                        })?;
                    Ok(())
                })?;
            Ok(())
        })();
        xml.map_err(|e| Error::io(path, e))?;
        w.into_inner()
            .write_all(b"\n")
            .map_err(|e| Error::io(path, e))
    })
}

fn check_len(what: &str, got: usize, expected: usize) -> Result<()> {
    if got != expected {
        return Err(Error::Invalid(format!(
            "VTK export: {what} has {got} entries, expected {expected}"
        )));
    }
    Ok(())
}

/// Write the particles as vertex cells with `radius`, `displacement` and `rotation`
/// (zeros when not given).
pub fn write_particles_vtu(
    path: &Path,
    packing: &Packing,
    state: Option<&StrainedState>,
) -> Result<()> {
    write_particles_vtu_grains(path, packing, state, None)
}

/// [`write_particles_vtu`] with the point field `grain` (each particle's grain id, for
/// ParaView to colour grains; docs/polycrystal.md) when `grains` is given.
pub fn write_particles_vtu_grains(
    path: &Path,
    packing: &Packing,
    state: Option<&StrainedState>,
    grains: Option<&[u32]>,
) -> Result<()> {
    let n = packing.len();
    if let Some(g) = grains {
        check_len("grain", g.len(), n)?;
    }
    let zeros = vec![Vec3::zeros(); n];
    let (disp, rot) = match state {
        Some(s) => {
            check_len("displacement", s.displacement.len(), n)?;
            check_len("rotation", s.rotation.len(), n)?;
            (&s.displacement, &s.rotation)
        }
        None => (&zeros, &zeros),
    };
    let mut point_data = vec![
        ("radius".into(), 1, join(&packing.radii)),
        ("displacement".into(), 3, vectors(disp)),
        ("rotation".into(), 3, vectors(rot)),
    ];
    if let Some(g) = grains {
        point_data.push(("grain".into(), 1, join(g)));
    }
    let grid = Grid {
        points: packing.positions.clone(),
        connectivity: (0..n).collect(),
        offsets: (1..=n).collect(),
        types: vec![1; n], // VTK_VERTEX
        point_data,
        cell_data: Vec::new(),
    };
    write_grid(path, &grid)
}

/// Write the bonds as line cells with their springs, geometry and forces (zeros when no
/// state is given).
pub fn write_bonds_vtu(
    path: &Path,
    packing: &Packing,
    bonds: &BondSet,
    stiffness: &BondStiffness,
    state: Option<&StrainedState>,
) -> Result<()> {
    write_bonds_vtu_grains(path, packing, bonds, stiffness, state, None)
}

/// [`write_bonds_vtu`] with the cell fields `grain_i`, `grain_j` (the grains of each bond's
/// particles, `grains` indexed by particle; docs/polycrystal.md) when `grains` is given.
pub fn write_bonds_vtu_grains(
    path: &Path,
    packing: &Packing,
    bonds: &BondSet,
    stiffness: &BondStiffness,
    state: Option<&StrainedState>,
    grains: Option<&[u32]>,
) -> Result<()> {
    let nb = bonds.len();
    if let Some(g) = grains {
        check_len("grain", g.len(), packing.len())?;
    }
    check_len("bond stiffness", stiffness.len(), nb)?;
    let zeros = vec![Vec3::zeros(); nb];
    let force = match state {
        Some(s) => {
            check_len("bond force", s.force.len(), nb)?;
            &s.force
        }
        None => &zeros,
    };
    let mut points = packing.positions.clone();
    let mut connectivity = Vec::with_capacity(2 * nb);
    for b in 0..nb {
        let (i, j) = (bonds.i[b] as usize, bonds.j[b] as usize);
        connectivity.push(i);
        if bonds.image[b] == [0, 0, 0] {
            connectivity.push(j);
        } else {
            // End the line at the periodic image of j: x_i + l.
            connectivity.push(points.len());
            points.push(packing.positions[i] + bonds.branch(b));
        }
    }
    let normal_force: Vec<f64> = (0..nb).map(|b| bonds.normal[b].dot(&force[b])).collect();
    let mut cell_data = vec![
        ("kn".into(), 1, join(&stiffness.kn)),
        ("ks".into(), 1, join(&stiffness.ks)),
        ("kr".into(), 1, join(&stiffness.kr)),
        ("ktw".into(), 1, join(&stiffness.ktw)),
        ("length".into(), 1, join(&bonds.length)),
        ("normal".into(), 3, vectors(&bonds.normal)),
        ("force".into(), 3, vectors(force)),
        ("normal_force".into(), 1, join(&normal_force)),
    ];
    if let Some(g) = grains {
        for (name, ends) in [("grain_i", &bonds.i), ("grain_j", &bonds.j)] {
            cell_data.push((
                name.into(),
                1,
                join(&ends.iter().map(|&p| g[p as usize]).collect::<Vec<u32>>()),
            ));
        }
    }
    let grid = Grid {
        points,
        connectivity,
        offsets: (1..=nb).map(|k| 2 * k).collect(),
        types: vec![3; nb], // VTK_LINE
        point_data: Vec::new(),
        cell_data,
    };
    write_grid(path, &grid)
}

/// Write bonds as line cells between `positions` (m; bond k joins `i[k]` and `j[k]`) with
/// one-component cell fields (name, one value per bond): e.g. a strength test's broken
/// bonds with their state, time and mode of breaking.
pub fn write_bond_fields_vtu(
    path: &Path,
    positions: &[Vec3],
    i: &[u32],
    j: &[u32],
    fields: &[(&str, Vec<f64>)],
) -> Result<()> {
    let nb = i.len();
    check_len("bond ends j", j.len(), nb)?;
    for (name, v) in fields {
        check_len(name, v.len(), nb)?;
    }
    if let Some(p) = i.iter().chain(j).find(|&&p| p as usize >= positions.len()) {
        return Err(Error::Invalid(format!(
            "VTK export: bond end {p} is not one of the {} particles",
            positions.len()
        )));
    }
    let grid = Grid {
        points: positions.to_vec(),
        connectivity: i
            .iter()
            .zip(j)
            .flat_map(|(&a, &b)| [a as usize, b as usize])
            .collect(),
        offsets: (1..=nb).map(|k| 2 * k).collect(),
        types: vec![3; nb], // VTK_LINE
        point_data: Vec::new(),
        cell_data: fields
            .iter()
            .map(|(n, v)| (n.to_string(), 1, join(v)))
            .collect(),
    };
    write_grid(path, &grid)
}
