"""Site adaptation curve: FDE over constant velocity's on a later part of a site's recordings
after fine-tuning on its first N minutes (``grouptron adapt``'s recipe: 300 optimiser steps,
batch 64, learning rate 3e-4, fp32).

Usage:
    python benchmarks/site_adaptation.py [--checkpoint NAME] [--seeds 0,1] [--threads 1]
        [--sites corridor,bookstore]

Sites of the out-of-domain development set (``$GROUPTRON_OOD``, default ../shared/data/ood):
- corridor: the three HERMES corridor runs in order (uo-145, uo-180, uo-300, about 3.9 min);
  held out: the last 1.35 min (uo-300); adapted on N = 0.5, 1, 2 min.
- bookstore: the Stanford Drone bookstore_0, _1, _2 videos in order (about 23.6 min); held out:
  the last 8 min (bookstore_2); adapted on N = 2, 5, 15 min.
- nexus (``--sites nexus``; Stanford Drone videos outside the development and confirmation
  sets, for the 30-minute point): nexus_1, 2, 3, 4, 7, 8, 9 in order (about 34.9 min); held
  out: the last 4 min (in nexus_9); adapted on N = 2, 5, 15, 30 min.
Every N of a site is scored on the same held-out samples: the checkpoint before, adapted, and
constant velocity, with the paired FDE difference (after minus before, 95% interval over time
steps). The adapted runs go to a temporary folder and are never shipped.
"""

from __future__ import annotations

import argparse
import os
import tempfile
from dataclasses import dataclass
from pathlib import Path

from grouptron.data.formats.layout import RecordingFormat
from grouptron.data.formats.track_files import TrackSource
from grouptron.inference.checkpoints import DEFAULT_CHECKPOINT
from grouptron.workflows.adapt import AdaptRequest, adapt

REPO = Path(__file__).resolve().parents[1]


@dataclass(frozen=True)
class Site:
    files: tuple[str, ...]
    recording: RecordingFormat
    holdout_minutes: float
    minutes: tuple[float, ...]


SITES = {
    "corridor": Site(
        tuple(
            f"hermes_corridor_1d/{n}.txt"
            for n in ("uo-145-240-240", "uo-180-180-180", "uo-300-300-300")
        ),
        RecordingFormat(columns=("id", "frame", "x", "y", "z"), fps=16, units="cm"),
        1.35,
        (0.5, 1.0, 2.0),
    ),
    "nexus": Site(
        tuple(f"trajnet_sdd/nexus_{i}.txt" for i in (1, 2, 3, 4, 7, 8, 9)),
        RecordingFormat(columns=("frame", "id", "x", "y"), fps=30),
        4.0,
        (2.0, 5.0, 15.0, 30.0),
    ),
    "bookstore": Site(
        tuple(f"trajnet_sdd/bookstore_{i}.txt" for i in range(3)),
        RecordingFormat(columns=("frame", "id", "x", "y"), fps=30),
        8.0,
        (2.0, 5.0, 15.0),
    ),
}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--checkpoint", default=DEFAULT_CHECKPOINT)
    parser.add_argument("--seeds", default="0,1", help="adaptation seeds (order of the steps)")
    parser.add_argument("--sites", default="corridor,bookstore")
    parser.add_argument("--threads", type=int, default=1)
    args = parser.parse_args()
    ood = Path(os.environ.get("GROUPTRON_OOD") or REPO.parent / "shared" / "data" / "ood")
    print(f"checkpoint {args.checkpoint}; seeds {args.seeds}\n")
    print(
        "| site | adapted on (min) | seed | held-out samples | FDE before m | FDE adapted m "
        "| CV m | before / CV | adapted / CV | adapted minus before, m [95%] |"
    )
    print("|---|---|---|---|---|---|---|---|---|---|")
    with tempfile.TemporaryDirectory() as scratch:
        for name in args.sites.split(","):
            site = SITES[name]
            for minutes in site.minutes:
                for seed in (int(s) for s in args.seeds.split(",")):
                    request = AdaptRequest(
                        files=tuple(ood / f for f in site.files),
                        layout=TrackSource.from_format("", site.recording),
                        minutes=minutes, holdout_minutes=site.holdout_minutes,
                        checkpoint=args.checkpoint, out=f"{scratch}/{name}-{minutes}-{seed}",
                        seed=seed, threads=args.threads,
                    )  # fmt: skip
                    result = adapt(request)
                    before, after, cv = result.rows
                    gain = result.gain
                    assert gain is not None
                    print(
                        f"| {name} | {minutes:g} | {seed} | {before.samples} | {before.fde:.3f} | "
                        f"{after.fde:.3f} | {cv.fde:.3f} | {before.fde / cv.fde:.3f} | "
                        f"{after.fde / cv.fde:.3f} | {gain.mean:+.3f} [{gain.low:+.3f}, "
                        f"{gain.high:+.3f}] |",
                        flush=True,
                    )


if __name__ == "__main__":
    main()
