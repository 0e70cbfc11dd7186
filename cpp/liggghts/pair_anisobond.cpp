// pair_style anisobond — see pair_anisobond.h for the bond law and the design.
//
//   pair_style anisobond table BONDS.csv [damping GT GR] [length_tolerance TOL]
//     (BONDS.csv with normal_adhesion,shear_adhesion,tan_friction columns: breakable bonds)
//   pair_style anisobond model MODEL.toml PACKING [damping GT GR] [length_tolerance TOL]
//   pair_style anisobond model MODEL.toml [write_bonds FILE] [damping GT GR] [length_tolerance TOL]
//   pair_style anisobond table BONDS.csv manybody MANYBODY.txt [...]   (the many-body term;
//     a model with [manybody] brings it to the model forms without the keyword)
//   pair_coeff * *
//   any form also takes `breaks FILE`: rank 0 writes one line `step id_i id_j tension|shear`
//   per broken bond (id_i < id_j, sorted by ids within a step; the same on any -np)
//   and `contacts KN KS MU`: broken bonds and spheres that come into touch are the
//   integrator's frictional contacts (see the header), new pairs with springs KN, KS (N/m),
//   every contact with friction MU
//
// BONDS.csv is the SPEC bond table (i, j 0-based in packing order = atom ids i+1, j+1);
// with `model MODEL PACKING` the bonds and springs are computed through the anisobond
// bridge from the packing file. With `model MODEL` alone the atoms in the box at the first
// run are bonded in place (ids = the atoms' own tags; a box periodic in x, y and z is the
// periodic cell, one periodic in none a free cluster; mixed periodicity and a tilted box are
// refused); `write_bonds FILE` makes rank 0 write that bond table (SPEC columns, then
// id_i,id_j), so `anisobond tensor DATA MODEL --bonds FILE` gives the tensor of the same
// network. Atoms inserted after the first run are not bonded. `damping GT GR` adds viscous damping −GT·m·v and −GR·I·ω on every
// owned atom (not in the virial), for quasi-static element tests; default 0 (undamped).
// Requires: atom_style granular (sphere), atom_modify map array, newton on,
// communicate single vel yes.

#include "pair_anisobond.h"

#include "atom.h"
#include "comm.h"
#include "domain.h"
#include "error.h"
#include "fix_property_atom.h"
#include "force.h"
#include "memory.h"
#include "modify.h"
#include "neigh_list.h"
#include "neigh_request.h"
#include "neighbor.h"
#include "update.h"

#include "anisobond/src/ffi/mod.rs.h"

#include "bond_vectors.h"

#include <mpi.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <cstdint>
#include <exception>
#include <stdexcept>
#include <string>
#include <vector>

using namespace LAMMPS_NS;

namespace {

using anisobond_vec::cross;
using anisobond_vec::dot;
using anisobond_vec::rotate_by;

// Remove bond slot b of an atom's row (the last slot moves into its place), nb the count.
void remove_slot(double *row, int b, int &nb) {
  const int head = PairAnisobond::HEAD, ns = PairAnisobond::NSLOT;
  double *s = &row[head + b * ns], *last = &row[head + (nb - 1) * ns];
  if (s != last)
    for (int k = 0; k < ns; k++) s[k] = last[k];
  for (int k = 0; k < ns; k++) last[k] = 0.0;
  nb--;
  row[PairAnisobond::H_COUNT] = nb;
}

}  // namespace

Pair *PairAnisobond::creator(LAMMPS *lmp) { return new PairAnisobond(lmp); }

PairAnisobond::PairAnisobond(LAMMPS *lmp)
    : Pair(lmp), max_bonds_(0), max_length_(0.0), damp_t_(0.0), damp_r_(0.0),
      length_tol_(1e-6), in_place_(false), bonded_(false), breakable_(false),
      breaks_fp_(NULL), manybody_(false), mb_gl_(true), mb_nmax_(0), mb_f_(NULL),
      mb_m_(NULL), fix_id_("anisobond_bonds"), fix_(NULL) {
  single_enable = 0;
  contacts_ = false;
  c_kn_ = c_ks_ = c_mu_ = 0.0;
  r_max_ = 0.0;
  slots_ = 1;
  // The many-body term's per-atom sums and M_p travel as 9 doubles (see the header).
  comm_forward = 9;
  comm_reverse = 9;
  no_virial_fdotr_compute = 1;  // the virial is tallied per bond
  restartinfo = 0;
}

PairAnisobond::~PairAnisobond() {
  if (breaks_fp_ != NULL) fclose(breaks_fp_);
  memory->destroy(mb_f_);
  memory->destroy(mb_m_);
  if (allocated) {
    memory->destroy(setflag);
    memory->destroy(cutsq);
  }
}

void PairAnisobond::allocate() {
  allocated = 1;
  int n = atom->ntypes;
  memory->create(setflag, n + 1, n + 1, "pair:setflag");
  for (int i = 1; i <= n; i++)
    for (int j = i; j <= n; j++) setflag[i][j] = 0;
  memory->create(cutsq, n + 1, n + 1, "pair:cutsq");
}

namespace {

bool is_keyword(const char *w) {
  return strcmp(w, "damping") == 0 || strcmp(w, "length_tolerance") == 0 ||
         strcmp(w, "write_bonds") == 0 || strcmp(w, "breaks") == 0 ||
         strcmp(w, "manybody") == 0 || strcmp(w, "contacts") == 0;
}

}  // namespace

