"""Losses, policies and evaluation take a device and keep everything on it: checked on every device this machine has."""

from __future__ import annotations

import pytest
import torch
from tensordict import TensorDict
from torchrl.data import Bounded

from vigen.devices import accelerator_paths, host_reads_are_free
from vigen.evaluation import evaluate
from vigen.losses import make_loss
from vigen.rendering import RenderSettings


def machine_devices() -> list[str]:
    devices = ["cpu"]
    if torch.cuda.is_available():
        devices.append("cuda")
    if getattr(torch.backends, "mps", None) is not None and torch.backends.mps.is_available():
        devices.append("mps")
    return devices


def batch(device: torch.device, size: int = 4) -> TensorDict:
    pixels = torch.randint(0, 256, (size, 9, 64, 64), dtype=torch.uint8, device=device)
    flags = torch.zeros(size, 1, dtype=torch.bool, device=device)
    return TensorDict({"pixels": pixels, "action": torch.rand(size, 2, device=device) * 2 - 1,
                       "next": {"pixels": pixels, "reward": torch.ones(size, 1, device=device), "done": flags,
                                "terminated": flags.clone()}}, [size], device=device)


@pytest.mark.parametrize("device", machine_devices())
@pytest.mark.parametrize("algo", ["drqv2", "drq", "svea", "curl"])  # DDPG and SAC heads, overlay and contrastive losses
def test_a_loss_made_on_a_device_computes_and_acts_there(algo, device):
    device = torch.device(device)
    loss = make_loss(algo, (9, 64, 64), 2, feature_dim=8, hidden_dim=16, seed=0, device=device)
    loss.make_value_estimator(gamma=0.99)
    assert loss.device.type == device.type
    assert {tensor.device.type for tensor in [*loss.parameters(), *loss.buffers()]} == {device.type}
    out = loss(batch(device))
    assert {value.device.type for value in out.values()} == {device.type}, "no output was moved off the device"
    sum(value for key, value in out.items() if key.startswith("loss_")).backward()
    assert {p.grad.device.type for p in loss.parameters() if p.grad is not None} == {device.type}
    policy = loss.make_policy(Bounded(-1.0, 1.0, shape=(2,)))
    action = policy(TensorDict({"pixels": batch(device, 1)["pixels"][0]}, [], device=device))["action"]
    assert action.device.type == device.type and action.shape == (2,)


@pytest.mark.render
@pytest.mark.parametrize("device", machine_devices())
def test_evaluation_builds_its_envs_on_the_device(device):
    loss = make_loss("drqv2", (9, 16, 16), 1, feature_dim=4, hidden_dim=8, seed=0, device=device)
    policy = loss.make_policy(Bounded(-1.0, 1.0, shape=(1,)))
    seen = []
    policy.register_forward_hook(lambda module, args, output: seen.append(output["action"].device.type))
    rows = evaluate(policy, "dmc/cartpole-balance", "train", episodes=1, max_steps=5, device=device,
                    env_options={"image_size": 16, "render_settings": RenderSettings.fast()})
    assert [row["length"] for row in rows] == [5]
    assert seen and set(seen) == {torch.device(device).type}
    random = evaluate(None, "dmc/cartpole-balance", "train", episodes=1, max_steps=5, device=device,
                      env_options={"image_size": 16, "render_settings": RenderSettings.fast()})
    assert [row["length"] for row in random] == [5], "the random baseline's draws go to the env's device"


def test_host_reads_are_free_on_cpu_tensors_only_and_not_on_the_accelerator_paths():
    assert host_reads_are_free(torch.zeros(2)) and host_reads_are_free(torch.device("cpu"))
    assert not host_reads_are_free(torch.device("cuda")) and not host_reads_are_free(torch.device("meta"))
    with accelerator_paths():
        assert not host_reads_are_free(torch.zeros(2))
    assert host_reads_are_free(torch.zeros(2)), "the paths end with the block"


def test_the_host_sync_detector_catches_what_a_gpu_would_wait_for_and_nothing_else(no_host_sync):
    """The CPU stand-in for CUDA's sync debug mode (test/conftest.py) that the update's no-sync tests rely on."""
    x = torch.rand(8)
    synchronizing = {
        "bool of a tensor": lambda: bool(x.sum() > 0), "a Python if": lambda: 1 if x.max() > 2 else 0,
        ".item()": lambda: x.sum().item(), "int()": lambda: int(x.argmax()), ".tolist()": lambda: x.tolist(),
        "a mask index": lambda: x[x > 0.5], "a mask assignment": lambda: x.clone().__setitem__(x > 0.5, 0.0),
        "nonzero": lambda: torch.nonzero(x), "one-argument where": lambda: torch.where(x > 0.5),
        "the loss's old finite check": lambda: torch.isfinite(torch.cat([x, x])).all() and None,
        ".cpu()": lambda: x.cpu(), "tensor repeats": lambda: x.repeat_interleave(torch.ones(8, dtype=torch.long)),
    }
    for what, call in synchronizing.items():
        with no_host_sync(), pytest.raises(AssertionError, match="host synchronization"):
            call()
    with no_host_sync():
        torch.where(x > 0.5, x, torch.zeros_like(x))  # selection by tensor ops
        x[torch.arange(4)]  # an integer index: its size is known
        x.repeat_interleave(3)
        rank = torch.tensor(0.93) * 7  # made on the host (no device=): a host tensor on a GPU machine too
        assert int(rank) == 6 and float(rank - int(rank)) > 0
