"""Arguments of the Python API: one clear ``GrouptronError`` for anything malformed, NumPy
integers taken as integers, and a refused streaming update that leaves the session usable."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from grouptron import Predictor
from grouptron.errors import GrouptronError
from grouptron.point_forecast import PointForecast


@pytest.fixture(scope="module")
def predictor(tiny_checkpoints: Path) -> Predictor:
    return Predictor.from_checkpoint(tiny_checkpoints / "grouptron-eth-backward")


def walk(people: int = 3, steps: int = 10) -> np.ndarray:
    """(R, 4) rows frame, id, x, y: people 1.. walking east at 1.25 m/s, 1 m apart."""
    return np.array(
        [(10 * k, p, 0.5 * k, float(p)) for k in range(steps) for p in range(1, people + 1)]
    )


def test_a_refused_streaming_update_leaves_the_session_as_it_was(predictor: Predictor) -> None:
    session, again = predictor.stream(), predictor.stream()
    positions = [[0.0, 1.0], [0.0, 2.0]]
    for k in range(4):
        xy = [[0.5 * k, 1.0], [0.5 * k, 2.0]]
        session.update(10 * k, [1, 2], xy)
        again.update(10 * k, [1, 2], xy)
    with pytest.raises(GrouptronError, match="whole numbers"):
        session.update(40, [1, 2.5], positions)
    with pytest.raises(GrouptronError, match="out of range"):
        session.update(40, [1, 2], [[1e9, 0.0], [0.0, 2.0]])
    expected = again.update(40, [1, 2], [[2.0, 1.0], [2.0, 2.0]])
    found = session.update(40, [1, 2], [[2.0, 1.0], [2.0, 2.0]])
    np.testing.assert_array_equal(found.point, expected.point)


def test_frames_t_samples_and_seeds_must_be_integers(predictor: Predictor) -> None:
    rows = walk()
    shifted = rows.copy()
    shifted[shifted[:, 0] == 90, 0] += 0.5  # only the last frame: it used to give nothing
    cases = [
        (lambda: predictor.predict(shifted), "row 27: frame 90.5 is not a whole number"),
        (lambda: predictor.predict(rows, t=45), "t=45 is not on the 10-frame grid"),
        (lambda: predictor.predict(rows, t=50.7), "t must be an integer"),
        (lambda: predictor.predict(rows, t="abc"), "t must be an integer"),
        (lambda: predictor.predict(rows, t=float("nan")), "t must be an integer"),
        (lambda: predictor.predict(rows, num_samples=2.5), "num_samples must be an integer"),
        (lambda: predictor.predict(rows, num_samples=10**12), "from 0 to 10000"),
        (lambda: predictor.predict(rows, num_samples=2, seed=None), "seed must be an integer"),
        (lambda: predictor.stream().update("0", [1], [[0.0, 0.0]]), "frame must be an integer"),
        (lambda: predictor.predict(rows, t=1000), "t=1000 is outside the tracks' frames 0-90"),
        (lambda: predictor.predict(rows, t=-10), "t=-10 is outside the tracks' frames 0-90"),
    ]
    for call, message in cases:
        with pytest.raises(GrouptronError, match=message):
            call()
    big = rows.copy()
    big[:, 1] += 2**60
    with pytest.raises(GrouptronError, match=r"id .* is beyond 2\*\*53"):
        predictor.predict(big)
    twice = np.vstack([rows, rows[-1:]])
    match = r"row 30: pedestrian 3 appears twice at frame 90 \(also row 29\)"
    with pytest.raises(GrouptronError, match=match):
        predictor.predict(twice)
    # Whole floats and NumPy integers are integers.
    t = predictor.predict(rows, t=np.int64(90), num_samples=np.int64(2), seed=np.int64(1))
    assert len(predictor.predict(rows, t=90.0)) == len(t) == 3


def test_constructor_arguments_are_checked(predictor: Predictor, tiny_checkpoints: Path) -> None:
    model, config = predictor.model, predictor.config
    folder = tiny_checkpoints / "grouptron-eth-backward"
    cases = [
        (lambda: Predictor(model, config, forecast=""), "forecast must be one of"),
        (lambda: Predictor(model, config, forecast=["ml"]), "forecast must be one of"),  # type: ignore[arg-type]
        (lambda: Predictor(model, config, device=None), "device must be a name"),
        (lambda: Predictor.from_checkpoint(folder, threads=0), "threads must be an integer"),
        (lambda: Predictor.from_checkpoint(None), "a checkpoint is a shipped name or a path"),
    ]
    for call, message in cases:
        with pytest.raises(GrouptronError, match=message):
            call()
    trimmed = Predictor(model, config, forecast="ml-top3", min_points=np.int64(3))
    assert (trimmed.decoded_latent_values, trimmed.min_points) == (3, 3)
    empty = predictor.predict(walk(steps=1))
    assert empty.ids.dtype == np.int64 and len(empty) == 0


def test_tables_of_every_common_kind_are_read_by_column_name(predictor: Predictor) -> None:
    rows = walk()
    expected = predictor.predict(rows).point
    columns = {name: rows[:, i] for i, name in enumerate(("frame", "id", "x", "y"))}
    structured = np.zeros(len(rows), dtype=[(n, "f8") for n in ("x", "y", "id", "frame")])
    for name, column in columns.items():
        structured[name] = column
    for table in (columns, structured):
        np.testing.assert_array_equal(predictor.predict(table).point, expected)
    with pytest.raises(GrouptronError, match="must be numbers: columns"):
        predictor.predict({**columns, "x": ["a"] * len(rows)})
    with pytest.raises(GrouptronError, match=r"load_tracks\(path\)"):
        predictor.predict("tracks.txt")


@pytest.mark.parametrize("row", [1, 56])
def test_a_far_position_names_the_callers_row_wherever_it_is(
    predictor: Predictor, row: int
) -> None:
    rows = walk(steps=20)
    # Row 1 (frame 0) lies outside the window a forecast at the last frame (190) reads.
    assert 190 - predictor.window_frames > 0
    rows[row, 3] = 1e300
    with pytest.raises(GrouptronError, match=rf"^tracks row {row}: y = 1e\+300 m is out of range"):
        predictor.predict(rows)
    with pytest.raises(GrouptronError, match=r"^frame 0: row 1: x = 3e\+09 m is out of range"):
        predictor.stream().update(0, [1, 2], [[0.0, 0.0], [3e9, 0.0]])


def test_the_older_keywords_most_likely_and_latent_values_still_work_with_a_warning(
    predictor: Predictor, tiny_checkpoints: Path
) -> None:
    """``most_likely=`` (``forecast``'s older name) and ``latent_values=K`` (``ml-topK``) are
    still accepted, each with a ``FutureWarning``, and checked as they were; a forecast's
    older attribute ``Forecast.most_likely`` is its ``point``."""
    model, config = predictor.model, predictor.config
    Z = config.model.latent_values
    folder = tiny_checkpoints / "grouptron-eth-backward"
    with pytest.warns(FutureWarning, match="most_likely= is now called forecast="):
        older = Predictor(model, config, most_likely="mean")
    assert older.forecast == PointForecast("mean")
    with pytest.warns(FutureWarning, match="most_likely= is now called forecast="):
        loaded = Predictor.from_checkpoint(folder, most_likely="ml-argmax")
    assert (loaded.point_forecast_name, loaded.decoded_latent_values) == ("ml-argmax", 1)
    with pytest.warns(FutureWarning, match="latent_values=K is now named as forecast='ml-topK'"):
        trimmed = Predictor(model, config, latent_values=np.int64(3), min_points=np.int64(3))
    assert (trimmed.point_forecast_name, trimmed.decoded_latent_values) == ("ml-top3", 3)
    with pytest.warns(FutureWarning):
        both = Predictor(model, config, most_likely="ml", latent_values=1)
    assert both.forecast == PointForecast.parse("ml-argmax")
    with pytest.warns(FutureWarning):
        same = Predictor(model, config, forecast="ml-top10", latent_values=min(10, Z))
    assert same.decoded_latent_values == min(10, Z)
    cases = [
        (lambda: Predictor(model, config, most_likely=""), "forecast must be one of"),
        (lambda: Predictor(model, config, latent_values=True), "latent_values must be"),
        (lambda: Predictor(model, config, latent_values=0), "latent_values"),
        (lambda: Predictor(model, config, latent_values=Z + 1), "latent_values"),
        (lambda: Predictor(model, config, latent_values=2.5), "latent_values"),
        (
            lambda: Predictor(model, config, most_likely="ml-argmax", latent_values=2),
            "'ml-argmax' does not decode 2 latent values",
        ),
        (
            lambda: Predictor(model, config, most_likely="mean", latent_values=2),
            "'mean' does not decode 2 latent values",
        ),
        (
            lambda: Predictor(model, config, forecast="ml", most_likely="ml"),
            "give forecast= or its older name most_likely=, not both",
        ),
    ]
    with pytest.warns(FutureWarning):
        for call, message in cases:
            with pytest.raises(GrouptronError, match=message):
                call()
    forecast = predictor.predict(walk())
    assert forecast.most_likely is forecast.point
