"""Tests of ``core.io``: formats, mesh sampling, thinning, and every refusal reason.

Files are written into ``tmp_path`` from known points so that what is loaded can be compared
with what was written; the real parts and the edge cases come from ``tests/fixtures/parts``.
"""

from __future__ import annotations

import io
from pathlib import Path

import numpy as np
import pytest
import trimesh

from core.errors import InvalidShapeError
from core.io import SUPPORTED_FORMATS, LoadedShape, detect_format, load_points, validate_points
from tests.hostile_files import obj_short_vertex

FIXTURES = Path(__file__).parents[1] / "fixtures" / "parts"
EDGE_CASES = FIXTURES / "edge_cases"
# Small sample counts keep the mesh tests fast; the defaults are exercised by the fixtures.
MAX = 2000

# What each edge case must do: a refusal reason, or None for "loads".
EDGE_CASE_OUTCOMES = {
    "busted.STL": None,
    "empty.stl": "empty_file",
    "nancolor.obj": None,
    "notenoughindices.obj": None,
    "ply_empty_header.ply": "empty_file",
    "stl_empty_bin.stl": "empty_file",
    "whitespace.off": None,
}


# --------------------------------------------------------------------------- helpers


def _cloud(n: int = 500, seed: int = 7) -> np.ndarray:
    """(n, 3) distinct random points in a box, a valid cloud."""
    return np.random.default_rng(seed).uniform(-1.0, 2.0, size=(n, 3))


def _rows(points: np.ndarray) -> np.ndarray:
    """Rows sorted lexicographically, to compare point sets regardless of order."""
    return points[np.lexsort(points.T[::-1])]


def _same_set(a: np.ndarray, b: np.ndarray, atol: float = 0.0) -> bool:
    return a.shape == b.shape and np.allclose(_rows(a), _rows(b), rtol=0.0, atol=atol)


def _text(points: np.ndarray, sep: str = " ", extra: int = 0) -> str:
    """One line per point, ``extra`` further columns, exact (repr) coordinates."""
    lines = []
    for row in points:
        values = [repr(float(v)) for v in row] + ["0.5"] * extra
        lines.append(sep.join(values))
    return "\n".join(lines) + "\n"


def _pcd(points: np.ndarray, binary: bool) -> bytes:
    """A PCD v0.7 file with float32 x y z, a uint32 rgb, and (binary) two padding fields."""
    n = len(points)
    fields = "x y z rgb _ _" if binary else "x y z rgb"
    sizes = "4 4 4 4 1 1" if binary else "4 4 4 4"
    types = "F F F U U U" if binary else "F F F U"
    counts = "1 1 1 1 1 1" if binary else "1 1 1 1"
    header = (
        "# .PCD v0.7 - Point Cloud Data file format\nVERSION 0.7\n"
        f"FIELDS {fields}\nSIZE {sizes}\nTYPE {types}\nCOUNT {counts}\n"
        f"WIDTH {n}\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS {n}\n"
        f"DATA {'binary' if binary else 'ascii'}\n"
    ).encode()
    if not binary:
        return header + "".join(f"{x!r} {y!r} {z!r} 255\n" for x, y, z in points.tolist()).encode()
    record = np.dtype(
        [("x", "<f4"), ("y", "<f4"), ("z", "<f4"), ("rgb", "<u4"), ("p", "u1"), ("q", "u1")]
    )
    data = np.zeros(n, dtype=record)
    data["x"], data["y"], data["z"] = points.T
    data["rgb"] = 0xFF00FF
    return header + data.tobytes()


def _sphere() -> trimesh.Trimesh:
    return trimesh.creation.icosphere(subdivisions=3)


def _write(tmp_path: Path, name: str, content: bytes | str) -> Path:
    path = tmp_path / name
    if isinstance(content, str):
        path.write_text(content)
    else:
        path.write_bytes(content)
    return path


def _reason(source, **kwargs) -> str:
    """Reason code of the refusal that loading ``source`` must raise."""
    with pytest.raises(InvalidShapeError) as info:
        load_points(source, **kwargs)
    assert info.value.message  # every refusal explains itself
    return info.value.reason


# --------------------------------------------------------------------------- point formats


def _xyz_with_normals(points):
    return _text(points, " ", extra=3)


def _txt_tabs_and_comments(points):
    return "# scanned part\n// exported by a scanner\n" + _text(points, "\t")


