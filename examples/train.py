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
easy tasks on a laptop CPU. An algorithm whose paper changes some of these settings gets them from
``algo_defaults`` (VRL3: a fixed exploration std of 0.01 and, on Adroit, RL-ViGen's reward scale,
door ×1/20, hammer ×1/100, pen ×1/50); flags override them and ``config.json`` records them.

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
import json
import sys
import time
from functools import partial
from pathlib import Path

import torch
from tensordict import TensorDict
from torchrl.collectors import Collector, MultiSyncCollector
from torchrl.data import LazyMemmapStorage, TensorDictReplayBuffer
from torchrl.envs import RewardSum, TransformedEnv
from torchrl.envs.transforms import MultiStepTransform
from torchrl.modules import AdditiveGaussianModule
from torchrl.objectives import SoftUpdate
from torchrl.record.loggers import get_logger
from tqdm import tqdm

from vigen.checkpoint import (CheckpointError, ReplayJournal, checkpoint_path, generator_states, multistep_state,
                              newest_checkpoint, random_states, remove_temporary_files, replay_state, restore_replay,
                              save_checkpoint, set_generator_states, set_multistep_state, set_random_states,
                              truncate_csv_logs)
from vigen.envs import available_envs, make_env
from vigen.envs.levels import resolve_levels
from vigen.evaluation import evaluate
from vigen.io import atomic_write, unused_path
from vigen.devices import resolve_device
from vigen.losses import ALGOS, LinearSchedule, SoftActorCritic, UpdateStep, make_loss, update_metrics
from vigen.losses.vrl3 import ADROIT_REWARD_SCALES
from vigen.protocols import PROTOCOLS
from vigen.ray_cluster import import_ray, ray_session
from vigen.rendering import RenderSettings
from vigen.seeding import ENV_SEED_LIMIT, derive_seed

PRESETS = {
    "paper": dict(batch_size=256, buffer_size=1_000_000, lr=1e-4, hidden_dim=1024, feature_dim=50, n_step=3,
                  gamma=0.99, tau=0.01, seed_frames=4000, update_every=2, std_duration=100_000,
                  eval_every=10_000, eval_episodes=10, std_init=1.0, std_final=0.1, reward_scale=1.0),
    "cpu": dict(batch_size=64, buffer_size=100_000, lr=1e-4, hidden_dim=1024, feature_dim=50, n_step=3,
                gamma=0.99, tau=0.01, seed_frames=4000, update_every=2, std_duration=100_000,
                eval_every=10_000, eval_episodes=5, std_init=1.0, std_final=0.1, reward_scale=1.0),
}
DEFAULTS = dict(algo="drqv2", env="dmc/cartpole-balance", preset="cpu", seed=0, workers=1, collector="local", eval_levels=["train"],
                logger="csv", episode_length=None, encoder_weights=None, protocol=None, action_repeat=None,
                frame_stack=None, image_size=None, compile=False)  # a new run's values of the flags a resumed run takes from config.json
DEFAULT_FRAMES = 100_000
PROTOCOL_KEYS = ("frames", "action_repeat", "frame_stack", "image_size", "episode_length", "eval_every", "eval_episodes",
                 "eval_levels")
"""The run settings a protocol fixes (vigen.protocols.Protocol.settings); explicit flags override them."""
WEIGHTS_OPTION = {"pieg": "encoder_weights", "vrl3": "stage1_weights"}  # --encoder-weights -> make_loss option


def algo_defaults(algo: str, env: str) -> dict:
    """The preset values an algorithm's paper changes (std: linear std_init → std_final; reward_scale: of stored rewards)."""
    if algo == "vrl3":  # RL-ViGen's Adroit VRL3: std linear(0.01, 0.01), rewards rescaled (as its safe-Q threshold assumes)
        suite, _, task = env.partition("/")
        scale = ADROIT_REWARD_SCALES.get(task, 1.0) if suite == "adroit" else 1.0
        return dict(std_init=0.01, std_final=0.01, reward_scale=scale)
    return {}


