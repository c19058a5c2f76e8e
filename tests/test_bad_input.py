"""A corpus of bad inputs through the command line: exit code, one error line, no output, input untouched.

Every case builds its input inside a fresh temporary directory and runs
``anglesmooth INPUT OUTPUT`` (click's CliRunner; a few also as a real
subprocess).  For a failing case the test asserts the expected exit code,
exactly one non-empty stderr line starting with ``anglesmooth: error:``, no
``Traceback``, the directory unchanged (no output, no temporary file) and every
file in it bit-identical (sha256).  Cases that are accepted (duplicate or unused
nodes, clockwise cells, zero-area or tangled cells) exit 0, leave the input
untouched and get their own semantic checks below.

``python tests/test_bad_input.py`` runs the corpus and rewrites
``tests/BAD_INPUTS.md`` (input -> exit code -> message);
:func:`test_bad_inputs_table_is_current` checks the committed table against the
corpus.

Decisions documented here (and in BAD_INPUTS.md):

* duplicate nodes are allowed: a duplicate that no cell uses is an unused node
  (fixed, never moved); duplicates used on both sides of a line of cells make a
  crack whose two sides are boundaries (fixed);
* unused nodes are allowed and fixed;
* zero-area cells (three collinear nodes, or a repeated node) are reported as
  degenerate, not inverted (count and first indices, ``degenerate`` and
  ``degenerate_cells`` in the JSON report; inverted means signed area < 0); the
  guarded methods may move the free nodes of a collinear cell apart, a cell
  with a repeated node stays degenerate;
* a mesh smaller than 1e-100 across (bounding-box diagonal) is refused (exit 3):
  its squared lengths and areas underflow; coordinates beyond 1e150 are refused;
* a mesh without a free node (cells that share no edge: every node is on the
  boundary) is accepted with a warning: nothing to smooth;
* tangled input is accepted with a warning; the guarded methods never increase
  the number of invalid cells around a node and move a folded node back into
  its ring when that lowers the count (angle, laplacian, smart-laplacian): see
  test_properties.py for the exact behaviour per method;
* as root, ``chmod`` does not make a directory read-only: an output path under a
  regular file (``afile.txt/out.vtu``) and one in ``/sys`` (where nobody can
  create files) stand in for it.
"""

from __future__ import annotations

import os
import re
import subprocess
import sys
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import meshio
import numpy as np
import pytest
from cli_runner import PREFIX, cli_runner, error_line, snapshot

from anglesmooth.cli import smooth as cli_module
from anglesmooth import io as asio
from anglesmooth.cli import cli
from anglesmooth.errors import MeshReadError, MeshWriteError
from anglesmooth.generate import paper_mixed_mesh, structured_triangles
from anglesmooth.mesh import Mesh2D

HERE = Path(__file__).parent
TABLE = HERE / "BAD_INPUTS.md"


# --------------------------------------------------------------------------- building inputs


def base_mesh() -> Mesh2D:
    """A small tri-quad mesh (both cell types in every format)."""
    return paper_mixed_mesh(seed=0, n_interior=60, per_side=6)


FORMATS = {  # name -> (extension, io.write keyword arguments)
    "msh22-ascii": ("msh", {"file_format": "gmsh22", "binary": False}),
    "msh22-binary": ("msh", {"file_format": "gmsh22", "binary": True}),
    "msh41-ascii": ("msh", {"file_format": "gmsh41", "binary": False}),
    "msh41-binary": ("msh", {"file_format": "gmsh41", "binary": True}),
    "vtu": ("vtu", {}),
    "vtk": ("vtk", {}),
    "xdmf": ("xdmf", {}),
}


def valid_file(d: Path, fmt: str) -> Path:
    ext, kwargs = FORMATS[fmt]
    path = d / f"valid-{fmt}.{ext}"
    asio.write(base_mesh(), path, **kwargs)
    return path


def truncated(fmt: str, frac: float) -> Callable[[Path], Path]:
    def build(d: Path) -> Path:
        src = valid_file(d, fmt)
        data = src.read_bytes()
        src.unlink()
        out = d / f"in.{FORMATS[fmt][0]}"
        out.write_bytes(data[: int(len(data) * frac)])
        return out

    return build


def corrupted(fmt: str, how: str) -> Callable[[Path], Path]:
    """``garbage``: 32 bytes 0xFF in the middle; ``flips``: 20 seeded bytes inverted."""

    def build(d: Path) -> Path:
        src = valid_file(d, fmt)
        data = bytearray(src.read_bytes())
        src.unlink()
        if how == "garbage":
            mid = len(data) // 2
            data[mid : mid + 32] = b"\xff" * 32
        else:
            for i in np.random.default_rng(0).integers(0, len(data), 20):
                data[i] ^= 0xFF
        out = d / f"in.{FORMATS[fmt][0]}"
        out.write_bytes(bytes(data))
        return out

    return build


def raw(name: str, content: bytes) -> Callable[[Path], Path]:
    def build(d: Path) -> Path:
        (d / name).write_bytes(content)
        return d / name

    return build


def random_bytes(ext: str) -> Callable[[Path], Path]:
    return raw(f"random.{ext}", np.random.default_rng(1).bytes(4096))


