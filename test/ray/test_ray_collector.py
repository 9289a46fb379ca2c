"""examples/train.py --ray (--collector ray): TorchRL's RayCollector on perturbed dm_control envs (vigen.run.make_collector),
its batches, weights and runs."""

from __future__ import annotations

import csv
import dataclasses
import json
import math
import subprocess
import sys
from functools import partial
from pathlib import Path

import pytest
import torch
from torchrl.data import LazyTensorStorage, TensorDictReplayBuffer
from torchrl.envs import RewardSum
from torchrl.envs.transforms import MultiStepTransform

from vigen.envs import make_env
from vigen.losses import LinearSchedule, make_loss
from vigen.ray_cluster import import_ray
from vigen.rendering import RenderSettings
from vigen.run import PRESETS, make_collector

ROOT = Path(__file__).resolve().parents[2]
import_ray().cloudpickle.register_pickle_by_value(sys.modules[__name__])  # Ray actors cannot import this test module by name

STEPS = 50  # agent steps per worker per batch


def perturbed_env(seed: int, worker: int | None = None):
    """dm_control's cartpole under DMC-GB's color_hard level, at 32 px: the perturbation runs inside the Ray actor (``worker``:
    its index, which make_collector passes to each worker's env)."""
    env = make_env("dmc/cartpole-balance", generalization="color_hard", seed=seed, image_size=32, episode_length=100,
                   render_settings=RenderSettings.fast())
    return env.append_transform(RewardSum())


def agent():
    torch.manual_seed(0)
    loss = make_loss("drqv2", (9, 32, 32), 1, feature_dim=8, hidden_dim=16, seed=0, std_schedule=LinearSchedule(1.0, 0.1, 1000))
    loss.make_value_estimator(gamma=0.99)
    return loss, loss.make_policy(perturbed_env(0).action_spec)


def collector(kind: str, workers: int, policy, batches: int = 1, env_seed: int = 3):
    config = dataclasses.replace(PRESETS["cpu"], workers=workers, collector=kind)
    return make_collector(perturbed_env, policy, config, env_seed=env_seed, steps_per_batch=STEPS, batches=batches,
                          random_steps=0)


@pytest.mark.render
@pytest.mark.timeout(300)
def test_ray_batches_match_the_single_process_collector_and_train_the_agent(ray_cluster):
    loss, policy = agent()
    local, _ = collector("local", 1, policy)
    reference = next(iter(local))
    local.shutdown()
    remote, _ = collector("ray", 2, policy, batches=3)  # 2 actors x 3 batches x 50 steps = 300 agent steps (600 frames)
    batches = [batch for batch in remote]  # not list(remote): RayCollector.__len__ fails in TorchRL 0.14.1
    remote.shutdown()

    assert [batch.batch_size for batch in batches] == [torch.Size([2, STEPS])] * 3
    assert set(batches[0].keys(True, True)) == set(reference.keys(True, True))
    for key in reference.keys(True, True):
        assert batches[0][key].dtype == reference[key].dtype, key
        assert batches[0][key].shape[1:] == reference[key].shape, key
    assert not torch.equal(batches[0]["pixels"][0], batches[0]["pixels"][1]), "each actor runs its own seeded env"

    n_step = MultiStepTransform(3, 0.99)
    buffer = TensorDictReplayBuffer(storage=LazyTensorStorage(1000), batch_size=16)
    for batch in batches:
        transitions = n_step.inv(batch)
        if transitions is not None:
            buffer.extend(transitions.reshape(-1))
    assert len(buffer) >= 2 * (3 * STEPS - 3)
    before = [parameter.detach().clone() for parameter in loss.parameters()]
    out = loss(buffer.sample())
    sum(value for key, value in out.items() if key.startswith("loss_")).backward()
    torch.optim.Adam(loss.parameters(), lr=1e-3).step()
    assert all(math.isfinite(value.item()) for key, value in out.items() if key.startswith("loss_"))
    assert any(not torch.equal(a, b) for a, b in zip(before, loss.parameters()))


