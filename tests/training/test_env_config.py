"""The recipes' ``env`` / ``eval_env`` sections (training/conf/base.yaml) agree with EnvOptions."""
from __future__ import annotations

import dataclasses
from importlib.resources import files

import pytest
from hydra import compose, initialize_config_module
from hydra.errors import ConfigCompositionException
from omegaconf import OmegaConf

from dcs_torchrl.envs import SCENE_OPTIONS, EnvOptions
from dcs_torchrl.training.envs import config_settings, train_eval_settings


def _compose(*overrides: str):
    with initialize_config_module("dcs_torchrl.training.conf", version_base=None):
        return compose("sac", overrides=list(overrides))


def test_the_yaml_holds_each_scene_option_once_with_its_default():
    base = OmegaConf.load(files("dcs_torchrl.training.conf") / "base.yaml")
    defaults = {f.name: f.default for f in dataclasses.fields(EnvOptions) if f.name in SCENE_OPTIONS}
    assert list(base.env) == ["domain", "task", *SCENE_OPTIONS]
    assert OmegaConf.to_container(base.env) == {"domain": "cartpole", "task": "swingup", **defaults}
    assert list(base.eval_env) == list(SCENE_OPTIONS)
    assert OmegaConf.to_container(base.eval_env) == dict.fromkeys(SCENE_OPTIONS)  # null: as in env
    for recipe in ("sac", "qtopt", "evaluate"):  # every recipe config gets them from base.yaml
        with initialize_config_module("dcs_torchrl.training.conf", version_base=None):
            cfg = compose(recipe, overrides=["train_dir=x"] if recipe == "evaluate" else [])
        assert (cfg.env, cfg.eval_env) == (base.env, base.eval_env)


@pytest.mark.parametrize("override", ["env.cam_scale=0.3", "eval_env.cam_scale=0.3"])
def test_hydra_refuses_an_unknown_env_key(override):
    with pytest.raises(ConfigCompositionException, match=override.split("=")[0]):
        _compose(override)


def test_the_evaluation_env_is_the_training_env_with_the_non_null_overrides():
    train, evaluation = train_eval_settings(_compose("env.benchmark=medium", "eval_env.camera_scale=0.3",
                                                     "eval_env.dynamic=true"))
    assert (train.benchmark, train.dynamic) == ("medium", False)
    assert (evaluation.benchmark, evaluation.dynamic) == ("medium", True)
    assert (train.camera_scale, evaluation.camera_scale) == (0.2, 0.3)


@pytest.mark.parametrize("override,match", [
    ("env.dynamic=maybe", r"env setting dynamic='maybe' \(str\): give a value of type bool, or null"),
    ("env.num_videos=2.5", r"num_videos=2.5 \(float\): give a value of type int"),
    ("eval_env.camera_scale=true", r"camera_scale=True \(bool\): give a value of type float"),
])
def test_a_value_of_the_wrong_type_is_refused(override, match):
    with pytest.raises(ValueError, match=match):
        train_eval_settings(_compose(override))


def test_a_stored_config_of_older_options_still_resolves():
    """A trained run's stored env section (here without the newer reference_blend, texture_size)."""
    stored = {"domain": "cartpole", "task": "swingup", "benchmark": "easy", "dynamic": False, "camera_scale": None,
              "background_split": "train", "background_dir": None, "camera_id": None}
    settings = config_settings(OmegaConf.create(stored), {"camera_scale": 0.5})
    assert (settings.camera_scale, settings.color_scale, settings.texture_size) == (0.5, 0.1, 256)
