// bond_style anisobond — see bond_anisobond.h for the bond law and the design.
//
//   plugin load /path/to/anisobond_lammps.so
//   bond_style anisobond model MODEL.toml [damping ZETA] [lattice_scaling MU]
//   bond_style anisobond table BONDS.csv  [damping ZETA] [length_tolerance TOL]
//   ... [break yes strengths STRENGTHS.csv [record BROKEN.txt]]   (or break no, the default)
//   ... [manybody D11 D12 … D66 [manybody/measure green-lagrange|small]
//        [manybody/degenerate refuse|exclude] [manybody/conditioning C]]   (21 numbers, Pa)
//   ... [manybody/grains GRAINS.txt [manybody/measure …] …]   (a polycrystal: D per grain,
//        the grain of an atom = its molecule ID − 1)
//   bond_coeff *
//
// Requires atom_style bpm/sphere (or sphere: radius, rmass, omega, torque), `newton on on`
// (newton_bond on: each bond stored once, on its first atom, which holds its state) and
// `comm_modify vel yes` (ghost velocities and spins); ghost atoms must reach every partner
// (`comm_modify cutoff` ≥ the longest bond, as for bpm/rotational).

#include "bond_anisobond.h"

#include "atom.h"
#include "comm.h"
#include "domain.h"
#include "error.h"
#include "force.h"
#include "memory.h"
#include "modify.h"
#include "neigh_list.h"
#include "neighbor.h"
#include "update.h"
#include "utils.h"

#include "bond_vectors.h"

#include <mpi.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <exception>
#include <fstream>
#include <sstream>
#include <utility>

using namespace LAMMPS_NS;

namespace {

const char *const FIX_ID = "ANISOBOND_STATE";
const char *const ARRAY_NAME = "anisobond_state";
const char *const MB_FIX_ID = "ANISOBOND_MANYBODY";
const char *const MB_ARRAY_NAME = "anisobond_manybody";

using anisobond_vec::cross;
using anisobond_vec::dot;
using anisobond_vec::rotate_by;

// Eigenvalues of the symmetric 3×3 matrix a (cyclic Jacobi rotations; a is overwritten).
void symmetric_eigenvalues(double a[3][3], double ev[3]) {
  for (int sweep = 0; sweep < 64; sweep++) {
    const double off = a[0][1] * a[0][1] + a[0][2] * a[0][2] + a[1][2] * a[1][2];
    const double diag = a[0][0] * a[0][0] + a[1][1] * a[1][1] + a[2][2] * a[2][2];
    if (off <= 1e-36 * diag || off == 0.0) break;
    for (int p = 0; p < 2; p++) {
      for (int q = p + 1; q < 3; q++) {
        if (a[p][q] == 0.0) continue;
        const double theta = (a[q][q] - a[p][p]) / (2.0 * a[p][q]);
        const double t = (theta >= 0.0 ? 1.0 : -1.0) /
                         (std::fabs(theta) + std::sqrt(theta * theta + 1.0));
        const double c = 1.0 / std::sqrt(t * t + 1.0), sn = t * c;
        for (int k = 0; k < 3; k++) {  // columns p, q
          const double akp = a[k][p], akq = a[k][q];
          a[k][p] = c * akp - sn * akq;
          a[k][q] = sn * akp + c * akq;
        }
        for (int k = 0; k < 3; k++) {  // rows p, q
          const double apk = a[p][k], aqk = a[q][k];
          a[p][k] = c * apk - sn * aqk;
          a[q][k] = sn * apk + c * aqk;
        }
      }
    }
  }
  for (int k = 0; k < 3; k++) ev[k] = a[k][k];
}

// The inverse of a 3×3 matrix by its cofactors; false when its determinant is 0 or not finite.
bool inverse3(const double a[3][3], double inv[9]) {
  const double c00 = a[1][1] * a[2][2] - a[1][2] * a[2][1];
  const double c01 = a[1][2] * a[2][0] - a[1][0] * a[2][2];
  const double c02 = a[1][0] * a[2][1] - a[1][1] * a[2][0];
  const double det = a[0][0] * c00 + a[0][1] * c01 + a[0][2] * c02;
  if (!(det != 0.0) || !std::isfinite(det)) return false;
  const double r = 1.0 / det;
  inv[0] = c00 * r;
  inv[1] = (a[0][2] * a[2][1] - a[0][1] * a[2][2]) * r;
  inv[2] = (a[0][1] * a[1][2] - a[0][2] * a[1][1]) * r;
  inv[3] = c01 * r;
  inv[4] = (a[0][0] * a[2][2] - a[0][2] * a[2][0]) * r;
  inv[5] = (a[0][2] * a[1][0] - a[0][0] * a[1][2]) * r;
  inv[6] = c02 * r;
  inv[7] = (a[0][1] * a[2][0] - a[0][0] * a[2][1]) * r;
  inv[8] = (a[0][0] * a[1][1] - a[0][1] * a[1][0]) * r;
  return true;
}

inline std::uint64_t pair_key(tagint a, tagint b) {
  const std::uint64_t lo = static_cast<std::uint64_t>(std::min(a, b));
  const std::uint64_t hi = static_cast<std::uint64_t>(std::max(a, b));
  return (lo << 32) | hi;
}

}  // namespace

BondAnisobond::BondAnisobond(LAMMPS *lmp)
    : Bond(lmp), break_(false), record_fp_(nullptr), zeta_(0.0), length_tol_(1e-6), mu_(0.0), r0_max_(0.0), index_(-1),
      need_init_(false), mb_(false), mb_small_(false), mb_cond_(1e-6), mb_exclude_(false),
      mb_index_(-1), mb_need_ref_(false), mb_width_(9) {
  for (int a = 0; a < 6; a++)
    for (int b = 0; b < 6; b++) mb_d_[a][b] = 0.0;
  comm_forward = comm_reverse = 0;
  partial_flag = 0;
  writedata = 0;
  born_matrix_enable = 0;
}

BondAnisobond::~BondAnisobond() {
  if (allocated) memory->destroy(setflag);
  if (record_fp_) fclose(record_fp_);
}

void BondAnisobond::allocate() {
  allocated = 1;
  const int n = atom->nbondtypes;
  memory->create(setflag, n + 1, "bond:setflag");
  for (int i = 1; i <= n; i++) setflag[i] = 0;
}

