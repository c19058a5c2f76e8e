"""Formatting only: quality summaries as rich tables and as JSON documents.

Nothing here prints; the builders return rich renderables or plain dicts, and
the command line decides where they go (tables to stderr, JSON to a file or
stdout).

>>> before = {"min_angle": 10.0, "inverted": 2}
>>> after = {"min_angle": 25.5, "inverted": 0}
>>> change(before["min_angle"], after["min_angle"], +1)
('+15.50', 'green')
>>> change(2, 0, -1, "int")
('-2', 'green')
>>> to_json({"a": float("inf"), "b": [1.5, float("nan")]})
'{\\n  "a": null,\\n  "b": [\\n    1.5,\\n    null\\n  ]\\n}'
"""

from __future__ import annotations

import json
import math
from collections.abc import Iterable, Mapping, Sequence
from typing import Any

from rich.table import Table
from rich.text import Text

from .__about__ import __version__

__all__ = [
    "ROWS",
    "SCHEMA_VERSION",
    "change",
    "check_json",
    "check_table",
    "compare_json",
    "compare_table",
    "files_table",
    "fmt",
    "smooth_json",
    "smooth_table",
    "to_json",
]

#: Version of the JSON documents written by ``--json``; bumped on incompatible changes.
SCHEMA_VERSION = 1

# (summary key, sub-key for {min, mean, max} statistics or None, label, kind, better)
# kind: "int", "angle", "num"; better: +1 higher is better, -1 lower is better, 0 neutral.
ROWS: list[tuple[str, str | None, str, str, int]] = [
    ("nodes", None, "nodes", "int", 0),
    ("triangles", None, "triangles", "int", 0),
    ("quads", None, "quads", "int", 0),
    ("fixed_nodes", None, "fixed nodes", "int", 0),
    ("min_angle", None, "min angle (°)", "angle", +1),
    ("max_angle", None, "max angle (°)", "angle", -1),
    ("tri_min_angle", None, "triangle min angle (°)", "angle", +1),
    ("tri_max_angle", None, "triangle max angle (°)", "angle", -1),
    ("quad_min_angle", None, "quad min angle (°)", "angle", +1),
    ("quad_max_angle", None, "quad max angle (°)", "angle", -1),
    ("angles_below_20", None, "angles < 20°", "int", -1),
    ("angles_above_130", None, "angles > 130°", "int", -1),
    ("angles_above_150", None, "angles > 150°", "int", -1),
    ("min_area", None, "min area", "num", 0),
    ("max_area", None, "max area", "num", 0),
    ("area_ratio", None, "area ratio (max/min)", "num", -1),
    ("inverted", None, "inverted cells", "int", -1),
    ("degenerate", None, "degenerate cells", "int", -1),
    ("nonconvex_quads", None, "non-convex quads", "int", -1),
    ("tri_aspect_ratio", "mean", "triangle aspect ratio, mean", "num", -1),
    ("tri_aspect_ratio", "max", "triangle aspect ratio, max", "num", -1),
    ("tri_radius_ratio", "max", "triangle radius ratio, max", "num", -1),
    ("quad_scaled_jacobian", "min", "quad scaled Jacobian, min", "num", +1),
    ("quad_scaled_jacobian", "mean", "quad scaled Jacobian, mean", "num", +1),
    ("quad_aspect_ratio", "max", "quad aspect ratio, max", "num", -1),
    ("quad_condition", "max", "quad condition, max", "num", -1),
    ("min_edge", None, "min edge length", "num", 0),
    ("edge_ratio", None, "edge ratio (max/min)", "num", -1),
]


def fmt(value: Any, kind: str = "num") -> str:
    """Format one table cell; None is an en dash.

    >>> fmt(12.3456, "angle"), fmt(3, "int"), fmt(1234567.0), fmt(None), fmt(0.000123)
    ('12.35', '3', '1.235e+06', '–', '0.000123')
    """
    if value is None:
        return "–"
    if kind == "int":
        return str(int(value))
    value = float(value)
    if math.isinf(value):
        return "inf"
    if kind == "angle":
        return f"{value:.2f}"
    return f"{value:.4g}"


