"""Compiled (numba) versions of the per-block kernels of :mod:`._local`, for large meshes.

Why a compiled kernel
    The numpy kernels evaluate the local score of a block's nodes row by row
    (one incident cell per row): about 25 array operations per triangle row and
    candidate, each streaming through memory, and the gathers of the fixed
    vertices of every row before that.  On a 1M-triangle mesh that is where a
    default ``angle`` pass spends most of its time (0.41 s of 0.93 s scoring,
    0.15 s gathering), already with cache-sized chunks.  The loops here read
    the vertices straight from the point array through the topology's tables,
    keep every intermediate in registers and need no gather, no temporaries
    and no per-chunk Python overhead.  Two of them do a whole per-node
    procedure at once: the candidate choice of the robust ``angle`` update
    (:func:`._fastcalls.angle_choose`) and the compass search of ``optimize``
    (:meth:`._fastcalls.FastGeometry.compass`).  Measured figures: ``benchmarks/README.md``.

Modules
    This module decides whether the compiled kernels run (:func:`active`),
    loads them (:mod:`._fastkernels`, through the disk cache of
    :mod:`._jitcache`; in the CLI's process without numba's BLAS probe,
    :mod:`._leanload`), counts their compile time and runs a call on
    threads (:func:`_run`); :mod:`._fastcalls` holds the Python entry points
    the smoothers call (one per numpy kernel of :mod:`._local`, plus
    :func:`._fastcalls.warm_up`), which import this module, never the
    other way round.

Threads
    The kernels are compiled serially and release the GIL; :func:`_run`
    splits a call's nodes into chunks that a few threads take in turn.  The
    number of threads (:func:`threads`) is the number of cores this process
    may run on (``os.sched_getaffinity``), capped by ``NUMBA_NUM_THREADS``
    and by :func:`set_threads`, and a call with fewer than
    :data:`MIN_CHUNK` nodes per thread uses fewer threads (one for small
    blocks).  Because the chunks are taken in turn, a core that is busy with
    other work simply takes fewer of them: on a loaded machine the threads
    never wait for each other the way numba's ``parallel=True`` layer did
    (issue 17: 3x slower than one thread with both cores loaded), and the
    serial compile is about five times cheaper.

Same numbers
    Every function computes the same floating-point operations in the same
    order as its numpy twin in :mod:`._local` (no fast-math, so no fused
    multiply-adds), and sums in the same order as ``np.bincount``: the
    results are bit-identical, except that the 3:2 angle split of a spoke
    between a quad and a triangle uses the C library's ``atan2``/``cos``/``sin``
    where numpy may use its own vectorized ones (equal to round-off).
    ``tests/test_kernels.py`` checks both against each other.

When
    :func:`active` decides per topology: with the environment variable
    ``ANGLESMOOTH_KERNEL`` unset or ``auto``, the compiled kernels run when
    numba is installed (the ``fast`` extra) and the mesh has at least
    :data:`AUTO_MIN_FREE` free nodes, so small meshes never wait for a
    compilation or for numba's import; ``numpy`` or ``numba`` force one.

Compiling
    A kernel compiles on its first call, so a method compiles only the
    kernels it uses.  The compiled code is cached on disk in a user cache
    directory (:mod:`._jitcache`: ``$XDG_CACHE_HOME/anglesmooth/numba`` unless
    ``NUMBA_CACHE_DIR`` or ``ANGLESMOOTH_CACHE_DIR`` says otherwise), so
    later processes load it.  The time spent compiling or loading is counted
    apart (:func:`jit_stats`), and :func:`cold_kernels` /
    :func:`compile_estimate` tell beforehand whether a run will compile.  The CLI starts the
    loading or compiling on a thread during its set-up (:mod:`._jitcache_warm`); a call then waits
    for a compile in progress on the compile lock, and :func:`jit_stats`' ``wait_s`` is what the
    calls waited (the compile time a run reports).
"""

from __future__ import annotations

import inspect
import itertools
import os
import threading
import time
from concurrent.futures import ThreadPoolExecutor

import numpy as np

from ..errors import ConfigurationError

__all__ = [
    "AUTO_MIN_FREE",
    "active",
    "cold_kernels",
    "compile_estimate",
    "jit_stats",
    "kernel_mode",
    "set_threads",
    "threads",
    "would_help",
]

