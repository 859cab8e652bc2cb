"""core.placement: points on an assembly are labelled with the part they lie on, parts
placed by translations and rotations, each part's points given in its own frame."""

from __future__ import annotations

import numpy as np
import trimesh
from trimesh.transformations import rotation_matrix, translation_matrix

from core.placement import part_labels
from tests.assembly_files import part_a, part_b


def _sample(mesh: trimesh.Trimesh, count: int, seed: int) -> np.ndarray:
    return np.asarray(trimesh.sample.sample_surface(mesh, count, seed=seed)[0])


def _assembly() -> tuple[np.ndarray, np.ndarray, list[tuple[np.ndarray, np.ndarray]]]:
    """Bracket A at two placements (one turned), pin B at one; points on the whole with
    the truth of which part each lies on, and each part's own points and placements."""
    a_places = np.stack([translation_matrix([0, 0, 0]),
                         translation_matrix([60, 0, 0]) @ rotation_matrix(0.9, [0, 0, 1])])
    b_places = np.stack([translation_matrix([0, 60, 0]) @ rotation_matrix(0.5, [1, 0, 0])])
    whole, truth = [], []
    for label, (mesh, places) in enumerate(((part_a(), a_places), (part_b(), b_places))):
        for number, place in enumerate(places):
            placed = mesh.copy()
            placed.apply_transform(place)
            whole.append(_sample(placed, 700, seed=10 * label + number))
            truth.append(np.full(700, label))
    parts = [(_sample(part_a(), 1500, seed=99), a_places), (_sample(part_b(), 1500, seed=98),
                                                            b_places)]
    return np.concatenate(whole), np.concatenate(truth), parts


def test_each_point_gets_the_part_it_lies_on() -> None:
    points, truth, parts = _assembly()
    labels = part_labels(points, parts)
    assert np.mean(labels == truth) > 0.99
    # Moving the whole assembly together with the placements changes nothing.
    motion = translation_matrix([5, -7, 3]) @ rotation_matrix(1.2, [1, 2, 3])
    moved = points @ motion[:3, :3].T + motion[:3, 3]
    moved_parts = [(p, np.einsum("ij,pjk->pik", motion, places)) for p, places in parts]
    assert np.array_equal(part_labels(moved, moved_parts), labels)


def test_a_part_without_points_labels_nothing_and_far_points_none() -> None:
    points, truth, parts = _assembly()
    labels = part_labels(points, [parts[0], None])
    assert np.all(labels[truth == 0] == 0)
    assert np.all(labels[truth == 1] == -1)  # the pin is 60 away from every bracket
    assert np.all(part_labels(points, []) == -1)
    assert part_labels(np.empty((0, 3)), parts).shape == (0,)
