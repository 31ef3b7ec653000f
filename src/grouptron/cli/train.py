"""``grouptron train``: train a model on one split or dataset (the work:
:func:`grouptron.workflows.train.train_run`)."""

from __future__ import annotations

import argparse

from grouptron.config import ExperimentConfig
from grouptron.workflows.train import TrainRequest, make_experiment, parse_setting, train_run

__all__ = ["cmd_train", "experiment_from_args", "parse_setting", "request_from_args"]


def request_from_args(args: argparse.Namespace) -> TrainRequest:
    """The flags of ``grouptron train`` (and ``config show``) as a request."""
    return TrainRequest(
        split=args.split,
        dataset=getattr(args, "dataset", None),
        model=args.model,
        epochs=args.epochs,
        out=getattr(args, "out", None),
        resume=getattr(args, "resume", False),
        init_from=args.init_from,
        config=args.config,
        settings=tuple(args.set or ()),
        seed=args.seed,
        batch_size=args.batch_size,
        lr=args.lr,
        threads=args.threads,
        precision=args.precision,
        device=args.device,
        derivatives=args.derivatives,
        on_gap=args.on_gap,
        data_dir=getattr(args, "data_dir", None),
        use_cache=not getattr(args, "no_cache", False),
    )


def experiment_from_args(
    args: argparse.Namespace, *, choose_precision: bool = True
) -> ExperimentConfig:
    """The run's configuration that the flags describe (see :func:`make_experiment`)."""
    return make_experiment(request_from_args(args), choose_precision=choose_precision)


def cmd_train(args: argparse.Namespace) -> int:
    """``grouptron train``: train a model, then plot its training curves and say which
    checkpoint was chosen."""
    # Progress by default: a bar on a terminal, else a line every half minute.
    quiet = getattr(args, "quiet", False)
    result = train_run(request_from_args(args), progress=not quiet, announce=True)
    if result.summary:
        print(result.summary)
    return 0
