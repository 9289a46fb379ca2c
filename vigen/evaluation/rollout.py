"""Zero-shot evaluation: run a trained policy on generalization levels it never saw, one row per episode."""

from __future__ import annotations

import csv
import functools
import io
import json
import os
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import Any

import torch
from tensordict import TensorDictBase
from torchrl.envs import EnvBase
from torchrl.envs.utils import ExplorationType, set_exploration_type

from vigen.envs import check_level_options_used, factors, level_label, level_options_for, make_env
from vigen.envs.levels import resolve_levels
from vigen.evaluation.jobs import EvaluationError, Job, JobError, Level
from vigen.evaluation.sweep import check_factor_intensity, level_columns
from vigen.io import atomic_write
from vigen.protocols import Protocol, get_protocol

EnvFactory = Callable[[Level, int], EnvBase]
"""``(level, seed) -> env``: how :func:`evaluate` builds an env when a name is not enough."""

Policy = Callable[[TensorDictBase], TensorDictBase]

BACKENDS = ("serial", "ray")


def evaluate(
    policy: Policy,
    env: str | EnvFactory,
    levels: Level | Sequence[Level] = "train",
    *,
    episodes: int = 10,
    seeds: Sequence[int] = (0,),
    max_steps: int = 100_000,
    env_options: Mapping[str, Any] | None = None,
    tags: Mapping[str, Any] | None = None,
    rows_path: str | os.PathLike | None = None,
    device: torch.device | str | None = None,
    backend: str = "serial",
    workers: int | None = None,
    progress: Callable[[int, int], None] | None = None,
    protocol: str | Protocol | None = None,
) -> list[dict[str, Any]]:
    """Run ``policy`` zero-shot on each level and return one row per episode.

    For every level and seed, one env is built (``make_env(env, generalization=level, seed=seed,
    **env_options)``, or ``env(level, seed)`` for a factory) and ``episodes`` episodes are played
    in it back to back, with TorchRL's exploration type set to ``DETERMINISTIC`` (the policy's
    mean action). The seed fixes the task's initial states and the level's perturbations, so two
    methods evaluated with the same seeds see the same scenes.

    Args:
        policy: a TorchRL policy (``TensorDictModule`` or any callable on a TensorDict) that reads
            the env's observation keys and writes ``"action"``.
        env: a vigen env name such as ``"dmc/walker-walk"``, or a factory ``(level, seed) -> env``.
        levels: level or group names (:func:`vigen.envs.levels.resolve_levels`) and generalization
            dicts ``{factor: intensity}``, e.g. ``["train", "dmcgb", *sweep("camera_rotation", [0.1, 0.3])]``;
            with a factory, any levels the factory understands. Repeated levels run once.
        episodes: episodes per level and seed.
        seeds: the env and level seeds.
        max_steps: a cap on agent steps per episode (the env's own time limit usually ends it first).
        env_options: more keyword arguments for :func:`vigen.envs.make_env` (e.g. ``render_settings``).
        tags: constant columns added to every row, e.g. ``{"method": "svea", "run": 1}``.
        rows_path: a new CSV file that receives each row as soon as its episode ends (flushed to
            disk), so a crash, a kill or a failing level loses no finished episode. It must not
            exist yet. With ``backend="ray"`` a job's rows arrive when the job ends, in the order jobs end.
        device: the device the envs are built on (``make_env(..., device=device)``; a factory decides
            for itself). The policy must already be there: nothing is moved for it.
        backend: ``"serial"`` plays the jobs (one per level and seed) one after another here;
            ``"ray"`` spreads them over Ray workers (:mod:`vigen.evaluation.ray_backend`), in the
            session that is running or else a local cluster started and stopped for the call. The
            rows are the same, in the same order: each job is seeded by its seed alone. (Ray tasks run
            torch on one thread; a policy run here on more threads sums its products in another
            order, which can move returns by float rounding.)
        workers: with ``backend="ray"``, how many jobs run at once (default: the cluster's CPUs).
        progress: called as ``progress(finished_jobs, total_jobs)`` after each job ends.
        protocol: a protocol name (:mod:`vigen.protocols`) whose version of each level to play: a level gets the
            protocol's ``level_options`` for it (:meth:`~vigen.protocols.Protocol.level_options_for`; e.g. under
            ``"dmcgb2"``, ``color_hard`` cycles DMC-GB2's way and ``video_hard`` plays on its in-scene screen), under
            the ``level_options`` of ``env_options``, which win. ``None``: vigen's levels as named. Needs an env name.

    Returns:
        Rows with ``env``, ``level`` (the level's label, :func:`vigen.envs.level_label`), ``seed``,
        ``episode``, ``return``, ``length`` and, where the task reports one, ``success`` (whether
        the episode ever succeeded), after the ``tags``. Rows of a generalization dict also carry
        ``factor`` and ``intensity`` after ``level`` (:func:`~vigen.evaluation.sweep.level_columns`).
        Every row says what its level showed (:func:`data_columns`): ``data``, by identity and never
        by path (:mod:`vigen.datasets.identity`: e.g. ``"dmcgb-colors/color_hard: 100 of 100, shipped"``,
        ``"dmcgb-videos/video_easy: 10 of 10, verified"``, ``"user folder: 7 videos"`` or
        ``"procedural stand-in videos (10)"``, ``""`` for a level that shows no data), ``stand_in``
        (True where vigen's stand-ins replace the source's data) and ``level_options`` (the options
        given, as JSON, a folder by its name: :func:`portable_option`); a level that shows data adds
        ``shown``, what that episode showed (``"video=video3.mp4"``, ``"preset=17"``).

    Examples:
        >>> from vigen.evaluation import evaluate
        >>> rows = evaluate(None, "dmc/cartpole-balance", ["train", "color_hard"], episodes=1, max_steps=5)
        >>> [(row["level"], row["length"]) for row in rows]
        [('train', 5), ('color_hard', 5)]

    A sweep adds one level per intensity, labelled by factor and intensity:

        >>> from vigen.evaluation import sweep
        >>> rows = evaluate(None, "dmc/cartpole-balance", ["train", *sweep("camera_rotation", [0, 0.3])], episodes=1,
        ...                 max_steps=5)
        >>> [(row["level"], row.get("factor"), row.get("intensity")) for row in rows]
        [('train', None, None), ('camera_rotation=0', 'camera_rotation', 0.0), ('camera_rotation=0.3', 'camera_rotation', 0.3)]

    ``policy=None`` plays uniform random actions in the action bounds, a baseline worth reporting
    next to trained agents. They are drawn from a generator seeded with the seed, so the random
    agent plays the same actions at every level: blind to pixels, its return changes only where a
    level changes the dynamics.

    If a level fails (a corrupt video, a policy error, ...), :class:`EvaluationError` is raised
    with the finished episodes in ``.rows``, the failing level, seed and episode in its message,
    and the original exception as its cause:

        >>> from vigen.evaluation import EvaluationError
        >>> def factory(level, seed):
        ...     if level == "broken":
        ...         raise OSError("corrupt video")
        ...     return make_env("dmc/cartpole-balance", seed=seed, image_size=16, frame_stack=1)
        >>> try:
        ...     evaluate(None, factory, ["train", "broken"], episodes=1, max_steps=2)
        ... except EvaluationError as error:
        ...     print(error, [row["level"] for row in error.rows], repr(error.__cause__))
        evaluation failed at level 'broken', seed 0 after 1 finished episode(s); they are in .rows. The error: OSError: corrupt video ['train'] OSError('corrupt video')
    """
    if episodes < 1:
        raise ValueError(f"episodes must be at least 1, got {episodes}.")
    if max_steps < 1:
        raise ValueError(f"max_steps must be at least 1 (agent steps per episode), got {max_steps}.")
    if not seeds:
        raise ValueError("seeds is empty: give at least one seed, e.g. seeds=[0].")
    if backend not in BACKENDS:
        raise ValueError(f"backend {backend!r} is unknown; use one of {', '.join(map(repr, BACKENDS))}.")
    if workers is not None and (backend != "ray" or workers < 1):
        raise ValueError(f"workers={workers}: it sets how many Ray jobs run at once (>= 1) and needs backend='ray'.")
    if backend == "ray" and device is not None and torch.device(device).type != "cpu":
        raise ValueError(f"device={device!r} with backend='ray': Ray tasks here reserve one CPU and no accelerator; "
                         "evaluate on the CPU with Ray, or on the device with backend='serial'.")
    if protocol is not None and not isinstance(env, str):
        raise ValueError("protocol= gives vigen's named levels the protocol's level_options; with an env factory, build "
                         "the protocol's levels in the factory and pass protocol=None.")
    name = env if isinstance(env, str) else getattr(env, "__name__", "env")
    checked = _check_levels(levels, env)
    if isinstance(env, str):  # options no level takes would do nothing: say so before any episode
        check_level_options_used(env, list(checked.values()), (env_options or {}).get("level_options"))
    by_protocol = {} if protocol is None else {
        label: options for label, level in checked.items() if (options := get_protocol(protocol).level_options_for(env, level))}
    jobs = [Job(label, level, seed) for label, level in checked.items() for seed in seeds]
    run = functools.partial(run_job, policy=policy, env=env, name=name, episodes=episodes, max_steps=max_steps,
                            env_options=dict(env_options or {}), tags=dict(tags or {}), device=device,
                            protocol_options=by_protocol)
    log = None if rows_path is None else _RowLog(Path(rows_path))
    if backend == "ray":
        from vigen.evaluation.ray_backend import run_jobs_on_ray

        return run_jobs_on_ray(jobs, run, workers=workers, progress=progress, log=log)
    rows: list[dict[str, Any]] = []
    for done, job in enumerate(jobs, start=1):
        try:
            job_rows = run(job, on_row=None if log is None else log.append)
        except JobError as failure:
            raise EvaluationError(rows + failure.rows, level=job.label, seed=job.seed, episode=failure.episode,
                                  rows_path=None if log is None else log.path, cause=failure.error) from failure.error
        rows += job_rows
        if progress is not None:
            progress(done, len(jobs))
    return rows