#: Smallest number of free nodes for which ``auto`` uses the compiled kernels.  Loading them costs
#: about 0.5 s per process (numba's import and the cached kernels), a default ``angle`` pass saves
#: about 1.6 us per free node: for 10 passes the CLI broke even at about 40k free nodes (measured,
#: 2 cores: 60k triangles numpy 1.14 s vs numba 1.29 s; 100k triangles 1.46 s vs 1.32 s).
AUTO_MIN_FREE = 40_000

#: Fewest nodes per thread of a kernel call: a call with fewer nodes runs on one thread.  Handing a
#: chunk to a thread costs some 10-50 us; 8192 nodes take 0.3 ms (``ring_mean``) to 8 ms
#: (``angle_choose``).
MIN_CHUNK = 8192
#: Chunks per thread: a thread on a busy core takes fewer of them instead of holding the others up.
CHUNKS_PER_THREAD = 4

#: Compile CPU time of each kernel's own code, s: a cold cache, one kernel (or the default ``angle``
#: set) per fresh process on the 2-core VM (``time.process_time``, numba's import excluded;
#: 2026-12-02, issue 17, a loaded VM: quiet figures are some 10 % lower), less what every kernel of
#: a process shares: numba's first compile in a process and the overloads of numpy / builtins the
#: kernels use (:data:`_FIRST_COMPILE_S`) and the called helpers (:data:`_SHARED_S`), which compile
#: once per process.  Only for the estimate that :func:`compile_estimate` gives before a run;
#: unknown kernels count :data:`_DEFAULT_COMPILE_S`.  ``angle_choose``'s figure holds its own
#: helpers ``_node_certified`` (0.5 s) and ``_node_score`` (0.45 s).  ``_cell_area_range``
#: (:func:`area_limits`) is a mesh-wide loop, not split per node (hence private).  The default
#: ``angle`` kernels in one process measured 6.0 s with stage 5's screen (median of 3, loaded VM;
#: 7.1 s before the helpers were called instead of inlined); the estimate for them is 5.7 s
#: (``_screen_below``: stage 5's screen, in :mod:`._patchkernels`, named here with the others; with
#: ``_chunk_ranges`` and ``_fold_range`` it gives the next pass's area range: 0.4, 0.25, 0.15 s measured
#: on a cold cache, loaded VM).
COMPILE_S = {"angle_choose": 2.5, "angle_optimize": 1.0, "compass": 0.9, "score": 0.4, "ring_mean": 0.35,
             "angle_target": 0.2, "_cell_area_range": 0.3, "_screen_below": 0.4, "_chunk_ranges": 0.25,
             "_fold_range": 0.15}
_DEFAULT_COMPILE_S = 2.0
#: numba's first compile in a process (its own set-up) and the shared overloads (``np.empty``,
#: ``min`` / ``max`` of tuples), s: paid once, by whichever kernel is first
_FIRST_COMPILE_S = 0.5
#: called (not inlined) helpers and the kernels that call them: compiled once per process, s
_SHARED_S = {"_node_score_rows": (0.9, ("angle_choose", "angle_optimize", "compass", "score")),
             "_node_rows": (0.35, ("angle_choose", "angle_optimize", "compass", "score")),
             "_node_angle": (0.25, ("angle_target",))}  # (angle_choose inlines it, and _node_score)
#: The kernels a method's default run calls (for :func:`compile_estimate`; a hint, not a contract).
METHOD_KERNELS = {
    "angle": ("angle_choose", "angle_optimize", "_cell_area_range", "_screen_below", "_chunk_ranges", "_fold_range"),
    "laplacian": ("ring_mean", "score"),
    "smart-laplacian": ("ring_mean", "score"),
    "optimization": ("ring_mean", "compass"),
}

# the kernels' array parameters that hold one row per node of the call, and the axis of that row;
# SHARED arrays are indexed by mesh-wide ids and go whole to every chunk; any other parameter is a
# scalar, or, when it is an array with one row per node, split along axis 0 too; a call with an
# argument that is none of these runs whole on one thread (tests/test_fast_install.py checks that
# every kernel's parameters are known)
PER_NODE = {"nodes": 0, "x": 0, "X": 1, "scale": 0}
SHARED = {"pts", "free", "sp", "ring", "sa", "sb", "frac", "sap", "rp", "nbr", "tp", "tv", "qp", "qv", "directions", "fl",
          "flnode"}
