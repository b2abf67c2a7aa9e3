"""Secondary-couple bearing loads over one revolution, against the handbook closed forms.

A Cardan joint's frictionless cross can pass no moment about either trunnion, so the
moment it transmits is ``m e3`` (``e3 = e1 x e2``); on a shaft whose axis is not
``e3`` this leaves a bending moment, the **secondary couple**. For an input torque
``T`` and joint angles ``b1``, ``b2`` (Dana Spicer, *Driveshaft / Universal Joint
Service Manual* and SAE AE-7 *Universal Joint and Driveshaft Design Manual*, section
on secondary couples; Klein, *Handbook of driveline components*, after
Seherr-Thoss et al., *Universal Joints and Driveshafts*, Springer 2006, ch. 1):

- at 90 deg (the driving trunnion normal to the articulation plane) the input shaft
  carries the couple ``T tan b1``, reacted by its two bearings ``a`` apart:
  ``+-T tan b1 / a``, normal to the articulation plane;
- at 0 deg (the driving trunnion in the plane) the intermediate shaft (joint centres
  ``L`` apart) carries the couples of both joints, ``T cos b1 (tan b1 -+ tan b2)``
  (``-`` Z, ``+`` W), reacted by a shear ``S = T cos b1 (tan b1 -+ tan b2) / L``
  through the joint centres, normal to the plane; on the input shaft (bearings ``a``
  apart, the joint ``c`` beyond the near bearing) ``near = -S (a + c) / a``,
  ``far = S c / a`` along ``+y``.

Signs (derived from the moment balance of each shaft and checked against the
operator in the tests): input torque about ``+x``, articulation towards ``+z``, the
joint centre at ``+x`` of the input shaft. At 90 deg the cross passes ``m e3 = T
a_mid / cos b1``, so the input shaft gets ``-T tan b1 z`` and its near bearing pushes
``+T tan b1 / a`` along ``+y``; at 0 deg the intermediate shaft gets ``-T cos b1 (tan
b1 -+ tan b2) u`` (``u`` its in-plane normal), balanced by ``+S y`` at joint 2 and
``-S y`` at joint 1. :func:`handbook` states them along ``r2``, the plane's normal in
the package's shaft frame (``-y`` here).

These hold when the intermediate shaft carries no axial force: with a frictionless
slip joint in it (``paper-slip``) every radial bearing load is determinate, and the
in-plane ones vanish at 0 and 90 deg (no gravity). Loads are quasi-static (constant
torque, no inertia, no gravity).
"""

from __future__ import annotations

import csv
import dataclasses
import math
import textwrap
from pathlib import Path

import numpy as np
from cardan_forces.driveline.determinacy import DETERMINATE_TOL, determinacy
from cardan_forces.driveline.dynamics import simulate
from cardan_forces.driveline.elements.registry import kind_of
from cardan_forces.driveline.equilibrium import Operator, build_operator
from cardan_forces.driveline.loading import load_scene
from cardan_forces.driveline.scene import LIMITS, Scene, SceneError, TimeGrid, TorqueLaw
from cardan_forces.experiments import files
from cardan_forces.experiments.environment import number_text
from cardan_forces.experiments.images import (
    PAGE_IN,
    SAME_RTOL,
    TITLE_PT,
    chars_across,
    coinciding,
    format_list,
    save,
    styled,
    typeset,
)

STEPS = 72
"""Instants per revolution (5 deg apart)."""


def requirements(scene: Scene) -> list[str]:
    """What ``scene`` lacks for the handbook comparison, found by structure (the chain's
    order, not names): three shafts joined by two Cardan joints, two bearings at
    different places on the first shaft, a slip joint in the middle shaft (without it the
    middle shaft's axial force, and with it the bearing loads, are not determinate).
    """
    missing = []
    if len(scene.shafts) != 3:
        missing.append(f"three shafts joined by two Cardan joints (it has "
                       f"{len(scene.shafts)} shafts)")
        return missing
    first, middle = scene.shafts[0], scene.shafts[1]
    if len(first.bearings) != 2 or first.bearings[0].offset_m == first.bearings[1].offset_m:
        missing.append(f"two bearings at different places on the first shaft "
                       f"{first.name!r} (it has {len(first.bearings)})")
    if not any(e.shaft == middle.name and kind_of(e).slides for e in scene.elements):
        missing.append(f"a slip joint in the middle shaft {middle.name!r}")
    return missing


