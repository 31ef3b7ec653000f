"""The out-of-domain section: causal checkpoints and constant velocity on datasets of one's own."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import numpy as np
import pytest

from grouptron.cli.app import main
from grouptron.constants import CONSTANT_VELOCITY
from grouptron.data.datasets.custom import read_dataset
from grouptron.data.formats.track_files import TrackSource
from grouptron.errors import GrouptronError
from grouptron.evaluation.evaluate import score_samples
from grouptron.evaluation.recordings import recording_samples
from grouptron.model.checkpoint import load_trained_model
from grouptron.model.factory import groups_for_model
from grouptron.reporting.out_of_domain import (
    causal_checkpoints,
    out_of_domain_markdown,
    prepare_out_of_domain,
    score_out_of_domain,
)
from tests.conftest import synthetic_recording

BACKWARD = "grouptron-eth-backward"


@pytest.fixture(scope="module")
def corridor(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A dataset description of two recordings in another layout (id first, centimetres,
    16 fps), like a corridor experiment from elsewhere."""
    root = tmp_path_factory.mktemp("elsewhere")
    for seed in (11, 12):
        plain = synthetic_recording(root / f"plain{seed}.txt", seed, pedestrians=10)
        rows = [line.split("\t") for line in plain.read_text().splitlines()]
        # frame (ETH/UCY: 10 per 0.4 s) -> 16 fps frames; metres -> centimetres; id first
        (root / f"run{seed}.txt").write_text(
            "".join(
                f"{i} {int(f) * 16 * 0.4 / 10:g} {float(x) * 100:g} {float(y) * 100:g} 170\n"
                for f, i, x, y in rows
            )
        )
    (root / "corridor.toml").write_text(
        'name = "corridor"\n[format]\ncolumns = "id,frame,x,y,z"\nfps = 16\nunits = "cm"\n'
        '[parts]\ntest = ["run11.txt", "run12.txt"]\n'
    )
    return root / "corridor.toml"


def _describe(folder: Path, name: str, files: list[str]) -> Path:
    path = folder / f"{name}.toml"
    path.write_text(
        f'name = "{name}"\n[format]\ncolumns = "id,frame,x,y,z"\nfps = 16\nunits = "cm"\n'
        f"[parts]\ntest = {json.dumps(files)}\n"
    )
    return path


def test_only_causal_checkpoints_are_scored(tiny_checkpoints: Path, tmp_path: Path) -> None:
    assert [p.parent.name for p in causal_checkpoints(tiny_checkpoints)] == [BACKWARD]
    with pytest.raises(GrouptronError, match="does not exist"):
        causal_checkpoints(tmp_path / "missing")


def test_bad_recordings_are_refused_before_any_model_runs(
    corridor: Path, tmp_path: Path, tiny_checkpoints: Path
) -> None:
    other = _describe(corridor.parent, "again", ["run11.txt"])  # a second run11.txt
    with pytest.raises(GrouptronError, match=r"distinct file names: \['run11.txt'\]"):
        prepare_out_of_domain([read_dataset(corridor), read_dataset(other)])
    train_only = tmp_path / "train.toml"
    train_only.write_text(
        read_dataset(corridor)
        .source.read_text()
        .replace("test =", "train =")
        .replace('["run11', f'["{corridor.parent}/run11')
        .replace(', "run12', f', "{corridor.parent}/run12')
    )
    with pytest.raises(GrouptronError, match="has no 'test' part"):
        prepare_out_of_domain([read_dataset(train_only)])
    prepared = prepare_out_of_domain([read_dataset(corridor)])
    (path,) = causal_checkpoints(tiny_checkpoints)
    with pytest.raises(GrouptronError, match="distinct folder names"):
        score_out_of_domain(prepared, [path, path])
    with pytest.raises(GrouptronError, match=r"need point forecasts .* not best-of-20"):
        score_out_of_domain(prepared, causal_checkpoints(tiny_checkpoints), ("best-of-20",))


