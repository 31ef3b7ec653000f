"""The typed, frozen settings of a run: data, groups, model, group encoders, loss, training."""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import Any, Literal

from grouptron import constants
from grouptron.errors import GrouptronError
from grouptron.geometry import DERIVATIVE_SCHEMES, BackwardStart, DerivativeScheme
from grouptron.point_forecast import PointForecast


@dataclass(frozen=True)
class DataConfig:
    """How raw tracks become samples. Defaults are the Trajectron++ reference protocol."""

    derivatives: DerivativeScheme = "central"
    backward_start: BackwardStart = "zero"
    """How ``backward`` derivatives begin a track: ``zero`` (strictly causal) or ``next`` (the
    reference's copy of the next value). Runs stored before this setting existed used
    ``next`` and are read with it, so they see the inputs they were trained on."""
    dt_s: float = constants.DT_S
    frames_per_step: int = constants.FRAMES_PER_STEP
    history_steps: int = constants.HISTORY_STEPS
    horizon_steps: int = constants.HORIZON_STEPS
    min_history_train: int = 2
    """Observed points (t-1, t) a training/validation sample needs; test samples need all 8."""
    perception_radius_m: float = constants.PERCEPTION_RADIUS_M
    edge_ramp_weights: tuple[float, ...] = constants.EDGE_RAMP_WEIGHTS
    position_scale_m: float = 3.0
    velocity_scale_mps: float = 2.0
    acceleration_scale_mps2: float = 1.0
    future_scale_m: float = 1.0
    """Divisor of the future positions (relative to the current one) that the future encoder
    q(z|x,y) reads: 1 m as in the reference. Runs trained before this field existed used the
    position scale (3 m); their stored configs are read with that value."""
    on_gap: Literal["split", "error"] = "split"
    neighbour_window_steps: tuple[int, int] = (0, 0)
    """(first, last) steps relative to t: whoever is within the perception radius at any of
    them is a neighbour. (0, 0): the causal rule. (-2, 4) copies the reference scene graph's
    window (its adjacency is a maximum over t-2..t+4), which looks 1.6 s into the future: a
    diagnostic of a possible leak in published numbers, never for a model to use."""

    def __post_init__(self) -> None:
        first, last = self.neighbour_window_steps
        if not first <= 0 <= last:
            raise GrouptronError("neighbour_window_steps must be (first <= 0, last >= 0)")
        if self.derivatives not in DERIVATIVE_SCHEMES:
            raise GrouptronError(
                f"derivatives must be one of {', '.join(DERIVATIVE_SCHEMES)}, "
                f"not {self.derivatives!r}"
            )
        if self.backward_start not in ("zero", "next"):
            raise GrouptronError(
                f"backward_start must be zero or next, not {self.backward_start!r}"
            )
        if self.on_gap not in ("split", "error"):
            raise GrouptronError(f"on_gap must be 'split' or 'error', not {self.on_gap!r}")
        if not 2 <= self.min_history_train <= self.history_steps:
            raise GrouptronError("min_history_train must be between 2 and history_steps")
        if self.history_steps < 2 or self.horizon_steps < 1:
            raise GrouptronError("history_steps must be >= 2 and horizon_steps >= 1")

    @property
    def neighbours_look_ahead(self) -> bool:
        """Whether neighbours are picked by contacts after t (the leak diagnostic)."""
        return self.neighbour_window_steps[1] > 0

    @property
    def causal(self) -> bool:
        """Whether a forecast at t reads nothing after t: backward derivatives and neighbours
        picked at or before t (what a live tracker can give)."""
        return self.derivatives == "backward" and not self.neighbours_look_ahead

    @property
    def state_scale(self) -> tuple[float, ...]:
        """Divisors of the 6 state components (x, y, vx, vy, ax, ay) in standardisation."""
        p, v, a = self.position_scale_m, self.velocity_scale_mps, self.acceleration_scale_mps2
        return (p, p, v, v, a, a)


