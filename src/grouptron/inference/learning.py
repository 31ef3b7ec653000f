"""Online learning of a site: a session fine-tunes its own copy of the model in rounds on the
people it has seen walk, and keeps new weights only where they forecast better.

Every person at every step becomes a training sample once its whole future has been seen
(``inference.site_samples``). Every ``round_s`` seconds of stream time, once enough samples
are there, a round runs:

1. The samples completed since the last round that no weights have trained on (the newest of
   them, at least ``min_holdout``) are held out to judge the round; the others join the
   site's buffer (the newest ``buffer_samples`` are kept).
2. Weights in use that were learnt earlier are judged first against the shipped ones on the
   held-out samples: where their paired FDE difference has a 95% interval above zero (worse),
   the session rolls back to the shipped weights.
3. A copy of the weights in use is fine-tuned on the buffer (``FineTune``: a fixed budget of
   steps, fp32, at most ``threads`` threads).
4. The fine-tuned copy replaces the weights in use only if its paired FDE difference on the
   held-out samples has a 95% interval below zero (better, beyond chance) and a mean gain of
   at least ``min_gain`` of the FDE in use (Adam moves weights the same way at any learning
   rate, so a gain of nanometres can be beyond chance too; no such round is worth a swap).

A site with nothing to learn keeps the shipped weights: no round is accepted. In a live
session a round runs in a background thread while forecasts go on with the weights in use;
a file's replay runs them in line, at recording time, so that it is deterministic.
"""

from __future__ import annotations

import copy
import logging
import threading
import time
from dataclasses import dataclass, field, replace

import numpy as np
import torch

from grouptron.config import ExperimentConfig
from grouptron.data.datasets.subsets import time_step_ids
from grouptron.data.prepare.samples import SampleSet
from grouptron.errors import GrouptronError
from grouptron.evaluation.uncertainty import Interval, mean_interval
from grouptron.groups.assign import SampleGroups
from grouptron.inference.engine import EngineOptions, forecast_samples
from grouptron.inference.site_samples import Completed, SiteLog, joined
from grouptron.model.cvae import TrajectronCVAE
from grouptron.model.factory import groups_for_model
from grouptron.point_forecast import PointForecast
from grouptron.training.fine_tune import FineTune, fine_tune

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class LearningOptions:
    """How a session learns its site.

    Attributes:
        round_s: stream seconds between rounds.
        budget: each round's fine-tune (steps, batch size, learning rate).
        min_train: buffered samples a round needs to train on.
        min_holdout: fresh samples (completed since the last round) a round needs to judge.
        holdout_share: the newest share of the fresh samples held out (at least
            ``min_holdout``); the rest join the buffer.
        min_gain: the smallest mean FDE gain a round must bring, as a share of the FDE of the
            weights in use on the held-out samples.
        buffer_samples: the newest training samples kept.
        seed: of the rounds' batches, rotations and noise.
        threads: PyTorch threads of a round.
        background: rounds in a background thread (live sessions); False: in line, at stream
            time (a file's replay: deterministic).
    """

    round_s: float = 30.0
    budget: FineTune = field(default_factory=FineTune)
    min_train: int = 100
    min_holdout: int = 40
    holdout_share: float = 0.3
    min_gain: float = 0.01
    buffer_samples: int = 4000
    seed: int = 0
    threads: int = 1
    background: bool = True

    def __post_init__(self) -> None:
        if not self.round_s > 0:
            raise GrouptronError(f"learning round_s must be > 0 seconds, not {self.round_s}")
        if min(self.min_train, self.min_holdout, self.buffer_samples, self.threads) < 1:
            raise GrouptronError("learning min_train, min_holdout, buffer_samples, threads >= 1")
        if not 0 < self.holdout_share < 1 or not 0 <= self.min_gain < 1:
            raise GrouptronError("learning holdout_share and min_gain are shares below 1")
        if self.budget.steps < 1 or self.budget.batch_size < 1 or self.budget.learning_rate <= 0:
            raise GrouptronError("learning steps and batch_size must be >= 1, learning_rate > 0")


