"""Trajectory metrics as pure NumPy functions (metres in, metres out), and the registry of the
per-sample metrics every evaluation reports.

Shapes: ``B`` samples, ``K`` predictions per sample, ``H`` horizon steps.

A metric is one function from forecasts and truths to a per-sample score and one
:func:`register_metric` line; every point forecast, best-of-K, ``grouptron evaluate`` (table
and JSON) and the reports then carry it. Every metric is lower-is-better per sample, so
that best-of-K is its minimum over the K forecasts.

A metric from outside the package needs no wrapper script: ``--metrics`` of ``evaluate`` and
``report`` (``EvaluationOptions.metrics``, ``ReportRequest.metrics`` in Python) names it, and
:func:`resolve_metric` finds it by name: a registered one, ``miss-rate-Xm`` (the share of
forecasts ending more than X m off, any X), ``module:name`` (a function or a ``Metric`` of an
importable module) or the name of an installed package's entry point in the
``grouptron.metrics`` group; :func:`scoring` registers it for one evaluation.

A scene-level metric (``evaluation.scene_metrics``: ``col-i``, ``col-ii``, ``jade``,
``jfde``) reads everyone forecast at the same moment together; it is scored only where
``--metrics`` names it, and still gives every sample a score.

The displacement error of every forecast step (:data:`DISPLACEMENT`) is kept per step beside
the metrics.

A region metric scores a point forecast's prediction regions (``model.regions.Regions``)
against the truths, per sample and step, for each probability ``q`` asked
(:func:`register_region_metric`): ``coverage-q90`` (1 where the truth lies inside the 90%
region) and ``area-q90`` (the region's area, m^2). They are read together, not each alone:
a region is better when it is smaller at the same coverage.
"""

from __future__ import annotations

import importlib
import os
import re
import sys
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass
from importlib.metadata import entry_points

import numpy as np

from grouptron.errors import GrouptronError
from grouptron.evaluation.scene_metrics import SCENE_METRICS, SceneMetric
from grouptron.model.regions import Regions

KDE_LOG_DENSITY_FLOOR = -20.0
"""Per-step log-density clip of the KDE NLL, as in the reference evaluation."""


def displacement_errors(pred: np.ndarray, truth: np.ndarray) -> np.ndarray:
    """Euclidean error at every step.

    Args:
        pred: (..., H, 2) predicted positions.
        truth: (..., H, 2) true positions (broadcastable to ``pred``).

    Returns:
        (..., H) distances in metres.
    """
    distances: np.ndarray = np.linalg.norm(pred - truth, axis=-1)
    return distances


def ade(pred: np.ndarray, truth: np.ndarray) -> np.ndarray:
    """Average displacement error over the horizon: (..., H, 2) -> (...)."""
    errors: np.ndarray = displacement_errors(pred, truth).mean(axis=-1)
    return errors


def fde(pred: np.ndarray, truth: np.ndarray) -> np.ndarray:
    """Final displacement error at the last step: (..., H, 2) -> (...)."""
    return displacement_errors(pred[..., -1:, :], truth[..., -1:, :])[..., 0]


def min_ade_k(samples: np.ndarray, truth: np.ndarray) -> np.ndarray:
    """Best ADE among K predictions per sample.

    Args:
        samples: (B, K, H, 2) predictions.
        truth: (B, H, 2).

    Returns:
        (B,) minimum over K. The minimum of ADE and of FDE are taken independently (they may
        come from different predictions), as the reference evaluation does.
    """
    best: np.ndarray = ade(samples, truth[:, None]).min(axis=1)
    return best


def min_fde_k(samples: np.ndarray, truth: np.ndarray) -> np.ndarray:
    """Best FDE among K predictions per sample: (B, K, H, 2), (B, H, 2) -> (B,)."""
    best: np.ndarray = fde(samples, truth[:, None]).min(axis=1)
    return best


