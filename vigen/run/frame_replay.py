"""A replay buffer in the device's memory that keeps one frame per observation and rebuilds frame stacks when it samples.

A stacked observation (DrQ-v2's ``[9, 84, 84]``: three frames) stored twice per transition, as
``pixels`` and the next pixels, takes 127 KB; the same transitions hold about one new 84×84×3
frame each (21 KB), because consecutive stacks share all but one frame. :class:`FrameReplay`
keeps the frames once, in a ring on the device, and per transition the ring rows of its
observation's stack and of its next observation's stack: DrQ-v2's 1M-transition buffer fits in
about 22 GB of one GPU instead of 128 GB.

What a sample must equal is what the replay buffer of ``examples/train.py`` stores: TorchRL's
``MultiStepTransform`` over the collector's batches, the env's frame stacks in ``pixels`` and
``("next", "pixels")``. Two things decide it:

* **Frame stacks at episode starts.** TorchRL's ``CatFrames`` (vigen's pixel chain stacks with it,
  ``padding="same"``) shows at a reset the reset frame ``k`` times, then shifts one new frame in
  per step: the observation ``t`` steps into an episode shows frames ``max(t - k + 1, 0) … t``.
  The next observation of a step that ends an episode is the terminal observation, stacked from
  the episode's own frames; the observation after it is the next episode's reset stack. So every
  observation is one new frame (its newest) and the ring rows of the frames before it in its
  episode, which the buffer records as the frames arrive: a reset frame's stack is that row ``k``
  times, every later observation's stack is its predecessor's shifted by one row.
* **n-step returns.** The transitions are TorchRL's own ``MultiStepTransform`` (the same ``n`` and
  ``γ``) run on the collector's batches with each observation replaced by its ``k`` ring rows:
  it sums the rewards, cuts the window at episode ends, counts ``steps_to_next_obs`` and gathers
  the next observation's rows exactly as it gathers the next pixels, and holds back the last ``n``
  steps of each worker until the next batch. The transitions therefore come out in the same
  order, and land in the same slots of a ring of the same capacity, as the stacked buffer's.

``extend`` checks, on the host, that the batch's stacks are what this rebuilds (each non-reset
observation equals the step before's next observation, each reset observation is its newest
frame ``k`` times, each next observation is its observation shifted by one frame), and raises,
naming the worker and step, where they are not (``check=False`` skips the comparison). Frames and
transitions are written with pinned, non-blocking copies into fixed memory.

``sample`` draws the slots with ``torch.randint`` on the device from the buffer's own generator
(seeded) and gathers the transitions and their frames there: nothing is read back to the host,
so a CUDA graph can capture it (:class:`vigen.run.SampledUpdate` captures it with the update).

Examples:
    >>> import torch
    >>> from tensordict import TensorDict
    >>> from vigen.run import FrameReplay
    >>> frames = torch.arange(6, dtype=torch.uint8).view(6, 1, 1, 1).expand(6, 3, 2, 2)  # frame i: all pixels i
    >>> stack = lambda *i: torch.cat([frames[j] for j in i])  # noqa: E731  (CatFrames' [3k, H, W])
    >>> steps = TensorDict({"pixels": torch.stack([stack(0, 0, 0), stack(0, 0, 1), stack(0, 1, 2), stack(3, 3, 3)]),
    ...     "action": torch.zeros(4, 1), "next": {"pixels": torch.stack([stack(0, 0, 1), stack(0, 1, 2), stack(1, 2, 5), stack(3, 3, 4)]),
    ...     "reward": torch.ones(4, 1), "done": torch.tensor([[False], [False], [True], [False]]),
    ...     "terminated": torch.tensor([[False], [False], [True], [False]]), "truncated": torch.zeros(4, 1, dtype=torch.bool)}},
    ...     batch_size=[4])
    >>> replay = FrameReplay(10, batch_size=2, n_step=1, gamma=0.99, device="cpu")
    >>> replay.extend(steps)  # 4 steps, 1 held back for the 1-step window; 6 frames stored, not 2 × 4 stacks
    >>> len(replay), replay.frames_stored
    (3, 6)
    >>> batch = replay.gather(torch.tensor([2]))  # the step that ended the episode: its next stack holds frame 5
    >>> batch["pixels"][0, :, 0, 0].tolist()[::3], batch["next", "pixels"][0, :, 0, 0].tolist()[::3]
    ([0, 1, 2], [1, 2, 5])
    >>> replay.sample()["pixels"].shape
    torch.Size([2, 9, 2, 2])
"""