def env_options(config: dict) -> dict:
    """The make_env options a run sets (episode length, action repeat, frame stack, image size); unset ones keep the suite's."""
    names = ("episode_length", "action_repeat", "frame_stack", "image_size")
    return {name: config[name] for name in names if config.get(name) is not None}


def training_env(name: str, seed: int, **options) -> TransformedEnv:
    """The suite's pixels (uint8 [9, 84, 84]; DrQ-v2's action repeat 2 on dm_control), rendered fast, with episode returns summed."""
    env = make_env(name, seed=seed, render_settings=RenderSettings.fast(), **options)
    return env.append_transform(RewardSum())


def parse_args() -> argparse.Namespace:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--algo", choices=list(ALGOS), default=None, help=f"default {DEFAULTS['algo']}")
    parser.add_argument("--env", default=None, help=f"default {DEFAULTS['env']}")
    parser.add_argument("--preset", choices=list(PRESETS), default=None, help=f"default {DEFAULTS['preset']}")
    parser.add_argument("--protocol", choices=list(PROTOCOLS), default=None,
                        help="train as a paper did: its budget, action repeat, frame stack, image size and evaluation")
    parser.add_argument("--frames", type=int, default=None,
                        help=f"environment frames in all (with action repeat); default: the protocol's budget, else {DEFAULT_FRAMES}")
    parser.add_argument("--action-repeat", type=int, default=None, help="simulator steps per agent step (default: the suite's)")
    parser.add_argument("--frame-stack", type=int, default=None, help="frames per observation (default 3)")
    parser.add_argument("--image-size", type=int, default=None, help="pixels per side (default 84)")
    parser.add_argument("--seed", type=int, default=None, help="default 0")
    parser.add_argument("--out", type=Path, default=None, help="run folder (default runs/<algo>-<task>-s<seed>)")
    parser.add_argument("--resume", type=Path, default=None, help="a run folder to continue up to --frames")
    parser.add_argument("--workers", type=int, default=None,
                        help="envs collecting in parallel, one per process (local collector: >1 is a MultiSyncCollector)")
    parser.add_argument("--collector", choices=["local", "ray"], default=None,
                        help="local (default): this machine's processes; ray: TorchRL's RayCollector, one Ray actor per worker")
    parser.add_argument("--ray-address", default=None,
                        help="with --collector ray: the cluster to join (default: start a local one on 127.0.0.1)")
    parser.add_argument("--eval-levels", nargs="+", default=None, help="levels evaluated at every checkpoint (train)")
    parser.add_argument("--logger", choices=["csv", "wandb"], default=None, help="csv (default) or wandb, offline")
    parser.add_argument("--episode-length", type=int, default=None,
                        help="simulator steps per episode (default: the suite's, dm_control 1000, robosuite 500, Adroit 200, pen 100)")
    parser.add_argument("--threads", type=int, default=None, help="torch threads (default: torch's choice)")
    parser.add_argument("--device", default="auto",
                        help="where the networks, optimizer, updates and policies run: auto (CUDA when present), cpu, cuda, cuda:N; "
                             "envs step on the CPU. A resumed run may change it.")
    parser.add_argument("--compile", action="store_const", const=True, default=None,
                        help="compile the whole update (torch.compile; on CUDA also a CUDA graph). The augmentations then "
                             "draw from torch's RNG seeded by --seed (torch.compile cannot trace their own generators)")
    parser.add_argument("--encoder-weights", default=None,
                        help="pretrained encoder weights: PIE-G's ImageNet ResNet-18 (a torchvision state dict), VRL3's stage-1 checkpoint")
    for name, value in PRESETS["paper"].items():  # every preset value can be overridden
        parser.add_argument(f"--{name.replace('_', '-')}", type=type(value), default=None)
    return parser.parse_args()


