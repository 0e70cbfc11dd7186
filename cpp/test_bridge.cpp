// C++ test of the anisobond cxx bridge: values checked against closed forms and the
// independently checked numbers of docs/references.md, and errors arriving as exceptions with
// the library's message. Prints "N passed, M failed" and exits non-zero on a failure.
//
// Build and run: make -C cpp check

#include "anisobond/src/ffi/mod.rs.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <string>
#include <vector>

namespace {

int passed = 0;
int failed = 0;

void check(bool ok, const std::string &what) {
  if (ok) {
    ++passed;
  } else {
    ++failed;
    std::printf("FAIL: %s\n", what.c_str());
  }
}

void close_abs(double got, double want, double tol, const std::string &what) {
  char buf[256];
  std::snprintf(buf, sizeof buf, " (got %.10g, want %.10g, tol %.1e)", got, want, tol);
  check(std::fabs(got - want) <= tol, what + buf);
}

void close_rel(double got, double want, double tol, const std::string &what) {
  close_abs(got, want, tol * std::fabs(want), what);
}

// Run f and check it throws an exception whose message contains `needle`.
template <class F> void throws_with(F f, const std::string &needle, const std::string &what) {
  try {
    f();
    check(false, what + ": no exception");
  } catch (const std::exception &e) {
    std::string msg = e.what();
    check(msg.find(needle) != std::string::npos,
          what + ": message `" + msg + "` lacks `" + needle + "`");
  }
}

std::string tmp_path(const std::string &name) {
  const char *dir = std::getenv("TMPDIR");
  return std::string(dir ? dir : "/tmp") + "/anisobond_test_bridge_" + name;
}

const char *cubic_spring(double normal, double shear, bool extended) {
  static std::string s;
  s = "[scheme]\nkind = \"cubic\"\nmodel = \"zener-above-1\"\na_n = 4.31\na_s = 10.0\n";
  s += "normal = " + std::to_string(normal) + "\nshear = " + std::to_string(shear) + "\n";
  s += std::string("extended = ") + (extended ? "true" : "false") + "\n";
  s += "[geometry]\nconvention = \"spring\"\n";
  return s.c_str();
}

}  // namespace

