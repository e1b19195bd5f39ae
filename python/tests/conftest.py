"""Shared fixtures of the Python tests (run by ctest as python.pytest, docs/python.md).

Small settings keep the suite to seconds: a 160x120 scanner, Poisson depth 6, 1500 iso-points,
a 32^3 view grid. The test mesh is data/models/eight.off normalised to the benchmark frame
(diagonal 1, centred), done in place through the NumPy view of its vertices.
"""

import os
import pathlib

import numpy as np
import pytest

import autoscan

SOURCE = pathlib.Path(os.environ.get("AUTOSCAN_SOURCE_DIR", pathlib.Path(__file__).resolve().parents[2]))
MODELS = pathlib.Path(os.environ.get("AUTOSCAN_MODELS_DIR", SOURCE / "data" / "models"))

SCANNER = {"width": 160, "height": 120}
SESSION = {
    "consolidate": {"wlop": {"mode": "off"}},
    "poisson": {"depth": 6},
    "confidence": {"iso": {"count": 1500}, "k": 30},
    "nbv": {"grid_resolution": 32, "cells": 4, "max_views": 3},
    "global_registration": False,
    "stop": {"rule": "paper"},  # with stop_threshold 0 the paper's rule never fires: the budgets end the run
    "stop_threshold": 0.0,
    "max_iterations": 3,
}


def normalized(mesh):
    lo, hi = mesh.bounds()
    v = mesh.vertices  # a view: the mesh changes in place
    v -= 0.5 * (lo + hi)
    v /= np.linalg.norm(hi - lo)
    return mesh


@pytest.fixture(scope="session")
def eight_path():
    path = MODELS / "eight.off"
    if not path.exists():
        pytest.skip(f"{path} is missing (scripts/fetch-models)")
    return path


@pytest.fixture(scope="session")
def eight(eight_path):
    return normalized(autoscan.read_mesh(eight_path))


@pytest.fixture(scope="session")
def scanner(eight):
    return autoscan.VirtualScanner(eight, scanner=SCANNER)


@pytest.fixture(scope="session")
def blind(scanner):
    return scanner.blind_scan({"views": 6})


@pytest.fixture(scope="session")
def consolidated(blind):
    return autoscan.consolidate(blind.cloud, {"wlop": {"mode": "off"}}).cloud


@pytest.fixture(scope="session")
def recon(consolidated):
    return autoscan.reconstruct(consolidated, {"depth": 6})
