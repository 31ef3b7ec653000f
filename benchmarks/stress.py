"""Busy processes beside a live benchmark, as a robot's computer runs SLAM, planning and
drivers beside the forecaster.

``--stress torch``: one other PyTorch process multiplying 512 x 512 matrices on PyTorch's
default threads (as a detector would); ``--stress N``: N processes spinning on one core each
(pure Python). They run until stopped (``with stressed(kind): ...``).
"""

from __future__ import annotations

import multiprocessing
import time
from collections.abc import Iterator
from contextlib import contextmanager


def _spin() -> None:
    while True:
        pass


def _matmuls() -> None:
    import torch

    a = torch.randn(512, 512)
    while True:
        a = torch.tanh(a @ a)


def stress_kind(text: str) -> str:
    """``torch``, or a whole number of busy processes (argparse type)."""
    if text == "torch" or (text.isdigit() and int(text) >= 0):
        return text
    raise ValueError(f"--stress takes 'torch' or a number of processes, not {text!r}")


@contextmanager
def stressed(kind: str | None) -> Iterator[str]:
    """Run the busy processes of ``kind`` (None or "0": none) while the block runs; yields a
    description for the report."""
    if not kind or kind == "0":
        yield "quiet"
        return
    context = multiprocessing.get_context("spawn")
    targets = [_matmuls] if kind == "torch" else [_spin] * int(kind)
    processes = [context.Process(target=t, daemon=True) for t in targets]
    for process in processes:
        process.start()
    time.sleep(3.0)  # each child imports the main script (and torch) before it loads a core
    try:
        yield (
            "beside a PyTorch process multiplying matrices"
            if kind == "torch"
            else f"beside {kind} busy processes"
        )
    finally:
        for process in processes:
            process.terminate()
        for process in processes:
            process.join()
