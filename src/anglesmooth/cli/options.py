"""Options shared by the commands (one definition each)."""

from __future__ import annotations

from collections.abc import Callable

import math

import click


class FiniteFloat(click.FloatRange):
    """A finite number (``nan`` / ``inf`` are refused, as the gate file refuses them)."""

    name = "finite float"

    def convert(self, value, param, ctx):
        number = super().convert(value, param, ctx)
        if not math.isfinite(number):
            self.fail(f"{value!r} is not a finite number.", param, ctx)
        return number

    def _describe_range(self) -> str:
        # click describes an unbounded range as "x<=None" in --help
        return "" if self.min is None and self.max is None else super()._describe_range()


def gate_options(f: Callable) -> Callable:
    options = [
        click.option("--min-angle", type=FiniteFloat(), metavar="DEG",
                     help="Gate: smallest corner angle must be >= DEG."),
        click.option("--max-angle", type=FiniteFloat(), metavar="DEG",
                     help="Gate: largest corner angle must be <= DEG."),
        click.option("--max-inverted", type=click.IntRange(min=0), metavar="N",
                     help="Gate: at most N inverted cells (0 in check, and when any other gate is given)."),
        click.option("--max-degenerate", type=click.IntRange(min=0), metavar="N",
                     help="Gate: at most N degenerate (zero-area) cells (0 in check, and when any other gate is given)."),
        click.option("--max-area-ratio", type=FiniteFloat(min=0), metavar="R",
                     help="Gate: max/min cell area must be <= R."),
        click.option("--max-aspect-ratio", type=FiniteFloat(min=0), metavar="R",
                     help="Gate: largest Verdict aspect ratio (triangles and quads) must be <= R."),
        click.option("--gate-file", type=click.Path(exists=True, dir_okay=False), metavar="FILE",
                     help="TOML file with gate thresholds (same names, underscores); options override it."),
        click.option("--exit-zero", is_flag=True, help="Report failed gates but exit 0."),
    ]
    for option in reversed(options):
        f = option(f)
    return f


json_option = click.option("--json", "json_path", metavar="PATH|-", help="Write the report as JSON ('-': stdout).")
quiet_option = click.option("--quiet", "-q", is_flag=True, help="Print nothing on stderr except errors and failed gates.")
debug_option = click.option("--debug", is_flag=True, help="Show the traceback of an error.")
input_format_option = click.option("--input-format", metavar="FORMAT",
                                    help="Format of INPUT (needed for '-'): a meshio name (gmsh, vtu, vtk, xdmf, ...) "
                                         "or a file extension (msh, xmf, inp, ...).")
output_format_option = click.option("--output-format", metavar="FORMAT",
                                     help="Format of OUTPUT (needed for '-'), named as for --input-format; also "
                                          "gmsh22 / gmsh41 (msh22 / msh41) for an MSH version.")
binary_option = click.option("--binary/--ascii", "binary", default=None,
                             help="Encoding of OUTPUT where its format has a choice (MSH, VTU, VTK, PLY, STL; XDMF: "
                                  "inline XML / HDF5) [default: the input's when the format is the same, else the "
                                  "writer's: binary VTU/VTK, XDMF with HDF5, ASCII MSH].")
node_numbering_option = click.option(
    "--node-numbering", type=click.Choice(["index", "gmsh"]), default="index", show_default=True,
    help="Numbers in the --fix-nodes file: 'index' = 0-based positions in the file's node order, "
         "'gmsh' = the 1-based node tags of an MSH file (as gmsh shows them).")
order_option = click.option("--order", type=click.Choice(["colour", "jacobi"]), default="colour", show_default=True,
                             help="Update order: Gauss-Seidel over colour classes, or all nodes at once.")
no_guard_option = click.option("--no-guard", is_flag=True,
                                help="Textbook methods: do not refuse moves that invert cells or lower the local minimum angle.")
