"""The parity harness: the run's settings and batch, float64 mode, replayed draws, what a case declares,
running both sides of one update, and comparing and reporting them (see the package's docstring)."""

from __future__ import annotations

import copy
import math
import types
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass, field
from typing import Any

import torch
from torch import Tensor

from benchmarks.parity.checkout import Reference

Pairs = list[tuple[Tensor, Tensor]]  # (source the augmentation must be given, the view it returns)


# -- settings ----------------------------------------------------------------------------------
@dataclass(frozen=True)
class Setup:
    """The shared sizes and draws of one parity run (tiny, float64)."""

    batch_size: int = 8
    image_size: int = 84
    frames: int = 3
    action_dim: int = 4
    feature_dim: int = 50
    hidden_dim: int = 32
    lr: float = 1e-4
    gamma: float = 0.99
    nstep: int = 3
    step: int = 90_000  # the std schedule linear(1.0, 0.1, 100000) gives 0.19 here: some noise clipped, some not
    seed: int = 0

    @property
    def channels(self) -> int:
        return 3 * self.frames

    @property
    def obs_shape(self) -> tuple[int, int, int]:
        return (self.channels, self.image_size, self.image_size)


@dataclass
class Batch:
    """One replay batch, float64 pixels on the 0–255 scale (integer-valued, as stored uint8 frames)."""

    pixels: Tensor
    next_pixels: Tensor
    action: Tensor
    reward: Tensor
    nstep: int
    gamma: float

    @classmethod
    def draw(cls, setup: Setup, nstep: int) -> Batch:
        g = torch.Generator().manual_seed(setup.seed)
        shape = (setup.batch_size, *setup.obs_shape)
        return cls(
            pixels=torch.randint(0, 256, shape, generator=g).to(torch.float64),
            next_pixels=torch.randint(0, 256, shape, generator=g).to(torch.float64),
            action=torch.rand(setup.batch_size, setup.action_dim, generator=g, dtype=torch.float64) * 2 - 1,
            reward=torch.randn(setup.batch_size, 1, generator=g, dtype=torch.float64),
            nstep=nstep,
            gamma=setup.gamma,
        )

    def for_original(self) -> tuple[Tensor, ...]:
        """``(obs, action, reward, discount, next_obs)`` as RL-ViGen's replay buffer yields it."""
        discount = torch.full_like(self.reward, self.gamma**self.nstep)
        return (self.pixels.clone(), self.action.clone(), self.reward.clone(), discount, self.next_pixels.clone())

    def for_vigen(self) -> Any:
        from tensordict import TensorDict

        size = self.pixels.shape[0]
        no = torch.zeros(size, 1, dtype=torch.bool)
        data = {
            "pixels": self.pixels.clone(), "action": self.action.clone(),
            "next": {"pixels": self.next_pixels.clone(), "reward": self.reward.clone(), "done": no, "terminated": no.clone()},
        }
        if self.nstep != 1:
            data["steps_to_next_obs"] = torch.full((size, 1), self.nstep, dtype=torch.long)
        return TensorDict(data, batch_size=[size])


# -- float64 everywhere ------------------------------------------------------------------------
@contextmanager
def float64_mode() -> Iterator[None]:
    """float64 while the block runs: the default dtype, ``Tensor.float()`` and ``torch.FloatTensor(...)``.

    ``Tensor.float()`` keeps float64 (complex: the real part, as ``.float()`` does);
    ``torch.FloatTensor(...)`` builds float64 (VRL3's zero BC term would make its actor loss float32).
    """
    real_float, real_float_tensor, default = torch.Tensor.float, torch.FloatTensor, torch.get_default_dtype()

    def as_float64(self: Tensor, *args: Any, **kwargs: Any) -> Tensor:
        return (self.real if self.is_complex() else self).to(torch.float64)

    def float_tensor(*args: Any, **kwargs: Any) -> Tensor:  # torch.FloatTensor(data) or torch.FloatTensor(*size)
        if len(args) == 1 and not isinstance(args[0], (int, torch.Size)):
            return torch.as_tensor(args[0], dtype=torch.float64)
        return torch.empty(*args, dtype=torch.float64)

    torch.set_default_dtype(torch.float64)
    torch.Tensor.float = as_float64  # type: ignore[method-assign]
    torch.FloatTensor = float_tensor  # type: ignore[misc, assignment]
    try:
        yield
    finally:
        torch.Tensor.float = real_float  # type: ignore[method-assign]
        torch.FloatTensor = real_float_tensor  # type: ignore[misc]
        torch.set_default_dtype(default)


