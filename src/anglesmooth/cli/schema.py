"""``anglesmooth schema {smooth,check,compare}``: print the JSON Schema (draft 2020-12) of a ``--json`` report.

The schema files ship in the package (``anglesmooth/schemas/*.schema.json``); ``schema_version`` in every
document is the contract they describe: keys may be added within a version, removing or changing one bumps it.
"""

from __future__ import annotations

import json
from importlib import resources

import click

from .errors import handle_errors

#: Documents with a schema: the command that writes them -> file name in ``anglesmooth/schemas``.
SCHEMAS = {name: f"{name}.schema.json" for name in ("smooth", "check", "compare")}


def load_schema(name: str) -> dict:
    """The schema of the JSON document of command ``name`` (a key of :data:`SCHEMAS`)."""
    text = resources.files("anglesmooth").joinpath("schemas", SCHEMAS[name]).read_text(encoding="utf-8")
    return json.loads(text)


@click.command("schema")
@click.argument("document", type=click.Choice(list(SCHEMAS)))
@click.option("--debug", is_flag=True, help="Show the traceback of an error.")
@handle_errors
def schema_cmd(document: str, debug: bool) -> None:
    """Print the JSON Schema (draft 2020-12) of the JSON report of DOCUMENT ('smooth', 'check' or 'compare')."""
    click.echo(json.dumps(load_schema(document), indent=2, ensure_ascii=False))
