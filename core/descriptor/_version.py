"""``descriptor_version``: everything that changes a descriptor, in one string.

Vectors with different versions must never be compared. The version names the layout, the
engine settings and the blocks' weights readably, and closes with a digest of every exact
value, the shipped vocabulary's content and the installed versions of the libraries the
numbers come from (``ENGINE_LIBRARIES``): an upgrade of one of them makes every stored model
stale, like a change of setting, until it is re-described.
"""

from __future__ import annotations

import hashlib
from functools import lru_cache
from importlib import metadata
from types import MappingProxyType
from typing import TYPE_CHECKING, Any, TypeVar

from core.descriptor._block import Block, bin_edges
from core.descriptor.blocks.caps import CapsBlock
from core.descriptor.blocks.distances import D1Block, D2Block
from core.descriptor.blocks.local import LocalBlock, load_vocabulary
from core.descriptor.blocks.normals import NormalsBlock
from core.descriptor.blocks.ring import RingBlock
from core.descriptor.blocks.spectral import DnaBlock, HksBlock, SlopeBlock, WksBlock
from core.descriptor.blocks.symmetry import SymmetryBlock
from core.settings import EngineSettings

if TYPE_CHECKING:
    from core.descriptor._union import DescriptorSpec

__all__ = [
    "ENGINE_LIBRARIES",
    "VERSION_LENGTH",
    "canonical_text",
    "descriptor_version",
    "engine_library_versions",
]

#: Layout generation: bump when the code changes the vector for unchanged settings.
LAYOUT = "ss12"

#: The libraries whose upgrade can change a descriptor for unchanged code and settings
#: (distribution names): the linear algebra and eigensolvers (numpy, scipy, qdldl), the
#: Laplacian (robust-laplacian), mesh loading and surface sampling (trimesh).
ENGINE_LIBRARIES = ("numpy", "scipy", "trimesh", "robust-laplacian", "qdldl")

#: Longest ``descriptor_version`` (the width of the database column).
VERSION_LENGTH = 255


@lru_cache(maxsize=1)
def engine_library_versions() -> MappingProxyType[str, str]:
    """``ENGINE_LIBRARIES``' installed versions, read once per process (reading them costs
    ~5 ms; the code a process has loaded cannot change under it anyway). A library that is
    not installed as a distribution is ``"none"``."""
    versions = {}
    for name in ENGINE_LIBRARIES:
        try:
            versions[name] = metadata.version(name)
        except metadata.PackageNotFoundError:
            versions[name] = "none"
    return MappingProxyType(versions)


def descriptor_version(spec: DescriptorSpec, settings: EngineSettings) -> str:
    """The version of ``spec``'s vectors under ``settings``: a readable part that rounds,
    then ten hex digits of SHA-256 over ``canonical_text``, which pins every exact value."""
    cutoff = settings.cutoff
    cut = (
        f"fixed{cutoff.n}"
        if cutoff.mode == "fixed"
        else f"adaptive(xi={cutoff.xi:g},t={cutoff.t:g},{cutoff.n_min}-{cutoff.n_max})"
    )
    grid, weight = spec.grid, spec.weight
    hks = _standard(spec, HksBlock)
    edges = bin_edges(hks.bounds, hks.bins)
    parts = [
        LAYOUT if spec.family == "parts" else f"{LAYOUT}-{spec.family}",
        f"lap={settings.laplacian}",
        f"norm={settings.normalisation}",
        f"pts={settings.max_points}"
        f"{f'+mor{settings.outlier_ratio:g}' if settings.outlier_filter else ''}",
        f"cut={cut}",
        f"hks{'s' if grid.scaled else ''}={len(grid.times)}"
        f"[{min(grid.times):g},{max(grid.times):g}]w{weight('hks'):g}",
        f"bins={len(edges) - 1}[{edges[0]:g},{edges[-1]:g}]",
    ]
    if grid.energies:
        parts.append(
            f"wks={len(grid.energies)}[{grid.energies[0]:g},{grid.energies[-1]:g}]"
            f"s{grid.sigma:.3g}w{weight('wks'):g}slope{weight('slope'):g}"
        )
    dna = _standard(spec, DnaBlock)
    if dna.count:
        parts.append(f"dna={dna.count}w{weight('dna'):g}")
    local = _standard(spec, LocalBlock)
    if weight("local") > 0:
        # The vocabulary's own digest: a refitted file is a new version.
        vocabulary = load_vocabulary(local.vocabulary)
        variation = "".join(f"+sv{k}" for k in local.neighbours)
        parts.append(
            f"loc={local.encoding}{vocabulary.size}{local.columns}{variation}"
            f"@{vocabulary.digest()[:6]}w{weight('local'):g}"
        )
    # The blocks measured on the points by their tags, with weights other than 1; bins,
    # pairs and neighbours are in the digest.
    tagged = [(block.tag, w) for block, w in spec.parts if block.tag is not None and w > 0]
    if tagged:
        parts.append("ext=" + ",".join(
            tag if w == 1 else f"{tag}:{w:g}" for tag, w in tagged
        ))
        if spec.runs_longest is not None:
            parts.append(f"runs={spec.runs_longest:g}")
    digest = hashlib.sha256(canonical_text(spec, settings).encode()).hexdigest()[:10]
    # The database keeps VERSION_LENGTH characters: an unusual setting's long readable
    # part is cut, never the digest that tells versions apart.
    readable = ";".join(parts)[: VERSION_LENGTH - len(digest) - 1]
    return f"{readable};{digest}"


