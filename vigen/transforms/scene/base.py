"""Scene transforms: Transforms that act on the live MuJoCo scene of the env they sit in.

A scene transform reaches its env's simulator through a small interface, :class:`SceneHandle`,
which every vigen env exposes as ``env.base_env.scene``. There are two kinds:

* :class:`ScenePerturbation` edits the model (colours, textures, lights, cameras). It draws its
  parameters once per episode, before the reset frame is rendered (TorchRL's
  ``_reset_env_preprocess`` hook), always applies them to the model's saved default values (so
  nothing drifts over many resets), and may also move things every step (``advance``).
* A pixel compositor such as :class:`~vigen.transforms.VideoBackground` leaves the model alone
  and rewrites the rendered frames, using the scene's segmentation to find what to replace.

Both are :class:`SceneTransform`: seeded from their own generator, placed on the raw frames
before any channel-first conversion or frame stacking, and only usable inside a single env.
"""

from __future__ import annotations

from typing import Any, Protocol, runtime_checkable

import numpy as np
import torch
from tensordict import TensorDictBase
from torchrl.envs import Transform

Defaults = dict[str, np.ndarray]
SceneParams = dict[str, Any]


@runtime_checkable
class SceneHandle(Protocol):
    """What a scene perturbation needs from an env: the live MuJoCo model and data, and texture uploads.

    ``model`` and ``data`` are the raw ``mujoco.MjModel`` / ``mujoco.MjData`` the env renders
    from. ``upload_texture(texture_id)`` makes the renderer see edited texture pixels
    (``model.tex_data``); it is a no-op before the first render, since MuJoCo uploads every
    texture when it creates its render context. ``segmentation()`` renders the env's camera view
    as ``[H, W, 2]`` (object id, ``mjtObj`` type), ``-1`` where no object is hit (the sky).
    """

    model: Any
    data: Any

    def upload_texture(self, texture_id: int) -> None: ...

    def segmentation(self) -> np.ndarray: ...




class SceneTransform(Transform):
    """Base of every transform that needs its env's scene: the seed, the scene handle, pickling.

    Subclasses draw all their randomness from :meth:`generator` (a NumPy generator seeded with
    ``seed``), reach the simulator through :attr:`scene` and refuse to run on plain data.

    Args:
        seed: seed of the transform's own NumPy generator. ``None`` draws the seed from torch's
            global RNG at the first reset, so ``ParallelEnv.set_seed`` gives every worker its own.

    Examples:
        >>> from vigen.transforms import RandomCamera, VideoBackground
        >>> isinstance(RandomCamera(), SceneTransform), isinstance(VideoBackground(), SceneTransform)
        (True, True)
    """

    def __init__(self, seed: int | None = None, in_keys: list | None = None) -> None:
        super().__init__(in_keys=in_keys or [], out_keys=in_keys or [])
        self.seed = seed
        self._rng: np.random.Generator | None = None
        self.params: SceneParams | None = None

    def set_seed(self, seed: int | None) -> None:
        """Restart the draws from ``seed`` (``None``: a seed from torch's global RNG at the next reset).

        The next reset then draws what a new transform built with ``seed`` would draw: the
        current episode's parameters are forgotten (they take effect again from that reset).
        """
        self.seed = seed
        self._rng = None
        self.params = None

    @property
    def scene(self) -> SceneHandle:
        """The scene handle of the env this transform sits in."""
        parent = self.parent
        base = getattr(parent, "base_env", None)
        if not isinstance(getattr(type(base), "scene", None), property):  # batched envs answer any attribute
            where = "no env" if parent is None else type(base).__name__
            raise RuntimeError(
                f"{type(self).__name__} acts on the MuJoCo scene of the env it sits in, but found {where}. "
                "Put it inside a single vigen env (make_env('dmc/...').append_transform(t), or generalization=[t]); for "
                "ParallelEnv, build it inside the factory each worker calls."
            )
        return base.scene

    def episode_data(self) -> dict[str, Any]:
        """What this episode shows of the transform's data (a video's file, a preset's index), for evaluation rows; ``{}`` here."""
        return {}

    def generator(self) -> np.random.Generator:
        """The transform's NumPy generator, created from ``seed`` at first use."""
        if self._rng is None:
            seed = self.seed if self.seed is not None else int(torch.randint(0, 2**62, ()).item())
            self._rng = np.random.default_rng(seed)
        return self._rng

    def extra_repr(self) -> str:
        return ""

    def forward(self, tensordict: TensorDictBase) -> TensorDictBase:
        raise RuntimeError(f"{type(self).__name__} acts on a simulator scene: it works inside an env, not on data.")

    def __repr__(self) -> str:
        extra = self.extra_repr()
        seed = "" if self.seed is None else f"seed={self.seed}"
        return f"{type(self).__name__}({', '.join(part for part in (extra, seed) if part)})"


