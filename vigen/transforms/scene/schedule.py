"""When a drifting distraction moves: per env step, or per control step counted as the Distracting Control Suite counts them.

The Distracting Control Suite's wrappers sit under the action repeat, so they see every control
step: one ``env.step`` of the dm_control task, ``control_timestep / physics timestep`` MuJoCo steps
(the walker's 10), not every MuJoCo step. The original suite (google-research ``distracting_control/camera.py:283-289``,
``color.py`` ``step``, ``background.py`` ``step``) moves the camera, the colours and the video on
every control step; DMC-GB's copy (nicklashansen/dmcontrol-generalization-benchmark
``src/env/distracting_control/camera.py:283-292``, ``color.py:75-89``, ``background.py:217-238``)
counts control steps from the reset and moves only on the even ones. A vigen env step is
``action_repeat`` control steps, so the number of moves per env step follows from the count.
"""

from __future__ import annotations

from typing import Any

from torchrl.envs import Transform


def check_update_every(name: str, update_every: int | None) -> None:
    """Raise a ValueError unless ``update_every`` is ``None`` or an int >= 1."""
    if update_every is not None and (isinstance(update_every, bool) or not isinstance(update_every, int) or update_every < 1):
        raise ValueError(f"{name}: update_every is the number of control steps between two moves (DMC-GB's DCS: 2, the "
                         f"original DCS: 1), an int >= 1, or None for one move per env step; got {update_every!r}.")


def updates_due(params: dict[str, Any], update_every: int, action_repeat: int) -> int:
    """Moves due during the next env step of ``action_repeat`` control steps, advancing the episode's count in ``params``.

    A move happens at every control step ``c`` (counted from 1 after the reset) with
    ``c % update_every == 0``, as DCS's wrappers count ``_frame_count``.

    Examples:
        >>> params = {}
        >>> [updates_due(params, 2, 3) for _ in range(4)]  # control steps 1-3, 4-6, 7-9, 10-12
        [1, 2, 1, 2]
        >>> params = {}
        >>> [updates_due(params, 1, 4) for _ in range(2)]
        [4, 4]
    """
    before = params.get("control_steps", 0)
    params["control_steps"] = before + action_repeat
    return params["control_steps"] // update_every - before // update_every


def action_repeat_of(transform: Transform) -> int:
    """The control steps per env step of the env ``transform`` sits in (its base env's ``action_repeat``)."""
    base = getattr(transform.parent, "base_env", None)
    repeat = getattr(base, "action_repeat", None)
    if isinstance(repeat, bool) or not isinstance(repeat, int) or repeat < 1:
        raise RuntimeError(
            f"{type(transform).__name__}(update_every=...) counts control steps, so it needs the action repeat of its env, "
            f"but {type(base).__name__} has no int action_repeat. Pass update_every=None (one move per env step) instead."
        )
    return repeat
