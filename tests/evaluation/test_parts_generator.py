"""The generated engineering-parts dev set: closed solids of the genus their parameters fix,
seeded, and laid out as ``shapesearch eval`` reads it."""

from __future__ import annotations

import numpy as np
import pytest

from core.evaluation.dataset import load_dataset
from core.evaluation.parts_generator import FAMILIES, generate_part, write_dataset


def _genus(mesh) -> int:
    # Closed orientable surface: chi = V - E + F = 2 - 2g (one body).
    return (2 - mesh.euler_number) // 2


def _thinness(mesh) -> float:
    """Wall thickness (about 2 V / A for a thin-walled solid) over the smallest extent."""
    return 2.0 * mesh.volume / mesh.area / float(np.min(mesh.extents))


@pytest.mark.parametrize("family", sorted(FAMILIES))
def test_every_family_is_a_closed_solid_of_the_expected_genus(family: str) -> None:
    for index in range(4):
        part = generate_part(family, index, seed=3)
        mesh = part.mesh
        assert mesh.is_watertight and mesh.is_volume, (family, index)
        assert mesh.body_count == 1, (family, index)
        assert mesh.volume > 0
        assert _genus(mesh) == part.genus, (family, index, part.params)


def test_holed_families_have_as_many_tunnels_as_drawn_holes() -> None:
    for index in range(3):
        flange = generate_part("flange", index)
        assert _genus(flange.mesh) == flange.params["bolts"] + 1  # bolt circle + bore
        plate = generate_part("plate", index)
        assert _genus(plate.mesh) == plate.params["rows"] * plate.params["cols"]
        gear = generate_part("gear", index)
        assert _genus(gear.mesh) == gear.params["holes"] + 1


def test_same_seed_same_part_and_splits_differ() -> None:
    first = generate_part("gear", 5, seed=7, split="tune")
    again = generate_part("gear", 5, seed=7, split="tune")
    np.testing.assert_array_equal(first.mesh.vertices, again.mesh.vertices)
    np.testing.assert_array_equal(first.mesh.faces, again.mesh.faces)
    assert first.params == again.params
    other_index = generate_part("gear", 6, seed=7, split="tune")
    other_split = generate_part("gear", 5, seed=7, split="test")
    other_seed = generate_part("gear", 5, seed=8, split="tune")
    for other in (other_index, other_split, other_seed):
        assert other.params != first.params


def test_parameters_vary_within_a_family() -> None:
    counts = {generate_part("flange", i).params["bolts"] for i in range(12)}
    assert len(counts) >= 3
    steps = {generate_part("shaft", i).params["steps"] for i in range(12)}
    assert len(steps) >= 2


def test_trivial_features_separate_the_families_they_should() -> None:
    def parts(family: str) -> list:
        return [generate_part(family, i).mesh for i in range(6)]

    # Genus alone: a nut has a bore, a bolt has none; an elbow is one tube, a tee two joined.
    assert {_genus(m) for m in parts("nut")} == {1}
    assert {_genus(m) for m in parts("bolt")} == {0}
    assert {_genus(m) for m in parts("pipe_elbow")} == {1}
    assert {_genus(m) for m in parts("pipe_tee")} == {2}
    # Wall thickness over the smallest extent: bent sheet is thinner than angle and channel
    # sections (a Z section is wider than it is thick in both flanges, so it may overlap).
    assert max(map(_thinness, parts("sheet_metal"))) < min(
        _thinness(m) for family in ("l_profile", "u_profile") for m in parts(family)
    )
    # Profiles are prisms: one long axis, at least twice the others.
    for mesh in parts("l_profile") + parts("u_profile"):
        extents = np.sort(mesh.extents)
        assert extents[2] >= 2 * extents[1]


def test_written_dataset_is_read_by_the_evaluator(tmp_path) -> None:
    written = write_dataset(tmp_path, per_family=2, seed=1, families=("nut", "pipe_tee"))
    assert len(written) == 2 * 2 * 2  # splits x families x parts
    for split in ("tune", "test"):
        dataset = load_dataset(tmp_path / split)
        assert sorted(set(dataset.labels)) == ["nut", "pipe_tee"]
        assert len(dataset.models) == 4
        assert not dataset.duplicates
    tune = {m.sha256 for m in load_dataset(tmp_path / "tune").models}
    test = {m.sha256 for m in load_dataset(tmp_path / "test").models}
    assert not tune & test
