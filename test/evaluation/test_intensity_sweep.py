"""Intensity sweeps: sweep() levels, evaluate() rows of generalization dicts, summaries and robustness curves."""

from __future__ import annotations

import csv
import math
import pickle

import pytest
import torch
from tensordict.nn import TensorDictModule
from torch import nn

import vigen.evaluation.rollout as rollout
from vigen.envs import make_env
from vigen.evaluation import DCS_INTENSITIES, evaluate, plot_intensity, summarize, sweep, write_csv
from vigen.evaluation.sweep import SweepPoint, level_columns
from vigen.rendering import RenderSettings

TASK = "dmc/cartpole-balance"
TINY = {"image_size": 16, "frame_stack": 1, "render_settings": RenderSettings.fast()}


class _Brightness(nn.Module):
    """An action read from the pixels, so a different scene gives a different return."""

    def forward(self, pixels: torch.Tensor) -> torch.Tensor:
        return torch.tanh(pixels.float().mean(dim=(-3, -2, -1)).unsqueeze(-1) / 64.0 - 1.5)


def _policy() -> TensorDictModule:
    return TensorDictModule(_Brightness(), in_keys=["pixels"], out_keys=["action"])


# -- sweep() ------------------------------------------------------------------------------------

def test_sweep_gives_one_dict_per_intensity_with_the_fixed_factors():
    levels = sweep("camera_rotation", [0, 0.1, 0.3], fixed={"object_color": 0.5})
    assert levels == [{"camera_rotation": 0.0, "object_color": 0.5}, {"camera_rotation": 0.1, "object_color": 0.5},
                      {"camera_rotation": 0.3, "object_color": 0.5}]
    assert all(isinstance(level, dict) and level.factor == "camera_rotation" for level in levels)
    assert [level.intensity for level in levels] == [0.0, 0.1, 0.3]
    assert levels[0]["camera_rotation"] == 0.0, "intensity 0 is kept as the factor switched off"
    assert pickle.loads(pickle.dumps(levels[1])).factor == "camera_rotation"


def test_dcs_intensities_are_the_published_scale():
    # Distracting Control Suite (Stone et al. 2021), ANCHORS.md §3: 0.025, 0.05, 0.1, 0.15, 0.2, 0.3, 0.4, 0.5
    assert DCS_INTENSITIES == (0.025, 0.05, 0.1, 0.15, 0.2, 0.3, 0.4, 0.5)
    assert len(sweep("camera_rotation", DCS_INTENSITIES)) == 8


@pytest.mark.parametrize("intensities, error, message", [
    ([0.1, 1.5], ValueError, r"intensities: .*'camera_rotation'.* \[0, 1\].*got 1.5"),
    ([-0.1], ValueError, r"intensities: .*got -0.1"),
    ([math.nan], ValueError, r"intensities: .*got nan"),
    ([True], TypeError, r"intensities: .*number"),
    (["0.3"], TypeError, r"intensities: .*number"),
    ([], ValueError, r"intensities is empty"),
    (0.3, TypeError, r"intensities must be a list"),
    ([0.1, 0.3, 0.1], ValueError, r"intensities repeat \[0.1\]"),
])
def test_sweep_rejects_bad_intensities(intensities, error, message):
    with pytest.raises(error, match=message):
        sweep("camera_rotation", intensities)


def test_sweep_rejects_bad_factors_and_fixed():
    with pytest.raises(TypeError, match="factor must be a factor name"):
        sweep("", [0.1])
    with pytest.raises(ValueError, match="level label, not a factor name"):
        sweep("camera_rotation=0.3", [0.1])
    with pytest.raises(ValueError, match="fixed holds 'camera_rotation'"):
        sweep("camera_rotation", [0.1], fixed={"camera_rotation": 0.2})
    with pytest.raises(ValueError, match=r"fixed: the intensity of 'object_color'.*got 2"):
        sweep("camera_rotation", [0.1], fixed={"object_color": 2})
    with pytest.raises(TypeError, match="fixed must be a dict"):
        sweep("camera_rotation", [0.1], fixed=[("object_color", 0.5)])


