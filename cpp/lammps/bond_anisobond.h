// bond_style anisobond: per-bond anisotropic elastic bonds for LAMMPS, loaded as a plugin
// (`plugin load anisobond_lammps.so`, see plugin.cpp and docs/lammps.md).
//
// Bond law: anisobond's own incremental bond (the law of cpp/liggghts/pair_anisobond.h:
// YADE's cohesive law, Law2_ScGeom6D_CohFrictPhys_CohesionMoment, incremental form), with the
// contact point at the bond's midpoint: lever arms a = r0/2 on both sides (anisobond's
// `LeverArm::HalfLength`, where bpm/rotational also puts its shear displacement and
// torques). For a bond stored on atom i (newton_bond on) with partner j, branch
// l = x_j − x_i, d = |l|, n = l/d:
//   normal   F_n = k_n (d − r0) n                               (force on i)
//   shear    F_s ← F_s − F_s×(n_prev×n) − F_s×τ,  τ = ½dt((ω_i+ω_j)·n) n   (rotate with the bond)
//            F_s += k_s [Δu − (Δu·n)n],  Δu = (l − l_prev) + dt(ω_j×(−a n) − ω_i×(a n))
//   moment   M rotated as F_s;  θ = dt(ω_j − ω_i);  M += k_r (θ − (θ·n)n) + k_tw (θ·n)n
//   damping  F_d = γ_n (Δv·n)n + γ_s (Δv − (Δv·n)n),  Δv = v_j − v_i + ω_j×(−a n) − ω_i×(a n)
//            M_d = γ_r (Δω − (Δω·n)n) + γ_t (Δω·n)n,   Δω = ω_j − ω_i
//   on i:    force F = F_n + F_s + F_d, torque (a n)×F + M + M_d
//   on j:    force −F,                  torque (a n)×F − M − M_d
// Linearised about the rest state this is anisobond's bond with springs k_n, k_s, k_r, k_tw
// and lever arm `half-length`: its quasi-static tensor is the relaxed tensor
// (`anisobond tensor --method relaxed --lever-arm half-length`), as bpm/rotational's with
// k_r = k_n, k_s = k_s, k_t = k_tw, k_b = k_r (route (a) of docs/lammps.md).
// dt is 0 in the setup force call of a run (update->setupflag), so a run's setup does not
// advance the history; a box deformation between runs (change_box … remap) enters through
// l − l_prev. The virial is tallied per bond (ev_tally_xyz, del = x_i − x_j = −l).
//
// Springs: `model MODEL.toml` computes each bond's springs through the anisobond bridge
// (src/ffi) from its initial direction, the two radii and the initial length, at the first
// force call of the bond; the cross-anisotropic scheme's lattice scaling
// μ = π̂·Σ(½ r0·min(R_i, R_j)²)/(3V) (Šmilauer Eq. 20) is summed over all bonds of all
// processes (MPI_Allreduce) with V the box volume, once, at the first run's setup (or given
// as `lattice_scaling MU`, which restart files keep). `table BONDS.csv` reads them from a
// SPEC bond table (atom ids = table indices + 1), checking each bond's length.
// Damping (optional, `damping ZETA`): γ = 2ζ√(k m*) of each bond's own spring and reduced
// mass m* or reduced inertia I* (rolling against k_r + k_s r0²/4, twisting against k_tw, or
// the rolling stiffness when k_tw = 0).
//
// Breakage (`break yes strengths BONDS.csv`, issue 32): each bond's critical loads f_rc, f_sc,
// τ_bc, τ_tc (read by atom ids from the strength table the export writes, stored in the bond's
// state beside its springs at its first force call) and bpm/rotational's criterion
//   B = max(0, F_r/f_rc + |F_s|/f_sc + |M_b|/τ_bc + |M_t|/τ_tc),  F_r = k_n (d − r0) (tension +)
// on the springs' loads (|F_s| the shear spring force, M_b and M_t the bending and twisting
// parts of the moment); B ≥ 1 breaks the bond before its forces are applied: it is removed
// from its atom's bond list with its state slot (as BondBPM::process_broken). Broken pairs
// leave the special lists (1-2 entries of the owned atoms, on every process: the broken
// pairs are gathered on all of them) and lose their special bits in the pair neighbour
// lists at once, as BPM's fix update/special/bonds does for bpm/rotational: a pair style
// (e.g. granular, with `special_bonds lj 0 1 1 coul 1 1 1`) acts on them from the next step.
// `record FILE` (with `break yes`): every broken bond is written to FILE as `id_lo id_hi step`
// (atom ids ascending, the timestep it broke), gathered and written by process 0, sorted by
// step and ids, so the file is the same on any number of processes (validate lammps --strength reads
// it); opened (truncated) at the style's first init, so a run restarted from a restart file
// starts a new record.
//
// Many-body term (`manybody D11 D12 … D66`, issue 33; docs/manybody.md, "LAMMPS"): anisobond's
// `ManyBody` (src/manybody/term.rs). Each atom p fits its local deformation gradient from its
// bonds, F_p = (Σ_b l_b ⊗ L_b)·A_p⁻¹ with A_p = Σ_b L_b ⊗ L_b (L_b the bond's branch vector at
// its first force call, l_b the present one, both from the bond's first atom to its second:
// the sign cancels at the other end), and carries U_p = ½ V_p E_p : D : E_p (E_p Green–Lagrange
// or small); D is the 6×6 Voigt matrix given by its 21 upper-triangle entries (Pa; order 11 22
// 33 23 13 12, engineering shear). V_p is the box volume at the reference shared in proportion
// to r³ (a fully periodic box, as the library's default). Bond b's gradient is
// g_b = (M_i + M_j) L_b with M_p = V_p P_p A_p⁻¹ (P = F·(D:E), or D:ε for the small strain),
// and f_i += g_b, f_j −= g_b. In LAMMPS each bond is stored once (newton_bond on), so a force
// call makes three passes: Σ l_b ⊗ L_b into both ends (owned or ghost) and a reverse
// communication to the owners; F_p and M_p on the owned atoms and a forward communication of
// M_p to the ghosts; then g_b per bond. The reference (A_p⁻¹, V_p, each bond's L_b) is set
// collectively at the first force call (the same reverse communication of Σ L ⊗ L and the
// bond count) and kept per atom (`fix property/atom d2_anisobond_manybody`, migrating with the
// atom, in restart files). An atom with fewer than three bonds, or with A_p's
// λ_min/λ_max below `manybody/conditioning` (default 1e-6), is degenerate: refused
// (`manybody/degenerate refuse`, the default) or left out of the term (`exclude`: V_p = 0,
// it still moves its neighbours' fits), as in the library.
//
// A polycrystal (issue 34; docs/polycrystal.md, "Engines"): `manybody/grains FILE` instead of
// the 21 numbers gives each grain its own D, FILE one line per grain `g D11 D12 … D66` (grain
// id g ≥ 0, then D's 21 upper-triangle entries in the lab frame, Pa; `#` starts a comment;
// docs/formats.md). Atom p's grain is its molecule ID − 1 (`anisobond export lammps` writes
// molecule = grain + 1 into data.lmp; atom_style bpm/sphere keeps molecule IDs), read on the
// owned atoms only (D_p enters M_p, formed by the owner); an owned atom whose grain the file
// does not give is refused. Restart files keep the keyword and FILE is read again.
//
// Per-bond state lives in a per-atom array (`fix property/atom d2_anisobond_state N ghost no`,
// created by the style): slot m of atom i belongs to its bond with atom->bond_atom[i][m],
// so the state migrates with the atom, is written to restart files, and is restored when
// the style is used after read_restart.
#ifndef ANISOBOND_BOND_ANISOBOND_H
#define ANISOBOND_BOND_ANISOBOND_H

