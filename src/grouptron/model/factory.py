"""Build a model from its config and load weights into it, with clear errors."""

from __future__ import annotations

import torch

from grouptron.config import ExperimentConfig
from grouptron.data.prepare.samples import SampleSet
from grouptron.errors import GrouptronError
from grouptron.groups.assign import SampleGroups, assign_groups
from grouptron.model.cvae import TrajectronCVAE
from grouptron.model.forecaster import Forecaster, outside_forecaster
from grouptron.model.grouptron import GrouptronCVAE
from grouptron.presets import MODEL_NAMES, MODELS

__all__ = ["MODEL_NAMES"]
PAPER_MODELS = tuple(name for name, spec in MODELS.items() if spec.paper)
"""The models of the paper's tables (the rest are this project's variants)."""
GROUP_MODELS = tuple(name for name, spec in MODELS.items() if spec.reads_groups)
"""The models with group- and scene-level encoders: one network (GrouptronCVAE), whose
named variants' settings come from their presets (presets.MODELS)."""
DISPLAY_NAMES = {name: spec.display for name, spec in MODELS.items()}


def uses_groups(config: ExperimentConfig) -> bool:
    """Whether the model's batches need the samples' groups."""
    spec = MODELS.get(config.model_name)
    if spec is None:
        return outside_forecaster(config.model_name).reads_groups
    return spec.reads_groups


def groups_for_model(samples: SampleSet, config: ExperimentConfig) -> SampleGroups | None:
    """The samples' groups when the model reads them (Grouptron), else None."""
    if not uses_groups(config):
        return None
    return assign_groups(samples, config.groups, config.data.position_scale_m)


def build_model(config: ExperimentConfig) -> Forecaster:
    """The model named by ``config.model_name``: a shipped one (Grouptron is Trajectron++ plus
    encoders) or any :class:`Forecaster` named by class or entry point, built from ``config``."""
    scale = config.data.velocity_scale_mps
    spec = MODELS.get(config.model_name)
    if spec is not None and not spec.reads_groups:
        return TrajectronCVAE(config.model, velocity_scale_mps=scale)
    if spec is not None:
        return GrouptronCVAE(config.model, config.group_encoder, scale)
    model_class = outside_forecaster(config.model_name)
    try:
        return model_class(config)
    except GrouptronError:
        raise
    except Exception as exc:
        raise GrouptronError(
            f"model {config.model_name!r} could not be built from its settings "
            f"({type(exc).__name__}: {exc})"
        ) from None


def cvae_only(model: Forecaster, what: str) -> TrajectronCVAE:
    """``model`` as the CVAE that ``what`` needs, or one line saying it needs one."""
    if not isinstance(model, TrajectronCVAE):
        raise GrouptronError(
            f"{what} works with the shipped CVAEs (Trajectron++, Grouptron) only, not "
            f"{type(model).__name__}"
        )
    return model


def load_weights(model: torch.nn.Module, state: dict[str, torch.Tensor], source: str) -> None:
    """Load ``state`` strictly; mismatched names or shapes are reported, not half-loaded."""
    expected = model.state_dict()
    missing = sorted(set(expected) - set(state))
    unexpected = sorted(set(state) - set(expected))
    wrong_shape = sorted(
        f"{k} {tuple(state[k].shape)} != {tuple(v.shape)}"
        for k, v in expected.items()
        if k in state and state[k].shape != v.shape
    )
    problems = []
    if missing:
        problems.append(f"missing tensors {', '.join(missing[:4])}")
    if unexpected:
        problems.append(f"unexpected tensors {', '.join(unexpected[:4])}")
    if wrong_shape:
        problems.append(f"tensor shapes do not match the config: {'; '.join(wrong_shape[:3])}")
    not_finite = sorted(
        k for k, v in state.items() if v.is_floating_point() and not torch.isfinite(v).all()
    )
    if not_finite:
        problems.append(f"tensors with values that are not finite: {', '.join(not_finite[:4])}")
    if problems:
        raise GrouptronError(f"{source}: weights do not fit the model ({'; '.join(problems)})")
    model.load_state_dict(state)
