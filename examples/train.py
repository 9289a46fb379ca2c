"""Train an augmentation-based agent from pixels with vigen and TorchRL: the whole run, top to bottom, in ``main``.

    python examples/train.py --algo svea --env dmc/cartpole-balance --preset cpu --frames 20000
    python examples/train.py --resume runs/svea-cartpole-balance-s0 --frames 40000     # continue it, exactly
    python examples/train.py --recipe svea-dmcgb --env dmc/walker-walk                   # DMC-GB's SVEA, its settings
    python examples/train.py --algo svea --env dmc/walker-walk --protocol dmcgb          # DMC-GB's protocol
    python examples/train.py --algo svea --env dmc/walker-walk --ray --workers 2         # collect on Ray
    python examples/train.py --env dmc/walker-walk --preset paper --device cuda --workers 8 --overlap --replay-on-device

The run's settings are ``vigen.run.TrainConfig`` (saved as the run folder's ``config.json``) and ``Launch`` below (how
this command runs them); ``--help`` lists every flag. What a run folder holds, what ``--resume`` guarantees (a run killed
at any moment, even while it writes a checkpoint, resumes bit for bit) and what each flag does: docs/training.md.
"""

from __future__ import annotations

import contextlib
import os
import sys
import time
from dataclasses import dataclass, replace
from functools import partial
from pathlib import Path
from typing import Annotated

import torch
from torchrl.envs import RewardSum, TransformedEnv
from torchrl.envs.transforms import MultiStepTransform
from torchrl.record.loggers import get_logger
from tqdm import tqdm

from vigen.devices import resolve_device
from vigen.envs import add_step_timers, make_env
from vigen.evaluation import evaluate
from vigen.io import FolderInUse, RunFolderLock
from vigen.losses import update_metrics
from vigen.ray_cluster import ray_session
from vigen.rendering import RenderSettings, render_on_cuda_device, renderer_name
from vigen.run import (RayAddress, RunReplay, RunSchedule, SegmentCollectors, StageTimes, TrainConfig, TrainingState,
                       build_agent, check_device_fits, check_runnable, list_recipes, make_update, new_config,
                       new_run_folder, parse_flags, resumed_run_config, unset_means)
from vigen.run.checkpoint import CheckpointError


@dataclass(frozen=True)
class Launch:
    """How this command runs its config: not saved in config.json, so a resumed run may change them (not --out)."""

    out: Annotated[Path | None, unset_means("runs/<algo>-<task>-s<seed>")] = None
    """run folder"""
    resume: Annotated[Path | None, unset_means("none")] = None
    """a run folder to continue up to --frames"""
    threads: Annotated[int | None, unset_means("torch's choice")] = None
    """torch threads"""
    device: str = "auto"
    ("where the networks, optimizer, updates and policies run: auto (CUDA when present), cpu, cuda, cuda:N; envs step "
     "on the CPU. A resumed run may change it.")
    ray: Annotated[RayAddress, unset_means("no Ray")] = None
    """collect on Ray (--collector ray): a local cluster on 127.0.0.1, or the cluster at ADDRESS"""
    ray_address: Annotated[str | None, unset_means("start a local one on 127.0.0.1")] = None
    """with --collector ray: the cluster to join (--ray ADDRESS says both)"""
    replay_on_device: bool = False
    ("keep a copy of the replay buffer in --device's memory and sample from it (a 1M-transition buffer of 84x84 frames "
     "needs ~128 GB, a 100k one ~13 GB); the memory-mapped buffer in the run folder gets every transition too and stays"
     " what --resume restores")
    time_stages: bool = False
    ("log where the time goes, per collector batch (logs/scalars/time/): the env workers' step, physics, render and "
     "policy, and the loop's wait, store, sample and update; on CUDA the GPU's busy share over one batch")


def parse_args(argv: list[str] | None = None) -> tuple[TrainConfig, Launch]:
    """The run's config (a new one from the flags typed, or the resumed run's) and this command's launch options,
    checked."""
    parsed = parse_flags({"config": TrainConfig, "launch": Launch}, argv, description=__doc__)
    flags, launch = parsed.given("config"), parsed.settings["launch"]
    if flags.get("recipe") == "list":
        print(list_recipes())
        raise SystemExit(0)
    if launch.ray is not None:  # --ray [ADDRESS] is --collector ray [--ray-address ADDRESS]
        if flags.setdefault("collector", "ray") != "ray" or launch.ray_address is not None:
            raise SystemExit("--ray is --collector ray with its cluster; drop --collector local or --ray-address.")
        launch = replace(launch, ray_address=None if launch.ray == "local" else launch.ray)
    try:
        if launch.resume is not None and launch.out is not None:
            raise ValueError("--out and --resume: a resumed run stays in its folder; drop --out.")
        config = new_config(flags) if launch.resume is None else resumed_run_config(launch.resume, flags)
        config.check()
        check_runnable(config)
    except ValueError as error:
        raise SystemExit(str(error)) from None
    if launch.threads is not None and launch.threads < 1:
        raise SystemExit(f"--threads must be >= 1, got {launch.threads}.")
    if launch.ray_address is not None and config.collector != "ray":
        raise SystemExit("--ray-address names the Ray cluster of --collector ray; add --collector ray or drop it.")
    return config, launch


