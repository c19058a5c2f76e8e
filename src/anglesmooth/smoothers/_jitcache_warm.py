"""Load or compile a method's compiled kernels on a background thread while the mesh is still being set up.

A run on the compiled kernels first imports numba and loads its kernels from the disk cache
(1M triangles, warm cache: about 0.5 s) or compiles them (a cold cache: about 5 s), on its first
kernel call, after the topology build and the quality summary.  :func:`start` begins that work on
a thread with :func:`._fastcalls.warm_up` (the kernels a method calls, on a tiny mesh whose tables
have any mesh's types, so the code is the very code the run calls), and the CLI's set-up overlaps
it: numpy's large operations and LLVM (through ctypes) release the GIL.  The CLI starts only a
compile (cold cache) this way, as soon as the mesh is read (the topology build overlaps it).  A load
from the cache is left to the first call: started after the read, numba's some 55 MB added to the
build's peak memory (1M triangles: 598 -> 609 MB); started after the build, only the summary
overlapped it and a warm 200k-triangle run took 0.25 s longer (the tiny mesh's set-up, GIL
contention: 2.41/2.31 -> 2.66/2.57 s, loaded 2-core VM).  The smoothing needs nothing more: a kernel call waits for a compile in progress
on ``_fast``'s compile lock and finds the code compiled (``_fast._prepare``); the time it waits
there is counted as that run's compile time.

Nothing here changes a result (the same kernels, compiled for the same types).  The thread is a
daemon: a run that fails or is interrupted meanwhile exits without waiting for it (a kernel it
compiled halfway is not cached; the next run compiles it).
"""

from __future__ import annotations

import importlib.util
import threading

from ._fast import AUTO_MIN_FREE, METHOD_KERNELS, kernel_mode
from ._jitcache import looks_cached

__all__ = ["start"]

_thread: threading.Thread | None = None


def _warm(kernels) -> None:
    from . import _fast

    _fast.background.on = True
    try:
        from ._fastcalls import warm_up

        warm_up(kernels)
    except Exception:  # noqa: BLE001 - the run's own first call compiles and reports any error
        pass


def start(method: str, n_points: int, *, only_cold: bool = False) -> bool:
    """Start loading ``method``'s kernels on a thread when the run will likely use them (the compiled
    kernels are on and the mesh has at least :data:`._fast.AUTO_MIN_FREE` nodes); True when started.
    ``only_cold``: only when they will compile (no cache index: :func:`._jitcache.looks_cached`).

    ``n_points`` bounds the free nodes from above, so a mesh ``auto`` keeps on numpy for having too
    few free nodes (many fixed ones) may load numba for nothing (on the thread); never the reverse.
    """
    global _thread
    kernels = METHOD_KERNELS.get(method)
    if kernels is None or _thread is not None:
        return False
    mode = kernel_mode()
    if mode == "numpy" or (mode == "auto" and n_points < AUTO_MIN_FREE):
        return False
    if importlib.util.find_spec("numba") is None:
        return False
    if only_cold and looks_cached(kernels):
        return False
    _thread = threading.Thread(target=_warm, args=(kernels,), name="anglesmooth-warm-up", daemon=True)
    _thread.start()
    return True
