"""How far the same seeded episodes of a shipped agent move when only the CPU kernels of its network change.

The shipped agents' provenance tables, the README's demo table and a re-run on another machine give
different returns for the same seeded episodes, while the random policy's returns are bit-identical
(the physics, the seeds and the level draws agree; the rendered frames too: ``scripts/golden_frames.py``
hashes match across machines). This script plays the same episodes with the same weights under oneDNN's
instruction sets (``ONEDNN_MAX_CPU_ISA``: the widest this CPU has, ``AVX2``, ``SSE41``) and with oneDNN
off (``torch.backends.mkldnn.enabled = False``), each in its own process, and prints every return and,
per agent, the spread against the first setting and against the provenance table's returns.

    python benchmarks/float_rounding_returns.py --episodes 3
    python benchmarks/float_rounding_returns.py --episodes 3 --level color_hard   # no provenance column off train

A difference here can only come from the float rounding of the network's convolutions: the encoder's
output moves in its last bits, the action by ~1e-6, and a 500-step closed loop (cartpole) carries that
into a different trajectory.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys

SETTINGS = {"native": {}, "avx2": {"ONEDNN_MAX_CPU_ISA": "AVX2"}, "sse41": {"ONEDNN_MAX_CPU_ISA": "SSE41"},
            "no-onednn": {"VIGEN_NO_MKLDNN": "1"}}
AGENTS = ("drqv2-cartpole-balance", "svea-cartpole-balance")


def play(episodes: int, level: str) -> dict:
    """The returns of both shipped agents at ``level`` in this process (seed 0, their evaluation settings)."""
    import torch

    torch.set_num_threads(1)
    if os.environ.get("VIGEN_NO_MKLDNN"):
        torch.backends.mkldnn.enabled = False
    from vigen.evaluation import evaluate
    from vigen.pretrained import load_policy
    from vigen.rendering import RenderSettings

    options = {"render_settings": RenderSettings.fast(), "action_repeat": 2, "frame_stack": 3, "image_size": 84}
    return {name: [row["return"] for row in evaluate(load_policy(name, device="cpu"), "dmc/cartpole-balance", [level],
                                                       episodes=episodes, seeds=[0], env_options=options)]
            for name in AGENTS}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--episodes", type=int, default=3)
    parser.add_argument("--level", default="train", help="the level the episodes play (default: train)")
    parser.add_argument("--child", action="store_true", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.child:
        print(json.dumps(play(args.episodes, args.level)))
        return
    from vigen.pretrained import info

    results = {}
    for name, extra in SETTINGS.items():
        done = subprocess.run([sys.executable, __file__, "--child", "--episodes", str(args.episodes), "--level", args.level], check=True,
                              capture_output=True, text=True, env={**os.environ, **extra})
        results[name] = json.loads(done.stdout.strip().splitlines()[-1])
    for agent in AGENTS:
        print(f"\n{agent}, {args.level}, seed 0, episodes 0-{args.episodes - 1}")
        recorded = [] if args.level != "train" else next(
            level["returns"] for level in info(agent)["evaluation"] if level["level"] == "train")[:args.episodes]
        if recorded:
            print(f"  {'provenance table':16s} " + " ".join(f"{value:9.3f}" for value in recorded))
        for name in SETTINGS:
            values = results[name][agent]
            print(f"  {name:16s} " + " ".join(f"{value:9.3f}" for value in values))
        first = results["native"][agent]
        moves = [other - base for name in SETTINGS for other, base in zip(results[name][agent], first)]
        against = [value - base for name in SETTINGS for value, base in zip(results[name][agent], recorded)]
        print(f"  across kernels: {min(moves):+.1f} to {max(moves):+.1f}" + (
            f"; against the provenance table: {min(against):+.1f} to {max(against):+.1f}" if against else ""))


if __name__ == "__main__":
    main()
