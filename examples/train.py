"""Train an augmentation-based agent from pixels on a dm_control, robosuite, Adroit or loco (Unitree, Franka) task, with vigen and TorchRL.

    python examples/train.py --algo svea --env dmc/cartpole-balance --preset cpu --frames 20000
    python examples/train.py --resume runs/svea-cartpole-balance-s0 --frames 40000   # continue it
    python examples/train.py --algo svea --env dmc/walker-walk --protocol dmcgb        # DMC-GB's protocol
    python examples/train.py --recipe svea-dmcgb --env dmc/walker-walk                 # DMC-GB's SVEA, its settings
    python examples/train.py --algo svea --env dmc/walker-walk --collector ray --workers 2  # collect on Ray
    python examples/train.py --env dmc/walker-walk --preset paper --device cuda --workers 8 --overlap --replay-on-device

The run folder (printed at start) gets ``config.json``, TorchRL CSV logs (``logs/scalars/*.csv``:
train losses, ``eval/return``), ``checkpoints/frames_XXXXXXXX.pt`` at every evaluation and the
replay buffer (memory-mapped in ``replay_buffer/storage``). ``--frames`` counts environment frames
(agent steps × action repeat), as in DrQ-v2's curves. Presets: ``paper`` is DrQ-v2 / RL-ViGen's
setup (batch 256, 1M-transition buffer, lr 1e-4, 3-step returns, τ = 0.01, 4000 seed frames, an
update every 2 agent steps); ``cpu`` is the same agent with batch 64 and a 100k buffer, to learn
easy tasks on a laptop CPU. Settings an algorithm's paper fixes are fields of its record in
``vigen.losses.ALGOS``, taken where the flags leave them unset (VRL3: a fixed exploration std of
0.01 and, on Adroit, RL-ViGen's reward scale, door ×1/20, hammer ×1/100, pen ×1/50).

One process writes a run folder at a time: a second ``--resume`` of a run in use stops at once,
naming the process that holds it (a lock that the OS drops when that process ends, so a killed
run never blocks its resume). The run trains whole collector batches: when ``--frames`` is not a
whole number of them, it says before it starts how many frames it trains, and why.

``--collector ray --workers N`` collects with TorchRL's ``RayCollector``: N Ray actors, each with
its own env (levels and perturbations run inside them), a batch from each per step, the policy's
weights (and its exploration σ) sent to them after every step's updates. It starts a local Ray
cluster on 127.0.0.1 (``pip install -e ".[ray]"``), or joins the one at ``--ray-address``. The run
folder, checkpoints and ``--resume`` are the same as with local workers.

Keeping a GPU busy (``docs/performance.md``, "End-to-end throughput"; ``benchmarks/train_throughput.py`` measures each):

* ``--workers N`` steps N envs in their own processes (TorchRL's ``MultiSyncCollector``), each batch
  ``50 × --update-every`` agent steps per worker; the updates due are the same per agent step
  whatever N is. On CUDA the workers render on the GPU's EGL device (``MUJOCO_EGL_DEVICE_ID``, set
  from ``--device``; a value you set yourself is kept).
* ``--overlap`` collects the next batch while the loop stores the last and updates on it: the
  workers (one process at least) act with a copy of the policy whose weights are sent between
  batches only, so batch k + 1 acts with the weights after batch k - 1's updates where the serial
  run uses those after batch k's: exactly one batch of updates behind, whatever the timing. The
  updates per agent step are the serial run's. The workers are kept for the whole run and
  reseeded at each segment's start. It is a setting of the run (saved in ``config.json``): it
  changes what is learned, slightly.
* ``--replay-on-device`` keeps a copy of the replay buffer in the device's memory and samples
  there; every transition still goes to the memory-mapped buffer in the run folder, which
  checkpoints count. Without it, batches bound for a GPU are gathered into pinned memory and
  copied without blocking.
* ``--time-stages`` logs, per collector batch, where the time goes (``logs/scalars/time/``).

``--recipe NAME`` (``--recipe list`` prints them; :data:`vigen.run.RECIPES`, docs/recipes.md) trains a method as its
original code does: vigen's loss with the original's options, its networks, per-module learning rates and Adam betas,
update schedule (seed steps, actor and targets every N updates, the target encoder's own rate, n-step, batch, buffer)
and the protocol it was published under. A flag that changes a recipe setting wins and is listed under
``recipe_overrides`` in ``config.json`` (``recipe_settings`` holds the recipe as the run was built); what vigen still
does differently is named by the recipe (``departures``). ``--recipe pieg-rlvigen`` loads torchvision's ImageNet
ResNet-18 from the data cache (``python -m vigen.datasets fetch torchvision-resnet18``).

``--protocol dmcgb|dmcgb2|rlvigen|drqv2|planet`` (see :mod:`vigen.protocols`) trains as that paper
did: its budget (DMC-GB's 500k *agent steps* become 2M frames at action repeat 4), its action
repeat for the task (DMC-GB: cartpole 8, finger 2, others 4), frame stack, image size, and its
evaluation while training (episodes, levels, how often). The run prints every value at its start
and ``config.json`` keeps them under ``protocol_settings``; an explicit flag wins over the protocol
and is listed under ``protocol_overrides``. ``examples/evaluate.py --compare`` reads them to put the
run beside the published numbers of the same protocol.

The flags are made from the fields of ``vigen.run.TrainConfig`` (the run's settings, saved in
``config.json``) and of ``Launch`` below (``--out``, ``--resume``, ``--threads``, ``--device``,
``--ray-address``: how this command runs them, not saved); ``--help`` lists them with their
defaults. The agent is ``vigen.run.build_agent(config, ...)``, as in ``examples/evaluate.py``.

What a run guarantees (``vigen.checkpoint`` does the work):

* Every argument is checked before the first frame, and a failed start leaves no run folder.
  ``--resume`` refuses flags that contradict the run's ``config.json`` (only ``--frames`` and
  the launch flags, ``--threads``, ``--device``, ``--ray-address``, ``--replay-on-device`` and
  ``--time-stages``, may change).
* Killed at any moment, even while a checkpoint is written, a run resumes exactly: counters,
  networks, optimizer, every random state, the replay buffer and the CSV logs end as in a run that
  was never killed. Checkpoints are written atomically and hold only tensors and plain data (loaded
  with ``weights_only=True``: a checkpoint can never run code); ``--resume`` takes the newest one
  that loads and prints the ones it skipped. The checkpoint holds the buffer's cursor and length
  and the n-step window; slots it counts valid are journaled before they are overwritten
  (``replay_buffer/journal``) and restored on resume; CSV rows logged after it are dropped.
* Each checkpoint ends a *segment*, in a resumed run and in one never killed alike: the episode in
  progress is cut there (marked truncated, so its n-step targets bootstrap), the collector is
  rebuilt and its env reset with seed ``derive_seed(seed, agent steps)`` (workers: one more index each, which also seeds their torch generators). With dm_control's defaults
  (1000-frame episodes, an evaluation every 10k frames) checkpoints fall on episode ends anyway.
* The same holds with ``--overlap``, exactly: which weights each batch acts with is fixed by the
  batch sequence (not by timing), the segment's last batch is awaited before its checkpoint, so
  nothing is collected past it, and each segment starts the kept workers afresh:
  ``set_seed(derive_seed(seed, agent steps))`` (TorchRL's chain: worker ``w`` gets the seed worker
  ``w - 1``'s env returned; each worker's env, perturbations, torch and numpy generators) and a
  reset. A resumed run builds its workers at the resume, without drawing from this process's
  generators, and the trajectory ids (which kept workers go on counting) are not stored.
  ``--replay-on-device`` is exact too: its copy is filled from the restored memory map. On a GPU,
  exact means the same kernels: the same device and torch.
  Not covered: wandb logs are not rewound, and falling back past a checkpoint that does not load
  keeps the transitions written after it in the overwritten slots (resume says so).
"""