def run_job(job: Job, *, policy: Policy | None, env: str | EnvFactory, name: str, episodes: int, max_steps: int,
            env_options: dict[str, Any], tags: dict[str, Any], device: torch.device | str | None,
            on_row: Callable[[dict[str, Any]], None] | None = None,
            protocol_options: Mapping[str, Mapping[str, Any]] | None = None) -> list[dict[str, Any]]:
    """Play one job's episodes and return their rows; raises :class:`JobError` with the finished ones.

    ``policy=None`` plays uniform random actions drawn from ``job.seed``; ``tags`` are added to every
    row; ``on_row`` is called with each row as its episode ends; ``protocol_options`` (level label ->
    ``level_options``) go under the ``level_options`` of ``env_options``.

    Examples:
        >>> from vigen.evaluation.rollout import Job, run_job
        >>> rows = run_job(Job("train", "train", 3), policy=None, env="dmc/cartpole-balance", name="cartpole", episodes=2,
        ...                max_steps=5, env_options={}, tags={"method": "random"}, device=None)
        >>> [(row["method"], row["level"], row["seed"], row["episode"], row["length"]) for row in rows]
        [('random', 'train', 3, 0, 5), ('random', 'train', 3, 1, 5)]
    """
    rows: list[dict[str, Any]] = []
    episode: int | None = None
    try:
        if isinstance(env, str):
            options = env_options if device is None else {**env_options, "device": device}
            own = (protocol_options or {}).get(job.label)
            if own:
                options = {**options, "level_options": {**own, **(options.get("level_options") or {})}}
            if options.get("level_options"):  # each level gets the options its transforms take
                options = {**options, "level_options": level_options_for(env, job.level, options["level_options"])}
            instance = make_env(env, generalization=job.level, seed=job.seed, **options)
        else:
            instance = env(job.level, job.seed)
        try:
            acting = _random_policy(instance, job.seed) if policy is None else policy
            columns = {**level_columns(job.level), **data_columns(instance, options.get("level_options") if isinstance(env, str) else None)}
            for episode in range(episodes):
                row = {**tags, "env": name, "level": job.label, **columns, "seed": job.seed, "episode": episode,
                       **_play(acting, instance, max_steps)}
                if columns["data"]:
                    row["shown"] = shown_data(instance)
                rows.append(row)
                if on_row is not None:
                    on_row(row)
            episode = None
        finally:
            instance.close()
    except Exception as error:
        raise JobError(rows, episode, error) from error
    return rows