SCALARS = {"lengths", "good", "iterations", "radius", "band", "keep", "nearest", "alo", "ahi", "strict", "best", "certify",
           "resume_iterations", "resume_radius", "resume_above", "cap", "s_min"}  # or one value per node, or empty

_ENV = "ANGLESMOOTH_KERNEL"
_kernels = None  # the compiled module, imported on first use
_COMPILE_LOCK = threading.Lock()
_POOL_LOCK = threading.Lock()  # apart: a call must not wait for a warm-up's compile of another kernel
_pool: ThreadPoolExecutor | None = None
_pool_size = 0
_threads_cap: int | None = None
_stats = {"compile_s": 0.0, "load_s": 0.0, "wait_s": 0.0, "compiled": [], "loaded": []}
#: ``background.on`` is True in a thread that compiles ahead of the run (:mod:`._jitcache_warm`)
background = threading.local()
_split_specs: dict = {}


#: Set while numba is first imported here (unless the user set it): numba then formats the typing
#: errors it raises and catches by the thousand while compiling (overload resolution) without
#: colorama's stream wrapping, which cost ~0.3 s CPU of a cold default compile (5.24 -> 4.96 s,
#: medians of 3, issue 17).  Only numba's error messages' colours depend on it.
_NO_HIGHLIGHT = "NUMBA_DISABLE_ERROR_MESSAGE_HIGHLIGHTING"


def _numba_available() -> bool:
    import sys

    if sys.modules.get("numba") is not None:  # (None there: an import blocked on purpose)
        return True
    unset = _NO_HIGHLIGHT not in os.environ
    if unset:
        os.environ[_NO_HIGHLIGHT] = "1"  # read once, when numba.core.errors is imported
    try:
        import numba  # noqa: F401
    except ImportError:
        return False
    finally:
        if unset:
            os.environ.pop(_NO_HIGHLIGHT, None)
    return True


def kernel_mode() -> str:
    """The requested kernel: ``auto``, ``numpy`` or ``numba`` (from ``ANGLESMOOTH_KERNEL``)."""
    mode = os.environ.get(_ENV, "auto").strip().lower() or "auto"
    if mode not in ("auto", "numpy", "numba"):
        raise ConfigurationError(f"{_ENV}={mode!r} is not one of auto, numpy, numba")
    if mode == "numba" and not _numba_available():
        raise ConfigurationError(f"{_ENV}=numba but numba is not installed (pip install 'anglesmooth[fast]')")
    return mode


def active(topo) -> bool:
    """True when the compiled kernels should run for this topology (see the module docstring)."""
    mode = kernel_mode()
    if mode == "numpy":
        return False
    if mode == "numba":
        return True
    key = ("fast-auto",)
    hit = topo._cache.get(key)
    if hit is None:
        hit = topo._cache[key] = _large(topo) and _numba_available()
    return hit


def _large(topo) -> bool:
    return topo.n_free >= AUTO_MIN_FREE


def would_help(topo) -> bool:
    """True when ``auto`` would use the compiled kernels for this topology but numba is not installed."""
    return kernel_mode() == "auto" and _large(topo) and not _numba_available()


def _k():
    global _kernels
    if _kernels is None:
        from . import _jitcache, _leanload

        _numba_available()  # numba's first import, as configured there

        _jitcache.install()  # before the kernels are decorated: numba picks their cache location then
        from . import _fastkernels

        _leanload.before_first_kernel()
        _kernels = _fastkernels
    return _kernels


def _cores() -> int:
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except (AttributeError, OSError):  # not Linux
        return max(1, os.cpu_count() or 1)


def set_threads(n: int | None) -> None:
    """Cap the threads of the compiled kernels at ``n`` (``None``: no cap beyond :func:`threads`')."""
    global _threads_cap
    if n is not None and int(n) < 1:
        raise ValueError(f"threads must be at least 1, not {n}")
    _threads_cap = None if n is None else int(n)


