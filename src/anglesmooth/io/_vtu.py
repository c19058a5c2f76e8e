"""meshio's compressed VTU writer with its zlib blocks compressed on several threads: the same bytes.

meshio's ``vtu.write`` (binary, ``compression="zlib"``, the default) cuts every data array into
blocks of 32 KiB and calls ``zlib.compress`` on each block in turn, which is most of the time a
large mesh takes to write (1M triangles: about 2 s of 2.3 s on one core).  ``zlib.compress``
releases the GIL, so here the blocks of each array are compressed by a pool of threads, ahead
of meshio's own loop, which then only picks the results up in order.  meshio writes the file as
always (header, XML, base64), and every block is compressed by the same call with the same
(default) level, so the file is byte for byte the one meshio writes alone
(``tests/test_io.py`` compares them).

How: while :func:`write` runs, meshio's module-level names ``_chunk_it`` (the block generator)
and ``zlib`` are replaced by a generator that hands out tokens whose compressed block is being
made in the pool, and by a stand-in for the zlib module whose ``compress`` returns a token's
result and calls the real ``zlib.compress`` on anything else (every other attribute is
zlib's own), so a meshio call in another thread meanwhile still works.  When meshio's writer
does not look the way this expects (another meshio version), meshio writes alone.
"""

from __future__ import annotations

import contextlib
import os
import threading
import zlib
from concurrent.futures import ThreadPoolExecutor

__all__ = ["threaded_zlib", "workers"]

#: Blocks per task handed to a thread (32 KiB each: 2 MiB of input, a few ms of zlib).
BATCH = 64
#: Arrays of fewer blocks are compressed by meshio's own loop (too small to gain).
MIN_BLOCKS = 2 * BATCH

_lock = threading.Lock()
_users = 0


def workers() -> int:
    """Threads for the compression: the cores this process may run on."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except (AttributeError, OSError):  # pragma: no cover - not Linux
        return max(1, os.cpu_count() or 1)


class _Block:
    """A block whose compressed bytes are (being) made by the pool: item ``index`` of ``future``'s list."""

    __slots__ = ("future", "index")

    def __init__(self, future, index: int):
        self.future = future
        self.index = index


def _compress_all(blocks) -> list[bytes]:
    return [zlib.compress(b) for b in blocks]


class _Zlib:
    """zlib, except that ``compress`` of a :class:`_Block` returns the pool's result for it."""

    def __getattr__(self, name):
        return getattr(zlib, name)

    @staticmethod
    def compress(data, *args, **kwargs):
        if isinstance(data, _Block):
            return data.future.result()[data.index]
        return zlib.compress(data, *args, **kwargs)


def _patched_chunk_it(pool, original):
    def chunk_it(array, n):
        size = len(array)
        if size < MIN_BLOCKS * n or not isinstance(array, (bytes, bytearray)):
            yield from original(array, n)
            return
        view = memoryview(array)
        starts = range(0, size, n)
        futures = [pool.submit(_compress_all, [view[k : k + n] for k in starts[i : i + BATCH]])
                   for i in range(0, len(starts), BATCH)]
        try:
            for q in range(len(starts)):
                yield _Block(futures[q // BATCH], q % BATCH)
        finally:
            for f in futures:
                f.cancel()

    return chunk_it


def _compatible(module) -> bool:
    return callable(getattr(module, "_chunk_it", None)) and getattr(module, "zlib", None) in (zlib, _ZLIB)


_ZLIB = _Zlib()
#: meshio's own ``_chunk_it``, kept from the first patch on (a thread may still call the dispatcher
#: it fetched just before the names were put back).
_original = None
#: The block generator of each thread that is inside :func:`write` (its own pool).
_pools: dict = {}


def _dispatch(array, n):
    """meshio's ``_chunk_it`` while patched: the calling thread's pooled generator, or meshio's own."""
    own = _pools.get(threading.get_ident())
    return own(array, n) if own is not None else _original(array, n)


@contextlib.contextmanager
def threaded_zlib():
    """While inside, meshio's VTU writer (binary, zlib: its default) compresses its blocks on threads.

    >>> import meshio, numpy as np, os, tempfile
    >>> d = tempfile.mkdtemp(); f = os.path.join(d, "a.vtu")
    >>> m = meshio.Mesh(np.random.default_rng(0).random((200_000, 3)), [("vertex", np.arange(200_000)[:, None])])
    >>> with threaded_zlib():
    ...     meshio.write(f, m)
    >>> meshio.write(f + "2.vtu", m)
    >>> open(f, "rb").read() == open(f + "2.vtu", "rb").read()
    True
    >>> os.remove(f); os.remove(f + "2.vtu"); os.rmdir(d)
    """
    from meshio.vtu import _vtu

    global _users, _original
    n = workers()
    with _lock:
        ok = n > 1 and (_users > 0 or _compatible(_vtu))
        if ok:
            if _users == 0:
                if _original is None:
                    _original = _vtu._chunk_it
                _vtu._chunk_it, _vtu.zlib = _dispatch, _ZLIB
            _users += 1
    if not ok:
        yield
        return
    me = threading.get_ident()
    try:
        with ThreadPoolExecutor(max_workers=n, thread_name_prefix="anglesmooth-zlib") as pool:
            _pools[me] = _patched_chunk_it(pool, _original)
            try:
                yield
            finally:
                _pools.pop(me, None)
    finally:
        with _lock:
            _users -= 1
            if _users == 0:
                _vtu._chunk_it, _vtu.zlib = _original, zlib
