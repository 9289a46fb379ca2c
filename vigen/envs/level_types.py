"""Levels as data: what a named level or a factor at some intensity applies, and how it is built.

A :class:`Level` (``"color_hard"``, robosuite's ``"easy"``, DMC-GB2's ``"rotate_hard"``) and a
:class:`Factor` (``"camera_rotation"`` at an intensity in [0, 1]) are lists of :class:`Step`:
a transform class and its parameters. A parameter is a plain value, or a small named rule
(:class:`Derived`) that reads the :class:`LevelContext` — the task, the scene id or the
intensity — such as :class:`Scaled` (``0.05·x``) or :class:`ByTask`. Every suite declares its
tables in its :class:`~vigen.envs.suite.Suite` record, from these types; this module imports no
suite, so the records, the factor vocabulary and the Suite class all build on it.
:mod:`vigen.envs.levels` re-exports them next to the functions over every suite's tables.

Examples:
    >>> from vigen.envs.level_types import LevelContext, Scaled, Step
    >>> from vigen.transforms import RandomCamera
    >>> step = Step(RandomCamera, {"position": 0.0, "rotation_deg": Scaled(90.0)})
    >>> step.build(LevelContext("walker-walk", intensity=0.1))
    RandomCamera(position=0.0, rotation_deg=9.0, fov_deg=None)
"""

from __future__ import annotations

import inspect
import math
import numbers
import warnings
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

from torchrl.envs import Transform

import vigen.datasets
from vigen.assets.image_bank import ImageBank
from vigen.assets.procedural import STAND_IN_KINDS


@dataclass(frozen=True)
class LevelContext:
    """What a level's parameters may depend on: the task, the scene id (robosuite's 0..9) and the factor intensity."""

    task: str
    scene_id: int = 0
    intensity: float = 1.0


class Derived:
    """A parameter computed from the :class:`LevelContext` by a small named rule; ``repr`` is its formula.

    Subclasses set :attr:`depends_on_scene` when the value follows the scene id, so an env can
    move its level to another scene without rebuilding it.
    """

    depends_on_scene = False

    def __call__(self, context: LevelContext) -> Any:
        raise NotImplementedError


@dataclass(frozen=True, repr=False)
class ByTask(Derived):
    """The value for the context's task, from a table.

    Examples:
        >>> ByTask({"door": ("door",), "lift": ("cube",)})(LevelContext("lift"))
        ('cube',)
    """

    table: Mapping[str, Any]

    def __call__(self, context: LevelContext) -> Any:
        return self.table[context.task]

    def __repr__(self) -> str:
        return "by task: " + ", ".join(f"{task}: {value!r}" for task, value in self.table.items())


@dataclass(frozen=True, repr=False)
class SceneIndex(Derived):
    """``offset + scene_id``: the scene's own draw, e.g. its texture set or its video.

    Examples:
        >>> SceneIndex(10)(LevelContext("door", scene_id=3))
        13
    """

    offset: int = 0
    depends_on_scene = True

    def __call__(self, context: LevelContext) -> int:
        return self.offset + context.scene_id

    def __repr__(self) -> str:
        return f"{self.offset} + scene_id" if self.offset else "scene_id"


@dataclass(frozen=True, repr=False)
class Scaled(Derived):
    """``scale · x`` for the intensity ``x`` (a tuple scales each entry).

    Examples:
        >>> Scaled(0.5)(LevelContext("walk", intensity=0.2)), Scaled((1.0, 0.5))(LevelContext("walk", intensity=0.2))
        (0.1, (0.2, 0.1))
    """

    scale: float | tuple[float, ...]

    def __call__(self, context: LevelContext) -> float | tuple[float, ...]:
        if isinstance(self.scale, tuple):
            return tuple(s * context.intensity for s in self.scale)
        return self.scale * context.intensity

    def __repr__(self) -> str:
        return f"{self.scale}·x"


@dataclass(frozen=True, repr=False)
class Span(Derived):
    """``(-half · x, half · x)``: a symmetric range that widens with the intensity ``x``.

    Examples:
        >>> Span(40.0)(LevelContext("walk", intensity=0.25))
        (-10.0, 10.0)
    """

    half: float

    def __call__(self, context: LevelContext) -> tuple[float, float]:
        return (-self.half * context.intensity, self.half * context.intensity)

    def __repr__(self) -> str:
        return f"±{self.half}·x"