def _csv_with_header(points):
    return "x,y,z,r,g,b\n" + _text(points, ",", extra=3)


def _pts_with_count(points):
    return f"{len(points)}\n" + _text(points, " ", extra=4)


TEXT_WRITERS = {
    "xyz": _xyz_with_normals,
    "txt": _txt_tabs_and_comments,
    "csv": _csv_with_header,
    "pts": _pts_with_count,
}


@pytest.mark.parametrize("fmt", sorted(TEXT_WRITERS))
def test_text_formats_round_trip_exactly(tmp_path, fmt):
    points = _cloud()
    path = _write(tmp_path, f"scan.{fmt}", TEXT_WRITERS[fmt](points))
    shape = load_points(path)
    assert isinstance(shape, LoadedShape)
    assert (shape.format, shape.kind, shape.n_input) == (fmt, "points", len(points))
    assert shape.points.dtype == np.float64
    # Without thinning the rows keep the file's order.
    np.testing.assert_array_equal(shape.points, points)


@pytest.mark.parametrize("encoding", ["ascii", "binary"])
def test_ply_points_round_trip(tmp_path, encoding):
    points = _cloud()
    data = trimesh.PointCloud(points).export(file_type="ply", encoding=encoding)
    shape = load_points(_write(tmp_path, "cloud.ply", data))
    assert (shape.format, shape.kind, shape.n_input) == ("ply", "points", len(points))
    # trimesh writes float32 (and 8 decimals in ASCII).
    assert _same_set(shape.points, points, atol=1e-6)


@pytest.mark.parametrize("binary", [False, True])
def test_pcd_round_trip(tmp_path, binary):
    points = _cloud().astype(np.float32).astype(np.float64)
    shape = load_points(_write(tmp_path, "cloud.pcd", _pcd(points, binary)))
    assert (shape.format, shape.kind, shape.n_input) == ("pcd", "points", len(points))
    np.testing.assert_array_equal(shape.points, points)


def test_npy_round_trip_ignores_extra_columns(tmp_path):
    points = _cloud()
    path = tmp_path / "cloud.npy"
    np.save(path, np.hstack([points, np.ones((len(points), 2))]).astype(np.float64))
    shape = load_points(path)
    assert (shape.format, shape.kind) == ("npy", "points")
    np.testing.assert_array_equal(shape.points, points)


def test_npy_structured_xyz_fields(tmp_path):
    points = _cloud()
    records = np.zeros(len(points), dtype=[("x", "f8"), ("y", "f8"), ("z", "f8"), ("i", "u2")])
    records["x"], records["y"], records["z"] = points.T
    path = tmp_path / "cloud.npy"
    np.save(path, records)
    np.testing.assert_array_equal(load_points(path).points, points)


# --------------------------------------------------------------------------- mesh formats

MESH_EXPORTS = {
    "stl": {"file_type": "stl"},  # binary
    "stl-ascii": {"file_type": "stl_ascii"},
    "obj": {"file_type": "obj"},
    "off": {"file_type": "off"},
    "ply": {"file_type": "ply"},
    "glb": {"file_type": "glb"},
}


@pytest.mark.parametrize("variant", sorted(MESH_EXPORTS))
def test_meshes_are_sampled_on_their_surface(tmp_path, variant):
    sphere = _sphere()
    data = sphere.export(**MESH_EXPORTS[variant])
    fmt = variant.split("-")[0]
    shape = load_points(_write(tmp_path, f"ball.{fmt}", data), max_points=MAX)
    assert (shape.format, shape.kind) == (fmt, "mesh")
    assert shape.points.shape == (MAX, 3)
    radius = np.linalg.norm(shape.points, axis=1)
    # Flat triangles inscribed in the unit sphere: |p| <= 1 and close to it.
    assert radius.max() <= 1.0 + 1e-6
    assert radius.min() > 0.97
    # Spread over the whole surface, not a few triangles.
    assert np.all(np.abs(shape.points.mean(axis=0)) < 0.05)


def test_glb_scene_is_concatenated_with_transforms(tmp_path):
    scene = trimesh.Scene()
    scene.add_geometry(_sphere(), node_name="a")
    scene.add_geometry(
        _sphere(), node_name="b", transform=trimesh.transformations.translation_matrix([10, 0, 0])
    )
    shape = load_points(_write(tmp_path, "two.glb", scene.export(file_type="glb")), max_points=MAX)
    near_a = np.linalg.norm(shape.points, axis=1) <= 1.0 + 1e-6
    near_b = np.linalg.norm(shape.points - [10, 0, 0], axis=1) <= 1.0 + 1e-6
    assert np.all(near_a | near_b)
    assert 0.4 < near_a.mean() < 0.6  # equal areas get equal shares


