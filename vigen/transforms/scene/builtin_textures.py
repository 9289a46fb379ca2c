"""MuJoCo's builtin texture rules (``checker`` with edge marks, ``gradient`` skybox), to rebuild a texture for new colours.

DMC-GB and DMC-GB2 recolour a scene by rewriting the XML and recompiling the model, so MuJoCo regenerates the
grid and sky textures from the new ``rgb1`` / ``rgb2``. vigen writes the same pixels into the live model
instead: a colour becomes a byte as MuJoCo's ``(mjtByte)(255 * c)`` (truncation), edge marks keep their
``markrgb``, and the cube gradient is MuJoCo's sigmoid of the elevation (``user_texture.cc``, ``interp`` and
``BuiltinCube``). The rules are checked against the default texture of the live model before use.

Examples:
    >>> to_bytes(np.array([0.1, 0.2, 0.109165])).tolist()
    [25, 51, 27]
    >>> edge_ring(4, 5).astype(int).tolist()[1]
    [1, 0, 0, 0, 1]
"""

from __future__ import annotations

import numpy as np

CUBE_FACES = 6
SIDE, UP, DOWN = 0, 1, 2
FACE_MAPS = (SIDE, SIDE, UP, DOWN, SIDE, SIDE)
"""Which elevation map each cube face uses (MuJoCo's face order: right, left, up, down, front, back)."""


def to_bytes(value: np.ndarray) -> np.ndarray:
    """Colours in [0, 1] (float64) as MuJoCo turns them into texture bytes: ``(mjtByte)(255 * c)``, truncated."""
    return (255.0 * np.asarray(value, dtype=np.float64)).astype(np.uint8)


def edge_ring(height: int, width: int) -> np.ndarray:
    """``[height, width]`` True on the outermost rows and columns: where ``mark="edge"`` paints ``markrgb``."""
    ring = np.zeros((height, width), dtype=bool)
    ring[[0, -1], :] = True
    ring[:, [0, -1]] = True
    return ring


def gradient_alpha(position: np.ndarray) -> np.ndarray:
    """MuJoCo's gradient weight of ``rgb1`` at ``position`` in [-1, 1]: ``0.5 (1 + √2 p / √(1 + p²))``, clipped to [0, 1]."""
    return np.clip(0.5 * (1.0 + position / np.sqrt(1.0 + position * position) / (1.0 / np.sqrt(2.0))), 0.0, 1.0)


def cube_gradient_alphas(width: int) -> np.ndarray:
    """``[3, width, width]``: the ``rgb1`` weight of each pixel of the side, up and down faces of a gradient skybox."""
    rows, cols = np.meshgrid(np.arange(width), np.arange(width), indexing="ij")
    x = 2 * cols / (width - 1.0) - 1
    y = 1 - 2 * rows / (width - 1.0)
    norm = np.sqrt(1 + x * x + y * y)
    side = np.arcsin(y / norm) / (0.5 * np.pi)
    up = 1 - np.arccos(1.0 / norm) / (0.5 * np.pi)
    return np.stack([gradient_alpha(side), gradient_alpha(up), gradient_alpha(-up)])


def cube_gradient(alphas: np.ndarray, rgb1: np.ndarray, rgb2: np.ndarray) -> np.ndarray:
    """``[6 * width, width, 3]`` uint8: the six faces of MuJoCo's gradient skybox from ``rgb1`` (top) to ``rgb2``.

    Examples:
        >>> faces = cube_gradient(cube_gradient_alphas(3), np.array([0.4, 0.6, 0.8]), np.zeros(3))
        >>> faces.shape, faces[7, 1].tolist(), faces[10, 1].tolist()  # the up and down faces' centres
        ((18, 3, 3), [102, 153, 204], [0, 0, 0])
    """
    rgb1, rgb2 = np.asarray(rgb1, dtype=np.float64), np.asarray(rgb2, dtype=np.float64)
    maps = [(255.0 * (alpha[..., None] * rgb1 + (1 - alpha[..., None]) * rgb2)).astype(np.uint8) for alpha in alphas]
    return np.concatenate([maps[index] for index in FACE_MAPS])


def fit_gradient_top(alphas: np.ndarray, pixels: np.ndarray) -> np.ndarray | None:
    """An ``rgb1`` that rebuilds ``pixels`` (``[6 * width * width, 3]`` uint8) as a gradient to black, or ``None``.

    The bytes only bound ``rgb1``: each pixel ``p`` with weight ``a`` needs ``p <= 255 a c < p + 1``.
    The middle of the bounds of every non-white pixel (white ones are the random marks) is returned
    if the bounds meet. (MuJoCo's parse of dm_control's ``rgb1=".4 .6 .8"`` is not the closest double
    to 0.4: its sky tops out at 101, not 102, so the colour must be fitted, not read off one pixel.)
    """
    low, high = np.zeros(3), np.full(3, np.inf)
    faces = pixels.reshape(CUBE_FACES, -1, 3)
    for face, index in zip(faces, FACE_MAPS):
        weight = 255.0 * alphas[index].reshape(-1, 1)
        use = ~(face == 255).all(axis=1) & (weight[:, 0] > 0)
        low = np.maximum(low, (face[use] / weight[use]).max(axis=0, initial=0.0))
        high = np.minimum(high, ((face[use] + 1.0) / weight[use]).min(axis=0, initial=np.inf))
    if not (low < high).all() or not np.isfinite(high).all():
        return None
    return (low + high) / 2