from __future__ import annotations

import argparse
import contextlib
import copy
import dataclasses
import itertools
import json
import os
import sys
import time
from dataclasses import dataclass
from functools import partial
from pathlib import Path

import torch
from tensordict import TensorDict
from torchrl.collectors import Collector, MultiSyncCollector
from torchrl.data import TensorSpec
from torchrl.envs import RewardSum, TransformedEnv
from torchrl.envs.transforms import MultiStepTransform
from torchrl.record.loggers import get_logger
from tqdm import tqdm

from vigen.checkpoint import (CheckpointError, ReplayJournal, checkpoint_path, generator_states, load_optimizer_state,
                              multistep_state, newest_checkpoint, random_states, remove_temporary_files, replay_state,
                              restore_replay, save_checkpoint, set_generator_states, set_multistep_state,
                              set_random_states, truncate_csv_logs)
from vigen.devices import resolve_device
from vigen.envs import add_step_timers, make_env, step_times, without_step_times
from vigen.evaluation import evaluate
from vigen.io import FolderInUse, RunFolderLock, atomic_write, unused_path
from vigen.losses import update_metrics
from vigen.protocols import PROTOCOLS
from vigen.ray_cluster import ray_session
from vigen.rendering import RenderSettings, gl_renderer, render_on_cuda_device
from vigen.run import (RECIPES, CollectorBatches, GpuBusy, RunReplay, StageClock, TrainConfig, add_flags, build_agent,
                       check_runnable, given_flags, list_recipes, make_update, new_config, resumed_config, setting,
                       transition_bytes, worker_timeouts)
