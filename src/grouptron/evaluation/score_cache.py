"""Per-sample scores kept on disk, so that a report scores only what it has not scored before.

Regenerating a report after one checkpoint was added or retrained should cost that
checkpoint's scoring, not every checkpoint's again. Each mode's (S,) ADE/FDE/NLL arrays (and
(S, H) region metrics, where asked) are stored as one ``.npz`` (never pickle) as soon as that
mode is scored, under a key that hashes everything they depend on: the model's weights and
configuration, the test samples and groups (their contents, not their file names), the mode,
seed, batch size and ablation, the definition of every metric scored (a digest of its code,
parameters and the values it reads: a metric registered again under its name with another
definition is scored again), the regions' probabilities and calibrated radii, and the
Python and library versions. The files sit in a subfolder named by a hash of the source of every
grouptron module that builds the model or scores it, so that edited code never reads old
scores and the sets of older code can be deleted whole (any of it can be, at any time).
"""

from __future__ import annotations

import ast
import dataclasses
import hashlib
import inspect
import json
import sys
from collections.abc import Sequence
from functools import cache, partial
from pathlib import Path

import numpy as np
import torch

from grouptron.config import ExperimentConfig
from grouptron.data.prepare.samples import SampleSet
from grouptron.evaluation import metrics
from grouptron.evaluation.definition import definition_digest
from grouptron.evaluation.evaluate import SHARED_DECODE, SampleScores, score_samples
from grouptron.evaluation.region_scores import RegionScoring
from grouptron.groups.assign import SampleGroups
from grouptron.io import keep_cache_npz, read_cache_npz
from grouptron.model.forecaster import Forecaster
from grouptron.model.predict import Ablation
from grouptron.point_forecast import is_point_forecast

SCORE_CACHE_FORMAT = 1
PACKAGE = "grouptron"
PACKAGE_DIR = Path(__file__).resolve().parents[1]
SCORING_MODULES = ("grouptron.evaluation.evaluate", "grouptron.model.factory")
"""Scoring, and the code that turns a stored configuration into a model."""


def cached_score_samples(  # noqa: PLR0913 - score_samples's options, all keyword-only
    folder: Path | None,
    model: Forecaster,
    config: ExperimentConfig,
    samples: SampleSet,
    modes: Sequence[str],
    *,
    batch_size: int = 256,
    seed: int = 0,
    progress: bool = False,
    groups: SampleGroups | None = None,
    ablate: Ablation = (),
    regions: RegionScoring | None = None,
) -> list[SampleScores]:
    """:func:`score_samples` on the CPU, each mode read from ``folder`` when it was scored
    before (None: no cache). The modes not found are scored and stored one by one (``ml`` and
    ``mean`` together: they share a decode), so a run stopped half-way keeps what it scored.
    A point forecast's scores with ``regions`` are kept under a key of their own."""
    score = partial(
        score_samples,
        model,
        config,
        samples,
        batch_size=batch_size,
        seed=seed,
        progress=progress,
        groups=groups,
        ablate=ablate,
        regions=regions,
    )
    if folder is None:
        return score(tuple(modes))
    common = _common_key(model, config, samples, groups, batch_size, seed, ablate)
    code = scoring_source_digest(_model_modules(model))
    outside = _outside_source_digest(model)  # a model of the forecaster interface's own code
    if outside:
        code = hashlib.sha256((code + outside).encode()).hexdigest()
    subfolder = folder / code[:16]
    paths = {mode: subfolder / f"{_mode_key(common, mode, regions)}.npz" for mode in modes}
    shape = (len(samples), config.data.horizon_steps)
    found = {mode: _read(paths[mode], mode, shape, regions) for mode in modes}
    missing = [mode for mode in modes if found[mode] is None]
    together = SHARED_DECODE if set(SHARED_DECODE) <= set(missing) else ()
    calls = [together] if together else []
    for call in calls + [(mode,) for mode in missing if mode not in together]:
        for scores in score(call):
            _write(paths[scores.mode], scores, regions)
            found[scores.mode] = scores
    return [found[mode] for mode in modes]  # type: ignore[misc]


