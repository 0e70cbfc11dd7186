//! Bond strength and failure criteria (issue 32, docs/strength.md): strength schemes by
//! orientation, planes of weakness, seeded scatter, the per-law criteria, Jaeger's single
//! plane of weakness and a bonded simple-cubic bar in direct tension and pure shear.
//! One module per file; see tests/README.md.

mod bar;
mod breakage;
mod criteria;
mod handed_on_shear;
mod jaeger;
mod jaeger_lattice;
mod model_file;
mod planes;
mod sc_bar;
mod scatter;
mod schemes;
