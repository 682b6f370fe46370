#!/usr/bin/env python3
"""Run one reference problem of `remembrane study` on the peer engine Mem3DG.

Usage (with the Mem3DG virtual environment first on PATH):

    echo '{"problem": "sphere", "level": 3, "kappa": 1}' | python3 benches/peers/mem3dg_case.py

Reads one JSON object from stdin and prints one JSON object on stdout; nothing
else goes to stdout (Mem3DG's own C++ console output is sent to stderr).
Exit codes: 0 success, 1 the engine failed (e.g. the integration blew up),
2 bad input, 3 pymem3dg is not importable. On failure the last stderr line is
a one-line reason.

Input, one of
  {"problem": "sphere", "level": L, "kappa": k}
      Mem3DG's icosphere (dg.getIcosphere) of radius 1 and subdivision level
      L (10*4^L + 2 vertices).
  {"problem": "spheroid", "level": L, "kappa": k, "semi_axes": [a, b, c],
   "jitter": j, "seed": s}
      Mem3DG's unit icosphere; each vertex p is moved by a seeded tangential
      offset (o uniform in the unit ball, t = o - (o.p)p, p <- normalize(p + j*l*t),
      l the unit icosphere's mean edge length), then mapped to (a x, b y, c z).
  {"problem": "rbc", "level": L, "kappa": k, "area_target": A_t,
   "volume_target": V_t, "area_k": kA, "volume_k": kV, "iterations": n,
   "out": "/abs/dir"[, "seed": s]}
      Red-blood-cell deflation from a sphere of (polyhedral) area A_t, see
      run_rbc. Writes <out>/final.ply.
  L is an integer in 0..6, k > 0.

Output keys (null where not applicable): engine, problem, vertices,
energy_bending, area, volume, reduced_volume (6 sqrt(pi) V / A^1.5), steps,
simulated_time, wall_s (the work after imports and input parsing), cost_s
(median wall time of one forward-Euler step for the static problems, wall_s
for rbc), mesh (the PLY written, or null), notes (conventions, dt, mappings).

Units and conventions
  Lengths and energies are in the caller's units (the same unit for kappa and
  the penalty strengths); Mem3DG has no intrinsic units. Its forward Euler is
  x <- x + F dt with F the integrated (per-vertex) force, i.e. mobility 1, so
  the simulated time is in energy^-1 length^2 units.
  Bending energy: Mem3DG's spontaneousCurvatureEnergy with H0 = 0,
  E = 2 Kb sum_i A_i (H_i / A_i)^2, H_i the dihedral-angle (Steiner) integrated
  mean curvature of geometry-central, A_i the barycentric dual area. This is
  (Kb/2) int (2H)^2 dA, so Kb = kappa with no conversion (a sphere gives
  8 pi kappa). Kb is set as bending.Kbc with Mem3DG's default homogeneous
  protein density 1, Mem3DG's recommended form for a homogeneous membrane.

Mem3DG is MPL-2.0; this script only drives the installed package.
"""
import json
import math
import os
import statistics
import sys
import tempfile
import time
from functools import partial

EXIT_ENGINE_FAILED = 1
EXIT_BAD_INPUT = 2
EXIT_NOT_IMPORTABLE = 3

MAX_LEVEL = 6

# Static problems: time forward-Euler steps until both bounds are reached.
TIMING_MIN_TOTAL_S = 0.2
TIMING_MIN_STEPS = 20
# Static problems: dt = factor * mean_edge^2 / kappa, about 50x below the
# bending stability limit measured for the rbc run (see RBC_DT_BENDING).
TIMING_DT_FACTOR = 1e-3

