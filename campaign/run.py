"""The training campaign behind the shipped checkpoints: a queue of runs, resumable.

Usage:
    python campaign/run.py [--only NAME_PART] [--dry-run | --status] [--out campaign/runs]
                           [--variant [MODEL] | --look-ahead | --baselines] [--threads N]
                           [--device cpu|cuda]

Every run trains with ``grouptron train`` into ``OUT/<name>`` for 100 epochs (the reference
recipe) and is skipped once finished (its ``selection.json`` exists). A run that was stopped
resumes from its ``last.safetensors``, so the script can be killed at any time and started
again, later or on another machine.

Precision: every invocation asks for what ``--precision auto`` chooses on this machine (bf16
only where it is native and measured faster; ``grouptron.training.precision``; on a GPU bf16
where it supports it); a run that changes machines or devices records each epoch's precision
and device. ``--bf16-ab`` adds the precision A/B: bf16
copies (``-bf16``) of the three univ Trajectron++ ``backward`` seeds, for a machine where bf16
pays (on the Intel Xeon the campaign started on it was 1.37x slower than fp32).

Order: univ ``backward`` (three seeds of both models), univ ``central`` seed 0, the other
splits (every shipped checkpoint), then the other univ ``central`` seeds.
``central`` runs of seed 0 continue the shipped checkpoints (copied from ``checkpoints/``, same
configuration, future encoder scale included); other seeds of ``central`` univ use the same
configuration so that seeds differ in the seed alone. ``backward`` runs start from scratch on
strictly causal inputs.

``--variant [MODEL]`` queues a named group variant instead (default ``grouptron-robust``; also
``grouptron-robust-residual``), all from scratch with its preset: univ ``central`` seed 0,
``backward`` of the other four splits (the causal targets need all five), univ ``central``
seeds 1-2, ``central`` of the other four splits, then seeds 1-2 of zara1 ``backward`` with
Trajectron++'s of the same seeds (seed spread on the second split). Their univ ``backward``
seeds are the screening runs of ``screen.py --only robust`` (``robust-residual``), named for
shipping with ``ship.py``.

``--baselines`` queues the learned baselines of other families (Social-STGCNN and the small
trajectory Transformer, ``grouptron.baselines``) on the five splits, strictly causal
(``backward``), seed 0, for ``BASELINE_EPOCHS`` epochs.

``--look-ahead`` queues the diagnostic of where the paper's gain comes from: both paper models on
univ in the papers' protocol, seeds 0-2, then Grouptron on eth (seed 0), each its shipped run's
configuration plus the reference implementation's neighbour window (``LOOK_AHEAD_WINDOW``).
Live forecasting refuses them.

The paper models' queue needs nothing newer than the package code its runs started with (the
variant's preset is imported only for ``--variant``), so ``PYTHONPATH=<checkout of that
commit>/src python campaign/run.py`` keeps those runs on their own code. ``--status`` prints
every queued run's progress and an estimate of the time left.

Workers: several copies of the script may work through one queue at once on one machine (one
per core). Each takes the first unfinished run that no other worker holds: a worker holds a
run by a kernel lock (``flock``) on the run's folder itself, which the training process
inherits, so the lock ends when both have exited; a killed worker never leaves a stale lock,
and there is no lock file to clean up or commit. (Across machines sharing ``--out`` over a
network file system the kernel lock is not reliable: give each machine its own ``--only``.)
"""

from __future__ import annotations

import argparse
import dataclasses
import fcntl
import json
import os
import shutil
import statistics
import subprocess
import sys
import time
from pathlib import Path

import torch

from grouptron.config import experiment_from_stored, save_config
from grouptron.training.precision import resolve_precision

REPO = Path(__file__).resolve().parents[1]
PAUSED = REPO / "campaign" / "paused"
"""Unfinished runs' resumable state, committed once when their training pauses (README,
"Training state"); the commit that ships or abandons a run deletes its folder here."""
NOT_PAUSED = ("curves.png",)
"""Run files a paused run does not need: redrawn when it finishes."""
WAITING = ("best.safetensors", "config.json", "campaign-config.json", "README.md",
           "metrics.jsonl", "selection.json")  # fmt: skip
