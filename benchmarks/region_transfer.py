"""Regions that transfer: which region shape and score let a calibration fitted on held-back
data hold its share at sites it never saw.

Usage:
    python benchmarks/region_transfer.py [--checkpoint NAME] [--forecast ml-top2]
                                         [--candidates A,B,...] [--details A,B] [--q 0.9]
                                         [--cache /tmp/region_transfer] [--threads 1]
                                         [--datasets A.toml,B.toml] [--leave-one-site-out]

The calibration set is the validation part of the checkpoint's own dataset description
(``campaign/deployment/eth-ucy-and-crowds.toml`` for the default model: the station's last
three files, the forum's August day, two campus sequences; never trained on). The
development set is the test parts of ``--datasets`` (default: ``DEVELOPMENT_SET``, the three
bookstore videos and the three corridor runs). Every person with 8 observed and 12 future
steps is forecast once with the checkpoint's point forecast and all its latent values
decoded; what the candidates need (the point forecast, the truth, the speed now, the shapes
of the point forecast's own 2-value mixture, of the 5 and 10 most probable latent values'
and of the whole 25-value mixture about it, the neighbours at t, the model's own
uncalibrated 90% regions) is cached per file in ``--cache``
as npz, so later runs only re-score.

Each candidate is a score per forecast step whose sublevel sets are the regions (an ellipse
or a circle around the point forecast). Its radius per step (per density bin for the
``E-...`` candidates) is fitted by split conformal prediction on the whole calibration set
(``model.regions.conformal_radii``: the ceil((n + 1) q)-th smallest score) and the regions
of that radius are checked on every development recording. Prints a summary per candidate
(does it hold 85-95% at steps 4, 8 and 12 on every development recording; by how much it
misses; whether any radius at all could), then per candidate and development recording the
share of truths inside at steps 4, 8, 12 (and over all twelve) and the mean region area in
m^2 at those steps; for the ``--details`` candidates the same per file with 95% intervals
over resampled time steps, the scale each recording's radius would need and the fitted
radii. ``--leave-one-site-out`` adds the same check inside the calibration set: fitted on
two of its three sites, checked on the third.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import torch

from grouptron.config import ExperimentConfig
from grouptron.constants import DT_S
from grouptron.data.datasets.custom import read_dataset
from grouptron.data.datasets.subsets import DENSITY_BINS
from grouptron.data.formats.track_files import TrackSource
from grouptron.data.prepare.samples import SampleSet
from grouptron.evaluation.recordings import recording_samples
from grouptron.inference.checkpoints import DEFAULT_CHECKPOINT, resolve_checkpoint
from grouptron.inference.engine import EngineOptions, forecast_samples
from grouptron.model.checkpoint import load_trained_model
from grouptron.model.cvae import TrajectronCVAE
from grouptron.model.factory import groups_for_model
from grouptron.model.mixture import Mixture
from grouptron.model.predict import default_point_forecast
from grouptron.model.regions import conformal_radii, prediction_regions, region_shapes
from grouptron.point_forecast import PointForecast

sys.path.insert(0, str(Path(__file__).resolve().parent))
from out_of_domain import DEVELOPMENT_SET

STEPS = (4, 8, 12)
BAND = (0.85, 0.95)
"""The share the 90% regions must hold at every one of STEPS on every development recording."""
CACHE_VERSION = 2

# --- forecasts, cached -----------------------------------------------------------------------


@dataclass(frozen=True)
class Recording:
    """One file: ``part`` is "calibration" or "development", ``site`` the place it shows."""

    part: str
    site: str
    name: str
    path: Path
    arrays: dict[str, np.ndarray]


def _speed_now(samples: SampleSet, dt: float) -> np.ndarray:
    """(S,) the speed over the last observed step, m/s (``hist_rel_m``'s last row is now)."""
    return np.linalg.norm(samples.hist_rel_m[:, -2].astype(np.float64), axis=-1) / dt


def _region_arrays(point: np.ndarray, mixture: Mixture, truth: np.ndarray, prefix: str) -> dict:
    """The mixture's shape about the point forecast and its own (uncalibrated) 90% region:
    whether the truth is inside, its area and its Mahalanobis radius under the shape."""
    shape = region_shapes(point, mixture)
    regions = prediction_regions(point, mixture, 0.9)
    largest = np.linalg.eigvalsh(shape)[..., -1]
    return {
        f"shape_{prefix}": shape,
        f"inside90_{prefix}": regions.contains(truth),
        f"area90_{prefix}": np.pi * regions.major_m * regions.minor_m,
        f"radius90_{prefix}": regions.major_m / np.sqrt(np.maximum(largest, 1e-300)),
    }


TOP = (5, 10)
"""The shapes of the K most probable latent values' mixtures are kept too (cheaper than 25)."""


def top(mixture: Mixture, k: int) -> Mixture:
    """The mixture of each person's ``k`` most probable components (weights renormalised
    where the shape is taken): what an ``ml-top{k}`` forecast decodes."""
    order = np.argsort(-mixture.log_weights, axis=1, kind="stable")[:, :k]
    return Mixture(
        np.take_along_axis(mixture.log_weights, order, 1),
        np.take_along_axis(mixture.means, order[:, :, None, None], 1),
        np.take_along_axis(mixture.covariances, order[:, :, None, None, None], 1),
    )


def forecast_arrays(
    model: TrajectronCVAE, config: ExperimentConfig, samples: SampleSet, forecast: PointForecast
) -> dict[str, np.ndarray]:
    """Everything the candidates need of one recording's forecasts (float64, metres)."""
    groups = groups_for_model(samples, config)
    made = forecast_samples(model, config, samples, forecast, groups, EngineOptions(mixture=True))
    assert made.distribution is not None and made.mixture is not None
    truth = samples.fut_rel_m.astype(np.float64)
    return {
        "point": made.point,
        "truth": truth,
        "speed": _speed_now(samples, config.data.dt_s),
        "neighbours": samples.num_neighbours,
        "step": samples.step,
        **{f"shape_top{k}": region_shapes(made.point, top(made.mixture, k)) for k in TOP},
        **_region_arrays(made.point, made.distribution, truth, "own"),
        **_region_arrays(made.point, made.mixture, truth, "all"),
    }


def cached_arrays(
    model: TrajectronCVAE,
    config: ExperimentConfig,
    forecast: PointForecast,
    samples_of: Callable[[], SampleSet],
    cache: Path,
    key: str,
) -> dict[str, np.ndarray]:
    """:func:`forecast_arrays` of a recording, from ``cache`` when it was made before."""
    path = cache / f"v{CACHE_VERSION}-{key}.npz"
    if path.exists():
        with np.load(path) as stored:
            return dict(stored)
    arrays = forecast_arrays(model, config, samples_of(), forecast)
    cache.mkdir(parents=True, exist_ok=True)
    np.savez(path, **arrays)
    return arrays


def load_recordings(
    checkpoint: str, forecast_name: str | None, datasets: str, cache: Path
) -> list[Recording]:
    """Every calibration file (the checkpoint's dataset's val part) and development file (the
    test parts of ``datasets``), forecast or read from ``cache``."""
    model, config = load_trained_model(resolve_checkpoint(checkpoint))
    model.eval()
    named = PointForecast.parse(forecast_name) if forecast_name else None
    forecast = (named or default_point_forecast(config)).for_model(config.model.latent_values)
    parts = [("calibration", read_dataset(config.dataset), "val")]
    parts += [("development", read_dataset(d), "test") for d in datasets.split(",") if d]
    out = []
    for part, dataset, split in parts:
        for path in dataset.files(split):
            source = TrackSource.from_format(path, dataset.recording)
            key = f"{Path(checkpoint).name}-{forecast}-{dataset.name}-{path.stem}"
            arrays = cached_arrays(
                model, config, forecast,
                lambda source=source: recording_samples([source], config.data),
                cache, key,
            )  # fmt: skip
            site = path.parent.name if part == "calibration" else dataset.name
            out.append(Recording(part, site, path.stem, path, arrays))
    return out


# --- candidates ------------------------------------------------------------------------------


def _mahalanobis(shape: np.ndarray, offset: np.ndarray) -> np.ndarray:
    solved = np.linalg.solve(shape, offset[..., None])[..., 0]
    return np.sqrt(np.maximum((offset * solved).sum(-1), 0.0))


def speed_scale(arrays: dict[str, np.ndarray], floor_m: float, dt: float = DT_S) -> np.ndarray:
    """(S, H) ``floor_m + speed_now * k * dt`` at step k: how far constant velocity goes."""
    H = arrays["truth"].shape[1]
    ahead = dt * np.arange(1, H + 1)
    scale: np.ndarray = floor_m + arrays["speed"][:, None] * ahead[None, :]
    return scale


def _ellipse(shape: np.ndarray, arrays: dict[str, np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    offset = arrays["truth"] - arrays["point"]
    unit = np.pi * np.sqrt(np.maximum(np.linalg.det(shape), 0.0))
    return _mahalanobis(shape, offset), unit


def _inflated(shape: np.ndarray, scale: np.ndarray, lam: np.ndarray) -> np.ndarray:
    """``shape + (lam_k * scale)^2 I``: a speed-scaled isotropic part added to the shape."""
    extra = (np.asarray(lam)[None, :] * scale) ** 2
    return shape + extra[..., None, None] * np.eye(2)


@dataclass(frozen=True)
class Candidate:
    """A region family: ``score(arrays, fitted)`` -> (score, unit area), with per-step
    numbers ``fit(calibration arrays)`` estimates (stored with the calibration), and whether
    radii are fitted per density bin."""

    name: str
    description: str
    score: Callable[[dict[str, np.ndarray], dict], tuple[np.ndarray, np.ndarray]]
    fit: Callable[[dict[str, np.ndarray]], dict] = lambda arrays: {}
    by_density: bool = False


def moment_lambda(shape_key: str, floor_m: float) -> Callable[[dict[str, np.ndarray]], dict]:
    """Per step the lam_k^2 = max(0, mean(|e|^2 - tr shape) / mean(2 s_k^2)) that makes the
    inflated shape's trace match the calibration errors' mean square (moments, no quantile)."""

    def fit(arrays: dict[str, np.ndarray]) -> dict:
        error = ((arrays["truth"] - arrays["point"]) ** 2).sum(-1)
        trace = np.trace(arrays[shape_key], axis1=-2, axis2=-1)
        scale = speed_scale(arrays, floor_m)
        lam2 = (error - trace).mean(0) / (2 * (scale**2).mean(0))
        return {"lam": np.sqrt(np.maximum(lam2, 0.0))}

    return fit


def _circle(arrays: dict[str, np.ndarray], floor_m: float) -> tuple[np.ndarray, np.ndarray]:
    scale = speed_scale(arrays, floor_m)
    distance = np.linalg.norm(arrays["truth"] - arrays["point"], axis=-1)
    return distance / scale, np.pi * scale**2


def _own_radius_ratio(arrays: dict[str, np.ndarray], key: str) -> tuple[np.ndarray, np.ndarray]:
    """The Mahalanobis score over the mixture's own 90% radius: calibrates a factor on the
    model's own 90% region (whose radius reflects how multi-modal the mixture is)."""
    distance, unit = _ellipse(arrays[f"shape_{key}"], arrays)
    own = arrays[f"radius90_{key}"]
    return distance / own, unit * own**2


def candidates() -> dict[str, Candidate]:
    """Every candidate by name."""

    def inflated(key: str, floor_m: float) -> Callable:
        def score(arrays: dict[str, np.ndarray], fitted: dict) -> tuple[np.ndarray, np.ndarray]:
            scale = speed_scale(arrays, floor_m)
            return _ellipse(_inflated(arrays[f"shape_{key}"], scale, fitted["lam"]), arrays)

        return score

    out = [
        Candidate(
            "A",
            "own 2-value mixture's shape, Mahalanobis, radius per step (today's)",
            lambda a, f: _ellipse(a["shape_own"], a),
        ),
        Candidate(
            "B",
            "whole 25-value mixture's shape about the point, Mahalanobis",
            lambda a, f: _ellipse(a["shape_all"], a),
        ),
        *(
            Candidate(
                f"B{k}",
                f"the {k} most probable latent values' mixture's shape about the point, "
                "Mahalanobis",
                lambda a, f, k=k: _ellipse(a[f"shape_top{k}"], a),
            )
            for k in TOP
        ),
        Candidate(
            "B-ratio",
            "B over the 25-value mixture's own 90% radius",
            lambda a, f: _own_radius_ratio(a, "all"),
        ),
        Candidate(
            "A-ratio",
            "A over the 2-value mixture's own 90% radius",
            lambda a, f: _own_radius_ratio(a, "own"),
        ),
        Candidate(
            "euclid",
            "circle, |truth - point| (no normaliser)",
            lambda a, f: (
                np.linalg.norm(a["truth"] - a["point"], axis=-1),
                np.full(a["truth"].shape[:2], np.pi),
            ),
        ),
    ]
    for floor in (0.1, 0.2, 0.3):
        out.append(Candidate(
            f"C{floor:g}", f"circle, |truth - point| / ({floor:g} m + speed * k dt)",
            lambda a, f, floor=floor: _circle(a, floor),
        ))  # fmt: skip
    for key in ("own", "all"):
        letter = "A" if key == "own" else "B"
        out.append(Candidate(
            f"D{letter}", f"{letter}'s shape + (lam_k (0.2 m + speed * k dt))^2 I, lam_k by "
            "moments on the calibration set",
            inflated(key, 0.2), moment_lambda(f"shape_{key}", 0.2),
        ))  # fmt: skip
    return {c.name: c for c in out}


def with_density(base: Candidate) -> Candidate:
    """``base`` with one radius per step and density bin (neighbours within 3 m at t)."""
    return Candidate(
        f"E-{base.name}",
        f"{base.name}, radius per step and density bin",
        base.score,
        base.fit,
        by_density=True,
    )


def density_bin(neighbours: np.ndarray) -> np.ndarray:
    """(S,) the index of each sample's bin in DENSITY_BINS."""
    lows = np.array([low for low, _ in DENSITY_BINS])
    return np.searchsorted(lows, neighbours, side="right") - 1


# --- fitting and checking --------------------------------------------------------------------


def _pooled(recordings: list[Recording]) -> dict[str, np.ndarray]:
    return {k: np.concatenate([r.arrays[k] for r in recordings]) for k in recordings[0].arrays}


def fit_radii(
    candidate: Candidate, calibration: dict[str, np.ndarray], q: float
) -> tuple[dict, np.ndarray]:
    """The candidate's fitted numbers and its (G, H) conformal radii per density bin (G = 1
    unless by density; a bin without enough calibration forecasts takes the pooled radius)."""
    fitted = candidate.fit(calibration)
    score, _ = candidate.score(calibration, fitted)
    pooled = conformal_radii(score, np.array([q]))[0]
    if not candidate.by_density:
        return fitted, pooled[None, :]
    bins = density_bin(calibration["neighbours"])
    radii = np.stack([
        conformal_radii(score[bins == g], np.array([q]))[0] if (bins == g).any() else pooled
        for g in range(len(DENSITY_BINS))
    ])  # fmt: skip
    return fitted, np.where(np.isfinite(radii), radii, pooled)


REFERENCES = {"own": "own", "all": "all"}
"""The model's own uncalibrated 90% regions: of the point forecast's 2-value mixture (what
ships today) and of the whole 25-value mixture about the point forecast."""


@dataclass(frozen=True)
class Checked:
    """One recording under one candidate: (S, H) inside, (S, H) area in m^2, and (S, H)
    score over the sample's radius (1 on the region's edge)."""

    inside: np.ndarray
    area: np.ndarray
    relative: np.ndarray


def check(name: str, fitted: dict, radii: np.ndarray, arrays: dict[str, np.ndarray]) -> Checked:
    """Candidate ``name``'s fitted regions (or a reference's own ones) on one recording."""
    if name in REFERENCES:
        key = REFERENCES[name]
        relative, _ = _own_radius_ratio(arrays, key)
        return Checked(arrays[f"inside90_{key}"], arrays[f"area90_{key}"], relative)
    candidate = candidate_named(name)
    score, unit = candidate.score(arrays, fitted)
    radius = radii[density_bin(arrays["neighbours"])] if candidate.by_density else radii[0]
    return Checked(score <= radius, unit * radius**2, score / radius)


def candidate_named(name: str) -> Candidate:
    """A candidate of :func:`candidates` by name, ``E-<name>`` for its per-density radii."""
    base = candidates()[name.removeprefix("E-")]
    return with_density(base) if name.startswith("E-") else base


@dataclass(frozen=True)
class Outcome:
    """A candidate on every recording (by name) and pooled ("development, pooled",
    "calibration, pooled"): coverage (H,), mean area (H,) in m^2, the scale its radius would
    need to hold exactly q there (H,; 0.6: the regions are 1/0.6 times too wide), and the
    fitted numbers and (G, H) radii."""

    coverage: dict[str, np.ndarray]
    area: dict[str, np.ndarray]
    needed: dict[str, np.ndarray]
    fitted: dict
    radii: np.ndarray
    checked: dict[str, Checked]


def evaluate(
    name: str, recordings: list[Recording], q: float = 0.9, held_out_site: str = ""
) -> Outcome:
    """Fit candidate ``name`` on the calibration recordings (those of every site but
    ``held_out_site`` when given) and check it on every recording: per file coverage, mean
    area and needed scale per step, pooled over each part too. ``own`` and ``all`` are the
    model's own uncalibrated 90% regions (nothing fitted)."""
    fitted: dict = {}
    radii = np.zeros((1, 0))
    if name not in REFERENCES:
        chosen = [r for r in recordings if r.part == "calibration" and r.site != held_out_site]
        fitted, radii = fit_radii(candidate_named(name), _pooled(chosen), q)
    checked = {r.name: check(name, fitted, radii, r.arrays) for r in recordings}
    for part in ("calibration", "development"):
        parts = [checked[r.name] for r in recordings if r.part == part]
        if parts:
            checked[f"{part}, pooled"] = Checked(
                *(np.concatenate([getattr(p, f) for p in parts]) for f in Checked.__annotations__)
            )
    return Outcome(
        coverage={k: c.inside.mean(0) for k, c in checked.items()},
        area={k: c.area.mean(0) for k, c in checked.items()},
        needed={k: np.quantile(c.relative, q, axis=0) for k, c in checked.items()},
        fitted=fitted,
        radii=radii,
        checked=checked,
    )


def interval(inside: np.ndarray, steps: np.ndarray, draws: int = 1000) -> tuple[float, float]:
    """95% interval of a share over (S,) forecasts, resampling time steps (people seen at one
    time step are not independent; region_coverage.py's interval)."""
    rng = np.random.default_rng(0)
    unique, owner = np.unique(steps, return_inverse=True)
    hits = np.bincount(owner, inside.astype(float), len(unique))
    count = np.bincount(owner, minlength=len(unique)).astype(float)
    picks = rng.integers(0, len(unique), (draws, len(unique)))
    shares = hits[picks].sum(axis=1) / count[picks].sum(axis=1)
    return float(np.percentile(shares, 2.5)), float(np.percentile(shares, 97.5))


def development_miss(outcome: Outcome, recordings: list[Recording]) -> tuple[float, float]:
    """How far the worst development cell (recording, step in STEPS) lies outside BAND, and
    the largest factor by which a development recording's radius is off (needed scale or its
    inverse, at STEPS)."""
    miss, factor = 0.0, 1.0
    for r in (r for r in recordings if r.part == "development"):
        for k in STEPS:
            share, need = outcome.coverage[r.name][k - 1], outcome.needed[r.name][k - 1]
            miss = max(miss, BAND[0] - share, share - BAND[1])
            factor = max(factor, need, 1.0 / need)
    return miss, factor


def one_radius_gap(outcome: Outcome, recordings: list[Recording]) -> float:
    """Whether any radius per step (any calibration at all, as one factor per step on the
    fitted radii) could hold every development recording within BAND: the largest, over
    STEPS, of (the highest BAND[0]-quantile of a recording's scores) over (the lowest
    BAND[1]-quantile); above 1 no radius can, and by that factor."""
    development = [outcome.checked[r.name].relative for r in recordings if r.part == "development"]
    gaps = [
        max(np.quantile(d[:, k - 1], BAND[0]) for d in development)
        / min(np.quantile(d[:, k - 1], BAND[1]) for d in development)
        for k in STEPS
    ]
    return float(max(gaps))


# --- tables ----------------------------------------------------------------------------------


def _cells(values: np.ndarray, digits: int = 3) -> str:
    return " | ".join(f"{values[k - 1]:.{digits}f}" for k in STEPS)


def summary_table(names: list[str], recordings: list[Recording], q: float) -> list[str]:
    """One row per candidate: the development set's lowest and highest share at STEPS, the
    miss, the mean area over the development recordings, the calibration set's share."""
    development = [r.name for r in recordings if r.part == "development"]
    lines = [
        "| candidate | dev lowest-highest at steps 4/8/12 | in 85-95% everywhere | worst miss "
        "(points) | radius off by (x) | no radius can (x) | mean area, steps 4 / 8 / 12 "
        "(m^2) | calibration set, steps 4 / 8 / 12 |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for name in names:
        outcome = evaluate(name, recordings, q)
        shares = np.array([outcome.coverage[d][k - 1] for d in development for k in STEPS])
        area = np.mean([outcome.area[d] for d in development], axis=0)
        miss, factor = development_miss(outcome, recordings)
        own = outcome.coverage["calibration, pooled"]
        lines.append(
            f"| {name} | {shares.min():.3f}-{shares.max():.3f} | "
            f"{'yes' if miss <= 0 else 'no'} | {100 * max(miss, 0):.1f} | {factor:.2f} | "
            f"{one_radius_gap(outcome, recordings):.2f} | "
            f"{' / '.join(f'{area[k - 1]:.2f}' for k in STEPS)} | "
            f"{' / '.join(f'{own[k - 1]:.3f}' for k in STEPS)} |"
        )
    return lines


def compact_tables(names: list[str], recordings: list[Recording], q: float) -> list[str]:
    """Two tables, one row per candidate: per development recording (and pooled, and the
    calibration set pooled) the share inside at STEPS with the mean over all steps in
    brackets; then the mean area (m^2) at STEPS."""
    columns = [r.name for r in recordings if r.part == "development"]
    columns += ["development, pooled", "calibration, pooled"]
    head = "| candidate | " + " | ".join(columns) + " |"
    rule = "|---|" + "---|" * len(columns)
    shares, areas = [head, rule], [head, rule]
    for name in names:
        outcome = evaluate(name, recordings, q)
        shares.append(f"| {name} | " + " | ".join(
            " / ".join(f"{outcome.coverage[c][k - 1]:.3f}" for k in STEPS)
            + f" ({outcome.coverage[c].mean():.3f})"
            for c in columns
        ) + " |")  # fmt: skip
        areas.append(f"| {name} | " + " | ".join(
            " / ".join(f"{outcome.area[c][k - 1]:.2f}" for k in STEPS) for c in columns
        ) + " |")  # fmt: skip
    return [
        "Share of truths inside, steps 4 / 8 / 12 (mean over the 12 steps):",
        "",
        *shares,
        "",
        "Mean region area (m^2), steps 4 / 8 / 12:",
        "",
        *areas,
    ]


def detail_table(name: str, recordings: list[Recording], q: float) -> list[str]:
    """Per recording: share at STEPS with 95% intervals and over all steps, mean area and the
    needed radius scale at STEPS."""
    outcome = evaluate(name, recordings, q)
    head = " | ".join(f"step {k}" for k in STEPS)
    lines = [
        f"`{name}`: {describe(name)}",
        "",
        f"| recording | forecasts | share inside, {head} | all steps | area (m^2), {head} "
        f"| needed radius scale, {head} |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    rows = [(r.name, r.arrays["step"]) for r in recordings]
    rows += [("calibration, pooled", None), ("development, pooled", None)]
    for label, steps in rows:
        checked = outcome.checked[label]
        shares = []
        for k in STEPS:
            cell = f"{checked.inside[:, k - 1].mean():.3f}"
            if steps is not None:
                low, high = interval(checked.inside[:, k - 1], steps)
                cell += f" [{low:.2f}, {high:.2f}]"
            shares.append(cell)
        lines.append(
            f"| {label} | {len(checked.inside)} | {' | '.join(shares)} | "
            f"{checked.inside.mean():.3f} | {_cells(outcome.area[label], 2)} | "
            f"{_cells(outcome.needed[label], 2)} |"
        )
    if outcome.radii.size:
        lines += ["", f"Radii at q = {q:g}, steps 1-12: " + "; ".join(
            " ".join(f"{r:.3f}" for r in row) for row in outcome.radii
        )]  # fmt: skip
    for key, value in outcome.fitted.items():
        lines += ["", f"Fitted {key}, steps 1-12: " + " ".join(f"{v:.3f}" for v in value)]
    return lines


def leave_one_site_out_table(names: list[str], recordings: list[Recording], q: float) -> list[str]:
    """Per candidate and calibration site: fitted on the other two sites, the held-out
    site's share at STEPS."""
    sites = sorted({r.site for r in recordings if r.part == "calibration"})
    lines = [
        "| candidate | " + " | ".join(f"{s} held out, steps 4 / 8 / 12" for s in sites) + " |",
        "|---|" + "---|" * len(sites),
    ]
    for name in (n for n in names if n not in REFERENCES):
        cells = []
        for site in sites:
            outcome = evaluate(name, recordings, q, held_out_site=site)
            inside = np.concatenate([
                outcome.checked[r.name].inside for r in recordings
                if r.part == "calibration" and r.site == site
            ])  # fmt: skip
            cells.append(" / ".join(f"{inside[:, k - 1].mean():.3f}" for k in STEPS))
        lines.append(f"| {name} | " + " | ".join(cells) + " |")
    return lines


def describe(name: str) -> str:
    """A candidate's one-line definition."""
    if name == "own":
        return "the point forecast's own 2-value mixture's 90% region, uncalibrated (ships today)"
    if name == "all":
        return "the whole 25-value mixture's own 90% region about the point forecast, uncalibrated"
    return candidate_named(name).description


DEFAULT_CANDIDATES = (
    "own,all,A,B,B5,B10,A-ratio,B-ratio,euclid,C0.1,C0.2,C0.3,DA,DB,E-A,E-B,E-C0.2,E-DA"
)
DEFAULT_DETAILS = "A,B"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--checkpoint", default=DEFAULT_CHECKPOINT)
    parser.add_argument("--forecast", help="the point forecast (default: the model's own)")
    parser.add_argument("--datasets", default=DEVELOPMENT_SET, help="development descriptions")
    parser.add_argument("--candidates", default=DEFAULT_CANDIDATES, help="summary rows")
    parser.add_argument("--details", default=DEFAULT_DETAILS, help="candidates shown per file")
    parser.add_argument("--q", type=float, default=0.9)
    parser.add_argument("--cache", type=Path, default=Path("/tmp/region_transfer"))
    parser.add_argument("--threads", type=int, default=1)
    parser.add_argument("--leave-one-site-out", action="store_true")
    args = parser.parse_args()
    torch.set_num_threads(args.threads)
    recordings = load_recordings(args.checkpoint, args.forecast, args.datasets, args.cache)
    for recording in recordings:
        print(f"{recording.part}: {recording.site} {recording.name} "
              f"({len(recording.arrays['step'])} forecasts)")  # fmt: skip
    names = [n for n in args.candidates.split(",") if n]
    print("\n" + "\n".join(f"- `{n}`: {describe(n)}" for n in names) + "\n")
    print("\n".join(summary_table(names, recordings, args.q)))
    print("\n" + "\n".join(compact_tables(names, recordings, args.q)))
    for name in (n for n in args.details.split(",") if n):
        print("\n" + "\n".join(detail_table(name, recordings, args.q)))
    if args.leave_one_site_out:
        print("\n" + "\n".join(leave_one_site_out_table(names, recordings, args.q)))


if __name__ == "__main__":
    main()