#include "bond.h"

#include "anisobond/src/ffi/mod.rs.h"

#include <cstdint>
#include <memory>
#include <string>
#include <unordered_map>
#include <vector>

namespace LAMMPS_NS {

class BondAnisobond : public Bond {
 public:
  explicit BondAnisobond(class LAMMPS *lmp);
  ~BondAnisobond() override;
  void compute(int eflag, int vflag) override;
  void settings(int narg, char **arg) override;
  void coeff(int narg, char **arg) override;
  void init_style() override;
  double equilibrium_distance(int) override;
  void write_restart(FILE *fp) override;
  void read_restart(FILE *fp) override;
  double single(int, double, int, int, double &) override;
  int pack_forward_comm(int, int *, double *, int, int *) override;
  void unpack_forward_comm(int, int, double *) override;
  int pack_reverse_comm(int, int, double *) override;
  void unpack_reverse_comm(int, int *, double *) override;

  // Slots of one bond in the per-atom array (NSLOT doubles per bond).
  enum Slot {
    S_R0 = 0,         // rest length r0 (m); 0 = bond not initialised yet
    S_KN, S_KS, S_KR, S_KTW,
    S_GN, S_GS, S_GR, S_GT,  // damping coefficients
    S_FS,             // shear force (3)
    S_M = S_FS + 3,   // bending + twisting moment (3)
    S_LP = S_M + 3,   // branch vector at the previous force call (3)
    S_FRC = S_LP + 3, // critical loads f_rc, f_sc (N), τ_bc, τ_tc (N·m); 0 = not read yet
    S_FSC, S_TBC, S_TTC,
    NSLOT
  };

