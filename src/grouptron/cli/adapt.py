"""``grouptron adapt``: fine-tune a checkpoint on a site's own recordings (the work:
:func:`grouptron.workflows.adapt.adapt`)."""

from __future__ import annotations

import argparse
from pathlib import Path

from grouptron.cli.common import show_progress, track_file
from grouptron.workflows.adapt import AdaptRequest, adapt


def cmd_adapt(args: argparse.Namespace) -> int:
    """Adapt, then print the held-out scores (or where the adapted weights are)."""
    request = AdaptRequest(
        files=tuple(Path(f) for f in args.tracks),
        layout=track_file(args, path=""),
        minutes=args.minutes,
        holdout_minutes=args.holdout_minutes,
        checkpoint=args.checkpoint,
        out=args.out,
        steps=args.steps,
        lr=args.lr,
        seed=args.seed,
        threads=args.threads,
        on_gap=args.on_gap,
    )
    print(adapt(request, progress=show_progress(args)).table())
    return 0
