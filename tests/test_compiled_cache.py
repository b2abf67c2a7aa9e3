"""The package's ``njit`` keys a kernel's disk cache also by the source files it
declares it depends on: editing one of them compiles the kernel again instead of
loading a cached copy that inlined the old code.
"""

from __future__ import annotations

import os
import subprocess
import sys

import pytest

HELPER = '''
from cardan_forces.util.compiled import njit


@njit(inline="always")
def offset(x):
    return x + {step}
'''

KERNEL = '''
from cardan_forces.util.compiled import njit
from helper_module import offset


@njit(cache=True, depends=("helper_module.py",))
def shifted(x):
    return offset(x)


value = shifted(1.0)
print(value, shifted.stats.cache_hits.get(shifted.signatures[0], 0))
'''


def _run(folder, cache):
    """Import the kernel module in a new process, its numba cache in ``cache``:
    (the kernel's value, whether it was loaded from the cache)."""
    env = dict(os.environ, NUMBA_CACHE_DIR=str(cache), PYTHONPATH=str(folder))
    done = subprocess.run([sys.executable, "-c", "import kernel_module"], env=env,
                          capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    value, hits = done.stdout.split()
    return float(value), int(hits) > 0


@pytest.mark.slow
def test_a_kernel_is_compiled_again_when_a_file_it_depends_on_changes(tmp_path):
    """A cached kernel that inlines a function of another file: loaded from the cache
    while nothing changes, compiled again (with the new function) once that file is
    edited, and loaded again after that."""
    pytest.importorskip("numba")
    (tmp_path / "kernel_module.py").write_text(KERNEL)
    (tmp_path / "helper_module.py").write_text(HELPER.format(step="1.0"))
    cache = tmp_path / "numba_cache"
    assert _run(tmp_path, cache) == (2.0, False)
    assert _run(tmp_path, cache) == (2.0, True)
    (tmp_path / "helper_module.py").write_text(HELPER.format(step="2.0"))
    assert _run(tmp_path, cache) == (3.0, False)
    assert _run(tmp_path, cache) == (3.0, True)


RATIO = '''
import os

from cardan_forces.util.compiled import njit


@njit(cache=True, error_model=os.environ["ERROR_MODEL"])
def ratio(x, y):
    return x / y


try:
    value = ratio(1.0, 0.0)
except ZeroDivisionError:
    value = "raised"
print(value, ratio.stats.cache_hits.get(ratio.signatures[0], 0))
'''


@pytest.mark.slow
def test_a_kernel_compiled_with_other_options_is_not_loaded_from_the_cache(tmp_path):
    """numba's own key leaves the error model out: the same source, cached under
    Python's model (raising on a division by zero), is not loaded for NumPy's (inf),
    nor back."""
    pytest.importorskip("numba")
    cache = tmp_path / "numba_cache"
    (tmp_path / "kernel_module.py").write_text(RATIO)
    for model, expected in (("python", "raised"), ("numpy", "inf"), ("python", "raised")):
        env = dict(os.environ, NUMBA_CACHE_DIR=str(cache), PYTHONPATH=str(tmp_path),
                   ERROR_MODEL=model)
        done = subprocess.run([sys.executable, "-c", "import kernel_module"], env=env,
                              capture_output=True, text=True, timeout=300)
        assert done.returncode == 0, done.stderr
        assert done.stdout.split()[0] == expected


def test_a_declared_dependency_that_does_not_exist_fails_at_import(tmp_path):
    """A kernel that names a missing file fails when its module is imported (a
    declaration that could never invalidate anything is an error, not a no-op)."""
    pytest.importorskip("numba")
    from cardan_forces.util.compiled import njit

    with pytest.raises(FileNotFoundError):
        njit(cache=True, depends=("no_such_file.py",))(lambda x: x)


def test_every_penalty_kernel_is_keyed_by_every_penalty_kernel_file():
    """The penalty integrator inlines kernels of several files: each of their cached
    kernels is keyed by the contents of all of them (so an edit of one cannot leave a
    stale integrator), and every file that holds one is among those listed."""
    numba = pytest.importorskip("numba")
    from cardan_forces.driveline import (
        penalty_bdf,
        penalty_contact,
        penalty_jacobian,
        penalty_linear,
    )

    from cardan_forces.util import compiled

    files = penalty_contact.KERNEL_FILES
    expected = compiled._files_hash(penalty_contact.__file__, files)
    found = 0
    for module in (penalty_contact, penalty_jacobian, penalty_linear, penalty_bdf):
        assert os.path.basename(module.__file__) in files
        for value in vars(module).values():
            if isinstance(value, numba.core.dispatcher.Dispatcher) \
                    and value.py_func.__module__ == module.__name__:
                assert value._cache._depends_hash == expected, value.py_func.__name__
                found += 1
    assert found >= 40


WHERE = '''
import os
import numba
from cardan_forces.driveline.harmonic import harmonic
index = harmonic._cache._cache_file._index_path
print(numba.config.CACHE_DIR, os.environ["NUMBA_CACHE_DIR"], index, sep="\\n")
'''


@pytest.mark.parametrize("given, expected, numba_first", [
    ("relative/cache", "{cwd}/relative/cache", False),
    ("relative/cache", "{cwd}/relative/cache", True),
    ("~/cache", "{home}/cache", True),
    ("~", "{home}", False),
    ("{cwd}/absolute", "{cwd}/absolute", False)])
def test_the_numba_cache_folder_is_absolute_with_home_expanded(tmp_path, given, expected,
                                                               numba_first):
    """A relative ``NUMBA_CACHE_DIR`` or one that starts with ``~``: numba's cache is in
    that folder, resolved from the working folder and the home folder (not a folder
    named ``~``), whether or not numba was imported first; processes started from it
    get the same."""
    pytest.importorskip("numba")
    home, cwd = tmp_path / "home", tmp_path / "work"
    cwd.mkdir()
    env = dict(os.environ, HOME=str(home), NUMBA_CACHE_DIR=given.format(cwd=cwd))
    script = ("import numba\n" if numba_first else "") + WHERE
    done = subprocess.run([sys.executable, "-c", script], env=env, cwd=cwd,
                          capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    config, environ, index = done.stdout.split("\n")[:3]
    folder = expected.format(cwd=cwd, home=home)
    assert config == environ == folder
    assert index.startswith(folder + os.sep)
    assert not (cwd / "~").exists()
