"""The cost shortcuts of the default ``angle`` pass give the numbers of the full computation.

The compiled stage 1 skips the exact score of a node whose angle position is certainly above every
optimization threshold of its colour class (``_fastkernels._node_certified``); the compiled stage 4
is one call (``angle_optimize``); the numpy stage 4 runs the resumed and the fresh searches as one
search with per-node steps.  Each is checked against the path without the shortcut.
"""

from __future__ import annotations

import numpy as np
import pytest

from anglesmooth import generate as gen
from anglesmooth.smoothers import _fast, _fastcalls, angle
from anglesmooth.smoothers._floors import input_floors
from anglesmooth.smoothers._local import BlockGeometry, optimize
from anglesmooth.topology import build_topology

MESHES = {
    "quads": lambda: gen.random_quad_mesh(900, seed=3),
    "triangles": lambda: gen.random_delaunay(1500, seed=4),
    "mixed": lambda: gen.paper_mixed_mesh(2),
}


def _passes(mesh, n=4):
    topo = build_topology(mesh)
    p = np.array(mesh.points)
    fl = input_floors(p, topo)
    for _ in range(n):
        p = angle.step(p, topo, floors=fl).points
    return p


@pytest.mark.parametrize("name", sorted(MESHES))
def test_skipping_certified_scores_changes_nothing(name, monkeypatch):
    monkeypatch.setenv("ANGLESMOOTH_KERNEL", "numba")
    mesh = MESHES[name]()
    real = _fastcalls.angle_choose
    lazy = []

    def counted(*args, **kw):
        out = real(*args, **kw)
        lazy.append(int(out[3].sum()))
        return out

    monkeypatch.setattr(_fastcalls, "angle_choose", counted)
    fast = _passes(mesh)

    def exact(*args, **kw):  # the same call without the certificate: every score exact
        args = list(args)
        if len(args) > 7:
            args[7] = None
        kw.pop("certify", None)
        return real(*args, **kw)

    monkeypatch.setattr(_fastcalls, "angle_choose", exact)
    np.testing.assert_array_equal(fast, _passes(mesh))
    if name == "quads":  # (random triangles have anisotropic cells: input floors, no certificate)
        assert sum(lazy) > 0


def test_a_certified_node_scores_above_the_threshold():
    """Random positions around random nodes: wherever the certificate holds, the exact score is valid
    and above the threshold (a false certificate would drop a node from stage 4)."""
    k = _fast._k()
    rng = np.random.default_rng(5)
    for mesh in (gen.paper_mixed_mesh(1), gen.random_quad_mesh(200, seed=1)):
        topo = build_topology(mesh)
        from anglesmooth.smoothers._fastcalls import _csr

        _, _, tp, qp = _csr(topo)
        pts = np.array(mesh.points)
        hits = 0
        for f in rng.integers(0, topo.n_free, 60):
            c0 = pts[topo.free_nodes[f]]
            for _ in range(40):
                px, py = c0 + rng.normal(scale=0.02, size=2)
                for c in (0.5, 0.766, 0.9):
                    if k._node_certified(pts, px, py, f, tp, topo.tri_verts, qp, topo.quad_verts, c):
                        hits += 1
                        s = k._node_score(pts, px, py, f, tp, topo.tri_verts, qp, topo.quad_verts, np.zeros((0, 0)))
                        assert s > -c
        assert hits > 50


def test_per_node_steps_are_two_searches_in_one():
    mesh = gen.random_quad_mesh(400, seed=2)
    topo = build_topology(mesh)
    blk = topo.blocks()[0]
    pts = np.array(mesh.points)
    g = BlockGeometry(pts, topo, blk)
    x = pts[topo.free_nodes[blk.nodes]]
    scale = np.full(blk.size, 0.02)
    its = np.where(np.arange(blk.size) % 3 == 0, 12, 4)
    rad = np.where(its == 12, 0.0625, 0.25)
    one, _ = optimize(g, x, scale, its, rad, 0.8, (1e-4, 1.0))
    a, b = np.flatnonzero(its == 4), np.flatnonzero(its == 12)
    sep = np.empty_like(one)
    sep[a], _ = optimize(g.restrict(a), x[a], scale[a], 4, 0.25, 0.8, (1e-4, 1.0))
    sep[b], _ = optimize(g.restrict(b), x[b], scale[b], 12, 0.0625, 0.8, (1e-4, 1.0))
    np.testing.assert_array_equal(one, sep)
    assert not np.array_equal(one, x)
