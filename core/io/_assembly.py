"""Splitting an assembly into its parts: each distinct geometry once, with every placement.

    GLB / glTF / 3MF / OBJ (trimesh scene)   every graph node holding a mesh, at its world
                                             transform
    STEP / IGES (OpenCascade)         every solid, at its location

Nested sub-assemblies are flattened: a leaf geometry placed through several levels of the
node graph gets one placement per path, the composed transform. Instances of one geometry
(the same mesh key of the scene graph, or the same vertices and triangles) become one
``AssemblyPart`` with all their placements, not one part each.

A scene can promise far more than its bytes hold: a glTF node graph that reuses nodes
(a DAG) expands to exponentially many placements, and a cycle to infinitely many. For glTF
the node graph is read from its JSON and counted (``check_gltf_graph``) before trimesh
builds anything; any format is refused once it has more than ``MAX_INSTANCES`` placements
or ``max_parts`` distinct parts (``assembly_too_large``).
"""

from __future__ import annotations

import hashlib
import struct
from dataclasses import dataclass

import numpy as np
import trimesh

from core.errors import InvalidShapeError
from core.io._cad import _import_ocp, _read_shape, _tessellate
from core.io._formats import CAD_FORMATS, detect_format
from core.io._headers import gltf_document
from core.io._meshes import _load_scene

__all__ = [
    "MAX_DEPTH",
    "MAX_INSTANCES",
    "MAX_NODES",
    "MAX_PARTS",
    "AssemblyPart",
    "check_gltf_graph",
    "split_assembly",
    "stl_bytes",
]

#: Distinct parts an assembly may have, unless the caller says otherwise.
MAX_PARTS = 500
#: Placements (leaf instances, after flattening) an assembly may have.
MAX_INSTANCES = 10_000
#: Nodes a glTF file may declare.
MAX_NODES = 20_000
#: Levels of nesting of a glTF node graph.
MAX_DEPTH = 64


@dataclass(frozen=True)
class AssemblyPart:
    """One distinct geometry of an assembly.

    Attributes
    ----------
    name : str
        The geometry's (or node's, or solid's) name in the file.
    vertices : (v, 3) float64
        In the part's own frame.
    faces : (f, 3) int64
    placements : tuple of 16-tuples of float
        Each instance's 4x4 transform from the part's frame to the assembly's, row-major.
    digest : str
        sha256 of the vertices and triangles: equal geometry, equal digest.
    """

    name: str
    vertices: np.ndarray
    faces: np.ndarray
    placements: tuple[tuple[float, ...], ...]
    digest: str

    @property
    def count(self) -> int:
        return len(self.placements)


def too_large(detail: str) -> InvalidShapeError:
    return InvalidShapeError(
        "assembly_too_large",
        f"{detail}: split it into sub-assemblies, or upload it as one model (assembly=whole)",
    )


def _digest(vertices: np.ndarray, faces: np.ndarray) -> str:
    digest = hashlib.sha256(np.ascontiguousarray(vertices, "<f8").tobytes())
    digest.update(np.ascontiguousarray(faces, "<i8").tobytes())
    return digest.hexdigest()


def stl_bytes(vertices: np.ndarray, faces: np.ndarray) -> bytes:
    """A binary STL of the triangles (float32 coordinates, zero normals)."""
    record = np.dtype([("normal", "<f4", 3), ("corners", "<f4", (3, 3)), ("attribute", "<u2")])
    triangles = np.zeros(len(faces), dtype=record)
    triangles["corners"] = np.asarray(vertices, np.float64)[np.asarray(faces, np.int64)]
    header = b"shapesearch assembly part".ljust(80, b" ")
    return header + struct.pack("<I", len(faces)) + triangles.tobytes()


def check_gltf_graph(data: bytes) -> None:
    """Refuse a glTF file (GLB or text) whose node graph is too large, too deep, cyclic or
    expands to more than ``MAX_INSTANCES`` mesh placements, reading only its JSON: in time
    and memory linear in the declared nodes (at most ``MAX_NODES``)."""
    document = gltf_document(data)
    nodes = document.get("nodes") or []
    if not isinstance(nodes, list):
        return
    if len(nodes) > MAX_NODES:
        raise too_large(f"the file declares {len(nodes):,} nodes, more than {MAX_NODES:,}")
    children: list[list[int]] = []
    meshes: list[int] = []
    for node in nodes:
        node = node if isinstance(node, dict) else {}
        kids = node.get("children") or []
        kids = [k for k in kids if isinstance(k, int) and 0 <= k < len(nodes)] if isinstance(
            kids, list) else []
        children.append(kids)
        meshes.append(1 if isinstance(node.get("mesh"), int) else 0)
    scenes = document.get("scenes") or []
    roots: list[int] = []
    for scene in scenes if isinstance(scenes, list) else []:
        if isinstance(scene, dict) and isinstance(scene.get("nodes"), list):
            roots += [n for n in scene["nodes"] if isinstance(n, int) and 0 <= n < len(nodes)]
    if not roots:
        roots = list(range(len(nodes)))
    # Iterative depth-first walk: placements below each node (memoised, so a DAG costs its
    # edges, not its paths), a cycle found by a node met again on the current path.
    placements: list[int | None] = [None] * len(nodes)
    depth: list[int] = [0] * len(nodes)
    on_path = [False] * len(nodes)
    for root in roots:
        if placements[root] is not None:
            continue
        stack: list[tuple[int, int]] = [(root, 0)]
        on_path[root] = True
        while stack:
            node, next_child = stack[-1]
            if len(stack) > MAX_DEPTH:
                raise too_large(f"its node graph nests more than {MAX_DEPTH} levels deep")
            if next_child < len(children[node]):
                stack[-1] = (node, next_child + 1)
                child = children[node][next_child]
                if on_path[child]:
                    raise too_large("its node graph is cyclic (a node contains itself)")
                if placements[child] is None:
                    on_path[child] = True
                    stack.append((child, 0))
                continue
            total = meshes[node] + sum(placements[c] or 0 for c in children[node])
            deepest = 1 + max((depth[c] for c in children[node]), default=0)
            if total > MAX_INSTANCES:
                raise too_large(f"its node graph places more than {MAX_INSTANCES:,} meshes")
            if deepest > MAX_DEPTH:
                raise too_large(f"its node graph nests more than {MAX_DEPTH} levels deep")
            placements[node], depth[node] = total, deepest
            on_path[node] = False
            stack.pop()
    if sum(placements[r] or 0 for r in roots) > MAX_INSTANCES:
        raise too_large(f"its node graph places more than {MAX_INSTANCES:,} meshes")


