// Minimal use of the anisobond C++ bridge: load a model, evaluate one bond's springs, and
// (with a packing) the stiffness tensor. Build: make -C cpp; run:
//   target/cpp/example MODEL.toml [PACKING.txt]
#include "anisobond/src/ffi/mod.rs.h"

#include <cstdio>
#include <exception>

int main(int argc, char **argv) {
  if (argc < 2) {
    std::fprintf(stderr, "usage: %s MODEL.toml [PACKING.txt]\n", argv[0]);
    return 2;
  }
  try {
    auto model = anisobond::load_model(argv[1]);
    if (argc > 2 && model->needs_packing()) model->bind_packing(argv[2]);
    std::printf("anisobond %s, scheme: %s\n", anisobond::library_version().c_str(),
                model->scheme_name().c_str());
    // A bond along [111] between two 1 mm spheres touching (centre distance 2 mm).
    anisobond::BondSprings k = model->bond_springs(1, 1, 1, 1e-3, 1e-3, 2e-3);
    std::printf("bond along [111]: k_n = %.6g N/m, k_s = %.6g N/m, k_r = %.6g, k_tw = %.6g N*m/rad\n",
                k.kn, k.ks, k.kr, k.ktw);
    if (argc > 2) {
      anisobond::Tensor6 c = anisobond::compute_tensor(argv[2], *model, "voigt");
      std::printf("Voigt tensor (GPa), Voigt order 11 22 33 23 13 12:\n");
      for (int a = 0; a < 6; ++a) {
        for (int b = 0; b < 6; ++b) std::printf(" %10.4f", c.c[6 * a + b] / 1e9);
        std::printf("\n");
      }
    }
  } catch (const std::exception &e) {
    std::fprintf(stderr, "error: %s\n", e.what());
    return 1;
  }
  return 0;
}
