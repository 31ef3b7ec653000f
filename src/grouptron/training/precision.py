"""Which arithmetic a training run uses: fp32, or the decoder under bfloat16 autocast.

bf16 autocast pays only where the hardware computes bf16 natively (CUDA, or x86 CPUs with
AVX-512 BF16 or AMX): there one training step took 57% of its fp32 time, while on an AVX2-only
CPU bf16 is emulated and about 10x slower (``benchmarks/RESULTS.md``). ``auto`` therefore
decides at run time, from the device and the CPU's feature flags, never from assumptions.
"""

from __future__ import annotations

from pathlib import Path
from typing import Literal

import torch

from grouptron.errors import GrouptronError

Precision = Literal["auto", "fp32", "bf16"]
PRECISIONS: tuple[Precision, ...] = ("auto", "fp32", "bf16")
NATIVE_BF16_CPU_FLAGS = frozenset({"avx512_bf16", "amx_bf16"})


def cpu_flags(cpuinfo: str | None = None) -> frozenset[str]:
    """The CPU feature flags of ``/proc/cpuinfo`` (empty where it cannot be read)."""
    if cpuinfo is None:
        try:
            cpuinfo = Path("/proc/cpuinfo").read_text()
        except OSError:
            return frozenset()
    for line in cpuinfo.splitlines():
        if line.startswith("flags"):
            return frozenset(line.split(":", 1)[1].split())
    return frozenset()


def native_bf16(device: torch.device, flags: frozenset[str] | None = None) -> bool:
    """True where bf16 arithmetic runs natively on ``device``."""
    if device.type == "cuda":
        return bool(torch.cuda.is_bf16_supported())
    return bool(NATIVE_BF16_CPU_FLAGS & (cpu_flags() if flags is None else flags))


def resolve_precision(
    requested: str, device: torch.device, flags: frozenset[str] | None = None
) -> bool:
    """Whether to train under bf16 autocast: ``auto`` where native, else as requested."""
    if requested not in PRECISIONS:
        raise GrouptronError(f"precision must be one of {', '.join(PRECISIONS)}, not {requested!r}")
    if requested == "auto":
        return native_bf16(device, flags)
    return requested == "bf16"


def precision_name(bf16: bool) -> str:
    return "bf16" if bf16 else "fp32"