def _read(
    path: Path, mode: str, shape: tuple[int, int], regions: RegionScoring | None
) -> SampleScores | None:
    """The stored scores, or None when absent or unreadable (then scored again). ``shape``:
    (S, H), the shape of the per-step scores; the others are (S,)."""
    count = shape[0]

    def parse(stored: dict[str, np.ndarray]) -> SampleScores:
        arrays = {name: np.asarray(stored[name], dtype=np.float64) for name in _names(mode)}
        per_step = {
            name: np.asarray(stored[name], dtype=np.float64) for name in _step_names(mode, regions)
        }
        if any(a.shape != (count,) for a in arrays.values()):
            raise ValueError(f"not {count} samples")
        if any(a.shape != shape for a in per_step.values()):
            raise ValueError(f"not {shape[0]} samples of {shape[1]} steps")
        means = {n: a.mean(axis=1) for n, a in per_step.items() if n != metrics.DISPLACEMENT}
        return SampleScores(mode, arrays | means, per_step)

    return read_cache_npz(path, parse)  # a metric missing from the file: scored again


def _names(mode: str) -> tuple[str, ...]:
    """The metrics a mode's stored scores must hold: every registered one, or the NLL."""
    return (metrics.NLL,) if mode == metrics.NLL else tuple(metrics.METRICS)


def _step_names(mode: str, regions: RegionScoring | None) -> tuple[str, ...]:
    """What a mode's stored scores must hold per step: the displacement error (every mode
    but the NLL) and the region metrics (point forecasts only)."""
    errors = () if mode == metrics.NLL else (metrics.DISPLACEMENT,)
    scored = regions is not None and is_point_forecast(mode)
    return errors + (regions.names if regions is not None and scored else ())


def _write(path: Path, scores: SampleScores, regions: RegionScoring | None) -> None:
    arrays = {name: scores.get(name) for name in _names(scores.mode)}
    arrays.update({name: scores.per_step[name] for name in _step_names(scores.mode, regions)})
    keep_cache_npz(path, arrays)


def _mode_key(common: str, mode: str, regions: RegionScoring | None) -> str:
    """A mode's key: the definitions of the metrics it holds too, and for a point forecast
    scored with regions their q and radii."""
    scored = f"{common}:{mode}:{metric_definitions(mode, regions)}"
    if regions is not None and is_point_forecast(mode):
        scored += f":{regions.key()}"
    return hashlib.sha256(scored.encode()).hexdigest()[:32]


def metric_definitions(mode: str, regions: RegionScoring | None = None) -> str:
    """What defines the scores a mode's file holds, as text: the digest of each registered
    metric's definition (its function's code, parameters, closure and the globals it reads:
    ``evaluation.definition``), so that a metric registered again under its name with another
    definition (a user's, outside the package's source) is scored again, never read back
    stale; and of each region metric where regions are scored. The NLL's code is the
    package's, keyed by the folder."""
    found = {}
    if mode != metrics.NLL:
        found.update({name: definition_digest(m) for name, m in metrics.METRICS.items()})
    if regions is not None and is_point_forecast(mode):
        found.update(
            {f"region:{n}": definition_digest(m) for n, m in metrics.REGION_METRICS.items()}
        )
    return hashlib.sha256(json.dumps(found, sort_keys=True).encode()).hexdigest()


def _common_key(
    model: Forecaster,
    config: ExperimentConfig,
    samples: SampleSet,
    groups: SampleGroups | None,
    batch_size: int,
    seed: int,
    ablate: Ablation,
) -> str:
    digest = hashlib.sha256()
    # Which forecast is the model's own changes no score: left out, choosing one keeps the
    # cache (and the keys made before the setting existed).
    stored = {k: v for k, v in dataclasses.asdict(config).items() if k != "point_forecast"}
    settings = {
        "format": SCORE_CACHE_FORMAT,
        "torch": torch.__version__,
        "numpy": np.__version__,
        "python": sys.version,
        "config": stored,
        "batch_size": batch_size,
        "seed": seed,
        "ablate": list(ablate),
    }
    digest.update(json.dumps(settings, sort_keys=True, default=str).encode())
    for name, tensor in model.state_dict().items():
        _update(digest, name, tensor.detach().cpu().contiguous().numpy())
    for part in (samples, groups):
        if part is not None:
            for field in dataclasses.fields(part):
                _update(digest, field.name, np.asarray(getattr(part, field.name)))
    return digest.hexdigest()


