"""Facts of the ETH/UCY benchmark protocol, as typed constants."""

from __future__ import annotations

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

CONSTANT_VELOCITY: Final = "constant-velocity"
"""The baseline every table shows beside a model, by the name rows and ``--model`` give it."""

MAX_GAP_S: Final = 0.8
"""Seconds without an observation after which a recording's track is split (shorter gaps are
bridged when it is resampled): ``--max-gap``'s and ``TrackSource.max_gap_s``'s default."""

EVALUATION_MODES: Final = ("ml", "ml-argmax", "mean", "ml-top10", "best-of-20", "nll")
"""What ``evaluate`` scores: each named point forecast (``grouptron.point_forecast.NAMED``;
``ml-topK`` when named), the best of 20 samples (``best-of-K`` for any K when named), the KDE
NLL."""


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
