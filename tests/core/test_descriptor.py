"""Histogram descriptor: its blocks, layout, weighting, normalisation and versioning."""

from __future__ import annotations

import hashlib
from dataclasses import dataclass, replace
from typing import ClassVar

import numpy as np
import pytest

from core.descriptor import (
    BLOCK_WEIGHTS,
    VERSION_LENGTH,
    Block,
    DescriptorSpec,
    Sample,
    area_histograms,
    distance_distribution,
    load_vocabulary,
)
from core.descriptor import _sample as sample_module
from core.descriptor._version import canonical_text
from core.descriptor.blocks import CapsBlock, D2Block, DnaBlock, NormalsBlock, RingBlock
from core.evaluation.scans import random_rotation
from core.evaluation.variants import (
    BENDABLE_WORDS_DESCRIPTOR,
    NAIVE_DESCRIPTOR,
    SPECTRAL_DESCRIPTOR,
    SS11_DESCRIPTOR,
)
from core.extrinsic import ANGULAR_BANDS, principal_frame
from core.settings import (
    DESCRIPTOR_FAMILIES,
    HKS_TIMES,
    CutoffSettings,
    DescriptorSettings,
    EngineSettings,
    log_spaced_times,
)
from tests.shapes import plate_points, sphere_points, torus_points


def test_area_histograms_weight_by_area_and_keep_outliers() -> None:
    values = np.array([[-10.0], [0.1], [0.2], [10.0]])
    areas = np.array([1.0, 1.0, 6.0, 2.0])
    histograms = area_histograms(values, areas, np.array([0.0, 0.5, 1.0]))
    # -10 falls into the first bin, 10 into the last: nothing is lost.
    np.testing.assert_allclose(histograms, [[0.8, 0.2]])


def test_area_histograms_rows_sum_to_one() -> None:
    rng = np.random.default_rng(0)
    histograms = area_histograms(rng.normal(size=(100, 4)), rng.random(100), np.linspace(-2, 2, 9))
    np.testing.assert_allclose(histograms.sum(axis=1), 1.0)


def fake_spectrum(n_points: int = 400, k: int = 60, seed: int = 0):
    rng = np.random.default_rng(seed)
    eigenvectors, _ = np.linalg.qr(rng.standard_normal((n_points, k)))
    eigenvectors *= np.sqrt(n_points)  # M-orthonormal for areas 1 / n_points
    eigenvalues = 4 * np.pi * np.arange(k, dtype=np.float64)
    return eigenvalues, eigenvectors, np.full(n_points, 1.0 / n_points)


def fake_points(n_points: int = 400, seed: int = 0) -> np.ndarray:
    return torus_points(n_points, seed=seed)


def local_length(settings: DescriptorSettings) -> int:
    """Words (bag of words), or words x feature columns (VLAD), of the shipped vocabulary."""
    vocabulary = load_vocabulary(settings.local_vocabulary)
    return vocabulary.size * (vocabulary.width if settings.local_encoding == "vlad" else 1)


