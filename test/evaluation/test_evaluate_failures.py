"""evaluate() keeps every finished episode when a level fails: in the error it raises and on disk as they finish."""

from __future__ import annotations

import csv
from pathlib import Path

import pytest
import torch
from torchrl.envs import Transform

import vigen.evaluation.rollout as rollout
from vigen.envs import make_env
from vigen.rendering import RenderSettings

TINY = {"image_size": 16, "frame_stack": 1, "render_settings": RenderSettings.fast()}


class FailOnReset(Transform):
    """Raises on its ``fail_at``-th reset (1-based), like a corrupt video found when an episode starts."""

    def __init__(self, fail_at: int, rows_path: Path | None = None) -> None:
        super().__init__()
        self.fail_at, self.rows_path, self.resets = fail_at, rows_path, 0
        self.rows_on_disk: list[int] = []
        self.error = OSError(f"corrupt video: reset {fail_at} could not decode its first frame")

    def _reset(self, tensordict, tensordict_reset):
        self.resets += 1
        if self.rows_path is not None:  # what a crash at this moment would leave behind
            self.rows_on_disk.append(len(_csv_rows(self.rows_path)) if self.rows_path.exists() else 0)
        if self.resets == self.fail_at:
            raise self.error
        return tensordict_reset


def _csv_rows(path: Path) -> list[dict[str, str]]:
    with path.open(newline="") as file:
        return list(csv.DictReader(file))


def _failing_level(monkeypatch, level: str, fail_at: int, rows_path: Path | None = None) -> FailOnReset:
    """Make ``evaluate(env_name, ...)`` build ``level`` with a transform that raises on its ``fail_at``-th reset."""
    failing = FailOnReset(fail_at, rows_path)

    def build(name, generalization=None, **kwargs):
        env = make_env(name, generalization=generalization, **kwargs)
        return env.append_transform(failing) if generalization == level else env

    monkeypatch.setattr(rollout, "make_env", build)
    return failing


def test_finished_episodes_come_back_with_the_error(monkeypatch):
    from vigen.evaluation import EvaluationError

    # episodes 0 and 1 of color_hard finish; the third reset (episode 2) fails
    failing = _failing_level(monkeypatch, "color_hard", fail_at=3)
    with pytest.raises(EvaluationError) as caught:
        rollout.evaluate(None, "dmc/cartpole-balance", ["train", "color_hard", "video_easy"], episodes=3, seeds=[0],
                         max_steps=2, env_options=TINY, tags={"method": "random"})
    error = caught.value
    expected = [("train", 0, e) for e in range(3)] + [("color_hard", 0, e) for e in range(2)]
    assert [(row["level"], row["seed"], row["episode"]) for row in error.rows] == expected
    assert all(row["length"] == 2 and row["method"] == "random" for row in error.rows)
    assert (error.level, error.seed, error.episode) == ("color_hard", 0, 2)
    assert error.__cause__ is failing.error, "the original exception is chained"
    assert "'color_hard'" in str(error) and "seed 0" in str(error) and "episode 2" in str(error)
    assert "5 finished" in str(error)


def test_rows_are_on_disk_as_each_episode_finishes(monkeypatch, tmp_path):
    from vigen.evaluation import EvaluationError

    path = tmp_path / "runs" / "rows.csv"  # its folder is created
    failing = _failing_level(monkeypatch, "color_hard", fail_at=3, rows_path=path)
    with pytest.raises(EvaluationError) as caught:
        rollout.evaluate(None, "dmc/cartpole-balance", ["train", "color_hard"], episodes=3, seeds=[0, 1],
                         max_steps=2, env_options=TINY, rows_path=path)
    # color_hard's resets come after 6 train episodes (2 seeds × 3), then after each of its own episodes
    assert failing.rows_on_disk == [6, 7, 8]
    written = _csv_rows(path)
    assert [(r["level"], r["seed"], r["episode"]) for r in written] == [
        (str(row["level"]), str(row["seed"]), str(row["episode"])) for row in caught.value.rows]
    assert [float(r["return"]) for r in written] == [row["return"] for row in caught.value.rows]
    assert str(path) in str(caught.value)


def test_rows_path_is_written_in_full_on_success(tmp_path):
    path = tmp_path / "rows.csv"
    rows = rollout.evaluate(None, "dmc/cartpole-balance", "train", episodes=2, seeds=[0], max_steps=2,
                            env_options=TINY, tags={"run": 3}, rows_path=path)
    written = _csv_rows(path)
    assert list(written[0]) == list(rows[0])
    assert [{key: str(value) for key, value in row.items()} for row in rows] == written


def test_an_existing_rows_path_is_refused_before_any_env_is_built(tmp_path):
    path = tmp_path / "rows.csv"
    path.write_text("precious\n")
    built = []

    def factory(level, seed):
        built.append(level)
        return make_env("dmc/cartpole-balance", seed=seed, **TINY)

    with pytest.raises(FileExistsError, match="rows.csv"):
        rollout.evaluate(None, factory, ["train"], episodes=1, max_steps=2, rows_path=path)
    assert built == [] and path.read_text() == "precious\n"


def test_a_failing_env_builder_and_a_failing_policy_keep_the_rows():
    from vigen.evaluation import EvaluationError

    def factory(level, seed):
        if level == "missing-videos":
            raise FileNotFoundError("no videos under /data/video_hard")
        return make_env("dmc/cartpole-balance", seed=seed, **TINY)

    with pytest.raises(EvaluationError) as caught:
        rollout.evaluate(None, factory, ["a", "b", "missing-videos", "c"], episodes=1, seeds=[4], max_steps=2)
    assert [row["level"] for row in caught.value.rows] == ["a", "b"]
    assert caught.value.episode is None and caught.value.level == "missing-videos" and caught.value.seed == 4
    assert isinstance(caught.value.__cause__, FileNotFoundError)
    assert str(caught.value).endswith("The error: FileNotFoundError: no videos under /data/video_hard"), "the cause's advice is kept"

    calls = []

    def policy(tensordict):
        calls.append(1)
        if len(calls) > 3:  # the policy breaks in the second episode (2 steps each)
            raise RuntimeError("NaN in the actor")
        return tensordict.set("action", tensordict["pixels"].new_zeros(1).float())

    with pytest.raises(EvaluationError) as caught:
        rollout.evaluate(policy, factory, ["a"], episodes=3, seeds=[0], max_steps=2)
    assert [row["episode"] for row in caught.value.rows] == [0]
    assert caught.value.episode == 1 and str(caught.value.__cause__) == "NaN in the actor"


def test_max_steps_below_one_is_refused_before_any_env_is_built():
    def factory(level, seed):
        raise AssertionError("no env may be built")

    with pytest.raises(ValueError, match="max_steps must be at least 1"):
        rollout.evaluate(None, factory, ["train"], episodes=1, max_steps=0)


def test_a_policy_with_the_wrong_action_shape_is_named_before_the_env_steps():
    from vigen.evaluation import EvaluationError

    def policy(tensordict):
        return tensordict.set("action", torch.zeros(3))  # cartpole takes one action

    with pytest.raises(EvaluationError, match=r"action has shape \(3,\), but the env's action spec has \(1,\)"):
        rollout.evaluate(policy, "dmc/cartpole-balance", ["train"], episodes=1, max_steps=2, env_options=TINY)