def data_columns(env: EnvBase, level_options: Mapping[str, Any] | None) -> dict[str, Any]:
    """What an env's level shows, for its rows: ``data`` (the level's data source, ``""`` if it shows none),
    ``stand_in`` (whether any of it is vigen's stand-ins) and ``level_options`` (the options given, as JSON).

    Examples:
        >>> from vigen.envs import make_env
        >>> data_columns(make_env("dmc/cartpole-balance", generalization="color_hard", image_size=32), None)
        {'data': 'dmcgb-colors/color_hard: 100 of 100, shipped', 'stand_in': False, 'level_options': ''}
    """
    level = getattr(env, "level", None)
    given = {key: portable_option(value) for key, value in (level_options or {}).items()}
    return {"data": "" if level is None else level.data_source, "stand_in": bool(level is not None and level.uses_stand_in),
            "level_options": json.dumps(given, sort_keys=True, default=str) if given else ""}


def portable_option(value: Any) -> Any:
    """A level option as a row records it: a folder or file by its name (``"folder video_easy"``), never the machine's path.

    Rows are shared and committed; the ``data`` column says what the folder held (its data set
    and file count, :mod:`vigen.datasets.identity`).

    Examples:
        >>> import tempfile, pathlib
        >>> folder = pathlib.Path(tempfile.mkdtemp()) / "video_easy"
        >>> folder.mkdir()
        >>> portable_option(str(folder)), portable_option(folder), portable_option(0.5), portable_option("dmcgb2")
        ('folder video_easy', 'folder video_easy', 0.5, 'dmcgb2')
    """
    if isinstance(value, (str, os.PathLike)):
        text = os.fspath(value)
        path = Path(text).expanduser()
        if isinstance(value, os.PathLike) or os.path.isabs(text) or text.startswith("~") or (os.sep in text and path.exists()):
            return f"{'folder' if path.is_dir() else 'file'} {path.name}"
    return value


