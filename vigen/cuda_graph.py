"""A call captured once as a CUDA graph and replayed at every later call, without waiting for the GPU.

:class:`CudaGraphCall` is vigen's own wrapper around :class:`torch.cuda.CUDAGraph`, on the pattern
of tensordict 0.15's ``CudaGraphModule`` (tensordict 0.14.3's, which torchrl 0.14.1 pins,
calls ``torch.cuda.synchronize()`` before every replay and clones every output): the inputs are
copied into static buffers on the current stream, the graph is replayed on the current stream,
and the outputs are handed back as they are. The host never waits; it reads an output (a metric,
one synchronization) when it chooses to.

Paper: CUDA graphs for RL updates as in LeanRL (https://github.com/pytorch-labs/LeanRL).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any

import torch
from tensordict import TensorDictBase
from torch import Tensor
from torch.utils._pytree import tree_flatten, tree_unflatten


class CudaGraphCall:
    """``fn(*inputs)`` run eagerly ``warmup`` times, then captured as one CUDA graph and replayed at every later call.

    Every call does ``fn``'s work exactly once:

    * calls 1 to ``warmup``: ``fn`` runs eagerly, on a side stream on CUDA (what capturing needs
      first: cuBLAS and cuDNN workspaces, autograd's streams, a compiled function's compilation);
    * call ``warmup + 1``: ``fn`` is captured (which runs nothing) and the graph replayed once;
    * later calls: replay.

    Per call the inputs (tensors and TensorDicts, in any nesting of tuples, lists and dicts, the
    same structure, shapes and dtypes each call) are copied into static buffers on the current
    stream (``non_blocking``; a TensorDict's entries that were not there at the first call are
    ignored), and ``fn`` always reads those buffers. After capture the call returns the graph's
    own output tensors: **no synchronize and no clone**. They are overwritten by the next call;
    a caller that needs a value past it clones it, and reads values to the host (one
    synchronization) when it chooses. Random draws inside ``fn`` follow their generators as the
    eager calls would (CUDA graphs advance a generator's offset at each replay); torch's default
    CUDA generator is registered by torch, any other generator ``fn`` draws from is named in
    ``generators``. ``torch.cuda.graph`` synchronizes the device once, when it captures.

    Off CUDA, or with ``enabled=False``, the calls run the same static-buffer path eagerly: the
    inputs are copied into the buffers, ``fn`` runs on them, and from call ``warmup + 1`` on its
    outputs are copied into the tensors that call returned, so a caller sees what a replay would
    show it (``vigen.devices.accelerator_paths`` and ``test/conftest.py``'s ``no_host_sync`` test the
    capture logic this way on a CPU).

    Args:
        fn: the work; reads only its inputs, its modules' parameters and buffers (fixed memory),
            and returns tensors or TensorDicts (any nesting), or ``None``.
        warmup: eager calls before the capture (at least 1).
        device: the CUDA device of the graph (default: the current one); ignored off CUDA.
        generators: ``torch.Generator`` objects on ``device`` that ``fn`` draws from, besides torch's default.
        enabled: capture on CUDA; ``False`` keeps the eager static-buffer path (to compare the two).

    Examples:
        >>> import torch
        >>> total = torch.zeros(())
        >>> def add(x):
        ...     total.add_(x.sum())
        ...     return {"total": total * 1, "doubled": 2 * x}
        >>> call = CudaGraphCall(add, device=torch.device("cpu"))  # on the CPU: the same static-buffer path, eagerly
        >>> outs = [call(torch.ones(3) * k) for k in range(1, 5)]
        >>> [out["total"].item() for out in outs[:2]], outs[2]["total"] is outs[3]["total"], outs[3]["total"].item()
        ([3.0, 9.0], True, 30.0)
        >>> call.captured, call.calls
        (False, 4)
    """

    def __init__(self, fn: Callable[..., Any], *, warmup: int = 2, device: torch.device | str | None = None,
                 generators: Sequence[torch.Generator] = (), enabled: bool = True) -> None:
        if not isinstance(warmup, int) or warmup < 1:
            raise ValueError(f"CudaGraphCall: warmup must be an integer >= 1 (eager calls before the capture), got {warmup!r}.")
        if device is None:
            device = "cuda" if torch.cuda.is_available() else "cpu"
        self.device = indexed(device)
        self.fn, self.warmup, self.generators = fn, warmup, tuple(generators)
        self.use_graph = enabled and self.device.type == "cuda"
        if self.use_graph:
            wrong = [generator.device for generator in self.generators if indexed(generator.device) != self.device]
            if wrong:
                raise ValueError(f"CudaGraphCall: generators on {wrong} cannot be replayed by a graph on {self.device}; "
                                 "give the graph's device's generators only.")
            if self.generators and not hasattr(torch.cuda.CUDAGraph, "register_generator_state"):
                raise RuntimeError(f"CudaGraphCall: torch {torch.__version__} cannot replay draws from a generator other "
                                   "than the default one in a CUDA graph (CUDAGraph.register_generator_state is missing); "
                                   "update torch or draw from the default generator.")
        self.calls = 0
        self.graph: torch.cuda.CUDAGraph | None = None
        self._spec: Any = None  # the inputs' structure: (pytree spec, per leaf: (kind, keys or None))
        self._static: list[Tensor] = []  # every input tensor's buffer, in the flattened order
        self._static_inputs: tuple | None = None  # the buffers in the inputs' structure, what fn is called with
        self._outputs: Any = None  # from call warmup + 1 on: what every call returns
        self._side_stream: torch.cuda.Stream | None = None

    @property
    def captured(self) -> bool:
        """Whether the graph was captured (on CUDA, after ``warmup`` calls)."""
        return self.graph is not None

    def __call__(self, *inputs: Any) -> Any:
        """``fn(*inputs)``, once; from call ``warmup + 1`` on, the graph's outputs (overwritten by the next call)."""
        self._copy_inputs(inputs)
        self.calls += 1
        if self.calls <= self.warmup:
            return self._eager()
        if not self.use_graph:
            out = self.fn(*self._fresh_inputs())
            if self._outputs is None:
                self._outputs = out
            else:
                _copy_into(self._outputs, out)
            return self._outputs
        if self.graph is None:
            self._capture()
        self.graph.replay()
        return self._outputs

    def _eager(self) -> Any:
        if not self.use_graph:
            return self.fn(*self._fresh_inputs())
        if self._side_stream is None:
            self._side_stream = torch.cuda.Stream(self.device)
        current = torch.cuda.current_stream(self.device)
        self._side_stream.wait_stream(current)
        with torch.cuda.stream(self._side_stream):
            out = self.fn(*self._fresh_inputs())
        current.wait_stream(self._side_stream)
        return out

    def _capture(self) -> None:
        graph = torch.cuda.CUDAGraph()
        for generator in self.generators:
            graph.register_generator_state(generator)
        # synchronizes once, then records fn on a side stream; "thread_local": a collector thread may use CUDA meanwhile
        with torch.cuda.device(self.device), torch.cuda.graph(graph, capture_error_mode="thread_local"):
            self._outputs = self.fn(*self._fresh_inputs())
        self.graph = graph

    def _fresh_inputs(self) -> tuple:
        """The buffers, each TensorDict as a new shallow copy: an entry ``fn`` sets or replaces stays out of the buffers."""
        leaves, spec = tree_flatten(self._static_inputs, is_leaf=lambda value: isinstance(value, TensorDictBase))
        return tree_unflatten([leaf.copy() if isinstance(leaf, TensorDictBase) else leaf for leaf in leaves], spec)

    def _copy_inputs(self, inputs: tuple) -> None:
        leaves, spec = tree_flatten(inputs, is_leaf=lambda value: isinstance(value, TensorDictBase))
        if self._spec is None:
            self._spec = (spec, [_leaf_layout(leaf) for leaf in leaves])
            static_leaves = [_static_copy(leaf, self.device) for leaf in leaves]
            for leaf in static_leaves:
                self._static.extend(_tensors_of(leaf, None) if leaf is not None else [])
            self._static_inputs = tree_unflatten(static_leaves, spec)
            return
        captured_spec, layouts = self._spec
        if spec != captured_spec:
            raise ValueError(f"CudaGraphCall: call {self.calls + 1} got inputs structured as {spec}, the first call {captured_spec}; "
                             "a captured call takes the same structure every call.")
        sources = [tensor for leaf, (_, keys) in zip(leaves, layouts) if leaf is not None for tensor in _tensors_of(leaf, keys)]
        for index, (source, static) in enumerate(zip(sources, self._static)):
            if source.shape != static.shape or source.dtype != static.dtype:
                raise ValueError(f"CudaGraphCall: call {self.calls + 1}'s input tensor {index} is {source.dtype}{list(source.shape)}, "
                                 f"the graph's buffer {static.dtype}{list(static.shape)}; a captured call takes fixed shapes "
                                 "and dtypes (a new shape needs a new CudaGraphCall).")
        if sources:
            torch._foreach_copy_(self._static, sources, non_blocking=True)


def indexed(device: torch.device | str) -> torch.device:
    """``device`` with its index: ``cuda`` is the current CUDA device, ``cuda:0`` on most machines (equal devices compare equal).

    Examples:
        >>> indexed("cpu")
        device(type='cpu')
    """
    device = torch.device(device)
    if device.type == "cuda" and device.index is None:
        return torch.device("cuda", torch.cuda.current_device())
    return device


def _leaf_layout(leaf: Any) -> tuple[str, list | None]:
    if isinstance(leaf, TensorDictBase):
        return "tensordict", sorted(leaf.keys(include_nested=True, leaves_only=True), key=str)
    if isinstance(leaf, Tensor):
        return "tensor", None
    if leaf is None:
        return "none", None
    raise TypeError(f"CudaGraphCall: inputs are tensors, TensorDicts or None (in tuples, lists or dicts); got {type(leaf).__name__}.")


def _tensors_of(leaf: Tensor | TensorDictBase, keys: list | None) -> list[Tensor]:
    if isinstance(leaf, Tensor):
        return [leaf]
    keys = sorted(leaf.keys(include_nested=True, leaves_only=True), key=str) if keys is None else keys
    missing = [key for key in keys if key not in leaf.keys(include_nested=True, leaves_only=True)]
    if missing:
        raise KeyError(f"CudaGraphCall: the input TensorDict lacks {missing}, which the first call had; a captured call "
                       "reads the same entries every call.")
    return [leaf.get(key) for key in keys]


def _static_copy(leaf: Any, device: torch.device) -> Any:
    if leaf is None:
        return None
    if isinstance(leaf, TensorDictBase):
        return leaf.to(device).clone() if device.type == "cuda" else leaf.clone()
    return leaf.detach().to(device).clone() if device.type == "cuda" else leaf.detach().clone()


def _copy_into(targets: Any, sources: Any) -> None:
    """Copy ``sources`` into ``targets`` (the same structure of tensors and TensorDicts), in place."""
    target_leaves, _ = tree_flatten(targets, is_leaf=lambda value: isinstance(value, TensorDictBase))
    source_leaves, _ = tree_flatten(sources, is_leaf=lambda value: isinstance(value, TensorDictBase))
    for target, source in zip(target_leaves, source_leaves, strict=True):
        if isinstance(target, TensorDictBase):
            target.update_(source)
        elif isinstance(target, Tensor):
            target.copy_(source)
