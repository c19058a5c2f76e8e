"""What gmsh itself sees in an MSH file, to check that gmsh reopens anglesmooth's outputs unchanged."""

from __future__ import annotations

import gmsh


def gmsh_view(path) -> dict:
    """What gmsh itself sees in a file: groups (names, entities), entities, element counts, nodes."""
    gmsh.initialize(readConfigFiles=False)
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        gmsh.open(str(path))
        groups = sorted(
            (d, t, gmsh.model.getPhysicalName(d, t), tuple(sorted(gmsh.model.getEntitiesForPhysicalGroup(d, t))))
            for d, t in gmsh.model.getPhysicalGroups()
        )
        entities = sorted(gmsh.model.getEntities())
        counts = {}
        for d, t in entities:
            types, tags, _ = gmsh.model.mesh.getElements(d, t)
            for ty, tg in zip(types, tags):
                counts[d, t, int(ty)] = len(tg)
        node_tags, coords, _ = gmsh.model.mesh.getNodes()
        return {"groups": groups, "entities": entities, "counts": counts, "nodes": len(node_tags), "tags": node_tags,
                "xyz": dict(zip(node_tags.tolist(), coords.reshape(-1, 3).tolist()))}
    finally:
        gmsh.finalize()


def same_for_gmsh(a, b, *, entities: bool = True) -> None:
    """gmsh sees the same groups, entities, element counts and node count in ``a`` and ``b``.

    ``entities=False`` (MSH 2.2, which stores no entity without elements): only entities holding elements.
    """
    va, vb = gmsh_view(a), gmsh_view(b)
    for key in ("groups", "counts", "nodes") + (("entities",) if entities else ()):
        assert va[key] == vb[key], key