# -- replayed draws ----------------------------------------------------------------------------
def _find(pairs: Pairs, used: list[bool], images: Tensor, who: str) -> Tensor:
    for index, (source, view) in enumerate(pairs):
        if not used[index] and source.shape == images.shape and torch.equal(source, images.detach()):
            used[index] = True
            return view.clone()
    raise RuntimeError(
        f"{who} was asked to augment a tensor that is none of its expected sources (shape {tuple(images.shape)}): "
        "the update feeds this augmentation something else than the original does."
    )


class ReplayCallable:
    """Replaces an original's augmentation callable: returns the pre-drawn view of each source, in order."""

    def __init__(self, pairs: Pairs, name: str) -> None:
        self.pairs, self.name, self.used = pairs, name, [False] * len(pairs)

    def __call__(self, images: Tensor, *args: Any, **kwargs: Any) -> Tensor:
        return _find(self.pairs, self.used, images, f"original {self.name}")


def replay_augmentation(pairs: Pairs, name: str) -> Any:
    """A vigen ``ImageAugmentation`` whose ``make_params`` picks the pre-drawn view of its input."""
    from vigen.transforms import ImageAugmentation

    class ReplayViews(ImageAugmentation):
        def __init__(self) -> None:
            super().__init__(max_value=255)
            self.pairs, self.name, self.used = pairs, name, [False] * len(pairs)

        def make_params(self, images: Tensor) -> dict[str, Tensor]:
            return {"view": _find(self.pairs, self.used, images, f"vigen {self.name}")}

        def apply(self, images: Tensor, params: dict[str, Tensor]) -> Tensor:
            return params["view"].reshape(images.shape).to(images.dtype)

    return ReplayViews()


class Draws:
    """One stream of standard normals (handed out in call order) and one uniform scalar ``u``."""

    def __init__(self, seed: int, size: int = 100_000) -> None:
        g = torch.Generator().manual_seed(seed + 1)
        self.normals = torch.randn(size, generator=g, dtype=torch.float64)
        self.u = float(torch.rand((), generator=g, dtype=torch.float64))
        self.cursor = 0
        self.uniform_calls = 0

    def normal(self, shape: Sequence[int], dtype: torch.dtype | None) -> Tensor:
        count = math.prod(shape)
        if self.cursor + count > self.normals.numel():
            raise RuntimeError("benchmarks.parity: the noise stream ran out; raise Draws(size=...).")
        out = self.normals[self.cursor: self.cursor + count].reshape(tuple(shape))
        self.cursor += count
        return out.to(dtype or torch.get_default_dtype(), copy=True)  # the originals scale it in place

    def uniform(self, low: Any, high: Any) -> Any:
        self.uniform_calls += 1
        return low + (high - low) * self.u

    @contextmanager
    def patched(self, python_random_modules: Sequence[types.ModuleType] = ()) -> Iterator[None]:
        """Route the draws of both sides through this object while the block runs."""
        import torch.distributions.normal as normal_module
        import torch.distributions.utils as dist_utils

        draws = self
        real = {"randn_like": torch.randn_like, "randn": torch.randn, "rand": torch.rand}

        def randn_like(t: Tensor, *args: Any, dtype: torch.dtype | None = None, **kwargs: Any) -> Tensor:
            return draws.normal(t.shape, dtype or t.dtype).to(t.device)

        def randn(*size: Any, generator: Any = None, dtype: torch.dtype | None = None, **kwargs: Any) -> Tensor:
            if generator is not None:
                return real["randn"](*size, generator=generator, dtype=dtype, **kwargs)
            shape = size[0] if len(size) == 1 and isinstance(size[0], (tuple, list, torch.Size)) else size
            return draws.normal(shape, dtype)

        def rand(*size: Any, generator: Any = None, **kwargs: Any) -> Tensor:
            shape = size[0] if len(size) == 1 and isinstance(size[0], (tuple, list, torch.Size)) else size
            if generator is None and tuple(shape) == ():
                return torch.tensor(draws.uniform(0.0, 1.0), dtype=kwargs.get("dtype"), device=kwargs.get("device"))
            return real["rand"](*size, generator=generator, **kwargs)

        def standard_normal(shape: Sequence[int], dtype: torch.dtype, device: Any) -> Tensor:
            return draws.normal(shape, dtype).to(device)

        shim = types.SimpleNamespace(uniform=self.uniform)
        targets = [(torch, "randn_like", randn_like), (torch, "randn", randn), (torch, "rand", rand),
                   (dist_utils, "_standard_normal", standard_normal), (normal_module, "_standard_normal", standard_normal)]
        for module in python_random_modules:
            if hasattr(module, "_standard_normal"):
                targets.append((module, "_standard_normal", standard_normal))
            if hasattr(module, "random"):
                targets.append((module, "random", shim))
        saved = [(obj, name, getattr(obj, name)) for obj, name, _ in targets]
        for obj, name, value in targets:
            setattr(obj, name, value)
        try:
            yield
        finally:
            for obj, name, value in saved:
                setattr(obj, name, value)

    def reset(self) -> None:
        self.cursor, self.uniform_calls = 0, 0