GRID = structured_triangles(4, 4)  # 25 nodes, 32 triangles; node 12 is the centre
P3 = np.column_stack([GRID.points, np.zeros(GRID.n_points)])
T = GRID.triangles


def vtu(points, cells, name="in.vtu", **kwargs) -> Callable[[Path], Path]:
    def build(d: Path) -> Path:
        meshio.write(d / name, meshio.Mesh(np.asarray(points, dtype=float), cells, **kwargs))
        return d / name

    return build


def with_coord(value: float) -> Callable[[Path], Path]:
    pts = P3.copy()
    pts[7, 0] = value
    return vtu(pts, [("triangle", T)])


def with_index(value: int) -> Callable[[Path], Path]:
    tri = T.copy()
    tri[3, 1] = value
    return vtu(P3, [("triangle", tri)])


def duplicate_unused() -> Callable[[Path], Path]:
    return vtu(np.vstack([P3, P3[12:13]]), [("triangle", T)])


def duplicate_crack() -> Callable[[Path], Path]:
    """Node 12 duplicated; the cells right of the centre use the copy: a slit from node 12 outwards."""
    tri = T.copy()
    right = (GRID.points[tri].mean(axis=1)[:, 0] > GRID.points[12, 0]) & (tri == 12).any(axis=1)
    tri[right] = np.where(tri[right] == 12, GRID.n_points, tri[right])
    return vtu(np.vstack([P3, P3[12:13]]), [("triangle", tri)])


def zero_area_collinear() -> Callable[[Path], Path]:
    pts = P3.copy()
    a, b, c = T[5]
    pts[c] = 0.5 * (pts[a] + pts[b])
    return vtu(pts, [("triangle", T)])


def clockwise(every: int) -> Callable[[Path], Path]:
    tri = T.copy()
    tri[::every] = tri[::every, ::-1]
    return vtu(P3, [("triangle", tri)])


def tangled() -> Callable[[Path], Path]:
    pts = P3.copy()
    pts[12, :2] += [1.6, 0.1]
    return vtu(pts, [("triangle", T)])


def non_planar(z) -> Callable[[Path], Path]:
    pts = P3.copy()
    pts[:, 2] = z(pts)
    return vtu(pts, [("triangle", T)])


def linked(hard: bool) -> Callable[[Path], Path]:
    """A valid input ``in.vtu`` and ``link.vtu``, a hard or symbolic link to it."""

    def build(d: Path) -> Path:
        inp = vtu(P3, [("triangle", T)])(d)
        (os.link if hard else os.symlink)(inp.name if not hard else inp, d / "link.vtu")
        return inp

    return build


def file_named(name: str, content: bytes = b"x") -> Callable[[Path], None]:
    def prepare(d: Path) -> None:
        (d / name).write_bytes(content)

    return prepare


@dataclass(frozen=True)
class Case:
    id: str
    what: str
    build: Callable[[Path], Path]
    code: int
    needle: str = ""  # a substring of the error line (or of stderr for exit 0)
    output: str = "out.vtu"  # relative to the case directory, or absolute; "{input}" means the input itself
    args: tuple = ()
    prepare: Callable[[Path], None] | None = None
    extra: dict = field(default_factory=dict)