def threads(n_nodes: int | None = None) -> int:
    """Threads for a kernel call over ``n_nodes`` nodes (``None``: the most any call would use).

    The cores this process may run on, capped by ``NUMBA_NUM_THREADS`` (when set) and
    :func:`set_threads`, and by one thread per :data:`MIN_CHUNK` nodes.
    """
    n = _cores()
    env = os.environ.get("NUMBA_NUM_THREADS", "").strip()
    if env.isdigit() and int(env) >= 1:
        n = min(n, int(env))
    if _threads_cap is not None:
        n = min(n, _threads_cap)
    if n_nodes is not None:
        n = min(n, max(1, n_nodes // MIN_CHUNK))
    return max(1, n)


def jit_stats() -> dict:
    """Time spent compiling (``compile_s``) and loading from the cache (``load_s``) kernels in this
    process so far, and which kernels (``compiled``, ``loaded``); ``wait_s``: the part of it (and of
    waiting for it) outside a background warm-up (:mod:`._jitcache_warm`), which the runs lost; a copy."""
    return {k: (list(v) if isinstance(v, list) else v) for k, v in _stats.items()}


def _is_dispatcher(fn) -> bool:
    return hasattr(fn, "py_func") and hasattr(fn, "overloads")


def _arg_key(a):
    """What numba's type of ``a`` depends on, cheaply (``typeof_pyval`` costs some 30 us per array)."""
    if isinstance(a, np.ndarray):
        f = a.flags
        return (a.dtype.num, a.ndim, f.c_contiguous, f.f_contiguous, f.writeable, f.aligned)
    return type(a)


_ready: set = set()  # (kernel, argument keys) already compiled or loaded in this process


def _prepare(fn, args) -> None:
    """Compile (or load from the cache) ``fn`` for ``args``' types before it runs, timed apart.

    A call whose arguments look like an earlier call's (:func:`_arg_key`) skips numba's typing: on a
    100k-triangle mesh that typing cost about 10 % of a default ``angle`` pass (3 calls per block).
    """
    key = (fn, tuple(_arg_key(a) for a in args))
    if key in _ready:
        return
    try:
        sig = tuple(fn.typeof_pyval(a) for a in args)
    except Exception:  # noqa: BLE001 - numba's API moved: the call compiles as usual, untimed
        return
    if sig in fn.overloads:
        _ready.add(key)
        return
    foreground = not getattr(background, "on", False)
    waited = 0.0
    if not _COMPILE_LOCK.acquire(blocking=False):  # another thread compiles (a warm-up): wait for it
        w0 = time.perf_counter()
        _COMPILE_LOCK.acquire()
        waited = time.perf_counter() - w0
    try:
        if foreground:
            _stats["wait_s"] += waited
        if sig in fn.overloads:
            return
        hits = sum(fn.stats.cache_hits.values())
        t0 = time.perf_counter()
        fn.compile(sig)
        dt = time.perf_counter() - t0
        loaded = sum(fn.stats.cache_hits.values()) > hits
        _stats["load_s" if loaded else "compile_s"] += dt
        _stats["loaded" if loaded else "compiled"].append(fn.__name__)
        if foreground:
            _stats["wait_s"] += dt
    finally:
        _COMPILE_LOCK.release()
    _ready.add(key)


def _params(fn) -> tuple:
    names = _split_specs.get(fn)
    if names is None:
        names = _split_specs[fn] = tuple(inspect.signature(fn.py_func).parameters)
    return names


def _split_spec(fn, args=None):
    """((argument index, axis), ...) of ``fn``'s per-node arguments, the axis of its outputs' nodes and
    the index of ``nodes``; None when the call cannot be split (it then runs whole).  With ``args``,
    a scalar-named parameter given an array with one row per node counts as per-node."""
    names = _params(fn)
    if "nodes" not in names or len(names) != (len(args) if args is not None else len(names)):
        return None
    at = names.index("nodes")
    n = args[at].shape[0] if args is not None else None
    per_node = []
    for i, p in enumerate(names):
        if p in PER_NODE:
            per_node.append((i, PER_NODE[p]))
        elif p in SHARED:
            continue
        elif p not in SCALARS:
            return None
        elif args is not None and isinstance(args[i], np.ndarray) and args[i].ndim and args[i].shape[0]:
            if args[i].shape[0] != n:
                return None
            per_node.append((i, 0))  # (an empty array, "none", goes whole like a scalar)
    return tuple(per_node), 1 if "X" in names else 0, at


def _get_pool(n: int) -> ThreadPoolExecutor:
    global _pool, _pool_size
    with _POOL_LOCK:
        if _pool is None or _pool_size < n:
            if _pool is not None:
                _pool.shutdown(wait=False)  # its threads finish what they hold, then exit
            _pool = ThreadPoolExecutor(max_workers=n, thread_name_prefix="anglesmooth-kernel")
            _pool_size = n
        return _pool


def _chunk(a: np.ndarray, axis: int, lo: int, hi: int) -> np.ndarray:
    part = a[lo:hi] if axis == 0 else a[(slice(None),) * axis + (slice(lo, hi),)]
    return part if part.flags.c_contiguous else np.ascontiguousarray(part)  # the same compiled signature


def _threaded(fn, args, spec, n: int, n_threads: int):
    """``fn(*args)`` with the per-node arguments cut into chunks that ``n_threads`` threads take in turn."""
    per_node, out_axis, _ = spec
    n_chunks = min(n_threads * CHUNKS_PER_THREAD, max(n_threads, n // MIN_CHUNK))
    bounds = np.linspace(0, n, n_chunks + 1).astype(np.int64)
    results = [None] * n_chunks
    counter = itertools.count()
    stop = []  # set when a thread fails or is interrupted: the others take no further chunk

    def work():
        try:
            while not stop and (i := next(counter)) < n_chunks:
                sub = list(args)
                for j, axis in per_node:
                    sub[j] = _chunk(args[j], axis, bounds[i], bounds[i + 1])
                results[i] = fn(*sub)
        except BaseException:
            stop.append(True)
            raise

    helpers = [_get_pool(n_threads - 1).submit(work) for _ in range(n_threads - 1)]
    try:
        work()
    finally:
        for h in helpers:  # wait for the others even when this thread failed (they use the arrays)
            h.exception()
    for h in helpers:
        h.result()
    if isinstance(results[0], tuple):
        return tuple(np.concatenate(parts, axis=out_axis) for parts in zip(*results))
    return np.concatenate(results, axis=out_axis)


def _call(fn, args):
    if not _is_dispatcher(fn):
        return fn(*args)
    _prepare(fn, args)
    names = _params(fn)
    n = args[names.index("nodes")].shape[0] if "nodes" in names and len(names) == len(args) else 0
    # fewer than 2 * MIN_CHUNK nodes run on one thread whatever the settings (threads() reads the
    # environment and the affinity mask: some 15 us a call)
    n_threads = threads(n) if n >= 2 * MIN_CHUNK else 1
    spec = _split_spec(fn, args) if n_threads > 1 else None
    if spec is None:
        return fn(*args)
    return _threaded(fn, args, spec, n, n_threads)


def _run(fn, *args):
    """Call a compiled kernel: compiled first (timed apart), then on :func:`threads` threads.

    A signal handler that raises (Ctrl-C's ``KeyboardInterrupt``, the CLI's SIGTERM handler) while
    a kernel runs may fire inside numba's own Python helpers (``_numba_unpickle``), which then
    report a chain of ``SystemError`` s ("returned a result with an exception set") whose root cause
    is that interrupt; the interrupt is re-raised instead, so that it is handled as one.
    """
    try:
        return _call(fn, args)
    except SystemError as exc:
        root = exc
        while isinstance(root, SystemError) and root.__cause__ is not None:
            root = root.__cause__
        if not isinstance(root, Exception):  # KeyboardInterrupt and its kin
            raise root from None
        raise


def cold_kernels(names=None) -> list[str]:
    """The kernels (of ``names``, default all) that have no compiled code in memory or in the cache:
    their first call will compile them.  Imports numba."""
    k = _k()
    names = [n for n in (names or COMPILE_S) if hasattr(k, n)]
    cold = []
    for name in names:
        fn = getattr(k, name)
        if fn.overloads:
            continue
        try:
            index = fn._cache._cache_file._load_index()  # {} when absent or stale (source changed)
        except Exception:  # noqa: BLE001 - no cache (NullCache) or numba's layout moved
            index = {}
        if not index:
            cold.append(name)
    return cold


def compile_estimate(method: str | None = None) -> float:
    """Seconds the kernels of ``method`` (default: all) will take to compile in this process, about
    (0.0 when they are all cached or compiled already); from :data:`COMPILE_S`."""
    names = METHOD_KERNELS.get(method, tuple(COMPILE_S)) if method else tuple(COMPILE_S)
    cold = cold_kernels(names)
    if not cold:
        return 0.0
    shared = sum(s for s, users in _SHARED_S.values() if set(users) & set(cold))
    return _FIRST_COMPILE_S + shared + sum(COMPILE_S.get(n, _DEFAULT_COMPILE_S) for n in cold)
