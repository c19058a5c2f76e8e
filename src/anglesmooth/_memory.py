"""Giving freed memory back to the operating system (issue 17: the CLI's peak memory).

The topology build and the first quality summary of a large mesh allocate and free temporaries of
12-24 MB.  glibc's malloc raises its mmap threshold dynamically after such frees, so later
temporaries of that size come from the heap, and the freed ones stay mapped in it: at 1M triangles
the CLI's peak RSS was 626 MB, 30 MB of it heap that no array used any more.  ``malloc_trim(0)``
returns the free pages of the heap (also those between live blocks) to the system without changing
how later allocations are made; measured, 1M-triangle binary MSH -> VTU, 10 default passes,
``/usr/bin/time -v``: 626 -> 596 MB, no measurable CPU.  Setting the mmap threshold instead
(``MALLOC_MMAP_THRESHOLD_=1048576``) reached 581 MB but doubled the system time (0.8-1.1 -> 1.9-2.4 s:
every large temporary page-faults afresh), so it is not done.

A no-op where the C library has no ``malloc_trim`` (macOS, Windows, musl).  Only the command line
calls it: a library that trims the heap of its host process on its own would surprise.
"""

from __future__ import annotations

import ctypes
import ctypes.util

__all__ = ["release_free_memory"]

_trim = None  # the C function once looked up; False where there is none


def _lookup():
    global _trim
    if _trim is None:
        _trim = False
        try:
            libc = ctypes.CDLL(ctypes.util.find_library("c") or "libc.so.6")
            fn = libc.malloc_trim
        except (OSError, AttributeError):
            return _trim
        fn.argtypes, fn.restype = [ctypes.c_size_t], ctypes.c_int
        _trim = fn
    return _trim


def release_free_memory() -> bool:
    """Return the heap's free pages to the system (glibc); True if the C library could do it."""
    fn = _lookup()
    if not fn:
        return False
    fn(0)
    return True
