//! The first steps of the specimen solve: the specimen's bonds, the held and moved groups,
//! the part of the bond network that carries load, its stiffness and the gauge length.

use super::{axis_name, Selection, SpecimenOptions};
use crate::assembly::Assembly;
use crate::bonds::BondSet;
use crate::homogenize::network::{element_stiffness, prune_dangling, Block6, BondLaw};
use crate::homogenize::sparse::BlockSparse;
use crate::packing::Packing;
use crate::{Error, Result, Vec3};

/// The bonds of the specimen: all but those crossing the cell's faces normal to `axis` (cut
/// there); a packing left without bonds is refused.
pub(super) fn specimen_bonds(assembly: &Assembly, axis: usize) -> Result<Vec<bool>> {
    let bonds = &assembly.bonds;
    let in_specimen: Vec<bool> = bonds.image.iter().map(|im| im[axis] == 0).collect();
    if bonds.is_empty() || !in_specimen.iter().any(|&b| b) {
        return Err(Error::Degenerate(
            "specimen: the packing has no bonds (check the model's bonding rule)".into(),
        ));
    }
    Ok(in_specimen)
}

/// The held and moved groups of the platens.
pub(super) struct Groups {
    /// How the held group was chosen.
    pub held: Selection,
    /// How the moved group was chosen.
    pub moved: Selection,
    /// Group of every particle: 0 none, 1 held, 2 moved.
    pub layer: Vec<u8>,
}

impl Groups {
    /// The groups `opts` asks for (the end layers by default); refused when the end layers
    /// overlap, a particle is in both groups, or a group is empty.
    pub fn select(packing: &Packing, opts: &SpecimenOptions) -> Result<Groups> {
        let (n, ax) = (packing.len(), opts.axis);
        let coord = |p: usize| packing.positions[p][ax];
        let end_layer = |top: bool| Selection::EndLayer {
            top,
            depth: opts.end_layer,
        };
        let held = opts.held.clone().unwrap_or(end_layer(false));
        let moved = opts.moved.clone().unwrap_or(end_layer(true));
        if opts.held.is_none() && opts.moved.is_none() {
            let lo = (0..n).map(coord).fold(f64::INFINITY, f64::min);
            let hi = (0..n).map(coord).fold(f64::NEG_INFINITY, f64::max);
            if hi - lo <= 2.0 * opts.end_layer {
                return Err(Error::Invalid(format!(
                    "specimen: the end layers ({} m deep each) overlap: the specimen is {:.6e} \
                     m long along {}",
                    opts.end_layer,
                    hi - lo,
                    axis_name(ax)
                )));
            }
        }
        let held_flag = held.select(packing, ax)?;
        let moved_flag = moved.select(packing, ax)?;
        let mut layer = vec![0u8; n];
        let mut both = 0usize;
        for p in 0..n {
            match (held_flag[p], moved_flag[p]) {
                (true, true) => both += 1,
                (true, false) => layer[p] = 1,
                (false, true) => layer[p] = 2,
                _ => {}
            }
        }
        if both > 0 {
            return Err(Error::Invalid(format!(
                "specimen: the held group ({}) and the moved group ({}) overlap: {both} \
                 particles are in both",
                held.describe(),
                moved.describe()
            )));
        }
        for (which, name, sel) in [(1u8, "held", &held), (2, "moved", &moved)] {
            if !layer.contains(&which) {
                return Err(Error::Invalid(format!(
                    "specimen: the {name} group ({}) holds no particle",
                    sel.describe()
                )));
            }
        }
        Ok(Groups { held, moved, layer })
    }
}

/// Union–find root with path halving.
fn root(parent: &mut [u32], mut p: u32) -> u32 {
    while parent[p as usize] != p {
        parent[p as usize] = parent[parent[p as usize] as usize];
        p = parent[p as usize];
    }
    p
}

/// The connected component (its root particle) of each of the `n` particles over the bonds
/// flagged in `in_specimen`.
fn components(n: usize, bonds: &BondSet, in_specimen: &[bool]) -> Vec<u32> {
    let mut parent: Vec<u32> = (0..n as u32).collect();
    for b in (0..bonds.len()).filter(|&b| in_specimen[b]) {
        let (a, c) = (root(&mut parent, bonds.i[b]), root(&mut parent, bonds.j[b]));
        if a != c {
            parent[a.max(c) as usize] = a.min(c);
        }
    }
    (0..n as u32).map(|p| root(&mut parent, p)).collect()
}

/// Whether bond `b` joins a particle to an image across a lateral face (`lateral` the two
/// lateral axes).
fn crosses(bonds: &BondSet, lateral: [usize; 2], b: usize) -> bool {
    lateral.iter().any(|&d| bonds.image[b][d] != 0)
}

