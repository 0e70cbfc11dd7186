// pair_style anisobond: per-bond anisotropic elastic bonds for LIGGGHTS 3.8, registered at
// run time by the driver (driver.cpp) through Force::pair_map, so the stock libliggghts
// needs no rebuild.
//
// Bond law (per bond, particles i < j by tag, branch l = x_j − x_i by minimum image,
// d = |l|, n = l/d, mid-gap contact arms r_i = R_i + g/2, r_j = R_j + g/2, g = d − R_i − R_j),
// following YADE's cohesive law (Law2_ScGeom6D_CohFrictPhys_CohesionMoment, incremental
// form) with the contact point at mid-gap:
//   normal   F_n = k_n (d − d0) n                        (force on i; d0 = distance at creation)
//   shear    F_s ← F_s − F_s×(n_prev×n) − F_s×τ,  τ = ½dt((ω_i+ω_j)·n) n      (rotate)
//            F_s += k_s [Δu − (Δu·n)n],  Δu = (l − l_prev) + dt(ω_j×(−r_j n) − ω_i×(r_i n))
//   moments  M_b, M_t rotated as F_s;  θ̇ = ω_j − ω_i;  M_b += k_r dt(θ̇ − (θ̇·n)n),
//            M_t += k_tw dt(θ̇·n)n
//   on i:    force F = F_n + F_s, torque (r_i n)×F + M_b + M_t
//   on j:    force −F,            torque (r_j n)×F − M_b − M_t
// dt is 0 during the setup force call of every run (update->setupflag), so a run's setup
// does not advance the history. The virial is tallied per bond (−l ⊗ F, LAMMPS order
// xx yy zz xy xz yz = l_x F_y …), so `compute pressure … virial` gives the stress σ = −p.
//
// Bonds come from a SPEC bond table (`table`), from the library bonding a packing file
// (`model MODEL PACKING`), or in place (`model MODEL` alone): the atoms present at the first
// init_style() (the first command that initialises LIGGGHTS: `run`, `minimize`,
// `write_data`) are gathered from every rank, rank 0 has the
// library bond them by the model's rule (the same Assembly as the CLI on the same packing,
// μ of a cross-anisotropic model from these bonds) and broadcasts the table, keyed by atom
// tag. Atoms inserted later are not bonded. In a run continued from a restart file that holds
// the bond state the in-place form is refused (it would bond the atoms again where they are
// then); write_bonds is written only once the bonds are known to be used.
//
// Strength and breakage (issue 32; docs/strength.md, "LIGGGHTS"): when the model has a
// `[strength]` table (forms `model MODEL PACKING` and `model MODEL`) or the bond table has
// the columns normal_adhesion, shear_adhesion, tan_friction (`table`, as `anisobond export
// yade` writes them), every bond carries YADE's CohFrict limits a_n, a_s, tan φ — the same
// law as the bond law above and as the integrator's law a — and is judged every step by the
// library's own criterion through the bridge (anisobond::yade_cohfrict_check =
// strength::criteria::yade_cohfrict, fragile, moments elastic as YADE 2023.02a): tension
// (−F_n > a_n, compression positive) removes the bond; shear (|F_s| > a_s + F_n tan φ) turns
// it into a frictional contact (compression only, |F_s| ≤ F_n tan φ, no moments) that is
// removed once it is in tension, as YADE does. Without `contacts` no new contacts are
// detected.
//
// Contacts (`contacts KN KS MU`; issue 32, docs/strength.md "LIGGGHTS"): the integrator's
// frictional contact (src/dem/contacts.rs, YADE's Law2_ScGeom_FrictPhys_CundallStrack) for
// every broken bond and for spheres that were never bonded and come into touch:
//   overlap  u_n = R_i + R_j − d ≥ 0, F_n = k_n u_n (compression only; apart: no force, the
//            shear force forgotten, as YADE erases the interaction)
//   shear    F_s ← F_s − F_s×(n_old×n) − F_s×τ, τ = ½dt((ω_i+ω_j)·n_old) n_old (n_old the
//            normal of the last step in touch; none for a new contact), then
//            F_s += k_s dt [v_r − (v_r·n)n], v_r the relative velocity at the contact point
//            (mid-overlap, arms R − u_n/2) from the atoms' velocities
//   Coulomb  |F_s| ≤ μ F_n; no moments.
// A broken bond's pair keeps the bond's k_n, k_s (as YADE's CohFrictPhys and the integrator's
// Contacts::set_pair_stiffness); new pairs get KN, KS; every contact μ = MU (the integrator's
// ContactLaw::friction). A bond broken in shear hands its trial shear force on, capped at
// μ F_n in the break step and neither rotated nor incremented there (the integrator's
// Contacts::carry_shear); one broken in tension starts a fresh contact (usually apart). A
// broken bond's slot stays (its springs), a new pair's slot is dropped when the spheres
// part. New pairs come from a full neighbour list (cutoff max(1.05 × longest bond, 2 R_max)
// + skin): each pair once, on the owner of its lower tag. Each atom has room for
// CONTACT_SLOTS contacts beyond its bonds (refused by name beyond that). Not with the
// many-body term.
//
// State lives in a `fix property/atom` created in init_style(): per owned atom the number of
// bonds, the number of its bonds that broke, then the bonds to partners of higher tag
// (newton on: each bond once), so LIGGGHTS' exchange carries the history when atoms migrate
// and the restart file keeps it. `compute reduce sum f_anisobond_bonds[1]` counts the bonds
// left, `…[2]` those broken.
//
// `breaks FILE` (issue 32): which bond broke when. Every step that broke a bond, each rank's
// breaks (lower tag, higher tag, mode) are gathered on rank 0, sorted by (id_i, id_j), and
// written as lines `step id_i id_j tension|shear` (a bond's cohesion broken; a frictional
// contact lost later in tension is no new break), so the file is the same on any number
// of processes. The step is update->ntimestep of the force call that judged the bond.
//
// Many-body term (issue 33; docs/manybody.md, "LIGGGHTS"): `manybody FILE` (the table form,
// FILE as `anisobond export liggghts` writes manybody.txt for a model with [manybody]) or a
// model with [manybody] (both model forms, through the bridge) adds the library's ManyBody
// forces of U = Σ_p ½ V_p E_p:D_p:E_p, D_p the one D or, for a polycrystal (issue 34), the
// D of p's grain (the table's `tensors G` and each particle's tensor index). Each bond carries its fit coefficients a = A_p⁻¹ L_b at
// both ends (the library's own, replicated with the bond table on every rank), each atom
// its volume share V_p (0 = excluded, as the library excludes degenerate particles). Per
// force call: (1) every bond adds l_b ⊗ a to F of both ends (ghost ends included), a reverse
// communication sums the ghosts' share into the owners: F_p = Σ_b l_b ⊗ a_b; (2) each owned
// atom forms E_p (Green–Lagrange or small), S = D:E, P = F·S (or S) and M_p = V_p P_p, and
// a forward communication sends M to the ghosts; (3) every bond gets g_b = M_i a_i + M_j a_j,
// f_i += g_b, f_j −= g_b, tallied in the virial as the springs are (−l ⊗ g), energy V_p W_p
// on its atom. With breakable bonds the term is refused (a broken bond would change the fits).
#ifndef ANISOBOND_PAIR_ANISOBOND_H
#define ANISOBOND_PAIR_ANISOBOND_H

