"""Backend ``qocogen``: a QOCO solver generated in C for one batch structure (qocogen).

qocogen writes a custom interior-point solver (QOCO's algorithm) for one sparsity of
``P``, ``A``, ``G`` and one cone layout: the KKT factorization is unrolled for that
pattern, so a solve has no symbolic work and no Python between iterations. This module
generates it once per structure, compiles it with a small driver that solves every
instant of a batch in one C call (each instant's numbers replace the last), with a
line search that computes QOCO's bisected step in closed form (:data:`STEP`), and keeps
the shared library in a user cache directory named by a hash of the structure, its
nonzero patterns beside it: a later process loads it instead of compiling it again, and
a batch of other instants whose nonzeros a cached solver's patterns hold (the union
over fewer instants of the same problem) is solved by that solver, its extra entries
zeros (a compilation is reported in the ``compile`` stage, never in a solve's time).

It is registered only as ``qocogen-reduced`` (``Backend.reduced_only``): on the full
form the equality rows are dense, so the unrolled factor is large (several times the
code, and as many times longer to compile) and a solve several times slower than on
the reduced form.

The answer does not depend on the order of the instants: the generated solver starts
every solve from its own initial point and does no equilibration (``ruiz_iters`` 0), and
the driver clears the status and iteration count before each. Like ``qoco`` it has no
certificate of infeasibility, so a "solved" whose own dual residual or gap exceeds
:data:`.qoco_form.CLAIM_TOL` is reported inaccurate. Optional extra ``qocogen``; absent
without qocogen or a C compiler.
"""

from __future__ import annotations

import contextlib
import ctypes
import functools
import hashlib
import io
import os
import shutil
import subprocess
import tempfile
import time
from pathlib import Path

import numpy as np
from cardan_forces.formulations.batch import ConicBatch

from . import qoco_form, settings
from .backend import Backend, dist_version
from .qoco_form import CLAIM_TOL, csc_ones, layout
from .record import BatchOutcome, Status

EXTRAS: dict[str, str | None] = {"qocogen-reduced": "qocogen"}

SETTINGS = ("max_iters", "bisect_iters", "iter_ref_iters", "kkt_static_reg",
            "kkt_dynamic_reg", "abstol", "reltol", "abstol_inacc", "reltol_inacc")
"""Settings of the generated solver an option may set (the others keep its defaults)."""

DEFAULTS = {"iter_ref_iters": 0, "bisect_iters": 7}
"""Settings that differ from the generated solver's own defaults (an option overrides
them). No iterative refinement of the KKT solves: on the built-in scenes it changes no
status or iteration count and leaves the package's measures at the same levels, at a
sizeable share of the solve's time; badly scaled cases (``cardan hard``) lose some
accuracy without it, and an instant it would have saved is solved again with
:data:`REFINED`. Steps on a grid of 2^-7 instead of QOCO's 2^-5 (free with
:data:`STEP`: the grid does not set the number of passes) take fewer iterations and
solve more instants (the measurements: CHANGELOG)."""

REFINED = {"iter_ref_iters": 1, "bisect_iters": 5}
"""The generated solver's own defaults, with which an instant that :data:`DEFAULTS`
leave unsolved is solved again (its iterations are added to the first attempt's): under
very large loads (``cardan hard``) the step can fall below 1e-8 without refinement and
the solve stop with a "numerical error"; refined, such instants are solved."""

STATUS = {1: Status.SOLVED, 2: Status.INACCURATE, 4: Status.INACCURATE}
"""Generated solver status -> ours; anything else is failed."""

NAMES = ("unsolved", "solved", "solved inaccurate", "numerical error", "max iterations")
"""The generated solver's status codes, by value."""

CFLAGS = ("-O3", "-fno-math-errno", "-fPIC", "-shared")
"""Portable flags (no ``-march=native``: the cache may be shared between machines).
``-fno-math-errno``: a square root is one instruction, without the call that would set
``errno`` for a negative argument (nothing reads it); the same answers to the bit."""