"""What a finished diagnostic run keeps while its study waits to be scored: its result, never
its training state (``last.safetensors``, ``candidates/``) nor what is derived (``metrics.csv``
repeats ``metrics.jsonl``)."""
EPOCHS = 100
SPLITS = ("univ", "eth", "hotel", "zara1", "zara2")
MODELS = ("trajectron++", "grouptron")
BASELINE_EPOCHS = {"social-stgcnn": 30, "transformer": 20}
"""The learned baselines of other families (``grouptron.baselines``) by their model names,
and their epochs: their validation error levels off after about 10; an epoch of the
Transformer costs three of Social-STGCNN's, so it gets fewer and all ten runs fit into about
an hour and a half of 2 cores."""
BASELINES = tuple(BASELINE_EPOCHS)


@dataclasses.dataclass(frozen=True)
class Run:
    model: str
    split: str
    protocol: str
    seed: int = 0
    bf16_only: bool = False
    look_ahead: bool = False
    """Neighbours chosen over the reference implementation's window (LOOK_AHEAD_WINDOW): a
    diagnostic of where the paper's gain comes from, never a forecaster."""

    @property
    def name(self) -> str:
        name = f"{self.model}-{self.split}-{self.protocol}"
        name += f"-s{self.seed}" if self.seed else ""
        name += "-look-ahead" if self.look_ahead else ""
        return name + ("-bf16" if self.bf16_only else "")

    @property
    def epochs(self) -> int:
        return BASELINE_EPOCHS.get(self.model, EPOCHS)

    @property
    def diagnostic(self) -> bool:
        """Never shipped: its finished result waits in ``campaign/paused/`` (weights only)
        until its whole study is scored, then that commit deletes it."""
        return self.look_ahead

    @property
    def shipped_run(self) -> Path:
        """The shipped checkpoint of the same model, split, protocol and seed."""
        suffix = f"-seed{self.seed}" if self.seed else ""
        return REPO / "checkpoints" / f"{self.model}-{self.split}-{self.protocol}{suffix}"

    @property
    def shipped_source(self) -> Path | None:
        """The shipped run this one continues (seed-0 central runs), when that folder still
        holds its training state; shipped folders no longer do (campaign/README.md)."""
        continued = self.model in MODELS and self.protocol == "central" and self.seed == 0
        source = REPO / "checkpoints" / f"{self.model}-{self.split}-central"
        if continued and not self.bf16_only and not self.look_ahead:
            return source if (source / "last.safetensors").exists() else None
        return None


def variant_models() -> tuple[str, ...]:
    """The named group variants, the first the default of ``--variant``; imported here, not at
    the top, so that the paper models' queue runs with package code older than the presets
    (``--variant`` needs the current code)."""
    from grouptron.presets import GROUP_RESIDUAL_MODEL, VARIANT_MODEL

    return VARIANT_MODEL, GROUP_RESIDUAL_MODEL


def variant_queue(variant: str) -> list[Run]:
    runs = [Run(variant, "univ", "central")]
    runs += [Run(variant, split, "backward") for split in SPLITS[1:]]
    runs += [Run(variant, "univ", "central", seed) for seed in (1, 2)]
    runs += [Run(variant, split, "central") for split in SPLITS[1:]]
    # Seed spread on zara1, the second screening split: the variant against Trajectron++.
    return runs + [
        Run(model, "zara1", "backward", seed) for seed in (1, 2) for model in (variant, MODELS[0])
    ]


LOOK_AHEAD_WINDOW = (-2, 4)
"""Steps before and after t over which the reference implementation's scene graph chooses
neighbours (``data.neighbour_window_steps``): it reads 1.6 s of the future."""


def look_ahead_queue() -> list[Run]:
    """The paper's two models on univ in the papers' protocol with the reference's neighbour
    window, three seeds, each its shipped run's configuration plus the window. The reference
    builds one scene graph for both models, so Trajectron++ (the control) gets it too. Paired
    by seed so that each finished pair can be compared at once. Then Grouptron on eth, seed 0:
    whether the window also moves its eth row (it did not, so eth needs no control run)."""
    models = ("grouptron", "trajectron++")
    univ = [Run(m, "univ", "central", seed, look_ahead=True) for seed in (0, 1, 2) for m in models]
    return [*univ, Run("grouptron", "eth", "central", 0, look_ahead=True)]


def baselines_queue() -> list[Run]:
    """Both learned baselines on the five splits, strictly causal (``backward``), seed 0."""
    return [Run(model, split, "backward") for model in BASELINES for split in SPLITS]


