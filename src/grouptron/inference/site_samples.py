"""A session's tracks as training samples of its site: each person at each step becomes a
sample once its whole future has been seen (``history_steps + horizon_steps`` steps later).

The log keeps raw observations (a time in seconds, an id, a position) at whatever rate they
came, and resamples a window of them onto the model's step when samples are asked for, the way
a recording is read (``data.formats.recording.resample``). A live session and a file's replay
feed the same log, so that they learn from the same samples.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from grouptron.config import DataConfig
from grouptron.data.formats.layout import Recording, RecordingFormat
from grouptron.data.formats.recording import resample
from grouptron.data.prepare.samples import SampleSet, concatenate_samples, scene_samples
from grouptron.data.prepare.scene import build_scene

# Steps before a sample's first observed one that its states read (backward derivatives).
_LOOKBACK_STEPS = 2


@dataclass(frozen=True)
class Completed:
    """Samples whose future was completed in a window of time.

    Attributes:
        samples: (S,) the samples, in the order the scene makes them.
        done_s: (S,) when each one's last future position was seen (seconds).
    """

    samples: SampleSet
    done_s: np.ndarray


class SiteLog:
    """Observations of one site, kept as long as a sample not yet completed may read them."""

    def __init__(self, data: DataConfig, max_gap_s: float) -> None:
        self.data = data
        self._format = RecordingFormat(
            columns=("t", "id", "x", "y"), check_speed=False, max_gap_s=max_gap_s
        )
        self._parts: list[np.ndarray] = []  # (R_i, 4) rows t_s, id, x, y
        self.last_s: float | None = None

    def add(self, t_s: float, ids: np.ndarray, xy_m: np.ndarray) -> None:
        """The (N,) integer ``ids`` seen at ``t_s`` at (N, 2) positions in metres."""
        if len(ids):
            self._parts.append(np.column_stack([np.full(len(ids), t_s), ids, xy_m]))
        self.last_s = t_s

    def completed(self, after_s: float, until_s: float) -> Completed | None:
        """The samples whose future ended in ``(after_s, until_s]``, from the observations up to
        ``until_s`` only; observations no later sample can read are dropped."""
        data = self.data
        span_s = (data.history_steps + data.horizon_steps + _LOOKBACK_STEPS) * data.dt_s
        rows = np.concatenate(self._parts) if self._parts else np.zeros((0, 4))
        window = rows[(rows[:, 0] >= after_s - span_s - 1e-9) & (rows[:, 0] <= until_s + 1e-9)]
        later = rows[rows[:, 0] >= until_s - span_s - 1e-9]  # what the next window reads
        self._parts = [later] if len(later) else []
        if len(np.unique(window[:, 0])) < data.horizon_steps + 2:
            return None
        return self._samples(window, after_s)

    def _samples(self, window: np.ndarray, after_s: float) -> Completed | None:
        data = self.data
        recording = Recording(
            Path("site"),
            window[:, 1].astype(np.int64),
            window[:, 0],
            window[:, 2:4],
            np.arange(len(window)),
        )
        # People who leave and come back split their tracks, as a live session does, without
        # a warning at every round.
        table = resample(recording, self._format, data.dt_s, on_gap="split", warn_on_gap=False)
        origin_s = float(window[:, 0].min())
        scene = build_scene(table, data, name="site")
        samples = scene_samples(scene, data, data.min_history_train)
        step_s = origin_s + (scene.first_frame + samples.step * scene.frames_per_step) * data.dt_s
        done_s = step_s + data.horizon_steps * data.dt_s
        keep = done_s > after_s + 1e-9
        if not keep.any():
            return None
        return Completed(samples.subset(keep), done_s[keep])


def joined(parts: list[Completed]) -> Completed:
    """Completed samples of several windows as one (in the order given)."""
    samples = concatenate_samples([p.samples for p in parts])
    return Completed(samples, np.concatenate([p.done_s for p in parts]))