class Views:
    """The views of one batch, drawn once with vigen's augmentations (seeded), float64 on 0–255."""

    def __init__(self, batch: Batch, setup: Setup) -> None:
        from vigen.transforms import RandomFrequencyMask, RandomOverlay, RandomShift

        self.batch = batch
        seed = setup.seed + 100
        self._shift = lambda k, x: RandomShift(pad=4, max_value=255, seed=seed + k).augment(x)
        self._overlay = lambda k, x: RandomOverlay(alpha=0.5, max_value=255, seed=seed + 10 + k).augment(x)
        # p=1 so that the frequency ring is really cut in this one batch (RL-ViGen draws p=0.5 per batch)
        self._srm = lambda x: RandomFrequencyMask(p=1.0, max_value=255, seed=seed + 20).augment(x)
        self.obs = self._shift(0, batch.pixels)
        self.next_obs = self._shift(1, batch.next_pixels)

    def weak(self) -> Pairs:
        return [(self.batch.pixels, self.obs), (self.batch.next_pixels, self.next_obs)]

    def shift(self, k: int) -> Tensor:
        return self._shift(2 + k, self.batch.pixels)

    def overlay(self, k: int, x: Tensor) -> Tensor:
        return self._overlay(k, x)

    def srm(self, x: Tensor) -> Tensor:
        return self._srm(x)


# -- what an algorithm entry declares ----------------------------------------------------------
@dataclass(frozen=True)
class ModuleMap:
    """An original network (attribute path on the agent) → a vigen network (canonical prefix).

    ``renames`` maps a leading part of the original's parameter names to vigen's (e.g. ``Q1`` →
    ``q1``). A plain tensor attribute (DrQ's ``log_alpha``) maps to the name ``prefix`` itself.
    """

    attribute: str
    prefix: str
    renames: tuple[tuple[str, str], ...] = ()

    def resolve(self, agent: Any) -> dict[str, Tensor]:
        obj = agent
        for part in self.attribute.split("."):
            obj = getattr(obj, part)
        if isinstance(obj, Tensor):
            return {self.prefix: obj}
        out = {}
        for name, param in obj.named_parameters():
            for old, new in self.renames:
                if name == old or name.startswith(old + "."):
                    name = new + name[len(old):]
                    break
            out[f"{self.prefix}.{name}"] = param
        return out


@dataclass(frozen=True)
class StepMap:
    """An update step of the original (its optimizers' k-th ``step()`` calls) and vigen's ``loss_*`` for it."""

    name: str
    loss: str
    optimizers: tuple[tuple[str, int], ...]