#include "pair.h"

#include "anisobond/src/ffi/mod.rs.h"

#include <cstdint>
#include <string>
#include <vector>

namespace LAMMPS_NS {

class PairAnisobond : public Pair {
 public:
  explicit PairAnisobond(class LAMMPS *lmp);
  ~PairAnisobond();
  void compute(int eflag, int vflag);
  void settings(int narg, char **arg);
  void coeff(int narg, char **arg);
  void init_style();
  double init_one(int i, int j);
  // The many-body term's per-atom communication: forward M_p (9), reverse F_p sums (9).
  int pack_comm(int n, int *list, double *buf, int pbc_flag, int *pbc);
  void unpack_comm(int n, int first, double *buf);
  int pack_reverse_comm(int n, int first, double *buf);
  void unpack_reverse_comm(int n, int *list, double *buf);

  // For Force::pair_map.
  static Pair *creator(class LAMMPS *lmp);

  // Values per atom before the bond slots: number of bonds, number broken.
  enum { H_COUNT = 0, H_BROKEN = 1, HEAD = 2 };

  // Slots of one bond in the per-atom array.
  enum Slot {
    S_TAG = 0,     // partner tag (as double); 0 = empty
    S_KN, S_KS, S_KR, S_KTW,
    S_R0,          // rest length d0; < 0 means −(table length), set at first force call
    S_FS,          // shear force (3)
    S_MB = S_FS + 3,  // bending moment (3)
    S_MT = S_MB + 3,  // twisting moment (3)
    S_LP = S_MT + 3,  // previous branch vector (3)
    S_AN = S_LP + 3,  // normalAdhesion a_n (N); < 0: unbreakable
    S_AS,             // shearAdhesion a_s (N)
    S_TF,             // tan φ
    S_COH,            // 1 cohesive, 0 cohesion broken in shear (frictional contact); with
                      // `contacts`: 0 a contact not in touch, −1 in touch (S_LP its normal)
    S_NEW,            // 1: a contact of a never-bonded pair (dropped when apart)
    NSLOT
  };
  // Contacts an atom can hold beyond its bonds (`contacts`): equal spheres touch at most 12.
  enum { CONTACT_SLOTS = 12 };

