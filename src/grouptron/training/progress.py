"""How a training epoch shows its progress: a bar on a terminal, else a line now and then (a log
file or a notebook gets no carriage returns), each with the loss, samples per second and the
time left."""

from __future__ import annotations

import sys
import time
from typing import TextIO

from tqdm import tqdm

FIRST_LINE_S = 5.0
"""Seconds into an epoch before its first progress line (a run says it is alive early)."""
LINE_EVERY_S = 30.0
"""Seconds between the progress lines that follow."""


def duration(seconds: float) -> str:
    """``"45 s"``, ``"3 min 20 s"`` or ``"1 h 05 min"``."""
    seconds = max(0.0, seconds)
    if seconds < 60:
        return f"{seconds:.0f} s"
    minutes, rest = divmod(round(seconds), 60)
    if minutes < 60:
        return f"{minutes} min {rest:02d} s"
    hours, minutes = divmod(minutes, 60)
    return f"{hours} h {minutes:02d} min"


class EpochProgress:
    """One epoch's progress: :meth:`step` after every optimiser step, :meth:`close` at its end.

    Args:
        epoch: the epoch (1-based) and ``epochs`` the run's length.
        steps: optimiser steps in the epoch.
        shown: False shows nothing (``--quiet``, the other processes of a distributed run).
        out: where lines go (None: standard output); a terminal gets a bar instead.
    """

    def __init__(
        self, epoch: int, epochs: int, steps: int, *, shown: bool, out: TextIO | None = None
    ) -> None:
        self.epoch, self.epochs, self.steps = epoch, epochs, steps
        self.out = out if out is not None else sys.stdout
        bar_wanted = shown and sys.stderr.isatty()
        self.lines = shown and not bar_wanted
        self.bar = tqdm(total=steps, desc=f"epoch {epoch}", unit="it", disable=not bar_wanted)
        self.started = time.perf_counter()
        self.next_line_s = FIRST_LINE_S
        self.done, self.seen = 0, 0

    def step(self, samples: int, loss: float) -> None:
        """One optimiser step of ``samples`` samples with loss ``loss`` done."""
        self.done += 1
        self.seen += samples
        elapsed = time.perf_counter() - self.started
        rate = self.seen / elapsed if elapsed > 0 else 0.0
        self.bar.update(1)
        self.bar.set_postfix(loss=f"{loss:.3f}", samples_s=f"{rate:.0f}")
        if self.lines and elapsed >= self.next_line_s:
            self.next_line_s = elapsed + LINE_EVERY_S
            print(self.line(loss, elapsed), file=self.out, flush=True)

    def line(self, loss: float, elapsed_s: float) -> str:
        """``epoch 1/2: step 120/560, loss 12.3, 410 samples/s, about 1 min 05 s left in
        this epoch (the whole run: about 9 min 40 s before validation)``."""
        per_step = elapsed_s / max(self.done, 1)
        epoch_left = per_step * (self.steps - self.done)
        run_left = epoch_left + per_step * self.steps * (self.epochs - self.epoch)
        rate = self.seen / elapsed_s if elapsed_s > 0 else 0.0
        text = (
            f"epoch {self.epoch}/{self.epochs}: step {self.done}/{self.steps}, loss {loss:.4g}, "
            f"{rate:.0f} samples/s, about {duration(epoch_left)} left in this epoch"
        )
        if self.epoch < self.epochs:
            text += f" ({duration(run_left)} in all, validation not counted)"
        return text

    def close(self) -> None:
        """Close the bar."""
        self.bar.close()