def kde_log_density(samples: np.ndarray, points: np.ndarray) -> np.ndarray:
    """Log-density of a 2-D Gaussian KDE (Scott's bandwidth) at one point per sample set.

    Matches ``scipy.stats.gaussian_kde(samples.T).logpdf(point)``: kernel covariance = the
    unbiased sample covariance times ``K ** (-1 / 3)`` (Scott's factor ``K^(-1/(d+4))``, squared,
    with ``d = 2``).

    Args:
        samples: (..., K, 2) points the KDE is built on.
        points: (..., 2) where to evaluate it.

    Returns:
        (...) log-densities; NaN where the sample covariance is singular (as scipy fails there).
    """
    num = samples.shape[-2]
    centred = samples - samples.mean(axis=-2, keepdims=True)  # (..., K, 2)
    cov = np.einsum("...ki,...kj->...ij", centred, centred) / (num - 1)
    cov = cov * num ** (-1.0 / 3.0)  # (..., 2, 2)
    det = cov[..., 0, 0] * cov[..., 1, 1] - cov[..., 0, 1] * cov[..., 1, 0]
    singular = ~(det > 1e-300)
    safe_det = np.where(singular, 1.0, det)
    inv = (
        np.stack(
            [
                np.stack([cov[..., 1, 1], -cov[..., 0, 1]], -1),
                np.stack([-cov[..., 1, 0], cov[..., 0, 0]], -1),
            ],
            -2,
        )
        / safe_det[..., None, None]
    )
    diff = points[..., None, :] - samples  # (..., K, 2)
    maha = np.einsum("...ki,...ij,...kj->...k", diff, inv, diff)  # (..., K)
    log_kernel = -0.5 * maha - np.log(2.0 * np.pi) - 0.5 * np.log(safe_det)[..., None]
    peak = log_kernel.max(axis=-1, keepdims=True)
    log_sum = np.log(np.exp(log_kernel - peak).sum(axis=-1)) + peak[..., 0]
    return np.where(singular, np.nan, log_sum - np.log(num))


def kde_nll(samples: np.ndarray, truth: np.ndarray, chunk: int = 256) -> np.ndarray:
    """Negative log-likelihood of the truth under per-step KDEs of the predictions.

    Per sample and step, the Gaussian KDE (Scott's rule) of the K predicted positions is
    evaluated at the true position; log-densities are clipped below at -20, averaged over the
    steps and negated (the reference protocol, 2000 predictions per sample).

    Args:
        samples: (B, K, H, 2) predictions.
        truth: (B, H, 2).
        chunk: samples per vectorised block (bounds memory).

    Returns:
        (B,) NLL in nats; NaN where a step's predictions have a singular covariance.
    """
    out = np.empty(len(truth))
    for start in range(0, len(truth), chunk):  # blocks of samples, vectorised inside
        block = samples[start : start + chunk].swapaxes(1, 2)  # (b, H, K, 2)
        log_density = kde_log_density(block, truth[start : start + chunk])  # (b, H)
        clipped = np.maximum(log_density, KDE_LOG_DENSITY_FLOOR)  # NaN stays NaN
        out[start : start + chunk] = -clipped.mean(axis=-1)
    return out


@dataclass(frozen=True)
class Metric:
    """A per-sample score of a forecast.

    Attributes:
        name: its key in score mappings and JSON (``ade``, ``fde``, ...).
        label: its column heading in tables, unit included (``ADE m``).
        score: (..., H, 2) forecast positions and (..., H, 2) true ones -> (...) scores, lower
            is better.
    """

    name: str
    label: str
    score: Callable[[np.ndarray, np.ndarray], np.ndarray]


METRICS: dict[str, Metric | SceneMetric] = {}
"""Every registered metric by name, in the order of registration (the order of columns): a
per-person ``Metric`` or a ``SceneMetric`` (``evaluation.scene_metrics``) that reads a whole
moment's forecasts."""


def register_metric(metric: Metric | SceneMetric) -> Metric | SceneMetric:
    """Add ``metric`` to :data:`METRICS` (a name is registered once)."""
    if metric.name in METRICS or metric.name == NLL:
        raise ValueError(f"a metric named {metric.name!r} is registered already")
    METRICS[metric.name] = metric
    return metric


NLL = "nll"
"""The KDE negative log-likelihood: a score of a forecast distribution (2000 draws), not of
one forecast, kept under this name beside the registered metrics."""

register_metric(Metric("ade", "ADE m", ade))
register_metric(Metric("fde", "FDE m", fde))

DISPLACEMENT = "displacement"
"""The displacement error (m) at every forecast step (``displacement_errors``), kept per step
beside the metrics: a point forecast's mean over the steps is its ADE and its last step its
FDE; best-of-K's is each step's minimum over the K forecasts (its last step is minFDE)."""

ENTRY_POINTS = "grouptron.metrics"
"""The entry-point group through which an installed package offers metrics by name (each
entry point a function or a ``Metric``)."""