Measure = Callable[[Any, Any], str]  # (the original's agent, vigen's loss), both after their update → a sentence


@dataclass
class Case:
    """Both sides of one algorithm, ready to run, and what the comparison needs to know."""

    name: str
    agent: Any
    loss: Any
    modules: list[ModuleMap]
    steps: list[StepMap]
    agent_views: dict[str, Pairs]
    module_views: list[tuple[types.ModuleType, str, Pairs]]
    draw_modules: list[types.ModuleType]
    metrics: list[tuple[str, str]]  # (vigen output key, original metric key)
    departures: list[str]
    reference: Reference
    batch: Batch
    setup: Setup
    update_kwargs: dict[str, Any] = field(default_factory=dict)  # the original's update(replay_iter, step, **these)
    # gradients that are 0 in exact arithmetic (name → why): compared on the scale of their step's largest gradient
    zero_gradients: dict[str, str] = field(default_factory=dict)
    measures: list[Measure] = field(default_factory=list)  # sentences on what the update leaves behind (not compared)
    # normals the original draws for outputs it never uses (after all the ones it uses): not owed by vigen
    unused_normals: int = 0


def canonical(vigen_name: str) -> str:
    """``encoder_params.convnet.0.weight`` → ``encoder.convnet.0.weight`` (the table's names)."""
    head, _, rest = vigen_name.partition(".")
    head = head[: -len("_params")] if head.endswith("_params") else head
    return f"{head}.{rest}" if rest else head


def copy_weights(case: Case) -> None:
    """Original → vigen, by mapped names; every vigen parameter must be covered, shapes must agree."""
    original = {}
    for module_map in case.modules:
        original.update(module_map.resolve(case.agent))
    vigen = {canonical(n): p for n, p in case.loss.named_parameters()}
    missing = sorted(set(vigen) - set(original))
    extra = sorted(set(original) - set(vigen))
    if missing or extra:
        raise RuntimeError(f"{case.name}: parameter names do not map: vigen only {missing}, original only {extra}.")
    with torch.no_grad():
        for name, param in vigen.items():
            if param.shape != original[name].shape:
                raise RuntimeError(f"{case.name}: {name} has shape {tuple(param.shape)} in vigen, {tuple(original[name].shape)} in the original.")
            param.copy_(original[name])
        target = getattr(case.loss, "target_critic_params", None)
        if target is not None:  # from the original's own target critic (equal to its critic at start)
            critic_target = ModuleMap("critic_target", "critic", next(m.renames for m in case.modules if m.prefix == "critic"))
            source = critic_target.resolve(case.agent)
            for key, value in target.items(True, True):
                name = "critic." + ".".join(key if isinstance(key, tuple) else (key,))
                value.data.copy_(source[name])


# -- running both sides ------------------------------------------------------------------------
@dataclass
class StepRecord:
    optimizer: str
    loss_index: int
    grads: dict[int, Tensor]


@dataclass
class OriginalRun:
    losses: list[Tensor]
    steps: list[StepRecord]
    metrics: dict[str, float]
    names: dict[int, str]  # id(parameter) → canonical name
    normals: int
    uniforms: int
    agent: Any = None  # the original's agent after the update