DRIVER = r"""
#include <stdlib.h>
#include <string.h>
#include "qoco_custom.h"

/* Every instant of a batch with one workspace: its numbers replace the last ones. */
int cardan_solve_batch(int T, int nP, int nA, int nG, const double* P, const double* c,
                       const double* A, const double* b, const double* G, const double* h,
                       const double* opts, double* x, double* y, double* z, int* iters,
                       int* status, double* info) {
   Workspace* w = calloc(1, sizeof(Workspace));
   if (!w) return 1;
   set_default_settings(w);
   load_data(w);
   Settings* s = &w->settings;
   int* ints[] = {&s->max_iters, &s->bisect_iters, &s->iter_ref_iters};
   double* reals[] = {&s->kkt_static_reg, &s->kkt_dynamic_reg, &s->abstol, &s->reltol,
                      &s->abstol_inacc, &s->reltol_inacc};
   for (int i = 0; i < 3; ++i) if (opts[i] == opts[i]) *ints[i] = (int)opts[i];
   for (int i = 0; i < 6; ++i) if (opts[3 + i] == opts[3 + i]) *reals[i] = opts[3 + i];
   s->verbose = 0;
   int n = w->n, p = w->p, m = w->m;
   for (long t = 0; t < T; ++t) {
      if (nP) update_P(w, (double*)P + t * nP);
      if (nA) update_A(w, (double*)A + t * nA);
      if (nG) update_G(w, (double*)G + t * nG);
      update_c(w, (double*)c + t * n);
      if (p) update_b(w, (double*)b + t * p);
      if (m) update_h(w, (double*)h + t * m);
      w->sol.iters = 0;
      w->sol.status = QOCO_CUSTOM_UNSOLVED;
      qoco_custom_solve(w);
      memcpy(x + t * n, w->x, sizeof(double) * n);
      if (p) memcpy(y + t * p, w->y, sizeof(double) * p);
      if (m) memcpy(z + t * m, w->z, sizeof(double) * m);
      iters[t] = w->sol.iters;
      status[t] = w->sol.status;
      info[3 * t] = w->sol.obj; info[3 * t + 1] = w->sol.dres; info[3 * t + 2] = w->sol.gap;
   }
   free(w);
   return 0;
}
"""
"""The batch driver compiled with the generated sources (the current iterate is read
from the workspace, so an instant that stops early never shows an earlier answer)."""

PROTOTYPE = """#include <math.h>
#include "cone.h"
double cardan_boundary_step(double* u, double* Du, double f, Workspace* work);
"""
"""Put before the generated ``cone.c`` (its header guards against a second inclusion)."""

STEP = r"""
/* QOCO's line search without its bisection: the bisection returns the largest multiple
   of 2^-k (k = bisect_iters) below f times the step to the cones' boundary, at most
   1 - 2^-k; this computes that step per block in closed form (a nonnegative row's
   ratio; a second-order cone's boundary by ECOS's formula, u moved to the cone's axis
   by a hyperbolic rotation) and rounds it down to the same grid. Where u is not
   strictly inside its cones, the bisection decides. */
double cardan_boundary_step(double* u, double* Du, double f, Workspace* work) {
   double amax = 1.0 / f;
   int idx = 0;
   for (; idx < work->l; ++idx) {
      if (!(u[idx] > 0)) return bisection_search(u, Du, f, work);
      if (Du[idx] * amax < -u[idx]) amax = -u[idx] / Du[idx];
   }
   for (int i = 0; i < work->nsoc; ++i) {
      int n = work->q[i];
      double* v = &u[idx];
      double* d = &Du[idx];
      double vv = 0.0, vd = 0.0;
      for (int j = 1; j < n; ++j) { vv += v[j] * v[j]; vd += v[j] * d[j]; }
      double norm2 = v[0] * v[0] - vv;
      if (!(v[0] > 0 && norm2 > 0)) return bisection_search(u, Du, f, work);
      double inv = 1.0 / sqrt(norm2);
      double rho0 = (v[0] * d[0] - vd) * inv * inv;
      double factor = (rho0 + d[0] * inv) / (v[0] * inv + 1.0);
      double rho1 = 0.0;
      for (int j = 1; j < n; ++j) {
         double r = (d[j] - factor * v[j]) * inv;
         rho1 += r * r;
      }
      double sigma = sqrt(rho1) - rho0;
      if (sigma * amax > 1.0) amax = 1.0 / sigma;
      idx += n;
   }
   double grid = ldexp(1.0, work->settings.bisect_iters);
   double below = ceil(f * amax * grid) - 1.0;
   return (below < 0.0 ? 0.0 : below > grid - 1.0 ? grid - 1.0 : below) / grid;
}
"""
"""The generated solver's line search (appended to ``cone.c``, after :data:`PROTOTYPE`):
QOCO's step, one pass over the cones instead of one per halving of the bisection (each
a pass that takes a square root per cone). The step is the bisection's (the same grid
below the boundary), so the iterations and answers are QOCO's. Not the step at the
boundary itself (0.99 of it): under very large loads it stalls ``socp_face``."""