void BondAnisobond::settings(int narg, char **arg) {
  if (narg < 2)
    error->all(FLERR, "bond_style anisobond: expected `model MODEL.toml` or `table BONDS.csv`, "
                      "then optional `damping ZETA`, `length_tolerance TOL`");
  args_.assign(arg, arg + narg);
  source_ = arg[0];
  model_.reset();
  table_.clear();
  limits_.clear();
  break_ = false;
  record_.clear();
  std::string strengths;
  zeta_ = 0.0;
  length_tol_ = 1e-6;
  mu_ = 0.0;
  mb_ = false;
  mb_small_ = false;
  mb_cond_ = 1e-6;
  mb_exclude_ = false;
  mb_grains_file_.clear();
  mb_grain_d_.clear();
  mb_grain_set_.clear();
  bool mb_options = false;  // a manybody/ keyword was given
  bool mb_one = false;      // `manybody D11 … D66` was given
  try {
    if (source_ == "model") {
      model_.reset(new rust::Box<anisobond::ModelHandle>(anisobond::load_model(arg[1])));
    } else if (source_ == "table") {
      const rust::Vec<anisobond::BondRow> rows = anisobond::load_bond_table(arg[1]);
      table_.reserve(rows.size());
      for (const anisobond::BondRow &r : rows) {
        const Springs s = {r.kn, r.ks, r.kr, r.ktw, r.length};
        table_[pair_key(static_cast<tagint>(r.i) + 1, static_cast<tagint>(r.j) + 1)] = s;
      }
    } else {
      error->all(FLERR, "bond_style anisobond: first argument `{}`: expected `model` or `table`",
                 source_);
    }
  } catch (const std::exception &e) {
    error->all(FLERR, "bond_style anisobond {} {}: {}", source_, arg[1], e.what());
  }
  int iarg = 2;
  while (iarg < narg) {
    const std::string key = arg[iarg];
    if (key == "damping" && iarg + 1 < narg) {
      zeta_ = utils::numeric(FLERR, arg[iarg + 1], false, lmp);
      if (!(zeta_ >= 0.0 && zeta_ <= 2.0))
        error->all(FLERR, "bond_style anisobond: damping ratio {} must be in [0, 2]", zeta_);
      iarg += 2;
    } else if (key == "lattice_scaling" && iarg + 1 < narg) {
      // μ given (written to restart files once computed, so that bonds initialised after a
      // restart get the springs of the original box).
      mu_ = utils::numeric(FLERR, arg[iarg + 1], false, lmp);
      if (!model_) error->all(FLERR, "bond_style anisobond: lattice_scaling is for `model`");
      try {
        (*model_)->set_lattice_scaling(mu_);
      } catch (const std::exception &e) {
        error->all(FLERR, "bond_style anisobond: lattice_scaling {}: {}", mu_, e.what());
      }
      iarg += 2;
    } else if (key == "break" && iarg + 1 < narg) {
      break_ = utils::logical(FLERR, arg[iarg + 1], false, lmp) == 1;
      iarg += 2;
    } else if (key == "record" && iarg + 1 < narg) {
      record_ = arg[iarg + 1];
      iarg += 2;
    } else if (key == "strengths" && iarg + 1 < narg) {
      strengths = arg[iarg + 1];
      iarg += 2;
    } else if (key == "manybody") {
      if (narg - iarg - 1 < 21)
        error->all(FLERR, "bond_style anisobond: `manybody` takes the 21 upper-triangle entries "
                          "D11 D12 D13 D14 D15 D16 D22 … D66 of the term's Voigt matrix (Pa), "
                          "got {}",
                   narg - iarg - 1);
      int k = iarg + 1;
      for (int a = 0; a < 6; a++) {
        for (int b = a; b < 6; b++) {
          const double v = utils::numeric(FLERR, arg[k++], false, lmp);
          if (!std::isfinite(v))
            error->all(FLERR, "bond_style anisobond: manybody D{}{} = {} is not finite", a + 1,
                       b + 1, v);
          mb_d_[a][b] = mb_d_[b][a] = v;
        }
      }
      mb_ = true;
      mb_one = true;
      iarg = k;
    } else if (key == "manybody/grains" && iarg + 1 < narg) {
      mb_grains_file_ = arg[iarg + 1];
      mb_ = true;
      iarg += 2;
    } else if (key == "manybody/measure" && iarg + 1 < narg) {
      const std::string m = arg[iarg + 1];
      if (m != "green-lagrange" && m != "small")
        error->all(FLERR, "bond_style anisobond: manybody/measure `{}`: expected green-lagrange "
                          "or small",
                   m);
      mb_small_ = m == "small";
      mb_options = true;
      iarg += 2;
    } else if (key == "manybody/degenerate" && iarg + 1 < narg) {
      const std::string m = arg[iarg + 1];
      if (m != "refuse" && m != "exclude")
        error->all(FLERR, "bond_style anisobond: manybody/degenerate `{}`: expected refuse or "
                          "exclude",
                   m);
      mb_exclude_ = m == "exclude";
      mb_options = true;
      iarg += 2;
    } else if (key == "manybody/conditioning" && iarg + 1 < narg) {
      mb_cond_ = utils::numeric(FLERR, arg[iarg + 1], false, lmp);
      if (!(mb_cond_ >= 0.0 && mb_cond_ < 1.0))
        error->all(FLERR, "bond_style anisobond: manybody/conditioning {} must lie in [0, 1) "
                          "(λ_min/λ_max of Σ L⊗L)",
                   mb_cond_);
      mb_options = true;
      iarg += 2;
    } else if (key == "length_tolerance" && iarg + 1 < narg) {
      length_tol_ = utils::numeric(FLERR, arg[iarg + 1], false, lmp);
      if (!(length_tol_ > 0.0))
        error->all(FLERR, "bond_style anisobond: length_tolerance {} must be > 0", length_tol_);
      iarg += 2;
    } else {
      error->all(FLERR, "bond_style anisobond: keyword `{}`: expected `damping ZETA`, "
                        "`length_tolerance TOL`, `lattice_scaling MU`, `break yes|no`, "
                        "`strengths STRENGTHS.csv`, `record BROKEN.txt`, `manybody D11 … D66`, "
                        "`manybody/grains GRAINS.txt`, "
                        "`manybody/measure M`, `manybody/degenerate D` or "
                        "`manybody/conditioning C`",
                 key);
    }
  }
  if (mb_options && !mb_)
    error->all(FLERR, "bond_style anisobond: manybody/measure, manybody/degenerate and "
                      "manybody/conditioning are for `manybody D11 … D66` or `manybody/grains "
                      "FILE`");
  if (mb_one && !mb_grains_file_.empty())
    error->all(FLERR, "bond_style anisobond: `manybody D11 … D66` (one D) and `manybody/grains "
                      "{}` (a D per grain) both given; give one",
               mb_grains_file_);
  if (!mb_grains_file_.empty()) read_grain_tensors(mb_grains_file_);
  if (mb_ && break_)
    error->all(FLERR, "bond_style anisobond: `manybody` with `break yes`: the many-body term of "
                      "a network whose bonds break is not defined (each atom's fit is of its "
                      "bonds at the reference); use `break no`");
  // Σ l⊗L (reverse) and M_p (forward): 9 doubles per atom.
  comm_forward = comm_reverse = mb_ ? 9 : 0;
  if (break_ && strengths.empty())
    error->all(FLERR, "bond_style anisobond: `break yes` needs `strengths STRENGTHS.csv` (each "
                      "bond's critical loads; `anisobond export lammps` writes "
                      "bond-strengths.csv for a model with a [strength] table)");
  if (!break_ && !strengths.empty())
    error->all(FLERR, "bond_style anisobond: `strengths {}` is for `break yes`", strengths);
  if (!break_ && !record_.empty())
    error->all(FLERR, "bond_style anisobond: `record {}` is for `break yes` (it lists the broken "
                      "bonds)",
               record_);
  if (break_) read_strengths(strengths);
}