def shown_data(env: EnvBase) -> str:
    """What the episode just played showed of its level's data, e.g. ``"video=video3.mp4"`` or ``"preset=17"``."""
    level = getattr(env, "level", None)
    shown = {} if level is None else level.episode_data()
    return "; ".join(f"{key}={value}" for key, value in shown.items())


def _check_levels(levels: Level | Sequence[Level], env: str | EnvFactory) -> dict[str, Level]:
    """Label -> level, groups expanded and repeats dropped; for an env name, dicts checked against its factors."""
    if isinstance(levels, (str, Mapping)):
        levels = [levels]
    if not isinstance(levels, Sequence):
        raise TypeError(f"levels must be a level name, a generalization dict or a list of them, got {levels!r}.")
    suite = env.split("/")[0] if isinstance(env, str) else None
    valid = None
    checked: dict[str, Level] = {}
    for level in levels:
        if isinstance(level, str):
            for resolved in (resolve_levels([level], suite=suite) if suite is not None else [level]):
                checked.setdefault(resolved, resolved)
            continue
        if not isinstance(level, Mapping):
            raise TypeError(f"levels: each level must be a name or a dict {{factor: intensity}}, got {level!r} "
                            f"({type(level).__name__}).")
        if not level:
            raise ValueError("levels: an empty generalization dict names no factor; use 'train' for the clean scene.")
        for factor, intensity in level.items():
            if not isinstance(factor, str):
                raise TypeError(f"levels: factor names are strings such as 'camera_rotation', got {factor!r}.")
            check_factor_intensity(factor, intensity, argument="levels")
        if isinstance(env, str):
            valid = factors(env) if valid is None else valid
            unknown = [factor for factor in level if factor not in valid]
            if unknown:
                raise ValueError(f"levels: unknown factors {unknown} for {env}; its factors are {', '.join(valid)}.")
        checked.setdefault(level_label(level), level)
    return checked


