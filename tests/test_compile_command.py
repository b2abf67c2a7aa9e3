"""``cardan compile`` compiles what a first run would: the penalty simulation's kernels
(through the same call a simulation makes) and the batched solvers' kernels."""

import argparse

import pytest
from cardan_forces.driveline import penalty

from cardan_forces.commands import compile as compile_command

pytestmark = pytest.mark.compiled  # also run for a generic CPU by .ci/run


def test_compile_runs_the_penalty_model_and_a_batch(monkeypatch):
    pytest.importorskip("numba")
    calls = []
    monkeypatch.setattr(penalty, "simulate_penalty",
                        lambda scene, times, **kw: calls.append((scene.name, list(times))))
    assert compile_command.run(argparse.Namespace()) == 0
    assert calls and calls[0][0] == "paper-penalty"
    from cardan_forces.solvers import _batched_kernels

    assert _batched_kernels.least_norm.signatures  # compiled (or loaded) by the batch