_MISS_RATE = re.compile(r"miss-rate-([0-9]+(?:\.[0-9]+)?)m")


@dataclass(frozen=True)
class MissBeyond:
    """1 where a forecast ends more than ``threshold_m`` from the truth, else 0:
    (..., H, 2), (..., H, 2) -> (...). Its mean is the miss rate; its minimum over K forecasts
    is 1 only where the lowest final error exceeds the threshold (best-of-K, as papers score
    it)."""

    threshold_m: float

    def __call__(self, pred: np.ndarray, truth: np.ndarray) -> np.ndarray:
        """(..., H, 2), (..., H, 2) -> (...) 1 where missed, else 0."""
        missed: np.ndarray = (fde(pred, truth) > self.threshold_m).astype(np.float64)
        return missed


def miss_rate(threshold_m: float) -> Metric:
    """The metric ``miss-rate-Xm``: the share of forecasts whose final error exceeds
    ``threshold_m`` (X) metres."""
    if not threshold_m > 0.0:
        raise GrouptronError(f"a miss rate's threshold is a distance above 0 m, not {threshold_m}")
    return Metric(f"miss-rate-{threshold_m:g}m", f"MR {threshold_m:g}m", MissBeyond(threshold_m))


def resolve_metric(spec: str | Metric | SceneMetric) -> Metric | SceneMetric:
    """The metric ``spec`` names: a ``Metric`` or ``SceneMetric`` as it is; a registered name;
    a scene-level metric's (``col-i``, ``col-ii``, ``jade``, ``jfde``); ``miss-rate-Xm``
    (X in metres); the name of an installed entry point of :data:`ENTRY_POINTS`; or
    ``module:name``, the function or ``Metric`` ``name`` of a module importable from the
    current folder or ``sys.path`` (a function is the metric ``name``, labelled so). Anything
    else is refused in one line."""
    if isinstance(spec, Metric | SceneMetric):
        return spec
    if spec in METRICS:
        return METRICS[spec]
    if spec in SCENE_METRICS:
        return SCENE_METRICS[spec]
    match = _MISS_RATE.fullmatch(spec)
    if match is not None:
        return miss_rate(float(match.group(1)))
    offered = [point for point in entry_points(group=ENTRY_POINTS) if point.name == spec]
    if offered:
        return _as_metric(offered[0].load(), spec)
    module, colon, name = spec.partition(":")
    if not (colon and module and name):
        raise GrouptronError(
            f"unknown metric {spec!r}; choose from {', '.join({**METRICS, **SCENE_METRICS})}, "
            f"miss-rate-Xm (X in "
            f"metres), module:name (a function or Metric of a module) or an installed "
            f"{ENTRY_POINTS} entry point"
        )
    try:
        imported = _import(module)
    except ImportError as error:
        raise GrouptronError(f"metric {spec}: cannot import {module} ({error})") from None
    if not hasattr(imported, name):
        raise GrouptronError(f"metric {spec}: module {module} has no {name}")
    return _as_metric(getattr(imported, name), name)


def _import(module: str) -> object:
    """The module named ``module``, the current folder searched first (as ``python -m``
    does), so that a metric file beside one's data needs no installing."""
    here = os.getcwd()
    added = here not in sys.path
    if added:
        sys.path.insert(0, here)
    try:
        return importlib.import_module(module)
    finally:
        if added:
            sys.path.remove(here)


def _as_metric(found: object, name: str) -> Metric | SceneMetric:
    """A ``Metric`` or ``SceneMetric`` as it is, a function as the metric ``name``."""
    if isinstance(found, Metric | SceneMetric):
        return found
    if callable(found):
        return Metric(name, name, found)
    raise GrouptronError(f"metric {name}: {found!r} is neither a function nor a Metric")


@contextmanager
def scoring(
    extra: Sequence[str | Metric | SceneMetric] = (),
) -> Iterator[tuple[Metric | SceneMetric, ...]]:
    """Inside the block every evaluation carries the registered metrics and ``extra`` (each
    resolved by :func:`resolve_metric`): those not registered are registered for the block
    only, so one evaluation's metrics never leak into the next. A name registered for a
    different metric is refused."""
    if isinstance(extra, str):
        raise GrouptronError(f"metrics is a sequence of metric names, not {extra!r}")
    chosen = tuple(resolve_metric(spec) for spec in extra)
    added: list[str] = []
    try:
        for metric in chosen:
            present = METRICS.get(metric.name)
            if present is None:
                register_metric(metric)
                added.append(metric.name)
            elif present != metric:
                raise GrouptronError(
                    f"a different metric named {metric.name!r} is registered already"
                )
        yield chosen
    finally:
        for name in added:
            METRICS.pop(name, None)


