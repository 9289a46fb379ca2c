"""Augmentations made of augmentations: one after another (``AugmentationChain``) or one per sample (``RandomChoice``)."""

from __future__ import annotations

from collections.abc import Iterable, Sequence

import torch
from tensordict.utils import NestedKey
from torch import Tensor, nn

from vigen.devices import host_reads_are_free
from vigen.seeding import derive_seed
from vigen.transforms.augmentations.base import ImageAugmentation, Params


def _check_members(name: str, augmentations: Sequence[ImageAugmentation], max_value: float | None) -> None:
    """Raise unless ``augmentations`` is a non-empty list of vigen augmentations that keep the image size and agree with
    the composite ``name`` on ``max_value``."""
    if isinstance(augmentations, ImageAugmentation) or not isinstance(augmentations, Sequence) or not augmentations:
        raise TypeError(f"{name} takes a non-empty list of vigen augmentations, e.g. [RandomRotate(), RandomShift(pad=16)].")
    for member in augmentations:
        if not isinstance(member, ImageAugmentation):
            raise TypeError(f"{name}: every member must be a vigen ImageAugmentation, got {type(member).__name__}.")
        if member.output_size(84, 84) != (84, 84):
            raise ValueError(f"{name}: {type(member).__name__} changes the image size; members must keep it.")
        if None not in (member.max_value, max_value) and member.max_value != max_value:
            raise ValueError(f"{name}: {type(member).__name__} has max_value={member.max_value} but the composite's "
                             f"is {max_value}; set it once, on the composite.")


class _Composite(ImageAugmentation):
    """Members held as submodules; ``max_value`` and the seed reach every member.

    A composite needs RGB stacks, or float pixels on ``[0, max_value]``, when any member does
    (``needs_rgb``, ``needs_scale``): a chain of geometric members takes any float range.
    """

    def __init__(
        self,
        augmentations: Sequence[ImageAugmentation],
        *,
        in_keys: Sequence[NestedKey] | NestedKey | None = None,
        out_keys: Sequence[NestedKey] | NestedKey | None = None,
        max_value: float | None = None,
        seed: int | None = None,
    ) -> None:
        _check_members(type(self).__name__, augmentations, max_value)
        self._max_value: float | None = None
        super().__init__(in_keys, out_keys, max_value=max_value, seed=None)
        self.members = nn.ModuleList(member.clone() for member in augmentations)
        self.max_value = max_value
        self.set_seed(seed)

    @property
    def needs_rgb(self) -> bool:  # type: ignore[override]
        return any(member.needs_rgb for member in self.members)

    @property
    def needs_scale(self) -> bool:  # type: ignore[override]
        return any(member.needs_scale for member in self.members)

    @property
    def max_value(self) -> float | None:  # type: ignore[override]
        return self._max_value

    @max_value.setter
    def max_value(self, value: float | None) -> None:
        self._max_value = value
        for member in getattr(self, "members", ()):
            member.max_value = value

    def set_seed(self, seed: int | None) -> None:
        """Seed this draw and each member's own stream below ``seed`` (``None``: the global RNG)."""
        super().set_seed(seed)
        for index, member in enumerate(getattr(self, "members", ())):
            member.set_seed(derive_seed(seed, index + 1))

    def clone(self) -> _Composite:
        """A copy whose members' generators continue from these members' states, on their own."""
        copy = super().clone()
        copy.members = nn.ModuleList(member.clone() for member in self.members)
        return copy

    def extra_repr(self) -> str:
        return "[" + ", ".join(f"{type(member).__name__}({member.extra_repr()})" for member in self.members) + "]"


