"""What every vigen loss owes TorchRL: keys, outputs, gradient routing, targets, copies and state."""

from __future__ import annotations

import copy
import pickle

import pytest
import torch
from torchrl.objectives import SoftUpdate

from vigen.losses import NoisyDeterministic, SquashedGaussian

from loss_helpers import LOSSES, make_batch, make_loss

pytestmark = pytest.mark.filterwarnings("ignore:No target network updater")
AUX_LOSSES = {"sgqn": "loss_attribution", "curl": "loss_curl", "scpl": "loss_dynamics"}
AUX_CRITIC_PART = {"scpl": "trunk"}  # SCPL's dynamics model reads the critic trunk's embedding (DMC-GB's projection)


def _grads(loss, name: str) -> dict[str, torch.Tensor | None]:
    return {key: value.grad for key, value in getattr(loss, f"{name}_params").items(True, True)}


def _has_grad(grads: dict[str, torch.Tensor | None]) -> bool:
    return any(g is not None and g.abs().sum() > 0 for g in grads.values())


def _output(loss, seed: int = 0):
    torch.manual_seed(seed)
    return loss(make_batch())


@pytest.mark.parametrize("name", LOSSES)
def test_outputs_are_losses_and_detached_metrics(name):
    loss = make_loss(name)
    SoftUpdate(loss, tau=0.01)
    out = loss(make_batch())
    assert out.batch_size == torch.Size([])
    assert set(out.keys()) <= set(loss.out_keys), "every output is declared in out_keys"
    for key, value in out.items():
        assert value.shape == torch.Size([]) and torch.isfinite(value), key
        assert value.requires_grad == key.startswith("loss_"), f"{key}: only loss_* entries carry gradients"
    assert {"loss_critic", "loss_actor"} <= set(out.keys())
    if name in AUX_LOSSES:
        assert AUX_LOSSES[name] in out.keys()


REFUSES = {("vrl3", "SquashedGaussian"), ("scpl", "NoisyDeterministic")}
"""VRL3 is DDPG (its penalty reads the deterministic actor's pre-tanh action); SCPL's policy KL needs SAC's Gaussians."""
SAMPLERS = {"NoisyDeterministic": lambda: NoisyDeterministic(std_schedule=0.2),
            "SquashedGaussian": lambda: SquashedGaussian(init_temperature=0.5)}


@pytest.mark.parametrize("sampler", sorted(SAMPLERS))
@pytest.mark.parametrize("name", LOSSES)
def test_every_loss_takes_either_sampler_with_all_its_terms_or_refuses_it_by_name(name, sampler):
    """A sampler's terms are never dropped: with SAC every loss outputs ``loss_alpha = mean α·(−log π − H̄)`` and its
    metrics, and an optimizer step over the loss's groups moves the temperature; with DDPG, the noise std and no ``loss_alpha``.

    Each loss's ``forward`` adds these terms itself (issue 47; before it, ``ActorCriticLoss.output`` added them for every
    loss; before issue 42, DrQ-v2, SGQN, CURL and VRL3 given a SquashedGaussian dropped ``loss_alpha``).
    """
    gaussian = sampler == "SquashedGaussian"
    chosen = SAMPLERS[sampler]()
    if (name, sampler) in REFUSES:
        with pytest.raises(TypeError, match=sampler):
            make_loss(name, gaussian=gaussian, sampler=chosen)
        return
    loss = make_loss(name, gaussian=gaussian, sampler=chosen)
    SoftUpdate(loss, tau=0.01)
    assert loss.sampler is chosen
    out = loss(make_batch())
    missing = {key for key in loss.out_keys if key not in out.keys()} - {"actor_pretanh_penalty", "abs_pretanh", "max_abs_pretanh"}
    assert not missing, f"out_keys lists {sorted(missing)}, which the output lacks"
    assert set(out.keys()) <= set(loss.out_keys)
    if not gaussian:
        assert not {"loss_alpha", "alpha", "entropy"} & set(out.keys()) and out["std"] == pytest.approx(0.2)
        return
    assert "std" not in out.keys() and out["alpha"] == pytest.approx(0.5) and not out["alpha"].requires_grad
    # SAC's temperature loss, by its definition, from the entropy the output reports: α·(−log π − H̄) with H̄ = −|A|
    target_entropy = -make_batch()["action"].shape[-1]
    assert torch.allclose(out["loss_alpha"], out["alpha"] * (out["entropy"] - target_entropy), rtol=1e-5, atol=1e-6)
    optimizer = torch.optim.Adam(loss.optimizer_groups(1e-2))
    before = chosen.log_alpha.detach().clone()
    optimizer.zero_grad(set_to_none=True)
    out["loss_alpha"].backward()
    assert chosen.log_alpha.grad is not None and chosen.log_alpha.grad != 0, "loss_alpha reaches the temperature"
    assert all(p.grad is None for name_, p in loss.named_parameters() if name_ != "sampler.log_alpha"), "and nothing else"
    optimizer.step()
    assert chosen.log_alpha.detach() != before, "an optimizer step over the loss's groups trains the temperature"