// The strength table: a header line, then `id_i,id_j,f_rc,f_sc,tau_bc,tau_tc` per bond (atom
// ids; N, N, N·m, N·m), each load finite and > 0 (the criterion divides by it).
void BondAnisobond::read_strengths(const std::string &path) {
  std::ifstream in(path);
  if (!in) error->all(FLERR, "bond_style anisobond: cannot open the strength table {}", path);
  std::string line;
  long lineno = 0;
  while (std::getline(in, line)) {
    lineno++;
    if (line.empty() || line[0] == '#' || line.rfind("id_i", 0) == 0) continue;
    std::stringstream ss(line);
    std::string field;
    std::vector<std::string> f;
    while (std::getline(ss, field, ',')) f.push_back(field);
    double v[6];
    bool ok = f.size() == 6;
    for (int k = 0; ok && k < 6; k++) {
      char *end = nullptr;
      v[k] = std::strtod(f[k].c_str(), &end);
      ok = end != f[k].c_str() && *end == '\0' && std::isfinite(v[k]);
    }
    ok = ok && v[0] >= 1 && v[1] >= 1 && v[0] != v[1] && v[2] > 0 && v[3] > 0 && v[4] > 0 &&
         v[5] > 0;
    if (!ok)
      error->all(FLERR, "bond_style anisobond: strength table {} line {}: `{}`: expected "
                        "id_i,id_j,f_rc,f_sc,tau_bc,tau_tc (two atom ids, four loads > 0)",
                 path, lineno, line);
    const std::uint64_t key = pair_key(static_cast<tagint>(v[0]), static_cast<tagint>(v[1]));
    if (!limits_.emplace(key, Limits{v[2], v[3], v[4], v[5]}).second)
      error->all(FLERR, "bond_style anisobond: strength table {} line {}: bond {}-{} given twice",
                 path, lineno, static_cast<tagint>(v[0]), static_cast<tagint>(v[1]));
  }
}

// `manybody/grains FILE`: one line per grain, `g D11 D12 … D66` (grain id g ≥ 0 and D's 21
// upper-triangle Voigt entries in the lab frame, Pa, each finite); `#` starts a comment.
// A grain given twice, a short line or a bad number is refused naming the file and line.
void BondAnisobond::read_grain_tensors(const std::string &path) {
  std::ifstream in(path);
  if (!in)
    error->all(FLERR, "bond_style anisobond: cannot open the many-body grain tensors {}", path);
  std::string line;
  long lineno = 0;
  while (std::getline(in, line)) {
    lineno++;
    const std::string body = line.substr(0, line.find('#'));
    std::stringstream ss(body);
    std::vector<std::string> w;
    std::string word;
    while (ss >> word) w.push_back(word);
    if (w.empty()) continue;
    if (w.size() != 22)
      error->all(FLERR, "bond_style anisobond: manybody/grains {} line {}: `{}`: expected a grain "
                        "id and D's 21 upper-triangle entries D11 D12 … D66 (Pa), found {} words",
                 path, lineno, line, w.size());
    char *end = nullptr;
    const long g = std::strtol(w[0].c_str(), &end, 10);
    if (end == w[0].c_str() || *end != '\0' || g < 0 || g > 2147483646L)
      error->all(FLERR, "bond_style anisobond: manybody/grains {} line {}: grain id `{}`: "
                        "expected a whole number ≥ 0 (molecule ID − 1)",
                 path, lineno, w[0]);
    double d[36];
    int k = 1;
    for (int a = 0; a < 6; a++)
      for (int b = a; b < 6; b++) {
        end = nullptr;
        const double v = std::strtod(w[k].c_str(), &end);
        if (end == w[k].c_str() || *end != '\0' || !std::isfinite(v))
          error->all(FLERR, "bond_style anisobond: manybody/grains {} line {}: D{}{} `{}`: "
                            "expected a finite number (Pa)",
                     path, lineno, a + 1, b + 1, w[k]);
        d[6 * a + b] = d[6 * b + a] = v;
        k++;
      }
    const size_t gi = static_cast<size_t>(g);
    if (gi >= mb_grain_set_.size()) {
      mb_grain_set_.resize(gi + 1, 0);
      mb_grain_d_.resize(36 * (gi + 1), 0.0);
    }
    if (mb_grain_set_[gi])
      error->all(FLERR, "bond_style anisobond: manybody/grains {} line {}: grain {} given twice",
                 path, lineno, g);
    mb_grain_set_[gi] = 1;
    std::copy(d, d + 36, mb_grain_d_.begin() + 36 * gi);
  }
  if (mb_grain_set_.empty())
    error->all(FLERR, "bond_style anisobond: manybody/grains {}: no grain given", path);
}

// D of owned atom p (row-major Voigt, 36 entries): its grain's (molecule ID − 1, checked by
// init_style) with `manybody/grains`, else the one D.
const double *BondAnisobond::manybody_tensor(int p) const {
  if (mb_grains_file_.empty()) return &mb_d_[0][0];
  return &mb_grain_d_[36 * static_cast<size_t>(atom->molecule[p] - 1)];
}

// bond_coeff TYPES: the springs come per bond from the model or table, so a type only
// needs to be declared (`bond_coeff *`); coefficients are refused rather than ignored.
void BondAnisobond::coeff(int narg, char **arg) {
  if (narg != 1)
    error->all(FLERR, "bond_coeff for bond_style anisobond: expected only the bond types "
                      "(`bond_coeff *`); each bond's springs come from `model` or `table`");
  if (!allocated) allocate();
  int ilo, ihi;
  utils::bounds(FLERR, arg[0], 1, atom->nbondtypes, ilo, ihi, error);
  for (int i = ilo; i <= ihi; i++) setflag[i] = 1;
}

