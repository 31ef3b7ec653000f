"""Data-parallel training across processes (PyTorch DDP, launched by ``torchrun``).

Every process walks the same shuffled order and draws the same augmentation angles and noise;
each global batch is split by stride (process ``r`` takes rows ``r, r + W, ...``, the layout of
``torch.utils.data.DistributedSampler``). Batch-level statistics of the loss (means, the
mutual-information term, the clamped KL) are summed across processes with
:func:`global_mean`, so every process computes the loss of the whole global batch and the
averaged gradients equal single-process training on that batch up to float rounding.
"""

from __future__ import annotations

import datetime
import os
from dataclasses import dataclass

import numpy as np
import torch
import torch.distributed as dist

from grouptron.errors import GrouptronError


@dataclass(frozen=True)
class Cluster:
    """This process's place among ``world_size`` training processes."""

    rank: int = 0
    world_size: int = 1
    local_rank: int = 0

    @property
    def is_main(self) -> bool:
        """The process that writes checkpoints, metrics and progress."""
        return self.rank == 0

    @property
    def distributed(self) -> bool:
        """Whether training runs in more than one process."""
        return self.world_size > 1

    def shard(self, size: int) -> np.ndarray:
        """Positions of this process's rows in a global batch of ``size`` rows."""
        return np.arange(self.rank, size, self.world_size)

    def barrier(self) -> None:
        """Wait for every process (``dist.barrier``); nothing to wait for in a single process."""
        if self.distributed:
            dist.barrier()


SINGLE = Cluster()


def launched_by_torchrun() -> bool:
    """Whether torchrun started several processes (``WORLD_SIZE`` above 1)."""
    return int(os.environ.get("WORLD_SIZE", "1")) > 1


def start(device: torch.device) -> Cluster:
    """Join the process group described by torchrun's environment (gloo on CPU, NCCL on CUDA).

    Without torchrun's variables this is a single process and nothing is started.
    """
    if not launched_by_torchrun():
        return SINGLE
    try:
        rank, world, local = (int(os.environ[k]) for k in ("RANK", "WORLD_SIZE", "LOCAL_RANK"))
    except (KeyError, ValueError) as exc:
        raise GrouptronError(f"incomplete torchrun environment: {exc}") from None
    backend = "nccl" if device.type == "cuda" else "gloo"
    if not dist.is_initialized():
        dist.init_process_group(backend, timeout=datetime.timedelta(minutes=30))
    return Cluster(rank, world, local)


def stop(cluster: Cluster) -> None:
    """Leave the process group of a distributed run (nothing for a single process)."""
    if cluster.distributed and dist.is_initialized():
        dist.destroy_process_group()


def global_mean(values: torch.Tensor, cluster: Cluster, global_count: int) -> torch.Tensor:
    """Mean over the global batch of per-sample ``values`` (b, ...) held by this process.

    The value is the mean over every process's rows; the gradient flows only into this
    process's rows (the others' sum enters as a constant), so after DDP averages gradients
    over W processes, scaling the loss by W gives the whole batch's gradient.
    """
    if not cluster.distributed:
        return values.mean(dim=0)
    local = values.sum(dim=0)
    total = local.detach().clone()
    dist.all_reduce(total)
    return (local + (total - local.detach())) / global_count