void PairAnisobond::settings(int narg, char **arg) {
  if (narg < 2)
    error->all(FLERR, "Illegal pair_style anisobond command: expected `table BONDS.csv`, "
                      "`model MODEL.toml PACKING` or `model MODEL.toml` (bond in place)");
  rust::Vec<anisobond::BondRow> rows;
  rust::Vec<anisobond::YadeLimits> limits;
  std::string limits_of;
  // The many-body term of the model forms (through the bridge) or of `manybody FILE`.
  anisobond::ManyBodyData mb_data;
  bool mb_have = false, model_form = false, model_strength = false;
  std::string mb_file;
  int iarg = 0;
  manybody_ = false;
  mb_volume_.clear();
  mb_tensor_.clear();
  mb_d_.clear();
  in_place_ = false;
  bonded_ = false;
  write_bonds_.clear();
  breaks_file_.clear();
  contacts_ = false;
  if (breaks_fp_ != NULL) {
    fclose(breaks_fp_);
    breaks_fp_ = NULL;
  }
  try {
    if (strcmp(arg[0], "table") == 0) {
      rows = anisobond::load_bond_table(arg[1]);
      limits = anisobond::load_yade_limits(arg[1]);
      limits_of = std::string("bond table ") + arg[1];
      iarg = 2;
    } else if (strcmp(arg[0], "model") == 0) {
      // A word after MODEL that is not a keyword is the packing file; without it the atoms
      // in the box are bonded at the first run.
      auto model = anisobond::load_model(arg[1]);
      model_form = true;
      model_strength = model->has_strength();
      if (model_strength && model->has_manybody())
        throw std::runtime_error(std::string("model ") + arg[1] +
                                 " has both [strength] and [manybody]: breakable bonds with the "
                                 "many-body term are not supported (a broken bond would change "
                                 "the fits of its particles); remove one of the two tables");
      if (narg >= 3 && !is_keyword(arg[2])) {
        if (model->needs_packing()) model->bind_packing(arg[2]);
        rows = anisobond::build_bond_table(arg[2], *model);
        if (model->has_strength()) limits = anisobond::packing_yade_limits(arg[2], *model);
        limits_of = std::string("model ") + arg[1] + " on " + arg[2];
        if (model->has_manybody()) {
          mb_data = anisobond::packing_manybody(arg[2], *model);
          mb_have = true;
          mb_of_ = limits_of;
        }
        iarg = 3;
      } else {
        in_place_ = true;
        model_path_ = arg[1];
        iarg = 2;
      }
    } else {
      error->all(FLERR, "Illegal pair_style anisobond command: first argument must be `table` or `model`");
    }
  } catch (const std::exception &e) {
    std::string msg = std::string("pair_style anisobond: ") + e.what();
    error->all(FLERR, msg.c_str());
  }
  while (iarg < narg) {
    if (strcmp(arg[iarg], "damping") == 0) {
      if (iarg + 3 > narg) error->all(FLERR, "pair_style anisobond: damping needs GT GR");
      damp_t_ = force->numeric(FLERR, arg[iarg + 1]);
      damp_r_ = force->numeric(FLERR, arg[iarg + 2]);
      iarg += 3;
    } else if (strcmp(arg[iarg], "length_tolerance") == 0) {
      if (iarg + 2 > narg) error->all(FLERR, "pair_style anisobond: length_tolerance needs a value");
      length_tol_ = force->numeric(FLERR, arg[iarg + 1]);
      iarg += 2;
    } else if (strcmp(arg[iarg], "write_bonds") == 0) {
      if (iarg + 2 > narg) error->all(FLERR, "pair_style anisobond: write_bonds needs a FILE");
      if (!in_place_)
        error->all(FLERR, "pair_style anisobond: write_bonds is for the in-place form "
                          "`model MODEL.toml write_bonds FILE` (with `table` or a PACKING the "
                          "bond table is already known: `anisobond bonds` writes it)");
      write_bonds_ = arg[iarg + 1];
      iarg += 2;
    } else if (strcmp(arg[iarg], "breaks") == 0) {
      if (iarg + 2 > narg) error->all(FLERR, "pair_style anisobond: breaks needs a FILE");
      breaks_file_ = arg[iarg + 1];
      iarg += 2;
    } else if (strcmp(arg[iarg], "contacts") == 0) {
      if (iarg + 4 > narg) error->all(FLERR, "pair_style anisobond: contacts needs KN KS MU");
      c_kn_ = force->numeric(FLERR, arg[iarg + 1]);
      c_ks_ = force->numeric(FLERR, arg[iarg + 2]);
      c_mu_ = force->numeric(FLERR, arg[iarg + 3]);
      if (!(c_kn_ > 0.0 && std::isfinite(c_kn_)) || !(c_ks_ >= 0.0 && std::isfinite(c_ks_)) ||
          !(c_mu_ >= 0.0 && std::isfinite(c_mu_)))
        error->all(FLERR, "pair_style anisobond: contacts KN KS MU needs KN > 0, KS >= 0 and "
                          "MU >= 0 (N/m, N/m, tan of the friction angle), all finite");
      contacts_ = true;
      iarg += 4;
    } else if (strcmp(arg[iarg], "manybody") == 0) {
      if (iarg + 2 > narg) error->all(FLERR, "pair_style anisobond: manybody needs a FILE");
      if (model_form)
        error->all(FLERR, "pair_style anisobond: manybody FILE is for the table form "
                          "`table BONDS.csv manybody FILE`; with `model MODEL` the model's "
                          "[manybody] table gives the term");
      mb_file = arg[iarg + 1];
      iarg += 2;
    } else {
      std::string msg = std::string("pair_style anisobond: unknown keyword `") + arg[iarg] +
                        "` (expected damping GT GR, length_tolerance TOL, write_bonds FILE, breaks FILE, contacts KN KS MU or manybody FILE)";
      error->all(FLERR, msg.c_str());
    }
  }
  if (!breaks_file_.empty()) {
    int ok = 1;
    if (comm->me == 0) {
      breaks_fp_ = fopen(breaks_file_.c_str(), "w");
      if (breaks_fp_ == NULL)
        ok = 0;
      else
        fprintf(breaks_fp_, "# step id_i id_j mode (pair_style anisobond: bonds broken)\n");
    }
    MPI_Bcast(&ok, 1, MPI_INT, 0, world);
    if (!ok) {
      std::string msg = "pair_style anisobond: breaks " + breaks_file_ + ": cannot open for writing";
      error->all(FLERR, msg.c_str());
    }
  }
  if (!mb_file.empty()) {
    if (!limits.empty())
      error->all(FLERR, "pair_style anisobond: manybody with breakable bonds (a bond table with "
                        "normal_adhesion,shear_adhesion,tan_friction) is not supported: a broken "
                        "bond would change the fits of its particles");
    try {
      mb_data = anisobond::load_manybody(mb_file);
    } catch (const std::exception &e) {
      std::string msg = std::string("pair_style anisobond: manybody ") + e.what();
      error->all(FLERR, msg.c_str());
    }
    mb_have = true;
    mb_of_ = "manybody " + mb_file;
  }
  if (in_place_) {
    // Bonded at the first init_style(), when the atoms are there.
    bonds_.clear();
    first_bond_.clear();
    max_bonds_ = 1;
    max_length_ = 0.0;
    return;
  }
  std::vector<Bond> bonds;
  bonds.reserve(rows.size());
  for (const anisobond::BondRow &r : rows)
    bonds.push_back(Bond{static_cast<int>(r.i) + 1, static_cast<int>(r.j) + 1, r.kn, r.ks, r.kr,
                         r.ktw, r.length, -1.0, 0.0, 0.0});
  add_limits(bonds, limits, limits_of);
  if (mb_have) {
    try {
      add_manybody(bonds, mb_data, mb_of_);
    } catch (const std::exception &e) {
      std::string msg = std::string("pair_style anisobond: ") + e.what();
      error->all(FLERR, msg.c_str());
    }
  }
  set_bonds(std::move(bonds));
}

