"""One point of ``cardan sweep``: a variant of a scene, solved over its window.

A :class:`Point` is plain frozen data (a process pool and Dask ship it); :func:`run_point`
simulates the variant, solves each requested formulation over the instants through the
study layer and sums each up in one typed :class:`Row`: worst status, worst equilibrium
residual, peak loads over time, cost. It never raises: a scene, motion or solver error
is a ``failed`` row with the reason. A row's key holds the SHA-256 of the scene's
content (:func:`scene_digest`), so that a store tells an edited scene's rows from the
rows of the scene it was computed for.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import math
import time
from dataclasses import dataclass

import numpy as np
from cardan_forces.driveline.dynamics import simulate
from cardan_forces.driveline.equilibrium import Operator, build_operator
from cardan_forces.driveline.kinematics import Geometry, kinematics
from cardan_forces.driveline.loading import load_scene
from cardan_forces.driveline.scene import Scene, TimeGrid
from cardan_forces.experiments.study import History, solve_over_time
from cardan_forces.solvers import Status


class SweepError(ValueError):
    """A sweep request (or its stored rows) that cannot be carried out (exit code 2)."""


def scene_digest(scene: Scene) -> str:
    """SHA-256 (hex) of a loaded scene's content: every field of the validated scene
    (what it extends already merged in), not the file it came from, so that a store
    tells an edited scene from the one it was computed for, wherever the file lies.
    """
    content = dataclasses.asdict(scene)
    content.pop("source", None)
    text = json.dumps(content, sort_keys=True, default=_plain, separators=(",", ":"))
    return hashlib.sha256(text.encode()).hexdigest()


def _plain(value):
    """A value JSON has no spelling for, spelled once and always alike (a set sorted)."""
    if isinstance(value, (set, frozenset)):
        return sorted(map(str, value))
    return repr(value)


@dataclass(frozen=True)
class Point:
    """One sweep point: scene ``scene`` (a built-in name or a resolved path) with every
    joint at ``angle_deg`` (when ``set_angle``) and the input torque's amplitude at
    ``amplitude_N_m`` N m (when ``set_amplitude``), over ``instants`` instants from the
    scene's start to ``stop_s``; ``methods``: ``(formulation, backend)`` pairs;
    ``digest``: the scene's content (:func:`scene_digest`; empty: not checked).
    """

    scene: str
    stop_s: float
    instants: int
    angle_deg: float
    amplitude_N_m: float
    set_angle: bool
    set_amplitude: bool
    methods: tuple[tuple[str, str], ...]
    digest: str = ""


def window(scene: Scene, stop_s: float, instants: int) -> TimeGrid:
    """The point's time grid: ``instants`` instants from the scene's start to ``stop_s``."""
    span = stop_s - scene.time.start_s
    return TimeGrid(scene.time.start_s, stop_s, span / max(instants - 1, 1))


def variant(scene: Scene, point: Point) -> Scene:
    """``scene`` changed as ``point`` says (validated again: SceneError if it is none)."""
    changes: dict = {"name": f"sweep-{point.angle_deg:g}deg-{point.amplitude_N_m:g}Nm",
                     "time": window(scene, point.stop_s, point.instants)}
    if point.set_angle:
        changes["joints"] = tuple(dataclasses.replace(j, articulation_deg=point.angle_deg)
                                  for j in scene.joints)
    if point.set_amplitude:
        changes["input_torque"] = dataclasses.replace(scene.input_torque,
                                                      amplitude_N_m=point.amplitude_N_m)
    return scene.with_changes(**changes)


def point_scene(point: Point) -> Scene:
    """The scene of one point (ValueError if the scene's content is no longer the one
    the sweep was planned for: a file edited since).
    """
    scene = load_scene(point.scene)
    if point.digest and scene_digest(scene) != point.digest:
        raise ValueError(f"scene {point.scene}: its content changed since the sweep "
                         "started; run the sweep again")
    return variant(scene, point)


PEAKS = ("peak_joint1_N", "peak_joint2_N", "peak_input_radial_N", "peak_input_axial_N",
         "peak_output_radial_N", "peak_input_out_of_plane_N")
"""Peak loads over the solved instants (N), see :func:`peaks`."""


@dataclass(frozen=True)
class Row:
    """One point x formulation: the key (scene ... solver, and the SHA-256 of the
    scene's content last), the outcome over the instants, peaks (N; NaN where none was
    solved or the scene lacks the part), the largest speed ratios, and the cost (s:
    simulation and operator, solving, the point's whole worker call). A failed row has
    ``inf`` residual and NaN peaks.
    """

    scene: str
    stop_s: float
    instants: int
    angle_deg: float
    amplitude_N_m: float
    formulation: str
    solver: str
    status: Status
    n_solved: int
    max_equilibrium: float
    peak_joint1_N: float = math.nan
    peak_joint2_N: float = math.nan
    peak_input_radial_N: float = math.nan
    peak_input_axial_N: float = math.nan
    peak_output_radial_N: float = math.nan
    peak_input_out_of_plane_N: float = math.nan
    speed_ratio_shaft2_max: float = math.nan
    speed_ratio_output_max: float = math.nan
    simulate_s: float = 0.0
    solve_s: float = 0.0
    total_s: float = 0.0
    message: str = ""
    scene_sha256: str = ""


KEY = ("scene", "stop_s", "instants", "angle_deg", "amplitude_N_m", "formulation", "solver",
       "scene_sha256")
"""The fields that name a row: a rerun skips every row whose key is stored."""


def run_point(point: Point) -> list[Row]:
    """Simulate one point and solve its methods: one row per method, never an exception."""
    start = time.perf_counter()
    key = {"scene": point.scene, "scene_sha256": point.digest, "stop_s": point.stop_s,
           "instants": point.instants, "angle_deg": point.angle_deg,
           "amplitude_N_m": point.amplitude_N_m}
    try:
        scene = point_scene(point)
        motion = simulate(scene, np.linspace(scene.time.start_s, point.stop_s, point.instants))
        op = build_operator(motion)
    except Exception as exc:  # every point ends as rows, never as a crash
        spent = time.perf_counter() - start
        return [_failed(key, f, s, exc, spent) for f, s in point.methods]
    simulate_s = time.perf_counter() - start
    ratios = speed_ratios(motion.geometry)
    rows = []
    for formulation, solver in point.methods:
        began = time.perf_counter()
        try:
            h = solve_over_time(op, formulation, solver)
        except Exception as exc:  # NotApplicable to this variant
            rows.append(_failed(key, formulation, solver, exc, simulate_s))
            continue
        rows.append(Row(**key, formulation=formulation, solver=solver, **summarize(h),
                        **peaks(op, h), **ratios, simulate_s=simulate_s,
                        solve_s=time.perf_counter() - began))
    total_s = time.perf_counter() - start
    return [dataclasses.replace(r, total_s=total_s) for r in rows]


def _failed(key: dict, formulation: str, solver: str, exc: Exception, spent: float) -> Row:
    return Row(**key, formulation=formulation, solver=solver, status=Status.FAILED,
               n_solved=0, max_equilibrium=math.inf, simulate_s=spent, total_s=spent,
               message=f"{type(exc).__name__}: {exc}")


def summarize(h: History) -> dict:
    """Worst status, solved count, worst equilibrium residual, the worst record's word."""
    worst = max(h.records, key=lambda r: r.status)
    return {"status": worst.status, "n_solved": h.solved,
            "max_equilibrium": h.worst(("equilibrium",))["equilibrium"],
            "message": worst.message}


def peaks(op: Operator, h: History) -> dict[str, float]:
    """Peak loads (N) over the solved instants, NaN where none is or the scene lacks the part.

    - ``peak_joint1_N``, ``peak_joint2_N``: the largest contact force on the first and
      second joint's cross-pin, F1-F8 (a radial force as the length of its 2-vector);
    - ``peak_input_radial_N``, ``peak_output_radial_N``: the largest radial bearing load
      on the first and last shaft (normal to its axis);
    - ``peak_input_axial_N``: the first shaft's axial load, its bearings summed (as the
      paper merges them);
    - ``peak_input_out_of_plane_N``: the first shaft's largest bearing load normal to the
      articulation plane, determinate in the paper's scenes (the others mostly are not:
      they are the chosen formulation's member of the rigid solution set).
    """
    x = h.forces[np.all(np.isfinite(h.forces), axis=1)]
    if not len(x):
        return dict.fromkeys(PEAKS, math.nan)
    out = {}
    for k, name in enumerate(("peak_joint1_N", "peak_joint2_N")):
        groups = [list(c.columns) for c in op.joint_contacts(k).values()]
        out[name] = _max(np.linalg.norm(x[:, cols], axis=1) for cols in groups)
    for k, radial in ((0, "peak_input_radial_N"), (len(op.scene.shafts) - 1,
                                                   "peak_output_radial_N")):
        loads = list(op.bearing_loads(x, k).values())
        out[radial] = _max(load.radial for load in loads)
        if k == 0:
            out["peak_input_axial_N"] = _max([np.abs(sum(load.axial for load in loads))]) \
                if loads else math.nan
            out["peak_input_out_of_plane_N"] = _max(np.abs(load.normal) for load in loads)
    return out


def _max(arrays) -> float:
    values = [float(np.max(a)) for a in arrays]
    return max(values) if values else math.nan


def speed_ratios(geometry: Geometry) -> dict[str, float]:
    """Largest speed of the second and the last shaft per unit input speed over one input
    revolution at 0.5 deg steps: ``1 / cos γ`` behind one joint at γ (Cardan fluctuation).
    """
    ratio = kinematics(geometry, np.linspace(0.0, 2.0 * math.pi, 721)).ratio
    return {"speed_ratio_shaft2_max": float(ratio[1].max()),
            "speed_ratio_output_max": float(ratio[-1].max())}
