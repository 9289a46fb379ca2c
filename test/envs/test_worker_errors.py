"""A ParallelEnv worker that fails shows its original exception in the parent (issue 13).

The failing pieces are defined at module level: spawned workers unpickle them by importing this
module (pytest puts its folder on ``sys.path``, which spawn hands to the workers).
"""

from __future__ import annotations

import multiprocessing
import time
from functools import partial

import pytest
import torch
import torchrl.envs
from torchrl.envs import TransformedEnv
from torchrl.envs.transforms import StepCounter

from vigen.envs import ParallelEnv, WorkerError, make_env
from vigen.envs.failure_report import record_failure
from vigen.envs.parallel import build_reporting_env
from vigen.rendering import RenderSettings
from vigen.transforms.scene import ScenePerturbation

pytestmark = pytest.mark.render

NAME = "dmc/cartpole-balance"
BOUND = 60.0
"""Seconds within which a worker's failure must reach the parent (TorchRL's own pipe timeout is 10000 s)."""


class FailingScene(ScenePerturbation):
    """Raises ``ValueError("boom: ...")`` at its ``at``-th reset, step or ``set_seed`` (``on``)."""

    def __init__(self, on: str = "reset", at: int = 2) -> None:
        super().__init__(seed=0)
        self.on, self.at, self.calls = on, at, 0

    def count(self, on: str) -> None:
        if on == self.on:
            self.calls += 1
            if self.calls == self.at:
                raise ValueError(f"boom: {on} {self.calls}")

    def read_defaults(self, scene):
        return {}

    def sample(self, rng, defaults):
        self.count("reset")
        return {}

    def identity_params(self, defaults):
        return {}

    def apply(self, scene, defaults, params):
        pass

    def advance(self, scene, defaults, params):
        self.count("step")

    def set_seed(self, seed):
        super().set_seed(seed)
        self.count("seed")


def build(fail_on: str | None = None, at: int = 2, **kwargs):
    """A tiny cartpole whose chain holds a fresh :class:`FailingScene` when ``fail_on`` is given."""
    generalization = [FailingScene(fail_on, at)] if fail_on else None
    return make_env(NAME, generalization=generalization, image_size=16, frame_stack=1,
                    render_settings=RenderSettings.fast(), **kwargs)


def build_only_in_parent():
    """Builds in the main process, raises in a worker (as a simulator missing from the workers' machine would)."""
    if multiprocessing.parent_process() is not None:
        raise OSError("boom: no simulator in this worker")
    return build()


def fails_in_worker_1(fail_on: str, at: int = 2) -> list:
    return [partial(build), partial(build, fail_on, at)]


def raised_by(call) -> tuple[BaseException, float]:
    start = time.monotonic()
    with pytest.raises(Exception) as caught:
        call()
    return caught.value, time.monotonic() - start


def assert_reports_boom(error: BaseException, worker: int, text: str, frame: str, elapsed: float) -> None:
    """``error`` names ``worker``, quotes its exception ``text`` and the traceback line of ``frame``, and chains TorchRL's error."""
    assert isinstance(error, WorkerError) and isinstance(error, RuntimeError)
    message = str(error)
    assert message.startswith(f"ParallelEnv worker {worker} failed: {text}\n"), message
    assert f"in {frame}\n" in message, "the tail of the worker's traceback is quoted"
    assert error.__cause__ is not None and "boom" not in str(error.__cause__), "chained from TorchRL's own error"
    assert error.worker == worker and list(error.reports) == [worker]
    assert elapsed < BOUND, f"the failure took {elapsed:.0f} s to reach the parent"


# -- in one process -------------------------------------------------------------------------------


def raise_and_record(report, error: Exception) -> None:
    try:
        raise error
    except Exception:
        record_failure(report)
        raise


def test_record_failure_writes_the_traceback_and_the_error_propagates_unchanged(tmp_path):
    report = tmp_path / "worker-3.txt"
    error = ValueError("boom: original")
    with pytest.raises(ValueError) as caught:
        raise_and_record(report, error)
    assert caught.value is error
    text = report.read_text()
    assert text.startswith("Traceback (most recent call last):")
    assert "in raise_and_record\n" in text
    assert text.rstrip().endswith("ValueError: boom: original")
    assert [p.name for p in tmp_path.iterdir()] == ["worker-3.txt"], "no temporary file left"