// Attach the term of `data` to `bonds` (aligned, checked by ids) and keep D, the measure
// and V_p by tag. Throws std::runtime_error naming `what` on a mismatch.
void PairAnisobond::add_manybody(std::vector<Bond> &bonds, const anisobond::ManyBodyData &data,
                                 const std::string &what) {
  if (data.bonds.size() != bonds.size())
    throw std::runtime_error(what + ": " + std::to_string(data.bonds.size()) +
                             " many-body bond rows for " + std::to_string(bonds.size()) +
                             " bonds (written for another bond table?)");
  for (size_t b = 0; b < bonds.size(); b++) {
    const anisobond::ManyBodyCoef &c = data.bonds[b];
    if (c.id_i != static_cast<std::uint64_t>(bonds[b].tag_i) ||
        c.id_j != static_cast<std::uint64_t>(bonds[b].tag_j))
      throw std::runtime_error(what + ": many-body bond " + std::to_string(b + 1) + " joins atoms " +
                               std::to_string(c.id_i) + "-" + std::to_string(c.id_j) +
                               " but bond " + std::to_string(b + 1) + " of the table joins " +
                               std::to_string(bonds[b].tag_i) + "-" +
                               std::to_string(bonds[b].tag_j));
    for (int k = 0; k < 3; k++) {
      bonds[b].ai[k] = c.coef_i[k];
      bonds[b].aj[k] = c.coef_j[k];
    }
  }
  std::uint64_t max_id = 0;
  for (const anisobond::ManyBodyParticle &p : data.particles) max_id = std::max(max_id, p.id);
  if (max_id > 2147483647ULL) throw std::runtime_error(what + ": atom id beyond 2^31");
  if (data.d.empty() || data.d.size() % 36 != 0)
    throw std::runtime_error(what + ": " + std::to_string(data.d.size()) +
                             " tensor entries, expected 36 per tensor D");
  const std::uint32_t ntensors = static_cast<std::uint32_t>(data.d.size() / 36);
  mb_volume_.assign(max_id + 1, -1.0);
  mb_tensor_.assign(max_id + 1, 0);
  for (const anisobond::ManyBodyParticle &p : data.particles) {
    if (mb_volume_[p.id] >= 0.0)
      throw std::runtime_error(what + ": atom " + std::to_string(p.id) + " given twice");
    if (p.tensor >= ntensors)
      throw std::runtime_error(what + ": atom " + std::to_string(p.id) + " loads tensor " +
                               std::to_string(p.tensor) + " of " + std::to_string(ntensors));
    mb_volume_[p.id] = p.volume;
    mb_tensor_[p.id] = static_cast<int>(p.tensor);
  }
  for (const Bond &b : bonds)
    for (int t : {b.tag_i, b.tag_j})
      if (t >= static_cast<int>(mb_volume_.size()) || mb_volume_[t] < 0.0)
        throw std::runtime_error(what + ": bonded atom " + std::to_string(t) +
                                 " has no volume share");
  mb_d_.assign(data.d.begin(), data.d.end());
  mb_gl_ = data.green_lagrange;
  manybody_ = true;
}

void PairAnisobond::broadcast_manybody() {
  int head[4] = {manybody_ ? 1 : 0, mb_gl_ ? 1 : 0, static_cast<int>(mb_volume_.size()),
                 static_cast<int>(mb_d_.size())};
  MPI_Bcast(head, 4, MPI_INT, 0, world);
  manybody_ = head[0] != 0;
  mb_gl_ = head[1] != 0;
  mb_d_.resize(head[3]);
  if (head[3] > 0) MPI_Bcast(mb_d_.data(), head[3], MPI_DOUBLE, 0, world);
  mb_volume_.resize(head[2]);
  mb_tensor_.resize(head[2]);
  if (head[2] > 0) {
    MPI_Bcast(mb_volume_.data(), head[2], MPI_DOUBLE, 0, world);
    MPI_Bcast(mb_tensor_.data(), head[2], MPI_INT, 0, world);
  }
}

void PairAnisobond::add_limits(std::vector<Bond> &bonds,
                               const rust::Vec<anisobond::YadeLimits> &lim,
                               const std::string &what) {
  if (lim.empty()) return;
  if (lim.size() != bonds.size()) {
    std::string msg = "pair_style anisobond: " + what + ": " + std::to_string(lim.size()) +
                      " bond limits for " + std::to_string(bonds.size()) + " bonds";
    error->all(FLERR, msg.c_str());
  }
  for (size_t b = 0; b < bonds.size(); b++) {
    bonds[b].an = lim[b].normal;
    bonds[b].as = lim[b].shear;
    bonds[b].tf = lim[b].tan_friction;
  }
}

// write_bonds of the in-place form, once the bonds are known to be used (rank 0: the same
// arrays bonded again, now with the library writing the table; deterministic, so the
// table is the one broadcast). The gathered arrays are released.
void PairAnisobond::write_in_place_table() {
  if (comm->me == 0 && !write_bonds_.empty()) {
    try {
      auto model = anisobond::load_model(model_path_);
      anisobond::bond_atoms(
          *model, rust::Slice<const double>(gathered_x_.data(), gathered_x_.size()),
          rust::Slice<const double>(gathered_r_.data(), gathered_r_.size()),
          rust::Slice<const uint64_t>(gathered_ids_.data(), gathered_ids_.size()),
          gathered_box_, write_bonds_);
    } catch (const std::exception &e) {
      std::string msg = std::string("pair_style anisobond: write_bonds ") + write_bonds_ + ": " +
                        e.what();
      error->one(FLERR, msg.c_str());
    }
  }
  std::vector<double>().swap(gathered_x_);
  std::vector<double>().swap(gathered_r_);
  std::vector<uint64_t>().swap(gathered_ids_);
}

// Index the bonds by the tag of their first atom (first_bond_), and note the longest bond
// and the most bonds on one atom.
void PairAnisobond::set_bonds(std::vector<Bond> bonds) {
  bonds_ = std::move(bonds);
  int max_tag = 0;
  for (const Bond &b : bonds_) max_tag = std::max(max_tag, b.tag_j);
  std::stable_sort(bonds_.begin(), bonds_.end(),
                   [](const Bond &a, const Bond &b) { return a.tag_i < b.tag_i; });
  first_bond_.assign(max_tag + 2, 0);
  for (const Bond &b : bonds_) first_bond_[b.tag_i + 1]++;
  max_bonds_ = 0;
  max_length_ = 0.0;
  for (int t = 0; t <= max_tag; t++) {
    max_bonds_ = std::max(max_bonds_, first_bond_[t + 1]);
    first_bond_[t + 1] += first_bond_[t];
  }
  for (const Bond &b : bonds_) max_length_ = std::max(max_length_, b.length);
  breakable_ = false;
  for (const Bond &b : bonds_) breakable_ = breakable_ || b.an >= 0.0;
  if (max_bonds_ == 0) max_bonds_ = 1;
  bonded_ = true;
}

