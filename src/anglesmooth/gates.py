"""Quality gates: thresholds on a quality summary, from options or a TOML file.

A gate compares one number of :func:`anglesmooth.quality.summarize`'s summary
with a threshold.  The six gates and what passes:

==================  =====================================================  =========
gate                value                                                  passes if
==================  =====================================================  =========
min_angle           ``min_angle``                                          value >= threshold
max_angle           ``max_angle``                                          value <= threshold
max_inverted        ``inverted`` (cells of signed area < 0)                value <= threshold
max_degenerate      ``degenerate`` (0 <= area <= 1e-12 x bbox diagonal^2)  value <= threshold
max_area_ratio      ``area_ratio`` (infinite when a cell has zero area)     value <= threshold
max_aspect_ratio    max of the triangle and quad Verdict aspect ratios      value <= threshold
==================  =====================================================  =========

An inverted cell is never also counted as degenerate, nor the reverse
(:mod:`anglesmooth.quality.validity`).  ``max_inverted`` and ``max_degenerate``
are 0 whenever another gate is given, and :func:`resolve_thresholds` with
``safe=True`` (what ``anglesmooth check`` uses) sets them even when no gate is
given: a mesh a solver rejects never passes silently.

A failed gate's message prints the value and the threshold with enough digits
to differ, the unit, and -- when :func:`evaluate` is given the points and the
topology -- the index of the worst cell (triangles first, then quads).

A gate file is TOML with the same keys, at top level, in a ``[gates]`` table, or
in ``[tool.anglesmooth.gates]`` (so ``pyproject.toml`` can hold them)::

    min_angle = 20
    max_inverted = 0

>>> summary = {"min_angle": 12.34, "max_angle": 150.0, "inverted": 0, "area_ratio": 4.0,
...            "tri_aspect_ratio": {"min": 1.0, "mean": 1.2, "max": 3.0}, "quad_aspect_ratio": None}
>>> [g.passed for g in evaluate(summary, {"min_angle": 20, "max_aspect_ratio": 5})]
[False, True]
>>> evaluate(summary, {"min_angle": 20})[0].message("a.msh")
'a.msh: gate min_angle failed: 12.3° < 20°'
>>> evaluate({"min_angle": 41.36314}, {"min_angle": 41.3632})[0].comparison()
'41.3631° < 41.3632°'
"""

from __future__ import annotations

import math
import sys
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from .errors import AngleSmoothError, GateFileError

__all__ = ["GATES", "SAFE_DEFAULTS", "UNITS", "Gate", "evaluate", "load_gate_file", "resolve_thresholds",
           "read_toml", "validate_gates", "worst_cell"]

#: Gate name -> (summary value description, True if the value must be >= the threshold).
GATES: dict[str, tuple[str, bool]] = {
    "min_angle": ("smallest corner angle, degrees", True),
    "max_angle": ("largest corner angle, degrees", False),
    "max_inverted": ("number of inverted cells (signed area < 0: orientation flipped)", False),
    "max_degenerate": ("number of degenerate cells (0 <= signed area <= 1e-12 x bounding-box diagonal squared; "
                       "not inverted)", False),
    "max_area_ratio": ("largest / smallest cell area", False),
    "max_aspect_ratio": ("largest Verdict aspect ratio (triangles and quads)", False),
}


#: Unit printed after a gate's value and threshold.
UNITS: dict[str, str] = {"min_angle": "°", "max_angle": "°"}

#: Gates on counts: their values print as integers.
_COUNTS = ("max_inverted", "max_degenerate")

#: Gates ``check`` applies even when no threshold is given (``resolve_thresholds(safe=True)``).
SAFE_DEFAULTS: dict[str, int] = {"max_inverted": 0, "max_degenerate": 0}


