"""Per-step cost of each generalization level against the clean ``train`` scene, in the same run.

For each level, the same task is built with ``generalization=level`` and stepped with zero
actions; the figure is the median ms per agent step (action repeat 2, one render) over
``--repeats`` blocks of ``--steps`` steps, measured after the reset (per-episode draws such as
colours and textures are paid once per episode, ``reset ms``). Levels and ``train`` are timed in
alternation. Goal: scene perturbations under +10 % per step, video backgrounds under +25 %.

Reproduce (about three minutes on 2 CPU cores):

    python benchmarks/level_speed.py
    python benchmarks/level_speed.py --task dmc/cheetah-run --fast
"""

from __future__ import annotations

import argparse
import statistics
import time

import vigen  # noqa: F401  (selects the EGL backend before mujoco is imported)
import torch
from vigen.envs import make_env
from vigen.rendering import RenderSettings

LEVELS = [
    "color_hard", "objects_color_hard", "floor_texture", "video_easy", "video_hard", "light_hard", "camera_hard",
    "gaussian_noise_3", "gaussian_blur_3", "jpeg_compression_3", "contrast_3", "brightness_3",
]


def step_ms(env, state, steps: int):
    action = torch.zeros(env.action_spec.shape)
    start = time.perf_counter()
    for _ in range(steps):
        _, state = env.step_and_maybe_reset(state.set("action", action))
    return (time.perf_counter() - start) / steps * 1e3, state


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--task", default="dmc/walker-walk")
    parser.add_argument("--levels", nargs="+", default=LEVELS)
    parser.add_argument("--steps", type=int, default=50)
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--fast", action="store_true", help="RenderSettings.fast() for every env")
    args = parser.parse_args()

    settings = RenderSettings.fast() if args.fast else None
    print(f"{args.task}, {'fast' if args.fast else 'default'} rendering, median of {args.repeats} blocks of {args.steps} steps")
    print("| level | train (ms/step) | level (ms/step) | overhead | first reset (ms) |")
    print("|---|---|---|---|---|")
    for level in args.levels:
        envs = {name: make_env(args.task, generalization=name, seed=0, render_settings=settings) for name in ("train", level)}
        states, times, resets = {}, {name: [] for name in envs}, {}
        for name, env in envs.items():
            start = time.perf_counter()
            states[name] = env.reset()
            resets[name] = (time.perf_counter() - start) * 1e3
        for _ in range(args.repeats):
            for name, env in envs.items():
                ms, states[name] = step_ms(env, states[name], args.steps)
                times[name].append(ms)
        train, ours = statistics.median(times["train"]), statistics.median(times[level])
        print(f"| {level} | {train:.1f} | {ours:.1f} | {ours / train - 1:+.0%} | {resets[level]:.0f} |", flush=True)


if __name__ == "__main__":
    main()
