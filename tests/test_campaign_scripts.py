"""The campaign's scripts: naming a screened run, copying a run into the shipped checkpoints
and the queue's progress, on small hand-made run folders."""

from __future__ import annotations

import dataclasses
import hashlib
import importlib.util
import json
import os
import sys
from pathlib import Path
from types import ModuleType

import pytest
import torch

from grouptron.config import ExperimentConfig, renamed_settings
from grouptron.errors import GrouptronError
from grouptron.model.checkpoint import Checkpoint, load_checkpoint, save_checkpoint
from grouptron.model.factory import build_model
from grouptron.presets import experiment_preset
from tests.conftest import REPO
from tests.helpers.models import SMALL

SMALL_ROBUST = dataclasses.replace(SMALL, edge_aggregation="mean", edge_count_feature=True)
ROBUST = dataclasses.replace(experiment_preset("univ", "grouptron-robust"), model=SMALL_ROBUST)
SCREENED = dataclasses.replace(ROBUST, model_name="grouptron")
"""A screening run: the paper's model name with every switch of the named variant."""


SELECTION = {
    "selected_epoch": 3,
    "validation_samples": 40,
    "full_val_ml_ade": 0.5,
    "full_val_ml_fde": 1.0,
    "full_val_cv_ade": 0.6,
    "full_val_cv_fde": 1.2,
    "candidates": [{"epoch": 3, "full_val_ml_fde": 1.0}],
}


def _script(name: str) -> ModuleType:
    sys.path.insert(0, str(REPO / "campaign"))
    try:
        spec = importlib.util.spec_from_file_location(name, REPO / "campaign" / f"{name}.py")
        assert spec is not None and spec.loader is not None
        module = importlib.util.module_from_spec(spec)
        sys.modules[name] = module  # dataclasses look their module up while it executes
        spec.loader.exec_module(module)
    finally:
        sys.path.remove(str(REPO / "campaign"))
        sys.modules.pop(name, None)
    return module


def _run(folder: Path, config: ExperimentConfig, *, finished: bool = True) -> dict:
    """A run folder as the trainer leaves it; returns the model's tensors."""
    folder.mkdir()
    state = build_model(config).state_dict()
    for name in ("best.safetensors", "last.safetensors"):
        save_checkpoint(folder / name, Checkpoint(config, state, epoch=3))
    (folder / "metrics.jsonl").write_text(json.dumps({"epoch": 1, "train_loss": 1.0}) + "\n")
    for name in ("README.md", "config.json", "curves.png", "metrics.csv"):
        (folder / name).write_text("-")
    if finished:
        (folder / "selection.json").write_text(json.dumps(SELECTION))
    return state


def test_a_screened_robust_run_gets_the_variant_name_and_keeps_its_weights(
    tmp_path: Path,
) -> None:
    script = _script("name_variant")
    state = _run(tmp_path / "screened", SCREENED)
    assert script.main([str(tmp_path / "screened")]) == 0
    for name in ("best.safetensors", "last.safetensors"):
        renamed = load_checkpoint(tmp_path / "screened" / name)
        assert renamed.config == ROBUST and renamed.epoch == 3
        assert all(torch.equal(state[k], renamed.model_state[k]) for k in state)
    stored = json.loads((tmp_path / "screened" / "config.json").read_text())
    assert stored["model_name"] == "grouptron-robust"
    assert "Grouptron (robust)" in (tmp_path / "screened" / "README.md").read_text()