@dataclass(frozen=True)
class LearningStatus:
    """What a session's learning has done so far.

    Attributes:
        rounds: rounds run (trained and judged).
        accepted: rounds whose weights replaced those in use.
        rolled_back: times learnt weights did worse than the shipped ones and were dropped.
        samples: completed samples seen (trained on or held out).
        seconds: stream seconds of the site seen.
        adapted: whether the weights in use are learnt ones (False: the shipped weights).
        last_difference: the last round's paired FDE difference, new minus in use (metres,
            95% interval), None before the first round.
        training_s: wall-clock seconds spent in rounds.
    """

    rounds: int = 0
    accepted: int = 0
    rolled_back: int = 0
    samples: int = 0
    seconds: float = 0.0
    adapted: bool = False
    last_difference: Interval | None = None
    training_s: float = field(default=0.0, compare=False)

    def line(self) -> str:
        """One line for a log or a diagnostic."""
        last = self.last_difference
        diff = "" if last is None else f"; last FDE difference {last.mean:+.3f} m "
        diff += "" if last is None else f"[{last.low:+.3f}, {last.high:+.3f}]"
        weights = "learnt" if self.adapted else "shipped"
        return (
            f"{self.rounds} rounds, {self.accepted} accepted, {self.rolled_back} rolled back; "
            f"{self.samples} samples in {self.seconds / 60:.1f} min; {weights} weights{diff}"
        )


@dataclass
class _Pool:
    """Samples a session learns from: the buffer (trained on) and the fresh ones (not yet)."""

    buffer: Completed | None = None
    fresh: list[Completed] = field(default_factory=list)

    def fresh_count(self) -> int:
        return sum(len(p.done_s) for p in self.fresh)