BISECTION_CALL = "return bisection_search(u, Du, f, work);"
"""The call in the generated ``linesearch`` that :data:`STEP` replaces."""

SOURCES = ("qoco_custom.c", "cone.c", "utils.c", "ldl.c", "kkt.c", "driver.c")


def supports(problem) -> bool:
    """Second-order cone programs without power cones: QOCO takes no power cone, and on
    the least-norm family (LS, QP) ``numpy-batched`` is much faster than any interior
    point, so compiling a solver for them would buy nothing.
    """
    return qoco_form.supports(problem) and any(kind == "soc" for kind, _ in problem.cones)


def cache_dir() -> Path:
    """Where compiled solvers are kept: ``$CARDAN_FORCES_CACHE`` or the user's cache
    directory (``$XDG_CACHE_HOME``, else ``~/.cache``), under ``cardan-forces/qocogen``;
    always an absolute path, ``~`` expanded (the compiler runs in a folder of its own,
    where a relative output path would name another file).
    """
    root = os.environ.get("CARDAN_FORCES_CACHE") or os.path.join(
        os.environ.get("XDG_CACHE_HOME") or "~/.cache", "cardan-forces")
    return Path(root).expanduser().absolute() / "qocogen"


def compiler() -> str | None:
    """The C compiler (``$CC``, else ``cc`` or ``gcc`` on the path), or None."""
    return shutil.which(os.environ.get("CC", "")) or shutil.which("cc") or shutil.which("gcc")


UNBUILT = "the generated solver could not be built"
"""The start of a :class:`BuildError`'s message (how a command tells a batch this
backend could not run from one it ran and failed)."""


class BuildError(RuntimeError):
    """A structure's solver could not be generated, compiled or loaded here; the message
    is one line: :data:`UNBUILT` and the first reason given.
    """


_LOADED: dict[str, ctypes.CDLL] = {}
_UNBUILT: dict[str, str] = {}
"""The solvers (by cache path) this process could not build, each with its message: a
later batch of the same structure fails at once, without building it again."""


@functools.cache
def _version() -> str:
    return dist_version("qocogen")


def _family(dims) -> str:
    """The name shared by every cached solver of these dimensions and this code (its
    sparsity patterns apart).
    """
    text = repr((dims, CFLAGS, DRIVER, PROTOTYPE, STEP, _version()))
    return hashlib.sha256(text.encode()).hexdigest()[:12]


def _key(dims, masks) -> str:
    """The structure's name in the cache: its family, then a hash of its patterns."""
    digest = hashlib.sha256(b"".join(np.packbits(m).tobytes() + b"|" for m in masks))
    return f"{_family(dims)}-{digest.hexdigest()[:12]}"


