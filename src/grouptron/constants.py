"""Facts of the ETH/UCY benchmark protocol, as typed constants."""

from __future__ import annotations

import re
from typing import Final

DT_S: Final = 0.4
"""Seconds per step (the benchmark convention, also for biwi_eth; see the data README)."""

FRAMES_PER_STEP: Final = 10
"""Video frames between two annotated steps in the benchmark files."""

HISTORY_STEPS: Final = 8
"""Observed steps t-7..t (3.2 s)."""

HORIZON_STEPS: Final = 12
"""Predicted steps t+1..t+12 (4.8 s)."""

PERCEPTION_RADIUS_M: Final = 3.0
"""Pedestrians within this distance of the ego at t are its neighbours."""

EDGE_RAMP_WEIGHTS: Final = (0.25, 0.5, 0.75, 1.0)
"""Weights of e_t, e_{t-1}, e_{t-2}, e_{t-3} in a new edge's ramp-in (clipped at 1)."""

SPLITS: Final = ("eth", "hotel", "univ", "zara1", "zara2")
"""The five leave-one-location-out splits."""

PARTS: Final = ("train", "val", "test")

ALL_LOCATIONS: Final = "all-locations"
"""A training-only split: the train and val parts of all five locations, nothing held out (a
model for use, never for benchmark tables; its best weights are the final epoch's)."""

EXPECTED_TEST_SAMPLES: Final = {
    "eth": 364,
    "hotel": 1197,
    "univ": 24334,
    "zara1": 2356,
    "zara2": 5910,
}
"""Test samples (exactly 8 observed + 12 future steps) of the reference protocol."""

UNIV_N_PAPER: Final = (40, 45, 50)
"""The dense UNIV subsets of the Grouptron paper (at least N pedestrians in the scene at t)."""

# The command line's vocabulary, here so that `grouptron --help` never imports PyTorch: the
# modules that implement each name take their lists from these.

POINT_FORECAST_NAMES: Final = ("ml", "ml-argmax", "mean", "ml-top10")
"""The named point forecasts (``grouptron.model.predict.POINT_FORECASTS`` implements each);
``ml-topK`` for another K is one too (:func:`top_forecast_size`), scored only when named."""

TOP_FORECAST_PREFIX: Final = "ml-top"
"""``ml-topK``: the most likely forecast of the K most probable latent values."""


def top_forecast_size(name: str) -> int | None:
    """K of a point forecast named ``ml-topK`` (K of at least 2, written without leading
    zeros), else None."""
    digits = name.removeprefix(TOP_FORECAST_PREFIX)
    if digits == name or not re.fullmatch(r"[1-9][0-9]*", digits) or int(digits) < 2:
        return None
    return int(digits)


def is_point_forecast(name: str) -> bool:
    """Whether ``name`` is a point forecast: one of :data:`POINT_FORECAST_NAMES` or
    ``ml-topK``."""
    return name in POINT_FORECAST_NAMES or top_forecast_size(name) is not None


EVALUATION_MODES: Final = (*POINT_FORECAST_NAMES, "best-of-20", "nll")
"""What ``evaluate`` scores: each point forecast, the best of 20 samples, the KDE NLL."""

FORECAST_MODES: Final = (*POINT_FORECAST_NAMES, "samples")
"""What ``predict`` writes: a point forecast, or sampled futures."""


def is_evaluation_mode(name: str) -> bool:
    """Whether ``evaluate`` scores ``name``: one of :data:`EVALUATION_MODES` or ``ml-topK``."""
    return name in EVALUATION_MODES or top_forecast_size(name) is not None


MAX_REGION_Q: Final = 0.99
"""The largest probability a prediction region may hold (``model/regions.py`` resolves it)."""

PRECISIONS: Final = ("auto", "fp32", "bf16")
"""Arithmetic of training (``grouptron.training.precision``)."""

ABLATIONS: Final = ("edges", "scene")
"""Inputs an evaluation can take away (``grouptron.model.predict``)."""

EXPORT_FORMATS: Final = ("onnx",)

LINKAGES: Final = ("single", "average", "complete")
"""Agglomerative linkages of group detection (``grouptron.groups.clustering``)."""

DISTANCE_KINDS: Final = ("hausdorff", "modified")
"""Trajectory distances of group detection (``grouptron.groups.distances``)."""

DEFAULT_CHECKPOINT: Final = "grouptron-robust-residual-crowds-backward"
"""The model used where none is named (``grouptron.inference.checkpoints``, which says why)."""

UNITS_M: Final = {"m": 1.0, "cm": 0.01, "mm": 0.001}
"""Metres per unit of the units a recording's x and y may be in."""

REPORT_NLL_MAX_SAMPLES: Final = 300
"""``report`` scores the KDE NLL on at most this many seeded test samples per split."""