// The in-place form: gather tag, x and radius of every atom on every rank, let rank 0 bond
// them through the library (bond_atoms: the same Assembly as the CLI) and broadcast the
// table, so that every rank holds the identical bonds whatever the decomposition.
void PairAnisobond::bond_in_place() {
  if (!atom->tag_enable)
    error->all(FLERR, "pair_style anisobond model MODEL (in place) needs atom ids (atom_modify id yes)");
  const int nlocal = atom->nlocal;
  const int nprocs = comm->nprocs, me = comm->me;
  std::vector<int> counts(nprocs), displs(nprocs, 0);
  MPI_Allgather(const_cast<int *>(&nlocal), 1, MPI_INT, counts.data(), 1, MPI_INT, world);
  long long total = 0;
  for (int p = 0; p < nprocs; p++) {
    displs[p] = static_cast<int>(total);
    total += counts[p];
  }
  if (total == 0)
    error->all(FLERR, "pair_style anisobond model MODEL (in place): there are no atoms to bond at "
                      "this run: create or read the atoms before the first run");
  if (total > 2147483647LL / 3)
    error->all(FLERR, "pair_style anisobond model MODEL (in place): too many atoms to gather");
  const int n = static_cast<int>(total);
  std::vector<int> tag_local(nlocal);
  std::vector<double> x_local(3 * nlocal), r_local(nlocal);
  for (int i = 0; i < nlocal; i++) {
    tag_local[i] = atom->tag[i];
    for (int k = 0; k < 3; k++) x_local[3 * i + k] = atom->x[i][k];
    r_local[i] = atom->radius[i];
  }
  std::vector<int> tags(n);
  std::vector<double> &xs = gathered_x_, &rs = gathered_r_;
  xs.assign(me == 0 ? 3 * static_cast<size_t>(n) : 0, 0.0);
  rs.assign(me == 0 ? n : 0, 0.0);
  MPI_Gatherv(tag_local.data(), nlocal, MPI_INT, tags.data(), counts.data(), displs.data(),
              MPI_INT, 0, world);
  MPI_Gatherv(r_local.data(), nlocal, MPI_DOUBLE, rs.data(), counts.data(), displs.data(),
              MPI_DOUBLE, 0, world);
  std::vector<int> counts3(nprocs), displs3(nprocs);
  for (int p = 0; p < nprocs; p++) {
    counts3[p] = 3 * counts[p];
    displs3[p] = 3 * displs[p];
  }
  MPI_Gatherv(x_local.data(), 3 * nlocal, MPI_DOUBLE, xs.data(), counts3.data(),
              displs3.data(), MPI_DOUBLE, 0, world);

  // Rank 0 bonds; the outcome (0 = bonds, 1 = the library's refusal) and the table or the
  // message are broadcast.
  std::vector<Bond> bonds;
  std::string failure;
  if (me == 0) {
    try {
      std::vector<uint64_t> &ids = gathered_ids_;
      ids.assign(n, 0);
      for (int k = 0; k < n; k++) {
        if (tags[k] <= 0) throw std::runtime_error("an atom has no id (tag 0)");
        ids[k] = static_cast<uint64_t>(tags[k]);
      }
      anisobond::AtomsBox &box = gathered_box_;
      for (int k = 0; k < 3; k++) {
        box.lo[k] = domain->boxlo[k];
        box.hi[k] = domain->boxhi[k];
        box.periodic[k] = domain->periodicity[k] != 0;
      }
      box.tilt[0] = domain->triclinic ? domain->xy : 0.0;
      box.tilt[1] = domain->triclinic ? domain->xz : 0.0;
      box.tilt[2] = domain->triclinic ? domain->yz : 0.0;
      auto model = anisobond::load_model(model_path_);
      anisobond::AtomBonds ab = anisobond::bond_atoms(
          *model, rust::Slice<const double>(xs.data(), xs.size()),
          rust::Slice<const double>(rs.data(), rs.size()),
          rust::Slice<const uint64_t>(ids.data(), ids.size()), box, "");
      bonds.reserve(ab.rows.size());
      for (const anisobond::BondRow &r : ab.rows)
        bonds.push_back(Bond{static_cast<int>(ab.ids[r.i]), static_cast<int>(ab.ids[r.j]), r.kn,
                             r.ks, r.kr, r.ktw, r.length, -1.0, 0.0, 0.0});
      if (model->has_strength()) {
        rust::Vec<anisobond::YadeLimits> lim = anisobond::atoms_yade_limits(
            *model, rust::Slice<const double>(xs.data(), xs.size()),
            rust::Slice<const double>(rs.data(), rs.size()),
            rust::Slice<const uint64_t>(ids.data(), ids.size()), box);
        if (lim.size() != bonds.size())
          throw std::runtime_error("the bond limits do not match the bonds");
        for (size_t b = 0; b < bonds.size(); b++) {
          bonds[b].an = lim[b].normal;
          bonds[b].as = lim[b].shear;
          bonds[b].tf = lim[b].tan_friction;
        }
      }
      if (model->has_manybody()) {
        mb_of_ = std::string("model ") + model_path_ + " (in place)";
        add_manybody(bonds, anisobond::atoms_manybody(
                                *model, rust::Slice<const double>(xs.data(), xs.size()),
                                rust::Slice<const double>(rs.data(), rs.size()),
                                rust::Slice<const uint64_t>(ids.data(), ids.size()), box),
                     mb_of_);
      }
    } catch (const std::exception &e) {
      failure = std::string("pair_style anisobond model ") + model_path_ +
                " (in place, bonding the " + std::to_string(n) + " atoms of the first run): " +
                e.what();
      bonds.clear();
    }
  }
  int header[2] = {failure.empty() ? 0 : 1,
                   failure.empty() ? static_cast<int>(bonds.size())
                                   : static_cast<int>(failure.size())};
  MPI_Bcast(header, 2, MPI_INT, 0, world);
  if (header[0] != 0) {
    failure.resize(header[1]);
    MPI_Bcast(&failure[0], header[1], MPI_CHAR, 0, world);
    error->all(FLERR, failure.c_str());
  }
  bonds.resize(header[1]);
  if (header[1] > 0)
    MPI_Bcast(bonds.data(), static_cast<int>(header[1] * sizeof(Bond)), MPI_BYTE, 0, world);
  broadcast_manybody();
  set_bonds(std::move(bonds));
}

void PairAnisobond::coeff(int narg, char **arg) {
  if (narg != 2) error->all(FLERR, "Incorrect args for pair coefficients: use `pair_coeff * *`");
  if (!allocated) allocate();
  int ilo, ihi, jlo, jhi;
  force->bounds(arg[0], atom->ntypes, ilo, ihi);
  force->bounds(arg[1], atom->ntypes, jlo, jhi);
  for (int i = ilo; i <= ihi; i++)
    for (int j = std::max(jlo, i); j <= jhi; j++) setflag[i][j] = 1;
}

double PairAnisobond::init_one(int, int) {
  // The ghost cutoff follows the pair cutoff (+ skin): at least the longest bond, with
  // room for stretching; with contacts also the largest touching distance 2 R_max.
  return std::max(1.05 * max_length_, contacts_ ? 2.0 * r_max_ : 0.0);
}

