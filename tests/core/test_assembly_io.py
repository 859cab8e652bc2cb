"""core.io._assembly: a scene's geometry nodes and a STEP file's solids become distinct parts
with their placements (instances merged, nesting flattened); bombs are refused from the
glTF JSON alone, fast."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh

from core.errors import InvalidShapeError
from core.io import load_points
from core.io._assembly import MAX_PARTS, check_gltf_graph, split_assembly, stl_bytes
from tests.assembly_files import (
    assembly_3mf,
    assembly_glb,
    assembly_gltf,
    cyclic_bomb,
    deep_bomb,
    doubling_bomb,
    part_a,
    step_assembly,
    translations,
    wide_bomb,
)


def test_a_glb_scene_splits_into_its_distinct_parts() -> None:
    parts = split_assembly(assembly_glb(), "asm.glb")
    assert sorted(p.count for p in parts) == [1, 4]
    a = next(p for p in parts if p.count == 4)
    # The nested instance's placement is the composed one (sub at z=100, rotated).
    assert translations([list(p) for p in a.placements]) == [
        [0.0, 0.0, 0.0], [0.0, 0.0, 100.0], [60.0, 0.0, 0.0], [120.0, 0.0, 0.0]]
    nested = next(np.asarray(p).reshape(4, 4) for p in a.placements if p[11] == 100.0)
    assert np.allclose(nested[:3, :3], trimesh.transformations.rotation_matrix(
        0.7, [0, 0, 1])[:3, :3])
    # Each part in its own frame: A's vertices are the bracket's.
    assert np.allclose(np.sort(a.vertices, axis=0), np.sort(part_a().vertices, axis=0))


def test_a_text_gltf_splits_as_its_glb_does() -> None:
    as_glb = split_assembly(assembly_glb(), "asm.glb")
    as_gltf = split_assembly(assembly_gltf(), "asm.gltf")
    assert sorted((p.count, p.digest) for p in as_gltf) == sorted(
        (p.count, p.digest) for p in as_glb)
    a = next(p for p in as_gltf if p.count == 4)
    assert translations([list(p) for p in a.placements]) == [
        [0.0, 0.0, 0.0], [0.0, 0.0, 100.0], [60.0, 0.0, 0.0], [120.0, 0.0, 0.0]]


def test_a_3mf_package_splits_into_its_objects_with_their_build_transforms() -> None:
    parts = split_assembly(assembly_3mf(a_count=3), "asm.3mf")
    assert sorted(p.count for p in parts) == [1, 3]
    a = next(p for p in parts if p.count == 3)
    assert translations([list(p) for p in a.placements]) == [
        [0.0, 0.0, 0.0], [60.0, 0.0, 0.0], [120.0, 0.0, 0.0]]
    b = next(p for p in parts if p.count == 1)
    assert translations([list(p) for p in b.placements]) == [[0.0, 60.0, 0.0]]
    # Read whole, it is one shape spanning every placement (three brackets 60 apart: 160
    # along x, more along the oriented box's longest side), not one part (40).
    whole = load_points(assembly_3mf(a_count=3), filename="asm.3mf", max_points=500)
    assert whole.size is not None and whole.size.length >= 160.0


def test_a_text_gltf_bomb_is_refused_from_its_json() -> None:
    text = doubling_bomb()[20:].rstrip()  # the GLB's JSON chunk, as a .gltf file
    with pytest.raises(InvalidShapeError) as caught:
        split_assembly(text, "bomb.gltf")
    assert caught.value.reason == "assembly_too_large"


def test_the_same_mesh_under_two_keys_is_one_part() -> None:
    scene = trimesh.Scene()
    scene.add_geometry(part_a(), geom_name="A1", node_name="n1")
    scene.add_geometry(part_a(), geom_name="A2", node_name="n2",
                       transform=trimesh.transformations.translation_matrix([50, 0, 0]))
    parts = split_assembly(bytes(scene.export(file_type="glb")), "twins.glb")
    assert [p.count for p in parts] == [2]


def test_a_part_file_reads_back_as_the_part() -> None:
    a = next(p for p in split_assembly(assembly_glb(), "asm.glb") if p.count == 4)
    loaded = load_points(stl_bytes(a.vertices, a.faces), filename="a.stl", max_points=500)
    assert loaded.kind == "mesh" and loaded.size is not None
    assert sorted(np.round([loaded.size.length, loaded.size.width, loaded.size.height])) == [
        25.0, 30.0, 40.0]


@pytest.mark.slow
@pytest.mark.parametrize("bomb", [wide_bomb, deep_bomb, doubling_bomb, cyclic_bomb])
def test_bombs_are_refused_from_the_json_fast(
    bomb: object, monkeypatch: pytest.MonkeyPatch
) -> None:
    # Refused from the JSON chunk alone: trimesh never builds the scene (how fast that is,
    # is bench's to measure, not a test's).
    def no_scene(*args: object, **kwargs: object) -> None:
        raise AssertionError("trimesh was asked to load a bomb")

    monkeypatch.setattr(trimesh, "load", no_scene)
    data = bomb()  # type: ignore[operator]
    with pytest.raises(InvalidShapeError) as caught:
        check_gltf_graph(data)
    assert caught.value.reason == "assembly_too_large"
    with pytest.raises(InvalidShapeError) as caught:
        split_assembly(data, "bomb.glb")
    assert caught.value.reason == "assembly_too_large"


def test_more_distinct_parts_than_the_limit_are_refused() -> None:
    scene = trimesh.Scene()
    for number in range(MAX_PARTS + 1):
        scene.add_geometry(trimesh.creation.box(extents=(1.0 + number * 0.01, 1.0, 1.0)),
                           geom_name=f"p{number}", node_name=f"n{number}")
    many = bytes(scene.export(file_type="glb"))
    with pytest.raises(InvalidShapeError) as caught:
        split_assembly(many, "many.glb")
    assert caught.value.reason == "assembly_too_large"
    assert len(split_assembly(many, "many.glb", max_parts=MAX_PARTS + 1)) == MAX_PARTS + 1
    with pytest.raises(InvalidShapeError, match="more than 1 distinct parts"):
        split_assembly(assembly_3mf(), "asm.3mf", max_parts=1)


@pytest.mark.slow
def test_a_step_assembly_splits_into_its_solids() -> None:
    pytest.importorskip("OCP.STEPControl", reason="OpenCascade (cadquery-ocp) is not installed")
    parts = split_assembly(step_assembly(), "asm.step")
    assert sorted(p.count for p in parts) == [1, 4]
    a = next(p for p in parts if p.count == 4)
    assert translations([list(p) for p in a.placements]) == [
        [0.0, 0.0, 0.0], [5.0, 5.0, 100.0], [60.0, 0.0, 0.0], [120.0, 0.0, 0.0]]
    assert np.allclose(a.vertices.min(axis=0), 0.0)
    assert np.allclose(a.vertices.max(axis=0), [40.0, 30.0, 5.0])
