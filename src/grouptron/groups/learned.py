"""A learned group detector: a few small networks give every pair of people near each other
the probability that they walk together (from ``pair_features``; their mean), a
``pair_memory`` carries it from step to step, and the pairs at least as probable as the rule's
threshold are linked into groups, a group larger than the rule's limit cut back by single
linkage on 1 - probability.

Its weights are plain tensors in a safetensors file with its feature scales and a JSON
description (never a pickle); ``SHIPPED_DETECTOR`` is the one trained on all four recordings
with human labels (campaign/group_detector.py).
"""

from __future__ import annotations

import functools
import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import torch
from safetensors import SafetensorError, safe_open
from safetensors.numpy import load_file, save_file
from scipy.spatial import cKDTree

from grouptron.errors import GrouptronError
from grouptron.groups.clustering import agglomerative_groups, canonical_labels, linked_pieces
from grouptron.groups.pair_features import FEATURES, pair_features
from grouptron.groups.pair_memory import PairMemory, pair_keys
from grouptron.io import save_atomically

GATE_M = 3.0
"""Only pairs at most this far apart now are scored (the others are never linked): the
radius within which the model reads its neighbours too."""
SHIPPED_DETECTOR = Path(__file__).resolve().parent / "detector" / "best.safetensors"
"""The detector trained on the four labelled recordings (campaign/group_detector.py; its card
is README.md beside it)."""
MEMBERS = 5
"""Networks of the detector, each from its own seed: their mean probability varies less from
seed to seed than one network's."""
_SLOWER, _FASTER = FEATURES.index("speed_low"), FEATURES.index("speed_high")


@dataclass(frozen=True)
class PairClassifier:
    """M one-hidden-layer networks over standardised pair features, their probabilities
    averaged.

    Attributes:
        mean, scale: (F,) the training features' means and standard deviations.
        hidden_w, hidden_b: (M, F, H) and (M, H) the hidden layers (ReLU).
        out_w, out_b: (M, H) and (M,) the logits of "walking together".
    """

    mean: np.ndarray
    scale: np.ndarray
    hidden_w: np.ndarray
    hidden_b: np.ndarray
    out_w: np.ndarray
    out_b: np.ndarray

    def probabilities(self, features: np.ndarray) -> np.ndarray:
        """(P, F) features -> (P,) probabilities that each pair walks together."""
        x = (features - self.mean) / self.scale
        m, f, h = self.hidden_w.shape
        # All M hidden layers as one (F, M H) product: one BLAS call instead of M.
        w = self.hidden_w.transpose(1, 0, 2).reshape(f, m * h)
        hidden = np.maximum(x @ w + self.hidden_b.reshape(-1), 0.0).reshape(len(x), m, h)
        logit = np.einsum("pmh,mh->pm", hidden, self.out_w) + self.out_b  # (P, M)
        probability: np.ndarray = (1.0 / (1.0 + np.exp(-np.clip(logit, -30, 30)))).mean(axis=1)
        return probability

    def save(self, path: Path, about: dict[str, object]) -> None:
        """Write the weights and ``about`` (how it was trained) atomically."""
        tensors = {k: np.ascontiguousarray(v, np.float32) for k, v in vars(self).items()}
        metadata = {"features": json.dumps(FEATURES), "about": json.dumps(about)}
        path.parent.mkdir(parents=True, exist_ok=True)
        save_atomically(path, lambda temporary: save_file(tensors, str(temporary), metadata))


@functools.cache
def load_classifier(path: Path = SHIPPED_DETECTOR) -> PairClassifier:
    """The detector in ``path``, refused in one line if its features are not this code's."""
    try:
        with safe_open(str(path), framework="numpy") as handle:
            features = json.loads((handle.metadata() or {}).get("features", "[]"))
        tensors = load_file(str(path))
    except (OSError, ValueError, SafetensorError) as exc:
        raise GrouptronError(f"{path}: cannot read the group detector ({exc})") from None
    if tuple(features) != FEATURES or tensors.get("hidden_w", np.zeros(0)).ndim != 3:
        raise GrouptronError(f"{path}: a group detector of other features than this code's")
    return PairClassifier(**{k: tensors[k].astype(np.float64) for k in tensors})


def near_pairs_now(pos_now: np.ndarray, gate_m: float = GATE_M) -> np.ndarray:
    """(P, 2) pairs i < j of (N, 2) positions within ``gate_m`` of each other now."""
    pairs = cKDTree(pos_now).query_pairs(gate_m, output_type="ndarray")
    return np.asarray(pairs, dtype=np.int64).reshape(-1, 2)


