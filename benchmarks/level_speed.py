"""Per-step cost of each generalization level against the clean ``train`` scene, in the same run.

For each level, the same task is built with ``generalization=level`` and stepped with zero
actions; the figure is the median ms per agent step (action repeat 2, one render) over
``--repeats`` blocks of ``--steps`` steps, measured after the reset (per-episode draws such as
colours and textures are paid once per episode, ``reset ms``). Levels and ``train`` are timed in
alternation. Goal: scene perturbations under +10 % per step, video backgrounds under +25 %,
dynamic variants (per-step drift or motion) under +15 % with the fast render settings.

Reproduce (about three minutes on 2 CPU cores):

    python benchmarks/level_speed.py
    python benchmarks/level_speed.py --task dmc/cheetah-run --fast
    python benchmarks/level_speed.py --fast --dynamic                 # every dynamic factor of the task at 0.3
    python benchmarks/level_speed.py --fast --factors camera_rotation=0.3 object_color=0.5+camera_fov=0.2

``--factors`` takes generalization dicts written as level labels (``factor=intensity``, joined by
``+`` for several); ``--dynamic [I]`` adds each dynamic factor the task has (``DYNAMIC``) at
intensity ``I`` (default 0.3, the Distracting Control Suite's hard setting).
"""

from __future__ import annotations

import argparse
import statistics
import time

import vigen  # noqa: F401  (selects the EGL backend before mujoco is imported)
import torch
from vigen.envs import factors, level_label, make_env
from vigen.evaluation.sweep import check_factor_intensity
from vigen.rendering import RenderSettings

LEVELS = [
    "color_hard", "objects_color_hard", "floor_texture", "video_easy", "video_hard", "light_hard", "camera_hard",
    "gaussian_noise_3", "gaussian_blur_3", "jpeg_compression_3", "contrast_3", "brightness_3",
]
DYNAMIC = ("moving_light", "dynamic_camera", "dynamic_color")
"""Factors that change the scene every step (the Distracting Control Suite's dynamic setting, moving lights)."""
DYNAMIC_GOAL = 0.15


def parse_factors(text: str) -> dict[str, float]:
    """``"camera_rotation=0.3+object_color=0.5"`` -> ``{"camera_rotation": 0.3, "object_color": 0.5}``."""
    level = {}
    for part in text.split("+"):
        name, equals, value = part.partition("=")
        if not equals:
            raise argparse.ArgumentTypeError(f"{part!r}: write FACTOR=INTENSITY, e.g. camera_rotation=0.3")
        try:
            level[name] = check_factor_intensity(name, float(value), argument="--factors")
        except ValueError as error:
            raise argparse.ArgumentTypeError(str(error)) from None
    return level


def step_ms(env, state, steps: int):
    action = torch.zeros(env.action_spec.shape)
    start = time.perf_counter()
    for _ in range(steps):
        _, state = env.step_and_maybe_reset(state.set("action", action))
    return (time.perf_counter() - start) / steps * 1e3, state


def median_step_ms(envs: dict, steps: int, repeats: int, warmup: int = 0) -> tuple[dict[str, float], dict[str, float]]:
    """Median ms per agent step of each env over ``repeats`` blocks of ``steps``, timed in alternation, and the ms of
    each first reset (taken apart), after ``warmup`` untimed steps."""
    states, resets, times = {}, {}, {name: [] for name in envs}
    for name, env in envs.items():
        start = time.perf_counter()
        states[name] = env.reset()
        resets[name] = (time.perf_counter() - start) * 1e3
        if warmup:
            _, states[name] = step_ms(env, states[name], warmup)
    for _ in range(repeats):
        for name, env in envs.items():
            ms, states[name] = step_ms(env, states[name], steps)
            times[name].append(ms)
    return {name: statistics.median(values) for name, values in times.items()}, resets


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--task", default="dmc/walker-walk")
    parser.add_argument("--levels", nargs="*", default=None, help="named levels (default: LEVELS, unless --factors "
                        "or --dynamic is given; --levels with no name measures none)")
    parser.add_argument("--factors", nargs="+", type=parse_factors, default=[], metavar="F=I[+G=J]",
                        help="generalization dicts, e.g. camera_rotation=0.3 or object_color=0.5+camera_fov=0.2")
    parser.add_argument("--dynamic", nargs="?", type=float, const=0.3, default=None, metavar="I",
                        help=f"add each dynamic factor of the task ({', '.join(DYNAMIC)}) at intensity I (default 0.3)")
    parser.add_argument("--steps", type=int, default=50)
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--fast", action="store_true", help="RenderSettings.fast() for every env")
    args = parser.parse_args()

    available = factors(args.task)
    unknown = sorted({name for level in args.factors for name in level if name not in available})
    if unknown:
        parser.error(f"--factors: {unknown} are not factors of {args.task}; its factors are {', '.join(available)}.")
    levels = list(args.levels if args.levels is not None else ([] if args.factors or args.dynamic is not None else LEVELS))
    levels += args.factors
    dynamic: list[str] = []
    if args.dynamic is not None:
        try:
            check_factor_intensity("dynamic factors", args.dynamic, argument="--dynamic")
        except ValueError as error:
            parser.error(str(error))
        dynamic = [name for name in DYNAMIC if name in available]
        missing = [name for name in DYNAMIC if name not in available]
        if missing:
            print(f"{args.task} has no dynamic factor {', '.join(missing)}; measuring {', '.join(dynamic) or 'none'}")
        levels += [{name: args.dynamic} for name in dynamic]
    if not levels:
        parser.error("nothing to measure: give --levels, --factors or --dynamic.")

    settings = RenderSettings.fast() if args.fast else None
    print(f"{args.task}, {'fast' if args.fast else 'default'} rendering, median of {args.repeats} blocks of {args.steps} steps")
    print("| level | train (ms/step) | level (ms/step) | overhead | first reset (ms) |")
    print("|---|---|---|---|---|")
    overheads = {}
    for level in levels:
        label = level_label(level)
        envs = {"train": make_env(args.task, generalization="train", seed=0, render_settings=settings),
                label: make_env(args.task, generalization=level, seed=0, render_settings=settings)}
        medians, resets = median_step_ms(envs, args.steps, args.repeats)
        train, ours = medians["train"], medians[label]
        overheads[label] = ours / train - 1
        print(f"| {label} | {train:.1f} | {ours:.1f} | {overheads[label]:+.0%} | {resets[label]:.0f} |", flush=True)
        for env in envs.values():
            env.close()
    for name in dynamic:
        label = level_label({name: args.dynamic})
        verdict = "within" if overheads[label] <= DYNAMIC_GOAL else "over"
        print(f"{label}: {overheads[label]:+.0%} per step, {verdict} the {DYNAMIC_GOAL:.0%} goal"
              f"{'' if args.fast else ' (the goal is for --fast)'}")


if __name__ == "__main__":
    main()
