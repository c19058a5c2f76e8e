"""How gate results are reported: the registry behind ``--format``, and the JUnit XML of ``--junit-xml``.

Formats (``FORMATS``; ``--format`` offers its keys):

``table`` (default)
    One line per failed gate on stderr (``a.msh: gate min_angle failed: 12.3° < 20° (worst cell 17)``,
    printed even with ``--quiet``: it explains exit 1) and ``a.msh: all 3 gates passed`` otherwise.
``github``
    GitHub Actions workflow commands: one ``::error file=PATH,title=anglesmooth min_angle::value 12.3° < 20°``
    per failed gate and file (and per unreadable file), then one ``::notice`` with the summary.  GitHub shows
    at most 10 error annotations per step (and 50 per job), so the 11th failure on prints as a plain line
    and the notice counts them.  The commands go to stdout, or to stderr when stdout carries data
    (``--json -``, a mesh written to ``-``); the runner reads both.

The human tables of the commands are printed on stderr whatever the format (``--quiet`` drops them).

JUnit XML (``--junit-xml PATH``): one ``<testsuite>`` per run, one ``<testcase>`` per file and gate
(``classname`` and ``file`` the file, ``name`` the gate), a ``<failure>`` with the value and the threshold
for a failed gate, an ``<error>`` for an unreadable file.  GitLab (``artifacts:reports:junit``) and Jenkins
show it.  The file is staged beside PATH and renamed into place, like the JSON report.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import NamedTuple

import click

from .. import _paths
from ..gates import Gate

#: GitHub shows at most this many error annotations per step (docs: "10 error annotations ... per step").
GITHUB_MAX_ERRORS = 10


@dataclass
class Outcome:
    """The gate results of one file: ``error`` is the error line of a file that could not be checked."""

    name: str
    gates: list[Gate] = field(default_factory=list)
    error: str | None = None

    @property
    def failed(self) -> list[Gate]:
        return [g for g in self.gates if not g.passed]


class Format(NamedTuple):
    name: str
    help: str
    write: Callable[..., None]  # write(outcomes, plain=..., data_on_stdout=...)


# ------------------------------------------------------------------ table


def write_table(outcomes: Sequence[Outcome], *, plain: Callable[[str], None], data_on_stdout: bool = False) -> None:
    """Failed-gate lines on stderr (always), then ``all N gates passed`` through ``plain`` (quiet-aware)."""
    for o in outcomes:
        for g in o.failed:
            click.echo(g.message(o.name), err=True)
    for o in outcomes:
        if o.error is None and o.gates and not o.failed:
            plain(f"{o.name}: all {len(o.gates)} gates passed")


# ------------------------------------------------------------------ github


def escape_data(text: str) -> str:
    """Escape the message of a workflow command (``%``, CR, LF), as actions/toolkit's ``escapeData``."""
    return text.replace("%", "%25").replace("\r", "%0D").replace("\n", "%0A")


def escape_property(text: str) -> str:
    """Escape a property value (also ``:`` and ``,``), as actions/toolkit's ``escapeProperty``."""
    return escape_data(text).replace(":", "%3A").replace(",", "%2C")


def _command(kind: str, message: str, file: str | None = None, title: str | None = None) -> str:
    props = []
    if file is not None and not file.startswith("<"):  # <stdin>, <stdout>: no file to point at
        props.append(f"file={escape_property(file)}")
    if title is not None:
        props.append(f"title={escape_property(title)}")
    return f"::{kind}{' ' + ','.join(props) if props else ''}::{escape_data(message)}"


def github_lines(outcomes: Sequence[Outcome]) -> list[str]:
    """The workflow commands (and, past GitHub's limit, plain lines) for ``outcomes``, the notice last."""
    lines: list[str] = []
    annotated = plain = 0
    for o in outcomes:
        problems = [(f"anglesmooth: error: {o.error}", "anglesmooth", o.error)] if o.error is not None else []
        problems += [(g.message(o.name), f"anglesmooth {g.name}", f"value {g.comparison()}{g.where()}")
                     for g in o.failed]
        for text, title, message in problems:
            if annotated < GITHUB_MAX_ERRORS:
                lines.append(_command("error", message, file=o.name, title=title))
                annotated += 1
            else:
                lines.append(text)
                plain += 1
    lines.append(_command("notice", summary(outcomes, plain), title="anglesmooth"))
    return lines


