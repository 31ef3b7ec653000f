"""How often the live session's reused-id rule fires on real tracks, where no id is reused.

Usage:
    python benchmarks/track_faults.py [FILES ...]
        (default: ../shared/data/eth_ucy/*/*.txt and ../shared/data/crowds/*/*.txt)

Every pair of consecutive sightings of a person (``frame id x y`` files on the 0.4 s grid, 10
frames a step) is judged by ``inference.track_faults.unreachable`` with the velocity of the
step before, as a frame-numbered session judges it: once as shipped (the acceleration bound
only after a gap of more than ``REAPPEARANCE_GAP_S``, the 15 m/s bound always), and once with
the acceleration bound applied to every step. Prints, per dataset folder, the pairs judged and
the share that restart under each.
"""

from __future__ import annotations

import argparse
from collections import defaultdict
from pathlib import Path

import numpy as np

from grouptron.inference import track_faults
from grouptron.inference.track_faults import unreachable

SHARED = Path(__file__).resolve().parents[1].parent / "shared" / "data"


def judged(path: Path, every_step: bool) -> tuple[int, int]:
    """(pairs judged, pairs that restart) in one file."""
    rows = np.loadtxt(path)
    rows = rows[np.lexsort((rows[:, 0], rows[:, 1]))]
    same = rows[1:, 1] == rows[:-1, 1]
    now, last = rows[1:][same], rows[:-1][same]
    index = np.flatnonzero(same)  # each pair's earlier sighting, in rows
    before = rows[np.maximum(index - 1, 0)]
    known = (before[:, 1] == last[:, 1]) & (last[:, 0] - before[:, 0] == 10)
    velocity = (last[:, 2:4] - before[:, 2:4]) / 0.4
    velocity[~known] = np.nan
    gap_s = (now[:, 0] - last[:, 0]) * 0.04
    shipped = track_faults.REAPPEARANCE_GAP_S
    track_faults.REAPPEARANCE_GAP_S = 0.0 if every_step else shipped
    try:
        restarts = unreachable(gap_s, last[:, 2:4], velocity, now[:, 2:4])
    finally:
        track_faults.REAPPEARANCE_GAP_S = shipped
    return len(restarts), int(restarts.sum())


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("files", nargs="*", type=Path)
    args = parser.parse_args()
    files = args.files or sorted(SHARED.glob("eth_ucy/*/*.txt")) + sorted(
        SHARED.glob("crowds/*/*.txt")
    )
    totals: dict[str, list[int]] = defaultdict(lambda: [0, 0, 0])
    for path in files:
        pairs, shipped = judged(path, every_step=False)
        _, every = judged(path, every_step=True)
        total = totals[f"{path.parent.parent.name}/{path.parent.name}"]
        total[0] += pairs
        total[1] += shipped
        total[2] += every
    print(f"{'folder':>22} {'pairs':>9} {'restarts as shipped':>20} {'bound at every step':>20}")
    for folder, (pairs, shipped, every) in sorted(totals.items()):
        print(
            f"{folder:>22} {pairs:>9} {shipped:>10} ({100 * shipped / pairs:.3f}%)"
            f" {every:>10} ({100 * every / pairs:.2f}%)"
        )


if __name__ == "__main__":
    main()
