"""Engine settings: every parameter that changes what ``describe`` computes.

Plain frozen dataclasses (the service maps its environment variables onto them), validated
in one place, ``validate()``, so every caller gets the same refusal for the same mistake.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from typing import Any, ClassVar, Literal, get_args

import numpy as np

from core.errors import SettingsError
from core.io._outliers import OUTLIER_RATIO

__all__ = [
    "DESCRIPTOR_FAMILIES",
    "HKS_TIMES",
    "MAX_VIEWS",
    "CutoffMode",
    "CutoffSettings",
    "DescriptorSettings",
    "EngineSettings",
    "Laplacian",
    "Normalisation",
    "ViewSettings",
    "log_spaced_times",
]


#: The point-cloud Laplacians, scale normalisations and cutoff modes (checked by ``validate``
#: too: callers outside a type checker may pass any string).
Laplacian = Literal["robust", "spcl"]
Normalisation = Literal["area", "bbox"]
CutoffMode = Literal["adaptive", "fixed"]


def _one_of(kind: Any) -> str:
    """A ``Literal``'s values for a refusal: ``'a' or 'b'``."""
    return " or ".join(repr(value) for value in get_args(kind))


@dataclass(frozen=True)
class CutoffSettings:
    """How many eigenpairs a model gets.

    ``mode="adaptive"`` runs the Williams & Ilies cutoff with ``xi`` and ``t``;
    ``mode="fixed"`` computes exactly ``n`` eigenpairs (the baseline of the paper).
    """

    mode: CutoffMode = "adaptive"
    xi: float = 1e-10
    # With unit area lambda_n ~ 4 pi n, so the criterion's n grows like 1 / t: t = 1e-3 asked
    # for thousands of eigenpairs (always clamped to n_max); t = 0.01 gives n ~ 160-250 on
    # capod at 3000 points.
    t: float = 1e-2
    seed: int = 50
    n_min: int = 80
    n_max: int = 500
    margin: int = 10
    n: int = 300

    def validate(self) -> None:
        if self.mode not in get_args(CutoffMode):
            raise SettingsError(
                f"cutoff mode must be {_one_of(CutoffMode)}, not {self.mode!r}", "mode"
            )
        if not 0 < self.xi < 1:
            raise SettingsError("cutoff xi must lie in (0, 1)", "xi")
        if self.t <= 0:
            raise SettingsError("cutoff t must be positive", "t")
        if self.seed < 2:
            raise SettingsError("cutoff seed must be at least 2 eigenpairs", "seed")
        if not 1 <= self.n_min <= self.n_max:
            raise SettingsError("cutoff needs 1 <= n_min <= n_max", "n_min", "n_max")
        if self.margin < 0:
            raise SettingsError("cutoff margin must be >= 0", "margin")
        if self.n < 2:
            raise SettingsError("fixed cutoff n must be at least 2", "n")


#: The default HKS times: 16 log-spaced in [1e-3, 1e-1], written out. Computed, they depend
#: on the CPU: ``np.geomspace(1e-3, 1e-1, 16)[6]`` is 0.006309573444801929 on the Intel Xeon
#: machines the stored versions were made on and 0.00630957344480193 on an AMD EPYC, and the
#: times are part of ``descriptor_version``: computed, one deployment's processes on two kinds
#: of CPU would each find the other's models stale.
HKS_TIMES: tuple[float, ...] = (
    0.001, 0.0013593563908785254, 0.0018478497974222907, 0.0025118864315095794,
    0.003414548873833601, 0.004641588833612777, 0.006309573444801929, 0.008576958985908946,
    0.011659144011798317, 0.015848931924611134, 0.021544346900318832, 0.02928644564625236,
    0.039810717055349734, 0.054116952654646375, 0.07356422544596414, 0.1,
)


