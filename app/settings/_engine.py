"""The engine's settings: what ``describe`` computes (``DescribeSettings``) and the virtual
views scan mode describes beside every model (``ScanSettings``). ``engine_settings`` is the
single place where they become the engine's ``core.settings.EngineSettings``; its defaults
come from there, so that the service and ``shapesearch describe`` agree."""

from __future__ import annotations

from dataclasses import replace
from typing import TYPE_CHECKING, Literal

from pydantic import BaseModel, Field

from core.descriptor import DescriptorSpec
from core.errors import SettingsError
from core.settings import (
    DESCRIPTOR_FAMILIES,
    CutoffMode,
    CutoffSettings,
    EngineSettings,
    Laplacian,
    Normalisation,
    log_spaced_times,
)

if TYPE_CHECKING:
    from app.settings import Settings

__all__ = [
    "ENGINE_VARIABLES", "DescribeSettings", "ScanSettings", "engine_settings", "variables_of",
]

_ENGINE = EngineSettings()


class DescribeSettings(BaseModel):
    """Sampling, the Laplacian, the eigenpair cutoff and the descriptor: every one is part of
    ``descriptor_version``."""

    max_points: int = Field(
        default=_ENGINE.max_points,
        description="Points per shape: meshes are sampled with exactly this many, larger "
        "clouds thinned to it, smaller clouds keep all theirs. Raise it (e.g. 20000) for "
        "thin-walled parts; one database uses one value.",
    )
    min_points: int = Field(
        default=_ENGINE.min_points,
        description="Fewer usable points than this: the shape is refused.",
    )
    laplacian: Laplacian = Field(
        default=_ENGINE.laplacian, description="Point-cloud Laplacian: robust or spcl."
    )
    normalisation: Normalisation = Field(
        default=_ENGINE.normalisation,
        description="Scale normalisation: unit surface area or unit bounding box.",
    )
    sample_seed: int = Field(default=_ENGINE.sample_seed, description="Seed of the point sampling.")
    outlier_filter: bool = Field(
        default=_ENGINE.outlier_filter,
        description="Drop statistical outliers (stray points) of uploaded point clouds; "
        "meshes are never filtered.",
    )
    outlier_ratio: float = Field(
        default=_ENGINE.outlier_ratio,
        description="Outlier filter cut: a cloud point whose mean distance to its 8 nearest "
        "neighbours exceeds this many times the median of that distance is dropped.",
    )
    cutoff_mode: CutoffMode = Field(
        default=_ENGINE.cutoff.mode, description="adaptive (per-model eigenpair count) or fixed."
    )
    cutoff_xi: float = Field(
        default=_ENGINE.cutoff.xi, description="Adaptive cutoff: xi."
    )
    cutoff_t: float = Field(
        default=_ENGINE.cutoff.t, description="Adaptive cutoff: diffusion time t."
    )
    cutoff_seed: int = Field(
        default=_ENGINE.cutoff.seed,
        description="Adaptive cutoff: eigenpairs of the first round.",
    )
    cutoff_n_min: int = Field(
        default=_ENGINE.cutoff.n_min, description="Adaptive cutoff: smallest n."
    )
    cutoff_n_max: int = Field(
        default=_ENGINE.cutoff.n_max, description="Adaptive cutoff: largest n."
    )
    cutoff_margin: int = Field(
        default=_ENGINE.cutoff.margin,
        description="Adaptive cutoff: extra eigenpairs per round.",
    )
    cutoff_n: int = Field(
        default=_ENGINE.cutoff.n, description="Fixed cutoff: eigenpairs per model."
    )
    descriptor_family: Literal["parts", "bendable"] = Field(
        default="parts",
        description="Descriptor family of this database: parts (rigid parts; sees how the "
        "surface sits in space) or bendable (hoses, cables, springs, hands, people: only what "
        "bending keeps). Written into descriptor_version; a change needs a re-describe.",
    )
    descriptor_t_min: float = Field(
        default=min(_ENGINE.descriptor.hks_times),
        description="Descriptor: smallest heat-kernel time.",
    )
    descriptor_t_max: float = Field(
        default=max(_ENGINE.descriptor.hks_times),
        description="Descriptor: largest heat-kernel time.",
    )
    descriptor_times: int = Field(
        default=len(_ENGINE.descriptor.hks_times),
        description="Descriptor: number of log-spaced heat-kernel times.",
    )
    descriptor_hks_scaled: bool = Field(
        default=_ENGINE.descriptor.hks_scaled,
        description="Descriptor: use the scale-invariant heat-kernel signature.",
    )
    descriptor_bins: int = Field(
        default=_ENGINE.descriptor.bins, description="Descriptor: histogram bins."
    )
    descriptor_wks_energies: int = Field(
        default=_ENGINE.descriptor.wks_energies,
        description="Descriptor: wave-kernel energies (0: no WKS block).",
    )
    descriptor_hks_weight: float | None = Field(
        default=None,
        description="Descriptor: weight of the heat-kernel block (unset: the family's).",
    )
    descriptor_wks_slope_weight: float | None = Field(
        default=None,
        description="Descriptor: weight of the WKS slope block (unset: the family's).",
    )
    descriptor_wks_weight: float = Field(
        default=_ENGINE.descriptor.wks_weight,
        description="Descriptor: weight of the WKS block.",
    )
    descriptor_dna_count: int = Field(
        default=_ENGINE.descriptor.dna_count,
        description="Descriptor: eigenvalues in the shape-DNA block (0: none).",
    )
    descriptor_dna_weight: float = Field(
        default=_ENGINE.descriptor.dna_weight,
        description="Descriptor: weight of the shape-DNA block.",
    )