def change(before: Any, after: Any, better: int, kind: str = "angle") -> tuple[str, str]:
    """The change column: signed difference and a colour (green better, red worse)."""
    if before is None or after is None:
        return ("", "")
    diff = float(after) - float(before)
    if diff == 0 or not math.isfinite(diff):
        return ("=" if diff == 0 else "", "dim")
    style = "" if better == 0 else "green" if diff * better > 0 else "red"
    if kind == "int":
        return (f"{int(diff):+d}", style)
    return (f"{diff:+.2f}" if kind == "angle" else f"{diff:+.4g}", style)


def _get(summary: Mapping[str, Any], key: str, sub: str | None) -> Any:
    value = summary.get(key)
    if sub is not None:
        return None if not value else value.get(sub)
    return value


def _rows(*summaries: Mapping[str, Any]) -> Iterable[tuple[str, str | None, str, str, int]]:
    """Rows with a value in at least one summary (per-type rows vanish for absent cell types)."""
    mixed = any(s.get("triangles") and s.get("quads") for s in summaries)
    for row in ROWS:
        if row[0].startswith(("tri_min", "tri_max", "quad_min", "quad_max")) and not mixed:
            continue  # same as the overall angle rows on a single-type mesh
        if any(_get(s, row[0], row[1]) is not None for s in summaries):
            yield row


def smooth_table(before: Mapping[str, Any], after: Mapping[str, Any], run: Mapping[str, Any], title: str = "") -> Table:
    """Before | after | change for every key metric, then the run's own numbers (passes, rejected moves, ...)."""
    table = Table(title=Text(title) if title else None, title_justify="left")
    table.add_column("metric")
    table.add_column("before", justify="right")
    table.add_column("after", justify="right")
    table.add_column("change", justify="right")
    for key, sub, label, kind, better in _rows(before, after):
        b, a = _get(before, key, sub), _get(after, key, sub)
        text, style = change(b, a, better, kind)
        table.add_row(label, fmt(b, kind), fmt(a, kind), f"[{style}]{text}[/]" if style else text)
    table.add_section()
    for label, value in run.items():
        table.add_row(label, "", str(value), "")
    return table


def check_table(summary: Mapping[str, Any], title: str = "") -> Table:
    """One file's quality: metric | value."""
    table = Table(title=Text(title) if title else None, title_justify="left")
    table.add_column("metric")
    table.add_column("value", justify="right")
    for key, sub, label, kind, _ in _rows(summary):
        table.add_row(label, fmt(_get(summary, key, sub), kind))
    return table


def _status(passed: bool | None, error: str | None) -> str:
    if error is not None:
        return "[red]ERROR[/]"
    if passed is None:
        return ""
    return "[green]pass[/]" if passed else "[red]FAIL[/]"


def files_table(entries: Sequence[Mapping[str, Any]], with_gates: bool) -> Table:
    """One row per checked file (``entries`` as in :func:`check_json`)."""
    table = Table()
    for name, justify in [
        ("file", "left"),
        ("cells", "right"),
        ("min angle", "right"),
        ("max angle", "right"),
        ("<20°", "right"),
        (">130°", "right"),
        (">150°", "right"),
        ("area ratio", "right"),
        ("inverted", "right"),
    ]:
        table.add_column(name, justify=justify, no_wrap=name != "file")
    if with_gates or any(e.get("error") for e in entries):
        table.add_column("gates")
    for e in entries:
        s = e.get("report") or {}
        cells = (s["triangles"] + s["quads"]) if s else None
        row = [
            Text(str(e["input"])),  # a file name, not markup
            fmt(cells, "int"),
            fmt(s.get("min_angle"), "angle"),
            fmt(s.get("max_angle"), "angle"),
            fmt(s.get("angles_below_20"), "int"),
            fmt(s.get("angles_above_130"), "int"),
            fmt(s.get("angles_above_150"), "int"),
            fmt(s.get("area_ratio") if s else None),
            fmt(s.get("inverted"), "int"),
        ]
        if len(table.columns) > len(row):
            row.append(_status(e.get("passed") if with_gates else None, e.get("error")))
        table.add_row(*row)
    return table


