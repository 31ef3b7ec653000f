"""Choose a trained model's own point forecast on validation and development data; store it.

Usage:
    python campaign/point_forecast.py FOLDER [--split univ] [--datasets DEV,...]
                                      [--candidates 1,2,3,4,5,8] [--write] [--threads 1]

Compares, for each candidate K, the most likely forecast of the K most probable latent values
(``ml-topK``; K = 1 is ``ml-argmax``) with ``ml-top10``, the forecast a velocity-residual model
gets by rule, on the split's validation files and on the test part of each development
dataset (``benchmarks/ood/``, default the out-of-domain development set): the FDE difference
with a 95% interval over resampled time steps (``benchmarks/most_likely.py``). A candidate
qualifies where no interval lies above zero (no worse anywhere); of the qualifying ones
(``ml-top10`` always among them) the one with the lowest FDE over the development set pooled is
the model's own. ``--write`` stores it as ``ExperimentConfig.point_forecast`` in the folder's
``best.safetensors`` (weights untouched) and ``config.json``, and writes the comparison into
the card's section "Point forecast". Test files are never read.
"""

from __future__ import annotations

import argparse
import dataclasses
import sys
from pathlib import Path

import numpy as np
import torch

REPO = Path(__file__).resolve().parents[1]
# most_likely.py is a benchmark script, not part of the package.
sys.path.insert(0, str(REPO / "benchmarks"))
from most_likely import errors_by_top  # noqa: E402

from grouptron.config import save_config  # noqa: E402
from grouptron.data.datasets.custom import read_dataset  # noqa: E402
from grouptron.evaluation.uncertainty import Interval, mean_interval  # noqa: E402
from grouptron.io import write_text_atomically  # noqa: E402
from grouptron.model.checkpoint import BEST_WEIGHTS_FILE, load_checkpoint, save_checkpoint  # noqa: E402
from grouptron.model.predict import default_point_forecast  # noqa: E402
from grouptron.point_forecast import PointForecast  # noqa: E402

REFERENCE = 10
"""``ml-top10``: the rule's forecast for a velocity-residual model, which every candidate is
compared with."""
DEVELOPMENT_SET = ",".join(
    str(REPO / "benchmarks" / "ood" / f) for f in ("stanford_drone.toml", "hermes_corridor.toml")
)
SECTION = "## Point forecast"


def forecast_of(k: int) -> str:
    """The point forecast's name for the K most probable latent values."""
    return PointForecast("ml", k).name


@dataclasses.dataclass(frozen=True)
class Comparison:
    """One candidate against ``ml-top10``: per source (label) its FDE and the paired
    difference; the development set pooled."""

    k: int
    fde_m: dict[str, float]
    difference_m: dict[str, Interval]
    pooled_development_fde_m: float

    @property
    def qualifies(self) -> bool:
        """No worse than ``ml-top10`` anywhere: no interval lies above zero."""
        return all(d.low <= 0.0 for d in self.difference_m.values())


def compare(
    folder: Path, split: str, datasets: list[Path], candidates: list[int]
) -> list[Comparison]:
    """Every candidate (and K = 10) on the split's validation files and each dataset."""
    tops = sorted({*candidates, REFERENCE})
    checkpoint = str(folder / BEST_WEIGHTS_FILE)
    sources = [(f"{split} val", None)] + [(p.stem, read_dataset(p)) for p in datasets]
    fde: dict[str, dict[int, np.ndarray]] = {}
    steps: dict[str, np.ndarray] = {}
    for label, dataset in sources:
        errors, steps[label] = errors_by_top(checkpoint, split, tops, dataset)
        fde[label] = {k: errors[k][:, 1] for k in tops}
    development = [label for label, dataset in sources if dataset is not None]
    out = []
    for k in tops:
        pooled = np.concatenate([fde[label][k] for label in development])
        out.append(
            Comparison(
                k,
                {label: float(fde[label][k].mean()) for label in fde},
                {
                    label: mean_interval(fde[label][k] - fde[label][REFERENCE], steps[label])
                    for label in fde
                },
                float(pooled.mean()),
            )
        )
    return out