@dataclass(frozen=True)
class GroupConfig:
    """How the ego and its neighbours are clustered into groups (Grouptron, section III-C)."""

    linkage: Literal["single", "average", "complete"] = "complete"
    """Chosen by agreement with human labels (docs/groups.md): best mean pairwise F1 and Dice
    in the per-ego scope the model uses."""
    distance: Literal["hausdorff", "modified"] = "hausdorff"
    quantile: float = 0.9
    """Quantile of the modified Hausdorff distance (Atev et al.)."""
    max_distance_m: float | None = None
    """None: C(N) = (N + 1) // 2 groups of N people (the paper's rule). A distance: merge
    while the two closest groups are at most this far apart (complete linkage: everyone in a
    group within it of everyone else), however many groups that leaves (docs/groups.md)."""
    velocity_weight_s: float = 0.0
    """Above 0, two people are at least this many seconds times the difference of their mean
    velocities over the window apart: walking together means walking alike (0: positions
    only, the paper's distance)."""
    max_group_size: int | None = None
    """With ``max_distance_m``: a merge that would make a group larger than this is skipped,
    so that a dense crowd is not chained into one group (None: no limit)."""
    detector: Literal["distance", "learned"] = "distance"
    """``distance``: the settings above on trajectory distances; ``learned``: 1 - the shipped
    pair classifier's probability of walking together is the distance (``groups.learned``),
    cut at ``max_distance_m`` with single linkage and ``max_group_size``."""

    def __post_init__(self) -> None:
        if self.linkage not in ("single", "average", "complete"):
            raise GrouptronError("groups.linkage must be single, average or complete")
        if self.distance not in ("hausdorff", "modified"):
            raise GrouptronError("groups.distance must be hausdorff or modified")
        if self.detector not in ("distance", "learned"):
            raise GrouptronError("groups.detector must be distance or learned")
        if self.detector == "learned" and self.max_distance_m is None:
            raise GrouptronError("groups.detector learned links pairs up to max_distance_m")
        if not 0.0 < self.quantile <= 1.0:
            raise GrouptronError("groups.quantile must be in (0, 1]")
        if not self.velocity_weight_s >= 0:
            raise GrouptronError("groups.velocity_weight_s must be >= 0 (seconds)")
        if self.max_distance_m is not None and not self.max_distance_m > 0:
            raise GrouptronError("groups.max_distance_m must be a positive distance (or None)")
        if self.max_group_size is not None and not self.max_group_size >= 2:
            raise GrouptronError("groups.max_group_size must be at least 2 (or None)")


@dataclass(frozen=True)
class ModelConfig:
    """Widths and switches of the CVAE. Defaults equal the Trajectron++ reference code."""

    state_dim: int = 6
    action_dim: int = 2
    history_hidden: int = 32
    edge_hidden: int = 32
    """The reference code uses 32; the Trajectron++ paper's text says 8."""
    future_hidden: int = 32
    latent_values: int = 25
    p_z_hidden: int = 32
    decoder_hidden: int = 128
    use_edges: bool = True
    edge_aggregation: Literal["sum", "mean"] = "sum"
    """How the edge encoder combines the neighbours' states at each step: ``sum`` (the
    reference; grows with the crowd, so a dense crowd lies outside the training range) or
    ``mean`` over the neighbours observed at that step (density-robust)."""
    edge_count_feature: bool = False
    """Append log(1 + neighbours observed) per step to the edge encoder's input, so that a
    ``mean`` keeps the density information a sum carried."""
    velocity_residual: bool = False
    """Decode each step's velocity as the current velocity plus a learnt change, so that an
    untrained or unsure decoder falls back on constant velocity (the reference decodes the
    velocity itself)."""
    rnn_dropout_keep: float = 0.75
    mlp_dropout_keep: float = 0.9
    log_sigma_min: float = -10.0
    log_sigma_max: float = 10.0
    corr_max: float = 0.999
    """|rho| bound of the bivariate Gaussians (keeps the covariance invertible)."""

    def __post_init__(self) -> None:
        for name in (
            "history_hidden",
            "edge_hidden",
            "future_hidden",
            "latent_values",
            "p_z_hidden",
            "decoder_hidden",
        ):
            if getattr(self, name) < 1:
                raise GrouptronError(f"model.{name} must be >= 1")
        for name in ("rnn_dropout_keep", "mlp_dropout_keep"):
            if not 0.0 < getattr(self, name) <= 1.0:
                raise GrouptronError(f"model.{name} must be in (0, 1]")


@dataclass(frozen=True)
class GroupEncoderConfig:
    """Grouptron's group- and scene-level ST-GCN encoders (unused by Trajectron++)."""

    group_dim: int = 16
    """Output width of both ST-GCNs (the paper narrows it to 8 on the eth split)."""
    group_adjacency: Literal["sym_norm", "laplacian"] = "sym_norm"
    """``sym_norm``: D^-1/2 (A + I) D^-1/2; ``laplacian``: Social-STGCNN's normalised
    Laplacian I - D^-1/2 A D^-1/2 (zero for a singleton group)."""
    # Variants (defaults: the paper's encoders). Each is a switch of the one model.
    temporal_layers: int = 1
    """Temporal convolutions per ST-GCN block, the k-th dilated 2^(k-1): 1 (the paper's) sees
    steps t-2..t at the last step; 3 see all 8 observed steps (receptive field 15)."""
    scene_dropout_keep: float = 1.0
    """Keep probability of dropout on E_scene (1: none, the paper's)."""
    scene_layer_norm: bool = False
    """Layer-normalise E_scene (it is 3-6x the magnitude of the other encodings otherwise)."""
    ego_in_own_group: bool = True
    """False: the ego's own group state E_g averages its other members only (alone: zeros),
    so E_scene cannot be a second copy of the ego's motion."""
    count_feature: bool = False
    """Give the scene encoder log(1 + members) of every group and E_scene log(1 + groups):
    the counts that mean aggregation removes (density)."""

    def __post_init__(self) -> None:
        if self.group_dim < 1:
            raise GrouptronError("group_encoder.group_dim must be >= 1")
        if self.temporal_layers < 1:
            raise GrouptronError("group_encoder.temporal_layers must be >= 1")
        if not 0.0 < self.scene_dropout_keep <= 1.0:
            raise GrouptronError("group_encoder.scene_dropout_keep must be in (0, 1]")
        if self.group_adjacency not in ("sym_norm", "laplacian"):
            raise GrouptronError("group_encoder.group_adjacency must be sym_norm or laplacian")


