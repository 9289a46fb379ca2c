"""Add vigen to a TorchRL training script you already have: a vigen loss, then a zero-shot test.

    python examples/compose_torchrl.py --frames 2000
    python examples/compose_torchrl.py --frames 2000 --device cuda   # networks, replay storage and updates on the GPU

Everything here is plain TorchRL (its ``DMControlWrapper``, collector, replay buffer and
``SoftUpdate``) except the lines marked ``# vigen``: the SVEA loss and its acting policy replace a
DDPG/TD3 loss, and a pixel corruption appended to a copy of the env tests the agent on images it
never saw. Scene-level perturbations (colours, videos, lights, camera) need vigen's own dm_control
env (``vigen.envs.make_env``), which exposes the scene to them.
"""

from __future__ import annotations

import argparse

import torch
from dm_control import suite
from torchrl.collectors import Collector
from torchrl.data import LazyTensorStorage, TensorDictReplayBuffer
from torchrl.envs import CatFrames, Compose, DMControlWrapper, DoubleToFloat, ToTensorImage, TransformedEnv
from torchrl.envs.transforms import MultiStepTransform
from torchrl.objectives import SoftUpdate

from vigen.devices import resolve_device  # vigen
from vigen.evaluation import evaluate, markdown_table, summarize  # vigen
from vigen.losses import make_loss  # vigen
from vigen.transforms import PixelCorruption  # vigen


def make_env(corruption: str | None = None, seed: int = 0) -> TransformedEnv:
    """Your pixel env: dm_control through TorchRL, 84×84 uint8 frames, 3 stacked, action repeat 2."""
    task = suite.load("cartpole", "balance", task_kwargs={"random": seed})
    base = DMControlWrapper(task, from_pixels=True, pixels_only=True, frame_skip=2,
                            render_kwargs={"height": 84, "width": 84, "camera_id": 0})
    transforms = [ToTensorImage(in_keys=["pixels"], from_int=False, dtype=torch.uint8)]
    if corruption is not None:
        transforms.append(PixelCorruption(corruption, severity=3, seed=seed))  # vigen: before frame stacking
    transforms += [CatFrames(N=3, dim=-3, in_keys=["pixels"]), DoubleToFloat()]
    return TransformedEnv(base, Compose(*transforms))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--frames", type=int, default=2000, help="agent steps to collect")
    parser.add_argument("--batch-size", type=int, default=32)
    parser.add_argument("--eval-steps", type=int, default=500, help="agent steps per test episode (a full one is 500)")
    parser.add_argument("--device", default="auto", help="auto (CUDA when present), cpu, cuda or cuda:N; envs step on the CPU")
    args = parser.parse_args()
    try:
        device = resolve_device(args.device)  # vigen: checked before anything is built
    except ValueError as error:
        raise SystemExit(f"--device: {error}") from None
    torch.manual_seed(0)

    env = make_env()
    loss = make_loss("svea", env.observation_spec["pixels"].shape, env.action_spec.shape[-1], hidden_dim=256,
                     device=device)  # vigen
    loss.make_value_estimator(gamma=0.99)
    policy = loss.make_policy(env.action_spec)  # vigen: actor(encoder(pixels)) + scheduled Gaussian noise
    optimizer = torch.optim.Adam(loss.parameters(), lr=1e-4, fused=True)
    target_update = SoftUpdate(loss, tau=0.01)

    collector = Collector(env, policy, frames_per_batch=100, total_frames=args.frames, env_device="cpu", policy_device=device,
                          storing_device=device, init_random_frames=min(500, args.frames // 2),
                          auto_register_policy_transforms=False)
    buffer = TensorDictReplayBuffer(storage=LazyTensorStorage(100_000, device=device), batch_size=args.batch_size,  # uint8 frames
                                    transform=MultiStepTransform(3, 0.99))
    steps = 0
    for batch in collector:
        buffer.extend(batch)
        steps += batch.numel()
        policy[-1].step(batch.numel())
        if steps < collector.init_random_frames:
            continue
        for _ in range(batch.numel() // 2):  # one update every 2 steps, as in DrQ-v2
            loss.set_step(steps)
            out = loss(buffer.sample())
            optimizer.zero_grad()
            sum(value for key, value in out.items() if key.startswith("loss_")).backward()
            optimizer.step()
            target_update.step()
        collector.update_policy_weights_()
        print(f"steps {steps}: loss_critic {out['loss_critic'].item():.3f}, loss_actor {out['loss_actor'].item():.3f}")
    collector.shutdown()

    # vigen: zero-shot test on clean and corrupted frames, 1 episode each
    rows = evaluate(policy, lambda level, seed: make_env(None if level == "clean" else level, seed),
                    ["clean", "gaussian_noise", "contrast"], episodes=1, max_steps=args.eval_steps, tags={"method": "svea"},
                    device=device)
    print(markdown_table(summarize(rows, reps=200)))


if __name__ == "__main__":
    main()
