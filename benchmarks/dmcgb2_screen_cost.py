"""Per-step cost of DMC-GB2's in-scene video screen against vigen's screen-space default, in the same run.

``color_video_easy`` (by default) is built twice on the same task and seed: with the video
composited into the frame's background pixels (vigen's default) and on DMC-GB2's lit
``video_screen`` box (``level_options={"screen": True}``: the physics reloaded once with the box,
the frame written into its texture every step, the box following the torso for walker and
cheetah, and a second render). Each is stepped with zero actions after a few warm-up steps; the
figure is the median ms per agent step over ``--repeats`` blocks of ``--steps`` steps, timed in
alternation, and their ratio. The first reset (the screen's physics reload) is reported apart.

Reproduce (a few minutes on 2 CPU cores):

    MUJOCO_GL=egl python benchmarks/dmcgb2_screen_cost.py
    MUJOCO_GL=egl python benchmarks/dmcgb2_screen_cost.py --task dmc/cheetah-run --level color_video_hard
"""

from __future__ import annotations

import argparse

import vigen  # noqa: F401  (selects the EGL backend before mujoco is imported)
from level_speed import median_step_ms  # benchmarks/level_speed.py, beside this script
from vigen.envs import make_env


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--task", default="dmc/walker-walk")
    parser.add_argument("--level", default="color_video_easy")
    parser.add_argument("--steps", type=int, default=50)
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--warmup", type=int, default=5)
    args = parser.parse_args()

    variants = {"composite (default)": None, "screen (DMC-GB2)": {"screen": True}}
    envs = {name: make_env(args.task, generalization=args.level, seed=0, level_options=options)
            for name, options in variants.items()}
    medians, resets = median_step_ms(envs, args.steps, args.repeats, warmup=args.warmup)
    base = medians["composite (default)"]
    print(f"{args.task} {args.level}: median ms per agent step over {args.repeats} blocks of {args.steps}")
    print("| variant | ms/step | vs default | first reset (ms) |\n|---|---|---|---|")
    for name in variants:
        print(f"| {name} | {medians[name]:.1f} | {medians[name] / base:.2f}x | {resets[name]:.0f} |")
    for env in envs.values():
        env.close()


if __name__ == "__main__":
    main()
