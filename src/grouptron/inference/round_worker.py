"""A process of its own for a live session's learning rounds.

A round run in a thread of the forecasting process shares its interpreter lock: the
forecast's Python between PyTorch calls waits for the round's, which slowed live updates;
beside a process of its own a live update at 50 people is within a few percent of one without
learning (``benchmarks/streaming.py --learn``). The session's process sends each
round's job and waits for the answer in a thread that sleeps meanwhile.

Nothing crosses the pipe as a pickle: settings go as JSON, weights as safetensors, samples as
NumPy ``.npz`` (read with ``allow_pickle=False``).
"""

from __future__ import annotations

import contextlib
import dataclasses
import io
import json
import os
import signal
import subprocess
import sys
import weakref
from pathlib import Path
from typing import IO, Any

import numpy as np
import torch
from safetensors.torch import load as load_weights
from safetensors.torch import save as save_weights

import grouptron
from grouptron.config import config_to_dict, experiment_from_stored
from grouptron.data.prepare.samples import SampleSet
from grouptron.errors import GrouptronError
from grouptron.evaluation.uncertainty import Interval
from grouptron.inference.learning_round import RoundJob, RoundResult, RoundSettings, seeded_round
from grouptron.model.factory import build_model
from grouptron.model.forecaster import Forecaster
from grouptron.point_forecast import PointForecast
from grouptron.training.fine_tune import FineTune

STOP_WAIT_S = 0.3
"""How long a worker gets to read the end of its input and return before it is terminated
when a round it runs is to be dropped: a node stops within a second."""
FINISH_WAIT_S = 10.0
"""How long a round running when a session closes gets to finish (its worker's start
included)."""


class RoundWorker:
    """Rounds in a process of its own (started at the first round; one per session).

    The process is a fresh interpreter running this module (``python -m``), not a
    ``multiprocessing`` child: those re-import the caller's main script, and a script without
    an ``if __name__ == "__main__"`` guard would start itself again.
    """

    def __init__(self, settings: RoundSettings, threads: int) -> None:
        """Start the process (it reads its settings from ``start``: until then it waits)."""
        package_root = str(Path(grouptron.__file__).resolve().parents[1])
        paths = [package_root, *os.environ.get("PYTHONPATH", "").split(os.pathsep)]
        env = {**os.environ, "PYTHONPATH": os.pathsep.join(p for p in paths if p)}
        self._process = subprocess.Popen(
            [sys.executable, "-m", __name__, str(threads)],
            stdin=subprocess.PIPE,
            stdout=subprocess.PIPE,
            env=env,
        )
        # A session dropped without close() stops its process too.
        self._stop = weakref.finalize(self, _stop, self._process)
        self._settings = settings
        start = {
            "config": config_to_dict(settings.config),
            "forecast": settings.forecast.name,
            "budget": dataclasses.asdict(settings.budget),
            "min_gain": settings.min_gain,
            "seed": settings.seed,
        }
        self._start = start
        self._pipes = _Pipes(self._process.stdout, self._process.stdin)

    def start(self, shipped: Forecaster) -> None:
        """Send the settings and the shipped weights (blocks until the process reads them:
        it imports PyTorch first; ``close`` from another thread ends the wait)."""
        try:
            self._pipes.send(self._start, [_weights_bytes(shipped)])
        except (OSError, ValueError):
            raise GrouptronError("the learning process stopped") from None

    def run(self, job: RoundJob) -> RoundResult:
        """The round's result, computed in the worker process."""
        header = {"adapted": job.adapted, "number": job.number, "iteration": job.iteration}
        blobs = [_weights_bytes(job.in_use), _samples_bytes(job.train)]
        try:
            self._pipes.send(header, [*blobs, _samples_bytes(job.holdout)])
            answer, weights = self._pipes.receive()
        except (EOFError, OSError):
            raise GrouptronError("the learning process stopped") from None
        if "error" in answer:
            raise GrouptronError(answer["error"])
        accepted = _model(weights[0], self._settings) if weights else None
        difference = Interval(*answer["difference"])
        return RoundResult(answer["rolled_back"], accepted, difference, answer["iteration"])

    def close(self, wait_s: float = STOP_WAIT_S) -> None:
        """Stop the process: it gets ``wait_s`` to finish a round and read the end of its
        input, then is terminated."""
        self._stop.detach()
        _stop(self._process, wait_s)


