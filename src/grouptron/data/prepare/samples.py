"""Samples: one ego pedestrian at one step, with its standardised history, future and neighbours.

Built for a whole scene at once from a dense (track, step) grid by gathering, never by looping
over samples or neighbours.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from grouptron.config import DataConfig
from grouptron.data.formats.fields import ranges_to_indices
from grouptron.data.prepare.neighbours import perception_edges
from grouptron.data.prepare.scene import Scene


@dataclass(frozen=True)
class SampleSet:
    """Flat arrays of ``S`` samples (``T`` history steps, ``H`` future steps).

    Relative positions are in the ego's frame of origin (its position at ``t``) but with the
    scene's axes; standardised (``_st``) values divide by the scales of ``DataConfig``.

    Attributes:
        scene_names: (num_scenes,) names of the scenes the samples come from.
        scene_index: (S,) scene of each sample.
        track: (S,) ego track inside its scene.
        step: (S,) the current step ``t``.
        num_present: (S,) pedestrians present in the scene at ``t``.
        pos_now_scene_m: (S, 2) ego position at ``t`` in the centred scene frame.
        hist_mask: (S, T) True where the ego was observed (t-T+1..t).
        hist_rel_m: (S, T, 2) ego positions minus its position at ``t``; 0 where masked.
        hist_st: (S, T, 6) standardised ego states: positions relative to ``t`` / 3 m,
            velocities / 2 m/s, accelerations / 1 m/s^2; 0 where masked.
        fut_rel_m: (S, H, 2) future positions minus the position at ``t``.
        nbr_sum_st: (S, T, 6) sum over the neighbours at ``t`` of their standardised states
            ``(state_n - state_ego(t)) / scale``, each neighbour counted at the steps where it
            was observed; 0 where the ego is masked.
        edge_weight_sum: (S,) sum of the neighbours' ramp-in edge weights (not clipped).
        nbr_offsets: (S + 1,) sample ``s`` has neighbours ``nbr_offsets[s]:nbr_offsets[s+1]``.
        nbr_track: (E,) neighbour tracks (same scene as their sample).
        nbr_weight: (E,) their edge weights.
        nbr_hist_st: (E, T, 6) each neighbour's standardised state relative to the ego's state
            at ``t`` over the history window; 0 where the neighbour was not observed.
        nbr_hist_mask: (E, T) True where the neighbour was observed.
    """

    scene_names: np.ndarray
    scene_index: np.ndarray
    track: np.ndarray
    step: np.ndarray
    num_present: np.ndarray
    pos_now_scene_m: np.ndarray
    hist_mask: np.ndarray
    hist_rel_m: np.ndarray
    hist_st: np.ndarray
    fut_rel_m: np.ndarray
    nbr_sum_st: np.ndarray
    edge_weight_sum: np.ndarray
    nbr_offsets: np.ndarray
    nbr_track: np.ndarray
    nbr_weight: np.ndarray
    nbr_hist_st: np.ndarray
    nbr_hist_mask: np.ndarray

    def __len__(self) -> int:
        return len(self.step)

    @property
    def num_neighbours(self) -> np.ndarray:
        """(S,) neighbours of every sample at ``t``."""
        return np.diff(self.nbr_offsets)

    def to_arrays(self) -> dict[str, np.ndarray]:
        """The fields as a flat dict of arrays (for ``np.savez``)."""
        return {f.name: getattr(self, f.name) for f in dataclasses.fields(self)}

    @classmethod
    def from_arrays(cls, arrays: dict[str, np.ndarray]) -> SampleSet:
        """The sample set from :meth:`to_arrays`'s dict (e.g. ``np.load`` of its ``np.savez``)."""
        return cls(**{f.name: arrays[f.name] for f in dataclasses.fields(cls)})

    def subset(self, keep: np.ndarray) -> SampleSet:
        """The samples where the boolean (S,) mask ``keep`` is True, neighbours included."""
        if keep.dtype != np.bool_ or keep.shape != (len(self),):
            raise ValueError(f"subset needs a boolean mask of shape ({len(self)},)")
        index = np.flatnonzero(keep)
        edge_index, counts = edge_rows(self.nbr_offsets, index)
        per_sample = {
            f.name: getattr(self, f.name)[index]
            for f in dataclasses.fields(self)
            if f.name not in ("scene_names", "nbr_offsets") and f.name not in PER_EDGE
        }
        per_edge = {name: getattr(self, name)[edge_index] for name in PER_EDGE}
        return SampleSet(
            scene_names=self.scene_names,
            nbr_offsets=np.concatenate([[0], np.cumsum(counts)]).astype(np.int64),
            **per_sample,
            **per_edge,
        )