@pytest.mark.parametrize("sampler", sorted(SAMPLERS))
@pytest.mark.parametrize("name", LOSSES)
def test_no_loss_term_is_added_outside_the_forward(name, sampler, monkeypatch):
    """``output()`` reduces the terms the ``forward`` hands it and adds none: its ``loss_*`` entries are exactly those.

    (Before issue 47, ``ActorCriticLoss.output`` added SAC's ``loss_alpha`` to every loss, guessing the views from
    tensor shapes: this test fails there for every SAC sampler.)
    """
    if (name, sampler) in REFUSES:
        pytest.skip(f"{name} refuses a {sampler} (the test above)")
    loss = make_loss(name, gaussian=sampler == "SquashedGaussian", sampler=SAMPLERS[sampler]())
    SoftUpdate(loss, tau=0.01)
    given = []
    output = type(loss).output

    def recorded(self, tensordict, target, q1, q2, losses, metrics=None, **rest):
        given.append(dict(losses))
        return output(self, tensordict, target, q1, q2, losses, metrics, **rest)

    monkeypatch.setattr(type(loss), "output", recorded)
    out = loss(make_batch())
    assert len(given) == 1, "the forward calls output() once"
    assert {key for key in out.keys() if key.startswith("loss_")} == set(given[0]), "output() added or dropped a loss term"
    if sampler == "SquashedGaussian":
        assert "loss_alpha" in given[0], f"{name}'s forward adds SAC's temperature loss"


def test_a_loss_term_must_hold_one_value_per_sample():
    """A forward that forgets to average an actor step over its views is told so, not reduced silently."""
    loss = make_loss("drqv2")
    batch = make_batch(batch=4)
    q = torch.zeros(4, 1)
    with pytest.raises(ValueError, match=r"loss_actor.*\[4\].*views"):
        loss.output(batch, q, q, q, {"loss_critic": torch.zeros(4), "loss_actor": torch.zeros(8)})
    with pytest.raises(ValueError, match="named loss_"):
        loss.output(batch, q, q, q, {"critic": torch.zeros(4)})


@pytest.mark.parametrize("name", LOSSES)
def test_gradient_routing(name):
    """Encoder: from the critic and auxiliary losses only. Actor: from its own loss only."""
    loss = make_loss(name)
    SoftUpdate(loss, tau=0.01)
    out = loss(make_batch())
    entries = ["loss_critic", "loss_actor", *([AUX_LOSSES[name]] if name in AUX_LOSSES else [])]
    for entry in entries:
        loss.zero_grad(set_to_none=True)
        out[entry].backward(retain_graph=True)
        encoder, actor, critic = (_grads(loss, part) for part in ("encoder", "actor", "critic"))
        if entry == "loss_actor":
            assert _has_grad(actor) and not _has_grad(encoder) and not _has_grad(critic)
        elif entry == "loss_critic":
            assert _has_grad(encoder) and _has_grad(critic) and not _has_grad(actor)
        else:
            part = AUX_CRITIC_PART.get(name)
            reached = {key: grad for key, grad in critic.items() if key[0] == part}
            rest = {key: grad for key, grad in critic.items() if key[0] != part}
            assert _has_grad(encoder) and not _has_grad(actor) and not _has_grad(rest)
            assert _has_grad(reached) == (part is not None), f"the critic's {part} is trained by {entry}"
        assert all(p.grad is None for p in loss.target_critic_params.values(True, True))


@pytest.mark.parametrize("name", LOSSES)
def test_target_critic_moves_only_through_soft_update(name):
    loss = make_loss(name)
    updater = SoftUpdate(loss, tau=0.25)
    optimizer = torch.optim.Adam(loss.parameters(), lr=1e-2)
    target_before = loss.target_critic_params.clone()
    out = loss(make_batch())
    sum(value for key, value in out.items() if key.startswith("loss_")).backward()
    optimizer.step()
    assert (loss.target_critic_params == target_before).all(), "an optimizer step leaves the target alone"
    online = loss.critic_params.detach().clone()
    assert not (online == target_before).all()
    updater.step()
    expected = target_before.apply(lambda t, o: 0.75 * t + 0.25 * o, online)
    assert all(
        torch.allclose(a, b, atol=1e-6)
        for a, b in zip(loss.target_critic_params.values(True, True), expected.values(True, True))
    )


