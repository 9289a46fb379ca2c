"""VRL3's stage-3 update (safe Q target, pre-tanh penalty, std 0.01, encoder lr scale) and its ResNet encoder."""

from __future__ import annotations

import math
import pickle
import warnings

import pytest
import torch
from tensordict.nn import InteractionType, set_interaction_type
from torch import nn
from torchrl.data import Bounded
from torchrl.objectives import SoftUpdate

from loss_helpers import ACTIONS, SIZE, make_batch, make_loss
from vigen.losses import ALGOS, LinearSchedule, VRL3Loss, build_loss
from vigen.losses import make_loss as make_paper_loss
from vigen.losses.base import RunningStatistics
from vigen.losses.vrl3 import pretanh_penalty, safe_q_target
from vigen.models import Actor, Critic, VRL3Encoder

pytestmark = [pytest.mark.filterwarnings("ignore:No target network updater"),
              pytest.mark.filterwarnings("ignore:VRL3Encoder starts from random weights")]
MEAN, STD = (0.485, 0.456, 0.406), (0.229, 0.224, 0.225)


def _encoder(in_channels: int = 9, **kwargs) -> VRL3Encoder:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return VRL3Encoder(in_channels, **kwargs)


def _deterministic(**kwargs) -> VRL3Loss:
    """No augmentation and no noise: every term can be computed by hand from the networks."""
    return make_loss("vrl3", augmentation=None, std_schedule=0.0, reduction="none", **kwargs)


# -- the safe Q target --------------------------------------------------------------------------
def test_safe_q_target_by_hand():
    y = torch.tensor([[-50.0], [0.0], [200.0], [201.0], [202.0], [216.0], [1200.0]])
    expected = torch.tensor([[-50.0], [0.0], [200.0], [201.0], [200 + 2 ** 0.5], [204.0], [200.0 + 1000 ** 0.5]])
    assert torch.allclose(safe_q_target(y, threshold=200.0, factor=0.5), expected)
    capped = torch.tensor([[-50.0], [0.0], [200.0], [201.0], [201.0], [201.0], [201.0]])
    assert torch.allclose(safe_q_target(y, threshold=200.0, factor=0.0), capped), "0: a hard cap at c + 1"
    assert torch.equal(safe_q_target(y, threshold=200.0, factor=1.0), y), "1: off"
    near = torch.tensor([201.0 - 1e-3, 201.0 + 1e-3])
    assert torch.allclose(safe_q_target(near), near, atol=2e-3), "the two pieces meet at c + 1"
    assert torch.isfinite(safe_q_target(torch.tensor([-1e6, 1e6]))).all()


def test_the_critic_trains_on_the_safe_target():
    loss = _deterministic(safe_q_threshold=0.5, safe_q_factor=0.5)
    SoftUpdate(loss, tau=0.01)
    reward = torch.tensor([[0.0], [0.2], [3.0], [10.0], [-4.0], [50.0]])
    batch = make_batch(reward=reward)
    out = loss(batch)
    with torch.no_grad():  # the encoder trains, so its BatchNorms use each batch's statistics, as in the loss
        next_features = loss.encoder(batch["next", "pixels"])
        next_action = loss.actor(next_features).clamp(-1 + 1e-6, 1 - 1e-6)
        y = reward + 0.9 * torch.min(*loss.critic(next_features, next_action))  # target critic = critic at start
        safe = torch.where(y > 1.5, 0.5 + (y - 0.5).clamp(min=1).sqrt(), y)
        q1, q2 = loss.critic(loss.encoder(batch["pixels"]), batch["action"])
    assert (y > 1.5).any() and (y <= 1.5).any(), "both pieces are exercised"
    assert torch.allclose(out["loss_critic"], ((q1 - safe) ** 2 + (q2 - safe) ** 2).squeeze(-1), atol=1e-5)
    assert torch.allclose(out["target_mean"], safe.mean(), atol=1e-6)


# -- the pre-tanh penalty -------------------------------------------------------------------------
def test_pretanh_penalty_by_hand():
    u = torch.tensor([[6.0, -2.0, 0.0], [-9.0, 5.0, 7.5]])
    # relu(|u| - 5)²: [1, 0, 0] and [16, 0, 6.25], averaged over the action dims
    assert torch.allclose(pretanh_penalty(u, threshold=5.0), torch.tensor([1 / 3, 22.25 / 3]))
    assert torch.equal(pretanh_penalty(torch.full((2, 3), 4.9)), torch.zeros(2))


def _saturated(loss: VRL3Loss, scale: float = 200.0) -> None:
    """Blow up the actor's last layer so its pre-tanh output leaves [-5, 5]."""
    with torch.no_grad():
        loss.actor_params["action_head", "4", "weight"].mul_(scale)
        loss.actor_params["action_head", "4", "bias"].fill_(3.0)