def log_spaced_times(low: float, high: float, count: int) -> tuple[float, ...]:
    """``count`` times log-spaced from ``low`` to ``high``: ``HKS_TIMES`` for the default
    grid (the same on every CPU), else ``np.geomspace``'s (as every release computed them,
    so that a deployment's own grid keeps its version on the machine it was made on)."""
    if (low, high, count) == (HKS_TIMES[0], HKS_TIMES[-1], len(HKS_TIMES)):
        return HKS_TIMES
    return tuple(np.geomspace(low, high, count).tolist())


@dataclass(frozen=True)
class DescriptorSettings:
    """Signature grids, block weights and block parameters; shared by every model of one
    database.

    Grids are database-wide (log-spaced ``t`` for unit-area shapes, log-energies for the WKS),
    never derived from one model's own spectrum, so that descriptors of different models are
    comparable.

    The descriptor (``core.descriptor``) joins weighted blocks, a block of weight 0 left out:
    area-weighted histograms of log scaled HKS per time (``hks_weight``), of log WKS per
    energy and of the WKS slope between neighbouring energies (``wks_weight`` and
    ``wks_slope_weight``, when ``wks_energies > 0``), a normalised eigenvalue channel
    (``dna_weight``, when ``dna_count > 0``), blocks measured on the points themselves
    (``core.extrinsic``): the D2 and D1 shape distributions (``d2_weight``, ``d1_weight``),
    the directions the surface faces relative to its principal axes (``normal_weight``), its
    distance from its mirror, half-turn and inversion images (``symmetry_weight``), what
    repeats around its axes (``ring_weight``) and how its ends look (``caps_weight``), and
    local signatures pooled over a shipped vocabulary (``local_weight``).

    The spectral blocks are intrinsic: they cannot tell a bent sheet from a flat one, nor a
    U profile from a Z profile with the same web and flanges; the extrinsic blocks can.
    Weights and parameters were chosen by leave-one-source-out on third-party sources (each
    source of parts held out in turn while the others choose), the figures on sources no
    setting was chosen on: see the changelog.
    """

    hks_times: tuple[float, ...] = HKS_TIMES
    hks_scaled: bool = True
    # 0.1 % and 99.9 % quantiles of log scaled HKS on capod lie in about [-1.9, 2.4].
    hks_range: tuple[float, float] = (-2.0, 2.5)
    bins: int = 32
    hks_weight: float = 0.5
    wks_energies: int = 16
    # Log-eigenvalue range: unit-area lambda_2 is about e^1.4..e^3, lambda_200 about e^7.7.
    wks_range: tuple[float, float] = (2.0, 7.5)
    # Width of the WKS filters in energy steps (Aubry et al. use 6-7 steps of a 100-step grid).
    wks_sigma: float = 2.0
    # Bin range of log WKS (its area-weighted mean is 1, so the log is centred near 0).
    wks_log_range: tuple[float, float] = (-2.5, 2.5)
    wks_weight: float = 1.0
    wks_slope_weight: float = 0.5
    dna_count: int = 30
    dna_weight: float = 0.2
    # D2 and D1 are measured on the part with its principal spreads evened
    # (core.extrinsic.evened_spreads), so that a kind made in many lengths (screws, shafts,
    # keys) keeps one distance distribution and its head or hub counts (leave-one-source-out
    # +0.0052 mAP over the part as sampled, eight tuning sources).
    d2_weight: float = 1.0
    # 20000 pairs: two samplings of one part differ by ~0.03 in the unit block, different
    # parts by ~0.2.
    d2_pairs: int = 20000
    d1_weight: float = 1.0
    # D2, D1, normals and symmetry weigh each point by the area it has on the evened surface
    # (core.extrinsic.evened_areas), so a long screw's shank does not outweigh its head
    # (leave-one-source-out +0.0048 mAP over the sample's own areas).
    # Normals by local PCA of the 12 nearest points; 10 bins of |cos| per principal axis.
    normal_weight: float = 0.5
    normal_neighbours: int = 12
    symmetry_weight: float = 1.0
    # What repeats around the first and third principal axes (teeth, bolt holes, hex heads:
    # core.extrinsic.angular_spectrum) by three soft shells of distance from the axis, 30
    # values scaled to norm <= 1 but not to unit norm (a part with nothing repeating has a
    # small block, and that is information). Weight 4: leave-one-source-out +0.009 mAP over
    # no ring block on six tuning sources, +0.010 with a seventh no setting was chosen on.
    ring_weight: float = 4.0
    # Each end's depth-radius profile along the first and third principal axes, measured
    # from the end in the part's median radius (core.extrinsic.end_profiles), so that a
    # kind that comes in many lengths (screws, shafts, keys) keeps its head, countersink or
    # hub alike: ``caps_bins`` per coordinate, ends ``caps_depth`` radii deep. Each axis'
    # profile is averaged over the directions the axis could take, so that a part without a
    # defined axis (a cube, a square plate) does not change its ends from one sampling to
    # the next. Weight 1, 6 bins, 1 radius: leave-one-source-out +0.005 mAP over no caps
    # block on seven tuning sources.
    caps_weight: float = 1.0
    caps_bins: int = 6
    caps_depth: float = 1.0
    # The extrinsic blocks measure the part with each run of one cross-section along its
    # first axis (a shank, a shaft, a key) longer than this many radii shortened to it
    # (core.extrinsic.shortened_runs), so that a kind made in many lengths looks alike and
    # its head counts; None: the part as it is. 4 radii: leave-one-source-out +0.0162 mAP
    # over the part as it is on ten tuning sources, +0.0164 on an unseen extraction.
    runs_longest: float | None = 4.0
    # Local signatures pooled over a shipped vocabulary (core.local_features): the file
    # core/data/<local_vocabulary>.npz; each point's features are its log HKS at every time
    # (``local_columns="hks"``; "hks+wks" adds its log WKS), then its surface variation at
    # ``local_neighbours`` (none: intrinsic, unchanged by bending). The default: VLAD on
    # 64 words of the 16 log HKS values and the surface variation at 10 and 30 neighbours.
    local_weight: float = 1.0
    local_encoding: str = "vlad"
    local_vocabulary: str = "hks-sv64"
    local_columns: str = "hks"
    local_neighbours: tuple[int, ...] = (10, 30)
    #: The named preset these settings started from (``DESCRIPTOR_FAMILIES``); written into
    #: ``descriptor_version`` so that a database says which family it holds.
    family: str = "parts"

    #: The weights of the blocks measured on the points rather than the spectrum.
    EXTRINSIC_WEIGHTS: ClassVar[tuple[str, ...]] = (
        "d2_weight", "d1_weight", "normal_weight", "symmetry_weight", "ring_weight",
        "caps_weight",
    )
    #: Every block's weight.
    WEIGHTS: ClassVar[tuple[str, ...]] = (
        "hks_weight", "wks_weight", "wks_slope_weight", "dna_weight", *EXTRINSIC_WEIGHTS,
        "local_weight",
    )

    def intrinsic(self) -> DescriptorSettings:
        """The same settings with every extrinsic block off: a purely spectral descriptor.

        A local block that measures surface variation is extrinsic too and goes off.
        """
        local = 0.0 if self.local_neighbours else self.local_weight
        off: dict[str, Any] = dict.fromkeys(self.EXTRINSIC_WEIGHTS, 0.0)
        return replace(self, **off, local_weight=local)

    def validate(self) -> None:
        if not self.hks_times or min(self.hks_times) <= 0:
            raise SettingsError("hks_times must be a non-empty list of positive times", "hks_times")
        if self.bins < 2:
            raise SettingsError("descriptor needs at least 2 histogram bins", "bins")
        for name in ("hks_range", "wks_range", "wks_log_range"):
            low, high = getattr(self, name)
            if not low < high:
                raise SettingsError(f"{name} must be (low, high) with low < high", name)
        if self.wks_energies < 0 or self.dna_count < 0:
            raise SettingsError(
                "wks_energies and dna_count must be >= 0", "wks_energies", "dna_count"
            )
        if self.wks_sigma <= 0:
            raise SettingsError("wks_sigma must be positive", "wks_sigma")
        extrinsic = [getattr(self, name) for name in self.EXTRINSIC_WEIGHTS]
        negative = [name for name in self.WEIGHTS if getattr(self, name) < 0]
        if negative:
            raise SettingsError("channel weights must be >= 0", *negative)
        if self.normal_neighbours < 3:
            raise SettingsError("normal_neighbours must be at least 3", "normal_neighbours")
        if self.d2_pairs < 100:
            raise SettingsError("d2_pairs must be at least 100", "d2_pairs")
        if self.caps_bins < 2 or not self.caps_depth > 0:
            raise SettingsError(
                "caps_bins must be >= 2 and caps_depth > 0", "caps_bins", "caps_depth"
            )
        if self.runs_longest is not None and not self.runs_longest > 0:
            raise SettingsError("runs_longest must be positive (or None)", "runs_longest")
        if self.local_weight < 0:
            raise SettingsError("local_weight must be >= 0", "local_weight")
        if self.local_weight > 0:
            if self.local_encoding not in ("vlad", "bof"):
                raise SettingsError("local_encoding must be 'vlad' or 'bof'", "local_encoding")
            if not self.local_vocabulary:
                raise SettingsError(
                    "a local block (local_weight > 0) needs a local_vocabulary",
                    "local_weight", "local_vocabulary",
                )
            if self.local_columns not in ("hks", "hks+wks"):
                raise SettingsError("local_columns must be 'hks' or 'hks+wks'", "local_columns")
            if self.local_columns == "hks+wks" and self.wks_energies == 0:
                raise SettingsError(
                    "local_columns 'hks+wks' needs wks_energies > 0",
                    "local_columns", "wks_energies",
                )
            if any(count < 3 for count in self.local_neighbours):
                raise SettingsError(
                    "local_neighbours must each be at least 3", "local_neighbours"
                )
        if not (
            self.hks_weight > 0
            or (self.wks_energies > 0 and self.wks_weight > 0)
            or (self.wks_energies > 1 and self.wks_slope_weight > 0)
            or (self.dna_count > 0 and self.dna_weight > 0)
            or max(extrinsic) > 0
            or self.local_weight > 0
        ):
            raise SettingsError("descriptor has no block with a positive weight", *self.WEIGHTS)


