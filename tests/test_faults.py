"""Faults and odd requests that once ended in a traceback, a silent success or a hung
run: each is constructed here and must end with a clear message, a failed record or a
clean result.
"""

from __future__ import annotations

import numpy as np
import pytest
from cardan_forces.experiments import engine

import cardan_forces as cf


def test_engine_comparison_passes_over_backends_that_cannot_take_a_friction_cone():
    """On a line with slip-joint friction the signed formulations are conic: the QP
    backends first in line cannot take them and the next backend solves them, and the
    forces found satisfy the equilibrium (A x = b).
    """
    scene = cf.load_scene("paper-penalty")
    op = cf.build_operator(cf.simulate(scene, [scene.time.start_s + 0.1]))
    forces = engine._formulation_forces(op, 0)
    x = forces["positive"]
    assert np.linalg.norm(op.A[0] @ x - op.b[0]) <= 1e-6 * np.linalg.norm(op.b[0])


KERNEL = '''
from cardan_forces.util.compiled import njit


@njit(cache=True)
def twice(x):
    return 2.0 * x


print(twice(21.0))
'''


def _run_kernel(folder, cache):
    """Run a module with one cached kernel in a new process, its numba cache in
    ``cache``: (exit code, stdout, stderr)."""
    import os
    import subprocess
    import sys

    env = dict(os.environ, NUMBA_CACHE_DIR=str(cache), PYTHONPATH=str(folder))
    done = subprocess.run([sys.executable, "-c", "import kernel_module"], env=env,
                          capture_output=True, text=True, timeout=300)
    return done.returncode, done.stdout, done.stderr


@pytest.mark.slow
@pytest.mark.parametrize("suffix, corrupt", [  # one index and one data file by default
    (".nbi", lambda text: b"\x80\x04garbage" + text[:7]),  # an unpickling error
    pytest.param(".nbi", lambda text: b"\x80\x04\x95" + b"\xff" * 8 + text[11:],
                 marks=pytest.mark.slow),  # a huge length
    (".nbc", lambda text: text[: len(text) // 2]),  # cut short: EOFError
    pytest.param(".nbc", lambda text: b"", marks=pytest.mark.slow),  # empty
], ids=["index-garbage", "index-huge-length", "data-cut-short", "data-empty"])
def test_a_corrupted_numba_cache_file_is_rebuilt_with_one_warning(tmp_path, suffix, corrupt):
    """A kernel's cache index or data file overwritten with bytes numba cannot read:
    the next run computes the right answer (compiling again), warns once, and leaves
    a cache the run after reads without a warning."""
    pytest.importorskip("numba")
    (tmp_path / "kernel_module.py").write_text(KERNEL)
    cache = tmp_path / "numba_cache"
    code, out, err = _run_kernel(tmp_path, cache)
    assert (code, out.strip()) == (0, "42.0"), err
    found = list(cache.rglob(f"*{suffix}"))
    assert found, "numba wrote no cache file"
    for path in found:
        path.write_bytes(corrupt(path.read_bytes()))
    code, out, err = _run_kernel(tmp_path, cache)
    assert (code, out.strip()) == (0, "42.0"), err
    assert "Traceback" not in err and err.count("compile again") == 1, err
    code, out, err = _run_kernel(tmp_path, cache)
    assert (code, out.strip(), err) == (0, "42.0", "")
