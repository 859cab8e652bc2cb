"""Bendable engineering shapes in several poses: the non-rigid source we generate.

Every shape is a tube swept along a centre line, or a plate folded along a line, and a class
holds one kind of object in several poses (and slightly different sizes): a hose bent by 0
to 150 degrees, a cable in an S-bend, a coil spring whose axis is bent, a flat strip bent
along its length, a finger of three links at its two knuckles, and a plate folded at a
hinge. The centre line is parameterised by arc length and bent by a curvature profile, so
its length is kept exactly and the surface is bent near-isometrically (up to the wall
thickness): what an intrinsic descriptor must not see, and an extrinsic one does.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator

import numpy as np
import trimesh

__all__ = [
    "IDENTITIES", "IDENTITY_KINDS", "KINDS", "bend_check_shapes", "bend_points", "centre_line",
    "identity_parts", "parts", "tube_mesh",
]

_STEPS = 240  # centre-line samples: fine enough that a bend's facets stay small


def centre_line(length: float, curvature: Callable[[np.ndarray], np.ndarray]) -> np.ndarray:
    """A planar curve of arc length ``length`` in the x-z plane, starting up the z axis.

    Parameters
    ----------
    length : float
    curvature : callable
        Curvature ``(m,) -> (m,)`` at arc lengths ``s`` (1 / radius; 0 is straight).

    Returns
    -------
    points : (_STEPS + 1, 3) float
        Samples at equal arc-length steps (the curve's length is ``length`` to round-off).
    """
    s = np.linspace(0.0, length, _STEPS + 1)
    kappa = curvature(s)
    # Tangent angle: the integral of curvature (trapezoids), then position: of the tangent.
    angle = np.concatenate([[0.0], np.cumsum((kappa[1:] + kappa[:-1]) / 2 * np.diff(s))])
    tangent = np.stack([np.sin(angle), np.zeros_like(angle), np.cos(angle)], axis=1)
    steps = (tangent[1:] + tangent[:-1]) / 2 * np.diff(s)[:, None]
    # Mid-point tangents shorten a step by O(h^2); rescale so every step is exactly h long.
    steps *= (np.diff(s) / np.linalg.norm(steps, axis=1))[:, None]
    return np.vstack([np.zeros(3), np.cumsum(steps, axis=0)])


def bend_points(points: np.ndarray, length: float,
                curvature: Callable[[np.ndarray], np.ndarray]) -> np.ndarray:
    """Bend ``points : (n, 3) float`` lying along the z axis (z in [0, length]) so that the
    z axis follows ``centre_line(length, curvature)``; x is the offset in the bending plane.
    """
    line = centre_line(length, curvature)
    s = np.linspace(0.0, length, len(line))
    tangent = np.gradient(line, s, axis=0)
    tangent /= np.linalg.norm(tangent, axis=1, keepdims=True)
    normal = np.stack([tangent[:, 2], np.zeros(len(s)), -tangent[:, 0]], axis=1)
    z = np.clip(points[:, 2], 0.0, length)
    at = [np.interp(z, s, column) for column in (*line.T, *normal.T)]
    base, across = np.stack(at[:3], axis=1), np.stack(at[3:], axis=1)
    return base + points[:, :1] * across + points[:, 1:2] * np.array([0.0, 1.0, 0.0])


def tube_mesh(line: np.ndarray, radius: float, inner: float | None = None,
              sections: int = 24) -> trimesh.Trimesh:
    """A closed tube of ``radius`` around ``line : (m, 3) float``, hollow when ``inner``.

    Rings are placed with a parallel-transported frame (no twist), so the tube's surface is
    the same however the line is bent; the ends are closed with discs or annuli.
    """
    tangent = np.gradient(line, axis=0)
    tangent /= np.linalg.norm(tangent, axis=1, keepdims=True)
    frame = np.cross(tangent[0], [1.0, 0.0, 0.0] if abs(tangent[0][0]) < 0.9 else [0, 1, 0])
    frames = []
    for t in tangent:  # parallel transport: remove the component along the new tangent
        frame = frame - (frame @ t) * t
        frame /= np.linalg.norm(frame)
        frames.append(frame)
    u = np.array(frames)
    v = np.cross(tangent, u)
    theta = np.linspace(0.0, 2 * np.pi, sections, endpoint=False)
    circle = np.cos(theta)[None, :, None] * u[:, None] + np.sin(theta)[None, :, None] * v[:, None]

    def wall(r: float) -> np.ndarray:
        return (line[:, None, :] + r * circle).reshape(-1, 3)

    rings, count = len(line), sections
    index = np.arange(rings * count).reshape(rings, count)
    a, b = index[:-1], np.roll(index[:-1], -1, axis=1)
    c, d = index[1:], np.roll(index[1:], -1, axis=1)
    side = np.concatenate([np.stack([a, b, d], -1).reshape(-1, 3),
                           np.stack([a, d, c], -1).reshape(-1, 3)])
    if inner is None:
        vertices = np.vstack([wall(radius), line[[0, -1]]])
        start, end = len(vertices) - 2, len(vertices) - 1
        caps = np.concatenate([
            np.stack([np.full(count, start), np.roll(index[0], -1), index[0]], -1),
            np.stack([np.full(count, end), index[-1], np.roll(index[-1], -1)], -1),
        ])
        return trimesh.Trimesh(vertices, np.concatenate([side, caps]), process=True)
    offset = rings * count
    inside = side[:, ::-1] + offset
    ends = []
    for ring in (index[0], index[-1]):
        nxt = np.roll(ring, -1)
        ends += [np.stack([ring, nxt + offset, nxt], -1), np.stack([ring, ring + offset,
                                                                    nxt + offset], -1)]
    faces = np.concatenate([side, inside, *ends])
    return trimesh.Trimesh(np.vstack([wall(radius), wall(inner)]), faces, process=True)


def _arc(angle: float, length: float) -> Callable[[np.ndarray], np.ndarray]:
    return lambda s: np.full_like(s, angle / length)


def _knuckles(length: float, angles: tuple[float, ...], width: float) -> Callable[
        [np.ndarray], np.ndarray]:
    """Curvature of a line bent only at evenly spaced joints of arc length ``width``."""
    joints = [length * (i + 1) / (len(angles) + 1) for i in range(len(angles))]

    def curvature(s: np.ndarray) -> np.ndarray:
        kappa = np.zeros_like(s)
        for joint, angle in zip(joints, angles, strict=True):
            kappa[np.abs(s - joint) <= width / 2] += angle / width
        return kappa
    return curvature


def _plate(length: float, width: float, thickness: float) -> trimesh.Trimesh:
    plate = trimesh.creation.box((thickness, width, length))
    plate.apply_translation([0.0, 0.0, length / 2])
    return plate.subdivide_to_size(max_edge=length / 80, max_iter=12)


def _poses(rng: np.random.Generator) -> Iterator[tuple[int, float, float]]:
    """(pose number, pose parameter in [0, 1], size jitter) for the eight poses of a class."""
    for pose, fraction in enumerate(np.linspace(0.0, 1.0, 8)):
        yield pose, float(fraction), float(rng.uniform(0.95, 1.05))


def _hose(f: float, j: float) -> trimesh.Trimesh:
    length = 120.0 * j
    return tube_mesh(centre_line(length, _arc(np.radians(150) * f, length)), 8.0, 6.0)


def _cable(f: float, j: float) -> trimesh.Trimesh:
    length = 150.0 * j
    k = np.radians(140) * f / (length / 2)
    return tube_mesh(centre_line(length, lambda s: np.where(s < length / 2, k, -k)), 3.0)


def _spring(f: float, j: float) -> trimesh.Trimesh:
    turns, pitch, coil = 8, 7.0 * j, 10.0
    t = np.linspace(0.0, 2 * np.pi * turns, 900)
    helix = np.stack([coil * np.cos(t), coil * np.sin(t), pitch * t / (2 * np.pi)], axis=1)
    length = pitch * turns
    return tube_mesh(bend_points(helix, length, _arc(np.radians(100) * f, length)), 1.2,
                     sections=12)


def _strip(f: float, j: float) -> trimesh.Trimesh:
    length = 140.0 * j
    plate = _plate(length, 20.0, 2.0)
    plate.vertices = bend_points(plate.vertices, length, _arc(np.radians(180) * f, length))
    return plate


def _finger(f: float, j: float) -> trimesh.Trimesh:
    length = 90.0 * j
    angles = (np.radians(80) * f, np.radians(60) * (1 - 0.5 * f) * f)
    return tube_mesh(centre_line(length, _knuckles(length, angles, 8.0)), 7.0)


def _hinge(f: float, j: float) -> trimesh.Trimesh:
    length = 100.0 * j
    plate = _plate(length, 60.0, 3.0)
    fold = _knuckles(length, (np.radians(170) * f,), 6.0)
    plate.vertices = bend_points(plate.vertices, length, fold)
    return plate


_BUILDERS: dict[str, Callable[[float, float], trimesh.Trimesh]] = {
    "hose": _hose, "cable": _cable, "bent_spring": _spring, "strip": _strip,
    "finger": _finger, "hinge_plate": _hinge,
}

#: Every kind this source makes (its class labels).
KINDS: tuple[str, ...] = tuple(_BUILDERS)


def parts(kinds: tuple[str, ...] = KINDS, seed: int = 0
          ) -> Iterator[tuple[str, str, trimesh.Trimesh]]:
    """``(kind, name, mesh)``: eight poses of every kind, the same for the same ``seed``."""
    for number, kind in enumerate(kinds):
        rng = np.random.default_rng([seed, KINDS.index(kind) if kind in KINDS else number])
        for pose, fraction, jitter in _poses(rng):
            yield kind, f"pose{pose}", _BUILDERS[kind](fraction, jitter)


#: ``identity_parts``: the kinds, and the length (or pitch) factors that make one shape of a
#: kind differ from another (its proportions, which bending keeps).
IDENTITY_KINDS: tuple[str, ...] = ("hose", "bent_spring", "strip", "finger")
IDENTITIES: tuple[float, ...] = (0.6, 0.8, 1.0, 1.25, 1.6)


def identity_parts() -> Iterator[tuple[str, str, trimesh.Trimesh]]:
    """``(class, name, mesh)``: shapes told apart only by their proportions, each in the same
    eight poses, a class per shape (FAUST's design: ten people in the same ten poses).

    A descriptor that sees the pose finds the same pose of another shape first; one that sees
    only what bending keeps finds the same shape in another pose. Deterministic (no jitter).
    """
    for kind in IDENTITY_KINDS:
        for factor in IDENTITIES:
            for pose, fraction in enumerate(np.linspace(0.0, 1.0, 8)):
                yield (f"{kind}_x{factor:g}", f"pose{pose}",
                       _BUILDERS[kind](float(fraction), factor))


def bend_check_shapes() -> dict[str, trimesh.Trimesh]:
    """The shapes of the bend check (``tests/core/test_families.py``): a straight tube and
    the same tube bent by 90 degrees along its whole length (arc length kept), a finger and
    the same finger with its knuckles turned by 70 and 40 degrees, and three other shapes
    (box, torus, cone) to compare the bend's distance with."""
    length = 100.0
    return {
        "straight": tube_mesh(centre_line(length, lambda s: 0 * s), 6.0),
        "bent": tube_mesh(centre_line(length, lambda s: np.full_like(s, np.pi / 2 / length)),
                          6.0),
        "finger": tube_mesh(centre_line(90.0, _knuckles(90.0, (0.0, 0.0), 8.0)), 7.0),
        "finger-bent": tube_mesh(
            centre_line(90.0, _knuckles(90.0, (np.radians(70), np.radians(40)), 8.0)), 7.0
        ),
        "box": trimesh.creation.box((20.0, 30.0, 60.0)),
        "torus": trimesh.creation.torus(30.0, 8.0),
        "cone": trimesh.creation.cone(15.0, 80.0),
    }
