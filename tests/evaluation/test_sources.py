"""The tuning sources (``core.evaluation.sources``): what they hold, and that bending keeps
lengths (the bendable source must be near-isometric to test what it claims)."""

from __future__ import annotations

import hashlib
import shutil
from itertools import islice
from pathlib import Path

import numpy as np
import pytest

from core.evaluation.dataset import load_dataset
from core.evaluation.sources import write_sources
from core.evaluation.sources.bendable import (
    IDENTITIES,
    IDENTITY_KINDS,
    KINDS,
    bend_points,
    centre_line,
    identity_parts,
    parts,
)


def test_centre_line_keeps_its_length_however_it_is_bent() -> None:
    for curvature in (lambda s: 0 * s, lambda s: 0.03 + 0 * s, lambda s: 0.05 * np.sin(s / 9)):
        line = centre_line(100.0, curvature)
        assert np.linalg.norm(np.diff(line, axis=0), axis=1).sum() == pytest.approx(100.0)


def test_a_bend_moves_the_far_end_as_an_arc_does() -> None:
    # A quarter circle of radius R: the end lies at (R, 0, R) from the start.
    radius = 40.0
    length = np.pi / 2 * radius
    line = centre_line(length, lambda s: np.full_like(s, 1 / radius))
    np.testing.assert_allclose(line[-1], [radius, 0.0, radius], atol=1e-3)


def test_bending_keeps_distances_along_the_centre_line() -> None:
    z = np.linspace(0.0, 50.0, 200)
    straight = np.stack([np.zeros_like(z), np.zeros_like(z), z], axis=1)
    bent = bend_points(straight, 50.0, lambda s: np.full_like(s, 0.04))
    assert np.linalg.norm(np.diff(bent, axis=0), axis=1).sum() == pytest.approx(50.0, rel=1e-3)
    assert np.linalg.norm(bent[-1] - bent[0]) < 45.0  # it did bend


@pytest.mark.slow
@pytest.mark.parametrize("kind", KINDS)
def test_every_bendable_pose_keeps_its_area(kind: str) -> None:
    meshes = [mesh for _, _, mesh in parts((kind,))]
    assert len(meshes) == 8
    areas = np.array([mesh.area for mesh in meshes])
    # Poses differ by a bend and a +-5 % size jitter (area +-10 %); a bend adds <= 5 %.
    assert areas.max() / areas.min() < 1.2
    assert all(mesh.is_watertight for mesh in meshes)
    extents = np.array([sorted(mesh.extents) for mesh in meshes])
    assert np.ptp(extents, axis=0).max() > 0.2 * extents[0].max()  # the poses really differ


@pytest.mark.slow
def test_the_poses_source_holds_shapes_in_shared_poses() -> None:
    """FAUST's design: classes differ only in proportions, and every class takes the same
    poses, so the same pose of another class looks alike in space but not intrinsically."""
    meshes = {(label, name): mesh for label, name, mesh in identity_parts()}
    labels = {label for label, _ in meshes}
    assert len(labels) == len(IDENTITY_KINDS) * len(IDENTITIES)
    assert len(meshes) == 8 * len(labels)
    for label in labels:
        areas = np.array([meshes[label, f"pose{pose}"].area for pose in range(8)])
        assert areas.max() / areas.min() < 1.01  # no size jitter; a bend keeps the area
    for kind in IDENTITY_KINDS:
        short, long = (meshes[f"{kind}_x{factor:g}", "pose0"] for factor in (0.6, 1.6))
        # Straight, the longer shape is about 1.6 / 0.6 as long and as thick: other
        # proportions (a spring's wire adds a little to both ends).
        assert max(long.extents) / max(short.extents) > 2.4
        assert min(long.extents) == pytest.approx(min(short.extents), rel=0.02)
        # In the last pose every shape of the kind is bent well away from its axis.
        for factor in IDENTITIES:
            bent = meshes[f"{kind}_x{factor:g}", "pose7"]
            assert np.ptp(bent.vertices[:, 0]) > 0.2 * max(bent.extents)


@pytest.mark.slow
def test_sources_are_written_as_a_labelled_dataset_and_repeat(tmp_path: Path) -> None:
    first = write_sources(tmp_path / "a", ["bendable"], seed=3)
    write_sources(tmp_path / "b", ["bendable"], seed=3)
    assert first == {"bendable": dict.fromkeys(KINDS, 8)}
    dataset = load_dataset(tmp_path / "a" / "bendable")
    assert sorted(set(dataset.labels)) == sorted(KINDS)

    def digest(root: Path) -> str:
        files = sorted(root.rglob("*.ply"))
        return hashlib.sha256(b"".join(p.read_bytes() for p in files)).hexdigest()

    assert digest(tmp_path / "a") == digest(tmp_path / "b")


