"""One registry of named models (presets.MODELS): every list derives from it, whether a model
reads groups comes from its code, and a run is named by the switches it has."""

from __future__ import annotations

import dataclasses
import json

import pytest

from grouptron.config import ExperimentConfig, experiment_from_stored
from grouptron.model.factory import DISPLAY_NAMES, GROUP_MODELS, PAPER_MODELS, build_model
from grouptron.model.forecaster import is_outside_name, outside_forecaster
from grouptron.model.grouptron import GrouptronCVAE
from grouptron.presets import CUSTOM, MODEL_NAMES, MODELS, experiment_preset, model_label
from grouptron.reporting.stats import PAIRS
from tests.conftest import REPO


def test_every_list_of_models_derives_from_the_registry() -> None:
    assert tuple(MODELS) == MODEL_NAMES
    assert set(DISPLAY_NAMES) == set(MODELS) and set(PAPER_MODELS) == {"trajectron++", "grouptron"}
    assert set(GROUP_MODELS) == {n for n, s in MODELS.items() if s.base == "grouptron"}
    assert {(n, b) for n, s in MODELS.items() for b in s.compared_with} == set(PAIRS)
    for name, spec in MODELS.items():  # reading groups is a property of the code it runs
        model = build_model(experiment_preset("univ", name))
        assert isinstance(model, GrouptronCVAE) == spec.reads_groups == (name in GROUP_MODELS)


@pytest.mark.parametrize("name", MODEL_NAMES)
def test_a_preset_run_is_named_by_its_model(name: str) -> None:
    assert model_label(experiment_preset("eth", name)) == name


def test_a_run_with_switches_is_named_by_the_model_they_make_or_custom() -> None:
    paper = experiment_preset("univ", "grouptron")
    residual = dataclasses.replace(
        paper, model=dataclasses.replace(paper.model, velocity_residual=True)
    )
    assert model_label(residual) == CUSTOM  # not grouptron-robust-residual: no robust switches
    robust = experiment_preset("univ", "grouptron-robust")
    assert model_label(dataclasses.replace(robust, model_name="grouptron")) == "grouptron-robust"
    plain = experiment_preset("univ", "trajectron++")
    # Trajectron++'s code never reads groups: their settings do not make another model of it.
    assert model_label(dataclasses.replace(plain, groups=robust.groups)) == "trajectron++"


def test_every_shipped_checkpoint_is_named_by_its_own_model() -> None:
    shipped = sorted((REPO / "checkpoints").glob("*/config.json"))
    assert len(shipped) > 20
    for path in shipped:
        config: ExperimentConfig = experiment_from_stored(json.loads(path.read_text()))
        if is_outside_name(config.model_name):  # a learned baseline: named by its class
            assert outside_forecaster(config.model_name).__module__.startswith("grouptron.")
            continue
        assert model_label(config) == config.model_name, path.parent.name
