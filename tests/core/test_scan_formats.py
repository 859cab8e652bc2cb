"""Scanner formats: E57, LAS, LAZ and PCD ``binary_compressed``, made in code from points
sampled on a part's mesh.

Each loads to the points it was written from, finds that part first through the API, and its
hostile variants (truncated, lying counts, compression bombs) are refused with the right
reason; those whose header gives them away are refused by ``check_header`` alone, which reads
no point data and decompresses nothing.
"""

from __future__ import annotations

import struct
from collections.abc import Callable, Iterator
from pathlib import Path

import lzf
import numpy as np
import pytest
from fastapi.testclient import TestClient

from app.api.main import create_app
from core.errors import InvalidShapeError
from core.io import EXPANDING_FORMATS, check_header, detect_format, load_points
from tests.conftest import PARTS, make_settings, upload, wait_for_status
from tests.hostile_files import scan_variants
from tests.scan_files import e57_file, las_file, pcd_compressed_file

PART = "angle_block.STL"
OTHERS = ["cylinder.stl", "20mm-xyz-cube.stl"]
PROBLEM = "application/problem+json"

# Writers of each format and the coordinate error they allow, relative to the part's size:
# E57 and PCD store float32, LAS/LAZ integers of 1e-6 units.
WRITERS: dict[str, tuple[Callable[[np.ndarray], bytes], float]] = {
    "e57": (e57_file, 1e-6),
    "las": (lambda points: las_file(points, compressed=False), 1e-6),
    "laz": (lambda points: las_file(points, compressed=True), 1e-6),
    "pcd": (pcd_compressed_file, 1e-6),
}
# Hostile variants that the header alone refuses, without reading any point.
REFUSED_BY_HEADER = {
    "e57-truncated", "e57-4e9-points", "las-truncated", "las-4e6-points-2e3-held",
    "laz-4e9-points", "pcd-lzf-truncated", "pcd-lzf-4gb-declared", "pcd-lzf-beyond-88x",
}
HOSTILE = scan_variants()


@pytest.fixture(scope="module")
def scan_points() -> np.ndarray:
    """3000 points sampled on the part's triangles (another count and seed than the
    service's own sampling of the mesh)."""
    return load_points(PARTS / PART, max_points=3000, seed=7).points


@pytest.mark.parametrize("fmt", list(WRITERS))
def test_a_scan_file_loads_to_the_points_it_holds(scan_points: np.ndarray, fmt: str) -> None:
    write, tolerance = WRITERS[fmt]
    data = write(scan_points)
    shape = load_points(data, filename=f"scan.{fmt}", max_points=5000)
    assert (shape.format, shape.kind, shape.n_input) == (fmt, "points", len(scan_points))
    scale = float(np.ptp(scan_points, axis=0).max())
    np.testing.assert_allclose(shape.points, scan_points, atol=tolerance * scale, rtol=0)
    # Without a name the first bytes tell the format.
    assert detect_format(None, data[:4096]) == fmt


def test_the_scan_formats_that_compress_points_are_parsed_in_a_sandbox() -> None:
    # E57 bit-packs and LAZ arithmetic-codes points: their size bounds nothing.
    assert {"e57", "laz"} <= set(EXPANDING_FORMATS)
    assert "las" not in EXPANDING_FORMATS and "pcd" not in EXPANDING_FORMATS


def test_e57_drops_invalid_points_and_applies_the_scan_pose(
    tmp_path: Path, scan_points: np.ndarray
) -> None:
    import pye57

    path = tmp_path / "posed.e57"
    invalid = np.zeros(len(scan_points), dtype=np.int8)
    invalid[:10] = 2  # the scanner's "no return" points: their coordinates mean nothing
    with pye57.E57(str(path), mode="w") as e57:
        e57.write_scan_raw(
            {"cartesianX": scan_points[:, 0], "cartesianY": scan_points[:, 1],
             "cartesianZ": scan_points[:, 2], "cartesianInvalidState": invalid},
            rotation=np.array([np.cos(np.pi / 4), 0.0, 0.0, np.sin(np.pi / 4)]),  # 90 deg, z
            translation=np.array([100.0, 0.0, 0.0]),
        )
    points = load_points(path).points
    x, y, z = scan_points[10:].T
    expected = np.column_stack([100.0 - y, x, z])
    np.testing.assert_allclose(points, expected, atol=1e-4)


