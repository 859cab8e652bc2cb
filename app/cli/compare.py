"""``shapesearch compare A B``: why two parts match, the figures of
``GET /v1/models/{id}/compare/{other_id}`` on the command line.

Each of A and B is a shape file or a model id. A file is read here as the engine reads it
(``core.io.load_points``: the same sample points a describe stores, in the file's units);
an id is a model of a running service (``--url``, ``--key``): two ids are compared by the
service, and a model compared with a file is fetched as its points (its comparison with
itself, ``points=4000``: its stored sample, in its units) and compared here with
``core.compare``, so the figures are the service's in either case. B is placed on A; the
lengths are in A's units.
"""

from __future__ import annotations

import json
import sys
import uuid
from pathlib import Path
from typing import Any

import numpy as np

__all__ = ["run"]

_POINTS = 4000


class CompareError(Exception):
    """What the command cannot do, in words for the user."""


def run(
    first: str,
    second: str,
    *,
    url: str | None,
    key: str | None,
    scale: bool = False,
    tolerance: float | None = None,
    as_json: bool = False,
) -> int:
    """Compare ``first`` and ``second`` (files or ids) and print the figures."""
    try:
        figures = _figures(first, second, url, key, scale, tolerance)
    except CompareError as error:
        print(f"error: {error}", file=sys.stderr)
        return 2
    if as_json:
        print(json.dumps(figures, indent=2))
    else:
        print(_text(figures))
    return 0


def _figures(
    first: str, second: str, url: str | None, key: str | None, scale: bool,
    tolerance: float | None,
) -> dict[str, Any]:
    if tolerance is not None and not tolerance > 0:
        raise CompareError(f"--tolerance must be positive, not {tolerance}")
    ids = [_model_id(first), _model_id(second)]
    if any(ids) and not url:
        raise CompareError("give the service's URL for a model id: --url or SHAPESEARCH_URL")
    if ids[0] and ids[1]:
        params: dict[str, Any] = {"scale": str(scale).lower()}
        if tolerance is not None:
            params["tolerance"] = tolerance
        answer = _get(url, key, f"/v1/models/{ids[0]}/compare/{ids[1]}", params)
        return {
            "a": first, "b": second, "units": answer["units"],
            **{name: answer[name] for name in ("alignment", "tolerance", "model_to_other",
                                               "other_to_model", "size_ratios", "extents")},
        }
    (a, units), (b, _) = (_points(text, found, url, key) for text, found in zip(
        (first, second), ids, strict=True))
    return _compared(first, second, a, b, units, scale, tolerance)


def _compared(
    first: str, second: str, a: np.ndarray, b: np.ndarray, units: str | None, scale: bool,
    tolerance: float | None,
) -> dict[str, Any]:
    from core.compare import compare

    try:
        found = compare(a, b, scale=scale, tolerance=tolerance)
    except ValueError as error:
        raise CompareError(str(error)) from error
    alignment, measured = found.alignment, found.deviations

    def figures(direction: Any) -> dict[str, float]:
        return {"rms": direction.rms, "mean": direction.mean, "p95": direction.p95,
                "max": direction.max, "within": direction.within}

    return {
        "a": first, "b": second, "units": units,
        "alignment": {"rotation": alignment.rotation.tolist(),
                      "translation": alignment.translation.tolist(),
                      "scale": alignment.scale, "candidates": alignment.candidates},
        "tolerance": measured.tolerance,
        "model_to_other": figures(measured.a_to_b),
        "other_to_model": figures(measured.b_to_a),
        "size_ratios": measured.size_ratios.tolist(),
        "extents": {"model": measured.extents_a.tolist(), "other": measured.extents_b.tolist()},
    }


def _model_id(text: str) -> str | None:
    """``text`` as a model id, unless a file of that name exists."""
    if Path(text).exists():
        return None
    try:
        return str(uuid.UUID(text))
    except ValueError:
        raise CompareError(f"{text!r} is neither a file nor a model id") from None


def _points(
    text: str, model_id: str | None, url: str | None, key: str | None
) -> tuple[np.ndarray, str | None]:
    """The sample points of a file (read as the engine reads it) or of a model of the
    service, and their units (None: the file's, undeclared)."""
    if model_id is None:
        from core.errors import InvalidShapeError
        from core.io import load_points
        from core.settings import EngineSettings

        engine = EngineSettings()
        try:
            loaded = load_points(Path(text), max_points=engine.max_points,
                                 min_points=engine.min_points, seed=engine.sample_seed,
                                 remove_outliers=engine.outlier_filter,
                                 outlier_ratio=engine.outlier_ratio, measure_size=False)
        except (InvalidShapeError, OSError) as error:
            raise CompareError(f"{text}: {error}") from error
        return loaded.points, None
    answer = _get(url, key, f"/v1/models/{model_id}/compare/{model_id}", {"points": _POINTS})
    return np.array(answer["points"]["model"]["positions"], dtype=np.float64), answer["units"]


def _get(url: str | None, key: str | None, path: str, params: dict[str, Any]) -> Any:
    import httpx

    headers = {"Authorization": f"Bearer {key}"} if key else {}
    try:
        response = httpx.get(f"{str(url).rstrip('/')}{path}", params=params, headers=headers,
                             timeout=60.0)
    except httpx.HTTPError as error:
        raise CompareError(f"{url}: {error}") from error
    if response.status_code != 200:
        try:
            detail = response.json().get("detail", response.text)
        except ValueError:
            detail = response.text
        raise CompareError(f"{response.status_code} from {path}: {detail}")
    return response.json()


def _text(figures: dict[str, Any]) -> str:
    units = f" {figures['units']}" if figures["units"] else ""
    a, b = figures["a"], figures["b"]
    there, back = figures["model_to_other"], figures["other_to_model"]

    def length(value: float) -> str:
        return f"{value:.4g}{units}"

    alignment = figures["alignment"]
    rows = [
        ("", "points of A", "points of B"),
        ("RMS", length(there["rms"]), length(back["rms"])),
        ("mean", length(there["mean"]), length(back["mean"])),
        ("95th percentile", length(there["p95"]), length(back["p95"])),
        ("maximum", length(there["max"]), length(back["max"])),
        (f"within {length(figures['tolerance'])}", f"{100 * there['within']:.1f} %",
         f"{100 * back['within']:.1f} %"),
        ("extents", " x ".join(f"{v:.4g}" for v in figures["extents"]["model"]),
         " x ".join(f"{v:.4g}" for v in figures["extents"]["other"])),
    ]
    width = [max(len(row[i]) for row in rows) for i in range(3)]
    lines = [f"A: {a}", f"B: {b} (placed on A; lengths in A's units{',' + units if units else ''})"]
    lines += ["  ".join(cell.ljust(w) for cell, w in zip(row, width, strict=True)).rstrip()
              for row in rows]
    lines += [
        "size of B over A along A's principal axes: "
        + " x ".join(f"{r:.4g}" for r in figures["size_ratios"]),
        "rotation (B onto A): " + "; ".join(
            " ".join(f"{v:+.5f}" for v in row) for row in alignment["rotation"]),
        "translation: " + " ".join(f"{v:.5g}" for v in alignment["translation"])
        + f"   scale: {alignment['scale']:.6g}   starts tried: {alignment['candidates']}",
    ]
    return "\n".join(lines)