# RBC: dt = RBC_DT_BENDING * mean_edge^2 / kappa (0.01 at level 3 with
# A_t = 553 and kappa = 5; 0.02 blew up there, so this is half the limit),
# also capped so that the volume-penalty relaxation is well resolved (see
# rbc_dt; forward Euler on that mode alone is stable below 2, 0.1 stays far
# from it; the cap binds only for stiff volume penalties, e.g. kV = 20).
RBC_DT_BENDING = 0.05
RBC_DT_VOLUME = 0.1
# RBC: amplitude of the symmetry-breaking perturbation, in mean edge lengths.
RBC_PERTURBATION = 1e-3
RBC_DEFAULT_SEED = 1
# RBC: Mem3DG mesh regularisation (vertex shift + Delaunay flips) every this
# many steps. Without it the plain forward Euler degenerates the mesh (edges
# grow to ~10 mean edge lengths and the bending energy drops below 8 pi kappa);
# every 200 steps is too rare, every 10-50 steps holds the shape in a higher
# bending-energy state (measured at level 3). At levels 2 and 4 the mesh
# degenerates even so (see RBC_MAX_EDGE_RATIO).
RBC_MUTATE_PERIOD = 100
# RBC: converged when |E(k) - E(k - 1000)| < 1e-7 |E(k)|, E the total potential
# energy, checked every 1000 steps.
RBC_CHECK_PERIOD = 1000
RBC_REL_TOL = 1e-7
# RBC: the run fails (exit 1) if, at a check, an edge is longer than this many
# initial mean edge lengths. The level-3 run peaks near 2.6 while buckling and
# ends at 1.3; runs that degenerate (level 4: a coarse tube grows out of the
# cell, its edges exceed 9 and the dihedral energy falls) pass 4 on their way.
RBC_MAX_EDGE_RATIO = 4.0


class InputError(Exception):
    """Bad input: exit code 2."""


class EngineError(Exception):
    """Mem3DG failed or produced a non-finite state: exit code 1."""


# --------------------------------------------------------------------------
# input validation
# --------------------------------------------------------------------------
def _number(spec, key, positive=False, nonnegative=False):
    value = spec[key]
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise InputError(f"'{key}' must be a finite number, got {value!r}")
    if positive and value <= 0:
        raise InputError(f"'{key}' must be > 0, got {value!r}")
    if nonnegative and value < 0:
        raise InputError(f"'{key}' must be >= 0, got {value!r}")
    return float(value)


def _integer(spec, key, lo, hi=None):
    value = spec[key]
    if isinstance(value, bool) or not isinstance(value, int):
        raise InputError(f"'{key}' must be an integer, got {value!r}")
    if value < lo or (hi is not None and value > hi):
        bound = f"in {lo}..{hi}" if hi is not None else f">= {lo}"
        raise InputError(f"'{key}' must be {bound}, got {value}")
    return value


REQUIRED = {
    "sphere": ("level", "kappa"),
    "spheroid": ("level", "kappa", "semi_axes", "jitter", "seed"),
    "rbc": ("level", "kappa", "area_target", "volume_target", "area_k", "volume_k",
            "iterations", "out"),
}
OPTIONAL = {"sphere": (), "spheroid": (), "rbc": ("seed",)}


def parse_input(text):
    """Validates the stdin JSON; returns a dict of typed values."""
    try:
        spec = json.loads(text)
    except json.JSONDecodeError as err:
        raise InputError(f"stdin is not valid JSON: {err}") from None
    if not isinstance(spec, dict):
        raise InputError("stdin must hold one JSON object")
    problem = spec.get("problem")
    if problem not in REQUIRED:
        raise InputError(f"unknown problem {problem!r} (expected one of {', '.join(REQUIRED)})")
    missing = [k for k in REQUIRED[problem] if k not in spec]
    if missing:
        raise InputError(f"problem '{problem}' is missing key(s): {', '.join(missing)}")
    unknown = sorted(set(spec) - {"problem"} - set(REQUIRED[problem]) - set(OPTIONAL[problem]))
    if unknown:
        raise InputError(f"problem '{problem}' does not take key(s): {', '.join(unknown)}")

    case = {"problem": problem,
            "level": _integer(spec, "level", 0, MAX_LEVEL),
            "kappa": _number(spec, "kappa", positive=True)}
    if problem == "spheroid":
        axes = spec["semi_axes"]
        if (not isinstance(axes, list) or len(axes) != 3
                or any(isinstance(a, bool) or not isinstance(a, (int, float))
                       or not math.isfinite(a) or a <= 0 for a in axes)):
            raise InputError(f"'semi_axes' must be a list of 3 positive numbers, got {axes!r}")
        case["semi_axes"] = [float(a) for a in axes]
        case["jitter"] = _number(spec, "jitter", nonnegative=True)
        if case["jitter"] >= 0.5:
            raise InputError(f"'jitter' must be below 0.5 (faces may fold), got {case['jitter']}")
        case["seed"] = _integer(spec, "seed", 0)
    elif problem == "rbc":
        case["area_target"] = _number(spec, "area_target", positive=True)
        case["volume_target"] = _number(spec, "volume_target", positive=True)
        case["area_k"] = _number(spec, "area_k", nonnegative=True)
        case["volume_k"] = _number(spec, "volume_k", nonnegative=True)
        case["iterations"] = _integer(spec, "iterations", 1)
        out = spec["out"]
        if not isinstance(out, str) or not os.path.isabs(out):
            raise InputError(f"'out' must be an absolute directory path, got {out!r}")
        case["out"] = out
        case["seed"] = _integer(spec, "seed", 0) if "seed" in spec else RBC_DEFAULT_SEED
    return case


