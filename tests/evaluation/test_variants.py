"""The evaluation's named variants (``core.evaluation.variants``): every one is a valid
engine setting, the defaults and the scan variants are among them, and the kept reference
layouts are what they say."""

from __future__ import annotations

from dataclasses import replace

import pytest

from core.descriptor import BLOCK_WEIGHTS, DescriptorSpec
from core.evaluation.variants import (
    DEFAULT_VARIANTS,
    NAIVE_DESCRIPTOR,
    SCAN_VARIANTS,
    SPECTRAL_DESCRIPTOR,
    SS11_DESCRIPTOR,
    VARIANTS,
    resolve_variants,
)
from core.settings import DESCRIPTOR_FAMILIES, DescriptorSettings


def test_every_variant_is_valid_and_the_defaults_are_named_ones() -> None:
    assert resolve_variants(list(VARIANTS)) == VARIANTS
    assert set(DEFAULT_VARIANTS) <= set(VARIANTS)
    assert set(SCAN_VARIANTS) <= set(VARIANTS)
    assert resolve_variants(None) == {name: VARIANTS[name] for name in DEFAULT_VARIANTS}
    with pytest.raises(ValueError, match="unknown variants"):
        resolve_variants(["no-such-variant"])


def test_the_reference_layouts_and_the_block_ablations() -> None:
    default = DescriptorSettings()
    assert VARIANTS["default"].descriptor == default
    assert VARIANTS["ss11"].descriptor == SS11_DESCRIPTOR == replace(default, runs_longest=None)
    assert VARIANTS["bendable"].descriptor == DESCRIPTOR_FAMILIES["bendable"]
    assert VARIANTS["spectral"].descriptor == SPECTRAL_DESCRIPTOR
    assert VARIANTS["baseline"].descriptor == NAIVE_DESCRIPTOR
    # One variant without each block measured on the points, and one without the local block.
    for name, weight in BLOCK_WEIGHTS.items():
        if weight in DescriptorSettings.EXTRINSIC_WEIGHTS or name == "local":
            ablation = VARIANTS[f"default-no-{weight.removesuffix('_weight')}"]
            spec = DescriptorSpec.from_settings(ablation.descriptor)
            assert name not in spec.widths
            assert set(spec.widths) == set(BLOCK_WEIGHTS) - {name}
