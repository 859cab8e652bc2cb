"""One search vector per model from its per-point signature and its points.

For each scale (heat time, or wave energy) the signature values of all points go into a
histogram with fixed bin edges, each point weighted by the area it stands for, so that a
dense patch of a scan does not outvote a sparse one. Histograms are square-rooted
(Hellinger embedding: L2 distance between them is the Hellinger distance) and every block
is scaled to unit norm, then weighted; the whole vector has unit norm, so L2 distance and
inner product rank alike in FAISS.

The spectral blocks are intrinsic (unchanged by bending); the extrinsic blocks describe the
embedding itself from ``core.extrinsic``'s measurements, all invariant to rotation,
translation and scale:

- D2 and D1 (Osada et al. 2002): histograms of the distances between random area-weighted
  point pairs and of the distances from the centroid, each over its mean, measured on the
  sample with its principal spreads evened (a kind made in many lengths keeps one
  distribution);
- spread: square roots of the principal variances over their sum;
- normals: per principal axis, an area-weighted histogram of ``|cos|`` between the surface
  normals and that axis;
- symmetry: the distances of the surface from its seven mirror, half-turn and inversion
  images in its principal frame;
- axes: per principal axis, an area-weighted histogram of the points' offsets from the
  centroid along it, over the RMS radius;
- ring: the angular spectrum about the first and third principal axes per (soft) shell of
  distance from the axis (what repeats around a turned part: teeth, bolt holes, hex heads);
- caps: each end's depth-radius profile along the first and third principal axes, in the
  part's own radius (a head, a countersink, a hub or a thread's end, whatever the length),
  each axis averaged over the directions it could take when the shape does not define it.

D2, D1, normals and symmetry weigh each point by the area it has on the evened surface
(``core.extrinsic.evened_areas``), so a long part's body does not outweigh its ends.

The local block (``core.local_features``) pools every point's whole signature, and for the
rigid family its surface variation, over a vocabulary shipped in ``core/data``: the detail
(a screw's head, a flange's hub, a gear's teeth) that per-scale histograms drown.

Layout: ``[HKS | WKS | WKS slope | eigenvalue channel | D2 | spread | D1 | normals |
symmetry | axes | ring | caps | local]``, blocks of weight 0 left out.

Everything that changes the vector is written into ``descriptor_version``: vectors with
different versions must never be compared. That includes the installed versions of the
libraries the numbers come from (``ENGINE_LIBRARIES``): an upgrade of one of them makes every
stored model stale, like a change of setting, until it is re-described.
"""

from __future__ import annotations

import hashlib
from dataclasses import dataclass
from functools import lru_cache
from importlib import metadata
from pathlib import Path
from types import MappingProxyType

import numpy as np

from core.errors import SettingsError
from core.extrinsic import (
    angular_spectrum,
    axis_offsets,
    centroid_distance_ratios,
    end_profiles,
    evened_areas,
    evened_spreads,
    normal_axis_cosines,
    pair_distance_ratios,
    reflection_symmetry,
    shortened_runs,
    spread_profile,
    surface_normals,
)
from core.local_features import Vocabulary, encode_bof, encode_vlad, local_descriptors
from core.settings import DescriptorSettings, EngineSettings
from core.signatures import heat_kernel_signature, wave_kernel_signature, zero_eigenvalue_count

__all__ = [
    "BLOCK_WEIGHTS",
    "ENGINE_LIBRARIES",
    "VERSION_LENGTH",
    "DescriptorSpec",
    "area_histograms",
    "distance_distribution",
    "engine_library_versions",
    "ring_block",
]

# Layout generation: bump when the code changes the vector for unchanged settings.
# ss5: the local block; ss6: the ring block; ss7: the caps block; ss8: its soft axes; ss9: the
# ring block's soft shells; ss10: D2 and D1 of the evened sample; ss11: the evened surface's
# areas in D2, D1, normals and symmetry; ss12: the extrinsic blocks measure the part with its
# long runs of one cross-section shortened (issue 24)
_LAYOUT = "ss12"

