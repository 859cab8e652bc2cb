"""Named engine configurations compared by ``shapesearch eval``.

Every variant is a full ``EngineSettings``. Variants that share the Laplacian, the point
count and the sampling seed share one description of each model (one Laplacian, one growing
set of eigenpairs); they differ only in the cutoff and the descriptor, which are cheap.

All variants use ``EVAL_POINTS`` points per model (the service default, ``max_points``, is a
deployment setting; the eval pins it so the figures do not move when it changes).
"""

from __future__ import annotations

from dataclasses import replace
from typing import Any

from core.settings import (
    DESCRIPTOR_FAMILIES,
    HKS_TIMES,
    CutoffSettings,
    DescriptorSettings,
    EngineSettings,
    Laplacian,
)

__all__ = [
    "BENDABLE_WORDS_DESCRIPTOR",
    "BUDGET_POINTS",
    "DEFAULT_VARIANTS",
    "EVAL_POINTS",
    "NAIVE_DESCRIPTOR",
    "SCAN_VARIANTS",
    "SPECTRAL_DESCRIPTOR",
    "SS11_DESCRIPTOR",
    "VARIANTS",
    "resolve_variants",
]

#: Points per model in the evaluation: the engine's default ``max_points`` (chosen by the
#: budget sweep).
EVAL_POINTS = EngineSettings().max_points

#: Point budgets of the budget sweep (variants ``points-<N>``).
BUDGET_POINTS: tuple[int, ...] = (2000, 3000, 5000, 10000, 20000)

#: The naive baseline descriptor: heat-trace-scaled log-HKS at 16 log-spaced times
#: in [1e-3, 1e-1], 32 area-weighted bins on [-3, 3] per time, square root, L2.
NAIVE_DESCRIPTOR = DescriptorSettings(
    hks_times=HKS_TIMES,
    hks_scaled=True,
    hks_range=(-3.0, 3.0),
    bins=32,
    hks_weight=1.0,
    wks_energies=0,
    dna_count=0,
    local_weight=0.0,
).intrinsic()


#: The spectral descriptor: spectral blocks only, WKS-dominated (HKS weight 0.2, WKS slope
#: 1.0), chosen on capod alone; kept to compare against and as the base of the signature
#: variants below.
SPECTRAL_DESCRIPTOR = replace(
    DescriptorSettings().intrinsic(), hks_weight=0.2, wks_slope_weight=1.0, local_weight=0.0
)

#: The ``bendable`` family's layout before it became the spectral blocks alone: those and a
#: local block of idf-weighted HKS words (the shipped ``hks64`` vocabulary) at weight 2. Kept
#: to compare against (a bendable database described with it re-describes on upgrade).
BENDABLE_WORDS_DESCRIPTOR = replace(
    DESCRIPTOR_FAMILIES["bendable"], local_weight=2.0, local_encoding="bof",
    local_vocabulary="hks64", local_neighbours=(),
)

#: The layout before the shortened runs (``ss11``): today's with the extrinsic blocks
#: measuring the part as it is. Kept so that a deployment's redescribe on upgrade can be
#: compared with what it replaces.
SS11_DESCRIPTOR = replace(DescriptorSettings(), runs_longest=None)


def _without(settings: DescriptorSettings, weight: str) -> DescriptorSettings:
    """``settings`` with the block weighed by ``weight`` off."""
    off: dict[str, Any] = {weight: 0.0}
    return replace(settings, **off)


def _engine(
    cutoff: CutoffSettings | None = None,
    descriptor: DescriptorSettings | None = None,
    laplacian: Laplacian = "robust",
    points: int = EVAL_POINTS,
) -> EngineSettings:
    return EngineSettings(
        max_points=points,
        laplacian=laplacian,
        cutoff=cutoff or CutoffSettings(),
        descriptor=descriptor or DescriptorSettings(),
    )


def _fixed(n: int) -> CutoffSettings:
    return CutoffSettings(mode="fixed", n=n)


def _adaptive(xi: float, t: float) -> CutoffSettings:
    return replace(CutoffSettings(), mode="adaptive", xi=xi, t=t)


