"""What the losses accept: the pixel contract, the batch's keys, and finite numbers (issue 13)."""

from __future__ import annotations

import re

import pytest
import torch
from tensordict.nn import InteractionType, set_interaction_type
from torchrl.data import Bounded
from torchrl.objectives import SoftUpdate

from loss_helpers import SAC_LOSSES, LOSSES, SIZE, make_batch, make_loss
from vigen.losses import make_loss as make_paper_loss
from vigen.transforms import ImageAugmentation, RandomShift

pytestmark = pytest.mark.filterwarnings("ignore:No target network updater")
CLASS_NAMES = {"drqv2": "DrQv2Loss", "svea": "SVEALoss", "srm": "SVEALoss", "sgqn": "SGQNLoss", "curl": "CURLLoss", "drq": "DrQLoss",
               "sada": "SADALoss", "madi": "SVEALoss", "simgrl": "SVEALoss",
               "vrl3": "VRL3Loss", "pieg": "PIEGLoss", "scpl": "SCPLLoss"}


def _deterministic(name: str, **kwargs):
    """No random view at all, so that two batches holding the same images must give the same losses."""
    extra = {"svea": {"strong_augmentation": []}, "srm": {"strong_augmentation": []},
             "sgqn": {"attribution_augmentation": []}, "curl": {"contrastive_augmentation": []},
             "sada": {"strong_augmentation": []}, "madi": {"strong_augmentation": []},
             "simgrl": {"strong_augmentation": []}, "pieg": {"strong_augmentation": []},
             "scpl": {"strong_augmentation": []}}.get(name, {})
    if name not in SAC_LOSSES:
        extra["std_schedule"] = 0.0
    return make_loss(name, augmentation=None, **extra, **kwargs)


def _losses(loss, batch, seed: int = 0) -> dict[str, torch.Tensor]:
    torch.manual_seed(seed)
    out = loss(batch)
    return {key: out[key] for key in out.keys() if key.startswith("loss_")}


def _as_float(batch, scale: float):
    batch = batch.clone()
    for key in ("pixels", ("next", "pixels")):
        batch[key] = batch[key].float() * scale
    return batch


# -- finding 1: one pixel scale ------------------------------------------------------------------
@pytest.mark.parametrize("name", LOSSES)
def test_float_pixels_on_0_1_are_the_same_images_as_uint8(name):
    """TorchRL's ToTensorImage() gives x / 255: the same images, so the same losses."""
    loss = _deterministic(name)
    batch = make_batch()
    expected = _losses(loss, batch)
    got = _losses(loss, _as_float(batch, 1 / 255))
    for key, value in expected.items():
        assert torch.allclose(got[key], value, atol=1e-5, rtol=1e-4), key


@pytest.mark.parametrize("name", LOSSES)
def test_float_pixels_on_0_255_must_be_declared(name):
    batch255 = _as_float(make_batch(), 1.0)
    with pytest.raises(ValueError, match=rf"{CLASS_NAMES[name]} \(batch entry 'pixels'\).*max_value=255"):
        _deterministic(name)(batch255)
    declared = _deterministic(name, max_value=255)
    expected = _losses(declared, make_batch())
    got = _losses(declared, batch255)
    for key, value in expected.items():
        assert torch.allclose(got[key], value, atol=1e-5, rtol=1e-4), key


@pytest.mark.parametrize("name", LOSSES)
def test_every_augmentation_of_a_loss_takes_the_encoders_max_value(name):
    loss = make_loss(name, max_value=255)  # default views: shift, overlay, frequency mask, ...
    augmentations = [m for m in loss.modules() if isinstance(m, ImageAugmentation)]
    assert augmentations and all(a.max_value == 255 for a in augmentations)
    assert loss.max_value == 255
    SoftUpdate(loss, tau=0.01)
    out = loss(_as_float(make_batch(), 1.0))  # float 0–255 through the default views
    assert torch.isfinite(out["loss_critic"])
    assert torch.isfinite(make_loss(name)(_as_float(make_batch(), 1 / 255))["loss_critic"]), "0–1 floats by default"


def test_an_augmentation_with_another_scale_is_refused():
    with pytest.raises(ValueError, match="max_value"):
        make_loss("drqv2", max_value=255, augmentation=RandomShift(pad=1, max_value=1.0))
    assert make_loss("drqv2", augmentation=RandomShift(pad=1, max_value=255)).augmentation[0].max_value == 255


def test_an_augmentation_that_changes_the_dtype_is_refused():
    """A view whose dtype changed has no known scale (0–255 or 0–1): it is not guessed."""

    class ToFloat(ImageAugmentation):
        def make_params(self, images):
            return {}

        def apply(self, images, params):
            return images.float()

    loss = make_loss("svea", strong_augmentation=ToFloat())
    with pytest.raises(TypeError, match="ToFloat.*dtype"):
        loss(make_batch())


def test_make_loss_gives_max_value_to_the_encoder_and_views():
    loss = make_paper_loss("svea", (9, 44, 44), action_dim=2, hidden_dim=8, max_value=255)
    assert loss.encoder.max_value == 255 and loss.max_value == 255
    assert all(a.max_value == 255 for a in [*loss.augmentation, *loss.strong_augmentation])


