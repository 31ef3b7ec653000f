"""Where tensors run: a device that exists here, or one clear line saying why not."""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager

import torch

from grouptron.errors import GrouptronError


def available_device(value: str | torch.device) -> torch.device:
    """``value`` as a torch device that this machine has (cpu, cuda[:i] or mps)."""
    if not isinstance(value, str | torch.device):
        raise GrouptronError(f"device must be a name such as 'cpu' or 'cuda', not {value!r}")
    try:
        device = torch.device(value)
    except RuntimeError:
        raise GrouptronError(f"not a torch device: {value!r}") from None
    if device.type == "cuda":
        if not torch.cuda.is_available():
            build = "a CPU-only build" if torch.version.cuda is None else "no GPU is visible"
            raise GrouptronError(
                f"{value}: CUDA is not available here (this PyTorch is {build}); use cpu"
            )
        if device.index is not None and device.index >= torch.cuda.device_count():
            raise GrouptronError(f"{value}: only {torch.cuda.device_count()} CUDA device(s) here")
    elif device.type == "mps" and not torch.backends.mps.is_available():
        raise GrouptronError(f"{value}: Apple's MPS is not available here; use cpu")
    elif device.type not in ("cpu", "cuda", "mps"):
        raise GrouptronError(f"{value}: grouptron runs on cpu, cuda or mps devices")
    return device


@contextmanager
def torch_threads(count: int | None) -> Iterator[None]:
    """PyTorch's intra-op threads set to ``count`` for the block and restored after (None:
    left as they are), so that one component's choice does not leak into the process."""
    if count is None or count == torch.get_num_threads():
        yield
        return
    before = torch.get_num_threads()
    torch.set_num_threads(count)
    try:
        yield
    finally:
        torch.set_num_threads(before)
