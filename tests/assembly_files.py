"""Assemblies made in code for the assembly tests: a GLB scene (part A placed three times,
part B once, a nested sub-assembly holding A once more), the same as a text glTF with its
buffers embedded, a 3MF package written by hand (its XML as the 3MF core specification
gives it), a STEP assembly through OpenCascade, and GLB bombs whose node graph is too large,
too deep or cyclic."""

from __future__ import annotations

import io
import json
import os
import struct
import tempfile
import zipfile
from typing import Any

import numpy as np
import trimesh
from trimesh.exchange.gltf import export_gltf
from trimesh.transformations import rotation_matrix, translation_matrix


def part_a() -> trimesh.Trimesh:
    """An L-shaped bracket, 40 x 30 x 25 (no symmetry to hide a rotation)."""
    foot = trimesh.creation.box(extents=(40.0, 30.0, 5.0))
    wall = trimesh.creation.box(extents=(5.0, 30.0, 20.0))
    wall.apply_translation((17.5, 0.0, 12.5))
    return trimesh.util.concatenate([foot, wall])


def part_b() -> trimesh.Trimesh:
    """A pin: a cylinder of radius 4, length 30."""
    return trimesh.creation.cylinder(radius=4.0, height=30.0, sections=32)


def assembly_scene(with_b: bool = True, a_outside: int = 3) -> trimesh.Scene:
    """A placed ``a_outside`` times at the top level, B once (``with_b``) and a nested
    sub-assembly ``sub`` holding A once more, rotated."""
    scene = trimesh.Scene()
    a = part_a()
    for number in range(a_outside):
        scene.add_geometry(a, geom_name="A", node_name=f"a{number}",
                           transform=translation_matrix([60.0 * number, 0.0, 0.0]))
    if with_b:
        scene.add_geometry(part_b(), geom_name="B", node_name="b0",
                           transform=translation_matrix([0.0, 60.0, 0.0]))
    scene.graph.update(frame_to="sub", frame_from=scene.graph.base_frame,
                       matrix=translation_matrix([0.0, 0.0, 100.0]))
    scene.add_geometry(a, geom_name="A", node_name="a_sub", parent_node_name="sub",
                       transform=rotation_matrix(0.7, [0.0, 0.0, 1.0]))
    return scene


def assembly_glb(with_b: bool = True, a_outside: int = 3) -> bytes:
    return bytes(assembly_scene(with_b, a_outside).export(file_type="glb"))


def assembly_gltf(with_b: bool = True, a_outside: int = 3) -> bytes:
    """The same assembly as a text ``.gltf``, its buffers embedded as data URIs."""
    return bytes(export_gltf(assembly_scene(with_b, a_outside), embed_buffers=True)[
        "model.gltf"])


def _mesh_object(number: int, mesh: trimesh.Trimesh) -> str:
    vertices = "".join(f'<vertex x="{x:.6f}" y="{y:.6f}" z="{z:.6f}"/>'
                       for x, y, z in mesh.vertices)
    triangles = "".join(f'<triangle v1="{p}" v2="{q}" v3="{r}"/>' for p, q, r in mesh.faces)
    return (f'<object id="{number}" type="model"><mesh><vertices>{vertices}</vertices>'
            f"<triangles>{triangles}</triangles></mesh></object>")


def assembly_3mf(a_count: int = 3, with_b: bool = True) -> bytes:
    """A 3MF package: part A as one object placed ``a_count`` times along x (build items
    with a transform, 3 x 4 column-major as the format has it), B once."""
    items = "".join(f'<item objectid="1" transform="1 0 0 0 1 0 0 0 1 {60 * n} 0 0"/>'
                    for n in range(a_count))
    if with_b:
        items += '<item objectid="2" transform="1 0 0 0 1 0 0 0 1 0 60 0"/>'
    model = ('<?xml version="1.0" encoding="UTF-8"?><model unit="millimeter" xmlns='
             '"http://schemas.microsoft.com/3dmanufacturing/core/2015/02"><resources>'
             f"{_mesh_object(1, part_a())}{_mesh_object(2, part_b())}</resources>"
             f"<build>{items}</build></model>")
    types = ('<?xml version="1.0" encoding="UTF-8"?><Types xmlns="http://schemas.openxmlformats'
             '.org/package/2006/content-types"><Default Extension="model" ContentType='
             '"application/vnd.ms-package.3dmanufacturing-3dmodel+xml"/></Types>')
    package = io.BytesIO()
    with zipfile.ZipFile(package, "w", zipfile.ZIP_DEFLATED) as archive:
        archive.writestr("[Content_Types].xml", types)
        archive.writestr("3D/3dmodel.model", model)
    return package.getvalue()


