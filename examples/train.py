"""Train an augmentation-based agent from pixels on a dm_control, robosuite, Adroit or loco (Unitree, Franka) task, with vigen and TorchRL.

    python examples/train.py --algo svea --env dmc/cartpole-balance --preset cpu --frames 20000
    python examples/train.py --resume runs/svea-cartpole-balance-s0 --frames 40000   # continue it
    python examples/train.py --algo svea --env dmc/walker-walk --protocol dmcgb        # DMC-GB's protocol
    python examples/train.py --algo svea --env dmc/walker-walk --collector ray --workers 2  # collect on Ray

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
  ``--resume`` refuses flags that contradict the run's ``config.json`` (only ``--frames``,
  ``--threads``, ``--device`` and ``--ray-address`` may change).
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
  Not covered: wandb logs are not rewound, and falling back past a checkpoint that does not load
  keeps the transitions written after it in the overwritten slots (resume says so).
"""

from __future__ import annotations

import argparse
import contextlib
import copy
import dataclasses
import json
import sys
import time
from dataclasses import dataclass
from functools import partial
from pathlib import Path

import torch
from tensordict import TensorDict
from torchrl.collectors import Collector, MultiSyncCollector
from torchrl.data import LazyMemmapStorage, TensorDictReplayBuffer, TensorSpec
from torchrl.envs import RewardSum, TransformedEnv
from torchrl.envs.transforms import MultiStepTransform
from torchrl.objectives import SoftUpdate
from torchrl.record.loggers import get_logger
from tqdm import tqdm

from vigen.checkpoint import (CheckpointError, ReplayJournal, checkpoint_path, generator_states, load_optimizer_state,
                              multistep_state, newest_checkpoint, random_states, remove_temporary_files, replay_state,
                              restore_replay, save_checkpoint, set_generator_states, set_multistep_state,
                              set_random_states, truncate_csv_logs)
from vigen.devices import resolve_device
from vigen.envs import make_env
from vigen.evaluation import evaluate
from vigen.io import FolderInUse, RunFolderLock, atomic_write, unused_path
from vigen.losses import UpdateStep, update_metrics
from vigen.protocols import PROTOCOLS
from vigen.ray_cluster import ray_session
from vigen.rendering import RenderSettings
from vigen.run import TrainConfig, add_flags, build_agent, check_runnable, given_flags, new_config, resumed_config, setting
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


def training_env(name: str, seed: int, **options) -> TransformedEnv:
    """The suite's pixels (uint8 [9, 84, 84]; DrQ-v2's action repeat 2 on dm_control), rendered fast, with episode returns summed."""
    env = make_env(name, seed=seed, render_settings=RenderSettings.fast(), **options)
    return env.append_transform(RewardSum())


