"""Sanity limits on what a mesh reader may allocate, checked before it allocates.

A corrupt count in a mesh file (a flipped byte in a binary MSH 4.1 element
block, ``POINTS 999999999999 float`` in a VTK file, ...) makes meshio's readers
size one array by it: a 34 KB file could ask for 8 GB, and on a small machine
the kernel kills the process before any error can be reported.  Every reader
:mod:`anglesmooth.io` wraps gets two checks while it runs (:func:`limits`):

* **counts against the bytes that remain**: every ``numpy.fromfile(f, count=n)``
  a reader makes is refused when the rest of the file cannot hold ``n`` values
  (binary: ``n`` x item size bytes; text: ``2n - 1`` bytes, a digit and a
  separator each).  This covers the node, element, entity, periodic and data
  blocks of MSH 2.2 / 4.0 / 4.1 in ASCII and binary, and the ``POINTS`` /
  ``CELLS`` / ``CELL_TYPES`` / data sections of legacy VTK, ASCII and binary;
* **allocations against the file size**: every ``numpy.empty`` / ``zeros`` /
  ``full`` / ``ones`` / ``arange`` inside a reader (e.g. meshio's
  ``np.empty((total_num_nodes, 3))`` from the MSH 4.1 ``$Nodes`` header, or
  ``np.full(max_node_tag + 1)``) may take at most ``ALLOC_FACTOR`` x the input's
  size plus ``ALLOC_SLACK`` bytes.  Real files need far less (a node costs at
  least 8 bytes of MSH text and becomes 24 bytes of coordinates).

XDMF with HDF5 heavy data is checked before meshio opens it: each referenced
dataset's declared size must fit the same allocation bound, computed from the
size of its ``.h5`` file.  VTU arrays are decoded from the bytes present
(base64, raw or compressed blocks), so their declared ``NumberOfPoints`` /
``NumberOfCells`` only reshape what was read and need no check.

A refused count raises :class:`SizeLimitError` (a ``ValueError``) inside the
reader, which :func:`anglesmooth.io.read` reports like any other corrupt file
(exit 3).  Outside :func:`limits` the wrapped functions are numpy's own.
"""

from __future__ import annotations

import contextlib
import contextvars
import os
import stat
import sys
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np

__all__ = ["ALLOC_FACTOR", "ALLOC_SLACK", "SizeLimitError", "limits"]

#: An array a reader allocates may take this many times the input's size ...
ALLOC_FACTOR = 64
#: ... plus this many bytes (sparse node tags of small files, fixed-size tables).
ALLOC_SLACK = 256 << 20

_LIMIT: contextvars.ContextVar[int | None] = contextvars.ContextVar("anglesmooth_alloc_limit", default=None)
_installed = False


class SizeLimitError(ValueError):
    """A count or size in a mesh file that the file cannot hold."""


def _remaining(file) -> int | None:
    """Bytes left in an open file (or the size of a file name), None when unknown."""
    try:
        if isinstance(file, (str, bytes, os.PathLike)):
            st, pos = os.stat(file), 0
        else:
            st, pos = os.fstat(file.fileno()), file.tell()
    except (OSError, AttributeError, ValueError):
        return None
    return st.st_size - pos if stat.S_ISREG(st.st_mode) else None  # a pipe or device has no size to go by


def _nbytes(shape, dtype) -> int:
    try:
        dims = [int(d) for d in (shape if np.iterable(shape) else (shape,))]
        item = np.dtype(float if dtype is None else dtype).itemsize
    except (TypeError, ValueError):
        return 0
    total = item
    for d in dims:
        total *= max(d, 0)
    return total


def _check_alloc(nbytes: int, what: str) -> None:
    limit = _LIMIT.get()
    if limit is not None and nbytes > limit:
        raise SizeLimitError(f"the file declares {what} of {nbytes:,} bytes, more than a file this size can "
                             f"describe (limit {limit:,} bytes): truncated or corrupt")