def _bendable() -> DescriptorSettings:
    """The spectral blocks alone (HKS weight 0.2, WKS slope 1): every part of it unchanged
    when a shape bends.

    On re-posed shapes made by others (TOSCA and FAUST, held out) this layout ranks above the
    family's earlier one, which added a local block of idf-weighted HKS words
    (``core.evaluation.variants.BENDABLE_WORDS_DESCRIPTOR``), and above the naive baseline;
    the words had been chosen on our own bendable sources alone. No third-party source of
    shapes that bend is at hand to choose by, so the family is the best layout measured.
    """
    return replace(
        DescriptorSettings().intrinsic(), hks_weight=0.2, wks_slope_weight=1.0,
        local_weight=0.0, family="bendable",
    )


#: The descriptor families a database can hold (``SHAPESEARCH_DESCRIPTOR_FAMILY``):
#: ``parts`` (the default) for rigid parts, where how the surface sits in space tells kinds
#: apart; ``bendable`` for shapes that bend or articulate (hoses, cables, springs, hands,
#: people), where only what bending keeps may count.
DESCRIPTOR_FAMILIES: dict[str, DescriptorSettings] = {
    "parts": DescriptorSettings(),
    "bendable": _bendable(),
}


#: Most views per model: the index gives each model 16 view ids (``app.search.index``).
MAX_VIEWS = 16