from vigen.seeding import ENV_SEED_LIMIT, derive_seed


@dataclass(frozen=True)
class Launch:
    """How this command runs its config: not saved in ``config.json``, so a resumed run may change them (not ``--out``)."""

    out: Path | None = setting(None, "run folder", unset="runs/<algo>-<task>-s<seed>")
    resume: Path | None = setting(None, "a run folder to continue up to --frames")
    threads: int | None = setting(None, "torch threads", unset="torch's choice")
    device: str = setting("auto", "where the networks, optimizer, updates and policies run: auto (CUDA when present), cpu, "
                                  "cuda, cuda:N; envs step on the CPU. A resumed run may change it.")
    ray_address: str | None = setting(None, "with --collector ray: the cluster to join",
                                        unset="start a local one on 127.0.0.1")
    replay_on_device: bool = setting(False, "keep a copy of the replay buffer in --device's memory and sample from it (a "
                                            "1M-transition buffer of 84x84 frames needs ~128 GB, a 100k one ~13 GB); the "
                                            "memory-mapped buffer in the run folder gets every transition too and stays what "
                                            "--resume restores")
    time_stages: bool = setting(False, "log where the time goes, per collector batch (logs/scalars/time/): the env workers' "
                                       "step, physics, render and policy, and the loop's wait, store, sample and update; on "
                                       "CUDA the GPU's busy share over one batch")


def make_parser() -> argparse.ArgumentParser:
    """The flags: one per field of TrainConfig (None unless given, so the preset, protocol or resumed run fills in) and of Launch."""
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    add_flags(parser, TrainConfig, given_only=True)
    add_flags(parser, Launch)
    return parser


def parse_args(argv: list[str] | None = None) -> tuple[TrainConfig, Launch]:
    """The run's config (a new one from the flags, or the resumed run's) and this command's launch options, all checked."""
    args = make_parser().parse_args(argv)
    launch = Launch(**{field.name: getattr(args, field.name) for field in dataclasses.fields(Launch)})
    flags = given_flags(args, TrainConfig)
    if flags.get("recipe") == "list":
        print(list_recipes())
        raise SystemExit(0)
    try:
        config = new_config(flags) if launch.resume is None else resumed(launch, flags)
        config.check()
        check_runnable(config)
    except ValueError as error:
        raise SystemExit(str(error)) from None
    if launch.threads is not None and launch.threads < 1:
        raise SystemExit(f"--threads must be >= 1, got {launch.threads}.")
    if launch.ray_address is not None and config.collector != "ray":
        raise SystemExit("--ray-address names the Ray cluster of --collector ray; add --collector ray or drop it.")
    return config, launch


def resumed(launch: Launch, flags: dict) -> TrainConfig:
    """The config of the run in ``--resume``'s folder, which the flags may not contradict."""
    if launch.out is not None:
        raise SystemExit("--out and --resume: a resumed run stays in its folder; drop --out.")
    if not (launch.resume / "config.json").is_file():
        raise SystemExit(f"--resume {launch.resume}: no config.json there; pass a run folder of examples/train.py.")
    try:
        return resumed_config(json.loads((launch.resume / "config.json").read_text()), flags)
    except ValueError as error:
        raise SystemExit(f"--resume {launch.resume}: {error}") from None


def hold(run_dir: Path) -> RunFolderLock:
    """The run folder's writer lock, or stop naming the process that holds it."""
    try:
        return RunFolderLock(run_dir).acquire()
    except FolderInUse as error:
        raise SystemExit(f"{run_dir}: {error}") from None