def test_record_failure_without_a_path_writes_nothing(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    with pytest.raises(ValueError):
        raise_and_record(None, ValueError("boom"))
    assert list(tmp_path.iterdir()) == []


def test_record_failure_gives_up_an_unwritable_report_and_keeps_the_original(tmp_path):
    with pytest.raises(ValueError, match="boom"):
        raise_and_record(tmp_path / "missing" / "r.txt", ValueError("boom"))


@pytest.mark.parametrize("fail_on", ["reset", "step", "seed"])
def test_pixel_env_records_reset_step_and_seed_failures_then_reraises(tmp_path, fail_on):
    env = build(fail_on, at=1)
    env.failure_report = str(tmp_path / "worker-0.txt")
    run = {"reset": env.reset, "step": lambda: env.rollout(2), "seed": lambda: env.set_seed(1)}[fail_on]
    with pytest.raises(ValueError, match=f"^boom: {fail_on} 1$"):
        run()
    assert (tmp_path / "worker-0.txt").read_text().rstrip().endswith(f"ValueError: boom: {fail_on} 1")


def test_pixel_env_without_a_report_path_writes_nothing(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    env = build("reset", at=1)
    assert env.failure_report is None
    with pytest.raises(ValueError, match="^boom: reset 1$"):
        env.reset()
    assert list(tmp_path.iterdir()) == []


def test_build_reporting_env_reaches_pixel_envs_below_other_transforms(tmp_path):
    report = str(tmp_path / "worker-1.txt")
    env = build_reporting_env(lambda: TransformedEnv(build("reset", at=1), StepCounter()), report)
    assert env.base_env.failure_report == report
    with pytest.raises(ValueError, match="boom"):
        env.reset()
    assert "boom: reset 1" in (tmp_path / "worker-1.txt").read_text()


def test_build_reporting_env_records_a_failed_construction(tmp_path):
    def broken():
        raise OSError("boom: no simulator")

    with pytest.raises(OSError, match="boom"):
        build_reporting_env(broken, str(tmp_path / "worker-0.txt"))
    assert (tmp_path / "worker-0.txt").read_text().rstrip().endswith("OSError: boom: no simulator")


# -- across processes -----------------------------------------------------------------------------


@pytest.mark.slow
@pytest.mark.timeout(300)
def test_reset_failure_in_a_worker_shows_its_exception_where_torchrl_shows_a_dead_worker():
    plain = torchrl.envs.ParallelEnv(2, fails_in_worker_1("reset"))
    try:
        plain.reset()
        error, _ = raised_by(plain.reset)
        assert "dead" in str(error) and "boom" not in str(error), "TorchRL alone loses the cause"
    finally:
        # TorchRL cannot close a ParallelEnv with a dead worker: a RuntimeError, or multiprocessing's ValueError
        # when the worker is still dying (seen on a loaded machine)
        with pytest.raises((RuntimeError, ValueError)):
            plain.close()

    env = ParallelEnv(2, fails_in_worker_1("reset"))
    try:
        env.reset()
        error, elapsed = raised_by(env.reset)
        assert_reports_boom(error, 1, "ValueError: boom: reset 2", "sample", elapsed)
        assert "dead" in str(error.__cause__)
        again, _ = raised_by(env.reset)
        assert isinstance(again, WorkerError) and "boom: reset 2" in str(again), "a failed env keeps saying why"
    finally:
        folder = env._report_folder
        env.close()
    assert env.is_closed and not folder.exists(), "close() works after a failure and removes the report folder"


@pytest.mark.slow
@pytest.mark.timeout(300)
def test_step_failure_in_a_rollout_and_a_failed_construction_reach_the_parent():
    env = ParallelEnv(2, fails_in_worker_1("step", at=2))
    try:
        error, elapsed = raised_by(lambda: env.rollout(4, break_when_any_done=False))
        assert_reports_boom(error, 1, "ValueError: boom: step 2", "advance", elapsed)
    finally:
        env.close()

    env = ParallelEnv(2, [partial(build), build_only_in_parent])
    try:
        error, elapsed = raised_by(env.reset)
        assert_reports_boom(error, 1, "OSError: boom: no simulator in this worker", "build_only_in_parent", elapsed)
    finally:
        env.close()


@pytest.mark.slow
@pytest.mark.timeout(300)
def test_set_seed_failure_in_a_worker_reaches_the_parent():
    env = ParallelEnv(2, fails_in_worker_1("seed", at=1))
    try:
        error, elapsed = raised_by(lambda: env.set_seed(0))
        assert_reports_boom(error, 1, "ValueError: boom: seed 1", "set_seed", elapsed)
    finally:
        env.close()


@pytest.mark.slow
@pytest.mark.timeout(300)
def test_a_normal_rollout_equals_torchrl_parallel_env():
    runs = []
    for cls in (torchrl.envs.ParallelEnv, ParallelEnv):
        env = cls(2, partial(build))
        try:
            env.set_seed(0)
            actions = iter(torch.linspace(-1, 1, 2 * 3).reshape(3, 2, 1))
            data = env.rollout(3, lambda td: td.set("action", next(actions)), break_when_any_done=False)
            runs.append((data["pixels"], data["next", "pixels"], data["next", "reward"]))
        finally:
            env.close()
    for plain, ours in zip(*runs):
        assert torch.equal(plain, ours)
