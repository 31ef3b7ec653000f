"""``grouptron report``: the paper's tables from a folder of checkpoints (the work:
:func:`grouptron.workflows.report.benchmark_report`)."""

from __future__ import annotations

import argparse
from pathlib import Path

import torch

from grouptron.cli.common import show_progress
from grouptron.cli.options import REPORT_CHECKPOINTS, eval_modes, parse_splits
from grouptron.constants import SPLITS
from grouptron.data.datasets.custom import read_dataset
from grouptron.data.datasets.locate import score_cache_dir
from grouptron.errors import GrouptronError
from grouptron.evaluation.metrics import scoring
from grouptron.geometry import DERIVATIVE_SCHEMES
from grouptron.io import (
    refuse_folder,
    write_text_atomically,
)
from grouptron.model.factory import MODEL_NAMES
from grouptron.reporting.datasets import dataset_json, dataset_markdown, dataset_report
from grouptron.reporting.report import ReportSettings
from grouptron.reporting.tables import report_markdown
from grouptron.workflows.report import ReportRequest, benchmark_report


def _report_command(args: argparse.Namespace, modes: tuple[str, ...]) -> str:
    """The canonical command line that regenerates this report (written into it)."""
    parts = ["grouptron report", f"--derivatives {args.derivatives}", f"--mode {','.join(modes)}"]
    if args.nll_max_samples != ReportSettings().nll_max_samples:
        parts.append(f"--nll-max-samples {args.nll_max_samples}")
    if args.checkpoints != REPORT_CHECKPOINTS:
        parts.append(f"--checkpoints {args.checkpoints}")
    if args.models:
        parts.append(f"--models {args.models}")
    if args.seeds:
        parts.append(f"--seeds {args.seeds}")
    if args.seed:
        parts.append(f"--seed {args.seed}")
    if args.split:
        parts.append(f"--split {args.split}")
    if args.metrics:
        parts.append(f"--metrics {','.join(args.metrics)}")
    if args.diagnostics:
        parts.append("--diagnostics")
    if args.out_of_domain:
        parts.append(f"--out-of-domain {' '.join(args.out_of_domain)}")
    if args.out:
        parts.append(f"--out {args.out}")
    return " ".join(parts)


def _checkpoint_filters(
    models: str | None, seeds: str | None
) -> tuple[tuple[str, ...], tuple[int, ...] | None]:
    """``--models`` and ``--seeds`` as names and integers, checked (None: every one)."""
    names = MODEL_NAMES if models is None else tuple(m.strip() for m in models.split(","))
    unknown = [m for m in names if m not in MODEL_NAMES]
    if unknown or not names:
        raise GrouptronError(
            f"--models: unknown model {', '.join(map(repr, unknown)) or repr(models)}; choose "
            f"from {', '.join(MODEL_NAMES)}"
        )
    if seeds is None:
        return names, None
    try:
        return names, tuple(int(s) for s in seeds.split(","))
    except ValueError:
        raise GrouptronError(
            f"--seeds must be integers separated by commas, not {seeds!r}"
        ) from None


def _score_cache(args: argparse.Namespace) -> Path | None:
    """Where scores are kept between reports; None with ``--no-cache``."""
    return None if args.no_cache else score_cache_dir()


def _emit(args: argparse.Namespace, text: str) -> int:
    """Write the report to --out (atomically) or standard output."""
    if args.out:
        write_text_atomically(Path(args.out), text)
        print(f"wrote {args.out}")
    else:
        print(text, end="")
    return 0


def cmd_report_dataset(args: argparse.Namespace) -> int:
    """``report --dataset``: every checkpoint trained on a dataset of one's own."""
    dataset = read_dataset(args.dataset)
    torch.set_num_threads(args.threads)
    modes = tuple(m for m in eval_modes(args.mode) if m != "nll")
    report = dataset_report(
        dataset,
        Path(args.checkpoints),
        modes=modes,
        seed=args.seed,
        use_cache=not args.no_cache,
        score_cache=_score_cache(args),
    )
    json_text = args.format == "json"
    text = dataset_json(report) + "\n" if json_text else dataset_markdown(dataset, report)
    return _emit(args, text)


def _splits(value: str | None) -> tuple[str, ...]:
    """``--split``: comma-separated splits (or ``all``), each once; None: all five."""
    if value is None:
        return SPLITS
    return tuple(dict.fromkeys(s for part in value.split(",") for s in parse_splits(part.strip())))


def _report_request(args: argparse.Namespace) -> ReportRequest:
    """The benchmark report's options as a request (``--models``, ``--seeds`` and ``--mode``
    checked)."""
    modes = eval_modes(args.mode)
    models, seeds = _checkpoint_filters(args.models, args.seeds)
    schemes = DERIVATIVE_SCHEMES if args.derivatives == "both" else (args.derivatives,)
    settings = ReportSettings(
        modes=modes,
        seed=args.seed,
        nll_max_samples=args.nll_max_samples,
        use_cache=not args.no_cache,
        score_cache=_score_cache(args),
        diagnostics=args.diagnostics,
    )
    return ReportRequest(
        Path(args.checkpoints),
        schemes,
        settings,
        models,
        seeds,
        tuple(args.out_of_domain or ()),
        args.data_dir,
        progress=show_progress(args),
        announce=not args.quiet,
        splits=_splits(args.split),
        metrics=args.metrics,
    )


def cmd_report(args: argparse.Namespace) -> int:
    """``grouptron report``: score a folder of checkpoints on every test set (Markdown or JSON)."""
    if args.out:
        refuse_folder(Path(args.out))  # before the work, not after it
    if args.dataset:
        if args.out_of_domain or args.models or args.seeds or args.split:
            raise GrouptronError(
                "--out-of-domain, --models, --seeds and --split go with the benchmark report, "
                "not --dataset"
            )
        with scoring(args.metrics):
            return cmd_report_dataset(args)
    request = _report_request(args)
    torch.set_num_threads(args.threads)
    with scoring(args.metrics):  # registered while the tables are written too: their labels
        report = benchmark_report(request)
        if args.format == "json":
            return _emit(args, report.to_json() + "\n")
        command = _report_command(args, request.settings.modes)
        return _emit(args, report_markdown(report, request.schemes, command))
