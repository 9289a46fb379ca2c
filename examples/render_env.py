"""Render a few dm_control pixel envs through vigen and save what the agent sees as one PNG grid.

Rows are tasks, columns are agent steps of a seeded random-action rollout; each tile is the
newest 84×84 frame of the stacked ``[9, 84, 84]`` uint8 observation.

    python examples/render_env.py                       # writes outputs/render_env.png
    python examples/render_env.py --tasks dmc/walker-walk dmc/reacher-easy --steps 0 25 50 --fast
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import vigen  # noqa: F401  (selects the EGL backend before mujoco is imported)
import cv2
import numpy as np
import torch
from vigen.envs import make_env
from vigen.io import unused_path
from vigen.rendering import RenderSettings

TASKS = ["dmc/walker-walk", "dmc/cheetah-run", "dmc/cartpole-swingup", "dmc/quadruped-walk", "dmc/finger-spin"]


def newest_frames(name: str, steps: list[int], seed: int, fast: bool) -> np.ndarray:
    """The newest RGB frame at each requested step of a seeded random rollout, as ``[len(steps), H, W, 3]``."""
    env = make_env(name, seed=seed, render_settings=RenderSettings.fast() if fast else None)
    torch.manual_seed(seed)
    rollout = env.rollout(max(steps) + 1, break_when_any_done=False)
    env.close()
    frames = rollout["pixels"][steps, -3:]  # the newest frame of each stack
    return frames.permute(0, 2, 3, 1).numpy()


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--tasks", nargs="+", default=TASKS)
    parser.add_argument("--steps", nargs="+", type=int, default=[0, 10, 20, 40, 80])
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--fast", action="store_true", help="CPU-friendly render settings (see vigen.rendering)")
    parser.add_argument("--out", type=Path, default=Path("outputs/render_env.png"))
    args = parser.parse_args()

    start = time.perf_counter()
    rows = [np.concatenate(list(newest_frames(name, args.steps, args.seed, args.fast)), axis=1) for name in args.tasks]
    grid = np.concatenate(rows, axis=0)

    out = unused_path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    if not cv2.imwrite(str(out), cv2.cvtColor(grid, cv2.COLOR_RGB2BGR)):
        raise OSError(f"could not write {out}")
    print(f"rows: {', '.join(args.tasks)}")
    print(f"columns: agent steps {args.steps} (action repeat 2, frames 84x84, stacked 3)")
    print(f"wrote {out} ({grid.shape[1]}x{grid.shape[0]} px) in {time.perf_counter() - start:.1f} s")


if __name__ == "__main__":
    main()