@dataclass(frozen=True)
class ViewSettings:
    """Scan mode: virtual partial views of every model, and boundary weights (``core.views``).

    ``count`` views per model are described next to the model itself (0: none); their
    directions are fixed (``core.views.view_directions``), ``distance`` bounding-box diagonals
    from the centre, seen by hidden point removal with exponent ``hpr_exponent``. Views and
    scan queries fade out points near an open rim (``core.views.boundary_weights`` with
    ``boundary_neighbours``, ``boundary_threshold`` and ``boundary_reach``) when
    ``boundary_weights`` is on. None of these change the model's own descriptor, so they are
    not part of the descriptor version.

    ``boundary_weights`` is off by default: on the whole of capod, scan mode scored higher
    without them for single-view and merged scans alike (mAP 0.748 / 0.867 against 0.717 /
    0.846, measured with an earlier default descriptor), and the generated parts' test split
    agreed.
    """

    # 29 parts and capod models, CPU seconds: a part with 3 views costs 2.8x a plain
    # describe (median), with 4 views 3.5x: over a budget of 3x.
    count: int = 3
    distance: float = 3.0
    hpr_exponent: float = 3.0
    boundary_weights: bool = False
    boundary_neighbours: int = 16
    boundary_threshold: float = 0.35
    boundary_reach: float = 0.1

    def validate(self) -> None:
        if not 0 <= self.count <= MAX_VIEWS:
            raise SettingsError(f"view count must lie in [0, {MAX_VIEWS}]", "count")
        if self.distance <= 0:
            raise SettingsError("view distance must be positive", "distance")
        if self.boundary_neighbours < 3:
            raise SettingsError("boundary_neighbours must be at least 3", "boundary_neighbours")
        if self.boundary_threshold <= 0 or self.boundary_reach <= 0:
            raise SettingsError(
                "boundary_threshold and boundary_reach must be positive",
                "boundary_threshold", "boundary_reach",
            )