#: The libraries whose upgrade can change a descriptor for unchanged code and settings
#: (distribution names): the linear algebra and eigensolvers (numpy, scipy, qdldl), the
#: Laplacian (robust-laplacian), mesh loading and surface sampling (trimesh).
ENGINE_LIBRARIES = ("numpy", "scipy", "trimesh", "robust-laplacian", "qdldl")

#: Longest ``descriptor_version`` (the width of the database column).
VERSION_LENGTH = 255

#: Every block's name (``DescriptorSpec.blocks``), in layout order, and the
#: ``DescriptorSettings`` field that weighs it.
BLOCK_WEIGHTS: dict[str, str] = {
    "hks": "hks_weight", "wks": "wks_weight", "slope": "wks_slope_weight", "dna": "dna_weight",
    "d2": "d2_weight", "spread": "spread_weight", "d1": "d1_weight", "normals": "normal_weight",
    "symmetry": "symmetry_weight", "axes": "axis_weight", "ring": "ring_weight",
    "caps": "caps_weight", "local": "local_weight",
}

#: Where the shipped vocabularies live (package data).
VOCABULARY_DIR = Path(__file__).resolve().parent / "data"


@lru_cache(maxsize=1)
def engine_library_versions() -> MappingProxyType[str, str]:
    """``ENGINE_LIBRARIES``' installed versions, read once per process (reading them costs
    ~5 ms; the code a process has loaded cannot change under it anyway). A library that is
    not installed as a distribution is ``"none"``."""
    versions = {}
    for name in ENGINE_LIBRARIES:
        try:
            versions[name] = metadata.version(name)
        except metadata.PackageNotFoundError:
            versions[name] = "none"
    return MappingProxyType(versions)


@lru_cache(maxsize=8)
def load_vocabulary(name: str) -> Vocabulary:
    """The shipped vocabulary ``core/data/<name>.npz``, loaded once per process.

    Raises
    ------
    SettingsError
        No such vocabulary.
    """
    path = VOCABULARY_DIR / f"{name}.npz"
    if not name or not path.is_file():
        raise SettingsError(
            f"unknown local vocabulary {name!r} (looked for {path})", "local_vocabulary"
        )
    return Vocabulary.load(path)


def area_histograms(
    values: np.ndarray, areas: np.ndarray, edges: np.ndarray
) -> np.ndarray:
    """Area-weighted histograms, one per column, with shared fixed bin edges.

    Parameters
    ----------
    values : (n, s) float
    areas : (n,) float
        Non-negative weights.
    edges : (b + 1,) float
        Increasing bin edges; values outside go to the end bins.

    Returns
    -------
    histograms : (s, b) float
        Each row sums to 1.
    """
    bins = edges.size - 1
    # Bin index of every value; clipping keeps outliers in the end bins instead of losing them.
    index = np.clip(np.searchsorted(edges, values, side="right") - 1, 0, bins - 1)
    histograms = np.zeros((values.shape[1], bins))
    for column in range(values.shape[1]):
        histograms[column] = np.bincount(index[:, column], weights=areas, minlength=bins)
    return histograms / np.maximum(histograms.sum(axis=1, keepdims=True), 1e-300)


def distance_distribution(
    points: np.ndarray, areas: np.ndarray, edges: np.ndarray, pairs: int, seed: int
) -> np.ndarray:
    """D2 shape distribution (Osada et al. 2002) of a surface given as weighted points.

    Distances between ``pairs`` random point pairs, each end drawn with probability
    proportional to its area (uniform on the surface, however unevenly it was sampled),
    divided by their mean so that neither scale nor the normalisation convention matters.

    Parameters
    ----------
    points : (n, 3) float
    areas : (n,) float
        Non-negative, not all zero.
    edges : (b + 1,) float
        Bin edges of distance over mean distance; values outside go to the end bins.
    pairs : int
    seed : int
        Seeds the pair draw: the same points always give the same histogram.

    Returns
    -------
    histogram : (b,) float
        Sums to 1.
    """
    ratios = pair_distance_ratios(points, areas, pairs, seed)
    return area_histograms(ratios[:, None], np.ones(pairs), edges)[0]