def test_level_columns():
    assert level_columns("color_hard") == {}
    assert level_columns({"camera_rotation": 0.3}) == {"factor": "camera_rotation", "intensity": 0.3}
    assert level_columns({"object_color": 0.5, "camera_rotation": 0.3}) == {"factor": "camera_rotation+object_color",
                                                                         "intensity": ""}
    point = SweepPoint("object_color", {"camera_rotation": 0.3, "object_color": 0.5})
    assert level_columns(point) == {"factor": "object_color", "intensity": 0.5, "fixed": "camera_rotation=0.3"}


# -- evaluate() with generalization dicts ------------------------------------------------------------

def test_dict_levels_reach_a_factory_and_label_the_rows():
    built = []

    def factory(level, seed):
        built.append((level, seed))
        return make_env(TASK, seed=seed, **TINY)

    levels = ["train", *sweep("camera_rotation", [0.1, 0.3]), {"object_color": 0.5, "camera_rotation": 0.3}]
    rows = evaluate(None, factory, levels, episodes=1, seeds=[5], max_steps=2)
    assert built == [(level, 5) for level in levels]
    labels = ["train", "camera_rotation=0.1", "camera_rotation=0.3", "camera_rotation=0.3+object_color=0.5"]
    assert [row["level"] for row in rows] == labels
    assert "factor" not in rows[0] and "intensity" not in rows[0], "named levels keep today's columns"
    assert [(row["factor"], row["intensity"]) for row in rows[1:]] == [
        ("camera_rotation", 0.1), ("camera_rotation", 0.3), ("camera_rotation+object_color", "")]
    assert list(rows[1])[:8] == ["env", "level", "factor", "intensity", "data", "stand_in", "level_options", "seed"]
    assert (rows[1]["data"], rows[1]["stand_in"], rows[1]["level_options"]) == ("", False, ""), "a factory env: no level to ask"


def test_repeated_levels_run_once():
    calls = []
    rows = evaluate(None, lambda level, seed: calls.append(level) or make_env(TASK, seed=seed, **TINY),
                    [{"camera_rotation": 0.3}, *sweep("camera_rotation", [0.3])], episodes=1, max_steps=2)
    assert len(rows) == len(calls) == 1


def test_bad_dict_levels_raise_before_any_env_is_built(monkeypatch):
    def no_env(*args, **kwargs):
        raise AssertionError("an env was built before the levels were checked")

    monkeypatch.setattr(rollout, "make_env", no_env)
    with pytest.raises(ValueError, match=r"levels: unknown factors \['camera_rotaton'\] for dmc/cartpole-balance; "
                                         r"its factors are .*camera_rotation"):
        rollout.evaluate(None, TASK, ["train", {"camera_rotaton": 0.3}])
    with pytest.raises(ValueError, match=r"levels: the intensity of 'camera_rotation' must be in \[0, 1\]"):
        rollout.evaluate(None, TASK, ["train", {"camera_rotation": 1.3}])
    with pytest.raises(ValueError, match="empty generalization dict"):
        rollout.evaluate(None, TASK, [{}])
    with pytest.raises(TypeError, match="each level must be a name or a dict"):
        rollout.evaluate(None, TASK, ["train", 0.3])


@pytest.mark.render
@pytest.mark.slow
def test_dict_levels_give_the_rows_of_hand_built_envs():
    """Same seeds, same factors: evaluate() plays the episodes make_env(generalization=dict) plays by hand."""
    levels = sweep("camera_rotation", [0.0, 0.5], fixed={"object_color": 0.5})
    rows = evaluate(_policy(), TASK, levels, episodes=2, seeds=[3, 4], max_steps=15, env_options=TINY)
    expected = []
    for level in levels:
        for seed in (3, 4):
            env = make_env(TASK, generalization=dict(level), seed=seed, **TINY)
            for _ in range(2):
                trajectory = env.rollout(15, _policy(), break_when_any_done=True)
                expected.append((seed, float(trajectory["next", "reward"].sum()), trajectory.numel()))
            env.close()
    assert [(row["seed"], row["return"], row["length"]) for row in rows] == expected
    assert {row["level"] for row in rows} == {"camera_rotation=0+object_color=0.5", "camera_rotation=0.5+object_color=0.5"}
    assert all(row["fixed"] == "object_color=0.5" for row in rows)