def compare_table(before: Mapping[str, Any], results: Sequence[Mapping[str, Any]], title: str = "") -> Table:
    """The paper's Tables 1-2: one row for the input, one per method (``results`` as in :func:`compare_json`)."""
    table = Table(title=Text(title) if title else None, title_justify="left")
    for name in ["method", "passes", "min angle", "max angle", "<20°", ">130°", ">150°", "area ratio",
                 "inverted", "rejected", "time (s)"]:
        table.add_column(name, justify="left" if name == "method" else "right", no_wrap=True)

    def row(label, s, passes="", rejected="", elapsed=""):
        return [
            label,
            str(passes),
            fmt(s["min_angle"], "angle"),
            fmt(s["max_angle"], "angle"),
            fmt(s["angles_below_20"], "int"),
            fmt(s["angles_above_130"], "int"),
            fmt(s["angles_above_150"], "int"),
            fmt(s["area_ratio"]),
            fmt(s["inverted"], "int"),
            str(rejected),
            elapsed,
        ]

    table.add_row(*row("input", before))
    table.add_section()
    for r in results:
        table.add_row(*row(r["method"], r["after"], r["passes"], r["rejected"], f"{r['elapsed_s']:.3f}"))
    return table


def _clean(obj: Any) -> Any:
    """JSON-safe copy: non-finite floats become None, numpy scalars/arrays plain Python."""
    if isinstance(obj, float):
        return obj if math.isfinite(obj) else None
    if isinstance(obj, Mapping):
        return {str(k): _clean(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_clean(v) for v in obj]
    if hasattr(obj, "tolist"):  # numpy scalar or array
        return _clean(obj.tolist())
    return obj


def to_json(obj: Any) -> str:
    """Serialize a report (strict JSON: no NaN or Infinity)."""
    return json.dumps(_clean(obj), indent=2, allow_nan=False)


def _header() -> dict[str, Any]:
    return {"schema_version": SCHEMA_VERSION, "anglesmooth_version": __version__}


def smooth_json(
    *,
    input: str,
    output: str,
    method: str,
    guard: bool,
    order: str,
    passes: int,
    passes_requested: int,
    tol: float | None,
    displacements: Sequence[float],
    rejected: int,
    before: Mapping[str, Any],
    after: Mapping[str, Any],
    elapsed_s: float,
    gates: Sequence[Any],
    passed: bool,
    compile_s: float = 0.0,
) -> dict[str, Any]:
    """The JSON document of a smoothing run (see the README for the schema)."""
    return {
        **_header(),
        "input": input,
        "output": output,
        "method": method,
        "guard": guard,
        "order": order,
        "passes": passes,
        "passes_requested": passes_requested,
        "tol": tol,
        "displacement": displacements[-1] if displacements else 0.0,
        "displacements": list(displacements),
        "rejected": rejected,
        "before": dict(before),
        "after": dict(after),
        "elapsed_s": elapsed_s,
        "compile_s": compile_s,
        "gates": [g.to_dict() for g in gates],
        "passed": passed,
    }


def check_json(entries: Sequence[Mapping[str, Any]], passed: bool) -> dict[str, Any]:
    """The JSON document of ``check``: one entry per file ({input, report, gates, passed, error})."""
    return {**_header(), "files": list(entries), "passed": passed}


def compare_json(*, input: str, passes_requested: int, guard: bool, order: str,
                 before: Mapping[str, Any], results: Sequence[Mapping[str, Any]]) -> dict[str, Any]:
    """The JSON document of ``compare``: the input's summary and one result per method."""
    return {
        **_header(),
        "input": input,
        "passes_requested": passes_requested,
        "guard": guard,
        "order": order,
        "before": dict(before),
        "methods": list(results),
    }