def per_person_metrics() -> dict[str, Metric]:
    """The registered metrics that score each person's forecast alone, by name."""
    return {name: m for name, m in METRICS.items() if isinstance(m, Metric)}


def scene_metrics() -> dict[str, SceneMetric]:
    """The registered metrics that read a whole moment's forecasts, by name."""
    return {name: m for name, m in METRICS.items() if isinstance(m, SceneMetric)}


def point_scores(pred: np.ndarray, truth: np.ndarray) -> dict[str, np.ndarray]:
    """Every registered per-person metric of one forecast per sample: (B, H, 2), (B, H, 2) ->
    name: (B,)."""
    return {name: metric.score(pred, truth) for name, metric in per_person_metrics().items()}


def best_of_scores(samples: np.ndarray, truth: np.ndarray) -> dict[str, np.ndarray]:
    """Every registered per-person metric's best over K forecasts, each minimum taken on its
    own (they may come from different forecasts, as the reference evaluation does):
    (B, K, H, 2), (B, H, 2) -> name: (B,)."""
    return {
        name: metric.score(samples, truth[:, None]).min(axis=1)
        for name, metric in per_person_metrics().items()
    }


@dataclass(frozen=True)
class RegionMetric:
    """A per-sample, per-step score of a point forecast's prediction regions.

    Attributes:
        name: its key with the probability appended (``coverage`` -> ``coverage-q90``).
        label: its column heading in tables, ``{q}`` standing for the percentage (``cov{q}``).
        score: ``Regions`` of (N, H) ellipses and (N, H, 2) true positions -> (N, H) scores.
    """

    name: str
    label: str
    score: Callable[[Regions, np.ndarray], np.ndarray]


REGION_METRICS: dict[str, RegionMetric] = {}
"""Every registered region metric by name, in the order of registration."""


def register_region_metric(metric: RegionMetric) -> RegionMetric:
    """Add ``metric`` to :data:`REGION_METRICS` (a name is registered once)."""
    if metric.name in REGION_METRICS:
        raise ValueError(f"a region metric named {metric.name!r} is registered already")
    REGION_METRICS[metric.name] = metric
    return metric


def region_coverage(regions: Regions, truth: np.ndarray) -> np.ndarray:
    """(N, H) 1 where the (N, H, 2) true position lies inside its step's region, else 0."""
    return regions.contains(truth).astype(np.float64)


def region_area_m2(regions: Regions, truth: np.ndarray) -> np.ndarray:
    """(N, H) each step's region area, pi * major * minor semi-axes, m^2 (``truth`` unread)."""
    area: np.ndarray = np.pi * regions.major_m * regions.minor_m
    return area


register_region_metric(RegionMetric("coverage", "cov{q}", region_coverage))
register_region_metric(RegionMetric("area", "area{q} m2", region_area_m2))


def percent(q: float) -> str:
    """A probability as the percentage that names it: 0.9 -> ``90``, 0.975 -> ``97.5``."""
    return f"{100 * q:g}"


def region_metric_name(name: str, q: float) -> str:
    """The key of a region metric at probability ``q``: ``coverage``, 0.9 -> ``coverage-q90``."""
    return f"{name}-q{percent(q)}"


def region_metric_names(qs: tuple[float, ...]) -> tuple[str, ...]:
    """Every registered region metric's key at every ``q``, q by q."""
    return tuple(region_metric_name(name, q) for q in qs for name in REGION_METRICS)


def region_scores(regions: Regions, truth: np.ndarray) -> dict[str, np.ndarray]:
    """Every registered region metric of ``regions`` (at their ``q``): name -> (N, H)."""
    return {
        region_metric_name(name, regions.q): metric.score(regions, truth)
        for name, metric in REGION_METRICS.items()
    }


def metric_label(name: str) -> str:
    """A metric's column heading: its registered label (a region metric's with its
    percentage), else its name."""
    if name in METRICS:
        return METRICS[name].label
    if name == DISPLACEMENT:
        return "DE m"
    for metric in REGION_METRICS.values():
        prefix = f"{metric.name}-q"
        if name.startswith(prefix):
            return metric.label.format(q=name[len(prefix) :])
    return name