 private:
  struct Bond {
    int tag_i, tag_j;
    double kn, ks, kr, ktw, length;
    double an, as, tf;  // YADE CohFrict limits; an < 0: unbreakable
    double ai[3], aj[3];  // many-body fit coefficients at tag_i and tag_j (0 without the term)
  };
  // The many-body term: on when manybody_; the tensors D row-major (Voigt, Pa; 36 each: one,
  // or one per grain of a polycrystal), the measure, V_p and the tensor of each atom by tag.
  bool manybody_;
  std::vector<double> mb_d_;
  bool mb_gl_;
  std::vector<double> mb_volume_;
  std::vector<int> mb_tensor_;
  std::string mb_of_;  // where the term came from (for messages)
  // Per-atom work arrays (owned + ghost): the sums Σ l⊗a (F_p) and M_p = V_p P_p, row-major.
  int mb_nmax_;
  double **mb_f_, **mb_m_;
  // Take the term of `data` (coefficients aligned with `bonds`, checked by atom ids).
  void add_manybody(std::vector<Bond> &bonds, const anisobond::ManyBodyData &data,
                    const std::string &what);
  // Every rank takes rank 0's D, measure and volumes (the in-place form).
  void broadcast_manybody();
  void compute_manybody(int eflag);
  // Give each bond its limits (lim aligned with bonds, or empty: unbreakable); a length
  // mismatch is refused naming `what`.
  void add_limits(std::vector<Bond> &bonds, const rust::Vec<anisobond::YadeLimits> &lim,
                  const std::string &what);
  bool breakable_;                  // some bond has limits
  // `contacts KN KS MU`: on, springs of new pairs (N/m), friction of every contact; the
  // largest radius (neighbour cutoff) and the slots per atom.
  bool contacts_;
  double c_kn_, c_ks_, c_mu_;
  double r_max_;
  int slots_;
  void add_new_contacts();
  // `breaks FILE`: rank 0's open file (NULL elsewhere and without the keyword), the name,
  // and this step's local breaks as (tag_i, tag_j, mode 0 tension / 1 shear) triples.
  std::string breaks_file_;
  FILE *breaks_fp_;
  std::vector<int> step_breaks_;
  void write_breaks();
  void allocate();
  void fill_bonds();
  void set_bonds(std::vector<Bond> bonds);
  void bond_in_place();
  void write_in_place_table();

  std::vector<Bond> bonds_;        // all bonds (read on every rank), sorted by tag_i
  std::vector<int> first_bond_;    // first_bond_[tag] .. first_bond_[tag+1]
  int max_bonds_;                  // largest number of bonds stored on one atom
  double max_length_;              // longest bond (m)
  double damp_t_, damp_r_;         // viscous damping rates (1/s), on owned atoms only
  double length_tol_;              // allowed mismatch of table length vs positions
  bool in_place_;                   // `model MODEL` without a packing: bond at first init
  bool bonded_;                     // the bond table is known (set_bonds done)
  std::string model_path_;          // the model of the in-place form
  std::string write_bonds_;         // `write_bonds FILE` of the in-place form, or empty
  // The atoms gathered on rank 0 for in-place bonding, kept until write_bonds is written.
  std::vector<double> gathered_x_, gathered_r_;
  std::vector<std::uint64_t> gathered_ids_;
  anisobond::AtomsBox gathered_box_;
  std::string fix_id_;
  class FixPropertyAtom *fix_;
};

}  // namespace LAMMPS_NS

#endif
