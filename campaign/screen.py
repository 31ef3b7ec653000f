"""Screening of Grouptron's variants on validation data (causal protocol), resumable.

Usage:
    python campaign/screen.py [--splits univ,zara1] [--seeds 0,1,2] [--epochs 100]
                              [--only VARIANT] [--out campaign/screen] [--threads 1] [--dry-run]
    python campaign/screen.py --table [--out campaign/screen]

Every (variant, split, seed) trains ``grouptron train --derivatives backward`` into
``OUT/<variant>-<split>-s<seed>`` with the variant's ``--set`` switches, and is skipped once
finished (its ``selection.json`` exists); a stopped run resumes. ``trajectron++`` and
``grouptron`` (the paper's) are the references; where the checkpoint campaign (``run.py``)
already trained the same run (``REFERENCES/<model>-<split>-backward[-s<seed>]``, identical
configuration) it is read from there instead of trained twice. ``--table`` prints, per split
and variant, the validation ML FDE (the trainer's re-scoring of its best epochs on the whole
validation part) of each seed, their mean, and the mean paired difference to Trajectron++ over
the seeds both have, and constant velocity's FDE on the same samples; ``--ood [FORECAST]`` adds the
FDE over constant velocity's on the out-of-domain development set, overall and with 25+
neighbours (univ's validation data is sparse, so it cannot show how a variant copes with a
crowd). Only validation and the development set are looked at: test waits for the winner.
Finished runs' records are read wherever they are kept (``records.py``), so the table needs no
run folder.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
from pathlib import Path

import numpy as np

# records.py is a script beside this one, not part of the package.
sys.path.insert(0, str(Path(__file__).resolve().parent))
from records import record

REPO = Path(__file__).resolve().parents[1]

ALL_GROUP_SWITCHES = [
    "group_encoder.temporal_layers=3",
    "group_encoder.scene_dropout_keep=0.75",
    "group_encoder.scene_layer_norm=true",
    "group_encoder.ego_in_own_group=false",
    "group_encoder.count_feature=true",
    "groups.linkage=single",
    "groups.max_distance_m=1.5",
    "groups.velocity_weight_s=2.0",
]
MEAN_EDGES = ["model.edge_aggregation=mean", "model.edge_count_feature=true"]
"""The edge encoder's density-robust aggregation (both models have it)."""
RESIDUAL = ["model.velocity_residual=true"]
"""The decoder predicts changes of the current velocity (constant velocity when unsure)."""

VARIANTS: dict[str, tuple[str, list[str]]] = {
    "trajectron++": ("trajectron++", []),
    "grouptron": ("grouptron", []),
    "receptive": ("grouptron", ["group_encoder.temporal_layers=3"]),
    "regularised": (
        "grouptron",
        ["group_encoder.scene_dropout_keep=0.75", "group_encoder.scene_layer_norm=true"],
    ),
    "ego-out": ("grouptron", ["group_encoder.ego_in_own_group=false"]),
    "counts": ("grouptron", ["group_encoder.count_feature=true"]),
    "threshold": (
        "grouptron",
        ["groups.linkage=single", "groups.max_distance_m=1.5", "groups.velocity_weight_s=2.0"],
    ),
    "all": ("grouptron", ALL_GROUP_SWITCHES),
    "mean-edges": ("grouptron", MEAN_EDGES),
    "robust": ("grouptron", ALL_GROUP_SWITCHES + MEAN_EDGES),
    "trajectron++-mean": ("trajectron++", MEAN_EDGES),
    "trajectron++-residual": ("trajectron++", RESIDUAL),
    "robust-residual": ("grouptron", ALL_GROUP_SWITCHES + MEAN_EDGES + RESIDUAL),
    # A diagnostic, never a candidate: neighbours chosen by contacts up to 4 steps after t.
    "leak-window": ("grouptron", ["data.neighbour_window_steps=[-2,4]"]),
}
"""name -> (model, --set switches). Each switch is a setting of the one model (docs)."""


def train_command(variant: str, split: str, seed: int, args: argparse.Namespace) -> list[str]:
    model, switches = VARIANTS[variant]
    out = Path(args.out) / f"{variant}-{split}-s{seed}"
    command = [sys.executable, "-m", "grouptron", "train", "--split", split, "--model", model]
    command += ["--out", str(out), "--epochs", str(args.epochs), "--seed", str(seed)]
    command += ["--derivatives", "backward", "--threads", str(args.threads), "--quiet"]
    for switch in switches:
        command += ["--set", switch]
    return command + (["--resume"] if (out / "last.safetensors").exists() else [])


def run_folder(variant: str, split: str, seed: int, args: argparse.Namespace) -> Path:
    """Where the run lives: the campaign's copy of a reference run once finished, else OUT."""
    model, switches = VARIANTS[variant]
    if not switches:
        name = f"{model}-{split}-backward" + (f"-s{seed}" if seed else "")
        reference = Path(args.references) / name
        if record(reference, "selection.json").exists():
            return reference
    return Path(args.out) / f"{variant}-{split}-s{seed}"


def validation_fde(run: Path) -> float | None:
    """The finished run's whole-validation ML FDE, or None while it runs."""
    selection = record(run, "selection.json")
    if not selection.exists():
        return None
    return float(json.loads(selection.read_text())["full_val_ml_fde"])


