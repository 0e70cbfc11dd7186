//! Export of a bonded model to other tools, ready to run there.
//!
//! - [`yade`]: the packing, the bond table, the model, the reusable Python module
//!   `anisobond_yade.py` (embedded in the binary) and a `run.py` that performs the six-path
//!   element test in YADE 2023.02a (`yade -n -x DIR/run.py`).
//! - [`liggghts`]: LIGGGHTS 3.8 data file and input decks: the driver deck with per-bond
//!   anisotropic bonds (`pair_style anisobond`, cpp/liggghts) and a stock `bond_style
//!   harmonic` deck (normal springs only).
//! - [`vtk`]: VTK XML (.vtu) files of particles and bonds for ParaView.

pub mod lammps;
pub mod liggghts;
pub mod vtk;
pub mod yade;

use crate::bonds::{BondSet, BondStiffness};
use crate::packing::{Packing, PeriodicCell};
use crate::{Error, Result};

/// The Voigt pairs (a, b) of the load cases 11 22 33 23 13 12, in order.
const VOIGT_AXES: [(usize, usize); 6] = [(0, 0), (1, 1), (2, 2), (1, 2), (0, 2), (0, 1)];

/// The load cases (Voigt indices 0–5: 11 22 33 23 13 12) an exported element test runs on
/// `cell`: all six on a fully periodic cell; on a box of mixed periodicity those whose
/// strain moves periodic axes only. A free axis has no box strain the particles feel (its
/// faces are free surfaces), and LAMMPS refuses a tilt whose second axis is not periodic.
pub fn load_cases(cell: &PeriodicCell) -> Vec<usize> {
    (0..6)
        .filter(|&c| {
            let (a, b) = VOIGT_AXES[c];
            cell.periodic[a] && cell.periodic[b]
        })
        .collect()
}

/// The `boundary` line's flags of a LAMMPS / LIGGGHTS deck for `cell`: `p` along periodic
/// axes, `m` along free ones. `m` (shrink-wrapped with a minimum) keeps every atom — a
/// fixed `f` face loses an atom that crosses it — and keeps the face at least where the
/// data file's box puts it, so that the virial stress is per the box as read unless an atom
/// leaves it (LAMMPS and LIGGGHTS `boundary` documentation).
pub(crate) fn deck_boundary(cell: &PeriodicCell) -> String {
    cell.periodic.map(|p| if p { "p" } else { "m" }).join(" ")
}

/// The smallest edge of `cell` along its periodic axes (m): a bond must be shorter than
/// half of it for the engines' minimum image (a free axis has no image).
pub(crate) fn min_periodic_length(cell: &PeriodicCell) -> f64 {
    (0..3)
        .filter(|&k| cell.periodic[k])
        .map(|k| cell.lengths[k])
        .fold(f64::INFINITY, f64::min)
}

/// The atom ids an engine's files give the particles: the packing's own ([`Packing::ids`]:
/// a data file's, a dump's) when every one is ≥ 1; else `None`, and the files number them
/// index + 1 (YADE's body ids start at 0: no LAMMPS / LIGGGHTS atom id).
pub(crate) fn engine_ids(packing: &Packing) -> Option<&[u64]> {
    packing.ids.as_deref().filter(|ids| !ids.contains(&0))
}

/// Give a written script its run bit wherever it is readable (`chmod +x` under the
/// user's umask: 644 → 755, 600 → 700), so that `./run.sh` runs as the export's message
/// says.
/// Refuses ([`Error::Invalid`]) grain ids (`Assembly::grains`) that are not one per particle,
/// before an export writes anything; `what` names the export in the message.
pub(crate) fn check_grain_count(
    grains: Option<&[u32]>,
    particles: usize,
    what: &str,
) -> Result<()> {
    match grains {
        Some(g) if g.len() != particles => Err(Error::Invalid(format!(
            "{what}: {} grain ids for {particles} particles; expected one per particle",
            g.len()
        ))),
        _ => Ok(()),
    }
}

pub(crate) fn make_executable(path: &std::path::Path) -> Result<()> {
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        let mode = std::fs::metadata(path)
            .map_err(|e| Error::io(path, e))?
            .permissions()
            .mode();
        std::fs::set_permissions(
            path,
            std::fs::Permissions::from_mode(mode | ((mode & 0o444) >> 2)),
        )
        .map_err(|e| Error::io(path, e))?;
    }
    #[cfg(not(unix))]
    let _ = path;
    Ok(())
}

/// An upper bound of the critical time step of the explicit (central-difference) integration
/// of a bonded packing: 2/ω_max ≤ 2/√(q_i) for every particle i, where q_i =
/// Σ_b (k_n + 2k_s)/(3m_i) is the Rayleigh quotient of M⁻¹K for a unit translation of i
/// averaged over three axes (a lower bound of ω_max²). A time step above it is certainly
/// unstable, whatever the rotational springs add.
pub fn critical_time_step_upper_bound(
    packing: &Packing,
    bonds: &BondSet,
    k: &BondStiffness,
    density: f64,
) -> f64 {
    let mut ksum = vec![0.0; packing.len()];
    for b in 0..bonds.len() {
        for p in [bonds.i[b] as usize, bonds.j[b] as usize] {
            ksum[p] += k.kn[b] + 2.0 * k.ks[b];
        }
    }
    ksum.iter()
        .zip(&packing.radii)
        .filter(|(&kp, _)| kp > 0.0)
        .map(|(&kp, &r)| {
            let m = density * 4.0 / 3.0 * std::f64::consts::PI * r * r * r;
            2.0 * (3.0 * m / kp).sqrt()
        })
        .fold(f64::INFINITY, f64::min)
}

/// Refuse an explicit time step `dt` (s) above [`critical_time_step_upper_bound`]: the
/// exported run would blow up in the other program after the user has started it.
pub fn check_time_step(
    dt: f64,
    packing: &Packing,
    bonds: &BondSet,
    k: &BondStiffness,
    density: f64,
    option: &str,
) -> Result<()> {
    let bound = critical_time_step_upper_bound(packing, bonds, k, density);
    if dt > bound {
        return Err(Error::Invalid(format!(
            "{option} {dt:e} s exceeds the critical time step of this bonded packing (at most \
             {bound:.4e} s at density {density} kg/m³): the explicit integration would be \
             unstable; leave {option} out to use a stable step"
        )));
    }
    Ok(())
}

/// Shortest round-trip text of a number (reads back bit-identical).
pub(crate) fn num(v: f64) -> String {
    let mut b = ryu::Buffer::new();
    b.format(v).to_string()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Vec3;

    /// The load cases and boundary of a deck by the periodic axes: all six and `p p p` for
    /// a periodic cell; for `p p f` the strains of x and y (11, 22, 12) and `p p m`.
    #[test]
    fn a_mixed_box_runs_the_cases_of_its_periodic_axes() {
        let cell = |p| PeriodicCell::with_periodic(Vec3::new(1.0, 2.0, 3.0), p).unwrap();
        assert_eq!(load_cases(&cell([true; 3])), vec![0, 1, 2, 3, 4, 5]);
        assert_eq!(deck_boundary(&cell([true; 3])), "p p p");
        assert_eq!(load_cases(&cell([true, true, false])), vec![0, 1, 5]);
        assert_eq!(deck_boundary(&cell([true, true, false])), "p p m");
        assert_eq!(load_cases(&cell([false, true, true])), vec![1, 2, 3]);
        assert_eq!(load_cases(&cell([true, false, false])), vec![0]);
        assert_eq!(min_periodic_length(&cell([false, true, true])), 2.0);
    }
}
