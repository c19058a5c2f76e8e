"""The VTU writer's zlib blocks compressed on threads (anglesmooth.io._vtu): the bytes meshio writes alone."""

from __future__ import annotations

import threading

import meshio
import numpy as np
import pytest
from meshio.vtu import _vtu as meshio_vtu

from anglesmooth import io as asio
from anglesmooth.generate import structured_quads
from anglesmooth.io import _vtu
from anglesmooth.mesh import Mesh2D


@pytest.fixture
def small_blocks(monkeypatch):
    """Small batches so that a test mesh takes the threaded path with many tasks; two workers."""
    monkeypatch.setattr(_vtu, "BATCH", 3)
    monkeypatch.setattr(_vtu, "MIN_BLOCKS", 2)
    monkeypatch.setattr(_vtu, "workers", lambda: 2)


def _mesh(n: int = 60) -> Mesh2D:
    m = structured_quads(n, n)
    rng = np.random.default_rng(1)
    tri = np.array([[0, 1, n + 2]])
    return Mesh2D.from_arrays(m.points + rng.normal(scale=1e-3, size=m.points.shape), triangles=tri, quads=m.quads[1:])


def test_threaded_vtu_is_the_bytes_meshio_writes(tmp_path, small_blocks):
    mesh = _mesh()
    used = []
    real = _vtu._compress_all
    _vtu._compress_all = lambda blocks: used.append(threading.current_thread().name) or real(blocks)
    try:
        asio.write(mesh, tmp_path / "ours.vtu")
    finally:
        _vtu._compress_all = real
    assert used and all(name.startswith("anglesmooth-zlib") for name in used)  # the pool did the work
    # meshio alone, on the same meshio mesh anglesmooth hands it
    out = asio._out_mesh(mesh, None, mesh.points, "vtu")
    meshio.write(tmp_path / "meshio.vtu", out, file_format="vtu")
    assert (tmp_path / "ours.vtu").read_bytes() == (tmp_path / "meshio.vtu").read_bytes()
    assert meshio_vtu._chunk_it is _vtu._original and meshio_vtu.zlib is _vtu.zlib  # put back
    back = meshio.read(tmp_path / "ours.vtu")
    assert np.array_equal(back.points[:, :2], mesh.points)


def test_meshio_names_are_put_back_after_an_error(tmp_path, small_blocks):
    mesh = meshio.Mesh(np.zeros((4, 3)), [("quad", np.array([[0, 1, 2, 3]]))])
    with pytest.raises(ZeroDivisionError), _vtu.threaded_zlib():
        assert meshio_vtu.zlib is _vtu._ZLIB
        1 / 0
    assert meshio_vtu._chunk_it is _vtu._original and meshio_vtu.zlib is _vtu.zlib
    meshio.write(tmp_path / "after.vtu", mesh)  # meshio's own writer works as before
    assert meshio.read(tmp_path / "after.vtu").cells[0].data.tolist() == [[0, 1, 2, 3]]


def test_writers_in_several_threads_each_write_their_own_bytes(tmp_path, small_blocks):
    meshes = [_mesh(40 + 5 * k) for k in range(3)]
    errors = []

    def job(k):
        try:
            asio.write(meshes[k], tmp_path / f"t{k}.vtu")
        except Exception as e:  # noqa: BLE001 - reported below
            errors.append(e)

    threads = [threading.Thread(target=job, args=(k,)) for k in range(3)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert not errors
    for k, mesh in enumerate(meshes):
        meshio.write(tmp_path / f"m{k}.vtu", asio._out_mesh(mesh, None, mesh.points, "vtu"), file_format="vtu")
        assert (tmp_path / f"t{k}.vtu").read_bytes() == (tmp_path / f"m{k}.vtu").read_bytes()
    assert meshio_vtu._chunk_it is _vtu._original and meshio_vtu.zlib is _vtu.zlib
