"""Returns of fixed policies on a loco task, to read a short training run against: random, zero action, untrained net.

The Unitree tasks start every episode from the same pose, so a deterministic policy repeats its
episode exactly; the uniform-random policy is averaged over ``--episodes``. "zero action" holds
every servo at the middle of its range; "untrained" is the run's network at its initial weights
(drawn as ``examples/train.py`` draws them: ``torch.manual_seed(seed)``, then ``make_loss``), where
its learning starts.

Reproduce the README's numbers (about 5 minutes on 2 CPU cores):

    python benchmarks/loco_baselines.py runs/drqv2-unitree-stand-s0

``--curve SIGMA`` reads the run's checkpoints instead: for the untrained network (frames 0) and
each checkpoint, the deterministic return and the mean return over ``--episodes`` episodes with
Gaussian noise of std SIGMA added to the actions (clamped to [-1, 1]), the same noise for every
checkpoint. Training returns are logged under the exploration σ of the moment, which falls as
training goes on and alone raises the return of a task that penalises actions; at one fixed σ
the checkpoints differ only by their weights. The deterministic episode's share of saturated
action components (beyond ±0.95: servos commanded to the ends of their ranges) is printed beside
its return (about 1 minute per checkpoint and 5 episodes):

    python benchmarks/loco_baselines.py runs/drqv2-unitree-stand-s0 --curve 0.3
"""

from __future__ import annotations

import argparse
import json
import statistics
from pathlib import Path

import vigen  # noqa: F401  (selects the EGL backend before mujoco is imported)
import torch
from tensordict.nn import TensorDictModule
from torchrl.data import Bounded
from vigen.run.checkpoint import load_checkpoint
from vigen.evaluation import evaluate
from vigen.losses import make_loss
from vigen.rendering import RenderSettings


SATURATED = 0.95
"""An action component beyond this magnitude (of 1) counts as saturated: the servo is commanded to the end of its range."""


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("run", type=Path, help="a run folder of examples/train.py on a loco task")
    parser.add_argument("--episodes", type=int, default=10, help="episodes of the random policy")
    parser.add_argument("--seed", type=int, default=10_000, help="evaluation seed (train.py evaluates at its seed + 10000)")
    parser.add_argument("--curve", type=float, default=None, metavar="SIGMA",
                        help="the checkpoints' returns, deterministic and with action noise of std SIGMA")
    parser.add_argument("--frames", nargs="+", type=int, default=None,
                        help="with --curve: only these checkpoints (0: the initial weights); default all")
    args = parser.parse_args()
    torch.set_num_threads(1)

    config = json.loads((args.run / "config.json").read_text())
    env, dims = config["env"], config["action_dim"]
    options = {"render_settings": RenderSettings.fast()}

    def returns(policy, episodes: int) -> list[float]:
        return [row["return"] for row in evaluate(policy, env, ["train"], episodes=episodes, seeds=[args.seed], env_options=options)]

    if args.curve is not None:
        return curve(args, config, returns)
    zero = TensorDictModule(lambda pixels: torch.zeros(*pixels.shape[:-3], dims), in_keys=["pixels"], out_keys=["action"])
    rows = {"random": returns(None, args.episodes), "zero action": returns(zero, 1),
            "untrained": returns(initial_loss(config).make_policy(Bounded(-1.0, 1.0, shape=(dims,))), 1)}
    print(f"{env}, train level, seed {args.seed}")
    print("| policy | mean return | episodes |")
    print("|---|---|---|")
    for name, values in rows.items():
        print(f"| {name} | {statistics.mean(values):.1f} | {len(values)} |")


def initial_loss(config: dict):
    """The run's loss at its initial weights, drawn as ``examples/train.py`` draws them (torch's global generator seeded)."""
    torch.manual_seed(config["seed"])
    loss = make_loss(config["algo"], tuple(config["observation_shape"]), config["action_dim"], feature_dim=config["feature_dim"],
                     hidden_dim=config["hidden_dim"], seed=config["seed"])
    return loss.make_value_estimator(gamma=config["gamma"])  # its gamma is part of a checkpoint's state


def curve(args: argparse.Namespace, config: dict, returns) -> None:
    """Deterministic and fixed-σ noisy returns of the untrained network and of every checkpoint of the run."""
    loss = initial_loss(config)
    policy = loss.make_policy(Bounded(-1.0, 1.0, shape=(config["action_dim"],)))
    generator = torch.Generator()

    def noisy(tensordict):
        action = policy(tensordict)["action"]
        noise = args.curve * torch.randn(action.shape, generator=generator)
        return tensordict.set("action", (action + noise).clamp(-1.0, 1.0))

    magnitudes: list[torch.Tensor] = []

    def recorded(tensordict):
        out = policy(tensordict)
        magnitudes.append(out["action"].detach().abs().reshape(-1))
        return out

    checkpoints = [(0, None)] + [(int(path.stem.split("_")[1]), path)
                                 for path in sorted((args.run / "checkpoints").glob("frames_*.pt"))]
    if args.frames is not None:
        missing = sorted(set(args.frames) - {frames for frames, _ in checkpoints})
        if missing:
            raise SystemExit(f"--frames {missing}: the run has no such checkpoints; it has "
                             f"{', '.join(str(frames) for frames, _ in checkpoints)}.")
        checkpoints = [(frames, path) for frames, path in checkpoints if frames in args.frames]
    print(f"{config['env']}, train level, seed {args.seed}; noise σ = {args.curve} over {args.episodes} episodes")
    print(f"| frames | deterministic return | saturated actions | return with σ = {args.curve} (mean ± std) |")
    print("|---|---|---|---|")
    for frames, path in checkpoints:
        if path is not None:
            loss.load_state_dict(load_checkpoint(path)["loss"])
        generator.manual_seed(args.seed)  # the same noise for every checkpoint
        magnitudes.clear()
        deterministic = returns(recorded, 1)[0]
        saturated = (torch.cat(magnitudes) > SATURATED).float().mean().item()
        with_noise = returns(noisy, args.episodes)
        spread = statistics.stdev(with_noise) if len(with_noise) > 1 else 0.0
        print(f"| {frames} | {deterministic:.1f} | {saturated:.0%} | {statistics.mean(with_noise):.1f} ± {spread:.1f} |", flush=True)


if __name__ == "__main__":
    main()
