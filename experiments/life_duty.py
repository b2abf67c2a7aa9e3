"""Duty cycles in ``cardan life``: the load spectrum a run rates, each bin's steady
state, and the bins' lives combined into the bearing's.

- The spectrum (:func:`spectrum`): the scene's ``[[duty_cycle]]`` bins, or the run's:
  a TOML file of ``[[duty_cycle]]`` bins (``--duty-cycle``) or one bin at the scene's
  mean input torque and a given speed (``--speed-rpm``), each read by the scene's own
  reader (:func:`~cardan_forces.driveline.duty.read_duty_cycle`), so a bad bin is
  refused in one line naming the field.
- A bin's steady state (:func:`bin_scene`): the scene made quasi-static (its
  ``inertia``, ``crosspin_inertia`` and ``penalty_dynamics`` effects dropped: the
  input turns at the bin's speed and the load balances the bin's torque,
  :mod:`~cardan_forces.driveline.dynamics`), over one input revolution, so that every
  angle-dependent load of the joints is seen, at instants spread evenly over it
  without the repeated end point (each stands for the same stretch of the revolution).
- The bins combined (:func:`combine`) by Palmgren-Miner over the revolutions each bin
  takes (:func:`~cardan_forces.driveline.duty.revolution_shares`): the mean load
  ``Pm = (sum u_i Pm_i^p)^(1/p)``, ISO 281's variable-load mean over the bins, hence
  ``L10 = (C / Pm)^p = 1 / sum (u_i / L10_i)``; ISO 281:2007's modified life per bin
  (``a_ISO`` from that bin's ``Pm`` and speed, :func:`~cardan_forces.driveline.
  bearing_life.modified_life`) and ``1 / L_nm = sum u_i / L_nm,i``; hours only at
  the spectrum's mean speed. The rigid set's worst (best) life combines each bin's
  worst (best): the set is independent instant by instant, so the combined ends are
  as exact as each instant's are.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
from cardan_forces.driveline import bearing_life as iso
from cardan_forces.driveline import duty
from cardan_forces.driveline.loading import scene_from_dict
from cardan_forces.driveline.scene import DutyBin, Scene, SceneError, TimeGrid, TorqueLaw

try:
    import tomllib
except ModuleNotFoundError:  # Python 3.10
    import tomli as tomllib

DYNAMIC = frozenset({"inertia", "crosspin_inertia", "penalty_dynamics"})
"""The effects a bin's steady state drops: the quasi-static line has no d'Alembert
loads, and no penalty simulation."""

NOT_RUN = ("not run: a duty cycle's bins are steady states of the quasi-static line, and "
           "this selection simulates the dynamic one (its start-up); run without a duty "
           "cycle to rate it over the scene's window")
"""Why a simulated selection is not run on a duty cycle."""

NO_HOURS = ("no hours: without a duty cycle the scene's window is a start-up, not the "
            "bearing's service; give the scene [[duty_cycle]] bins, or run with "
            "--duty-cycle FILE or --speed-rpm N")
"""Why a life rated over the scene's window has no hours."""

NO_SPEED = ("no a_ISO: ISO 281:2007's life modification factor needs the bearing's "
            "operating speed (for its viscosity ratio), which a start-up window does not "
            "give; give a duty cycle")
"""Why a life rated over the scene's window has no modified life."""


def spectrum(scene_spec: str, scene: Scene, duty_file: str | None = None,
             speed_rpm: float | None = None) -> tuple[tuple[DutyBin, ...], str]:
    """The bins a run rates and where they come from: ``duty_file``'s, else one bin at
    ``speed_rpm`` and the scene's mean input torque, else the scene's own (none: an
    empty tuple, the window is rated). Either of the run's is read as the bins of the
    scene ``scene_spec`` extended by them, so by the scene's reader (SceneError, one
    line, for a bad one).
    """
    if duty_file is not None:
        return _read(scene_spec, _bins_of(Path(duty_file)), duty_file), f"file {duty_file}"
    if speed_rpm is not None:
        one = {"torque_N_m": scene.input_torque.mean_N_m, "speed_rpm": speed_rpm,
               "share": 1.0}
        return (_read(scene_spec, [one], "--speed-rpm"),
                f"--speed-rpm {speed_rpm:g} at the scene's mean input torque")
    return scene.duty_cycle, "the scene's [[duty_cycle]]"


