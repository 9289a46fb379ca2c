"""Picture gallery of the generalization levels: what the agent sees, one row per level, one column per seed.

    python examples/gallery.py --task dmc/walker-walk              # writes docs/gallery_walker-walk.png
    python examples/gallery.py --task dmc/cartpole-swingup --levels train dmcgb --seeds 0 1 2
    python examples/gallery.py --levels video_hard --level-option videos=/data/dmcgb/video_hard
    python examples/gallery.py --task robosuite/door                # every robosuite level; seeds pick the scenes
    python examples/gallery.py --task adroit/door                   # writes docs/gallery_adroit-door.png

An existing file is never overwritten: the new grid gets the next free name (``-1``, ``-2``, ...)
unless ``--overwrite`` is given.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import vigen  # noqa: F401  (selects the EGL backend before mujoco is imported)
import cv2
import numpy as np
from vigen.envs import make_env
from vigen.envs.levels import resolve_levels
from vigen.io import unused_path
from vigen.rendering import RenderSettings

DMC_LEVELS = [
    "train", "color_easy", "color_hard", "objects_color_hard", "floor_texture", "video_easy", "video_hard",
    "light_easy", "light_hard", "camera_easy", "camera_hard", "gaussian_noise_3", "gaussian_blur_3",
    "jpeg_compression_5", "contrast_3", "brightness_3",
]
LABEL_WIDTH, SCALE = 190, 2


def first_frames(task: str, level: str, seeds: list[int], fast: bool, options: dict[str, str]) -> list[np.ndarray]:
    """The newest RGB frame of the reset observation, one per seed (each seed its own episode)."""
    frames = []
    for seed in seeds:
        env = make_env(task, generalization=level, seed=seed, level_options=options,
                       render_settings=RenderSettings.fast() if fast else None)
        frames.append(env.reset()["pixels"][-3:].permute(1, 2, 0).numpy())
        env.close()
    return frames


def labelled_row(level: str, frames: list[np.ndarray]) -> np.ndarray:
    tiles = np.concatenate(frames, axis=1).repeat(SCALE, axis=0).repeat(SCALE, axis=1)
    label = np.full((tiles.shape[0], LABEL_WIDTH, 3), 255, np.uint8)
    cv2.putText(label, level, (6, tiles.shape[0] // 2 + 5), cv2.FONT_HERSHEY_SIMPLEX, 0.5, (0, 0, 0), 1, cv2.LINE_AA)
    return np.concatenate([label, tiles], axis=1)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--task", default="dmc/walker-walk")
    parser.add_argument("--levels", nargs="+", default=None,
                        help="level or group names (see docs/levels.md); default: every scene level of the task's suite")
    parser.add_argument("--seeds", nargs="+", type=int, default=[0, 1, 2, 3, 4])
    parser.add_argument("--fast", action="store_true", help="CPU-friendly render settings")
    parser.add_argument("--level-option", action="append", default=[], metavar="KEY=VALUE",
                        help="passed to the levels' transforms, e.g. videos=/path or palette=/path/color_hard.pt")
    parser.add_argument("--out", type=Path, help="default: docs/gallery_<task>.png (dmc), docs/gallery_<suite>-<task>.png")
    parser.add_argument("--overwrite", action="store_true")
    args = parser.parse_args()

    options = dict(option.split("=", 1) for option in args.level_option)
    suite, name = args.task.split("/", 1)
    levels = resolve_levels(args.levels or (DMC_LEVELS if suite == "dmc" else ["all"]), suite=suite)
    rows = [labelled_row(level, first_frames(args.task, level, args.seeds, args.fast, options)) for level in levels]
    grid = np.concatenate(rows, axis=0)

    out = args.out or Path("docs") / f"gallery_{name if suite == 'dmc' else f'{suite}-{name}'}.png"
    out = out if args.overwrite else unused_path(out)
    out.parent.mkdir(parents=True, exist_ok=True)
    if not cv2.imwrite(str(out), cv2.cvtColor(grid, cv2.COLOR_RGB2BGR)):
        raise OSError(f"could not write {out}")
    print(f"wrote {out}: {len(levels)} levels x {len(args.seeds)} seeds of {args.task}")


if __name__ == "__main__":
    main()