@pytest.mark.parametrize(
    "settings",
    [
        DescriptorSettings(),
        DescriptorSettings(wks_energies=0, dna_count=0),
        DescriptorSettings(wks_energies=8),
        DescriptorSettings(wks_energies=8, dna_count=20, wks_slope_weight=0.0),
        DescriptorSettings(bins=16, hks_times=(0.01, 0.1), local_weight=0.0),
        DescriptorSettings(local_encoding="bof"),
        DescriptorSettings(local_weight=0.0),
        DescriptorSettings(hks_weight=0.0, wks_weight=0.0),
        DescriptorSettings(d2_weight=0.0),
        DescriptorSettings(bins=8),
        DescriptorSettings(d1_weight=0.0),
        DescriptorSettings(normal_weight=0.0, symmetry_weight=0.0),
        DescriptorSettings(ring_weight=0.0),
        DescriptorSettings(caps_weight=0.0),
        DescriptorSettings(caps_bins=4, caps_depth=2.0),
        DescriptorSettings(runs_longest=None),
        DescriptorSettings(
            hks_weight=0.0, wks_weight=0.0, wks_slope_weight=0.0, dna_weight=0.0
        ),
    ],
)
def test_descriptor_is_unit_norm_float32_of_the_announced_length(settings) -> None:
    spec = DescriptorSpec.from_settings(settings)
    eigenvalues, eigenvectors, areas = fake_spectrum()
    signature = spec.signature(eigenvalues, eigenvectors)
    descriptor = spec.histogram(signature, areas, eigenvalues, fake_points())
    # Blocks: HKS (times x bins), WKS (energies x bins), WKS slope ((energies - 1) x bins),
    # eigenvalue channel (dna_count), D2 (bins), D1 (bins), normals (3 x 10 bins), symmetry
    # (7), ring (2 axes x 3 shells x bands), caps (2 axes x 2 ends x caps_bins^2), local
    # (words, x columns for VLAD); a block with weight 0 is left out.
    energies = settings.wks_energies
    length = (
        (len(settings.hks_times) * settings.bins if settings.hks_weight > 0 else 0)
        + (energies * settings.bins if energies and settings.wks_weight > 0 else 0)
        + ((energies - 1) * settings.bins if energies > 1 and settings.wks_slope_weight else 0)
        + (settings.dna_count if settings.dna_weight > 0 else 0)
        + (settings.bins if settings.d2_weight > 0 else 0)
        + (settings.bins if settings.d1_weight > 0 else 0)
        + (3 * 10 if settings.normal_weight > 0 else 0)
        + (7 if settings.symmetry_weight > 0 else 0)
        + (2 * 3 * len(ANGULAR_BANDS) if settings.ring_weight > 0 else 0)
        + (4 * settings.caps_bins**2 if settings.caps_weight > 0 else 0)
        + (local_length(settings) if settings.local_weight > 0 else 0)
    )
    assert descriptor.dtype == np.float32
    assert descriptor.shape == (length,)
    assert np.linalg.norm(descriptor) == pytest.approx(1.0, abs=1e-6)
    assert np.all(np.isfinite(descriptor))
    assert sum(spec.widths.values()) == length


def test_eigenvalue_channel_skips_zero_modes_of_multi_part_models() -> None:
    dna = DnaBlock(10)
    one_body = 4 * np.pi * np.arange(0, 40, dtype=np.float64) * 1.1
    two_bodies = np.concatenate([[0.0], one_body])  # a second zero: two components
    np.testing.assert_allclose(dna.channel(one_body), dna.channel(two_bodies))


def test_wks_block_uses_its_own_log_range_centred_near_zero() -> None:
    # M-orthonormal eigenvectors on unit area: the WKS has area-weighted mean 1 at every
    # energy, so log WKS must sit near 0, inside the default bin range.
    settings = DescriptorSettings(wks_range=(2.0, 6.0))
    spec = DescriptorSpec.from_settings(settings)
    eigenvalues, eigenvectors, areas = fake_spectrum()
    log_wks = spec.signature(eigenvalues, eigenvectors)[:, len(spec.grid.times) :]
    assert abs(np.median(log_wks)) < 1.0
    low, high = settings.wks_log_range
    assert np.mean((log_wks > low) & (log_wks < high)) > 0.95


def test_a_descriptor_without_blocks_is_refused() -> None:
    with pytest.raises(ValueError, match="no block"):
        DescriptorSettings(
            hks_weight=0.0, wks_energies=0, dna_count=0, d2_weight=0.0, d1_weight=0.0,
            normal_weight=0.0, symmetry_weight=0.0, ring_weight=0.0, caps_weight=0.0,
            local_weight=0.0,
        ).validate()


@pytest.mark.parametrize("longest", [0.0, -4.0, float("nan")])
def test_a_runs_longest_that_is_not_positive_is_refused(longest: float) -> None:
    with pytest.raises(ValueError, match="runs_longest"):
        DescriptorSettings(runs_longest=longest).validate()
    DescriptorSettings(runs_longest=None).validate()  # the part as it is: allowed


