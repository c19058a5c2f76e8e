"""The block loop every step function shares."""

from __future__ import annotations

from collections.abc import Callable
from typing import NamedTuple

import numpy as np

from ..topology import Block, Topology


#: Largest index table :func:`intp` converts (entries): an intp copy of every spoke and ring table of a
#: 1M-triangle mesh added 160 MB to a numpy-kernel run's peak (485 -> 644 MB) for no measurable gain
#: per pass; large meshes run the compiled kernels anyway.
INTP_MAX = 1 << 20


def intp(topo: Topology, name: str) -> np.ndarray:
    """``topo.<name>`` (an int32 index table) as an ``np.intp`` array, converted once and cached
    (tables above :data:`INTP_MAX` entries: the table itself).

    numpy converts non-intp indices on every gather or scatter: ``np.take`` of (n, 2) rows with
    int32 indices costs about 1.7x the same with intp ones (numpy 2.x).  The indices are the same
    either way, so are the results.
    """
    table = getattr(topo, name)
    if table.size > INTP_MAX:
        return table
    key = ("intp", name)
    hit = topo._cache.get(key)
    if hit is None:
        hit = topo._cache[key] = np.ascontiguousarray(table, dtype=np.intp)
    return hit


class StepResult(NamedTuple):
    """What one pass of a smoother returns: new (N, 2) points and the number of refused moves.

    ``area_range``: None, or (a :func:`with_area_range` result) the (smallest, largest) signed cell
    area at ``points``, which the next pass of the same smoother may take (its ``area_range``) instead
    of reading every cell again; valid only while ``points`` is not modified.
    """

    points: np.ndarray
    rejected: int

    area_range = None


class _RangedStepResult(StepResult):
    """A :class:`StepResult` that carries ``area_range`` (an instance attribute; still a 2-tuple)."""


def with_area_range(res: StepResult, area_range) -> StepResult:
    """``res`` with ``area_range`` (see :class:`StepResult`); ``res`` itself when it is None."""
    if area_range is None:
        return res
    out = _RangedStepResult(*res)
    out.area_range = area_range
    return out


def run_blocks(
    points: np.ndarray,
    topo: Topology,
    order: str,
    update: Callable[[np.ndarray, Block, np.ndarray | None], tuple[np.ndarray, int]],
    current: bool = True,
) -> StepResult:
    """Apply ``update(points, block, current)`` to each block in turn.

    ``update`` returns the new positions of the block's nodes and its number
    of refused moves; ``current`` False: it gets None instead of the block's
    current positions (one gather per block fewer, for an update that does
    not read them).  Blocks see the positions written by earlier blocks
    (Gauss-Seidel over colour classes); with ``order="jacobi"`` there is a
    single block.  Only free nodes are ever written, so fixed nodes are
    bit-identical.  The input array is not modified.
    """
    out = np.array(points, dtype=np.float64, copy=True)
    x, y = out[:, 0], out[:, 1]  # column scatters: faster than scattering (n, 2) rows
    rejected = 0
    for blk in topo.blocks(order):
        if blk.size == 0:
            continue
        nodes = intp(topo, "free_nodes")[blk.nodes]
        new, rej = update(out, blk, np.take(out, nodes, axis=0) if current else None)
        x[nodes] = new[:, 0]
        y[nodes] = new[:, 1]
        rejected += int(rej)
    return StepResult(out, rejected)