def frames_note(frames: int, action_repeat: int, steps: int, eval_every: int, batch_steps: int) -> str | None:
    """What the run trains when it is not ``frames``: the collector gathers whole batches of ``batch_steps`` agent steps.

    ``None`` when the run trains exactly ``frames`` (from ``steps`` agent steps already done).
    """
    total = frames // action_repeat
    done = steps
    while done < total:
        done += segment_batches(done, total, eval_every, batch_steps) * batch_steps
    if done * action_repeat == frames:
        return None
    if done == steps:
        return f"--frames {frames}: the run has trained {steps * action_repeat} frames already; nothing to train."
    rounded = f"; {frames} frames are {total} whole agent steps" if frames % action_repeat else ""
    return (f"--frames {frames}: training {done * action_repeat} frames, not {frames}: the collector gathers whole batches "
            f"of {batch_steps} agent steps ({batch_steps * action_repeat} frames at action repeat {action_repeat}){rounded}.")


def training_env(name: str, seed: int, time_stages: bool = False, **options) -> TransformedEnv:
    """The suite's pixels (uint8 [9, 84, 84]; DrQ-v2's action repeat 2 on dm_control), rendered fast, with episode returns summed
    (and, with ``time_stages``, each step's time: :func:`vigen.envs.add_step_timers`)."""
    env = make_env(name, seed=seed, render_settings=RenderSettings.fast(), **options).append_transform(RewardSum())
    return add_step_timers(env) if time_stages else env


def renderer_name(env: TransformedEnv) -> str:
    """Which OpenGL renderer ``env`` draws with (the GPU's name, or Mesa's ``llvmpipe``), for the run's output."""
    physics = getattr(env.base_env, "physics", None)
    try:
        return gl_renderer(physics) if physics is not None else "unknown (not a dm_control env)"
    except Exception as error:  # noqa: BLE001 - only a report
        return f"unknown ({type(error).__name__})"


def main() -> None:
    config, launch = parse_args()
    lock = None if launch.resume is None else hold(launch.resume)  # a second writer stops before any work
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
    if config.recipe is not None:
        print("\n".join(RECIPES[config.recipe].describe(config.env)) if config.recipe in RECIPES else
              f"recipe {config.recipe} (as recorded in config.json)", flush=True)
        for key, values in (config.recipe_overrides or {}).items():
            print(f"  overridden by a flag: {key} = {values['flag']} (recipe: {values['recipe']})", flush=True)
    if config.protocol is not None:
        print("\n".join(PROTOCOLS[config.protocol].describe(config.env)), flush=True)
        for key, values in (config.protocol_overrides or {}).items():
            print(f"  overridden by a flag: {key} = {values['flag']} (protocol: {values['protocol']})", flush=True)
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
    if launch.resume is None:  # the run folder is made only now, after every check passed
        config = dataclasses.replace(config, observation_shape=observation_shape, action_dim=action_spec.shape[-1])
        run_dir = unused_path(launch.out or Path("runs") / f"{config.algo}-{config.env.split('/', 1)[-1]}-s{config.seed}")
        run_dir.mkdir(parents=True)
        lock = hold(run_dir)
        atomic_write(run_dir / "config.json", json.dumps(config.to_json(), indent=2))
    else:
        run_dir = launch.resume
    print(f"run folder: {run_dir}", flush=True)
    training = Training(config, run_dir, make, action_spec, action_repeat, device, replay_on_device=launch.replay_on_device,
                        time_stages=launch.time_stages)
    if launch.resume is not None:
        training.resume()
    note = frames_note(config.frames, action_repeat, training.steps, training.eval_every,
                       training.steps_per_batch * config.workers)
    if note:
        print(note, flush=True)
    with lock, contextlib.ExitStack() as session:
        if config.collector == "ray":  # one cluster for the whole run; collectors come and go with segments
            session.enter_context(ray_session(launch.ray_address))
        training.run()