def hold(run_dir: Path) -> RunFolderLock:
    """The run folder's writer lock, or stop naming the process that holds it."""
    try:
        return RunFolderLock(run_dir).acquire()
    except FolderInUse as error:
        raise SystemExit(f"{run_dir}: {error}") from None


def training_env(name: str, seed: int, time_stages: bool = False, worker: int | None = None, **options) -> TransformedEnv:
    """The suite's pixels (uint8 [9, 84, 84]), rendered fast, with episode returns summed; with ``time_stages``, each step's
    time (:func:`vigen.envs.add_step_timers`), and an env worker says what it renders with."""
    env = make_env(name, seed=seed, render_settings=RenderSettings.fast(), **options).append_transform(RewardSum())
    if time_stages and worker is not None:
        egl = os.environ.get("MUJOCO_EGL_DEVICE_ID", "unset")
        print(f"env worker {worker} renders with {renderer_name(env)} (MUJOCO_EGL_DEVICE_ID={egl})", flush=True)
    return add_step_timers(env) if time_stages else env


def main(argv: list[str] | None = None) -> None:
    # config: every setting checked before any work; a second writer of a resumed run stops at once
    config, launch = parse_args(argv)
    lock = None if launch.resume is None else hold(launch.resume)
    try:
        device = resolve_device(launch.device)
    except ValueError as error:
        raise SystemExit(f"--device: {error}") from None
    if launch.threads:
        torch.set_num_threads(launch.threads)
    if device.type == "cuda":  # env workers render on this GPU's EGL device (before anything imports MuJoCo's EGL backend)
        egl = render_on_cuda_device(device.index if device.index is not None else torch.cuda.current_device())
        if egl is not None:
            print(f"MuJoCo renders on EGL device {egl} (MUJOCO_EGL_DEVICE_ID), the one of {device}", flush=True)
    torch.manual_seed(config.seed)
    if config.describe():
        print("\n".join(config.describe()), flush=True)

    # env: the suite's pixels, with the protocol's options of its training envs; the run folder once the env is known
    make = partial(training_env, config.env, time_stages=launch.time_stages, **config.training_env_options())
    probe = make(seed=config.seed)
    action_repeat, action_spec = probe.base_env.action_repeat, probe.action_spec
    observation_shape = tuple(probe.observation_spec["pixels"].shape)
    if launch.time_stages:
        print(f"this process renders with {renderer_name(probe)}", flush=True)
    probe.close()
    if config.eval_every < action_repeat:
        raise SystemExit(f"--eval-every {config.eval_every} is below one agent step ({action_repeat} frames with "
                         f"{config.env}'s action repeat); raise it.")
    if launch.resume is None:  # made only now, after every check passed
        config = replace(config, observation_shape=observation_shape, action_dim=action_spec.shape[-1])
        run_dir = new_run_folder(config, launch.out)
        lock = hold(run_dir)
    else:
        run_dir = launch.resume
    print(f"run folder: {run_dir}", flush=True)

    # loss and policy: a vigen loss on the paper's networks and its acting policy; Adam, the target update, the schedule
    agent = build_agent(config, action_spec, device=device)
    update = make_update(config, agent.loss, device)
    if config.compile and device.type == "cuda" and not update.cudagraph:
        print("compiled without a CUDA graph: the update schedule (actor / target every N updates) alternates two "
              "graphs, which vigen has not checked as CUDA graphs", flush=True)

    # replay: uint8 n-step transitions memory-mapped in the run folder (--replay-on-device: sampled from a copy in the
    # device's memory); the journal keeps the slots the last checkpoint counts until the next one
    if launch.replay_on_device and device.type == "cuda" and config.observation_shape is not None:
        try:
            check_device_fits(config.buffer_size, config.observation_shape, device)
        except ValueError as error:
            raise SystemExit(str(error)) from None
    replay = RunReplay(config.buffer_size, config.batch_size, run_dir / "replay_buffer" / "storage", device,
                       on_device=launch.replay_on_device, n_step=MultiStepTransform(config.n_step, config.gamma),
                       reward_scale=agent.reward_scale, journal=run_dir / "replay_buffer" / "journal")
    logger = get_logger(config.logger, logger_name=str(run_dir), experiment_name="logs",
                        **({"offline": True} if config.logger == "wandb" else {}))
    schedule, state = RunSchedule.of(config, action_repeat), TrainingState(run_dir, agent.loss, agent.policy, update, replay)
    steps = updates = 0  # agent steps collected, gradient updates made
    if launch.resume is not None:  # everything as it was when the newest checkpoint that loads was written
        try:
            resumed = state.restore()
        except CheckpointError as error:
            raise SystemExit(f"--resume {run_dir}: {error}") from None
        print(f"resuming from {resumed.checkpoint.name}", flush=True)
        for note in resumed.notes:
            print(note, file=sys.stderr)
        steps, updates = resumed.steps, resumed.updates
    if note := schedule.frames_note(steps):
        print(note, flush=True)

    timing, noise = StageTimes(logger.log_scalar, device, enabled=launch.time_stages), agent.exploration_noise

    def learn():
        """One gradient update on a sampled batch (issue 48's SampledUpdate over a FrameReplay is this call, captured)."""
        with timing.clock("sample"):
            batch = replay.sample()  # on the device: pinned and copied without blocking, or gathered there
        with timing.clock("update"):
            return update(batch)

    # the loop: each segment collects up to the next checkpoint (storing, updating as due), evaluates and checkpoints
    collectors, compiled = SegmentCollectors(make, agent.policy, config, schedule), False
    with lock, contextlib.ExitStack() as session:
        if config.collector == "ray":  # one cluster for the whole run; collectors come and go with segments
            session.enter_context(ray_session(launch.ray_address))
        session.callback(collectors.shutdown)
        progress = tqdm(total=schedule.total_steps * action_repeat, initial=steps * action_repeat, unit="frame",
                        dynamic_ncols=True)
        while steps < schedule.total_steps:
            for batch in timing.batches(collectors.segment(steps)):  # collect (--overlap: the next batch meanwhile)
                new, steps = batch.numel(), steps + batch.numel()
                frames = steps * action_repeat
                with timing.clock("store"):  # store; the segment's last batch ends its episode, n-step targets bootstrap
                    ends = batch["next", "done"].squeeze(-1)
                    if ends.any():
                        logger.log_scalar("train/episode_reward", batch["next", "episode_reward"][ends].mean().item(), step=frames)
                    if schedule.ends_segment(steps - new, steps):
                        batch["next", "truncated"][..., -1, :] = True
                        batch["next", "done"][..., -1, :] = True
                    replay.store(batch)
                    if noise is not None:
                        noise.step(new)  # the exploration noise follows the std schedule
                    progress.update(new * action_repeat)
                # update: one per --update-every agent steps after the seed steps (--seed-catch-up: theirs too, at once)
                counted = steps if config.seed_catch_up else steps - schedule.seed_steps
                due = max(counted // config.update_every - updates if steps >= schedule.seed_steps else 0, 0)
                started = time.perf_counter()
                agent.loss.set_step(steps)
                for _ in range(due):
                    out = learn()
                    updates += 1
                if due:
                    with timing.clock("update"):
                        update.raise_if_diverged()  # the metrics stay on the device until here: one read per batch
                    for key, value in update_metrics(out).items():
                        logger.log_scalar(f"train/{key}", value, step=frames)
                    logger.log_scalar("train/seconds_per_update", (time.perf_counter() - started) / due, step=frames)
                    if update.compile_seconds is not None and not compiled:
                        logger.log_scalar("train/compile_seconds", update.compile_seconds, step=frames)
                        print(f"compiled the update in {update.compile_seconds:.1f} s", flush=True)
                        compiled = True
                timing.log(frames, new, due)
            # evaluate: the protocol's test envs at its evaluation seed; checkpoint: what resume needs, ending the segment
            frames = steps * action_repeat
            rows = evaluate(agent.policy, config.env, list(config.eval_levels), episodes=config.eval_episodes,
                            seeds=[config.evaluation_seed()], device=device, protocol=config.protocol,
                            env_options={"render_settings": RenderSettings.fast(), **config.test_env_options()})
            for level in config.eval_levels:
                returns = [row["return"] for row in rows if row["level"] == level]
                logger.log_scalar(f"eval/{level}_return", sum(returns) / len(returns), step=frames)
            first = [row["return"] for row in rows if row["level"] == config.eval_levels[0]]
            progress.set_postfix(eval=round(sum(first) / config.eval_episodes))
            state.save(frames, steps, updates)
        progress.close()
    # report: the run folder holds the checkpoints, the logs (train/, eval/ and time/ scalars) and config.json
    print(f"trained {steps * action_repeat} frames: {run_dir}", flush=True)


if __name__ == "__main__":
    main()