def _bins_of(path: Path) -> list:
    """The ``[[duty_cycle]]`` tables of a duty-cycle file as TOML gives them; refused
    (SceneError) where the file cannot be read, is not TOML, holds anything else or
    no bin.
    """
    where = f"duty cycle {path}"
    try:
        raw = tomllib.loads(path.read_bytes().decode("utf-8-sig"))
    except OSError as err:
        raise SceneError(f"{where}: cannot be read: {err.strerror}") from None
    except UnicodeDecodeError:
        raise SceneError(f"{where}: not UTF-8 text; TOML files are UTF-8") from None
    except tomllib.TOMLDecodeError as err:
        raise SceneError(f"{where}: not valid TOML: {err}") from None
    other = sorted(set(raw) - {"duty_cycle"})
    if other:
        raise SceneError(f"{where}: holds {', '.join(other)}; a duty-cycle file holds "
                         "[[duty_cycle]] tables only")
    if not raw.get("duty_cycle"):
        raise SceneError(f"{where}: holds no [[duty_cycle]] bin")
    return raw["duty_cycle"]


def _read(scene_spec: str, tables, source: str) -> tuple[DutyBin, ...]:
    """``tables`` read as the ``[[duty_cycle]]`` of scene ``scene_spec``."""
    return scene_from_dict({"extends": scene_spec, "duty_cycle": tables}, source).duty_cycle


def bin_scene(scene: Scene, duty_bin: DutyBin, instants: int) -> tuple[Scene, np.ndarray]:
    """The steady state of ``duty_bin`` (module doc) and its ``instants`` instants (s):
    ``k T / instants`` for ``k < instants`` over the input's period ``T = 60 / n``.
    """
    speed = duty_bin.speed_rpm * 2.0 * math.pi / 60.0
    period = 2.0 * math.pi / speed
    variant = scene.with_changes(
        effects=scene.effects - DYNAMIC, input_torque=TorqueLaw(duty_bin.torque_N_m),
        initial_speed_rad_s=speed, time=TimeGrid(0.0, period, period / instants))
    return variant, period * np.arange(instants) / instants


def revolutions(omega: np.ndarray, period_s: float) -> np.ndarray:
    """Revolutions of a shaft turning at ``omega`` (rad/s) over each instant's stretch
    of :func:`bin_scene`'s evenly spread instants (``period_s / len(omega)`` each).
    """
    return np.abs(np.asarray(omega, float)) * (period_s / len(omega)) / (2.0 * math.pi)


def modified(rating, life: dict, speed_rpm: float, reliability: float) -> dict:
    """``life`` (``Pm_N``, ``L10_Mrev``) of one bin with ISO 281:2007's ``a_ISO``,
    ``kappa`` and ``L_nm_Mrev`` at the bin's ``speed_rpm`` and ``modified_reason``
    where they have no value.
    """
    found = iso.modified_life(rating, life["L10_Mrev"], life["Pm_N"], speed_rpm,
                              reliability)
    return {"a_ISO": found["a_ISO"], "kappa": found["kappa"],
            "L_nm_Mrev": found["L_nm_Mrev"], "modified_reason": found["reason"]}


def combine(rating, lives: list[dict], u: np.ndarray, mean_speed_rpm: float) -> dict:
    """One life over the spectrum from the bins' ``lives`` (each ``Pm_N``,
    ``L10_Mrev``, ``L_nm_Mrev``, ``a_ISO``, ``reason``, ``modified_reason``) taking the
    revolution shares ``u``: ``Pm``, ``L10`` and ``L_nm`` by Palmgren-Miner, each in
    hours at ``mean_speed_rpm``, ``a_ISO`` per bin, and the bins' reasons where the
    combined life has no finite value.
    """
    pm = iso.mean_load([v["Pm_N"] for v in lives], u, iso.exponent(rating))
    l10 = iso.rating_life(rating, pm)
    l_nm = duty.miner_life([v["L_nm_Mrev"] for v in lives], u)
    per_second = np.array([mean_speed_rpm / 60.0])  # the revolutions of one second
    finite = math.isfinite(pm) and math.isfinite(l10)
    return {"Pm_N": pm, "L10_Mrev": l10, "L10_h": iso.life_hours(l10, per_second, 1.0),
            "L_nm_Mrev": l_nm, "L_nm_h": iso.life_hours(l_nm, per_second, 1.0),
            "a_ISO": [v["a_ISO"] for v in lives],
            "reason": None if finite else bins_reason([v["reason"] for v in lives]),
            "modified_reason": (None if math.isfinite(l_nm) else
                                bins_reason([v["modified_reason"] for v in lives]))}


def bins_reason(reasons: list[str | None]) -> str | None:
    """The bins' distinct ``reasons``, each after the bins (numbered from 1) that give
    it, in one line; ``None`` where no bin gives one.
    """
    found: dict[str, list[str]] = {}
    for k, why in enumerate(reasons):
        if why:
            found.setdefault(why, []).append(str(k + 1))
    return "; ".join(f"{'bins' if len(ks) > 1 else 'bin'} {', '.join(ks)}: {why}"
                     for why, ks in found.items()) or None


