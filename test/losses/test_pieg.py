"""PIE-G's update (SVEA's critic on a frozen ResNet-18, one BatchNorm batch per view) and its acting BatchNorm modes."""

from __future__ import annotations

import copy
import warnings

import pytest
import torch
from tensordict import TensorDict
from tensordict.nn import InteractionType, set_interaction_type
from torchrl.data import Bounded
from torchrl.objectives import SoftUpdate

from loss_helpers import ACTIONS, SIZE, make_batch, make_loss
from vigen.losses import ALGOS, PIEGLoss
from vigen.losses import make_loss as make_paper_loss
from vigen.models import PIEGEncoder
from vigen.transforms import ImageAugmentation

pytestmark = pytest.mark.filterwarnings("ignore:No target network updater")
GAMMA = 0.9  # loss_helpers' discount


class Invert(ImageAugmentation):
    """A deterministic 'strong view' (255 − x), so that the update can be computed by hand."""

    def make_params(self, images):
        return {}

    def apply(self, images, params):
        return 255 - images


def _deterministic(**kwargs) -> PIEGLoss:
    return make_loss("pieg", augmentation=None, strong_augmentation=Invert(), std_schedule=0.0, **kwargs)


def _resnet_state(loss: PIEGLoss) -> dict[str, torch.Tensor]:
    return {key: value.detach().clone() for key, value in loss.encoder.resnet.state_dict().items()}


# -- the update, by hand ----------------------------------------------------------------------------------
def test_update_by_hand():
    """loss_critic = 0.5·[(Q1(h)−y)² + (Q2(h)−y)²] + 0.5·[(Q1(h̃)−y)² + (Q2(h̃)−y)²], one BN batch per view."""
    loss = _deterministic(reduction="none")
    batch = make_batch(batch=5)
    out = loss(batch)
    encoder, actor, critic = loss.encoder, loss.actor, loss.critic  # training mode: batch statistics
    pixels, next_pixels, action = batch["pixels"], batch["next", "pixels"], batch["action"]
    with torch.no_grad():
        h, h_strong, h_next = encoder(pixels), encoder(255 - pixels), encoder(next_pixels)
        next_action = actor(h_next).clamp(-1 + 1e-6, 1 - 1e-6)
        target_critic = copy.deepcopy(critic)  # no soft update yet: the target equals the online critic
        y = batch["next", "reward"] + GAMMA * torch.min(*target_critic(h_next, next_action))
        q1, q2 = critic(h, action)
        s1, s2 = critic(h_strong, action)
        expected = 0.5 * ((q1 - y) ** 2 + (q2 - y) ** 2) + 0.5 * ((s1 - y) ** 2 + (s2 - y) ** 2)
        actor_loss = -torch.min(*critic(h, actor(h).clamp(-1 + 1e-6, 1 - 1e-6)))
        # one BatchNorm batch for both views (SVEA's concatenation) would give other features
        joint = encoder(torch.cat([pixels, 255 - pixels]))
    assert torch.allclose(out["loss_critic"], expected.squeeze(-1), atol=1e-5)
    assert torch.allclose(out["loss_actor"], actor_loss.squeeze(-1), atol=1e-5)
    assert not torch.allclose(joint[:5], h, atol=1e-3), "the per-view passes matter"
    assert torch.allclose(out["q_strong_mean"], s1.mean(), atol=1e-5)


def test_is_svea_with_weak_and_strong_weights():
    loss = _deterministic(reduction="none", weak_weight=0.25, strong_weight=2.0)
    clean = _deterministic(reduction="none", weak_weight=1.0, strong_weight=0.0)
    strong = _deterministic(reduction="none", weak_weight=0.0, strong_weight=1.0)
    for other, (alpha, beta) in ((clean, (1.0, 0.0)), (strong, (0.0, 1.0))):
        other.load_state_dict(loss.state_dict())  # (the coefficients are buffers: set them again)
        other.weak_weight.fill_(alpha), other.strong_weight.fill_(beta)
    batch = make_batch()
    expected = 0.25 * clean(batch)["loss_critic"] + 2.0 * strong(batch)["loss_critic"]
    assert torch.allclose(loss(batch)["loss_critic"], expected, atol=1e-5)


# -- frozen weights, adapting statistics ------------------------------------------------------------------
def test_an_optimizer_step_moves_the_head_and_the_statistics_but_not_the_resnet():
    loss = make_loss("pieg")
    SoftUpdate(loss, tau=0.01)
    optimizer = torch.optim.Adam(loss.optimizer_groups(lr=1e-2))
    before = _resnet_state(loss)
    head = loss.encoder.fc.weight.detach().clone()
    out = loss(make_batch())
    sum(value for key, value in out.items() if key.startswith("loss_")).backward()
    assert all(p.grad is None for p in loss.encoder.resnet.parameters()), "the ResNet gets no gradient"
    optimizer.step()
    after = _resnet_state(loss)
    frozen = [key for key, _ in loss.encoder.resnet.named_parameters()]
    statistics = [key for key, _ in loss.encoder.resnet.named_buffers()]
    assert frozen and all(torch.equal(after[key], before[key]) for key in frozen)
    assert int(after["bn1.num_batches_tracked"]) == int(before["bn1.num_batches_tracked"]) + 3, "next, clean, strong"
    moved = [key for key in statistics if key.endswith("running_mean") and not torch.equal(after[key], before[key])]
    assert len(moved) == sum(key.endswith("running_mean") for key in statistics), "every BatchNorm adapts"
    assert not torch.equal(loss.encoder.fc.weight, head)
    assert loss.encoder.training and all(m.training for m in loss.encoder.modules())


