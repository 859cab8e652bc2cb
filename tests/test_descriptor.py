"""Histogram descriptor: layout, weighting, normalisation and versioning."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from core.descriptor import DescriptorSpec, area_histograms
from core.settings import CutoffSettings, DescriptorSettings, EngineSettings


def test_area_histograms_weight_by_area_and_keep_outliers() -> None:
    values = np.array([[-10.0], [0.1], [0.2], [10.0]])
    areas = np.array([1.0, 1.0, 6.0, 2.0])
    histograms = area_histograms(values, areas, np.array([0.0, 0.5, 1.0]))
    # -10 falls into the first bin, 10 into the last: nothing is lost.
    np.testing.assert_allclose(histograms, [[0.8, 0.2]])


def test_area_histograms_rows_sum_to_one() -> None:
    rng = np.random.default_rng(0)
    histograms = area_histograms(rng.normal(size=(100, 4)), rng.random(100), np.linspace(-2, 2, 9))
    np.testing.assert_allclose(histograms.sum(axis=1), 1.0)


def fake_spectrum(n_points: int = 400, k: int = 60, seed: int = 0):
    rng = np.random.default_rng(seed)
    eigenvectors, _ = np.linalg.qr(rng.standard_normal((n_points, k)))
    eigenvectors *= np.sqrt(n_points)  # M-orthonormal for areas 1 / n_points
    eigenvalues = 4 * np.pi * np.arange(k, dtype=np.float64)
    return eigenvalues, eigenvectors, np.full(n_points, 1.0 / n_points)


@pytest.mark.parametrize(
    "settings",
    [
        DescriptorSettings(),
        DescriptorSettings(wks_energies=0, dna_count=0),
        DescriptorSettings(wks_energies=8),
        DescriptorSettings(wks_energies=8, dna_count=20, wks_slope_weight=0.0),
        DescriptorSettings(bins=16, hks_times=(0.01, 0.1)),
        DescriptorSettings(hks_weight=0.0, wks_weight=0.0),
    ],
)
def test_descriptor_is_unit_norm_float32_of_the_announced_length(settings) -> None:
    spec = DescriptorSpec.from_settings(settings)
    eigenvalues, eigenvectors, areas = fake_spectrum()
    signature = spec.signature(eigenvalues, eigenvectors)
    descriptor = spec.histogram(signature, areas, eigenvalues)
    # Blocks: HKS (times x bins), WKS (energies x bins), WKS slope ((energies - 1) x bins),
    # eigenvalue channel (dna_count); a block with weight 0 is left out.
    energies = settings.wks_energies
    length = (
        (len(settings.hks_times) * settings.bins if settings.hks_weight > 0 else 0)
        + (energies * settings.bins if energies and settings.wks_weight > 0 else 0)
        + ((energies - 1) * settings.bins if energies > 1 and settings.wks_slope_weight else 0)
        + settings.dna_count
    )
    assert descriptor.dtype == np.float32
    assert descriptor.shape == (length,)
    assert np.linalg.norm(descriptor) == pytest.approx(1.0, abs=1e-6)
    assert np.all(np.isfinite(descriptor))


def test_eigenvalue_channel_skips_zero_modes_of_multi_part_models() -> None:
    spec = DescriptorSpec.from_settings(DescriptorSettings(dna_count=10))
    one_body = 4 * np.pi * np.arange(0, 40, dtype=np.float64) * 1.1
    two_bodies = np.concatenate([[0.0], one_body])  # a second zero: two components
    np.testing.assert_allclose(
        spec._eigenvalue_channel(one_body), spec._eigenvalue_channel(two_bodies)
    )


def test_wks_block_uses_its_own_log_range_centred_near_zero() -> None:
    # M-orthonormal eigenvectors on unit area: the WKS has area-weighted mean 1 at every
    # energy, so log WKS must sit near 0, inside the default bin range.
    spec = DescriptorSpec.from_settings(DescriptorSettings(wks_range=(2.0, 6.0)))
    eigenvalues, eigenvectors, areas = fake_spectrum()
    log_wks = spec.signature(eigenvalues, eigenvectors)[:, len(spec.times) :]
    assert abs(np.median(log_wks)) < 1.0
    low, high = spec.wks_edges[0], spec.wks_edges[-1]
    assert np.mean((log_wks > low) & (log_wks < high)) > 0.95


def test_a_descriptor_without_blocks_is_refused() -> None:
    with pytest.raises(ValueError, match="no block"):
        DescriptorSettings(hks_weight=0.0, wks_energies=0, dna_count=0).validate()


def test_version_changes_with_every_parameter_that_changes_the_vector() -> None:
    base = EngineSettings()
    spec = DescriptorSpec.from_settings(base.descriptor)
    variants = [
        replace(base, laplacian="spcl"),
        replace(base, max_points=base.max_points * 2),
        replace(base, normalisation="bbox"),
        replace(base, outlier_filter=False),
        replace(base, outlier_ratio=base.outlier_ratio + 1.0),
        replace(base, cutoff=CutoffSettings(mode="fixed", n=300)),
        replace(base, cutoff=CutoffSettings(xi=1e-12)),
    ]
    versions = {spec.version(base)} | {spec.version(v) for v in variants}
    for descriptor in (
        DescriptorSettings(bins=16),
        DescriptorSettings(hks_scaled=False),
        DescriptorSettings(wks_energies=8),
        DescriptorSettings(hks_times=(1e-3, 1e-2, 0.05)),
        DescriptorSettings(hks_times=(1e-3, 1e-2, 0.06)),
        DescriptorSettings(hks_weight=0.3),
        DescriptorSettings(wks_sigma=3.0),
        DescriptorSettings(wks_slope_weight=0.5),
        DescriptorSettings(wks_log_range=(-2.0, 2.0)),
        DescriptorSettings(dna_weight=0.3),
    ):
        versions.add(DescriptorSpec.from_settings(descriptor).version(base))
    assert len(versions) == 18
    assert spec.version(base) == DescriptorSpec.from_settings(base.descriptor).version(base)