def run_original(case: Case, draws: Draws, take_steps: bool) -> OriginalRun:
    agent = copy.deepcopy(case.agent)
    names = {}
    for module_map in case.modules:
        names.update({id(p): n for n, p in module_map.resolve(agent).items()})
    optimizers = {k: v for k, v in vars(agent).items() if isinstance(v, torch.optim.Optimizer)}
    losses: list[Tensor] = []
    steps: list[StepRecord] = []
    real_backward = torch.Tensor.backward

    def backward(self: Tensor, *args: Any, **kwargs: Any) -> None:
        losses.append(self.detach().clone())
        real_backward(self, *args, **kwargs)

    def recorder(name: str, optimizer: torch.optim.Optimizer) -> Callable[..., Any]:
        def step(*args: Any, **kwargs: Any) -> Any:
            grads = {id(p): p.grad.detach().clone() for group in optimizer.param_groups for p in group["params"] if p.grad is not None}
            steps.append(StepRecord(name, len(losses) - 1, grads))
            return type(optimizer).step(optimizer, *args, **kwargs) if take_steps else None
        return step

    for attr, pairs in case.agent_views.items():
        setattr(agent, attr, ReplayCallable(pairs, attr))
    for name, optimizer in optimizers.items():
        optimizer.step = recorder(name, optimizer)  # type: ignore[method-assign]
    saved = [(module, attr, getattr(module, attr)) for module, attr, _ in case.module_views]
    for module, attr, pairs in case.module_views:
        setattr(module, attr, ReplayCallable(pairs, f"{module.__name__}.{attr}"))
    draws.reset()
    torch.Tensor.backward = backward  # type: ignore[method-assign]
    try:
        with draws.patched(case.draw_modules):
            metrics = agent.update(iter([case.batch.for_original()]), case.setup.step, **case.update_kwargs)
    finally:
        torch.Tensor.backward = real_backward  # type: ignore[method-assign]
        for module, attr, value in saved:
            setattr(module, attr, value)
    return OriginalRun(losses, steps, dict(metrics or {}), names, draws.cursor, draws.uniform_calls, agent)


@dataclass
class VigenRun:
    values: dict[str, float]
    grads: dict[str, dict[str, Tensor | None]]  # loss key → canonical name → gradient
    normals: int
    uniforms: int


def run_vigen(case: Case, draws: Draws) -> VigenRun:
    loss = case.loss
    draws.reset()
    params = dict(loss.named_parameters())
    trainable = {name: p for name, p in params.items() if p.requires_grad}  # frozen ones (PIE-G's ResNet) get none
    with draws.patched():
        out = loss(case.batch.for_vigen())
    grads: dict[str, dict[str, Tensor | None]] = {}
    for key in [k for k in out.keys() if k.startswith("loss_")]:
        result = torch.autograd.grad(out[key], list(trainable.values()), retain_graph=True, allow_unused=True)
        grads[key] = {canonical(n): None for n in params} | {canonical(n): g for n, g in zip(trainable, result)}
    values = {k: float(v.detach()) for k, v in out.items() if v.numel() == 1}
    return VigenRun(values, grads, draws.cursor, draws.uniform_calls)


# -- comparison --------------------------------------------------------------------------------
TINY = torch.finfo(torch.float64).tiny


def relative(a: Tensor | float, b: Tensor | float, scale: float | None = None) -> float:
    """``max|a − b| / max(max|b|, tiny)``; ``scale`` replaces ``max|b|`` (a quantity that is 0 in exact arithmetic)."""
    a, b = torch.as_tensor(a, dtype=torch.float64), torch.as_tensor(b, dtype=torch.float64)
    if scale is None:
        scale = b.abs().max().item() if b.numel() else 0.0
    diff = (a - b).abs().max().item() if a.numel() else 0.0
    return diff / max(scale, TINY) if diff else 0.0


@dataclass
class Row:
    quantity: str
    vigen: float
    original: float
    rel: float
    stepped: float | None = None  # rel. diff against the original with its optimizer steps taken
    kind: str = "grad"  # "loss", "metric", "grad", "stray"


def _step_records(run: OriginalRun, step: StepMap, case: Case) -> list[StepRecord]:
    records = []
    for optimizer, index in step.optimizers:
        calls = [r for r in run.steps if r.optimizer == optimizer]
        if index >= len(calls):
            raise RuntimeError(f"{case.name}: the original called {optimizer}.step() {len(calls)} times, the map expects call #{index}.")
        records.append(calls[index])
    if len({r.loss_index for r in records}) != 1:
        raise RuntimeError(f"{case.name}: the optimizers of step {step.name!r} consumed different backward passes.")
    return records