@pytest.mark.parametrize("name", LOSSES)
def test_set_keys(name):
    loss = make_loss(name)
    with pytest.raises(ValueError):
        loss.set_keys(not_a_key="x")
    batch = make_batch()
    renamed = batch.rename_key_("pixels", "obs").rename_key_(("next", "pixels"), ("next", "obs"))
    loss.set_keys(pixels="obs", priority="my_error")
    assert "obs" in loss.in_keys and ("next", "obs") in loss.in_keys
    loss(renamed)
    assert renamed["my_error"].shape == (6,), "the TD error is written where the priority key says"
    loss.set_keys(pixels=None)
    assert loss.tensor_keys.pixels == "pixels"


@pytest.mark.parametrize("name", ["drqv2", "drq"])
def test_missing_key_names_the_fix(name):
    loss = make_loss(name)
    batch = make_batch().exclude(("next", "pixels"))
    with pytest.raises(KeyError, match="set_keys"):
        loss(batch)


@pytest.mark.parametrize("name", LOSSES)
def test_state_dict_round_trip(name):
    loss, other = make_loss(name), make_loss(name)
    SoftUpdate(loss, tau=0.01), SoftUpdate(other, tau=0.01)
    loss.set_step(5000)
    with torch.no_grad():
        for value in loss.target_critic_params.values(True, True):
            value.add_(0.01)
    other.load_state_dict(loss.state_dict())
    assert int(other.schedule_step) == 5000
    if isinstance(loss.sampler, NoisyDeterministic):  # the std at the restored step
        assert torch.equal(other.sampler.std(other.schedule_step), loss.sampler.std(loss.schedule_step))
    assert (other.target_critic_params == loss.target_critic_params).all()
    a, b = _output(loss), _output(other)
    assert all(torch.allclose(a[key], b[key]) for key in a.keys())


@pytest.mark.parametrize("name", LOSSES)
def test_deepcopy_and_pickle(name):
    loss = make_loss(name)
    SoftUpdate(loss, tau=0.01)
    reference = _output(loss)
    for clone in (copy.deepcopy(loss), pickle.loads(pickle.dumps(loss))):
        out = _output(clone)
        assert all(torch.allclose(reference[key], out[key]) for key in reference.keys())
        assert clone.critic_params["q1", "0", "weight"].data_ptr() != loss.critic_params["q1", "0", "weight"].data_ptr()


@pytest.mark.parametrize("name", LOSSES)
def test_reduction_none_gives_per_sample_losses(name):
    loss = make_loss(name, reduction="none")
    SoftUpdate(loss, tau=0.01)
    out = loss(make_batch(batch=5))
    for key in out.keys():
        if key.startswith("loss_"):
            assert out[key].shape == (5,), key
    mean = make_loss(name)
    mean.load_state_dict(loss.state_dict())
    SoftUpdate(mean, tau=0.01)
    torch.manual_seed(1)
    per_sample = loss(make_batch(batch=5))
    torch.manual_seed(1)
    averaged = mean(make_batch(batch=5))
    assert torch.allclose(per_sample["loss_critic"].mean(), averaged["loss_critic"], rtol=1e-5)


@pytest.mark.parametrize("name", LOSSES)
def test_reset_parameters_recursive(name):
    loss = make_loss(name)
    before = loss.critic_params.clone()
    loss.reset_parameters_recursive()
    assert not (loss.critic_params == before).all()
    assert (loss.target_critic_params == loss.critic_params.data).all()


def test_priority_weights_weight_the_critic_loss():
    """TorchRL's weighted mean: sum(w · loss) / sum(w)."""
    loss = make_loss("drqv2", augmentation=None, std_schedule=0.0)
    per_sample = make_loss("drqv2", augmentation=None, std_schedule=0.0, reduction="none")
    per_sample.load_state_dict(loss.state_dict())
    batch = make_batch(batch=4)
    losses = per_sample(batch.clone())["loss_critic"]
    weights = torch.tensor([3.0, 1.0, 0.0, 0.0])
    weighted = batch.clone().set("priority_weight", weights)
    expected = (weights * losses).sum() / weights.sum()
    assert torch.allclose(loss(weighted)["loss_critic"], expected)
    assert not torch.allclose(expected, losses.mean())


def test_works_on_a_torchrl_replay_buffer_sample():
    from torchrl.data import LazyTensorStorage, TensorDictReplayBuffer

    buffer = TensorDictReplayBuffer(storage=LazyTensorStorage(32), batch_size=8)
    buffer.extend(make_batch(batch=20))
    loss = make_loss("svea")
    SoftUpdate(loss, tau=0.01)
    out = loss(buffer.sample())
    assert torch.isfinite(out["loss_critic"])


def test_bad_arguments_are_explained():
    with pytest.raises(ValueError, match="reduction"):
        make_loss("drqv2", reduction="average")
    with pytest.raises(TypeError, match="ImageAugmentation"):
        make_loss("drqv2", augmentation=torch.nn.Identity())
    with pytest.raises(TypeError, match="std"):
        make_loss("drq", std_schedule=0.2)
    with pytest.raises(ValueError, match="quantile"):
        make_loss("sgqn", quantile=1.5)
