"""Golden frames: a small, exact record of what every named level renders at a fixed seed.

For each suite, task and level, the env is built at ``seed=3`` with 48×48 frames and the fast
render settings, and played for two short episodes (reset, 2 zero-action steps; reset, 1 step).
The newest frames of the observations are kept as their SHA-256 (exact) and the per-frame,
per-channel means (for a readable report when the hash changes).

    python scripts/golden_frames.py --out test/envs/golden_frames.json               # every suite
    python scripts/golden_frames.py --out /tmp/after.json --frames /tmp/after.npz    # also the full frames
    python scripts/golden_frames.py --out test/envs/golden_frames.json --only 'dmc/*:color_*'  # re-record these, keep the rest

``test/envs/test_golden_frames.py`` renders the same frames and compares them with the file, so
a change of any level's pixels is caught. Regenerate it only when a level is meant to change.
"""

from __future__ import annotations

import argparse
import fnmatch
import hashlib
import json
from pathlib import Path
from typing import Any

import vigen  # noqa: F401  (selects the EGL backend before mujoco is imported)
import numpy as np
import torch
from vigen.io import atomic_write
from vigen.rendering import RenderSettings

SEED = 3
IMAGE_SIZE = 48
PLAY = (2, 1)
"""Zero-action steps in each of the two episodes."""


def cases() -> list[tuple[str, str]]:
    """(env name, level) for every named level of every suite; robosuite, Adroit and loco on each of their tasks."""
    from vigen.envs import SUITES

    found = []
    for suite in SUITES.values():
        tasks = [suite.example_task] if suite.name == "dmc" else list(suite.tasks())
        found += [(f"{suite.name}/{task}", level) for task in tasks for level in suite.levels_for(task)]
    return found


def play(env_name: str, level: str) -> np.ndarray:
    """The newest RGB frame of every observation of the two short episodes, ``[frames, H, W, 3]`` uint8."""
    from vigen.envs import make_env

    env = make_env(env_name, generalization=level, seed=SEED, image_size=IMAGE_SIZE, render_settings=RenderSettings.fast())
    frames = []
    action = torch.zeros(env.action_spec.shape)
    for steps in PLAY:
        state = env.reset()
        frames.append(state["pixels"][-3:])
        for _ in range(steps):
            state = env.step(state.set("action", action))["next"]
            frames.append(state["pixels"][-3:])
    env.close()
    return torch.stack(frames).permute(0, 2, 3, 1).numpy()


def record(frames: np.ndarray) -> dict[str, Any]:
    """SHA-256 of the frames and their per-frame, per-channel means (rounded to 0.01)."""
    return {"sha256": hashlib.sha256(np.ascontiguousarray(frames).tobytes()).hexdigest(),
            "means": np.round(frames.mean(axis=(1, 2)), 2).tolist()}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, required=True, help="JSON file to write (replaced atomically)")
    parser.add_argument("--frames", type=Path, help="also save every full frame to this .npz file")
    parser.add_argument("--suites", nargs="+", help="only these suites (dmc, robosuite, adroit, loco)")
    parser.add_argument("--only", nargs="+", metavar="PATTERN",
                        help="only the entries 'env:level' matching one of these shell patterns; the other entries of an "
                             "existing --out file are kept as they are")
    args = parser.parse_args()

    kept = {}
    if args.only and args.out.exists():
        kept = json.loads(args.out.read_text())["levels"]
    results, full = {}, {}
    for env_name, level in cases():
        if args.suites and env_name.split("/")[0] not in args.suites:
            continue
        if args.only and not any(fnmatch.fnmatchcase(f"{env_name}:{level}", pattern) for pattern in args.only):
            continue
        frames = play(env_name, level)
        results[f"{env_name}:{level}"] = record(frames)
        full[f"{env_name}:{level}"] = frames
        print(f"{env_name:32s} {level:24s} {results[f'{env_name}:{level}']['sha256'][:12]}", flush=True)
    if kept:  # the file's order: re-recorded entries in place, new ones at the end
        results = {**{name: results.get(name, entry) for name, entry in kept.items()}, **results}
    payload = {"seed": SEED, "image_size": IMAGE_SIZE, "play": list(PLAY), "levels": results}
    atomic_write(args.out, json.dumps(payload, indent=1) + "\n")
    if args.frames:
        np.savez_compressed(args.frames, **full)


if __name__ == "__main__":
    main()