def queue(bf16_ab: bool = False) -> list[Run]:
    runs = [Run("trajectron++", "univ", "backward", seed) for seed in (0, 1, 2)]
    if bf16_ab:
        runs += [Run("trajectron++", "univ", "backward", s, bf16_only=True) for s in (0, 1, 2)]
    runs += [Run("grouptron", "univ", "backward", seed) for seed in (0, 1, 2)]
    runs += [Run(model, "univ", "central") for model in MODELS]
    for split in SPLITS[1:]:
        runs += [
            Run(model, split, protocol) for protocol in ("backward", "central") for model in MODELS
        ]
    # The other central univ seeds last: every shipped checkpoint comes first.
    runs += [Run(model, "univ", "central", seed) for seed in (1, 2) for model in MODELS]
    return runs


def finished(folder: Path) -> bool:
    return (folder / "selection.json").exists()


def _lock(folder: Path) -> int | None:
    """A read-only descriptor of ``folder`` holding its exclusive lock, or None when another
    process holds it."""
    descriptor = os.open(folder, os.O_RDONLY | os.O_DIRECTORY)
    try:
        fcntl.flock(descriptor, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except BlockingIOError:
        os.close(descriptor)
        return None
    return descriptor


def claim(folder: Path, retry_s: float = 1.0) -> int | None:
    """A descriptor holding the run's lock, or None when another worker holds it. One retry
    after ``retry_s``: ``--status`` takes the lock for an instant to see whether it is free."""
    folder.mkdir(parents=True, exist_ok=True)
    descriptor = _lock(folder)
    if descriptor is None and retry_s > 0:
        time.sleep(retry_s)
        descriptor = _lock(folder)
    return descriptor


def held(folder: Path) -> bool:
    """Whether some worker is training the run now (it holds the run's lock)."""
    if not folder.is_dir():
        return False
    descriptor = _lock(folder)
    if descriptor is None:
        return True
    os.close(descriptor)
    return False


def progress(folder: Path) -> tuple[int, float | None]:
    """(epochs done, median wall seconds per epoch over the last 10) of a run from its
    ``metrics.jsonl``: the recent epochs, since a run that moved between machines or devices
    runs at the speed of the one it is on now."""
    path = folder / "metrics.jsonl"
    records = [json.loads(line) for line in path.read_text().splitlines()] if path.exists() else []
    seconds = [r["epoch_seconds"] for r in records if "epoch_seconds" in r]
    epochs = max((int(r["epoch"]) for r in records), default=0)
    return epochs, statistics.median(seconds[-10:]) if seconds else None


def validation_summary(folder: Path) -> str:
    """``", validation ML FDE 1.012 m (epoch 48) = 0.966 x constant velocity's 1.048 m"``: the
    final choice on the whole validation set against constant velocity on the same samples."""
    chosen = json.loads((folder / "selection.json").read_text())
    model, baseline = chosen.get("full_val_ml_fde"), chosen.get("full_val_cv_fde")
    if model is None or not baseline:
        return ""
    return (
        f", validation ML FDE {model:.3f} m (epoch {chosen['selected_epoch']}) = "
        f"{model / baseline:.3f} x constant velocity's {baseline:.3f} m"
    )


def status(runs: list[Run], out: Path) -> list[str]:
    """One line per queued run (finished with its validation score against constant velocity,
    epochs done and hours left, or not started) and the hours left of the runs that have
    started (a run not started has no epoch time yet)."""
    lines, hours_left = [], 0.0
    for run in runs:
        folder = out / run.name
        epochs, seconds = progress(folder)
        if finished(folder):
            state = "finished" + validation_summary(folder)
        elif epochs == 0:
            state = "starting (training now)" if held(folder) else "not started"
        else:
            state = f"epoch {epochs} of {run.epochs}" + (" (training now)" if held(folder) else "")
            if seconds is not None:
                left = (run.epochs - epochs) * seconds / 3600
                hours_left += left
                state += f", about {left:.1f} h left at {seconds:.0f} s per epoch"
        lines.append(f"{run.name}: {state}")
    lines.append(f"started runs: about {hours_left:.1f} h left at one run at a time")
    return lines


def command(
    run: Run, folder: Path, precision: str, threads: int = 1, device: str = "cpu"
) -> list[str]:
    argv = [
        sys.executable,
        "-m",
        "grouptron",
        "train",
        "--split",
        run.split,
        "--model",
        run.model,
        "--out",
        str(folder),
        "--epochs",
        str(run.epochs),
        "--precision",
        precision,
        "--threads",
        str(threads),
        "--quiet",
        *(["--device", device] if device != "cpu" else []),
    ]
    if (folder / "last.safetensors").exists():
        return [*argv, "--resume"]
    if run.shipped_source is not None:  # dry run: prepare() has not copied it
        return [*argv, "--resume"]
    if run.look_ahead:
        # The shipped run of the same seed, from scratch, with the reference's window.
        stored = experiment_from_stored(json.loads((run.shipped_run / "config.json").read_text()))
        config = dataclasses.replace(
            stored,
            data=dataclasses.replace(stored.data, neighbour_window_steps=LOOK_AHEAD_WINDOW),
            train=dataclasses.replace(stored.train, seed=run.seed, epochs=EPOCHS),
        )
        folder.mkdir(parents=True, exist_ok=True)
        save_config(config, folder / "campaign-config.json")
        return [*argv, "--config", str(folder / "campaign-config.json")]
    if run.model in MODELS and run.seed:
        # Same configuration as the shipped seed-0 run it is compared with, another seed.
        shipped = REPO / "checkpoints" / f"{run.model}-{run.split}-{run.protocol}"
        stored = experiment_from_stored(json.loads((shipped / "config.json").read_text()))
        config = dataclasses.replace(
            stored, train=dataclasses.replace(stored.train, seed=run.seed, epochs=EPOCHS)
        )
        folder.mkdir(parents=True, exist_ok=True)
        save_config(config, folder / "campaign-config.json")
        return [*argv, "--config", str(folder / "campaign-config.json")]
    return [*argv, "--derivatives", run.protocol, "--seed", str(run.seed)]


def snapshot(runs: list[Run], out: Path, paused: Path = PAUSED) -> tuple[list[str], int]:
    """Copy each started, unfinished run's resumable state to ``paused/<run>`` (replacing an
    older copy) and refuse finished runs: a finished run is shipped or dropped, never kept as
    training state. A finished diagnostic run (never shipped) keeps its result alone there
    until its study is scored. Returns one line per run and the number of runs copied."""
    lines, copied = [], 0
    for run in runs:
        folder = out / run.name
        if held(folder):  # its files would be of different epochs
            lines.append(f"{run.name}: refused, being trained (stop its worker first)")
        elif finished(folder) and run.diagnostic:
            target = paused / run.name
            shutil.rmtree(target, ignore_errors=True)
            target.mkdir(parents=True)
            for name in WAITING:
                if (folder / name).exists():
                    shutil.copy2(folder / name, target / name)
            lines.append(f"{run.name}: finished, its result (no training state) -> {target}")
            copied += 1
        elif finished(folder):
            lines.append(f"{run.name}: refused, finished (ship it with ship.py or drop it)")
        elif not (folder / "last.safetensors").exists():
            lines.append(f"{run.name}: not started, nothing to keep")
        else:
            target = paused / run.name
            shutil.rmtree(target, ignore_errors=True)
            ignored = shutil.ignore_patterns(*NOT_PAUSED)
            shutil.copytree(folder, target, ignore=ignored)
            epochs, _ = progress(folder)
            lines.append(f"{run.name}: paused at epoch {epochs} of {run.epochs} -> {target}")
            copied += 1
    return lines, copied


def restore(run: Run, folder: Path, paused: Path = PAUSED) -> bool:
    """Start a run from its paused state (made on another machine) when this machine has no
    state of its own for it; True when it did."""
    source = paused / run.name
    state = (source / "last.safetensors").exists() or (source / "selection.json").exists()
    if (folder / "last.safetensors").exists() or finished(folder) or not state:
        return False
    shutil.copytree(source, folder, dirs_exist_ok=True)
    return True


def prepare(run: Run, folder: Path) -> None:
    """Copy the shipped run a seed-0 ``central`` run continues."""
    source = run.shipped_source
    if source is None or (folder / "last.safetensors").exists():
        return
    folder.mkdir(parents=True, exist_ok=True)
    for item in source.iterdir():
        if item.is_file():
            shutil.copy2(item, folder / item.name)


def build_parser() -> argparse.ArgumentParser:
    """The command's options."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--out", type=Path, default=REPO / "campaign" / "runs")
    parser.add_argument("--only", help="run only the runs whose name contains this")
    parser.add_argument("--dry-run", action="store_true", help="print the commands only")
    parser.add_argument(
        "--status", action="store_true", help="print every queued run's progress and stop"
    )
    parser.add_argument(
        "--bf16-ab", action="store_true", help="add the bf16 copies of the precision A/B"
    )
    parser.add_argument(
        "--snapshot",
        action="store_true",
        help="copy the resumable state of every started, unfinished queued run to "
        "campaign/paused/ (to commit once when training pauses) and stop; finished runs are "
        "refused",
    )
    parser.add_argument(
        "--threads",
        type=int,
        default=1,
        help="CPU threads per run (default 1: leaves a core of a 2-core machine to other work; "
        "two jobs of 2 threads each on 2 cores slow both several-fold)",
    )
    parser.add_argument(
        "--device",
        default="cpu",
        help="torch device of the runs (default cpu); e.g. cuda: several workers may share one "
        "GPU, and a run may move between devices (metrics.jsonl records each epoch's)",
    )
    queues = parser.add_mutually_exclusive_group()  # each a queue of its own
    queues.add_argument(
        "--variant",
        nargs="?",
        const="grouptron-robust",
        metavar="MODEL",
        help="queue the runs of a named group variant instead (grouptron-robust when no MODEL "
        "is given, or grouptron-robust-residual)",
    )
    queues.add_argument(
        "--look-ahead",
        action="store_true",
        help="queue the diagnostic runs with the reference's neighbour window instead: the "
        "paper's two models, univ, papers' protocol, seeds 0-2 (never shipped as forecasters)",
    )
    epochs = ", ".join(f"{model} {n} epochs" for model, n in BASELINE_EPOCHS.items())
    queues.add_argument(
        "--baselines",
        action="store_true",
        help=f"queue the learned baselines instead on the five splits, backward derivatives "
        f"({epochs})",
    )
    return parser


def checked_queue(parser: argparse.ArgumentParser, args: argparse.Namespace) -> list[Run]:
    """The runs the options ask for (their combinations and the device checked first)."""
    if args.bf16_ab and (args.variant or args.look_ahead or args.baselines):
        parser.error("--bf16-ab adds to the default queue: not with --variant, --look-ahead or "
                     "--baselines")  # fmt: skip
    if args.variant is not None and args.variant not in variant_models():
        parser.error(f"--variant: one of {', '.join(variant_models())}, not {args.variant!r}")
    if args.device != "cpu":
        # Imported here: the paper models' queue runs on package code older than this module.
        from grouptron.devices import available_device
        from grouptron.errors import GrouptronError

        try:
            available_device(args.device)
        except GrouptronError as exc:
            parser.error(f"--device: {exc}")
    if args.baselines:
        runs = baselines_queue()
    elif args.look_ahead:
        runs = look_ahead_queue()
    else:
        runs = variant_queue(args.variant) if args.variant else queue(args.bf16_ab)
    if args.only:
        runs = [run for run in runs if args.only in run.name]
    return runs


def work(runs: list[Run], args: argparse.Namespace) -> None:
    """Train every unfinished run of ``runs`` not claimed by another worker, in order (with
    ``--dry-run`` print the commands only)."""
    bf16 = resolve_precision("auto", torch.device(args.device), threads=args.threads)
    chosen = "bf16" if bf16 else "fp32"
    for run in runs:
        folder = args.out / run.name
        if finished(folder):
            print(f"{run.name}: finished", flush=True)
            continue
        precision = "bf16" if run.bf16_only else chosen
        if args.dry_run:
            paused = PAUSED / run.name
            if not (folder / "last.safetensors").exists() and paused.is_dir():
                print(f"{run.name}: would be restored from {paused}", flush=True)
                continue
            print(" ".join(command(run, folder, precision, args.threads, args.device)), flush=True)
            continue
        lock = claim(folder)
        if lock is None:
            print(f"{run.name}: being trained by another worker", flush=True)
            continue
        try:
            if finished(folder):  # another worker finished it while this one waited
                continue
            if restore(run, folder):
                print(f"{run.name}: restored from {PAUSED / run.name}", flush=True)
            if finished(folder):  # a finished diagnostic's result, restored for its study
                continue
            prepare(run, folder)
            argv = command(run, folder, precision, args.threads, args.device)
            print(" ".join(argv), flush=True)
            # The training process inherits the lock: it outlives this worker if killed.
            subprocess.run(argv, check=True, cwd=REPO, pass_fds=(lock,))
        finally:
            os.close(lock)
        print(json.dumps({"finished": run.name}), flush=True)


def main() -> int:
    options = build_parser()
    args = options.parse_args()
    runs = checked_queue(options, args)
    if args.status:
        print("\n".join(status(runs, args.out)))
        return 0
    if args.snapshot:
        lines, copied = snapshot(runs, args.out)
        print("\n".join(lines))
        return 0 if copied else 2
    work(runs, args)
    return 0


if __name__ == "__main__":
    sys.exit(main())
