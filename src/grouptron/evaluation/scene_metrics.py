"""Scene-level metrics: scores that read the forecasts of everyone forecast at one moment
together, as pure NumPy functions (metres in).

A *moment* is one scene at one time step; the people forecast at a moment are its samples.
Each metric still gives every sample a score, so that means, subsets, paired differences and
intervals (time steps resampled: a moment's samples stay together) work as for the per-person
metrics; a mean over samples weighs each moment by the people forecast in it, as ADE does.

- ``col-i``: 1 where a person's forecast collides with another person's forecast of the same
  moment, else 0 (TrajNet++'s prediction collision, Kothari et al., "Human Trajectory
  Forecasting in Crowds: A Deep Learning Perspective", T-ITS 2021).
- ``col-ii``: 1 where a person's forecast collides with another person's true path (TrajNet++'s
  ground-truth collision).
- ``jade`` / ``jfde``: joint best-of-K: the one of the K sampled futures (sample k of every
  person together) whose mean ADE (FDE) over the moment's people is lowest, chosen per moment,
  not per person; each person scores their error in that sample. For one point forecast they
  equal ADE and FDE.

Collisions follow TrajNet++'s evaluator (``trajnetplusplustools``' ``collision``): two paths
collide where, at some forecast step or halfway between two consecutive steps (both walked
at constant speed), the two people are at most two radii apart, a person's radius being
0.1 m (so 0.2 m between centres). Only the forecast steps are read, not the segment from the
present position to the first step. With K sampled futures a person's score is the share of
the K joint samples in which they collide (a point forecast's is 0 or 1). "The others" are
the other people scored at the same moment: people without a whole observed future are no
samples and are not counted.

Shapes: ``S`` samples, ``K`` forecasts per sample, ``H`` steps.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

PERSON_RADIUS_M = 0.1
"""TrajNet++'s person radius: two people collide within two radii of each other."""

PAIR_BLOCK_VALUES = 4_000_000
"""Pairs of paths compared per block, counted in positions (bounds memory)."""


@dataclass(frozen=True)
class SceneForecasts:
    """Everyone's forecasts of a sample set, with the moments that tie them together.

    Attributes:
        forecasts_m: (S, K, H, 2) forecast positions in each moment's own frame.
        truths_m: (S, H, 2) true positions in the same frame.
        moment: (S,) which moment (scene and time step) each sample belongs to.
    """

    forecasts_m: np.ndarray
    truths_m: np.ndarray
    moment: np.ndarray


@dataclass(frozen=True)
class SceneMetric:
    """A per-sample score that reads the whole moment's forecasts.

    Attributes:
        name: its key in score mappings and JSON (``col-i``).
        label: its column heading in tables.
        score: ``SceneForecasts`` -> (S,) scores, lower is better.
    """

    name: str
    label: str
    score: Callable[[SceneForecasts], np.ndarray]


def moment_ids(scene_index: np.ndarray, step: np.ndarray) -> np.ndarray:
    """(S,) one number per distinct (scene, time step) pair."""
    codes: np.ndarray = np.unique(np.stack([scene_index, step], 1), axis=0, return_inverse=True)[1]
    return codes.ravel()


