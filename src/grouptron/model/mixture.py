"""A forecast's distribution: per person a Gaussian mixture over positions at every step."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True, eq=False)  # arrays have no single truth value: compare by identity
class Mixture:
    """M weighted Gaussian components per person, each with a mean and covariance per step.

    Attributes:
        log_weights: (N, M) log weights of the components (normalised over the M).
        means: (N, M, H, 2) position means, metres.
        covariances: (N, M, H, 2, 2) their covariance matrices, m^2.
    """

    log_weights: np.ndarray
    means: np.ndarray
    covariances: np.ndarray

    def __len__(self) -> int:
        return len(self.log_weights)

    @property
    def components(self) -> int:
        """M, the components per person."""
        return int(self.log_weights.shape[1])

    def rows(self, index: np.ndarray | slice) -> Mixture:
        """The mixtures of the people ``index`` selects, in its order."""
        return Mixture(self.log_weights[index], self.means[index], self.covariances[index])

    def moved(self, origin: np.ndarray) -> Mixture:
        """The mixtures with every mean moved by the (N, 2) ``origin`` (from relative to the
        person's position now to the input's coordinates)."""
        return Mixture(self.log_weights, self.means + origin[:, None, None, :], self.covariances)

    @staticmethod
    def concatenate(parts: list[Mixture]) -> Mixture:
        """One mixture of the people of every part, in order (all parts of one M and H)."""
        return Mixture(
            np.concatenate([p.log_weights for p in parts]),
            np.concatenate([p.means for p in parts]),
            np.concatenate([p.covariances for p in parts]),
        )

    @staticmethod
    def empty(components: int, horizon: int) -> Mixture:
        """The mixtures of nobody, with M = ``components`` and H = ``horizon``."""
        M, H = components, horizon
        return Mixture(np.zeros((0, M)), np.zeros((0, M, H, 2)), np.zeros((0, M, H, 2, 2)))