def configure(args: argparse.Namespace) -> dict:
    """The run's settings: a new run's preset with overrides, or a resumed run's saved config (flags may not contradict it)."""
    given = {name: getattr(args, name) for name in [*DEFAULTS, *PRESETS["paper"]] if getattr(args, name) is not None}
    if args.resume is None:
        preset = given.get("preset", DEFAULTS["preset"])
        env = given.get("env", DEFAULTS["env"])
        algo = algo_defaults(given.get("algo", DEFAULTS["algo"]), env)
        config = {**DEFAULTS, **PRESETS[preset], **algo, **given, "frames": DEFAULT_FRAMES if args.frames is None else args.frames}
        if config["protocol"] is not None:
            config.update(protocol_config(config["protocol"], env, {**given, **({} if args.frames is None else {"frames": args.frames})}))
        return config
    if args.out is not None:
        raise SystemExit("--out and --resume: a resumed run stays in its folder; drop --out.")
    if not (args.resume / "config.json").is_file():
        raise SystemExit(f"--resume {args.resume}: no config.json there; pass a run folder of examples/train.py.")
    saved = json.loads((args.resume / "config.json").read_text())
    config = {**PRESETS[DEFAULTS["preset"]], "collector": DEFAULTS["collector"], **saved}  # a setting newer than the run: the run had its default
    conflicts = [f"--{name.replace('_', '-')} {value} (the run has {config.get(name)})"
                 for name, value in given.items() if config.get(name) != value]
    if conflicts:
        raise SystemExit(f"--resume {args.resume}: these flags contradict its config.json: {'; '.join(conflicts)}. "
                         "Drop them to continue the run as it was, or start a new run.")
    if args.frames is not None:
        return dict(config, frames=args.frames)
    overridden = config.get("protocol_overrides", {}).get("frames")  # the run's own budget, when a flag set it
    return dict(config, frames=overridden["flag"] if overridden else config.get("protocol_settings", {}).get("frames", DEFAULT_FRAMES))


def protocol_config(name: str, env: str, given: dict) -> dict:
    """A protocol's settings on ``env`` as run settings, with the flags that override them recorded (and kept)."""
    try:
        settings = PROTOCOLS[name].settings(env)
    except ValueError as error:
        raise SystemExit(f"--protocol {name}: {error}") from None
    overrides = {key: {"protocol": settings[key], "flag": given[key]} for key in PROTOCOL_KEYS
                 if key in given and given[key] != settings[key]}
    return {**{key: settings[key] for key in PROTOCOL_KEYS}, **{key: given[key] for key in PROTOCOL_KEYS if key in given},
            "protocol_settings": settings, "protocol_overrides": overrides}


def validate(config: dict, threads: int | None) -> None:
    """Check every setting before anything runs, so no training is lost to a typo found later."""
    def positive(*names: str) -> None:
        for name in names:
            if not isinstance(config[name], int) or config[name] < 1:
                raise SystemExit(f"--{name.replace('_', '-')} must be an integer >= 1, got {config[name]}.")
    positive("batch_size", "buffer_size", "hidden_dim", "feature_dim", "n_step", "update_every", "std_duration",
             "eval_every", "eval_episodes", "workers")
    for name in ("action_repeat", "frame_stack", "image_size"):
        if config.get(name) is not None and config[name] < 1:
            raise SystemExit(f"--{name.replace('_', '-')} must be an integer >= 1, got {config[name]}.")
    if config["frames"] < 0 or config["seed_frames"] < 0:
        raise SystemExit(f"--frames and --seed-frames must be >= 0, got {config['frames']} and {config['seed_frames']}.")
    if config["buffer_size"] < config["batch_size"]:
        raise SystemExit(f"--buffer-size {config['buffer_size']} is below --batch-size {config['batch_size']}: "
                         "the buffer could never fill one batch; raise it.")
    if not (config["lr"] > 0 and 0 < config["gamma"] <= 1 and 0 < config["tau"] <= 1):
        raise SystemExit(f"--lr must be > 0 and --gamma, --tau in (0, 1], got {config['lr']}, {config['gamma']}, {config['tau']}.")
    if not (config["std_init"] >= 0 and config["std_final"] >= 0 and 0 < config["reward_scale"] < float("inf")):
        raise SystemExit(f"--std-init and --std-final must be >= 0 and --reward-scale positive, got {config['std_init']}, "
                         f"{config['std_final']} and {config['reward_scale']}.")
    weights = config.get("encoder_weights")
    if weights is not None:
        if config["algo"] not in WEIGHTS_OPTION:
            raise SystemExit(f"--encoder-weights: {config['algo']} has no pretrained encoder; it applies to {', '.join(WEIGHTS_OPTION)}.")
        if not Path(weights).expanduser().is_file():
            raise SystemExit(f"--encoder-weights {weights}: no such file; give the path of the weights file.")
    if config["episode_length"] is not None and config["episode_length"] < 1:
        raise SystemExit(f"--episode-length must be >= 1, got {config['episode_length']}.")
    if threads is not None and threads < 1:
        raise SystemExit(f"--threads must be >= 1, got {threads}.")
    if config["collector"] == "ray":
        try:
            import_ray()
        except ImportError as error:
            raise SystemExit(f"--collector ray: {error}") from None
    if config["env"] not in available_envs(config["env"].split("/")[0] if "/" in config["env"] else None):
        make_env(config["env"])  # raises with the valid names and the closest matches
    try:
        resolve_levels(config["eval_levels"], suite=config["env"].split("/")[0])
    except ValueError as error:
        raise SystemExit(f"--eval-levels: {error}") from None


