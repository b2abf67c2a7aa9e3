"""numba's ``njit`` where numba is installed, else a decorator that leaves functions as
they are (callers then use their NumPy paths; see :data:`HAVE_NUMBA`).

The package's kernels compile with NumPy's error model: a division by zero gives an
infinity or a NaN, as the NumPy reference does, instead of raising
``ZeroDivisionError`` from inside compiled code. Whether a divisor is exactly zero can
depend on the CPU numba compiles for (fused multiply-adds change the last bits), so a
raise there would fail on one machine and not on another; the kernels' callers check
their results for finite numbers and end with a failed status instead.

A cache file numba cannot read (a disk that filled while it was written, a copy from
another machine or numba) is removed and the kernel compiled again, with one warning,
instead of ending the run in numba's unpickling error.

``NUMBA_CACHE_DIR`` is made absolute, ``~`` expanded, before numba reads it: numba takes
it as written, so a literal ``~/...`` would be a folder named ``~`` in the working folder
and a relative path would move with it.

numba keys a cached function by its own source file only: a kernel that inlines or
calls kernels of other files would be loaded stale after an edit there. A kernel names
the files it depends on (``njit(cache=True, depends=(...))``, paths relative to its own
file or absolute); their contents' hash joins its cache key, so an edit of any of them
compiles it again.
"""

from __future__ import annotations

import contextlib
import functools
import hashlib
import os
import warnings
from pathlib import Path


def _absolute_cache_dir() -> None:
    """``NUMBA_CACHE_DIR``, where set, as an absolute path with ``~`` expanded (in this
    process's environment, which numba reads, and the processes it starts inherit).
    """
    folder = os.environ.get("NUMBA_CACHE_DIR")
    if folder:
        os.environ["NUMBA_CACHE_DIR"] = str(Path(folder).expanduser().absolute())


_absolute_cache_dir()

try:
    import numba
    from numba.core.caching import FunctionCache

    numba.core.config.reload_config()  # read again, had numba been imported before
    HAVE_NUMBA = True

    def njit(*args, depends=(), **kwargs):
        """``numba.njit`` with NumPy's error model unless the caller sets one, and a
        disk cache that rebuilds a file it cannot read and is keyed also by the
        contents of the source files in ``depends`` (:class:`_RebuildingCache`).
        """
        kwargs.setdefault("error_model", "numpy")
        made = numba.njit(*args, **kwargs)
        options = repr(sorted((k, v) for k, v in kwargs.items() if k != "cache"))
        if args and callable(args[0]):
            return _rebuilding(made, depends, options)
        return lambda function: _rebuilding(made(function), depends, options)

    class _RebuildingCache(FunctionCache):
        """numba's on-disk cache of one function, where a cache file that cannot be read
        (cut short, overwritten, written by another numba: numba itself then ends the
        call in ``EOFError``, ``UnpicklingError``, ``MemoryError`` or ``IndexError``) is
        removed and counts as absent: the function compiles again and its cache is
        written anew, with one warning per process.

        Its index key holds, besides numba's (signature, CPU, bytecode), the hash of
        the files the function ``depends`` on (:func:`_files_hash`) and the compile
        options (the error model among them, which numba's key leaves out): a cache
        written before any of them changed is not found, and the function compiles
        again.
        """

        def __init__(self, py_func, depends=(), options=""):
            super().__init__(py_func)
            self._depends_hash = _files_hash(py_func.__code__.co_filename, tuple(depends))
            self._options = options

        def _index_key(self, sig, codegen):
            key = super()._index_key(sig, codegen)
            return (*key[:2], (*key[2], self._depends_hash, self._options))

        def load_overload(self, sig, target_context):
            try:
                return super().load_overload(sig, target_context)
            except Exception as exc:  # any unreadable file: rebuild it
                _discard(self, exc)
                return None

        def save_overload(self, sig, data):
            try:
                super().save_overload(sig, data)
            except Exception as exc:  # the compiled function still runs
                _discard(self, exc)

except ImportError:
    HAVE_NUMBA = False

    def njit(*args, depends=(), **kwargs):
        """Leave a function as it is where numba is not installed."""
        return args[0] if args and callable(args[0]) else (lambda f: f)

def compiled_form(load, compiled: bool | None):
    """The compiled kernels ``load()`` imports, or ``None`` for the NumPy reference:
    ``compiled=None`` takes them where numba is installed, ``True`` insists (an
    ``ImportError`` without numba), ``False`` refuses them.
    """
    if compiled is False:
        return None
    try:
        return load()
    except ImportError:
        if compiled:
            raise
        return None


_WARNED: list[str] = []
"""The cache files already reported as unreadable in this process (one warning)."""


def _rebuilding(dispatcher, depends=(), options=""):
    """``dispatcher`` with its disk cache (if it has one) replaced by a
    :class:`_RebuildingCache` of the same function, keyed also by ``depends`` and the
    compile ``options``.
    """
    if type(getattr(dispatcher, "_cache", None)) is FunctionCache:
        dispatcher._cache = _RebuildingCache(dispatcher.py_func, depends, options)
    return dispatcher


@functools.cache
def _files_hash(source: str, depends: tuple) -> str:
    """SHA-256 of the contents of the files ``depends`` (paths relative to the folder
    of the file ``source``, or absolute), in their order; empty where there are none. A file that
    is missing raises at import: a kernel's declared dependency must exist.
    """
    if not depends:
        return ""
    hasher, folder = hashlib.sha256(), Path(source).parent
    for name in depends:
        hasher.update((folder / name).read_bytes())
    return hasher.hexdigest()


def _discard(cache, exc: Exception) -> None:
    """Remove ``cache``'s index (numba then writes a new one, and its data files are
    overwritten) and warn once per process that the cache is rebuilt and why.
    """
    index = getattr(getattr(cache, "_cache_file", None), "_index_path", None)
    if index:
        with contextlib.suppress(OSError):
            os.unlink(index)
    if not _WARNED:  # named by the file, not by numba's line that read it
        warnings.warn_explicit(f"{index or cache}: unreadable ({type(exc).__name__}: {exc}); "
                               "removed, the kernels compile again and are cached anew",
                               RuntimeWarning, filename="numba cache", lineno=0)
    _WARNED.append(str(index))


__all__ = ["HAVE_NUMBA", "compiled_form", "njit"]
