"""autoscan: quality-driven Poisson-guided autoscanning (Wu et al. 2014) over NumPy arrays.

The compiled module ``_autoscan`` holds the bindings (docs/python.md). Everything is re-exported
here: ``import autoscan; autoscan.read_mesh(...)``. Errors: ``autoscan.InputError`` (bad input, a
``ValueError``) and ``autoscan.Error`` (a ``RuntimeError``, the base of both). Log records of the
library go to ``logging.getLogger("autoscan")``.
"""

import logging as _logging

from ._autoscan import (  # noqa: F401
    BlindScanResult,
    CloudAssessment,
    ConfidenceResult,
    ConsolidateResult,
    Error,
    InputError,
    NextViews,
    PlanResult,
    PointCloud,
    PoissonField,
    PoissonResult,
    ScanResult,
    Session,
    TriangleMesh,
    VirtualScanner,
    __version__,
    assess_cloud,
    blind_scan,
    confidence,
    consolidate,
    evaluate,
    evaluate_cloud,
    plan,
    read_mesh,
    read_point_cloud,
    reconstruct,
    scan,
    simulate,
    write_mesh,
    write_point_cloud,
)

# A library logs nothing unless the application configures logging (the logging HOWTO's advice).
_logging.getLogger("autoscan").addHandler(_logging.NullHandler())

__all__ = [
    "BlindScanResult",
    "CloudAssessment",
    "ConfidenceResult",
    "ConsolidateResult",
    "Error",
    "InputError",
    "NextViews",
    "PlanResult",
    "PointCloud",
    "PoissonField",
    "PoissonResult",
    "ScanResult",
    "Session",
    "TriangleMesh",
    "VirtualScanner",
    "assess_cloud",
    "blind_scan",
    "confidence",
    "consolidate",
    "evaluate",
    "evaluate_cloud",
    "plan",
    "read_mesh",
    "read_point_cloud",
    "reconstruct",
    "scan",
    "simulate",
    "write_mesh",
    "write_point_cloud",
]
