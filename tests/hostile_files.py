"""Hostile shape files, made in code (no committed blobs), shared by tests and bench.

``glb_instancing_bomb(instances)``
    A small GLB whose scene instances one mesh (an icosphere of 2,562 vertices) ``instances``
    times: 3,000 instances make a 0.2 MB file that expands to 7.7 million vertices, 20,000
    a 1.4 MB file that expands to 51 million.
``stl_triangle_bomb(size)``
    A binary STL of ``size`` bytes (60 MB by default) whose header declares 3.2 billion
    triangles: 160 GB of records it does not have.
``ply_vertex_bomb()``
    A tiny binary PLY whose header declares 10^9 vertices.
"""

from __future__ import annotations

import json
import struct

import numpy as np
import trimesh

__all__ = ["HOSTILE_FILES", "glb_instancing_bomb", "ply_vertex_bomb", "stl_triangle_bomb"]


def _pad(chunk: bytes, fill: bytes) -> bytes:
    return chunk + fill * (-len(chunk) % 4)


def glb_instancing_bomb(instances: int) -> bytes:
    """A GLB: one icosphere mesh, ``instances`` nodes that each place it (a flat scene)."""
    sphere = trimesh.creation.icosphere(subdivisions=4)
    vertices = np.asarray(sphere.vertices, np.float32)
    faces = np.asarray(sphere.faces, np.uint32)
    binary = _pad(vertices.tobytes() + faces.tobytes(), b"\x00")
    document = {
        "asset": {"version": "2.0"},
        "buffers": [{"byteLength": len(binary)}],
        "bufferViews": [
            {"buffer": 0, "byteOffset": 0, "byteLength": vertices.nbytes},
            {"buffer": 0, "byteOffset": vertices.nbytes, "byteLength": faces.nbytes},
        ],
        "accessors": [
            {
                "bufferView": 0, "componentType": 5126, "count": len(vertices), "type": "VEC3",
                "min": vertices.min(axis=0).tolist(), "max": vertices.max(axis=0).tolist(),
            },
            {"bufferView": 1, "componentType": 5125, "count": faces.size, "type": "SCALAR"},
        ],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0}, "indices": 1}]}],
        "nodes": [{"mesh": 0, "translation": [3.0 * i, 0.0, 0.0]} for i in range(instances)],
        "scenes": [{"nodes": list(range(instances))}],
        "scene": 0,
    }
    text = _pad(json.dumps(document, separators=(",", ":")).encode(), b" ")
    chunks = struct.pack("<I4s", len(text), b"JSON") + text
    chunks += struct.pack("<I4s", len(binary), b"BIN\x00") + binary
    return struct.pack("<4sII", b"glTF", 2, 12 + len(chunks)) + chunks


def stl_triangle_bomb(size: int = 60 * 1024 * 1024, triangles: int = 3_200_000_000) -> bytes:
    """``size`` bytes of binary STL (random records) declaring ``triangles`` triangles."""
    header = b"hostile".ljust(80, b" ") + struct.pack("<I", triangles)
    body = np.random.default_rng(0).integers(0, 256, size - len(header), dtype=np.uint8)
    return header + body.tobytes()


def ply_vertex_bomb(vertices: int = 10**9) -> bytes:
    """A binary PLY declaring ``vertices`` vertices, followed by three of them."""
    header = (
        "ply\nformat binary_little_endian 1.0\n"
        f"element vertex {vertices}\nproperty float x\nproperty float y\nproperty float z\n"
        "end_header\n"
    ).encode()
    return header + np.eye(3, dtype=np.float32).tobytes()


#: name -> (file name, bytes maker, expected status, expected reason)
HOSTILE_FILES = {
    "glb-20000-instances": ("bomb.glb", lambda: glb_instancing_bomb(20_000), 413, "too_large"),
    "glb-3000-instances": ("bomb.glb", lambda: glb_instancing_bomb(3_000), 413, "too_large"),
    "stl-3.2e9-triangles": ("bomb.stl", stl_triangle_bomb, 422, "unparsable"),
    "ply-1e9-vertices": ("bomb.ply", ply_vertex_bomb, 413, "too_large"),
}