def canonical_text(spec: DescriptorSpec, settings: EngineSettings) -> str:
    """The digest's canonical text: every exact value that changes the vector, in one
    fixed order and format.

    The order and format are those the stored versions were made with (the repr of a tuple
    that opens with ``DescriptorSpec(name=value, ...)``): the same settings give the same
    digest, so a deployment's stored models stay current across releases that do not
    change the vector. No entry is ever renamed or dropped here: five belong to no block of
    the layout and keep the constant values they always had (``spread_weight``,
    ``evened_distances``, ``evened_areas``, ``axis_edges``, ``axis_weight``). A block
    outside the layout is appended as ``extra=``, so it changes the digest.
    """
    grid, weight = spec.grid, spec.weight
    hks, wks, slope = (_standard(spec, HksBlock), _standard(spec, WksBlock),
                       _standard(spec, SlopeBlock))
    d2, d1 = _standard(spec, D2Block), _standard(spec, D1Block)
    normals, ring = _standard(spec, NormalsBlock), _standard(spec, RingBlock)
    caps, local = _standard(spec, CapsBlock), _standard(spec, LocalBlock)

    def edges(bounds: tuple[float, float], bins: int) -> tuple[float, ...]:
        return tuple(bin_edges(bounds, bins).tolist())

    fields: list[tuple[str, Any]] = [
        ("times", grid.times), ("scaled", grid.scaled),
        ("hks_edges", edges(hks.bounds, hks.bins)), ("hks_weight", weight("hks")),
        ("energies", grid.energies), ("wks_sigma", grid.sigma),
        ("wks_edges", edges(wks.bounds, wks.bins)), ("wks_weight", weight("wks")),
        ("slope_edges", edges(slope.bounds, slope.bins)), ("slope_weight", weight("slope")),
        ("dna_count", _standard(spec, DnaBlock).count), ("dna_weight", weight("dna")),
        ("d2_edges", edges(d2.bounds, d2.bins)), ("d2_pairs", d2.pairs),
        ("d2_seed", d2.seed), ("d2_weight", weight("d2")),
        ("spread_weight", 0.0),
        ("d1_edges", edges(d1.bounds, d1.bins)), ("d1_weight", weight("d1")),
        ("evened_distances", True), ("evened_areas", True),
        ("normal_neighbours", spec.normal_neighbours),
        ("normal_edges", edges((0.0, 1.0), normals.bins)),
        ("normal_weight", weight("normals")), ("symmetry_weight", weight("symmetry")),
        ("axis_edges", edges((0.0, 2.5), 16)), ("axis_weight", 0.0),
        ("ring_weight", weight("ring")), ("ring_shells", ring.shells),
        ("caps_bins", caps.bins), ("caps_depth", caps.depth), ("caps_weight", weight("caps")),
        ("caps_sharpness", caps.sharpness),
        ("runs_longest", spec.runs_longest),
        ("local_weight", weight("local")), ("local_encoding", local.encoding),
        ("local_vocabulary", local.vocabulary), ("local_columns", local.columns),
        ("local_neighbours", local.neighbours),
        ("family", spec.family),
    ]
    layout = {kind.name for kind in _LAYOUT_BLOCKS}
    extra = tuple((block, w) for block, w in spec.parts if block.name not in layout)
    if extra:
        fields.append(("extra", extra))
    text = "DescriptorSpec(" + ", ".join(f"{name}={value!r}" for name, value in fields) + ")"
    vocabulary = load_vocabulary(local.vocabulary).digest() if weight("local") > 0 else ""
    # The libraries' versions only here: they would crowd the readable part, and
    # GET /v1/stats shows them (engine_libraries).
    libraries = sorted(engine_library_versions().items())
    rest = (settings.laplacian, settings.normalisation, settings.max_points,
            settings.sample_seed, settings.outlier_filter, settings.outlier_ratio,
            settings.cutoff, vocabulary, libraries)
    return "(" + ", ".join([text, *map(repr, rest)]) + ")"


#: The blocks of the layout, whose parameters ``canonical_text`` names one by one.
_LAYOUT_BLOCKS: tuple[type[Block], ...] = (
    HksBlock, WksBlock, SlopeBlock, DnaBlock, D2Block, D1Block, NormalsBlock, SymmetryBlock,
    RingBlock, CapsBlock, LocalBlock,
)

_Kind = TypeVar("_Kind", bound=Block)


def _standard(spec: DescriptorSpec, kind: type[_Kind]) -> _Kind:
    """The block of the layout called ``kind.name``, checked to be a ``kind``."""
    block = spec.block(kind.name)
    if not isinstance(block, kind):
        raise TypeError(f"block {kind.name!r} is a {type(block).__name__}, not a "
                        f"{kind.__name__}")
    return block