def _variants() -> dict[str, EngineSettings]:
    default = DescriptorSettings()
    spectral = SPECTRAL_DESCRIPTOR
    hks_only = replace(spectral, hks_weight=1.0, wks_energies=0, dna_count=0)
    variants = {
        # The naive baseline, with the paper's fixed 300 eigenpairs.
        "baseline": _engine(_fixed(300), NAIVE_DESCRIPTOR),
        # ... and with the cutoff defaults it shipped with (t = 1e-3: always n_max = 500).
        "baseline-adaptive": _engine(_adaptive(1e-10, 1e-3), NAIVE_DESCRIPTOR),
        # The chosen defaults, as the service runs them.
        "default": _engine(),
        "fixed100": _engine(_fixed(100)),
        "fixed300": _engine(_fixed(300)),
        # The cutoff knobs: t sets which eigenvalues matter, xi how small a step is ignored.
        "adaptive-t0.01-xi1e-8": _engine(_adaptive(1e-8, 0.01)),
        "adaptive-t0.01-xi1e-10": _engine(_adaptive(1e-10, 0.01)),
        "adaptive-t0.01-xi1e-12": _engine(_adaptive(1e-12, 0.01)),
        "adaptive-t0.02-xi1e-10": _engine(_adaptive(1e-10, 0.02)),
        "adaptive-t0.005-xi1e-10": _engine(_adaptive(1e-10, 0.005)),
        # Signatures, each with the default cutoff.
        "hks-raw": _engine(descriptor=replace(hks_only, hks_scaled=False)),
        "hks-scaled": _engine(descriptor=hks_only),
        "wks": _engine(
            descriptor=replace(spectral, hks_weight=0.0, wks_slope_weight=0.0, dna_count=0)
        ),
        "wks+slope": _engine(descriptor=replace(spectral, hks_weight=0.0, dna_count=0)),
        "hks+wks+slope": _engine(descriptor=replace(spectral, dna_count=0)),
        # The spectral descriptor, the layout before the shortened runs (ss11), the family
        # for bendable shapes, and the default without each block or with only the blocks
        # measured on the points.
        "spectral": _engine(descriptor=spectral),
        "ss11": _engine(descriptor=SS11_DESCRIPTOR),
        "bendable": _engine(descriptor=DESCRIPTOR_FAMILIES["bendable"]),
        "bendable-words": _engine(descriptor=BENDABLE_WORDS_DESCRIPTOR),
        "default-no-local": _engine(descriptor=replace(default, local_weight=0.0)),
        **{
            f"default-no-{name.removesuffix('_weight')}": _engine(
                descriptor=_without(default, name)
            )
            for name in DescriptorSettings.EXTRINSIC_WEIGHTS
        },
        "default-no-extrinsic": _engine(descriptor=default.intrinsic()),
        "extrinsic": _engine(
            descriptor=replace(
                default, hks_weight=0.0, wks_weight=0.0, wks_slope_weight=0.0, dna_weight=0.0,
                local_weight=0.0,
            )
        ),
        # The other Laplacian at the chosen setting (slow: run on a subset).
        "spcl": _engine(laplacian="spcl"),
    }
    # The point budget (max_points) with everything else at the default: the budget sweep.
    variants.update({f"points-{points}": _engine(points=points) for points in BUDGET_POINTS})
    return variants


#: Every named variant.
VARIANTS: dict[str, EngineSettings] = _variants()

#: What ``shapesearch eval`` runs when ``--variants`` is not given (all on the robust
#: Laplacian, so one eigen-solve per model serves them all).
DEFAULT_VARIANTS: tuple[str, ...] = tuple(
    name for name in VARIANTS
    if name not in ("spcl", "baseline-adaptive") and not name.startswith("points-")
)

#: Variants scored on simulated scans (each scan is one more eigen-solve per model).
SCAN_VARIANTS: tuple[str, ...] = (
    "baseline", "default", "fixed100", "fixed300", "adaptive-t0.02-xi1e-10"
)


def resolve_variants(names: list[str] | None) -> dict[str, EngineSettings]:
    """The variants named (all defaults when ``names`` is empty), validated.

    Raises
    ------
    ValueError
        An unknown name; the message lists the known ones.
    """
    chosen = list(names) if names else list(DEFAULT_VARIANTS)
    unknown = [name for name in chosen if name not in VARIANTS]
    if unknown:
        raise ValueError(f"unknown variants {unknown}; known: {', '.join(VARIANTS)}")
    result = {name: VARIANTS[name] for name in chosen}
    for settings in result.values():
        settings.validate()
    return result