@dataclass(frozen=True, repr=False)
class Severity(Derived):
    """``⌈5 · x⌉``: an ImageNet-C severity (1..5) from the intensity ``x`` > 0.

    Examples:
        >>> [Severity()(LevelContext("walk", intensity=x)) for x in (0.1, 0.2, 0.5, 1.0)]
        [1, 1, 3, 5]
    """

    def __call__(self, context: LevelContext) -> int:
        return min(5, max(1, math.ceil(5 * context.intensity - 1e-9)))

    def __repr__(self) -> str:
        return "⌈5·x⌉"


@dataclass(frozen=True, repr=False)
class Choice(Derived):
    """One of ``options`` by intensity: ``x`` in ``((i-1)/n, i/n]`` picks the ``i``-th (of ``n``).

    Examples:
        >>> [Choice(("IIWA", "Kinova3"))(LevelContext("door", intensity=x)) for x in (0.3, 0.5, 0.9)]
        ['IIWA', 'IIWA', 'Kinova3']
    """

    options: tuple[Any, ...]

    def __call__(self, context: LevelContext) -> Any:
        index = math.ceil(context.intensity * len(self.options) - 1e-9) - 1
        return self.options[min(len(self.options) - 1, max(0, index))]

    def __repr__(self) -> str:
        return f"one of {self.options!r} by x"


@dataclass(frozen=True)
class StandInImages:
    """``count`` generated test-side textures of side ``size`` from ``seed``, made at the first reset (a texture set of a level).

    :meth:`ImageBank.stand_in` of ``kinds`` (of wood, marble, checker, mosaic): generators that the
    overlay augmentations' training images never use.
    """

    count: int
    size: int
    seed: int
    kinds: tuple[str, ...] = STAND_IN_KINDS

    def __call__(self) -> ImageBank:
        return ImageBank.stand_in(self.count, size=self.size, seed=self.seed, kinds=self.kinds)

    def __repr__(self) -> str:
        kinds = "" if self.kinds == STAND_IN_KINDS else f", kinds={self.kinds!r}"
        return f"stand-in({self.count}{kinds}, size={self.size}, seed={self.seed})"


@dataclass(frozen=True, repr=False)
class FetchedData(Derived):
    """The folder of a benchmark data set fetched with ``python -m vigen.datasets fetch`` (:func:`vigen.datasets.locate`), or ``None``.

    A level whose source shows real data (DMC-GB's videos, DAVIS 2017) names it here: when every
    file of the data set (or ``part``) is in the cache, the transform gets its folder (plus
    ``subfolder``); when not, it gets ``None`` (its stand-ins) and a :class:`~vigen.datasets.StandInDataWarning`
    names the command that fetches the data. A folder given in ``level_options`` replaces the rule.

    Examples:
        >>> import os, tempfile, warnings
        >>> before = os.environ.get("VIGEN_DATA")
        >>> os.environ["VIGEN_DATA"] = tempfile.mkdtemp()  # an empty cache
        >>> with warnings.catch_warnings(record=True) as caught:
        ...     warnings.simplefilter("always")
        ...     FetchedData("dmcgb-videos", "video_hard")(LevelContext("walker-walk"))
        >>> print(str(caught[0].message).split(" is not")[0])
        dmc/walker-walk shows stand-ins: dmcgb-videos (part video_hard)
        >>> _ = os.environ.pop("VIGEN_DATA") if before is None else os.environ.update(VIGEN_DATA=before)
    """

    dataset: str
    part: str | None = None
    subfolder: str = ""
    suite: str = "dmc"

    def __call__(self, context: LevelContext) -> str | None:
        folder = vigen.datasets.locate(self.dataset, self.part)
        if folder is None:
            what = f"{self.dataset}" + (f" (part {self.part})" if self.part else "")
            warnings.warn(vigen.datasets.StandInDataWarning(
                f"{self.suite}/{context.task} shows stand-ins: {what} is not in the data cache "
                f"{vigen.datasets.cache_root()}; fetch it with `{vigen.datasets.fetch_command(self.dataset, self.part)}` "
                "(docs/data.md), or pass a folder in level_options."), stacklevel=2)
            return None
        return str(folder / self.subfolder) if self.subfolder else str(folder)

    def __repr__(self) -> str:
        return f"fetched {self.dataset}{'/' + self.part if self.part else ''} (stand-ins without it)"


def evaluate_value(value: Any, context: LevelContext) -> Any:
    """A parameter's value in ``context``: a :class:`Derived` rule is applied, anything else is returned as it is."""
    return value(context) if isinstance(value, Derived) else value


