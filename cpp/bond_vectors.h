// Small 3-vector helpers of anisobond's incremental bond laws (the LIGGGHTS pair style in
// cpp/liggghts/ and the LAMMPS bond style in cpp/lammps/), in one place.
#ifndef ANISOBOND_BOND_VECTORS_H
#define ANISOBOND_BOND_VECTORS_H

namespace anisobond_vec {

// c = a × b
inline void cross(const double *a, const double *b, double *c) {
  c[0] = a[1] * b[2] - a[2] * b[1];
  c[1] = a[2] * b[0] - a[0] * b[2];
  c[2] = a[0] * b[1] - a[1] * b[0];
}

// a · b
inline double dot(const double *a, const double *b) {
  return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}

// v ← v − v×a  (YADE ScGeom::rotate, first order in the small rotation a)
inline void rotate_by(double *v, const double *a) {
  double c[3];
  cross(v, a, c);
  v[0] -= c[0];
  v[1] -= c[1];
  v[2] -= c[2];
}

}  // namespace anisobond_vec

#endif
