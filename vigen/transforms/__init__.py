"""Image augmentations (training time) and visual perturbations (evaluation time) as TorchRL Transforms.

This room may import torch, torchrl, tensordict, numpy and mujoco (scene edits only), never
``vigen.envs`` or ``vigen.losses``.
"""

__all__: list[str] = []
