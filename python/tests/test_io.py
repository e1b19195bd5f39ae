import numpy as np
import pytest

import autoscan


def test_read_mesh(eight_path):
    mesh = autoscan.read_mesh(eight_path)
    assert mesh.vertices.shape[1] == 3 and mesh.vertices.dtype == np.float64
    assert mesh.faces.dtype == np.int32 and mesh.faces.max() < len(mesh.vertices)
    assert mesh.area() > 0


def test_arrays_are_views_of_the_cpp_storage(tmp_path):
    pts = np.random.default_rng(1).normal(size=(100, 3))
    cloud = autoscan.PointCloud(pts, normals=pts / np.linalg.norm(pts, axis=1)[:, None])
    a, b = cloud.positions, cloud.positions
    # Zero copy: both arrays point at the same C++ buffer, owned by the cloud.
    assert a.base is cloud and b.base is cloud
    assert a.__array_interface__["data"][0] == b.__array_interface__["data"][0]
    assert a.flags.c_contiguous and a.flags.writeable
    a[0] = (7.0, 8.0, 9.0)  # writes go to the C++ cloud
    autoscan.write_point_cloud(tmp_path / "c.ply", cloud, double_coordinates=True)
    back = autoscan.read_point_cloud(tmp_path / "c.ply")
    np.testing.assert_array_equal(back.positions[0], [7.0, 8.0, 9.0])
    np.testing.assert_array_equal(back.positions[1:], pts[1:])
    # Results of C++ calls are moved into Python, not copied; the view keeps its owner alive.
    view = back.positions
    del back
    assert view.shape == (100, 3) and view[0, 0] == 7.0
    # Assigning copies in place: the buffer (and earlier views) stay valid.
    cloud.positions = np.zeros((100, 3))
    assert a.__array_interface__["data"][0] == cloud.positions.__array_interface__["data"][0]
    assert not a.any()


def test_scalars_and_colors(tmp_path):
    n = 10
    cloud = autoscan.PointCloud(np.arange(3 * n, dtype=float).reshape(n, 3), colors=np.full((n, 3), 200, np.uint8))
    cloud.set_scalar("f", np.linspace(0, 1, n))
    assert cloud.scalars["f"].base is cloud
    for ext in ("ply", "pcd"):
        autoscan.write_point_cloud(tmp_path / f"c.{ext}", cloud, double_scalars=True)
        back = autoscan.read_point_cloud(tmp_path / f"c.{ext}")
        np.testing.assert_array_equal(back.scalars["f"], np.linspace(0, 1, n))
        np.testing.assert_array_equal(back.colors, cloud.colors)


@pytest.mark.parametrize("ext,ascii", [("ply", False), ("pcd", False), ("pcd", True), ("xyz", True), ("pts", True)])
def test_point_cloud_round_trip(tmp_path, ext, ascii):
    rng = np.random.default_rng(2)
    pts = rng.normal(size=(50, 3))
    nrm = pts / np.linalg.norm(pts, axis=1)[:, None]
    cloud = autoscan.PointCloud(pts, normals=nrm)
    path = tmp_path / f"c.{ext}"
    autoscan.write_point_cloud(path, cloud, ascii=ascii, double_coordinates=True)
    back = autoscan.read_point_cloud(path)
    np.testing.assert_array_equal(back.positions, pts)
    if ext != "pts":
        np.testing.assert_array_equal(back.normals, nrm)


def test_write_and_read_mesh(tmp_path, eight):
    autoscan.write_mesh(tmp_path / "m.ply", eight, double_coordinates=True)
    back = autoscan.read_mesh(tmp_path / "m.ply")
    np.testing.assert_array_equal(back.vertices, eight.vertices)
    np.testing.assert_array_equal(back.faces, eight.faces)


def test_errors_are_python_exceptions_with_the_library_message(tmp_path):
    bad = tmp_path / "bad.ply"
    bad.write_text("ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nend_header\nnan\n")
    with pytest.raises(autoscan.InputError) as e:
        autoscan.read_point_cloud(bad)
    assert str(bad) in str(e.value)
    assert isinstance(e.value, ValueError) and isinstance(e.value, autoscan.Error)
    with pytest.raises(ValueError, match="no such file"):
        autoscan.read_mesh(tmp_path / "missing.off")
    with pytest.raises(autoscan.InputError, match="unknown file format"):
        autoscan.read_mesh(tmp_path / "x.abc")
    with pytest.raises(autoscan.InputError, match=r"shape \(N, 3\)"):
        autoscan.PointCloud(np.zeros((4, 2)))
    with pytest.raises(autoscan.InputError, match="non-finite"):
        autoscan.PointCloud(np.array([[0.0, np.nan, 0.0]]))
    assert issubclass(autoscan.Error, RuntimeError)