def choose(comparisons: list[Comparison]) -> Comparison:
    """Of the candidates no worse than ``ml-top10`` anywhere, the lowest pooled development
    FDE (``ml-top10`` itself always qualifies)."""
    return min((c for c in comparisons if c.qualifies), key=lambda c: c.pooled_development_fde_m)


def markdown(comparisons: list[Comparison], chosen: Comparison, command: str) -> list[str]:
    """The card's section: the rule, the table and the choice."""
    labels = list(comparisons[0].fde_m)
    lines = [
        SECTION,
        "",
        f"Its own point forecast (what `Predictor`, `predict` and `evaluate` use unless told) "
        f"is `{forecast_of(chosen.k)}`, stored as `point_forecast` in its config. Chosen by "
        f"`{command}`: each `ml-topK` against `ml-top10` (the rule's forecast for a "
        "velocity-residual model), FDE in metres and the paired difference with its 95% "
        "interval over resampled time steps; a candidate qualifies where no interval lies "
        "above zero, and of those the lowest FDE over the development recordings pooled wins. "
        "The validation files may be ones the model trained on (a dataset-trained model's); "
        "the comparison is paired, between forecasts of one model.",
        "",
        "| forecast | " + " | ".join(labels) + " | development pooled | qualifies |",
        "|---|" + "---|" * (len(labels) + 2),
    ]
    for c in comparisons:
        cells = [
            f"{c.fde_m[label]:.3f} ({c.difference_m[label].signed_text()})"
            if c.k != REFERENCE
            else f"{c.fde_m[label]:.3f}"
            for label in labels
        ]
        mark = "chosen" if c is chosen else ("yes" if c.qualifies else "no")
        lines.append(
            f"| `{forecast_of(c.k)}` | "
            + " | ".join(cells)
            + f" | {c.pooled_development_fde_m:.3f} | {mark} |"
        )
    return lines


def write_choice(folder: Path, forecast: str, section: list[str]) -> None:
    """Store ``forecast`` in the folder's checkpoint and config.json, the section in its card."""
    path = folder / BEST_WEIGHTS_FILE
    checkpoint = load_checkpoint(path)
    checkpoint.config = dataclasses.replace(checkpoint.config, point_forecast=forecast)
    save_checkpoint(path, checkpoint)
    save_config(checkpoint.config, folder / "config.json")
    card = folder / "README.md"
    text = card.read_text() if card.exists() else ""
    if SECTION in text:  # a new choice replaces the old section
        before, _, after = text.partition(SECTION)
        rest = after.split("\n## ", 1)
        text = before + ("## " + rest[1] if len(rest) > 1 else "")
    write_text_atomically(card, text.rstrip("\n") + "\n\n" + "\n".join(section) + "\n")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("folder", type=Path, help="a trained run's or a shipped model's folder")
    parser.add_argument("--split", default="univ", help="whose validation files (default: univ)")
    parser.add_argument("--datasets", default=DEVELOPMENT_SET, help="development descriptions")
    parser.add_argument("--candidates", default="1,2,3,4,5,8", help="the K of each ml-topK")
    parser.add_argument("--write", action="store_true", help="store the choice in the folder")
    parser.add_argument("--threads", type=int, default=1)
    args = parser.parse_args()
    torch.set_num_threads(args.threads)
    datasets = [Path(p) for p in args.datasets.split(",") if p]
    candidates = [int(k) for k in args.candidates.split(",")]
    latent_values = load_checkpoint(args.folder / BEST_WEIGHTS_FILE).config.model.latent_values
    if not datasets:
        parser.error("--datasets names no development dataset to choose on")
    if max(*candidates, REFERENCE) > latent_values or min(candidates) < 1:
        parser.error(f"each K must be 1 to the model's {latent_values} latent values (and 10)")
    comparisons = compare(args.folder, args.split, datasets, candidates)
    chosen = choose(comparisons)
    command = f"python campaign/point_forecast.py checkpoints/{args.folder.name} --write"
    section = markdown(comparisons, chosen, command)
    print("\n".join(section))
    before = default_point_forecast(load_checkpoint(args.folder / BEST_WEIGHTS_FILE).config)
    print(f"\n{args.folder}: {before} -> {forecast_of(chosen.k)}")
    if args.write:
        write_choice(args.folder, forecast_of(chosen.k), section)


if __name__ == "__main__":
    main()
