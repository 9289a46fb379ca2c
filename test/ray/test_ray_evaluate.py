"""evaluate(..., backend="ray") returns the serial rows, row for row, and names the job whose worker dies."""

from __future__ import annotations

import csv
import os
import signal
import sys
import threading
import time
from pathlib import Path

import pytest
import torch
from torchrl.data import Bounded

from vigen.envs import make_env
from vigen.evaluation import EvaluationError, evaluate
from vigen.losses import make_loss
from vigen.ray_cluster import import_ray
from vigen.rendering import RenderSettings

import_ray().cloudpickle.register_pickle_by_value(sys.modules[__name__])  # Ray workers cannot import this module by name

TINY = {"image_size": 16, "render_settings": RenderSettings.fast()}
ENV = "dmc/cartpole-balance"


def tiny_policy():
    """DrQ-v2's acting policy on fresh tiny networks: deterministic under evaluate's DETERMINISTIC exploration."""
    torch.manual_seed(0)
    loss = make_loss("drqv2", (9, 16, 16), 1, feature_dim=4, hidden_dim=8, seed=0)
    return loss.make_policy(Bounded(-1.0, 1.0, shape=(1,)))


@pytest.mark.timeout(180)
def test_ray_rows_equal_the_serial_rows(ray_cluster, tmp_path):
    policy = tiny_policy()
    options = dict(episodes=2, seeds=[0, 1], max_steps=25, env_options=TINY, tags={"method": "drqv2"})
    threads = torch.get_num_threads()
    torch.set_num_threads(1)  # as in a Ray task: another thread count sums the network's products in another order
    try:
        serial = evaluate(policy, ENV, ["train", "color_hard"], **options)
    finally:
        torch.set_num_threads(threads)
    finished = []
    rows = evaluate(policy, ENV, ["train", "color_hard"], backend="ray", workers=2, rows_path=tmp_path / "rows.csv",
                    progress=lambda done, total: finished.append((done, total)), **options)
    assert len(serial) == 8 and rows == serial
    assert len({row["return"] for row in rows}) > 2, "levels and seeds give different episodes"
    assert finished == [(1, 4), (2, 4), (3, 4), (4, 4)]
    with (tmp_path / "rows.csv").open(newline="") as file:
        on_disk = sorted((row["level"], row["seed"], row["episode"]) for row in csv.DictReader(file))
    assert on_disk == sorted((row["level"], str(row["seed"]), str(row["episode"])) for row in serial)


@pytest.mark.timeout(120)
def test_a_job_that_raises_is_named_and_the_other_rows_kept(ray_cluster):
    def factory(level, seed):
        if level == "broken":
            raise OSError("corrupt video")
        return make_env(ENV, seed=seed, frame_stack=1, **TINY)

    with pytest.raises(EvaluationError, match="level 'broken', seed 0") as caught:
        evaluate(None, factory, ["train", "broken"], episodes=1, max_steps=3, backend="ray", workers=1)
    assert [row["level"] for row in caught.value.rows] == ["train"]
    assert isinstance(caught.value.__cause__, OSError) and "corrupt video" in str(caught.value.__cause__)


@pytest.mark.timeout(120)
def test_a_failing_rows_path_write_is_an_evaluation_error_with_the_finished_rows(ray_cluster, tmp_path, monkeypatch):
    from vigen.evaluation import rollout

    written = []

    def append(log, row):  # the file system fills up after the first job's row
        if written:
            raise OSError(28, "No space left on device")
        written.append(row)

    monkeypatch.setattr(rollout._RowLog, "append", append)
    path = tmp_path / "rows.csv"
    with pytest.raises(EvaluationError, match=rf"level 'color_hard', seed 0 \(writing its rows to {path} failed") as caught:
        evaluate(None, ENV, ["train", "color_hard"], episodes=1, max_steps=3, env_options=TINY, backend="ray", workers=1,
                 rows_path=path)
    assert [row["level"] for row in caught.value.rows] == ["train", "color_hard"]
    assert caught.value.rows_path is None, "the file does not hold the rows"
    assert isinstance(caught.value.__cause__, OSError)


class SlowPolicy:
    """Zero actions, slowly; writes its worker's pid on its first call so the test can kill that worker."""

    def __init__(self, pid_file: Path) -> None:
        self.pid_file = pid_file

    def __call__(self, tensordict):
        if not self.pid_file.exists():
            self.pid_file.write_text(str(os.getpid()))
        time.sleep(0.02)
        return tensordict.set("action", torch.zeros(*tensordict["pixels"].shape[:-3], 1))


@pytest.mark.timeout(180)
def test_killing_a_worker_mid_evaluation_names_the_job_within_a_bounded_time(ray_cluster, tmp_path):
    pid_file = tmp_path / "pid"

    def kill_the_worker():
        deadline = time.monotonic() + 120
        while not pid_file.exists() and time.monotonic() < deadline:
            time.sleep(0.1)
        os.kill(int(pid_file.read_text()), signal.SIGKILL)

    killer = threading.Thread(target=kill_the_worker, daemon=True)
    killer.start()
    started = time.monotonic()
    with pytest.raises(EvaluationError, match=r"level 'train', seed 7 \(its Ray worker died") as caught:
        evaluate(SlowPolicy(pid_file), ENV, ["train"], episodes=3, seeds=[7], max_steps=1000, env_options=TINY,
                 backend="ray", workers=1)
    assert time.monotonic() - started < 90, "the death is reported, not waited out"
    assert caught.value.rows == [] and caught.value.episode is None
    killer.join(timeout=5)


@pytest.mark.parametrize("options, message", [
    (dict(backend="dask"), "backend 'dask' is unknown"),
    (dict(workers=2), "needs backend='ray'"),
    (dict(backend="ray", workers=0), r"workers=0"),
    (dict(backend="ray", device="cuda"), "reserve one CPU and no accelerator"),
])
def test_bad_backend_options_are_refused_before_any_work(options, message):
    with pytest.raises(ValueError, match=message):
        evaluate(None, ENV, "train", **options)
