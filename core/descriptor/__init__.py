"""One search vector per model from its per-point signature and its points.

The descriptor is an ordered union of blocks (``DescriptorSpec``, composed like
scikit-learn's ``FeatureUnion``): each block measures the model (a ``Sample``: its signature,
areas, eigenvalues and points, and what several blocks share, derived once), is multiplied by
its weight, and the blocks are joined; the whole vector has unit norm, so L2 distance and
inner product rank alike in FAISS.

Most blocks are histograms with fixed bin edges, each point weighted by the area it stands
for (so that a dense patch of a scan does not outvote a sparse one), square-rooted
(Hellinger embedding: L2 distance between them is the Hellinger distance) and scaled to unit
norm before weighting.

The spectral blocks (``blocks.spectral``) are intrinsic, unchanged by bending: histograms of
log HKS per heat time, of log WKS per energy and of the WKS slope between neighbouring
energies, and a normalised eigenvalue channel. They cannot tell a bent sheet from a flat
one, nor a U profile from a Z profile with the same web and flanges; the extrinsic blocks
can. They describe the embedding from ``core.extrinsic``'s measurements, all invariant to
rotation, translation and scale, of the part with each long run of one cross-section
shortened (a kind made in many lengths looks alike, and its head counts):

- ``d2`` and ``d1`` (Osada et al. 2002): the distances between random area-weighted point
  pairs and from the centroid, each over its mean, on the part with its principal spreads
  evened;
- ``normals``: per principal axis, a histogram of ``|cos|`` between the normals and it;
- ``symmetry``: the distances of the surface from its seven mirror, half-turn and inversion
  images in its principal frame (raw, not unit: how symmetric, not only in which way);
- ``ring``: the angular spectrum about the first and third principal axes per soft shell of
  distance from the axis (what repeats around a turned part: teeth, bolt holes, hex heads);
- ``caps``: each end's depth-radius profile along the first and third principal axes, in
  the part's own radius (a head, a countersink, a hub or a thread's end, whatever the
  length), each axis averaged over the directions it could take when the shape does not
  define it.

D2, D1, normals and symmetry weigh each point by the area it has on the evened surface
(``core.extrinsic.evened_areas``), so a long part's body does not outweigh its ends.

The ``local`` block (``core.local_features``) pools every point's whole signature, and for
the rigid family its surface variation, over a vocabulary shipped in ``core/data``: the
detail (a screw's head, a flange's hub, a gear's teeth) that per-scale histograms drown.

Layout: ``[hks | wks | slope | dna | d2 | d1 | normals | symmetry | ring | caps | local]``,
blocks of weight 0 left out (``BLOCK_WEIGHTS`` names the setting that weighs each). A block
is one module in ``blocks/``: a ``Block`` with its ``name``, ``width`` and ``measure``,
composed in by ``DescriptorSpec.with_block``; one of the layout also has its place in
``DescriptorSpec.from_settings`` and a weight in ``DescriptorSettings``.

Everything that changes the vector is written into ``descriptor_version``
(``DescriptorSpec.version``): vectors with different versions must never be compared.
"""

from core.descriptor._block import Block, area_histograms, unit_block
from core.descriptor._sample import Sample
from core.descriptor._signature import SignatureGrid
from core.descriptor._union import BLOCK_WEIGHTS, DescriptorSpec
from core.descriptor._version import (
    ENGINE_LIBRARIES,
    VERSION_LENGTH,
    engine_library_versions,
)
from core.descriptor.blocks import (
    VOCABULARY_DIR,
    caps_block,
    distance_distribution,
    load_vocabulary,
    ring_block,
)

__all__ = [
    "BLOCK_WEIGHTS",
    "ENGINE_LIBRARIES",
    "VERSION_LENGTH",
    "VOCABULARY_DIR",
    "Block",
    "DescriptorSpec",
    "Sample",
    "SignatureGrid",
    "area_histograms",
    "caps_block",
    "distance_distribution",
    "engine_library_versions",
    "load_vocabulary",
    "ring_block",
    "unit_block",
]
