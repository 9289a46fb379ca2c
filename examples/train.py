"""Train an augmentation-based agent from pixels on a dm_control or robosuite task, with vigen and TorchRL.

    python examples/train.py --algo svea --env dmc/cartpole-balance --preset cpu --frames 20000
    python examples/train.py --resume runs/svea-cartpole-balance-s0 --frames 40000   # continue it

The run folder gets ``config.json``, TorchRL CSV logs (``logs/scalars/*.csv``: train losses,
``eval/return``), ``checkpoints/frames_XXXXXXXX.pt`` at every evaluation and the replay buffer
needed to resume. ``--frames`` counts environment frames (agent steps × action repeat), as in
DrQ-v2's curves. Presets: ``paper`` is DrQ-v2 / RL-ViGen's setup (batch 256, 1M-transition
buffer, lr 1e-4, 3-step returns, τ = 0.01, 4000 seed frames, an update every 2 agent steps);
``cpu`` is the same agent with batch 64 and a 100k buffer, to learn easy tasks on a laptop CPU.
"""

from __future__ import annotations

import argparse
import json
import time
from functools import partial
from pathlib import Path

import torch
from torchrl.collectors import Collector, MultiSyncCollector
from torchrl.data import LazyMemmapStorage, TensorDictReplayBuffer
from torchrl.envs import RewardSum, TransformedEnv
from torchrl.envs.transforms import MultiStepTransform
from torchrl.modules import AdditiveGaussianModule
from torchrl.objectives import SoftUpdate
from torchrl.record.loggers import get_logger
from tqdm import tqdm

from vigen.envs import make_env
from vigen.evaluation import evaluate
from vigen.io import unused_path
from vigen.losses import ALGOS, LinearSchedule, make_loss
from vigen.policies import make_policy
from vigen.rendering import RenderSettings

PRESETS = {
    "paper": dict(batch_size=256, buffer_size=1_000_000, lr=1e-4, hidden_dim=1024, feature_dim=50, n_step=3,
                  gamma=0.99, tau=0.01, seed_frames=4000, update_every=2, std_duration=100_000,
                  eval_every=10_000, eval_episodes=10),
    "cpu": dict(batch_size=64, buffer_size=100_000, lr=1e-4, hidden_dim=1024, feature_dim=50, n_step=3,
                gamma=0.99, tau=0.01, seed_frames=4000, update_every=2, std_duration=100_000,
                eval_every=10_000, eval_episodes=5),
}


def training_env(name: str, seed: int, episode_length: int | None = None) -> TransformedEnv:
    """The suite's pixels (uint8 [9, 84, 84]; DrQ-v2's action repeat 2 on dm_control), rendered fast, with episode returns summed."""
    length = {} if episode_length is None else {"episode_length": episode_length}
    env = make_env(name, seed=seed, render_settings=RenderSettings.fast(), **length)
    return env.append_transform(RewardSum())


def parse_args() -> argparse.Namespace:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--algo", choices=list(ALGOS), default="drqv2")
    parser.add_argument("--env", default="dmc/cartpole-balance")
    parser.add_argument("--preset", choices=list(PRESETS), default="cpu")
    parser.add_argument("--frames", type=int, default=100_000, help="environment frames in all (with action repeat)")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--out", type=Path, default=None, help="run folder (default runs/<algo>-<task>-s<seed>)")
    parser.add_argument("--resume", type=Path, default=None, help="a run folder to continue up to --frames")
    parser.add_argument("--workers", type=int, default=1, help=">1: a MultiSyncCollector with one env per process")
    parser.add_argument("--eval-levels", nargs="*", default=["train"], help="levels evaluated at every checkpoint")
    parser.add_argument("--logger", choices=["csv", "wandb"], default="csv", help="wandb runs offline")
    parser.add_argument("--episode-length", type=int, default=None,
                        help="simulator steps per episode (default: the suite's, dm_control 1000, robosuite 500)")
    parser.add_argument("--threads", type=int, default=None, help="torch threads (default: torch's choice)")
    for name, value in PRESETS["paper"].items():  # every preset value can be overridden
        parser.add_argument(f"--{name.replace('_', '-')}", type=type(value), default=None)
    return parser.parse_args()