class _RowLog:
    """A CSV file that grows by one flushed line per row; new columns rewrite it (atomically) with a wider header."""

    def __init__(self, path: Path) -> None:
        if path.exists():
            raise FileExistsError(f"rows_path {path} exists and would be overwritten; choose a new file name.")
        path.parent.mkdir(parents=True, exist_ok=True)
        self.path = path
        self.columns: list[str] = []
        self.rows: list[dict[str, Any]] = []

    def append(self, row: dict[str, Any]) -> None:
        self.rows.append(row)
        new = [key for key in row if key not in self.columns]
        if new or not self.path.exists():
            self.columns += new
            text = io.StringIO()
            writer = csv.DictWriter(text, fieldnames=self.columns, restval="")
            writer.writeheader()
            writer.writerows(self.rows)
            atomic_write(self.path, text.getvalue())
            return
        with self.path.open("a", newline="") as file:
            csv.DictWriter(file, fieldnames=self.columns, restval="").writerow(row)
            file.flush()
            os.fsync(file.fileno())


def _random_policy(env: EnvBase, seed: int) -> Policy | None:
    """Uniform actions in ``env``'s bounds from a generator seeded with ``seed``; ``None`` (TorchRL's own draw) if unbounded."""
    spec = env.action_spec
    space = getattr(spec, "space", None)
    if not (hasattr(space, "low") and hasattr(space, "high")):
        return None
    generator = torch.Generator().manual_seed(seed)
    low, high = space.low, space.high

    def act(tensordict: TensorDictBase) -> TensorDictBase:
        draw = torch.rand(spec.shape, generator=generator, dtype=low.dtype).to(low.device)  # the CPU generator's draw, moved
        return tensordict.set("action", (low + (high - low) * draw).to(spec.dtype))

    return act


def _shape_checked(policy: Policy, spec: Any) -> Policy:
    """``policy``, refusing (before the env steps) an action whose shape is not the env's action spec's."""
    def act(tensordict: TensorDictBase) -> TensorDictBase:
        out = policy(tensordict)
        action = out.get("action", None)
        if action is None:
            raise KeyError("the policy wrote no 'action' entry; a policy takes the env's tensordict and sets 'action'.")
        if action.shape != spec.shape:
            raise ValueError(f"the policy's action has shape {tuple(action.shape)}, but the env's action spec has "
                             f"{tuple(spec.shape)}; build the policy for this env's action size "
                             f"(make_loss(..., action_dim={spec.shape[-1] if len(spec.shape) else 1})).")
        return out
    return act


def _play(policy: Policy | None, env: EnvBase, max_steps: int) -> dict[str, Any]:
    with set_exploration_type(ExplorationType.DETERMINISTIC), torch.no_grad():
        trajectory = env.rollout(max_steps, policy if policy is None else _shape_checked(policy, env.action_spec),
                                 break_when_any_done=True)
    episode = trajectory["next"]
    result: dict[str, Any] = {
        "return": float(episode["reward"].sum()),
        "length": int(trajectory.numel()),
    }
    if "success" in episode.keys():
        result["success"] = bool(episode["success"].any())
    return result