@pytest.mark.parametrize("name", list(HOSTILE))
def test_a_hostile_scan_file_is_refused_with_its_reason(name: str) -> None:
    filename, make, _, reason = HOSTILE[name]
    data = make()
    fmt = detect_format(filename, data[:4096])
    if name in REFUSED_BY_HEADER:
        with pytest.raises(InvalidShapeError) as info:
            check_header(data, fmt)
        assert info.value.reason == reason, info.value.message
    with pytest.raises(InvalidShapeError) as info:
        load_points(data, filename=filename)
    assert info.value.reason == reason, info.value.message


def test_an_lzf_block_is_never_expanded_beyond_its_declared_size(
    monkeypatch: pytest.MonkeyPatch, scan_points: np.ndarray
) -> None:
    """The declared size is the decompressor's bound: a block that really expands further
    is refused, and no call asks for more than the header declared."""
    data = pcd_compressed_file(scan_points)
    start = data.index(b"binary_compressed\n") + len(b"binary_compressed\n")
    compressed, uncompressed = struct.unpack_from("<II", data, start)
    asked: list[int] = []
    decompress = lzf.decompress

    def bounded(block: bytes, max_length: int) -> bytes | None:
        asked.append(max_length)
        return decompress(block, max_length)

    monkeypatch.setattr(lzf, "decompress", bounded)
    assert len(load_points(data, filename="scan.pcd", max_points=5000).points) > 0
    # Two points fewer declared: the same block now expands beyond the declared size.
    fewer = len(scan_points) - 2
    lying = (
        data[:start].replace(b"POINTS 3000", b"POINTS %d" % fewer)
        .replace(b"WIDTH 3000", b"WIDTH %d" % fewer)
        + struct.pack("<II", compressed, fewer * 16) + data[start + 8 :]
    )
    with pytest.raises(InvalidShapeError, match="instead of the") as info:
        load_points(lying, filename="scan.pcd")
    assert info.value.reason == "unparsable"
    assert asked == [uncompressed, fewer * 16]


# --- through the API --------------------------------------------------------------------


@pytest.fixture(scope="module")
def client(tmp_path_factory: pytest.TempPathFactory) -> Iterator[TestClient]:
    """The real engine on SQLite, with the part and two different shapes described."""
    url = f"sqlite:///{tmp_path_factory.mktemp('scans') / 'shapesearch.db'}"
    app = create_app(make_settings(url, workers=2), embedded_worker=True)
    with TestClient(app, raise_server_exceptions=False) as client:
        ids = [upload(client, PARTS / name, external_id=name).json()["id"]
               for name in [PART, *OTHERS]]
        for model_id in ids:
            assert wait_for_status(client, model_id, timeout=300)["status"] == "ready"
        yield client


@pytest.mark.slow
@pytest.mark.parametrize("fmt", list(WRITERS))
def test_a_scan_file_finds_the_part_it_was_sampled_from(
    client: TestClient, scan_points: np.ndarray, fmt: str
) -> None:
    data = WRITERS[fmt][0](scan_points)
    response = client.post("/v1/search", params={"k": 3}, files={"file": (f"scan.{fmt}", data)})
    assert response.status_code == 200, response.text
    results = response.json()["results"]
    assert [r["model"]["external_id"] for r in results][0] == PART, results
    assert results[0]["score"] > results[1]["score"]


@pytest.mark.slow
@pytest.mark.parametrize("route", ["/v1/models", "/v1/search"])
@pytest.mark.parametrize("name", list(HOSTILE))
def test_a_hostile_scan_upload_is_a_problem(client: TestClient, route: str, name: str) -> None:
    filename, make, status, reason = HOSTILE[name]
    response = client.post(route, files={"file": (filename, make())})
    assert response.status_code == status, response.text
    assert response.headers["content-type"].startswith(PROBLEM)
    body = response.json()
    assert body["reason"] == reason and body["status"] == status
    assert body["type"] == f"urn:shapesearch:problem:{reason.replace('_', '-')}"
