"""Fasteners and bearings of the cqparts libraries (GPL-3.0), a third-party source.

The eleventh library, added after every setting had been chosen, to judge them. Its
kinds are the held-out set's weakest: screws that
differ by their head, hex and square nuts, ball and tapered roller bearings (no other
library here draws a tapered roller bearing). Another maker than every library before it:
``cqparts_fasteners`` draws heads, drives and nuts, ``cqparts_bearings`` the bearings as
assemblies of rings and rolling elements, eight sizes a kind:

- ``hex_bolt``, ``hex_nut``, ``square_nut``, ``wood_screw``: items of the Bolt Depot
  catalogue that ``cqparts_fasteners`` ships (a store's own table of sizes), eight spread
  over each kind's distinct sizes;
- ``socket_head_screw``, ``button_head_screw``, ``countersunk_screw`` (hexagon socket) and
  ``pan_head_screw`` (cross recess): ``MaleFastenerPart`` with the ``cheese``, ``dome``,
  ``countersunk`` and ``pan`` heads, the same eight diameters and lengths for every head, so
  that within a size only the head differs; head diameters and heights are the published
  nominal ones of ISO 4762, ISO 7380, ISO 10642 and ISO 7045;
- ``ball_bearing``, ``tapered_roller_bearing``: bore, outside diameter and width of eight
  standard bearings each (the 60, 62, 63 and 302, 320 series).

Threads are plain cylinders (``_simple``): 3000 points do not resolve a thread.

cqparts builds on CadQuery 1.x, which runs inside FreeCAD, so this source needs
``freecadcmd`` (``apt-get install freecad``) and the libraries in a folder of their own,
``SHAPESEARCH_CQPARTS_LIB`` (default ``/opt/cqparts``)::

    pip install --target /opt/cqparts --no-deps cadquery==1.2.5 'pyparsing<3' six tinydb \\
        jinja2 markupsafe requests idna urllib3 certifi charset-normalizer \\
        cqparts==0.2.1 cqparts-fasteners==0.1.0 cqparts-bearings==0.1.0

Not Python wheels of this project: the source is for bench runs, never for the service or
its tests.
"""

from __future__ import annotations

import json
import os
import tempfile
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import trimesh

from core.evaluation.sources._freecad import render, require_freecad

__all__ = ["KINDS", "parts", "require_cqparts"]

#: Nominal diameter and length (mm) of the machine screws, the same for every head.
_SCREW_SIZES = ((3, 12), (4, 20), (5, 16), (6, 30), (8, 25), (10, 50), (12, 40), (16, 60))
#: Head diameter and height per nominal diameter: ISO 4762 (socket head cap), ISO 7380
#: (button head), ISO 10642 (countersunk), ISO 7045 (pan head), nominal values.
_HEADS: dict[str, dict[int, tuple[float, float]]] = {
    "socket_head_screw": {3: (5.5, 3), 4: (7, 4), 5: (8.5, 5), 6: (10, 6), 8: (13, 8),
                          10: (16, 10), 12: (18, 12), 16: (24, 16)},
    "button_head_screw": {3: (5.7, 1.65), 4: (7.6, 2.2), 5: (9.5, 2.75), 6: (10.5, 3.3),
                          8: (14, 4.4), 10: (17.5, 5.5), 12: (21, 6.6), 16: (28, 8.8)},
    "countersunk_screw": {3: (6.72, 1.86), 4: (8.96, 2.48), 5: (11.2, 3.1), 6: (13.44, 3.72),
                          8: (17.92, 4.96), 10: (22.4, 6.2), 12: (26.88, 7.44),
                          16: (33.6, 8.8)},
    "pan_head_screw": {3: (5.6, 1.8), 4: (8, 2.4), 5: (9.5, 3), 6: (12, 3.6), 8: (16, 4.8),
                       10: (20, 6), 12: (24, 7.2), 16: (32, 9.6)},
}
#: Each machine screw kind's cqparts head and drive.
_HEAD_TYPES = {"socket_head_screw": "cheese", "button_head_screw": "dome",
               "countersunk_screw": "countersunk", "pan_head_screw": "pan"}
#: Hexagon socket width across flats per nominal diameter (ISO 4762; the button and
#: countersunk heads take the next smaller key, as their standards do).
_SOCKET = {3: 2.5, 4: 3, 5: 4, 6: 5, 8: 6, 10: 8, 12: 10, 16: 14}
_SMALLER_SOCKET = {3: 2, 4: 2.5, 5: 3, 6: 4, 8: 5, 10: 6, 12: 8, 16: 10}
#: (bore, outside diameter, width) of 6000, 6201, 6002, 6203, 6004, 6305, 6206, 6008.
_BALL_BEARINGS = ((10, 26, 8), (12, 32, 10), (15, 32, 9), (17, 40, 12), (20, 42, 12),
                  (25, 62, 17), (30, 62, 16), (40, 68, 15))
#: (bore, outside diameter, width) of 30202, 30203, 30204, 32004, 30205, 32005, 30206, 32006.
_TAPERED_BEARINGS = ((15, 35, 11.75), (17, 40, 13.25), (20, 47, 15.25), (20, 42, 15),
                     (25, 52, 16.25), (25, 47, 15), (30, 62, 17.25), (30, 55, 17))
#: Catalogue kind -> (file of ``cqparts_fasteners/catalogue``, cqparts class, units or None).
_CATALOGUE = {"hex_bolt": ("boltdepot-bolts.json", "Bolt", "metric"),
              "hex_nut": ("boltdepot-nuts.json", "HexNut", "metric"),
              "square_nut": ("boltdepot-nuts.json", "SquareNut", None),
              "wood_screw": ("boltdepot-woodscrews.json", "Screw", None)}