def test_version_changes_with_every_parameter_that_changes_the_vector() -> None:
    base = EngineSettings()
    spec = DescriptorSpec.from_settings(base.descriptor)
    variants = [
        replace(base, laplacian="spcl"),
        replace(base, max_points=base.max_points * 2),
        replace(base, normalisation="bbox"),
        replace(base, outlier_filter=False),
        replace(base, outlier_ratio=base.outlier_ratio + 1.0),
        replace(base, cutoff=CutoffSettings(mode="fixed", n=300)),
        replace(base, cutoff=CutoffSettings(xi=1e-12)),
    ]
    versions = {spec.version(base)} | {spec.version(v) for v in variants}
    descriptors = (
        DescriptorSettings(bins=16),
        DescriptorSettings(hks_scaled=False),
        DescriptorSettings(wks_energies=8),
        DescriptorSettings(hks_times=(1e-3, 1e-2, 0.05), local_weight=0.0),
        DescriptorSettings(hks_times=(1e-3, 1e-2, 0.06), local_weight=0.0),
        DescriptorSettings(local_weight=0.0),
        DescriptorSettings(local_weight=2.0),
        DescriptorSettings(local_encoding="bof"),
        DescriptorSettings(hks_weight=0.3),
        DescriptorSettings(wks_sigma=3.0),
        DescriptorSettings(wks_slope_weight=1.0),
        DescriptorSettings(wks_log_range=(-2.0, 2.0)),
        DescriptorSettings(dna_weight=0.3),
        DescriptorSettings(d2_weight=0.5),
        DescriptorSettings(d2_pairs=5000),
        DescriptorSettings(d1_weight=0.5),
        DescriptorSettings(normal_weight=1.0),
        DescriptorSettings(normal_neighbours=16),
        DescriptorSettings(symmetry_weight=0.5),
        DescriptorSettings(ring_weight=2.0),
        DescriptorSettings(caps_weight=2.0),
        DescriptorSettings(caps_bins=4),
        DescriptorSettings(caps_depth=2.0),
        DescriptorSettings(runs_longest=None),
        DescriptorSettings(runs_longest=3.0),
    )
    versions |= {DescriptorSpec.from_settings(d).version(base) for d in descriptors}
    # The blocks' own parameters, which no setting reaches, are in the digest too.
    blocks = (D2Block(32, seed=1), D2Block(32, bounds=(0.0, 2.5)), NormalsBlock(bins=8),
              RingBlock(shells=(0.25, 1.0, 1.75)), CapsBlock(sharpness=1024.0))
    versions |= {spec.with_block(b, spec.weight(b.name)).version(base) for b in blocks}
    assert len(versions) == 1 + len(variants) + len(descriptors) + len(blocks)
    # Readable too: D2 and D1 of the evened sample ("e") and the blocks weighed by the evened
    # surface's areas ("a") are marked.
    assert "ext=d2ea,d1ea,nrma:0.5,syma," in spec.version(base)
    # ... and the runs of one cross-section shortened to 4 radii.
    assert ";runs=4;" in spec.version(base)
    unshortened = DescriptorSpec.from_settings(DescriptorSettings(runs_longest=None))
    assert "runs=" not in unshortened.version(base)
    assert max(len(version) for version in versions) <= VERSION_LENGTH
    assert spec.version(base) == DescriptorSpec.from_settings(base.descriptor).version(base)


def test_a_long_version_keeps_its_digest_within_the_column() -> None:
    # Unusual settings make the readable part longer than the database column: it is cut,
    # the digest that tells the two apart is not.
    cutoff = CutoffSettings(xi=1.2345e-10, t=0.012345, n_min=1000, n_max=10000)
    times = tuple(np.geomspace(1.23456e-4, 0.123456, 16).tolist())
    base = EngineSettings(max_points=100000, cutoff=cutoff,
                          descriptor=DescriptorSettings(hks_times=times, d2_weight=0.75,
                                                        d1_weight=0.25, caps_weight=0.125))
    other = replace(base, descriptor=replace(base.descriptor, symmetry_weight=0.5))
    first, second = (DescriptorSpec.from_settings(s.descriptor).version(s) for s in (base, other))
    assert len(first) == len(second) == VERSION_LENGTH
    assert first[:150] == second[:150] and first != second