class _GuardedNumpy:
    """``numpy`` as meshio's reader modules see it: the same, with checked allocations."""

    def __init__(self, np_module):
        self._np = np_module

    def __getattr__(self, name):
        return getattr(self._np, name)

    def fromfile(self, file, dtype=float, count=-1, sep="", offset=0, **kwargs):
        count = int(count)
        if _LIMIT.get() is not None and count > 0:
            left = _remaining(file)
            if left is not None:
                left -= int(offset)
                need = 2 * count - 1 if sep else count * np.dtype(dtype).itemsize
                if need > left:
                    raise SizeLimitError(f"the file declares {count:,} values where only {max(left, 0):,} bytes "
                                         "remain: truncated or corrupt")
        return self._np.fromfile(file, dtype=dtype, count=count, sep=sep, offset=offset, **kwargs)

    def empty(self, shape, dtype=float, *args, **kwargs):
        _check_alloc(_nbytes(shape, dtype), "an array")
        return self._np.empty(shape, dtype, *args, **kwargs)

    def zeros(self, shape, dtype=float, *args, **kwargs):
        _check_alloc(_nbytes(shape, dtype), "an array")
        return self._np.zeros(shape, dtype, *args, **kwargs)

    def ones(self, shape, dtype=None, *args, **kwargs):
        _check_alloc(_nbytes(shape, dtype), "an array")
        return self._np.ones(shape, dtype, *args, **kwargs)

    def full(self, shape, fill_value, dtype=None, *args, **kwargs):
        _check_alloc(_nbytes(shape, dtype if dtype is not None else np.asarray(fill_value).dtype), "an array")
        return self._np.full(shape, fill_value, dtype, *args, **kwargs)

    def arange(self, *args, **kwargs):
        with contextlib.suppress(TypeError, ValueError, OverflowError):
            nums = [float(a) for a in args[:3] if not isinstance(a, (type, np.dtype, str))]
            if nums:
                start, stop, step = (0.0, nums[0], 1.0) if len(nums) == 1 else (nums[0], nums[1], 1.0) \
                    if len(nums) == 2 else tuple(nums)
                if step:
                    _check_alloc(int(max((stop - start) / step, 0)) * 8, "a range")
        return self._np.arange(*args, **kwargs)


def _install() -> None:
    """Give every loaded meshio module the guarded numpy (once; a no-op outside :func:`limits`)."""
    global _installed
    if _installed:
        return
    import meshio  # noqa: F401  (loads every format module)

    guarded = _GuardedNumpy(np)
    for name, module in list(sys.modules.items()):
        if name.startswith("meshio.") and getattr(module, "np", None) is np:
            module.np = guarded
    _installed = True


def _limit_for(size: int) -> int:
    return ALLOC_FACTOR * max(size, 0) + ALLOC_SLACK


def _check_xdmf(path: Path) -> int:
    """Every HDF5 dataset an XDMF file names must fit the allocation bound of its ``.h5`` file.

    Returns the total size of the ``.h5`` files (the heavy data counts towards the input's size).
    """
    try:
        root = ET.parse(path).getroot()
    except (ET.ParseError, OSError, ValueError):
        return 0  # meshio reports it
    items = [d for d in root.iter() if d.tag == "DataItem" and d.get("Format") == "HDF" and (d.text or "").strip()]
    if not items:
        return 0
    try:
        import h5py
    except ImportError:  # pragma: no cover - meshio needs h5py for these files anyway
        return 0
    sizes: dict[Path, int] = {}
    for item in items:
        filename, _, h5path = item.text.strip().partition(":")
        h5file = path.resolve().parent / filename
        try:
            size = sizes[h5file] = h5file.stat().st_size
            with h5py.File(h5file, "r") as f:
                node = f[h5path.lstrip("/")] if h5path.strip("/") else None
                if not isinstance(node, h5py.Dataset):
                    continue
                nbytes = int(np.prod(node.shape, dtype=object)) * node.dtype.itemsize if node.shape else 0
        except (OSError, KeyError, ValueError, TypeError):
            continue  # meshio reports it
        if nbytes > _limit_for(size):
            raise SizeLimitError(f"HDF5 dataset '{h5path}' in '{filename}' declares {nbytes:,} bytes, more than "
                                 f"a {size:,}-byte file can hold: truncated or corrupt")
    return sum(sizes.values())


@contextlib.contextmanager
def limits(path: str | os.PathLike, fmt: str | None = None):
    """Run a meshio reader on ``path`` with the checks of this module (see the module docstring)."""
    p = Path(path)
    try:
        size = p.stat().st_size
    except OSError:
        size = 0
    if fmt == "xdmf" or (fmt is None and p.suffix.lower() in (".xdmf", ".xmf")):
        size += _check_xdmf(p)
    _install()
    token = _LIMIT.set(_limit_for(size))
    try:
        yield
    finally:
        _LIMIT.reset(token)
