"""The paper's report from a folder of checkpoints (``grouptron report``): every checkpoint on
every benchmark test set beside constant velocity, optionally scored on recordings from
elsewhere too (the out-of-domain section).

    from grouptron.workflows.report import ReportRequest, benchmark_report
    report = benchmark_report(ReportRequest(Path("checkpoints"), ("backward",)))
    print(report.to_json())
    eth = ReportRequest(Path("checkpoints"), ("backward",), splits=("eth",),
                        metrics=("miss-rate-2m",))
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from pathlib import Path

from grouptron.constants import SPLITS
from grouptron.data.datasets.custom import read_dataset
from grouptron.data.datasets.locate import resolve_data_dir
from grouptron.errors import GrouptronError
from grouptron.evaluation.metrics import Metric, scoring
from grouptron.geometry import DerivativeScheme
from grouptron.inference.checkpoints import DEFAULT_CHECKPOINT
from grouptron.model.factory import MODEL_NAMES
from grouptron.point_forecast import NAMED as POINT_FORECASTS
from grouptron.point_forecast import is_point_forecast
from grouptron.reporting.out_of_domain import (
    causal_checkpoints,
    prepare_out_of_domain,
    score_out_of_domain,
)
from grouptron.reporting.report import ReportSettings, find_checkpoints, run_report
from grouptron.reporting.stats import Report


@dataclass(frozen=True)
class ReportRequest:
    """What the benchmark report covers.

    Attributes:
        checkpoints: the folder of checkpoint folders (``*/best.safetensors``).
        schemes: the derivatives whose checkpoints are reported (a table each).
        settings: modes, seed, NLL cap, caches, diagnostics.
        models: the models reported (each of ``MODEL_NAMES``).
        seeds: the training seeds reported (None: every one found).
        out_of_domain: dataset description files whose test recordings are scored by the
            causal checkpoints too (in ``settings``' point-forecast modes).
        data_dir: the ETH/UCY folder (None: ``$GROUPTRON_DATA``, else the download cache).
        progress: progress bars; announce: name each checkpoint as it starts (standard error).
        splits: the test sets reported (the checkpoints of these splits, constant velocity on
            them; the AVG column needs all five).
        metrics: metrics scored beside the registered ones, each a name, ``miss-rate-Xm``,
            ``module:name`` or a ``Metric`` (``evaluation.metrics.resolve_metric``).
    """

    checkpoints: Path
    schemes: tuple[DerivativeScheme, ...]
    settings: ReportSettings = field(default_factory=ReportSettings)
    models: tuple[str, ...] = MODEL_NAMES
    seeds: tuple[int, ...] | None = None
    out_of_domain: tuple[str | Path, ...] = ()
    data_dir: str | Path | None = None
    progress: bool = False
    announce: bool = False
    splits: tuple[str, ...] = SPLITS
    metrics: tuple[str | Metric, ...] = ()

    def __post_init__(self) -> None:
        unknown = [s for s in self.splits if s not in SPLITS]
        if unknown or not self.splits or isinstance(self.splits, str):
            raise GrouptronError(
                f"unknown split {', '.join(map(repr, unknown)) or repr(self.splits)}; choose "
                f"from {', '.join(SPLITS)}"
            )


def benchmark_report(request: ReportRequest) -> Report:
    """Score every checkpoint the request names on every test set (rows, AVG rows, intervals,
    paired differences, seed spread) in every registered metric and ``request.metrics``, and
    the causal ones on the out-of-domain recordings. The recordings and metrics are read
    before the long work, so that bad ones fail at once."""
    with scoring(request.metrics):
        return _benchmark_report(request)


def _benchmark_report(request: ReportRequest) -> Report:
    point_modes = [m for m in request.settings.modes if is_point_forecast(m)]
    if request.out_of_domain and not point_modes:
        raise GrouptronError(
            f"--out-of-domain scores point forecasts: add one of {', '.join(POINT_FORECASTS)} "
            "to --mode"
        )
    recordings = (
        prepare_out_of_domain([read_dataset(path) for path in request.out_of_domain])
        if request.out_of_domain
        else None
    )
    data_dir = resolve_data_dir(request.data_dir)
    found = find_checkpoints(
        request.checkpoints, request.schemes, request.models, request.seeds, request.splits
    )
    report = run_report(
        data_dir,
        found,
        request.schemes,
        request.settings,
        progress=request.progress,
        announce=request.announce,
        splits=request.splits,
    )
    if recordings is None:
        return report
    out_of_domain = score_out_of_domain(
        recordings,
        causal_checkpoints(request.checkpoints),
        point_modes,
        default_model=DEFAULT_CHECKPOINT,
        progress=request.progress,
        score_cache=request.settings.score_cache,
    )
    return dataclasses.replace(report, out_of_domain=out_of_domain)