@pytest.mark.render
@pytest.mark.timeout(300)
def test_the_actors_act_with_the_weights_sent_after_each_batch(ray_cluster):
    loss, policy = agent()
    remote, sync_weights = collector("ray", 2, policy, batches=2)
    batches = iter(remote)
    first = next(batches)
    assert first["action"].std() > 0.5, "σ = 1 at first: exploring"
    actor_head = policy[0].module.head.action_head[-1]  # the last linear layer: zero weights, a bias of atanh(0.3), σ = 0
    with torch.no_grad():
        actor_head.weight.zero_()
        actor_head.bias.fill_(math.atanh(0.3))
        policy[-1].sigma.zero_()
    sync_weights()
    second = next(batches)
    remote.shutdown()
    torch.testing.assert_close(second["action"], torch.full_like(second["action"], 0.3))


@pytest.mark.render
@pytest.mark.timeout(300)
def test_each_actor_explores_with_its_own_seeded_noise(ray_cluster):
    _, policy = agent()
    with torch.no_grad():  # a constant mean action of 0: what the actors act is their exploration noise (σ = 1)
        policy[0].module.head.action_head[-1].weight.zero_()
        policy[0].module.head.action_head[-1].bias.zero_()

    def noise(env_seed: int) -> torch.Tensor:
        remote, _ = collector("ray", 2, policy, env_seed=env_seed)
        batch = next(iter(remote))
        remote.shutdown()
        return batch["action"]

    first, again, other = noise(3), noise(3), noise(4)
    assert not torch.equal(first[0], first[1]), "two actors draw different noise"
    torch.testing.assert_close(first, again, rtol=0, atol=0, msg="a segment's seed fixes its actors' noise")
    assert not torch.equal(first, other), "the next segment's actors draw new noise"


def run(*args) -> subprocess.CompletedProcess:
    result = subprocess.run([sys.executable, str(ROOT / "examples" / "train.py"), *map(str, args)], capture_output=True,
                            text=True, cwd=ROOT, timeout=600)
    assert result.returncode == 0, result.stderr[-3000:]
    return result


@pytest.mark.slow
@pytest.mark.render
@pytest.mark.matrix  # the longest test (86 s idle, 561 s on a busy CI run, serial with the other Ray tests): -m matrix
@pytest.mark.timeout(900)
def test_train_and_evaluate_on_ray_write_the_run_folder_resume_and_report(tmp_path):
    run_dir = tmp_path / "ray-run"
    tiny = ["--env", "dmc/cartpole-balance", "--seed-frames", "200", "--eval-every", "400", "--eval-episodes", "1",
            "--batch-size", "8", "--hidden-dim", "32", "--buffer-size", "2000", "--episode-length", "100"]
    run("--frames", "400", "--out", run_dir, "--ray", "--workers", "2", "--eval-levels", "train", "color_hard", *tiny)
    config = json.loads((run_dir / "config.json").read_text())
    assert (config["collector"], config["workers"]) == ("ray", 2)
    run("--resume", run_dir, "--frames", "800")
    checkpoint = torch.load(run_dir / "checkpoints" / "frames_00000800.pt", weights_only=True)
    assert checkpoint["steps"] == 400 and checkpoint["updates"] == 150
    with (run_dir / "logs" / "scalars" / "eval" / "color_hard_return.csv").open() as file:
        assert [row[0] for row in csv.reader(file)] == ["400", "800"]
    report = tmp_path / "report"
    evaluated = subprocess.run([sys.executable, str(ROOT / "examples" / "evaluate.py"), str(run_dir), "--levels", "train",
                                "color_hard", "--seeds", "0", "1", "--episodes", "1", "--episode-length", "20", "--ray",
                                "--workers", "2", "--out", str(report)], capture_output=True, text=True, cwd=ROOT, timeout=600)
    assert evaluated.returncode == 0, evaluated.stderr[-3000:]
    with (report / "episodes.csv").open(newline="") as file:
        jobs = [(row["level"], row["seed"], row["length"]) for row in csv.DictReader(file)]
    assert jobs == [("train", "0", "10"), ("train", "1", "10"), ("color_hard", "0", "10"), ("color_hard", "1", "10")]
    assert "4/4" in evaluated.stderr, "the job progress bar reached the end"
    refused = subprocess.run([sys.executable, str(ROOT / "examples" / "train.py"), "--resume", str(run_dir), "--frames", "1200",
                              "--collector", "local"], capture_output=True, text=True, cwd=ROOT, timeout=300)
    assert refused.returncode != 0 and "--collector local (the run has ray)" in refused.stderr