def main() -> None:
    args = parse_args()
    config = configure(args)
    validate(config, args.threads)
    try:
        device = resolve_device(args.device)
    except ValueError as error:
        raise SystemExit(f"--device: {error}") from None
    if args.ray_address is not None and config["collector"] != "ray":
        raise SystemExit("--ray-address names the Ray cluster of --collector ray; add --collector ray or drop it.")
    if args.threads:
        torch.set_num_threads(args.threads)
    torch.manual_seed(config["seed"])

    if config.get("protocol") is not None:
        print("\n".join(PROTOCOLS[config["protocol"]].describe(config["env"])), flush=True)
        for key, values in config["protocol_overrides"].items():
            print(f"  overridden by a flag: {key} = {values['flag']} (protocol: {values['protocol']})", flush=True)
    make = partial(training_env, config["env"], **env_options(config))
    probe = make(seed=config["seed"])
    action_repeat = probe.base_env.action_repeat
    observation_shape = tuple(probe.observation_spec["pixels"].shape)
    action_spec = probe.action_spec
    probe.close()
    if config["eval_every"] < action_repeat:
        raise SystemExit(f"--eval-every {config['eval_every']} is below one agent step ({action_repeat} frames with "
                         f"{config['env']}'s action repeat); raise it.")

    if args.resume is None:  # the run folder is made only now, after every check passed
        task = config["env"].split("/", 1)[-1]
        run_dir = unused_path(args.out or Path("runs") / f"{config['algo']}-{task}-s{config['seed']}")
        run_dir.mkdir(parents=True)
        config.update(observation_shape=list(observation_shape), action_dim=action_spec.shape[-1])
        atomic_write(run_dir / "config.json", json.dumps({k: v for k, v in config.items() if k != "frames"}, indent=2))
    else:
        run_dir = args.resume
    print(f"run folder: {run_dir}", flush=True)

    # the agent: a vigen loss on the paper's networks, its acting policy, Adam and the target-critic update
    std = LinearSchedule(config["std_init"], config["std_final"], config["std_duration"])
    options = {} if issubclass(ALGOS[config["algo"]], SoftActorCritic) else {"std": std}
    if config.get("encoder_weights") is not None:
        options[WEIGHTS_OPTION[config["algo"]]] = str(Path(config["encoder_weights"]).expanduser())
    compiled = config.get("compile", False)
    loss = make_loss(config["algo"], observation_shape, config["action_dim"], feature_dim=config["feature_dim"],
                     hidden_dim=config["hidden_dim"], seed=None if compiled else config["seed"], device=device, **options)
    loss.make_value_estimator(gamma=config["gamma"])
    policy = loss.make_policy(action_spec)
    noise = next((module for module in policy.modules() if isinstance(module, AdditiveGaussianModule)), None)
    # eager: fused (the same step, ~10x faster on CPU); compiled: torch.compile fuses it, capturable for a CUDA graph
    optimizer = torch.optim.Adam(loss.optimizer_groups(config["lr"]), fused=not compiled, capturable=compiled and device.type == "cuda")
    target_update = SoftUpdate(loss, tau=config["tau"])
    update = UpdateStep(loss, optimizer, target_update, compile=compiled)

    # replay: uint8 transitions memory-mapped in the run folder, n-step returns computed as trajectories
    # come in; the journal keeps what the last checkpoint counts valid until the next checkpoint
    storage_dir = run_dir / "replay_buffer" / "storage"
    buffer = TensorDictReplayBuffer(storage=LazyMemmapStorage(config["buffer_size"], scratch_dir=storage_dir),
                                    batch_size=config["batch_size"])
    journal = ReplayJournal(run_dir / "replay_buffer" / "journal", buffer)
    n_step = MultiStepTransform(config["n_step"], config["gamma"])  # holds back the last n steps of each batch
    steps, updates = 0, 0  # agent steps collected, gradient updates made
    compile_logged = False
    logger = get_logger(config["logger"], logger_name=str(run_dir), experiment_name="logs",
                        **({"offline": True} if config["logger"] == "wandb" else {}))
    if args.resume is not None:
        try:
            path, checkpoint, skipped = newest_checkpoint(run_dir / "checkpoints")
        except CheckpointError as error:
            raise SystemExit(f"--resume {run_dir}: {error}") from None
        for bad, why in skipped:
            print(f"skipped checkpoint {bad.name}: {why}", file=sys.stderr)
        for leftover in remove_temporary_files(run_dir / "checkpoints"):
            print(f"removed {leftover.name}, left by a run killed while writing a checkpoint", file=sys.stderr)
        print(f"resuming from {path.name}", flush=True)
        loss.load_state_dict(checkpoint["loss"])
        optimizer.load_state_dict(checkpoint["optimizer"])
        policy.load_state_dict(checkpoint["policy"])
        set_generator_states(loss, checkpoint["generators"])
        set_random_states(checkpoint["random"])
        set_multistep_state(n_step, checkpoint["n_step"])
        restore_replay(buffer, checkpoint["replay"], storage_dir)
        for note in journal.rollback(checkpoint["replay"]):
            print(note, file=sys.stderr)
        for note in truncate_csv_logs(run_dir / "logs", checkpoint["frames"]):
            print(f"logs: {note}", file=sys.stderr)
        steps, updates = checkpoint["steps"], checkpoint["updates"]

    total_steps = config["frames"] // action_repeat
    seed_steps = config["seed_frames"] // action_repeat
    eval_every = config["eval_every"] // action_repeat
    steps_per_batch = 50 * config["update_every"]  # per worker
    with contextlib.ExitStack() as session:
        if config["collector"] == "ray":  # one cluster for the whole run; collectors come and go with segments
            session.enter_context(ray_session(args.ray_address))
        progress = tqdm(total=total_steps * action_repeat, initial=steps * action_repeat, unit="frame", dynamic_ncols=True)
        while steps < total_steps:  # one segment per checkpoint
            collector, sync_weights = make_collector(
                make, policy, config, env_seed=derive_seed(config["seed"], steps, below=ENV_SEED_LIMIT), steps_per_batch=steps_per_batch,
                batches=segment_batches(steps, total_steps, eval_every, steps_per_batch * config["workers"]),
                random_steps=max(0, seed_steps - steps))
            for batch in collector:
                new = batch.numel()
                steps += new
                episode_ends = batch["next", "done"].squeeze(-1)
                if episode_ends.any():
                    logger.log_scalar("train/episode_reward", batch["next", "episode_reward"][episode_ends].mean().item(), step=steps * action_repeat)
                segment_ends = steps // eval_every > (steps - new) // eval_every or steps >= total_steps
                if segment_ends:  # the episode in progress ends with the segment: its n-step targets bootstrap there
                    batch["next", "truncated"][..., -1, :] = True
                    batch["next", "done"][..., -1, :] = True
                transitions = n_step.inv(batch)  # [time] or [workers, time], with n-step rewards and next pixels
                if transitions is not None:
                    if config["reward_scale"] != 1:
                        transitions.set(("next", "reward"), transitions["next", "reward"] * config["reward_scale"])
                    journal.protect(transitions.numel())
                    buffer.extend(transitions.reshape(-1))
                if noise is not None:
                    noise.step(new)  # the exploration noise follows the std schedule (DrQ samples from its policy instead)
                progress.update(new * action_repeat)

                due = (steps - seed_steps) // config["update_every"] - updates if steps >= seed_steps else 0
                started = time.perf_counter()
                loss.set_step(steps)
                for _ in range(max(0, due)):
                    out = update(buffer.sample().to(device, non_blocking=True))
                    updates += 1
                if due > 0:  # the update's metrics stay on the device until here: one read per batch of updates
                    update.raise_if_diverged()
                    for key, value in update_metrics(out).items():
                        logger.log_scalar(f"train/{key}", value, step=steps * action_repeat)
                    logger.log_scalar("train/seconds_per_update", (time.perf_counter() - started) / due, step=steps * action_repeat)
                    if update.compile_seconds is not None and not compile_logged:
                        logger.log_scalar("train/compile_seconds", update.compile_seconds, step=steps * action_repeat)
                        print(f"compiled the update in {update.compile_seconds:.1f} s", flush=True)
                        compile_logged = True
                sync_weights()
            collector.shutdown()

            rows = evaluate(policy, config["env"], config["eval_levels"], episodes=config["eval_episodes"],
                            seeds=[config["seed"] + 10_000], device=device, env_options={"render_settings": RenderSettings.fast(), **env_options(config)})
            for level in config["eval_levels"]:
                returns = [row["return"] for row in rows if row["level"] == level]
                logger.log_scalar(f"eval/{level}_return", sum(returns) / len(returns), step=steps * action_repeat)
            progress.set_postfix(eval=round(sum(r["return"] for r in rows if r["level"] == config["eval_levels"][0]) / config["eval_episodes"]))
            state = {"loss": loss.state_dict(), "optimizer": optimizer.state_dict(), "policy": policy.state_dict(),
                     "generators": generator_states(loss), "random": random_states(), "n_step": multistep_state(n_step),
                     "replay": replay_state(buffer), "frames": steps * action_repeat, "steps": steps, "updates": updates}
            (run_dir / "checkpoints").mkdir(exist_ok=True)
            save_checkpoint(checkpoint_path(run_dir / "checkpoints", steps * action_repeat), state)
            journal.commit(state["replay"])
        progress.close()


