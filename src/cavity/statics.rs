//! Static response of the pressurised cavity: K u = p·f on the free spheres, with K the
//! block-sparse stiffness the relaxed solver assembles (Kruyt 2014 Eqs. 10–14, six DOFs per
//! sphere) restricted to the free spheres (the clamped ring's DOFs removed), factored by
//! faer's sparse Cholesky ([`BlockCholesky::factor_definite`]: no rigid mode to pin).

use super::Cavity;
use crate::homogenize::cholesky::BlockCholesky;
use crate::homogenize::network::Block6;
use crate::homogenize::sparse::BlockSparse;
use crate::{Error, Result, Vec3};

/// Largest relative residual ‖K u − f‖/‖f‖ accepted from the direct solve.
pub const RESIDUAL_LIMIT: f64 = 1e-8;

/// The static solution under pressure p.
#[derive(Clone, Debug)]
pub struct StaticCavity {
    /// Pressure (Pa).
    pub pressure: f64,
    /// Displacement of every sphere of the cut (m; zero for clamped and unbonded ones).
    pub displacement: Vec<Vec3>,
    /// Rotation of every sphere (rad).
    pub rotation: Vec<Vec3>,
    /// Load-weighted mean radial wall displacement (m), [`Cavity::wall_displacement`].
    pub wall_displacement: f64,
    /// Load-weighted mean axial (z) wall displacement Σ|f_i|u_z,i/Σ|f_i| (m).
    pub wall_axial_displacement: f64,
    /// Relative residual of the solve.
    pub relative_residual: f64,
    /// Free spheres solved for.
    pub free_spheres: usize,
    /// Unknowns after removing local mechanisms.
    pub unknowns: usize,
}

impl Cavity {
    /// Solve the linear static problem for pressure `pressure` (Pa, > 0 pushes the wall
    /// outward). Errors when the free network has a global mechanism (factorisation fails)
    /// or the residual exceeds `RESIDUAL_LIMIT`.
    pub fn solve_static(&self, pressure: f64) -> Result<StaticCavity> {
        if !(pressure.is_finite() && pressure != 0.0) {
            return Err(Error::Invalid(format!(
                "cavity: pressure must be finite and non-zero, got {pressure} Pa"
            )));
        }
        let net = &self.network;
        let (free_index, free) = self.free_nodes();
        let kf = BlockSparse::assemble(net).restrict(&free_index, 1.0);
        let chol = BlockCholesky::factor_definite(&kf)?;
        let rhs: Vec<Block6> = free
            .iter()
            .map(|&a| {
                let f = self.unit_load[net.original[a] as usize] * pressure;
                let mut b = Block6::zeros();
                for i in 0..3 {
                    b[(i, 0)] = f[i];
                }
                b
            })
            .collect();
        let x = chol.solve(&rhs)?;
        let relative_residual = load_residual(&kf, &x, &rhs)?;
        let n = self.cut.packing.len();
        let mut displacement = vec![Vec3::zeros(); n];
        let mut rotation = vec![Vec3::zeros(); n];
        for (fi, &a) in free.iter().enumerate() {
            let p = net.original[a] as usize;
            displacement[p] = Vec3::new(x[fi][(0, 0)], x[fi][(1, 0)], x[fi][(2, 0)]);
            rotation[p] = Vec3::new(x[fi][(3, 0)], x[fi][(4, 0)], x[fi][(5, 0)]);
        }
        let (mut uz, mut w) = (0.0, 0.0);
        for &p in &self.wall {
            let f = self.unit_load[p as usize].norm();
            uz += f * displacement[p as usize].z;
            w += f;
        }
        Ok(StaticCavity {
            pressure,
            wall_displacement: self.wall_displacement(&displacement),
            wall_axial_displacement: uz / w,
            displacement,
            rotation,
            relative_residual,
            free_spheres: free.len(),
            unknowns: chol.unknowns(),
        })
    }

    /// The free (not clamped) nodes of the network: every node's index among them
    /// (`u32::MAX` when clamped) and the free nodes in increasing order.
    fn free_nodes(&self) -> (Vec<u32>, Vec<usize>) {
        let net = &self.network;
        let mut free_index = vec![u32::MAX; net.n_active];
        let mut free: Vec<usize> = Vec::new();
        for (a, slot) in free_index.iter_mut().enumerate() {
            if !self.clamped[net.original[a] as usize] {
                *slot = free.len() as u32;
                free.push(a);
            }
        }
        (free_index, free)
    }
}

/// Relative residual ‖K x − b‖/‖b‖ of the load case (column 0); refused above
/// [`RESIDUAL_LIMIT`] (an ill-conditioned free network or a mechanism).
fn load_residual(kf: &BlockSparse, x: &[Block6], rhs: &[Block6]) -> Result<f64> {
    let mut kx = vec![Block6::zeros(); x.len()];
    kf.apply(x, &mut kx);
    let (mut rr, mut bb) = (0.0, 0.0);
    for (r, b) in kx.iter().zip(rhs) {
        rr += (r.column(0) - b.column(0)).norm_squared();
        bb += b.column(0).norm_squared();
    }
    let relative_residual = (rr / bb).sqrt();
    if relative_residual.is_nan() || relative_residual > RESIDUAL_LIMIT {
        return Err(Error::NotConverged(format!(
            "cavity: static solve residual {relative_residual:.3e} > {RESIDUAL_LIMIT:e}: the \
             free network is too ill-conditioned or has a mechanism"
        )));
    }
    Ok(relative_residual)
}