PER_KIND = 8

# Build the part, then every solid of it: a lone part as made, an assembly's parts where
# the assembly puts them.
_BUILD = """
import cqparts, Part
import cqparts_bearings.ball, cqparts_bearings.tapered_roller, cqparts_fasteners.male
from cqparts.params import ParametricObject
part = {make}
def solids(component):
    if isinstance(component, cqparts.Part):
        placed = component.world_obj if component.world_coords else component.local_obj
        return [placed.val().wrapped]
    return [s for child in component.components.values() for s in solids(child)]
found = solids(part)
shape = found[0] if len(found) == 1 else Part.makeCompound(found)
"""


def require_cqparts() -> Path:
    """The folder that holds CadQuery 1.x and the cqparts libraries.

    Raises
    ------
    FileNotFoundError
        They are not there: the message says how to install them.
    """
    folder = Path(os.environ.get("SHAPESEARCH_CQPARTS_LIB", "/opt/cqparts"))
    if not (folder / "cqparts_fasteners").is_dir():
        raise FileNotFoundError(
            f"cqparts is not in {folder}: install it there (core.evaluation.sources."
            "cqparts_parts' docstring) or set SHAPESEARCH_CQPARTS_LIB")
    return folder


def _simple_threads(params: Any) -> Any:
    """``params`` with every thread drawn as a plain cylinder."""
    if isinstance(params, dict):
        out = {key: _simple_threads(value) for key, value in params.items()}
        if out.get("class", {}).get("name", "").endswith("Thread"):
            out["params"]["_simple"] = True
        return out
    return params


def _catalogue_items(library: Path, kind: str) -> list[dict[str, Any]]:
    """``PER_KIND`` items of ``kind``'s catalogue, spread evenly over its distinct
    geometries in order of thread diameter, then length (or height)."""
    file, name, units = _CATALOGUE[kind]
    items = json.loads((library / "cqparts_fasteners" / "catalogue" / file).read_text())
    distinct: dict[str, dict[str, Any]] = {}
    for item in items["items"].values():
        if item["obj"]["class"]["name"] != name:
            continue
        if units is not None and item["criteria"].get("units") != units:
            continue
        obj = _simple_threads(item["obj"])
        geometry = {k: v for k, v in obj["params"].items() if k != "_render"}
        distinct.setdefault(json.dumps(geometry, sort_keys=True), obj)
    def size(obj: dict[str, Any]) -> tuple[float, float]:
        params = obj["params"]
        return (params["thread"]["params"]["diameter"],
                params.get("length", params.get("height", 0.0)))
    ordered = sorted(distinct.values(), key=lambda obj: (size(obj), json.dumps(obj)))
    step = (len(ordered) - 1) / (PER_KIND - 1)
    return [ordered[round(i * step)] for i in range(PER_KIND)]


def _machine_screw(kind: str, diameter: int, length: float) -> str:
    head_diameter, head_height = _HEADS[kind][diameter]
    head = (_HEAD_TYPES[kind], {"diameter": head_diameter, "height": head_height})
    if kind == "pan_head_screw":
        drive: tuple[str, dict[str, float]] = (
            "phillips", {"diameter": 0.5 * head_diameter, "depth": 0.6 * head_height})
    else:
        key = (_SOCKET if kind == "socket_head_screw" else _SMALLER_SOCKET)[diameter]
        drive = ("hex", {"width": key, "depth": 0.6 * head_height})
    thread = ("iso68", {"diameter": diameter, "pitch": 0.15 * diameter, "_simple": True})
    return ("cqparts_fasteners.male.MaleFastenerPart("
            f"head={head!r}, drive={drive!r}, thread={thread!r}, length={length})")


def _makers(library: Path) -> dict[str, list[str]]:
    """Kind -> one Python expression per size that makes its cqparts component."""
    makers = {kind: ["ParametricObject.deserialize(" + repr(obj) + ")"
                     for obj in _catalogue_items(library, kind)] for kind in _CATALOGUE}
    for kind in _HEADS:
        makers[kind] = [_machine_screw(kind, *size) for size in _SCREW_SIZES]
    makers["ball_bearing"] = [
        "cqparts_bearings.ball.BallBearing("
        f"inner_diam={d}, outer_diam={outer}, width={b})" for d, outer, b in _BALL_BEARINGS]
    makers["tapered_roller_bearing"] = [
        "cqparts_bearings.tapered_roller.TaperedRollerBearing("
        f"inner_diam={d}, outer_diam={outer}, height={t}, roller_height={0.6 * t})"
        for d, outer, t in _TAPERED_BEARINGS]
    return makers


#: Every kind this source makes (its class labels).
KINDS: tuple[str, ...] = ("hex_bolt", "socket_head_screw", "button_head_screw",
                          "countersunk_screw", "pan_head_screw", "wood_screw", "hex_nut",
                          "square_nut", "ball_bearing", "tapered_roller_bearing")


def parts(kinds: tuple[str, ...] = KINDS) -> Iterator[tuple[str, str, trimesh.Trimesh]]:
    """``(kind, name, mesh)`` of every part of ``kinds``, in a fixed order.

    Raises
    ------
    FileNotFoundError
        ``freecadcmd`` is not on the path, or the cqparts libraries are not installed.
    RuntimeError
        cqparts built no valid solid for a size (the message says why).
    """
    require_freecad()
    library = require_cqparts()
    makers = _makers(library)
    with tempfile.TemporaryDirectory(prefix="cqparts-") as folder:
        for kind in kinds:
            for index, make in enumerate(makers[kind]):
                yield kind, f"{kind}_{index:02d}", render(
                    _BUILD.format(make=make), Path(folder), paths=(library,))