# --- extrinsic blocks (their measurements: tests/test_extrinsic.py) --------------------------

D2_EDGES = np.linspace(0.0, 3.0, 33)


def _d2(points: np.ndarray, areas: np.ndarray | None = None, seed: int = 0) -> np.ndarray:
    areas = np.full(len(points), 1.0 / len(points)) if areas is None else areas
    return distance_distribution(points, areas, D2_EDGES, 20000, seed)


def test_d2_sums_to_one_and_its_distances_are_over_their_mean() -> None:
    histogram = _d2(sphere_points(500))
    assert histogram.sum() == pytest.approx(1.0)
    centres = (D2_EDGES[1:] + D2_EDGES[:-1]) / 2
    # Distances over their mean have mean 1 (up to the bin width).
    assert histogram @ centres == pytest.approx(1.0, abs=0.05)
    # Unit sphere: D2 density is d / 2 on [0, 2], mean distance 4 / 3, so nothing lies
    # beyond 2 / (4 / 3) = 1.5 mean distances.
    assert histogram[centres > 1.55].sum() == 0.0


def test_d2_draws_pairs_by_area() -> None:
    points = plate_points(400)
    far = np.vstack([points, [[50.0, 50.0, 50.0]]])
    areas = np.append(np.full(400, 1.0 / 400), 0.0)
    # A point that stands for no area is never drawn: the far one changes nothing.
    np.testing.assert_allclose(_d2(far, areas), _d2(points))
    weighted = np.append(np.full(400, 0.5 / 400), 0.5)
    assert not np.allclose(_d2(far, weighted), _d2(points))


def test_extrinsic_blocks_ignore_rotation_translation_and_scale() -> None:
    points = torus_points(800, r=0.3)
    areas = np.random.default_rng(1).uniform(0.5, 1.5, 800)
    rotation = random_rotation(np.random.default_rng(2))
    moved = 3.7 * points @ rotation.T + np.array([5.0, -2.0, 1.0])
    np.testing.assert_allclose(_d2(moved, areas), _d2(points, areas), atol=1e-12)
    np.testing.assert_allclose(_extrinsic(moved, areas), _extrinsic(points, areas), atol=1e-6)


def _extrinsic(
    points: np.ndarray, areas: np.ndarray | None = None, caps_weight: float = 1.0
) -> np.ndarray:
    """The extrinsic part of the default descriptor, unit norm."""
    spec = DescriptorSpec.from_settings(
        DescriptorSettings(hks_weight=0.0, wks_weight=0.0, wks_slope_weight=0.0, dna_weight=0.0,
                           caps_weight=caps_weight)
    )
    eigenvalues, eigenvectors, uniform = fake_spectrum(len(points))
    areas = uniform if areas is None else areas
    signature = spec.signature(eigenvalues, eigenvectors)
    return spec.histogram(signature, areas, eigenvalues, points)


# The caps block measures each end in a window one radius deep, a few per cent of the
# points, and about an axis that a square plate does not define (its first axis turns between
# an edge and a diagonal from one sampling to the next): it brings more sampling noise than
# whole-part histograms. Measured at 1500 points, two samplings of a plate lie 0.45 of the
# way to the nearest other shape with it and under 0.25 without it (square plate 0.13,
# sphere 0.19, torus 0.06); on real parts the lowest copy score is lower than without the
# block.
@pytest.mark.parametrize(("caps_weight", "bound"), [(0.0, 0.25), (1.0, 0.5)])
def test_two_samplings_of_one_shape_are_closer_than_two_shapes(
    caps_weight: float, bound: float
) -> None:
    makers = {
        "square plate": lambda seed: plate_points(1500, seed=seed),
        "long plate": lambda seed: plate_points(1500, a=4.0, b=0.5, seed=seed),
        "sphere": lambda seed: sphere_points(1500, seed=seed),
        "torus": lambda seed: torus_points(1500, seed=seed),
    }
    first = {name: _extrinsic(make(0), caps_weight=caps_weight) for name, make in makers.items()}
    second = {name: _extrinsic(make(1), caps_weight=caps_weight) for name, make in makers.items()}
    for name in makers:
        same = np.linalg.norm(first[name] - second[name])
        others = min(
            np.linalg.norm(first[name] - first[other]) for other in makers if other != name
        )
        assert same < bound * others, (name, same, others)


