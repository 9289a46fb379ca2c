"""One gradient update of a vigen loss (loss, backward, optimizer step, target update), eager or compiled.

The update of every vigen algorithm is the same four steps on a replay-buffer batch:
``out = loss(batch)``, one ``backward()`` of the summed ``loss_*`` entries, one optimizer step,
``SoftUpdate.step()``. :class:`UpdateStep` runs them as one call that never synchronizes with
the host, so that it can be compiled whole (``torch.compile(..., fullgraph=True)``) and, on CUDA,
captured as a CUDA graph (:class:`vigen.cuda_graph.CudaGraphCall`, as LeanRL does with tensordict's).
"""

from __future__ import annotations

import functools
import time
import types
from collections.abc import Callable
from typing import Any

import torch
from torch.optim.adam import adam as functional_adam
from tensordict import TensorDict, TensorDictBase
from torch import Tensor
from torchrl.objectives import SoftUpdate

from vigen.cuda_graph import CudaGraphCall
from vigen.devices import host_reads_are_free
from vigen.losses.base import ActorCriticLoss
from vigen.transforms import ImageAugmentation


class UpdateStep:
    """One update of ``loss``: forward, backward of the summed ``loss_*``, ``optimizer.step()``, target update.

    ``step(batch)`` returns the loss's output (losses and metrics), detached, as tensors on the
    loss's device; nothing in it reads a value back to the host, so metrics cost nothing until a
    script logs them.

    Finite-loss guard, as tensor ops: where the summed loss of an update is NaN or inf, that
    update's gradients are zeroed before the optimizer step (the parameters stay finite) and a
    counter on the device goes up. :meth:`raise_if_diverged`, called at a script's logging
    interval, reads it (one synchronization) and raises. An eager CPU update of a loss built with
    ``check_finite=True`` (the default) keeps the loss's own check instead, which raises inside the
    call and names the batch entries or parameters to blame (reading the value is free there).
    Off the CPU, and compiled, the loss only counts such calls on the device (its own check never
    synchronizes; see :class:`~vigen.losses.ActorCriticLoss`) and this guard acts, whatever
    ``check_finite`` says. UpdateStep never changes the loss it is given.

    The caller's batch gets the loss's ``td_error`` priority (``loss.tensor_keys.priority``), as
    TorchRL's losses write it, eager, compiled or replayed from a CUDA graph: after ``update(batch)``,
    ``replay_buffer.update_tensordict_priority(batch)`` updates a prioritized sampler.

    ``compile=True`` compiles the whole update with ``torch.compile(fullgraph=True, dynamic=False)`` (a
    new batch size compiles anew: shapes stay static, as a replay batch's do); it first calls
    ``loss.prepare_compile()`` (SGQN and SCPL install the hooks of their traceable guided pass). Random
    draws then follow torch's global RNG in the same order as the eager update (``fallback_random``),
    so the compiled update equals the eager one within float tolerance. ``torch.compile`` cannot
    trace a ``torch.Generator``: build the loss without ``seed`` (``make_loss(..., seed=None)``) and
    seed torch instead (``torch.manual_seed``); a loss with seeded augmentations is refused.
    On CUDA the compiled update is also captured as a CUDA graph (``cudagraph=None`` picks that;
    :class:`~vigen.cuda_graph.CudaGraphCall`: no host wait per replay, and the returned losses are
    the graph's own tensors, overwritten by the next update: clone what you keep); the optimizer
    must then be ``capturable`` (``torch.optim.Adam(..., capturable=True)``).
    ``compile_seconds`` holds the time the first call(s) took to compile (and capture).

    Gradients, compiled or captured: before the first call every parameter of the optimizer gets a
    zero gradient, and each update zeroes them in place (``zero_grad(set_to_none=False)``), so the
    one graph traced is the one a CUDA graph captures (gradients present, accumulated into the same
    memory), on the CPU as on a GPU, and nothing recompiles on the second call. A parameter that
    gets no gradient from the loss is then stepped with a zero one (Adam leaves it where it is
    unless ``weight_decay`` is set), while the eager update skips it; every parameter of vigen's
    losses gets a gradient.

    A schedule steps parts on every N-th update only, as DMC-GB's SAC steps its actor and temperature,
    and its target networks, on every second update (``actor_update_freq``, ``critic_target_update_freq``):
    an optimizer group with ``"every": N`` (``loss.optimizer_groups``, from the loss's ``param_groups``)
    is stepped on updates ``0, N, 2N, ...`` and left untouched on the others (its parameters, and Adam's
    moments and step count, as under a separate optimizer that is not called), and ``target_every``
    does the same for the target update. The update's index is :attr:`count` (set it when resuming a
    run). The loss still computes every term on every update; a group that is not due only skips its
    step, which equals the original's whenever the group's gradients come from its own terms (the
    actor's from ``loss_actor`` on detached features, the temperature's from ``loss_alpha``). Compiled,
    each pattern of due groups is its own graph (two for "every second update"), checked equal to the
    eager update; captured as a CUDA graph, a schedule is refused (not yet checked on a GPU).

    Paper: DrQ-v2's update (https://arxiv.org/abs/2107.09645); compiled RL updates as in LeanRL
    (https://github.com/pytorch-labs/LeanRL); the schedule, DMC-GB's SAC
    (https://github.com/nicklashansen/dmcontrol-generalization-benchmark, ``src/algorithms/sac.py``).

    Args:
        loss: a vigen loss with its value estimator made.
        optimizer: over the loss's parameters (``torch.optim.Adam(loss.optimizer_groups(lr))``).
        target_update: TorchRL's ``SoftUpdate(loss, tau=...)`` (or :class:`~vigen.losses.SplitSoftUpdate`);
            ``None`` for none.
        target_every: update the targets on every N-th update only (DMC-GB: 2).
        compile: compile the update.
        cudagraph: capture the (compiled) update as a CUDA graph; ``None``: on CUDA when compiling.
        backend: ``torch.compile``'s backend (``"inductor"``; ``"aot_eager"`` traces without code
            generation, e.g. to check in seconds that the update compiles whole).
        mode: ``torch.compile``'s mode (``None``, ``"max-autotune-no-cudagraphs"``, ...); with
            inductor, its options are merged with the update's own (``fallback_random``). The modes
            that capture CUDA graphs themselves (``"reduce-overhead"``, ``"max-autotune"``) need
            ``cudagraph=False``.

    Examples:
        >>> import torch
        >>> from tensordict import TensorDict
        >>> from torchrl.objectives import SoftUpdate
        >>> from vigen.losses import UpdateStep, make_loss
        >>> loss = make_loss("drqv2", (9, 32, 32), 2, hidden_dim=16, feature_dim=8).make_value_estimator(gamma=0.99)
        >>> update = UpdateStep(loss, torch.optim.Adam(loss.parameters(), lr=1e-4), SoftUpdate(loss, tau=0.01))
        >>> pixels = torch.randint(0, 256, (4, 9, 32, 32), dtype=torch.uint8)
        >>> batch = TensorDict({"pixels": pixels, "action": torch.zeros(4, 2), "next": {
        ...     "pixels": pixels, "reward": torch.ones(4, 1), "done": torch.zeros(4, 1, dtype=torch.bool),
        ...     "terminated": torch.zeros(4, 1, dtype=torch.bool)}}, batch_size=[4])
        >>> out = update(batch)
        >>> sorted(key for key in out.keys() if key.startswith("loss_"))
        ['loss_actor', 'loss_critic']
        >>> update.raise_if_diverged()  # reads the guard's counter: no NaN so far
    """

    def __init__(
        self,
        loss: ActorCriticLoss,
        optimizer: torch.optim.Optimizer,
        target_update: SoftUpdate | None = None,
        *,
        target_every: int = 1,
        compile: bool = False,
        cudagraph: bool | None = None,
        backend: str = "inductor",
        mode: str | None = None,
    ) -> None:
        if not isinstance(loss, ActorCriticLoss):
            raise TypeError(f"UpdateStep takes a vigen ActorCriticLoss, got {type(loss).__name__}.")
        if not loss.has_value_estimator:
            raise ValueError(f"UpdateStep: {type(loss).__name__} has no value estimator; call "
                             "loss.make_value_estimator(gamma=...) first.")
        device = loss.device
        cudagraph = compile and device.type == "cuda" if cudagraph is None else cudagraph
        if isinstance(target_every, bool) or not isinstance(target_every, int) or target_every < 1:
            raise ValueError(f"UpdateStep: target_every is a number of updates, an integer >= 1, got {target_every!r}.")
        everies = tuple(int(group.get("every", 1)) for group in optimizer.param_groups)
        scheduled = target_every > 1 or any(every > 1 for every in everies)
        if cudagraph and scheduled:
            raise ValueError("UpdateStep: a schedule (a group's 'every' or target_every above 1) alternates two update "
                             "graphs, which vigen has not yet checked as CUDA graphs on a GPU; pass cudagraph=False "
                             "(torch.compile alone, checked equal to the eager update) or drop the schedule.")
        if cudagraph and device.type != "cuda":
            raise ValueError(f"UpdateStep: cudagraph=True needs a loss on CUDA; this one is on {device}.")
        if compile:
            seeded = [type(module).__name__ for module in loss.modules()
                      if isinstance(module, ImageAugmentation) and module.seed is not None]
            if seeded:
                raise ValueError(
                    f"UpdateStep(compile=True): the loss's augmentations {', '.join(seeded)} draw from their own "
                    "torch.Generator, which torch.compile cannot trace. Build the loss without seed "
                    "(make_loss(..., seed=None)) and seed torch's global RNG (torch.manual_seed(seed)) instead."
                )
            if not isinstance(optimizer, torch.optim.Adam):
                raise TypeError(f"UpdateStep(compile=True) steps torch.optim.Adam or AdamW through their functional form "
                                f"(Optimizer.step breaks the graph on purpose); got {type(optimizer).__name__}.")
            if any(group.get("fused") for group in optimizer.param_groups):
                raise ValueError("UpdateStep(compile=True): torch.compile does not trace a fused Adam (torch.optim.Adam(..., "
                                 "fused=True)); build it with fused=False: the compiled update fuses the step itself.")
            loss.prepare_compile()
        self.loss = loss
        self.optimizer = optimizer
        self.target_update = target_update
        self.target_every = target_every
        self.group_every = everies
        self.count = 0
        """Updates made so far: the schedule's phase (a group of ``every`` N is stepped when ``count % N == 0``)."""
        self.device = device
        self.compiled = compile
        self.cudagraph = cudagraph
        self._check_capturable()
        self.compile_seconds: float | None = None
        # an eager CPU loss with check_finite raises inside the call; otherwise the update guards with tensor ops
        self.guard_in_loss = loss.check_finite and not compile and host_reads_are_free(device)
        # compiled or captured: gradients live in the same memory from the first trace on (one graph, see above)
        self.static_gradients = compile or cudagraph
        self._diverged = torch.zeros((), dtype=torch.long, device=device)
        self._parameters = [parameter for group in optimizer.param_groups for parameter in group["params"]]
        self._compile = functools.partial(torch.compile, fullgraph=True, dynamic=False, backend=backend,
                                          **_compile_options(backend, mode, cudagraph)) if compile else None
        self._every_due = (tuple(True for _ in everies), True)
        self._pattern = self._every_due  # which groups and whether the targets are due in the update running now
        step = self._update
        if compile:  # the whole update in one graph
            step = self._compile(_own_code(step))
        if cudagraph:  # vigen's own wrapper: copies the batch in and replays, without waiting for the GPU or cloning
            step = CudaGraphCall(step, warmup=2, device=device)
        self._step = step  # the update with every part due
        self._scheduled_steps: dict[tuple, Callable[[TensorDictBase], TensorDictBase]] = {}  # compiled, one per other pattern
        self._calls = 0

    def __call__(self, batch: TensorDictBase) -> TensorDictBase:
        """One update on ``batch`` (on the loss's device); its losses and metrics, detached."""
        pixels = batch.get(self.loss.tensor_keys.pixels, None)
        if pixels is not None and pixels.device != self.device:
            raise ValueError(f"UpdateStep: the batch is on {pixels.device} but the loss on {self.device}; move it with "
                             f"batch.to({str(self.device)!r}) (or give the replay buffer's storage device={str(self.device)!r}).")
        started = time.perf_counter() if self._calls < 3 and self.compiled else None
        if self._calls == 0 and self.static_gradients:
            self._check_capturable()  # again: an optimizer state loaded since may have brought other flags
            self.loss.check_batch(batch)  # readable errors, and the one scan of float pixels, before any trace
            for parameter in self._parameters:  # the graph is traced once, with the gradients it will run with
                if parameter.requires_grad and parameter.grad is None:
                    parameter.grad = torch.zeros_like(parameter)
        if self.compiled and self._calls == 0:
            self._init_adam_state()
            for module in self.loss.modules():  # image banks load and move to the device outside the graph
                if isinstance(module, ImageAugmentation) and pixels is not None:
                    module.prepare(pixels.shape, self.device)
        self.optimizer.zero_grad(set_to_none=not self.static_gradients)  # dynamo does not trace zero_grad
        self._pattern = self.due(self.count)
        step = self._step
        if self._pattern != self._every_due and self.compiled:  # its own code object: its own graph and cache
            step = self._scheduled_steps.get(self._pattern)
            if step is None:
                step = self._scheduled_steps[self._pattern] = self._compile(_own_code(self._update))
        if self.compiled:
            with torch._dynamo.config.patch(trace_autograd_ops=True):  # backward() inside the graph
                result = step(batch)
        else:
            result = step(batch)
        self.count += 1
        if started is not None:  # compilation (and CUDA-graph warm-up and capture) happens in the first calls
            self.compile_seconds = (self.compile_seconds or 0.0) + time.perf_counter() - started
        self._calls += 1
        # the loss wrote the priority into the batch it was given; a CUDA graph's replay gives it a copy, so write it here
        batch.set(self.loss.tensor_keys.priority, result["priority"])
        return result["losses"]

    def due(self, index: int) -> tuple[tuple[bool, ...], bool]:
        """Which optimizer groups are stepped in update ``index`` (one flag per group), and whether the targets are.

        Examples:
            >>> import torch
            >>> from vigen.losses import UpdateStep, make_loss
            >>> loss = make_loss("drq", (9, 32, 32), 2, hidden_dim=8,
            ...                  param_groups={"actor": {"every": 2}}).make_value_estimator(gamma=0.99)
            >>> update = UpdateStep(loss, torch.optim.Adam(loss.optimizer_groups(1e-4)), target_every=2)
            >>> update.due(0), update.due(1)
            (((True, True), True), ((True, False), False))
        """
        return tuple(index % every == 0 for every in self.group_every), index % self.target_every == 0

    def _check_capturable(self) -> None:
        if self.cudagraph and not all(group.get("capturable", False) for group in self.optimizer.param_groups):
            raise ValueError("UpdateStep(cudagraph=True): the optimizer must be capturable, e.g. "
                             "torch.optim.Adam(loss.optimizer_groups(lr), capturable=True); an optimizer state loaded "
                             "from another run keeps this run's flags with vigen.run.checkpoint.load_optimizer_state.")

    def _update(self, batch: TensorDictBase) -> TensorDictBase:
        """The update; its losses and metrics (``"losses"``) and the batch's priority (``"priority"``), detached."""
        out = self.loss(batch)
        total = sum(value for key, value in out.items() if key.startswith("loss_"))
        total.backward()
        if not self.guard_in_loss:
            finite = torch.isfinite(total.detach())
            self._diverged.add_((~finite).long())
            for parameter in self._parameters:
                if parameter.grad is not None:
                    parameter.grad.copy_(torch.where(finite, parameter.grad, torch.zeros_like(parameter.grad)))
        groups_due, target_due = self._pattern
        if self.compiled:
            with torch.no_grad():
                self._adam_step(groups_due)
        else:
            skipped = [(parameter, parameter.grad) for group, due in zip(self.optimizer.param_groups, groups_due) if not due
                       for parameter in group["params"]]
            for parameter, _ in skipped:  # Adam skips a parameter without a gradient: its state stays as it is
                parameter.grad = None
            self.optimizer.step()
            for parameter, gradient in skipped:  # the gradients stay readable, as in the compiled update
                parameter.grad = gradient
        if self.target_update is not None and target_due:
            self.target_update.step()
        return TensorDict({"losses": out.detach(), "priority": batch.get(self.loss.tensor_keys.priority).detach()},
                          batch_size=[])

    def _adam_step(self, groups_due: tuple[bool, ...]) -> None:
        """``optimizer.step()`` through Adam's functional form, which dynamo traces (the method graph-breaks on purpose),
        over the groups due."""
        for group, due in zip(self.optimizer.param_groups, groups_due):
            if not due:
                continue
            params = [parameter for parameter in group["params"] if parameter.grad is not None]
            states = [self.optimizer.state[parameter] for parameter in params]
            beta1, beta2 = group["betas"]
            functional_adam(
                params, [parameter.grad for parameter in params], [state["exp_avg"] for state in states],
                [state["exp_avg_sq"] for state in states], [state["max_exp_avg_sq"] for state in states] if group["amsgrad"] else [],
                [state["step"] for state in states], foreach=group["foreach"], capturable=group["capturable"],
                differentiable=False, fused=group["fused"], amsgrad=group["amsgrad"], beta1=beta1, beta2=beta2,
                lr=group["lr"], weight_decay=group["weight_decay"], eps=group["eps"], maximize=group["maximize"],
                decoupled_weight_decay=group.get("decoupled_weight_decay", False),
            )

    def _init_adam_state(self) -> None:
        """Adam's per-parameter state as its first ``step()`` would make it (a compiled update must not create it)."""
        for group in self.optimizer.param_groups:
            on_device = group["capturable"] or group["fused"]
            for parameter in group["params"]:
                state = self.optimizer.state[parameter]
                if not parameter.requires_grad or state:
                    continue
                state["step"] = (torch.zeros((), dtype=torch.float32, device=parameter.device) if on_device
                                 else torch.tensor(0.0, dtype=torch.float32))
                state["exp_avg"] = torch.zeros_like(parameter, memory_format=torch.preserve_format)
                state["exp_avg_sq"] = torch.zeros_like(parameter, memory_format=torch.preserve_format)
                if group["amsgrad"]:
                    state["max_exp_avg_sq"] = torch.zeros_like(parameter, memory_format=torch.preserve_format)

    @property
    def diverged_updates(self) -> Tensor:
        """The number of updates whose loss was NaN or inf (a 0-d tensor on the device)."""
        return self._diverged

    def raise_if_diverged(self) -> None:
        """Raise ``FloatingPointError`` if an update since the start had a NaN or inf loss (reads one number)."""
        count = int(self._diverged)
        if count:
            raise FloatingPointError(
                f"{type(self.loss).__name__}: {count} update(s) had a NaN or inf loss; their gradients were zeroed, so the "
                "parameters are finite, but training has diverged: lower the learning rate, clip gradients or scale the "
                "rewards, and check the replay buffer for NaN or inf entries.")