def _unit_block(block: np.ndarray) -> np.ndarray:
    flat = block.ravel()
    norm = np.linalg.norm(flat)
    return flat / norm if norm > 0 else flat


def ring_block(points: np.ndarray, areas: np.ndarray, weight: float = 1.0,
               shell_centres: tuple[float, float, float] | None = None) -> np.ndarray:
    """The ring block: ``core.extrinsic.angular_spectrum`` flattened, times ``weight``, over
    the square root of its length, ``(30,) float``.

    Not scaled to unit norm (see ``DescriptorSettings.ring_weight``): each value is in
    [0, 1], so the block's norm is at most 1 and small when nothing repeats.

    Parameters
    ----------
    points : (n, 3) float
    areas : (n,) float
    weight : float
        The block's weight (applied first, so the service's vectors stay bit for bit what
        they were before this helper existed).
    shell_centres : (3,) float, optional
        ``angular_spectrum``'s soft shells (``None``: the area tertiles).
    """
    spectrum = angular_spectrum(points, areas, shell_centres).ravel()
    return weight * spectrum / np.sqrt(spectrum.size)


def caps_block(
    points: np.ndarray, areas: np.ndarray, bins: int, depth: float, weight: float = 1.0,
    sharpness: float | None = None,
) -> np.ndarray:
    """The caps block: ``core.extrinsic.end_profiles``' square root at unit norm, times
    ``weight``, ``(4 * bins**2,) float``.

    Parameters
    ----------
    points : (n, 3) float
    areas : (n,) float
    bins : int
        Bins per coordinate of each end's histogram.
    depth : float
        How deep an end reaches, in the part's median radius.
    weight : float
    sharpness : float, optional
        ``end_profiles``' axis kernel (``None``: along the principal axes themselves).
    """
    profiles = end_profiles(points, areas, bins, depth, sharpness)
    return weight * _unit_block(np.sqrt(profiles))


