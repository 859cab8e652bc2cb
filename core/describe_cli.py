"""``shapesearch describe FILE``: run the engine on one file and print what it found."""

from __future__ import annotations

import argparse
import json
import sys
from dataclasses import replace
from typing import Any

from core.errors import InvalidShapeError
from core.pipeline import Description, describe
from core.settings import CutoffSettings, EngineSettings

__all__ = ["parse_cutoff", "run"]


def parse_cutoff(text: str) -> CutoffSettings:
    """``"adaptive"`` or ``"fixed:N"`` as cutoff settings."""
    if text == "adaptive":
        return CutoffSettings(mode="adaptive")
    mode, _, count = text.partition(":")
    if mode == "fixed" and count.isdigit():
        return CutoffSettings(mode="fixed", n=int(count))
    raise ValueError(f"--cutoff must be 'adaptive' or 'fixed:N', not {text!r}")


def summary(description: Description, preview: int = 8) -> dict[str, Any]:
    """The JSON-ready summary printed by the command."""
    cutoff = description.cutoff
    return {
        "format": description.format,
        "n_points": description.n_points,
        "cutoff": cutoff.record(description.features).to_json(),
        "eigenvalues_head": [round(float(v), 6) for v in description.eigenvalues[:preview]],
        "timings": description.timings,
        "descriptor_version": description.descriptor_version,
        "descriptor_length": int(description.descriptor.size),
        "descriptor_head": [round(float(v), 6) for v in description.descriptor[:preview]],
    }


def run(args: argparse.Namespace) -> int:
    settings = EngineSettings()
    try:
        settings = replace(settings, cutoff=parse_cutoff(args.cutoff))
        if args.laplacian:
            settings = replace(settings, laplacian=args.laplacian)
        if args.max_points:
            settings = replace(settings, max_points=args.max_points)
        settings.validate()
    except ValueError as error:
        print(f"shapesearch describe: {error}", file=sys.stderr)
        return 2
    try:
        description = describe(args.file, settings)
    except (InvalidShapeError, OSError) as error:
        print(f"shapesearch describe: {args.file}: {error}", file=sys.stderr)
        return 1
    report = summary(description)
    if args.json:
        print(json.dumps(report, indent=2))
        return 0
    cutoff = report["cutoff"]
    print(f"{args.file}: {report['format']}, {report['n_points']} points")
    print(f"cutoff   {cutoff['mode']}: n = {cutoff['n']}, solver calls = {cutoff['solver_calls']}"
          f", predicted = {cutoff['predicted']}")
    print("timings  " + ", ".join(f"{k} {v:.3f} s" for k, v in description.timings.items()))
    print(f"version  {report['descriptor_version']}")
    print(f"vector   {report['descriptor_length']} floats: {report['descriptor_head']} ...")
    return 0