@pytest.mark.render
def test_rows_path_widens_for_sweep_columns(tmp_path):
    path = tmp_path / "rows.csv"
    rows = evaluate(None, TASK, ["train", *sweep("camera_rotation", [0.2])], episodes=1, max_steps=2,
                    env_options=TINY, rows_path=path)
    with path.open(newline="") as file:
        on_disk = list(csv.DictReader(file))
    assert list(on_disk[0]) == ["env", "level", "data", "stand_in", "level_options", "seed", "episode", "return", "length", "factor",
                                "intensity"]
    assert [(row["level"], row["factor"], row["intensity"]) for row in on_disk] == [
        ("train", "", ""), ("camera_rotation=0.2", "camera_rotation", "0.2")]
    assert len(rows) == 2


@pytest.mark.render
@pytest.mark.slow
def test_random_baseline_is_seeded_and_blind():
    """policy=None: actions from a generator seeded by the seed, so the same at every visual level and every call."""
    levels = ["train", *sweep("camera_rotation", [0.5])]
    rows = evaluate(None, TASK, levels, episodes=2, seeds=[0, 1], max_steps=10, env_options=TINY)
    again = evaluate(None, TASK, levels, episodes=2, seeds=[0, 1], max_steps=10, env_options=TINY)
    returns = {(row["level"], row["seed"], row["episode"]): row["return"] for row in rows}
    assert returns == {(row["level"], row["seed"], row["episode"]): row["return"] for row in again}
    for seed in (0, 1):
        for episode in (0, 1):
            assert returns["train", seed, episode] == returns["camera_rotation=0.5", seed, episode]
    assert len({returns["train", seed, episode] for seed in (0, 1) for episode in (0, 1)}) == 4


# -- summaries and curves -------------------------------------------------------------------------

def _sweep_rows() -> list[dict]:
    rows = []
    for method, slope in (("drqv2", 1500.0), ("svea", 600.0)):
        for run in range(3):
            rows.append({"method": method, "run": run, "env": TASK, "level": "train", "seed": 0, "return": 900.0 + run})
            for x in (0.0, 0.1, 0.3):
                rows.append({"method": method, "run": run, "env": TASK, "level": f"camera_rotation={x:g}",
                             "factor": "camera_rotation", "intensity": x, "seed": 0,
                             "return": 900.0 - slope * x + 10.0 * run})
    return rows


def test_summarize_carries_factor_and_intensity():
    lines = summarize(_sweep_rows(), reps=50)
    by_level = {(line["method"], line["level"]): line for line in lines}
    assert "factor" not in by_level["drqv2", "train"]
    line = by_level["svea", "camera_rotation=0.3"]
    assert (line["factor"], line["intensity"]) == ("camera_rotation", 0.3)
    assert line["mean"] == pytest.approx(900.0 - 600.0 * 0.3 + 10.0)  # runs 0, 1, 2 add 0, 10, 20


@pytest.mark.slow
def test_plot_intensity_from_lines_rows_and_csv(tmp_path):
    rows = _sweep_rows()
    lines = summarize(rows, reps=50)
    first = plot_intensity(lines, tmp_path / "curve.png", factor="camera_rotation")
    assert first.stat().st_size > 1000 and first.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    with pytest.raises(FileExistsError):
        plot_intensity(lines, first, factor="camera_rotation")
    one_method = [row for row in rows if row["method"] == "svea" and "factor" in row]  # summarized with 2000 draws
    assert plot_intensity(one_method, tmp_path / "from_rows.png", factor="camera_rotation", statistic="mean").exists()
    with (write_csv(lines, tmp_path / "summary.csv")).open(newline="") as file:
        from_csv = list(csv.DictReader(file))  # every value a string, blanks for train
    assert plot_intensity(from_csv, tmp_path / "from_csv.png", factor="camera_rotation",
                          statistic="rlvigen_mean").exists()


def test_plot_intensity_errors(tmp_path):
    lines = summarize(_sweep_rows(), reps=50)
    with pytest.raises(ValueError, match=r"no line sweeps factor 'object_color'; the swept factors are \['camera_rotation'\]"):
        plot_intensity(lines, tmp_path / "a.png", factor="object_color")
    with pytest.raises(ValueError, match="statistic must be"):
        plot_intensity(lines, tmp_path / "b.png", factor="camera_rotation", statistic="median")
    with pytest.raises(ValueError, match="lines is empty"):
        plot_intensity([], tmp_path / "c.png", factor="camera_rotation")
    assert not any(tmp_path.iterdir()), "nothing is written when the arguments are wrong"
