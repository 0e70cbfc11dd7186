// anisobond-liggghts: LIGGGHTS 3.8 with `pair_style anisobond` registered at run time.
// Same command line as `liggghts` (e.g. `-in deck.in -var name value -echo screen`); works
// under mpirun. The style is added through the public Force::pair_map, so the stock
// libliggghts is used unchanged.
#include <mpi.h>

#include "force.h"
#include "input.h"
#include "lammps.h"

#include "pair_anisobond.h"

#include <string>

using namespace LAMMPS_NS;

int main(int argc, char **argv) {
  MPI_Init(&argc, &argv);
  LAMMPS *lmp = new LAMMPS(argc, argv, MPI_COMM_WORLD);
  (*lmp->force->pair_map)[std::string("anisobond")] = &PairAnisobond::creator;
  lmp->input->file();
  delete lmp;
  MPI_Finalize();
  return 0;
}