def _covering(dims, masks) -> tuple[Path, list[np.ndarray]] | None:
    """A cached solver of the same family whose patterns hold every nonzero of
    ``masks`` (a batch of other instants of the same problem may have fewer), with its
    own masks; ``None`` if none. Its extra entries are solved as zeros.
    """
    for index in sorted(cache_dir().glob(f"{_family(dims)}-*.npz")):
        try:
            with np.load(index) as saved:
                theirs = [saved[f"m{k}"] for k in range(len(masks))]
        except (OSError, ValueError, KeyError):  # cut short or foreign: not a candidate
            continue
        fits = all(t.shape == m.shape and not np.any(m & ~t) for t, m in zip(theirs, masks))
        if fits and index.with_suffix(".so").exists():
            return index.with_suffix(".so"), theirs
    return None


def _build(target: Path, dims, patterns) -> None:
    """Generate the solver for ``dims`` and ``patterns`` and compile it into ``target``
    (built in a temporary folder, then moved into place in one step).
    """
    import qocogen

    n, m, p, nonneg, sizes = dims
    P, A, G = patterns
    target.parent.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory(dir=target.parent) as folder:
        with contextlib.redirect_stdout(io.StringIO()):  # qocogen reports on stdout
            qocogen.generate_solver(n, m, p, P, np.ones(n), A, np.ones(p) if p else None,
                                    G, np.ones(m), nonneg, len(sizes),
                                    np.array(sizes, np.int32), output_dir=folder,
                                    name="solver")
        source = Path(folder) / "solver"
        (source / "driver.c").write_text(DRIVER)
        _exact_steps(source / "cone.c")
        built = source / "solver.so"
        done = subprocess.run([compiler(), *CFLAGS, "-o", str(built), *SOURCES, "-lm"],
                              cwd=source, capture_output=True, text=True)
        if done.returncode:
            errors = [line for line in done.stderr.splitlines() if "error" in line]
            said = errors or done.stderr.splitlines() or [f"nothing (exit code {done.returncode})"]
            raise BuildError(f"{UNBUILT}: the C compiler says {said[0]}")
        os.replace(built, target)


def _exact_steps(cone: Path) -> None:
    """The generated ``cone.c`` with :data:`STEP` as its line search."""
    text = cone.read_text()
    if text.count(BISECTION_CALL) != 1:
        raise RuntimeError(f"qocogen {_version()}: the generated line search has no "
                           f"'{BISECTION_CALL}' to replace")
    cone.write_text(PROTOTYPE + text.replace(BISECTION_CALL, BISECTION_CALL.replace(
        "bisection_search", "cardan_boundary_step")) + STEP)


def _library(dims, masks) -> tuple[ctypes.CDLL, list[np.ndarray], float]:
    """The compiled solver of this structure (loaded, from the cache, or built), the
    masks of its patterns (the batch's, or a cached solver's that covers them) and the
    seconds spent building and loading it now (0 when this process had it already).
    A structure that cannot be built raises :class:`BuildError`, at once after the first
    attempt in this process.
    """
    target = cache_dir() / f"{_key(dims, masks)}.so"
    if str(target) in _LOADED:
        return _LOADED[str(target)], masks, 0.0
    if str(target) in _UNBUILT:
        raise BuildError(_UNBUILT[str(target)])
    try:
        return _built(target, dims, masks)
    except Exception as exc:  # any step: the backend cannot run this structure here
        why = (str(exc) if isinstance(exc, BuildError)
               else f"{UNBUILT}: {type(exc).__name__}: {exc}")
        _UNBUILT[str(target)] = " ".join(why.split())
        raise BuildError(_UNBUILT[str(target)]) from exc


def _built(target: Path, dims, masks):
    """:func:`_library`'s solver: a covering one of the cache, or built now, loaded."""
    start = time.perf_counter()
    if not target.exists():
        found = _covering(dims, masks)
        if found is not None:
            target, masks = found
        else:
            _build(target, dims, [_pattern(m)[0] for m in masks])
            _save_masks(target.with_suffix(".npz"), masks)
    if str(target) not in _LOADED:
        library = ctypes.CDLL(str(target))
        library.cardan_solve_batch.restype = ctypes.c_int
        _LOADED[str(target)] = library
    return _LOADED[str(target)], masks, time.perf_counter() - start