def test_ply_with_faces_is_a_mesh_without_is_points(tmp_path):
    sphere = _sphere()
    mesh = load_points(_write(tmp_path, "m.ply", sphere.export(file_type="ply")), max_points=MAX)
    cloud = trimesh.PointCloud(sphere.vertices).export(file_type="ply")
    points = load_points(_write(tmp_path, "p.ply", cloud), max_points=MAX)
    assert mesh.kind == "mesh" and points.kind == "points"
    assert mesh.n_input == points.n_input == len(sphere.vertices)
    assert len(points.points) == len(sphere.vertices)


def test_mesh_sampling_is_reproducible_and_seeded(tmp_path):
    path = _write(tmp_path, "ball.stl", _sphere().export(file_type="stl"))
    first = load_points(path, max_points=MAX, seed=0).points
    again = load_points(path, max_points=MAX, seed=0).points
    other = load_points(path, max_points=MAX, seed=1).points
    np.testing.assert_array_equal(first, again)
    assert not np.array_equal(first, other)


def test_mesh_sampling_is_area_weighted(tmp_path):
    # Two squares side by side, the right one 9x the area of the left one.
    vertices = np.array(
        [[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [1, 0, 0], [4, 0, 0], [4, 3, 0], [1, 3, 0]],
        dtype=float,
    )
    faces = np.array([[0, 1, 2], [0, 2, 3], [4, 5, 6], [4, 6, 7]])
    data = trimesh.Trimesh(vertices, faces, process=False).export(file_type="off")
    points = load_points(_write(tmp_path, "squares.off", data), max_points=MAX).points
    assert abs(np.mean(points[:, 0] < 1.0) - 0.1) < 0.03


# --------------------------------------------------------------------------- sources, formats


def test_bytes_source_equals_path_source(tmp_path):
    path = _write(tmp_path, "ball.stl", _sphere().export(file_type="stl"))
    from_path = load_points(path, max_points=MAX)
    from_bytes = load_points(path.read_bytes(), filename="ball.stl", max_points=MAX)
    np.testing.assert_array_equal(from_path.points, from_bytes.points)
    assert (from_path.format, from_path.kind, from_path.n_input) == (
        from_bytes.format,
        from_bytes.kind,
        from_bytes.n_input,
    )


def test_uppercase_extension():
    assert detect_format("PART.STL", b"") == "stl"
    assert detect_format("scan.Xyz", b"") == "xyz"
    assert detect_format("a.b.PLY", b"") == "ply"
    shape = load_points((FIXTURES / "angle_block.STL").read_bytes(), filename="ANGLE.STL")
    assert shape.format == "stl"


def _magic_samples() -> dict[str, bytes]:
    buffer = io.BytesIO()
    np.save(buffer, _cloud())
    sphere = _sphere()
    return {
        "ply": sphere.export(file_type="ply"),
        "stl": sphere.export(file_type="stl_ascii").encode(),
        "npy": buffer.getvalue(),
        "glb": sphere.export(file_type="glb"),
        "pcd": _pcd(_cloud(), binary=True),
        "off": sphere.export(file_type="off").encode(),
        "xyz": _text(_cloud()).encode(),
    }


@pytest.mark.parametrize("fmt", sorted(_magic_samples()))
def test_format_from_magic_bytes_without_filename(fmt):
    data = _magic_samples()[fmt]
    assert detect_format(None, data[:512]) == fmt
    assert detect_format("upload.bin", data[:512]) == fmt
    shape = load_points(data, max_points=MAX)
    assert shape.format == fmt and len(shape.points) >= 100


def test_unknown_format_lists_the_supported_ones():
    with pytest.raises(InvalidShapeError) as info:
        detect_format("drawing.dwg", b"\x01\x02\x03 AC1032 binary")
    assert info.value.reason == "unknown_format"
    for fmt in SUPPORTED_FORMATS:
        assert f".{fmt}" in info.value.message
    assert _reason(b"\x01\x02garbage\xff" * 20, filename="part.docx") == "unknown_format"
    assert _reason(b"\x01\x02garbage\xff" * 20) == "unknown_format"


# --------------------------------------------------------------------------- thinning


def test_downsampling_gives_exactly_max_points_independent_of_row_order():
    points = _cloud(30000, seed=3)
    thinned = validate_points(points, max_points=MAX, seed=5)
    assert thinned.shape == (MAX, 3)
    # Every kept point is an input point, and no point is kept twice.
    assert len(np.unique(thinned, axis=0)) == MAX
    assert np.isin(thinned[:, 0], points[:, 0]).all()
    shuffled = points[np.random.default_rng(9).permutation(len(points))]
    assert _same_set(validate_points(shuffled, max_points=MAX, seed=5), thinned)


def test_downsampling_file_order_independent(tmp_path):
    points = _cloud(6000, seed=4)
    shuffled = points[np.random.default_rng(1).permutation(len(points))]
    a = load_points(_write(tmp_path, "a.xyz", _text(points)), max_points=1000)
    b = load_points(_write(tmp_path, "b.xyz", _text(shuffled)), max_points=1000)
    assert a.n_input == 6000 and len(a.points) == 1000
    assert _same_set(a.points, b.points)


def test_downsampling_is_even_over_the_surface():
    # A 1 x 1 plate, uniformly sampled, plus a corner 0.1 x 0.1 holding 3x as many points
    # again: first rows or a random subset would keep ~75 % of the points in that corner.
    rng = np.random.default_rng(2)
    plate = np.c_[rng.random((20000, 2)), np.zeros(20000)]
    corner = np.c_[0.1 * rng.random((60000, 2)), np.zeros(60000)]
    thinned = validate_points(np.vstack([corner, plate]), max_points=MAX)
    assert thinned.shape == (MAX, 3)
    in_corner = np.all(thinned[:, :2] < 0.1, axis=1).mean()
    assert in_corner < 0.03  # 1 % of the area
    quadrants = np.histogram2d(thinned[:, 0], thinned[:, 1], bins=2, range=[[0, 1], [0, 1]])[0]
    assert quadrants.min() > 0.8 * MAX / 4


def test_thinning_is_seeded():
    points = _cloud(8000, seed=11)
    a = validate_points(points, max_points=MAX, seed=0)
    assert np.array_equal(a, validate_points(points, max_points=MAX, seed=0))
    assert not _same_set(a, validate_points(points, max_points=MAX, seed=1))


def test_planar_cloud_is_valid():
    rng = np.random.default_rng(0)
    plate = np.c_[rng.random((300, 2)), np.full(300, 5.0)]
    assert validate_points(plate).shape == (300, 3)


def test_duplicates_are_merged():
    points = _cloud(200)
    noisy = points + 1e-13  # near-duplicates, far below 1e-9 of the diagonal
    merged = validate_points(np.vstack([points, points, noisy]))
    assert len(merged) == 200


# --------------------------------------------------------------------------- refusals


def test_empty_files(tmp_path):
    assert _reason(b"", filename="part.stl") == "empty_file"
    assert _reason(b"  \n\t\n", filename="part.xyz") == "empty_file"
    assert _reason(_write(tmp_path, "c.xyz", "# only a comment\n\n")) == "empty_file"
    with pytest.raises(InvalidShapeError, match="file is empty"):
        load_points(_write(tmp_path, "zero.obj", b""))


def test_nan_rows_are_refused_and_counted(tmp_path):
    points = _cloud(200)
    points[[3, 50], 1] = np.nan
    with pytest.raises(InvalidShapeError) as info:
        load_points(_write(tmp_path, "nan.xyz", _text(points)))
    assert info.value.reason == "non_finite"
    assert "2 of 200" in info.value.message and "point 4" in info.value.message
    points[3, 1] = np.inf
    with pytest.raises(InvalidShapeError) as info:
        validate_points(points)
    assert info.value.reason == "non_finite"


def test_overflowing_coordinates_are_refused():
    with pytest.raises(InvalidShapeError) as info:
        validate_points(_cloud(200) * 1e300)
    assert info.value.reason == "non_finite" and "rescale" in info.value.message


def test_nan_mesh_vertex_is_refused(tmp_path):
    obj = "v 0 0 0\nv 1 0 0\nv nan 1 0\nv 0 0 1\nf 1 2 3\nf 1 2 4\n"
    assert _reason(_write(tmp_path, "nan.obj", obj)) == "non_finite"


@pytest.mark.parametrize(
    ("name", "content"),
    [
        ("bad.xyz", "0 0 0\n1 2 3\n1 2 three\n"),
        ("binary.xyz", b"\x00\x01\x02 1 2 3\n"),
        ("words.csv", "this is not\na point file\n"),
        ("garbage.stl", b"\x07" * 200),
        ("garbage.ply", b"ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nend_header\n"),
        ("garbage.off", "not an off file at all"),
        ("garbage.glb", b"glTF" + b"\x00" * 40),
        ("garbage.obj", "hello world\nthis is text\n"),
        ("noheader.pcd", "1 2 3\n"),
        ("noxyz.pcd", "FIELDS a b c\nPOINTS 1\nDATA ascii\n1 2 3\n"),
    ],
)
def test_unparsable_files(tmp_path, name, content):
    assert _reason(_write(tmp_path, name, content)) == "unparsable"


def test_obj_vertex_lines_of_unequal_length_are_unparsable(tmp_path):
    # trimesh reads one two-number ``v`` line among many three-number ones as a two-column
    # vertex array; the area computation then failed with numpy's AxisError (found by fuzzing).
    with pytest.raises(InvalidShapeError) as info:
        load_points(_write(tmp_path, "short_vertex.obj", obj_short_vertex()))
    assert info.value.reason == "unparsable" and "three coordinates" in info.value.message


def test_truncated_binary_stl_is_unparsable(tmp_path):
    data = _sphere().export(file_type="stl")
    with pytest.raises(InvalidShapeError) as info:
        load_points(_write(tmp_path, "cut.stl", data[: len(data) // 2]))
    assert info.value.reason == "unparsable" and "truncated" in info.value.message


@pytest.mark.parametrize("name", ["part.stl", "part.xyz"])
def test_a_parser_out_of_memory_is_not_called_unreadable(tmp_path, monkeypatch, name):
    """Under the sandbox's limit a parser raises ``MemoryError``; it must reach the sandbox,
    which refuses the file as too large, not be reported as a corrupt file."""
    def out_of_memory(*args, **kwargs):
        raise MemoryError

    monkeypatch.setattr(trimesh, "load_scene", out_of_memory)
    monkeypatch.setattr(np, "loadtxt", out_of_memory)
    path = _write(tmp_path, name, _sphere().export(file_type="stl") if name.endswith("stl")
                  else "0 0 0\n1 0 0\n0 1 0\n0 0 1\n")
    with pytest.raises(MemoryError):
        load_points(path)


def test_truncated_binary_pcd_and_packed_records_called_compressed(tmp_path):
    data = _pcd(_cloud(), binary=True)
    assert _reason(_write(tmp_path, "cut.pcd", data[:-100])) == "unparsable"
    # Packed records under 'DATA binary_compressed': their first bytes are no LZF sizes.
    # (Real binary_compressed files: tests/test_scan_formats.py.)
    compressed = data.replace(b"DATA binary", b"DATA binary_compressed")
    with pytest.raises(InvalidShapeError, match="uncompressed") as info:
        load_points(_write(tmp_path, "z.pcd", compressed))
    assert info.value.reason == "unparsable"


def test_npy_never_unpickles(tmp_path):
    path = tmp_path / "objects.npy"
    np.save(path, np.array([{"x": 1}, None], dtype=object), allow_pickle=True)
    assert _reason(path) == "unparsable"
    np.save(path, np.zeros((10, 2)))
    assert _reason(path) == "unparsable"


def test_one_point_and_few_distinct_points(tmp_path):
    assert _reason(_write(tmp_path, "one.xyz", "1 2 3\n")) == "too_few_points"
    many_repeats = np.repeat(_cloud(50), 20, axis=0)
    with pytest.raises(InvalidShapeError) as info:
        validate_points(many_repeats)
    assert info.value.reason == "too_few_points" and "50 distinct" in info.value.message
    with pytest.raises(InvalidShapeError) as info:
        validate_points(np.zeros((500, 3)))  # zero extent
    assert info.value.reason == "too_few_points"
    with pytest.raises(InvalidShapeError) as info:
        validate_points(np.zeros((1, 3)), min_points=1)
    assert info.value.reason == "degenerate"


def test_points_on_a_line_are_degenerate(tmp_path):
    line = np.linspace(0, 1, 300)[:, None] * np.array([1.0, 2.0, 3.0]) + 5.0
    assert _reason(_write(tmp_path, "line.xyz", _text(line))) == "degenerate"
    with pytest.raises(InvalidShapeError) as info:
        validate_points(line + 1e-9 * np.random.default_rng(0).random(line.shape))
    assert info.value.reason == "degenerate"


def test_zero_area_mesh_falls_back_to_vertices_or_is_degenerate(tmp_path):
    # Every triangle collapsed onto a line, but the vertices span a plane: use the vertices.
    grid = np.array([[x, y, 0.0] for x in range(15) for y in range(15)])
    faces = np.array([[i, i, i + 1] for i in range(len(grid) - 1)])
    lines = [f"v {x} {y} {z}" for x, y, z in grid] + [
        f"f {a + 1} {b + 1} {c + 1}" for a, b, c in faces
    ]
    shape = load_points(_write(tmp_path, "flat.obj", "\n".join(lines)), max_points=MAX)
    assert shape.kind == "mesh" and _same_set(shape.points, grid)
    tiny = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 1 2\nf 2 2 3\n"
    assert _reason(_write(tmp_path, "tiny.obj", tiny)) == "degenerate"


def test_too_large_is_refused_from_headers(tmp_path):
    header = io.BytesIO()
    np.lib.format.write_array_header_1_0(
        header, {"descr": "<f8", "fortran_order": False, "shape": (6_000_000, 3)}
    )
    assert _reason(_write(tmp_path, "huge.npy", header.getvalue())) == "too_large"
    pcd = b"FIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nPOINTS 6000000\nDATA binary\n"
    assert _reason(_write(tmp_path, "huge.pcd", pcd)) == "too_large"
    ply = b"ply\nformat binary_little_endian 1.0\nelement vertex 9000000\nend_header\n"
    assert _reason(_write(tmp_path, "huge.ply", ply)) == "too_large"


def test_validate_points_refuses_wrong_shapes():
    with pytest.raises(InvalidShapeError) as info:
        validate_points(np.zeros((10, 2)))
    assert info.value.reason == "unparsable"


# --------------------------------------------------------------------------- real files


def _fixture_files() -> list[Path]:
    files = [p for p in FIXTURES.iterdir() if p.is_file() and p.suffix.lower() != ".md"]
    return sorted(files) + sorted(EDGE_CASES.iterdir())


@pytest.mark.parametrize("path", _fixture_files(), ids=lambda p: p.name)
def test_every_fixture_loads_or_is_refused_cleanly(path):
    try:
        shape = load_points(path)
    except InvalidShapeError as exc:
        assert exc.reason in InvalidShapeError.REASONS and exc.message
        return
    assert shape.points.ndim == 2 and shape.points.shape[1] == 3
    assert 100 <= len(shape.points) <= 20000
    assert np.isfinite(shape.points).all()
    assert shape.format in SUPPORTED_FORMATS and shape.kind in ("mesh", "points")


def test_edge_cases_do_what_the_readme_says():
    assert sorted(EDGE_CASE_OUTCOMES) == sorted(p.name for p in EDGE_CASES.iterdir())
    for name, expected in EDGE_CASE_OUTCOMES.items():
        path = EDGE_CASES / name
        if expected is None:
            shape = load_points(path, max_points=MAX)
            assert shape.kind == "mesh" and shape.points.shape == (MAX, 3), name
        else:
            assert _reason(path) == expected, name


def test_point_only_ply_fixtures_are_too_small():
    for name in ("points_ascii.ply", "points_bin.ply"):
        assert _reason(FIXTURES / name) == "too_few_points"
        # With a lower bar they load, as the five points of the file.
        shape = load_points(FIXTURES / name, min_points=5)
        assert shape.kind == "points" and shape.points.shape == (5, 3)


def test_a_cloud_below_the_default_budget_keeps_every_point(tmp_path):
    from core.settings import EngineSettings

    budget = EngineSettings().max_points
    small = _cloud(budget - 1, seed=11)
    kept = load_points(_write(tmp_path, "small.xyz", _text(small)), max_points=budget)
    assert _same_set(kept.points, small)  # nothing thinned, nothing added
    large = _cloud(budget + 500, seed=12)
    thinned = load_points(_write(tmp_path, "large.xyz", _text(large)), max_points=budget)
    assert len(thinned.points) == budget
