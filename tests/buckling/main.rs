//! Free-boundary bars and their buckling: cutting from periodic packings, the geometric
//! stiffness, linearised buckling against Euler/Engesser/Mazzilli. See tests/README.md.

mod cut;
mod euler;
mod geometric;
