"""What training prints per epoch: one readable line, each score labelled."""

from __future__ import annotations

from grouptron.training.trainer import epoch_line


def test_an_epoch_is_one_readable_line() -> None:
    record = {
        "epoch": 3,
        "train_loss": 12.8437,
        "val_ml_fde": 1.03149,
        "val_cv_fde": 1.02997,
        "val_samples": 1024,
        "epoch_seconds": 22.71,
        "nonfinite_steps": 0,
    }
    assert epoch_line(record, 100) == (
        "epoch 3/100: loss 12.84; validation ML FDE 1.031 m (constant velocity 1.030 m) on a "
        "1024-sample subset; 22.7 s"
    )
    bare = {"epoch": 1, "train_loss": 3.0, "train_seconds": 1.04, "nonfinite_steps": 2}
    assert epoch_line(bare, 5) == "epoch 1/5: loss 3; 2 non-finite steps skipped; 1.0 s"