def test_extrinsic_blocks_tell_a_flat_sheet_from_a_bent_one() -> None:
    # Rolling a 2 x pi/2 sheet into a half cylinder of radius 1/2 is an isometry: the
    # spectral blocks cannot see it, the extrinsic ones must.
    flat = plate_points(1500, a=2.0, b=np.pi / 2)
    angle = flat[:, 1] * 2.0  # arc length / radius, radius 0.5
    bent = np.column_stack([flat[:, 0], 0.5 * np.sin(angle), 0.5 * np.cos(angle)])
    resampled = plate_points(1500, a=2.0, b=np.pi / 2, seed=1)
    noise = np.linalg.norm(_extrinsic(flat) - _extrinsic(resampled))
    assert np.linalg.norm(_extrinsic(flat) - _extrinsic(bent)) > 4 * noise


def test_extrinsic_blocks_need_the_points() -> None:
    spec = DescriptorSpec.from_settings(DescriptorSettings())
    eigenvalues, eigenvectors, areas = fake_spectrum()
    signature = spec.signature(eigenvalues, eigenvectors)
    with pytest.raises(ValueError, match="points"):
        spec.histogram(signature, areas, eigenvalues)
    with pytest.raises(ValueError, match="points"):
        spec.histogram(signature, areas, eigenvalues, fake_points(300))
    # The default's local words hold surface variation (extrinsic): intrinsic() drops them.
    intrinsic = DescriptorSettings().intrinsic()
    assert intrinsic.local_weight == 0
    spectral = DescriptorSpec.from_settings(intrinsic)
    assert not spectral.extrinsic
    assert spectral.histogram(signature, areas, eigenvalues).shape == (1534,)
    # The bendable family is the spectral blocks alone; its earlier local block of HKS words
    # is intrinsic too, and needs no points.
    bendable = DESCRIPTOR_FAMILIES["bendable"]
    assert not DescriptorSpec.from_settings(bendable).extrinsic and bendable.local_weight == 0
    words = DescriptorSpec.from_settings(BENDABLE_WORDS_DESCRIPTOR)
    assert not words.extrinsic and BENDABLE_WORDS_DESCRIPTOR.local_weight > 0
    assert words.histogram(signature, areas, eigenvalues).shape == (
        1534 + local_length(BENDABLE_WORDS_DESCRIPTOR),
    )


def test_unit_blocks_reweighted_give_the_descriptor_of_those_weights() -> None:
    # What a weight search relies on: the blocks of a spec with every weight 1, scaled by w
    # and joined, are the descriptor of weights w.
    ones = DescriptorSpec.from_settings(
        DescriptorSettings(**dict.fromkeys(BLOCK_WEIGHTS.values(), 1.0))
    )
    weights = {"hks": 0.5, "wks": 1.0, "slope": 0.0, "dna": 0.2, "d2": 1.5, "d1": 0.0,
               "normals": 0.5, "symmetry": 2.0, "ring": 4.0, "caps": 1.5, "local": 0.7}
    chosen = DescriptorSpec.from_settings(
        DescriptorSettings(**{BLOCK_WEIGHTS[block]: weight for block, weight in weights.items()})
    )
    eigenvalues, eigenvectors, areas = fake_spectrum()
    points = fake_points()
    signature = ones.signature(eigenvalues, eigenvectors)
    unit = ones.blocks(signature, areas, eigenvalues, points)
    assert list(unit) == list(weights)
    joined = np.concatenate([weights[name] * unit[name] for name in unit if weights[name] > 0])
    np.testing.assert_allclose(
        chosen.histogram(signature, areas, eigenvalues, points),
        joined / np.linalg.norm(joined),
        atol=1e-6,
    )


