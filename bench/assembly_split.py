"""Benchmark: a 50-part assembly uploaded with ``assembly=split`` against the same 50 parts
uploaded one by one, through one real ``shapesearch serve`` (embedded SQLite and worker,
default engine), in the same run.

The assembly is made in code: 50 distinct parts (boxes, cylinders and L-brackets of their
own proportions), 120 placements in all (some parts placed several times), one GLB.
Measured:

* ``split``: the POST of the assembly, which splits it in the sandbox and stores the
  assembly and its 50 part models in one transaction (the request's time);
* ``assembly to ready``: from that POST until the assembly and all its parts are ready;
* ``parts to ready``: the 50 parts' own files (binary STL, each in its own frame, as the
  split stores them) POSTed one after the other, until all are ready: the describe time
  the split cannot avoid.

Claim checked (issue 76): splitting and describing the assembly is bounded by its parts'
describe time: ``assembly to ready`` is about ``parts to ready`` plus one describe (the
assembly's whole shape), and ``split`` is small beside it.

Usage::

    .venv/bin/python -m bench.assembly_split [--parts 50]
"""

from __future__ import annotations

import argparse
import os
import tempfile
import time

import httpx
import numpy as np
import trimesh

from bench._common import shapesearch, wait_until
from core.io import split_assembly, stl_bytes


def _part(number: int) -> trimesh.Trimesh:
    """Part ``number``: a box, a cylinder or an L-bracket, of proportions its own."""
    rng = np.random.default_rng(number)
    size = rng.uniform(10.0, 60.0, size=3)
    if number % 3 == 0:
        return trimesh.creation.box(extents=size)
    if number % 3 == 1:
        return trimesh.creation.cylinder(radius=size[0] / 4, height=size[1], sections=48)
    foot = trimesh.creation.box(extents=(size[0], size[1], 3.0))
    wall = trimesh.creation.box(extents=(3.0, size[1], size[2]))
    wall.apply_translation((size[0] / 2 - 1.5, 0.0, size[2] / 2 + 1.5))
    return trimesh.util.concatenate([foot, wall])


def assembly(parts: int) -> bytes:
    """A GLB placing ``parts`` distinct parts, part ``i`` placed ``1 + i % 4`` times."""
    scene = trimesh.Scene()
    for number in range(parts):
        mesh = _part(number)
        for copy in range(1 + number % 4):
            place = trimesh.transformations.translation_matrix(
                [100.0 * number, 100.0 * copy, 0.0])
            scene.add_geometry(mesh, geom_name=f"p{number}", node_name=f"p{number}-{copy}",
                               transform=place)
    return bytes(scene.export(file_type="glb"))


def _all_ready(client: httpx.Client, ids: list[str]) -> bool:
    statuses = [client.get(f"/v1/models/{i}").json()["status"] for i in ids]
    if "failed" in statuses:
        raise RuntimeError("a model failed")
    return all(status == "ready" for status in statuses)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--parts", type=int, default=50)
    args = parser.parse_args()
    content = assembly(args.parts)
    part_files = [stl_bytes(p.vertices, p.faces) for p in split_assembly(content, "a.glb")]
    placements = sum(1 + n % 4 for n in range(args.parts))
    print(f"assembly: {args.parts} distinct parts, {placements} placements, "
          f"{len(content) / 1e6:.2f} MB GLB")
    load_before = os.getloadavg()
    with shapesearch(env={"SHAPESEARCH_DATA_DIR": tempfile.mkdtemp()}) as base, \
            httpx.Client(base_url=base, timeout=600) as client:
        start = time.perf_counter()
        posted = client.post("/v1/models", files={"file": ("assembly.glb", content)},
                             data={"assembly": "split"})
        split_seconds = time.perf_counter() - start
        assert posted.status_code == 202, posted.text
        assembly_id = posted.json()["id"]
        listed = client.get(f"/v1/models/{assembly_id}/parts").json()["parts"]
        assert len(listed) == args.parts, len(listed)
        ids = [assembly_id, *(part["model"]["id"] for part in listed)]
        wait_until(lambda: _all_ready(client, ids), 3600)
        assembly_seconds = time.perf_counter() - start

        start = time.perf_counter()
        alone = []
        for number, part in enumerate(part_files):
            answer = client.post("/v1/models", files={"file": (f"part-{number}.stl", part)})
            assert answer.status_code == 202, answer.text
            alone.append(answer.json()["id"])
        wait_until(lambda: _all_ready(client, alone), 3600)
        parts_seconds = time.perf_counter() - start
    load_after = os.getloadavg()
    print(f"split (the POST: sandboxed split, {args.parts + 1} models stored): "
          f"{split_seconds:.2f} s")
    print(f"assembly to ready (split + {args.parts} parts + the whole described): "
          f"{assembly_seconds:.1f} s")
    print(f"parts to ready ({args.parts} part files uploaded one by one): "
          f"{parts_seconds:.1f} s")
    print(f"ratio assembly / parts: {assembly_seconds / parts_seconds:.2f} "
          f"(one more describe, the whole assembly's, is {100 / args.parts:.0f} % of "
          f"{args.parts})")
    print(f"load average before {load_before[0]:.2f}, after {load_after[0]:.2f}; "
          f"{os.cpu_count()} cores")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
