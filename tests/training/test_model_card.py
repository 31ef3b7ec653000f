"""Model cards say how a run differs from the reference recipe and how it was selected."""

from __future__ import annotations

import dataclasses

from grouptron.config import ExperimentConfig, TrainConfig
from grouptron.presets import experiment_preset
from grouptron.training.model_card import render_model_card


def test_the_card_lists_every_setting_other_than_the_defaults() -> None:
    config = experiment_preset("eth", "grouptron")
    config = dataclasses.replace(config, train=TrainConfig(seed=2, bf16=True))
    records = [{"epoch": 1, "iteration": 10, "val_ml_fde": 1.0, "val_ml_ade": 0.5,
                "val_cv_fde": 1.1, "val_cv_ade": 0.6, "precision": "bf16"}]  # fmt: skip
    card = render_model_card("run", config, records)
    assert "`train.seed = 2`" in card and "`group_encoder.group_dim = 8`" in card
    assert "bf16 (all epochs)" in card
    assert "| settings other than the defaults | none |" in render_model_card(
        "run", ExperimentConfig(), records
    )


def test_the_card_shows_the_final_selection_on_all_validation_samples() -> None:
    selection = {
        "selected_epoch": 7,
        "validation_samples": 4148,
        "full_val_ml_ade": 0.4,
        "full_val_ml_fde": 0.9,
        "full_val_cv_ade": 0.5,
        "full_val_cv_fde": 1.0,
        "candidates": [{"epoch": 7, "full_val_ml_fde": 0.9}, {"epoch": 9, "full_val_ml_fde": 0.95}],
    }
    card = render_model_card("run", ExperimentConfig(), [{"epoch": 9}], selection)
    assert "epoch 7: best ML FDE on all 4148 validation samples" in card
    assert "0.400 / 0.900 m" in card


def test_a_baselines_card_names_its_class_and_what_it_is() -> None:
    config = ExperimentConfig(model_name="social-stgcnn")
    card = render_model_card("run", config, [{"epoch": 1}])
    assert "`grouptron.baselines.social_stgcnn:SocialSTGCNN`: Social-STGCNN (Mohamed" in card
    assert "future encoder input" not in card  # a CVAE's input only
    assert "future encoder input" in render_model_card("run", ExperimentConfig(), [{"epoch": 1}])
