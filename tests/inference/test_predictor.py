"""The Python API: one-shot and streaming forecasts agree with each other and the evaluator."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import torch

from grouptron import Predictor
from grouptron.data.datasets.dataset import load_scenes
from grouptron.data.datasets.locate import split_files
from grouptron.errors import GrouptronError
from grouptron.inference.tracks import forecast_scene
from grouptron.point_forecast import PointForecast


@pytest.fixture(scope="module")
def recording(synthetic_data_dir: Path) -> np.ndarray:
    """(R, 4) frame, id, x, y rows of the synthetic test recording."""
    return np.loadtxt(split_files(synthetic_data_dir, "eth", "test")[0])


@pytest.fixture(scope="module")
def causal(tiny_checkpoints: Path) -> Predictor:
    return Predictor.from_checkpoint(
        "grouptron-eth-backward",
        checkpoints_dir=tiny_checkpoints,
        forecast="ml",
        mixture=True,
    )


def test_predict_matches_the_track_file_forecast(
    causal: Predictor, recording: np.ndarray, synthetic_data_dir: Path
) -> None:
    (scene,) = load_scenes(split_files(synthetic_data_dir, "eth", "test"), causal.config.data)
    whole = forecast_scene(causal.model, causal.config, scene, min_points=2)
    frame = int(np.median(whole.frames))
    forecast = causal.predict(recording, t=frame, num_samples=4)
    at_frame = whole.frames == frame
    assert len(forecast) == at_frame.sum() > 1
    order = np.argsort(whole.ids[at_frame])
    np.testing.assert_allclose(forecast.ids, whole.ids[at_frame][order])
    np.testing.assert_allclose(forecast.point, whole.point[at_frame][order], atol=1e-5)
    N, Z, H = len(forecast), causal.config.model.latent_values, 12
    assert forecast.samples is not None and forecast.samples.shape == (N, 4, H, 2)
    assert forecast.mixture is not None and forecast.mixture.means.shape == (N, Z, H, 2)
    np.testing.assert_allclose(np.exp(forecast.mixture.log_weights).sum(1), 1.0, rtol=1e-5)
    cov = forecast.mixture.covariances
    np.testing.assert_allclose(cov, cov.swapaxes(-1, -2))
    assert (np.linalg.eigvalsh(cov) > 0).all()
    assert ((forecast.group >= 0) & (forecast.group < N)).all()


def test_argmax_latent_fast_path_follows_the_most_probable_latent(
    causal: Predictor, recording: np.ndarray
) -> None:
    frame = int(np.median(recording[:, 0]))
    full = causal.predict(recording, t=frame)
    fast = Predictor(causal.model, causal.config, forecast="ml-argmax", mixture=False)
    quick = fast.predict(recording, t=frame)
    assert quick.mixture is None and full.mixture is not None
    best = full.mixture.log_weights.argmax(axis=1)
    expected = full.mixture.means[np.arange(len(best)), best]  # (N, H, 2)
    np.testing.assert_allclose(quick.point, expected, atol=1e-4)
    np.testing.assert_array_equal(quick.group, full.group)
    # The two definitions of "most likely" differ for a trained multimodal model.
    assert not np.allclose(quick.point, full.point, atol=1e-4)
    with pytest.raises(GrouptronError, match="forecast must be one of"):
        Predictor(causal.model, causal.config, forecast="median")


def test_the_mean_forecast_is_the_weighted_mean_of_the_mixture_means(
    causal: Predictor, recording: np.ndarray, synthetic_data_dir: Path
) -> None:
    frame = int(np.median(recording[:, 0]))
    full = causal.predict(recording, t=frame)
    mean = Predictor(causal.model, causal.config, forecast="mean").predict(recording, t=frame)
    assert full.mixture is not None
    weights = np.exp(full.mixture.log_weights)[:, :, None, None]  # (N, Z, 1, 1)
    expected = (weights * full.mixture.means).sum(axis=1)  # (N, H, 2)
    np.testing.assert_allclose(mean.point, expected, atol=1e-4)
    assert not np.allclose(mean.point, full.point, atol=1e-4)
    # The track-file path gives the same mean forecast.
    (scene,) = load_scenes(split_files(synthetic_data_dir, "eth", "test"), causal.config.data)
    whole = forecast_scene(causal.model, causal.config, scene, "mean", min_points=2)
    at_frame = whole.frames == frame
    order = np.argsort(whole.ids[at_frame])
    np.testing.assert_allclose(mean.point, whole.point[at_frame][order], atol=1e-5)
    with pytest.raises(GrouptronError, match="only ml takes the K >= 1 most probable"):
        PointForecast("mean", 3)


def test_streaming_equals_predicting_from_all_rows(
    causal: Predictor, recording: np.ndarray
) -> None:
    session = causal.stream()
    compared = 0
    for frame in np.unique(recording[:, 0]):
        rows = recording[recording[:, 0] == frame]
        streamed = session.update(int(frame), rows[:, 1], rows[:, 2:])
        direct = causal.predict(recording, t=int(frame))
        np.testing.assert_array_equal(streamed.ids, direct.ids)
        np.testing.assert_allclose(streamed.point, direct.point, atol=1e-5)
        np.testing.assert_array_equal(streamed.group, direct.group)
        compared += len(direct)
    assert compared > 50
    # The session keeps a bounded window, not the whole recording.
    assert np.ptp(session._rows[:, 0]) <= session.window_frames


def test_a_central_checkpoint_warns_on_live_tracks(
    tiny_checkpoints: Path, recording: np.ndarray
) -> None:
    path = tiny_checkpoints / "trajectron++-eth-central" / "best.safetensors"
    predictor = Predictor.from_checkpoint(path)
    with pytest.warns(UserWarning, match="central derivatives"):
        predictor.predict(recording)


class _Table:
    """A minimal DataFrame stand-in: named columns."""

    def __init__(self, values: np.ndarray, names: tuple[str, ...]) -> None:
        self.columns = list(names)
        self._values = dict(zip(names, values.T, strict=True))

    def __getitem__(self, name: str) -> np.ndarray:
        return self._values[name]


def test_inputs_are_checked(causal: Predictor, recording: np.ndarray, tmp_path: Path) -> None:
    table = _Table(recording[:, [2, 3, 0, 1]], ("x", "y", "frame", "id"))
    np.testing.assert_allclose(causal.predict(table).point, causal.predict(recording).point)
    bad = recording.copy()
    bad[5, 2] = np.nan
    cases = [
        (lambda: causal.predict(recording[:, :3]), "shape|rows, 4"),
        (lambda: causal.predict(bad), "row 5 is not finite"),
        (lambda: causal.predict([["a", 1, 2, 3]]), "must be numbers"),
        (lambda: causal.predict(np.zeros((0, 4))), "empty"),
        (lambda: causal.predict(_Table(recording, ("frame", "id", "x", "z"))), "columns"),
        (lambda: causal.predict(recording, num_samples=-1), "num_samples"),
        (lambda: Predictor.from_checkpoint("nope", checkpoints_dir=tmp_path), "no checkpoint nope"),
    ]
    for call, message in cases:
        with pytest.raises(GrouptronError, match=message):
            call()
    session = causal.stream()
    session.update(100, [1, 2], [[0.0, 0.0], [1.0, 1.0]])
    for frame, ids, xy, message in [
        (100, [1], [[0, 0]], "not after"),  # late: dropped (LateUpdateError)
        (105, [1], [[0, 0]], "grid"),
        (110, [1, 2], [[0, 0]], r"\(2, 2\) for 2 ids, got \(1, 2\)"),
        (110, [1], [[np.inf, 0]], "not finite"),
    ]:
        with pytest.raises(GrouptronError, match=message):
            session.update(frame, ids, xy)
    # Nobody seen twice yet: an empty forecast, not an error; then person 1's second point.
    assert len(session.update(110, [3], [[0.1, 0.1]])) == 0
    assert len(session.update(120, [1, 3], [[0.1, 0.1], [0.2, 0.2]])) == 2


def test_a_recording_forecast_with_central_derivatives_matches_the_track_file_forecast(
    tiny_checkpoints: Path, recording: np.ndarray, synthetic_data_dir: Path
) -> None:
    central = Predictor.from_checkpoint(
        "grouptron-eth-central", checkpoints_dir=tiny_checkpoints, forecast="ml"
    )
    (scene,) = load_scenes(split_files(synthetic_data_dir, "eth", "test"), central.config.data)
    whole = forecast_scene(central.model, central.config, scene, min_points=2)
    for frame in np.unique(whole.frames)[::7]:  # forecasts read a window around the frame
        forecast = central.predict(recording, t=int(frame), live=False)
        at_frame = whole.frames == frame
        order = np.argsort(whole.ids[at_frame])
        expected = whole.point[at_frame][order]
        np.testing.assert_allclose(forecast.point, expected, atol=1e-5)


def test_older_names_of_point_forecasts_are_still_accepted(tiny_checkpoints: Path) -> None:
    path = tiny_checkpoints / "grouptron-eth-backward/best.safetensors"
    for older, name in (("argmax-latent", "ml-argmax"), ("mixture-mode", "ml")):
        with pytest.warns(FutureWarning, match=f"'{older}' is now called '{name}'"):
            assert Predictor.from_checkpoint(path, forecast=older).point_forecast_name == name


def test_shipped_names_resolve_from_any_working_directory(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    from grouptron.errors import GrouptronError
    from grouptron.inference.checkpoints import resolve_checkpoint

    monkeypatch.chdir(tmp_path)
    monkeypatch.delenv("GROUPTRON_CHECKPOINTS", raising=False)
    found = resolve_checkpoint("grouptron-univ-backward")
    assert found.is_file() and found.parent.name == "grouptron-univ-backward"
    with pytest.raises(GrouptronError, match=r"no checkpoint nowhere.*GROUPTRON_CHECKPOINTS"):
        resolve_checkpoint("nowhere")


@pytest.mark.slow
def test_an_installed_package_is_lean_and_names_where_the_rest_is(tmp_path: Path) -> None:
    """A wheel of the project holds the weights of the installed models only (no training
    state), every card and config, at most 10 MB; a plain install resolves an installed name
    from anywhere and refuses a shipped name it lacks in one line that says where it is."""
    import shutil
    import subprocess
    import sys
    import zipfile

    from grouptron.inference.checkpoints import INSTALLED_CHECKPOINTS
    from tests.conftest import REPO

    source = tmp_path / "source"  # a copy: building writes into the source tree
    shutil.copytree(REPO / "src", source / "src", symlinks=True)
    keep = shutil.ignore_patterns("candidates", "*.png", "metrics.*")
    shutil.copytree(REPO / "checkpoints", source / "checkpoints", ignore=keep)
    for name in ("pyproject.toml", "README.md"):
        shutil.copy(REPO / name, source / name)
    build = [sys.executable, "-m", "pip", "wheel", "--no-deps", "--no-build-isolation", "-q"]
    subprocess.run([*build, str(source), "-w", str(tmp_path / "wheel")], check=True)
    (wheel,) = (tmp_path / "wheel").glob("grouptron-*.whl")
    assert wheel.stat().st_size <= 10_000_000
    names = zipfile.ZipFile(wheel).namelist()
    detector = "grouptron/groups/detector/best.safetensors"  # the learned group detector's
    assert detector in names
    weights = sorted(n.split("/")[2] for n in names if n.endswith(".safetensors") and n != detector)
    assert weights == sorted(INSTALLED_CHECKPOINTS)  # best.safetensors only, nothing else
    shipped = sorted(p.parent.name for p in (REPO / "checkpoints").glob("*/best.safetensors"))
    for name in shipped:
        assert f"grouptron/checkpoints/{name}/config.json" in names
    target = tmp_path / "installed"
    install = [sys.executable, "-m", "pip", "install", "--no-deps", "-q", "--target"]
    subprocess.run([*install, str(target), str(wheel)], check=True)
    code = (
        "import sys; from grouptron.inference.predictor import Predictor\n"
        "p = Predictor.from_checkpoint(); print(p.source)\n"
        "try:\n    Predictor.from_checkpoint('grouptron-univ-central')\n"
        "except Exception as exc:\n    print(exc)"
    )
    run = subprocess.run(
        [sys.executable, "-c", code],
        cwd=tmp_path,
        env={"PYTHONPATH": str(target), "PATH": "/usr/bin:/bin"},
        capture_output=True,
        text=True,
        check=True,
    )
    source_line, refusal = run.stdout.strip().splitlines()
    assert source_line.startswith(str(target)), run.stdout
    assert "grouptron-univ-central is shipped in the repository's checkpoints/" in refusal
    assert "GROUPTRON_CHECKPOINTS" in refusal


def test_centimetres_given_as_metres_are_refused_by_the_api(tiny_checkpoints: Path) -> None:
    from grouptron.errors import GrouptronError

    predictor = Predictor.from_checkpoint(tiny_checkpoints / "grouptron-eth-backward")
    steps = np.arange(12)
    walkers = [(s * 10, p, 120.0 * 0.4 * s + 300 * p, 50.0 * p) for p in range(3) for s in steps]
    rows = np.asarray(walkers, dtype=float)  # 1.2 m/s written in centimetres
    with pytest.raises(GrouptronError, match=r"median walking speed is 120 m/s"):
        predictor.predict(rows)
    metres = rows.copy()
    metres[:, 2:] /= 100.0
    assert len(predictor.predict(metres)) == 3
    unchecked = Predictor.from_checkpoint(
        tiny_checkpoints / "grouptron-eth-backward", check_speed=False
    )
    assert len(unchecked.predict(rows)) == 3


@pytest.mark.parametrize("people", [1, 2, 5])
def test_a_stream_in_centimetres_never_gets_a_forecast(tiny_checkpoints: Path, people: int) -> None:
    from grouptron.errors import GrouptronError

    session = Predictor.from_checkpoint(tiny_checkpoints / "grouptron-eth-backward").stream()
    metres = Predictor.from_checkpoint(tiny_checkpoints / "grouptron-eth-backward").stream()
    ids = np.arange(people)
    refused = forecasts = 0
    for step in range(40):  # 1.2 m/s written in centimetres
        xy = np.column_stack([120.0 * 0.4 * step + 300 * ids, 50.0 * ids])
        expected = metres.update(step * 10, ids, xy / 100.0)
        try:
            forecast = session.update(step * 10, ids, xy)
        except GrouptronError as error:
            assert "median walking speed" in str(error)
            refused += 1
        else:
            assert len(forecast) == 0, f"a forecast in centimetres left at step {step}"
        forecasts += len(expected) > 0
    assert forecasts >= 30  # the same stream in metres is forecast from an early step on
    # In centimetres every update that would forecast is refused (a refused update is not kept,
    # so a track restarts after a few of them and its next update has nothing to forecast).
    assert refused >= 20


@pytest.mark.skipif(torch.cuda.is_available(), reason="the message of a machine without CUDA")
def test_an_unavailable_device_is_one_clear_error(tiny_checkpoints: Path) -> None:
    from grouptron.errors import GrouptronError

    path = tiny_checkpoints / "grouptron-eth-backward"
    with pytest.raises(GrouptronError, match="CUDA is not available here"):
        Predictor.from_checkpoint(path, device="cuda")
    with pytest.raises(GrouptronError, match="not a torch device"):
        Predictor.from_checkpoint(path, device="gpu7")
    assert Predictor.from_checkpoint(path, device="cpu").device.type == "cpu"


@pytest.mark.parametrize(
    ("ids", "xy", "message"),
    [
        ([1, 2], [[0.0, 1.0], [0.0, 1.0]][::-1], None),  # (2, 2) rows of x, y: accepted
        ([1, 2, 3], [[0.0, 1.0, 2.0], [0.0, 0.0, 0.0]], r"shape \(N, 2\) = \(3, 2\)"),  # (2, N)
        ([1, 2], [[0.0, 1.0, 2.0, 3.0]], r"got \(1, 4\)"),
        ([1, 1], [[0.0, 0.0], [1.0, 1.0]], "an id appears twice"),
        ([[1, 2]], [[0.0, 0.0], [1.0, 1.0]], "ids must be a 1-d array"),
        ([1], [[0.0, 0.0], [1.0, 1.0]], r"\(1, 2\) for 1 ids"),
    ],
)
def test_stream_inputs_are_checked_strictly(
    tiny_checkpoints: Path, ids: list, xy: list, message: str | None
) -> None:
    from grouptron.errors import GrouptronError

    session = Predictor.from_checkpoint(tiny_checkpoints / "grouptron-eth-backward").stream()
    if message is None:
        assert len(session.update(0, ids, xy)) == 0
        return
    with pytest.raises(GrouptronError, match=message):
        session.update(0, ids, xy)


def test_without_a_forecast_named_each_model_uses_its_own(causal: Predictor) -> None:
    """A velocity-residual decoder forecasts ``ml-top10`` (``ml`` of min(10, Z) latent
    values), a plain one the argmax latent; ``ml-topK`` decodes K."""
    import dataclasses

    from grouptron.model.factory import build_model

    plain = Predictor(causal.model, causal.config)
    assert (plain.point_forecast_name, plain.decoded_latent_values) == ("ml-argmax", 1)
    trimmed = Predictor(causal.model, causal.config, forecast="ml-top3")
    assert (trimmed.forecast.kind, trimmed.decoded_latent_values) == ("ml", 3)
    for latent_values, decoded in ((25, 10), (5, 5)):
        model = dataclasses.replace(
            causal.config.model, velocity_residual=True, latent_values=latent_values
        )
        config = dataclasses.replace(causal.config, model=model)
        residual = Predictor(build_model(config), config)
        assert (residual.forecast.kind, residual.decoded_latent_values) == ("ml", decoded)
        named = Predictor(build_model(config), config, forecast="ml-top10")
        assert named.decoded_latent_values == decoded


def test_a_point_forecast_stored_with_the_model_is_its_own(causal: Predictor) -> None:
    """``ExperimentConfig.point_forecast`` overrides the rule of the model's kind everywhere
    the default is read; a name that is no point forecast is refused when the config is made."""
    import dataclasses

    from grouptron.model.predict import default_point_forecast

    config = dataclasses.replace(causal.config, point_forecast="ml-top3")
    assert default_point_forecast(config) == PointForecast.parse("ml-top3")
    own = Predictor(causal.model, config)
    assert (own.forecast.kind, own.decoded_latent_values, own.point_forecast_name) == (
        "ml",
        3,
        "ml-top3",
    )
    assert Predictor(causal.model, config, forecast="ml-argmax").decoded_latent_values == 1
    with pytest.raises(GrouptronError, match="point_forecast must be one of"):
        dataclasses.replace(causal.config, point_forecast="ml-top")
    with pytest.raises(GrouptronError, match="ml-topK"):
        Predictor(causal.model, causal.config, forecast="fastest")


def test_the_most_likely_of_the_top_latent_values(causal: Predictor, recording: np.ndarray) -> None:
    """``ml-topK`` trims the mixture: K = 1 is the argmax latent, K = Z is the full mixture,
    and decoding only the top values equals picking them from all decoded ones."""
    frame = int(np.median(recording[:, 0]))
    model, config = causal.model, causal.config
    Z = config.model.latent_values

    def point(forecast: str, **options: object) -> np.ndarray:
        made = Predictor(model, config, forecast=forecast, **options)  # type: ignore[arg-type]
        return made.predict(recording, t=frame).point

    full = point("ml")
    np.testing.assert_allclose(point(f"ml-top{Z}"), full, atol=1e-5)
    np.testing.assert_allclose(point("ml-top1"), point("ml-argmax"))
    top = point("ml-top4")
    np.testing.assert_allclose(point("ml-top4", mixture=True), top, atol=1e-5)
    assert not np.allclose(top, full, atol=1e-5)  # a different mixture, so a different mode
    top10 = point("ml-top10")  # ml of the 10 most probable (all if Z <= 10)
    np.testing.assert_allclose(top10, point(f"ml-top{min(10, Z)}"))
    for bad in ("ml-top0", "ml-top2.5", "ml-top-1"):
        with pytest.raises(GrouptronError, match="ml-topK"):
            Predictor(model, config, forecast=bad)


def test_a_stream_track_that_jumps_restarts_with_a_warning(
    tiny_checkpoints: Path, caplog: pytest.LogCaptureFixture
) -> None:
    ids = np.array([1, 2, 3])
    for check_speed in (True, False):
        session = Predictor.from_checkpoint(
            tiny_checkpoints / "grouptron-eth-backward", check_speed=check_speed
        ).stream()
        caplog.clear()
        for step in range(12):
            xy = np.column_stack([0.5 * step + ids, 2.0 * ids])  # 1.25 m/s, 2 m apart
            if step == 11:
                xy[0] += 500.0  # person 1 swapped with someone far away
            forecast = session.update(step * 10, ids, xy)
        if check_speed:  # person 1 has one sighting again: nothing to forecast it from yet
            assert "id 1 reappeared where no walker gets to" in caplog.text
            assert forecast.ids.tolist() == [2, 3]
        else:  # runners, vehicles: no speed is judged
            assert "reappeared" not in caplog.text
            assert forecast.ids.tolist() == [1, 2, 3]
        assert (forecast.observed_points == 8).all()  # the others keep their history
