"""The Python API: forecasts for live or recorded tracks from a trained checkpoint.

    predictor = Predictor.from_checkpoint("grouptron-univ-backward")
    forecast = predictor.predict(tracks)            # (R, 4) frame, id, x, y
    session = predictor.stream()
    forecast = session.update(frame, ids, xy)       # one frame at a time

Only positions up to the forecast frame are used. Every agent observed at that frame with at
least ``min_points`` positions in a row gets a forecast (2 by default: the fewest the models were
trained on); up to ``max_missed_steps`` missed detections in a row are filled by interpolation
once the agent is seen again, instead of restarting its track.
"""

from __future__ import annotations

import copy
import dataclasses
import logging
import warnings
from pathlib import Path
from typing import Any

import numpy as np
import torch

from grouptron.config import ExperimentConfig
from grouptron.data.formats import glitches
from grouptron.data.formats.reader import table_from_values
from grouptron.data.prepare.gaps import bridge_gaps, filled_in_histories
from grouptron.data.prepare.samples import SampleSet, scene_samples
from grouptron.data.prepare.scene import Scene, build_scene
from grouptron.devices import available_device, torch_threads
from grouptron.errors import GrouptronError
from grouptron.groups.assign import assign_groups_at_step
from grouptron.groups.pair_memory import PairMemory
from grouptron.groups.scene import groups_at_step
from grouptron.inference.calibration import RegionCalibration, calibration_for
from grouptron.inference.checkpoints import DEFAULT_CHECKPOINT, resolve_checkpoint
from grouptron.inference.engine import EngineOptions, forecast_samples
from grouptron.inference.forecast import Forecast, empty_forecast
from grouptron.inference.inputs import (
    MAX_MISSED_STEPS,
    as_track_array,
    check_track_rows,
    check_walking_speed,
    frame_argument,
    integer_argument,
    refuse_future_neighbours,
)
from grouptron.inference.learning import LearningOptions, SiteLearner
from grouptron.inference.online import OnlineCalibration, online_state
from grouptron.inference.stream import StreamSession
from grouptron.model.checkpoint import load_trained_model
from grouptron.model.factory import uses_groups
from grouptron.model.forecaster import Forecaster, latent_values_of
from grouptron.model.predict import default_point_forecast
from grouptron.point_forecast import PointForecast
from grouptron.presets import DETECTION_GROUPS

log = logging.getLogger(__name__)

MAX_SAMPLES = 10_000
"""Sampled futures per agent at most: more only fill memory (1.9 MB an agent)."""

LIVE_THREADS = 1  # more collapse on a shared CPU: docs/robots.md, "Threads"