def ood_ratios(run: Path, args: argparse.Namespace) -> dict[str, float] | None:
    """A finished run's FDE over constant velocity's on the out-of-domain development set,
    overall and by density bin (``benchmarks/out_of_domain.py``, scored once into
    ``ood-<mode>.json``, the point forecast ``--ood`` names); None while the run trains or
    without ``--ood``."""
    if not args.ood or not record(run, "selection.json").exists():
        return None
    cached = record(run, f"ood-{args.ood}.json")
    if not cached.exists():
        script = REPO / "benchmarks" / "out_of_domain.py"
        command = [sys.executable, str(script), "--checkpoints", str(run)]
        command += ["--modes", args.ood, "--threads", str(args.threads), "--json", str(cached)]
        subprocess.run(command, check=True, stdout=subprocess.DEVNULL)
    ratios = json.loads(cached.read_text())["fde_over_cv"]
    (model,) = [name for name in ratios if name not in ("constant velocity", "constant-velocity")]
    return dict(ratios[model])


def _ood_cells(ratios: list[dict[str, float] | None]) -> str:
    """Mean over seeds of the out-of-domain FDE / CV, overall and with 25+ neighbours."""
    done = [r for r in ratios if r is not None]
    if not done:
        return " - | - |"
    overall = np.mean([r["all"] for r in done])
    dense = [r["neighbours 25+"] for r in done if "neighbours 25+" in r]
    return f" {overall:.3f} | {np.mean(dense):.3f} |" if dense else f" {overall:.3f} | - |"


def table(args: argparse.Namespace) -> None:
    seeds = [int(s) for s in args.seeds.split(",")]
    ood = f" out-of-domain FDE / CV ({args.ood}) | the same, 25+ neighbours |" if args.ood else ""
    print("| split | variant | " + " | ".join(f"seed {s}" for s in seeds) + " | mean | "
          "mean paired difference to Trajectron++ |" + ood)  # fmt: skip
    print("|---|---|" + "---|" * (len(seeds) + 2 + (2 if args.ood else 0)))
    for split in args.splits.split(","):
        runs = {
            (v, s): validation_fde(run_folder(v, split, s, args)) for v in VARIANTS for s in seeds
        }
        for variant in VARIANTS:
            values = [runs[variant, s] for s in seeds]
            done = [v for v in values if v is not None]
            paired = [
                runs[variant, s] - runs["trajectron++", s]  # type: ignore[operator]
                for s in seeds
                if runs[variant, s] is not None and runs["trajectron++", s] is not None
            ]
            cells = " | ".join("-" if v is None else f"{v:.3f}" for v in values)
            mean = f"{np.mean(done):.3f}" if done else "-"
            diff = f"{np.mean(paired):+.3f} ({len(paired)} seeds)" if paired else "-"
            row = f"| {split} | {variant} | {cells} | {mean} | {diff} |"
            if args.ood:
                row += _ood_cells([ood_ratios(run_folder(variant, split, s, args), args)
                                   for s in seeds])  # fmt: skip
            print(row)
        selections = [
            record(run_folder(v, split, s, args), "selection.json") for v in VARIANTS for s in seeds
        ]
        cv = [
            json.loads(path.read_text())["full_val_cv_fde"] for path in selections if path.exists()
        ]
        if cv:  # the same validation samples for every run of a split
            print(f"| {split} | constant velocity | " + " | ".join(["-"] * len(seeds))
                  + f" | {cv[0]:.3f} | - |" + (" 1.000 | 1.000 |" if args.ood else ""))  # fmt: skip


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--splits", default="univ,zara1")
    parser.add_argument("--seeds", default="0,1,2")
    parser.add_argument("--epochs", type=int, default=100)
    parser.add_argument("--only", help="run only this variant")
    parser.add_argument("--out", default=str(REPO / "campaign" / "screen"))
    parser.add_argument("--threads", type=int, default=1)
    parser.add_argument(
        "--references",
        default=str(REPO / "campaign" / "runs"),
        help="the checkpoint campaign's runs, reused for the reference variants",
    )
    parser.add_argument("--dry-run", action="store_true", help="print the commands only")
    parser.add_argument("--table", action="store_true", help="print the validation table")
    parser.add_argument(
        "--ood",
        nargs="?",
        const="ml-argmax",
        choices=("ml", "ml-argmax", "mean", "ml-top10"),
        help="with --table: add each variant's FDE over constant velocity on the out-of-domain "
        "development set (benchmarks/ood/*.toml) for this point forecast (default ml-argmax, "
        "the plain models' default; scored once per run into ood-<forecast>.json)",
    )
    args = parser.parse_args()
    if args.table:
        table(args)
        return
    for seed in (int(s) for s in args.seeds.split(",")):  # seeds outer: early rows comparable
        for split in args.splits.split(","):
            for variant in VARIANTS if args.only is None else [args.only]:
                if validation_fde(run_folder(variant, split, seed, args)) is not None:
                    continue
                command = train_command(variant, split, seed, args)
                print(" ".join(command), flush=True)
                if not args.dry_run:
                    subprocess.run(command, check=True)


if __name__ == "__main__":
    main()
