"""gmsh files: what meshio's readers drop, and an MSH 4.1 writer that holds any mesh.

Reading
    :func:`install` wraps meshio's gmsh readers (once) so that each read leaves
    behind, in :func:`take_captured`, the gmsh node tags of the points (MSH 2.2,
    4.0, 4.1) and the whole MSH 4.1 ``$Entities`` table: bounding boxes, *all*
    physical tags of every entity and its bounding entities (meshio keeps one
    physical tag per entity and no bounding box).  It also reads MSH 4.1 files
    with elements outside every physical group, which meshio refuses.

Writing
    meshio's MSH 4.1 writer refuses two cell blocks of one entity ("non-unique
    CellBlock dim_tag"), which is what gmsh writes for a surface holding
    triangles and quads (``BoundaryLayer`` field with ``Quads = 1``, partial
    recombination).  The format allows one element block per entity *and element
    type*; :func:`write` writes such files, ASCII or binary:

    * ``$Entities``: the table read from the source when there is one (all
      physical tags, bounding entities, boxes), else one entity per
      (dimension, ``gmsh:geometrical`` tag) with the physical tags of its cells
      and a box around its nodes;
    * ``$Nodes``: one block per run of consecutive points on one entity
      (``gmsh:dim_tags``, or the lowest-dimensional entity of a cell using the
      node), so that the node order is kept, with the source's node tags
      (else 1..N);
    * ``$Elements``: one block per cell block and entity, element tags 1..M;
    * ``$PhysicalNames``, ``$Periodic``, ``$NodeData`` / ``$ElementData`` (1, 3
      or 9 doubles per node / element).

Modules: ``reading`` (the wrapped readers), ``blocks`` (element and node blocks,
entities), ``writer`` (the MSH 4.1 file) and ``storable`` (tags and data any MSH
version can hold); ``blocks`` is imported by ``writer`` only.  Everything public
is imported here: ``from anglesmooth.gmshfile import X``.
"""

from __future__ import annotations

from .blocks import first_of_duplicates
from .reading import install, take_captured
from .storable import gmsh_data, gmsh_tags, int_tags
from .writer import write

__all__ = ["first_of_duplicates", "gmsh_data", "gmsh_tags", "install", "int_tags", "take_captured", "write"]