def _save_masks(path: Path, masks) -> None:
    """The masks beside their solver (written to a temporary name, then moved), so a
    later batch whose nonzeros they cover reuses it.
    """
    with tempfile.NamedTemporaryFile(dir=path.parent, suffix=".npz", delete=False) as f:
        np.savez(f, **{f"m{k}": m for k, m in enumerate(masks)})
    os.replace(f.name, path)


def _options(tol, options: dict) -> np.ndarray:
    """The driver's settings array in :data:`SETTINGS` order (NaN: the default)."""
    unknown = set(options) - set(SETTINGS)
    if unknown:
        raise TypeError(f"qocogen takes no option {', '.join(sorted(unknown))}")
    chosen = DEFAULTS | settings.solver_options("qocogen", tol) | options
    return np.array([float(chosen.get(name, np.nan)) for name in SETTINGS])


def _pointer(array: np.ndarray):
    return None if array.size == 0 else array.ctypes.data_as(ctypes.c_void_p)


def _pattern(mask: np.ndarray):
    """:func:`.qoco_form.csc_ones` of ``mask``, with no matrix where it is empty (the
    generated solver takes none).
    """
    if not mask.any():
        return None, np.zeros(0, int), np.zeros(0, int)
    return csc_ones(mask)


def _entries(M: np.ndarray, mask: np.ndarray, rows_of: np.ndarray, T: int):
    """The CSC pattern of ``mask`` (over the rows ``rows_of`` of the stack ``M``) and
    its entries' values per instant, C-ordered (T, k) as the driver reads them: one
    ``np.take`` on the flattened rows (``M[:, rows, cols]`` comes out ordered by entry,
    not by instant, and reordering it cost more than the gather); a shared ``P`` is
    broadcast.
    """
    pattern, rows, cols = _pattern(mask)
    picked = np.take(M.reshape(len(M), -1), rows_of[rows] * M.shape[2] + cols, axis=1)
    if len(picked) != T:
        picked = np.ascontiguousarray(np.broadcast_to(picked, (T, len(rows))))
    return pattern, picked


def _structure(batch: ConicBatch):
    """The batch's dimensions and the masks of its matrices' nonzeros over its instants
    (``P``'s upper triangle, the equality and the cone rows of ``A``).
    """
    T, _, n = batch.A.shape
    eq, cone, nonneg, sizes = layout(batch.cones)
    P = _stacked_P(batch, n)
    nonzero = np.any(np.asarray(batch.A) != 0, axis=0)
    masks = [np.triu(np.any(P != 0, axis=0)), nonzero[eq], nonzero[cone]]
    return (n, len(cone), len(eq), nonneg, tuple(sizes)), masks, (eq, cone)


def _stacked_P(batch: ConicBatch, n: int) -> np.ndarray:
    P = np.zeros((1, n, n)) if batch.P is None else np.asarray(batch.P, float)
    return P if P.ndim == 3 else P[None]


def _data(batch: ConicBatch, masks, rows):
    """The batch's values in the generated solver's terms, ``P, c, A, b, G, h`` per
    instant: matrices as their entries in CSC order of ``masks`` (the solver's
    patterns), rows those of the equality and cone parts.
    """
    T, _, n = batch.A.shape
    eq, cone = rows
    A, b = np.asarray(batch.A, float), np.asarray(batch.b, float)
    entries = [_entries(M, mask, at, T)[1] for M, mask, at in
               zip((_stacked_P(batch, n), A, A), masks, (np.arange(n), eq, cone))]
    return (entries[0], np.ascontiguousarray(batch.q, float), entries[1],
            np.take(b, eq, axis=1), entries[2], np.take(b, cone, axis=1))


