"""One home per paper default: the algorithm's record (``vigen.losses.ALGOS``); the loss classes take it as arguments."""

from __future__ import annotations

import inspect
from pathlib import Path

import pytest
import torch

from vigen.losses import ALGOS, ActorCriticLoss, defaults_help, defaults_markdown, make_loss

ROOT = Path(__file__).resolve().parents[2]
GENERIC = {"input_mask", "param_groups", "channels_last", "reduction", "check_finite"}
"""The options of ActorCriticLoss that are no paper's: a module the caller gives, and TorchRL's plumbing."""


def _own_parameters(cls: type) -> list[inspect.Parameter]:
    """The keyword parameters of every ``__init__`` from ``cls`` up to ActorCriticLoss (the networks left out)."""
    found = []
    for klass in cls.__mro__:
        if "__init__" in vars(klass) and issubclass(klass, ActorCriticLoss):
            found += [p for p in inspect.signature(klass.__init__).parameters.values() if p.kind is p.KEYWORD_ONLY]
    return found


@pytest.mark.parametrize("cls", sorted({record.loss for record in ALGOS.values()}, key=lambda cls: cls.__name__))
def test_a_loss_class_holds_no_paper_default(cls):
    """Every option of a loss class that a paper sets (sampler, augmentations, coefficients, switches) has no default."""
    with_default = [p.name for p in _own_parameters(cls) if p.default is not p.empty and p.name not in GENERIC]
    assert not with_default, f"{cls.__name__} has defaults for {with_default}: they belong in its record (ALGOS)"


@pytest.mark.parametrize("algo", list(ALGOS))
def test_make_loss_builds_the_records_loss(algo):
    """The loss, its sampler, options, augmentations and optimizer groups are the record's (and nothing it needs is missing)."""
    record = ALGOS[algo]
    loss = make_loss(algo, (9, 64, 64), 2, hidden_dim=8, feature_dim=8)
    assert type(loss) is record.loss and type(loss.sampler) is record.sampler
    for name, value in record.options.items():
        got = getattr(loss, name, None)
        if name == "target_encoder":
            got = "target_encoder_params" in dict(loss.named_children())
        got = got.item() if isinstance(got, torch.Tensor) else got
        assert got == pytest.approx(value) if isinstance(value, float) else got == value, f"{algo}.{name}"
    for name, factory in record.augmentations.items():
        built = getattr(loss, name)
        assert [type(t) for t in built] == [type(t) for t in (factory() if isinstance(factory(), list) else [factory()])]
    for module, options in record.param_groups.items():
        group = next(g for g in loss.optimizer_groups(1e-4)[1:] if g["params"][0] is next(getattr(loss, module).parameters()))
        assert all(group[key] == value for key, value in options.items()), f"{algo}: {module}'s group"


def test_the_records_are_read_only():
    with pytest.raises(TypeError):
        ALGOS["svea"].options["weak_weight"] = 0.3  # type: ignore[index]
    with pytest.raises(TypeError):
        ALGOS["madi"].param_groups["input_mask"]["lr"] = 1.0  # type: ignore[index]


def test_help_texts_read_the_records():
    assert defaults_help("std_init") == "the algorithm's: 1.0 (drqv2, svea, srm, sgqn, curl, pieg), 0.01 (vrl3)"
    assert defaults_help("std_duration") == "the algorithm's: 100000 (drqv2, svea, srm, sgqn, curl, pieg), 500000 (vrl3)"
    assert "adroit/door 1/20" in defaults_help("reward_scale")
    with pytest.raises(ValueError, match="std_init"):
        defaults_help("lr")


def test_docs_hold_the_records_table():
    text = (ROOT / "docs" / "losses.md").read_text()
    assert defaults_markdown() in text, "run: python -m vigen.losses, and paste its table into docs/losses.md"
    for algo in ALGOS:
        assert f"| `{algo}` |" in defaults_markdown()