# --------------------------------------------------------------------------
# meshes and measurements
# --------------------------------------------------------------------------
def unit_ball_points(rng, n):
    """n points uniform in the unit ball, by rejection from the cube [-1, 1)^3
    (as remembrane's Ellipsoid jitter: the tangential move is at most 1)."""
    out = np.empty((0, 3))
    while len(out) < n:
        p = rng.uniform(-1.0, 1.0, (2 * n, 3))
        out = np.vstack([out, p[np.einsum("ij,ij->i", p, p) <= 1.0]])
    return out[:n]


def mean_edge_length(faces, vertices):
    """Mean length of the unique edges of a triangle mesh."""
    edges = np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]])
    edges = np.unique(np.sort(edges, axis=1), axis=0)
    return float(np.linalg.norm(vertices[edges[:, 0]] - vertices[edges[:, 1]], axis=1).mean())


def reduced_volume(area, volume):
    return 6.0 * math.sqrt(math.pi) * volume / area ** 1.5


def check_closed_oriented(faces):
    """Raises EngineError unless every directed edge appears once and its
    reverse once (closed, consistently oriented, manifold edges)."""
    directed = np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]])
    forward = {tuple(e) for e in directed.tolist()}
    if len(forward) != len(directed):
        raise EngineError("final mesh has a repeated directed edge (inconsistent orientation)")
    if any((b, a) not in forward for a, b in forward):
        raise EngineError("final mesh is not closed (an edge has one face)")


def signed_volume(faces, vertices):
    a, b, c = (vertices[faces[:, i]] for i in range(3))
    return float(np.einsum("ij,ij->i", a, np.cross(b, c)).sum() / 6.0)


def write_ply(path, faces, vertices):
    """ASCII PLY: double x, y, z; int vertex_indices lists. Written to a
    temporary name and renamed, so a partial file never has the final name."""
    header = ("ply\nformat ascii 1.0\ncomment Mem3DG final mesh (remembrane peer case)\n"
              f"element vertex {len(vertices)}\n"
              "property double x\nproperty double y\nproperty double z\n"
              f"element face {len(faces)}\nproperty list uchar int vertex_indices\n"
              "end_header\n")
    tmp = path + ".tmp"
    with open(tmp, "w") as fh:
        fh.write(header)
        fh.writelines("%.17g %.17g %.17g\n" % tuple(p) for p in vertices.tolist())
        fh.writelines("3 %d %d %d\n" % tuple(f) for f in faces.tolist())
    os.replace(tmp, path)


def measure(system):
    """Bending energy, total potential energy, area, volume of the current state."""
    system.computeTotalEnergy()
    energy = system.getEnergy()
    geometry = system.getGeometry()
    values = dict(bending=energy.spontaneousCurvatureEnergy, potential=energy.potentialEnergy,
                  area=geometry.getSurfaceArea(), volume=geometry.getVolume())
    if not all(math.isfinite(v) for v in values.values()):
        raise EngineError(f"non-finite state: {values}")
    return values


# --------------------------------------------------------------------------
# Mem3DG drivers
# --------------------------------------------------------------------------
def bending_parameters(kappa):
    params = dg.Parameters()
    params.bending.Kbc = kappa  # Kb = Kbc * protein density (1); H0 = 0
    return params


def make_system(faces, vertices, params, regularise=False):
    """(geometry, system): the geometry must outlive the system, which holds a
    reference to it. `regularise` enables Mem3DG's vertex shift and
    non-Delaunay edge flips (no split/collapse, so the vertex count is kept);
    they run only where run_rbc calls mutateMesh."""
    geometry = dg.Geometry(faces, vertices)
    system = dg.System(geometry=geometry, parameters=params)
    if regularise:
        mutator = system.meshProcessor.meshMutator
        mutator.isShiftVertex = True
        mutator.flipNonDelaunay = True
    system.initialize()
    return geometry, system


