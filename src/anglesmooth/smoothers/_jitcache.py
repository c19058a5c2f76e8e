"""Where numba caches the compiled kernels of :mod:`._fastkernels`: a user cache directory.

numba's default puts its cache next to the source file (``__pycache__`` in
site-packages), which is read-only in many containers and is lost with every
reinstall; it then falls back to ``~/.cache/numba``, or to no cache at all.
Here the kernels of this package are cached in

1. ``$NUMBA_CACHE_DIR`` when it is set (numba's own setting wins),
2. else ``$ANGLESMOOTH_CACHE_DIR`` when it is set,
3. else the platform's user cache directory: ``$XDG_CACHE_HOME/anglesmooth/numba``
   (``~/.cache/anglesmooth/numba``), ``~/Library/Caches/anglesmooth/numba`` on
   macOS, ``%LOCALAPPDATA%\\anglesmooth\\numba`` on Windows;

and when that directory cannot be written, numba's own locators are tried
next (``__pycache__``, ``~/.cache/numba``).  The files are keyed by the
source file's path and content, so several installs or checkouts share the
directory without mixing their kernels; a cached kernel is stamped with every kernel module
of the package (:func:`_kernel_files`), as it holds the helpers it calls from the others.  Nothing else numba caches is
affected: the locator answers only for files of this package.
"""

from __future__ import annotations

import glob
import hashlib
import os
import sys
from pathlib import Path

_PACKAGE_DIR = os.path.dirname(os.path.abspath(__file__))
_installed = False


def cache_dir() -> Path:
    """The directory the compiled kernels are cached in (see the module docstring; not created here)."""
    numba_dir = os.environ.get("NUMBA_CACHE_DIR")
    if numba_dir:
        return Path(numba_dir)
    own = os.environ.get("ANGLESMOOTH_CACHE_DIR")
    if own:
        return Path(own)
    home = Path.home()
    if os.name == "nt":
        base = Path(os.environ.get("LOCALAPPDATA") or home / "AppData" / "Local")
    elif sys.platform == "darwin":
        base = home / "Library" / "Caches"
    else:
        base = Path(os.environ.get("XDG_CACHE_HOME") or home / ".cache")
    return base / "anglesmooth" / "numba"


def _kernel_files() -> list[str]:
    """The package's compiled-code modules (the kernels and the helpers compiled into them)."""
    return sorted(os.path.join(_PACKAGE_DIR, f) for f in ("_fastkernels.py", "_nodescore.py", "_patchkernels.py"))


def install() -> None:
    """Put the locator in front of numba's own ones (after ``NUMBA_CACHE_DIR``'s); once per process.

    Must run before the kernels are decorated: numba picks a function's cache location then.
    """
    global _installed
    if _installed:
        return
    _installed = True
    try:
        from numba.core import caching
    except ImportError:  # pragma: no cover - numba's layout changed: keep its defaults
        return
    base = getattr(caching, "UserProvidedCacheLocator", None) or getattr(caching, "_UserProvidedCacheLocator", None)
    impl = getattr(caching, "CacheImpl", None) or getattr(caching, "_CacheImpl", None)  # numba >= 0.6x / older
    if base is None or impl is None or not isinstance(getattr(impl, "_locator_classes", None), list):
        return  # pragma: no cover - as above

    class AnglesmoothCacheLocator(base):
        """numba's user-provided-directory locator, pointed at :func:`cache_dir`, for this package only."""

        def __init__(self, py_func, py_file):
            self._py_file = py_file
            self._lineno = py_func.__code__.co_firstlineno
            self._cache_path = os.path.join(str(cache_dir()), self.get_suitable_cache_subpath(py_file))

        def get_source_stamp(self):
            """The stamps of every kernel module of the package, not just the kernel's own file: a kernel's
            cached code includes the compiled helpers it calls from the others (``_nodescore``), so a change
            of any of them must invalidate it."""
            return tuple((os.stat(f).st_mtime, os.stat(f).st_size) for f in _kernel_files())

        @classmethod
        def from_function(cls, py_func, py_file):
            if os.environ.get("NUMBA_CACHE_DIR"):
                return None  # numba's own user-provided locator (first in the list) applies
            if os.path.dirname(os.path.abspath(py_file)) != _PACKAGE_DIR:
                return None
            # the mixin's from_function: the file exists and the directory is writable, else None
            return super(base, cls).from_function(py_func, py_file)

    classes = impl._locator_classes
    at = classes.index(base) + 1 if base in classes else 0
    classes.insert(at, AnglesmoothCacheLocator)


def looks_cached(names, modules=("_fastkernels", "_patchkernels")) -> bool:
    """True when every kernel of ``names`` has a cache index in :func:`cache_dir` newer than its
    module's source, without importing numba (numba's own layout: ``<dir>_<sha1 of the source dir>/
    <module>.<kernel>-<line>.pyXY.nbi``).  A guess: a stale or foreign index makes it True, the
    first compile then happens later than it could (see :mod:`._jitcache_warm`), nothing worse."""
    sub = os.path.join(str(cache_dir()), "_".join([os.path.basename(_PACKAGE_DIR),
                                                  hashlib.sha1(_PACKAGE_DIR.encode()).hexdigest()]))
    tag = f"py{sys.version_info[0]}{sys.version_info[1]}"
    for name in names:
        found = False
        for mod in modules:
            try:
                stamp = os.stat(os.path.join(_PACKAGE_DIR, mod + ".py")).st_mtime
            except OSError:
                continue
            for index in glob.glob(os.path.join(glob.escape(sub), f"{mod}.{name}-*.{tag}.nbi")):
                try:
                    found = found or os.stat(index).st_mtime >= stamp
                except OSError:
                    pass
        if not found:
            return False
    return True
