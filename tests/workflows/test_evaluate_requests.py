"""A Python caller of ``workflows.evaluate`` gets the command line's one-line refusals, before
anything is read (nothing here exists on disk)."""

from __future__ import annotations

from pathlib import Path

import pytest

from grouptron.errors import GrouptronError
from grouptron.workflows.evaluate import Benchmark, EvaluationOptions, Tracks, evaluate

MISSING = Path("no-such-folder") / "tracks.txt"


@pytest.mark.parametrize(
    ("source", "checkpoint", "modes", "options", "message"),
    [
        (Benchmark(), None, ("best-of-20",), EvaluationOptions(), "constant velocity makes one"),
        (Benchmark(), None, ("ml",), EvaluationOptions(ablate=("edges",)), "--ablate takes"),
        (Tracks((MISSING,)), "x.safetensors", ("nll",), EvaluationOptions(), "nll is scored on"),
        (Benchmark(), "x.safetensors", ("ml-best",), EvaluationOptions(), "unknown mode ml-best"),
        (Benchmark(), "x.safetensors", "ml", EvaluationOptions(), "a sequence of evaluation"),
        (Benchmark(), None, None, EvaluationOptions(regions=(0.9,)), "no distribution to draw"),
        (Benchmark(), "x.safetensors", None, EvaluationOptions(regions=(1.0,)), "in \\(0, 0.99"),
        (Benchmark(), "x.safetensors", None, EvaluationOptions(regions=0.9), "a sequence of prob"),
        (Benchmark(), "x.safetensors", None, EvaluationOptions(calibration="c.json"), "--regions"),
        (
            Benchmark(),
            "x.safetensors",
            ("best-of-20",),
            EvaluationOptions(regions=(0.9,)),
            "--mode best-of-20 has none",
        ),
    ],
)
def test_meaningless_requests_are_refused_in_one_line(
    source: object, checkpoint: str | None, modes: object, options: EvaluationOptions, message: str
) -> None:
    with pytest.raises(GrouptronError, match=message) as caught:
        evaluate(source, checkpoint, modes, options)  # type: ignore[arg-type]
    assert "\n" not in str(caught.value)


def test_tracks_need_a_file() -> None:
    with pytest.raises(GrouptronError, match="at least one track file"):
        Tracks(())
