"""The Python API: forecasts for live or recorded tracks from a trained checkpoint.

    predictor = Predictor.from_checkpoint("grouptron-univ-backward")
    forecast = predictor.predict(tracks)            # (R, 4) frame, id, x, y
    session = predictor.stream()
    forecast = session.update(frame, ids, xy)       # one frame at a time

Only positions up to the forecast frame are used. Every agent observed at that frame with
``history_steps`` consecutive steps gets a forecast; the others are skipped.
"""

from __future__ import annotations

import logging
import os
import warnings
from pathlib import Path
from typing import Any, Literal

import numpy as np
import torch

from grouptron.config import ExperimentConfig
from grouptron.data.reader import table_from_values
from grouptron.data.recording import MAX_MEDIAN_SPEED_MPS, median_speed_mps
from grouptron.data.samples import SampleSet, scene_samples
from grouptron.data.scene import Scene, build_scene
from grouptron.devices import available_device
from grouptron.errors import GrouptronError
from grouptron.groups.scene import groups_at_step
from grouptron.inference.forecast import Forecast
from grouptron.inference.tracks import groups_for_model
from grouptron.model.batch import Batch, batches
from grouptron.model.checkpoint import load_trained_model
from grouptron.model.cvae import TrajectronCVAE
from grouptron.model.gaussians import (
    covariance_matrices,
    position_covariances,
    positions_from_velocities,
)
from grouptron.model.predict import (
    decode_every_latent,
    most_likely_positions,
    predict_argmax_latent,
    predict_samples,
)

log = logging.getLogger(__name__)

CHECKPOINTS_ENV = "GROUPTRON_CHECKPOINTS"
WEIGHTS_FILE = "best.safetensors"
SOURCE_CHECKPOINTS = Path(__file__).resolve().parents[3] / "checkpoints"
"""The shipped checkpoints of the source tree this package runs from (src/ layout)."""
TRACK_COLUMNS = ("frame", "id", "x", "y")
MostLikely = Literal["ml", "ml-argmax"]
MOST_LIKELY_CHOICES = ("ml", "ml-argmax")
STREAM_MIN_PAIRS = 30
"""A stream's speeds are judged once it holds this many consecutive observations."""
OLDER_NAMES = {"mixture-mode": "ml", "argmax-latent": "ml-argmax"}
"""Names these choices had before the vocabulary was unified (still accepted)."""


def _as_track_array(tracks: Any) -> np.ndarray:
    """(R, 4) float64 ``frame, id, x, y`` from an array or a table with those columns."""
    if hasattr(tracks, "columns"):  # a DataFrame-like table: pick the columns by name
        missing = [c for c in TRACK_COLUMNS if c not in list(tracks.columns)]
        if missing:
            raise GrouptronError(f"tracks lack the columns {missing} (need frame, id, x, y)")
        tracks = np.column_stack([np.asarray(tracks[c], dtype=np.float64) for c in TRACK_COLUMNS])
    try:
        values = np.asarray(tracks, dtype=np.float64)
    except (TypeError, ValueError):
        raise GrouptronError("tracks must be numbers: rows of frame, id, x, y") from None
    if values.ndim != 2 or values.shape[1] != 4:
        raise GrouptronError(
            f"tracks must have shape (rows, 4) = frame, id, x, y; got {values.shape}"
        )
    bad = np.flatnonzero(~np.isfinite(values).all(axis=1))
    if bad.size:
        raise GrouptronError(f"tracks row {int(bad[0])} is not finite: {values[bad[0]].tolist()}")
    return values


def resolve_checkpoint(name_or_path: str | Path, checkpoints_dir: str | Path | None = None) -> Path:
    """A checkpoint file from a path or a shipped name such as ``"grouptron-univ-backward"``.

    Names are looked up in ``checkpoints_dir``, ``$GROUPTRON_CHECKPOINTS``, ``./checkpoints`` and
    the ``checkpoints/`` folder of the source tree grouptron is installed from, so shipped names
    resolve from any working directory.
    """
    path = Path(name_or_path)
    if path.is_file():
        return path
    if path.is_dir() and (path / WEIGHTS_FILE).is_file():
        return path / WEIGHTS_FILE
    if path.suffix == ".safetensors" or len(path.parts) > 1:  # a path, not a shipped name
        raise GrouptronError(f"{path}: checkpoint not found")
    folders = [Path(d) for d in (checkpoints_dir, os.environ.get(CHECKPOINTS_ENV)) if d]
    folders += [Path("checkpoints"), SOURCE_CHECKPOINTS]
    for folder in folders:
        candidate = folder / str(name_or_path) / WEIGHTS_FILE
        if candidate.is_file():
            return candidate
    known = sorted(
        {p.parent.name for f in folders if f.is_dir() for p in f.glob(f"*/{WEIGHTS_FILE}")}
    )
    hint = f"; known names: {', '.join(known)}" if known else ""
    raise GrouptronError(
        f"no checkpoint {name_or_path!s}: not a file, and no {WEIGHTS_FILE} under "
        f"{', '.join(str(f) for f in dict.fromkeys(folders))}{hint} (set ${CHECKPOINTS_ENV} to "
        "a folder of <name>/best.safetensors)"
    )