def compare(case: Case, fixed: OriginalRun, stepped: OriginalRun, ours: VigenRun) -> list[Row]:
    rows: list[Row] = []
    for step in case.steps:
        records = _step_records(fixed, step, case)
        records_stepped = _step_records(stepped, step, case)
        value, value_stepped = fixed.losses[records[0].loss_index], stepped.losses[records_stepped[0].loss_index]
        mine = ours.values[step.loss]
        rows.append(Row(f"{step.loss} ({step.name} step)", mine, float(value), relative(mine, value), relative(mine, value_stepped), "loss"))
    for vigen_key, original_key in case.metrics:
        if original_key in fixed.metrics and vigen_key in ours.values:
            mine, theirs = ours.values[vigen_key], fixed.metrics[original_key]
            rows.append(Row(f"{vigen_key} ({original_key})", mine, theirs, relative(mine, theirs),
                            relative(mine, stepped.metrics[original_key]), "metric"))
    for step in case.steps:
        owned: set[str] = set()
        stepped_grads = {}
        for record in _step_records(stepped, step, case):
            stepped_grads.update({stepped.names[i]: g for i, g in record.grads.items()})
        records = _step_records(fixed, step, case)
        largest = max((g.abs().max().item() for r in records for g in r.grads.values() if g.numel()), default=0.0)
        for record in records:
            for pid, theirs in record.grads.items():
                name = fixed.names[pid]
                owned.add(name)
                mine = ours.grads[step.loss].get(name)
                mine = torch.zeros_like(theirs) if mine is None else mine
                quantity, scale = f"∂{step.loss}/∂{name}", None
                if name in case.zero_gradients:  # both sides are rounding noise: measure it against the step's gradients
                    quantity, scale = f"{quantity} (0 in exact arithmetic; rel. to the step's largest gradient)", largest
                rows.append(Row(quantity, mine.norm().item(), theirs.norm().item(), relative(mine, theirs, scale),
                                relative(mine, stepped_grads[name], scale) if name in stepped_grads else None))
        for name, mine in ours.grads[step.loss].items():
            if name not in owned and mine is not None and mine.abs().max().item() > 0:
                rows.append(Row(f"stray ∂{step.loss}/∂{name}", mine.norm().item(), 0.0, math.inf, None, "stray"))
    return rows


def _fmt(x: float | None) -> str:
    if x is None:
        return "—"
    return f"{x:.3e}" if x else "0"


def report(case: Case, rows: list[Row], fixed: OriginalRun, ours: VigenRun, seconds: float, tolerance: float,
           measured: Sequence[str] = ()) -> bool:
    print(f"\n## {case.name}  (reference: {case.reference.root})\n")
    print("| quantity | vigen | original | rel. diff | rel. diff, steps taken |")
    print("| --- | ---: | ---: | ---: | ---: |")
    for row in rows:
        print(f"| {row.quantity} | {_fmt(row.vigen)} | {_fmt(row.original)} | {_fmt(row.rel)} | {_fmt(row.stepped)} |")
    values = [r.rel for r in rows if r.kind in ("loss", "metric")]
    grads = [r.rel for r in rows if r.kind in ("grad", "stray")]
    worst = max(values + grads)
    draws_ok = fixed.normals == ours.normals + case.unused_normals and fixed.uniforms == ours.uniforms
    ok = worst <= tolerance and draws_ok
    unused = f" ({case.unused_normals} of them for outputs it never uses)" if case.unused_normals else ""
    print(f"\nnoise draws: vigen {ours.normals} normals, {ours.uniforms} uniform; original {fixed.normals} normals{unused}, "
          f"{fixed.uniforms} uniform")
    for note in case.reference.notes:
        print(f"note: {note}")
    if case.reference.stubbed:
        print(f"stubbed (not used by the update): {', '.join(case.reference.stubbed)}")
    print("departures (documented; how they are compared):")
    for departure in case.departures:
        print(f"- {departure}")
    for name, why in case.zero_gradients.items():
        print(f"0 in exact arithmetic: the gradient of {name} ({why})")
    for sentence in measured:
        print(f"measured (not compared): {sentence}")
    print(f"\nSUMMARY {case.name}: max rel. diff losses/metrics {max(values):.2e} ({len(values)}), "
          f"gradients {max(grads):.2e} ({len(grads)} tensors); {'OK' if ok else 'MISMATCH'} at tolerance {tolerance:g}"
          f"{'' if draws_ok else ' (draw counts differ)'}; {seconds:.1f} s")
    return ok
