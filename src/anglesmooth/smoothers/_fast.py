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
    (:func:`angle_choose`) and the compass search of ``optimize``
    (:meth:`FastGeometry.compass`).  Loops over nodes run on every core
    (numba ``prange``; ``NUMBA_NUM_THREADS`` limits it).  Measured figures:
    ``benchmarks/README.md``.

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
    compilation or for numba's import; ``numpy`` or ``numba`` force one.  The
    compiled code is cached on disk by numba after its first use.
"""

from __future__ import annotations

import os
import threading

import numpy as np

from ..errors import ConfigurationError

__all__ = [
    "AUTO_MIN_FREE",
    "FastGeometry",
    "active",
    "angle_choose",
    "angle_target",
    "kernel_mode",
    "laplacian_target",
    "local_scale",
    "warm_up",
    "would_help",
]

#: Smallest number of free nodes for which ``auto`` uses the compiled kernels.  Loading them costs
#: about 0.5 s per process (numba's import and the cached kernels), a default ``angle`` pass saves
#: about 1.6 us per free node: for 10 passes the CLI broke even at about 40k free nodes (measured,
#: 2 cores: 60k triangles numpy 1.14 s vs numba 1.29 s; 100k triangles 1.46 s vs 1.32 s).
AUTO_MIN_FREE = 40_000

_ENV = "ANGLESMOOTH_KERNEL"
_kernels = None  # the compiled module, imported on first use
# numba's default ("workqueue") threading layer aborts the process when two threads launch
# parallel kernels at once; library callers may smooth several meshes from a thread pool
_LOCK = threading.Lock()


def _numba_available() -> bool:
    try:
        import numba  # noqa: F401
    except ImportError:
        return False
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
        from . import _fastkernels

        _kernels = _fastkernels
    return _kernels


def _run(fn, *args):
    """Call a compiled kernel, one at a time across threads (see ``_LOCK``).

    A signal handler that raises (Ctrl-C's ``KeyboardInterrupt``, the CLI's SIGTERM handler) while
    a kernel runs may fire inside numba's own Python helpers (``_numba_unpickle``), which then
    report a chain of ``SystemError`` s ("returned a result with an exception set") whose root cause
    is that interrupt; the interrupt is re-raised instead, so that it is handled as one.
    """
    with _LOCK:
        try:
            return fn(*args)
        except SystemError as exc:
            root = exc
            while isinstance(root, SystemError) and root.__cause__ is not None:
                root = root.__cause__
            if not isinstance(root, Exception):  # KeyboardInterrupt and its kin
                raise root from None
            raise


def _csr(topo):
    """Row pointers of the per-node tables (ring, spokes, triangles, quads) over all free nodes, cached."""
    hit = topo._cache.get(("csr",))
    if hit is None:
        f = np.arange(topo.n_free + 1)
        hit = topo._cache[("csr",)] = tuple(
            np.searchsorted(loc, f).astype(np.int64) for loc in (topo.ring_loc, topo.spoke_loc, topo.tri_loc, topo.quad_loc)
        )
    return hit


def _nodes(blk) -> np.ndarray:
    return np.arange(blk.nodes.start, blk.nodes.stop, dtype=np.int64)


def angle_target(points: np.ndarray, topo, blk) -> np.ndarray:
    """Compiled :func:`._local.angle_target`."""
    _, sp, _, _ = _csr(topo)
    return _run(
        _k().angle_target,
        points, _nodes(blk), topo.free_nodes, sp, topo.spoke_ring, topo.spoke_a, topo.spoke_b, topo.spoke_frac,
    )


def laplacian_target(points: np.ndarray, topo, blk) -> np.ndarray:
    """Compiled :func:`._local.laplacian_target`."""
    rp, _, _, _ = _csr(topo)
    return _run(_k().ring_mean, points, _nodes(blk), topo.free_nodes, rp, topo.ring_nbr, False)


def local_scale(points: np.ndarray, topo, blk, subset: np.ndarray | None = None) -> np.ndarray:
    """Compiled :func:`._local.local_scale`."""
    rp, _, _, _ = _csr(topo)
    nodes = _nodes(blk)
    if subset is not None:
        nodes = nodes[subset]
    return _run(_k().ring_mean, points, nodes, topo.free_nodes, rp, topo.ring_nbr, True)[:, 0]


def _floors(floors) -> np.ndarray:
    """The input floors (``_floors.Floors`` or None) as the (6, rows) array the kernels take; (0, 0) for none."""
    return np.zeros((0, 0)) if floors is None or not floors.active else floors.packed


def angle_choose(points: np.ndarray, topo, blk, good, floors=None, keep=None):
    """Stages 1 and 2 of the robust ``angle`` update, fused per node (see :func:`.angle.step`).

    ``good``: the acceptance score threshold, one per block node or one for all; ``keep``: None or
    a bool per block node, where the angle position must also be no worse than staying.
    """
    rp, sp, tp, qp = _csr(topo)
    good = np.ascontiguousarray(np.broadcast_to(np.asarray(good, dtype=np.float64), (blk.size,)))
    return _run(
        _k().angle_choose,
        points, _nodes(blk), topo.free_nodes, sp, topo.spoke_ring, topo.spoke_a, topo.spoke_b, topo.spoke_frac,
        rp, topo.ring_nbr, tp, topo.tri_verts, qp, topo.quad_verts, good, _floors(floors),
        np.zeros(0, np.bool_) if keep is None else np.ascontiguousarray(keep, dtype=np.bool_),
    )


class FastGeometry:
    """Compiled stand-in for :class:`._local.BlockGeometry` (``n``, ``restrict``, ``score``) plus
    the whole compass search of :func:`._local.optimize`; no gathered copies.

    It keeps a reference to ``points`` (which must not change while it is
    used: the block loop writes a block's moves only after its update) and
    the free-node indices it scores.
    """

    def __init__(self, points: np.ndarray, topo, blk, nodes: np.ndarray | None = None, floors=None):
        self._pts = points
        self._topo = topo
        self._nodes = _nodes(blk) if nodes is None else nodes
        self.n = self._nodes.shape[0]
        self._fl = floors if isinstance(floors, np.ndarray) else _floors(floors)

    def restrict(self, subset: np.ndarray) -> FastGeometry:
        return FastGeometry(self._pts, self._topo, None, self._nodes[subset], self._fl)

    def score(self, X: np.ndarray) -> np.ndarray:
        """Local score at candidate positions ``X`` (..., n, 2) -> (..., n)."""
        t = self._topo
        _, _, tp, qp = _csr(t)
        X = np.asarray(X, dtype=np.float64)
        Xf = np.ascontiguousarray(X.reshape((-1, self.n, 2)))
        s = _run(_k().score, self._pts, Xf, self._nodes, tp, t.tri_verts, qp, t.quad_verts, self._fl)
        return s.reshape(X.shape[:-2] + (self.n,))

    def compass(self, x, scale, iterations: int, radius: float, area_band: float | None, directions: np.ndarray):
        """:func:`._local.optimize` from positions ``x`` (n, 2): (positions, scores)."""
        t = self._topo
        _, _, tp, qp = _csr(t)
        band = -1.0 if area_band is None else float(area_band)
        return _run(
            _k().compass, self._pts, np.ascontiguousarray(x, dtype=np.float64), self._nodes, tp, t.tri_verts, qp,
            t.quad_verts, np.ascontiguousarray(scale, dtype=np.float64), int(iterations), float(radius), band,
            directions, self._fl,
        )


def warm_up() -> None:
    """Compile (or load from numba's cache) every kernel on a tiny mesh."""
    from ..generate import structured_quads, structured_triangles
    from ..mesh import Mesh2D
    from ..topology import build_topology

    t, q = structured_triangles(4, 4), structured_quads(4, 4)
    n = t.points.shape[0]
    m = Mesh2D.from_arrays(
        np.concatenate([t.points, q.points + [5.0, 0.0]]), triangles=t.triangles, quads=q.quads + n
    )
    topo = build_topology(m)
    for blk in topo.blocks():
        g = FastGeometry(m.points, topo, blk)
        x = m.points[topo.free_nodes[blk.nodes]]
        g.score(x)
        g.compass(x, np.ones(g.n), 1, 0.25, 0.8, np.eye(2)), g.compass(x, np.ones(g.n), 1, 0.25, None, np.eye(2))
        angle_target(m.points, topo, blk), laplacian_target(m.points, topo, blk), local_scale(m.points, topo, blk)
        angle_choose(m.points, topo, blk, 0.5)