def test_a_residual_trajectron_run_gets_its_name_and_other_runs_are_refused(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    script = _script("name_variant")
    residual = dataclasses.replace(SMALL, velocity_residual=True)
    trained = dataclasses.replace(experiment_preset("univ", "trajectron++"), model=residual)
    _run(tmp_path / "residual", trained)
    assert script.main([str(tmp_path / "residual"), "--as", "trajectron++-residual"]) == 0
    renamed = load_checkpoint(tmp_path / "residual" / "best.safetensors").config
    assert renamed == dataclasses.replace(trained, model_name="trajectron++-residual")
    assert renamed == dataclasses.replace(
        experiment_preset("univ", "trajectron++-residual"), model=residual
    )
    assert "Trajectron++ (residual)" in (tmp_path / "residual" / "README.md").read_text()
    plain = dataclasses.replace(trained, model=SMALL)
    _run(tmp_path / "plain", plain)
    assert script.main([str(tmp_path / "plain"), "--as", "trajectron++-residual"]) == 2
    assert "model.velocity_residual = False (the preset: True)" in capsys.readouterr().err
    _run(tmp_path / "group", SCREENED)
    assert script.main([str(tmp_path / "group"), "--as", "trajectron++-residual"]) == 2
    assert "a grouptron run, not trajectron++" in capsys.readouterr().err
    # Robust Grouptron with the residual too is neither of those: it is the third named model.
    both = dataclasses.replace(
        SCREENED, model=dataclasses.replace(SMALL_ROBUST, velocity_residual=True)
    )
    _run(tmp_path / "both", both)
    assert script.main([str(tmp_path / "both")]) == 2
    assert "model.velocity_residual = True (the preset: False)" in capsys.readouterr().err
    shipped = tmp_path / "checkpoints"
    with pytest.raises(GrouptronError, match="velocity_residual"):
        _script("ship").ship(
            tmp_path / "both", "b", replicate=False, named="grouptron-robust", shipped=shipped
        )
    assert not (shipped / "b").exists()  # refused before anything was copied
    copy = _script("ship").ship(
        tmp_path / "both", "b", replicate=True, named="grouptron-robust-residual", shipped=shipped
    )
    assert load_checkpoint(copy / "best.safetensors").config == dataclasses.replace(
        both, model_name="grouptron-robust-residual"
    )
    assert "Grouptron (robust, residual)" in (copy / "README.md").read_text()


def test_naming_refuses_a_run_with_other_settings(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    paper = dataclasses.replace(experiment_preset("univ", "grouptron"), model=SMALL_ROBUST)
    _run(tmp_path / "paper", paper)
    assert _script("name_variant").main([str(tmp_path / "paper")]) == 2
    assert "groups.linkage = 'complete' (the preset: 'single')" in capsys.readouterr().err
    assert load_checkpoint(tmp_path / "paper" / "best.safetensors").config == paper


def test_shipping_copies_a_finished_run_without_its_training_state(tmp_path: Path) -> None:
    script = _script("ship")
    shipped, paused = tmp_path / "checkpoints", tmp_path / "paused"
    _run(tmp_path / "run", SCREENED)
    (paused / "run").mkdir(parents=True)
    (paused / "run" / "last.safetensors").write_bytes(b"state")
    target = script.ship(
        tmp_path / "run",
        "v",
        replicate=False,
        named="grouptron-robust",
        shipped=shipped,
        paused=paused,
    )
    assert sorted(p.name for p in target.iterdir()) == sorted(script.FILES)
    assert not (paused / "run").exists()  # shipping deletes the paused state
    assert load_checkpoint(target / "best.safetensors").config.model_name == "grouptron-robust"
    assert load_checkpoint(tmp_path / "run" / "best.safetensors").config == SCREENED  # untouched
    card = (target / "README.md").read_text()
    assert script.SHIPPED_LINE in card and script.RESUME_LINE not in card
    replicate = script.ship(
        tmp_path / "run",
        "v-seed1",
        replicate=True,
        named="grouptron-robust",
        shipped=shipped,
        paused=paused,
    )
    assert not (replicate / "last.safetensors").exists()
    card = (replicate / "README.md").read_text()
    assert script.REPLICATE_LINE in card and script.RESUME_LINE not in card
    with pytest.raises(Exception, match="exists"):
        script.ship(tmp_path / "run", "v", replicate=False, named=None, shipped=shipped)
    _run(tmp_path / "training", SCREENED, finished=False)
    with pytest.raises(Exception, match="not finished"):
        script.ship(tmp_path / "training", "w", replicate=False, named=None, shipped=shipped)


def test_status_reports_each_runs_progress_and_the_time_left(tmp_path: Path) -> None:
    script = _script("run")
    done, running, waiting = script.queue()[:3]
    for run, epochs in ((done, 2), (running, 40)):
        folder = tmp_path / run.name
        folder.mkdir()
        records = [
            {"epoch": e, "epoch_seconds": 90.0 if e % 2 else 270.0} for e in range(1, epochs + 1)
        ]
        (folder / "metrics.jsonl").write_text("".join(json.dumps(r) + "\n" for r in records))
    (tmp_path / done.name / "selection.json").write_text(json.dumps(SELECTION))
    lines = script.status([done, running, waiting], tmp_path)
    # The final choice against constant velocity on the same validation samples: 1.0 / 1.2.
    assert lines[0] == (
        f"{done.name}: finished, validation ML FDE 1.000 m (epoch 3) = 0.833 x constant "
        "velocity's 1.200 m"
    )
    # 60 epochs left at the median 180 s: 3 h.
    assert lines[1] == f"{running.name}: epoch 40 of 100, about 3.0 h left at 180 s per epoch"
    assert lines[2] == f"{waiting.name}: not started"
    assert lines[3] == "started runs: about 3.0 h left at one run at a time"


def test_the_variant_queue_names_each_named_group_variants_runs() -> None:
    script = _script("run")
    assert script.variant_models() == ("grouptron-robust", "grouptron-robust-residual")
    names = [run.name for run in script.variant_queue("grouptron-robust-residual")]
    # The names the runs already trained under: univ central seed 0, then the causal splits.
    assert names[:3] == [
        "grouptron-robust-residual-univ-central",
        "grouptron-robust-residual-eth-backward",
        "grouptron-robust-residual-hotel-backward",
    ]
    assert "grouptron-robust-residual-univ-central-s2" in names and len(names) == 15
    assert names[-2:] == [
        "grouptron-robust-residual-zara1-backward-s2",
        "trajectron++-zara1-backward-s2",
    ]


def test_workers_share_the_queue_one_run_each(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    script = _script("run")
    name = "trajectron++-zara1-backward"
    folder = tmp_path / name
    started: list[list[str]] = []

    def train(argv: list[str], **kwargs: object) -> None:
        # While the run trains, its lock is held: another worker can neither claim it nor
        # see it idle.
        assert script.claim(folder, retry_s=0) is None and script.held(folder)
        started.append(argv)

    monkeypatch.setattr(script.subprocess, "run", train)
    monkeypatch.setattr(sys, "argv", ["run.py", "--out", str(tmp_path), "--only", name])
    other_worker = script.claim(folder, retry_s=0)
    assert other_worker is not None
    try:
        assert script.main() == 0
        assert (
            started == [] and f"{name}: being trained by another worker" in capsys.readouterr().out
        )
    finally:
        os.close(other_worker)
    assert not script.held(folder)
    assert script.main() == 0
    assert len(started) == 1 and started[0][started[0].index("--split") + 1] == "zara1"
    assert not script.held(folder)  # released when the training ends


def test_a_run_on_another_device_names_it_and_resumes_there(tmp_path: Path) -> None:
    script = _script("run")
    run = next(r for r in script.variant_queue("grouptron-robust-residual") if r.seed == 2)
    on_cpu = script.command(run, tmp_path / run.name, "fp32")
    assert "--device" not in on_cpu  # the default leaves the training's own default
    (tmp_path / run.name).mkdir()
    (tmp_path / run.name / "last.safetensors").write_bytes(b"")
    on_gpu = script.command(run, tmp_path / run.name, "bf16", threads=2, device="cuda")
    assert on_gpu[on_gpu.index("--device") + 1] == "cuda" and on_gpu[-1] == "--resume"


def test_the_time_left_follows_the_device_a_run_is_on_now(tmp_path: Path) -> None:
    script = _script("run")
    # 50 epochs on a fast device, then 7 on a slow one: the recent epochs set the pace.
    records = [{"epoch": e, "epoch_seconds": 10.0 if e <= 50 else 45.0} for e in range(1, 58)]
    (tmp_path / "metrics.jsonl").write_text("".join(json.dumps(r) + "\n" for r in records))
    assert script.progress(tmp_path) == (57, 45.0)


def test_a_device_this_machine_lacks_is_refused_before_any_run_starts(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    script = _script("run")
    monkeypatch.setattr(sys, "argv", ["run.py", "--out", str(tmp_path), "--device", "gpu"])
    with pytest.raises(SystemExit) as stopped:
        script.main()
    assert stopped.value.code == 2 and "--device: not a torch device" in capsys.readouterr().err
    assert not any(tmp_path.iterdir())


def test_a_snapshot_keeps_unfinished_runs_once_and_refuses_finished_ones(tmp_path: Path) -> None:
    script = _script("run")
    out, paused = tmp_path / "runs", tmp_path / "paused"
    done, running, waiting = script.look_ahead_queue()[:3]
    out.mkdir()
    _run(out / done.name, SCREENED)
    _run(out / running.name, SCREENED, finished=False)
    (out / running.name / "curves.png").write_text("picture")
    lines, copied = script.snapshot([done, running, waiting], out, paused)
    # The finished run is a diagnostic: its result waits (weights only) until it is scored.
    assert copied == 2 and "its result (no training state)" in lines[0]
    assert "not started" in lines[2]
    assert sorted(p.name for p in paused.iterdir()) == sorted([done.name, running.name])
    assert not (paused / done.name / "last.safetensors").exists()
    assert (paused / done.name / "best.safetensors").exists()
    # A finished run that is shipped, not a diagnostic, is refused.
    shipped_kind = dataclasses.replace(done, look_ahead=False)
    (out / shipped_kind.name).mkdir()
    (out / shipped_kind.name / "selection.json").write_text("{}")
    lines, copied = script.snapshot([shipped_kind], out, paused)
    assert copied == 0 and "refused, finished" in lines[0]
    kept = {p.name for p in (paused / running.name).iterdir()}
    assert "last.safetensors" in kept and "curves.png" not in kept
    # Another machine: no run folder yet, so the run starts from its paused state...
    elsewhere = tmp_path / "elsewhere"
    assert script.restore(running, elsewhere / running.name, paused)
    assert (elsewhere / running.name / "last.safetensors").read_bytes() == (
        out / running.name / "last.safetensors"
    ).read_bytes()
    assert script.command(running, elsewhere / running.name, "fp32")[-1] == "--resume"
    # ...but never over the state a machine has of its own.
    assert not script.restore(running, out / running.name, paused)


def test_the_look_ahead_runs_are_their_shipped_runs_plus_the_window(tmp_path: Path) -> None:
    script = _script("run")
    runs = script.look_ahead_queue()
    assert [(r.model, r.split, r.seed) for r in runs] == [
        *((model, "univ", seed) for seed in (0, 1, 2) for model in ("grouptron", "trajectron++")),
        ("grouptron", "eth", 0),
    ]
    run = runs[3]  # trajectron++, seed 1
    argv = script.command(run, tmp_path / run.name, "fp32")
    stored = json.loads((tmp_path / run.name / "campaign-config.json").read_text())
    # The shipped settings, under today's names (model.latent_modes is model.latent_values).
    shipped = renamed_settings(json.loads((run.shipped_run / "config.json").read_text()))
    assert argv[argv.index("--config") + 1] == str(tmp_path / run.name / "campaign-config.json")
    assert stored["data"]["neighbour_window_steps"] == [-2, 4]
    assert stored["train"]["seed"] == 1 and stored["data"]["derivatives"] == "central"
    assert stored["model_name"] == "trajectron++"
    for section in ("data", "model", "loss"):  # the shipped settings (newer keys at defaults)
        kept = {k: v for k, v in stored[section].items() if k in shipped[section]}
        assert kept == shipped[section]


def test_a_snapshot_refuses_a_run_being_trained(tmp_path: Path) -> None:
    """Its files could be of different epochs: stop its worker first."""
    script = _script("run")
    out, paused = tmp_path / "runs", tmp_path / "paused"
    out.mkdir()
    (running,) = script.look_ahead_queue()[:1]
    _run(out / running.name, SCREENED, finished=False)
    lock = script.claim(out / running.name)
    try:
        lines, copied = script.snapshot([running], out, paused)
    finally:
        os.close(lock)
    assert copied == 0 and "being trained" in lines[0] and not paused.exists()


def test_a_chosen_point_forecast_is_stored_with_the_weights_untouched(tmp_path: Path) -> None:
    """The candidate no worse than ml-top10 anywhere with the lowest pooled development FDE
    wins; writing it keeps the weights and replaces the card's section on a second choice."""
    from grouptron.evaluation.uncertainty import Interval
    from grouptron.model.predict import default_point_forecast
    from grouptron.point_forecast import PointForecast

    script = _script("point_forecast")

    def candidate(k: int, low: float, pooled: float) -> object:
        difference = {"univ val": Interval(0.0, low, low + 0.01), "dev": Interval(0.0, -0.01, 0.0)}
        return script.Comparison(k, {"univ val": 0.8, "dev": 1.0}, difference, pooled)

    worse_but_best, good, reference = (
        candidate(3, 0.001, 0.5),
        candidate(2, -0.002, 0.7),
        (candidate(10, 0.0, 0.9)),
    )
    assert not worse_but_best.qualifies and good.qualifies
    assert script.choose([worse_but_best, good, reference]) is good
    assert script.choose([worse_but_best, reference]) is reference
    folder = tmp_path / "run"
    state = _run(folder, ROBUST)
    for forecast in ("ml-top2", "ml-top3"):
        section = script.markdown([good, reference], good, "cmd")
        script.write_choice(folder, forecast, section)
    stored = load_checkpoint(folder / "best.safetensors")
    assert default_point_forecast(stored.config) == PointForecast.parse("ml-top3")
    assert all(torch.equal(state[k], stored.model_state[k]) for k in state)
    assert json.loads((folder / "config.json").read_text())["point_forecast"] == "ml-top3"
    card = (folder / "README.md").read_text()
    assert card.count("## Point forecast") == 1 and "| `ml-top2` |" in card


def test_shipping_names_a_dataset_description_portably_and_keeps_the_tensors(
    tmp_path: Path,
) -> None:
    script = _script("ship")
    repo, elsewhere = tmp_path / "repo", tmp_path / "elsewhere"
    inside, outside = repo / "campaign" / "c.toml", elsewhere / "c.toml"
    for path in (inside, outside):
        path.parent.mkdir(parents=True)
        path.write_text('name = "c"\n')
    digest = hashlib.sha256(outside.read_bytes()).hexdigest()
    for description, portable in (
        (inside, "campaign/c.toml"),
        (outside, f"c.toml#sha256={digest}"),
    ):
        folder = tmp_path / f"run-{description.parent.name}"
        _run(folder, dataclasses.replace(SCREENED, dataset=str(description)))
        (folder / "config.json").write_text(json.dumps({"dataset": str(description)}))
        (folder / "README.md").write_text(f"a dataset of your own, `{description}`\n")
        weights = folder / "best.safetensors"
        before = weights.read_bytes()
        script.make_portable(folder, repo)
        after = weights.read_bytes()
        tensors = [data[8 + int.from_bytes(data[:8], "little") :] for data in (before, after)]
        assert tensors[0] == tensors[1] and int.from_bytes(after[:8], "little") % 8 == 0
        stored = load_checkpoint(weights)
        assert stored.config == dataclasses.replace(SCREENED, dataset=portable)
        assert json.loads((folder / "config.json").read_text()) == {"dataset": portable}
        assert (folder / "README.md").read_text() == f"a dataset of your own, `{portable}`\n"
        script.make_portable(folder, repo)  # a portable name stays as it is
        assert weights.read_bytes() == after