void BondAnisobond::init_style() {
  if (source_.empty()) error->all(FLERR, "bond_style anisobond: no `model` or `table` given");
  if (!atom->radius_flag || !atom->rmass_flag || !atom->omega_flag || !atom->torque_flag)
    error->all(FLERR, "bond_style anisobond needs per-atom radius, rmass, omega and torque: "
                      "atom_style bpm/sphere or sphere");
  if (!force->newton_bond)
    error->all(FLERR, "bond_style anisobond needs newton_bond on (`newton on on`): each bond "
                      "is stored once, on its first atom, which holds its state");
  if (!comm->ghost_velocity)
    error->all(FLERR, "bond_style anisobond needs `comm_modify vel yes` (partners' velocities "
                      "and spins)");
  if (atom->bond_per_atom < 1) error->all(FLERR, "bond_style anisobond: the system has no bonds");
  // A table bond missing from the system would be silently dropped: the counts must agree
  // (a system bond missing from the table is an error at its first force call).
  // With breakage the system may hold fewer (broken bonds are gone after a restart).
  const bigint held = atom->nbonds;
  if (source_ == "table" && (break_ ? static_cast<bigint>(table_.size()) < held
                                    : static_cast<bigint>(table_.size()) != held))
    error->all(FLERR, "bond_style anisobond: the bond table {} has {} bonds, the system {} "
                      "(another packing or bonding rule?)",
               args_[1], table_.size(), atom->nbonds);
  if (break_ && static_cast<bigint>(limits_.size()) < held)
    error->all(FLERR, "bond_style anisobond: the strength table has {} bonds, the system {}",
               limits_.size(), held);
  // A broken pair leaves the special list (share_breaks) and meets the pair style: intact
  // bonds must be censored (1-2 weight 0) but kept in the neighbour lists with their special
  // bits (a coul weight ≠ 0), as for bpm/rotational.
  if (break_ && force->pair && !force->pair_match("zero", 1) &&
      !(force->special_lj[1] == 0.0 && force->special_coul[1] != 0.0))
    error->all(FLERR, "bond_style anisobond break yes with pair_style {} needs `special_bonds "
                      "lj 0 1 1 coul 1 1 1` (bonded pairs censored but kept in the neighbour "
                      "lists, so that a broken pair becomes a contact at once)",
               force->pair_style);

  if (!record_.empty() && comm->me == 0 && !record_fp_) {
    record_fp_ = fopen(record_.c_str(), "w");
    if (!record_fp_)
      error->one(FLERR, "bond_style anisobond: cannot open the record of broken bonds {}: {}",
                 record_, utils::getsyserror());
    fputs("# bonds broken by bond_style anisobond: id_lo id_hi timestep\n", record_fp_);
    fflush(record_fp_);
  }

  // The per-bond state: created on first use, found again on later runs, restored from
  // the restart file when the fix of the same ID and style was in it (Modify::add_fix).
  const int ncols = atom->bond_per_atom * NSLOT;
  int flag = 0, cols = 0;
  index_ = atom->find_custom(ARRAY_NAME, flag, cols);
  if (index_ < 0) {
    modify->add_fix(fmt::format("{} all property/atom d2_{} {} ghost no", FIX_ID, ARRAY_NAME,
                                ncols));
    index_ = atom->find_custom(ARRAY_NAME, flag, cols);
    if (index_ < 0) error->all(FLERR, "bond_style anisobond: could not create its state array");
  }
  if (flag != 1 || cols != ncols)
    error->all(FLERR, "bond_style anisobond: per-atom array d2_{} has {} columns, expected {} "
                      "({} bonds per atom × {}); was the number of bonds per atom changed?",
               ARRAY_NAME, cols, ncols, atom->bond_per_atom, static_cast<int>(NSLOT));
  // The cross-anisotropic scheme needs μ from all bonds: a collective step in the first
  // force call of the first run (compute() runs on every process at setup).
  need_init_ = model_ && (*model_)->needs_packing() && mu_ == 0.0;

  // The many-body term's per-atom reference (created, found again or restored as the state).
  mb_index_ = -1;
  mb_need_ref_ = false;
  if (mb_) {
    if (!domain->xperiodic || !domain->yperiodic || !domain->zperiodic)
      error->all(FLERR, "bond_style anisobond: `manybody` shares the box volume among the atoms "
                        "(V_p ∝ r³, as anisobond's default), which needs a box periodic along "
                        "x, y and z");
    const int mcols = MB_L0 + 3 * atom->bond_per_atom;
    mb_index_ = atom->find_custom(MB_ARRAY_NAME, flag, cols);
    if (mb_index_ < 0) {
      modify->add_fix(fmt::format("{} all property/atom d2_{} {} ghost no", MB_FIX_ID,
                                  MB_ARRAY_NAME, mcols));
      mb_index_ = atom->find_custom(MB_ARRAY_NAME, flag, cols);
      if (mb_index_ < 0)
        error->all(FLERR, "bond_style anisobond: could not create its many-body array");
    }
    if (flag != 1 || cols != mcols)
      error->all(FLERR, "bond_style anisobond: per-atom array d2_{} has {} columns, expected {} "
                        "({} + 3 × {} bonds per atom)",
                 MB_ARRAY_NAME, cols, mcols, static_cast<int>(MB_L0), atom->bond_per_atom);
    // A polycrystal: every owned atom's grain (molecule ID − 1) must have its D in the file.
    if (!mb_grains_file_.empty()) {
      if (!atom->molecule_flag)
        error->all(FLERR, "bond_style anisobond: manybody/grains takes each atom's grain from "
                          "its molecule ID (grain + 1), which this atom style has not: use "
                          "atom_style bpm/sphere");
      for (int i = 0; i < atom->nlocal; i++) {
        const tagint m = atom->molecule[i];
        if (m < 1 || static_cast<size_t>(m - 1) >= mb_grain_set_.size() ||
            !mb_grain_set_[static_cast<size_t>(m - 1)])
          error->one(FLERR, "bond_style anisobond: atom {} has molecule ID {} (grain {}), whose "
                            "D manybody/grains {} does not give",
                     atom->tag[i], m, m - 1, mb_grains_file_);
      }
    }
    // Collective: any atom without its reference makes every process set it at the first
    // force call (after read_data all are unset; after read_restart all are set).
    double **mb = atom->darray[mb_index_];
    int mine = 0, any = 0;
    for (int i = 0; i < atom->nlocal; i++)
      if (mb[i][MB_READY] != 1.0) mine = 1;
    MPI_Allreduce(&mine, &any, 1, MPI_INT, MPI_MAX, world);
    mb_need_ref_ = any != 0;
  }
}

// μ = π̂·Σ(½ r0·min(R_i, R_j)²)/(3V) over every bond of every process (Šmilauer Eq. 20,
// anisobond's schemes::cross_anisotropic::lattice_scaling), with r0 the stored rest length
// or, for a bond not yet initialised, its present length; V the box volume.
void BondAnisobond::initialise_bonds() {
  double **x = atom->x;
  double *radius = atom->radius;
  double **state = atom->darray[index_];
  int **bondlist = neighbor->bondlist;
  double local[2] = {0.0, 0.0};
  for (int n = 0; n < neighbor->nbondlist; n++) {
    const int i = bondlist[n][0], j = bondlist[n][1];
    int m = 0;
    while (m < atom->num_bond[i] && atom->bond_atom[i][m] != atom->tag[j]) m++;
    if (m == atom->num_bond[i]) continue;  // reported by compute()
    double r0 = state[i][m * NSLOT + S_R0];
    if (r0 == 0.0) {
      const double l[3] = {x[j][0] - x[i][0], x[j][1] - x[i][1], x[j][2] - x[i][2]};
      r0 = std::sqrt(dot(l, l));
    }
    const double r = std::min(radius[i], radius[j]);
    local[0] += 0.5 * r0 * r * r;
    local[1] += 1.0;
  }
  double total[2];
  MPI_Allreduce(local, total, 2, MPI_DOUBLE, MPI_SUM, world);
  const double volume = domain->xprd * domain->yprd * domain->zprd;
  if (total[1] == 0.0)
    error->all(FLERR, "bond_style anisobond: the cross-anisotropic lattice scaling needs bonds");
  const double mu = (*model_)->pi_hat() * total[0] / (3.0 * volume);
  try {
    (*model_)->set_lattice_scaling(mu);
  } catch (const std::exception &e) {
    error->all(FLERR, "bond_style anisobond: lattice scaling μ = {}: {}", mu, e.what());
  }
  mu_ = mu;
  if (comm->me == 0)
    utils::logmesg(lmp, "bond_style anisobond: lattice scaling mu = {:.17g} from {} bonds, "
                        "volume {:.17g}\n",
                   mu, static_cast<bigint>(total[1]), volume);
  need_init_ = false;
}