class ScenePerturbation(SceneTransform):
    """Base of the scene perturbations: per-episode draws applied to saved defaults.

    Subclasses implement :meth:`read_defaults` (copy the model values they edit),
    :meth:`sample` (all the randomness, from a NumPy generator) and :meth:`apply` (write
    ``defaults`` + the draw into the model), and optionally :meth:`advance` (per-step motion).

    The transform must sit inside the env whose scene it edits (in each ``ParallelEnv``
    worker, i.e. in the factory you hand to ``ParallelEnv``), not around a batched env.

    Args:
        seed: seed of the transform's own NumPy generator. ``None`` draws the seed from torch's
            global RNG at the first reset, so ``ParallelEnv.set_seed`` gives every worker its own.

    Examples:
        >>> class RandomGravity(ScenePerturbation):
        ...     def read_defaults(self, scene):
        ...         return {"gravity": scene.model.opt.gravity.copy()}
        ...     def sample(self, rng, defaults):
        ...         return {"scale": rng.uniform(0.5, 1.5)}
        ...     def identity_params(self, defaults):
        ...         return {"scale": 1.0}
        ...     def apply(self, scene, defaults, params):
        ...         scene.model.opt.gravity[:] = defaults["gravity"] * params["scale"]
        >>> from vigen.envs import make_env
        >>> env = make_env("dmc/walker-walk", generalization=[RandomGravity(seed=0)], image_size=32)
        >>> _ = env.reset()
        >>> float(env.base_env.scene.model.opt.gravity[2]) != -9.81
        True
    """

    def __init__(self, seed: int | None = None) -> None:
        super().__init__(seed=seed)
        self._defaults: Defaults | None = None
        self._model: Any = None

    # -- what subclasses write --------------------------------------------------------------
    def read_defaults(self, scene: SceneHandle) -> Defaults:
        raise NotImplementedError

    def sample(self, rng: np.random.Generator, defaults: Defaults) -> SceneParams:
        raise NotImplementedError

    def apply(self, scene: SceneHandle, defaults: Defaults, params: SceneParams) -> None:
        raise NotImplementedError

    def advance(self, scene: SceneHandle, defaults: Defaults, params: SceneParams) -> None:
        """Per-step change after each env step (default: none)."""

    # -- machinery ---------------------------------------------------------------------------
    def defaults(self, scene: SceneHandle) -> Defaults:
        """The model's values before any edit, read once per model (again if the model is rebuilt)."""
        if self._defaults is None or self._model is not scene.model:
            self._defaults = self.read_defaults(scene)
            self._model = scene.model
        return self._defaults

    def restore(self) -> None:
        """Write the saved defaults back into the model (the scene as it was before this transform)."""
        scene = self.scene
        self.apply(scene, self.defaults(scene), self.identity_params(self.defaults(scene)))
        self.params = None

    def identity_params(self, defaults: Defaults) -> SceneParams:
        """Parameters that leave the scene at its defaults."""
        raise NotImplementedError

    def _reset_env_preprocess(self, tensordict: TensorDictBase | None) -> TensorDictBase | None:
        scene = self.scene
        defaults = self.defaults(scene)
        self.params = self.sample(self.generator(), defaults)
        self.apply(scene, defaults, self.params)
        return tensordict

    def _step(self, tensordict: TensorDictBase, next_tensordict: TensorDictBase) -> TensorDictBase:
        if self.params is not None:
            scene = self.scene
            self.advance(scene, self.defaults(scene), self.params)
        return next_tensordict

    def _call(self, next_tensordict: TensorDictBase) -> TensorDictBase:
        return next_tensordict

    def __getstate__(self) -> dict[str, Any]:
        state = super().__getstate__()
        state["_model"] = None  # MuJoCo handles stay in their process; defaults are re-read there
        state["_defaults"] = None
        return state
