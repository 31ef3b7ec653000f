"""What the ETH/UCY benchmark holds: scenes, tracks and samples per part of each split, and
univ's UNIV-N subsets (``grouptron data stats``).

    from grouptron.workflows.data import data_stats
    print(data_stats(["eth", "univ"]).table())
"""

from __future__ import annotations

import dataclasses
import json
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

from grouptron.config import DataConfig
from grouptron.data.datasets.dataset import load_part
from grouptron.data.datasets.locate import resolve_data_dir
from grouptron.data.datasets.subsets import UNIV_N_DEFINITIONS, UnivN, univ_n_mask

DEFAULT_UNIV_N = (40, 45, 50)
"""The paper's UNIV-N thresholds (pedestrians at the forecast step)."""
_UNIV_N_LABELS = {
    "predicted": "at steps with >= N predicted agents (the paper's)",
    "present": "at steps with >= N pedestrians present",
}


@dataclass(frozen=True)
class SplitStats:
    """One split's counts.

    Attributes:
        scenes: scenes of its three parts.
        tracks: tracks of those scenes.
        train_samples, val_samples, test_samples: samples (8 observed, 12 future steps).
        test_max_pedestrians_per_step: the most pedestrians present at one step of a test scene.
        univ_n: univ only: {definition: {N: test samples of UNIV-N}} (``UNIV_N_DEFINITIONS``).
    """

    scenes: int
    tracks: int
    train_samples: int
    val_samples: int
    test_samples: int
    test_max_pedestrians_per_step: int
    univ_n: dict[str, dict[str, int]] | None = None

    def to_dict(self) -> dict[str, object]:
        """The counts by name (``univ_n`` only where there is one)."""
        values = dataclasses.asdict(self)
        if self.univ_n is None:
            del values["univ_n"]
        return values


@dataclass(frozen=True)
class DataStats:
    """Every split's counts, and which data they came from."""

    data_dir: Path
    derivatives: str
    splits: dict[str, SplitStats]

    def to_json(self) -> str:
        """``{split: counts}`` as indented JSON."""
        return json.dumps({s: stats.to_dict() for s, stats in self.splits.items()}, indent=2)

    def table(self) -> str:
        """A table of the counts per split, then univ's UNIV-N counts (where univ is one)."""
        header = (
            f"{'split':<6} {'scenes':>6} {'tracks':>7} {'train':>8} {'val':>7} {'test':>7} "
            f"{'max peds/step (test)':>21}"
        )
        lines = [
            f"ETH/UCY samples ({self.derivatives} derivatives) from {self.data_dir}",
            header,
            "-" * len(header),
        ]
        for split, e in self.splits.items():
            lines.append(
                f"{split:<6} {e.scenes:>6} {e.tracks:>7} {e.train_samples:>8} "
                f"{e.val_samples:>7} {e.test_samples:>7} {e.test_max_pedestrians_per_step:>21}"
            )
        univ_n = self.splits["univ"].univ_n if "univ" in self.splits else None
        if univ_n is not None:
            for definition, label in _UNIV_N_LABELS.items():
                per_n = ", ".join(f"N={n}: {c}" for n, c in univ_n[definition].items())
                lines.append(f"UNIV-N test samples {label}: {per_n}")
        return "\n".join(lines)


def data_stats(
    splits: Sequence[str],
    config: DataConfig | None = None,
    *,
    data_dir: str | Path | None = None,
    univ_n: Sequence[int] = DEFAULT_UNIV_N,
    use_cache: bool = True,
) -> DataStats:
    """Scenes, tracks and samples of each of ``splits`` (its train, val and test parts) under
    ``config``'s data settings (None: ``DataConfig()``, the papers'), from ``data_dir`` (None:
    ``$GROUPTRON_DATA``, else the download cache); for univ the test samples of UNIV-N for
    each N of ``univ_n``."""
    config = config or DataConfig()
    folder = resolve_data_dir(data_dir)
    stats: dict[str, SplitStats] = {}
    for split in splits:
        parts = {
            part: load_part(folder, split, part, config, use_cache=use_cache)
            for part in ("train", "val", "test")
        }
        scenes = [s for p in parts.values() for s in p.scenes]
        test = parts["test"].samples
        counts: dict[str, dict[str, int]] | None = None
        if split == "univ":
            counts = {
                definition: {
                    str(n): int(univ_n_mask(test, UnivN(n, definition)).sum()) for n in univ_n
                }
                for definition in UNIV_N_DEFINITIONS
            }
        stats[split] = SplitStats(
            scenes=len(scenes),
            tracks=sum(s.num_tracks for s in scenes),
            train_samples=len(parts["train"].samples),
            val_samples=len(parts["val"].samples),
            test_samples=len(test),
            test_max_pedestrians_per_step=max(s.max_present for s in parts["test"].scenes),
            univ_n=counts,
        )
    return DataStats(folder, config.derivatives, stats)