def corpus() -> list[Case]:
    cases = [
        Case("empty-msh", "empty file (.msh)", raw("in.msh", b""), 3, "the file is empty"),
        Case("empty-vtu", "empty file (.vtu)", raw("in.vtu", b""), 3, "the file is empty"),
        Case("whitespace-msh", "only whitespace (.msh)", raw("in.msh", b"\n \n"), 3, "cannot read"),
        Case("header-only-msh", "MSH 2.2 header, nothing else", raw("in.msh", b"$MeshFormat\n2.2 0 8\n$EndMeshFormat\n"),
             3, "the mesh has no nodes"),
    ]
    for fmt in FORMATS:
        for frac in (0.1, 0.5, 0.9):
            cases.append(Case(f"truncated-{fmt}-{int(frac * 100)}", f"{fmt} truncated at {int(frac * 100)} %",
                              truncated(fmt, frac), 3))
        cases.append(Case(f"garbage-{fmt}", f"{fmt} with 32 bytes 0xFF in the middle", corrupted(fmt, "garbage"), 3))
        cases.append(Case(f"flips-{fmt}", f"{fmt} with 20 random bytes inverted", corrupted(fmt, "flips"), 3))
    for ext in ("msh", "vtu", "vtk", "xdmf", "mesh", "inp", "stl", "obj"):
        cases.append(Case(f"random-{ext}", f"4 KiB of random bytes named .{ext}", random_bytes(ext), 3, "cannot read"))
    cases += [
        Case("unknown-ext", "unknown extension (.foo)", raw("in.foo", b"hello"), 3, "unknown file extension '.foo'"),
        Case("no-ext", "no extension", raw("in", b"hello"), 3, "unknown file extension '(none)'"),
        Case("bad-input-format", "--input-format nonsense", raw("in.vtu", b"hello"), 2, "unknown format 'nonsense'",
             args=("--input-format", "nonsense")),
        Case("missing-input", "input file does not exist", lambda d: d / "missing.vtu", 3, "no such file"),
        Case("input-is-dir", "input is a directory", lambda d: (d / "dir.vtu").mkdir() or d / "dir.vtu", 3,
             "is a directory"),
        Case("nan", "a NaN coordinate", with_coord(np.nan), 3, "node 7 has a non-finite coordinate"),
        Case("inf", "an inf coordinate", with_coord(np.inf), 3, "node 7 has a non-finite coordinate"),
        Case("1e308", "a 1e308 coordinate", with_coord(1e308), 3, "node 7 has an absurd coordinate"),
        Case("scaled-1e-300", "the coordinates scaled by 1e-300 (areas underflow)",
             vtu(P3 * 1e-300, [("triangle", T)]), 3, "the mesh is too small to compute with"),
        Case("scaled-1e300", "the coordinates scaled by 1e+300 (squares overflow)",
             vtu(P3 * 1e300, [("triangle", T)]), 3, "has an absurd coordinate"),
        Case("index-missing", "a cell references node 30 of 25", with_index(30), 3, "references node 30"),
        Case("index-negative", "a cell references node -1", with_index(-1), 3, "references node -1"),
        Case("no-nodes", "no nodes, one triangle block of zero cells", vtu(np.zeros((0, 3)),
                                                                           [("triangle", np.zeros((0, 3), int))]), 3),
        Case("only-lines", "only line cells", vtu(P3, [("line", [[0, 1], [1, 2]])]), 3,
             "the mesh has no triangle or quad cells"),
        Case("only-vertices", "only vertex cells", vtu(P3, [("vertex", [[0], [1]])]), 3,
             "the mesh has no triangle or quad cells"),
        Case("tetra", "a tetrahedral mesh", vtu([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], [("tetra", [[0, 1, 2, 3]])]),
             3, "unsupported cell type 'tetra'"),
        Case("tri-and-tetra", "triangles plus a tetra block", vtu(P3, [("triangle", T), ("tetra", [[0, 1, 5, 6]])]), 3,
             "unsupported cell type 'tetra'"),
        Case("hexahedron", "a hexahedron", vtu(np.vstack([P3[[0, 1, 6, 5]], P3[[0, 1, 6, 5]] + [0, 0, 1]]),
                                               [("hexahedron", [list(range(8))])]), 3, "unsupported cell type 'hexahedron'"),
        Case("polygon5", "a pentagon (polygon with 5 sides)",
             vtu([[0, 0, 0], [1, 0, 0], [1.5, 1, 0], [0.5, 1.5, 0], [-0.5, 1, 0]], [("polygon", [[0, 1, 2, 3, 4]])]), 3,
             "unsupported cell type 'polygon'"),
        Case("non-planar-bump", "surface mesh with one node lifted by 1e-3", non_planar(
            lambda p: np.where(np.arange(len(p)) == 12, 1e-3, 0.0)), 3, "mesh is not planar"),
        # accepted inputs
        Case("tilted-plane", "surface mesh on a tilted plane (smoothed in its own plane)",
             non_planar(lambda p: 0.3 * p[:, 0]), 0),
        Case("duplicate-unused", "a duplicate node that no cell uses (allowed: unused, fixed)", duplicate_unused(), 0),
        Case("duplicate-crack", "a duplicated node splitting the mesh along a slit (allowed: both sides fixed)",
             duplicate_crack(), 0),
        Case("unused-nodes", "two nodes no cell uses (allowed: fixed, not moved)",
             vtu(np.vstack([P3, [[10, 10, 0], [0.5, 0.5, 0]]]), [("triangle", T)]), 0),
        Case("zero-area-collinear", "a triangle with three collinear nodes (reported as degenerate)",
             zero_area_collinear(), 0, "degenerate cell"),
        Case("zero-area-repeated", "a triangle with a repeated node (reported as degenerate, stays degenerate)",
             vtu(P3, [("triangle", np.vstack([T, [[0, 0, 1]]]))]), 0, "degenerate cell"),
        Case("disconnected", "triangles that share no node (every node on the boundary: nothing to smooth)",
             vtu(P3[T[:4].ravel()], [("triangle", np.arange(12).reshape(4, 3))]), 0, "nothing to smooth"),
        Case("clockwise-some", "every third triangle written clockwise (re-oriented, valid)", clockwise(3), 0),
        Case("clockwise-all", "all triangles written clockwise (re-oriented, valid)", clockwise(1), 0),
        Case("tangled", "an interior node thrown across its ring (2 inverted cells; untangled)", tangled(), 0,
             "inverted cell"),
        Case("polygon4", "polygon blocks with 3 and 4 nodes (read as triangle / quad)",
             vtu([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [2, 0, 0]], [("polygon", [[0, 1, 2, 3]]),
                                                                          ("polygon", [[1, 4, 2]])]), 0),
        # output paths
        Case("out-missing-dir", "output in a missing directory", vtu(P3, [("triangle", T)]), 3, "does not exist",
             output="nodir/out.vtu"),
        Case("out-under-file", "output under a regular file (afile.txt/out.vtu; stands for a read-only dir as root)",
             vtu(P3, [("triangle", T)]), 3, "cannot write", output="afile.txt/out.vtu", prepare=file_named("afile.txt")),
        Case("out-in-sys", "output in /sys (no one can create files there, root included)",
             vtu(P3, [("triangle", T)]), 3, "cannot write '/sys/anglesmooth-out.vtu'", output="/sys/anglesmooth-out.vtu"),
        Case("out-is-dir", "output is an existing directory", vtu(P3, [("triangle", T)]), 3, "is a directory",
             output="adir", prepare=lambda d: (d / "adir").mkdir()),
        Case("out-unknown-ext", "output with an unknown extension", vtu(P3, [("triangle", T)]), 3,
             "unknown file extension '.qqq'", output="out.qqq"),
        Case("out-is-input", "output = input without --force", vtu(P3, [("triangle", T)]), 2,
             "pass --force or --in-place", output="{input}"),
        # side outputs and the other output paths (issue 13): every output differs from every input and
        # from each other (resolved path and inode), and is checked before any work
        Case("out-hardlink-to-input", "OUTPUT is a hard link to the input, without --force", linked(True), 2,
             "pass --force or --in-place", output="link.vtu"),
        Case("out-symlink-to-input", "OUTPUT is a symlink to the input, without --force", linked(False), 2,
             "pass --force or --in-place", output="link.vtu"),
        Case("json-is-input", "--json names the input", vtu(P3, [("triangle", T)]), 2,
             "is the same file as INPUT", args=("--json", "{input}")),
        Case("json-hardlink-to-input", "--json names a hard link to the input", linked(True), 2,
             "is the same file as INPUT", args=("--json", "{d}/link.vtu")),
        Case("json-symlink-to-input", "--json names a symlink to the input", linked(False), 2,
             "is the same file as INPUT", args=("--json", "{d}/link.vtu")),
        Case("plot-is-input", "--plot names the input", vtu(P3, [("triangle", T)]), 2,
             "is the same file as INPUT", args=("--plot", "{input}")),
        Case("json-is-output", "--json names OUTPUT", vtu(P3, [("triangle", T)]), 2, "are the same file",
             args=("--json", "{d}/out.vtu")),
        Case("json-is-plot", "--json and --plot name the same file", vtu(P3, [("triangle", T)]), 2,
             "are the same file", args=("--json", "{d}/r.png", "--plot", "{d}/r.png")),
        Case("json-is-fix-nodes", "--json names the --fix-nodes file", vtu(P3, [("triangle", T)]), 2,
             "is the same file as --fix-nodes", args=("--fix-nodes", "{d}/fix.txt", "--json", "{d}/fix.txt"),
             prepare=file_named("fix.txt", b"0 1\n")),
        Case("json-is-gate-file", "--json names the --gate-file", vtu(P3, [("triangle", T)]), 2,
             "is the same file as --gate-file", args=("--gate-file", "{d}/g.toml", "--json", "{d}/g.toml"),
             prepare=file_named("g.toml", b"min_angle = 1\n")),
        Case("h5-beside-output-is-gate-file", "OUTPUT out.xdmf, whose HDF5 data out.h5 is the --gate-file",
             vtu(P3, [("triangle", T)]), 2, "out.h5' is the same file as --gate-file",
             output="out.xdmf", args=("--gate-file", "{d}/out.h5"), prepare=file_named("out.h5", b"min_angle = 1\n")),
        Case("json-is-h5-beside-output", "--json out.h5 with OUTPUT out.xdmf (its HDF5 data)",
             vtu(P3, [("triangle", T)]), 2, "are the same file", output="out.xdmf", args=("--json", "{d}/out.h5")),
        Case("json-missing-dir", "--json in a missing directory", vtu(P3, [("triangle", T)]), 3,
             "cannot write JSON report", args=("--json", "{d}/nodir/r.json")),
        Case("json-in-sys", "--json in /sys", vtu(P3, [("triangle", T)]), 3,
             "cannot write JSON report '/sys/anglesmooth-r.json'", args=("--json", "/sys/anglesmooth-r.json")),
        Case("json-is-dir", "--json names a directory", vtu(P3, [("triangle", T)]), 3, "it is a directory",
             args=("--json", "{d}/adir"), prepare=lambda d: (d / "adir").mkdir()),
        Case("plot-missing-dir", "--plot in a missing directory (found before the mesh is written)",
             vtu(P3, [("triangle", T)]), 3, "cannot write plot", args=("--plot", "{d}/nodir/p.png")),
        Case("out-dev-full", "OUTPUT /dev/full (written into, stays a device)", vtu(P3, [("triangle", T)]), 3,
             "No space left on device", output="/dev/full", args=("--output-format", "vtu")),
        Case("gate-file-gates-not-table", "gate file `[tool.anglesmooth] gates = 5`", vtu(P3, [("triangle", T)]), 2,
             "gates must be a table", args=("--gate-file", "{d}/g.toml"),
             prepare=file_named("g.toml", b"[tool.anglesmooth]\ngates = 5\n")),
        Case("gate-file-tool-not-table", "gate file `tool = {anglesmooth = 3}`", vtu(P3, [("triangle", T)]), 2,
             "[tool.anglesmooth] must be a table", args=("--gate-file", "{d}/g.toml"),
             prepare=file_named("g.toml", b"tool = {anglesmooth = 3}\n")),
        Case("fix-nodes-beyond-int64", "--fix-nodes file holding 100000000000000000000000", vtu(P3, [("triangle", T)]),
             2, "--fix-nodes: node 100000000000000000000000", args=("--fix-nodes", "{d}/fix.txt"),
             prepare=file_named("fix.txt", b"100000000000000000000000\n")),
        Case("numba-threads-0", "NUMBA_NUM_THREADS=0 in the environment", vtu(P3, [("triangle", T)]), 2,
             "NUMBA_NUM_THREADS='0' must be a positive integer", extra={"env": {"NUMBA_NUM_THREADS": "0"}}),
    ]
    return cases


