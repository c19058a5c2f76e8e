"""Which nodes a run keeps fixed beside the boundary: ``--fix-group`` and ``--fix-nodes`` resolved on a mesh.

One function for the one-file command and for every file of a batch, so that a group
is found the same way in both: by name, by gmsh physical number (``11``) or by
``dim:number`` (``2:11``, when a number is used in several dimensions).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from .errors import AngleSmoothError

__all__ = ["FixedNodesError", "fixed_mask", "group_nodes"]


class FixedNodesError(AngleSmoothError):
    """A group that is not in the mesh, or a node index out of range (a usage error, exit 2)."""

    exit_code = 2


def group_nodes(mesh, name: str) -> np.ndarray:
    """The nodes of a group given by name, by gmsh physical number ('11') or by dim:number ('2:11')."""
    if name in mesh.groups:
        return mesh.groups[name]
    physical = getattr(mesh, "physical", {}) or {}
    text = name.strip()
    if text.isdigit():
        hits = [k for k in physical if k[1] == int(text)]
        if len(hits) == 1:
            return physical[hits[0]]
        if len(hits) > 1:
            choices = " or ".join(f"{d}:{t}" for d, t in sorted(hits))
            raise FixedNodesError(f"--fix-group: physical number {text} exists in several dimensions; "
                                  f"write {choices}")
    elif text.count(":") == 1 and all(part.strip().isdigit() for part in text.split(":")):
        d, t = (int(part) for part in text.split(":"))
        if (d, t) in physical:
            return physical[(d, t)]
    names = ", ".join(repr(k) for k in sorted(mesh.groups)) or "none"
    numbers = ", ".join(f"{d}:{t}" for d, t in sorted(physical)) or "none"
    raise FixedNodesError(f"--fix-group: no group {name!r} in the mesh; names: {names}; "
                          f"physical numbers (dim:number): {numbers}")


def fixed_mask(mesh, groups: Sequence[str], nodes: Sequence[int] | np.ndarray | None) -> np.ndarray | None:
    """The extra fixed nodes of ``mesh`` as a boolean mask (None when neither groups nor nodes are given).

    ``nodes`` are 0-based indices; one out of range raises :class:`FixedNodesError`.
    """
    if not groups and nodes is None:
        return None
    mask = np.zeros(mesh.n_points, dtype=bool)
    for name in groups:
        mask[group_nodes(mesh, name)] = True
    if nodes is not None and len(nodes):
        idx = np.asarray(nodes, dtype=np.int64)
        bad = idx[(idx < 0) | (idx >= mesh.n_points)]
        if bad.size:
            raise FixedNodesError(f"--fix-nodes: node {int(bad[0])} out of range "
                                  f"(the mesh has nodes 0..{mesh.n_points - 1})")
        mask[idx] = True
    return mask