def _update(digest: hashlib._Hash, name: str, array: np.ndarray) -> None:
    """Hash an array with its name, dtype and shape (equal bytes of another shape differ)."""
    digest.update(f"{name}:{array.dtype.str}:{array.shape}".encode())
    digest.update(np.ascontiguousarray(array).tobytes())


def _model_modules(model: torch.nn.Module) -> tuple[str, ...]:
    """The grouptron modules that define the classes of the model, its parts and their bases."""
    names = {c.__module__ for part in model.modules() for c in type(part).__mro__}
    return tuple(sorted(n for n in names if n.startswith(f"{PACKAGE}.")))


def _outside_source_digest(model: torch.nn.Module) -> str:
    """SHA256 of the source files of the model's classes outside grouptron (a model of the
    forecaster interface): editing its code must not reuse its old scores ("" for none)."""
    files = {
        inspect.getsourcefile(c)
        for part in model.modules()
        for c in type(part).__mro__
        if not c.__module__.startswith((f"{PACKAGE}.", "torch", "builtins"))
    }
    found = sorted(f for f in files if f is not None and Path(f).is_file())
    if not found:
        return ""
    digest = hashlib.sha256()
    for path in found:
        digest.update(Path(path).read_bytes())
    return digest.hexdigest()


@cache
def scoring_source_digest(modules: tuple[str, ...] = ()) -> str:
    """SHA256 of the source of :data:`SCORING_MODULES`, ``modules`` (the model's classes) and
    every grouptron module they import, directly or not: the code that turns a configuration,
    weights and samples into scores."""
    digest = hashlib.sha256()
    for path in sorted(scoring_sources(modules)):
        digest.update(str(path.relative_to(PACKAGE_DIR)).encode())
        digest.update(path.read_bytes())
    return digest.hexdigest()


def scoring_sources(modules: Sequence[str] = ()) -> set[Path]:
    """The source files of :data:`SCORING_MODULES`, ``modules`` and their grouptron imports,
    transitively."""
    root = PACKAGE_DIR
    seen: set[Path] = set()
    pending: list[tuple[str, ...]] = [(name,) for name in (*SCORING_MODULES, *modules)]
    while pending:
        found = (_module_path(root, module) for module in pending.pop())
        path = next((p for p in found if p is not None), None)
        if path is None or path in seen:
            continue
        seen.add(path)
        package = ".".join(path.relative_to(root.parent).with_suffix("").parts)
        if path.name != "__init__.py":
            package = package.rpartition(".")[0]
        pending += _imports(path, package)
    return seen


def _module_path(root: Path, module: str) -> Path | None:
    if module != PACKAGE and not module.startswith(f"{PACKAGE}."):
        return None
    folder = root.joinpath(*module.split(".")[1:])
    for candidate in (folder.with_name(f"{folder.name}.py"), folder / "__init__.py"):
        if candidate.is_file():
            return candidate
    return None


def _imports(path: Path, package: str) -> list[tuple[str, ...]]:
    """The modules ``path`` imports (relative ones resolved against ``package``), each as the
    names to try in order: ``from a import b`` is module ``a.b`` if there is one, else ``a``
    (a package's ``__init__`` counts only when a name is taken from it)."""
    names: list[tuple[str, ...]] = []
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.Import):
            names += [(alias.name,) for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                parent = package.rsplit(".", node.level - 1)[0] if node.level > 1 else package
                base = f"{parent}.{base}" if base else parent
            names += [(f"{base}.{alias.name}", base) for alias in node.names]
    return names