impl StaticCavity {
    /// Write one CSV row per sphere of the cut: `id,x [m],y [m],z [m],radius [m],rho [m],
    /// theta [deg],ux [m],uy [m],uz [m],u_radial [m],fx [N],fy [N],clamped` (the wall force
    /// p·share, zero off the wall; θ from x towards y about the hole's axis).
    pub fn write_csv(&self, cavity: &Cavity, path: &std::path::Path) -> Result<()> {
        crate::io::write_atomic(path, |w| {
            let io = |e| Error::io(path, e);
            writeln!(
                w,
                "id,x [m],y [m],z [m],radius [m],rho [m],theta [deg],ux [m],uy [m],uz [m],\
                 u_radial [m],fx [N],fy [N],clamped"
            )
            .map_err(io)?;
            for p in 0..cavity.cut.packing.len() {
                let x = cavity.cut.packing.positions[p];
                let rel = cavity.relative_position(p);
                let u = self.displacement[p];
                let f = cavity.unit_load[p] * self.pressure;
                writeln!(
                    w,
                    "{p},{:e},{:e},{:e},{:e},{:e},{:.3},{:e},{:e},{:e},{:e},{:e},{:e},{}",
                    x.x,
                    x.y,
                    x.z,
                    cavity.cut.packing.radii[p],
                    rel.x.hypot(rel.y),
                    rel.y.atan2(rel.x).to_degrees(),
                    u.x,
                    u.y,
                    u.z,
                    u.dot(&cavity.radial_unit(p)),
                    f.x,
                    f.y,
                    u8::from(cavity.clamped[p])
                )
                .map_err(io)?;
            }
            Ok(())
        })
    }
}

/// One ±half-width bin of the wall: the DEM's wall spheres beside the continuum's wall nodes.
#[derive(Clone, Copy, Debug, serde::Serialize)]
pub struct WallBin {
    /// Direction of the bin (degrees from x towards y).
    pub angle_from_x_deg: f64,
    /// Mean radial displacement of the wall spheres (m).
    pub dem_radial_m: f64,
    /// Mean axial displacement of the wall spheres (m).
    pub dem_axial_m: f64,
    /// Mean radial displacement of the continuum's wall nodes (m).
    pub continuum_radial_m: f64,
    /// Mean axial displacement of the continuum's wall nodes (m).
    pub continuum_axial_m: f64,
}

/// The static solution beside its continuum references: Lamé with the tensor's isotropic
/// projection, and the anisotropic continuum of the full tensor (`continuum.rs`).
#[derive(Clone, Debug)]
pub struct StaticComparison {
    /// The bonded slab's solution.
    pub solution: StaticCavity,
    /// Lamé's wall displacement (m) with λ, μ the group means of the tensor.
    pub lame_wall_displacement: f64,
    /// Lamé constants (λ, μ) used (Pa).
    pub lame_constants: (f64, f64),
    /// The continuum solution (default mesh).
    pub continuum: super::continuum::ContinuumCavity,
    /// Wall bins of ±20° along +x, +y, −x, −y.
    pub bins: Vec<WallBin>,
}

impl Cavity {
    /// Solve under `pressure` (Pa) and set the result beside Lamé and the anisotropic
    /// continuum of `tensor` (the source's relaxed tensor, Pa, in the slab's frame).
    pub fn compare_static(
        &self,
        tensor: &crate::tensor::Stiffness6,
        pressure: f64,
    ) -> Result<StaticComparison> {
        let solution = self.solve_static(pressure)?;
        let (a, b) = (self.geometry.inner_radius, self.geometry.outer_radius);
        let (lambda, mu) = super::isotropic_lame_constants(tensor);
        let continuum = super::continuum::solve_annulus(
            tensor,
            a,
            b,
            pressure,
            &super::continuum::AnnulusMesh::default(),
        )?;
        let bins = [0.0, 90.0, 180.0, 270.0]
            .iter()
            .map(|&d| {
                let (dem_radial_m, dem_axial_m) = self.wall_bin(&solution.displacement, d, 20.0);
                let (continuum_radial_m, continuum_axial_m) = continuum.wall_bin(d, 20.0);
                WallBin {
                    angle_from_x_deg: d,
                    dem_radial_m,
                    dem_axial_m,
                    continuum_radial_m,
                    continuum_axial_m,
                }
            })
            .collect();
        Ok(StaticComparison {
            lame_wall_displacement: super::lame_wall_displacement(pressure, a, b, lambda, mu),
            lame_constants: (lambda, mu),
            solution,
            continuum,
            bins,
        })
    }
}
