#!/usr/bin/env python3
"""The relaxed tensor by scipy's Jacobi-preconditioned CG on the system anisobond hands out
(`Assembly.relaxed_system`): the reference of issue 35's "at least 20× a Jacobi-CG scipy
solve". Run with the Python package installed (target/venv of .ci/test-all) and scipy:

    target/venv/bin/python benches/scipy_cg.py PACKING MODEL TOLERANCE OUT.json

Writes OUT.json: the time to get the system (s), the solve's wall and CPU time (s; scipy's
sparse product runs on one thread, numpy's vector operations may use more), CG iterations per load case, and C (Pa)."""
import json
import sys
import time

import numpy as np
import scipy
import scipy.sparse as sp
import scipy.sparse.linalg as sla

import anisobond as ab


def main():
    packing, model, tol, out = sys.argv[1], sys.argv[2], float(sys.argv[3]), sys.argv[4]
    asm = ab.Assembly(ab.Packing.load(packing), ab.Model.load(model))
    t0 = time.time()
    s = asm.relaxed_system()
    t_system = time.time() - t0
    n = len(s["indptr"]) - 1
    k = sp.csr_matrix((s["data"], s["indices"], s["indptr"]), shape=(n, n))
    diag = k.diagonal()
    m = sp.diags(np.where(diag > 0, 1.0 / np.where(diag > 0, diag, 1.0), 0.0))
    g = s["g"]
    q = np.zeros_like(g)
    iterations = []
    # scipy >= 1.12 names the relative tolerance rtol; older ones tol.
    major, minor = (int(x) for x in scipy.__version__.split(".")[:2])
    tol_key = "rtol" if (major, minor) >= (1, 12) else "tol"
    w0, c0 = time.time(), time.process_time()
    for c in range(6):
        b = g[:, c]
        if not np.any(b):
            iterations.append(0)
            continue
        count = [0]

        def step(_x, count=count):
            count[0] += 1

        x, info = sla.cg(k, b, M=m, maxiter=100000, callback=step, **{tol_key: tol})
        if info != 0:
            sys.exit("scipy CG did not converge on load case %d (info %d)" % (c, info))
        q[:, c] = x
        iterations.append(count[0])
    wall, cpu = time.time() - w0, time.process_time() - c0
    cmat = (s["h"] - g.T @ q) / s["volume"]
    cmat = 0.5 * (cmat + cmat.T)
    with open(out, "w") as f:
        json.dump({"unknowns": n, "stored_entries": int(k.nnz), "system_s": t_system,
                   "solve_wall_s": wall, "solve_cpu_s": cpu, "iterations": iterations,
                   "scipy": scipy.__version__, "C": cmat.tolist()}, f)


if __name__ == "__main__":
    main()