void PairAnisobond::init_style() {
  if (!atom->radius_flag || !atom->omega_flag || !atom->torque_flag || !atom->rmass_flag)
    error->all(FLERR, "pair_style anisobond needs atom_style granular (radius, omega, torque, rmass)");
  if (atom->map_style == 0)
    error->all(FLERR, "pair_style anisobond needs `atom_modify map array` before the box is created");
  if (!force->newton_pair)
    error->all(FLERR, "pair_style anisobond needs `newton on` (each bond is stored once, on its lower-tag atom)");
  if (!comm->ghost_velocity)
    error->all(FLERR, "pair_style anisobond needs `communicate single vel yes` (ghost spins)");
  // LIGGGHTS 3.8 makes no ghost atoms for a triclinic box when it runs on more than one
  // process: bonds across processor boundaries would lose their partner. Refuse at once.
  if (domain->triclinic && comm->nprocs > 1)
    error->all(FLERR,
               "pair_style anisobond: this deck shears a triclinic box, and LIGGGHTS 3.8 makes "
               "no ghost atoms for a triclinic box under MPI (bonds across processors would be "
               "lost). Run it on one process, export with --no-shear for the three normal "
               "cases under mpirun, or take the shear cases to LAMMPS");
  // The in-place form bonds the atoms present now, once (the first run); later runs keep
  // those bonds, and atoms added since are not bonded.
  const bool bonding_now = in_place_ && !bonded_;
  if (bonding_now) bond_in_place();
  // Table and packing ids are 1 … N; in place they are the atoms' own (gaps allowed).
  if (!in_place_ && !first_bond_.empty() &&
      static_cast<int>(first_bond_.size()) - 2 > atom->natoms)
    error->all(FLERR, "pair_style anisobond: the bond table names atom ids beyond the number of atoms");

  // Ghost atoms must reach every partner: the pair cutoff alone does not widen the ghost
  // shell when no neighbour list is requested, so raise the user ghost cutoff to the
  // longest bond (+5 % for stretching) + skin. A partner still missing is an error in
  // compute().
  // Contacts: the largest radius sets the neighbour cutoff; a full list finds each pair
  // from both ends, so the owner of the lower tag keeps it whether the other is a ghost.
  if (contacts_) {
    if (manybody_)
      error->all(FLERR, "pair_style anisobond: contacts with the many-body term is not "
                        "supported (its bonds are read slot by slot from the bond table)");
    double rmax = 0.0;
    for (int i = 0; i < atom->nlocal; i++) rmax = std::max(rmax, atom->radius[i]);
    MPI_Allreduce(&rmax, &r_max_, 1, MPI_DOUBLE, MPI_MAX, world);
    const int irequest = neighbor->request(this);
    neighbor->requests[irequest]->half = 0;
    neighbor->requests[irequest]->full = 1;
  }
  const double need =
      std::max(1.05 * max_length_, contacts_ ? 2.0 * r_max_ : 0.0) + neighbor->skin;
  if (comm->cutghostuser < need) comm->cutghostuser = need;

  slots_ = max_bonds_ + (contacts_ ? static_cast<int>(CONTACT_SLOTS) : 0);
  const int nvalues = HEAD + slots_ * NSLOT;
  fix_ = static_cast<FixPropertyAtom *>(modify->find_fix_id(fix_id_.c_str()));
  if (fix_ == NULL) {
    // fix ID all property/atom NAME vector restart commGhost commGhostRev defaults...
    std::vector<std::string> words = {fix_id_, "all", "property/atom", fix_id_, "vector",
                                      "yes", "no", "no"};
    words.push_back("-1");  // H_COUNT: number of bonds, −1 = not filled yet
    for (int k = 1; k < nvalues; k++) words.push_back("0");  // H_BROKEN, then the slots
    std::vector<char *> argv;
    for (std::string &w : words) argv.push_back(&w[0]);
    modify->add_fix(static_cast<int>(argv.size()), argv.data());
    fix_ = static_cast<FixPropertyAtom *>(modify->find_fix_id(fix_id_.c_str()));
    if (fix_ == NULL) error->all(FLERR, "pair_style anisobond: could not create its fix property/atom");
    // Without this LIGGGHTS resets a new fix property/atom to its defaults after the
    // first force call, wiping the bonds.
    fix_->just_created = 0;
    // A restart file restored this fix's per-atom bond state: the in-place form would bond
    // the atoms again where they are now (and its size need not match the file's).
    int restored = bonding_now && fix_->recent_restart ? 1 : 0, any = 0;
    MPI_Allreduce(&restored, &any, 1, MPI_INT, MPI_MAX, world);
    if (any)
      error->all(FLERR,
                 "pair_style anisobond model MODEL (in place) in a run continued from a restart "
                 "file that holds the bonds of pair_style anisobond: it would bond the atoms "
                 "again where they are now. Bond in place in the run that starts from the "
                 "packing, not after read_restart");
  }
  if (bonding_now) write_in_place_table();
  if (fix_->get_nvalues() != nvalues)
    error->all(FLERR, "pair_style anisobond: its fix property/atom has a different size (bond table changed?)");
  fill_bonds();
}

// Fill the slots of owned atoms that have none yet (−1). Atoms restored from a restart
// file or filled in an earlier run keep their state.
void PairAnisobond::fill_bonds() {
  double **a = fix_->array_atom;
  const int nlocal = atom->nlocal;
  const int *tag = atom->tag;
  const int ntag = static_cast<int>(first_bond_.size()) - 2;
  for (int i = 0; i < nlocal; i++) {
    if (a[i][H_COUNT] >= 0.0) continue;
    int nb = 0;
    const int t = tag[i];
    if (t >= 1 && t <= ntag) {
      for (int b = first_bond_[t]; b < first_bond_[t + 1]; b++, nb++) {
        double *s = &a[i][HEAD + nb * NSLOT];
        for (int k = 0; k < NSLOT; k++) s[k] = 0.0;
        s[S_TAG] = bonds_[b].tag_j;
        s[S_KN] = bonds_[b].kn;
        s[S_KS] = bonds_[b].ks;
        s[S_KR] = bonds_[b].kr;
        s[S_KTW] = bonds_[b].ktw;
        s[S_R0] = -bonds_[b].length;
        s[S_AN] = bonds_[b].an;
        s[S_AS] = bonds_[b].as;
        s[S_TF] = bonds_[b].tf;
        s[S_COH] = 1.0;
      }
    }
    a[i][H_COUNT] = nb;
    a[i][H_BROKEN] = 0.0;
  }
}

// Contacts: give every owned atom a slot for each never-bonded partner of higher tag in
// touch now (R_i + R_j − d ≥ 0) that it has none for; the slot loop of compute() evaluates
// it as a new contact in this force call.
void PairAnisobond::add_new_contacts() {
  double **x = atom->x, *radius = atom->radius;
  const int *tag = atom->tag;
  double **a = fix_->array_atom;
  const int inum = list->inum;
  for (int ii = 0; ii < inum; ii++) {
    const int i = list->ilist[ii];
    const int *jlist = list->firstneigh[i];
    const int jnum = list->numneigh[i];
    for (int jj = 0; jj < jnum; jj++) {
      const int j = jlist[jj] & NEIGHMASK;
      if (tag[j] <= tag[i]) continue;
      const double l[3] = {x[j][0] - x[i][0], x[j][1] - x[i][1], x[j][2] - x[i][2]};
      const double rs = radius[i] + radius[j];
      if (dot(l, l) > rs * rs) continue;
      int nb = static_cast<int>(a[i][H_COUNT]);
      bool have = false;
      for (int b = 0; b < nb && !have; b++)
        have = static_cast<int>(a[i][HEAD + b * NSLOT + S_TAG]) == tag[j];
      if (have) continue;
      if (nb >= slots_) {
        char msg[256];
        std::snprintf(msg, sizeof msg,
                      "pair_style anisobond contacts: atom %d has %d bonds and contacts, no room "
                      "for one more (with atom %d): at most its bonds + %d contacts",
                      tag[i], nb, tag[j], static_cast<int>(CONTACT_SLOTS));
        error->one(FLERR, msg);
      }
      double *s = &a[i][HEAD + nb * NSLOT];
      for (int k = 0; k < NSLOT; k++) s[k] = 0.0;
      s[S_TAG] = tag[j];
      s[S_KN] = c_kn_;
      s[S_KS] = c_ks_;
      s[S_AN] = -1.0;  // never judged: not a bond
      s[S_TF] = c_mu_;
      s[S_COH] = 0.0;  // a contact, new (no normal yet)
      s[S_NEW] = 1.0;
      a[i][H_COUNT] = nb + 1;
    }
  }
}