def revolution_scene(base: str, arrangement: str, angles_deg: tuple[float, float],
                     torque_N_m: float, steps: int = STEPS) -> Scene:
    """``base`` quasi-static over one input revolution (1 rad/s, so ``t`` = angle), no
    gravity, constant input torque ``torque_N_m`` (N m), the given arrangement and joint
    angles (deg, one per joint).
    """
    parent = load_scene(base)
    if len(angles_deg) != len(parent.joints):
        raise SceneError(f"scene {parent.source}: {len(angles_deg)} joint angles given for "
                         f"{len(parent.joints)} joints")
    joints = tuple(dataclasses.replace(j, articulation_deg=float(a))
                   for j, a in zip(parent.joints, angles_deg))
    return parent.with_changes(
        name=f"{parent.name}-revolution", effects=frozenset(), arrangement=arrangement,
        joints=joints, input_torque=TorqueLaw(float(torque_N_m)), load_torque=TorqueLaw(0.0),
        initial_angle_rad=0.0, initial_speed_rad_s=1.0,
        time=TimeGrid(0.0, 2 * math.pi, 2 * math.pi / steps))


def bearing_loads(op: Operator) -> dict[str, np.ndarray]:
    """Per bearing and instant: ``<shaft>.<bearing>.in_plane`` (along ``r1``) and
    ``.normal`` (along ``r2``, the plane's normal), N, least-norm; NaN where the rigid
    model does not determine it.
    """
    out = {}
    dets = [determinacy(op, i) for i in range(len(op.t))]
    x = np.array([d.min_norm for d in dets])
    for c in op.bearings():
        rows = op.bearing_matrix(c)  # the load in the shaft's frame from the columns
        for label, row in (("in_plane", rows[0]), ("normal", rows[1])):
            free = np.array([np.linalg.norm(row @ d.null_basis) for d in dets])
            out[f"{c.element}.{label}"] = np.where(free < DETERMINATE_TOL, x @ row, np.nan)
    return out


def handbook(torque: float, b1_deg: float, b2_deg: float, arrangement: str, a: float,
             c: float, length: float) -> dict[str, float]:
    """The closed forms of the module docstring (N): input bearings ``normal`` loads at
    0 and 90 deg, and the intermediate shaft's shear ``S`` at 0 deg.
    """
    b1, b2 = math.radians(b1_deg), math.radians(b2_deg)
    sign = -1.0 if arrangement == "Z" else 1.0
    shear = torque * math.cos(b1) * (math.tan(b1) + sign * math.tan(b2)) / length
    couple = torque * math.tan(b1) / a
    # along r2 = -y the bearing forces of the docstring change sign; the spline's shear
    # on the downstream segment balances joint 2's +S y: it is -S y = +S r2
    return {"shear_0": shear, "near_0": shear * (a + c) / a, "far_0": -shear * c / a,
            "near_90": -couple, "far_90": couple}


HANDBOOK_LABEL = "handbook closed form (0 and 90 deg)"
"""The closed forms' legend entry, and their source in ``secondary.csv``."""
PACKAGE_SOURCE = "package (rigid model)"
"""The source of the curves' values in ``secondary.csv``: the rigid model's loads."""
CSV_COLUMNS = ("case", "bearing_load", "angle_deg", "force_N", "source")
"""Columns of ``secondary.csv``: one row per case, load, angle and source."""