// Springs, damping and history of a bond at its first force call: rest length and
// direction are the present ones.
void BondAnisobond::springs_of(int i, int j, const double *l, double d, double *s) {
  Springs k = {0.0, 0.0, 0.0, 0.0, d};
  if (model_) {
    try {
      const anisobond::BondSprings b = (*model_)->bond_springs(
          l[0] / d, l[1] / d, l[2] / d, atom->radius[i], atom->radius[j], d);
      k = {b.kn, b.ks, b.kr, b.ktw, d};
    } catch (const std::exception &e) {
      error->one(FLERR, "bond_style anisobond: springs of bond {}-{}: {}", atom->tag[i],
                 atom->tag[j], e.what());
    }
  } else {
    const auto it = table_.find(pair_key(atom->tag[i], atom->tag[j]));
    if (it == table_.end())
      error->one(FLERR, "bond_style anisobond: bond {}-{} is not in the bond table {}",
                 atom->tag[i], atom->tag[j], args_[1]);
    k = it->second;
    if (std::fabs(d - k.length) > length_tol_ * k.length)
      error->one(FLERR, "bond_style anisobond: bond {}-{} is {:.9g} m long in the box but "
                        "{:.9g} m in the bond table {} (another packing or other atom ids?)",
                 atom->tag[i], atom->tag[j], d, k.length, args_[1]);
  }
  for (int q = 0; q < NSLOT; q++) s[q] = 0.0;
  s[S_R0] = d;
  s[S_KN] = k.kn;
  s[S_KS] = k.ks;
  s[S_KR] = k.kr;
  s[S_KTW] = k.ktw;
  if (zeta_ > 0.0) {
    const double mi = atom->rmass[i], mj = atom->rmass[j];
    const double ri = atom->radius[i], rj = atom->radius[j];
    const double m_red = mi * mj / (mi + mj);
    const double ii = 0.4 * mi * ri * ri, ij = 0.4 * mj * rj * rj;
    const double i_red = ii * ij / (ii + ij);
    const double a = 0.5 * d;
    const double k_roll = k.kr + k.ks * a * a;
    const double k_twist = k.ktw > 0.0 ? k.ktw : k_roll;
    s[S_GN] = 2.0 * zeta_ * std::sqrt(k.kn * m_red);
    s[S_GS] = 2.0 * zeta_ * std::sqrt(k.ks * m_red);
    s[S_GR] = 2.0 * zeta_ * std::sqrt(k_roll * i_red);
    s[S_GT] = 2.0 * zeta_ * std::sqrt(k_twist * i_red);
  }
  s[S_LP] = l[0];
  s[S_LP + 1] = l[1];
  s[S_LP + 2] = l[2];
  r0_max_ = std::max(r0_max_, d);
}

// The critical loads of bond i-j from the strength table, into its state.
void BondAnisobond::limits_of(int i, int j, double *s) {
  const auto it = limits_.find(pair_key(atom->tag[i], atom->tag[j]));
  if (it == limits_.end())
    error->one(FLERR, "bond_style anisobond: bond {}-{} is not in the strength table",
               atom->tag[i], atom->tag[j]);
  s[S_FRC] = it->second.frc;
  s[S_FSC] = it->second.fsc;
  s[S_TBC] = it->second.tbc;
  s[S_TTC] = it->second.ttc;
}

// Remove bond m of owned atom i (newton_bond on: it is stored only there): the last bond and
// its state slot take its place.
void BondAnisobond::remove_bond(int i, int m) {
  const int last = atom->num_bond[i] - 1;
  double *st = atom->darray[index_][i];
  if (m != last) {
    atom->bond_atom[i][m] = atom->bond_atom[i][last];
    atom->bond_type[i][m] = atom->bond_type[i][last];
    std::memcpy(st + m * NSLOT, st + last * NSLOT, NSLOT * sizeof(double));
  }
  for (int q = 0; q < NSLOT; q++) st[last * NSLOT + q] = 0.0;
  atom->num_bond[i] = last;
}