def test_a_tiny_recording_and_an_absent_default_model_are_said_not_hidden(
    corridor: Path, tiny_checkpoints: Path
) -> None:
    # Two people walking 22 steps side by side: 6 samples, too few for any density bin, but
    # the pooled row stays.
    root = corridor.parent
    steps = [(k, i) for k in range(22) for i in (0, 1)]
    (root / "tiny.txt").write_text(
        "".join(f"{i} {k * 6.4:g} {40 * k + 3 * i} {150 * i} 170\n" for k, i in steps)
    )
    prepared = prepare_out_of_domain([read_dataset(_describe(root, "tiny", ["tiny.txt"]))])
    assert 0 < len(prepared.baseline) < 20
    checkpoints = causal_checkpoints(tiny_checkpoints)
    result = score_out_of_domain(prepared, checkpoints, default_model=BACKWARD)
    assert [p.bin for p in result.pooled if p.model == BACKWARD] == ["all"]
    text = "\n".join(out_of_domain_markdown(result))
    assert "FDE / CV not growing with density: not judged (fewer than 20 samples" in text
    assert f"- tiny: tiny.txt ({len(prepared.baseline)})" in text
    elsewhere = score_out_of_domain(prepared, checkpoints, default_model="no-such-model")
    text = "\n".join(out_of_domain_markdown(elsewhere))
    assert "The default model `no-such-model` was not among the checkpoints." in text
    assert f"| tiny.txt | {BACKWARD} (ml) |" in text  # every model's rows instead
    alone = "\n".join(out_of_domain_markdown(score_out_of_domain(prepared, [])))
    assert "No causal checkpoint was found: constant velocity only." in alone


def test_rows_are_paired_with_constant_velocity_per_recording_mode_and_density_bin(
    tiny_checkpoints: Path, corridor: Path
) -> None:
    dataset = read_dataset(corridor)
    (path,) = causal_checkpoints(tiny_checkpoints)
    result = score_out_of_domain(
        prepare_out_of_domain([dataset]), [path], ("ml", "mean"), default_model=BACKWARD
    )
    by = {(r.model, r.mode, r.recording): r for r in result.recordings}
    runs = [(CONSTANT_VELOCITY, None), (BACKWARD, "ml"), (BACKWARD, "mean")]
    assert set(by) == {(m, mode, f"run{s}.txt") for m, mode in runs for s in (11, 12)}
    for recording in ("run11.txt", "run12.txt"):
        cv = by[CONSTANT_VELOCITY, None, recording]
        assert cv.difference.mean == 0.0 and cv.ratio == 1.0
        for mode in ("ml", "mean"):
            ours = by[BACKWARD, mode, recording]
            assert cv.samples == ours.samples > 0
            assert ours.fde_constant_velocity == pytest.approx(cv.fde.mean)
            assert ours.difference.mean == pytest.approx(ours.fde.mean - cv.fde.mean)
            assert ours.difference.low <= ours.difference.mean <= ours.difference.high
        assert by[BACKWARD, "ml", recording].fde.mean != by[BACKWARD, "mean", recording].fde.mean
    # One row recomputed on its own recording: labels and recordings are not mixed up.
    model, config = load_trained_model(path)
    source = TrackSource.from_format(dataset.files("test")[1], dataset.recording)
    alone = recording_samples([source], config.data)
    groups = groups_for_model(alone, config)
    (mean,) = score_samples(model, config, alone, ("mean",), groups=groups)
    assert by[BACKWARD, "mean", "run12.txt"].fde.mean == pytest.approx(mean.fde.mean())
    pooled = {(p.model, p.mode, p.bin): p for p in result.pooled}
    total = sum(by[BACKWARD, "ml", f"run{s}.txt"].samples for s in (11, 12))
    whole = pooled[BACKWARD, "ml", "all"]
    assert whole.samples == total and np.isclose(
        whole.ratio, whole.fde / whole.fde_constant_velocity
    )
    bins = [p for p in result.pooled if p.model == BACKWARD and p.mode == "ml" and p.bin != "all"]
    assert bins and all(p.samples >= 20 for p in bins)  # smaller bins are left out

    text = "\n".join(out_of_domain_markdown(result))
    counts = [by[CONSTANT_VELOCITY, None, f"run{s}.txt"].samples for s in (11, 12)]
    assert "## Out of domain" in text
    assert f"- corridor: run11.txt ({counts[0]}), run12.txt ({counts[1]}); columns id,fr" in text
    assert f"| run12.txt | {BACKWARD} (mean) |" in text
    for mode in ("ml", "mean"):
        worst = max(by[BACKWARD, mode, f"run{s}.txt"].ratio for s in (11, 12))
        verdict = "met" if worst <= 1.0 else "NOT met"
        expected = f"({mode}) at or below constant velocity's FDE on every recording: {verdict}"
        assert f"{expected} (highest FDE / CV {worst:.3f}" in text
    json.dumps(result.to_dict())  # serialisable as the report's JSON carries it


