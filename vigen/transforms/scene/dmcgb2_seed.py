"""DMC-GB2 seeds each of its wrappers with the env's own seed; vigen's DMC-GB2 transforms recover that seed from theirs.

DMC-GB2 (aalmuzairee/dmcgb2, ``envs/dmcgb/dmcgb_wrapper.py:17-31``) builds every wrapper with the seed of the
env: the camera wrappers shuffle their 100 presets with ``np.random.RandomState(seed)``
(``dmcgb_geometric.py:15, 25, 125, 130``) and the colour / video wrapper draws one start index
``np.random.RandomState(seed).randint(100)`` for its colour cycle and its video cycle together
(``dmcgb_photometric.py:31, 53, 58, 62``). A vigen env seeded ``s`` gives its ``i``-th transform the seed
``derive_seed(s, i) = s * 1_000_003 + i`` (exact for env seeds below ``2**32``), so ``s`` is that seed
divided by 1_000_003: :func:`env_seed_of`. Every DMC-GB2 transform (``DMCGB2Camera``, ``RandomSceneColors``
with ``draw="dmcgb2"``, ``DMCGB2VideoBackground``) plays the presets DMC-GB2 plays for the same env seed.
DMC-GB seeds its ``ColorWrapper`` the same way (``src/env/wrappers.py``: ``np.random.RandomState(seed)``,
one ``randint`` per reset), so ``RandomSceneColors``' default draw recovers the env seed here too.

Paper: Almuzairee et al., DMC-GB2, https://arxiv.org/abs/2405.17416.

Examples:
    >>> from vigen.seeding import derive_seed
    >>> env_seed_of(derive_seed(7, 0)), env_seed_of(derive_seed(7, 2)), photometric_start(0)
    (7, 7, 44)
"""

from __future__ import annotations

import numbers

import numpy as np

from vigen.seeding import ENV_SEED_LIMIT, SEED_STRIDE

NUM_PRESETS = 100
"""DMC-GB2's count of camera presets (``_num_starting_rots`` / ``_num_starting_shifts``) and its start-index range."""


def env_seed_of(transform_seed: int) -> int:
    """The env seed ``s`` a vigen env derived ``transform_seed`` from: ``derive_seed(s, i) // 1_000_003``.

    Exact for env seeds below ``2**32`` (vigen's range) and chain indices below 1_000_003. A seed
    that was not derived (a transform built with ``seed=5`` by hand) maps to ``5 // 1_000_003 = 0``:
    give such a transform ``source_seed=`` instead.

    Examples:
        >>> env_seed_of(3 * 1_000_003 + 1), env_seed_of(5)
        (3, 0)
    """
    return int(transform_seed) // SEED_STRIDE


def check_source_seed(source_seed: int | None, owner: str) -> int | None:
    """``source_seed`` as an int in ``[0, 2**32)`` (NumPy's ``RandomState`` range) or ``None``; a clear error otherwise."""
    if source_seed is None:
        return None
    if isinstance(source_seed, bool) or not isinstance(source_seed, numbers.Integral) or not 0 <= source_seed < ENV_SEED_LIMIT:
        raise ValueError(f"{owner}: source_seed is the source env's seed (DMC-GB's / DMC-GB2's), an int in [0, 2**32) "
                         f"(or None: the seed of the vigen env the transform sits in); got {source_seed!r}.")
    return int(source_seed)


def resolve_source_seed(source_seed: int | None, transform_seed: int | None, rng: np.random.Generator) -> int:
    """The seed DMC-GB2 would have: ``source_seed`` if given, else the env seed behind ``transform_seed``, else a draw."""
    if source_seed is not None:
        return source_seed
    if transform_seed is not None:
        return env_seed_of(transform_seed)
    return int(rng.integers(ENV_SEED_LIMIT))


def photometric_start(seed: int) -> int:
    """``ColorVideoWrapper``'s start index for env seed ``seed``: ``np.random.RandomState(seed).randint(100)``.

    Episode ``k`` shows colour preset ``(start + k) % len(colors)`` and video ``(start + 1 + k) % len(videos)``
    (``dmcgb_photometric.py:53, 58, 62``; the video index is advanced before its first use, line 120).

    Examples:
        >>> photometric_start(1), photometric_start(2)
        (37, 40)
    """
    return int(np.random.RandomState(seed).randint(NUM_PRESETS))
