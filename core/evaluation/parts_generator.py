"""A labelled dev set of engineering parts, made in code.

capod is household objects; the product searches engineering parts. This module builds
parametric part families with constructive solid geometry (manifold3d: exact, always
watertight booleans) and writes them in the ``DATASET_DIR/CLASS/MODEL_FILE`` layout that
``shapesearch eval`` reads::

    python -m core.evaluation.parts_generator OUT_DIR [--per-family 20] [--seed 0]

writes ``OUT_DIR/tune/<family>/<family>_NNN.ply`` and ``OUT_DIR/test/<family>/...``: two
disjoint splits of the same families (each part has its own seed, derived from the base seed,
the split, the family and the part's index), so a setting can be chosen on ``tune`` and
reported on ``test``.

Every family draws its dimensions, proportions and feature counts (holes, teeth, steps,
bends) from a ``numpy.random.Generator``; lengths are in millimetres (the descriptor is
scale-invariant, so only proportions matter). Each part is a closed solid; the genus of the
holed families is known from their parameters (``GeneratedPart.genus``), which the tests use.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import trimesh
from manifold3d import CrossSection, Manifold

__all__ = [
    "FAMILIES",
    "SPLITS",
    "GeneratedPart",
    "generate_part",
    "main",
    "write_dataset",
]

#: Splits written by ``write_dataset``; their seeds never overlap.
SPLITS: tuple[str, ...] = ("tune", "test")
#: Segments of a full circle (holes, shafts, pipes).
_SEGMENTS = 40

Params = dict[str, float | int]


@dataclass
class GeneratedPart:
    """One generated part.

    Attributes
    ----------
    family : str
        Class label.
    mesh : trimesh.Trimesh
    params : dict
        The drawn parameters (dimensions in mm, counts).
    genus : int or None
        Through-holes of the solid, when the family's construction fixes it.
    """

    family: str
    mesh: trimesh.Trimesh
    params: Params = field(default_factory=dict)
    genus: int | None = None


# -- primitives -------------------------------------------------------------------------------


def _box(x: float, y: float, z: float) -> Manifold:
    """Axis-aligned box with its lower corner at the origin."""
    return Manifold.cube((x, y, z))


def _rod(radius: float, length: float, axis: str = "z", segments: int = _SEGMENTS) -> Manifold:
    """A cylinder from 0 to ``length`` along ``axis``, centred on it."""
    rod = Manifold.cylinder(length, radius, radius, segments)
    if axis == "x":
        return rod.rotate((0.0, 90.0, 0.0))
    if axis == "y":
        return rod.rotate((-90.0, 0.0, 0.0))
    return rod


def _through_z(radius: float, x: float, y: float, low: float, high: float) -> Manifold:
    """A hole cutter along z at ``(x, y)``, reaching past ``low`` and ``high``."""
    return _rod(radius, high - low + 2.0).translate((x, y, low - 1.0))


def _union(parts: list[Manifold]) -> Manifold:
    result = parts[0]
    for part in parts[1:]:
        result = result + part
    return result


def _polygon(points: np.ndarray) -> CrossSection:
    """A cross-section from one counter-clockwise outline ``(n, 2)``."""
    return CrossSection([np.asarray(points, dtype=np.float64)])


def _strip(centre_line: np.ndarray, thickness: float) -> CrossSection:
    """A closed outline of constant ``thickness`` around an open polyline ``(n, 2)``.

    Offsets are taken along the averaged normals of neighbouring segments (mitred), which is
    exact for the straight legs and the finely sampled arcs of a bent sheet.
    """
    tangents = np.gradient(centre_line, axis=0)
    tangents /= np.linalg.norm(tangents, axis=1, keepdims=True)
    normals = np.column_stack([-tangents[:, 1], tangents[:, 0]])
    half = thickness / 2.0
    outline = np.vstack([centre_line + half * normals, (centre_line - half * normals)[::-1]])
    section = _polygon(outline)
    if section.area() <= 0:  # clockwise outline: reverse it
        section = _polygon(outline[::-1])
    return section


# -- families ---------------------------------------------------------------------------------


def _hole_columns(count: int, width: float, keep_centre_free: bool) -> np.ndarray:
    """Hole positions across a plate of ``width``: evenly spaced, or off-centre pairs."""
    if keep_centre_free:
        return np.array([0.22, 0.78][:count]) * width
    return np.arange(1, count + 1) * width / (count + 1)


def _bracket(rng: np.random.Generator) -> tuple[Manifold, Params, int]:
    """Angle bracket: base and upright plates, an optional gusset, holes in both plates."""
    width = rng.uniform(30, 90)
    depth = rng.uniform(30, 80)
    height = rng.uniform(30, 90)
    thick = rng.uniform(3, 8)
    base_holes = int(rng.integers(1, 4))
    wall_holes = int(rng.integers(1, 3))
    gusset = bool(rng.integers(0, 2))
    solid = _box(width, depth, thick) + _box(width, thick, height)
    if gusset:
        g = min(depth, height) * 0.6
        triangle = _polygon(np.array([[0, 0], [g, 0], [0, g]], dtype=float))
        web = triangle.extrude(thick).rotate((90.0, 0.0, 90.0))
        solid = solid + web.translate((width / 2 - thick / 2, thick, thick))
    radius = rng.uniform(0.06, 0.1) * min(width, depth, height)
    if gusset:  # holes stay clear of the web in the middle
        base_holes, wall_holes = min(base_holes, 2), min(wall_holes, 2)
    base_x = _hole_columns(base_holes, width, gusset)
    wall_x = _hole_columns(wall_holes, width, gusset)
    cutters = [_through_z(radius, x, thick + (depth - thick) * 0.6, -1, thick + 1)
               for x in base_x]
    cutters += [_rod(radius, thick + 2, "y").translate((x, -1, thick + 0.65 * height))
                for x in wall_x]
    solid = solid - _union(cutters)
    params = {"width": width, "depth": depth, "height": height, "thickness": thick,
              "base_holes": base_holes, "wall_holes": wall_holes, "gusset": int(gusset)}
    return solid, params, base_holes + wall_holes


def _flange(rng: np.random.Generator) -> tuple[Manifold, Params, int]:
    """Round flange: disc, hub, central bore and a bolt circle."""
    radius = rng.uniform(30, 90)
    thick = rng.uniform(0.1, 0.25) * radius
    hub_radius = rng.uniform(0.35, 0.5) * radius
    hub_height = rng.uniform(0.2, 1.0) * radius
    bore = rng.uniform(0.45, 0.75) * hub_radius
    bolts = int(rng.integers(4, 13))
    pitch = (hub_radius + radius) / 2
    bolt_radius = min(0.4 * (radius - hub_radius), 0.7 * np.pi * pitch / bolts) / 1.2
    solid = _rod(radius, thick, segments=64) + _rod(hub_radius, thick + hub_height)
    angles = np.arange(bolts) * 2 * np.pi / bolts
    cutters = [_through_z(bore, 0, 0, 0, thick + hub_height)]
    cutters += [_through_z(bolt_radius, pitch * np.cos(a), pitch * np.sin(a), 0, thick)
                for a in angles]
    params = {"radius": radius, "thickness": thick, "hub_radius": hub_radius,
              "hub_height": hub_height, "bore": bore, "bolts": bolts}
    return solid - _union(cutters), params, bolts + 1


def _plate(rng: np.random.Generator) -> tuple[Manifold, Params, int]:
    """Rectangular plate with a rows x columns grid of holes."""
    length = rng.uniform(60, 200)
    width = rng.uniform(0.3, 0.9) * length
    thick = rng.uniform(0.02, 0.08) * length
    rows = int(rng.integers(1, 4))
    cols = int(rng.integers(2, 6))
    pitch = min(width / (rows + 1), length / (cols + 1))
    radius = rng.uniform(0.15, 0.35) * pitch
    xs = np.linspace(length / (cols + 1), length * cols / (cols + 1), cols)
    ys = np.linspace(width / (rows + 1), width * rows / (rows + 1), rows)
    cutters = [_through_z(radius, x, y, 0, thick) for x in xs for y in ys]
    params = {"length": length, "width": width, "thickness": thick, "rows": rows,
              "cols": cols, "hole_radius": radius}
    return _box(length, width, thick) - _union(cutters), params, rows * cols


def _shaft(rng: np.random.Generator) -> tuple[Manifold, Params, int]:
    """Stepped shaft with a keyway milled into its largest step."""
    steps = int(rng.integers(2, 6))
    radii = rng.uniform(6, 20, size=steps)
    lengths = rng.uniform(15, 60, size=steps)
    z = np.concatenate([[0.0], np.cumsum(lengths)])
    solid = _union([_rod(r, h).translate((0, 0, z0))
                    for r, h, z0 in zip(radii, lengths, z[:-1], strict=True)])
    big = int(np.argmax(radii))
    key_width = 0.5 * radii[big]
    key_depth = 0.3 * radii[big]
    key_length = 0.6 * lengths[big]
    key = _box(key_width, key_depth + 1, key_length).translate(
        (-key_width / 2, radii[big] - key_depth, z[big] + 0.2 * lengths[big])
    )
    params = {"steps": steps, "length": float(z[-1]), "max_radius": float(radii.max()),
              "keyway_step": big}
    return solid - key, params, 0


def _gear(rng: np.random.Generator) -> tuple[Manifold, Params, int]:
    """Spur gear with trapezoidal teeth, a bore and optional lightening holes."""
    teeth = int(rng.integers(10, 41))
    module = rng.uniform(1.5, 4.0)
    pitch_radius = module * teeth / 2
    tip, root = pitch_radius + module, pitch_radius - 1.25 * module
    width = rng.uniform(0.15, 0.6) * pitch_radius
    outline = []
    step = 2 * np.pi / teeth
    for i in range(teeth):
        a = i * step
        for angle, radius in ((a - 0.3 * step, root), (a - 0.15 * step, tip),
                              (a + 0.15 * step, tip), (a + 0.3 * step, root)):
            outline.append((radius * np.cos(angle), radius * np.sin(angle)))
    solid = _polygon(np.array(outline)).extrude(width)
    bore = rng.uniform(0.15, 0.3) * root
    holes = int(rng.choice([0, 4, 5, 6])) if root > 3 * bore else 0
    cutters = [_through_z(bore, 0, 0, 0, width)]
    ring = (bore + root) / 2
    hole_radius = 0.3 * (root - bore) / 2
    cutters += [_through_z(hole_radius, ring * np.cos(a), ring * np.sin(a), 0, width)
                for a in np.arange(holes) * 2 * np.pi / max(holes, 1)]
    params = {"teeth": teeth, "module": module, "width": width, "holes": holes}
    return solid - _union(cutters), params, 1 + holes


def _pipe_elbow(rng: np.random.Generator) -> tuple[Manifold, Params, int]:
    """Pipe elbow: a bent tube (annulus revolved by 45-90 degrees) with straight stubs."""
    outer = rng.uniform(8, 30)
    inner = rng.uniform(0.6, 0.9) * outer
    bend = rng.uniform(1.5, 3.5) * outer
    angle = float(rng.choice([45.0, 60.0, 90.0]))
    stub = rng.uniform(0.0, 2.0) * outer
    ring = CrossSection.circle(outer, _SEGMENTS) - CrossSection.circle(inner, _SEGMENTS)
    tube = ring.translate((bend, 0.0)).revolve(_SEGMENTS, angle)
    if stub > 1.0:
        straight = ring.extrude(stub)  # along +z at the origin, as the revolve's start face
        tube = tube + straight.rotate((90.0, 0.0, 0.0)).translate((bend, 0.0, 0.0))
    params = {"outer": outer, "inner": inner, "bend_radius": bend, "angle": angle,
              "stub": stub}
    return tube, params, 1


def _pipe_tee(rng: np.random.Generator) -> tuple[Manifold, Params, int]:
    """Pipe tee: a run and a branch tube, bores joined."""
    outer = rng.uniform(8, 30)
    inner = rng.uniform(0.6, 0.9) * outer
    run = rng.uniform(4, 8) * outer
    branch_outer = rng.uniform(0.6, 1.0) * outer
    branch_inner = branch_outer * inner / outer
    branch = rng.uniform(1.5, 4) * outer
    solid = _rod(outer, run, "x").translate((-run / 2, 0, 0)) + _rod(branch_outer, branch)
    bores = (_rod(inner, run + 2, "x").translate((-run / 2 - 1, 0, 0))
             + _rod(branch_inner, branch + 1))
    params = {"outer": outer, "inner": inner, "run": run, "branch": branch}
    return solid - bores, params, 2


def _profile(outline: np.ndarray, length: float) -> Manifold:
    return _polygon(outline).extrude(length)


def _l_profile(rng: np.random.Generator) -> tuple[Manifold, Params, int]:
    """Angle section: an L outline extruded to length."""
    a, b = rng.uniform(20, 80), rng.uniform(20, 80)
    t = rng.uniform(0.06, 0.15) * min(a, b)
    length = rng.uniform(2, 8) * max(a, b)
    outline = np.array([[0, 0], [a, 0], [a, t], [t, t], [t, b], [0, b]])
    return _profile(outline, length), {"a": a, "b": b, "t": t, "length": length}, 0


def _u_profile(rng: np.random.Generator) -> tuple[Manifold, Params, int]:
    """Channel section: a U outline extruded to length."""
    w, h = rng.uniform(30, 100), rng.uniform(20, 80)
    t = rng.uniform(0.06, 0.12) * min(w, h)
    length = rng.uniform(2, 8) * max(w, h)
    outline = np.array([[0, 0], [w, 0], [w, h], [w - t, h], [w - t, t], [t, t], [t, h],
                        [0, h]])
    return _profile(outline, length), {"w": w, "h": h, "t": t, "length": length}, 0


def _z_profile(rng: np.random.Generator) -> tuple[Manifold, Params, int]:
    """Z section: two flanges on opposite sides of a web."""
    f1, f2, h = rng.uniform(20, 60), rng.uniform(20, 60), rng.uniform(40, 120)
    t = rng.uniform(0.06, 0.12) * min(f1, f2)
    length = rng.uniform(2, 6) * h
    outline = np.array([[0, 0], [f1 + t, 0], [f1 + t, h - t], [f1 + t + f2, h - t],
                        [f1 + t + f2, h], [f1, h], [f1, t], [0, t]])
    return _profile(outline, length), {"f1": f1, "f2": f2, "h": h, "t": t,
                                       "length": length}, 0


def _housing(rng: np.random.Generator) -> tuple[Manifold, Params, int]:
    """Open-top box housing with corner mounting lugs and a cable hole in one wall."""
    x, y, z = rng.uniform(40, 120), rng.uniform(30, 100), rng.uniform(25, 80)
    wall = rng.uniform(0.04, 0.1) * min(x, y)
    lug = rng.uniform(0.12, 0.2) * min(x, y)
    solid = _box(x, y, z) - _box(x - 2 * wall, y - 2 * wall, z).translate((wall, wall, wall))
    lugs, cutters = [], []
    for cx, cy in ((-lug, -lug), (x, -lug), (-lug, y), (x, y)):
        lugs.append(_box(lug + wall, lug + wall, wall).translate(
            (cx if cx < 0 else cx - wall, cy if cy < 0 else cy - wall, 0)))
        hx = cx + lug / 2 if cx < 0 else cx + lug / 2
        hy = cy + lug / 2 if cy < 0 else cy + lug / 2
        cutters.append(_through_z(0.25 * lug, hx, hy, 0, wall))
    cable = rng.uniform(0.1, 0.25) * min(y, z)
    cutters.append(_rod(cable, wall + 2, "x").translate((-1, y / 2, z / 2)))
    solid = (solid + _union(lugs)) - _union(cutters)
    params = {"x": x, "y": y, "z": z, "wall": wall, "lug": lug}
    return solid, params, 5


def _bolt(rng: np.random.Generator) -> tuple[Manifold, Params, int]:
    """Hex bolt: hexagonal head, plain shank (threads are below the sampling resolution)."""
    d = rng.uniform(4, 20)
    length = rng.uniform(2, 10) * d
    head_width = rng.uniform(1.5, 1.8) * d  # across corners / 2 ~ radius of the hexagon
    head_height = rng.uniform(0.6, 0.8) * d
    head = Manifold.cylinder(head_height, head_width / 2 * 1.15, head_width / 2 * 1.15, 6)
    shank = _rod(d / 2, length).translate((0, 0, head_height))
    params = {"d": d, "length": length, "head_height": head_height}
    return head + shank, params, 0


def _nut(rng: np.random.Generator) -> tuple[Manifold, Params, int]:
    """Hex nut, optionally with a washer face or a flange."""
    d = rng.uniform(4, 24)
    width = rng.uniform(1.5, 1.8) * d * 1.15
    height = rng.uniform(0.5, 1.0) * d
    nut = Manifold.cylinder(height, width / 2, width / 2, 6)
    flanged = bool(rng.integers(0, 2))
    if flanged:
        nut = nut + _rod(width / 2 * 1.15, 0.15 * height, segments=48)
    params = {"d": d, "width": width, "height": height, "flanged": int(flanged)}
    return nut - _through_z(d / 2, 0, 0, 0, height), params, 1


def _sheet_metal(rng: np.random.Generator) -> tuple[Manifold, Params, int]:
    """Bent sheet: 1-3 bends of 45-90 degrees with inner radii, thin wall, holes in legs."""
    width = rng.uniform(20, 80)
    bends = int(rng.integers(1, 4))
    legs = rng.uniform(15, 60, size=bends + 1)
    # Sheet gauge: 1-3 % of the smallest leg or width (about 0.5-2 mm at these sizes).
    thick = rng.uniform(0.01, 0.03) * min(width, legs.min())
    heading = 0.0
    point = np.zeros(2)
    line = [point.copy()]
    radius = rng.uniform(1.0, 3.0) * thick
    for i in range(bends + 1):
        direction = np.array([np.cos(heading), np.sin(heading)])
        # Dense samples along straight legs keep the mitred offsets exact at the bends.
        for s in np.linspace(0, legs[i], 8)[1:]:
            line.append(point + s * direction)
        point = line[-1].copy()
        if i == bends:
            break
        # Headings stay within +-90 degrees, so the sheet runs forward and never overlaps.
        turn = np.radians(rng.uniform(45, 90)) * rng.choice([-1.0, 1.0])
        if abs(heading + turn) > np.pi / 2 + 1e-9:
            turn = -turn
        centre = point + radius * np.sign(turn) * np.array([-direction[1], direction[0]])
        start = np.arctan2(*(point - centre)[::-1])
        for a in np.linspace(0, turn, 12)[1:]:
            line.append(centre + radius * np.array([np.cos(start + a), np.sin(start + a)]))
        point = line[-1].copy()
        heading += turn
    centre_line = np.array(line)
    solid = _strip(centre_line, thick).extrude(width)
    # One hole through the middle of the first and last leg, normal to the leg.
    cutters = []
    for leg_start, leg_end in ((centre_line[0], centre_line[7]),
                               (centre_line[-8], centre_line[-1])):
        middle = (leg_start + leg_end) / 2
        tangent = (leg_end - leg_start) / np.linalg.norm(leg_end - leg_start)
        normal = np.array([-tangent[1], tangent[0]])
        hole = min(0.2 * width, 0.2 * np.linalg.norm(leg_end - leg_start))
        # Just longer than the sheet is thick: it must not reach another leg.
        cutter = Manifold.cylinder(2 * thick, hole, hole, 32).translate((0, 0, -thick))
        # Turn the cutter's z axis onto the leg's in-plane normal, at mid-width.
        yaw = np.degrees(np.arctan2(normal[1], normal[0]))
        cutter = cutter.rotate((0.0, 90.0, 0.0)).rotate((0.0, 0.0, yaw))
        cutters.append(cutter.translate((middle[0], middle[1], width / 2)))
    solid = solid - _union(cutters)
    params = {"thickness": thick, "width": width, "bends": bends, "bend_radius": radius}
    return solid, params, 2


Family = Callable[[np.random.Generator], tuple[Manifold, Params, int]]

#: Family name (class label) -> builder.
FAMILIES: dict[str, Family] = {
    "bracket": _bracket,
    "flange": _flange,
    "plate": _plate,
    "shaft": _shaft,
    "gear": _gear,
    "pipe_elbow": _pipe_elbow,
    "pipe_tee": _pipe_tee,
    "l_profile": _l_profile,
    "u_profile": _u_profile,
    "z_profile": _z_profile,
    "housing": _housing,
    "bolt": _bolt,
    "nut": _nut,
    "sheet_metal": _sheet_metal,
}


def _to_trimesh(solid: Manifold) -> trimesh.Trimesh:
    mesh = solid.to_mesh()
    return trimesh.Trimesh(
        vertices=np.asarray(mesh.vert_properties)[:, :3].astype(np.float64),
        faces=np.asarray(mesh.tri_verts, dtype=np.int64),
        process=True,
    )


def part_seed(seed: int, split: str, family: str, index: int) -> list[int]:
    """Seed sequence of one part: independent of every other part and of the split order."""
    return [seed, SPLITS.index(split) if split in SPLITS else len(SPLITS) + len(split),
            sorted(FAMILIES).index(family), index]


def generate_part(family: str, index: int, seed: int = 0, split: str = "tune") -> GeneratedPart:
    """Part ``index`` of ``family`` in ``split``; the same arguments give the same mesh.

    Raises
    ------
    KeyError
        Unknown family.
    """
    builder = FAMILIES[family]
    rng = np.random.default_rng(part_seed(seed, split, family, index))
    solid, params, genus = builder(rng)
    return GeneratedPart(family=family, mesh=_to_trimesh(solid), params=params, genus=genus)


def write_dataset(
    out: str | Path,
    per_family: int = 20,
    seed: int = 0,
    splits: tuple[str, ...] = SPLITS,
    families: tuple[str, ...] | None = None,
) -> list[Path]:
    """Write ``out/<split>/<family>/<family>_NNN.ply`` for every split and family.

    Returns
    -------
    paths : list of Path
        The files written.
    """
    out = Path(out)
    written = []
    for split in splits:
        for family in families or tuple(FAMILIES):
            folder = out / split / family
            folder.mkdir(parents=True, exist_ok=True)
            for index in range(per_family):
                part = generate_part(family, index, seed, split)
                path = folder / f"{family}_{index:03d}.ply"
                part.mesh.export(path)
                written.append(path)
    return written


def main(argv: list[str] | None = None) -> int:
    """``python -m core.evaluation.parts_generator OUT_DIR [--per-family N] [--seed S]``."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("out")
    parser.add_argument("--per-family", type=int, default=20)
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args(argv)
    paths = write_dataset(args.out, args.per_family, args.seed)
    print(f"wrote {len(paths)} parts in {len(FAMILIES)} families x {len(SPLITS)} splits "
          f"to {args.out}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