def _statuses(codes: np.ndarray, info: np.ndarray) -> tuple[np.ndarray, tuple[str, ...]]:
    """Our status and a message per instant from the driver's status codes and ``info``
    (objective, dual residual, gap): by table over all instants at once, a message
    written only where an instant is not solved.
    """
    table = np.array([STATUS.get(k, Status.FAILED) for k in range(len(NAMES))], object)
    known = (codes >= 0) & (codes < len(NAMES))
    status = np.full(len(codes), Status.FAILED, object)
    status[known] = table[codes[known]]
    status[(codes == 1) & (np.max(info[:, 1:], axis=1) > CLAIM_TOL)] = Status.INACCURATE
    messages = np.full(len(codes), "", object)
    for t in np.flatnonzero(status != Status.SOLVED):
        k, (_, dual, gap) = int(codes[t]), info[t]
        messages[t] = (f"qocogen: {NAMES[k] if 0 <= k < len(NAMES) else k} (dual residual "
                       f"{dual:.1e}, gap {gap:.1e})")
    return status, tuple(messages)


def _run(library, dims, values, chosen: np.ndarray):
    """One C call over the instants of ``values``: ``x, y, z, iterations, codes, info``."""
    T, n, m, p = len(values[1]), dims[0], dims[1], dims[2]
    x, y, z = np.zeros((T, n)), np.zeros((T, p)), np.zeros((T, m))
    iterations, codes, info = np.zeros(T, np.int32), np.zeros(T, np.int32), np.zeros((T, 3))
    sizes = [ctypes.c_int(v.shape[1]) for v in values[::2]]
    library.cardan_solve_batch(ctypes.c_int(T), *sizes, *map(_pointer, values),
                               _pointer(chosen), _pointer(x), _pointer(y), _pointer(z),
                               _pointer(iterations), _pointer(codes), _pointer(info))
    return x, y, z, iterations, codes, info


def solve_batch(batch: ConicBatch, tol=None, **options) -> BatchOutcome:
    """Every instant of the batch in one call of the structure's generated solver; the
    instants whose status is not "solved", again with :data:`REFINED` (unless the caller
    chose one of those settings): an instant's answer is still its own.

    ``stages``: ``layout`` (the package's side: rows, patterns, entries), ``compile``
    (generation, compilation and loading when this process meets the structure first;
    0 after) and ``solve`` (the C calls).
    """
    start = time.perf_counter()
    chosen = _options(tol, options)
    dims, masks, (eq, cone) = _structure(batch)
    found = time.perf_counter()
    library, masks, compile_s = _library(dims, masks)
    loaded = time.perf_counter()
    values = _data(batch, masks, (eq, cone))
    laid_out = time.perf_counter()
    layout_s = (found - start) + (laid_out - loaded)
    out = _run(library, dims, values, chosen)
    again = np.flatnonzero(out[4] != 1)  # not "solved" by the solver's own status
    if len(again) and not set(REFINED) & set(options):
        retry = _run(library, dims, [np.take(v, again, axis=0) for v in values],
                     _options(tol, options | REFINED))
        np.add(retry[3], out[3][again], out=retry[3])  # the iterations of both attempts
        for mine, theirs in zip(out, retry):
            mine[again] = theirs
    solved = time.perf_counter()
    x, y, z, iterations, codes, info = out
    duals = np.empty((len(x), len(eq) + len(cone)))
    duals[:, eq], duals[:, cone] = y, z
    status, messages = _statuses(codes, info)
    return BatchOutcome(status=status, z=x, y=duals, iterations=iterations.astype(int),
                        setup_s=layout_s, solve_s=solved - laid_out, messages=messages,
                        stages={"layout": layout_s, "compile": compile_s,
                                "solve": solved - laid_out})


def backends() -> list[Backend]:
    """The generated-QOCO backend, if qocogen and a C compiler are installed (registered
    as ``qocogen-reduced`` only: ``reduced_only``).
    """
    try:
        import qocogen  # noqa: F401
    except ImportError:
        return []
    if compiler() is None:
        return []
    return [Backend(name="qocogen", family="qoco", distributions=("qocogen",),
                    extra="qocogen", supports=supports, tolerances=settings.TOLERANCES["qocogen"],
                    batch=solve_batch, batch_accepts=(ConicBatch,), reduced_only=True)]
