"""Cheap structural checks that run before any geometry is built, for files of every size.

A file's header often says how big its geometry will be: a binary STL's triangle count, a
PLY's vertex count, a GLB's node graph and accessor counts, a PCD's point count and
compressed sizes, a LAS/LAZ header's point count, an E57's record counts. Checking those
numbers against the file size and the limits refuses a bomb in milliseconds, before a parser
allocates anything in proportion to what the file *claims* (a 186 KB GLB can instance one mesh
thousands of times; a 60 MB STL can declare 3.2 billion triangles).

    check_header(data, fmt)     raises InvalidShapeError (too_large, unparsable, empty_file)
    glb_scene_size(data)        (instances, vertices) of a glTF scene once expanded
"""

from __future__ import annotations

import json
import struct
from typing import Any

from core.errors import InvalidShapeError
from core.io._e57 import check_e57_header
from core.io._las import check_las_header
from core.io._meshes import check_ply_header, check_stl_header
from core.io._pcd import check_pcd_header
from core.io._validate import MAX_PARSED_POINTS

__all__ = ["MAX_SCENE_INSTANCES", "check_header", "glb_scene_size", "gltf_document"]

#: Most mesh instances (node visits) a GLB scene may expand to.
MAX_SCENE_INSTANCES = 10_000

_GLB_HEADER = struct.Struct("<4sII")  # magic, version, total length
_GLB_CHUNK = struct.Struct("<I4s")  # chunk length, chunk type


def _unparsable_glb(detail: str) -> InvalidShapeError:
    return InvalidShapeError(
        "unparsable",
        f"could not read this glTF file ({detail}): check that it is a complete, valid "
        ".glb or .gltf file (a .gltf with its buffers embedded), or export the part again",
    )


def gltf_document(data: bytes) -> dict[str, Any]:
    """The scene description of a glTF file, parsed: a GLB's JSON chunk, or the whole of a
    text ``.gltf``."""
    if data[:4] == b"glTF":
        if len(data) < _GLB_HEADER.size + _GLB_CHUNK.size:
            raise _unparsable_glb("shorter than a GLB header")
        length, kind = _GLB_CHUNK.unpack_from(data, _GLB_HEADER.size)
        start = _GLB_HEADER.size + _GLB_CHUNK.size
        if kind != b"JSON" or start + length > len(data):
            raise _unparsable_glb("the first chunk is not a complete JSON chunk")
        text = data[start : start + length]
    else:
        text = data
    try:
        document = json.loads(text)
    except (ValueError, RecursionError) as error:
        raise _unparsable_glb("its JSON is not valid JSON") from error
    if not isinstance(document, dict):
        raise _unparsable_glb("its JSON is not an object")
    return document


def _mesh_vertices(document: dict[str, Any]) -> list[int]:
    """Vertices of each mesh: the POSITION accessor counts of its primitives."""
    accessors = document.get("accessors", [])
    counts = []
    for mesh in document.get("meshes", []):
        total = 0
        for primitive in mesh.get("primitives", []):
            position = primitive.get("attributes", {}).get("POSITION")
            if isinstance(position, int) and 0 <= position < len(accessors):
                total += max(0, int(accessors[position].get("count", 0)))
        counts.append(total)
    return counts


def _roots(document: dict[str, Any], node_count: int) -> list[int]:
    """The nodes of the default scene, or every node that is nobody's child."""
    scenes = document.get("scenes") or []
    if scenes:
        index = document.get("scene", 0)
        scene = scenes[index] if isinstance(index, int) and 0 <= index < len(scenes) else {}
        return [int(n) for n in scene.get("nodes", [])]
    children = {int(c) for node in document.get("nodes", []) for c in node.get("children", [])}
    return [n for n in range(node_count) if n not in children]


def _expanded(document: dict[str, Any]) -> tuple[int, int]:
    """(instances, vertices) of the scene with every node instanced where it is referenced.

    Iterative post-order over the node graph with one memo per node, so a shared subtree is
    counted (not walked) once per reference and a cycle is refused.
    """
    nodes = document.get("nodes", [])
    vertices_of_mesh = _mesh_vertices(document)
    if not nodes:
        return len(vertices_of_mesh), sum(vertices_of_mesh)
    done: dict[int, tuple[int, int]] = {}
    open_nodes: set[int] = set()
    for root in _roots(document, len(nodes)):
        stack = [(root, False)]
        while stack:
            node, children_done = stack.pop()
            if node in done:
                continue
            if not 0 <= node < len(nodes):
                raise _unparsable_glb(f"node {node} does not exist")
            children = [int(c) for c in nodes[node].get("children", [])]
            if not children_done:
                if node in open_nodes:
                    raise _unparsable_glb("its node graph has a cycle")
                open_nodes.add(node)
                stack.append((node, True))
                stack.extend((child, False) for child in children if child not in done)
                continue
            open_nodes.discard(node)
            mesh = nodes[node].get("mesh")
            has_mesh = isinstance(mesh, int) and 0 <= mesh < len(vertices_of_mesh)
            instances = int(has_mesh) + sum(done[c][0] for c in children)
            vertices = (vertices_of_mesh[mesh] if has_mesh else 0) + sum(
                done[c][1] for c in children
            )
            done[node] = (instances, vertices)
    roots = _roots(document, len(nodes))
    return sum(done[r][0] for r in roots), sum(done[r][1] for r in roots)


def glb_scene_size(data: bytes) -> tuple[int, int]:
    """Mesh instances and vertices of a GLB's scene once expanded, read from its JSON only.

    Returns
    -------
    (instances, vertices) : (int, int)
    """
    document = gltf_document(data)
    try:
        return _expanded(document)
    except InvalidShapeError:
        raise
    except (TypeError, ValueError, AttributeError, KeyError) as error:
        raise _unparsable_glb(f"its scene description is malformed: {error}") from error


def _check_glb(data: bytes) -> None:
    instances, vertices = glb_scene_size(data)
    if instances > MAX_SCENE_INSTANCES:
        raise InvalidShapeError(
            "too_large",
            f"the GLB scene instances meshes {instances:,} times, more than the "
            f"{MAX_SCENE_INSTANCES:,} accepted: merge the instances or export fewer parts",
        )
    if vertices > MAX_PARSED_POINTS:
        raise InvalidShapeError(
            "too_large",
            f"the GLB scene expands to {vertices:,} vertices, more than the "
            f"{MAX_PARSED_POINTS:,} accepted: simplify the meshes or export fewer instances",
        )


def check_header(data: bytes, fmt: str) -> None:
    """Refuse a file whose header promises more than it holds or than we accept.

    Parameters
    ----------
    data : bytes
        The whole file (only headers are read).
    fmt : str
        The detected format; formats without a cheap header check pass.

    Raises
    ------
    InvalidShapeError
        ``too_large``, ``unparsable`` or ``empty_file``.
    """
    if fmt == "stl":
        check_stl_header(data)
    elif fmt == "ply":
        check_ply_header(data)
    elif fmt in ("glb", "gltf"):
        _check_glb(data)
    elif fmt == "pcd":
        check_pcd_header(data)
    elif fmt in ("las", "laz"):
        check_las_header(data, fmt)
    elif fmt == "e57":
        check_e57_header(data)
