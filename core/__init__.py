"""shapesearch engine: spectral shape descriptors with a model-adaptive eigenpair cutoff.

The science only: no web, no database. The public face::

    from core import describe, EngineSettings
    description = describe("part.stl")
    description.descriptor        # (d,) float32, unit norm
    description.cutoff.n          # eigenpairs used

Modules: ``io`` (files to points), ``normalise``, ``laplacian`` (L, M), ``eigen``
(incremental generalised eigen-solver), ``cutoff``, ``signatures`` (HKS, WKS),
``descriptor`` (weighted blocks), ``extrinsic`` (measurements of the embedding),
``pipeline`` (``describe``), ``evaluation`` (retrieval scores).
Names are imported on first use, so ``import core.cutoff`` does not load trimesh.
"""

from __future__ import annotations

import importlib
from typing import Any

_EXPORTS = {
    "AdaptiveCutoff": "core.cutoff",
    "CutoffResult": "core.cutoff",
    "FixedCutoff": "core.cutoff",
    "InvalidShapeError": "core.errors",
    "ShapeSearchError": "core.errors",
    "SolverError": "core.errors",
    "Description": "core.pipeline",
    "describe": "core.pipeline",
    "describe_points": "core.pipeline",
    "CutoffSettings": "core.settings",
    "DescriptorSettings": "core.settings",
    "EngineSettings": "core.settings",
}

__all__ = sorted(_EXPORTS)


def __getattr__(name: str) -> Any:
    if name not in _EXPORTS:
        raise AttributeError(f"module 'core' has no attribute {name!r}")
    return getattr(importlib.import_module(_EXPORTS[name]), name)
