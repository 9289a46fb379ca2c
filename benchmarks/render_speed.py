"""Render cost of dm_control pixel envs: dm_control's default quality vs vigen's fast preset.

For each task, builds the same env twice (``RenderSettings()`` and ``RenderSettings.fast()``) and
measures, in the same run and interleaved so that machine noise hits both alike:

* render: ms per ``physics.render`` of one frame at the env's image size (camera of the task);
* step: ms per agent step of the full vigen env (physics ×2 for action repeat, one render,
  frame stacking, TorchRL bookkeeping).

Each figure is the median over ``--repeats`` blocks of ``--frames`` calls. The ratio is
default / fast (how many times faster the fast preset is).

Reproduce (about two minutes on 2 CPU cores):

    python benchmarks/render_speed.py
    python benchmarks/render_speed.py --tasks dmc/walker-walk --frames 300 --size 84
"""

from __future__ import annotations

import argparse
import statistics
import time

import vigen  # noqa: F401  (selects the EGL backend before mujoco is imported)
import torch
from vigen.envs import make_env
from vigen.rendering import RenderSettings

TASKS = ["dmc/walker-walk", "dmc/cartpole-swingup", "dmc/cheetah-run", "dmc/quadruped-walk", "dmc/finger-spin"]


def ms_per_call(fn, calls: int) -> float:
    start = time.perf_counter()
    for _ in range(calls):
        fn()
    return (time.perf_counter() - start) / calls * 1e3


def measure(name: str, size: int, frames: int, repeats: int) -> dict[str, tuple[float, float]]:
    settings = {"default": RenderSettings(), "fast": RenderSettings.fast()}
    envs = {k: make_env(name, seed=0, image_size=size, render_settings=s) for k, s in settings.items()}
    renders, steps = {k: [] for k in envs}, {k: [] for k in envs}
    for env in envs.values():
        env.reset()
    for _ in range(repeats):
        for key, env in envs.items():
            physics, camera = env.base_env.physics, env.base_env.camera_id
            renders[key].append(ms_per_call(lambda: physics.render(size, size, camera_id=camera), frames))
            state = env.reset()
            action = torch.zeros(env.action_spec.shape)

            def step() -> None:
                nonlocal state
                state = env.step_and_maybe_reset(state.set("action", action))[1]

            steps[key].append(ms_per_call(step, frames))
    for env in envs.values():
        env.close()
    return {
        "render": (statistics.median(renders["default"]), statistics.median(renders["fast"])),
        "step": (statistics.median(steps["default"]), statistics.median(steps["fast"])),
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--tasks", nargs="+", default=TASKS)
    parser.add_argument("--size", type=int, default=84)
    parser.add_argument("--frames", type=int, default=100)
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args()

    print(f"{args.size}x{args.size}, median of {args.repeats} blocks of {args.frames} calls, threads={torch.get_num_threads()}")
    print("| task | render default (ms) | render fast (ms) | ratio | step default (ms) | step fast (ms) | ratio |")
    print("|---|---|---|---|---|---|---|")
    for name in args.tasks:
        result = measure(name, args.size, args.frames, args.repeats)
        (rd, rf), (sd, sf) = result["render"], result["step"]
        print(f"| {name} | {rd:.1f} | {rf:.1f} | {rd / rf:.2f}x | {sd:.1f} | {sf:.1f} | {sd / sf:.2f}x |", flush=True)


if __name__ == "__main__":
    main()