def main() -> None:
    config, launch = parse_args()
    lock = None if launch.resume is None else hold(launch.resume)  # a second writer stops before any work
    try:
        device = resolve_device(launch.device)
    except ValueError as error:
        raise SystemExit(f"--device: {error}") from None
    if launch.threads:
        torch.set_num_threads(launch.threads)
    torch.manual_seed(config.seed)
    if config.protocol is not None:
        print("\n".join(PROTOCOLS[config.protocol].describe(config.env)), flush=True)
        for key, values in (config.protocol_overrides or {}).items():
            print(f"  overridden by a flag: {key} = {values['flag']} (protocol: {values['protocol']})", flush=True)
    make = partial(training_env, config.env, **config.env_options())
    probe = make(seed=config.seed)
    action_repeat, action_spec = probe.base_env.action_repeat, probe.action_spec
    observation_shape = tuple(probe.observation_spec["pixels"].shape)
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
    training = Training(config, run_dir, make, action_spec, action_repeat, device)
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
                 device: torch.device) -> None:
        self.config, self.run_dir, self.make, self.action_repeat, self.device = config, run_dir, make, action_repeat, device
        # the agent: a vigen loss on the paper's networks, its acting policy, Adam and the target-critic update
        self.agent = build_agent(config, action_spec, device=device)
        self.noise = self.agent.exploration_noise  # stepped with the frames collected; None: the policy samples (SAC)
        # eager: fused (the same step, ~10x faster on CPU); compiled: torch.compile fuses it, capturable for a CUDA graph
        optimizer = torch.optim.Adam(self.agent.loss.optimizer_groups(config.lr), fused=not config.compile,
                                     capturable=config.compile and device.type == "cuda")
        self.update = UpdateStep(self.agent.loss, optimizer, SoftUpdate(self.agent.loss, tau=config.tau), compile=config.compile)
        # replay: uint8 transitions memory-mapped in the run folder, n-step returns computed as trajectories
        # come in; the journal keeps what the last checkpoint counts valid until the next checkpoint
        self.storage_dir = run_dir / "replay_buffer" / "storage"
        self.buffer = TensorDictReplayBuffer(storage=LazyMemmapStorage(config.buffer_size, scratch_dir=self.storage_dir),
                                             batch_size=config.batch_size)
        self.journal = ReplayJournal(run_dir / "replay_buffer" / "journal", self.buffer)
        self.n_step = MultiStepTransform(config.n_step, config.gamma)  # holds back the last n steps of each batch
        self.steps, self.updates = 0, 0  # agent steps collected, gradient updates made
        self.compile_logged = False
        self.logger = get_logger(config.logger, logger_name=str(run_dir), experiment_name="logs",
                                 **({"offline": True} if config.logger == "wandb" else {}))
        self.total_steps = config.frames // action_repeat
        self.seed_steps = config.seed_frames // action_repeat
        self.eval_every = config.eval_every // action_repeat
        self.steps_per_batch = 50 * config.update_every  # per worker
        self.progress: tqdm | None = None

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
        restore_replay(self.buffer, checkpoint["replay"], self.storage_dir)
        for note in self.journal.rollback(checkpoint["replay"]):
            print(note, file=sys.stderr)
        for note in truncate_csv_logs(self.run_dir / "logs", checkpoint["frames"]):
            print(f"logs: {note}", file=sys.stderr)
        self.steps, self.updates = checkpoint["steps"], checkpoint["updates"]

    def run(self) -> None:
        """Train up to the config's frames, one segment per checkpoint."""
        self.progress = tqdm(total=self.total_steps * self.action_repeat, initial=self.steps * self.action_repeat,
                             unit="frame", dynamic_ncols=True)
        while self.steps < self.total_steps:
            self.collect()
            self.evaluate_and_checkpoint()
        self.progress.close()

    def collect(self) -> None:
        """One segment: collect up to the next checkpoint with a fresh collector, storing each batch and updating as due."""
        collector, sync_weights = make_collector(
            self.make, self.agent.policy, self.config, env_seed=derive_seed(self.config.seed, self.steps, below=ENV_SEED_LIMIT),
            steps_per_batch=self.steps_per_batch, random_steps=max(0, self.seed_steps - self.steps),
            batches=segment_batches(self.steps, self.total_steps, self.eval_every, self.steps_per_batch * self.config.workers))
        for batch in collector:
            self.store(batch)
            self.update_as_due()
            sync_weights()
        collector.shutdown()

    def store(self, batch: TensorDict) -> None:
        """Count a batch, log its finished episodes, store its n-step transitions; the segment's last batch cuts its episode."""
        new = batch.numel()
        self.steps += new
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
            self.buffer.extend(transitions.reshape(-1))
        if self.noise is not None:
            self.noise.step(new)  # the exploration noise follows the std schedule
        self.progress.update(new * self.action_repeat)

    def update_as_due(self) -> None:
        """The gradient updates due after the seed steps (one per ``update_every`` agent steps), then their metrics."""
        due = (self.steps - self.seed_steps) // self.config.update_every - self.updates if self.steps >= self.seed_steps else 0
        started = time.perf_counter()
        self.agent.loss.set_step(self.steps)
        for _ in range(due):
            out = self.update(self.buffer.sample().to(self.device, non_blocking=True))
            self.updates += 1
        if due <= 0:
            return
        frames = self.steps * self.action_repeat
        self.update.raise_if_diverged()  # the metrics stay on the device until here: one read per batch of updates
        for key, value in update_metrics(out).items():
            self.logger.log_scalar(f"train/{key}", value, step=frames)
        self.logger.log_scalar("train/seconds_per_update", (time.perf_counter() - started) / due, step=frames)
        if self.update.compile_seconds is not None and not self.compile_logged:
            self.logger.log_scalar("train/compile_seconds", self.update.compile_seconds, step=frames)
            print(f"compiled the update in {self.update.compile_seconds:.1f} s", flush=True)
            self.compile_logged = True

    def evaluate_and_checkpoint(self) -> None:
        """Evaluate the policy on the config's levels, log the returns, then write the checkpoint that ends the segment."""
        config, frames = self.config, self.steps * self.action_repeat
        rows = evaluate(self.agent.policy, config.env, list(config.eval_levels), episodes=config.eval_episodes,
                        seeds=[config.seed + 10_000], device=self.device,
                        env_options={"render_settings": RenderSettings.fast(), **config.env_options()})
        for level in config.eval_levels:
            returns = [row["return"] for row in rows if row["level"] == level]
            self.logger.log_scalar(f"eval/{level}_return", sum(returns) / len(returns), step=frames)
        first = [row["return"] for row in rows if row["level"] == config.eval_levels[0]]
        self.progress.set_postfix(eval=round(sum(first) / config.eval_episodes))
        state = {"loss": self.agent.loss.state_dict(), "optimizer": self.update.optimizer.state_dict(),
                 "policy": self.agent.policy.state_dict(), "generators": generator_states(self.agent.loss),
                 "random": random_states(), "n_step": multistep_state(self.n_step), "replay": replay_state(self.buffer),
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


def make_collector(make, policy, config: TrainConfig, *, env_seed: int, steps_per_batch: int, batches: int, random_steps: int):
    """A collector for one segment, its env freshly reset with ``env_seed`` (of several, worker ``w``: ``derive_seed(env_seed, w)``),
    and the call that sends it the policy's current weights."""
    workers = config.workers
    if workers == 1 and config.collector == "local":  # in this process, whose torch generator the run seeds and saves
        makers = [partial(make, seed=env_seed)]
    else:
        makers = [partial(worker_env, make, seed=derive_seed(env_seed, w, below=ENV_SEED_LIMIT) if workers > 1 else env_seed,
                          torch_seed=derive_seed(env_seed, w, 1)) for w in range(workers)]
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
    if device.type != "cpu":  # envs step on the CPU; the policy acts on the device; frames are stored on the CPU
        options.update(policy_device=device, env_device="cpu", storing_device="cpu")
    if workers > 1:
        collector = MultiSyncCollector(makers, policy, cat_results="stack", **options)
    else:
        collector = Collector(makers[0](), policy, **options)
    return collector, collector.update_policy_weights_


def worker_env(make, *, seed: int, torch_seed: int):
    """``make(seed=seed)`` in a worker process, after seeding that process's torch generator with ``torch_seed``.

    A worker's exploration noise and seed-phase random actions come from its own torch generator,
    which neither TorchRL's collectors nor Ray seed: unseeded, every worker (and every segment's new
    worker) would draw the same sequence.
    """
    torch.manual_seed(torch_seed)
    return make(seed=seed)


def contiguous_copy(module: torch.nn.Module) -> torch.nn.Module:
    """A deep copy of ``module`` whose parameters and buffers are contiguous (channels-last conv weights become NCHW)."""
    duplicate = copy.deepcopy(module)
    for tensor in [*duplicate.parameters(), *duplicate.buffers()]:
        tensor.data = tensor.data.contiguous()
    return duplicate


if __name__ == "__main__":
    main()
