"""A second benchmark: TrajNet's Stanford Drone scenes in metres, on a fixed split by scene.

Usage:
    python benchmarks/trajnet_sdd.py --data-dir ../shared/data/ood/trajnet_sdd
        [--out benchmarks/trajnet_sdd_runs] [--counts-only] [--models M,M,...]
        [--epochs N] [--cvae-epochs N] [--threads N]

The 31 files of TrajNet's Stanford Drone training set (``datasets/TrajNet/Train/stanford`` of
OpenTraj: frames at 30 fps, one row every 12 frames = 0.4 s, metres) come from six campus
scenes. The split is by scene, so that no test place is seen in training (:data:`SPLIT`):
train on bookstore, hyang and nexus, choose the epoch on gates, test on coupa and
deathCircle. No published rows exist for this split (TrajNet's own test set is a separate
one whose futures are hidden).

The script writes the dataset description ``OUT/trajnet-sdd.toml`` (absolute paths to the
files), prints the sample counts of every part and scene, trains every model of ``--models``
on it with strictly causal inputs (``backward``) into ``OUT/runs/<model>`` (a finished run is
kept, a stopped one resumes), and writes ``OUT/report.md``: constant velocity and every
model's most likely forecast and best of 20, with 95% intervals and each row's paired
difference to the best (``grouptron report --dataset``), Col-I and Col-II beside them.

These runs are trained on files that are also the out-of-domain development set: a model
scored out of domain must not have trained on them, and ``report --out-of-domain`` refuses
one that has. So the runs stay in ``OUT``, never in ``checkpoints/``.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
from pathlib import Path

from grouptron.config import DataConfig
from grouptron.data.datasets.custom import load_dataset_part, read_dataset
from grouptron.model.forecaster import is_outside_name
from grouptron.training.run_state import LAST
from grouptron.training.selection import SELECTION

REPO = Path(__file__).resolve().parents[1]
SPLIT = {
    "train": ("bookstore", "hyang", "nexus"),
    "val": ("gates",),
    "test": ("coupa", "deathCircle"),
}
"""The scenes of each part: every file of a scene goes to the same part."""
MODELS = ("social-stgcnn", "transformer", "trajectron++", "grouptron")


def description(data_dir: Path, out: Path) -> Path:
    """Write the dataset description of :data:`SPLIT` over the files in ``data_dir``."""
    lines = ['name = "trajnet-sdd"', "[format]", 'columns = "frame,id,x,y"', "fps = 30"]
    lines += ['units = "m"', "[parts]"]
    for part, scenes in SPLIT.items():
        files = sorted(f for scene in scenes for f in data_dir.glob(f"{scene}_*.txt"))
        if not files:
            sys.exit(f"trajnet_sdd: no {'/'.join(scenes)} files in {data_dir}")
        # A JSON string is a TOML basic string: any path, quotes and backslashes included.
        lines.append(f"{part} = [{', '.join(json.dumps(str(f.resolve())) for f in files)}]")
    out.mkdir(parents=True, exist_ok=True)
    path = out / "trajnet-sdd.toml"
    path.write_text("\n".join(lines) + "\n")
    return path


def counts(path: Path) -> list[str]:
    """Markdown lines: files, scenes and samples of every part (training samples as training
    counts them, at least 2 observed steps; test samples with all 8), causal inputs."""
    dataset = read_dataset(path)
    data = DataConfig(derivatives="backward")
    lines = ["| part | scenes | files | samples | most people in one step |"]
    lines.append("|---|---|---|---|---|")
    for part, scenes in SPLIT.items():
        samples = load_dataset_part(dataset, part, data).samples
        most = int(samples.num_present.max()) if len(samples) else 0
        row = [part, ", ".join(scenes), str(len(dataset.files(part))), str(len(samples)), str(most)]
        lines.append("| " + " | ".join(row) + " |")
    return lines


def train(path: Path, runs: Path, model: str, epochs: int, threads: int) -> None:
    """Train ``model`` into ``runs/model`` unless finished; resume a stopped run."""
    folder = runs / model
    if (folder / SELECTION).exists():
        print(f"{model}: finished", flush=True)
        return
    argv = [sys.executable, "-m", "grouptron", "train", "--dataset", str(path), "--model", model]
    argv += ["--derivatives", "backward", "--epochs", str(epochs), "--out", str(folder)]
    argv += ["--threads", str(threads), "--precision", "auto", "--quiet"]
    if (folder / LAST).exists():
        argv.append("--resume")
    print(" ".join(argv), flush=True)
    subprocess.run(argv, check=True)


def report(path: Path, runs: Path, out: Path) -> None:
    """``grouptron report --dataset`` of every run, with the scene metrics, into ``out``."""
    argv = [sys.executable, "-m", "grouptron", "report", "--dataset", str(path)]
    argv += ["--checkpoints", str(runs), "--mode", "ml,best-of-20", "--derivatives", "backward"]
    argv += ["--metrics", "col-i,col-ii", "--out", str(out)]
    subprocess.run(argv, check=True)
    print(out.read_text(), end="")


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--data-dir", type=Path, required=True, help="the 31 TrajNet SDD files")
    parser.add_argument("--out", type=Path, default=REPO / "benchmarks" / "trajnet_sdd_runs")
    parser.add_argument("--counts-only", action="store_true", help="print the counts and stop")
    parser.add_argument("--models", default=",".join(MODELS), help="models to train and report")
    parser.add_argument("--epochs", type=int, default=15, help="epochs of the learned baselines")
    parser.add_argument(
        "--cvae-epochs", type=int, default=5, help="epochs of Trajectron++ and Grouptron"
    )
    parser.add_argument("--threads", type=int, default=1, help="CPU threads per training run")
    args = parser.parse_args()
    path = description(args.data_dir, args.out)
    print("\n".join(counts(path)), flush=True)
    if args.counts_only:
        return 0
    runs = args.out / "runs"
    for model in args.models.split(","):
        epochs = args.epochs if is_outside_name(model) else args.cvae_epochs
        train(path, runs, model, epochs, args.threads)
    report(path, runs, args.out / "report.md")
    return 0


if __name__ == "__main__":
    sys.exit(main())