class Predictor:
    """A trained Trajectron++ or Grouptron model ready to forecast tracks.

    Args:
        forecast: the point forecast (a ``PointForecast`` or its name): ``ml-argmax``, the
            means of the most probable latent value only, the fast choice for a control loop;
            ``ml``: per step the mode of the p(z|x)-weighted mixture of the latent values'
            Gaussians, integrated (the benchmark's most likely trajectory); ``ml-topK``: ``ml``
            of the K most probable latent values only; ``mean``: the p(z|x)-weighted mean of
            every latent value's trajectory. None (the default): the model's own
            (``default_point_forecast``: the one stored with it, ``ml-top2`` for the default
            model; else ``ml-top10`` for a velocity-residual decoder, ``ml-argmax``
            otherwise). ``most_likely`` is its older name, and ``latent_values=K`` an older
            way to name ``ml-topK`` (both still accepted, with a warning).
        mixture: also return the mixture parameters (decodes all Z latent values; slower).
        check_speed: refuse tracks whose median speed no pedestrian walks (wrong units), and
            repair jumps faster than anyone runs (``grouptron.data.formats.glitches``).
        device: where the network runs (``cpu``, ``cuda``, ``mps``); NumPy results either way.
        min_points: the fewest positions in a row (the last one at the forecast frame) an agent
            needs for a forecast, 2 to ``history_steps``; more history, better forecasts.
        max_missed_steps: missed detections of up to this many steps in a row are filled by
            linear interpolation (0: a missed detection restarts the agent's track).
        calibration: a ``grouptron calibrate`` file (or its ``RegionCalibration``) for this
            model and point forecast: ``Forecast.regions`` then takes its conformal radii.
            None (the default): the calibration the checkpoint ships with, where it has one
            for this forecast (``campaign/ship_calibration.py``); False: none.
        online_calibration: live sessions (``stream``) adapt the radii as truths arrive,
            starting from ``calibration`` (``inference.online``; True, or a saved state's file
            to resume one).
        learn: live sessions (``stream``) learn their site: each fine-tunes its own copy of
            the weights in rounds on the people it saw walk, guarded (``inference.learning``;
            True: the default ``LearningOptions``, or one's own).
        threads: PyTorch threads of its forecasts, set around each and restored (default
            ``LIVE_THREADS``, 1: holds on a shared CPU; None: PyTorch's own setting).

    Attributes:
        group_rule: the rule behind ``Forecast.group``: the model's own for one that reads
            groups, otherwise ``DETECTION_GROUPS`` (the rule chosen on human labels).
        pair_memory: a learned ``group_rule``'s memory of pairs, for one stream fed in order.
    """

    def __init__(  # noqa: PLR0913 - the predictor's settings, keyword-only after the forecast
        self,
        model: Forecaster,
        config: ExperimentConfig,
        source: str = "",
        forecast: PointForecast | str | None = None,
        *,
        mixture: bool = False,
        check_speed: bool = True,
        device: str | torch.device = "cpu",
        min_points: int = 2,
        max_missed_steps: int = MAX_MISSED_STEPS,
        calibration: str | Path | RegionCalibration | bool | None = None,
        online_calibration: bool | str | Path | OnlineCalibration = False,
        learn: bool | LearningOptions = False,
        threads: int | None = LIVE_THREADS,
        **older: Any,
    ) -> None:
        refuse_future_neighbours(config.data, source)
        unknown = sorted(set(older) - {"most_likely", "latent_values"})
        if unknown:
            raise GrouptronError(f"Predictor takes no {', '.join(unknown)}")
        self.forecast = _chosen_forecast(forecast, config, **older)
        self.device = available_device(device)
        self.model = model.eval().to(self.device)
        self.config = config
        self.source = source
        # A model that reads groups colours by what it reads; any other by the rule chosen on
        # human labels (C(N) merges standing strangers).
        self.group_rule = config.groups if uses_groups(config) else DETECTION_GROUPS
        self.mixture = mixture
        self.check_speed = check_speed
        history = config.data.history_steps
        self.min_points = integer_argument(min_points, "min_points", 2, history)
        self.max_missed_steps = integer_argument(max_missed_steps, "max_missed_steps", 0)
        self.calibration = calibration_for(calibration, config, self.forecast, source)
        self.online_calibration = online_calibration
        self.learn = _learning_options(learn)
        self.threads = None if threads is None else integer_argument(threads, "threads", 1)
        self._warned_central = False
        self.pair_memory: PairMemory | None = None

    @classmethod
    def from_checkpoint(
        cls,
        name_or_path: str | Path = DEFAULT_CHECKPOINT,
        checkpoints_dir: str | Path | None = None,
        threads: int | None = LIVE_THREADS,
        forecast: PointForecast | str | None = None,
        **options: Any,
    ) -> Predictor:
        """Load a ``.safetensors`` checkpoint (never a pickle) by path or shipped name
        (default: :data:`DEFAULT_CHECKPOINT`); ``options`` are the constructor's."""
        if threads is not None:
            threads = integer_argument(threads, "threads", 1)
        path = resolve_checkpoint(name_or_path, checkpoints_dir)
        model, config = load_trained_model(path)
        return cls(model, config, str(path), forecast, threads=threads, **options)

    @property
    def point_forecast_name(self) -> str:
        """The point forecast's one name (``ml-top10``, ``ml-argmax``, ...)."""
        return self.forecast.name

    @property
    def decoded_latent_values(self) -> int:
        """How many latent values the point forecast decodes (the mean: all of them)."""
        return self.forecast.latent_values(latent_values_of(self.config))

    @property
    def history_steps(self) -> int:
        """History steps the model reads (T, its ``data.history_steps``)."""
        return self.config.data.history_steps

    @property
    def frames_per_step(self) -> int:
        """Frame numbers between consecutive steps (the model's ``data.frames_per_step``)."""
        return self.config.data.frames_per_step

    @property
    def window_frames(self) -> int:
        """Frames before ``t`` a forecast reads: ``history_steps`` steps plus the two before
        them, so velocities and accelerations at the oldest step equal the whole track's, plus
        ``max_missed_steps`` so that a gap at the window's start can still be filled."""
        return (self.history_steps + 1 + self.max_missed_steps) * self.frames_per_step

    def predict(
        self,
        tracks: Any,
        t: int | None = None,
        num_samples: int = 0,
        seed: int = 0,
        *,
        live: bool = True,
    ) -> Forecast:
        """Forecast every agent observed at frame ``t`` (default: the last frame) with
        ``min_points`` consecutive steps up to it (missed steps filled; impossible jumps
        repaired with a warning, ``grouptron.data.formats.glitches``); rows after ``t`` are ignored
        unless ``live`` is False (a recording: then the derivatives use the rows the
        checkpoint's protocol reads, as the evaluator does; ``central`` reads two steps ahead).

        Args:
            tracks: (R, 4) rows ``frame, id, x, y`` (an array, a list of rows, or a table with
                those columns); frames on a grid of ``frames_per_step`` (10 for ETH/UCY-like
                0.4 s steps), ids integers, coordinates in metres.
            t: the frame to forecast from.
            num_samples: sampled futures per agent (0: only the most likely and the mixture).
            seed: seed of the samples.
        """
        values = as_track_array(tracks)
        if len(values) == 0:
            raise GrouptronError("tracks are empty: no frame, id, x, y rows")
        check_track_rows(values, self.frames_per_step)
        self.check_plausible(values)
        frame = int(values[:, 0].max()) if t is None else frame_argument(t, "t")
        first_frame, last_frame = int(values[:, 0].min()), int(values[:, 0].max())
        if not first_frame <= frame <= last_frame:
            raise GrouptronError(
                f"t={frame} is outside the tracks' frames {first_frame}-{last_frame}"
            )
        if (frame - first_frame) % self.frames_per_step:
            raise GrouptronError(
                f"t={frame} is not on the {self.frames_per_step}-frame grid of the tracks "
                f"(first frame {first_frame})"
            )
        # Only the rows a forecast at ``frame`` reads, so that a long recording is not turned
        # into a scene for every frame asked about (central derivatives read two steps ahead).
        ahead = 0 if live else 2 * self.frames_per_step
        near = (values[:, 0] >= frame - self.window_frames) & (values[:, 0] <= frame + ahead)
        rows = self._without_jumps(values[near], frame, np.flatnonzero(near))
        return self.forecast_window(rows, frame, num_samples, seed, warn_if_central=live)

    def _without_jumps(self, values: np.ndarray, frame: int, numbers: np.ndarray) -> np.ndarray:
        """``values``, jumps up to ``frame`` repaired and named by row ``numbers`` in a warning."""
        past = values[:, 0] <= frame
        if not self.check_speed:
            return values
        per_frame_s, fresh = self.config.data.dt_s / self.frames_per_step, values[:, 1].max() + 1
        repaired, found = glitches.repair_rows(values[past], per_frame_s, float(fresh))
        if len(found):
            rows, where = values[past], lambda r: f"row {numbers[past][r]}"
            text = glitches.describe_glitches(found, rows[:, 1], rows[:, 2:4], where)
            log.warning("tracks: %s", text)
        return np.concatenate([repaired, values[~past]])

    def stream(
        self,
        online_calibration: bool | str | Path | OnlineCalibration | None = None,
        learn: bool | LearningOptions | None = None,
        state: str | Path | None = None,
    ) -> StreamSession:
        """A session that is fed one frame at a time and keeps the history it needs.

        With ``online_calibration`` (default: the predictor's) its regions' radii adapt to
        every forecast whose truth arrives (True: starting from ``calibration``, else the
        Gaussian radii; a saved state's file, or an ``OnlineCalibration``, resumes it). With
        ``learn`` (default: the predictor's; True or ``LearningOptions``) it learns its site
        on its own copy of the weights (``session.learning``, ``session.save_site``). With
        ``state`` (a folder that ``session.save_state`` writes to), the session takes up the
        online radii and learnt weights kept there by an earlier one (none yet: a first
        start).
        """
        chosen = self.online_calibration if online_calibration is None else online_calibration
        options = self.learn if learn is None else _learning_options(learn)
        if options is None:
            session = StreamSession(
                self, online_state(chosen, self.config.data.horizon_steps, self.calibration)
            )
        else:
            own = copy.copy(self)  # the session's weights change; this predictor's do not
            learner = SiteLearner(
                self.model, self.config, self.forecast, options, self.max_missed_steps
            )
            session = StreamSession(
                own, online_state(chosen, self.config.data.horizon_steps, self.calibration), learner
            )
        if state is not None:
            log.info("resumed %s from %s", session.resume_state(state) or "nothing", state)
        return session

    def forecast_window(
        self,
        values: np.ndarray,
        frame: int,
        num_samples: int,
        seed: int,
        *,
        warn_if_central: bool = True,
    ) -> Forecast:
        """The forecast at ``frame`` of (R, 4) rows cut to its window and checked already."""
        num_samples = integer_argument(num_samples, "num_samples", 0, MAX_SAMPLES)
        seed = integer_argument(seed, "seed", -(2**63), 2**64 - 1)  # torch's seed range
        if warn_if_central:
            self._warn_if_central()
        data = self.config.data
        if len(values) == 0 or not (values[:, 0] == frame).any():
            return self._empty(frame, num_samples)
        # Only gaps closed by the forecast frame are filled: a later sighting must not put
        # anyone at a step before it (that would leak the future into the forecast).
        past = values[:, 0] <= frame
        filled_past, is_filled = bridge_gaps(
            values[past], data.frames_per_step, self.max_missed_steps
        )
        values = np.concatenate([filled_past, values[~past]])
        is_filled = np.concatenate([is_filled, np.zeros(int((~past).sum()), dtype=bool)])
        table = table_from_values(
            Path("tracks"),
            values,
            np.arange(len(values)),
            data.frames_per_step,
            on_gap="split",
            warn_on_gap=False,
        )
        scene = build_scene(table, data, name="tracks")
        step = (frame - scene.first_frame) // scene.frames_per_step
        samples = scene_samples(scene, data, self.min_points, require_future=False, only_step=step)
        if not len(samples):
            return self._empty(frame, num_samples)
        forecast = self._run(scene, samples, frame, step, num_samples=num_samples, seed=seed)
        points = forecast.observed_points  # filled ones included so far
        assert points is not None
        filled = filled_in_histories(
            forecast.ids, frame, points, values[is_filled, :2], frames_per_step=self.frames_per_step
        )
        return dataclasses.replace(
            forecast,
            observed_points=points - filled,
            filled_points=filled,
            calibration=self.calibration,
        )

    def _run(
        self,
        scene: Scene,
        samples: SampleSet,
        frame: int,
        step: int,
        *,
        num_samples: int,
        seed: int,
    ) -> Forecast:
        data = self.config.data
        # The step's distances serve both the scene-wide groups and every sample's own.
        found = groups_at_step(scene, self.group_rule, step, data.history_steps, self.pair_memory)
        groups = None
        if uses_groups(self.config) and found is not None:
            groups = assign_groups_at_step(samples, found.tracks, found.distances, self.group_rule)
        options = EngineOptions(
            mixture=self.mixture,
            num_samples=num_samples,
            seed=seed,
            batch_size=len(samples),
            device=self.device,
        )
        with torch_threads(self.threads):
            made = forecast_samples(
                self.model, self.config, samples, self.forecast, groups, options
            )
        origin = samples.pos_now_scene_m.astype(np.float64) + scene.centre_world_m  # (N, 2)
        group_of_track = np.full(scene.num_tracks, -1)
        if found is not None:
            group_of_track[found.tracks] = found.labels
        ids = scene.ped_id[samples.track]
        order = np.argsort(ids, kind="stable")
        assert made.distribution is not None
        return Forecast(
            frame=frame,
            frames=np.full(len(ids), frame, dtype=np.int64),
            ids=ids[order],
            point=(made.point + origin[:, None])[order],
            samples=None if made.samples is None else (made.samples + origin[:, None, None])[order],
            distribution=made.distribution.moved(origin).rows(order),
            mixture=None if made.mixture is None else made.mixture.moved(origin).rows(order),
            group=group_of_track[samples.track][order],
            observed_points=samples.hist_mask.sum(axis=1)[order],  # filled ones counted too
            filled_points=np.zeros(len(ids), dtype=np.int64),
        )

    def check_plausible(self, values: np.ndarray, min_pairs: int = 1) -> bool:
        """Refuse (R, 4) tracks whose median speed no pedestrian walks (wrong units or frame
        grid); returns whether there were ``min_pairs`` consecutive observations to judge."""
        if not self.check_speed:
            return True
        return check_walking_speed(values, self.config.data, self.frames_per_step, min_pairs)

    def _empty(self, frame: int, num_samples: int) -> Forecast:
        data, Z = self.config.data, latent_values_of(self.config)
        M = self.decoded_latent_values
        empty = empty_forecast(frame, data.horizon_steps, Z, M, num_samples, self.mixture)
        return dataclasses.replace(empty, calibration=self.calibration)

    def _warn_if_central(self) -> None:
        if self.config.data.derivatives == "central" and not self._warned_central:
            self._warned_central = True
            warnings.warn(
                f"{self.source or 'this model'} was trained with central derivatives, whose "
                "velocity at the last observed step uses the next position; live tracks do not "
                "have it, so forecasts are off-protocol. Use a 'backward' checkpoint for live "
                "data.",
                stacklevel=3,
            )