CASES = corpus()
BY_ID = {c.id: c for c in CASES}


# --------------------------------------------------------------------------- running a case




@dataclass
class Outcome:
    code: int
    stderr: str
    before: dict
    after: dict
    input: Path
    output: Path


def setup_case(case: Case, d: Path) -> tuple[Path, Path]:
    if case.prepare is not None:
        case.prepare(d)
    inp = case.build(d)
    out = inp if case.output == "{input}" else (d / case.output)
    return inp, out


def run_case(case: Case, d: Path, subprocess_: bool = False, env: dict | None = None) -> Outcome:
    inp, out = setup_case(case, d)
    before = snapshot(d)
    argv = [str(inp), str(out), *(a.replace("{d}", str(d)).replace("{input}", str(inp)) for a in case.args)]
    env = {**case.extra.get("env", {}), **(env or {})} or None
    if subprocess_:
        proc = subprocess.run([sys.executable, "-m", "anglesmooth", *argv], capture_output=True, timeout=120,
                              cwd=d, env={**os.environ, "PYTHONPATH": str(HERE.parent / "src"), **(env or {})})
        assert proc.stdout == b""
        code, stderr = proc.returncode, proc.stderr.decode()
    else:
        r = cli_runner().invoke(cli, argv, env=env)
        assert r.stdout == ""
        code, stderr = r.exit_code, r.stderr
    return Outcome(code, stderr, before, snapshot(d), inp, out)


