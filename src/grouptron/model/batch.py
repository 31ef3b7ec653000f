"""The typed batch the model consumes, gathered from a :class:`SampleSet` by index."""

from __future__ import annotations

from dataclasses import dataclass, fields

import numpy as np
import torch

from grouptron.config import DataConfig
from grouptron.data.samples import SampleSet
from grouptron.geometry import rotate_xy_pairs, rotation_matrix


@dataclass(frozen=True)
class Batch:
    """Model inputs and targets of ``B`` samples (``T`` history, ``H`` future steps).

    Attributes:
        hist_st: (B, T, 6) standardised ego history, 0 where masked.
        hist_mask: (B, T) True where the ego was observed; masked steps lead (left padding).
        nbr_sum_st: (B, T, 6) summed standardised neighbour states.
        edge_scale: (B,) ``min(1, sum of edge weights)``, the edge encoding's scale.
        fut_rel_m: (B, H, 2) future positions relative to the current one, metres.
        fut_st: (B, H, 2) the same divided by the position scale (future encoder input).
    """

    hist_st: torch.Tensor
    hist_mask: torch.Tensor
    nbr_sum_st: torch.Tensor
    edge_scale: torch.Tensor
    fut_rel_m: torch.Tensor
    fut_st: torch.Tensor

    def __len__(self) -> int:
        return self.hist_st.shape[0]

    @property
    def state_now_st(self) -> torch.Tensor:
        """(B, 6) the standardised state at ``t`` (position part is 0)."""
        return self.hist_st[:, -1]

    def to(self, device: torch.device | str) -> Batch:
        return Batch(**{f.name: getattr(self, f.name).to(device) for f in fields(self)})


def make_batch(
    samples: SampleSet,
    index: np.ndarray,
    config: DataConfig,
    rotation_rad: np.ndarray | None = None,
) -> Batch:
    """Gather samples ``index`` into a batch, optionally rotating each sample's scene.

    Args:
        samples: the sample set.
        index: (B,) sample indices.
        config: the data protocol (for the position scale).
        rotation_rad: (B,) angles; rotating all (x, y) pairs equals rotating the scene.
    """
    hist_st = samples.hist_st[index]
    nbr_sum_st = samples.nbr_sum_st[index]
    fut_rel_m = samples.fut_rel_m[index]
    if rotation_rad is not None:
        rotation = rotation_matrix(rotation_rad)[:, None]  # (B, 1, 2, 2)
        hist_st = rotate_xy_pairs(hist_st, rotation).astype(np.float32)
        nbr_sum_st = rotate_xy_pairs(nbr_sum_st, rotation).astype(np.float32)
        fut_rel_m = rotate_xy_pairs(fut_rel_m, rotation).astype(np.float32)
    fut = torch.from_numpy(np.ascontiguousarray(fut_rel_m))
    return Batch(
        hist_st=torch.from_numpy(np.ascontiguousarray(hist_st)),
        hist_mask=torch.from_numpy(samples.hist_mask[index]),
        nbr_sum_st=torch.from_numpy(np.ascontiguousarray(nbr_sum_st)),
        edge_scale=torch.from_numpy(np.minimum(samples.edge_weight_sum[index], 1.0)),
        fut_rel_m=fut,
        fut_st=fut / config.position_scale_m,
    )