def summary(outcomes: Sequence[Outcome], not_annotated: int = 0) -> str:
    """One sentence: files checked, passed, failed (gates), unreadable."""
    unreadable = sum(o.error is not None for o in outcomes)
    failed = [o for o in outcomes if o.error is None and o.failed]
    gates = sum(len(o.failed) for o in failed)
    passed = len(outcomes) - unreadable - len(failed)
    files = f"{len(outcomes)} file{'s' if len(outcomes) != 1 else ''}"
    text = f"{files}: {passed} passed, {len(failed)} failed ({gates} gate{'s' if gates != 1 else ''})"
    if unreadable:
        text += f", {unreadable} unreadable"
    if not_annotated:
        text += (f"; {not_annotated} more failure(s) in the log only "
                 f"(GitHub shows {GITHUB_MAX_ERRORS} error annotations per step)")
    return text


def write_github(outcomes: Sequence[Outcome], *, plain: Callable[[str], None], data_on_stdout: bool = False) -> None:
    for line in github_lines(outcomes):
        click.echo(line, err=data_on_stdout)


FORMATS: dict[str, Format] = {
    "table": Format("table", "failed gates as plain lines on stderr (default)", write_table),
    "github": Format("github", "GitHub Actions workflow commands (::error / ::notice annotations)", write_github),
}

format_option = click.option(
    "--format", "report_format", type=click.Choice(list(FORMATS)), default="table", show_default=True,
    help="How gate results are reported: " + "; ".join(f"{f.name}: {f.help}" for f in FORMATS.values()) + ".")
junit_option = click.option("--junit-xml", "junit_path", type=click.Path(dir_okay=False), metavar="PATH",
                            help="Also write the gate results as JUnit XML (GitLab, Jenkins).")


def report(report_format: str, outcomes: Sequence[Outcome], plain: Callable[[str], None],
           data_on_stdout: bool = False) -> None:
    """Write ``outcomes`` in the format named ``report_format``."""
    FORMATS[report_format].write(outcomes, plain=plain, data_on_stdout=data_on_stdout)


# ------------------------------------------------------------------ JUnit XML


def junit_xml(outcomes: Sequence[Outcome], suite: str) -> str:
    """The JUnit XML document: one testsuite, a testcase per file x gate (an ``<error>`` for an unreadable file)."""
    cases = []
    for o in outcomes:
        if o.error is not None:
            case = ET.Element("testcase", classname=o.name, name="read", file=o.name)
            ET.SubElement(case, "error", message=o.error, type="error").text = o.error
            cases.append(case)
        for g in o.gates:
            case = ET.Element("testcase", classname=o.name, name=g.name, file=o.name)
            if not g.passed:
                failure = ET.SubElement(case, "failure", message=f"{g.name}: {g.comparison()}{g.where()}",
                                        type=g.name)
                failure.text = (f"{o.name}: gate {g.name} failed\nvalue: {g.value}\nthreshold: {g.threshold}"
                                + (f"\ncell: {g.cell}" if g.cell is not None else ""))
            cases.append(case)
    failures = sum(len(o.failed) for o in outcomes)
    errors = sum(o.error is not None for o in outcomes)
    counts = {"tests": str(len(cases)), "failures": str(failures), "errors": str(errors), "skipped": "0"}
    root = ET.Element("testsuites", name="anglesmooth", **counts)
    suite_el = ET.SubElement(root, "testsuite", name=suite, **counts)
    suite_el.extend(cases)
    ET.indent(root)
    return '<?xml version="1.0" encoding="UTF-8"?>\n' + ET.tostring(root, encoding="unicode") + "\n"


def check_junit_path(path: str | None) -> None:
    """``--junit-xml -`` is refused: stdout carries the report or the mesh (and JUnit is a file CI collects)."""
    if path == "-":
        from .errors import Usage

        raise Usage("--junit-xml needs a file path ('-' is not supported)")


def stage_text(path: str, text: str, what: str = "JUnit XML") -> None:
    """Write ``text`` to ``path`` like every output (``anglesmooth._paths``): staged in the command's
    Outputs and committed with the others, or atomically at once outside one.  The one place
    ``--junit-xml`` writes."""

    def write(tmp):
        with open(tmp, "w", encoding="utf-8") as fh:
            fh.write(text)

    _paths.atomic_write(path, write, what=f"cannot write {what}")


def write_junit(path: str | None, outcomes: Sequence[Outcome], suite: str) -> None:
    """Write the JUnit XML file atomically (nothing when ``path`` is None)."""
    if path is not None:
        stage_text(path, junit_xml(outcomes, suite))


def outcome(entry: dict) -> Outcome:
    """The :class:`Outcome` of one ``check`` JSON entry ({input, gates, error, ...})."""
    return Outcome(entry["input"], [Gate(**g) for g in entry["gates"]], entry["error"])