def plain_euler(system, dt, outdir):
    """Mem3DG's forward Euler with a fixed step: no backtracking line search,
    no adaptive step, no output files, no console output."""
    euler = dg.Euler(system=system, characteristicTimeStep=dt, totalTime=1e30,
                     savePeriod=1e30, tolerance=0.0, outputDirectory=outdir)
    euler.isBacktrack = False
    euler.ifAdaptiveStep = False
    euler.ifPrintToConsole = False
    euler.ifOutputTrajFile = False
    euler.ifOutputMeshFile = False
    return euler


def run_static(case):
    """sphere / spheroid: Mem3DG's bending energy of the initial mesh, then the
    median wall time of single forward-Euler steps (Euler.step(1): forces,
    energies, finiteness check and the position update)."""
    t_start = time.perf_counter()
    faces, vertices = dg.getIcosphere(1.0, case["level"])
    notes = [f"Mem3DG icosphere level {case['level']}"]
    if case["problem"] == "sphere":
        notes[0] += ", radius 1"
    else:
        if case["jitter"] > 0:
            edge = mean_edge_length(faces, vertices)
            offsets = unit_ball_points(np.random.default_rng(case["seed"]), len(vertices))
            tangential = offsets - np.einsum("ij,ij->i", offsets, vertices)[:, None] * vertices
            vertices = vertices + case["jitter"] * edge * tangential
            vertices /= np.linalg.norm(vertices, axis=1)[:, None]
            notes.append(f"tangential jitter {case['jitter']} x unit mean edge {edge:.6g} from "
                         f"numpy PCG64 seed {case['seed']} (same recipe as remembrane, "
                         "not the same random numbers)")
        vertices = vertices * np.array(case["semi_axes"])
        notes.append("mapped to semi-axes [%s]" % ", ".join("%g" % a for a in case["semi_axes"]))

    # `geometry` is not used below but must outlive `system` (see make_system).
    geometry, system = make_system(faces, vertices, bending_parameters(case["kappa"]))
    initial = measure(system)

    dt = TIMING_DT_FACTOR * mean_edge_length(faces, vertices) ** 2 / case["kappa"]
    with tempfile.TemporaryDirectory() as outdir:
        euler = plain_euler(system, dt, outdir)
        times = []
        while sum(times) < TIMING_MIN_TOTAL_S or len(times) < TIMING_MIN_STEPS:
            t0 = time.perf_counter()
            euler.step(1)
            times.append(time.perf_counter() - t0)
    measure(system)  # raises if the timing steps went non-finite
    wall = time.perf_counter() - t_start

    notes += [
        "energy_bending = Mem3DG spontaneousCurvatureEnergy (H0 = 0) of the initial mesh: "
        "2 Kb sum A_i (H_i/A_i)^2, dihedral (Steiner) H_i, barycentric A_i; Kb = kappa, "
        "no conversion (= (kappa/2) int (2H)^2 dA, sphere -> 8 pi kappa)",
        f"cost_s = median of {len(times)} single-step wall times (mean {statistics.fmean(times):.4g} s) "
        f"of plain forward Euler (isBacktrack off, no mesh mutation), bending only, "
        f"dt = {dt:.4g} = {TIMING_DT_FACTOR:g} mean_edge^2/kappa, single-threaded",
    ]
    return dict(vertices=int(vertices.shape[0]), energy_bending=initial["bending"],
                area=initial["area"], volume=initial["volume"],
                reduced_volume=reduced_volume(initial["area"], initial["volume"]),
                steps=len(times), simulated_time=None, wall_s=wall,
                cost_s=statistics.median(times), mesh=None, notes="; ".join(notes))


def rbc_dt(case, edge, vertex_areas):
    """(dt, bending bound, volume bound): the fixed step is the smaller of the
    bending bound c l^2/kappa and the volume-penalty bound. With
    F_i = -(2 kV/V_t) dV A_i n_i the volume excess dV relaxes at the rate
    (2 kV/V_t) sum A_i^2, and the bound keeps rate * dt <= RBC_DT_VOLUME."""
    bending = RBC_DT_BENDING * edge ** 2 / case["kappa"]
    volume_rate = 2.0 * case["volume_k"] / case["volume_target"] * float(np.sum(vertex_areas ** 2))
    volume = RBC_DT_VOLUME / volume_rate if volume_rate > 0 else math.inf
    return min(bending, volume), bending, volume


