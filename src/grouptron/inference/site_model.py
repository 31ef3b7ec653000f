"""What a session learnt of its site, kept as a checkpoint folder: ``best.safetensors`` (the
weights in use, loadable by ``Predictor.from_checkpoint`` like any checkpoint) and
``site.json``, its card: the checkpoint it started from, how much of the site it saw, and
what the rounds gained on samples they did not train on."""

from __future__ import annotations

import json
from pathlib import Path

from grouptron.config import ExperimentConfig
from grouptron.errors import GrouptronError
from grouptron.evaluation.uncertainty import Interval
from grouptron.inference.calibration import weights_digest
from grouptron.inference.learning import LearningStatus
from grouptron.io import write_text_atomically
from grouptron.model.checkpoint import BEST_WEIGHTS_FILE as BEST
from grouptron.model.checkpoint import Checkpoint, load_trained_model, save_checkpoint
from grouptron.model.forecaster import Forecaster

SITE_CARD = "site.json"
"""The card beside a kept site's weights."""


def save_site(
    folder: str | Path,
    model: Forecaster,
    config: ExperimentConfig,
    status: LearningStatus,
    source: str,
) -> Path:
    """Write ``model`` (the weights a session uses) and its card to ``folder``; returns the
    weights' file. ``source``: the checkpoint file the session started from."""
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    weights = folder / BEST
    save_checkpoint(weights, Checkpoint(config=config, model_state=model.state_dict()))
    last = status.last_difference
    card = {
        "base_checkpoint": source,
        "base_weights_sha256": weights_digest(source) if source and Path(source).is_file() else "",
        "model": config.model_name,
        "learnt": status.adapted,
        "rounds": status.rounds,
        "accepted": status.accepted,
        "rolled_back": status.rolled_back,
        "samples": status.samples,
        "minutes": round(status.seconds / 60, 3),
        "last_fde_difference_m": None if last is None else [last.mean, last.low, last.high],
        "weights_sha256": weights_digest(weights),
    }
    write_text_atomically(folder / SITE_CARD, json.dumps(card, indent=2) + "\n")
    return weights


def load_site(folder: str | Path, source: str) -> tuple[Forecaster, LearningStatus]:
    """The weights and status kept by :func:`save_site` in ``folder``, for a session that
    starts from the checkpoint file ``source`` again; one line if they were learnt from other
    weights."""
    folder = Path(folder)
    try:
        card = json.loads((folder / SITE_CARD).read_text())
        model, _ = load_trained_model(folder / BEST)
        kept_base = str(card["base_weights_sha256"])
        last = card["last_fde_difference_m"]
        status = LearningStatus(
            rounds=int(card["rounds"]),
            accepted=int(card["accepted"]),
            rolled_back=int(card["rolled_back"]),
            samples=int(card["samples"]),
            seconds=60.0 * float(card["minutes"]),
            adapted=bool(card["learnt"]),
            last_difference=None if last is None else Interval(*map(float, last)),
        )
    except (OSError, ValueError, KeyError, TypeError) as error:
        raise GrouptronError(f"{folder}: not a kept site ({error})") from None
    base = weights_digest(source) if source and Path(source).is_file() else ""
    if kept_base != base:
        raise GrouptronError(
            f"{folder}: learnt from other weights than {source or 'these'}; start without it "
            "or from the checkpoint it was learnt from"
        )
    return model, status