void BondAnisobond::compute(int eflag, int vflag) {
  ev_init(eflag, vflag);
  if (need_init_) initialise_bonds();
  if (mb_ && mb_need_ref_) manybody_reference();

  double **x = atom->x, **v = atom->v, **f = atom->f;
  double **omega = atom->omega, **torque = atom->torque;
  const tagint *tag = atom->tag;
  const int *num_bond = atom->num_bond;
  tagint **bond_atom = atom->bond_atom;
  const int nlocal = atom->nlocal;
  const int newton_bond = force->newton_bond;
  double **state = atom->darray[index_];
  int **bondlist = neighbor->bondlist;
  const int nbondlist = neighbor->nbondlist;
  // The setup force call of a run must not advance the history (rotations by ω·dt).
  const double dt = update->setupflag ? 0.0 : update->dt;
  bigint broken = 0;  // bonds broken by this process in this call

  for (int nb = 0; nb < nbondlist; nb++) {
    // newton_bond on: bondlist[.][0] is the owned atom whose bond_atom list holds the bond
    // and [1] the closest image of its partner. Type 0: broken since the list was built.
    if (bondlist[nb][2] <= 0) continue;
    const int i = bondlist[nb][0], j = bondlist[nb][1];
    const tagint tj = tag[j];
    const int nbi = num_bond[i];
    const tagint *partners = bond_atom[i];
    int m = 0;
    while (m < nbi && partners[m] != tj) m++;
    if (m == nbi)
      error->one(FLERR, "bond_style anisobond: bond {}-{} is not in atom {}'s bond list",
                 tag[i], tj, tag[i]);
    double *s = state[i] + m * NSLOT;

    double l[3] = {x[j][0] - x[i][0], x[j][1] - x[i][1], x[j][2] - x[i][2]};
    const double d = std::sqrt(dot(l, l));
    if (s[S_R0] == 0.0) springs_of(i, j, l, d, s);
    if (break_ && s[S_FRC] == 0.0) limits_of(i, j, s);
    const double inv_d = 1.0 / d;
    const double n[3] = {l[0] * inv_d, l[1] * inv_d, l[2] * inv_d};
    const double a = 0.5 * s[S_R0];  // lever arm: the bond's midpoint

    // Rotate the shear force and moment with the bond (YADE ScGeom::rotate): the change of
    // direction n_prev × n and the mean spin about n.
    double *lp = &s[S_LP];
    const double inv_dp = 1.0 / std::sqrt(dot(lp, lp));
    const double np[3] = {lp[0] * inv_dp, lp[1] * inv_dp, lp[2] * inv_dp};
    double axis[3];
    cross(np, n, axis);
    const double spin[3] = {omega[i][0] + omega[j][0], omega[i][1] + omega[j][1],
                            omega[i][2] + omega[j][2]};
    const double tw = 0.5 * dt * dot(spin, n);
    const double twist_axis[3] = {tw * n[0], tw * n[1], tw * n[2]};
    double *fs = &s[S_FS], *mom = &s[S_M];
    rotate_by(fs, axis);
    rotate_by(fs, twist_axis);
    rotate_by(mom, axis);
    rotate_by(mom, twist_axis);

    // Velocity of j relative to i at the midpoint, and its displacement over the step.
    const double an[3] = {a * n[0], a * n[1], a * n[2]};
    double wi[3], wj[3];
    cross(omega[i], an, wi);  // ω_i × (a n)
    cross(omega[j], an, wj);  // ω_j × (a n); at j the arm is −a n
    double dv[3], du[3];
    for (int k = 0; k < 3; k++) {
      dv[k] = v[j][k] - v[i][k] - wj[k] - wi[k];
      du[k] = (l[k] - lp[k]) - dt * (wj[k] + wi[k]);
    }
    const double dun = dot(du, n);
    const double ks = s[S_KS];
    for (int k = 0; k < 3; k++) fs[k] += ks * (du[k] - dun * n[k]);

    // Relative rotation over the step: bending (⊥ n) and twisting (∥ n).
    const double dw[3] = {omega[j][0] - omega[i][0], omega[j][1] - omega[i][1],
                          omega[j][2] - omega[i][2]};
    const double dwn = dot(dw, n);
    const double kr = s[S_KR], ktw = s[S_KTW];
    for (int k = 0; k < 3; k++)
      mom[k] += dt * (kr * (dw[k] - dwn * n[k]) + ktw * dwn * n[k]);
    lp[0] = l[0];
    lp[1] = l[1];
    lp[2] = l[2];

    const double stretch = d - s[S_R0];
    if (break_) {
      // bpm/rotational's criterion on the springs' loads (damping excluded, as there).
      const double mn = dot(mom, n);
      const double mb[3] = {mom[0] - mn * n[0], mom[1] - mn * n[1], mom[2] - mn * n[2]};
      const double b = s[S_KN] * stretch / s[S_FRC] + std::sqrt(dot(fs, fs)) / s[S_FSC] +
                       std::sqrt(dot(mb, mb)) / s[S_TBC] + std::fabs(mn) / s[S_TTC];
      if (b >= 1.0) {
        broken_now_.push_back(std::min(tag[i], tj));
        broken_now_.push_back(std::max(tag[i], tj));
        bondlist[nb][2] = 0;
        remove_bond(i, m);
        broken++;
        continue;
      }
    }

    // Forces and torques: springs plus the bond's own damping.
    const double dvn = dot(dv, n);
    const double gn = s[S_GN], gs = s[S_GS], gr = s[S_GR], gt = s[S_GT];
    const double fn = s[S_KN] * stretch + (gn - gs) * dvn;
    double F[3], M[3];
    for (int k = 0; k < 3; k++) {
      F[k] = fn * n[k] + fs[k] + gs * dv[k];
      M[k] = mom[k] + gr * (dw[k] - dwn * n[k]) + gt * dwn * n[k];
    }
    double t[3];
    cross(an, F, t);  // (a n) × F, the same on both sides
    f[i][0] += F[0];
    f[i][1] += F[1];
    f[i][2] += F[2];
    f[j][0] -= F[0];
    f[j][1] -= F[1];
    f[j][2] -= F[2];
    torque[i][0] += t[0] + M[0];
    torque[i][1] += t[1] + M[1];
    torque[i][2] += t[2] + M[2];
    torque[j][0] += t[0] - M[0];
    torque[j][1] += t[1] - M[1];
    torque[j][2] += t[2] - M[2];

    if (evflag) {
      double e = 0.0;
      if (eflag_either) {
        e = 0.5 * s[S_KN] * stretch * stretch;
        if (ks > 0.0) e += 0.5 * dot(fs, fs) / ks;
        const double mn = dot(mom, n);
        const double mb2 = dot(mom, mom) - mn * mn;
        if (kr > 0.0) e += 0.5 * mb2 / kr;
        if (ktw > 0.0) e += 0.5 * mn * mn / ktw;
      }
      // LAMMPS' convention: force on i, del = x_i − x_j = −l.
      ev_tally_xyz(i, j, nlocal, newton_bond, e, F[0], F[1], F[2], -l[0], -l[1], -l[2]);
    }
  }
  if (mb_) manybody_compute();
  if (break_) {
    // The system's bond count (thermo `bonds`, restart files) follows the broken bonds.
    bigint all = 0;
    MPI_Allreduce(&broken, &all, 1, MPI_LMP_BIGINT, MPI_SUM, world);
    atom->nbonds -= all;
    if (all > 0) share_breaks(all);
    broken_now_.clear();
  }
}

// The bonds broken in this call (`broken_now_` of every process, `nbroken` in all), gathered
// on every process: process 0 appends them to the record sorted by ids (the same lines on any
// process count); every process takes each broken pair out of its owned atoms' 1-2 special
// lists and out of the special bits of its pair neighbour lists, so the pair style acts on
// the pair from the next force call on (what BPM's fix update/special/bonds does for
// bpm/rotational; here the partner may be owned by another process, hence the gather).
void BondAnisobond::share_breaks(bigint nbroken) {
  const int mine = static_cast<int>(broken_now_.size());
  std::vector<int> counts(comm->nprocs), offsets(comm->nprocs);
  MPI_Allgather(&mine, 1, MPI_INT, counts.data(), 1, MPI_INT, world);
  int total = 0;
  for (int p = 0; p < comm->nprocs; p++) {
    offsets[p] = total;
    total += counts[p];
  }
  if (total != 2 * nbroken)
    error->all(FLERR, "bond_style anisobond: {} broken bonds gathered, {} counted", total / 2,
               nbroken);
  std::vector<tagint> all(total);
  MPI_Allgatherv(broken_now_.data(), mine, MPI_LMP_TAGINT, all.data(), counts.data(),
                 offsets.data(), MPI_LMP_TAGINT, world);
  std::vector<std::pair<tagint, tagint>> pairs;
  for (int k = 0; k + 1 < total; k += 2) pairs.emplace_back(all[k], all[k + 1]);
  std::sort(pairs.begin(), pairs.end());
  if (record_fp_) {
    for (const auto &p : pairs)
      fprintf(record_fp_, TAGINT_FORMAT " " TAGINT_FORMAT " " BIGINT_FORMAT "\n", p.first,
              p.second, update->ntimestep);
    fflush(record_fp_);
  }

  // The owned atoms' special lists: 1-2 entries first, then 1-3, 1-4 (cumulative counts).
  const int nlocal = atom->nlocal;
  for (const auto &p : pairs) {
    for (int side = 0; side < 2; side++) {
      const tagint me = side ? p.second : p.first, other = side ? p.first : p.second;
      const int i = atom->map(me);
      if (i < 0 || i >= nlocal) continue;
      tagint *sl = atom->special[i];
      int *ns = atom->nspecial[i];
      int m = 0;
      while (m < ns[0] && sl[m] != other) m++;
      if (m == ns[0]) continue;  // not a 1-2 partner (already removed)
      for (; m < ns[2] - 1; m++) sl[m] = sl[m + 1];
      ns[0]--;
      ns[1]--;
      ns[2]--;
    }
  }
  // The pair neighbour lists built before the break still mark the pair as special.
  std::unordered_map<std::uint64_t, bool> gone;
  for (const auto &p : pairs) gone[pair_key(p.first, p.second)] = true;
  const tagint *tag = atom->tag;
  for (int q = 0; q < neighbor->nlist; q++) {
    NeighList *list = neighbor->lists[q];
    if (!list || list->requestor_type != NeighList::PAIR || !list->firstneigh) continue;
    for (int ii = 0; ii < list->inum; ii++) {
      const int i = list->ilist[ii];
      int *jlist = list->firstneigh[i];
      for (int jj = 0; jj < list->numneigh[i]; jj++) {
        const int j = jlist[jj];
        if ((j >> SBBITS & 3) == 0) continue;
        if (gone.count(pair_key(tag[i], tag[j & NEIGHMASK]))) jlist[jj] = j & NEIGHMASK;
      }
    }
  }
}

