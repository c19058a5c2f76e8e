"""Slow, obvious per-node reference implementations of the smoothers.

Written from the paper's formulas with plain Python loops and trigonometry
(acos, rotation matrices), independent of the vectorized code: the only thing
shared is the update order (``topo.free_nodes`` grouped by colour), which the
reference takes as given.  Nodes of one colour share no cell, so updating them
one after another in that order is the same as updating the class at once.

Modules (each imports only those above it): :mod:`.geometry` (cells, incidence,
corner angles, the Laplacian and angle positions), :mod:`.untangle` (the
untangling key and pass), :mod:`.angle` (the smoothers' passes and the input
rules of the default ``angle``), :mod:`.patch` (stage 5's patch moves).  Tests
import the names from here: ``from reference import reference_pass``.
"""

from __future__ import annotations

from .angle import (
    reference_input_max,
    reference_input_min,
    reference_keep,
    reference_pass,
    reference_strict,
)
from .geometry import (
    angle_pos,
    ccw_angle,
    cells_of,
    corner_angle,
    free_corner_degrees,
    incident,
    laplacian_pos,
    largest_moving_angle,
    local_min_angle,
    neighbours,
    rotate_about,
)
from .patch import reference_patch_moves
from .untangle import kernel_centroid_ref, local_key, reference_untangle_pass, untangle_ref

__all__ = [
    "angle_pos",
    "ccw_angle",
    "cells_of",
    "corner_angle",
    "free_corner_degrees",
    "incident",
    "kernel_centroid_ref",
    "laplacian_pos",
    "largest_moving_angle",
    "local_key",
    "local_min_angle",
    "neighbours",
    "reference_input_max",
    "reference_input_min",
    "reference_keep",
    "reference_pass",
    "reference_patch_moves",
    "reference_strict",
    "reference_untangle_pass",
    "rotate_about",
    "untangle_ref",
]
