"""The registry of smoothing methods.

``SMOOTHERS`` maps each method name to a :class:`Smoother`; the command line's
``--method`` choices and the tests' parametrization both read it, so the list
of methods exists once.  Every ``step`` has the signature::

    step(points, topo, /, *, guard=True, order="colour", **options) -> StepResult

is pure (returns new arrays, never modifies ``points``), vectorized over the
nodes of one colour class, and leaves fixed nodes bit-identical.

>>> sorted(SMOOTHERS)
['angle', 'laplacian', 'optimization', 'smart-laplacian']
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

from ..errors import UnknownMethodError
from . import angle, laplacian, optimization, smart_laplacian
from ._blocks import StepResult

__all__ = ["SMOOTHERS", "Smoother", "StepResult", "get_smoother"]


@dataclass(frozen=True)
class Smoother:
    """A registered smoothing method."""

    name: str
    step: Callable[..., StepResult]
    summary: str
    reference: str


SMOOTHERS: dict[str, Smoother] = {
    s.name: s
    for s in (
        Smoother(
            "angle",
            angle.step,
            "angle-based (Zhou & Shimada 2000); robust hybrid by default, the paper's rule with --no-guard",
            "Zhou & Shimada, 9th International Meshing Roundtable, 2000",
        ),
        Smoother("laplacian", laplacian.step, "move each node to the centroid of its neighbours", "Field 1988"),
        Smoother(
            "smart-laplacian",
            smart_laplacian.step,
            "Laplacian move (or half of it) kept only if the local minimum angle does not decrease",
            "Freitag 1997",
        ),
        Smoother(
            "optimization",
            optimization.step,
            "local max-min-angle optimization (compass search per node)",
            "Freitag 1997; Canann, Tristano & Staten 1998",
        ),
    )
}


def get_smoother(name: str) -> Smoother:
    """Look a method up by name; raise :class:`UnknownMethodError` with the valid names otherwise."""
    try:
        return SMOOTHERS[name]
    except KeyError:
        raise UnknownMethodError(f"unknown method {name!r}; choose one of: {', '.join(SMOOTHERS)}") from None