def segment_batches(steps: int, total_steps: int, eval_every: int, batch_steps: int) -> int:
    """Collector batches until the next checkpoint: the first batch that crosses a multiple of eval_every or ends the run."""
    batches = 1
    while (steps + batches * batch_steps) // eval_every == steps // eval_every and steps + batches * batch_steps < total_steps:
        batches += 1
    return batches


def make_collector(make, policy, config: dict, *, env_seed: int, steps_per_batch: int, batches: int, random_steps: int):
    """A collector for one segment, its env freshly reset with ``env_seed`` (of several, worker ``w``: ``derive_seed(env_seed, w)``),
    and the call that sends it the policy's current weights."""
    workers = config["workers"]
    if workers == 1 and config["collector"] == "local":  # in this process, whose torch generator the run seeds and saves
        makers = [partial(make, seed=env_seed)]
    else:
        makers = [partial(worker_env, make, seed=derive_seed(env_seed, w, below=ENV_SEED_LIMIT) if workers > 1 else env_seed,
                          torch_seed=derive_seed(env_seed, w, 1)) for w in range(workers)]
    options = dict(frames_per_batch=steps_per_batch * workers, total_frames=steps_per_batch * workers * batches,
                   init_random_frames=random_steps)
    if config["collector"] == "ray":
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