@dataclass(frozen=True)
class LossConfig:
    """The ELBO terms and their schedules, as in the Trajectron++ reference code."""

    log_likelihood_max: float = 6.0
    """Per-step clamp of log p(y_k | x)."""
    kl_free_bits: float = 0.07
    kl_weight_final: float = 100.0
    kl_weight_centre_iter: float = 400.0
    kl_weight_divisor: float = 100.0
    mutual_info_weight: float = 1.0
    logit_clip_start: float = 0.05
    logit_clip_final: float = 5.0
    logit_clip_centre_iter: float = 300.0
    logit_clip_divisor: float = 60.0


@dataclass(frozen=True)
class TrainConfig:
    """Optimisation. Defaults equal the Trajectron++ reference (100 epochs)."""

    epochs: int = 100
    batch_size: int = 256
    learning_rate: float = 1e-3
    lr_decay_per_iter: float = 0.9999
    grad_clip_value: float = 1.0
    rotation_augmentation: bool = True
    seed: int = 0
    threads: int = 2
    eval_batch_size: int = 256
    bf16: bool = False
    """Run the decoder recurrence in bfloat16 autocast; fp32 otherwise. ``grouptron train
    --precision auto`` sets it where the hardware computes bf16 natively."""
    val_subset: int = 1024
    """Validation samples scored after every epoch (a fixed seeded subset, the same for every
    seed); the best epochs on it are re-scored on the whole validation part at the end of the
    schedule, which picks ``best.safetensors``. 0 scores the whole part every epoch."""
    init_from: str = ""
    """Warm start: a full training checkpoint (``last.safetensors``) of the same model whose
    weights, optimiser state and step count start this run; its schedules continue from there.
    Empty: start from the seed."""
    epoch_samples: int = 0
    """Samples an epoch draws (with replacement) by the training samples' weights, where a
    dataset names its train sources; 0: one pass over the training samples (or as many draws)."""
    max_nonfinite_steps: int = 10
    """Optimiser steps whose loss or gradients are NaN/inf are skipped (the weights are left as
    they were) and counted; after this many in a run, training stops with an error."""

    def __post_init__(self) -> None:
        if self.val_subset < 0:
            raise GrouptronError("train.val_subset must be >= 0 (0: the whole validation part)")
        if self.max_nonfinite_steps < 0 or self.epoch_samples < 0:
            raise GrouptronError("train.max_nonfinite_steps and epoch_samples must be >= 0")
        if self.epochs < 1 or self.batch_size < 1 or self.eval_batch_size < 1:
            raise GrouptronError("train.epochs, batch_size and eval_batch_size must be >= 1")
        if self.threads < 1:
            raise GrouptronError("train.threads must be >= 1")
        if not self.learning_rate > 0.0:
            raise GrouptronError("train.learning_rate must be > 0")
        if self.seed < 0:
            raise GrouptronError("train.seed must be >= 0")
        if not 0.0 < self.lr_decay_per_iter <= 1.0:
            raise GrouptronError("train.lr_decay_per_iter must be in (0, 1]")


@dataclass(frozen=True)
class ExperimentConfig:
    """Everything a training run needs; stored in every checkpoint as JSON."""

    split: str = "eth"
    """The ETH/UCY split, or the name of a dataset of one's own (see ``dataset``)."""
    model_name: str = "trajectron++"
    dataset: str = ""
    """Empty for the ETH/UCY benchmark; else the description file of a dataset of one's own
    (``grouptron train --dataset``), which never gets the benchmark's presets."""
    data: DataConfig = dataclasses.field(default_factory=DataConfig)
    groups: GroupConfig = dataclasses.field(default_factory=GroupConfig)
    model: ModelConfig = dataclasses.field(default_factory=ModelConfig)
    group_encoder: GroupEncoderConfig = dataclasses.field(default_factory=GroupEncoderConfig)
    loss: LossConfig = dataclasses.field(default_factory=LossConfig)
    train: TrainConfig = dataclasses.field(default_factory=TrainConfig)
    model_settings: dict[str, Any] = dataclasses.field(default_factory=dict, hash=False)
    """The settings of a model of the forecaster interface (``model_name`` a class or an entry
    point), JSON values by name, as its class reads them; the shipped models use the sections
    above and leave it empty."""
    point_forecast: str = ""
    """The trained model's own point forecast, chosen after training and written into its
    checkpoint (empty: its kind's rule, ``grouptron.model.predict.default_point_forecast``)."""

    def __post_init__(self) -> None:
        if self.point_forecast:  # its one name, so that a stored config names it one way
            named = PointForecast.parse(self.point_forecast, option="point_forecast").name
            object.__setattr__(self, "point_forecast", named)