  // Columns of the many-body per-atom array: A_p⁻¹ (row-major), V_p, a flag (1 = the
  // reference is set), then the reference branch vector L_b (3) of each bond slot.
  enum ManyBodySlot { MB_AINV = 0, MB_V = 9, MB_READY = 10, MB_L0 = 11 };

 private:
  struct Springs {
    double kn, ks, kr, ktw, length;
  };
  struct Limits {
    double frc, fsc, tbc, ttc;
  };
  void allocate();
  void initialise_bonds();
  void springs_of(int i, int j, const double *l, double d, double *s);
  void limits_of(int i, int j, double *s);
  void read_strengths(const std::string &path);
  void remove_bond(int i, int m);
  void share_breaks(bigint nbroken);
  int slot_of(int i, tagint partner) const;
  void manybody_reference();
  void read_grain_tensors(const std::string &path);
  const double *manybody_tensor(int p) const;
  void manybody_compute();

  std::vector<std::string> args_;  // bond_style arguments (kept for restart files)
  std::string source_;             // "model" or "table"
  std::unique_ptr<rust::Box<anisobond::ModelHandle>> model_;
  std::unordered_map<std::uint64_t, Springs> table_;  // key: tag_lo << 32 | tag_hi
  std::unordered_map<std::uint64_t, Limits> limits_;  // `strengths` table, same key
  bool break_;                     // `break yes`: bonds break at B >= 1
  std::string record_;             // `record FILE`: broken bonds written there ("" = none)
  FILE *record_fp_;                // process 0's open record file
  std::vector<tagint> broken_now_;  // (id_lo, id_hi) of the bonds this process broke this call
  double zeta_;                    // damping ratio (0: undamped)
  double length_tol_;              // table lengths vs. the box (relative)
  double mu_;                      // cross-anisotropic lattice scaling (0: not yet known)
  double r0_max_;                  // longest rest length seen (all processes)
  int index_;                      // atom->darray index of the state array
  bool need_init_;                 // some bond may be uninitialised (set by init_style)
  // Many-body term (off unless `manybody` is given).
  bool mb_;                        // the term is on
  double mb_d_[6][6];              // D (Pa, Voigt) of `manybody D11 … D66`
  std::string mb_grains_file_;     // `manybody/grains FILE` ("" = one D)
  std::vector<double> mb_grain_d_;  // 36 per grain id (row-major Voigt, Pa), by grain id
  std::vector<char> mb_grain_set_;  // 1 where the file gives that grain's D
  bool mb_small_;                  // small strain instead of Green–Lagrange
  double mb_cond_;                 // smallest accepted λ_min/λ_max of A_p
  bool mb_exclude_;                // degenerate atoms left out (else refused)
  int mb_index_;                   // atom->darray index of the many-body array
  bool mb_need_ref_;               // some atom's reference is not set yet (init_style)
  std::vector<double> mb_acc_;     // 9 per atom (owned + ghost): Σ l⊗L, then M_p
  int mb_width_;                   // doubles per atom in the present communication
};

}  // namespace LAMMPS_NS

#endif