void PairAnisobond::compute(int eflag, int vflag) {
  if (eflag || vflag)
    ev_setup(eflag, vflag);
  else
    evflag = vflag_fdotr = 0;

  double **x = atom->x, **v = atom->v, **f = atom->f;
  double **omega = atom->omega, **torque = atom->torque;
  double *radius = atom->radius, *rmass = atom->rmass;
  const int *tag = atom->tag;
  const int nlocal = atom->nlocal;
  const int newton_pair = force->newton_pair;
  double **a = fix_->array_atom;
  // The setup force call of a run must not advance the history (rotations by ω·dt).
  const double dt = update->setupflag ? 0.0 : update->dt;

  if (contacts_) add_new_contacts();

  for (int i = 0; i < nlocal; i++) {
    int nb = static_cast<int>(a[i][H_COUNT]);
    for (int b = 0; b < nb; b++) {
      double *s = &a[i][HEAD + b * NSLOT];
      const int tag_j = static_cast<int>(s[S_TAG]);
      const int j = atom->map(tag_j);
      if (j < 0) {
        char msg[512];
        std::snprintf(msg, sizeof msg,
                      "pair_style anisobond: bond partner %d of atom %d is missing on this "
                      "process (ghost cutoff too short: raise `communicate single cutoff`, "
                      "or the atom was lost; ghost cutoff %g %g %g, %d ghosts)",
                      tag_j, tag[i], comm->cutghost[0], comm->cutghost[1], comm->cutghost[2],
                      atom->nghost);
        error->one(FLERR, msg);
      }
      double l[3] = {x[j][0] - x[i][0], x[j][1] - x[i][1], x[j][2] - x[i][2]};
      domain->minimum_image(l);
      const double d = std::sqrt(dot(l, l));
      const double n[3] = {l[0] / d, l[1] / d, l[2] / d};
      const double kn = s[S_KN], ks = s[S_KS], kr = s[S_KR], ktw = s[S_KTW];
      double *fs = &s[S_FS], *mb = &s[S_MB], *mt = &s[S_MT];
      // Loads on i (force F at the arm r_i n, moment M) and the pair's elastic energy.
      double F[3], M[3] = {0.0, 0.0, 0.0}, ri = 0.0, rj = 0.0, e = 0.0;
      // The slot is a contact in this call; `carried`: a bond just broken in shear handed
      // its trial shear force on (capped, neither rotated nor incremented now).
      bool contact = contacts_ && s[S_COH] <= 0.0, carried = false;

      if (!contact) {
        if (s[S_R0] < 0.0) {
          // First force call of this bond: the rest length is the actual distance, which
          // must agree with the table's (same packing, same ids).
          const double want = -s[S_R0];
          if (std::fabs(d - want) > length_tol_ * want) {
            char msg[512];
            std::snprintf(msg, sizeof msg,
                          "pair_style anisobond: bond %d-%d has length %.9g m in the box but "
                          "%.9g m in the bond table (wrong packing or atom ids?)",
                          tag[i], tag_j, d, want);
            error->one(FLERR, msg);
          }
          s[S_R0] = d;
          s[S_LP] = l[0];
          s[S_LP + 1] = l[1];
          s[S_LP + 2] = l[2];
        }
        const double gap = d - radius[i] - radius[j];
        ri = radius[i] + 0.5 * gap;
        rj = radius[j] + 0.5 * gap;

        // Rotate the shear force and moments with the contact (YADE ScGeom::rotate).
        double *lp = &s[S_LP];
        const double dp = std::sqrt(dot(lp, lp));
        const double np[3] = {lp[0] / dp, lp[1] / dp, lp[2] / dp};
        double axis[3];
        cross(np, n, axis);
        double spin[3] = {omega[i][0] + omega[j][0], omega[i][1] + omega[j][1],
                          omega[i][2] + omega[j][2]};
        const double tw = 0.5 * dt * dot(spin, n);
        const double twist_axis[3] = {tw * n[0], tw * n[1], tw * n[2]};
        rotate_by(fs, axis);
        rotate_by(fs, twist_axis);
        rotate_by(mb, axis);
        rotate_by(mb, twist_axis);
        rotate_by(mt, axis);
        rotate_by(mt, twist_axis);

        // Relative displacement of j w.r.t. i at the contact point.
        double wi[3], wj[3];
        const double ani[3] = {ri * n[0], ri * n[1], ri * n[2]};
        const double anj[3] = {-rj * n[0], -rj * n[1], -rj * n[2]};
        cross(omega[i], ani, wi);
        cross(omega[j], anj, wj);
        double du[3];
        for (int k = 0; k < 3; k++) du[k] = (l[k] - lp[k]) + dt * (wj[k] - wi[k]);
        const double dun = dot(du, n);
        for (int k = 0; k < 3; k++) fs[k] += ks * (du[k] - dun * n[k]);

        // Relative rotation increment.
        double th[3] = {dt * (omega[j][0] - omega[i][0]), dt * (omega[j][1] - omega[i][1]),
                        dt * (omega[j][2] - omega[i][2])};
        const double thn = dot(th, n);
        for (int k = 0; k < 3; k++) {
          mb[k] += kr * (th[k] - thn * n[k]);
          mt[k] += ktw * thn * n[k];
        }
        lp[0] = l[0];
        lp[1] = l[1];
        lp[2] = l[2];

        const double fnm = kn * (d - s[S_R0]);  // tension positive
        bool frictional = false;
        if (s[S_AN] >= 0.0 && !update->setupflag) {
          // Breakage by YADE's CohFrict criterion, the library's own (the normal force
          // compression positive); dt = 0 setup calls do not judge.
          if (s[S_COH] > 0.0) {
            const anisobond::YadeLimits lim{s[S_AN], s[S_AS], s[S_TF]};
            const anisobond::BondVerdict verdict =
                anisobond::yade_cohfrict_check(lim, -fnm, std::sqrt(dot(fs, fs)));
            if (verdict.broken) {
              a[i][H_BROKEN] += 1.0;
              if (!breaks_file_.empty()) {
                step_breaks_.push_back(std::min(tag[i], tag_j));
                step_breaks_.push_back(std::max(tag[i], tag_j));
                step_breaks_.push_back(verdict.mode == 0 ? 0 : 1);
              }
              if (contacts_) {
                // The pair is a contact from now on, with the bond's springs and the
                // contacts' friction; a shear break hands its trial shear force on.
                contact = true;
                carried = verdict.mode != 0;
                s[S_COH] = 0.0;
                s[S_TF] = c_mu_;
                for (int k = 0; k < 3; k++) {
                  mb[k] = mt[k] = 0.0;
                  if (!carried) fs[k] = 0.0;
                }
              } else if (verdict.mode == 0) {
                remove_slot(a[i], b, nb);
                b--;
                continue;
              } else {
                s[S_COH] = 0.0;  // broken in shear: a frictional contact from now on
              }
            }
          }
          if (!contact && s[S_COH] <= 0.0) {
            // Frictional contact (YADE after cohesion broke): lost in tension; else
            // |F_s| ≤ F_n tan φ and no moments.
            if (fnm > 0.0) {
              remove_slot(a[i], b, nb);
              b--;
              continue;
            }
            const double cap = -fnm * s[S_TF], mag = std::sqrt(dot(fs, fs));
            if (mag > cap)
              for (int k = 0; k < 3; k++) fs[k] *= mag > 0.0 ? cap / mag : 0.0;
            for (int k = 0; k < 3; k++) mb[k] = mt[k] = 0.0;
            frictional = true;
          }
        }
        if (!contact) {
          for (int k = 0; k < 3; k++) {
            F[k] = fnm * n[k] + fs[k];
            M[k] = mb[k] + mt[k];
          }
          if (eflag) {
            e = 0.5 * kn * (d - s[S_R0]) * (d - s[S_R0]);
            if (ks > 0) e += 0.5 * dot(fs, fs) / ks;
            if (!frictional && kr > 0) e += 0.5 * dot(mb, mb) / kr;
            if (!frictional && ktw > 0) e += 0.5 * dot(mt, mt) / ktw;
          }
        }
      }

      if (contact) {
        // The integrator's frictional contact (header; src/dem/contacts.rs pair_kernel).
        const double pd = radius[i] + radius[j] - d;
        if (!(pd >= 0.0) || d == 0.0) {
          // Apart: no force, no memory; a never-bonded pair's slot goes.
          if (s[S_NEW] > 0.0) {
            remove_slot(a[i], b, nb);
            b--;
            continue;
          }
          s[S_COH] = 0.0;
          for (int k = 0; k < 3; k++) fs[k] = s[S_LP + k] = 0.0;
          continue;
        }
        const bool active = s[S_COH] < 0.0;
        const double *nold = active ? &s[S_LP] : n;
        ri = radius[i] - 0.5 * pd;
        rj = radius[j] - 0.5 * pd;
        const double c1x[3] = {ri * n[0], ri * n[1], ri * n[2]};
        const double c2x[3] = {c1x[0] - l[0], c1x[1] - l[1], c1x[2] - l[2]};
        if (!carried) {
          double axis[3];
          cross(nold, n, axis);
          double spin[3] = {omega[i][0] + omega[j][0], omega[i][1] + omega[j][1],
                            omega[i][2] + omega[j][2]};
          const double tw = dt * 0.5 * dot(nold, spin);
          const double twist_axis[3] = {nold[0] * tw, nold[1] * tw, nold[2] * tw};
          rotate_by(fs, axis);
          rotate_by(fs, twist_axis);
          double wi[3], wj[3], vr[3];
          cross(omega[i], c1x, wi);
          cross(omega[j], c2x, wj);
          for (int k = 0; k < 3; k++) vr[k] = (v[j][k] + wj[k]) - (v[i][k] + wi[k]);
          const double vn = dot(n, vr);
          // The integrator's F_s (on j) less k_s Δu_s is this (on i) plus it.
          for (int k = 0; k < 3; k++) fs[k] += ((vr[k] - n[k] * vn) * dt) * ks;
        }
        const double fn = kn * pd;
        const double mu = s[S_TF];
        const double max2 = (fn * fn) * (mu * mu), fs2 = dot(fs, fs);
        if (fs2 > max2) {
          const double ratio = std::sqrt(max2) / std::sqrt(fs2);
          for (int k = 0; k < 3; k++) fs[k] *= ratio;
        }
        s[S_COH] = -1.0;
        for (int k = 0; k < 3; k++) {
          s[S_LP + k] = n[k];
          F[k] = -fn * n[k] + fs[k];
        }
        if (eflag) {
          e = 0.5 * fn * fn / kn;
          if (ks > 0) e += 0.5 * dot(fs, fs) / ks;
        }
      }

      double ti[3], tj[3];
      const double ani[3] = {ri * n[0], ri * n[1], ri * n[2]};
      cross(ani, F, ti);  // (r_i n) × F
      const double anjp[3] = {rj * n[0], rj * n[1], rj * n[2]};
      cross(anjp, F, tj);  // (r_j n) × F
      for (int k = 0; k < 3; k++) {
        f[i][k] += F[k];
        f[j][k] -= F[k];
        torque[i][k] += ti[k] + M[k];
        torque[j][k] += tj[k] - M[k];
      }
      if (evflag) {
        // LAMMPS convention: force on i, del = x_i − x_j = −l.
        ev_tally_xyz(i, j, nlocal, newton_pair, eflag ? e : 0.0, 0.0, F[0], F[1], F[2], -l[0],
                     -l[1], -l[2]);
      }
    }
  }
  if (manybody_) compute_manybody(eflag);

  if (!breaks_file_.empty() && !update->setupflag) write_breaks();

  if (damp_t_ > 0.0 || damp_r_ > 0.0) {
    for (int i = 0; i < nlocal; i++) {
      const double m = rmass[i];
      const double inertia = 0.4 * m * radius[i] * radius[i];
      for (int k = 0; k < 3; k++) {
        f[i][k] -= damp_t_ * m * v[i][k];
        torque[i][k] -= damp_r_ * inertia * omega[i][k];
      }
    }
  }
}

