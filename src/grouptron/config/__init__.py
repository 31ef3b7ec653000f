"""Typed, frozen configuration dataclasses (``settings``); their round trip to JSON with
errors on unknown keys (``dicts``); stored configs of older runs read back (``stored``)."""

from grouptron.config.dicts import (
    config_from_dict,
    config_to_dict,
    load_config,
    merge_settings,
    non_default_settings,
    save_config,
)
from grouptron.config.settings import (
    DataConfig,
    ExperimentConfig,
    GroupConfig,
    GroupEncoderConfig,
    LossConfig,
    ModelConfig,
    TrainConfig,
)
from grouptron.config.stored import (
    STORED_DEFAULTS,
    STORED_RENAMES,
    experiment_from_stored,
    renamed_settings,
)

__all__ = [
    "STORED_DEFAULTS",
    "STORED_RENAMES",
    "DataConfig",
    "ExperimentConfig",
    "GroupConfig",
    "GroupEncoderConfig",
    "LossConfig",
    "ModelConfig",
    "TrainConfig",
    "config_from_dict",
    "config_to_dict",
    "experiment_from_stored",
    "load_config",
    "merge_settings",
    "non_default_settings",
    "renamed_settings",
    "save_config",
]