def _placement(matrix: np.ndarray) -> tuple[float, ...]:
    return tuple(float(v) for v in np.asarray(matrix, np.float64).reshape(16))


def _group(found: list[tuple[str, str, np.ndarray, np.ndarray, np.ndarray]], max_parts: int
           ) -> list[AssemblyPart]:
    """Parts from ``(key, name, vertices, faces, placement)`` instances: one per key, and
    keys with the same geometry merged; in the order first met."""
    by_digest: dict[str, tuple[str, np.ndarray, np.ndarray, list[tuple[float, ...]]]] = {}
    digest_of: dict[str, str] = {}
    for key, name, vertices, faces, matrix in found:
        if key not in digest_of:
            digest_of[key] = key if key.startswith("sha256:") else _digest(vertices, faces)
        digest = digest_of[key]
        if digest not in by_digest:
            if len(by_digest) >= max_parts:
                raise too_large(f"it has more than {max_parts} distinct parts")
            by_digest[digest] = (name, vertices, faces, [])
        by_digest[digest][3].append(_placement(matrix))
    return [
        AssemblyPart(name, vertices, faces, tuple(placements), digest)
        for digest, (name, vertices, faces, placements) in by_digest.items()
    ]


def _scene_parts(data: bytes, fmt: str, max_parts: int) -> list[AssemblyPart]:
    if fmt in ("glb", "gltf"):
        check_gltf_graph(data)
    scene = _load_scene(data, fmt)
    nodes = scene.graph.nodes_geometry
    if len(nodes) > MAX_INSTANCES:
        raise too_large(f"it places {len(nodes):,} meshes, more than {MAX_INSTANCES:,}")
    found = []
    for node in nodes:
        matrix, key = scene.graph[node]
        geometry = scene.geometry.get(key)
        if not isinstance(geometry, trimesh.Trimesh) or not len(geometry.faces):
            continue
        vertices = np.asarray(geometry.vertices, np.float64)
        faces = np.asarray(geometry.faces, np.int64)
        found.append((str(key), str(key), vertices, faces, np.asarray(matrix)))
    return _group(found, max_parts)


def _cad_parts(data: bytes, fmt: str, max_parts: int) -> list[AssemblyPart]:
    try:
        ocp = _import_ocp()
        from OCP.TopAbs import TopAbs_SOLID
    except ImportError as error:
        from core.io._cad import CAD_HINT

        raise InvalidShapeError("cad_unavailable", CAD_HINT) from error
    shape = _read_shape(ocp, data, fmt)
    solids = []
    explorer = ocp.TopExp_Explorer(shape, TopAbs_SOLID)
    while explorer.More():
        solids.append(explorer.Current())
        explorer.Next()
        if len(solids) > MAX_INSTANCES:
            raise too_large(f"it holds more than {MAX_INSTANCES:,} solids")
    if not solids:
        solids = [shape]  # shells or faces only: the whole shape is the one part
    found = []
    for number, solid in enumerate(solids, 1):
        transform = solid.Location().Transformation()
        matrix = np.eye(4)
        for row in range(3):
            for column in range(4):
                matrix[row, column] = transform.Value(row + 1, column + 1)
        # The solid in its own frame: instances share one TShape, hence one tessellation.
        local = solid.Located(ocp.TopLoc_Location())
        geometry = _tessellate(ocp, local)
        # A writer may bake part of an instance's placement into its coordinates (a
        # translated copy of the solid): move each solid's lowest corner to the origin and
        # compare the geometry quantised to a millionth of its size.
        corner = geometry.vertices.min(axis=0)
        vertices = geometry.vertices - corner
        shift = np.eye(4)
        shift[:3, 3] = corner
        scale = float(np.ptp(vertices, axis=0).max()) or 1.0
        quantised = np.round(vertices / (scale * 1e-6)).astype(np.int64)
        found.append(("sha256:" + _digest(quantised, geometry.faces), f"solid-{number}", vertices,
                      geometry.faces, matrix @ shift))
    return _group(found, max_parts)


def split_assembly(data: bytes, filename: str, max_parts: int = MAX_PARTS
                   ) -> list[AssemblyPart]:
    """The distinct parts of an assembly file, each with its placements; at most
    ``max_parts`` of them.

    Raises
    ------
    InvalidShapeError
        ``assembly_too_large`` (see the module's limits), ``empty_file`` for a file without
        triangles, or any refusal of the format's reader.
    """
    fmt = detect_format(filename, data[:4096])
    if fmt in CAD_FORMATS:
        parts = _cad_parts(data, fmt, max_parts)
    else:
        parts = _scene_parts(data, fmt, max_parts)
    if not parts:
        raise InvalidShapeError(
            "empty_file", f"this .{fmt} file holds no triangulated parts to split"
        )
    return parts
