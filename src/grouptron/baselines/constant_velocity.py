"""Constant velocity: repeat the last observed displacement for every future step."""

from __future__ import annotations

import numpy as np


def constant_velocity(hist_rel_m: np.ndarray, horizon_steps: int) -> np.ndarray:
    """Extrapolate ``x_t + k (x_t - x_{t-1})`` for ``k = 1..H``.

    Args:
        hist_rel_m: (B, T, 2) observed positions relative to the current one (the last row is
            the current position, the row before it ``t-1``).
        horizon_steps: H.

    Returns:
        (B, H, 2) predicted positions relative to the current position.
    """
    step_m = hist_rel_m[:, -1] - hist_rel_m[:, -2]  # (B, 2)
    k = np.arange(1, horizon_steps + 1, dtype=hist_rel_m.dtype)
    return hist_rel_m[:, -1:, :] + k[None, :, None] * step_m[:, None, :]