@dataclass(frozen=True)
class Gate:
    """The outcome of one gate: ``value`` is ``inf`` for an infinite area ratio, None when undefined.

    ``cell`` is the index of the worst cell (triangles first, then quads) of a
    failed gate when :func:`evaluate` was given the points and topology: the
    cell with the smallest / largest angle, the first inverted or degenerate
    cell, the smallest cell (area ratio), the cell with the largest aspect ratio.
    """

    name: str
    threshold: float
    value: float | None
    passed: bool
    cell: int | None = None

    def comparison(self) -> str:
        """Value, operator and threshold with their unit, e.g. ``12.3° < 20°`` (the operator a failure shows)."""
        at_least = GATES[self.name][1]
        unit = UNITS.get(self.name, "")
        value, threshold = _pair(self.value, self.threshold, at_least, self.name in _COUNTS)
        op = ("<" if at_least else ">") if not self.passed else (">=" if at_least else "<=")
        return f"{value}{unit} {op} {threshold}{unit}"

    def where(self) -> str:
        """`` (worst cell 17)``, or an empty string when the cell is unknown."""
        if self.cell is None:
            return ""
        return f" ({'first' if self.name in _COUNTS else 'worst'} cell {self.cell})"

    def message(self, file: str) -> str:
        """One line describing a failed gate, e.g. ``a.msh: gate min_angle failed: 12.3° < 20° (worst cell 17)``."""
        return f"{file}: gate {self.name} {'passed' if self.passed else 'failed'}: {self.comparison()}{self.where()}"

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready form; a non-finite value becomes None."""
        value = self.value if self.value is not None and math.isfinite(self.value) else None
        return {"name": self.name, "threshold": self.threshold, "value": value, "passed": self.passed,
                "cell": self.cell}


def _number(x: float) -> str:
    """A threshold as the user wrote it: ``20``, ``41.3632``, ``1e+30``."""
    if float(x).is_integer() and abs(x) < 1e15:
        return str(int(x))
    return repr(float(x))


def _pair(value: float | None, threshold: float, at_least: bool, count: bool) -> tuple[str, str]:
    """Value and threshold as text, the value with the fewest digits that still show the failure.

    At least as many decimals as the threshold has; more until the printed value
    compares with the threshold as the value does (``19.99999 < 20``, not ``20.0 < 20``).
    """
    shown = _number(threshold)
    if value is None:
        return "undefined", shown
    if math.isinf(value) or math.isnan(value):
        return str(value), shown
    if count or (float(value).is_integer() and abs(value) < 1e15 and float(threshold).is_integer()):
        return str(int(value)) if float(value).is_integer() else repr(float(value)), shown
    fails = (lambda v: v < threshold) if at_least else (lambda v: v > threshold)
    big = abs(value) >= 1e6 or "e" in shown
    decimals = len(shown.split(".")[1]) if "." in shown and not big else 0
    for digits in range(max(decimals, 1), 18):
        text = f"{value:.{digits + 3}g}" if big else f"{value:.{digits}f}"
        if fails(float(text)) == fails(value):
            return text, shown
    return repr(float(value)), shown


def _value(summary: Mapping[str, Any], name: str) -> float | None:
    if name == "min_angle":
        return summary.get("min_angle")
    if name == "max_angle":
        return summary.get("max_angle")
    if name == "max_inverted":
        return summary.get("inverted")
    if name == "max_degenerate":
        return summary.get("degenerate")
    if name == "max_area_ratio":
        ratio = summary.get("area_ratio")
        return math.inf if ratio is None else ratio
    stats = [summary.get("tri_aspect_ratio"), summary.get("quad_aspect_ratio")]
    maxima = [s["max"] for s in stats if s]
    return max(maxima) if maxima else None


def evaluate(summary: Mapping[str, Any], thresholds: Mapping[str, float | None],
             points: Any = None, topology: Any = None) -> list[Gate]:
    """Evaluate the gates whose threshold is not None, in the order of :data:`GATES`.

    A gate whose value is undefined (None, e.g. an aspect ratio on a mesh without
    cells) passes; an infinite area ratio fails any ``max_area_ratio``.  Given
    the ``points`` and ``topology`` the summary was computed from, a failed gate
    also names its worst cell (:func:`worst_cell`, computed for failures only).
    """
    out = []
    for name, (_, at_least) in GATES.items():
        threshold = thresholds.get(name)
        if threshold is None:
            continue
        value = _value(summary, name)
        if value is None:
            passed = True
        else:
            passed = value >= threshold if at_least else value <= threshold
        cell = worst_cell(points, topology, name) if not passed and topology is not None else None
        out.append(Gate(name, threshold, None if value is None else float(value), bool(passed), cell))
    return out


def worst_cell(points: Any, topology: Any, name: str) -> int | None:
    """Index (triangles first, then quads) of the cell that decides gate ``name``; None without cells.

    Vectorized over cells, from the per-cell measures of :mod:`anglesmooth.quality`.
    """
    import numpy as np

    from . import quality

    pts = np.asarray(points, dtype=np.float64)
    if name == "min_angle":
        per_cell, pick = quality.cell_min_angles(pts, topology), np.argmin
    elif name == "max_angle":
        per_cell, pick = quality.cell_max_angles(pts, topology), np.argmax
    elif name in ("max_inverted", "max_degenerate"):
        first = (quality.inverted_cells if name == "max_inverted" else quality.degenerate_cells)(pts, topology)
        return int(first[0]) if first.size else None
    elif name == "max_area_ratio":
        per_cell, pick = np.abs(quality.cell_areas(pts, topology)), np.argmin
    else:
        per_cell = np.concatenate([quality.tri_aspect_ratio(pts, topology), quality.quad_aspect_ratio(pts, topology)])
        pick = np.argmax
    return int(pick(per_cell)) if per_cell.size else None


def _toml_loads(text: str) -> dict:
    if sys.version_info >= (3, 11):
        import tomllib
    else:  # pragma: no cover - exercised on Python 3.10 only
        import tomli as tomllib
    return tomllib.loads(text)


def read_toml(path: Path, what: str, error: type[AngleSmoothError] = GateFileError) -> dict:
    """The parsed TOML file ``path``; ``error(...)`` naming ``what`` (``gate file``, ``configuration``) and the
    path when it cannot be read, is not UTF-8 or is not TOML.  The one TOML reader of gate and configuration files.
    """
    try:
        return _toml_loads(path.read_text(encoding="utf-8"))
    except OSError as exc:
        raise error(f"cannot read {what} '{path}': {exc.strerror or exc}") from None
    except UnicodeDecodeError:
        raise error(f"{what} '{path}' is not UTF-8 text") from None
    except ValueError as exc:  # tomllib.TOMLDecodeError
        raise error(f"{what} '{path}' is not valid TOML: {exc}") from None


def load_gate_file(path: str | Path) -> dict[str, float]:
    """Read thresholds from a TOML gate file.

    Raises :class:`~anglesmooth.errors.GateFileError` (exit code 2) naming the problem when
    the file cannot be read, is not TOML, has an unknown key, or a value that is
    not a number (the command line reports it as a usage error, exit 2).
    """
    path = Path(path)
    data = read_toml(path, "gate file")
    tool = data.get("tool")
    tool = tool.get("anglesmooth") if isinstance(tool, dict) else None
    if tool is not None and not isinstance(tool, dict):
        raise GateFileError(f"gate file '{path}': [tool.anglesmooth] must be a table, got {tool!r}")
    table = tool.get("gates") if tool is not None else None
    if tool is not None and "gates" in tool and not isinstance(table, dict):
        raise GateFileError(f"gate file '{path}': [tool.anglesmooth] gates must be a table, got {table!r}")
    if table is None:
        if "gates" in data and not isinstance(data["gates"], dict):
            raise GateFileError(f"gate file '{path}': gates must be a table, got {data['gates']!r}")
        table = data["gates"] if isinstance(data.get("gates"), dict) else data
    return validate_gates(table, f"gate file '{path}'")


def validate_gates(table: Mapping[str, Any], source: str) -> dict[str, float]:
    """Check a table of thresholds (keys of :data:`GATES`, finite numbers); ``source`` names it in errors.

    Raises :class:`~anglesmooth.errors.GateFileError` (exit code 2) naming the
    key and the source.  A key may be written with hyphens (``min-angle``).
    """
    out: dict[str, float] = {}
    for raw, value in table.items():
        key = str(raw).replace("-", "_")
        if key not in GATES:
            raise GateFileError(f"{source}: unknown key {raw!r} (valid keys: {', '.join(GATES)})")
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
            raise GateFileError(f"{source}: {key} must be a finite number, got {value!r}")
        if key in _COUNTS and (value < 0 or not float(value).is_integer()):
            raise GateFileError(f"{source}: {key} must be a non-negative integer")
        out[key] = value
    return out


def resolve_thresholds(options: Mapping[str, float | None], gate_file: str | Path | None = None, *,
                       base: Mapping[str, float] | None = None, safe: bool = False) -> dict[str, float]:
    """Merge thresholds: ``base`` (e.g. from a configuration file), then the gate file, then the options.

    When any gate is given, or ``safe`` is true, ``max_inverted`` and
    ``max_degenerate`` that are not given are 0: a mesh with inverted or
    degenerate cells never passes a quality gate silently.

    >>> resolve_thresholds({"min_angle": 20, "max_angle": None})
    {'min_angle': 20, 'max_inverted': 0, 'max_degenerate': 0}
    >>> resolve_thresholds({"min_angle": None})
    {}
    >>> resolve_thresholds({"max_inverted": 3}, safe=True)
    {'max_inverted': 3, 'max_degenerate': 0}
    """
    merged: dict[str, float] = dict(base or {})
    if gate_file is not None:
        merged.update(load_gate_file(gate_file))
    merged.update({k: v for k, v in options.items() if v is not None})
    if merged or safe:
        for name, default in SAFE_DEFAULTS.items():
            merged.setdefault(name, default)
    return merged