def run_rbc(case):
    """Deflation of a sphere with bending + area and volume penalties under
    Mem3DG's plain forward Euler, with vertex shift + Delaunay flips every
    RBC_MUTATE_PERIOD steps, until the energy is stationary or n steps."""
    t_start = time.perf_counter()
    faces, vertices = dg.getIcosphere(1.0, case["level"])
    vertices = vertices * math.sqrt(case["area_target"] / dg.Geometry(faces, vertices).getSurfaceArea())
    edge = mean_edge_length(faces, vertices)
    rng = np.random.default_rng(case["seed"])
    vertices = vertices + RBC_PERTURBATION * edge * rng.uniform(-1.0, 1.0, vertices.shape)

    params = bending_parameters(case["kappa"])
    # remembrane: E_A = kA (A - A_t)^2 / A_t. Mem3DG's preferred-area model:
    # E = modulus (A - A_t)^2 / (2 A_t)  ->  modulus = 2 kA.
    params.tension.form = partial(dgb.preferredAreaSurfaceTensionModel,
                                  modulus=2.0 * case["area_k"], preferredArea=case["area_target"])
    # remembrane: E_V = kV (V - V_t)^2 / V_t. Mem3DG's preferred-volume model:
    # E = strength (V - V_t)^2 / (2 V_t^2)  ->  strength = 2 kV V_t.
    params.osmotic.form = partial(dgb.preferredVolumeOsmoticPressureModel,
                                  strength=2.0 * case["volume_k"] * case["volume_target"],
                                  preferredVolume=case["volume_target"], reservoirVolume=0.0)
    geometry, system = make_system(faces, vertices, params, regularise=True)
    initial = measure(system)
    dt, dt_bending, dt_volume = rbc_dt(case, edge, geometry.getVertexDualAreas())

    os.makedirs(case["out"], exist_ok=True)
    euler = plain_euler(system, dt, case["out"])
    steps, converged = 0, False
    last_check = initial["potential"]
    while steps < case["iterations"] and not converged:
        chunk = min(RBC_MUTATE_PERIOD, case["iterations"] - steps)
        euler.step(chunk)
        steps += chunk
        if steps % RBC_MUTATE_PERIOD == 0:
            system.mutateMesh(1)
            system.updateConfigurations()
        state = measure(system)  # raises on blow-up, at most one chunk late
        if steps % RBC_CHECK_PERIOD == 0:
            longest = float(system.getGeometry().getEdgeLengths().max())
            if longest > RBC_MAX_EDGE_RATIO * edge:
                raise EngineError(
                    f"mesh degenerated at step {steps} (t = {system.time:.4g}): longest edge "
                    f"{longest:.3g} = {longest / edge:.3g} initial mean edges (limit "
                    f"{RBC_MAX_EDGE_RATIO:g}); plain forward Euler, dt = {dt:.4g}, vertex shift + "
                    f"flips every {RBC_MUTATE_PERIOD} steps")
            converged = abs(state["potential"] - last_check) < RBC_REL_TOL * abs(state["potential"])
            last_check = state["potential"]

    final = measure(system)
    final_faces = system.getGeometry().getFaceMatrix().astype(np.int64)
    final_vertices = system.getGeometry().getVertexMatrix()
    check_closed_oriented(final_faces)
    if signed_volume(final_faces, final_vertices) <= 0:
        raise EngineError("final mesh has non-positive signed volume (inward orientation)")
    mesh_path = os.path.join(case["out"], "final.ply")
    write_ply(mesh_path, final_faces, final_vertices)
    wall = time.perf_counter() - t_start

    energy = system.getEnergy()
    v_target = reduced_volume(case["area_target"], case["volume_target"])
    stop = ("converged: |dE| < %g |E| over %d steps" % (RBC_REL_TOL, RBC_CHECK_PERIOD) if converged
            else f"not converged: stopped at the iteration limit (last {RBC_CHECK_PERIOD}-step "
                 f"relative change of E above {RBC_REL_TOL:g})")
    notes = [
        f"Mem3DG icosphere level {case['level']} scaled to polyhedral area {case['area_target']:g}, "
        f"perturbed by uniform [-1,1)^3 x {RBC_PERTURBATION:g} mean edge ({edge:.4g}), numpy PCG64 "
        f"seed {case['seed']}",
        "Kb = kappa (Mem3DG energy 2 Kb sum A_i (H_i/A_i)^2 = (kappa/2) int (2H)^2 dA, H0 = 0)",
        f"area penalty: preferredAreaSurfaceTensionModel modulus = 2 kA = {2 * case['area_k']:g}, "
        "E = modulus (A-A_t)^2/(2 A_t) = kA (A-A_t)^2/A_t",
        f"volume penalty: preferredVolumeOsmoticPressureModel strength = 2 kV V_t = "
        f"{2 * case['volume_k'] * case['volume_target']:g}, E = strength (V-V_t)^2/(2 V_t^2) "
        "= kV (V-V_t)^2/V_t",
        f"plain forward Euler x += F dt (mobility 1), isBacktrack off, fixed dt = {dt:.4g}: the "
        f"smaller of the bending bound {RBC_DT_BENDING:g} mean_edge^2/kappa = {dt_bending:.4g} "
        f"(2x larger blew up at level 3) and the volume-relaxation bound {dt_volume:.4g}",
        f"Mem3DG mesh mutation ON for stability: vertex shift + non-Delaunay flips every "
        f"{RBC_MUTATE_PERIOD} steps (no split/collapse/smoothing; without it the mesh degenerates); "
        "the end state depends on this period (measured at level 3: every 10-50 steps ends at "
        "higher bending energy, every 200 degenerates); at levels 2 and 4 the mesh degenerates "
        f"anyway and the run fails once an edge exceeds {RBC_MAX_EDGE_RATIO:g} mean edges",
        stop,
        f"final: E_bending = {final['bending']:.6g} = {final['bending'] / (8 * math.pi * case['kappa']):.4f} "
        f"x 8 pi kappa, E_area = {energy.surfaceEnergy:.4g}, E_volume = {energy.pressureEnergy:.4g}, "
        f"A/A_t = {final['area'] / case['area_target']:.4f}, V/V_t = "
        f"{final['volume'] / case['volume_target']:.4f}, v target {v_target:.4f}",
        f"wall_s = cost_s = whole run ({wall / steps * 1e3:.3g} ms per step including the mesh "
        f"mutation and an energy check every {RBC_MUTATE_PERIOD} steps), single-threaded",
    ]
    return dict(vertices=int(final_vertices.shape[0]), energy_bending=final["bending"],
                area=final["area"], volume=final["volume"],
                reduced_volume=reduced_volume(final["area"], final["volume"]),
                steps=steps, simulated_time=system.time, wall_s=wall, cost_s=wall,
                mesh=mesh_path, notes="; ".join(notes))