from __future__ import annotations

import math

import numpy as np
import torch
from tensordict import TensorDict, TensorDictBase
from torch import Tensor
from torchrl.envs.transforms import MultiStepTransform

from vigen.cuda_graph import indexed
from vigen.run.replay import to_device

ROWS = "_frame_rows"
"""The entry of a transition (and of its ``"next"``) that holds its stack's ``k`` ring rows, oldest first."""

_DRAW_RANGE = 2**62  # slots are drawn as randint(2**62) % length: uniform to within length / 2**62


class FrameReplay:
    """A replay buffer on ``device``: one frame per observation in a ring, stacks and n-step transitions rebuilt as stored.

    See the module for what it stores and why a sample equals the stacked buffer's.

    Args:
        capacity: transitions it holds (a ring, like ``LazyTensorStorage(capacity)``).
        batch_size: transitions per :meth:`sample`.
        n_step: n of the n-step returns (TorchRL's ``MultiStepTransform(n_step, gamma)``).
        gamma: their discount.
        device: where frames and transitions live and batches are gathered.
        frame_channels: channels of one frame (3: RGB); ``pixels`` holds ``k`` of them.
        frame_capacity: frames the ring holds (default ``capacity + capacity // 16 + 4096``): each
            transition needs its new frame, each episode one more (its reset frame), so
            episodes of 16 steps and more fit; :meth:`extend` raises before overwriting a frame
            that a stored transition still shows.
        seed: the seed of the generator that draws the sampled slots (on ``device``).
        reward_scale: multiplies the n-step reward, as ``examples/train.py`` scales it.
        check: compare the batch's stacks with what the buffer rebuilds (on the host) at each ``extend``.
    """

    def __init__(self, capacity: int, batch_size: int, *, n_step: int, gamma: float, device: torch.device | str,
                 frame_channels: int = 3, frame_capacity: int | None = None, seed: int = 0, reward_scale: float = 1.0,
                 check: bool = True) -> None:
        if capacity < 1 or batch_size < 1:
            raise ValueError(f"FrameReplay: capacity ({capacity}) and batch_size ({batch_size}) must be >= 1.")
        self.capacity, self.batch_size, self.device = capacity, batch_size, indexed(device)
        self.frame_capacity = frame_capacity if frame_capacity is not None else capacity + capacity // 16 + 4096
        self.frame_channels, self.reward_scale, self.check = frame_channels, reward_scale, check
        self.n_step = MultiStepTransform(n_step, gamma)
        self.generator = torch.Generator(device=self.device).manual_seed(seed)
        self._frames: Tensor | None = None  # [frame_capacity, C, H, W] uint8, on the device
        self._transitions: TensorDictBase | None = None  # [capacity], on the device; ROWS hold frame ring rows
        self._count = torch.zeros((), dtype=torch.long, device=self.device)  # the length, for draws on the device
        self._length = self._cursor = 0
        self._frames_stored = 0  # frames written since the start (absolute frame numbers count from 0)
        self._oldest = np.full(capacity, np.iinfo(np.int64).max, dtype=np.int64)  # per slot: the oldest frame it shows
        self._workers: int | None = None
        self._stacks: Tensor | None = None  # per worker: its current observation's stack (absolute frame numbers)
        self._ended: Tensor | None = None  # per worker: its last step ended an episode (the next observation is a reset)
        self._last_next: Tensor | None = None  # per worker: its last next pixels, for the check across batches
        self._held_back: Tensor | None = None  # [workers, <= n]: the oldest frame of each step the n-step transform holds back
        self._layout: tuple[int, int, int, int] | None = None  # k, C, H, W
        self._failed: str | None = None  # why an extend stopped half-way (the buffer is then unusable)

    def __len__(self) -> int:
        return self._length

    @property
    def frames_stored(self) -> int:
        """Frames written since the start (each observation's newest frame, once)."""
        return self._frames_stored

    def bytes_on_device(self) -> int:
        """The device memory the buffer holds (frames, transitions and their ring rows)."""
        total = 0 if self._frames is None else self._frames.numel()
        if self._transitions is not None:
            total += sum(value.numel() * value.element_size()
                         for value in self._transitions.values(include_nested=True, leaves_only=True))
        return total

    # -- storing ----------------------------------------------------------------------------------
    def extend(self, steps: TensorDictBase) -> None:
        """Store a collector batch: ``[T]`` (one worker) or ``[workers, T]``, with ``pixels`` and ``("next", "pixels")`` stacks.

        The batch is what ``examples/train.py`` gives ``MultiStepTransform`` (before the n-step
        transform), on the host; consecutive calls continue each worker's trajectory.
        """
        self._raise_if_failed()
        steps = steps if steps.ndim == 2 else steps.unsqueeze(0)
        pixels, next_pixels, done = self._read(steps)
        if self.check:
            self._check_stacks(pixels, next_pixels, done)
        observed, following, new_frames, stacks = self._assign_frames(pixels, next_pixels, done)
        index_steps = steps.exclude("pixels", ("next", "pixels"))
        index_steps.set(ROWS, observed)
        index_steps.set(("next", ROWS), following)
        transitions = self.n_step.inv(index_steps)
        shown = torch.minimum(observed.amin(-1), following.amin(-1))  # [workers, T]: the oldest frame each step shows
        held_back = torch.cat([self._held_back, shown], 1)[:, -self.n_step.n_steps:]  # the steps MultiStepTransform keeps
        if transitions is not None:
            transitions = transitions.reshape(-1)
            if self.reward_scale != 1:
                transitions.set(("next", "reward"), transitions["next", "reward"] * self.reward_scale)
        try:
            self._check_ring(transitions, len(new_frames), torch.cat([stacks.flatten(), held_back.flatten()]))
        except RuntimeError as error:  # the n-step transform has taken the batch in: the buffer cannot go on
            self._failed = str(error)
            raise
        self._stacks, self._ended, self._held_back = stacks, done[:, -1].clone(), held_back
        self._write_frames(new_frames)
        if transitions is not None and transitions.numel():
            self._write_transitions(transitions)
        self._last_next = next_pixels[:, -1].clone()

    def _read(self, steps: TensorDictBase) -> tuple[Tensor, Tensor, Tensor]:
        keys = steps.keys(include_nested=True, leaves_only=True)
        missing = [key for key in ("pixels", ("next", "pixels"), ("next", "done")) if key not in keys]
        if missing:
            raise KeyError(f"FrameReplay.extend: the batch has no {missing}; give it a collector's batch (pixels stacked by "
                           "the env, the next pixels and done flags), before MultiStepTransform.")
        pixels, next_pixels = steps["pixels"], steps["next", "pixels"]
        if pixels.dtype != torch.uint8 or pixels.ndim != 5 or pixels.shape[2] % self.frame_channels:
            raise ValueError(f"FrameReplay.extend: pixels must be uint8 [workers, T, k·{self.frame_channels}, H, W] stacks; got "
                             f"{pixels.dtype}{list(pixels.shape)}.")
        if pixels.device.type != "cpu":
            raise ValueError(f"FrameReplay.extend: the batch is on {pixels.device}; give the collector's batch on the CPU (the "
                             "buffer reads its stacks and flags on the host and copies the new frames over itself).")
        k = pixels.shape[2] // self.frame_channels
        layout = (k, self.frame_channels, *pixels.shape[3:])
        workers = steps.shape[0]
        if self._layout is None:
            self._layout, self._workers = layout, workers
            self._stacks = torch.zeros(workers, k, dtype=torch.long)
            self._ended = torch.ones(workers, dtype=torch.bool)  # a worker's first observation is a reset
            self._held_back = torch.empty(workers, 0, dtype=torch.long)
        elif layout != self._layout or workers != self._workers:
            raise ValueError(f"FrameReplay.extend: this batch has {workers} worker(s) and stacks of {layout} (k, C, H, W); the "
                             f"buffer was started with {self._workers} and {self._layout}.")
        return pixels, next_pixels, steps["next", "done"].reshape(workers, -1)

    def _resets(self, done: Tensor) -> Tensor:
        """``[workers, T]``: whether each step's observation is a reset (the step before it ended an episode)."""
        return torch.cat([self._ended[:, None], done[:, :-1]], dim=1)

    def _check_stacks(self, pixels: Tensor, next_pixels: Tensor, done: Tensor) -> None:
        k, channels = self._layout[:2]
        reset = self._resets(done)
        first = self._last_next[:, None] if self._last_next is not None else pixels[:, :1]
        previous = torch.cat([first, next_pixels[:, :-1]], 1)
        problems = {
            "is not the step before's next observation (a trajectory must go on from one extend to the next)":
                ~(pixels == previous).flatten(2).all(-1) & ~reset,
            "starts an episode but is not its newest frame repeated (CatFrames' padding='same')":
                ~(pixels == pixels[:, :, -channels:].repeat(1, 1, k, 1, 1)).flatten(2).all(-1) & reset,
            "is not followed by its stack shifted by one frame in the next observation":
                ~(next_pixels[:, :, :-channels] == pixels[:, :, channels:]).flatten(2).all(-1),
        }
        for what, wrong in problems.items():
            if wrong.any():
                worker, step = (int(i) for i in wrong.nonzero()[0])
                raise ValueError(f"FrameReplay.extend: the observation of worker {worker} at step {step} of this batch {what}; "
                                 "the buffer rebuilds stacks as TorchRL's CatFrames makes them in one trajectory per worker. "
                                 "Store stacks it cannot rebuild in a stacked buffer (vigen.run.RunReplay).")

    def _assign_frames(self, pixels: Tensor, next_pixels: Tensor, done: Tensor) -> tuple[Tensor, Tensor, Tensor, Tensor]:
        """Each step's observation and next observation as ``k`` absolute frame numbers, the new frames in number order, and
        each worker's last observation after the batch (nothing is changed yet)."""
        k, channels = self._layout[:2]
        workers, length = done.shape
        reset = self._resets(done).tolist()
        observed: list[list[int]] = []
        following: list[list[int]] = []
        sources: list[Tensor] = []
        number = self._frames_stored
        stacks: list[list[int]] = []  # each worker's last observation, after the batch
        for worker in range(workers):
            stack = self._stacks[worker].tolist()
            for step in range(length):
                if reset[worker][step]:
                    sources.append(pixels[worker, step, -channels:])
                    stack = [number] * k
                    number += 1
                observed.append(stack)
                sources.append(next_pixels[worker, step, -channels:])
                stack = [*stack[1:], number]
                number += 1
                following.append(stack)
            stacks.append(stack)
        shape = (workers, length, k)
        return torch.tensor(observed).view(shape), torch.tensor(following).view(shape), torch.stack(sources), torch.tensor(stacks)

    def _check_ring(self, transitions: TensorDictBase | None, new: int, pending: Tensor) -> None:
        """Raise before writing ``new`` frames over one that a stored (or held-back) transition still shows."""
        oldest = self._oldest.copy()
        if transitions is not None and transitions.numel():
            shown = torch.minimum(transitions[ROWS].amin(-1), transitions["next", ROWS].amin(-1)).numpy()
            slots = (self._cursor + np.arange(len(shown))) % self.capacity
            oldest[slots] = shown
        needed = min(int(oldest.min()), int(pending.min()))
        overwritten = self._frames_stored + new - self.frame_capacity  # frames numbered below this are gone after the write
        if needed < overwritten:
            raise RuntimeError(f"FrameReplay: the frame ring of {self.frame_capacity} frames is too small for {self.capacity} "
                               f"transitions here (short episodes need a reset frame each): writing {new} frames would overwrite "
                               f"frame {needed}, which a stored transition shows. Pass frame_capacity= (e.g. "
                               f"{2 * self.capacity + 4096}) or a smaller capacity.")
        self._oldest = oldest

    def _write_frames(self, frames: Tensor) -> None:
        if self._frames is None:
            self._frames = torch.zeros((self.frame_capacity, *frames.shape[1:]), dtype=torch.uint8, device=self.device)
        if self.device.type == "cuda":  # pinned, so that the copy does not wait for the device's queued work
            frames = frames.pin_memory().to(self.device, non_blocking=True)
        else:
            frames = frames.to(self.device)
        for (start, stop), part in _ring_ranges(self._frames_stored, len(frames), self.frame_capacity):
            self._frames[start:stop].copy_(frames[part], non_blocking=True)
        self._frames_stored += len(frames)

    def _write_transitions(self, transitions: TensorDictBase) -> None:
        transitions = transitions.clone()
        transitions.set(ROWS, transitions[ROWS] % self.frame_capacity)
        transitions.set(("next", ROWS), transitions["next", ROWS] % self.frame_capacity)
        transitions = to_device(transitions, self.device)
        if self._transitions is None:
            self._transitions = transitions[:1].expand(self.capacity).clone().zero_()
        for (start, stop), part in _ring_ranges(self._cursor, len(transitions), self.capacity):
            self._transitions[start:stop] = transitions[part]
        self._cursor = (self._cursor + len(transitions)) % self.capacity
        self._length = min(self._length + len(transitions), self.capacity)
        self._count.fill_(self._length)

    def _raise_if_failed(self) -> None:
        if self._failed is not None:
            raise RuntimeError(f"FrameReplay: an earlier extend failed ({self._failed}); build a new buffer.")

    # -- sampling ---------------------------------------------------------------------------------
    def sample(self) -> TensorDictBase:
        """``batch_size`` transitions drawn uniformly (with replacement) on the device, their stacks rebuilt; nothing read back."""
        self._raise_if_failed()
        if self._length == 0:
            raise RuntimeError("FrameReplay.sample: the buffer holds no transition yet; extend it first.")
        index = torch.randint(_DRAW_RANGE, (self.batch_size,), generator=self.generator, device=self.device)
        return self.gather(index.remainder_(self._count))

    def gather(self, index: Tensor) -> TensorDictBase:
        """The transitions at ``index`` (slots, on the device) as the stacked buffer holds them, with ``"index"``."""
        batch = self._transitions[index]
        observed, following = batch.pop(ROWS), batch.pop(("next", ROWS))
        batch.set("pixels", self._frames[observed].flatten(1, 2))
        batch.set(("next", "pixels"), self._frames[following].flatten(1, 2))
        batch.set("index", index)
        return batch


def _ring_ranges(start: int, count: int, size: int) -> list[tuple[tuple[int, int], slice]]:
    """The slices of a ring of ``size`` that ``count`` items written from absolute position ``start`` go to, with their parts.

    Examples:
        >>> _ring_ranges(8, 5, 10)
        [((8, 10), slice(0, 2, None)), ((0, 3), slice(2, 5, None))]
    """
    if count > size:
        raise ValueError(f"FrameReplay: {count} items in one write exceed the ring's {size}; extend with smaller batches.")
    first = start % size
    head = min(count, size - first)
    ranges = [((first, first + head), slice(0, head))]
    if head < count:
        ranges.append(((0, count - head), slice(head, count)))
    return ranges


def frame_bytes(observation_shape: tuple[int, int, int], frame_channels: int = 3) -> int:
    """About how many bytes one transition takes in a :class:`FrameReplay`: one frame, its ring rows, 256 bytes of the rest.

    Examples:
        >>> frame_bytes((9, 84, 84))
        21472
    """
    stack = observation_shape[0] // frame_channels
    return frame_channels * math.prod(observation_shape[1:]) + 2 * 8 * stack + 256