/// The part of the specimen that carries load, numbered as the nodes of the system.
pub(super) struct Network {
    /// Connected component (root particle) of every particle.
    pub roots: Vec<u32>,
    /// Whether each bond of the packing takes part.
    pub active: Vec<bool>,
    /// Particle of every loaded node: node a is particle `original[a]`.
    pub original: Vec<usize>,
    /// The bonds that take part, in the packing's order.
    pub loaded_bonds: Vec<usize>,
    /// Periodic across the axis: the lateral periods (m), whose changes a₀, a₁ are the DOFs
    /// 0–2 and 3–5 of a last node (some loaded bond crosses a lateral face, else refused).
    pub periods: Option<Vec3>,
}

impl Network {
    /// The components joined by bonds to both groups carry the load; the rest is left out,
    /// and so are dangling chains (particles off the groups left with one bond, repeatedly:
    /// they would swing freely), as in the periodic network. Refused when nothing joins the
    /// groups, or when periodic across the axis but no loaded bond crosses a lateral face.
    pub fn of(
        assembly: &Assembly,
        axis: usize,
        groups: &Groups,
        in_specimen: &[bool],
        cell: Option<Vec3>,
    ) -> Result<Network> {
        let (n, bonds, layer) = (assembly.packing.len(), &assembly.bonds, &groups.layer);
        let roots = components(n, bonds, in_specimen);
        let mut touches = vec![0u8; n];
        for p in 0..n {
            if layer[p] != 0 {
                touches[roots[p] as usize] |= layer[p];
            }
        }
        let in_loaded_component = |p: usize| touches[roots[p] as usize] == 3;
        let (active, degree) = prune_dangling(
            n,
            bonds,
            (0..bonds.len())
                .map(|b| in_specimen[b] && in_loaded_component(bonds.i[b] as usize))
                .collect(),
            |p| layer[p] != 0,
        );
        let original: Vec<usize> = (0..n)
            .filter(|&p| in_loaded_component(p) && degree[p] > 0)
            .collect();
        if original.is_empty() {
            return Err(Error::Degenerate(format!(
                "specimen: no bonded path joins the held group ({}) and the moved group ({}) \
                 along {}; the specimen falls apart under load",
                groups.held.describe(),
                groups.moved.describe(),
                axis_name(axis)
            )));
        }
        let loaded_bonds: Vec<usize> = (0..bonds.len()).filter(|&b| active[b]).collect();
        let lateral = [(axis + 1) % 3, (axis + 2) % 3];
        if cell.is_some() && !loaded_bonds.iter().any(|&b| crosses(bonds, lateral, b)) {
            // Laterally periodic by option but joined across no lateral face: its lateral
            // strain would be read as 0 from period changes that nothing resists.
            return Err(Error::Degenerate(
                "specimen: periodic across the axis (--lateral periodic) but no loaded bond \
                 crosses a lateral face of the cell; the specimen is free laterally: use \
                 --lateral free"
                    .into(),
            ));
        }
        Ok(Network {
            roots,
            active,
            original,
            loaded_bonds,
            periods: cell,
        })
    }

    /// Nodes of the system: the loaded particles, and the lateral periods' changes if any.
    pub fn nodes(&self) -> usize {
        self.original.len() + usize::from(self.periods.is_some())
    }

    /// The stiffness K of the loaded network (Kruyt 2014 Eqs. 10–14, six DOFs per sphere):
    /// with lateral periodicity the image of j across the lateral faces (n₀, n₁) is displaced
    /// by n₀a₀ + n₁a₁, which couples the bonds crossing them to the period changes' node.
    pub fn stiffness(&self, assembly: &Assembly, opts: &SpecimenOptions) -> BlockSparse {
        self.with_elements(assembly, opts, |m, ends, blocks| {
            BlockSparse::assemble_rows(m, ends, blocks)
        })
    }

    /// (K u, the diagonal blocks of K) of [`Self::stiffness`] without storing K (the same
    /// bits as forming it and multiplying; [`BlockSparse::assemble_rows_times`]).
    pub fn stiffness_times(
        &self,
        assembly: &Assembly,
        opts: &SpecimenOptions,
        u: &[Block6],
    ) -> (Vec<Block6>, Vec<Block6>) {
        self.with_elements(assembly, opts, |m, ends, blocks| {
            BlockSparse::assemble_rows_times(m, ends, blocks, u)
        })
    }

