"""remembrane from Python: a tutorial.

1. Run the bundled red-blood-cell scene and plot its reduced volume and
   energies against time.
2. Add a force term written in Python (gravity pulling the vesicle onto a
   flat substrate), check it against finite differences, and watch the
   vesicle settle and spread.
3. Run a small sweep over the bending rigidity and read it back.

Run from the repository root (it writes into OUT, default runs/tutorial):

    python python/examples/tutorial.py [OUT]

It saves OUT/tutorial.png. Units: energy Ē = 10 k_BT, length l̄ = 1 µm,
time s.
"""

import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

import remembrane as rm  # noqa: E402

REPO = Path(__file__).resolve().parents[2]
OUT = Path(sys.argv[1]) if len(sys.argv) > 1 else REPO / "runs" / "tutorial"
OUT.mkdir(parents=True, exist_ok=True)

# --- 1. The red blood cell ------------------------------------------------
# The scene deflates a 642-vertex sphere to v ≈ 0.66 with free-energy
# remeshing; run() writes the same run directory as `remembrane run`.
scene = rm.Scene.load(REPO / "scenes" / "red_blood_cell.ron")
rbc = rm.Simulation(scene)
summary = rbc.run(out=OUT / "rbc", progress=False, overwrite=True)
print(
    f"RBC: {summary['iterations']} iterations, t = {summary['simulated_time']:.3f} s, "
    f"v = {summary['reduced_volume']:.3f}, shape {summary['shape']['class']}, "
    f"{summary['wall_time_s']:.1f} s wall"
)
run = rm.load_run(OUT / "rbc")
series = run.series  # a pandas DataFrame if pandas is installed, else a dict of arrays
t = np.asarray(series["time"])
v = np.asarray(series["reduced_volume"])
energies = {name: np.asarray(series[f"energy_{name}"]) for name in ("bending", "vin", "volume", "area")}

# --- 2. A Python force term: gravity onto a substrate ----------------------
# E = g Σ z_i + ½ k_s Σ min(0, z_i − z_floor)²: a uniform downward force g
# on every vertex and a stiff floor at z_floor. Forces are −∇E.
G = 0.02  # Ē/l̄ per vertex
K_FLOOR = 50.0  # Ē/l̄²


def make_gravity(z_floor):
    def gravity(x):
        z = x[:, 2]
        below = np.minimum(z - z_floor, 0.0)
        energy = G * z.sum() + 0.5 * K_FLOOR * float((below * below).sum())
        force = np.zeros_like(x)
        force[:, 2] = -G - K_FLOOR * below
        return energy, force

    return gravity


# Check it on the engine's perturbed test sphere (radius ≈ 3.3 l̄) with the
# floor cutting through its lower half, so both branches are tested. (E is
# only C¹ at the floor: a vertex within 2h of it would fail the default
# 4-point stencil, as it should.)
report = rm.check_force(make_gravity(-0.5), rm.perturbed_icosphere(2, seed=1))
print(f"gravity term FD check: passed={report['passed']}, max rel. error {report['max_rel_error']:.1e}")

# A softer vesicle (v target 0.9) so it can spread; no deflation from the RBC.
vesicle_scene = scene.replace(
    iterations=6000,
    set={"energy.Volume.target": {"OfInitial": 0.9}, "energy.Area.target": {"OfInitial": 1.0}},
)
vesicle = rm.Simulation(vesicle_scene)
start = vesicle.positions
z_floor = start[:, 2].min() - 0.05
vesicle.add_force_term("gravity", make_gravity(z_floor))
vesicle.step(vesicle_scene.iterations)
settled = vesicle.positions
height0 = np.ptp(start[:, 2])
height = np.ptp(settled[:, 2])
contact = int((settled[:, 2] < z_floor + 0.1).sum())
print(
    f"settled vesicle: height {height0:.2f} -> {height:.2f} l̄, {contact} vertices on the floor, "
    f"gravity energy {vesicle.energies()['gravity']:.2f} Ē after t = {vesicle.time:.4f} s"
)

# --- 3. A sweep over κ ---------------------------------------------------
sweep_dir = OUT / "kappa_sweep"
(OUT / "small_vesicle.ron").write_text(
    """Scene(
    name: "small_vesicle",
    membrane: Icosphere(level: 2),
    energy: [Bending(kappa: 1.0), Area(k: 1.0, target: OfInitial(1.0)), Volume(k: 1.0, target: OfInitial(0.9))],
    dynamics: (max_displacement: 0.01, iterations: 400, frames: 4),
)"""
)
(OUT / "kappa_sweep.ron").write_text(
    """Sweep(
    name: "kappa_sweep",
    scene: "small_vesicle.ron",
    repeats: 1,
    grid: [(name: "kappa", values: [Kappa(0.5), Kappa(1.0), Kappa(2.0), Kappa(4.0)])],
)"""
)
print("sweep:", rm.sweep(OUT / "kappa_sweep.ron", sweep_dir, jobs=2))
table = rm.load_run(sweep_dir).table()
rows = table.to_dict("records") if hasattr(table, "to_dict") else table
for r in rows:
    print(f"  κ = {r['kappa']:4.1f} Ē: E_bending = {r['energy_bending']:8.3f} Ē  (8πκ = {8 * np.pi * r['kappa']:8.3f})")

# --- The chart -------------------------------------------------------------
fig, ax = plt.subplots(1, 3, figsize=(13, 3.8))
ax[0].plot(t, v, color="C0")
ax[0].set_xlabel("time (s)")
ax[0].set_ylabel("reduced volume v")
ax[0].set_title("red blood cell: deflation")
for name, e in energies.items():
    ax[1].plot(t, e, label=name)
ax[1].set_yscale("log")
ax[1].set_xlabel("time (s)")
ax[1].set_ylabel("energy (Ē = 10 k_BT)")
ax[1].set_title("energies by term")
ax[1].legend(fontsize=8)
# The vertices near the plane y = 0: a cross-section of the vesicle.
for x, color, label in [(start, "0.6", "start"), (settled, "C3", f"after t = {vesicle.time:.3f} s")]:
    near = np.abs(x[:, 1] - x[:, 1].mean()) < 0.8
    ax[2].scatter(x[near, 0], x[near, 2], s=6, color=color, label=label)
ax[2].axhline(z_floor, color="k", lw=1)
ax[2].set_aspect("equal")
ax[2].set_xlabel("x (µm)")
ax[2].set_ylabel("z (µm)")
ax[2].set_title("Python term: gravity onto a floor (v → 0.9)")
ax[2].legend(fontsize=8, loc="upper right")
fig.tight_layout()
fig.savefig(OUT / "tutorial.png", dpi=110)
print(f"chart: {OUT / 'tutorial.png'}")