def test_the_report_command_refuses_out_of_domain_with_a_dataset_and_bad_descriptions(
    tmp_path: Path, corridor: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert main(["report", "--dataset", str(corridor), "--out-of-domain", str(corridor)]) == 2
    assert (
        "--out-of-domain, --models, --seeds and --split go with the benchmark report"
        in capsys.readouterr().err
    )
    no_point = ["report", "--out-of-domain", str(corridor), "--mode", "best-of-20"]
    assert main(no_point) == 2
    assert "add one of ml, ml-argmax, mean, ml-top10 to --mode" in capsys.readouterr().err
    bad = tmp_path / "bad.toml"
    bad.write_text('name = "x"\n[parts]\ntest = ["missing.txt"]\n')
    assert main(["report", "--out-of-domain", str(bad)]) == 2
    err = capsys.readouterr().err
    assert "test files not found" in err and len(err.strip().splitlines()) == 1


@pytest.mark.realdata
def test_the_report_command_appends_the_section(
    tiny_checkpoints: Path,
    eth_ucy_dir: Path,
    corridor: Path,
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
) -> None:
    folder = tmp_path / "ckpt"
    shutil.copytree(tiny_checkpoints / BACKWARD, folder / BACKWARD)
    out = tmp_path / "RESULTS.md"
    argv = ["report", "--checkpoints", str(folder), "--data-dir", str(eth_ucy_dir)]
    argv += ["--derivatives", "backward", "--mode", "ml,mean", "--quiet", "--out", str(out)]
    assert main([*argv, "--out-of-domain", str(corridor)]) == 0
    text = out.read_text()
    assert f"--out-of-domain {corridor}" in text  # the command that regenerates it
    assert f"| run12.txt | {BACKWARD} (ml) |" in text and f"| {BACKWARD} (mean) |" in text
    assert "## Mean trajectory (every latent value's, weighted by p(z|x))" in text


def test_a_checkpoint_that_trained_on_a_recording_is_refused_before_any_scoring(
    corridor: Path, tiny_checkpoints: Path, tmp_path: Path
) -> None:
    import dataclasses

    from grouptron.model.checkpoint import load_checkpoint, save_checkpoint

    root = corridor.parent
    site = root / "site.toml"  # a dataset of one's own that trains on run11.txt
    site.write_text(
        'name = "site"\n[format]\ncolumns = "id,frame,x,y,z"\nfps = 16\nunits = "cm"\n'
        '[parts]\ntrain = ["run11.txt"]\nval = ["run11.txt"]\ntest = ["run12.txt"]\n'
    )
    stored = load_checkpoint(tiny_checkpoints / BACKWARD / "best.safetensors")
    config = dataclasses.replace(stored.config, split="site", dataset=str(site))
    save_checkpoint(
        tmp_path / "site-model" / "best.safetensors", dataclasses.replace(stored, config=config)
    )
    prepared = prepare_out_of_domain([read_dataset(corridor)])
    checkpoints = [
        *causal_checkpoints(tiny_checkpoints),
        tmp_path / "site-model" / "best.safetensors",
    ]
    with pytest.raises(GrouptronError, match=r"site-model trained or validated on run11\.txt"):
        score_out_of_domain(prepared, checkpoints)