    /// `use_them(nodes, edges, blocks of edge e)` on the network's edges: its bonds, and with
    /// lateral periodicity the edges to the period changes' node.
    fn with_elements<R>(
        &self,
        assembly: &Assembly,
        opts: &SpecimenOptions,
        use_them: impl FnOnce(
            usize,
            &[(u32, u32)],
            &(dyn Fn(usize) -> (Block6, Block6, Block6) + Sync),
        ) -> R,
    ) -> R {
        let (packing, bonds) = (&assembly.packing, &assembly.bonds);
        let lateral = [(opts.axis + 1) % 3, (opts.axis + 2) % 3];
        let element_of = |b: usize| {
            let law = BondLaw::of(packing, bonds, &assembly.springs, b, opts.lever_arm);
            element_stiffness(&law, true)
        };
        let mut index = vec![u32::MAX; packing.len()];
        for (a, &p) in self.original.iter().enumerate() {
            index[p] = a as u32;
        }
        let mut ends: Vec<(u32, u32)> = self
            .loaded_bonds
            .iter()
            .map(|&b| (index[bonds.i[b] as usize], index[bonds.j[b] as usize]))
            .collect();
        // The edges past the bonds couple a bond across a lateral face to the period changes'
        // node: (bond, whether the edge is j's). Each edge's blocks are formed at both of its
        // rows when the row-by-row assembly asks for them, never all at once (at a million
        // particles 3.3 GB; issue 35).
        let nb = ends.len();
        let mut across: Vec<(usize, bool)> = Vec::new();
        if self.periods.is_some() {
            let a = self.original.len() as u32;
            for (e, &b) in self.loaded_bonds.iter().enumerate() {
                if crosses(bonds, lateral, b) {
                    ends.push((ends[e].0, a));
                    across.push((b, false));
                    ends.push((ends[e].1, a));
                    across.push((b, true));
                }
            }
        }
        let blocks = |e: usize| -> (Block6, Block6, Block6) {
            if e < nb {
                return element_of(self.loaded_bonds[e]);
            }
            let (b, at_j) = across[e - nb];
            // T (3×6) = [n₀ I | n₁ I] maps the period changes to j's extra translation.
            let mut t = nalgebra::Matrix3x6::<f64>::zeros();
            for (c, &d) in lateral.iter().enumerate() {
                let nd = f64::from(bonds.image[b][d]);
                for r in 0..3 {
                    t[(r, 3 * c + r)] = nd;
                }
            }
            let (_, kjj, kij) = element_of(b);
            if at_j {
                let kj_t = kjj.fixed_view::<6, 3>(0, 0) * t;
                (Block6::zeros(), Block6::zeros(), kj_t)
            } else {
                let ki_t = kij.fixed_view::<6, 3>(0, 0) * t;
                let kaa = t.transpose() * kjj.fixed_view::<3, 3>(0, 0) * t;
                (Block6::zeros(), kaa, ki_t)
            }
        };
        use_them(self.nodes(), &ends, &blocks)
    }
}

/// The gauge: the moved group is pushed towards the held one along the axis.
pub(super) struct Gauge {
    /// Mean centre of the held group's loaded particles along the axis (m).
    pub held_mean: f64,
    /// 1 when the moved group lies above the held one along the axis, else −1.
    pub sign: f64,
    /// Distance between the groups' mean centres along the axis (m).
    pub length: f64,
    /// Loaded particles of the held group.
    pub n_held: usize,
    /// Loaded particles of the moved group.
    pub n_moved: usize,
}

impl Gauge {
    /// The gauge of the loaded particles of `net`; refused when a group has no loaded
    /// particle or the groups' mean centres coincide.
    pub fn of(packing: &Packing, axis: usize, layer: &[u8], net: &Network) -> Result<Gauge> {
        let mean_of = |which: u8| {
            let (s, c) = net
                .original
                .iter()
                .filter(|&&p| layer[p] == which)
                .fold((0.0, 0usize), |(s, c), &p| {
                    (s + packing.positions[p][axis], c + 1)
                });
            (s / c.max(1) as f64, c)
        };
        let ((held_mean, n_held), (moved_mean, n_moved)) = (mean_of(1), mean_of(2));
        let sign = if moved_mean >= held_mean { 1.0 } else { -1.0 };
        let length = (moved_mean - held_mean).abs();
        if n_held == 0 || n_moved == 0 || length.is_nan() || length <= 0.0 {
            return Err(Error::Degenerate(format!(
                "specimen: the loaded part holds {n_held} held and {n_moved} moved particles, \
                 {length:e} m apart along {}: no gauge length",
                axis_name(axis)
            )));
        }
        Ok(Gauge {
            held_mean,
            sign,
            length,
            n_held,
            n_moved,
        })
    }
}
