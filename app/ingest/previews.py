"""Small previews of described models, for the viewer: points, HKS and spectrum in one blob.

A preview is what a browser needs to draw a model coloured by its heat kernel signature
without the eigenvectors: a fixed subsample of the normalised points, the log scaled HKS of
those points at every time of the database's grid, and the eigenvalues. Stored once per
description (``models.preview``) and served as is by ``GET /v1/models/{id}/preview``.

Layout, little-endian::

    magic  b"SSP1"
    uint32 n        points
    uint32 s        times of the HKS grid
    uint32 k        eigenvalues
    float32[s]      times
    float32[k]      eigenvalues
    float16[n, 3]   points (centred, unit surface area)
    float16[n, s]   log scaled HKS, point-major

float16 keeps 3 significant digits: plenty for a picture, a quarter of float64's size.
"""

from __future__ import annotations

import struct
from dataclasses import dataclass

import numpy as np

__all__ = ["MAGIC", "PREVIEW_POINTS", "Preview", "decode_preview", "encode_preview"]

MAGIC = b"SSP1"
PREVIEW_POINTS = 2000
_HEADER = struct.Struct("<4sIII")


@dataclass(frozen=True)
class Preview:
    """A decoded preview.

    Attributes
    ----------
    points : (n, 3) float16
    log_hks : (n, s) float16
    times : (s,) float32
    eigenvalues : (k,) float32
    """

    points: np.ndarray
    log_hks: np.ndarray
    times: np.ndarray
    eigenvalues: np.ndarray


def subsample(n: int, size: int = PREVIEW_POINTS, seed: int = 0) -> np.ndarray:
    """Sorted indices of at most ``size`` of ``n`` points, the same for the same ``n``."""
    if n <= size:
        return np.arange(n)
    return np.sort(np.random.default_rng(seed).choice(n, size, replace=False))


def encode_preview(
    points: np.ndarray, log_hks: np.ndarray, times: np.ndarray, eigenvalues: np.ndarray
) -> bytes:
    """The preview bytes.

    Parameters
    ----------
    points : (n, 3) float
        All points of the description; a subsample of ``PREVIEW_POINTS`` is kept.
    log_hks : (n, s) float
        Log scaled HKS of every point at every time.
    times : (s,) float
    eigenvalues : (k,) float
    """
    keep = subsample(len(points))
    times = np.asarray(times, dtype="<f4")
    eigenvalues = np.asarray(eigenvalues, dtype="<f4").ravel()
    if log_hks.shape != (len(points), times.size):
        raise ValueError(f"log_hks must be (n, {times.size}), not {log_hks.shape}")
    return b"".join(
        [
            _HEADER.pack(MAGIC, keep.size, times.size, eigenvalues.size),
            times.tobytes(),
            eigenvalues.tobytes(),
            np.ascontiguousarray(points[keep], dtype="<f2").tobytes(),
            np.ascontiguousarray(log_hks[keep], dtype="<f2").tobytes(),
        ]
    )


def decode_preview(blob: bytes) -> Preview:
    """Read what ``encode_preview`` wrote; ``ValueError`` for anything else."""
    if len(blob) < _HEADER.size:
        raise ValueError("preview too short")
    magic, n, s, k = _HEADER.unpack_from(blob)
    if magic != MAGIC:
        raise ValueError("not a preview")
    expected = _HEADER.size + 4 * (s + k) + 2 * n * (3 + s)
    if len(blob) != expected:
        raise ValueError(f"preview has {len(blob)} bytes, expected {expected}")
    offset = _HEADER.size
    times = np.frombuffer(blob, "<f4", s, offset)
    offset += 4 * s
    eigenvalues = np.frombuffer(blob, "<f4", k, offset)
    offset += 4 * k
    points = np.frombuffer(blob, "<f2", 3 * n, offset).reshape(n, 3)
    offset += 6 * n
    log_hks = np.frombuffer(blob, "<f2", n * s, offset).reshape(n, s)
    return Preview(points=points, log_hks=log_hks, times=times, eigenvalues=eigenvalues)
