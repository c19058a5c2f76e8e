"""Module layout: the packages split for readability import without cycles and stay small."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

SRC = Path(__file__).resolve().parents[1] / "src" / "anglesmooth"
PACKAGES = ("quality", "gmshfile", "generate", "_paths", "smoothers")
MODULES = sorted(
    ".".join(("anglesmooth", *p.relative_to(SRC).with_suffix("").parts)).removesuffix(".__init__")
    for pkg in PACKAGES for p in (SRC / pkg).glob("*.py")
)


def test_every_module_of_the_split_packages_imports_on_its_own():
    """Each module imported first, in an interpreter where no anglesmooth module is loaded yet: an
    import cycle that depends on the import order fails here."""
    code = (
        "import importlib, sys\n"
        f"for name in {MODULES!r}:\n"
        "    for m in [m for m in sys.modules if m == 'anglesmooth' or m.startswith('anglesmooth.')]:\n"
        "        del sys.modules[m]\n"
        "    importlib.import_module(name)\n"
        "print(len(" + repr(MODULES) + "))\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=SRC.parents[1],
                         env={**os.environ, "PYTHONPATH": str(SRC.parent)})
    assert out.returncode == 0, out.stderr
    assert int(out.stdout) == len(MODULES) >= 4 * len(PACKAGES)


@pytest.mark.parametrize("name", MODULES)
def test_modules_stay_under_500_lines(name):
    rel = Path(*name.split(".")[1:])
    path = SRC / (rel / "__init__.py" if (SRC / rel).is_dir() else rel.with_suffix(".py"))
    assert len(path.read_text(encoding="utf-8").splitlines()) <= 500


@pytest.mark.parametrize("package", PACKAGES)
def test_public_names_are_importable_from_the_package(package):
    import importlib

    mod = importlib.import_module(f"anglesmooth.{package}")
    for name in mod.__all__:
        assert getattr(mod, name) is not None, name