def check_outcome(case: Case, o: Outcome) -> None:
    assert o.code == case.code, o.stderr
    assert "Traceback" not in o.stderr
    if case.code != 0:
        line = error_line(o.stderr)
        assert case.needle in line, line
        assert o.after == o.before, "files appeared, vanished or changed"
        if str(o.output).startswith("/dev/"):
            assert o.output.is_char_device()  # written into, never replaced
        elif not o.output.is_relative_to(o.input.parent) and o.output != o.input:
            assert not o.output.exists()
    else:
        assert case.needle in o.stderr
        new = {k: v for k, v in o.after.items() if k not in o.before}
        assert list(new) == [o.output.name], new
        assert {k: o.after[k] for k in o.before} == o.before, "the input changed"


@pytest.mark.parametrize("case", CASES, ids=[c.id for c in CASES])
def test_bad_input(case, tmp_path):
    check_outcome(case, run_case(case, tmp_path))


SUBPROCESS_IDS = ["empty-msh", "truncated-msh41-binary-50", "nan", "tetra", "out-under-file", "tangled",
                  "json-symlink-to-input", "out-dev-full", "numba-threads-0"]


@pytest.mark.parametrize("case_id", SUBPROCESS_IDS)
def test_bad_input_subprocess(case_id, tmp_path):
    case = BY_ID[case_id]
    check_outcome(case, run_case(case, tmp_path, subprocess_=True))


# --------------------------------------------------------------------------- semantics of accepted inputs


def _smooth_json(tmp_path, case_id, *extra):
    case = BY_ID[case_id]
    inp, out = setup_case(case, tmp_path)
    r = cli_runner().invoke(cli, [str(inp), str(out), "--json", "-", *extra])
    assert r.exit_code == 0, r.stderr
    import json

    return inp, out, json.loads(r.stdout)


def test_unused_and_duplicate_nodes_are_fixed_and_not_moved(tmp_path):
    for case_id, nodes in [("unused-nodes", [25, 26]), ("duplicate-unused", [25]), ("duplicate-crack", [12, 25])]:
        d = tmp_path / case_id
        d.mkdir()
        inp, out, doc = _smooth_json(d, case_id, "--method", "laplacian")
        a, b = meshio.read(inp).points, meshio.read(out).points
        assert np.array_equal(a[nodes], b[nodes])
        assert doc["after"]["inverted"] == 0


def test_crack_sides_are_boundary(tmp_path):
    _, _, plain = _smooth_json(tmp_path, "unused-nodes")
    (tmp_path / "c").mkdir()
    _, _, crack = _smooth_json(tmp_path / "c", "duplicate-crack")
    # unused-nodes: 16 boundary + 2 unused; the slit adds node 12, its copy and the nodes along the slit
    assert plain["before"]["fixed_nodes"] == 18
    assert crack["before"]["fixed_nodes"] > 17


def test_clockwise_cells_are_reoriented(tmp_path):
    for case_id in ("clockwise-some", "clockwise-all"):
        d = tmp_path / case_id
        d.mkdir()
        inp, out, doc = _smooth_json(d, case_id)
        assert doc["before"]["inverted"] == 0 and doc["after"]["inverted"] == 0
        # the file keeps its own (clockwise) node order
        got, src = meshio.read(out), meshio.read(inp)
        assert np.array_equal(got.cells[0].data, src.cells[0].data)