def learned_distances(
    traj: np.ndarray,
    mask: np.ndarray,
    dt_s: float,
    classifier: PairClassifier,
    memory: PairMemory | None = None,
    ids: np.ndarray | None = None,
) -> np.ndarray:
    """(N, N) 1 - the probability that each pair walks together (infinity beyond
    :data:`GATE_M`, 0 on the diagonal) of N people over the window ((N, W, 2), (N, W)); with
    a ``memory`` (and the people's (N,) track ``ids``), as it carries it from earlier steps."""
    n = len(traj)
    distances = np.full((n, n), np.inf)
    np.fill_diagonal(distances, 0.0)
    pairs = near_pairs_now(traj[:, -1])
    if not len(pairs):
        if memory is not None:
            memory.forget()  # every pair parted
        return distances
    features = pair_features(traj, mask, pairs, dt_s)
    probability = classifier.probabilities(features)
    if memory is not None:
        assert ids is not None, "a memory needs the tracks' ids"
        keys = pair_keys(ids, pairs)
        probability = memory.step(keys, probability, features[:, _SLOWER], features[:, _FASTER])
    distances[pairs[:, 0], pairs[:, 1]] = distances[pairs[:, 1], pairs[:, 0]] = 1.0 - probability
    return distances


def linked_groups(distances: np.ndarray, threshold: float, max_size: int | None) -> np.ndarray:
    """(N,) groups of the pairs at most ``threshold`` apart (connected pieces), a piece
    larger than ``max_size`` cut by single linkage with that limit."""
    labels = linked_pieces(len(distances), np.argwhere(distances <= threshold))
    if max_size is not None:
        sizes = np.bincount(labels)
        for piece in np.flatnonzero(sizes > max_size):  # rare: a chain through a crowd
            members = np.flatnonzero(labels == piece)
            sub = agglomerative_groups(
                distances[np.ix_(members, members)],
                "single",
                max_distance=threshold,
                max_size=max_size,
            )
            labels[members] = labels.max() + 1 + sub
    return canonical_labels(labels)


def fit_classifier(
    features: np.ndarray,
    together: np.ndarray,
    *,
    hidden: int = 16,
    steps: int = 600,
    seed: int = 0,
    members: int = MEMBERS,
) -> PairClassifier:
    """A :class:`PairClassifier` of ``members`` networks (seeds ``seed``, ``seed`` + 1, ...)
    fitted to (P, F) ``features`` and (P,) ``together`` labels: full-batch Adam on the
    cross-entropy, the classes as they come, so that its probabilities are the pairs' share of
    companions (weighting the classes equally linked more strangers on the held-out
    recordings)."""
    mean, scale = features.mean(axis=0), features.std(axis=0) + 1e-6
    x = torch.from_numpy(((features - mean) / scale).astype(np.float32))
    y = torch.from_numpy(together.astype(np.float32))
    layers = [_fit_network(x, y, hidden, steps, seed + k) for k in range(members)]
    weights = {name: np.stack([layer[name] for layer in layers]) for name in layers[0]}
    return PairClassifier(mean=mean, scale=scale, **weights)


def _fit_network(
    x: torch.Tensor, y: torch.Tensor, hidden: int, steps: int, seed: int
) -> dict[str, np.ndarray]:
    """One network's weights (float64 arrays named as :class:`PairClassifier`'s)."""
    torch.manual_seed(seed)
    first, last = torch.nn.Linear(x.shape[1], hidden), torch.nn.Linear(hidden, 1)
    network = torch.nn.Sequential(first, torch.nn.ReLU(), last)
    optimiser = torch.optim.Adam(network.parameters(), lr=0.01, weight_decay=1e-4)
    for _ in range(steps):  # full batch: some ten thousand pairs
        optimiser.zero_grad()
        loss = torch.nn.functional.binary_cross_entropy_with_logits(network(x)[:, 0], y)
        loss.backward()
        optimiser.step()
    return {
        "hidden_w": first.weight.detach().numpy().T.astype(np.float64),
        "hidden_b": first.bias.detach().numpy().astype(np.float64),
        "out_w": last.weight.detach().numpy()[0].astype(np.float64),
        "out_b": last.bias.detach().numpy()[0].astype(np.float64),
    }
