"""Zero-shot evaluation throughput, episodes per minute: serial against Ray with 1 and 2 workers, in the same run.

A DrQ-v2 policy (the paper's network sizes, fresh weights) plays ``--levels`` × ``--seeds`` jobs of
``--episodes`` episodes each on ``--env`` (84 px, the fast render settings), three ways:

* ``serial``: ``evaluate(...)`` in this process with torch on one thread (the reference, ratio 1),
  and again on torch's default threads (one per core), what a plain serial run gets;
* ``ray, N workers``: ``evaluate(..., backend="ray", workers=N)`` on a local Ray cluster started
  once beforehand (its start-up is reported on its own line, not in the throughput).

Each way also checks that its rows equal the serial rows. Every job is an env built, its episodes
played and the env closed, so the work is independent and the expected speed-up is the number of
workers up to the cores (and the number of jobs), less Ray's per-task cost (shipping the policy,
starting an env in a fresh worker): on a machine with C free cores, ``--workers C`` should give
close to C times the serial rate when jobs outnumber cores and episodes last seconds.

Reproduce (about 2 and 5 minutes on 2 CPU cores, machine otherwise idle):

    python benchmarks/ray_evaluation.py
    python benchmarks/ray_evaluation.py --episode-length 1000 --episodes 2      # dm_control's full episodes
"""

from __future__ import annotations

import argparse
import time

import vigen  # noqa: F401  (selects the EGL backend before mujoco is imported)
import torch
from torchrl.data import Bounded
from vigen.envs import make_env
from vigen.evaluation import evaluate
from vigen.losses import make_loss
from vigen.ray_cluster import ray_session
from vigen.rendering import RenderSettings


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--env", default="dmc/walker-walk")
    parser.add_argument("--levels", nargs="+", default=["train", "color_hard", "video_easy", "camera_hard"])
    parser.add_argument("--seeds", nargs="+", type=int, default=[0, 1])
    parser.add_argument("--episodes", type=int, default=1, help="episodes per job")
    parser.add_argument("--episode-length", type=int, default=500, help="simulator steps per episode")
    parser.add_argument("--workers", nargs="+", type=int, default=[1, 2])
    args = parser.parse_args()

    probe = make_env(args.env, image_size=84)
    shape, action_dim = tuple(probe.observation_spec["pixels"].shape), probe.action_spec.shape[-1]
    probe.close()
    torch.manual_seed(0)
    policy = make_loss("drqv2", shape, action_dim, seed=0).make_policy(Bounded(-1.0, 1.0, shape=(action_dim,)))
    options = dict(episodes=args.episodes, seeds=args.seeds, env_options={
        "render_settings": RenderSettings.fast(), "episode_length": args.episode_length})
    episodes = len(args.levels) * len(args.seeds) * args.episodes

    default_threads = torch.get_num_threads()
    started = time.perf_counter()
    threaded = evaluate(policy, args.env, args.levels, **options)
    threaded_seconds = time.perf_counter() - started
    torch.set_num_threads(1)
    started = time.perf_counter()
    serial = evaluate(policy, args.env, args.levels, **options)
    reference = time.perf_counter() - started
    lines = [("serial (1 thread)", reference, "yes"),
             (f"serial ({default_threads} threads)", threaded_seconds, "yes" if threaded == serial else "to float rounding")]
    started = time.perf_counter()
    with ray_session() as ray:
        lines.append(("(Ray local cluster start)", time.perf_counter() - started, ""))
        cpus = int(ray.cluster_resources()["CPU"])
        for workers in args.workers:
            started = time.perf_counter()
            rows = evaluate(policy, args.env, args.levels, backend="ray", workers=workers, **options)
            lines.append((f"ray, {workers} worker{'s' * (workers > 1)}", time.perf_counter() - started,
                          "yes" if rows == serial else "NO"))

    print(f"{args.env}: {len(args.levels)} levels x {len(args.seeds)} seeds x {args.episodes} episode(s) of "
          f"{args.episode_length} simulator steps, 84 px, DrQ-v2 policy; Ray cluster of {cpus} CPUs")
    print("| evaluation | seconds | episodes / min | speed-up vs serial | rows equal serial |")
    print("|---|---|---|---|---|")
    for name, seconds, same in lines:
        if name.startswith("("):
            print(f"| {name} | {seconds:.1f} | | | |")
            continue
        print(f"| {name} | {seconds:.1f} | {60 * episodes / seconds:.1f} | {reference / seconds:.2f}x | {same} |")


if __name__ == "__main__":
    main()
