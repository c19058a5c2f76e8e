"""numba's first kernel load without its BLAS probe, for the CLI's process (issue 17, compile/load cost).

:func:`lean_load` is called by the CLI's entry point only; :func:`before_first_kernel` by
:func:`._fast._k` just before the first kernel loads.  A library user's process loads numba as usual.
"""

from __future__ import annotations

#: ``on``: this process is the CLI's (:func:`lean_load`), so numba's one BLAS probe may be skipped
_lean = {"on": False}

#: The numba releases whose ``numba.np.arraymath`` was read for :func:`_skip_blas_probe` (major, minor):
#: its import runs ``_HAVE_BLAS = _check_blas()`` (``import scipy.linalg.cython_blas``) and nothing
#: else of scipy.  Another release loads as usual.
LEAN_NUMBA = ((0, 49), (0, 68))

#: The numba overloads that read ``_HAVE_BLAS`` (checked against the kernels' source by a test).
BLAS_PROBE_USERS = ("np.correlate", "np.convolve", "np.cov", "np.corrcoef")


def lean_load(on: bool = True) -> None:
    """Let :func:`._fast._k` skip numba's BLAS probe (:func:`_skip_blas_probe`): only for a process that runs
    nothing compiled but these kernels (the CLI's entry point), as it changes numba's ``_HAVE_BLAS``
    for the process.  A library user's process never calls it and loads numba as usual."""
    _lean["on"] = bool(on)


def _lean_numba_ok() -> bool:
    """True if the installed numba is one whose BLAS probe :func:`_skip_blas_probe` knows."""
    import importlib.util

    import numba

    try:
        version = tuple(int(p) for p in numba.__version__.split(".")[:2])
    except ValueError:
        return False
    try:
        found = importlib.util.find_spec("numba.np.arraymath") is not None
    except (ImportError, ValueError):
        found = False
    return found and LEAN_NUMBA[0] <= version <= LEAN_NUMBA[1]


def _skip_blas_probe() -> bool:
    """Import ``numba.np.arraymath`` with ``scipy.linalg`` unimportable, unless either is imported
    already or numba is not a release this was checked against (:data:`LEAN_NUMBA`); True if it did.

    numba imports that module when it loads its first kernel (from the cache too) and probes there
    once for a BLAS by importing ``scipy.linalg``, which pulls in scipy's array API layer and
    ``numpy.f2py``: 0.2 s of a warm 1M-triangle CLI run's 0.5 s kernel load (0.36 -> 0.13 s for the
    default ``angle`` kernels, issue 17).  The probe's answer (``_HAVE_BLAS``) only picks BLAS for
    the inner products of numba's ``np.correlate`` / ``np.convolve`` (and so ``np.cov`` /
    ``np.corrcoef``) overloads, which no kernel here calls (:data:`BLAS_PROBE_USERS`; ``np.dot``
    and ``np.linalg`` check for scipy on their own, when compiled); the kernels' cached code is the
    same either way.  ``scipy.linalg`` imports as usual afterwards.  A thread that imports
    ``scipy.linalg`` in this very moment would fail: the CLI's other threads (zlib) do not import.
    """
    import sys

    if "numba.np.arraymath" in sys.modules or "scipy.linalg" in sys.modules or not _lean_numba_ok():
        return False
    sys.modules["scipy.linalg"] = None  # type: ignore[assignment]  # "import scipy.linalg" raises ImportError
    try:
        import numba.np.arraymath  # noqa: F401
    except Exception:  # noqa: BLE001 - numba's layout moved: its first kernel load imports it as usual
        return False
    finally:
        if sys.modules.get("scipy.linalg", 0) is None:
            del sys.modules["scipy.linalg"]
    return True


def before_first_kernel() -> bool:
    """Called once by :func:`._fast._k`: :func:`_skip_blas_probe` if :func:`lean_load` was called."""
    return _lean["on"] and _skip_blas_probe()
