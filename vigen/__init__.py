"""vigen: TorchRL modules for visual generalization in reinforcement learning.

vigen rebuilds the ideas of the RL-ViGen benchmark (https://arxiv.org/abs/2307.10224) as TorchRL
``Transform``s, ``LossModule``s and env builders:

* ``vigen.envs``: pixel envs (dm_control suite first) ready for TorchRL pipelines;
* ``vigen.transforms``: training-time augmentations and evaluation-time visual perturbations;
* ``vigen.losses``: augmentation-based actor-critic losses.

Importing vigen selects MuJoCo's offscreen EGL backend unless ``MUJOCO_GL`` is already set (see
:mod:`vigen.rendering`), so import vigen before dm_control or mujoco.
"""

from vigen.rendering import configure_mujoco_gl

configure_mujoco_gl()

__version__ = "0.1.0"

__all__ = ["__version__"]