def test_tangled_input_is_reported_and_untangled(tmp_path):
    case = BY_ID["tangled"]
    inp, out = setup_case(case, tmp_path)
    r = cli_runner().invoke(cli, [str(inp), str(out), "--json", "-"])
    import json

    doc = json.loads(r.stdout)
    assert doc["before"]["inverted"] == 2 and doc["before"]["inverted_cells"]
    assert "inverted cell(s) (first: " in r.stderr
    assert doc["after"]["inverted"] == 0
    for method in ("laplacian", "smart-laplacian", "optimization", "angle"):
        o = tmp_path / f"{method}.vtu"
        r = cli_runner().invoke(cli, [str(inp), str(o), "--json", "-", "--method", method])
        assert json.loads(r.stdout)["after"]["inverted"] <= 2


def test_zero_area_cells_are_reported(tmp_path):
    """A zero-area cell is degenerate, never also inverted (inverted: signed area < 0)."""
    _, _, doc = _smooth_json(tmp_path, "zero-area-collinear")
    b, a = doc["before"], doc["after"]
    assert (b["degenerate"], b["degenerate_cells"], b["inverted"]) == (1, [5], 0)
    assert a["degenerate"] == 0 and a["inverted"] == 0  # the free node moves off the line
    (tmp_path / "r").mkdir()
    _, _, doc = _smooth_json(tmp_path / "r", "zero-area-repeated")
    b, a = doc["before"], doc["after"]
    assert (b["degenerate"], b["inverted"]) == (1, 0)
    assert (a["degenerate"], a["inverted"]) == (1, 0)  # a repeated node cannot be fixed


def test_disconnected_cells_warn_nothing_to_smooth(tmp_path):
    inp, out, doc = _smooth_json(tmp_path, "disconnected")
    assert doc["before"]["fixed_nodes"] == doc["before"]["nodes"] == 12
    assert np.array_equal(meshio.read(inp).points, meshio.read(out).points)
    r = cli_runner().invoke(cli, [str(inp), str(tmp_path / "o2.vtu")])
    warn = [line for line in r.stderr.splitlines() if "warning" in line]
    assert r.exit_code == 0 and len(warn) == 1 and "all 12 nodes are fixed" in warn[0], r.stderr
    r = cli_runner().invoke(cli, [str(inp), str(tmp_path / "o3.vtu"), "-q"])
    assert r.exit_code == 0 and "warning" not in r.stderr


# --------------------------------------------------------------------------- out of memory, write failures


def _out_of_memory(d: Path, words: str) -> None:
    """Smooth a small file with a MemoryError patched in: exit 3, one line holding ``words``, nothing written."""
    inp = vtu(P3, [("triangle", T)])(d)
    before = snapshot(d)
    r = cli_runner().invoke(cli, [str(inp), str(d / "o.vtu")])
    assert r.exit_code == 3
    assert words in error_line(r.stderr)
    assert snapshot(d) == before


def test_memory_error_while_reading_is_one_line(tmp_path, monkeypatch):
    from meshio._helpers import reader_map

    def boom(*a, **k):
        raise MemoryError()

    monkeypatch.setitem(reader_map, "vtu", boom)
    _out_of_memory(tmp_path, "too large to read: out of memory")


@pytest.mark.parametrize("where", ["build_topology", "run_smooth", "summarize"])
def test_memory_error_later_is_one_line(tmp_path, monkeypatch, where):
    def boom(*a, **k):
        raise MemoryError()

    monkeypatch.setattr(cli_module, where, boom)
    _out_of_memory(tmp_path, "out of memory")


def test_memory_error_while_writing_leaves_nothing(tmp_path, monkeypatch):
    def boom(*a, **k):
        raise MemoryError()

    monkeypatch.setattr(asio, "_write_meshio", boom)
    _out_of_memory(tmp_path, "out of memory")


def test_huge_declared_node_count(tmp_path):
    """An MSH header announcing 10^12 nodes: a one-line error, not a MemoryError traceback."""
    path = tmp_path / "huge.msh"
    path.write_text("$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$Nodes\n1000000000000\n1 0 0 0\n2 1 0 0\n3 0 1 0\n"
                    "$EndNodes\n$Elements\n1\n1 2 2 0 1 1 2 3\n$EndElements\n")
    r = cli_runner().invoke(cli, [str(path), str(tmp_path / "o.vtu")])
    assert r.exit_code == 3
    error_line(r.stderr)
    assert sorted(os.listdir(tmp_path)) == ["huge.msh"]


def test_io_write_cannot_create_temporary_file(tmp_path, monkeypatch):
    """A read-only directory (simulated: root passes os.access): MeshWriteError, nothing left."""
    real = os.open

    def denied(path, flags, *a, **k):  # creating the temporary file (O_EXCL) is refused, as in a read-only dir
        if flags & os.O_EXCL:
            raise PermissionError(13, "Permission denied")
        return real(path, flags, *a, **k)

    monkeypatch.setattr(os, "open", denied)
    with pytest.raises(MeshWriteError, match="cannot create a file in .*Permission denied"):
        asio.write(Mesh2D.from_arrays(GRID.points, triangles=T), tmp_path / "o.vtu")
    assert os.listdir(tmp_path) == []


def test_io_write_parent_is_a_file(tmp_path):
    (tmp_path / "afile.txt").write_text("x")
    with pytest.raises(MeshWriteError, match="is not a directory"):
        asio.write(Mesh2D.from_arrays(GRID.points, triangles=T), tmp_path / "afile.txt" / "o.vtu")