def _compile_options(backend: str, mode: str | None, cudagraph: bool) -> dict[str, Any]:
    """``torch.compile``'s ``mode``/``options`` for the update: with inductor, the mode's options and ``fallback_random``.

    ``torch.compile`` takes ``mode`` or ``options``, not both; the update needs an option (random
    draws as the eager update makes them), so a mode is passed as the options it stands for.
    """
    if backend != "inductor":
        return {} if mode is None else {"mode": mode}
    from torch._inductor import list_mode_options  # torch.compile's docstring points here for what each mode sets

    modes = list_mode_options()
    if mode is not None and mode not in modes:
        raise ValueError(f"UpdateStep: unknown torch.compile mode {mode!r}; the modes are {', '.join(map(repr, modes))}.")
    options = {**(modes[mode] if mode is not None else {}), "fallback_random": True}
    if cudagraph and options.get("triton.cudagraphs"):
        raise ValueError(f"UpdateStep: mode={mode!r} captures CUDA graphs itself, and cudagraph=True captures the update "
                         "as one; pass cudagraph=False to keep the mode's, or mode='max-autotune-no-cudagraphs'.")
    return {"options": options}


def _own_code(method: Callable[..., Any]) -> Callable[..., Any]:
    """``method`` on a copy of its code object: dynamo keeps one cache (and one recompile limit) per code object,
    so every UpdateStep, and every loss it compiles, gets its own instead of sharing the class's."""
    function = method.__func__
    copy = types.FunctionType(function.__code__.replace(), function.__globals__, function.__name__, function.__defaults__,
                              function.__closure__)
    return types.MethodType(functools.wraps(function)(copy), method.__self__)


def update_metrics(out: TensorDictBase) -> dict[str, float]:
    """The scalar entries of an update's output as Python floats (one synchronization), for a logger.

    Examples:
        >>> import torch
        >>> from tensordict import TensorDict
        >>> update_metrics(TensorDict({"loss_actor": torch.tensor(1.5)}, batch_size=[]))
        {'loss_actor': 1.5}
    """
    values = {key: value for key, value in out.items() if isinstance(value, Tensor) and value.numel() == 1}
    if not values:
        return {}
    numbers = torch.stack([value.detach().reshape(()).float() for value in values.values()]).cpu().tolist()
    return dict(zip(values, numbers))
