"""Which arithmetic a training run uses: fp32, or the decoder under bfloat16 autocast.

bf16 autocast pays only on some hardware: on a 2-core AMD EPYC with AVX-512 BF16 a training step
took 57% of its fp32 time, on an AVX2-only CPU bf16 is emulated and about 10x slower, and on an
Intel Xeon that announces AVX-512 BF16 (without AMX) it was 1.37x *slower* than fp32
(``benchmarks/precision.py``, ``benchmarks/RESULTS.md``). The CPU flags are therefore not
enough: on a CPU with native bf16 flags ``auto`` also times the decoder's recurrence in both
precisions (a few seconds, paired timings that a busy machine does not flip) and takes bf16
only where it is clearly faster; ``grouptron train`` prints the measurement with its choice.
"""

from __future__ import annotations

import functools
import logging
import statistics
import time
from pathlib import Path
from typing import Literal

import torch

from grouptron import constants
from grouptron.errors import GrouptronError

log = logging.getLogger(__name__)

Precision = Literal["auto", "fp32", "bf16"]
PRECISIONS: tuple[Precision, ...] = constants.PRECISIONS
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


BF16_MIN_SPEEDUP = 1.15
"""``auto`` takes bf16 on a CPU only when the timed recurrence runs at least this much faster."""


TIMED_ROUNDS = 5
"""Paired timings (fp32 then bf16, back to back) after one warm-up round: the median of their
ratios, so that other work on a busy machine, which slows both runs of a pair, does not flip
the choice the way one slow run in a minimum can."""


@functools.cache
def bf16_speedup_cpu(threads: int) -> float:
    """fp32 time / bf16 time of a decoder-shaped GRU recurrence (6,400 rows, hidden 128, 12
    steps, forward and backward) on this CPU with ``threads`` threads, the median of
    :data:`TIMED_ROUNDS` paired ratios; above 1: bf16 faster."""
    previous = torch.get_num_threads()
    torch.set_num_threads(threads)
    try:
        generator = torch.Generator().manual_seed(0)
        cell = torch.nn.GRUCell(130, 128)
        inputs = torch.randn(12, 6400, 130, generator=generator)

        def run(bf16: bool) -> float:
            start = time.perf_counter()
            with torch.autocast("cpu", dtype=torch.bfloat16, enabled=bf16):
                h = torch.zeros(6400, 128)
                for x in inputs:
                    h = cell(x, h)
                loss = h.float().square().mean()
            loss.backward()
            return time.perf_counter() - start

        run(False), run(True)  # warm both paths up
        ratios = [run(False) / run(True) for _ in range(TIMED_ROUNDS)]
        return float(statistics.median(ratios))
    finally:
        torch.set_num_threads(previous)


def resolve_precision(
    requested: str,
    device: torch.device,
    flags: frozenset[str] | None = None,
    threads: int = 2,
) -> bool:
    """Whether to train under bf16 autocast: as requested, or for ``auto`` on CUDA where the
    GPU supports bf16 and on a CPU where it is native and measured to be faster."""
    if requested not in PRECISIONS:
        raise GrouptronError(f"precision must be one of {', '.join(PRECISIONS)}, not {requested!r}")
    if requested != "auto":
        return requested == "bf16"
    if not native_bf16(device, flags):
        return False
    if device.type == "cuda":
        return True
    speedup = bf16_speedup_cpu(threads)
    log.info("bf16 autocast runs the decoder recurrence %.2fx as fast as fp32 here", speedup)
    return speedup >= BF16_MIN_SPEEDUP


def precision_name(bf16: bool) -> str:
    """The name of a precision: ``bf16`` or ``fp32``."""
    return "bf16" if bf16 else "fp32"