def test_the_actor_loss_adds_the_weighted_penalty():
    loss = _deterministic(pretanh_weight=0.01, pretanh_threshold=2.0)
    _saturated(loss)
    SoftUpdate(loss, tau=0.01)
    batch = make_batch()
    out = loss(batch)
    with torch.no_grad():
        features = loss.encoder(batch["pixels"])
        u = loss.actor.action_head(loss.actor.trunk(features))
        action = torch.tanh(u).clamp(-1 + 1e-6, 1 - 1e-6)
        q = torch.min(*loss.critic(features, action)).squeeze(-1)
        penalty = 0.01 * ((u.abs() - 2.0).clamp(min=0) ** 2).mean(-1)
    assert (u.abs() > 2.0).any(), "the penalty is active"
    assert torch.allclose(out["loss_actor"], -q + penalty, rtol=1e-5, atol=1e-5)
    assert torch.allclose(out["actor_pretanh_penalty"], penalty.mean(), rtol=1e-5)
    assert torch.allclose(out["max_abs_pretanh"], u.abs().max(), rtol=1e-5)


def test_the_penalty_trains_the_actor_only_and_shrinks_the_pre_tanh_output():
    loss = make_loss("vrl3", pretanh_weight=1.0)
    _saturated(loss)
    SoftUpdate(loss, tau=0.01)
    out = loss(make_batch())
    loss.zero_grad(set_to_none=True)
    out["loss_actor"].backward()
    for part in ("encoder", "critic"):
        assert all(g.grad is None or not g.grad.any() for g in getattr(loss, f"{part}_params").values(True, True)), part
    assert all(p.grad is None for p in loss.target_critic_params.values(True, True))
    free = make_loss("vrl3", pretanh_weight=1.0, std_schedule=0.0, augmentation=None)
    free.load_state_dict(loss.state_dict())
    optimizer = torch.optim.SGD(free.actor_params.values(True, True), lr=1e-4)
    pixels = make_batch()["pixels"]
    before = free.actor.action_head(free.actor.trunk(free.encoder(pixels).detach())).abs().max()
    for _ in range(5):
        optimizer.zero_grad()
        out = free(make_batch())
        out["loss_actor"].backward()
        optimizer.step()
    after = free.actor.action_head(free.actor.trunk(free.encoder(pixels).detach())).abs().max()
    assert after < before


def test_without_penalty_any_actor_works_and_with_it_the_actor_must_expose_pre_tanh():
    encoder = _encoder(channels=4)

    class Plain(nn.Module):
        def __init__(self):
            super().__init__()
            self.net = nn.Linear(32, ACTIONS)

        def forward(self, h):
            return torch.tanh(self.net(h))

    critic = Critic(32, ACTIONS, feature_dim=8, hidden_dim=16)
    with pytest.raises(TypeError, match="before its tanh"):
        build_loss("vrl3", encoder, Plain(), critic)
    loss = build_loss("vrl3", encoder, Plain(), critic, pretanh_weight=0.0, augmentation=None)
    loss.make_value_estimator(gamma=0.9)
    out = loss(make_batch())
    assert "actor_pretanh_penalty" not in out.keys() and torch.isfinite(out["loss_actor"])


@pytest.mark.parametrize("options, match", [
    ({"safe_q_factor": 1.5}, "safe_q_factor"), ({"safe_q_factor": -0.1}, "safe_q_factor"),
    ({"safe_q_threshold": math.inf}, "safe_q_threshold"), ({"pretanh_weight": -1.0}, "pretanh_weight"),
    ({"pretanh_threshold": -1.0}, "pretanh_threshold"), ({"param_groups": {"encoder": {"lr_scale": -0.1}}}, "lr_scale"),
    ({"param_groups": {"encoder": {"learning_rate": 0.1}}}, "unknown options"),
])
def test_bad_options_are_refused(options, match):
    with pytest.raises(ValueError, match=match):
        make_loss("vrl3", **options)


# -- VRL3's defaults: std, encoder learning rate ------------------------------------------------------
def test_vrl3_defaults():
    loss = make_paper_loss("vrl3", (9, SIZE, SIZE), ACTIONS, hidden_dim=8, feature_dim=8)
    assert isinstance(loss, VRL3Loss) and isinstance(loss.encoder, VRL3Encoder)
    loss.set_step(10**6)
    assert loss.sampler.std_schedule == LinearSchedule(0.01, 0.01, 500_000) and loss.sampler.clip == 0.3, "linear(0.01, 0.01, 500000)"
    assert (loss.safe_q_threshold, loss.safe_q_factor, loss.pretanh_threshold, loss.pretanh_weight) == (200.0, 0.5, 5.0, 1e-3)
    assert len(loss.optimizer_groups(1e-4)) == 1, "the encoder at the base lr (VRL3's encoder_lr_scale 1)"
    assert ALGOS["vrl3"].reward_scale("adroit/door") == 1 / 20
    policy = loss.make_policy(Bounded(-1, 1, shape=(ACTIONS,)))
    assert policy[-1].sigma == pytest.approx(0.01), "acting noise: the same fixed std"