# --------------------------------------------------------------------------
# entry point
# --------------------------------------------------------------------------
def fail(code, message):
    print("mem3dg_case: " + " ".join(str(message).split()), file=sys.stderr)
    sys.exit(code)


def main():
    # Keep the real stdout for the JSON answer; route everything else that
    # writes to fd 1 (Python prints, Mem3DG's std::cout) to stderr.
    answer_fd = os.dup(1)
    os.dup2(2, 1)
    sys.stdout = sys.stderr

    # The engine modules are imported here, after the redirection, and used
    # as module globals by the functions above.
    global np, dg, dgb
    try:
        import pymem3dg as dg
        import pymem3dg.boilerplate as dgb
        import numpy as np
    except Exception as err:  # any import-time failure means the engine is unusable
        fail(EXIT_NOT_IMPORTABLE, f"pymem3dg is not importable: {type(err).__name__}: {err}")

    try:
        case = parse_input(sys.stdin.read())
    except InputError as err:
        fail(EXIT_BAD_INPUT, err)

    try:
        result = run_rbc(case) if case["problem"] == "rbc" else run_static(case)
    except (EngineError, RuntimeError, OSError) as err:
        fail(EXIT_ENGINE_FAILED, f"{case['problem']} failed: {err}")

    answer = {"engine": f"Mem3DG {dg.__version__}", "problem": case["problem"]}
    answer.update(result)
    try:
        text = json.dumps(answer, allow_nan=False)
    except ValueError:
        fail(EXIT_ENGINE_FAILED, f"{case['problem']} produced a non-finite value: {answer}")
    os.write(answer_fd, (text + "\n").encode())


if __name__ == "__main__":
    main()