class AugmentationChain(_Composite):
    """Apply augmentations one after another, each with its own draw (DMC-GB2's ``rotate_shift``, ``conv_overlay``).

    ``AugmentationChain([a, b])(x)`` is ``b(a(x))``; its parameters are the members' parameters,
    drawn in order and stored flat (member ``i``'s ``key`` as ``"i.key"``), so a draw replays exactly. Members must keep the image size. The members are
    copies; ``seed`` seeds each member's own stream (``derive_seed(seed, index)``).

    Paper: DMC-GB2 / SADA, https://arxiv.org/abs/2405.17416.

    Args:
        augmentations: the members, applied in list order.
        in_keys, out_keys, max_value, seed: see :class:`~vigen.transforms.ImageAugmentation`.

    Examples:
        >>> import torch
        >>> from vigen.transforms import AugmentationChain, RandomRotate, RandomShift
        >>> chain = AugmentationChain([RandomRotate(180), RandomShift(pad=16)], seed=0)
        >>> pixels = torch.randint(0, 256, (4, 9, 84, 84), dtype=torch.uint8)
        >>> params = chain.make_params(pixels)
        >>> rotate, shift = chain.members
        >>> sorted(params)  # member i's parameters under "i."
        ['0.degrees', '1.offsets']
        >>> turned = rotate.apply(pixels, {"degrees": params["0.degrees"]})
        >>> torch.equal(chain.apply(pixels, params), shift.apply(turned, {"offsets": params["1.offsets"]}))
        True
    """

    def make_params(self, images: Tensor) -> Params:
        return _flatten(member.make_params(images) for member in self.members)

    def apply(self, images: Tensor, params: Params) -> Tensor:
        for index, member in enumerate(self.members):
            images = member.apply(images, _member_params(params, index))
        return images


class RandomChoice(_Composite):
    """Give each sample one augmentation, drawn uniformly among the members (DMC-GB2's ``compose_augs``).

    Each sample draws a member index, and every member draws its parameters for every sample
    (cheap: a few numbers each), so the parameters stay per sample and a draw replays or slices
    like any augmentation's. DMC-GB2 trains SADA with its ``all`` choice of six augmentations
    (see :func:`~vigen.transforms.dmcgb2_strong_augmentation`).

    On the CPU a member augments only the samples that chose it. Picking them out reads the
    choice back to the host, which on an accelerator is a synchronization and under
    ``torch.compile`` a data-dependent shape, so there (:func:`~vigen.devices.host_reads_are_free`
    is ``False``) every member augments the whole batch and each sample keeps its own member's
    result (``torch.where``): the same images, with no synchronization, for K members' work.

    Paper: DMC-GB2 / SADA, https://arxiv.org/abs/2405.17416.

    Args:
        augmentations: the members.
        in_keys, out_keys, max_value, seed: see :class:`~vigen.transforms.ImageAugmentation`.

    Examples:
        >>> import torch
        >>> from vigen.transforms import RandomChoice, RandomConv, RandomRotate
        >>> choice = RandomChoice([RandomRotate(180), RandomConv()], seed=0)
        >>> pixels = torch.randint(0, 256, (8, 9, 84, 84), dtype=torch.uint8)
        >>> params = choice.make_params(pixels)
        >>> params["choice"].shape, choice(pixels=pixels).dtype
        (torch.Size([8]), torch.uint8)
    """

    def make_params(self, images: Tensor) -> Params:
        choice = self.randint(len(self.members), images.shape[0], like=images)
        return {"choice": choice, **_flatten(member.make_params(images) for member in self.members)}

    def apply(self, images: Tensor, params: Params) -> Tensor:
        choice = params["choice"]
        if host_reads_are_free(choice):  # a member augments only the samples that chose it (a mask index reads values)
            out = images.clone()
            for index, member in enumerate(self.members):
                selected = choice == index
                if selected.any():
                    own = {key: value[selected] for key, value in _member_params(params, index).items()}
                    out[selected] = member.apply(images[selected], own)
            return out
        # on an accelerator and under torch.compile: every member augments every sample, and each sample keeps its
        # own member's result; the same output, with no host synchronization and static shapes, for K times the work
        out = images
        for index, member in enumerate(self.members):
            selected = (choice == index).reshape(-1, *(1,) * (images.ndim - 1))
            out = torch.where(selected, member.apply(images, _member_params(params, index)), out)
        return out


def _flatten(member_params: Iterable[Params]) -> Params:
    """Members' parameters in one flat dict: member ``i``'s ``key`` is ``"i.key"`` (per-sample tensors stay per sample)."""
    return {f"{index}.{key}": value for index, params in enumerate(member_params) for key, value in params.items()}


def _member_params(params: Params, index: int) -> Params:
    prefix = f"{index}."
    return {key[len(prefix):]: value for key, value in params.items() if key.startswith(prefix)}