@dataclass(frozen=True)
class DescriptorSpec:
    """The signature grids and histogram layout of one database.

    Build it with ``from_settings``; it only holds parameters.
    """

    times: tuple[float, ...]
    scaled: bool
    hks_edges: tuple[float, ...]
    hks_weight: float
    energies: tuple[float, ...]
    wks_sigma: float
    wks_edges: tuple[float, ...]
    wks_weight: float
    slope_edges: tuple[float, ...]
    slope_weight: float
    dna_count: int
    dna_weight: float
    d2_edges: tuple[float, ...]
    d2_pairs: int
    d2_seed: int
    d2_weight: float
    spread_weight: float
    d1_edges: tuple[float, ...]
    d1_weight: float
    evened_distances: bool
    evened_areas: bool
    normal_neighbours: int
    normal_edges: tuple[float, ...]
    normal_weight: float
    symmetry_weight: float
    axis_edges: tuple[float, ...]
    axis_weight: float
    ring_weight: float = 0.0
    ring_shells: tuple[float, float, float] | None = None
    caps_bins: int = 6
    caps_depth: float = 1.0
    caps_weight: float = 0.0
    caps_sharpness: float | None = None
    runs_longest: float | None = None
    local_weight: float = 0.0
    local_encoding: str = "vlad"
    local_vocabulary: str = ""
    local_columns: str = "hks"
    local_neighbours: tuple[int, ...] = ()
    family: str = "parts"

    @classmethod
    def from_settings(cls, settings: DescriptorSettings) -> DescriptorSpec:
        """The spec of ``settings``, validated.

        Raises
        ------
        ValueError
            Invalid settings, or a local block whose vocabulary is missing or was fitted on
            other columns than these settings give (another time grid needs its own
            vocabulary, or ``local_weight=0``).
        """
        settings.validate()
        if settings.local_weight > 0:
            columns = len(settings.hks_times) + (
                settings.wks_energies if settings.local_columns == "hks+wks" else 0
            ) + len(settings.local_neighbours)
            width = load_vocabulary(settings.local_vocabulary).width
            if width != columns:
                raise SettingsError(
                    f"local vocabulary {settings.local_vocabulary!r} was fitted on {width} "
                    f"columns, these settings give {columns} ({settings.local_columns}"
                    f" with {len(settings.hks_times)} times): fit a vocabulary for them "
                    "or set local_weight 0",
                    "hks_times", "local_vocabulary", "local_weight",
                )
        energies = np.linspace(*settings.wks_range, settings.wks_energies)
        # Aubry et al. tie the filter width to the energy step; on a coarse 16-step grid
        # two steps keep neighbouring energies distinct (7 steps smeared the whole spectrum
        # into one bump and made every model's WKS alike).
        step = float(energies[1] - energies[0]) if energies.size > 1 else 1.0
        return cls(
            times=tuple(settings.hks_times),
            scaled=settings.hks_scaled,
            hks_edges=tuple(np.linspace(*settings.hks_range, settings.bins + 1).tolist()),
            hks_weight=settings.hks_weight,
            energies=tuple(energies.tolist()),
            wks_sigma=settings.wks_sigma * step,
            wks_edges=tuple(np.linspace(*settings.wks_log_range, settings.bins + 1).tolist()),
            wks_weight=settings.wks_weight,
            slope_edges=tuple(np.linspace(*settings.wks_slope_range, settings.bins + 1).tolist()),
            slope_weight=settings.wks_slope_weight if energies.size > 1 else 0.0,
            dna_count=settings.dna_count,
            dna_weight=settings.dna_weight,
            d2_edges=tuple(np.linspace(*settings.d2_range, settings.bins + 1).tolist()),
            d2_pairs=settings.d2_pairs,
            d2_seed=settings.d2_seed,
            d2_weight=settings.d2_weight,
            spread_weight=settings.spread_weight,
            d1_edges=tuple(np.linspace(*settings.d1_range, settings.bins + 1).tolist()),
            d1_weight=settings.d1_weight,
            evened_distances=settings.evened_distances,
            evened_areas=settings.evened_areas,
            normal_neighbours=settings.normal_neighbours,
            normal_edges=tuple(np.linspace(0.0, 1.0, settings.normal_bins + 1).tolist()),
            normal_weight=settings.normal_weight,
            symmetry_weight=settings.symmetry_weight,
            axis_edges=tuple(np.linspace(*settings.axis_range, settings.axis_bins + 1).tolist()),
            axis_weight=settings.axis_weight,
            ring_weight=settings.ring_weight,
            ring_shells=settings.ring_shells,
            caps_bins=settings.caps_bins,
            caps_depth=settings.caps_depth,
            caps_weight=settings.caps_weight,
            caps_sharpness=settings.caps_sharpness,
            runs_longest=settings.runs_longest,
            local_weight=settings.local_weight,
            local_encoding=settings.local_encoding,
            local_vocabulary=settings.local_vocabulary,
            local_columns=settings.local_columns,
            local_neighbours=tuple(settings.local_neighbours),
            family=settings.family,
        )

    def signature(self, eigenvalues: np.ndarray, eigenvectors: np.ndarray) -> np.ndarray:
        """Per-point signature, ``(n, s)``: log HKS per time, then log WKS per energy.

        With unit total area and M-orthonormal eigenvectors, the scaled HKS and the WKS
        (normalised by its filter sum) both have area-weighted mean 1 at every scale, so their
        logs are centred near 0 and one set of bin edges fits every scale.
        """
        hks = heat_kernel_signature(
            eigenvalues, eigenvectors, np.asarray(self.times), scaled=self.scaled
        )
        columns = [np.log(np.maximum(hks, 1e-300))]
        if self.energies:
            wks = wave_kernel_signature(
                eigenvalues, eigenvectors, np.asarray(self.energies), self.wks_sigma
            )
            columns.append(np.log(np.maximum(wks, 1e-300)))
        return np.hstack(columns)

    @property
    def extrinsic(self) -> bool:
        """True when the vector depends on the points, not only on the spectrum."""
        return max(getattr(self, name) for name in DescriptorSettings.EXTRINSIC_WEIGHTS) > 0

    def histogram(
        self,
        signature: np.ndarray,
        areas: np.ndarray,
        eigenvalues: np.ndarray,
        points: np.ndarray | None = None,
    ) -> np.ndarray:
        """The descriptor, ``(d,) float32`` of unit norm.

        Parameters
        ----------
        signature : (n, s) float
            From ``signature``.
        areas : (n,) float
            Area each point stands for.
        eigenvalues : (k,) float
            Unit-area eigenvalues, for the normalised eigenvalue channel.
        points : (n, 3) float, optional
            The points the signature was computed on (any position and scale); required
            when ``extrinsic``.

        Raises
        ------
        ValueError
            ``points`` missing, or not one per signature row, while an extrinsic block is on.

        Notes
        -----
        The WKS slope block histograms ``log WKS(x, e_{j+1}) - log WKS(x, e_j)``: per-scale
        histograms lose which values occur together at one point, and the slope keeps the
        part of that joint information that separates classes best (measured on capod).
        """
        blocks = self.blocks(signature, areas, eigenvalues, points)
        return _unit_block(np.concatenate(list(blocks.values()))).astype(np.float32)

    def blocks(
        self,
        signature: np.ndarray,
        areas: np.ndarray,
        eigenvalues: np.ndarray,
        points: np.ndarray | None = None,
    ) -> dict[str, np.ndarray]:
        """The weighted blocks of ``histogram`` by name (``BLOCK_WEIGHTS``), in layout
        order, before the whole is scaled to unit norm; blocks of weight 0 are left out.
        Same parameters.

        With every weight 1 they are the unit blocks (``spread`` is unit by construction,
        ``symmetry`` raw) that a weight search recombines.
        """
        n_times = len(self.times)
        blocks: dict[str, np.ndarray] = {}
        if self.hks_weight > 0:
            hks = area_histograms(signature[:, :n_times], areas, np.asarray(self.hks_edges))
            blocks["hks"] = self.hks_weight * _unit_block(np.sqrt(hks))
        if self.energies:
            log_wks = signature[:, n_times:]
            if self.wks_weight > 0:
                wks = area_histograms(log_wks, areas, np.asarray(self.wks_edges))
                blocks["wks"] = self.wks_weight * _unit_block(np.sqrt(wks))
            if self.slope_weight > 0:
                slope = area_histograms(
                    np.diff(log_wks, axis=1), areas, np.asarray(self.slope_edges)
                )
                blocks["slope"] = self.slope_weight * _unit_block(np.sqrt(slope))
        if self.dna_count and self.dna_weight > 0:
            blocks["dna"] = self.dna_weight * _unit_block(self._eigenvalue_channel(eigenvalues))
        if self.extrinsic:
            blocks.update(self._extrinsic_blocks(points, areas, signature.shape[0]))
        if self.local_weight > 0:
            blocks["local"] = self.local_weight * self.local_block(signature, areas, points)
        return blocks

    def local_block(
        self, signature: np.ndarray, areas: np.ndarray, points: np.ndarray | None = None
    ) -> np.ndarray:
        """The unit local block: the points' local descriptors encoded on the vocabulary.

        Raises
        ------
        ValueError
            The vocabulary is unknown or its width does not match the local descriptors.
        """
        vocabulary = load_vocabulary(self.local_vocabulary)
        columns = signature[:, : len(self.times)] if self.local_columns == "hks" else signature
        features = local_descriptors(columns, points, self.local_neighbours)
        if features.shape[1] != vocabulary.width:
            raise ValueError(
                f"vocabulary {self.local_vocabulary!r} has {vocabulary.width} columns, the "
                f"local descriptors {features.shape[1]}"
            )
        encode = encode_vlad if self.local_encoding == "vlad" else encode_bof
        return encode(features, areas, vocabulary)

    def _extrinsic_blocks(
        self, points: np.ndarray | None, areas: np.ndarray, count: int
    ) -> dict[str, np.ndarray]:
        if points is None or points.shape != (count, 3):
            raise ValueError("the extrinsic blocks need the (n, 3) points of the signature")
        blocks: dict[str, np.ndarray] = {}
        # D2, D1, normals and symmetry weigh each point by its area on the evened surface
        # when asked (evened_areas; the spread, axis offsets, ring and caps keep the
        # sample's), and D2 and D1 measure distances apart from the proportions
        # (evened_spreads).
        evens_areas = self.evened_areas and max(
            self.d2_weight, self.d1_weight, self.normal_weight, self.symmetry_weight) > 0
        normals = (surface_normals(points, self.normal_neighbours)
                   if self.normal_weight > 0 or evens_areas else None)
        if self.runs_longest is not None:
            # Normals of the sample itself: a shortened run faces where it faced, and
            # estimating them on its denser points would not see that.
            points, areas, axes = shortened_runs(points, areas, self.runs_longest)
            normals = None if normals is None else normals @ axes
        layout_areas = (evened_areas(points, areas, normals)
                        if evens_areas and normals is not None else areas)
        distance_points = (evened_spreads(points, layout_areas) if self.evened_distances
                           else points)
        if self.d2_weight > 0:
            d2 = distance_distribution(distance_points, layout_areas,
                                       np.asarray(self.d2_edges), self.d2_pairs, self.d2_seed)
            blocks["d2"] = self.d2_weight * _unit_block(np.sqrt(d2))
        if self.spread_weight > 0:
            blocks["spread"] = self.spread_weight * spread_profile(points, areas)
        if self.d1_weight > 0:
            ratios = centroid_distance_ratios(distance_points, layout_areas)
            d1 = area_histograms(ratios[:, None], layout_areas, np.asarray(self.d1_edges))
            blocks["d1"] = self.d1_weight * _unit_block(np.sqrt(d1))
        if self.normal_weight > 0 and normals is not None:
            cosines = normal_axis_cosines(points, layout_areas, normals)
            facing = area_histograms(cosines, layout_areas, np.asarray(self.normal_edges))
            blocks["normals"] = self.normal_weight * _unit_block(np.sqrt(facing))
        if self.symmetry_weight > 0:
            # Raw distances, not unit norm: how symmetric a part is, not only in which way.
            blocks["symmetry"] = self.symmetry_weight * reflection_symmetry(points, layout_areas)
        if self.axis_weight > 0:
            edges = np.asarray(self.axis_edges)
            offsets = area_histograms(axis_offsets(points, areas), areas, edges)
            blocks["axes"] = self.axis_weight * _unit_block(np.sqrt(offsets))
        if self.ring_weight > 0:
            blocks["ring"] = ring_block(points, areas, self.ring_weight, self.ring_shells)
        if self.caps_weight > 0:
            blocks["caps"] = caps_block(
                points, areas, self.caps_bins, self.caps_depth, self.caps_weight,
                self.caps_sharpness,
            )
        return blocks

    def _eigenvalue_channel(self, eigenvalues: np.ndarray) -> np.ndarray:
        """ShapeDNA on Weyl's scale: ``log(lambda_j / 4 pi j)`` for the first non-zero ones.

        Zero eigenvalues (one per connected component of a multi-part model) are skipped, so
        a part made of two bodies is not shifted by one against a part made of one. A short
        spectrum repeats its last value rather than leaving zeros that would look like data.
        """
        nonzero = eigenvalues[zero_eigenvalue_count(eigenvalues) :][: self.dna_count]
        channel = np.zeros(self.dna_count)
        if nonzero.size:
            ratios = np.log(nonzero / (4.0 * np.pi * np.arange(1, nonzero.size + 1)))
            channel[: nonzero.size] = ratios
            channel[nonzero.size :] = ratios[-1]
        # Centre so the channel measures the shape of the spectrum, not a global offset.
        return channel - channel.mean()

    def version(self, settings: EngineSettings) -> str:
        """Everything that changes the vector, in one readable string; the exact values and
        ``engine_library_versions`` enter its closing digest."""
        cutoff = settings.cutoff
        cut = (
            f"fixed{cutoff.n}"
            if cutoff.mode == "fixed"
            else f"adaptive(xi={cutoff.xi:g},t={cutoff.t:g},{cutoff.n_min}-{cutoff.n_max})"
        )
        parts = [
            _LAYOUT if self.family == "parts" else f"{_LAYOUT}-{self.family}",
            f"lap={settings.laplacian}",
            f"norm={settings.normalisation}",
            f"pts={settings.max_points}"
            f"{f'+mor{settings.outlier_ratio:g}' if settings.outlier_filter else ''}",
            f"cut={cut}",
            f"hks{'s' if self.scaled else ''}={len(self.times)}"
            f"[{min(self.times):g},{max(self.times):g}]w{self.hks_weight:g}",
            f"bins={len(self.hks_edges) - 1}[{self.hks_edges[0]:g},{self.hks_edges[-1]:g}]",
        ]
        if self.energies:
            parts.append(
                f"wks={len(self.energies)}[{self.energies[0]:g},{self.energies[-1]:g}]"
                f"s{self.wks_sigma:.3g}w{self.wks_weight:g}slope{self.slope_weight:g}"
            )
        if self.dna_count:
            parts.append(f"dna={self.dna_count}w{self.dna_weight:g}")
        # "e": measured on the evened sample (evened_spreads); "a": weighed by the areas of
        # the evened surface (evened_areas).
        evened = "e" if self.evened_distances else ""
        areas = "a" if self.evened_areas else ""
        extrinsic = {
            f"d2{evened}{areas}": self.d2_weight, "spr": self.spread_weight,
            f"d1{evened}{areas}": self.d1_weight,
            f"nrm{areas}": self.normal_weight, f"sym{areas}": self.symmetry_weight,
            "ax": self.axis_weight,
            "ring": self.ring_weight, "caps": self.caps_weight,
        }
        if self.local_weight > 0:
            # The vocabulary's own digest: a refitted file is a new version.
            vocabulary = load_vocabulary(self.local_vocabulary)
            variation = "".join(f"+sv{k}" for k in self.local_neighbours)
            parts.append(
                f"loc={self.local_encoding}{vocabulary.size}{self.local_columns}{variation}"
                f"@{vocabulary.digest()[:6]}w{self.local_weight:g}"
            )
        if self.extrinsic:
            # Names, and weights other than 1; bins, pairs and neighbours are in the digest.
            parts.append("ext=" + ",".join(
                name if weight == 1 else f"{name}:{weight:g}"
                for name, weight in extrinsic.items() if weight > 0
            ))
            if self.runs_longest is not None:
                parts.append(f"runs={self.runs_longest:g}")
        # The readable part rounds; the digest pins every exact value (a custom time grid).
        vocabulary_digest = (
            load_vocabulary(self.local_vocabulary).digest() if self.local_weight > 0 else ""
        )
        # The libraries' versions only in the digest: they would crowd the readable part,
        # and GET /v1/stats shows them (engine_libraries).
        libraries = sorted(engine_library_versions().items())
        exact = repr((self, settings.laplacian, settings.normalisation, settings.max_points,
                      settings.sample_seed, settings.outlier_filter, settings.outlier_ratio,
                      cutoff, vocabulary_digest, libraries))
        digest = hashlib.sha256(exact.encode()).hexdigest()[:10]
        # The database keeps VERSION_LENGTH characters: an unusual setting's long readable
        # part is cut, never the digest that tells versions apart.
        readable = ";".join(parts)[: VERSION_LENGTH - len(digest) - 1]
        return f"{readable};{digest}"