def edge_rows(nbr_offsets: np.ndarray, index: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The per-edge rows of samples ``index``, concatenated, and (B,) their counts."""
    counts = nbr_offsets[index + 1] - nbr_offsets[index]
    return ranges_to_indices(nbr_offsets[index], counts), counts


PER_EDGE = ("nbr_track", "nbr_weight", "nbr_hist_st", "nbr_hist_mask")
"""Fields with one row per (sample, neighbour) pair, indexed through ``nbr_offsets``."""


def ego_first_layout(num_neighbours: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The flat node layout of S samples' graphs: sample s owns the rows ``node_start[s]`` ..
    ``node_start[s] + num_neighbours[s]``, its ego first, then its neighbours in edge order.

    Returns:
        (S,) ``node_start`` and (total nodes,) ``is_ego``.
    """
    nodes = num_neighbours + 1
    node_start = np.concatenate([[0], np.cumsum(nodes)[:-1]]).astype(np.int64)
    is_ego = np.zeros(int(nodes.sum()), dtype=bool)
    is_ego[node_start] = True
    return node_start, is_ego


def dense_grid(scene: Scene, pad_before: int, pad_after: int) -> tuple[np.ndarray, np.ndarray]:
    """(N, pad_before + num_steps + pad_after, 6) states of the N tracks on the step grid and
    the matching (N, ...) presence mask; padding lets windows run past the ends."""
    width = pad_before + scene.num_steps + pad_after
    state = np.zeros((scene.num_tracks, width, 6))
    present = np.zeros((scene.num_tracks, width), dtype=bool)
    state[scene.track, scene.step + pad_before] = scene.state_scene
    present[scene.track, scene.step + pad_before] = True
    return state, present


def _ego_history(
    hist_state: np.ndarray, hist_mask: np.ndarray, ego_now: np.ndarray, scale: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """(S, T, 6) states and (S, T) masks -> (S, T, 2) positions relative to now (metres) and
    (S, T, 6) standardised states (positions relative to now); 0 where unobserved."""
    hist_rel = (hist_state[..., :2] - ego_now[:, None, :2]) * hist_mask[..., None]
    hist_st = hist_state.copy()
    hist_st[..., :2] = hist_rel
    return hist_rel, hist_st / scale * hist_mask[..., None]


def segment_sums(values: np.ndarray, offsets: np.ndarray) -> np.ndarray:
    """Sums of consecutive row ranges: (E, ...) values and (S + 1,) CSR offsets -> (S, ...),
    via a prefix sum (no loop over the S ranges)."""
    values = np.asarray(values, dtype=np.float64)
    prefix = np.concatenate([np.zeros((1, *values.shape[1:])), np.cumsum(values, axis=0)])
    return prefix[offsets[1:]] - prefix[offsets[:-1]]


def _neighbours_at(
    scene: Scene,
    config: DataConfig,
    track: np.ndarray,
    step: np.ndarray,
    *,
    only_step: int | None,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The neighbours of S samples at their step: (E,) tracks and edge weights, flat in sample
    order, and (S,) counts. ``only_step`` limits the edge search to the steps it needs."""
    ramp = config.edge_ramp_weights
    first, last = config.neighbour_window_steps
    from_step = 0 if only_step is None else max(0, only_step + first - (len(ramp) - 1))
    edges = perception_edges(scene, config.perception_radius_m, ramp, from_step)
    # The ego's outgoing edges at its steps, already sorted by (src, step, dst).
    edge_key = edges.src.astype(np.int64) * scene.num_steps + edges.step
    track_key = track.astype(np.int64) * scene.num_steps
    lo = np.searchsorted(edge_key, track_key + np.maximum(step + first, 0), side="left")
    hi = np.searchsorted(
        edge_key, track_key + np.minimum(step + last, scene.num_steps - 1), "right"
    )
    counts = hi - lo
    edge_index = ranges_to_indices(lo, counts)
    dst, weight = edges.dst[edge_index], edges.weight[edge_index]
    if (first, last) == (0, 0):
        return dst, weight, counts
    # A window: everyone met at any of its steps once, with their largest weight.
    sample = np.repeat(np.arange(len(step)), counts)
    order = np.lexsort((-weight, dst, sample))
    sample, dst, weight = sample[order], dst[order], weight[order]
    first_of_pair = np.ones(len(dst), dtype=bool)
    first_of_pair[1:] = (sample[1:] != sample[:-1]) | (dst[1:] != dst[:-1])
    kept = sample[first_of_pair]
    return dst[first_of_pair], weight[first_of_pair], np.bincount(kept, minlength=len(step))


# Longer than 60 lines on purpose: a 20-line docstring and the 17 named fields of the
# SampleSet it fills; the steps in between are the helpers above.
def scene_samples(
    scene: Scene,
    config: DataConfig,
    min_history: int,
    scene_index: int = 0,
    *,
    require_future: bool = True,
    only_step: int | None = None,
) -> SampleSet:
    """All samples of a scene whose ego has ``min_history`` observed points up to ``t`` and a
    full future of ``config.horizon_steps``.

    Args:
        scene: the scene.
        config: the data protocol.
        min_history: 2 for training/validation (t-1, t), ``history_steps`` for testing.
        scene_index: stored in ``SampleSet.scene_index``.
        require_future: False keeps samples whose future is cut short (forecasting new
            tracks); their missing future positions are NaN.
        only_step: keep only the samples at this step (live forecasting); the neighbours are
            then found only over the steps their edge weights need.
    """
    T, H = config.history_steps, config.horizon_steps
    scale = np.asarray(config.state_scale)
    pad_before = T - 1
    state_grid, present_grid = dense_grid(scene, pad_before, H)

    # A row is a sample when its track has enough points before and after it.
    first, last = scene.track_first_step[scene.track], scene.track_last_step[scene.track]
    is_sample = scene.step - first >= min_history - 1
    if require_future:
        is_sample &= last - scene.step >= H
    if only_step is not None:
        is_sample &= scene.step == only_step
    track, step = scene.track[is_sample], scene.step[is_sample]
    ego_now = scene.state_scene[is_sample]  # (S, 6)

    hist_cols = step[:, None] + np.arange(T)  # grid columns of t-T+1..t, (S, T)
    hist_mask = present_grid[track[:, None], hist_cols]  # (S, T)
    hist_rel, hist_st = _ego_history(
        state_grid[track[:, None], hist_cols], hist_mask, ego_now, scale
    )
    fut_cols = step[:, None] + pad_before + 1 + np.arange(H)  # (S, H)
    fut_rel = state_grid[track[:, None], fut_cols, :2] - ego_now[:, None, :2]  # (S, H, 2)
    fut_rel[~present_grid[track[:, None], fut_cols]] = np.nan

    nbr_track, nbr_weight, counts = _neighbours_at(scene, config, track, step, only_step=only_step)
    nbr_offsets = np.concatenate([[0], np.cumsum(counts)]).astype(np.int64)

    # Neighbour states per history step: each one's, and their sum per sample.
    edge_sample = np.repeat(np.arange(len(step)), counts)
    nbr_cols = hist_cols[edge_sample]  # (E, T)
    nbr_present = present_grid[nbr_track[:, None], nbr_cols]  # (E, T)
    nbr_state = state_grid[nbr_track[:, None], nbr_cols] * nbr_present[..., None]  # (E, T, 6)
    state_sum, present_sum, edge_weight_sum = (
        segment_sums(values, nbr_offsets) for values in (nbr_state, nbr_present, nbr_weight)
    )  # (S, T, 6), (S, T), (S,)
    nbr_hist_st = (nbr_state - ego_now[edge_sample, None, :]) / scale * nbr_present[..., None]
    nbr_sum_st = (state_sum - present_sum[..., None] * ego_now[:, None, :]) / scale
    nbr_sum_st = nbr_sum_st * hist_mask[..., None]

    return SampleSet(
        scene_names=np.asarray([scene.name]),
        scene_index=np.full(len(step), scene_index, dtype=np.int32),
        track=track.astype(np.int32),
        step=step.astype(np.int32),
        num_present=scene.present_per_step()[step].astype(np.int32),
        pos_now_scene_m=ego_now[:, :2].copy(),
        hist_mask=hist_mask,
        hist_rel_m=hist_rel.astype(np.float32),
        hist_st=hist_st.astype(np.float32),
        fut_rel_m=fut_rel.astype(np.float32),
        nbr_sum_st=nbr_sum_st.astype(np.float32),
        edge_weight_sum=edge_weight_sum.astype(np.float32),
        nbr_offsets=nbr_offsets,
        nbr_track=nbr_track.astype(np.int32),
        nbr_weight=nbr_weight.astype(np.float32),
        nbr_hist_st=nbr_hist_st.astype(np.float32),
        nbr_hist_mask=nbr_present,
    )


def concatenate_samples(parts: list[SampleSet]) -> SampleSet:
    """Join sample sets of different scenes, renumbering scenes and neighbour offsets."""
    if not parts:
        raise ValueError("nothing to concatenate")
    scene_shift = np.cumsum([0] + [len(p.scene_names) for p in parts[:-1]])
    edge_shift = np.cumsum([0] + [int(p.nbr_offsets[-1]) for p in parts[:-1]])
    per_sample = {
        f.name: np.concatenate([getattr(p, f.name) for p in parts])
        for f in dataclasses.fields(SampleSet)
        if f.name not in ("scene_names", "scene_index", "nbr_offsets")
    }
    return SampleSet(
        scene_names=np.concatenate([p.scene_names for p in parts]),
        scene_index=np.concatenate(
            [p.scene_index + shift for p, shift in zip(parts, scene_shift, strict=True)]
        ).astype(np.int32),
        nbr_offsets=np.concatenate(
            [[0]] + [p.nbr_offsets[1:] + s for p, s in zip(parts, edge_shift, strict=True)]
        ).astype(np.int64),
        **per_sample,
    )