# -- acting ---------------------------------------------------------------------------------------------
def _act(policy, pixels):
    with set_interaction_type(InteractionType.DETERMINISTIC), torch.no_grad():
        return policy(TensorDict({"pixels": pixels}, batch_size=pixels.shape[:-3]))["action"]


def test_acting_uses_running_statistics_by_default():
    """RL-ViGen acts (and evaluates while training) with its agent in eval mode."""
    loss = make_loss("pieg")
    loss(make_batch())  # move the running statistics away from their start
    pixels = make_batch(batch=3, seed=1)["pixels"]
    action = _act(loss.make_policy(Bounded(-1, 1, shape=(ACTIONS,))), pixels)
    with torch.no_grad():
        expected = loss.actor(copy.deepcopy(loss.encoder).eval()(pixels))
        batch_statistics = loss.actor(copy.deepcopy(loss.encoder)(pixels))
    assert torch.allclose(action, expected, atol=1e-5)
    assert not torch.allclose(action, batch_statistics, atol=1e-3)
    assert loss.encoder.training and all(m.training for m in loss.encoder.modules())


def test_acting_leaves_the_running_statistics_alone():
    for mode in ("running", "observation"):
        loss = make_loss("pieg", acting_batchnorm=mode)
        statistics = _resnet_state(loss)
        _act(loss.make_policy(Bounded(-1, 1, shape=(ACTIONS,))), make_batch(batch=3)["pixels"])
        after = _resnet_state(loss)
        assert all(torch.equal(after[key], statistics[key]) for key in statistics), mode
        assert all(m.training for m in loss.encoder.modules()), mode


def test_acting_with_each_observations_statistics():
    """RL-ViGen's standalone evaluators leave PIE-G's BatchNorms in training mode: each observation's own frames."""
    loss = make_loss("pieg", acting_batchnorm="observation")
    pixels = make_batch(batch=2, seed=2)["pixels"]
    action = _act(loss.make_policy(Bounded(-1, 1, shape=(ACTIONS,))), pixels)
    reference = copy.deepcopy(loss.encoder)  # training mode
    with torch.no_grad():
        expected = torch.cat([loss.actor(reference(pixels[i : i + 1])) for i in range(2)])
        together = loss.actor(reference(pixels))
    assert torch.allclose(action, expected, atol=1e-5)
    assert not torch.allclose(action, together, atol=1e-3)
    single = _act(loss.make_policy(Bounded(-1, 1, shape=(ACTIONS,))), pixels[1])  # one unbatched observation
    assert single.shape == (ACTIONS,) and torch.allclose(single, expected[1], atol=1e-5)
    running = _act(loss.make_policy(Bounded(-1, 1, shape=(ACTIONS,)), batchnorm="running"), pixels)
    assert not torch.allclose(running, action, atol=1e-3)


def test_bad_acting_mode_is_refused():
    with pytest.raises(ValueError, match="'running'.*'observation'"):
        make_loss("pieg", acting_batchnorm="eval")
    with pytest.raises(ValueError, match="'running'.*'observation'"):
        make_loss("pieg").make_policy(Bounded(-1, 1, shape=(ACTIONS,)), batchnorm="train")


# -- reset and the factory --------------------------------------------------------------------------------
def test_reset_keeps_the_frozen_resnet_and_its_loaded_statistics():
    loss = make_loss("pieg")
    SoftUpdate(loss, tau=0.01)
    start = _resnet_state(loss)
    loss(make_batch())  # the statistics move
    critic, head = loss.critic_params.clone(), loss.encoder.fc.weight.detach().clone()
    loss.reset_parameters_recursive()
    after = _resnet_state(loss)
    assert all(torch.equal(after[key], start[key]) for key in start), "weights and statistics as loaded"
    assert not (loss.critic_params == critic).all() and not torch.equal(loss.encoder.fc.weight, head)
    assert (loss.target_critic_params == loss.critic_params.data).all()
    assert not any(p.requires_grad for p in loss.encoder.resnet.parameters())


def test_make_loss_builds_pieg_and_loads_weights(tmp_path):
    assert ALGOS["pieg"].loss is PIEGLoss
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        source = PIEGEncoder(9, image_size=SIZE, out_dim=8)
    with torch.no_grad():
        for value in source.resnet.parameters():
            value.normal_()
    path = tmp_path / "resnet18.pth"
    torch.save(source.resnet.state_dict(), path)  # torchvision's names (test/models/test_resnet.py checks the layout)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        loss = make_paper_loss("pieg", (9, SIZE, SIZE), action_dim=ACTIONS, hidden_dim=16, encoder_weights=path, seed=0)
    assert isinstance(loss.encoder, PIEGEncoder) and loss.encoder.out_dim == 1024  # RL-ViGen's repr_dim
    assert torch.equal(loss.encoder.resnet.layer2[1].conv2.weight, source.resnet.layer2[1].conv2.weight)
    with pytest.warns(UserWarning, match="ImageNet weights.*encoder_weights="):
        make_paper_loss("pieg", (9, SIZE, SIZE), action_dim=ACTIONS, hidden_dim=16)
