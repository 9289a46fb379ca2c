"""Per-step cost of the Distracting Control Suite's skybox video (the DCS levels' default) against the screen-space composite, in the same run.

The DCS level (``dcs_0.2`` by default) is built twice on the same task, seed and video folder:
with the video written into the skybox texture as DCS does (the default: one 800×800 face,
re-uploaded to the render context at every new video frame) and composited into the frame's
background pixels (``level_options={"skybox": False}``), and once more with a smaller sky face
(``--sky-size``, 256 by default). ``train``
(no perturbation) is timed too. Each is stepped with zero actions; the
figure is the median ms per agent step over ``--repeats`` blocks of ``--steps`` steps, timed in
alternation, and the ratio of the two DCS variants. First resets (which decode the episode's
video: at 84×84 for the composite, at the sky face's size for the skybox) are reported apart.

Without ``--videos`` a DAVIS-like folder (``ImageSets/2017/train.txt``, ``JPEGImages/480p``,
854×480 JPEG frames of noise) is written to a temporary folder.

Reproduce (about two minutes on 2 CPU cores):

    MUJOCO_GL=egl python benchmarks/dcs_skybox_cost.py
    MUJOCO_GL=egl python benchmarks/dcs_skybox_cost.py --level dcs_0.5 --videos ~/data/DAVIS
"""

from __future__ import annotations

import argparse
import tempfile
from pathlib import Path

import vigen  # noqa: F401  (selects the EGL backend before mujoco is imported)
import numpy as np
from level_speed import median_step_ms  # benchmarks/level_speed.py, beside this script
from vigen.envs import make_env


def write_davis_like(root: Path, videos: int = 8, frames: int = 50, seed: int = 0) -> Path:
    """A DAVIS 2017 layout of ``videos`` noise videos of ``frames`` 854×480 JPEG frames."""
    import cv2

    rng = np.random.default_rng(seed)
    names = [f"video{index:02d}" for index in range(videos)]
    (root / "ImageSets" / "2017").mkdir(parents=True)
    (root / "ImageSets" / "2017" / "train.txt").write_text("\n".join(names) + "\n")
    for name in names:
        folder = root / "JPEGImages" / "480p" / name
        folder.mkdir(parents=True)
        for frame in range(frames):
            cv2.imwrite(str(folder / f"{frame:05d}.jpg"), rng.integers(0, 256, (480, 854, 3), dtype=np.uint8))
    return root


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--task", default="dmc/walker-walk")
    parser.add_argument("--level", default="dcs_0.2")
    parser.add_argument("--videos", default=None, help="a DAVIS 2017 folder (default: a generated DAVIS-like one)")
    parser.add_argument("--steps", type=int, default=50)
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--image-size", type=int, default=84)
    parser.add_argument("--sky-size", type=int, default=256, help="also time the skybox with this smaller face (0: skip)")
    args = parser.parse_args()

    with tempfile.TemporaryDirectory() as scratch:
        videos = args.videos or str(write_davis_like(Path(scratch) / "DAVIS"))
        builds = {
            "train": dict(generalization="train"),
            "composite (skybox=False)": dict(generalization=args.level, level_options={"videos": videos, "skybox": False}),
            "skybox (DCS, default)": dict(generalization=args.level, level_options={"videos": videos}),
        }
        if args.sky_size:
            builds[f"skybox, sky_size={args.sky_size}"] = dict(
                generalization=args.level, level_options={"videos": videos, "sky_size": args.sky_size})
        envs = {name: make_env(args.task, seed=0, image_size=args.image_size, **kwargs) for name, kwargs in builds.items()}
        medians, resets = median_step_ms(envs, args.steps, args.repeats)
        print(f"{args.task} {args.level}, {args.image_size}px, default rendering, median of {args.repeats} blocks of "
              f"{args.steps} steps (action repeat 2)")
        print("| variant | ms/step | vs train | first reset (ms) |")
        print("|---|---|---|---|")
        for name in envs:
            print(f"| {name} | {medians[name]:.1f} | {medians[name] / medians['train']:.2f}x | {resets[name]:.0f} |")
        for name in list(envs)[2:]:
            print(f"{name} / composite: {medians[name] / medians['composite (skybox=False)']:.2f}x per step")
        for env in envs.values():
            env.close()


if __name__ == "__main__":
    main()
