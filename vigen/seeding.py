"""The one rule that derives every seed vigen uses below a user's seed: per transform, per worker, per video, per run segment.

Examples:
    >>> from vigen.seeding import derive_seed
    >>> derive_seed(7, 0), derive_seed(7, 0) == derive_seed(7, 0), derive_seed(7, 0) != derive_seed(7, 1)
    (7000021, True, True)
"""

from __future__ import annotations

ENV_SEED_LIMIT = 2**32
"""Env seeds lie in ``[0, 2**32)``: the range of NumPy's ``RandomState`` (dm_control) and of ``ParallelEnv``'s worker seeds."""

DERIVED_SEED_LIMIT = 2**63
"""Derived seeds are taken modulo this, so that they fit a ``torch.Generator`` and NumPy's generators."""

SEED_STRIDE = 1_000_003
"""A prime: ``derive_seed(seed, i)`` gives distinct streams for distinct seeds and indices."""


def derive_seed(seed: int | None, *path: int, below: int = DERIVED_SEED_LIMIT) -> int | None:
    """The seed of one stream below ``seed``: ``path`` names it (e.g. a transform's index in its env).

    Each step folds one index in as ``seed * 1_000_003 + index`` (modulo ``2**63``), so distinct
    seeds and paths give distinct streams and one index reproduces what vigen has always drawn.
    ``None`` stays ``None`` (unseeded: the global RNG decides). ``below`` bounds the result:
    :data:`ENV_SEED_LIMIT` for a seed handed to an env (``make_env(..., seed=)``, a worker).

    Examples:
        >>> derive_seed(0, 1), derive_seed(2, 0), derive_seed(None, 3)
        (1, 2000006, None)
        >>> derive_seed(5000, 7, below=ENV_SEED_LIMIT) < 2**32
        True
    """
    if seed is None:
        return None
    for index in path:
        seed = (seed * SEED_STRIDE + index) % DERIVED_SEED_LIMIT
    return seed % below
