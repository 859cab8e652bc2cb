"""Running the engine for the service: ``core.pipeline.describe`` with BLAS pinned, and the
translation of its ``Description`` into stored columns and API fields."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
from threadpoolctl import threadpool_limits

from app.previews import encode_preview
from core.pipeline import Description, describe
from core.settings import EngineSettings

__all__ = [
    "cutoff_record",
    "describe_upload",
    "model_columns",
    "pin_blas_threads",
    "problem_of_reason",
]


def pin_blas_threads() -> None:
    """Give BLAS/OpenMP one thread for the rest of this process.

    Workers and synchronous searches run side by side, one describe per thread; letting each
    also fan out over every core would oversubscribe the machine and slow all of them down.
    Done once per process because the limits are process-wide, not per thread.
    """
    import faiss

    threadpool_limits(limits=1)
    faiss.omp_set_num_threads(1)


def describe_upload(content: bytes, filename: str, settings: EngineSettings) -> Description:
    """Describe an uploaded file (call ``pin_blas_threads`` once in the process first)."""
    return describe(content, settings, filename=filename)


def cutoff_record(description: Description) -> dict[str, Any]:
    """The cutoff as stored: mode, n, solver calls, parameters and the predicted n per round."""
    cutoff = description.cutoff
    return {
        "mode": cutoff.mode,
        "n": int(cutoff.n),
        "solver_calls": int(cutoff.solver_calls),
        "params": {key: _plain(value) for key, value in cutoff.params.items()},
        "predicted": [int(n) for n in cutoff.predicted],
    }


def model_columns(description: Description, hks_times: Sequence[float]) -> dict[str, Any]:
    """The Model columns a finished description fills in; ``hks_times`` is the descriptor's
    time grid, the first columns of ``description.signature`` (its log scaled HKS)."""
    descriptor = np.ascontiguousarray(description.descriptor, dtype=np.float32)
    return {
        "n_points": description.n_points,
        "cutoff": cutoff_record(description),
        "eigenvalues": [float(v) for v in np.asarray(description.eigenvalues).ravel()],
        "descriptor": descriptor.tobytes(),
        "descriptor_version": description.descriptor_version,
        "timings": {stage: float(seconds) for stage, seconds in description.timings.items()},
        "preview": encode_preview(
            description.points,
            description.signature[:, : len(hks_times)],
            np.asarray(hks_times),
            description.eigenvalues,
        ),
    }


def problem_of_reason(reason: str, message: str) -> dict[str, str]:
    """A model's ``error`` for an ``InvalidShapeError`` reason code."""
    return {
        "type": f"urn:shapesearch:problem:{reason.replace('_', '-')}",
        "title": reason.replace("_", " ").capitalize(),
        "detail": message,
    }


def _plain(value: Any) -> Any:
    """JSON-safe copy of a numpy scalar or array."""
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, np.ndarray):
        return value.tolist()
    return value
