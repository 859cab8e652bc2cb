"""How long a valid file of each format takes to describe, by its size: the data behind the
describe's time limit (``SHAPESEARCH_DESCRIBE_TIMEOUT_SECONDS`` and its per-MB part).

Makes valid files of growing size in code (binary STL, OBJ and PLY meshes of subdivided
spheres, or with ``--shape cylinder`` of cylinders with ever more sides, as a turned part
exported at a fine tolerance is; XYZ point clouds; STEP assemblies of many drilled,
filleted blocks when the ``cad`` extra is installed), describes each with the worker's
production handler (in its sandbox, with scan views, as a job does), and prints the seconds
and the seconds per MB of each, then the largest seconds per MB of every format. Files the
API quick-checks (up to 16 MiB) also get that check's seconds, in-process (its sandbox's
start aside): the data behind ``SHAPESEARCH_UPLOAD_CHECK_TIMEOUT_SECONDS``. A limit
must stay above these on the slowest machine it runs on (these machines differ about 3x).

    .venv/bin/python -m bench.describe_by_size [--sizes-mb 1 4 16 64]
        [--formats stl obj ply xyz step] [--shape sphere|cylinder] [--service-limits]
"""

from __future__ import annotations

import argparse
import io
import os
import time

import numpy as np
import trimesh

from app.api.uploads import FULL_CHECK_MAX_BYTES
from app.ingest.describing import quick_check
from app.jobs.worker import describe_handler
from app.settings import Settings


def sphere_mesh(target_mb: float, text: bool) -> trimesh.Trimesh:
    """A subdivided icosphere whose file is about ``target_mb`` (binary STL: 50 bytes a
    face; text formats: about 60 bytes a face and vertex)."""
    bytes_per_face = 60.0 if text else 50.0
    faces = target_mb * 1e6 / bytes_per_face
    level = max(1, int(round(np.log(faces / 20) / np.log(4))))
    return trimesh.creation.icosphere(subdivisions=level)


def cylinder_mesh(target_mb: float, text: bool) -> trimesh.Trimesh:
    """A cylinder (radius 3, height 10) whose file is about ``target_mb``: four faces a
    side, its vertices on two circles (the hull's worst case: every one is cocircular)."""
    bytes_per_face = 60.0 if text else 50.0
    sides = max(8, int(target_mb * 1e6 / bytes_per_face / 4))
    return trimesh.creation.cylinder(3.0, 10.0, sections=sides)


def mesh_file(fmt: str, target_mb: float, shape: str = "sphere") -> bytes:
    maker = cylinder_mesh if shape == "cylinder" else sphere_mesh
    mesh = maker(target_mb, text=fmt == "obj")
    exported = mesh.export(file_type=fmt)
    return exported.encode() if isinstance(exported, str) else bytes(exported)


def xyz_file(target_mb: float) -> bytes:
    count = int(target_mb * 1e6 / 30)  # "x y z\n" at %.6f: about 30 bytes a point
    points = np.random.default_rng(0).normal(size=(count, 3))
    points /= np.linalg.norm(points, axis=1, keepdims=True)
    buffer = io.StringIO()
    np.savetxt(buffer, points, fmt="%.6f")
    return buffer.getvalue().encode()


