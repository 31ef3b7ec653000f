"""Data-parallel training: two processes on 127.0.0.1 equal one process on the same batches."""

from __future__ import annotations

import csv
import dataclasses
import socket
import subprocess
import sys
from pathlib import Path

import pytest
import torch
from safetensors.torch import load_file

from grouptron.config import ExperimentConfig, GroupEncoderConfig, TrainConfig, save_config
from grouptron.data.datasets.dataset import load_part
from grouptron.errors import GrouptronError
from grouptron.training.distributed import Cluster, global_mean
from grouptron.training.trainer import train
from tests.conftest import REPO
from tests.helpers.models import SMALL


def _config(batch_size: int) -> ExperimentConfig:
    return ExperimentConfig(
        model_name="grouptron",
        split="eth",
        model=SMALL,
        group_encoder=GroupEncoderConfig(group_dim=4),
        train=TrainConfig(epochs=1, batch_size=batch_size, threads=1),
    )


def _free_port() -> int:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return int(probe.getsockname()[1])


def test_global_mean_of_one_process_is_the_batch_mean() -> None:
    values = torch.randn(7, 3, requires_grad=True)
    torch.testing.assert_close(global_mean(values, Cluster(), 7), values.mean(0))
    assert Cluster(rank=1, world_size=3).shard(8).tolist() == [1, 4, 7]


def test_a_last_batch_smaller_than_the_process_count_is_refused(
    synthetic_data_dir: Path, tmp_path: Path
) -> None:
    config = dataclasses.replace(_config(batch_size=64), model_name="trajectron++")
    samples = load_part(synthetic_data_dir, "eth", "train", config.data).samples
    size = len(samples) - 1  # one sample left over for the last batch
    config = dataclasses.replace(config, train=dataclasses.replace(config.train, batch_size=size))
    with pytest.raises(GrouptronError, match="fewer than the 2 processes"):
        train(config, samples, samples, tmp_path / "run", cluster=Cluster(0, 2))


# `grouptron train` whose loss is NaN on its third step (the same step on every process).
POISONED_TRAIN = """
import sys
import dataclasses
import torch
from grouptron.cli import main
from grouptron.model import cvae

real, calls = cvae.elbo_loss, [0]

def poisoned(*args, **kwargs):
    terms = real(*args, **kwargs)
    calls[0] += 1
    return dataclasses.replace(terms, loss=terms.loss * torch.nan) if calls[0] == 3 else terms

cvae.elbo_loss = poisoned
sys.exit(main(sys.argv[1:]))
"""


@pytest.mark.slow
@pytest.mark.parametrize("poisoned", [False, True])
def test_two_processes_end_at_the_weights_of_one(
    synthetic_data_dir: Path, tmp_path: Path, poisoned: bool
) -> None:
    config_file = tmp_path / "config.json"
    save_config(_config(batch_size=64), config_file)  # 7 steps, the last one uneven (27 rows)
    common = ["train", "--config", str(config_file), "--split", "eth", "--model", "grouptron"]
    common += ["--data-dir", str(synthetic_data_dir), "--quiet", "--threads", "1"]
    launcher = [sys.executable, "-m", "torch.distributed.run", "--nnodes", "1"]
    launcher += ["--nproc-per-node", "2", "--master-addr", "127.0.0.1"]
    launcher += ["--master-port", str(_free_port())]
    if poisoned:  # a skipped step must be skipped by both processes, as by one
        script = tmp_path / "poisoned_train.py"
        script.write_text(POISONED_TRAIN)
        launcher, single = [*launcher, str(script)], [sys.executable, str(script)]
    else:
        launcher, single = [*launcher, "-m", "grouptron"], [sys.executable, "-m", "grouptron"]
    for command, out in ((launcher, "two"), (single, "one")):
        run = subprocess.run(
            [*command, *common, "--out", str(tmp_path / out)],
            capture_output=True,
            text=True,
            cwd=REPO,
            timeout=300,
        )
        assert run.returncode == 0, run.stderr[-3000:]
        steps = 6 if poisoned else 7
        assert run.stdout.count(f"done: 1 epochs, {steps} steps") == 1  # only the main reports
    both = [load_file(tmp_path / folder / "last.safetensors") for folder in ("two", "one")]
    weights = [name for name in both[1] if name.startswith("model.")]
    assert weights and sorted(both[0]) == sorted(both[1])
    for name in weights:
        torch.testing.assert_close(both[0][name], both[1][name], atol=1e-5, rtol=1e-4)
    with (tmp_path / "two" / "metrics.csv").open() as handle:
        assert next(csv.DictReader(handle))["processes"] == "2"