class ScanSettings(BaseModel):
    """Scan mode's virtual partial views (not part of a model's own descriptor)."""

    scan_views: int = Field(
        default=_ENGINE.views.count,
        description="Scan mode: virtual partial views described and indexed per model, next "
        "to the model itself (0: none; search?mode=scan then compares whole models only). "
        "Applies to models described from then on.",
    )
    scan_boundary_weights: bool = Field(
        default=_ENGINE.views.boundary_weights,
        description="Scan mode: fade points near an open rim out of the histograms of views "
        "and scan queries.",
    )
    scan_boundary_neighbours: int = Field(
        default=_ENGINE.views.boundary_neighbours,
        description="Scan mode: neighbours that decide whether a point lies on an open rim.",
    )
    scan_boundary_threshold: float = Field(
        default=_ENGINE.views.boundary_threshold,
        description="Scan mode: a point is on a rim when its neighbours' centroid is off by "
        "more than this many mean neighbour distances.",
    )
    scan_boundary_reach: float = Field(
        default=_ENGINE.views.boundary_reach,
        description="Scan mode: distance from the rim, in square roots of the surface area, "
        "over which a point's histogram weight rises from 0 to 1.",
    )


def _or(value: float | None, family_value: float) -> float:
    return family_value if value is None else value


#: The variables behind each engine setting (``core.errors.SettingsError.fields``); engine
#: settings without a variable of their own keep their family's value.
ENGINE_VARIABLES: dict[str, tuple[str, ...]] = {
    **{name: (name,) for name in ("max_points", "min_points", "laplacian", "normalisation",
                                  "outlier_ratio")},
    **{f"cutoff.{name}": (f"cutoff_{name}",)
       for name in ("mode", "xi", "t", "seed", "n_min", "n_max", "margin", "n")},
    "descriptor.hks_times": ("descriptor_t_min", "descriptor_t_max", "descriptor_times"),
    **{f"descriptor.{name}": (f"descriptor_{name}",)
       for name in ("bins", "wks_energies", "hks_weight", "wks_weight", "wks_slope_weight",
                    "dna_count", "dna_weight")},
    "views.count": ("scan_views",),
    **{f"views.{name}": (f"scan_{name}",)
       for name in ("boundary_neighbours", "boundary_threshold", "boundary_reach")},
}


def variables_of(error: SettingsError) -> list[str]:
    """The ``SHAPESEARCH_*`` variables an engine ``SettingsError`` is about (a setting without
    a variable is named by its engine path)."""
    names = [
        f"SHAPESEARCH_{variable.upper()}" if path in ENGINE_VARIABLES else path
        for path in error.fields
        for variable in ENGINE_VARIABLES.get(path, (path,))
    ]
    return list(dict.fromkeys(names))


def engine_settings(settings: Settings) -> EngineSettings:
    """Map the service settings onto the engine's settings, validated by the engine
    (``core.errors.SettingsError`` names the settings that do not work together)."""
    family = DESCRIPTOR_FAMILIES[settings.descriptor_family]
    if min(settings.descriptor_t_min, settings.descriptor_t_max) <= 0:
        raise SettingsError("heat-kernel times must be positive", "descriptor.hks_times")
    engine = EngineSettings(
        max_points=settings.max_points,
        min_points=settings.min_points,
        laplacian=settings.laplacian,
        normalisation=settings.normalisation,
        sample_seed=settings.sample_seed,
        outlier_filter=settings.outlier_filter,
        outlier_ratio=settings.outlier_ratio,
        cutoff=CutoffSettings(
            mode=settings.cutoff_mode,
            xi=settings.cutoff_xi,
            t=settings.cutoff_t,
            seed=settings.cutoff_seed,
            n_min=settings.cutoff_n_min,
            n_max=settings.cutoff_n_max,
            margin=settings.cutoff_margin,
            n=settings.cutoff_n,
        ),
        # Fields without a variable of their own (bin ranges, filter widths) keep the
        # family's measured defaults: start from them, never from a second copy of the numbers.
        descriptor=replace(
            family,
            hks_times=log_spaced_times(
                settings.descriptor_t_min, settings.descriptor_t_max, settings.descriptor_times
            ),
            hks_scaled=settings.descriptor_hks_scaled,
            hks_weight=_or(settings.descriptor_hks_weight, family.hks_weight),
            bins=settings.descriptor_bins,
            wks_energies=settings.descriptor_wks_energies,
            wks_weight=settings.descriptor_wks_weight,
            wks_slope_weight=_or(settings.descriptor_wks_slope_weight, family.wks_slope_weight),
            dna_count=settings.descriptor_dna_count,
            dna_weight=settings.descriptor_dna_weight,
        ),
        views=replace(
            _ENGINE.views,
            count=settings.scan_views,
            boundary_weights=settings.scan_boundary_weights,
            boundary_neighbours=settings.scan_boundary_neighbours,
            boundary_threshold=settings.scan_boundary_threshold,
            boundary_reach=settings.scan_boundary_reach,
        ),
    )
    engine.validate()
    try:
        # The local block's vocabulary must fit the time grid: refused at start-up, not per job.
        DescriptorSpec.from_settings(engine.descriptor)
    except SettingsError as error:
        raise error.within("descriptor") from None
    return engine