def moment_pairs(moment: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Every ordered pair of two different samples of one moment: (P,) firsts, (P,) seconds,
    grouped by the first."""
    order = np.argsort(moment, kind="stable")
    ordered = moment[order]
    starts = np.flatnonzero(np.r_[True, ordered[1:] != ordered[:-1]])  # (M,) each moment's first
    sizes = np.diff(np.r_[starts, len(moment)])  # (M,)
    member_start = np.repeat(starts, sizes)  # (S,) per sorted sample, its moment's first
    member_size = np.repeat(sizes, sizes)  # (S,) and its moment's size
    first = np.repeat(np.arange(len(moment)), member_size)  # (sum of sizes^2,)
    block_start = np.repeat(np.cumsum(member_size) - member_size, member_size)
    second = np.repeat(member_start, member_size) + np.arange(len(first)) - block_start
    distinct = first != second
    return order[first[distinct]], order[second[distinct]]


def closest_approach_m(paths: np.ndarray, others: np.ndarray) -> np.ndarray:
    """The least distance between two people walking their paths at the same time, read at
    every step and halfway between consecutive steps: (..., H, 2), (..., H, 2) -> (...)."""
    gap = paths - others  # (..., H, 2); linear between steps, so halfway is the mean
    at_steps = np.linalg.norm(gap, axis=-1).min(axis=-1)
    halfway_m = np.linalg.norm(0.5 * (gap[..., 1:, :] + gap[..., :-1, :]), axis=-1)
    halfway = halfway_m.min(axis=-1, initial=np.inf)  # none for one step
    closest: np.ndarray = np.minimum(at_steps, halfway)
    return closest


def _collision_share(paths: np.ndarray, others: np.ndarray, moment: np.ndarray) -> np.ndarray:
    """(S,) share of the K forecasts of (S, K, H, 2) ``paths`` that come within two radii of
    another sample's path of the same moment in ``others`` ((S, K, H, 2): forecast k against
    forecast k; (S, 1, H, 2): against the one true path)."""
    first, second = moment_pairs(moment)
    count, K, H = paths.shape[:3]
    collided = np.zeros((count, K), bool)
    block = max(1, PAIR_BLOCK_VALUES // (K * H))
    for start in range(0, len(first), block):  # blocks of pairs, vectorised inside
        i, j = first[start : start + block], second[start : start + block]
        hit = closest_approach_m(paths[i], others[j]) <= 2 * PERSON_RADIUS_M  # (P, K)
        np.logical_or.at(collided, i, hit)
    share: np.ndarray = collided.mean(axis=1)
    return share


def collisions_among_forecasts(scene: SceneForecasts) -> np.ndarray:
    """Col-I: (S,) share of a person's K forecasts that collide with someone else's forecast
    of the same sample k at the same moment."""
    paths = scene.forecasts_m
    return _collision_share(paths, paths, scene.moment)


def collisions_with_truths(scene: SceneForecasts) -> np.ndarray:
    """Col-II: (S,) share of a person's K forecasts that collide with someone else's true
    path at the same moment."""
    return _collision_share(scene.forecasts_m, scene.truths_m[:, None], scene.moment)


def _joint_best(errors: np.ndarray, moment: np.ndarray) -> np.ndarray:
    """(S,) each sample's error in the one of its (S, K) forecasts' samples whose mean error
    over the sample's moment is lowest."""
    if not len(errors):
        return np.zeros(0)
    codes = np.unique(moment, return_inverse=True)[1].ravel()  # (S,) 0..M-1
    totals = np.zeros((codes.max() + 1, errors.shape[1]))
    np.add.at(totals, codes, errors)  # (M, K): a moment's mean up to its size, enough for argmin
    best = totals.argmin(axis=1)  # (M,)
    chosen: np.ndarray = errors[np.arange(len(codes)), best[codes]]
    return chosen


def joint_ade(scene: SceneForecasts) -> np.ndarray:
    """jADE: (S,) each person's ADE in the sample of futures best for their moment as a whole."""
    errors = np.linalg.norm(scene.forecasts_m - scene.truths_m[:, None], axis=-1).mean(axis=-1)
    return _joint_best(errors, scene.moment)


def joint_fde(scene: SceneForecasts) -> np.ndarray:
    """jFDE: (S,) each person's FDE in the sample of futures best for their moment as a whole."""
    errors = np.linalg.norm(scene.forecasts_m[..., -1, :] - scene.truths_m[:, None, -1], axis=-1)
    return _joint_best(errors, scene.moment)


SCENE_METRICS: dict[str, SceneMetric] = {
    metric.name: metric
    for metric in (
        SceneMetric("col-i", "Col-I", collisions_among_forecasts),
        SceneMetric("col-ii", "Col-II", collisions_with_truths),
        SceneMetric("jade", "jADE m", joint_ade),
        SceneMetric("jfde", "jFDE m", joint_fde),
    )
}
"""The scene-level metrics ``--metrics`` names (none is scored unless asked: each reads every
pair of people of a moment)."""