// `breaks FILE`: gather this step's breaks of every rank on rank 0, sort them by ids and
// write them (a collective: every rank calls it on every force call of a run).
void PairAnisobond::write_breaks() {
  int mine = static_cast<int>(step_breaks_.size()), total = 0;
  MPI_Allreduce(&mine, &total, 1, MPI_INT, MPI_SUM, world);
  if (total == 0) return;
  const int np = comm->nprocs;
  std::vector<int> counts(np, 0), offsets(np, 0), all(comm->me == 0 ? total : 0);
  MPI_Gather(&mine, 1, MPI_INT, counts.data(), 1, MPI_INT, 0, world);
  for (int r = 1; r < np; r++) offsets[r] = offsets[r - 1] + counts[r - 1];
  MPI_Gatherv(step_breaks_.data(), mine, MPI_INT, all.data(), counts.data(), offsets.data(),
              MPI_INT, 0, world);
  step_breaks_.clear();
  if (comm->me != 0 || breaks_fp_ == NULL) return;
  std::vector<std::array<int, 3>> rows(total / 3);
  for (size_t k = 0; k < rows.size(); k++) rows[k] = {all[3 * k], all[3 * k + 1], all[3 * k + 2]};
  std::sort(rows.begin(), rows.end());
  for (const std::array<int, 3> &r : rows)
    fprintf(breaks_fp_, BIGINT_FORMAT " %d %d %s\n", update->ntimestep, r[0], r[1],
            r[2] == 0 ? "tension" : "shear");
  fflush(breaks_fp_);
}