// The slot of owned atom i's bond with the atom of id `partner` (error if it has none).
int BondAnisobond::slot_of(int i, tagint partner) const {
  const int nbi = atom->num_bond[i];
  const tagint *partners = atom->bond_atom[i];
  int m = 0;
  while (m < nbi && partners[m] != partner) m++;
  if (m == nbi)
    error->one(FLERR, "bond_style anisobond: bond {}-{} is not in atom {}'s bond list",
               atom->tag[i], partner, atom->tag[i]);
  return m;
}

// The many-body reference, collectively at the first force call: each bond's L_b (its present
// branch vector), A_p = Σ_b L_b ⊗ L_b and the bond count summed into both ends and reverse-
// communicated to the owners, then per owned atom A_p⁻¹ and V_p = V·r_p³/Σ r³, or the atom
// refused or excluded when degenerate (src/manybody/term.rs, fit_inverse).
void BondAnisobond::manybody_reference() {
  double **x = atom->x;
  double **mb = atom->darray[mb_index_];
  const tagint *tag = atom->tag;
  const int nlocal = atom->nlocal, nall = nlocal + atom->nghost;
  int **bondlist = neighbor->bondlist;
  mb_acc_.assign(9 * static_cast<size_t>(nall), 0.0);
  for (int nb = 0; nb < neighbor->nbondlist; nb++) {
    if (bondlist[nb][2] <= 0) continue;
    const int i = bondlist[nb][0], j = bondlist[nb][1];
    const int m = slot_of(i, tag[j]);
    double *L = mb[i] + MB_L0 + 3 * m;
    for (int k = 0; k < 3; k++) L[k] = x[j][k] - x[i][k];
    for (const int p : {i, j}) {
      double *acc = &mb_acc_[9 * static_cast<size_t>(p)];
      acc[0] += L[0] * L[0];
      acc[1] += L[0] * L[1];
      acc[2] += L[0] * L[2];
      acc[3] += L[1] * L[1];
      acc[4] += L[1] * L[2];
      acc[5] += L[2] * L[2];
      acc[6] += 1.0;
    }
  }
  mb_width_ = 7;
  comm->reverse_comm(this, 7);

  double r3 = 0.0, r3_all = 0.0;
  for (int p = 0; p < nlocal; p++) r3 += atom->radius[p] * atom->radius[p] * atom->radius[p];
  MPI_Allreduce(&r3, &r3_all, 1, MPI_DOUBLE, MPI_SUM, world);
  const double volume = domain->xprd * domain->yprd * domain->zprd;
  bigint excluded = 0;
  for (int p = 0; p < nlocal; p++) {
    const double *acc = &mb_acc_[9 * static_cast<size_t>(p)];
    double a[3][3] = {{acc[0], acc[1], acc[2]}, {acc[1], acc[3], acc[4]}, {acc[2], acc[4], acc[5]}};
    const double a_copy[3][3] = {{acc[0], acc[1], acc[2]},
                                 {acc[1], acc[3], acc[4]},
                                 {acc[2], acc[4], acc[5]}};
    const int count = static_cast<int>(acc[6] + 0.5);
    std::string why;
    double inv[9];
    if (count < 3) {
      why = fmt::format("has {} bond{}", count, count == 1 ? "" : "s");
    } else {
      double ev[3];
      symmetric_eigenvalues(a, ev);
      const double lo = std::min(ev[0], std::min(ev[1], ev[2]));
      const double hi = std::max(ev[0], std::max(ev[1], ev[2]));
      const double ratio = lo / hi;
      if (!(ratio >= mb_cond_ && ratio > 0.0))
        why = fmt::format("has {} bonds (nearly) in one plane: λ_min/λ_max of Σ L⊗L is {:e}, "
                          "below the accepted {:e}",
                          count, ratio, mb_cond_);
      else if (!inverse3(a_copy, inv))
        why = fmt::format("has {} bonds whose Σ L⊗L cannot be inverted", count);
    }
    if (!why.empty()) {
      if (!mb_exclude_)
        error->one(FLERR, "bond_style anisobond: many-body term: atom {} {}; its local strain "
                          "needs at least three bonds not in one plane (`manybody/degenerate "
                          "exclude` leaves such atoms out)",
                   tag[p], why);
      for (int k = 0; k < 9; k++) mb[p][MB_AINV + k] = 0.0;
      mb[p][MB_V] = 0.0;
      excluded++;
    } else {
      for (int k = 0; k < 9; k++) mb[p][MB_AINV + k] = inv[k];
      const double r = atom->radius[p];
      mb[p][MB_V] = volume * (r * r * r) / r3_all;
    }
    mb[p][MB_READY] = 1.0;
  }
  bigint excluded_all = 0;
  MPI_Allreduce(&excluded, &excluded_all, 1, MPI_LMP_BIGINT, MPI_SUM, world);
  if (comm->me == 0)
    utils::logmesg(lmp, "bond_style anisobond: many-body reference of {} atoms, {} excluded "
                        "(degenerate), box volume {:.17g}{}\n",
                   atom->natoms, excluded_all, volume,
                   mb_grains_file_.empty()
                       ? std::string()
                       : fmt::format(", D per grain from {}", mb_grains_file_));
  mb_need_ref_ = false;
}

