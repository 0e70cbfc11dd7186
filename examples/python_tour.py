"""A tour of the anisobond Python package, notebook style: packing -> springs -> relaxed
tensor -> polar plot of the normal spring k_n.

    pip install .                       # from a clone (builds the Rust crate with maturin)
    python examples/python_tour.py [OUTPUT_DIR [PACKING]]

Reads PACKING (any format the command line reads: `anisobond pack -o packing.txt`, YADE's
SpherePack.save, LIGGGHTS data) or, without one, makes a seeded periodic packing in Python
(a jittered FCC lattice: its bonds lie along <110> only), bonds it by Truszkowska 2018's MRV model, prints the relaxed tensor and its cubic
constants, and, when matplotlib is installed, writes kn-polar.png: k_n of every bond against
its angle to the crystal axis x, with the scheme's own k_n(θ) in the (x, y) plane.
"""

import os
import sys

import numpy as np

import anisobond as ab

out = sys.argv[1] if len(sys.argv) > 1 else "."
os.makedirs(out, exist_ok=True)

# %% A packing: FCC lattice of 6x6x6 cells (864 spheres, R = 1 mm), jittered, seeded.
rng = np.random.default_rng(2018)
cells, radius = 6, 1e-3
a = 2 * np.sqrt(2) * radius  # FCC lattice constant of touching spheres
basis = np.array([[0, 0, 0], [0.5, 0.5, 0], [0.5, 0, 0.5], [0, 0.5, 0.5]])
grid = np.stack(np.meshgrid(*[np.arange(cells)] * 3, indexing="ij"), -1).reshape(-1, 3)
positions = ((grid[:, None, :] + basis[None]) * a).reshape(-1, 3)
positions += rng.normal(scale=0.02 * radius, size=positions.shape)
radii = radius * (1 + rng.uniform(-0.05, 0.05, len(positions)))
packing = ab.Packing(positions, radii, cell=(cells * a,) * 3)
if len(sys.argv) > 2:
    packing = ab.Packing.load(sys.argv[2])
    radii = packing.radii
print(packing)

# %% The model: Truszkowska 2018 MRV (cubic, Zener > 1), or your own file:
# model = ab.Model.load("model.toml")
model = ab.Model.truszkowska_mrv()
assembly = ab.Assembly(packing, model)
print(assembly)

# %% Springs: the bond table as numpy columns (N/m), and the same from arbitrary geometry.
bonds = assembly.bonds
print("k_n: %.3e to %.3e N/m over %d bonds" % (bonds["kn"].min(), bonds["kn"].max(),
                                                assembly.n_bonds))
again = model.springs(bonds["normal"], radii[bonds["i"]], radii[bonds["j"]], bonds["length"])
assert np.array_equal(again["kn"], bonds["kn"])

# %% Tensors (Pa): relaxed (exact static equilibrium) against the Voigt (affine) bound.
relaxed = assembly.tensor("relaxed")
voigt = assembly.tensor("voigt")
np.set_printoptions(precision=3, suppress=True)
print("relaxed C (GPa):\n", relaxed / 1e9)
report = assembly.tensor_report("relaxed")
cubic = report["cubic"]
print("cubic C11, C12, C44 = %.3f, %.3f, %.3f GPa; Zener ratio %.3f; relaxed/Voigt C11 %.3f"
      % (cubic["C11"] / 1e9, cubic["C12"] / 1e9, cubic["C44"] / 1e9,
         2 * cubic["C44"] / (cubic["C11"] - cubic["C12"]), relaxed[0, 0] / voigt[0, 0]))
print("engineering constants:", {k: "%.4g" % v for k, v in
                                  ab.engineering_constants(relaxed).items()})

# %% Polar plot of k_n (needs matplotlib).
try:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
except ImportError:
    print("matplotlib is not installed: no plot (pip install matplotlib)")
    sys.exit(0)

n = bonds["normal"]
theta_bonds = np.arctan2(n[:, 1], n[:, 0])
theta = np.linspace(0, 2 * np.pi, 721)
ring = np.column_stack([np.cos(theta), np.sin(theta), np.zeros_like(theta)])
length = np.full(len(theta), 2 * radii.mean())
curve = model.springs(ring, length / 2, length / 2, length)["kn"]
near_plane = np.abs(n[:, 2]) < 0.2
fig = plt.figure(figsize=(5, 5))
ax = fig.add_subplot(projection="polar")
ax.scatter(theta_bonds[near_plane], bonds["kn"][near_plane] / 1e6, s=4, alpha=0.5,
           label="bonds with |n_z| < 0.2")
ax.plot(theta, curve / 1e6, "k", lw=1, label="scheme, mean R, |l| = 2R")
ax.set_title("normal spring k_n (MN/m) in the (x, y) plane")
ax.legend(loc="lower left", fontsize=7)
path = os.path.join(out, "kn-polar.png")
fig.savefig(path, dpi=120, bbox_inches="tight")
print("wrote", path)