@pytest.mark.parametrize("name", ["drqv2", "drq"])
def test_the_acting_policy_takes_the_same_pixels(name):
    loss = make_loss(name)
    policy = loss.make_policy(Bounded(-1, 1, shape=(2,)))
    pixels = make_batch(batch=3)["pixels"]  # uint8, as the env writes them
    with set_interaction_type(InteractionType.DETERMINISTIC):
        action = policy(make_batch(batch=3).select("pixels"))["action"]
        unit = policy(make_batch(batch=3).select("pixels").set("pixels", pixels.float() / 255))["action"]
        assert action.shape == (3, 2) and torch.allclose(action, unit, atol=1e-5)
        with pytest.raises(ValueError, match="max_value=255"):
            policy(make_batch(batch=3).select("pixels").set("pixels", pixels.float()))


# -- finding 2: terminations are never guessed from done ------------------------------------------
@pytest.mark.parametrize("name", LOSSES)
def test_a_batch_without_terminated_is_refused(name):
    done = torch.tensor([[False], [True], [False], [False], [True], [False]])  # time limits: they bootstrap
    batch = make_batch(done=done).exclude(("next", "terminated"))
    with pytest.raises(KeyError, match=r"\('next', 'terminated'\).*set_keys\(terminated='done'\)"):
        make_loss(name)(batch)


def test_terminated_from_done_only_when_asked():
    """``set_keys(terminated='done')`` says every done is a true termination: no bootstrap there."""
    loss = _deterministic("drqv2", reduction="none")
    done = torch.tensor([[False], [True], [False], [False], [True], [False]])
    batch = make_batch(done=done)
    loss.set_keys(terminated="done")
    out = loss(batch.exclude(("next", "terminated")))
    with torch.no_grad():
        q1, q2 = loss.critic(loss.encoder(batch["pixels"]), batch["action"])
    target = batch["next", "reward"]  # only where done: y = r
    expected = ((q1 - target) ** 2 + (q2 - target) ** 2).squeeze(-1)
    assert torch.allclose(out["loss_critic"][done.squeeze(-1)], expected[done.squeeze(-1)], atol=1e-5)


# -- finding 3: every missing key, named up front -------------------------------------------------
@pytest.mark.parametrize("name", LOSSES)
def test_missing_keys_are_named_before_any_work(name):
    loss = make_loss(name)
    batch = make_batch().exclude(("next", "reward"), "action")
    rng = torch.get_rng_state()
    with pytest.raises(KeyError) as error:
        loss(batch)
    message = str(error.value)
    assert "('next', 'reward')" in message and "'action'" in message and "set_keys(action=..., reward=...)" in message
    assert "The batch has:" in message and "('next', 'pixels')" in message
    assert torch.equal(rng, torch.get_rng_state()), "nothing was drawn: the check comes before any work"


def test_missing_keys_follow_set_keys():
    loss = make_loss("drqv2")
    loss.set_keys(reward="r")
    with pytest.raises(KeyError, match=r"\('next', 'r'\)"):
        loss(make_batch())
    batch = make_batch()
    batch["next", "r"] = batch["next", "reward"]
    assert torch.isfinite(loss(batch)["loss_critic"])


# -- finding 4: NaN and inf stop the update, naming their source ----------------------------------
@pytest.mark.parametrize("name", LOSSES)
def test_non_finite_rewards_are_named(name):
    batch = make_batch()
    batch["next", "reward"][2] = float("nan")
    with pytest.raises(ValueError, match=r"batch entries \('next', 'reward'\) hold NaN or inf"):
        make_loss(name)(batch)


@pytest.mark.parametrize(
    "key, value", [("pixels", float("nan")), (("next", "pixels"), float("nan")), ("action", float("inf"))]
)
def test_non_finite_pixels_and_actions_are_named(key, value):
    batch = _as_float(make_batch(), 1 / 255)
    if batch[key].ndim == 4:
        batch[key][1, 0, 0, 0] = value
    else:
        batch[key][1, 0] = value
    with pytest.raises(ValueError, match=re.escape(repr(key)) + ".*NaN or inf"):
        make_loss("drqv2", augmentation=None)(batch)


def test_check_finite_can_be_turned_off():
    batch = make_batch()
    batch["next", "reward"][0] = float("inf")
    out = make_loss("drqv2", check_finite=False)(batch)
    assert not torch.isfinite(out["loss_critic"])


def test_diverged_parameters_are_named():
    loss = make_loss("drqv2")
    with torch.no_grad():
        loss.critic_params["q1", "0", "weight"].fill_(float("nan"))
    with pytest.raises(FloatingPointError, match=r"batch is finite.*critic_params\.q1\.0\.weight"):
        loss(make_batch())


@pytest.mark.parametrize("name", ["drqv2", "sada"])
def test_an_action_of_the_wrong_size_is_named_before_any_work(name):
    loss = make_loss(name)
    batch = make_batch()
    batch["action"] = torch.zeros(len(batch), 3)
    with pytest.raises(ValueError, match=r"'action' has shape \(6, 3\), but the critic was built for actions of size 2"):
        loss(batch)


@pytest.mark.parametrize("flag", ["done", "terminated"])
def test_float_done_flags_are_refused_with_the_fix(flag):
    batch = make_batch()
    batch["next", flag] = batch["next", flag].float()
    with pytest.raises(TypeError, match=rf"\('next', '{flag}'\) is torch.float32.*\.bool\(\)"):
        make_loss("drqv2")(batch)