class SiteLearner:
    """A session's learning: its weights in use (``model``), rounds at stream times, status."""

    def __init__(
        self,
        model: TrajectronCVAE,
        config: ExperimentConfig,
        forecast: PointForecast,
        options: LearningOptions,
        max_gap_s: float,
    ) -> None:
        self.config = config
        self.forecast = forecast
        self.options = options
        self.shipped = copy.deepcopy(model).eval()
        self.model = copy.deepcopy(model).eval()
        """The weights forecasts use now (replaced whole by a round, never changed in place)."""
        self.status = LearningStatus()
        self.source_samples = 0
        self._log = SiteLog(config.data, max_gap_s)
        self._pool = _Pool()
        self._first_s: float | None = None
        self._cut_s: float | None = None  # samples completed by then are in the pool
        self._iteration = 0
        self._round = 0
        self._thread: threading.Thread | None = None
        self._lock = threading.Lock()

    def observe(self, t_s: float, ids: np.ndarray, xy_m: np.ndarray) -> None:
        """People (N,) ``ids`` seen at ``t_s`` at (N, 2) positions; runs a round when one is
        due (in the background, or in line)."""
        if self._first_s is None:
            self._first_s = self._cut_s = t_s
        self._log.add(t_s, np.asarray(ids, dtype=np.int64), np.asarray(xy_m, dtype=np.float64))
        assert self._cut_s is not None
        if t_s - self._cut_s < self.options.round_s - 1e-9 or self.busy:
            return
        found = self._log.completed(self._cut_s, t_s)
        self._cut_s = t_s
        seen = 0 if found is None else len(found.done_s)
        if found is not None:
            self._pool.fresh.append(found)
        with self._lock:
            status = self.status
            self.status = replace(
                status, seconds=t_s - self._first_s, samples=status.samples + seen
            )
        planned = self._plan()
        if planned is None:
            return
        if not self.options.background:
            self._run_round(*planned)
            return
        self._thread = threading.Thread(target=self._run_round, args=planned, daemon=True)
        self._thread.start()

    @property
    def busy(self) -> bool:
        """Whether a background round is running."""
        return self._thread is not None and self._thread.is_alive()

    def wait(self) -> None:
        """Until a background round has finished."""
        if self._thread is not None:
            self._thread.join()

    def _plan(self) -> tuple[Completed, Completed] | None:
        """(train, holdout) of the next round, or None while there is too little of either."""
        options, pool = self.options, self._pool
        if pool.fresh_count() < options.min_holdout:
            return None
        fresh = joined(pool.fresh)
        order = np.argsort(fresh.done_s, kind="stable")
        held = max(options.min_holdout, round(options.holdout_share * len(order)))
        newest = np.zeros(len(order), dtype=bool)
        newest[order[len(order) - held :]] = True
        older = _subset(fresh, ~newest)
        if len(older.done_s):
            pool.buffer = older if pool.buffer is None else joined([pool.buffer, older])
            pool.buffer = _newest(pool.buffer, options.buffer_samples)
        holdout = _subset(fresh, newest)
        pool.fresh = [holdout]
        if pool.buffer is None or len(pool.buffer.done_s) < options.min_train:
            return None
        pool.fresh = []
        train = pool.buffer
        pool.buffer = _newest(joined([train, holdout]), options.buffer_samples)
        return train, holdout

    def _run_round(self, train: Completed, holdout: Completed) -> None:
        started = time.perf_counter()
        self._round += 1
        threads = torch.get_num_threads()
        torch.set_num_threads(self.options.threads)  # in a background thread: its pool only
        try:
            if self.options.background:
                decision = self._judged_round(train, holdout)
            else:  # in line: seeded, and the caller's random state left as it was
                with torch.random.fork_rng(devices=[]):
                    torch.manual_seed(self.options.seed + self._round)
                    decision = self._judged_round(train, holdout)
        except (GrouptronError, RuntimeError, ValueError) as exc:
            # A round that breaks (its fine-tune diverged, say) is a round not accepted: a
            # session that forecasts for a robot goes on with the weights it has.
            log.warning("learning: round %d failed and was dropped: %s", self._round, exc)
            decision = {}
        finally:
            torch.set_num_threads(threads)
        with self._lock:
            status = self.status
            spent = status.training_s + time.perf_counter() - started
            self.status = replace(status, rounds=status.rounds + 1, training_s=spent, **decision)
        log.info("learning: %s", self.status.line())

    def _judged_round(self, train: Completed, holdout: Completed) -> dict[str, object]:
        """Roll back, fine-tune and judge; the status fields the round changed."""
        held_groups = groups_for_model(holdout.samples, self.config)
        in_use, changes = self.model, dict[str, object]()
        if self.status.adapted:
            worse, _ = self._difference(in_use, self.shipped, holdout.samples, held_groups)
            if worse.low > 0:
                in_use = self.shipped
                changes.update(rolled_back=self.status.rolled_back + 1, adapted=False)
                self.model = self.shipped
        candidate = copy.deepcopy(in_use)
        train_groups = groups_for_model(train.samples, self.config)
        rng = np.random.default_rng([self.options.seed, self._round])
        self._iteration = fine_tune(
            candidate,
            self.config,
            train.samples,
            train_groups,
            self.options.budget,
            rng=rng,
            iteration=self._iteration,
        )
        difference, fde_in_use = self._difference(candidate, in_use, holdout.samples, held_groups)
        changes["last_difference"] = difference
        if difference.high < 0 and -difference.mean >= self.options.min_gain * fde_in_use:
            self.model = candidate  # one assignment: a forecast sees old or new, never half
            changes.update(accepted=self.status.accepted + 1, adapted=True)
        return changes

    def _difference(
        self,
        new: TrajectronCVAE,
        old: TrajectronCVAE,
        samples: SampleSet,
        groups: SampleGroups | None,
    ) -> tuple[Interval, float]:
        """FDE of ``new`` minus ``old`` on ``samples`` (metres; 95% interval over time steps),
        and ``old``'s mean FDE."""
        options = EngineOptions(distribution=False, batch_size=1024)
        final = samples.fut_rel_m[:, -1].astype(np.float64)  # (S, 2)
        errors = []
        for model in (new, old):
            made = forecast_samples(model, self.config, samples, self.forecast, groups, options)
            errors.append(np.linalg.norm(made.point[:, -1] - final, axis=-1))  # (S,)
        difference = mean_interval(errors[0] - errors[1], time_step_ids(samples))
        return difference, float(errors[1].mean())


def _subset(completed: Completed, keep: np.ndarray) -> Completed:
    return Completed(completed.samples.subset(keep), completed.done_s[keep])


def _newest(completed: Completed, count: int) -> Completed:
    """The ``count`` most recently completed samples (all where there are fewer)."""
    if len(completed.done_s) <= count:
        return completed
    cut = np.sort(completed.done_s)[len(completed.done_s) - count]
    return _subset(completed, completed.done_s >= cut)