def configure(args: argparse.Namespace) -> dict:
    """The run's settings: a new run's preset with overrides (in a new folder), or a resumed run's saved config."""
    if args.resume is not None:
        config = json.loads((args.resume / "config.json").read_text())
        config.update(frames=args.frames, run_dir=str(args.resume))
        return config
    config = dict(PRESETS[args.preset], algo=args.algo, env=args.env, preset=args.preset, frames=args.frames,
                  seed=args.seed, workers=args.workers, eval_levels=args.eval_levels, logger=args.logger,
                  episode_length=args.episode_length)
    config.update({name: getattr(args, name) for name in PRESETS["paper"] if getattr(args, name) is not None})
    task = args.env.split("/", 1)[-1]
    run_dir = unused_path(args.out or Path("runs") / f"{args.algo}-{task}-s{args.seed}")  # never reuse a run folder
    run_dir.mkdir(parents=True)
    return dict(config, run_dir=str(run_dir))


def main() -> None:
    args = parse_args()
    if args.threads:
        torch.set_num_threads(args.threads)
    config = configure(args)
    run_dir = Path(config["run_dir"])
    torch.manual_seed(config["seed"])

    make = partial(training_env, config["env"], episode_length=config["episode_length"])
    probe = make(seed=config["seed"])
    action_repeat = probe.base_env.action_repeat
    observation_shape = tuple(probe.observation_spec["pixels"].shape)
    action_spec = probe.action_spec
    probe.close()
    if args.resume is None:
        config.update(observation_shape=observation_shape, action_dim=action_spec.shape[-1])
        (run_dir / "config.json").write_text(json.dumps({k: v for k, v in config.items() if k != "run_dir"}, indent=2))

    # the agent: a vigen loss on the paper's networks, its acting policy, Adam and the target-critic update
    std = LinearSchedule(1.0, 0.1, config["std_duration"])
    loss = make_loss(config["algo"], observation_shape, config["action_dim"], feature_dim=config["feature_dim"],
                     hidden_dim=config["hidden_dim"], **({} if config["algo"] == "drq" else {"std": std}))
    loss.make_value_estimator(gamma=config["gamma"])
    policy = make_policy(loss, action_spec)
    noise = next((module for module in policy.modules() if isinstance(module, AdditiveGaussianModule)), None)
    optimizer = torch.optim.Adam(loss.parameters(), lr=config["lr"])
    target_update = SoftUpdate(loss, tau=config["tau"])

    # replay: uint8 transitions memory-mapped in the run folder (saving it for --resume copies nothing),
    # n-step returns computed as trajectories come in
    buffer = TensorDictReplayBuffer(
        storage=LazyMemmapStorage(config["buffer_size"], scratch_dir=run_dir / "replay_buffer" / "storage"),
        batch_size=config["batch_size"],
    )
    n_step = MultiStepTransform(config["n_step"], config["gamma"])  # holds back the last n steps of each batch
    steps, updates = 0, 0  # agent steps collected, gradient updates made
    if args.resume is not None:
        checkpoint = torch.load(sorted((run_dir / "checkpoints").glob("frames_*.pt"))[-1], weights_only=False)
        loss.load_state_dict(checkpoint["loss"])
        optimizer.load_state_dict(checkpoint["optimizer"])
        policy.load_state_dict(checkpoint["policy"])
        steps, updates = checkpoint["steps"], checkpoint["updates"]
        torch.set_rng_state(checkpoint["torch_rng"])
        buffer.loads(run_dir / "replay_buffer")

    total_steps = config["frames"] // action_repeat
    seed_steps = config["seed_frames"] // action_repeat
    frames_per_batch = 50 * config["update_every"] * max(1, config["workers"])
    remaining = max(0, total_steps - steps)
    env_seed = config["seed"] + 1000 * steps  # a resumed run starts fresh episodes, not the first ones again
    if config["workers"] > 1:
        collector = MultiSyncCollector([partial(make, seed=env_seed + w) for w in range(config["workers"])], policy,
                                       frames_per_batch=frames_per_batch, total_frames=remaining,
                                       init_random_frames=max(0, seed_steps - steps), cat_results="stack",
                                       auto_register_policy_transforms=False)
    else:
        collector = Collector(make(seed=env_seed), policy, frames_per_batch=frames_per_batch, total_frames=remaining,
                              init_random_frames=max(0, seed_steps - steps), auto_register_policy_transforms=False)

    logger = get_logger(config["logger"], logger_name=str(run_dir), experiment_name="logs",
                        **({"offline": True} if config["logger"] == "wandb" else {}))
    progress = tqdm(total=total_steps * action_repeat, initial=steps * action_repeat, unit="frame", dynamic_ncols=True)
    eval_every = config["eval_every"] // action_repeat
    for batch in collector:
        transitions = n_step.inv(batch)  # [time] or [workers, time], with n-step rewards and next pixels
        if transitions is not None:
            buffer.extend(transitions.reshape(-1))
        new = batch.numel()
        steps += new
        if noise is not None:
            noise.step(new)  # the exploration noise follows the std schedule (DrQ samples from its policy instead)
        progress.update(new * action_repeat)
        episode_ends = batch["next", "done"].squeeze(-1)
        if episode_ends.any():
            logger.log_scalar("train/episode_reward", batch["next", "episode_reward"][episode_ends].mean().item(), step=steps * action_repeat)

        due = (steps - seed_steps) // config["update_every"] - updates if steps >= seed_steps else 0
        started = time.perf_counter()
        for _ in range(max(0, due)):
            loss.set_step(steps)
            out = loss(buffer.sample())
            optimizer.zero_grad(set_to_none=True)
            sum(value for key, value in out.items() if key.startswith("loss_")).backward()
            optimizer.step()
            target_update.step()
            updates += 1
        if due > 0:
            for key, value in out.items():
                logger.log_scalar(f"train/{key}", value.item(), step=steps * action_repeat)
            logger.log_scalar("train/seconds_per_update", (time.perf_counter() - started) / due, step=steps * action_repeat)
        collector.update_policy_weights_()

        if steps // eval_every > (steps - new) // eval_every or steps >= total_steps:
            length = {} if config["episode_length"] is None else {"episode_length": config["episode_length"]}
            rows = evaluate(policy, config["env"], config["eval_levels"], episodes=config["eval_episodes"],
                            seeds=[config["seed"] + 10_000], env_options={"render_settings": RenderSettings.fast(), **length})
            for level in config["eval_levels"]:
                returns = [row["return"] for row in rows if row["level"] == level]
                logger.log_scalar(f"eval/{level}_return", sum(returns) / len(returns), step=steps * action_repeat)
            progress.set_postfix(eval=round(sum(r["return"] for r in rows if r["level"] == config["eval_levels"][0]) / config["eval_episodes"]))
            save(run_dir, steps * action_repeat, loss, optimizer, policy, buffer, steps=steps, updates=updates)
    collector.shutdown()
    progress.close()


def save(run_dir: Path, frames: int, loss, optimizer, policy, buffer, **counters: int) -> None:
    """A checkpoint per evaluation (never overwritten) and the replay buffer to resume from."""
    checkpoints = run_dir / "checkpoints"
    checkpoints.mkdir(exist_ok=True)
    state = {"loss": loss.state_dict(), "optimizer": optimizer.state_dict(), "policy": policy.state_dict(),
             "torch_rng": torch.get_rng_state(), "frames": frames, **counters}
    torch.save(state, unused_path(checkpoints / f"frames_{frames:08d}.pt"))
    buffer.dumps(run_dir / "replay_buffer")


if __name__ == "__main__":
    main()
