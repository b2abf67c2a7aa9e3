"""The bench's performance targets, a developer's check kept out of what users read:
``report.md``, ``--json`` and the Benchmarks page carry measurements only, and a quick
bench is held to the targets by ``pytest -m targets`` on the developer's machine.
"""

from __future__ import annotations

import json
import time

import pytest
from cardan_forces.experiments import bench, bench_targets

from cardan_forces.cli import main


def _run(summary, success=(), conic=(), wall_s=None) -> dict:
    return {t["name"]: t for t in bench_targets.targets(list(summary), list(success),
                                                        set(conic), wall_s)}


def test_a_target_is_met_or_not_by_its_measured_value():
    """The wall time's target is met below its bound, not above, and not judged when
    not measured."""
    name = "wall time of the run (s)"
    assert _run([], wall_s=bench_targets.WALL_S / 2)[name]["met"] is True
    assert _run([], wall_s=bench_targets.WALL_S * 2)[name]["met"] is False
    assert _run([])[name]["met"] is None


def test_the_outputs_carry_no_target(tmp_path, capsys):
    assert main(["bench", "--quick", "--formulation", "min_norm", "--solver", "numpy-kkt",
                 "--json", "--out", str(tmp_path), "--quiet"]) == 0
    printed = json.loads(capsys.readouterr().out)
    report = (tmp_path / "report.md").read_text()
    assert "targets" not in printed
    assert "target" not in report.lower() and "NOT met" not in report
    assert "Solved: the share of instants whose record the package calls solved" in report


@pytest.mark.targets
def test_a_quick_bench_meets_every_target(tmp_path, monkeypatch, capsys):
    """Every target of :func:`bench_targets.targets` met by ``cardan bench --quick`` on
    this machine (a developer's check: ``pytest -m targets``)."""
    found = {}
    evaluate = bench.evaluate

    def kept(measured, ladder):
        found["results"] = evaluate(measured, ladder)
        return found["results"]

    monkeypatch.setattr(bench, "evaluate", kept)
    started = time.perf_counter()
    assert main(["bench", "--quick", "--out", str(tmp_path), "--quiet"]) == 0
    results = found["results"]
    rows = bench_targets.targets(results["summary"], results["success"], results["conic"],
                                 time.perf_counter() - started)
    unmet = [f"{t['name']}: {t['value']} (wanted {t['wanted']:g})" for t in rows
             if t["met"] is False]
    assert not unmet, "\n".join(unmet)


def test_the_solved_sentence_names_the_backends_that_left_instants_unsolved():
    from cardan_forces.experiments.bench_report import solved_sentence
    from cardan_forces.solvers.record import ACCEPT

    rows = [{"solver": "qpsolvers-osqp", "success_rate": 0.0},
            {"solver": "clarabel", "success_rate": 0.61},
            {"solver": "numpy-batched", "success_rate": 1.0}]
    text = solved_sentence(rows)
    assert text.endswith("(here: clarabel, qpsolvers-osqp).")
    assert f"within {ACCEPT:.0e}".replace("e-0", "e-") in text
    assert solved_sentence(rows[2:]).endswith("(none here).")