def rotated_a_stl() -> bytes:
    """Part A on its own, turned and moved: another frame, the same part."""
    mesh = part_a()
    mesh.apply_transform(rotation_matrix(1.1, [1.0, 2.0, 0.5]))
    mesh.apply_translation((7.0, -3.0, 11.0))
    return bytes(mesh.export(file_type="stl"))


def glb_of(document: dict[str, Any]) -> bytes:
    """A GLB holding ``document`` as its JSON chunk (and no binary chunk)."""
    body = json.dumps(document).encode()
    body += b" " * (-len(body) % 4)
    header = struct.pack("<4sII", b"glTF", 2, 12 + 8 + len(body))
    return header + struct.pack("<I4s", len(body), b"JSON") + body


def _bomb(nodes: list[dict[str, Any]], roots: list[int]) -> bytes:
    return glb_of({"asset": {"version": "2.0"}, "scene": 0, "scenes": [{"nodes": roots}],
                   "nodes": nodes, "meshes": [{"primitives": []}]})


def wide_bomb(count: int = 100_000) -> bytes:
    """``count`` nodes, each placing the mesh."""
    return _bomb([{"mesh": 0} for _ in range(count)], list(range(count)))


def deep_bomb(depth: int = 100_000) -> bytes:
    """A chain of ``depth`` nested nodes."""
    nodes: list[dict[str, Any]] = [{"children": [i + 1]} for i in range(depth - 1)]
    return _bomb([*nodes, {"mesh": 0}], [0])


def doubling_bomb(levels: int = 60) -> bytes:
    """Each node holds the next one twice: 2**levels placements from ``levels`` nodes."""
    nodes: list[dict[str, Any]] = [{"children": [i + 1, i + 1]} for i in range(levels)]
    return _bomb([*nodes, {"mesh": 0}], [0])


def cyclic_bomb() -> bytes:
    """Node 0 holds node 1, which holds node 0."""
    return _bomb([{"children": [1]}, {"children": [0], "mesh": 0}], [0])


def step_assembly(with_b: bool = True) -> bytes:
    """A STEP file (OpenCascade needed): a box A placed three times, a cylinder B once
    (``with_b``), and a sub-assembly compound holding A once more."""
    from OCP.BRep import BRep_Builder
    from OCP.BRepPrimAPI import BRepPrimAPI_MakeBox, BRepPrimAPI_MakeCylinder
    from OCP.gp import gp_Trsf, gp_Vec
    from OCP.STEPControl import STEPControl_AsIs, STEPControl_Writer
    from OCP.TopLoc import TopLoc_Location
    from OCP.TopoDS import TopoDS_Compound

    def moved(shape: Any, x: float, y: float, z: float) -> Any:
        transform = gp_Trsf()
        transform.SetTranslation(gp_Vec(x, y, z))
        return shape.Moved(TopLoc_Location(transform))

    a = BRepPrimAPI_MakeBox(40.0, 30.0, 5.0).Shape()
    b = BRepPrimAPI_MakeCylinder(4.0, 30.0).Shape()
    builder = BRep_Builder()
    top = TopoDS_Compound()
    builder.MakeCompound(top)
    for x in (0.0, 60.0, 120.0):
        builder.Add(top, moved(a, x, 0.0, 0.0))
    if with_b:
        builder.Add(top, moved(b, 0.0, 60.0, 0.0))
    sub = TopoDS_Compound()
    builder.MakeCompound(sub)
    builder.Add(sub, moved(a, 5.0, 5.0, 0.0))
    builder.Add(top, moved(sub, 0.0, 0.0, 100.0))
    writer = STEPControl_Writer()
    writer.Transfer(top, STEPControl_AsIs)
    handle, path = tempfile.mkstemp(suffix=".step")
    os.close(handle)
    try:
        writer.Write(path)
        with open(path, "rb") as file:
            return file.read()
    finally:
        os.unlink(path)


def translations(placements: list[list[float]]) -> list[list[float]]:
    """The translation of each 16-number placement, rounded."""
    return sorted(np.round(np.asarray(p).reshape(4, 4)[:3, 3], 6).tolist() for p in placements)