int main() {
  using namespace anisobond;

  // 1. Cubic factors (f_n, f_s) of zener-above-1, a_n = 4.31, a_s = 10 (docs/references.md,
  //    "Model factors", 4 decimals). With the spring convention k = magnitude.
  {
    auto m = parse_model(cubic_spring(1.0, 1.0, false), "toml");
    struct Row { double n[3]; double fn, fs; const char *dir; };
    const Row rows[] = {{{1, 0, 0}, 0.7427, 4.6416, "[100]"},
                        {{1, 1, 0}, 1.0113, 0.6532, "[110]"},
                        {{1, 1, 1}, 2.6484, 0.5671, "[111]"},
                        {{0, -1, 1}, 1.0113, 0.6532, "[0-11]"}};
    for (const Row &r : rows) {
      Magnitudes g = m->magnitudes(r.n[0], r.n[1], r.n[2]);
      close_abs(g.normal, r.fn, 6e-5, std::string("f_n along ") + r.dir);
      close_abs(g.shear, r.fs, 6e-5, std::string("f_s along ") + r.dir);
      BondSprings k = m->bond_springs(r.n[0], r.n[1], r.n[2], 1e-3, 1e-3, 2e-3);
      close_rel(k.kn, g.normal, 1e-15, std::string("spring convention k_n = f_n ") + r.dir);
      close_rel(k.ks, g.shear, 1e-15, std::string("spring convention k_s = f_s ") + r.dir);
      check(k.kr == 0.0 && k.ktw == 0.0, "no moments by default");
    }
    check(std::string(m->scheme_name()).find("cubic") != std::string::npos, "scheme name");
    check(!m->needs_packing(), "cubic needs no packing");
  }

  // 2. Cubic mean field T (docs/references.md "Cubic mean field", zener-above-1, normal 1e13,
  //    shear 3.55e12): prefactor 1 with the spring convention gives T.
  {
    auto m = parse_model(cubic_spring(1.0e13, 3.55e12, false), "toml");
    Tensor6 t = m->mean_field_tensor(1.0);
    close_rel(t.c[0], 2.791698e12, 1e-6, "T11");
    close_rel(t.c[1], 7.711806e11, 1e-6, "T12");
    close_rel(t.c[3 * 6 + 3], 1.387484e12, 1e-6, "T44");
    close_rel(t.c[2 * 6 + 2], t.c[0], 1e-10, "cubic symmetry T33 = T11");
    close_rel(t.c[0 * 6 + 2], t.c[1], 1e-10, "cubic symmetry T13 = T12");
    close_abs(t.c[0 * 6 + 3], 0.0, 1e-6 * t.c[0], "T14 = 0");
    Tensor6 t2 = m->mean_field_tensor(2.5);
    close_rel(t2.c[0], 2.5 * t.c[0], 1e-14, "mean field is linear in the prefactor");
  }

  // 3. Geometry closed forms: isotropic, area convention, parallel-bond moments:
  //    k = magnitude·π·min(R)², k_r = k_n R_b²/4, k_tw = k_s R_b²/2.
  {
    auto m = parse_model(
        "[scheme]\nkind = \"isotropic\"\nnormal = 2.0e12\nshear = 1.0e12\n"
        "[geometry]\nconvention = \"area\"\nmoments = \"parallel-bond\"\n",
        "toml");
    const double pi = 3.14159265358979323846, rb = 1e-3;
    BondSprings k = m->bond_springs(0.3, -0.2, 0.9, 1e-3, 2e-3, 3.1e-3);
    close_rel(k.kn, 2.0e12 * pi * rb * rb, 1e-14, "area: k_n = normal·π R_min²");
    close_rel(k.ks, 1.0e12 * pi * rb * rb, 1e-14, "area: k_s = shear·π R_min²");
    close_rel(k.kr, k.kn * rb * rb / 4, 1e-14, "parallel bond k_r = k_n R_b²/4");
    close_rel(k.ktw, k.ks * rb * rb / 2, 1e-14, "parallel bond k_tw = k_s R_b²/2");
  }

  // 4. Errors become exceptions carrying the library's message.
  throws_with([] { parse_model(cubic_spring(1.0, 1.0, true), "toml"); }, "negative",
              "extended zener-above-1 at a_s = 10 has negative shear (docs/references.md)");
  throws_with([] { load_model("/nonexistent/dir/model.toml"); }, "/nonexistent/dir/model.toml",
              "missing model file names the path");
  throws_with([] { parse_model("[scheme]\nkind = \"isotropic\"\n", "yaml"); }, "yaml",
              "unknown model format");
  throws_with([] { parse_model("[scheme]\nkind = \"hexagonal\"\n", "toml"); }, "hexagonal",
              "unknown scheme kind");
  {
    auto m = parse_model(cubic_spring(1.0, 1.0, false), "toml");
    throws_with([&] { m->bond_springs(0, 0, 0, 1e-3, 1e-3, 2e-3); }, "non-zero",
                "zero normal refused");
    throws_with([&] { m->bond_springs(1, 0, 0, -1e-3, 1e-3, 2e-3); }, "ri",
                "negative radius refused");
  }

  // 5. Bond table round trip, and a malformed table reported with its line.
  {
    std::vector<BondRow> rows;
    BondRow a{0, 1, 1.0, 0.0, 0.0, 2.0e-3, 1.0e-3, 1.5e6, 0.5e6, 0.25, 0.125, 0, 0, 0};
    BondRow b{1, 7, 0.0, 0.6, 0.8, 2.1e-3, 0.9e-3, 2.5e6, 0.0, 0.0, 0.0, 0, -1, 1};
    rows.push_back(a);
    rows.push_back(b);
    const std::string path = tmp_path("bonds.csv");
    write_bond_table(path, rust::Slice<const BondRow>(rows.data(), rows.size()));
    rust::Vec<BondRow> back = load_bond_table(path);
    check(back.size() == 2, "two rows read back");
    if (back.size() == 2) {
      check(back[0] == a, "row 0 reads back bit-identical");
      check(back[1] == b, "row 1 reads back bit-identical");
    }
    const std::string bad = tmp_path("bad.csv");
    {
      std::ofstream f(bad);
      f << "i,j,nx,ny,nz,length,radius,kn,ks,kr,ktw,ix,iy,iz\n"
        << "0,1,1,0,0,2e-3,1e-3,1,1,0,0,0,0,0\n"
        << "3,2,1,0,0,2e-3,1e-3,1,1,0,0,0,0,0\n";
    }
    throws_with([&] { load_bond_table(bad); }, ":3:", "bad row reported with its line number");
  }

  // 6. Simple cubic lattice (docs/references.md "Relaxed"): 3×3×3 spheres, R = 1 mm, spacing 2R,
  //    springs k_n, k_t: C11 = k_n/(2R), C12 = 0, C44 = k_t/(4R), Voigt = relaxed.
  {
    const double R = 1e-3, kn = 1.0e6, kt = 4.0e5;
    const std::string pack = tmp_path("sc.txt");
    {
      std::ofstream f(pack);
      f.precision(17);
      f << "# periodic " << 6 * R << " " << 6 * R << " " << 6 * R << "\n";
      for (int a = 0; a < 3; ++a)
        for (int b = 0; b < 3; ++b)
          for (int c = 0; c < 3; ++c)
            f << (1 + 2 * a) * R << " " << (1 + 2 * b) * R << " " << (1 + 2 * c) * R << " " << R
              << "\n";
    }
    auto m = parse_model(
        "[bonding]\nrule = \"gap\"\nvalue = 0.01\n"
        "[scheme]\nkind = \"isotropic\"\nnormal = 1.0e6\nshear = 4.0e5\n"
        "[geometry]\nconvention = \"spring\"\n",
        "toml");
    rust::Vec<BondRow> bonds = build_bond_table(pack, *m);
    check(bonds.size() == 81, "simple cubic 3x3x3: 81 bonds");
    for (const char *method : {"voigt", "relaxed"}) {
      Tensor6 c = compute_tensor(pack, *m, method);
      const std::string w = std::string(method) + " SC ";
      close_rel(c.c[0], kn / (2 * R), 1e-9, w + "C11 = k_n/(2R)");
      close_rel(c.c[2 * 6 + 2], kn / (2 * R), 1e-9, w + "C33 = k_n/(2R)");
      close_abs(c.c[1], 0.0, 1e-9 * kn / R, w + "C12 = 0");
      close_rel(c.c[3 * 6 + 3], kt / (4 * R), 1e-9, w + "C44 = k_t/(4R)");
      close_rel(c.c[5 * 6 + 5], kt / (4 * R), 1e-9, w + "C66 = k_t/(4R)");
    }
    throws_with([&] { compute_tensor(pack, *m, "relax"); }, "method `relax`: expected",
                "unknown method");
    throws_with([&] { compute_tensor(pack, *m, "relax"); }, "prestressed, laf or dynamic",
                "the refusal lists every method of the registry");
  }

  // 7. bond_atoms: the same SC lattice given as arrays the way the LIGGGHTS pair style gathers
  //    them (any order, ids with gaps, a box not at the origin) gives build_bond_table's rows
  //    of the packing file, named by the atoms sorted by id; free and refused boxes.
  {
    const double R = 1e-3, lo = -2.5e-3;
    const std::string pack = tmp_path("sc.txt");  // written by section 6
    auto m = parse_model(
        "[bonding]\nrule = \"gap\"\nvalue = 0.01\n"
        "[scheme]\nkind = \"isotropic\"\nnormal = 1.0e6\nshear = 4.0e5\n"
        "[geometry]\nconvention = \"spring\"\n",
        "toml");
    rust::Vec<BondRow> want = build_bond_table(pack, *m);
    std::vector<double> x, r;
    std::vector<uint64_t> ids;
    for (int k = 26; k >= 0; --k) {  // file order a, b, c = k / 9, k / 3 % 3, k % 3, reversed
      const int a = k / 9, b = k / 3 % 3, c = k % 3;
      x.push_back((1 + 2 * a) * R + lo);
      x.push_back((1 + 2 * b) * R + lo);
      x.push_back((1 + 2 * c) * R + lo);
      r.push_back(R);
      ids.push_back(10 * (k + 1));
    }
    AtomsBox box;
    for (int k = 0; k < 3; ++k) {
      box.lo[k] = lo;
      box.hi[k] = lo + 6 * R;
      box.tilt[k] = 0.0;
      box.periodic[k] = true;
    }
    auto xs = rust::Slice<const double>(x.data(), x.size());
    auto rs = rust::Slice<const double>(r.data(), r.size());
    auto is = rust::Slice<const uint64_t>(ids.data(), ids.size());
    AtomBonds got = bond_atoms(*m, xs, rs, is, box, "");
    check(got.rows.size() == want.size(), "bond_atoms: as many bonds as the packing file");
    bool ids_sorted = got.ids.size() == 27;
    for (size_t k = 0; ids_sorted && k < 27; ++k) ids_sorted = got.ids[k] == 10 * (k + 1);
    check(ids_sorted, "bond_atoms: ids sorted");
    double worst = 0.0;
    bool same_pairs = got.rows.size() == want.size();
    for (size_t b = 0; same_pairs && b < want.size(); ++b) {
      const BondRow &g = got.rows[b], &w = want[b];
      same_pairs = g.i == w.i && g.j == w.j && g.ix == w.ix && g.iy == w.iy && g.iz == w.iz;
      for (double d : {g.nx - w.nx, g.ny - w.ny, g.nz - w.nz, (g.length - w.length) / w.length,
                       (g.kn - w.kn) / w.kn, (g.ks - w.ks) / w.ks})
        worst = std::max(worst, std::fabs(d));
    }
    check(same_pairs, "bond_atoms: the packing file's pairs and images");
    close_abs(worst, 0.0, 1e-12, "bond_atoms: normals, lengths and springs");
    const std::string table = tmp_path("atoms_bonds.csv");
    bond_atoms(*m, xs, rs, is, box, table);
    std::ifstream f(table);
    std::string header;
    std::getline(f, header);
    check(header.size() > 10 && header.substr(header.size() - 10) == ",id_i,id_j",
          "bond_atoms: write_bonds has id columns");

    AtomsBox free_box = box;
    for (int k = 0; k < 3; ++k) free_box.periodic[k] = false;
    check(bond_atoms(*m, xs, rs, is, free_box, "").rows.size() == 54,
          "bond_atoms: free 3x3x3 cluster: 54 bonds");
    AtomsBox mixed = box;
    mixed.periodic[2] = false;
    throws_with([&] { bond_atoms(*m, xs, rs, is, mixed, ""); }, "periodic along x and y only",
                "bond_atoms: mixed periodicity refused");
    AtomsBox tilted = box;
    tilted.tilt[0] = 1e-4;
    throws_with([&] { bond_atoms(*m, xs, rs, is, tilted, ""); }, "tilted",
                "bond_atoms: tilted box refused");
    std::vector<uint64_t> twice = ids;
    twice[3] = twice[4];
    throws_with(
        [&] {
          bond_atoms(*m, xs, rs, rust::Slice<const uint64_t>(twice.data(), twice.size()), box,
                     "");
        },
        "appears twice", "bond_atoms: duplicate id refused");
  }

  // 8. Cross-anisotropic lattice scaling μ given instead of a packing (as the LAMMPS plugin
  //    does, summing over its processes' bonds): on the simple cubic lattice above, 81 bonds of
  //    length 2R between spheres of radius R in V = (6R)³, μ = π̂·Σ(½·2R·R²)/(3V) = π̂/8
  //    (Šmilauer Eq. 20). The springs then equal those of the scheme bound to the packing.
  {
    const double R = 1e-3;
    const std::string pack = tmp_path("sc.txt");
    const char *cross =
        "[bonding]\nrule = \"gap\"\nvalue = 0.01\n"
        "[scheme]\nkind = \"cross-anisotropic\"\nC11 = 30e9\nC33 = 12e9\nC13 = 5e9\nC12 = 8e9\n"
        "strike_deg = 270\ndip_deg = 25\n[geometry]\nconvention = \"modulus\"\n";
    auto given = parse_model(cross, "toml");
    auto bound = parse_model(cross, "toml");
    check(given->needs_packing(), "cross-anisotropic needs a packing or μ");
    close_rel(given->pi_hat(), std::acos(-1.0), 1e-15, "default pi_hat = π");
    throws_with([&] { given->bond_springs(1, 0, 0, R, R, 2 * R); }, "bonded packing",
                "springs before μ is known");
    throws_with([&] { given->set_lattice_scaling(-1.0); }, "must be finite and > 0",
                "negative μ refused");
    given->set_lattice_scaling(given->pi_hat() / 8.0);
    bound->bind_packing(pack);
    const double dirs[2][3] = {{1, 0, 0}, {0.3, -0.5, 0.8}};
    for (const double *n : dirs) {
      BondSprings a = given->bond_springs(n[0], n[1], n[2], R, R, 2 * R);
      BondSprings b = bound->bond_springs(n[0], n[1], n[2], R, R, 2 * R);
      close_rel(a.kn, b.kn, 1e-12, "k_n with μ = π̂/8 = k_n bound to the lattice");
      close_rel(a.ks, b.ks, 1e-12, "k_s with μ = π̂/8 = k_s bound to the lattice");
      check(a.kn > 0.0, "k_n > 0");
    }
  }

  // 9. Every method of the library's registry: when tests/ffi/cpp.rs names a packing, a model
  //    and an output file (ANISOBOND_BRIDGE_PACKING, _MODEL, _OUT), write the laf and
  //    prestressed tensors there, full precision, for it to compare with the library's own.
  {
    const char *pack = std::getenv("ANISOBOND_BRIDGE_PACKING");
    const char *model = std::getenv("ANISOBOND_BRIDGE_MODEL");
    const char *out = std::getenv("ANISOBOND_BRIDGE_OUT");
    if (pack && model && out) {
      auto m = load_model(model);
      std::ofstream f(out);
      f.precision(17);
      for (const char *method : {"laf", "prestressed"}) {
        Tensor6 c = compute_tensor(pack, *m, method);
        f << method;
        for (double x : c.c) f << " " << x;
        f << "\n";
      }
      check(static_cast<bool>(f), "laf and prestressed tensors written");
    }
  }

  std::printf("%d passed, %d failed\n", passed, failed);
  return failed == 0 ? 0 : 1;
}
