"""Scripted policies on ``loco/unitree-stand`` for each quadruped: what returns the task allows, robot by robot.

The stand task scores every control step ``(2·standing + upright)/3`` minus action and tilt
penalties, so a return of 1000 (1000 steps of 0.01 s) is a robot standing tall, still and level
from the first step. These policies show where a learned policy's return sits on that scale, and
whether the Go1 that vigen ships in place of RL-ViGen's A1 makes the task easier or harder:

* ``uniform random``: actions drawn uniformly in [-1, 1], held for 2 control steps (action repeat 2),
  mean ± std over ``--episodes`` episodes;
* ``zero action``: every servo at the middle of its range (the robot sinks onto its belly, upright);
* ``hold the folded start``: the start pose commanded throughout;
* ``command <pose>``: a standing pose commanded at once (the robot jumps);
* ``ramp to <pose> in 1 s``: the same pose reached by moving linearly from the start pose over 100 steps.

Poses are (hip, thigh, calf) in radians on all four legs, clipped to each robot's servo ranges.
Runs the physics only (no rendering): a few seconds per robot.

Reproduce the README's table:

    python benchmarks/loco_robots.py
    python benchmarks/loco_robots.py --model-dir ~/mujoco_menagerie   # adds RL-ViGen's A1 (unitree_a1/a1.xml)
"""

from __future__ import annotations

import argparse
import statistics
from collections.abc import Callable
from pathlib import Path

import numpy as np

import vigen  # noqa: F401  (selects the EGL backend before mujoco is imported)
from vigen.envs.loco.scene import build_scene
from vigen.envs.loco.tasks import make_control_env

ACTION_REPEAT = 2
RAMP_STEPS = 100
POSES = {"crouch": (0.0, 0.9, -1.8), "stand": (0.0, 0.45, -0.9)}
"""Standing poses (hip, thigh, calf): Menagerie's A1 / Go1 ``home`` crouch, and a tall stance near the stand height."""


def episode(env, policy: Callable[[int], np.ndarray]) -> tuple[float, float]:
    """The return of one 1000-step episode and the base's final height."""
    env.reset()
    total = 0.0
    for step in range(1000):
        total += env.step(policy(step)).reward
    return total, env.task.readings(env.physics)["height"]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--robots", nargs="+", default=["go1", "go2", "aliengo"], help="installed quadrupeds to score")
    parser.add_argument("--model-dir", type=Path, default=None, help="a MuJoCo Menagerie checkout: also score RL-ViGen's A1")
    parser.add_argument("--episodes", type=int, default=10, help="episodes of the random policy")
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()
    if args.episodes < 1:
        raise SystemExit(f"--episodes must be >= 1, got {args.episodes}.")
    scenes = {robot: build_scene("unitree-stand", robot) for robot in args.robots}
    if args.model_dir is not None:
        scenes["a1"] = build_scene("unitree-stand", "a1", model_dir=args.model_dir.expanduser())

    results: dict[str, dict[str, str]] = {}
    for robot, scene in scenes.items():
        env = make_control_env(scene, seed=args.seed)
        low, high = env.physics.model.actuator_ctrlrange.T
        start = scene.start_qpos[-12:]

        def action(pose: np.ndarray) -> np.ndarray:
            return 2.0 * (np.clip(pose, low, high) - low) / (high - low) - 1.0

        rng = np.random.default_rng(args.seed)
        held = {}

        def random_policy(step: int) -> np.ndarray:
            if step % ACTION_REPEAT == 0:
                held["action"] = rng.uniform(-1.0, 1.0, size=len(low))
            return held["action"]

        random_returns = [episode(env, random_policy)[0] for _ in range(args.episodes)]
        spread = statistics.stdev(random_returns) if len(random_returns) > 1 else 0.0
        cells = {"uniform random": f"{statistics.mean(random_returns):.0f} ± {spread:.0f}"}
        policies = {"zero action": lambda step: np.zeros(len(low)), "hold the folded start": lambda step: action(start)}
        for name, joints in POSES.items():
            pose = np.tile(joints, 4)
            policies[f"command {name} {joints[1:]}"] = lambda step, pose=pose: action(pose)
            policies[f"ramp to {name} in 1 s"] = lambda step, pose=pose: action(start + min(1.0, step / RAMP_STEPS) * (pose - start))
        for name, policy in policies.items():
            value, height = episode(env, policy)
            cells[name] = f"{value:.0f} ({height:.2f} m)"
        results[f"{robot} (stand height {scene.stand_height:.3f} m)"] = cells

    robots = list(results)
    print("loco/unitree-stand returns (final base height); random: mean ± std over "
          f"{args.episodes} episodes, seed {args.seed}")
    print("| policy | " + " | ".join(robots) + " |")
    print("|---|" + "---|" * len(robots))
    for name in results[robots[0]]:
        print(f"| {name} | " + " | ".join(results[robot][name] for robot in robots) + " |")


if __name__ == "__main__":
    main()