@dataclass(frozen=True)
class Step:
    """One transform of a level: its class and its parameters (plain values or :class:`Derived` rules).

    Examples:
        >>> from vigen.transforms import RandomSceneColors
        >>> Step(RandomSceneColors, {"scale": 0.2})
        RandomSceneColors(scale=0.2)
    """

    transform: type[Transform]
    params: Mapping[str, Any] = field(default_factory=dict)

    def accepts(self) -> set[str]:
        """The keyword arguments the transform's constructor takes (its real signature), without ``seed``."""
        return accepted_options(self.transform)

    def build(self, context: LevelContext, options: Mapping[str, Any] | None = None) -> Transform:
        """The transform, with its parameters evaluated in ``context`` and the ``options`` it accepts on top.

        A parameter that an option replaces is not evaluated (a folder given for ``videos`` looks up no cache).
        """
        given = {name: value for name, value in (options or {}).items() if name in self.accepts()}
        params = {name: evaluate_value(value, context) for name, value in self.params.items() if name not in given}
        params.update(given)
        return self.transform(**params)

    def scene_params(self, context: LevelContext) -> dict[str, Any]:
        """The parameters that follow the scene id, evaluated in ``context`` (empty for most steps)."""
        return {name: value(context) for name, value in self.params.items() if isinstance(value, Derived) and value.depends_on_scene}

    def __repr__(self) -> str:
        return f"{self.transform.__name__}({', '.join(f'{name}={value!r}' for name, value in self.params.items())})"


def accepted_options(transform: type[Transform]) -> set[str]:
    """The keyword arguments of ``transform``'s constructor, without ``seed`` (seeds are derived, never passed).

    Examples:
        >>> from vigen.transforms import VideoBackground
        >>> {"videos", "floor"} <= accepted_options(VideoBackground), "seed" in accepted_options(VideoBackground)
        (True, False)
    """
    parameters = inspect.signature(transform.__init__).parameters.values()
    kinds = (inspect.Parameter.POSITIONAL_OR_KEYWORD, inspect.Parameter.KEYWORD_ONLY)
    return {p.name for p in parameters if p.kind in kinds and p.name not in ("self", "seed")}


@dataclass(frozen=True)
class Level:
    """A named level: what it shows, its source, its steps, and env options it sets (e.g. another robot).

    Examples:
        >>> from vigen.transforms import RandomSceneColors
        >>> level = Level("agent colour", "RL-ViGen objects_color hard", (Step(RandomSceneColors, {"scale": 0.2, "parts": ("self",)}),))
        >>> level.steps[0].transform.__name__
        'RandomSceneColors'
    """

    what: str
    source: str
    steps: tuple[Step, ...] = ()
    env_options: Mapping[str, Any] = field(default_factory=dict)
    tasks: tuple[str, ...] | None = None
    """The tasks the level applies to (the loco suite's Unitree-only cross-embodiment levels); ``None``: all of its suite's."""

    def applies_to(self, task: str) -> bool:
        return self.tasks is None or task in self.tasks


@dataclass(frozen=True)
class Factor:
    """One factor of variation in a suite: its steps at intensity ``x`` (parameters may read ``x``), and env options.

    ``points`` names the suite's levels that are this factor at one intensity (same transform,
    same parameters), e.g. ``{"objects_color_hard": 0.2}``.
    """

    steps: tuple[Step, ...] = ()
    env_options: Mapping[str, Any] = field(default_factory=dict)
    points: Mapping[str, float] = field(default_factory=dict)


def check_intensity(factor: str, intensity: Any) -> float:
    """``intensity`` as a float in [0, 1], or a clear error naming the factor.

    Examples:
        >>> check_intensity("camera_rotation", 0.5)
        0.5
        >>> check_intensity("camera_rotation", 2)
        Traceback (most recent call last):
        ...
        ValueError: Intensity of 'camera_rotation' must be in [0, 1] (0: off, 1: the strongest), got 2.
    """
    if isinstance(intensity, bool) or not isinstance(intensity, numbers.Real):
        raise TypeError(f"Intensity of {factor!r} must be a number in [0, 1], got {intensity!r} ({type(intensity).__name__}).")
    if not 0.0 <= float(intensity) <= 1.0 or math.isnan(float(intensity)):
        raise ValueError(f"Intensity of {factor!r} must be in [0, 1] (0: off, 1: the strongest), got {intensity}.")
    return float(intensity)


def level_label(generalization: str | Mapping[str, float] | None) -> str:
    """The row label of a level: its name, or ``factor=intensity`` joined by ``+`` (sorted by factor) for a factor dict.

    Examples:
        >>> level_label("color_hard"), level_label({"object_color": 0.5, "camera_rotation": 0.3}), level_label(None)
        ('color_hard', 'camera_rotation=0.3+object_color=0.5', 'train')
    """
    if generalization is None:
        return "train"
    if isinstance(generalization, str):
        return generalization
    return "+".join(f"{name}={float(value):g}" for name, value in sorted(generalization.items()))