// The many-body term's forces, energy and virial (three passes, see bond_anisobond.h):
// Σ l_b ⊗ L_b per atom (reverse communication), M_p = V_p P_p A_p⁻¹ per owned atom
// (forward communication), g_b = (M_i + M_j) L_b per bond, f_i += g_b, f_j −= g_b.
void BondAnisobond::manybody_compute() {
  double **x = atom->x, **f = atom->f;
  double **mb = atom->darray[mb_index_];
  const tagint *tag = atom->tag;
  const int nlocal = atom->nlocal, nall = nlocal + atom->nghost;
  const int newton_bond = force->newton_bond;
  int **bondlist = neighbor->bondlist;
  const int nbondlist = neighbor->nbondlist;
  mb_acc_.assign(9 * static_cast<size_t>(nall), 0.0);
  for (int nb = 0; nb < nbondlist; nb++) {
    if (bondlist[nb][2] <= 0) continue;
    const int i = bondlist[nb][0], j = bondlist[nb][1];
    const double *L = mb[i] + MB_L0 + 3 * slot_of(i, tag[j]);
    const double l[3] = {x[j][0] - x[i][0], x[j][1] - x[i][1], x[j][2] - x[i][2]};
    for (const int p : {i, j}) {
      double *acc = &mb_acc_[9 * static_cast<size_t>(p)];
      for (int a = 0; a < 3; a++)
        for (int b = 0; b < 3; b++) acc[3 * a + b] += l[a] * L[b];
    }
  }
  mb_width_ = 9;
  comm->reverse_comm(this, 9);

  for (int p = 0; p < nlocal; p++) {
    double *acc = &mb_acc_[9 * static_cast<size_t>(p)];
    const double vol = mb[p][MB_V];
    if (vol == 0.0) {
      for (int k = 0; k < 9; k++) acc[k] = 0.0;
      continue;
    }
    const double *ai = mb[p] + MB_AINV;
    double F[3][3];  // F = (Σ l⊗L)·A⁻¹
    for (int a = 0; a < 3; a++)
      for (int b = 0; b < 3; b++)
        F[a][b] = acc[3 * a] * ai[b] + acc[3 * a + 1] * ai[3 + b] + acc[3 * a + 2] * ai[6 + b];
    double E[3][3];
    for (int a = 0; a < 3; a++)
      for (int b = 0; b < 3; b++) {
        if (mb_small_) {
          E[a][b] = 0.5 * (F[a][b] + F[b][a]) - (a == b ? 1.0 : 0.0);
        } else {
          double c = 0.0;
          for (int k = 0; k < 3; k++) c += F[k][a] * F[k][b];
          E[a][b] = 0.5 * (c - (a == b ? 1.0 : 0.0));
        }
      }
    const double e[6] = {E[0][0], E[1][1], E[2][2], 2.0 * E[1][2], 2.0 * E[0][2], 2.0 * E[0][1]};
    const double *D = manybody_tensor(p);  // p's grain's D, or the one D
    double sv[6];
    double w = 0.0;
    for (int a = 0; a < 6; a++) {
      sv[a] = 0.0;
      for (int b = 0; b < 6; b++) sv[a] += D[6 * a + b] * e[b];
      w += 0.5 * e[a] * sv[a];
    }
    const double S[3][3] = {{sv[0], sv[5], sv[4]}, {sv[5], sv[1], sv[3]}, {sv[4], sv[3], sv[2]}};
    double P[3][3];
    for (int a = 0; a < 3; a++)
      for (int b = 0; b < 3; b++)
        P[a][b] = mb_small_ ? S[a][b] : F[a][0] * S[0][b] + F[a][1] * S[1][b] + F[a][2] * S[2][b];
    for (int a = 0; a < 3; a++)  // M = V·P·A⁻¹, in place of Σ l⊗L
      for (int b = 0; b < 3; b++)
        acc[3 * a + b] = vol * (P[a][0] * ai[b] + P[a][1] * ai[3 + b] + P[a][2] * ai[6 + b]);
    if (eflag_global) energy += vol * w;
    if (eflag_atom) eatom[p] += vol * w;
  }
  comm->forward_comm(this, 9);

  for (int nb = 0; nb < nbondlist; nb++) {
    if (bondlist[nb][2] <= 0) continue;
    const int i = bondlist[nb][0], j = bondlist[nb][1];
    const double *L = mb[i] + MB_L0 + 3 * slot_of(i, tag[j]);
    const double *mi = &mb_acc_[9 * static_cast<size_t>(i)];
    const double *mj = &mb_acc_[9 * static_cast<size_t>(j)];
    double g[3];
    for (int a = 0; a < 3; a++)
      g[a] = (mi[3 * a] + mj[3 * a]) * L[0] + (mi[3 * a + 1] + mj[3 * a + 1]) * L[1] +
             (mi[3 * a + 2] + mj[3 * a + 2]) * L[2];
    for (int a = 0; a < 3; a++) {
      f[i][a] += g[a];
      f[j][a] -= g[a];
    }
    if (evflag)
      ev_tally_xyz(i, j, nlocal, newton_bond, 0.0, g[0], g[1], g[2], x[i][0] - x[j][0],
                   x[i][1] - x[j][1], x[i][2] - x[j][2]);
  }
}

int BondAnisobond::pack_forward_comm(int n, int *list, double *buf, int, int *) {
  int m = 0;
  for (int k = 0; k < n; k++) {
    const double *acc = &mb_acc_[9 * static_cast<size_t>(list[k])];
    for (int q = 0; q < mb_width_; q++) buf[m++] = acc[q];
  }
  return m;
}

void BondAnisobond::unpack_forward_comm(int n, int first, double *buf) {
  int m = 0;
  for (int k = first; k < first + n; k++) {
    double *acc = &mb_acc_[9 * static_cast<size_t>(k)];
    for (int q = 0; q < mb_width_; q++) acc[q] = buf[m++];
  }
}

int BondAnisobond::pack_reverse_comm(int n, int first, double *buf) {
  int m = 0;
  for (int k = first; k < first + n; k++) {
    const double *acc = &mb_acc_[9 * static_cast<size_t>(k)];
    for (int q = 0; q < mb_width_; q++) buf[m++] = acc[q];
  }
  return m;
}

void BondAnisobond::unpack_reverse_comm(int n, int *list, double *buf) {
  int m = 0;
  for (int k = 0; k < n; k++) {
    double *acc = &mb_acc_[9 * static_cast<size_t>(list[k])];
    for (int q = 0; q < mb_width_; q++) acc[q] += buf[m++];
  }
}

double BondAnisobond::equilibrium_distance(int) { return r0_max_; }

// Restart files keep the style's arguments; the per-bond state is in the fix's per-atom
// data, restored when init_style() recreates the fix after read_restart.
void BondAnisobond::write_restart(FILE *fp) {
  std::vector<std::string> words = args_;
  if (mu_ > 0.0 && std::find(words.begin(), words.end(), "lattice_scaling") == words.end()) {
    words.push_back("lattice_scaling");
    words.push_back(fmt::format("{:.17g}", mu_));
  }
  const int n = static_cast<int>(words.size());
  fwrite(&n, sizeof(int), 1, fp);
  for (const std::string &w : words) {
    const int len = static_cast<int>(w.size());
    fwrite(&len, sizeof(int), 1, fp);
    fwrite(w.data(), 1, len, fp);
  }
}

void BondAnisobond::read_restart(FILE *fp) {
  int n = 0;
  if (comm->me == 0) utils::sfread(FLERR, &n, sizeof(int), 1, fp, nullptr, error);
  MPI_Bcast(&n, 1, MPI_INT, 0, world);
  std::vector<std::string> words(n);
  for (int k = 0; k < n; k++) {
    int len = 0;
    if (comm->me == 0) utils::sfread(FLERR, &len, sizeof(int), 1, fp, nullptr, error);
    MPI_Bcast(&len, 1, MPI_INT, 0, world);
    std::vector<char> buf(len + 1, '\0');
    if (comm->me == 0 && len > 0) utils::sfread(FLERR, buf.data(), 1, len, fp, nullptr, error);
    MPI_Bcast(buf.data(), len, MPI_CHAR, 0, world);
    words[k].assign(buf.data(), len);
  }
  std::vector<char *> argv;
  for (std::string &w : words) argv.push_back(&w[0]);
  settings(static_cast<int>(argv.size()), argv.data());
  allocate();
  for (int i = 1; i <= atom->nbondtypes; i++) setflag[i] = 1;
}

double BondAnisobond::single(int, double, int, int, double &) {
  error->all(FLERR, "bond_style anisobond has no single() (its force is not a function of the "
                    "distance alone): compute bond/local and bond_write are not supported");
}