def _stop(process: subprocess.Popen[bytes], wait_s: float = STOP_WAIT_S) -> None:
    if process.stdin is not None:
        with contextlib.suppress(OSError):  # it is gone already
            process.stdin.close()  # a worker between rounds reads the end and returns
    try:
        process.wait(timeout=wait_s)
    except subprocess.TimeoutExpired:
        process.terminate()
        try:
            process.wait(timeout=STOP_WAIT_S)
        except subprocess.TimeoutExpired:
            process.kill()
            process.wait()


class _Pipes:
    """Length-prefixed frames: a JSON header, then the blobs it counts."""

    def __init__(self, incoming: IO[bytes] | None, outgoing: IO[bytes] | None) -> None:
        assert incoming is not None and outgoing is not None
        self.incoming, self.outgoing = incoming, outgoing

    def send(self, header: dict[str, Any], blobs: list[bytes]) -> None:
        for frame in (json.dumps({**header, "blobs": len(blobs)}).encode(), *blobs):
            self.outgoing.write(len(frame).to_bytes(8, "little"))
            self.outgoing.write(frame)
        self.outgoing.flush()

    def receive(self) -> tuple[dict[str, Any], list[bytes]]:
        header = json.loads(self._frame().decode())
        return header, [self._frame() for _ in range(header.pop("blobs"))]

    def _frame(self) -> bytes:
        size = self.incoming.read(8)
        if len(size) < 8:
            raise EOFError
        data = self.incoming.read(int.from_bytes(size, "little"))
        if len(data) < int.from_bytes(size, "little"):
            raise EOFError
        return data


def serve(threads: int) -> None:
    """The worker process: read the session's settings, then answer rounds until its input
    ends. Its standard output carries the frames alone (anything printed goes to stderr)."""
    # Ctrl-C in a terminal reaches the whole process group: the session stops this process
    # (``RoundWorker.close``), which must not end in a traceback of its own first.
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    torch.set_num_threads(threads)
    frames_out = os.fdopen(os.dup(sys.stdout.fileno()), "wb")
    os.dup2(sys.stderr.fileno(), sys.stdout.fileno())
    pipes = _Pipes(sys.stdin.buffer, frames_out)
    start, (shipped_bytes,) = pipes.receive()
    settings = RoundSettings(
        config=experiment_from_stored(start["config"]),
        forecast=PointForecast.parse(start["forecast"]),
        budget=FineTune(**start["budget"]),
        min_gain=start["min_gain"],
        seed=start["seed"],
    )
    shipped = _model(shipped_bytes, settings)
    while True:
        try:
            header, (in_use, train, holdout) = pipes.receive()
        except EOFError:
            return
        job = RoundJob(
            in_use=_model(in_use, settings) if header["adapted"] else shipped,
            adapted=header["adapted"],
            train=_samples(train),
            holdout=_samples(holdout),
            number=header["number"],
            iteration=header["iteration"],
        )
        try:
            result = seeded_round(job, shipped, settings)
        except (GrouptronError, RuntimeError, ValueError) as exc:
            pipes.send({"error": str(exc)}, [])
            continue
        d = result.difference
        answer = {
            "rolled_back": result.rolled_back,
            "difference": [d.mean, d.low, d.high],
            "iteration": result.iteration,
        }
        pipes.send(answer, [] if result.accepted is None else [_weights_bytes(result.accepted)])


def _weights_bytes(model: Forecaster) -> bytes:
    return save_weights({k: v.detach().cpu().contiguous() for k, v in model.state_dict().items()})


def _model(weights: bytes, settings: RoundSettings) -> Forecaster:
    model = build_model(settings.config)
    model.load_state_dict(load_weights(weights))
    return model.eval()


def _samples_bytes(samples: SampleSet) -> bytes:
    """The samples as the sample cache stores them (``SampleSet.to_arrays``), in memory."""
    buffer = io.BytesIO()
    np.savez(buffer, **samples.to_arrays())  # type: ignore[arg-type]  # stubs: allow_pickle
    return buffer.getvalue()


def _samples(blob: bytes) -> SampleSet:
    with np.load(io.BytesIO(blob), allow_pickle=False) as arrays:
        return SampleSet.from_arrays(dict(arrays))


if __name__ == "__main__":
    serve(int(sys.argv[1]))
