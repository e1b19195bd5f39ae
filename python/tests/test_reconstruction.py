import os
import subprocess

import numpy as np
import pytest

import autoscan
from conftest import SCANNER


def test_consolidate(blind, consolidated):
    assert consolidated.has_normals and 0 < len(consolidated) <= len(blind.cloud)
    r = autoscan.consolidate(blind.cloud, {"wlop": {"mode": "off"}})
    assert r.report["points_in"] == len(blind.cloud) and r.report["normals_orientation"] == "sensor"
    np.testing.assert_array_equal(r.cloud.positions, consolidated.positions)
    with pytest.raises(autoscan.InputError, match="unknown option 'outlier'"):
        autoscan.consolidate(blind.cloud, {"outlier": {}})


def test_poisson_field_matches_the_cpp_result(tmp_path, consolidated, recon):
    """The field seen from Python is the C++ field: values and gradients agree to 1e-12."""
    exe = os.environ.get("AUTOSCAN_PY_REFERENCE")
    if not exe:
        pytest.skip("AUTOSCAN_PY_REFERENCE is not set (run through ctest)")
    autoscan.write_point_cloud(tmp_path / "cloud.ply", consolidated, double_coordinates=True)
    rng = np.random.default_rng(5)
    queries = np.vstack([rng.uniform(-0.6, 0.6, size=(200, 3)), recon.mesh.vertices[::50]])
    np.savetxt(tmp_path / "queries.txt", queries, fmt="%.17g")
    out = subprocess.run([exe, tmp_path / "cloud.ply", tmp_path / "queries.txt", "6"], check=True,
                         capture_output=True, text=True).stdout.split("\n")
    iso, nv, nf = out[0].split()
    ref = np.array([[float(x) for x in line.split()] for line in out[1:] if line])
    field = recon.field
    assert float(iso) == pytest.approx(field.iso_value, abs=1e-12)
    assert (int(nv), int(nf)) == (len(recon.mesh.vertices), len(recon.mesh.faces))
    np.testing.assert_allclose(field.values(queries), ref[:, 0], rtol=0, atol=1e-12)
    np.testing.assert_allclose(field.gradients(queries), ref[:, 1:], rtol=0, atol=1e-12)
    # On the surface chi is the iso-value; the gradient points inward (the field is larger inside).
    v = recon.mesh.vertices
    assert np.median(np.abs(field.values(v) - field.iso_value)) < 1e-9
    assert field.gradients(np.zeros((0, 3))).shape == (0, 3)


def test_reconstruct(recon):
    assert recon.mesh.faces.shape[0] > 100 and "density" in recon.mesh.scalars
    d = recon.diagnostics
    assert d["points"] > 0 and d["levels"] and d["seconds"]["total"] > 0
    f = recon.field
    assert f.depth == 6 and f.reference_gradient > 0 and f.finest_cell_width > 0
    grid = f.sample_grid(8)
    assert grid.shape == (8, 8, 8) and grid.dtype == np.float32
    density = f.density(recon.mesh.vertices)
    assert (density >= 0).all() and density.max() > 0
    with pytest.raises(autoscan.InputError, match="depth"):
        autoscan.reconstruct(autoscan.PointCloud(np.zeros((3, 3))), {"depth": 99})


def test_confidence(blind, recon):
    c = autoscan.confidence(recon, blind.cloud, {"iso": {"count": 800}, "k": 30})
    iso = c.iso_points
    assert 500 < len(iso) < 1200 and {"f", "f_g", "f_s"} <= set(iso.scalars)
    assert 0 <= c.mean_f <= 1 and c.mean_f == pytest.approx(iso.scalars["f"].mean())
    assert "f" in c.mesh.scalars
    np.testing.assert_allclose(c.inward_normals, -iso.normals)


def test_assess_and_plan(consolidated, recon):
    a = autoscan.assess_cloud(consolidated, {"depth": 6}, {"iso": {"count": 800}, "k": 30})
    np.testing.assert_array_equal(a.reconstruction.mesh.vertices, recon.mesh.vertices)
    p = autoscan.plan(a.reconstruction.mesh, a.confidence.iso_points, scanner=SCANNER, rig="free",
                      current={"position": [1.2, 0, 0.3], "direction": [-1, 0, 0]},
                      options={"grid_resolution": 24, "cells": 4, "max_views": 4},
                      field=a.reconstruction.field)
    assert 0 < len(p.views) <= 4
    assert p.positions.shape == (len(p.views), 3) and p.scores.shape == (len(p.views),)
    assert p.g.shape == tuple(reversed(p.grid["dims"])) and p.g.base is p
    np.testing.assert_allclose(np.linalg.norm(p.directions, axis=1), 1)
    assert p.views[0]["score"] == p.scores[0] and p.path_length > 0
    assert p.to_json()["views"][0]["position"] == pytest.approx(list(p.positions[0]))
    assert "candidates" in p.diagnostics
    # A planned view is a pose: the scanner takes it as it is.
    vs = autoscan.VirtualScanner(a.reconstruction.mesh, scanner=SCANNER)
    assert len(vs.scan(p.views[0]).cloud) > 0