def step_file(target_mb: float) -> bytes:
    """An assembly of drilled, filleted blocks on a grid (about 80 KB of STEP each)."""
    import tempfile

    from OCP.BRep import BRep_Builder
    from OCP.BRepAlgoAPI import BRepAlgoAPI_Cut
    from OCP.BRepBuilderAPI import BRepBuilderAPI_Transform
    from OCP.BRepFilletAPI import BRepFilletAPI_MakeFillet
    from OCP.BRepPrimAPI import BRepPrimAPI_MakeBox, BRepPrimAPI_MakeCylinder
    from OCP.gp import gp_Ax2, gp_Dir, gp_Pnt, gp_Trsf, gp_Vec
    from OCP.STEPControl import STEPControl_AsIs, STEPControl_Writer
    from OCP.TopAbs import TopAbs_EDGE
    from OCP.TopExp import TopExp_Explorer
    from OCP.TopoDS import TopoDS, TopoDS_Compound

    block = BRepPrimAPI_MakeBox(10.0, 8.0, 4.0).Shape()
    fillet = BRepFilletAPI_MakeFillet(block)
    explorer = TopExp_Explorer(block, TopAbs_EDGE)
    while explorer.More():
        fillet.Add(0.5, TopoDS.Edge(explorer.Current()))
        explorer.Next()
    part = fillet.Shape()
    for x, y in ((2.5, 2.0), (7.5, 2.0), (2.5, 6.0), (7.5, 6.0)):
        hole = BRepPrimAPI_MakeCylinder(gp_Ax2(gp_Pnt(x, y, -1), gp_Dir(0, 0, 1)), 1.0, 6.0)
        part = BRepAlgoAPI_Cut(part, hole.Shape()).Shape()
    count = max(1, int(target_mb * 1e6 / 80e3))
    side = int(np.ceil(np.sqrt(count)))
    compound = TopoDS_Compound()
    builder = BRep_Builder()
    builder.MakeCompound(compound)
    for i in range(count):
        move = gp_Trsf()
        move.SetTranslation(gp_Vec(12.0 * (i % side), 10.0 * (i // side), 0.0))
        builder.Add(compound, BRepBuilderAPI_Transform(part, move, True).Shape())
    writer = STEPControl_Writer()
    writer.Transfer(compound, STEPControl_AsIs)
    with tempfile.TemporaryDirectory() as folder:
        path = os.path.join(folder, "assembly.step")
        writer.Write(path)
        with open(path, "rb") as handle:
            return handle.read()


def make(fmt: str, target_mb: float, shape: str) -> bytes:
    if fmt == "xyz":
        return xyz_file(target_mb)
    if fmt == "step":
        return step_file(target_mb)
    return mesh_file(fmt, target_mb, shape)


def check_seconds(settings: Settings, content: bytes, fmt: str) -> str:
    """The upload's quick check of ``content``, timed in this process ("-" when the API
    leaves a file this large unchecked)."""
    if len(content) > FULL_CHECK_MAX_BYTES:
        return "    -  "
    started = time.perf_counter()
    try:
        quick_check(content, f"part.{fmt}", settings.upload_check_points, settings.min_points,
                    settings.sample_seed)
    except Exception as error:  # a refusal is a finding here too
        return f"refused ({type(error).__name__})"
    return f"{time.perf_counter() - started:5.2f} s"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes-mb", type=float, nargs="+", default=[1, 4, 16, 64])
    parser.add_argument("--formats", nargs="+", default=["stl", "obj", "ply", "xyz", "step"])
    parser.add_argument("--shape", choices=["sphere", "cylinder"], default="sphere",
                        help="what the meshes (STL, OBJ, PLY) are")
    parser.add_argument("--service-limits", action="store_true",
                        help="keep the service's time and memory limits: what a job would do")
    args = parser.parse_args()
    # The production handler with room to finish (what a valid file needs, not the limit),
    # or with the service's default limits (a refusal then is what a job would report).
    roomy = Settings(describe_timeout_seconds=3600, describe_timeout_base_seconds=3600,
                     describe_memory_bytes=8 * 1024**3)
    settings = Settings() if args.service_limits else roomy
    handle = describe_handler(settings)
    print(f"load {os.getloadavg()[0]:.1f}")
    slopes: dict[str, float] = {}
    for fmt in args.formats:
        for target in args.sizes_mb:
            content = make(fmt, target, args.shape)
            megabytes = len(content) / 1e6
            started = time.perf_counter()
            try:
                handle(content, f"part.{fmt}")
                outcome = "ok"
            except Exception as error:  # report and go on: a refusal is a finding here
                outcome = f"{type(error).__name__}: {str(error)[:80]}"
            seconds = time.perf_counter() - started
            slopes[fmt] = max(slopes.get(fmt, 0.0), seconds / megabytes)
            print(f"{fmt:5s} {megabytes:7.2f} MB  {seconds:7.2f} s  {seconds / megabytes:6.2f} s/MB"
                  f"  check {check_seconds(settings, content, fmt)}  {outcome}", flush=True)
    print("largest seconds per MB: " + ", ".join(f"{f} {s:.2f}" for f, s in slopes.items()))


if __name__ == "__main__":
    main()