@pytest.mark.slow
def test_madcad_source_makes_every_kind() -> None:
    pytest.importorskip("madcad", reason="pymadcad (the tune extra) is not installed")
    from core.evaluation.sources.madcad_parts import KINDS as MADCAD
    from core.evaluation.sources.madcad_parts import parts as madcad_parts

    seen: dict[str, int] = {}
    for kind, _, mesh in madcad_parts(MADCAD):
        seen[kind] = seen.get(kind, 0) + 1
        assert len(mesh.faces) > 50 and mesh.area > 0
    assert seen == dict.fromkeys(MADCAD, 10)


def test_vslot_source_makes_every_kind_in_distinct_sizes() -> None:
    pytest.importorskip("bd_vslot", reason="bd-vslot (the tune extra) is not installed")
    from core.evaluation.sources.vslot_parts import KINDS as VSLOT
    from core.evaluation.sources.vslot_parts import parts as vslot_parts

    areas: dict[str, set[float]] = {}
    for kind, _, mesh in vslot_parts(VSLOT):
        assert mesh.is_watertight and mesh.area > 0
        areas.setdefault(kind, set()).add(round(mesh.area, 2))
    # Eight parts per kind, no two of one kind alike (625 and 688 bearings share their
    # envelope and differ by the bore, T-nuts by the hole: the area tells them apart).
    assert {kind: len(found) for kind, found in areas.items()} == dict.fromkeys(VSLOT, 8)


def test_bosl2_source_renders_closed_parts_of_distinct_sizes() -> None:
    pytest.importorskip("solid2", reason="solidpython2 (the tune extra, BOSL2) is not installed")
    if shutil.which("openscad") is None:
        pytest.skip("openscad (apt-get install openscad) is not installed")
    from core.evaluation.sources.bosl2_parts import KINDS as BOSL2
    from core.evaluation.sources.bosl2_parts import parts as bosl2_parts

    # The ball bearings take ~10 s each to render (their balls): every other kind, and the
    # first two sizes of each (the source renders lazily), which must differ.
    for kind in (kind for kind in BOSL2 if kind != "ball_bearing"):
        meshes = [mesh for _, _, mesh in islice(bosl2_parts((kind,)), 2)]
        assert all(mesh.is_watertight and len(mesh.faces) > 50 for mesh in meshes), kind
        assert meshes[0].area != meshes[1].area, kind


def test_freecad_source_builds_closed_parts_of_distinct_sizes() -> None:
    if shutil.which("freecadcmd") is None:
        pytest.skip("freecadcmd (apt-get install freecad) is not installed")
    from core.evaluation.sources.freecad_parts import KINDS as FREECAD
    from core.evaluation.sources.freecad_parts import parts as freecad_parts

    # The first two sizes of each kind (the source builds lazily): closed, and not alike.
    for kind in FREECAD:
        meshes = [mesh for _, _, mesh in islice(freecad_parts((kind,)), 2)]
        assert all(mesh.is_watertight and mesh.is_volume for mesh in meshes), kind
        assert not np.isclose(meshes[0].area, meshes[1].area, rtol=1e-3), kind


def test_cqparts_source_builds_closed_parts_of_distinct_sizes() -> None:
    if shutil.which("freecadcmd") is None:
        pytest.skip("freecadcmd (apt-get install freecad) is not installed")
    from core.evaluation.sources.cqparts_parts import KINDS as CQPARTS
    from core.evaluation.sources.cqparts_parts import parts as cqparts_parts
    from core.evaluation.sources.cqparts_parts import require_cqparts

    try:
        require_cqparts()
    except FileNotFoundError as missing:
        pytest.skip(str(missing))
    # The first two sizes of each kind (the source builds lazily): closed, and not alike.
    for kind in CQPARTS:
        meshes = [mesh for _, _, mesh in islice(cqparts_parts((kind,)), 2)]
        assert all(mesh.is_watertight and mesh.is_volume for mesh in meshes), kind
        assert not np.isclose(meshes[0].area, meshes[1].area, rtol=1e-3), kind
