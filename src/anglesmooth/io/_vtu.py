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

Ahead of time: the cell arrays (connectivity, offsets, types, cell data: most of the bytes) do not
depend on the smoothing, so :func:`precompress` (called by the CLI once the mesh is read) makes
their blocks on one background thread while the topology is built (one core is idle then), as
meshio would make them from the input mesh.  The writer takes them only for an array whose bytes
have the same length and BLAKE2b digest as the one compressed (else it compresses the array as
usual), so the file stays meshio's.
"""

from __future__ import annotations

import contextlib
import hashlib
import os
import threading
import zlib
from concurrent.futures import ThreadPoolExecutor

import numpy as np

__all__ = ["precompress", "threaded_zlib", "workers"]

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


#: meshio's block size (``max_block_size`` of its compressed writer)
BLOCK = 32768
#: (future of {(length, digest): compressed blocks}, the thread's pool) of :func:`precompress`
_ahead: list = []


def _digest(data) -> bytes:
    return hashlib.blake2b(data, digest_size=32).digest()


def _cell_arrays(mesh):
    """The arrays besides the points that meshio's VTU writer compresses, made as it makes them
    (``meshio.vtu._vtu.write``, cells other than polyhedra), one at a time: views where one cell
    block holds them (no copy beside the topology build's peak)."""
    from meshio.vtu import _vtu

    cells = list(mesh.cells)
    if not cells or any(c.type.startswith("polyhedron") for c in cells):
        return
    parts = []
    for c in cells:
        d, order = np.asarray(c.data), _vtu.meshio_to_vtk_order(c.type)
        parts.append((d if order is None else d[:, order]).ravel())
    conn = parts[0] if len(parts) == 1 else np.concatenate(parts)
    dtype = conn.dtype
    yield conn
    del parts, conn
    if len(cells) == 1:  # made piecewise, as meshio makes them whole
        (c,), dtype = cells, np.dtype(dtype)
        k, n, vtk = c.data.shape[1], c.data.shape[0], _vtu.meshio_to_vtk_type[c.type]
        yield n, lambda lo, hi: k * np.arange(lo + 1, hi + 1, dtype=dtype)
        yield n, lambda lo, hi: np.full(hi - lo, vtk)
    else:
        offsets = [c.data.shape[1] * np.arange(1, c.data.shape[0] + 1, dtype=dtype) for c in cells]
        for k in range(1, len(offsets)):
            offsets[k] += offsets[k - 1][-1]
        yield np.concatenate(offsets)
        del offsets
        yield np.concatenate([np.full(len(c), _vtu.meshio_to_vtk_type[c.type]) for c in cells])
    for name, per_block in (mesh.cell_data or {}).items():
        yield np.asarray(per_block[0]) if len(per_block) == 1 else _vtu.raw_from_cell_data({name: per_block})[name]


def _blocks(a):
    """The bytes of array ``a`` (an array, or (n, f) for the ``f(lo, hi)`` items lo..hi of an array of
    n made piecewise: no whole copy) in meshio's blocks."""
    if isinstance(a, tuple):
        n, f = a
        step = BLOCK // f(0, 1).itemsize
        for lo in range(0, n, step):
            yield memoryview(np.ascontiguousarray(f(lo, min(n, lo + step)))).cast("B")
        return
    a = np.ascontiguousarray(a.astype(a.dtype.newbyteorder("="), copy=False))
    data = memoryview(a).cast("B") if a.size else memoryview(b"")
    for k in range(0, len(data), BLOCK):
        yield data[k : k + BLOCK]


def _compress_ahead(mesh) -> dict:
    out = {}
    for a in _cell_arrays(mesh):
        size = a[0] * a[1](0, 1).itemsize if isinstance(a, tuple) else a.nbytes
        if size < MIN_BLOCKS * BLOCK:
            continue
        h, blocks = hashlib.blake2b(digest_size=32), []
        for b in _blocks(a):
            h.update(b)
            blocks.append(zlib.compress(b))
        out[(size, h.digest())] = blocks
    return out


def precompress(mesh) -> bool:
    """Compress the blocks of ``mesh``'s (a meshio.Mesh to be written as compressed VTU) cell arrays
    on a background thread, for the next :func:`threaded_zlib` write in this process; True when
    started (several cores and a compatible meshio)."""
    from meshio.vtu import _vtu

    if workers() < 2 or not _compatible(_vtu) or not all(
            hasattr(_vtu, n) for n in ("meshio_to_vtk_order", "meshio_to_vtk_type", "raw_from_cell_data")):
        return False
    pool = ThreadPoolExecutor(max_workers=1, thread_name_prefix="anglesmooth-zlib-ahead")
    _ahead[:] = [pool.submit(_compress_ahead, mesh), pool]
    pool.shutdown(wait=False)
    return True


def _take_ahead(array, n):
    """The blocks :func:`precompress` made of these bytes (waiting for it), or None."""
    if not _ahead or n != BLOCK:
        return None
    try:
        done = _ahead[0].result()
    except Exception:  # noqa: BLE001 - compress here instead
        return None
    return done.get((len(array), _digest(array)))  # (two arrays may have the same bytes)


class _Done:
    """A finished "future" of precompressed blocks."""

    __slots__ = ("blocks",)

    def __init__(self, blocks):
        self.blocks = blocks

    def result(self):
        return self.blocks

    def cancel(self):
        return False


def _patched_chunk_it(pool, original):
    def chunk_it(array, n):
        size = len(array)
        if size < MIN_BLOCKS * n or not isinstance(array, (bytes, bytearray)):
            yield from original(array, n)
            return
        ready = _take_ahead(array, n)
        if ready is not None:
            done = _Done(ready)
            for q in range(len(ready)):
                yield _Block(done, q)
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
                _ahead.clear()  # what precompress made is for one write
    finally:
        with _lock:
            _users -= 1
            if _users == 0:
                _vtu._chunk_it, _vtu.zlib = _original, zlib