def test_io_read_reports_the_reader_reason(tmp_path):
    """meshio.read hides its readers' errors behind sys.exit(1); io.read keeps them."""
    path = truncated("xdmf", 0.5)(tmp_path)
    with pytest.raises(MeshReadError, match=r"not a valid xdmf file \(ParseError: "):  # XDMF with HDF5 data: one line
        asio.read(path)
    path = truncated("vtk", 0.5)(tmp_path)  # refused before meshio allocates (see _guard)
    with pytest.raises(MeshReadError, match=r"not a valid vtk file \(SizeLimitError: the file declares \d+ values"):
        asio.read(path)
    path = truncated("vtu", 0.5)(tmp_path)
    with pytest.raises(MeshReadError, match=r"not a valid vtu file \(truncated or corrupt\)"):
        asio.read(path)
    (tmp_path / "r.msh").write_bytes(b"\x80" * 100)
    with pytest.raises(MeshReadError, match=r"^cannot read '.*r.msh': not a valid gmsh file"):
        asio.read(tmp_path / "r.msh")


# --------------------------------------------------------------------------- the committed table


def _clean(message: str, d: Path) -> str:
    return message.replace(str(d) + os.sep, "").replace(str(d), ".")


def table_rows(base: Path) -> list[tuple[str, str, int, str]]:
    rows = []
    for case in CASES:
        d = base / case.id
        d.mkdir()
        o = run_case(case, d, env={"COLUMNS": "1000"})  # warnings on one line
        if o.code != 0:
            msg = _clean(error_line(o.stderr), d)
        else:
            warn = [line.strip() for line in o.stderr.splitlines() if "warning" in line]
            msg = "(accepted) " + _clean(" ".join(" ".join(warn).split()), d) if warn else "(accepted)"
        rows.append((case.id, case.what, o.code, msg))
    return rows


def render(rows) -> str:
    head = [
        "# Bad inputs: exit code and message",
        "",
        "Generated by `python tests/test_bad_input.py` from the corpus in `tests/test_bad_input.py` (meshio "
        f"{meshio.__version__}); every case runs `anglesmooth INPUT out.vtu` (or the OUTPUT and options the case "
        "names) in a fresh directory. Exit codes: "
        "0 accepted, 2 usage error, 3 unreadable / unsupported / invalid input or unwritable output. For every "
        "non-zero case the tests check: one stderr line, no traceback, no output or temporary file, input "
        "unchanged (sha256). Paths are shown relative to the case directory.",
        "",
        "| case | input | exit | message |",
        "|---|---|---|---|",
    ]
    esc = lambda s: s.replace("|", "\\|")  # noqa: E731
    body = [f"| `{i}` | {esc(w)} | {c} | {esc(m)} |" for i, w, c, m in rows]
    return "\n".join(head + body + NOTES) + "\n"


NOTES = [
    "",
    "## Decisions",
    "",
    "* **Duplicate nodes** are allowed. A duplicate that no cell uses is an unused node: fixed, never moved. "
    "Duplicates used on both sides of a line of cells make a slit whose sides are boundaries: fixed.",
    "* **Unused nodes** are allowed, fixed and bit-identical in the output.",
    "* **Zero-area cells** (0 <= signed area <= 1e-12 x the bounding-box diagonal squared) are *degenerate*, not "
    "inverted (inverted means signed area < 0; the two are disjoint): `degenerate`, `degenerate_cells` in the "
    "JSON report, a warning on stderr, their own colour in `--plot`. A collinear triangle with a free node is "
    "opened up by the guarded methods; a cell with a repeated node cannot be and stays degenerate.",
    "* **Clockwise cells** (some or all) are re-oriented internally per connected patch; the written file keeps "
    "the input's node order.",
    "* **Tangled input** is accepted with a warning (count and first indices). With the guard (default), a move "
    "is scored by the number of invalid (inverted, degenerate or non-convex) incident cells first, so the guarded "
    "methods never increase that number and pull a folded node back into its ring when a candidate position has "
    "fewer invalid cells: every guarded method untangles a single fold completely (`tangled`: 2 -> 0; "
    "`optimization` and `smart-laplacian` through their untangling stage, which also tries the centroid of the "
    "node's kernel, the positions where all its cells are valid: issue 12). They are not global untanglers: a "
    "node whose candidates are all as bad stays (tests/test_properties.py).",
    "* **Read-only output directory**: as root, `chmod` does not stop writes. `afile.txt/out.vtu` (a path under "
    "a regular file) and `/sys/...` (no file can be created there) stand in for it. Both give exit 3, and no "
    "output or temporary file is left.",
    "* **Out of memory** while reading, building the topology, smoothing, measuring or writing: exit 3 with one "
    "line (`too large to read: out of memory` / `out of memory ...`), tested by monkeypatching; an MSH header "
    "announcing 10^12 nodes gives exit 3 as well.",
    "* **Output paths** (issue 13): OUTPUT, `--json` and `--plot` must each differ from every input (INPUT, "
    "`--fix-nodes`, `--gate-file`) and from each other, compared by resolved path *and* inode, so a hard link "
    "or a symlink to the input is the input (exit 2; OUTPUT may be the input with `--force` / `--in-place`). "
    "The `.h5` an XDMF OUTPUT writes beside itself (`out.xdmf` -> `out.h5`) is an output too: it may not be an "
    "input or another output (`--json out.h5`; for several INPUTs, `a.xdmf` and `a.xmf` in one directory). "
    "Every output path is checked before the input is read (missing directory, a directory, not creatable: "
    "exit 3), so a bad `--plot` path no longer leaves the mesh behind. A device such as `/dev/full` is written "
    "into and stays a device (exit 3 when it is full). The cases that need a real process (closed stdin / "
    "stdout, `/dev/full` as stdout, a FIFO, a socket, a device made with `mknod`, a slow non-blocking pipe, "
    "`| head -c 100`, signals while plotting, SIGKILL) are in tests/test_output_safety.py.",
    "* **Absurd counts** (a corrupt MSH 4.1 binary element count, `POINTS 300000000` in a 200-byte VTK file, an "
    "HDF5 dataset declaring 9.6 GB in a tiny `.h5`) are refused before the reader allocates "
    "(`SizeLimitError`, see `anglesmooth/_guard.py`), in bounded memory: the tests run them under a 1 GB "
    "address-space limit.",
    "* Corruption that still parses (a flipped digit in a coordinate) cannot be detected: none of these formats "
    "has a checksum.",
]


