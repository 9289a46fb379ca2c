"""Returns of fixed policies on a loco task, to read a short training run against: random, zero action, untrained net.

The Unitree tasks start every episode from the same pose, so a deterministic policy repeats its
episode exactly; the uniform-random policy is averaged over ``--episodes``. "zero action" holds
every servo at the middle of its range; "untrained" is the run's network at its initial weights
(drawn as ``examples/train.py`` draws them: ``torch.manual_seed(seed)``, then ``make_loss``), where
its learning starts.

Reproduce the README's numbers (about 5 minutes on 2 CPU cores):

    python benchmarks/loco_baselines.py runs/drqv2-unitree-stand-s0
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
from vigen.evaluation import evaluate
from vigen.losses import make_loss
from vigen.policies import make_policy
from vigen.rendering import RenderSettings


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("run", type=Path, help="a run folder of examples/train.py on a loco task")
    parser.add_argument("--episodes", type=int, default=10, help="episodes of the random policy")
    parser.add_argument("--seed", type=int, default=10_000, help="evaluation seed (train.py evaluates at its seed + 10000)")
    args = parser.parse_args()
    torch.set_num_threads(1)

    config = json.loads((args.run / "config.json").read_text())
    env, dims = config["env"], config["action_dim"]
    options = {"render_settings": RenderSettings.fast()}

    def returns(policy, episodes: int) -> list[float]:
        return [row["return"] for row in evaluate(policy, env, ["train"], episodes=episodes, seeds=[args.seed], env_options=options)]

    zero = TensorDictModule(lambda pixels: torch.zeros(*pixels.shape[:-3], dims), in_keys=["pixels"], out_keys=["action"])
    torch.manual_seed(config["seed"])  # network weights come from torch's global generator, seeded as train.py seeds it
    loss = make_loss(config["algo"], tuple(config["observation_shape"]), dims, feature_dim=config["feature_dim"],
                     hidden_dim=config["hidden_dim"], seed=config["seed"])
    rows = {"random": returns(None, args.episodes), "zero action": returns(zero, 1),
            "untrained": returns(make_policy(loss, Bounded(-1.0, 1.0, shape=(dims,))), 1)}
    print(f"{env}, train level, seed {args.seed}")
    print("| policy | mean return | episodes |")
    print("|---|---|---|")
    for name, values in rows.items():
        print(f"| {name} | {statistics.mean(values):.1f} | {len(values)} |")


if __name__ == "__main__":
    main()