class Training:
    """A run's agent, update, replay buffer, logs and counters; each segment collects (updating as due), then evaluates and checkpoints."""

    def __init__(self, config: TrainConfig, run_dir: Path, make, action_spec: TensorSpec, action_repeat: int,
                 device: torch.device, *, replay_on_device: bool = False, time_stages: bool = False) -> None:
        self.config, self.run_dir, self.make, self.action_repeat, self.device = config, run_dir, make, action_repeat, device
        # the agent: a vigen loss on the paper's networks, its acting policy, Adam and the target-critic update
        self.agent = build_agent(config, action_spec, device=device)
        self.noise = self.agent.exploration_noise  # stepped with the frames collected; None: the policy samples (SAC)
        # Adam over the loss's groups, the target update and the schedule (vigen.run.make_update)
        self.update = make_update(config, self.agent.loss, device)
        if config.compile and device.type == "cuda" and not self.update.cudagraph:
            print("compiled without a CUDA graph: the update schedule (actor / target every N updates) alternates two "
                  "graphs, which vigen has not checked as CUDA graphs", flush=True)
        # replay: uint8 transitions memory-mapped in the run folder (and, --replay-on-device, copied into the device's
        # memory to sample from), n-step returns computed as trajectories come in; the journal keeps what the last
        # checkpoint counts valid until the next checkpoint
        self.storage_dir = run_dir / "replay_buffer" / "storage"
        if replay_on_device and device.type == "cuda" and config.observation_shape is not None:
            check_fits(config.buffer_size * transition_bytes(config.observation_shape), device)
        self.replay = RunReplay(config.buffer_size, config.batch_size, self.storage_dir, device, on_device=replay_on_device)
        self.journal = ReplayJournal(run_dir / "replay_buffer" / "journal", self.replay.disk)
        self.n_step = MultiStepTransform(config.n_step, config.gamma)  # holds back the last n steps of each batch
        self.steps, self.updates = 0, 0  # agent steps collected, gradient updates made
        self.compile_logged = False
        self.logger = get_logger(config.logger, logger_name=str(run_dir), experiment_name="logs",
                                 **({"offline": True} if config.logger == "wandb" else {}))
        self.total_steps = config.frames // action_repeat
        self.seed_steps = config.seed_steps if config.seed_steps is not None else config.seed_frames // action_repeat
        self.eval_every = config.eval_every // action_repeat
        self.steps_per_batch = 50 * config.update_every  # per worker
        self.progress: tqdm | None = None
        # --time-stages: wall seconds per stage of each collector batch, logged as time/*
        self.time_stages, self.clock, self.started = time_stages, StageClock(), time.perf_counter()
        self.update_batches = 0  # collector batches after which updates were made
        self.overlap_workers: tuple | None = None  # --overlap: (collector, its iterator, send weights), kept for the whole run

    def resume(self) -> None:
        """Restore everything from the newest checkpoint that loads, as it was when that checkpoint was written."""
        try:
            path, checkpoint, skipped = newest_checkpoint(self.run_dir / "checkpoints")
        except CheckpointError as error:
            raise SystemExit(f"--resume {self.run_dir}: {error}") from None
        for bad, why in skipped:
            print(f"skipped checkpoint {bad.name}: {why}", file=sys.stderr)
        for leftover in remove_temporary_files(self.run_dir / "checkpoints"):
            print(f"removed {leftover.name}, left by a run killed while writing a checkpoint", file=sys.stderr)
        print(f"resuming from {path.name}", flush=True)
        self.agent.loss.load_state_dict(checkpoint["loss"])
        load_optimizer_state(self.update.optimizer, checkpoint["optimizer"])  # this run's device flags, the file's moments
        self.agent.policy.load_state_dict(checkpoint["policy"])
        set_generator_states(self.agent.loss, checkpoint["generators"])
        set_random_states(checkpoint["random"])
        set_multistep_state(self.n_step, checkpoint["n_step"])
        restore_replay(self.replay.disk, checkpoint["replay"], self.storage_dir)
        for note in self.journal.rollback(checkpoint["replay"]):
            print(note, file=sys.stderr)
        self.replay.reload()  # the device copy, from the restored memory map
        for note in truncate_csv_logs(self.run_dir / "logs", checkpoint["frames"]):
            print(f"logs: {note}", file=sys.stderr)
        self.steps, self.updates = checkpoint["steps"], checkpoint["updates"]
        self.update.count = self.updates  # the schedule's phase (actor / target every N updates)

    def run(self) -> None:
        """Train up to the config's frames, one segment per checkpoint."""
        self.progress = tqdm(total=self.total_steps * self.action_repeat, initial=self.steps * self.action_repeat,
                             unit="frame", dynamic_ncols=True)
        try:
            while self.steps < self.total_steps:
                self.collect()
                self.evaluate_and_checkpoint()
        finally:
            if self.overlap_workers is not None:
                self.overlap_workers[0].shutdown()
        self.progress.close()

    def collect(self) -> None:
        """One segment: collect up to the next checkpoint with a fresh collector (``--overlap``: the kept, reseeded workers),
        storing each batch and updating as due.

        Serial: each batch is collected after the updates due so far, with their weights. ``--overlap``: the next batch
        collects while this one is stored and updated on (:class:`vigen.run.CollectorBatches`), one batch of updates
        behind; the segment's last batch is awaited before the checkpoint, so nothing is in flight when it is written.
        """
        env_seed = derive_seed(self.config.seed, self.steps, below=ENV_SEED_LIMIT)
        count = segment_batches(self.steps, self.total_steps, self.eval_every, self.steps_per_batch * self.config.workers)
        if self.config.overlap:
            collector, running, sync_weights = self.overlapped_workers(env_seed)
            sync_weights()  # the segment's first batch acts with every update so far, as after a rebuild
            collector.set_seed(env_seed)  # each worker's env, perturbations, torch and numpy reseeded (a chain from env_seed), reset
            source = itertools.islice(running, count)
        else:
            collector, sync_weights = make_collector(self.make, self.agent.policy, self.config, env_seed=env_seed,
                                                     steps_per_batch=self.steps_per_batch, batches=count,
                                                     random_steps=max(0, self.seed_steps - self.steps))
            source = collector
        batches = CollectorBatches(source, sync_weights, overlap=self.config.overlap)
        iterator = iter(batches)
        while True:
            busy = GpuBusy(self.device) if self.time_stages and self.device.type == "cuda" and self.update_batches == 1 else None
            if busy is not None:  # one whole batch, end to end, once the updates have started (compilation done)
                busy.start()
            batch = next(iterator, None)
            if batch is None:
                if busy is not None:
                    busy.stop()
                break
            for stage in ("collect", "wait", "sync"):
                self.clock.add(stage, getattr(batches, f"{stage}_seconds"))
            env_times = None
            if self.time_stages:
                env_times, batch = step_times(batch), without_step_times(batch)
            with self.clock("store"):
                self.store(batch)
            updates = self.update_as_due()
            if self.time_stages:
                self.log_stages(batch.numel(), updates, env_times, busy.stop() if busy is not None else None)
        if not self.config.overlap:
            collector.shutdown()

    def overlapped_workers(self, env_seed: int) -> tuple:
        """``--overlap``'s collector, built at the first segment (of this process) for the rest of the run.

        A run never killed builds it once, a resumed run at its resume: so that both go on alike, building it draws
        nothing from this process's random generators (their states are put back), every segment starts by reseeding
        and resetting the workers, and the trajectory ids, which a kept collector keeps counting, are not stored.
        """
        if self.overlap_workers is None:
            batch_steps = self.steps_per_batch * self.config.workers
            saved = random_states()
            collector, send_weights = make_collector(
                self.make, self.agent.policy, self.config, env_seed=env_seed, steps_per_batch=self.steps_per_batch,
                batches=-(-(self.total_steps - self.steps) // batch_steps), random_steps=max(0, self.seed_steps - self.steps))
            set_random_states(saved)
            self.overlap_workers = (collector, iter(collector), send_weights)
        return self.overlap_workers

    def store(self, batch: TensorDict) -> None:
        """Count a batch, log its finished episodes, store its n-step transitions; the segment's last batch cuts its episode."""
        new = batch.numel()
        self.steps += new
        if self.config.overlap:  # a kept collector's trajectory ids go on counting across segments, a rebuilt one's restart
            batch = batch.exclude("collector")
        frames = self.steps * self.action_repeat
        episode_ends = batch["next", "done"].squeeze(-1)
        if episode_ends.any():
            self.logger.log_scalar("train/episode_reward", batch["next", "episode_reward"][episode_ends].mean().item(), step=frames)
        if self.steps // self.eval_every > (self.steps - new) // self.eval_every or self.steps >= self.total_steps:
            batch["next", "truncated"][..., -1, :] = True  # the episode in progress ends with the segment:
            batch["next", "done"][..., -1, :] = True  # its n-step targets bootstrap there
        transitions = self.n_step.inv(batch)  # [time] or [workers, time], with n-step rewards and next pixels
        if transitions is not None:
            if self.agent.reward_scale != 1:
                transitions.set(("next", "reward"), transitions["next", "reward"] * self.agent.reward_scale)
            self.journal.protect(transitions.numel())
            self.replay.extend(transitions.reshape(-1))
        if self.noise is not None:
            self.noise.step(new)  # the exploration noise follows the std schedule
        self.progress.update(new * self.action_repeat)

    def update_as_due(self) -> int:
        """The gradient updates due after the seed steps (one per ``update_every`` agent steps; with ``--seed-catch-up`` the
        seed steps' too, made when they end), then their metrics; how many."""
        counted = self.steps if self.config.seed_catch_up else self.steps - self.seed_steps
        due = counted // self.config.update_every - self.updates if self.steps >= self.seed_steps else 0
        started = time.perf_counter()
        self.agent.loss.set_step(self.steps)
        for _ in range(due):
            with self.clock("sample"):
                batch = self.replay.sample()  # on the device: pinned and copied without blocking, or gathered there
            with self.clock("update"):
                out = self.update(batch)
            self.updates += 1
        if due <= 0:
            return 0
        frames = self.steps * self.action_repeat
        with self.clock("update"):
            self.update.raise_if_diverged()  # the metrics stay on the device until here: one read per batch of updates
        self.update_batches += 1
        for key, value in update_metrics(out).items():
            self.logger.log_scalar(f"train/{key}", value, step=frames)
        self.logger.log_scalar("train/seconds_per_update", (time.perf_counter() - started) / due, step=frames)
        if self.update.compile_seconds is not None and not self.compile_logged:
            self.logger.log_scalar("train/compile_seconds", self.update.compile_seconds, step=frames)
            print(f"compiled the update in {self.update.compile_seconds:.1f} s", flush=True)
            self.compile_logged = True
        return due

    def log_stages(self, steps: int, updates: int, env_times: dict[str, float] | None, gpu_busy: float | None) -> None:
        """``--time-stages``: one row per collector batch under ``time/``, at the run's frames.

        ``wall_s`` (seconds since the run started, to read frames/s between two rows), the batch's
        ``steps`` and ``updates``; the loop's seconds in this batch per stage (``collect_s``: the
        collector's own time, in the background when overlapping; ``wait_s``: the part the loop
        waited for; ``sync_s``, ``store_s``, ``sample_s``, ``update_s``); the env workers' mean
        milliseconds per agent step (``env_step_ms`` and its ``env_physics_ms``, ``env_render_ms``;
        ``env_policy_ms``, ``env_reset_ms``); ``gpu_busy`` once.
        """
        frames = self.steps * self.action_repeat
        rows = {"wall_s": time.perf_counter() - self.started, "steps": steps, "updates": updates}
        rows.update({f"{stage}_s": seconds for stage, seconds in self.clock.take().items()})
        if env_times is not None:
            rows.update({f"env_{name}_ms": 1000 * value for name, value in env_times.items() if value == value})
        if gpu_busy is not None:
            rows["gpu_busy"] = gpu_busy
        for name, value in rows.items():
            self.logger.log_scalar(f"time/{name}", value, step=frames)

    def evaluate_and_checkpoint(self) -> None:
        """Evaluate the policy on the config's levels, log the returns, then write the checkpoint that ends the segment."""
        config, frames = self.config, self.steps * self.action_repeat
        rows = evaluate(self.agent.policy, config.env, list(config.eval_levels), episodes=config.eval_episodes,
                        seeds=[config.evaluation_seed()], device=self.device, protocol=config.protocol,
                        env_options={"render_settings": RenderSettings.fast(), **config.test_env_options()})
        for level in config.eval_levels:
            returns = [row["return"] for row in rows if row["level"] == level]
            self.logger.log_scalar(f"eval/{level}_return", sum(returns) / len(returns), step=frames)
        first = [row["return"] for row in rows if row["level"] == config.eval_levels[0]]
        self.progress.set_postfix(eval=round(sum(first) / config.eval_episodes))
        state = {"loss": self.agent.loss.state_dict(), "optimizer": self.update.optimizer.state_dict(),
                 "policy": self.agent.policy.state_dict(), "generators": generator_states(self.agent.loss),
                 "random": random_states(), "n_step": multistep_state(self.n_step), "replay": replay_state(self.replay.disk),
                 "frames": frames, "steps": self.steps, "updates": self.updates}
        (self.run_dir / "checkpoints").mkdir(exist_ok=True)
        save_checkpoint(checkpoint_path(self.run_dir / "checkpoints", frames), state)
        self.journal.commit(state["replay"])


def segment_batches(steps: int, total_steps: int, eval_every: int, batch_steps: int) -> int:
    """Collector batches until the next checkpoint: the first batch that crosses a multiple of eval_every or ends the run."""
    batches = 1
    while (steps + batches * batch_steps) // eval_every == steps // eval_every and steps + batches * batch_steps < total_steps:
        batches += 1
    return batches


def check_fits(needed: int, device: torch.device) -> None:
    """Stop before training when ``--replay-on-device``'s copy (``needed`` bytes) would not fit in the GPU's free memory."""
    free, total = torch.cuda.mem_get_info(device)
    if needed > 0.9 * free:
        raise SystemExit(f"--replay-on-device: a copy of the replay buffer needs about {needed / 2**30:.1f} GiB, and {device} "
                         f"has {free / 2**30:.1f} of {total / 2**30:.1f} GiB free; lower --buffer-size or drop the flag.")


def make_collector(make, policy, config: TrainConfig, *, env_seed: int, steps_per_batch: int, batches: int, random_steps: int):
    """A collector for one segment, its env freshly reset with ``env_seed`` (of several, worker ``w``: ``derive_seed(env_seed, w)``),
    and the call that sends it the policy's current weights.

    ``--overlap``: worker processes (one at least) acting with a copy of the policy, which only the returned call
    updates, so the weights never change under a batch being collected."""
    workers = config.workers
    if workers == 1 and config.collector == "local" and not config.overlap:  # in this process, whose generator the run saves
        makers = [partial(make, seed=env_seed)]
    else:
        makers = [partial(worker_env, make, seed=derive_seed(env_seed, w, below=ENV_SEED_LIMIT) if workers > 1 else env_seed,
                          torch_seed=derive_seed(env_seed, w, 1), worker=w) for w in range(workers)]
    options = dict(frames_per_batch=steps_per_batch * workers, total_frames=steps_per_batch * workers * batches,
                   init_random_frames=random_steps)
    if config.collector == "ray":
        from torchrl.collectors.distributed import RayCollector

        # the actors' copy keeps its tensors contiguous (TorchRL's Ray weight transport refuses channels-last
        # conv weights); it receives the trained weights, then sends them on
        acting = contiguous_copy(policy).to("cpu")  # Ray actors act on their CPU
        collector = RayCollector(makers, acting, sync=True, collector_kwargs={"auto_register_policy_transforms": False},
                                 remote_configs={"num_cpus": 1}, **options)

        def sync_weights() -> None:
            TensorDict.from_module(acting).data.update_(TensorDict.from_module(policy).data)
            collector.update_policy_weights_()
        sync_weights()  # the actors start from the weights the segment starts with
        return collector, sync_weights
    options["auto_register_policy_transforms"] = False
    device = next(policy.parameters()).device
    if config.overlap or (workers > 1 and device.type != "cpu"):
        # worker processes act with a CPU copy of the policy, sent between batches: a copy on the GPU would be shared
        # with the workers through CUDA IPC, and TorchRL's weight set-up with 8 such workers timed out on the H200
        # (2026-11-28); on the CPU each worker's exploration noise also comes from its own seeded CPU generator
        acting = copy.deepcopy(policy).to("cpu")
        with worker_timeouts():  # the workers' wait for their first weights (TorchRL reads it as they start)
            collector = MultiSyncCollector(makers, acting, cat_results="stack", **options)

        def send_weights() -> None:
            TensorDict.from_module(acting).data.update_(TensorDict.from_module(policy).data)
            collector.update_policy_weights_()
        return collector, send_weights
    if device.type != "cpu":  # envs step on the CPU; the policy acts on the device; frames are stored on the CPU
        options.update(policy_device=device, env_device="cpu", storing_device="cpu")
    if workers > 1:
        with worker_timeouts():
            collector = MultiSyncCollector(makers, policy, cat_results="stack", **options)
    else:
        collector = Collector(makers[0](), policy, **options)
    return collector, collector.update_policy_weights_


def worker_env(make, *, seed: int, torch_seed: int, worker: int = 0):
    """``make(seed=seed)`` in a worker process, after seeding that process's torch generator with ``torch_seed``.

    A worker's exploration noise and seed-phase random actions come from its own torch generator,
    which neither TorchRL's collectors nor Ray seed: unseeded, every worker (and every segment's new
    worker) would draw the same sequence. With ``--time-stages`` the worker says what it renders with.
    """
    torch.manual_seed(torch_seed)
    env = make(seed=seed)
    if getattr(make, "keywords", {}).get("time_stages"):
        egl = os.environ.get("MUJOCO_EGL_DEVICE_ID", "unset")
        print(f"env worker {worker} renders with {renderer_name(env)} (MUJOCO_EGL_DEVICE_ID={egl})", flush=True)
    return env


def contiguous_copy(module: torch.nn.Module) -> torch.nn.Module:
    """A deep copy of ``module`` whose parameters and buffers are contiguous (channels-last conv weights become NCHW)."""
    duplicate = copy.deepcopy(module)
    for tensor in [*duplicate.parameters(), *duplicate.buffers()]:
        tensor.data = tensor.data.contiguous()
    return duplicate


if __name__ == "__main__":
    main()