def write(results: dict[str, dict[str, np.ndarray]], angle_deg: np.ndarray,
          out: Path, formats=("png",), handbook_marks: dict | None = None,
          title: str = "") -> list[Path]:
    """``secondary.csv`` (long format, every number the figure draws: the package's
    loads, source :data:`PACKAGE_SOURCE`, then the closed forms, source
    :data:`HANDBOOK_LABEL`) and the figure ``secondary.<format>`` (one panel per case,
    titled ``title``) for each of ``formats``; ``handbook_marks`` (case -> load name ->
    ((angle deg, N), ...)): the closed forms, drawn as open markers over the package's
    curves.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    out.mkdir(parents=True, exist_ok=True)
    with files.replacing(out / "secondary.csv", newline="") as f:
        w = csv.writer(f)
        w.writerow(CSV_COLUMNS)
        for case, loads in results.items():
            for name, values in loads.items():
                w.writerows([case, name, f"{q:.6g}", number_text(v, ".9g", ""), PACKAGE_SOURCE]
                            for q, v in zip(angle_deg, values))
        for case, marks in (handbook_marks or {}).items():
            for name, points in marks.items():
                w.writerows([case, name, f"{q:.6g}", number_text(v, ".9g", ""), HANDBOOK_LABEL]
                            for q, v in points)
    with styled():
        fig, axes = plt.subplots(len(results), 1, squeeze=False, figsize=(
            PAGE_IN[0], min(PAGE_IN[1], 2.1 * len(results) + 0.6)))
        colours = {n: f"C{k}" for k, n in enumerate(dict.fromkeys(
            n for loads in results.values() for n in loads))}
        for k, (ax, (case, loads)) in enumerate(zip(axes[:, 0], results.items())):
            _panel(ax, f"({'abcdefgh'[k]}) {case}", angle_deg, loads, colours,
                   (handbook_marks or {}).get(case, {}))
        fig.suptitle(textwrap.fill(typeset(title or "Bearing loads over one revolution"),
                                   chars_across(PAGE_IN[0], TITLE_PT)))
        fig.tight_layout(h_pad=0.8)
        paths = save(fig, out / "secondary", formats)
    plt.close(fig)
    return [out / "secondary.csv", *paths]


def _panel(ax, title: str, angle_deg, loads: dict, colours: dict, marks: dict) -> None:
    """One case: each load drawn once, loads that coincide over the revolution as one
    line labelled with each of their names (found from the data), loads the rigid model
    does not determine named in the title; the handbook's values as open circles.
    """
    drawn = {n: v for n, v in loads.items() if np.isfinite(v).any()}
    scale = max((np.nanmax(np.abs(v)) for v in drawn.values()), default=1.0)
    together = coinciding(drawn, SAME_RTOL * max(scale, 1.0))
    hidden = {n for g in together for n in g[1:]}
    for name, values in drawn.items():
        if name in hidden:
            continue
        group = next((g for g in together if g[0] == name), (name,))
        ax.plot(angle_deg, values, color=colours[name], ls="-" if "normal" in name else "--",
                label=" = ".join(group))
    for k, (name, points) in enumerate(marks.items()):
        x, y = zip(*points)
        ax.plot(x, y, ls="none", marker="o", ms=7, mfc="none", mew=1.2, color="k", zorder=5,
                label=HANDBOOK_LABEL if k == 0 else "_", gid=name)
    missing = [n for n in loads if n not in drawn]
    ax.set_title(title + (f"; not determinate: {', '.join(missing)}" if missing else ""),
                 loc="left")
    ax.set_xlabel("input angle [deg]")
    ax.set_ylabel("bearing force [N]")
    ax.set_xticks(np.arange(0, 361, 45))
    ax.grid(True)
    ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), handlelength=2.0)


CASES = (("Z", (30.0, 30.0)), ("W", (30.0, 30.0)), ("Z", (10.0, 40.0)), ("W", (15.0, 25.0)))
"""(arrangement, joint angles in deg) of ``cardan secondary``: equal and unequal angles."""


def revolutions(base: str = "paper-slip", torque: float = 100.0, out: Path | None = None,
                cases=CASES, formats=("png",)) -> dict[str, dict[str, np.ndarray]]:
    """Bearing loads over one revolution for each (arrangement, angles) case, by case
    name (``"Z 30/30 deg"``); with ``out``, also ``secondary.csv`` and the figure in
    each of ``formats`` there, the handbook's values over the package's curves.
    """
    results, marks = {}, {}
    for arrangement, angles in cases:
        scene = revolution_scene(base, arrangement, angles, torque)
        op = build_operator(simulate(scene))
        name = _case_name(arrangement, angles)
        results[name] = bearing_loads(op)
        marks[name] = handbook_points(scene, torque)
    if out is not None:
        write(results, np.degrees(scene.time.instants()), Path(out), formats, marks,
              f"Secondary-couple bearing loads over one revolution: scene {load_scene(base).name}, "
              f"constant input torque {number_text(torque, 'g')} N m (quasi-static, no gravity)")
    return results


def handbook_points(scene: Scene, torque: float) -> dict[str, tuple]:
    """The handbook's values (:func:`handbook`) as the package names its loads: the
    first shaft's bearings' ``normal`` loads (N) at input angles 0 and 90 deg, as
    ``{load: ((0, N), (90, N))}``; ``scene`` a :func:`revolution_scene`.
    """
    first = scene.shafts[0]
    near, far = sorted(first.bearings, key=lambda b: b.offset_m, reverse=True)
    a, c = near.offset_m - far.offset_m, first.length_m / 2 - near.offset_m
    angles = tuple(j.articulation_deg for j in scene.joints)
    expect = handbook(torque, *angles, scene.arrangement, a, c, scene.shafts[1].length_m)
    return {f"{first.name}.{b.name}.normal": ((0, expect[f"{key}_0"]), (90, expect[f"{key}_90"]))
            for key, b in (("near", near), ("far", far))}


def _case_name(arrangement: str, angles) -> str:
    return f"{arrangement} {angles[0]:g}/{angles[1]:g} deg"


def add_parser(subparsers) -> None:
    """Register ``cardan secondary``."""
    p = subparsers.add_parser("secondary", help="secondary-couple bearing loads over one "
                              "revolution (Z and W, equal and unequal angles) against the "
                              "handbook closed forms")
    p.add_argument("scene", nargs="?", default="paper-slip",
                   help="three shafts, two bearings on the first, a slip joint in the "
                        "middle one (default paper-slip)")
    p.add_argument("--torque", type=float, default=100.0,
                   help="constant input torque, N m (default 100)")
    p.add_argument("--out", type=files.folder, default="results/secondary",
                   help="output folder (default %(default)s)")
    p.add_argument("--format", type=format_list, default=("png",), metavar="FORMATS",
                   help="figure formats, comma-separated: png, svg, pdf (default png)")
    p.set_defaults(func=run)


def run(args) -> int:
    """``cardan secondary``: loads over one revolution to CSV + PNG; the closed forms at 0
    and 90 deg beside the package's numbers on stdout. A scene without the handbook's
    layout is refused before any work (SceneError).
    """
    scene = load_scene(args.scene)
    missing = requirements(scene)
    if missing:
        raise SceneError(f"scene {scene.source}: cardan secondary compares bearing loads with "
                         f"the handbook's closed forms and needs {'; '.join(missing)}")
    limit = LIMITS["torque_N_m"][1]
    if not (math.isfinite(args.torque) and abs(args.torque) <= limit):
        raise SceneError(f"--torque {args.torque}: must be a finite number of at most "
                         f"{limit:g} N m in magnitude")
    results = revolutions(args.scene, args.torque, Path(args.out), formats=args.format)
    first = scene.shafts[0]
    near, far = sorted(first.bearings, key=lambda b: b.offset_m, reverse=True)
    a, c = near.offset_m - far.offset_m, first.length_m / 2 - near.offset_m
    print(f"constant input torque {number_text(args.torque, 'g')} N m, quasi-static, no "
          f"gravity; each row: the force of a bearing of the first shaft {first.name!r} on it "
          "along r2 (the normal to the articulation plane), N, at input angle 0 and 90 deg; "
          f"{near.name!r} is the bearing nearer to joint {scene.joints[0].name!r}; "
          "'-': not determinate")
    print(f"{'case':16s} {'bearing':12s} {'angle deg':>9s} {'handbook N':>12s} "
          f"{'package N':>12s}")
    for (arrangement, angles), loads in zip(CASES, results.values()):
        expect = handbook(args.torque, *angles, arrangement, a, c, scene.shafts[1].length_m)
        for key, bearing, i in (("near_0", near, 0), ("far_0", far, 0),
                                ("near_90", near, STEPS // 4), ("far_90", far, STEPS // 4)):
            got = loads[f"{first.name}.{bearing.name}.normal"][i]
            print(f"{_case_name(arrangement, angles):16s} {bearing.name:12s} "
                  f"{360 * i // STEPS:9d} {number_text(expect[key], '12.4f')} "
                  f"{number_text(got, '12.4f')}")
    out = Path(args.out)
    files.say_written("secondary", [out / "secondary.csv",
                                    *(out / f"secondary.{f}" for f in args.format)])
    return 0