class Predictor:
    """A trained Trajectron++ or Grouptron model ready to forecast tracks.

    Args:
        most_likely: ``"ml"`` (the benchmark's most likely trajectory: per step the
            mode of the p(z|x)-weighted mixture over all Z latent values) or
            ``"ml-argmax"`` (follow the means of the most probable latent value only; the
            "ML-argmax" row of the evaluator, several times faster without the mixture).
        mixture: also return the mixture parameters (decodes all Z latent values).
        check_speed: refuse tracks whose median speed no pedestrian walks (wrong units).
        device: where the network runs (``cpu``, ``cuda``, ``cuda:1``, ``mps``); results are
            NumPy arrays either way. One clear error when the device is not available.
    """

    def __init__(
        self,
        model: TrajectronCVAE,
        config: ExperimentConfig,
        source: str = "",
        most_likely: MostLikely = "ml",
        *,
        mixture: bool = True,
        check_speed: bool = True,
        device: str | torch.device = "cpu",
    ) -> None:
        most_likely = OLDER_NAMES.get(most_likely, most_likely)  # type: ignore[assignment]
        if most_likely not in MOST_LIKELY_CHOICES:
            raise GrouptronError(
                f"most_likely must be one of {', '.join(MOST_LIKELY_CHOICES)}, not {most_likely!r}"
            )
        self.device = available_device(device)
        self.model = model.eval().to(self.device)
        self.config = config
        self.source = source
        self.most_likely = most_likely
        self.mixture = mixture
        self.check_speed = check_speed
        self._warned_central = False

    @classmethod
    def from_checkpoint(
        cls,
        name_or_path: str | Path,
        checkpoints_dir: str | Path | None = None,
        threads: int | None = None,
        most_likely: MostLikely = "ml",
        *,
        mixture: bool = True,
        check_speed: bool = True,
        device: str | torch.device = "cpu",
    ) -> Predictor:
        """Load a ``.safetensors`` checkpoint (never a pickle) by path or shipped name."""
        path = resolve_checkpoint(name_or_path, checkpoints_dir)
        model, config = load_trained_model(path)
        if threads is not None:
            torch.set_num_threads(threads)
        return cls(
            model,
            config,
            str(path),
            most_likely=most_likely,
            mixture=mixture,
            check_speed=check_speed,
            device=device,
        )

    @property
    def history_steps(self) -> int:
        return self.config.data.history_steps

    @property
    def frames_per_step(self) -> int:
        return self.config.data.frames_per_step

    @property
    def window_frames(self) -> int:
        """Frames before ``t`` a forecast reads: ``history_steps`` steps plus the two before
        them, so velocities and accelerations at the oldest step equal the whole track's."""
        return (self.history_steps + 1) * self.frames_per_step

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
        ``history_steps`` consecutive steps up to it; rows after ``t`` are ignored unless
        ``live`` is False (a recording: then the derivatives use the rows the checkpoint's
        protocol reads, as the evaluator does; ``central`` reads two steps ahead).

        Args:
            tracks: (R, 4) rows ``frame, id, x, y`` (an array, a list of rows, or a table with
                those columns); frames on a grid of ``frames_per_step`` (10 for ETH/UCY-like
                0.4 s steps), ids integers, coordinates in metres.
            t: the frame to forecast from.
            num_samples: sampled futures per agent (0: only the most likely and the mixture).
            seed: seed of the samples.
        """
        values = _as_track_array(tracks)
        if len(values) == 0:
            raise GrouptronError("tracks are empty: no frame, id, x, y rows")
        self.check_plausible(values)
        frame = int(values[:, 0].max()) if t is None else int(t)
        # Only the rows a forecast at ``frame`` reads, so that a long recording is not turned
        # into a scene for every frame asked about (central derivatives read two steps ahead).
        ahead = 0 if live else 2 * self.frames_per_step
        near = (values[:, 0] >= frame - self.window_frames) & (values[:, 0] <= frame + ahead)
        return self._forecast(values[near], frame, num_samples, seed, warn_if_central=live)

    def stream(self) -> StreamSession:
        """A session that is fed one frame at a time and keeps the history it needs."""
        return StreamSession(self)

    def _forecast(
        self,
        values: np.ndarray,
        frame: int,
        num_samples: int,
        seed: int,
        *,
        warn_if_central: bool = True,
    ) -> Forecast:
        if num_samples < 0:
            raise GrouptronError(f"num_samples must be >= 0, not {num_samples}")
        if warn_if_central:
            self._warn_if_central()
        data = self.config.data
        if len(values) == 0 or not (values[:, 0] == frame).any():
            return self._empty(frame, num_samples)
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
        samples = scene_samples(
            scene, data, data.history_steps, require_future=False, only_step=step
        )
        if not len(samples):
            return self._empty(frame, num_samples)
        return self._run(scene, samples, frame, step, num_samples=num_samples, seed=seed)

    @torch.inference_mode()
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
        data, H, dt = self.config.data, self.config.data.horizon_steps, self.config.data.dt_s
        groups = groups_for_model(samples, self.config)
        ((_, batch),) = batches(samples, self.config, len(samples), groups)
        batch = batch.to(self.device)
        most_likely, log_weights, mean, cov = self._most_likely_and_mixture(batch)
        drawn = None
        if num_samples:
            generator = torch.Generator(device=self.device).manual_seed(seed)
            drawn = predict_samples(
                self.model, batch, H, dt, num_samples=num_samples, generator=generator
            )
        origin = samples.pos_now_scene_m.astype(np.float64) + scene.centre_world_m  # (N, 2)
        found = groups_at_step(scene, self.config.groups, step, data.history_steps)
        group_of_track = np.full(scene.num_tracks, -1)
        if found is not None:
            group_of_track[found.tracks] = found.labels
        ids = scene.ped_id[samples.track]
        order = np.argsort(ids, kind="stable")
        return Forecast(
            frame=frame,
            frames=np.full(len(ids), frame, dtype=np.int64),
            ids=ids[order],
            most_likely=(most_likely + origin[:, None])[order],
            samples=None
            if drawn is None
            else (drawn.double().cpu().numpy() + origin[:, None, None])[order],
            mixture_log_weights=None if log_weights is None else log_weights[order],
            mixture_means=None if mean is None else (mean + origin[:, None, None])[order],
            mixture_covariances=None if cov is None else cov[order],
            group=group_of_track[samples.track][order],
        )

    def _most_likely_and_mixture(
        self, batch: Batch
    ) -> tuple[np.ndarray, np.ndarray | None, np.ndarray | None, np.ndarray | None]:
        """(N, H, 2) most likely offsets from now and, if asked for, the mixture: (N, Z) log
        weights, (N, Z, H, 2) position offsets, (N, Z, H, 2, 2) covariances (float64)."""
        H, dt = self.config.data.horizon_steps, self.config.data.dt_s
        if not self.mixture and self.most_likely == "ml-argmax":
            fast = predict_argmax_latent(self.model, batch, H, dt)  # decodes one latent value
            return fast.double().cpu().numpy(), None, None, None
        encoding, velocity = decode_every_latent(self.model, batch, H)
        mean = positions_from_velocities(velocity.mean, dt)  # (N, Z, H, 2)
        if self.most_likely == "ml":
            most_likely = most_likely_positions(encoding, velocity, H, dt)
        else:
            best = encoding.p_logits.argmax(dim=-1)  # (N,)
            most_likely = mean[torch.arange(len(best)), best]
        if not self.mixture:
            return most_likely.double().cpu().numpy(), None, None, None
        cov = position_covariances(velocity.cov, dt)  # (N, Z, H, 3)
        return (
            most_likely.double().cpu().numpy(),
            torch.log_softmax(encoding.p_logits, -1).double().cpu().numpy(),
            mean.double().cpu().numpy(),
            covariance_matrices(cov).double().cpu().numpy(),
        )

    def check_plausible(self, values: np.ndarray, min_pairs: int = 1) -> bool:
        """Refuse (R, 4) tracks whose median speed no pedestrian walks (wrong units or frame
        grid); returns whether there were ``min_pairs`` consecutive observations to judge."""
        if not self.check_speed:
            return True
        seconds_per_frame = self.config.data.dt_s / self.frames_per_step
        time_s = values[:, 0] * seconds_per_frame
        pairs = len(values) - len(np.unique(values[:, 1]))
        if pairs < min_pairs:
            return False
        median = median_speed_mps(values[:, 1], time_s, values[:, 2:4])
        if median > MAX_MEDIAN_SPEED_MPS:
            raise GrouptronError(
                f"the tracks' median walking speed is {median:.3g} m/s with frames "
                f"{self.frames_per_step} apart per {self.config.data.dt_s} s step: positions "
                "must be metres (convert centimetres or millimetres) and frames on that grid; "
                "Predictor(check_speed=False) goes on anyway"
            )
        return True

    def _empty(self, frame: int, num_samples: int) -> Forecast:
        H, Z = self.config.data.horizon_steps, self.config.model.latent_modes
        return Forecast(
            frame=frame,
            frames=np.zeros(0, dtype=np.int64),
            ids=np.zeros(0),
            most_likely=np.zeros((0, H, 2)),
            samples=np.zeros((0, num_samples, H, 2)) if num_samples else None,
            mixture_log_weights=np.zeros((0, Z)) if self.mixture else None,
            mixture_means=np.zeros((0, Z, H, 2)) if self.mixture else None,
            mixture_covariances=np.zeros((0, Z, H, 2, 2)) if self.mixture else None,
            group=np.zeros(0, dtype=np.int64),
        )

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


def _frame_arrays(frame: int, ids: Any, xy: Any) -> tuple[np.ndarray, np.ndarray]:
    """(N,) ids and (N, 2) positions of one frame, checked strictly: a (2, N) array, ids of
    another length or repeated ids are refused, never reshaped into scrambled points."""
    try:
        ids_arr = np.asarray(ids, dtype=np.float64)
        xy_arr = np.asarray(xy, dtype=np.float64)
    except (TypeError, ValueError):
        raise GrouptronError(f"frame {frame}: ids and positions must be numbers") from None
    if ids_arr.ndim != 1:
        raise GrouptronError(f"frame {frame}: ids must be a 1-d array, got shape {ids_arr.shape}")
    if len(ids_arr) == 0 and xy_arr.size == 0:
        return ids_arr, np.zeros((0, 2))
    if xy_arr.shape != (len(ids_arr), 2):
        raise GrouptronError(
            f"frame {frame}: positions must have shape (N, 2) = ({len(ids_arr)}, 2) for "
            f"{len(ids_arr)} ids, got {xy_arr.shape} (one row of x, y per person; a (2, N) "
            "array needs transposing)"
        )
    if len(np.unique(ids_arr)) != len(ids_arr):
        raise GrouptronError(f"frame {frame}: an id appears twice in one frame")
    return ids_arr, xy_arr


class StreamSession:
    """Feeds a :class:`Predictor` one frame at a time.

    Keeps the last ``Predictor.window_frames`` of rows (the history and the two steps before
    it); agents appear and vanish freely and a missed detection splits the agent's track.
    """

    def __init__(self, predictor: Predictor) -> None:
        self.predictor = predictor
        self._rows = np.zeros((0, 4))
        self._last_frame: int | None = None
        self._judged = False  # units and frame grid judged plausible once (they do not change)

    @property
    def window_frames(self) -> int:
        return self.predictor.window_frames

    def update(
        self, frame: int, ids: Any, xy: Any, num_samples: int = 0, *, seed: int = 0
    ) -> Forecast:
        """Add the agents observed at ``frame`` ((N,) ids, (N, 2) positions in metres) and
        forecast every agent with enough history."""
        ids_arr, xy_arr = _frame_arrays(frame, ids, xy)
        if self._last_frame is not None:
            if frame <= self._last_frame:
                raise GrouptronError(
                    f"frame {frame} is not after the previous frame {self._last_frame}"
                )
            if (frame - self._last_frame) % self.predictor.frames_per_step:
                raise GrouptronError(
                    f"frame {frame} is not on the {self.predictor.frames_per_step}-frame grid of "
                    f"the previous frame {self._last_frame}"
                )
        new = np.column_stack([np.full(len(ids_arr), float(frame)), ids_arr, xy_arr])
        _as_track_array(new)  # finite, shape
        rows = np.concatenate([self._rows, new])
        self._rows = rows[rows[:, 0] >= frame - self.window_frames]
        self._last_frame = frame
        if not self._judged:
            self._judged = self.predictor.check_plausible(self._rows, min_pairs=STREAM_MIN_PAIRS)
        return self.predictor._forecast(self._rows, frame, num_samples, seed)