@dataclass(frozen=True)
class EngineSettings:
    """Everything ``describe`` needs.

    ``outlier_ratio`` (service: ``SHAPESEARCH_OUTLIER_RATIO``): with ``outlier_filter`` on,
    a point of an uploaded cloud is dropped when its mean distance to its 8 nearest neighbours
    exceeds this many times the median of that distance. A rule of mean + 2 standard
    deviations would cut 3-4 % of the points of a *clean* cloud, so that an ``.xyz`` export
    of a part would be described unlike its own mesh (descriptor distance median 0.08-0.11,
    a third to a half of the distance to the nearest other model, on the generated parts and
    capod); with the median rule (ratio 3) it is 0 for the median part. On simulated scans
    (capod tune subset, 45 models) the median rule moved the mAP by -0.005 to +0.009 per scan
    kind, within the subset's noise.
    """

    max_points: int = 3000
    min_points: int = 100
    laplacian: Laplacian = "robust"
    normalisation: Normalisation = "area"
    sample_seed: int = 0
    # Drop stray points of scanned clouds (meshes are never filtered); see core/io/_outliers.py.
    outlier_filter: bool = True
    outlier_ratio: float = OUTLIER_RATIO
    cutoff: CutoffSettings = field(default_factory=CutoffSettings)
    descriptor: DescriptorSettings = field(default_factory=DescriptorSettings)
    views: ViewSettings = field(default_factory=ViewSettings)

    def validate(self) -> None:
        if self.min_points < 10:
            raise SettingsError("min_points must be at least 10", "min_points")
        if self.max_points < self.min_points:
            raise SettingsError("max_points must be >= min_points", "max_points", "min_points")
        if self.laplacian not in get_args(Laplacian):
            raise SettingsError(
                f"laplacian must be {_one_of(Laplacian)}, not {self.laplacian!r}", "laplacian"
            )
        if not self.outlier_ratio > 1.0:
            raise SettingsError(
                "outlier_ratio must be > 1 (in median neighbour spacings)", "outlier_ratio"
            )
        if self.normalisation not in get_args(Normalisation):
            raise SettingsError(f"normalisation must be {_one_of(Normalisation)}",
                                "normalisation")
        for section in ("cutoff", "descriptor", "views"):
            try:
                getattr(self, section).validate()
            except SettingsError as error:
                raise error.within(section) from None
