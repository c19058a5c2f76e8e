"""Project configuration: ``[tool.anglesmooth]`` in ``pyproject.toml``, or a standalone ``anglesmooth.toml``.

Found as ruff finds its configuration: from a directory (the working directory)
up to the root, the first directory holding ``anglesmooth.toml`` (its top level
is the configuration) or a ``pyproject.toml`` with a ``[tool.anglesmooth]``
table wins; a ``pyproject.toml`` without the table is passed over.  In one
directory ``anglesmooth.toml`` wins over ``pyproject.toml``.

Keys are the long option names of the command line (:data:`KEYS`); the gate
thresholds go in a ``gates`` table with the gate names (as in a gate file)::

    [tool.anglesmooth]
    method = "angle"
    passes = 20
    fix-group = ["wall"]

    [tool.anglesmooth.gates]
    min_angle = 20
    max_inverted = 0

The library never reads a configuration by itself: only the command line calls
:func:`discover`, and its options override what the file says.  An unknown key
or a value of the wrong type raises :class:`ConfigFileError` (exit code 2)
naming the key and the file.

>>> cfg = parse({"passes": 5, "fix-group": "wall", "gates": {"min_angle": 20}}, "anglesmooth.toml")
>>> cfg.settings, cfg.gates
({'passes': 5, 'fix-group': ['wall']}, {'min_angle': 20})
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from .errors import AngleSmoothError, GateFileError
from .gates import GATES, read_toml, validate_gates

__all__ = ["KEYS", "Config", "ConfigFileError", "discover", "find_config", "load_config", "parse"]

#: Configuration key -> (kind, what it sets).  Kinds: str, int, number, bool, strings (a list of
#: strings, or one string), path (relative to the configuration file's directory).
KEYS: dict[str, tuple[str, str]] = {
    "method": ("str", "smoothing method (smooth)"),
    "passes": ("int", "maximum passes (smooth, compare)"),
    "tol": ("number", "stop tolerance, relative to the mean edge length (smooth)"),
    "order": ("str", "update order: colour or jacobi (smooth, compare)"),
    "no-guard": ("bool", "textbook methods without the guards (smooth, compare)"),
    "fix-group": ("strings", "named groups whose nodes stay fixed (smooth)"),
    "fix-nodes": ("path", "file of 0-based node indices to keep fixed (smooth)"),
    "input-format": ("str", "meshio format of the input (smooth, check, compare)"),
    "output-format": ("str", "meshio format of the output (smooth)"),
    "progress": ("bool", "show progress (smooth)"),
    "format": ("str", "how gate results are reported: table or github (smooth, check)"),
    "exit-zero": ("bool", "report failed gates but exit 0 (smooth, check)"),
    "gate-file": ("path", "TOML file with gate thresholds (smooth, check)"),
}

#: File names looked for in every directory, in order.
FILE_NAMES = ("anglesmooth.toml", "pyproject.toml")


class ConfigFileError(AngleSmoothError):
    """A configuration file that cannot be used (unreadable, invalid TOML, unknown key, bad value)."""

    exit_code = 2


@dataclass(frozen=True)
class Config:
    """A parsed configuration: ``settings`` by key of :data:`KEYS` (paths made absolute), ``gates`` thresholds."""

    path: Path | None
    settings: dict[str, Any] = field(default_factory=dict)
    gates: dict[str, float] = field(default_factory=dict)


def _read_toml(path: Path) -> dict:
    return read_toml(path, "configuration", ConfigFileError)


def _table(path: Path, data: dict) -> dict | None:
    """The anglesmooth table of a parsed file: ``[tool.anglesmooth]`` of a pyproject, else the whole file (or its
    ``[tool.anglesmooth]`` when it has one, e.g. a pyproject copied under another name for ``--config``)."""
    tool = data.get("tool")
    if path.name != "pyproject.toml" and not (isinstance(tool, dict) and "anglesmooth" in tool):
        return data
    table = tool.get("anglesmooth") if isinstance(tool, dict) else None
    if table is not None and not isinstance(table, dict):
        raise ConfigFileError(f"configuration '{path}': tool.anglesmooth must be a table")
    return table


def find_config(start: str | Path | None = None) -> Path | None:
    """The configuration file that applies in ``start`` (default: the working directory), or None."""
    try:
        here = Path(start if start is not None else Path.cwd()).absolute()
    except OSError:  # the working directory was removed
        return None
    for directory in (here, *here.parents):
        for name in FILE_NAMES:
            candidate = directory / name
            try:
                if not candidate.is_file():
                    continue
            except OSError:  # a directory that cannot be searched: no configuration there
                continue
            if name == "anglesmooth.toml" or _table(candidate, _read_toml(candidate)) is not None:
                return candidate
    return None


def load_config(path: str | Path) -> Config:
    """Read and validate a configuration file (``anglesmooth.toml``, or a pyproject's ``[tool.anglesmooth]``)."""
    path = Path(path)
    table = _table(path, _read_toml(path))
    return parse(table or {}, path)


def discover(start: str | Path | None = None) -> Config | None:
    """:func:`load_config` of :func:`find_config`, or None when no configuration applies."""
    path = find_config(start)
    return load_config(path) if path is not None else None


def _bad(source: Path | str, key: str, expected: str, value: Any) -> ConfigFileError:
    return ConfigFileError(f"configuration '{source}': {key} must be {expected}, got {value!r}")


def _check(source: Path | str, key: str, kind: str, value: Any) -> Any:
    if kind == "bool":
        if not isinstance(value, bool):
            raise _bad(source, key, "true or false", value)
        return value
    if kind == "int":
        if isinstance(value, bool) or not isinstance(value, int) or value < 0:
            raise _bad(source, key, "a non-negative integer", value)
        return value
    if kind == "number":
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value) or value < 0:
            raise _bad(source, key, "a non-negative number", value)
        return value
    if kind == "strings":
        values = [value] if isinstance(value, str) else value
        if not isinstance(values, list) or not all(isinstance(v, str) for v in values):
            raise _bad(source, key, "a string or a list of strings", value)
        return list(values)
    if not isinstance(value, str) or not value:
        raise _bad(source, key, "a non-empty string", value)
    if kind == "path":
        base = Path(source).absolute().parent
        return str(Path(value) if Path(value).is_absolute() else base / value)
    return value


def parse(table: Mapping[str, Any], source: str | Path) -> Config:
    """Validate a configuration table (``source`` names it in errors and anchors relative paths)."""
    settings: dict[str, Any] = {}
    gates: dict[str, float] = {}
    for key, value in table.items():
        if key == "gates":
            if not isinstance(value, dict):
                raise ConfigFileError(f"configuration '{source}': gates must be a table of thresholds")
            try:
                gates = validate_gates(value, f"configuration '{source}' [gates]")
            except GateFileError as exc:
                raise ConfigFileError(str(exc)) from None
            continue
        name = key.replace("_", "-")
        if name not in KEYS:
            hint = ""
            if name.replace("-", "_") in GATES:
                hint = f"; gate thresholds go in the gates table ([tool.anglesmooth.gates] {name.replace('-', '_')} = ...)"
            raise ConfigFileError(f"configuration '{source}': unknown key {key!r}{hint} "
                                  f"(valid keys: {', '.join(KEYS)}, gates)")
        settings[name] = _check(source, name, KEYS[name][0], value)
    return Config(Path(source), settings, gates)