# --- the union of blocks -------------------------------------------------------------------


def _default_parts() -> tuple[DescriptorSpec, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    spec = DescriptorSpec.from_settings(DescriptorSettings())
    eigenvalues, eigenvectors, areas = fake_spectrum()
    return spec, spec.signature(eigenvalues, eigenvectors), areas, eigenvalues, fake_points()


def test_the_union_holds_the_blocks_in_layout_order_and_their_widths_make_the_vector() -> None:
    spec, signature, areas, eigenvalues, points = _default_parts()
    assert spec.names == tuple(BLOCK_WEIGHTS)
    assert list(spec.widths) == list(BLOCK_WEIGHTS)  # every block is on by default
    blocks = spec.blocks(signature, areas, eigenvalues, points)
    assert {name: len(block) for name, block in blocks.items()} == spec.widths
    vector = spec.histogram(signature, areas, eigenvalues, points)
    assert len(vector) == sum(spec.widths.values())
    joined = np.concatenate(list(blocks.values()))
    np.testing.assert_array_equal(vector, (joined / np.linalg.norm(joined)).astype(np.float32))
    # Each block's weight is that of its setting.
    settings = DescriptorSettings()
    for name, field in BLOCK_WEIGHTS.items():
        assert spec.weight(name) == getattr(settings, field)


@pytest.mark.parametrize("name", list(BLOCK_WEIGHTS))
def test_a_block_of_weight_zero_is_left_out_and_the_others_stay_as_they_were(name: str) -> None:
    spec, signature, areas, eigenvalues, points = _default_parts()
    without = DescriptorSpec.from_settings(
        replace(DescriptorSettings(), **{BLOCK_WEIGHTS[name]: 0.0}))
    assert name not in without.widths and name in without.names
    before = spec.blocks(signature, areas, eigenvalues, points)
    after = without.blocks(signature, areas, eigenvalues, points)
    assert list(after) == [other for other in before if other != name]
    for other, block in after.items():
        np.testing.assert_array_equal(block, before[other])
    assert len(without.histogram(signature, areas, eigenvalues, points)) == (
        sum(spec.widths.values()) - spec.widths[name])


@dataclass(frozen=True)
class SpreadBlock(Block):
    """A block outside the layout: the principal spreads over their sum, ``(3,)``."""

    name: ClassVar[str] = "spread"
    extrinsic: ClassVar[bool] = True
    tag: ClassVar[str | None] = "spr"

    @property
    def width(self) -> int:
        return 3

    def measure(self, sample: Sample) -> np.ndarray:
        _, variances, _ = principal_frame(sample.body_points, sample.body_areas)
        return np.sqrt(variances / variances.sum())


def test_a_block_composed_in_changes_only_its_slice() -> None:
    spec, signature, areas, eigenvalues, points = _default_parts()
    composed = spec.with_block(SpreadBlock(), 2.0)
    assert composed.names == (*spec.names, "spread")
    assert composed.widths == {**spec.widths, "spread": 3}
    before = spec.blocks(signature, areas, eigenvalues, points)
    after = composed.blocks(signature, areas, eigenvalues, points)
    for name, block in before.items():
        np.testing.assert_array_equal(after[name], block)
    sample = composed.sample(signature, areas, eigenvalues, points)
    np.testing.assert_array_equal(after["spread"], 2.0 * SpreadBlock().measure(sample))
    # In the unit vector, the old blocks keep their directions: only the new slice is new.
    old = spec.histogram(signature, areas, eigenvalues, points).astype(np.float64)
    new = composed.histogram(signature, areas, eigenvalues, points).astype(np.float64)
    head = new[: len(old)]
    np.testing.assert_allclose(head / np.linalg.norm(head), old, atol=1e-6)
    # A new block is a new version: readable in the ext= list, and in the digest.
    base = EngineSettings()
    assert ",caps,spr:2;runs=4;" in composed.version(base)
    assert composed.version(base).rsplit(";", 1)[1] != spec.version(base).rsplit(";", 1)[1]
    # A block replaced in place keeps its slot, and changes only its own slice.
    replaced = spec.with_block(D2Block(32, pairs=5000), 1.0)
    assert replaced.names == spec.names
    again = replaced.blocks(signature, areas, eigenvalues, points)
    assert [name for name in before if not np.array_equal(before[name], again[name])] == ["d2"]


def test_block_names_are_unique() -> None:
    spec = DescriptorSpec.from_settings(DescriptorSettings())
    with pytest.raises(ValueError, match="unique"):
        replace(spec, parts=(*spec.parts, (RingBlock(), 1.0)))


def test_the_sample_derives_what_blocks_share_once(monkeypatch: pytest.MonkeyPatch) -> None:
    # Normals serve the normals block and the evened areas (which D2, D1, normals and
    # symmetry weigh by): one estimate for all; none when no block needs them.
    calls = []
    real = sample_module.surface_normals

    def counted(points: np.ndarray, neighbours: int) -> np.ndarray:
        calls.append(neighbours)
        return real(points, neighbours)

    monkeypatch.setattr(sample_module, "surface_normals", counted)
    spec, signature, areas, eigenvalues, points = _default_parts()
    spec.histogram(signature, areas, eigenvalues, points)
    assert calls == [12]
    calls.clear()
    ring_only = DescriptorSpec.from_settings(replace(
        DescriptorSettings(), d2_weight=0.0, d1_weight=0.0, normal_weight=0.0,
        symmetry_weight=0.0))
    ring_only.histogram(signature, areas, eigenvalues, points)
    assert calls == []


# The digest's canonical text opens with these settings' descriptor part, whose SHA-256
# begins so: stored versions were made with exactly this text, and a release that changes
# it makes every stored model stale although its vector did not change.
DIGEST_TEXTS = {
    "parts": (DESCRIPTOR_FAMILIES["parts"], "41f00960a849386d"),
    "bendable": (DESCRIPTOR_FAMILIES["bendable"], "e61fb60c35d08d61"),
    "bendable-words": (BENDABLE_WORDS_DESCRIPTOR, "6fecff2d83b34f8b"),
    "naive": (NAIVE_DESCRIPTOR, "32a361589317588d"),
    "spectral": (SPECTRAL_DESCRIPTOR, "49c39e7458ecc5fe"),
    "ss11": (SS11_DESCRIPTOR, "85e9366d3e160112"),
}


def test_the_default_times_are_written_out_as_their_grid() -> None:
    """The HKS times are literal values (a computed grid's last bit follows the CPU, and the
    times are part of the version): 16 log-spaced times in [1e-3, 1e-1], each within an
    ulp or two of the analytic value."""
    assert DescriptorSettings().hks_times is HKS_TIMES and len(HKS_TIMES) == 16
    exact = [10.0 ** (-3.0 + 2.0 * i / 15.0) for i in range(16)]
    np.testing.assert_allclose(HKS_TIMES, exact, rtol=1e-15, atol=0.0)
    assert HKS_TIMES[0] == 0.001 and HKS_TIMES[-1] == 0.1
    # The default grid is the written-out one (so the same version on every CPU); another
    # grid is computed.
    assert log_spaced_times(1e-3, 1e-1, 16) is HKS_TIMES
    other = log_spaced_times(1e-3, 1.0, 4)
    np.testing.assert_allclose(other, [1e-3, 1e-2, 1e-1, 1.0], rtol=1e-14)


@pytest.mark.parametrize("name", list(DIGEST_TEXTS))
def test_the_digest_text_is_that_of_the_stored_versions(name: str) -> None:
    settings, expected = DIGEST_TEXTS[name]
    engine = EngineSettings(descriptor=settings)
    spec = DescriptorSpec.from_settings(settings)
    text = canonical_text(spec, engine)
    described = text[1 : text.index(f", {engine.laplacian!r}, ")]
    assert described.startswith("DescriptorSpec(times=(0.001, ")
    assert hashlib.sha256(described.encode()).hexdigest()[:16] == expected
    digest = hashlib.sha256(text.encode()).hexdigest()[:10]
    assert spec.version(engine).endswith(f";{digest}")