def test_bad_inputs_table_is_current(tmp_path):
    """BAD_INPUTS.md is what ``python tests/test_bad_input.py`` writes today: every row (exit code *and* message,
    in corpus order) and the decisions; a changed message or decision needs the table regenerated."""
    text = TABLE.read_text(encoding="utf-8")
    rows = re.findall(r"^\| `([^`]+)` \| .* \| (\d+) \| (.*) \|$", text, flags=re.M)
    assert [(i, int(c)) for i, c, _ in rows] == [(c.id, c.code) for c in CASES]
    for (i, _, msg), case in zip(rows, CASES):
        assert case.needle in msg, (i, msg)
        assert msg.startswith(PREFIX) == (case.code != 0)
    now = render(table_rows(tmp_path)).splitlines()
    stale = [(old, new) for old, new in zip(text.splitlines(), now) if old != new]
    assert not stale and len(now) == len(text.splitlines()), stale[:3]


if __name__ == "__main__":
    import tempfile

    with tempfile.TemporaryDirectory() as tmp:
        TABLE.write_text(render(table_rows(Path(tmp))), encoding="utf-8")
    print(f"wrote {TABLE}")


# --- corrupt gmsh files: the reason in words, the technical detail after it -------------------

_MSH22_HEAD = "$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$Nodes\n4\n1 0 0 0\n2 1 0 0\n{n3} 1 1 0\n4 0 1 0\n$EndNodes\n"


@pytest.mark.parametrize(
    "nodes3, last_cell, words",
    [
        ("3", "1 3 9", "a cell refers to a node the file does not define, or node numbers repeat; IndexError"),
        ("2", "1 3 4", "references node -1, a node the file does not define (in a gmsh file: a node tag missing or repeated)"),
    ],
    ids=["missing-node-tag", "repeated-node-tag"],
)
def test_corrupt_gmsh_node_tags_are_named(tmp_path, nodes3, last_cell, words):
    from anglesmooth import read
    from anglesmooth.errors import InvalidMeshError, MeshReadError

    p = tmp_path / "bad.msh"
    p.write_text(_MSH22_HEAD.format(n3=nodes3) + f"$Elements\n2\n1 2 2 0 1 1 2 3\n2 2 2 0 1 {last_cell}\n$EndElements\n")
    with pytest.raises((MeshReadError, InvalidMeshError)) as e:
        read(p)
    assert words in str(e.value) and "\n" not in str(e.value)


def test_truncated_gmsh_file_says_truncated(tmp_path):
    """A gmsh file cut in the middle of its node block: meshio's reshape error comes with the words."""
    import gmsh

    from anglesmooth import read
    from anglesmooth.errors import MeshReadError

    full = tmp_path / "full.msh"
    gmsh.initialize(["-noenv"])
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        gmsh.model.occ.addRectangle(0, 0, 0, 1, 1)
        gmsh.model.occ.synchronize()
        gmsh.model.mesh.generate(2)
        gmsh.write(str(full))
    finally:
        gmsh.finalize()
    text = full.read_text()
    cut = tmp_path / "cut.msh"
    cut.write_text(text[: text.index("$EndNodes") // 2 + len(text[: text.index("$Nodes")]) // 2])
    with pytest.raises(MeshReadError, match=r"not a valid gmsh file \((truncated or corrupt; |.*: truncated or corrupt)"):
        read(cut)


def test_coordinate_limit_is_defined_once():
    """meshconv (reading a file) and Mesh2D (building from arrays) refuse coordinates by the same limit."""
    from anglesmooth import mesh, meshconv

    assert meshconv.MAX_COORD is mesh.MAX_COORD
    assert not re.search(r"^\s*_?MAX_COORD\s*=", Path(meshconv.__file__).read_text(encoding="utf-8"), flags=re.M)
    m = meshio.Mesh(np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 2 * mesh.MAX_COORD]]), [("triangle", [[0, 1, 2]])])
    with pytest.raises(Exception, match=re.escape(f"(limit {mesh.MAX_COORD:g})")):
        meshconv.as_mesh2d(m)