def test_encoder_learning_rate_scale():
    loss = make_loss("vrl3", param_groups={"encoder": {"lr_scale": 0.01}})
    groups = loss.optimizer_groups(1e-4)
    assert [group["lr"] for group in groups] == [1e-4, pytest.approx(1e-6)]
    assert pickle.loads(pickle.dumps(loss)).optimizer_groups(1e-4)[1]["lr"] == pytest.approx(1e-6), "the scale pickles"
    encoder = {id(p) for p in loss.encoder_params.parameters()}
    assert {id(p) for p in groups[1]["params"]} == encoder
    everything = [id(p) for group in groups for p in group["params"]]
    assert len(everything) == len(set(everything)) and set(everything) == {id(p) for p in loss.parameters()}
    optimizer = torch.optim.Adam(groups)
    SoftUpdate(loss, tau=0.01)
    weights = {"encoder": loss.encoder_params, "actor": loss.actor_params}
    before = {name: {key: value.detach().clone() for key, value in params.items(True, True) if isinstance(value, nn.Parameter)}
              for name, params in weights.items()}
    out = loss(make_batch())
    sum(value for key, value in out.items() if key.startswith("loss_")).backward()
    optimizer.step()
    # Adam's first step moves each weight by at most about its lr, most of them by nearly that
    step = {name: max((weights[name][key] - value).abs().max() for key, value in before[name].items()) for name in weights}
    assert 5e-7 < step["encoder"] < 1.1e-6 and 5e-5 < step["actor"] < 1.1e-4


# -- acting: BatchNorms on their running statistics --------------------------------------------------
def test_the_policy_acts_on_running_statistics_and_leaves_them_alone():
    loss = make_loss("vrl3")
    policy = loss.make_policy(Bounded(-1, 1, shape=(ACTIONS,)))
    loss(make_batch())  # an update: the running statistics move
    norms = [m for m in loss.encoder.modules() if isinstance(m, nn.BatchNorm2d)]
    stats = [(m.running_mean.clone(), int(m.num_batches_tracked)) for m in norms]
    pixels = make_batch(batch=1)["pixels"]
    with set_interaction_type(InteractionType.DETERMINISTIC):
        action = policy(make_batch(batch=1).select("pixels"))["action"]
    assert all(m.training for m in norms), "the loss's encoder stays in training mode"
    assert all(torch.equal(m.running_mean, mean) and int(m.num_batches_tracked) == n for m, (mean, n) in zip(norms, stats))
    loss.encoder.eval()
    with torch.no_grad():
        expected = loss.actor(loss.encoder(pixels))
    loss.encoder.train()
    assert torch.allclose(action, expected, atol=1e-6)


def test_running_statistics_restores_only_what_it_switched():
    net = nn.Sequential(nn.Conv2d(3, 2, 3), nn.BatchNorm2d(2), nn.BatchNorm2d(2))
    net[2].eval()
    RunningStatistics(net)(torch.rand(2, 3, 5, 5))
    assert net[1].training and not net[2].training and net.training


# -- the encoder ----------------------------------------------------------------------------------
def test_encoder_shapes_and_pixel_contract():
    encoder = _encoder(channels=8)
    pixels = make_batch()["pixels"]
    assert encoder(pixels).shape == (6, 64) and encoder.output_dim(9, SIZE, SIZE) == 64
    assert _encoder(channels=8)(torch.zeros(2, 5, 9, 84, 84, dtype=torch.uint8)).shape == (2, 5, 64), "leading dims"
    assert torch.allclose(encoder(pixels.float() / 255), encoder(pixels), atol=1e-5)
    with pytest.raises(ValueError, match="max_value=255"):
        encoder(pixels.float())
    scaled = _encoder(channels=8, max_value=255)
    scaled.load_state_dict(encoder.state_dict())
    assert scaled.max_value == 255 and torch.allclose(scaled(pixels.float()), encoder(pixels), atol=1e-5)
    with pytest.raises(ValueError, match="channels-last"):
        encoder(pixels.movedim(-3, -1))
    with pytest.raises(ValueError, match="in_channels=6"):
        encoder(pixels[:, :6])
    with pytest.raises(ValueError, match="3·frames"):
        _encoder(8)
    with pytest.raises(ValueError, match="max_value"):
        _encoder(max_value=0)


