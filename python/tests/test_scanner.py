import numpy as np
import pytest

import autoscan
from conftest import SCANNER

POSE = {"position": [1.2, 0.0, 0.2], "direction": [-1.0, 0.0, -0.15]}


def test_scan(eight):
    r = autoscan.scan(eight, POSE, scanner=SCANNER, scan_id=3, seed=7)
    c = r.cloud
    assert len(c) > 1000 and c.has_normals
    assert set(c.scalars) >= {"scan_id", "sensor_x", "sensor_y", "sensor_z"}
    assert (c.scalars["scan_id"] == 3).all()
    assert r.pixels.dtype == np.uint32 and len(r.pixels) == len(c)
    assert r.diagnostics["points"] == len(c)
    np.testing.assert_allclose(r.misalignment, np.eye(4), atol=1e-12)
    # The points lie on the mesh's surface, in front of the scanner.
    assert (c.positions[:, 0] < 1.2).all()
    # The same scan through a VirtualScanner (BVH built once), pose given as a string.
    vs = autoscan.VirtualScanner(eight, scanner=SCANNER)
    r2 = vs.scan("1.2,0,0.2,-1,0,-0.15", scan_id=3, seed=7)
    np.testing.assert_array_equal(r2.cloud.positions, c.positions)


def point_inside(mesh):
    """A point just below the first face (faces are counter-clockwise seen from outside)."""
    a, b, c = mesh.vertices[mesh.faces[0]]
    n = np.cross(b - a, c - a)
    return (a + b + c) / 3 - 1e-3 * n / np.linalg.norm(n)


def test_scan_refusals(eight, scanner):
    with pytest.raises(autoscan.InputError, match="inside"):
        scanner.scan({"position": point_inside(eight), "direction": [1, 0, 0]})
    with pytest.raises(autoscan.InputError):
        scanner.scan({"position": [0, 0, float("nan")], "direction": [1, 0, 0]})
    with pytest.raises(autoscan.InputError, match="widht"):
        autoscan.VirtualScanner(autoscan.TriangleMesh(np.eye(3), [[0, 1, 2]]), scanner={"widht": 10})


def test_blind_scan(eight, blind):
    assert len(blind.poses) == 6 and set(blind.poses[0]) == {"position", "direction", "up"}
    assert len(np.unique(blind.cloud.scalars["scan_id"])) == 6
    r = autoscan.blind_scan(eight, scanner=SCANNER, options={"views": 6})
    np.testing.assert_array_equal(r.cloud.positions, blind.cloud.positions)
    with pytest.raises(autoscan.InputError, match="views"):
        autoscan.blind_scan(eight, options={"views": 0})


def test_inside(eight, scanner):
    inside = scanner.inside(np.array([[5.0, 5.0, 5.0], point_inside(eight)]))
    assert inside.dtype == bool and inside.tolist() == [False, True]