def _learning_options(learn: bool | LearningOptions) -> LearningOptions | None:
    """The options of ``learn`` (None: no learning)."""
    if isinstance(learn, LearningOptions):
        return learn
    if isinstance(learn, bool):
        return LearningOptions() if learn else None
    raise GrouptronError(f"learn must be True, False or LearningOptions, not {learn!r}")


def _chosen_forecast(
    named: PointForecast | str | None,
    config: ExperimentConfig,
    most_likely: str | None = None,
    latent_values: int | None = None,
) -> PointForecast:
    """The point forecast a predictor makes: ``named``, else the model's own; the older
    keywords ``most_likely`` (its older name) and ``latent_values=K`` (``ml-topK``) with a
    warning."""
    if most_likely is not None:
        warnings.warn("most_likely= is now called forecast=", FutureWarning, stacklevel=3)
        if named is not None:
            raise GrouptronError("give forecast= or its older name most_likely=, not both")
        named = most_likely
    if named is not None:
        forecast = PointForecast.parse(named)
    elif latent_values is not None:  # latent_values=K alone asks for ml of K (ml-topK)
        forecast = PointForecast("ml")
    else:
        forecast = default_point_forecast(config)
    if latent_values is not None:
        warnings.warn(
            "latent_values=K is now named as forecast='ml-topK'", FutureWarning, stacklevel=3
        )
        K = integer_argument(latent_values, "latent_values", 1, latent_values_of(config))
        plain_ml = forecast == PointForecast("ml")  # ml of K latent values is ml-topK
        if not plain_ml and forecast.latent_values(latent_values_of(config)) != K:
            raise GrouptronError(f"forecast={str(named)!r} does not decode {K} latent values")
        forecast = PointForecast("ml", K)
    return forecast.for_model(latent_values_of(config))
