"""Local signatures over a fixed vocabulary (``core.local_features``): invariances,
determinism, and the vocabulary's place in ``descriptor_version``."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from core.descriptor import DescriptorSpec, load_vocabulary
from core.descriptor.blocks import local as local_module
from core.evaluation.variants import BENDABLE_WORDS_DESCRIPTOR
from core.local_features import (
    Vocabulary,
    encode_bof,
    encode_vlad,
    local_descriptors,
    surface_variation,
)
from core.settings import DESCRIPTOR_FAMILIES, DescriptorSettings, EngineSettings
from tests.shapes import plate_points, sphere_points, torus_points


def rotation(seed: int) -> np.ndarray:
    matrix, _ = np.linalg.qr(np.random.default_rng(seed).standard_normal((3, 3)))
    return matrix * np.sign(np.linalg.det(matrix))


def test_surface_variation_is_zero_on_a_plane_and_constant_on_a_sphere() -> None:
    flat = surface_variation(plate_points(2000), (10, 30))
    assert flat.max() < 1e-12
    round_ = surface_variation(sphere_points(4000), (10, 30))
    # On a sphere every neighbourhood is alike: small, positive, nearly the same everywhere.
    assert 0 < np.median(round_[:, 1]) < 0.05
    assert np.percentile(round_[:, 1], 90) < 3 * np.percentile(round_[:, 1], 10)
    # A larger neighbourhood sees more of the curve.
    assert np.median(round_[:, 1]) > np.median(round_[:, 0])


@pytest.mark.parametrize(
    "transform",
    [
        pytest.param(lambda p: p @ rotation(1).T, id="rotation"),
        pytest.param(lambda p: 4.2 * p + np.array([10.0, -3.0, 2.0]), id="scale-translation"),
    ],
)
def test_surface_variation_is_invariant(transform) -> None:
    points = torus_points(1500)
    np.testing.assert_allclose(
        surface_variation(transform(points), (10, 30)),
        surface_variation(points, (10, 30)),
        atol=1e-9,
    )


def small_vocabulary(words: int = 8) -> tuple[Vocabulary, list[np.ndarray]]:
    rng = np.random.default_rng(0)
    shapes = [torus_points(600, seed=s) for s in range(3)] + [sphere_points(600, seed=4)]
    features = [
        local_descriptors(rng.normal(size=(600, 4)) + i, points, (10, 30))
        for i, points in enumerate(shapes)
    ]
    return Vocabulary.fit(features, words, seed=3), features


def test_vocabulary_fit_is_deterministic_and_round_trips(tmp_path) -> None:
    first, features = small_vocabulary()
    again = Vocabulary.fit(features, 8, seed=3)
    np.testing.assert_array_equal(first.centres, again.centres)
    assert first.digest() == again.digest()
    first.save(tmp_path / "v.npz")
    loaded = Vocabulary.load(tmp_path / "v.npz")
    assert loaded.digest() == first.digest()
    moved = replace(first, centres=first.centres + 1e-6)
    assert moved.digest() != first.digest()


@pytest.mark.parametrize("encode", [encode_vlad, encode_bof])
def test_encodings_are_unit_and_free_of_point_order(encode) -> None:
    vocabulary, features = small_vocabulary()
    rows, areas = features[0], np.random.default_rng(1).random(600)
    encoded = encode(rows, areas, vocabulary)
    assert np.isclose(np.linalg.norm(encoded), 1.0)
    order = np.random.default_rng(2).permutation(600)
    np.testing.assert_allclose(encode(rows[order], areas[order], vocabulary), encoded,
                               atol=1e-12)
    # Different shapes encode differently.
    assert np.linalg.norm(encode(features[3], areas, vocabulary) - encoded) > 0.1


def test_vlad_sees_a_small_region_that_word_counts_barely_notice() -> None:
    # 2 % of the points moved to an unusual place of their word: VLAD's per-word
    # normalisation lets that residual count; the bag of words moves far less.
    vocabulary, features = small_vocabulary()
    rows = features[0].copy()
    areas = np.full(600, 1.0 / 600)
    changed = rows.copy()
    changed[:12] += 1.5 * vocabulary.scale
    vlad = np.linalg.norm(encode_vlad(changed, areas, vocabulary)
                          - encode_vlad(rows, areas, vocabulary))
    bof = np.linalg.norm(encode_bof(changed, areas, vocabulary)
                         - encode_bof(rows, areas, vocabulary))
    assert vlad > 2 * bof


# Each shipped vocabulary and a layout that uses it: the default family's, and the bendable
# family's earlier one (kept to compare against).
WORDS_LAYOUTS = {"parts": DESCRIPTOR_FAMILIES["parts"], "bendable": BENDABLE_WORDS_DESCRIPTOR}


@pytest.mark.parametrize("family", sorted(WORDS_LAYOUTS))
def test_shipped_vocabularies_match_their_family(family: str) -> None:
    settings = WORDS_LAYOUTS[family]
    assert settings.family == family
    assert settings.local_weight > 0
    vocabulary = load_vocabulary(settings.local_vocabulary)
    spec = DescriptorSpec.from_settings(settings)
    signature = len(spec.grid.times) + (
        len(spec.grid.energies) if settings.local_columns == "hks+wks" else 0
    )
    assert vocabulary.width == signature + len(settings.local_neighbours)
    version = spec.version(EngineSettings(descriptor=settings))
    assert f"@{vocabulary.digest()[:6]}" in version
    assert family in version or family == "parts"


def test_a_changed_vocabulary_changes_the_version(tmp_path, monkeypatch) -> None:
    settings = DescriptorSettings()
    spec = DescriptorSpec.from_settings(settings)
    before = spec.version(EngineSettings())
    shipped = load_vocabulary(settings.local_vocabulary)
    refitted = replace(shipped, centres=shipped.centres * (1 + 1e-9))
    refitted.save(tmp_path / f"{settings.local_vocabulary}.npz")
    monkeypatch.setattr(local_module, "VOCABULARY_DIR", tmp_path)
    load_vocabulary.cache_clear()
    try:
        after = spec.version(EngineSettings())
    finally:
        load_vocabulary.cache_clear()
    assert after != before
    assert f"@{refitted.digest()[:6]}" in after


def test_unknown_vocabulary_is_refused() -> None:
    settings = replace(DescriptorSettings(), local_vocabulary="no-such-words")
    with pytest.raises(ValueError, match="no-such-words"):
        DescriptorSpec.from_settings(settings).version(EngineSettings(descriptor=settings))
