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
session a round runs in a process of its own (``inference.round_worker``) while forecasts go
on with the weights in use; a file's replay runs them in line, at recording time. Either way
a round is seeded by its number: the same samples give the same weights.
"""

from __future__ import annotations

import copy
import logging
import os
import threading
import time
from dataclasses import dataclass, field, replace

import numpy as np
import torch

from grouptron.config import ExperimentConfig
from grouptron.errors import GrouptronError
from grouptron.evaluation.uncertainty import Interval
from grouptron.inference.inputs import MAX_MISSED_STEPS
from grouptron.inference.learning_round import RoundJob, RoundResult, RoundSettings, seeded_round
from grouptron.inference.round_worker import FINISH_WAIT_S, STOP_WAIT_S, RoundWorker
from grouptron.inference.site_samples import Completed, SiteLog, joined
from grouptron.model.forecaster import Forecaster
from grouptron.point_forecast import PointForecast
from grouptron.training.fine_tune import FineTune

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
        min_holdout_steps: distinct completion times the held-out samples span at least (the
            guard's interval resamples time steps).
        min_gain: the smallest mean FDE gain a round must bring, as a share of the FDE of the
            weights in use on the held-out samples.
        buffer_samples: the newest training samples kept.
        seed: of the rounds' batches, rotations and noise.
        threads: PyTorch threads of a round.
        background: rounds in a process of its own (live sessions); False: in line, at
            stream time (a file's replay: deterministic).
    """

    round_s: float = 30.0
    budget: FineTune = field(default_factory=FineTune)
    min_train: int = 100
    min_holdout: int = 40
    holdout_share: float = 0.3
    min_holdout_steps: int = 10
    min_gain: float = 0.01
    buffer_samples: int = 4000
    seed: int = 0
    threads: int = 1
    background: bool = True

    def __post_init__(self) -> None:
        if not self.round_s > 0:
            raise GrouptronError(f"learning round_s must be > 0 seconds, not {self.round_s}")
        counts = (self.min_train, self.min_holdout, self.min_holdout_steps, self.buffer_samples)
        if min(*counts, self.threads) < 1:
            raise GrouptronError(
                "learning min_train, min_holdout, min_holdout_steps, buffer_samples and "
                "threads must be >= 1"
            )
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
        model: Forecaster,
        config: ExperimentConfig,
        forecast: PointForecast,
        options: LearningOptions,
        max_missed_steps: int = MAX_MISSED_STEPS,
    ) -> None:
        self.config = config
        self.forecast = forecast
        self.options = options
        self.shipped = copy.deepcopy(model).eval()
        self.model = copy.deepcopy(model).eval()
        """The weights forecasts use now (replaced whole by a round, never changed in place)."""
        self._device = next(model.parameters()).device
        self.status = LearningStatus()
        # Its tracks bridge the gaps the session fills, and split at longer ones.
        self._log = SiteLog(config.data, (max_missed_steps + 1) * config.data.dt_s)
        self._pool = _Pool()
        self._first_s: float | None = None
        self._cut_s: float | None = None  # samples completed by then are in the pool
        self._iteration = 0
        self._round = 0
        self._thread: threading.Thread | None = None
        self._worker: RoundWorker | None = None
        self._lock = threading.Lock()
        self._closing = False  # close() is stopping a round: its end is no failure
        self._settings = RoundSettings(
            config, forecast, options.budget, options.min_gain, options.seed
        )

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

    def snapshot(self) -> tuple[Forecaster, LearningStatus]:
        """The weights in use and the status that describes them, taken together (a round
        replaces both)."""
        with self._lock:
            return self.model, self.status

    def resume(self, model: Forecaster, status: LearningStatus) -> None:
        """Start from weights a session of this site learnt before (a kept state) and its
        status; the shipped weights stay the yardstick a rollback returns to."""
        self.model = model.to(self._device).eval()
        self.status = status

    def threads_left(self, wanted: int) -> int:
        """The PyTorch threads a forecast may use beside a background round (``wanted`` while
        none runs): capped so that with the round's they fit the machine's cores, since with
        more threads than cores the forecast's parallel regions wait for each other."""
        if not self.busy:
            return wanted
        return min(wanted, max(1, _cores() - self.options.threads))

    def wait(self) -> None:
        """Until a background round has finished."""
        if self._thread is not None:
            self._thread.join()

    def _plan(self) -> tuple[Completed, Completed] | None:
        """(train, holdout) of the next round, or None while there is too little of either.

        The holdout: the fresh samples (never trained on) of the newest completion times, at
        least ``min_holdout`` samples over ``min_holdout_steps`` times (the interval is over
        time steps) and ``holdout_share`` of them. Training: every sample completed a horizon
        or more before the first held-out one, so that no held-out future position was a
        training target (a person's samples a step apart share 11 of 12); the others wait
        for the next round."""
        options, pool = self.options, self._pool
        if pool.fresh_count() < options.min_holdout:
            return None
        fresh = joined(pool.fresh)
        held = _newest_times(
            fresh.done_s,
            max(options.min_holdout, round(options.holdout_share * len(fresh.done_s))),
            options.min_holdout_steps,
        )
        if held is None:
            return None
        horizon_s = self.config.data.horizon_steps * self.config.data.dt_s
        cut_s = fresh.done_s[held].min() - horizon_s + 1e-9
        everything = fresh if pool.buffer is None else joined([pool.buffer, fresh])
        train = _subset(everything, everything.done_s <= cut_s)
        if len(train.done_s) < options.min_train:
            return None  # the fresh samples stay fresh
        pool.buffer = _newest(everything, options.buffer_samples)
        pool.fresh = []
        return _newest(train, options.buffer_samples), _subset(fresh, held)

    def close(self, drop_round: bool = False) -> None:
        """Stop the learning process (if one started) and the thread waiting on it; a later
        round starts another process. A round still running there gets ``FINISH_WAIT_S`` to
        finish, or (``drop_round``: a node that stops within a second) is dropped at once."""
        if not drop_round and self._thread is not None:
            self._thread.join(timeout=FINISH_WAIT_S)  # the round sends, trains and answers
        with self._lock:
            self._closing = True
            worker, self._worker = self._worker, None
        if worker is not None:
            worker.close(STOP_WAIT_S)
        if self._thread is not None:  # its process is gone: the thread ends at once
            self._thread.join(timeout=FINISH_WAIT_S)
        self._closing = False

    def _run_round(self, train: Completed, holdout: Completed) -> None:
        started = time.perf_counter()
        self._round += 1
        job = RoundJob(
            in_use=self.model,
            adapted=self.status.adapted,
            train=train.samples,
            holdout=holdout.samples,
            number=self._round,
            iteration=self._iteration,
        )
        try:
            result = self._result(job)
        except Exception as exc:
            if self._closing:  # the session stopped it: nothing failed
                log.info("learning: round %d stopped with the session", self._round)
                return
            # A round that breaks (its fine-tune diverged, its process was killed) is a round
            # not accepted: a session that forecasts for a robot goes on with its weights.
            log.warning("learning: round %d failed and was dropped: %s", self._round, exc)
            result = None
        with self._lock:
            self.status = self._applied(result, time.perf_counter() - started)
        log.info("learning: %s", self.status.line())

    def _result(self, job: RoundJob) -> RoundResult:
        """The round, in line (this thread, ``options.threads`` threads) or in the worker."""
        if self.options.background:
            worker = self._worker
            if worker is None:
                worker = RoundWorker(self._settings, self.options.threads)
                with self._lock:  # close() sees the process from now on, or it is closing
                    if self._closing:
                        worker.close()
                        raise GrouptronError("the session is closing")
                    self._worker = worker
                try:
                    worker.start(self.shipped)
                except GrouptronError:
                    worker.close()
                    self._worker = None  # the next round starts a fresh one
                    raise
            try:
                result = worker.run(job)
            except (GrouptronError, OSError):
                worker.close()  # a process that failed once is not trusted again
                if self._worker is worker:
                    self._worker = None  # the next round starts a fresh one
                raise
            accepted = result.accepted
            if accepted is not None:  # built on the CPU there: to where the session forecasts
                result = replace(result, accepted=accepted.to(self._device))
            return result
        threads = torch.get_num_threads()
        torch.set_num_threads(self.options.threads)
        try:
            return seeded_round(job, self.shipped, self._settings)
        finally:
            torch.set_num_threads(threads)

    def _applied(self, result: RoundResult | None, spent_s: float) -> LearningStatus:
        """The status after ``result`` (None: a failed round), its weights put in use."""
        status = self.status
        status = replace(status, rounds=status.rounds + 1, training_s=status.training_s + spent_s)
        if result is None:
            return status
        self._iteration = result.iteration
        if result.rolled_back:
            self.model = self.shipped
            status = replace(status, rolled_back=status.rolled_back + 1, adapted=False)
        status = replace(status, last_difference=result.difference)
        if result.accepted is not None:
            self.model = result.accepted  # one assignment: a forecast sees old or new, never half
            status = replace(status, accepted=status.accepted + 1, adapted=True)
        return status


def _cores() -> int:
    """The cores this process may run on."""
    affinity = getattr(os, "sched_getaffinity", None)
    return len(affinity(0)) if affinity is not None else os.cpu_count() or 1


def _subset(completed: Completed, keep: np.ndarray) -> Completed:
    return Completed(completed.samples.subset(keep), completed.done_s[keep])


def _newest_times(done_s: np.ndarray, samples: int, times: int) -> np.ndarray | None:
    """(S,) mask of the samples of the newest completion times that hold at least ``samples``
    samples over at least ``times`` distinct times; None where all of them do not."""
    distinct, per_time = np.unique(done_s, return_counts=True)
    distinct, held = distinct[::-1], np.cumsum(per_time[::-1])  # newest first
    enough = (held >= samples) & (np.arange(1, len(distinct) + 1) >= times)
    if not enough.any():
        return None
    mask: np.ndarray = done_s >= distinct[int(np.argmax(enough))]
    return mask


def _newest(completed: Completed, count: int) -> Completed:
    """The ``count`` most recently completed samples (all where there are fewer)."""
    if len(completed.done_s) <= count:
        return completed
    cut = np.sort(completed.done_s)[len(completed.done_s) - count]
    return _subset(completed, completed.done_s >= cut)