def bearing_over_bins(rating, of_bins: list[dict], bins: tuple, reliability: float) -> dict:
    """One bearing over a duty cycle from its entries ``of_bins`` of each bin (as
    ``cardan life`` rates a window): each bin's lives with ISO 281:2007's modified life
    at the bin's speed (for ``reliability``, %), each selection's and the set's ends
    combined over the bins (:func:`combine`), the loads' ranges, ``kappa`` per bin and
    the minimum-load check over every bin. Whether each selection's combined life lies
    in the set's is the caller's check.
    """
    speeds = [e["mean_speed_rpm"] for e in of_bins]
    u, mean = duty.revolution_shares(bins, speeds), duty.mean_speed_rpm(bins, speeds)
    for e, n in zip(of_bins, speeds):
        for sel in e["selections"].values():
            sel.update(modified(rating, sel, n, reliability))
        _modified_ends(rating, e["interval"], n, reliability)
    first = of_bins[0]
    return {
        "bearing": first["bearing"], "kind": first["kind"], "rating": first["rating"],
        "speed_rpm": speeds, "mean_speed_rpm": mean, "revolution_shares": u,
        "kappa": [e["interval"]["kappa"] for e in of_bins],
        "kappa_reason": bins_reason([e["interval"]["modified_reason"][1]
                                     if math.isnan(e["interval"]["kappa"]) else None
                                     for e in of_bins]),
        "load_range": _ranges_over([e["load_range"] for e in of_bins]),
        "selections": {name: {**combine(rating, [e["selections"][name] for e in of_bins],
                                        u, mean),
                              "axial_instants": sum(e["selections"][name]["axial_instants"]
                                                    for e in of_bins)}
                       for name in first["selections"]},
        "peak_P_over_C": max(e["peak_P_over_C"] for e in of_bins),
        "minimum_load": _minimum_over([e["minimum_load"] for e in of_bins]),
        "interval": _interval_over(rating, [e["interval"] for e in of_bins], u, mean),
        "bins": [{k: v for k, v in e.items() if k not in ("bearing", "kind", "rating")}
                 for e in of_bins],
    }


def _interval_over(rating, intervals: list[dict], u: np.ndarray, mean: float) -> dict:
    """The set's interval over the bins: its worst life combines each bin's worst, its
    best each bin's best (:func:`combine`); open where a bin's is.
    """
    worst, best = (combine(rating, [_end(i, k) for i in intervals], u, mean) for k in (0, 1))
    return {"Pm_N": [best["Pm_N"], worst["Pm_N"]],
            **{key: [worst[key], best[key]]
               for key in ("L10_Mrev", "L10_h", "L_nm_Mrev", "L_nm_h", "a_ISO", "reason",
                           "modified_reason")},
            "open": any(i["open"] for i in intervals),
            "radial_determinate": all(i["radial_determinate"] for i in intervals),
            "ends": "; ".join(dict.fromkeys(i["ends"] for i in intervals))}


def _minimum_over(checks: list[dict]) -> dict:
    """The bins' minimum-load checks as one: the least ``P / C`` of any bin and the
    bins (numbered from 1) below the rule.
    """
    below = [k + 1 for k, c in enumerate(checks) if c["below"]]
    least = [c["least_P_over_C"] for c in checks if not math.isnan(c["least_P_over_C"])]
    return {"rule_P_over_C": checks[0]["rule_P_over_C"],
            "least_P_over_C": min(least, default=math.nan), "below": bool(below),
            "bins": below}


def _modified_ends(rating, interval: dict, speed_rpm: float, reliability: float) -> None:
    """A bin's set interval with the modified life of its worst and best ends, and the
    viscosity ratio ``kappa`` at the bin's speed (one for the bearing and bin).
    """
    found = [modified(rating, _end(interval, k), speed_rpm, reliability)
             for k in (0, 1)]
    interval.update({key: [f[key] for f in found]
                     for key in ("a_ISO", "L_nm_Mrev", "modified_reason")})
    interval["kappa"] = found[1]["kappa"]


def _end(interval: dict, k: int) -> dict:
    """The set's worst (``k`` 0) or best (1) life of an interval, as one life."""
    found = {"Pm_N": interval["Pm_N"][1 - k], "L10_Mrev": interval["L10_Mrev"][k],
             "reason": interval["reason"][k]}
    if "L_nm_Mrev" in interval:
        found.update({key: interval[key][k]
                      for key in ("a_ISO", "L_nm_Mrev", "modified_reason")})
    return found


def _ranges_over(ranges: list[dict]) -> dict:
    """The loads' ranges of every bin as one (:func:`_load_range`)."""
    found = {key: [min(r[key][0] for r in ranges), max(r[key][1] for r in ranges)]
             for key in ("Fr_N", "Fa_N")}
    reasons = [r["reason"] for r in ranges if r["reason"]]
    return {**found, "reason": reasons[0] if reasons else None}
