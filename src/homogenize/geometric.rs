//! Geometric (initial-stress) stiffness of a pre-loaded bond network.
//!
//! A bond of branch vector l = |l| n that carries the axial force N (N > 0 in tension)
//! stores, to second order in the relative translation w = u_j − u_i, the extra energy
//! ½ (N/|l|) wᵀ(I − n⊗n) w: the Hessian of N·|l + w| (the rotation of a loaded bond; a
//! pre-tensioned string's transverse stiffness N/|l|). In the 6×6 block form of
//! [`super::network`] it acts on the translations only: K_g,ii = K_g,jj = G, K_g,ij = −G with
//! G = (N/|l|)(I − n⊗n).
//!
//! Included: the axial part N = F·n of each bond's force vector F. Neglected: the geometric
//! terms of the shear force F − (F·n)n (its co-rotation with the bond gives a non-symmetric
//! term of order |F_t|/|l|), of the bending and twisting moments, and of the contact-point
//! lever arms (the second-order change of (r n)×ω). In a bar under axial load the shear
//! forces of the random network have no mean along the load, so the leading, stress-resultant
//! part of the initial-stress stiffness is the axial one (the continuum's σ₀:∇δu·∇δu term).

use super::network::{bond_geometric_stiffness, Block6, Network};
use super::sparse::BlockSparse;
use crate::bonds::BondSet;
use crate::{Error, Result, Vec3};

/// The geometric stiffness matrix K_g of a network (same nodes and block layout as
/// [`BlockSparse::assemble`] of it) under the bond forces `forces`, one per bond of `bonds`
/// (the original bond index; the network's pruned bonds are skipped). Refuses a force list
/// of the wrong length or a force that is not finite.
pub fn geometric_stiffness(net: &Network, bonds: &BondSet, forces: &[Vec3]) -> Result<BlockSparse> {
    if forces.len() != bonds.len() {
        return Err(Error::Invalid(format!(
            "geometric stiffness: {} bond forces for {} bonds",
            forces.len(),
            bonds.len()
        )));
    }
    if let Some(b) = forces.iter().position(|f| f.iter().any(|c| !c.is_finite())) {
        return Err(Error::Invalid(format!(
            "geometric stiffness: the force of bond {b} is not finite"
        )));
    }
    Ok(BlockSparse::assemble_blocks(net.n_active, &net.ends, |e| {
        let b = net.bond[e];
        let g = bond_geometric_stiffness(&forces[b], &bonds.normal[b], bonds.length[b]);
        let mut kii = Block6::zeros();
        kii.fixed_view_mut::<3, 3>(0, 0).copy_from(&g);
        (kii, kii, -kii)
    }))
}
