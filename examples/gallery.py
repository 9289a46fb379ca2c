"""Picture gallery of the generalization levels: what the agent sees, one row per level, one column per seed.

    python examples/gallery.py --task dmc/walker-walk              # writes docs/gallery_walker-walk.png
    python examples/gallery.py --task dmc/walker-walk --factors    # docs/gallery_factors_walker-walk.png
    python examples/gallery.py --task robosuite/door --factors --intensities 0.2 0.5 1.0 --seeds 3
    python examples/gallery.py --task dmc/cartpole-swingup --levels train dmcgb --seeds 0 1 2
    python examples/gallery.py --levels video_hard --level-option videos=/data/dmcgb/video_hard
    python examples/gallery.py --task robosuite/door                # every robosuite level; seeds pick the scenes
    python examples/gallery.py --task adroit/door                   # writes docs/gallery_adroit-door.png

``--factors`` shows every factor of the task's suite (``vigen.envs.factors``) instead: one row
per factor, one column per intensity (``--intensities``, default 0.1 0.3 0.5), all at the first
seed. An existing file is never overwritten: the new grid gets the next free name (``-1``,
``-2``, ...) unless ``--overwrite`` is given.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import vigen  # noqa: F401  (selects the EGL backend before mujoco is imported)
import cv2
import numpy as np
from vigen.envs import level_options_for, factors, get_suite, make_env
from vigen.envs.levels import resolve_levels
from vigen.evaluation import sweep
from vigen.io import unused_path
from vigen.rendering import RenderSettings

DMC_LEVELS = [
    "train", "color_easy", "color_hard", "objects_color_hard", "floor_texture", "video_easy", "video_hard",
    "light_easy", "light_hard", "camera_easy", "camera_hard", "gaussian_noise_3", "gaussian_blur_3",
    "jpeg_compression_5", "contrast_3", "brightness_3",
]
LABEL_WIDTH, SCALE = 190, 2


def first_frame(task: str, level: str | dict[str, float], seed: int, fast: bool, options: dict[str, str]) -> np.ndarray:
    """The newest RGB frame of the reset observation of ``level`` at ``seed``."""
    env = make_env(task, generalization=level, seed=seed, level_options=level_options_for(task, level, options),
                   render_settings=RenderSettings.fast() if fast else None)
    frame = env.reset()["pixels"][-3:].permute(1, 2, 0).numpy()
    env.close()
    return frame


def first_frames(task: str, level: str, seeds: list[int], fast: bool, options: dict[str, str]) -> list[np.ndarray]:
    """The newest RGB frame of the reset observation, one per seed (each seed its own episode)."""
    return [first_frame(task, level, seed, fast, options) for seed in seeds]


def labelled_row(level: str, frames: list[np.ndarray]) -> np.ndarray:
    tiles = np.concatenate(frames, axis=1).repeat(SCALE, axis=0).repeat(SCALE, axis=1)
    label = np.full((tiles.shape[0], LABEL_WIDTH, 3), 255, np.uint8)
    cv2.putText(label, level, (6, tiles.shape[0] // 2 + 5), cv2.FONT_HERSHEY_SIMPLEX, 0.5, (0, 0, 0), 1, cv2.LINE_AA)
    return np.concatenate([label, tiles], axis=1)


def header(titles: list[str], tile_width: int) -> np.ndarray:
    """A white strip with one centred title above each column of tiles."""
    strip = np.full((24, LABEL_WIDTH + tile_width * len(titles), 3), 255, np.uint8)
    for index, title in enumerate(titles):
        width = cv2.getTextSize(title, cv2.FONT_HERSHEY_SIMPLEX, 0.5, 1)[0][0]
        x = LABEL_WIDTH + index * tile_width + (tile_width - width) // 2
        cv2.putText(strip, title, (x, 17), cv2.FONT_HERSHEY_SIMPLEX, 0.5, (0, 0, 0), 1, cv2.LINE_AA)
    return strip


def factor_grid(task: str, sweeps: dict[str, list[dict[str, float]]], seed: int, fast: bool,
                options: dict[str, str]) -> np.ndarray:
    """Rows: factors; columns: the intensities of their sweeps; each tile the reset frame at ``seed``."""
    rows = []
    for factor, levels in sweeps.items():
        rows.append(labelled_row(factor, [first_frame(task, level, seed, fast, options) for level in levels]))
        print(f"  {factor}", flush=True)
    intensities = [level.intensity for level in next(iter(sweeps.values()))]
    tile_width = (rows[0].shape[1] - LABEL_WIDTH) // len(intensities)
    return np.concatenate([header([f"x = {x:g}" for x in intensities], tile_width), *rows], axis=0)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--task", default="dmc/walker-walk")
    parser.add_argument("--levels", nargs="+", default=None,
                        help="level or group names (see docs/levels.md); default: every scene level of the task's suite")
    parser.add_argument("--seeds", nargs="+", type=int, default=[0, 1, 2, 3, 4], help="with --factors: the first one")
    parser.add_argument("--factors", action="store_true",
                        help="one row per factor of the task's suite, one column per intensity, instead of levels × seeds")
    parser.add_argument("--intensities", nargs="+", type=float, default=[0.1, 0.3, 0.5],
                        help="the columns of --factors, each in [0, 1]")
    parser.add_argument("--fast", action="store_true", help="CPU-friendly render settings")
    parser.add_argument("--level-option", action="append", default=[], metavar="KEY=VALUE",
                        help="passed to the levels' transforms, e.g. videos=/path or palette=/path/color_hard.pt")
    parser.add_argument("--out", type=Path, help="default: docs/gallery_<task>.png (dmc), docs/gallery_<suite>-<task>.png")
    parser.add_argument("--overwrite", action="store_true")
    args = parser.parse_args()

    options = dict(option.split("=", 1) for option in args.level_option)
    suite, name = args.task.split("/", 1)
    if args.factors:
        if args.levels:
            parser.error("--levels and --factors draw different grids; give one of them.")
        outside = [x for x in args.intensities if not 0.0 <= x <= 1.0]
        if outside:
            parser.error(f"--intensities must be in [0, 1] (0: the factor off, 1: its strongest setting), got {outside}.")
        try:
            sweeps = {factor: sweep(factor, args.intensities) for factor in factors(args.task)}
        except ValueError as error:
            parser.error(f"--intensities: {error}")
        grid = factor_grid(args.task, sweeps, args.seeds[0], args.fast, options)
        shape = f"{len(sweeps)} factors x {len(args.intensities)} intensities"
    else:
        levels = resolve_levels(args.levels or (DMC_LEVELS if suite == "dmc" else get_suite(suite).levels_for(name)), suite=suite)
        rows = [labelled_row(level, first_frames(args.task, level, args.seeds, args.fast, options)) for level in levels]
        grid = np.concatenate(rows, axis=0)
        shape = f"{len(levels)} levels x {len(args.seeds)} seeds"

    kind = "factors_" if args.factors else ""
    out = args.out or Path("docs") / f"gallery_{kind}{name if suite == 'dmc' else f'{suite}-{name}'}.png"
    out = out if args.overwrite else unused_path(out)
    out.parent.mkdir(parents=True, exist_ok=True)
    if not cv2.imwrite(str(out), cv2.cvtColor(grid, cv2.COLOR_RGB2BGR)):
        raise OSError(f"could not write {out}")
    print(f"wrote {out}: {shape} of {args.task}")


if __name__ == "__main__":
    main()
