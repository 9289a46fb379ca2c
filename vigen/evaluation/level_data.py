"""What each level of an evaluation shows: the videos a user gives per level, checked against the benchmark's data set,
and the ``data`` / ``stand_in`` columns of its rows, known before any episode runs.

A video level plays the benchmark's data once fetched (``python -m vigen.datasets fetch ...``), else
vigen's procedural stand-ins; ``examples/evaluate.py --videos`` gives folders per level instead,
as ``(pattern, folder)`` pairs (:func:`video_folders`): a level name or a shell pattern, the first
match wins. A folder given for a level of a benchmark data set must hold as many videos as that
data set's part (:func:`check_video_counts`), unless partial data is allowed.
"""

from __future__ import annotations

import fnmatch
from collections.abc import Callable, Iterable
from pathlib import Path
from typing import Any

import vigen.datasets
from vigen.assets.video_source import folder_videos
from vigen.envs import get_suite, level_label
from vigen.envs.level_types import FetchedData


def video_folders(items: Iterable[str]) -> list[tuple[str, Path]]:
    """``LEVEL=FOLDER`` or ``FOLDER`` items (``--videos``) -> (level pattern, folder) pairs, in order; a bare ``FOLDER``
    serves every level (``*``).

    Raises:
        ValueError: an item without a level before ``=`` or whose folder does not exist.

    Examples:
        >>> import tempfile
        >>> folder = tempfile.mkdtemp()
        >>> video_folders([f"video_easy={folder}", folder]) == [("video_easy", Path(folder)), ("*", Path(folder))]
        True
    """
    pairs = []
    for item in items:
        pattern, _, folder = item.rpartition("=") if "=" in item else ("*", "", item)
        path = Path(folder).expanduser()
        if not pattern or not path.is_dir():
            raise ValueError(f"--videos {item}: give LEVEL=FOLDER or FOLDER, with an existing folder "
                             f"({path} {'is not a folder' if pattern else 'has no level before ='}).")
        pairs.append((pattern, path))
    return pairs


def videos_for(env: str, level: Any, pairs: list[tuple[str, Path]]) -> dict[str, str]:
    """The ``level_options`` a level gets from ``--videos``: the first matching pattern's folder, if the level plays videos.

    Examples:
        >>> pairs = [("video_easy", Path("/e")), ("dcs_*", Path("/davis"))]
        >>> videos_for("dmc/walker-walk", "dcs_0.2", pairs), videos_for("dmc/walker-walk", "color_hard", pairs)
        ({'videos': '/davis'}, {})
    """
    suite, task = env.split("/", 1)
    if not pairs or "videos" not in get_suite(suite).options_taken(level, task):
        return {}
    label = level_label(level)
    folder = next((folder for pattern, folder in pairs if fnmatch.fnmatchcase(label, pattern)), None)
    return {} if folder is None else {"videos": str(folder)}


def in_runs(levels: list[Any], options_of: Callable[[Any], dict[str, str]]) -> list[tuple[list[Any], dict[str, str]]]:
    """Consecutive levels that share their ``level_options``, in order (one evaluate() call each keeps Ray's parallelism).

    Examples:
        >>> in_runs(["train", "video_easy", "video_hard"], lambda level: {"videos": "/v"} if level != "train" else {})
        [(['train'], {}), (['video_easy', 'video_hard'], {'videos': '/v'})]
    """
    runs: list[tuple[list[Any], dict[str, str]]] = []
    for level in levels:
        options = options_of(level)
        if runs and runs[-1][1] == options:
            runs[-1][0].append(level)
        else:
            runs.append(([level], options))
    return runs


def level_data_set(env: str, level: Any) -> tuple[str, str, int] | None:
    """(data set, part, its files) that ``level`` plays videos from once fetched (DMC-GB's ``video_easy``: 10), or ``None``."""
    suite, _ = env.split("/", 1)
    named = get_suite(suite).levels.get(level) if isinstance(level, str) else None
    for step in named.steps if named is not None else ():
        rule = step.params.get("videos")
        if isinstance(rule, FetchedData) and rule.part is not None:
            dataset = vigen.datasets.get_dataset(rule.dataset)
            if dataset.files:
                return dataset.name, rule.part, len(dataset.files_of(rule.part))
    return None


def check_video_counts(levels: dict[str, list[Any]], videos: list[tuple[str, Path]], allow_partial_data: bool) -> None:
    """Raise a ``ValueError`` where a ``--videos`` folder holds another number of videos than its level's data set part,
    unless ``allow_partial_data``; the message names each folder, the data set and the fixes."""
    problems = []
    for env, env_levels in levels.items():
        for level in env_levels:
            folder, expected = videos_for(env, level, videos).get("videos"), level_data_set(env, level)
            if folder is None or expected is None:
                continue
            dataset, part, count = expected
            found = len(folder_videos(folder))
            if found != count:
                problems.append(f"{level_label(level)}={folder}: {found} video{'s' * (found != 1)}; {level_label(level)} plays "
                                f"{dataset}/{part}, {count} videos")
    if problems and not allow_partial_data:
        parts = sorted({problem.split(" plays ")[1].split(",")[0] for problem in problems})
        fetch = "; ".join(f"python -m vigen.datasets fetch {name.split('/')[0]} --part {name.split('/')[1]}" for name in parts)
        raise ValueError("--videos: a folder does not hold its level's data set:\n" + "\n".join(f"  - {p}" for p in problems)
                         + f"\nFetch the data set ({fetch}) and drop --videos for these levels (they find it), give a folder "
                           "holding all of it, or pass --allow-partial-data to evaluate on these videos anyway (each row "
                           "then says what it showed).")


def shown_data(env: str, level: str, videos: list[tuple[str, Path]]) -> dict[str, Any]:
    """What ``level`` will show (its transforms built, no env), as the ``data`` / ``stand_in`` columns of its rows."""
    suite, task = env.split("/", 1)
    built = [transform for transform in get_suite(suite).level_transforms(task, level, **videos_for(env, level, videos))
             if hasattr(transform, "data_source")]
    return {"data": "; ".join(t.data_source for t in built), "stand_in": any(t.uses_stand_in for t in built)}