// The many-body term's forces (see the header): F_p by a reverse communication, M_p = V_p P_p
// by a forward one, then g_b = M_i a_i + M_j a_j on every bond (docs/manybody.md).
void PairAnisobond::compute_manybody(int eflag) {
  const int nlocal = atom->nlocal, nall = nlocal + atom->nghost;
  if (atom->nmax > mb_nmax_) {
    memory->destroy(mb_f_);
    memory->destroy(mb_m_);
    mb_nmax_ = atom->nmax;
    memory->create(mb_f_, mb_nmax_, 9, "pair:anisobond_mb_f");
    memory->create(mb_m_, mb_nmax_, 9, "pair:anisobond_mb_m");
  }
  for (int i = 0; i < nall; i++)
    for (int k = 0; k < 9; k++) mb_f_[i][k] = mb_m_[i][k] = 0.0;
  double **x = atom->x, **f = atom->f;
  const int *tag = atom->tag;
  double **a = fix_->array_atom;
  const int ntag = static_cast<int>(first_bond_.size()) - 2;

  // The bond b of owned atom i: its partner's index and the table row (same partner).
  auto row_of = [&](int i, int b, int &j) -> const Bond & {
    const double *s = &a[i][HEAD + b * NSLOT];
    const int tag_j = static_cast<int>(s[S_TAG]);
    const int k = tag[i] >= 1 && tag[i] <= ntag ? first_bond_[tag[i]] + b : -1;
    if (k < 0 || k >= first_bond_[tag[i] + 1] || bonds_[k].tag_j != tag_j) {
      char msg[256];
      std::snprintf(msg, sizeof msg,
                    "pair_style anisobond manybody: bond %d of atom %d (partner %d) is not the "
                    "bond table's; the many-body term needs the bonds as the table gives them",
                    b, tag[i], tag_j);
      error->one(FLERR, msg);
    }
    j = atom->map(tag_j);
    return bonds_[k];
  };

  // (1) Σ_b l_b ⊗ a_b at both ends.
  for (int i = 0; i < nlocal; i++) {
    const int nb = static_cast<int>(a[i][H_COUNT]);
    for (int b = 0; b < nb; b++) {
      int j;
      const Bond &bd = row_of(i, b, j);
      double l[3] = {x[j][0] - x[i][0], x[j][1] - x[i][1], x[j][2] - x[i][2]};
      domain->minimum_image(l);
      for (int r = 0; r < 3; r++)
        for (int c = 0; c < 3; c++) {
          mb_f_[i][3 * r + c] += l[r] * bd.ai[c];
          mb_f_[j][3 * r + c] += l[r] * bd.aj[c];
        }
    }
  }
  comm->reverse_comm_pair(this);

  // (2) E_p, S = D_p:E (D_p: p's grain's D, or the one D), P and M_p = V_p P_p of every
  // owned atom in the term.
  double energy = 0.0;
  for (int i = 0; i < nlocal; i++) {
    const double vp = tag[i] < static_cast<int>(mb_volume_.size()) ? mb_volume_[tag[i]] : 0.0;
    if (!(vp > 0.0)) continue;
    const double *D = &mb_d_[36 * static_cast<size_t>(mb_tensor_[tag[i]])];
    const double *F = mb_f_[i];
    double E[9];
    for (int r = 0; r < 3; r++)
      for (int c = 0; c < 3; c++) {
        if (mb_gl_) {
          double ftf = 0.0;
          for (int k = 0; k < 3; k++) ftf += F[3 * k + r] * F[3 * k + c];
          E[3 * r + c] = 0.5 * (ftf - (r == c ? 1.0 : 0.0));
        } else {
          E[3 * r + c] = 0.5 * (F[3 * r + c] + F[3 * c + r]) - (r == c ? 1.0 : 0.0);
        }
      }
    const double ev[6] = {E[0], E[4], E[8], 2.0 * E[5], 2.0 * E[2], 2.0 * E[1]};
    double sv[6];
    for (int r = 0; r < 6; r++) {
      sv[r] = 0.0;
      for (int c = 0; c < 6; c++) sv[r] += D[6 * r + c] * ev[c];
    }
    double w = 0.0;
    for (int r = 0; r < 6; r++) w += 0.5 * ev[r] * sv[r];
    const double S[9] = {sv[0], sv[5], sv[4], sv[5], sv[1], sv[3], sv[4], sv[3], sv[2]};
    double *M = mb_m_[i];
    for (int r = 0; r < 3; r++)
      for (int c = 0; c < 3; c++) {
        double p = S[3 * r + c];
        if (mb_gl_) {
          p = 0.0;
          for (int k = 0; k < 3; k++) p += F[3 * r + k] * S[3 * k + c];
        }
        M[3 * r + c] = vp * p;
      }
    if (eflag) {
      if (eflag_global) energy += vp * w;
      if (eflag_atom) eatom[i] += vp * w;
    }
  }
  if (eflag && eflag_global) eng_vdwl += energy;
  comm->forward_comm_pair(this);

  // (3) g_b = M_i a_i + M_j a_j: +g_b on i, −g_b on j.
  for (int i = 0; i < nlocal; i++) {
    const int nb = static_cast<int>(a[i][H_COUNT]);
    for (int b = 0; b < nb; b++) {
      int j;
      const Bond &bd = row_of(i, b, j);
      double g[3];
      for (int r = 0; r < 3; r++) {
        g[r] = 0.0;
        for (int c = 0; c < 3; c++) g[r] += mb_m_[i][3 * r + c] * bd.ai[c] + mb_m_[j][3 * r + c] * bd.aj[c];
      }
      for (int k = 0; k < 3; k++) {
        f[i][k] += g[k];
        f[j][k] -= g[k];
      }
      if (evflag) {
        double l[3] = {x[j][0] - x[i][0], x[j][1] - x[i][1], x[j][2] - x[i][2]};
        domain->minimum_image(l);
        ev_tally_xyz(i, j, nlocal, force->newton_pair, 0.0, 0.0, g[0], g[1], g[2], -l[0], -l[1],
                     -l[2]);
      }
    }
  }
}

// LIGGGHTS 3.8's Comm (the LAMMPS interface before 2014) sends n × the returned count:
// pack_comm and pack_reverse_comm return the values per atom (9), not the total.
int PairAnisobond::pack_comm(int n, int *list, double *buf, int, int *) {
  int m = 0;
  for (int i = 0; i < n; i++)
    for (int k = 0; k < 9; k++) buf[m++] = mb_m_[list[i]][k];
  return 9;
}

void PairAnisobond::unpack_comm(int n, int first, double *buf) {
  int m = 0;
  for (int i = first; i < first + n; i++)
    for (int k = 0; k < 9; k++) mb_m_[i][k] = buf[m++];
}

int PairAnisobond::pack_reverse_comm(int n, int first, double *buf) {
  int m = 0;
  for (int i = first; i < first + n; i++)
    for (int k = 0; k < 9; k++) buf[m++] = mb_f_[i][k];
  return 9;
}

void PairAnisobond::unpack_reverse_comm(int n, int *list, double *buf) {
  int m = 0;
  for (int i = 0; i < n; i++)
    for (int k = 0; k < 9; k++) mb_f_[list[i]][k] += buf[m++];
}
