"""Labelled tuning sources, one folder each: data made by others, and ours as one of them.

``python -m core.evaluation.sources OUT [--sources NAME ...]`` writes
``OUT/<source>/<class>/<model>.ply`` for the evaluation (``core.evaluation.dataset``), the
same bytes for the same seed. Generated files are never committed: they are rebuilt from
the libraries' own parametric models.

| source | made by | licence | classes |
|---|---|---|---|
| ``madcad`` | pymadcad ``madcad.standard`` | LGPL-3.0 | 12: screws (4 heads), nuts, ... |
| ``gearworks`` | py-gearworks on build123d | MIT / Apache-2.0 | 7 gear kinds |
| ``vslot`` | bd-vslot on build123d | MIT / Apache-2.0 | 6: plates, brackets, wheels, ... |
| ``parts`` | trimesh project's part meshes | MIT | one per part (instance level) |
| ``capod`` | CAPOD (Papadakis 2014) | CC BY 3.0 | 15 object classes |
| ``generated`` | ours (``core.evaluation.parts_generator``) | ours | 14 part families |
| ``bendable`` | ours (``core.evaluation.sources.bendable``) | ours | 6 bendable kinds, 8 poses |
| ``mcad`` | OpenSCAD's MCAD (``openscad-mcad``) | LGPL-2.1 | 11: bolts (3 heads), gears, ... |
| ``bosl2`` | BOSL2 (its ``.scad`` in ``solidpython2``) | BSD-2-Clause | 15: screws, nuts, ... |
| ``freecad`` | FreeCAD's own modules (``freecad``) | LGPL-2.1+ | 7: sprockets, gears, sections |
| ``cqparts`` | cqparts' fasteners and bearings (on FreeCAD) | GPL-3.0 | 10: screws (5 heads), ... |
| ``poses`` | ours (``bendable.identity_parts``) | ours | 20 shapes of 4 kinds, 8 shared poses |

``NON_RIGID`` names what bends: the whole ``bendable`` and ``poses`` sources and capod's
articulated classes.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from pathlib import Path

import trimesh

__all__ = [
    "CHECK_SOURCES", "DEFAULT_SOURCES", "NON_RIGID", "SHARED", "SOURCES", "write_sources",
]

#: The shared datasets folder (next to the repository), for ``parts`` and ``capod``.
SHARED = Path(__file__).resolve().parents[3].parent / "shared" / "datasets"

#: Source -> classes that bend or articulate (``None``: every class of the source).
NON_RIGID: dict[str, tuple[str, ...] | None] = {
    "bendable": None,
    "poses": None,
    "capod": ("Dog", "Hand", "Horse", "Human", "Spider"),
}

Parts = Iterator[tuple[str, str, trimesh.Trimesh]]


def _madcad(seed: int, shared: Path) -> Parts:
    from core.evaluation.sources.madcad_parts import parts

    return parts()


def _gearworks(seed: int, shared: Path) -> Parts:
    from core.evaluation.sources.gearworks_gears import parts

    return parts()


def _vslot(seed: int, shared: Path) -> Parts:
    from core.evaluation.sources.vslot_parts import parts

    return parts()


def _mcad(seed: int, shared: Path) -> Parts:
    from core.evaluation.sources.mcad_parts import parts

    return parts()


def _bosl2(seed: int, shared: Path) -> Parts:
    from core.evaluation.sources.bosl2_parts import parts

    return parts()


def _freecad(seed: int, shared: Path) -> Parts:
    from core.evaluation.sources.freecad_parts import parts

    return parts()


def _cqparts(seed: int, shared: Path) -> Parts:
    from core.evaluation.sources.cqparts_parts import parts

    return parts()


def _poses(seed: int, shared: Path) -> Parts:
    from core.evaluation.sources.bendable import identity_parts
    return identity_parts()


def _parts(seed: int, shared: Path) -> Parts:
    from core.evaluation.sources.real_parts import parts

    return parts(shared / "parts", seed)


def _generated(seed: int, shared: Path) -> Parts:
    from core.evaluation.parts_generator import FAMILIES, generate_part

    for family in FAMILIES:
        for index in range(10):
            yield family, f"{family}_{index:03d}", generate_part(family, index, seed).mesh


def _bendable(seed: int, shared: Path) -> Parts:
    from core.evaluation.sources.bendable import parts

    return parts(seed=seed)


#: Every source that writes meshes (``capod`` is linked, not written).
SOURCES: dict[str, Callable[[int, Path], Parts]] = {
    "madcad": _madcad, "gearworks": _gearworks, "vslot": _vslot, "parts": _parts,
    "generated": _generated, "bendable": _bendable, "mcad": _mcad, "bosl2": _bosl2,
    "freecad": _freecad, "cqparts": _cqparts, "poses": _poses,
}

#: Sources written only when named: ``mcad`` and ``bosl2`` need the ``openscad`` program,
#: ``freecad`` the ``freecadcmd`` program, ``cqparts`` that and CadQuery 1.x (none a wheel);
#: they were added later, as checks on settings chosen without them (``bosl2``, then
#: ``freecad``, then ``cqparts``, each after every other);
#: ``poses`` checks the descriptor families (shapes in shared poses) and is not a tuning
#: source.
CHECK_SOURCES: tuple[str, ...] = ("mcad", "bosl2", "freecad", "cqparts", "poses")

#: The sources written when none are named.
DEFAULT_SOURCES: tuple[str, ...] = (
    *(name for name in SOURCES if name not in CHECK_SOURCES), "capod")


def write_sources(out: Path, names: list[str], seed: int = 0,
                  shared: Path = SHARED) -> dict[str, dict[str, int]]:
    """Write every named source under ``out``; returns the model count per class.

    ``capod`` is a symbolic link to the shared copy (it is labelled already).
    """
    counts: dict[str, dict[str, int]] = {}
    for name in names:
        target = out / name
        if name == "capod":
            out.mkdir(parents=True, exist_ok=True)
            if not target.exists():
                target.symlink_to(shared / "capod", target_is_directory=True)
            classes = [p for p in target.iterdir() if p.is_dir()]
            counts[name] = {p.name: len(list(p.glob("*.obj"))) for p in classes}
            continue
        counts[name] = {}
        for label, model, mesh in SOURCES[name](seed, shared):
            folder = target / label
            folder.mkdir(parents=True, exist_ok=True)
            mesh.export(folder / f"{model}.ply")
            counts[name][label] = counts[name].get(label, 0) + 1
    return counts
