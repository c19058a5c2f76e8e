"""Quality gates: thresholds on a quality summary, from options or a TOML file.

A gate compares one number of :func:`anglesmooth.quality.summarize`'s summary
with a threshold.  The five gates and what passes:

==================  =====================================================  =========
gate                value                                                  passes if
==================  =====================================================  =========
min_angle           ``min_angle``                                          value >= threshold
max_angle           ``max_angle``                                          value <= threshold
max_inverted        ``inverted``                                           value <= threshold
max_area_ratio      ``area_ratio`` (infinite when a cell has zero area)     value <= threshold
max_aspect_ratio    max of the triangle and quad Verdict aspect ratios      value <= threshold
==================  =====================================================  =========

A gate file is TOML with the same keys, at top level, in a ``[gates]`` table, or
in ``[tool.anglesmooth.gates]`` (so ``pyproject.toml`` can hold them)::

    min_angle = 20
    max_inverted = 0

>>> summary = {"min_angle": 12.34, "max_angle": 150.0, "inverted": 0, "area_ratio": 4.0,
...            "tri_aspect_ratio": {"min": 1.0, "mean": 1.2, "max": 3.0}, "quad_aspect_ratio": None}
>>> [g.passed for g in evaluate(summary, {"min_angle": 20, "max_aspect_ratio": 5})]
[False, True]
>>> evaluate(summary, {"min_angle": 20})[0].message("a.msh")
'a.msh: gate min_angle failed: 12.3 < 20'
"""

from __future__ import annotations

import math
import sys
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from .errors import GateFileError

__all__ = ["GATES", "Gate", "evaluate", "load_gate_file", "resolve_thresholds"]

#: Gate name -> (summary value description, True if the value must be >= the threshold).
GATES: dict[str, tuple[str, bool]] = {
    "min_angle": ("smallest corner angle, degrees", True),
    "max_angle": ("largest corner angle, degrees", False),
    "max_inverted": ("number of inverted cells", False),
    "max_area_ratio": ("largest / smallest cell area", False),
    "max_aspect_ratio": ("largest Verdict aspect ratio (triangles and quads)", False),
}


@dataclass(frozen=True)
class Gate:
    """The outcome of one gate: ``value`` is ``inf`` for an infinite area ratio, None when undefined."""

    name: str
    threshold: float
    value: float | None
    passed: bool

    def message(self, file: str) -> str:
        """One line describing a failed gate, e.g. ``a.msh: gate min_angle failed: 12.3 < 20``."""
        op = "<" if GATES[self.name][1] else ">"
        return f"{file}: gate {self.name} failed: {_fmt(self.value)} {op} {_fmt(self.threshold)}"

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready form; a non-finite value becomes None."""
        value = self.value if self.value is not None and math.isfinite(self.value) else None
        return {"name": self.name, "threshold": self.threshold, "value": value, "passed": self.passed}


def _fmt(x: float | None) -> str:
    if x is None:
        return "undefined"
    if math.isinf(x):
        return "inf"
    if float(x).is_integer() and abs(x) < 1e15:
        return str(int(x))
    return f"{x:.3g}" if abs(x) >= 1e6 else f"{x:.1f}" if abs(x) >= 1 else f"{x:.3g}"


def _value(summary: Mapping[str, Any], name: str) -> float | None:
    if name == "min_angle":
        return summary.get("min_angle")
    if name == "max_angle":
        return summary.get("max_angle")
    if name == "max_inverted":
        return summary.get("inverted")
    if name == "max_area_ratio":
        ratio = summary.get("area_ratio")
        return math.inf if ratio is None else ratio
    stats = [summary.get("tri_aspect_ratio"), summary.get("quad_aspect_ratio")]
    maxima = [s["max"] for s in stats if s]
    return max(maxima) if maxima else None


def evaluate(summary: Mapping[str, Any], thresholds: Mapping[str, float | None]) -> list[Gate]:
    """Evaluate the gates whose threshold is not None, in the order of :data:`GATES`.

    A gate whose value is undefined (None, e.g. an aspect ratio on a mesh without
    cells) passes; an infinite area ratio fails any ``max_area_ratio``.
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
        out.append(Gate(name, threshold, None if value is None else float(value), bool(passed)))
    return out


def _toml_loads(text: str) -> dict:
    if sys.version_info >= (3, 11):
        import tomllib
    else:  # pragma: no cover - exercised on Python 3.10 only
        import tomli as tomllib
    return tomllib.loads(text)


def load_gate_file(path: str | Path) -> dict[str, float]:
    """Read thresholds from a TOML gate file.

    Raises :class:`~anglesmooth.errors.GateFileError` (exit code 2) naming the problem when
    the file cannot be read, is not TOML, has an unknown key, or a value that is
    not a number (the command line reports it as a usage error, exit 2).
    """
    path = Path(path)
    try:
        data = _toml_loads(path.read_text(encoding="utf-8"))
    except OSError as exc:
        raise GateFileError(f"cannot read gate file '{path}': {exc.strerror or exc}") from None
    except UnicodeDecodeError:
        raise GateFileError(f"gate file '{path}' is not UTF-8 text") from None
    except ValueError as exc:  # tomllib.TOMLDecodeError
        raise GateFileError(f"gate file '{path}' is not valid TOML: {exc}") from None
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
    out: dict[str, float] = {}
    for key, value in table.items():
        if key not in GATES:
            raise GateFileError(f"gate file '{path}': unknown key {key!r} (valid keys: {', '.join(GATES)})")
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
            raise GateFileError(f"gate file '{path}': {key} must be a finite number, got {value!r}")
        if key == "max_inverted" and (value < 0 or not float(value).is_integer()):
            raise GateFileError(f"gate file '{path}': max_inverted must be a non-negative integer")
        out[key] = value
    return out


def resolve_thresholds(options: Mapping[str, float | None], gate_file: str | Path | None = None) -> dict[str, float]:
    """Merge the gate file with command-line thresholds (options win).

    When any gate is given and ``max_inverted`` is not, ``max_inverted`` is 0:
    a mesh with inverted cells never passes a quality gate silently.

    >>> resolve_thresholds({"min_angle": 20, "max_angle": None})
    {'min_angle': 20, 'max_inverted': 0}
    >>> resolve_thresholds({"min_angle": None})
    {}
    """
    merged: dict[str, float] = dict(load_gate_file(gate_file)) if gate_file is not None else {}
    merged.update({k: v for k, v in options.items() if v is not None})
    if merged and "max_inverted" not in merged:
        merged["max_inverted"] = 0
    return merged