def test_output_dim_does_not_touch_the_running_statistics():
    encoder = _encoder(channels=4)
    assert encoder.output_dim(9, 84, 84) == 32 and int(encoder.bn1.num_batches_tracked) == 0
    with pytest.raises(ValueError, match="3×3"):
        encoder.output_dim(9, 2, 2)


def test_pixels_are_normalised_with_imagenet_statistics():
    encoder = _encoder(channels=4)
    seen = []
    encoder.conv1.register_forward_hook(lambda module, args, out: seen.append(args[0]))
    pixels = make_batch(batch=2)["pixels"]
    encoder(pixels)
    mean = torch.tensor(MEAN * 3).view(1, 9, 1, 1)
    std = torch.tensor(STD * 3).view(1, 9, 1, 1)
    assert torch.allclose(seen[0], (pixels.float() / 255 - mean) / std, atol=1e-6)


def test_the_stem_is_one_frames_stem_tiled_over_the_stack(tmp_path):
    """A stack of three copies of a frame gives the features of that frame alone (weights / k)."""
    one = _encoder(3, channels=4)
    torch.save({"state_dict": one.state_dict()}, tmp_path / "one.pth.tar")
    stack = VRL3Encoder(9, channels=4, stage1_weights=tmp_path / "one.pth.tar")
    assert torch.allclose(stack.conv1.weight, one.conv1.weight.repeat(1, 3, 1, 1) / 3)
    frame = make_batch()["pixels"][:, :3]
    assert torch.allclose(stack(frame.repeat(1, 3, 1, 1)), one(frame), atol=1e-5)
    fresh = _encoder(9, channels=4)
    weight = fresh.conv1.weight
    assert torch.equal(weight[:, :3], weight[:, 3:6]) and torch.equal(weight[:, :3], weight[:, 6:]), "random init too"


def test_stage1_checkpoints(tmp_path):
    source = _encoder(3, channels=4, blocks=1)
    with torch.no_grad():
        source.bn1.running_mean.uniform_()
    state = {f"module.{key}": value for key, value in source.state_dict().items()}  # DataParallel names
    state["module.fc.weight"], state["module.fc.bias"] = torch.zeros(1000, 32), torch.zeros(1000)  # the classifier
    torch.save({"epoch": 90, "arch": "resnet10_32channel", "state_dict": state, "best_acc1": 0.5}, tmp_path / "ck.pth.tar")
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # no "random weights" warning when a checkpoint is given
        encoder = VRL3Encoder(9, channels=4, blocks=1, stage1_weights=tmp_path / "ck.pth.tar")
    assert torch.equal(encoder.bn1.running_mean, source.bn1.running_mean)
    assert torch.equal(encoder.layer2[0].downsample[0].weight, source.layer2[0].downsample[0].weight)
    with pytest.raises(ValueError, match=r"channels=4, blocks=0.*unexpected: .*conv2"):
        VRL3Encoder(9, channels=4, blocks=0, stage1_weights=tmp_path / "ck.pth.tar")
    with pytest.raises(ValueError, match="wrong shape"):
        VRL3Encoder(9, channels=8, blocks=1, stage1_weights=tmp_path / "ck.pth.tar")
    with pytest.raises(FileNotFoundError, match="no stage-1 checkpoint.*stage1_weights=None"):
        VRL3Encoder(9, stage1_weights=tmp_path / "missing.pth.tar")


def test_without_stage1_weights_a_warning_says_so():
    with pytest.warns(UserWarning, match="random weights.*stage1_weights="):
        VRL3Encoder(9)


def test_make_loss_passes_stage1_weights_to_the_encoder(tmp_path):
    source = _encoder(3, channels=32)
    torch.save(source.state_dict(), tmp_path / "plain.pt")
    loss = make_paper_loss("vrl3", (9, SIZE, SIZE), ACTIONS, hidden_dim=8, stage1_weights=tmp_path / "plain.pt")
    assert torch.allclose(loss.encoder.conv1.weight, source.conv1.weight.repeat(1, 3, 1, 1) / 3)
    assert torch.equal(loss.encoder_params["layer4", "0", "conv1", "weight"], source.layer4[0].conv1.weight)


def test_the_actor_reads_the_same_actor_as_vigens():
    """The penalty's ``u = actor.action_head(actor.trunk(h))`` is the input of vigen's Actor's final tanh."""
    actor = Actor(32, ACTIONS, feature_dim=8, hidden_dim=16)
    loss = build_loss("vrl3", _encoder(channels=4), actor, Critic(32, ACTIONS, feature_dim=8, hidden_dim=16))
    features = torch.randn(5, 32)
    assert torch.allclose(torch.tanh(actor.action_head(actor.trunk(features))), loss.actor_output(features))
