"""The signature grid: the heat times and wave energies every model of a database shares.

Grids are database-wide (log-spaced times for unit-area shapes, log-energies for the WKS),
never derived from one model's own spectrum, so that descriptors of different models are
comparable.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from core.settings import DescriptorSettings
from core.signatures import heat_kernel_signature, wave_kernel_signature

__all__ = ["SignatureGrid"]


@dataclass(frozen=True)
class SignatureGrid:
    """Heat times and wave energies.

    Attributes
    ----------
    times : tuple of float
        Heat times of the HKS.
    scaled : bool
        The HKS divided by the heat trace.
    energies : tuple of float
        Log-energies of the WKS (empty: no WKS).
    sigma : float
        Width of the WKS filters, in log-energy.
    """

    times: tuple[float, ...]
    scaled: bool
    energies: tuple[float, ...]
    sigma: float

    @classmethod
    def from_settings(cls, settings: DescriptorSettings) -> SignatureGrid:
        energies = np.linspace(*settings.wks_range, settings.wks_energies)
        # Aubry et al. tie the filter width to the energy step; on a coarse 16-step grid
        # two steps keep neighbouring energies distinct (7 steps smeared the whole spectrum
        # into one bump and made every model's WKS alike).
        step = float(energies[1] - energies[0]) if energies.size > 1 else 1.0
        return cls(
            times=tuple(settings.hks_times),
            scaled=settings.hks_scaled,
            energies=tuple(energies.tolist()),
            sigma=settings.wks_sigma * step,
        )

    def signature(self, eigenvalues: np.ndarray, eigenvectors: np.ndarray) -> np.ndarray:
        """Per-point signature, ``(n, len(times) + len(energies)) float``: log HKS per time,
        then log WKS per energy, from ``eigenvalues : (k,)`` and M-orthonormal
        ``eigenvectors : (n, k)``.

        With unit total area and M-orthonormal eigenvectors, the scaled HKS and the WKS
        (normalised by its filter sum) both have area-weighted mean 1 at every scale, so their
        logs are centred near 0 and one set of bin edges fits every scale.
        """
        hks = heat_kernel_signature(
            eigenvalues, eigenvectors, np.asarray(self.times), scaled=self.scaled
        )
        columns = [np.log(np.maximum(hks, 1e-300))]
        if self.energies:
            wks = wave_kernel_signature(
                eigenvalues, eigenvectors, np.asarray(self.energies), self.sigma
            )
            columns.append(np.log(np.maximum(wks, 1e-300)))
        return np.hstack(columns)
