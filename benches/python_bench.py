"""Python package figures for BENCHMARKS.md (called by benches/regenerate.py with the virtual
environment's Python, the package installed): prints one JSON object.

    python benches/python_bench.py PACKING MODEL CLI_REPORT.json N_SPRINGS
"""
import json
import sys
import time

import numpy as np

import anisobond as ab

packing, model_path, cli_report, n_springs = sys.argv[1], sys.argv[2], sys.argv[3], int(sys.argv[4])
out = {}

t0 = time.perf_counter()
model = ab.Model.load(model_path)
asm = ab.Assembly(ab.Packing.load(packing), model)
t1 = time.perf_counter()
report = asm.tensor_report("relaxed")
t2 = time.perf_counter()
out["load_and_bond_s"] = t1 - t0
out["relaxed_s"] = t2 - t1
out["n_particles"] = asm.n_particles
out["n_bonds"] = asm.n_bonds
out["identical_to_cli"] = report == json.load(open(cli_report))
out["C11_GPa"] = report["cubic"]["C11"] / 1e9 if "C11" in report["cubic"] else None

# model.springs: one call on n_springs bonds, and the fixed cost of a call (one bond).
rng = np.random.default_rng(1)
n = rng.normal(size=(n_springs, 3))
n /= np.linalg.norm(n, axis=1)[:, None]
r = np.full(n_springs, 1e-3)
length = np.full(n_springs, 2.05e-3)
t0 = time.perf_counter()
k = model.springs(n, r, r, length)
out["springs_s"] = time.perf_counter() - t0
assert np.all(np.isfinite(k["kn"]))
one = (n[:1], r[:1], r[:1], length[:1])
calls = 2000
t0 = time.perf_counter()
for _ in range(calls):
    model.springs(*one)
out["springs_call_us"] = (time.perf_counter() - t0) / calls * 1e6
out["n_springs"] = n_springs
print(json.dumps(out))
