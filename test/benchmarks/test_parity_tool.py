"""The helpers of the parity tool (benchmarks/parity/), without a checkout of any original repository.

The end-to-end runs need a checkout: SADA against DMC-GB2 is skipped unless the environment
variable VIGEN_PARITY_DMCGB2 names one, VRL3 against RL-ViGen's ViGen-adroit branch unless
VIGEN_PARITY_RLVIGEN_ADROIT names its src/ folder.
"""

from __future__ import annotations

import math
import os
import random
import sys
import types
from pathlib import Path

import pytest
import torch
from torch import nn

from benchmarks.parity import algorithms, batchnorm_statistics, checkout, cli, dmcgb, harness, stand_ins


def test_relative_difference_takes_a_given_scale_for_quantities_that_are_zero_in_exact_arithmetic():
    noise_a, noise_b = torch.tensor([1e-15, -2e-15]), torch.tensor([-1e-15, 1e-15])
    assert harness.relative(noise_a, noise_b) == pytest.approx(3.0)  # rounding noise against rounding noise
    assert harness.relative(noise_a, noise_b, scale=3.0) == pytest.approx(1e-15)


def test_relative_difference_is_max_abs_error_over_max_abs_reference():
    assert harness.relative(1.0 + 1e-12, 1.0) == pytest.approx(1e-12, rel=1e-3)
    a, b = torch.tensor([1.0, 10.0]), torch.tensor([1.5, 10.0])
    assert harness.relative(a, b) == pytest.approx(0.5 / 10.0)  # the error of one element, over the tensor's scale
    assert harness.relative(torch.zeros(3), torch.zeros(3)) == 0.0
    assert harness.relative(1.0, 0.0) == 1.0 / torch.finfo(torch.float64).tiny  # no reference scale: huge, not NaN


def test_canonical_names_drop_the_params_suffix():
    assert harness.canonical("encoder_params.convnet.0.weight") == "encoder.convnet.0.weight"
    assert harness.canonical("critic_params.q1.4.bias") == "critic.q1.4.bias"
    assert harness.canonical("head.W") == "head.W"
    assert harness.canonical("log_alpha") == "log_alpha"


def test_module_map_renames_leading_parts_and_maps_plain_tensors():
    critic = nn.Module()
    critic.Q1 = nn.Linear(2, 1)
    critic.Q10 = nn.Linear(2, 1)  # "Q1" must not rename "Q10"
    agent = types.SimpleNamespace(critic=critic, log_alpha=torch.zeros(()))
    names = harness.ModuleMap("critic", "critic", (("Q1", "q1"),)).resolve(agent)
    assert sorted(names) == ["critic.Q10.bias", "critic.Q10.weight", "critic.q1.bias", "critic.q1.weight"]
    assert names["critic.q1.weight"] is critic.Q1.weight
    assert harness.ModuleMap("log_alpha", "log_alpha").resolve(agent) == {"log_alpha": agent.log_alpha}


def test_replay_returns_each_sources_view_once_in_order_and_refuses_other_inputs():
    source, other = torch.zeros(2, 3, 4, 4), torch.ones(2, 3, 4, 4)
    first, second = torch.full_like(source, 5.0), torch.full_like(source, 7.0)
    replay = harness.ReplayCallable([(source, first), (other, second), (source.clone(), second)], "aug")
    assert torch.equal(replay(source), first)
    assert torch.equal(replay(other), second)
    out = replay(source)  # the same source again: its next view
    assert torch.equal(out, second)
    out.add_(1)  # a clone: the stored view is untouched
    assert torch.equal(second, torch.full_like(source, 7.0))
    with pytest.raises(RuntimeError, match="none of its expected sources"):
        replay(source)  # both views of `source` are used up


def test_replay_augmentation_is_a_vigen_augmentation_returning_the_view():
    from vigen.transforms import ImageAugmentation

    source = torch.randint(0, 256, (2, 9, 8, 8)).double()
    view = (source + 1).clamp(max=255)
    augmentation = harness.replay_augmentation([(source, view)], "shift")
    assert isinstance(augmentation, ImageAugmentation)
    assert torch.equal(augmentation.augment(source), view)
    with pytest.raises(RuntimeError, match="vigen shift"):
        augmentation.augment(view)


def test_draws_hand_out_one_normal_stream_in_call_order():
    draws = harness.Draws(seed=3)
    one_call = draws.normal((2, 3), torch.float64)
    draws.reset()
    two_calls = torch.cat([draws.normal((1, 3), torch.float64), draws.normal((1, 3), torch.float64)])
    assert torch.equal(one_call, two_calls)  # DrQ: vigen draws [2B, A] once, RL-ViGen [B, A] twice
    two_calls.mul_(0)  # RL-ViGen's TruncatedNormal scales its noise in place
    draws.reset()
    assert torch.equal(draws.normal((2, 3), torch.float64), one_call)


def test_draws_patch_both_sides_samplers_and_restore_them():
    draws = harness.Draws(seed=0)
    real_randn_like = torch.randn_like
    original = types.ModuleType("original_like")  # an original's module with `import random`
    original.random = random
    with draws.patched([original]):
        vigen_side = torch.randn_like(torch.zeros(4, dtype=torch.float64))
        normal = torch.distributions.Normal(torch.zeros(4, dtype=torch.float64), torch.ones(4, dtype=torch.float64))
        original_side = normal.rsample()
        scalar = torch.rand(())
        python = original.random.uniform(2.0, 4.0)
        generated = torch.rand(3, generator=torch.Generator().manual_seed(0))  # seeded draws are left alone
    assert torch.equal(vigen_side, draws.normals[:4])
    assert torch.equal(original_side, draws.normals[4:8])
    assert scalar.item() == pytest.approx(draws.u)
    assert python == pytest.approx(2.0 + 2.0 * draws.u)
    assert torch.equal(generated, torch.rand(3, generator=torch.Generator().manual_seed(0)))
    assert draws.uniform_calls == 2
    assert torch.randn_like is real_randn_like and original.random is random


def test_float64_mode_makes_float_keep_float64_and_restores():
    default, float_tensor = torch.get_default_dtype(), torch.FloatTensor
    with harness.float64_mode():
        assert torch.zeros(1).dtype == torch.float64
        assert torch.zeros(1, dtype=torch.uint8).float().dtype == torch.float64
        assert torch.tensor([1 + 2j]).float().tolist() == [1.0]
        assert nn.Linear(2, 2).weight.dtype == torch.float64
        zero = torch.FloatTensor([0])  # VRL3's zero BC term: float32 would make a float64 loss + it float32
        assert zero.dtype == torch.float64 and zero.tolist() == [0.0]
        assert (torch.tensor(1.0) + zero).dtype == torch.float64
        assert torch.FloatTensor(2, 3).shape == (2, 3) and torch.FloatTensor(2, 3).dtype == torch.float64
    assert torch.get_default_dtype() == default and torch.FloatTensor is float_tensor
    assert torch.zeros(1, dtype=torch.uint8).float().dtype == torch.float32


def test_import_reference_loads_a_checkout_in_isolation_with_stubs(tmp_path):
    (tmp_path / "algos").mkdir()
    (tmp_path / "utils.py").write_text(
        "import not_installed_pkg_xyz\nfrom not_installed_pkg_xyz.sub import helper\nVALUE = 1\n"
    )
    (tmp_path / "algos" / "agent.py").write_text("import utils\nX = utils.VALUE + 1\n")
    before_path, before_utils = list(sys.path), sys.modules.get("utils")
    ref = checkout.import_reference(tmp_path, ["utils", "agent"], paths=("", "algos"),
                                  optional=("not_installed_pkg_xyz", "not_installed_pkg_xyz.sub"))
    assert ref.modules["agent"].X == 2
    assert ref.stubbed == ["not_installed_pkg_xyz", "not_installed_pkg_xyz.sub"]
    with pytest.raises(RuntimeError, match="stubbed not_installed_pkg_xyz.sub.helper"):
        ref.modules["utils"].helper()
    assert sys.path == before_path
    assert sys.modules.get("utils") is before_utils and "agent" not in sys.modules
    assert "not_installed_pkg_xyz" not in sys.modules
    with pytest.raises(FileNotFoundError, match="plain checkout"):
        checkout.import_reference(tmp_path / "missing", ["utils"])


@pytest.mark.parametrize("inplace", [False, True])
def test_guided_backprop_stand_in_clamps_negative_gradients_at_relus(inplace):
    # x = [1, 2]; h = W1 x = [1, 2, 3] (all active); dQ/dh = W2 = [1, -1, 2].
    # Guided: dQ/dh clamped at 0 → [1, 0, 2]; dQ/dx = W1ᵀ [1, 0, 2] = [3, 2] (the plain gradient is [3, 1]).
    first, second = nn.Linear(2, 3, bias=False), nn.Linear(3, 1, bias=False)
    with torch.no_grad():
        first.weight.copy_(torch.tensor([[1.0, 0.0], [0.0, 1.0], [1.0, 1.0]]))
        second.weight.copy_(torch.tensor([[1.0, -1.0, 2.0]]))
    model = nn.Sequential(first, nn.ReLU(inplace=inplace), second)
    x = torch.tensor([[1.0, 2.0]])
    assert stand_ins.GuidedBackpropStandIn(model).attribute(x).tolist() == [[3.0, 2.0]]
    assert x.grad is None and not x.requires_grad  # the input is left as it was


def test_parse_references_gives_every_algorithm_a_path_and_per_name_overrides(tmp_path):
    refs = cli.parse_references([str(tmp_path), f"curl={tmp_path / 'curl'}"], ["drqv2", "curl"])
    assert refs == {"drqv2": tmp_path, "curl": tmp_path / "curl"}
    assert cli.parse_references([f"sgqn={tmp_path}"], ["drqv2", "sgqn"]) == {"sgqn": tmp_path}
    with pytest.raises(ValueError, match="'pieg_x' is not an algorithm"):
        cli.parse_references([f"pieg_x={tmp_path}"], ["drqv2"])


def _runs(vigen_grads, original_grads):
    weight = nn.Parameter(torch.zeros(2))
    original = harness.OriginalRun(
        losses=[torch.tensor(2.0)], steps=[harness.StepRecord("critic_opt", 0, {id(weight): original_grads})],
        metrics={}, names={id(weight): "critic.w"}, normals=0, uniforms=0,
    )
    ours = harness.VigenRun({"loss_critic": 2.0}, {"loss_critic": vigen_grads}, 0, 0)
    case = types.SimpleNamespace(name="toy", metrics=[], steps=[harness.StepMap("critic", "loss_critic", (("critic_opt", 0),))],
                                 zero_gradients={})
    return case, original, ours


def test_compare_matches_steps_with_losses_and_flags_stray_gradients():
    case, original, ours = _runs({"critic.w": torch.tensor([1.0, 2.0]), "actor.w": torch.tensor([0.5])},
                                 torch.tensor([1.0, 2.5]))
    rows = {row.quantity: row for row in harness.compare(case, original, original, ours)}
    assert rows["loss_critic (critic step)"].rel == 0.0
    assert rows["∂loss_critic/∂critic.w"].rel == pytest.approx(0.5 / 2.5)
    assert math.isinf(rows["stray ∂loss_critic/∂actor.w"].rel)  # vigen's critic loss reaches the actor: reported


def test_compare_counts_a_missing_vigen_gradient_as_zero():
    case, original, ours = _runs({"critic.w": None}, torch.tensor([1.0, 2.0]))
    (loss_row, grad_row) = harness.compare(case, original, original, ours)
    assert grad_row.rel == pytest.approx(1.0)


def test_compare_measures_a_declared_zero_gradient_against_the_steps_largest():
    weight, bias = nn.Parameter(torch.zeros(2)), nn.Parameter(torch.zeros(1))
    original = harness.OriginalRun(
        losses=[torch.tensor(2.0)],
        steps=[harness.StepRecord("critic_opt", 0, {id(weight): torch.tensor([4.0, -2.0]), id(bias): torch.tensor([1e-15])})],
        metrics={}, names={id(weight): "critic.w", id(bias): "critic.b"}, normals=0, uniforms=0,
    )
    ours = harness.VigenRun({"loss_critic": 2.0}, {"loss_critic": {"critic.w": torch.tensor([4.0, -2.0]),
                                                                  "critic.b": torch.tensor([-1e-15])}}, 0, 0)
    case = types.SimpleNamespace(name="toy", metrics=[], steps=[harness.StepMap("critic", "loss_critic", (("critic_opt", 0),))],
                                 zero_gradients={})
    rows = {row.quantity: row for row in harness.compare(case, original, original, ours)}
    assert rows["∂loss_critic/∂critic.b"].rel == pytest.approx(2.0)  # undeclared: noise against noise
    case.zero_gradients = {"critic.b": "a bias before a BatchNorm"}
    (row,) = [row for row in harness.compare(case, original, original, ours) if "critic.b" in row.quantity]
    assert "0 in exact arithmetic" in row.quantity and row.rel == pytest.approx(2e-15 / 4.0)


def test_step_map_refuses_a_call_the_original_did_not_make():
    case, original, ours = _runs({"critic.w": None}, torch.tensor([1.0, 2.0]))
    case.steps = [harness.StepMap("curl", "loss_critic", (("critic_opt", 1),))]
    with pytest.raises(RuntimeError, match="called critic_opt.step\\(\\) 1 times"):
        harness.compare(case, original, original, ours)


def _checkout(root, *files):
    for name in files:
        (root / name).parent.mkdir(parents=True, exist_ok=True)
        (root / name).write_text("")
    return root


def test_select_algorithms_runs_what_each_checkout_holds_and_notes_the_rest(tmp_path):
    rlvigen = _checkout(tmp_path / "rlvigen", "rl_utils.py", "cfgs/config.yaml", "algos/drqv2.py", "algos/drq.py")
    dmcgb2 = _checkout(tmp_path / "dmcgb2", "augmentations.py", "algos/sada.py", "algos/drq.py", "algos/svea.py")
    run, skipped = cli.select_algorithms(None, {**dict.fromkeys(algorithms.ALGORITHMS, rlvigen), "sada": dmcgb2})
    assert run == ["drqv2", "drq", "sada"]
    assert len(skipped) == len(algorithms.ALGORITHMS) - 3
    assert all(algorithms.ORIGINALS[note.split()[1].rstrip(":")].repository in note for note in skipped), "each note names its original"
    # DMC-GB2 also has algos/drq.py and algos/svea.py, with other agents: a DMC-GB2 path runs only SADA
    run, skipped = cli.select_algorithms(None, dict.fromkeys(algorithms.ALGORITHMS, dmcgb2))
    assert run == ["sada"]
    assert any(note.startswith("skipped drq:") and "rl_utils.py" in note for note in skipped)
    # the ViGen-adroit branch's src/ has agents named svea, pieg, ... on VRL3's update: only VRL3 runs there
    adroit = _checkout(tmp_path / "adroit", "rl_utils.py", "utils.py", "stage1_models.py", "cfgs_adroit/config.yaml",
                       *(f"algos/{name}.py" for name in ("svea", "srm", "sgqn", "curl", "pieg", "vrl3_agent")))
    run, skipped = cli.select_algorithms(None, dict.fromkeys(algorithms.ALGORITHMS, adroit))
    assert run == ["vrl3"]
    assert any(note.startswith("skipped pieg:") and "cfgs/config.yaml" in note for note in skipped)


def test_select_algorithms_refuses_a_requested_algorithm_without_its_original(tmp_path):
    rlvigen = _checkout(tmp_path / "rlvigen", "rl_utils.py", "cfgs/config.yaml", "algos/drqv2.py")
    assert cli.select_algorithms(["drqv2"], {"drqv2": rlvigen}) == (["drqv2"], [])
    with pytest.raises(ValueError, match=r"sada: .* no augmentations.py, algos/sada.py .*--reference sada=PATH .*DMC-GB2"):
        cli.select_algorithms(["drqv2", "sada"], {"drqv2": rlvigen, "sada": rlvigen})
    with pytest.raises(ValueError, match="sada: no --reference"):
        cli.select_algorithms(["sada"], {})
    with pytest.raises(ValueError, match="no algorithm has a checkout of its original"):
        cli.select_algorithms(None, dict.fromkeys(algorithms.ALGORITHMS, tmp_path))


def test_parse_references_takes_sada_and_vrl3_by_name(tmp_path):
    refs = cli.parse_references([str(tmp_path / "rlvigen"), f"sada={tmp_path / 'dmcgb2'}", f"vrl3={tmp_path / 'src'}"],
                                   ["drq", "pieg", "sada", "vrl3"])
    assert refs == {"drq": tmp_path / "rlvigen", "pieg": tmp_path / "rlvigen", "sada": tmp_path / "dmcgb2",
                    "vrl3": tmp_path / "src"}


def test_torchvision_resnet18_stand_in_has_torchvisions_layout_and_loads_into_vigens_features(tmp_path):
    from vigen.models.resnet import ResNet18Features

    model = stand_ins.imagenet_stand_in(seed=0).eval()
    names = [name for name, _ in model.named_children()]
    assert names == ["conv1", "bn1", "relu", "maxpool", "layer1", "layer2", "layer3", "layer4", "avgpool", "fc"]
    assert "layer2.0.downsample.1.running_var" in model.state_dict() and model.fc.in_features == 512
    assert not torch.equal(model.bn1.weight, torch.ones(64))  # BatchNorms are not the identity
    torch.save(model.state_dict(), tmp_path / "resnet18.pth")
    features = ResNet18Features(depth=2)
    features.load_torchvision_weights(tmp_path / "resnet18.pth")
    features.eval()
    x = torch.randn(2, 3, 32, 32)
    with torch.no_grad():
        theirs = x
        for name, module in model.named_children():  # PIE-G's forward: the children in order, up to layer2
            theirs = module(theirs)
            if name == "layer2":
                break
        assert torch.allclose(features(x), theirs, atol=1e-5)


def test_torchvision_substitute_builds_what_the_originals_build_and_fails_on_anything_else():
    model = stand_ins.TorchvisionResNet18()
    modules, notes = stand_ins.torchvision_substitute(model)
    copy_ = modules["torchvision.models"].resnet18(pretrained=True)
    assert copy_ is not model and torch.equal(copy_.conv1.weight, model.conv1.weight)
    transforms = modules["torchvision.transforms"]
    normalize = transforms.Normalize((1.0, 2.0), (2.0, 4.0))
    assert normalize(torch.full((2, 1, 1), 5.0)).flatten().tolist() == [2.0, 0.75]
    compose = transforms.Compose([transforms.Resize(256), transforms.CenterCrop(224)])  # PIE-G builds it, never uses it
    with pytest.raises(RuntimeError, match="stubbed torchvision.transforms.Compose"):
        compose(torch.zeros(3, 8, 8))
    with pytest.raises(RuntimeError, match="stubbed torchvision.models.resnet34"):
        modules["torchvision.models"].resnet34()
    assert modules["torchvision"].transforms is transforms and len(notes) == 2
    assert len(stand_ins.torchvision_substitute()[1]) == 1  # without a ResNet: no resnet18, no note on it


class _ToyAgent:
    """An original's agent as StatisticsGap uses it: a BatchNorm network, train() and act()."""

    def __init__(self) -> None:
        self.net = nn.Sequential(nn.BatchNorm1d(2))

    def train(self, training: bool = True) -> None:
        self.net.train(training)

    def act(self, obs, step, eval_mode):
        assert eval_mode and not self.net.training
        return self.net(torch.as_tensor(obs).unsqueeze(0))[0].numpy()


def test_statistics_gap_splits_the_gap_after_an_update_into_build_time_and_order():
    original = _ToyAgent()
    ours = nn.Sequential(nn.BatchNorm1d(2))
    with torch.no_grad():
        original.net[0].running_mean.fill_(1.0)  # a gap at build: 1 against vigen's 0
    loss = types.SimpleNamespace(named_buffers=lambda: [(f"encoder_params.{n}", b) for n, b in ours.named_buffers()])
    gap = batchnorm_statistics.StatisticsGap(original, "net", "encoder", loss, torch.tensor([[3.0, 3.0]]), step=0)
    a, b = torch.tensor([[0.0, 0.0], [2.0, 2.0]]), torch.tensor([[4.0, 4.0], [6.0, 6.0]])
    for x in (a, b):  # the original sees a then b, vigen b then a
        original.net(x)
    for x in (b, a):
        ours(x)
    sentence = gap(original, loss)
    # mean after: original 0.81·1 + 0.09·1 + 0.1·5 = 1.4, vigen 0.09·5 + 0.1·1 = 0.55; build gap 1 (of 1.4),
    # (0.9)² of it left: 0.81/1.4; the order: (0.55 − 1.4 + 0.81)/1.4
    assert "2 encoder passes in vigen, 2 in the original" in sentence
    assert f"{1 / 1.4:.1e} at build, {0.85 / 1.4:.1e} after the update" in sentence
    assert f"of which {0.81 / 1.4:.1e} is what is left" in sentence and f"and {0.04 / 1.4:.1e} comes from the order" in sentence
    # acting on x = 3: (3 − mean) / sqrt(var + eps), the original's mean 1.4 against vigen's 0.55 (the same variance)
    var = original.net[0].running_var[0].item()
    assert torch.equal(ours[0].running_var, original.net[0].running_var)
    ours_action, theirs_action = (3 - 0.55) / math.sqrt(var + 1e-5), (3 - 1.4) / math.sqrt(var + 1e-5)
    assert f"max rel. diff {abs(ours_action - theirs_action) / abs(theirs_action):.1e}" in sentence
    assert original.net.training  # act() ran in eval mode, the agent is back in training mode


DMCGB2 = os.environ.get("VIGEN_PARITY_DMCGB2")
RLVIGEN_ADROIT = os.environ.get("VIGEN_PARITY_RLVIGEN_ADROIT")
SCPL = os.environ.get("VIGEN_PARITY_SCPL")
MADI = os.environ.get("VIGEN_PARITY_MADI")
SIMGRL = os.environ.get("VIGEN_PARITY_SIMGRL")


def _one_float64_update(name: str, path: str):
    """One float64 update of ``name`` on both sides at batch 2 (steps recorded, not taken); every vigen weight mapped."""
    setup = harness.Setup(batch_size=2)
    torch.manual_seed(setup.seed)  # the networks' initial weights, as the command line seeds them (unseeded, VRL3's worst row varied)
    with harness.float64_mode():
        case = algorithms.ALGORITHMS[name](Path(path), setup)
        harness.copy_weights(case)  # every vigen parameter has a counterpart of the same shape
        draws = harness.Draws(setup.seed)
        fixed = harness.run_original(case, draws, take_steps=False)
        ours = harness.run_vigen(case, draws)
    return setup, case, fixed, ours, harness.compare(case, fixed, fixed, ours)


@pytest.mark.skipif(not DMCGB2, reason="set VIGEN_PARITY_DMCGB2 to a checkout of DMC-GB2 (algos/, augmentations.py, utils.py)")
def test_sada_matches_dmcgb2_in_one_float64_update():
    setup, case, fixed, ours, rows = _one_float64_update("sada", DMCGB2)
    assert [row.quantity for row in rows if row.kind == "loss"] == [
        "loss_critic (critic step)", "loss_actor (actor step)", "loss_alpha (alpha step)"]
    assert not [row for row in rows if row.kind == "stray"]
    assert max(row.rel for row in rows) < 1e-10
    assert fixed.normals == ours.normals == 3 * setup.batch_size * setup.action_dim  # B next actions, 2B actor actions


@pytest.mark.skipif(not RLVIGEN_ADROIT, reason="set VIGEN_PARITY_RLVIGEN_ADROIT to the src/ folder of RL-ViGen's ViGen-adroit branch")
def test_vrl3_matches_rlvigen_adroit_in_one_float64_update():
    setup, case, fixed, ours, rows = _one_float64_update("vrl3", RLVIGEN_ADROIT)
    assert [row.quantity for row in rows if row.kind == "loss"] == ["loss_critic (critic step)", "loss_actor (actor step)"]
    assert not [row for row in rows if row.kind == "stray"]
    assert max(row.rel for row in rows) < 1e-10
    assert fixed.normals == ours.normals == 2 * setup.batch_size * setup.action_dim  # B next actions, B actor actions


def test_dmcgb_driver_exposes_the_originals_optimizers_and_heads_under_vigens_names():
    """A DMC-GB agent behind the tool's update(replay_iter, step): replayed shifted views, its logger's values back."""
    seen = {}

    class Agent:
        def __init__(self):
            encoder = torch.nn.Module()
            encoder.projection = torch.nn.Module()
            encoder.projection.projection = torch.nn.Linear(3, 2)
            self.critic = torch.nn.Module()
            self.critic.encoder = encoder
            self.critic.Q1, self.critic.Q2 = (torch.nn.Module() for _ in range(2))
            self.critic.Q1.trunk, self.critic.Q2.trunk = torch.nn.Linear(2, 1), torch.nn.Linear(2, 1)
            self.critic_target = self.critic
            self.critic_optimizer = torch.optim.Adam(self.critic.parameters())

        def update(self, buffer, log, step):
            seen["sample"], seen["svea"], seen["step"] = buffer.sample_drq(), buffer.sample_svea(), step
            log.log("train/kl_loss", torch.tensor(0.5), step)

    driver = dmcgb.DMCGBDriver(Agent())
    assert driver.critic_optimizer is driver.agent.critic_optimizer
    assert driver.critic.trunk is driver.agent.critic.encoder.projection.projection
    assert driver.critic.q1 is driver.agent.critic.Q1.trunk
    obs, action, reward, next_obs = torch.zeros(2, 9, 4, 4), torch.zeros(2, 1), torch.ones(2, 1), torch.ones(2, 9, 4, 4)
    driver.aug = lambda x: x + 1
    metrics = driver.update(iter([(obs, action, reward, torch.full_like(reward, 0.99), next_obs)]), 90_000)
    shifted, _, _, shifted_next, not_done = seen["sample"]
    assert torch.equal(shifted, obs + 1) and torch.equal(shifted_next, next_obs + 1) and torch.equal(not_done, torch.ones(2, 1))
    assert torch.equal(seen["svea"][0], obs + 1) and torch.equal(seen["svea"][3], next_obs), "sample_svea: obs shifted only"
    assert seen["step"] == dmcgb.DMCGB_STEP and seen["step"] % 2 == 0 and seen["step"] % 10_000
    assert metrics == {"train/kl_loss": 0.5}


@pytest.mark.skipif(not SCPL, reason="set VIGEN_PARITY_SCPL to a checkout of bofusun/SCPL (and captum on the path)")
def test_scpl_matches_its_original_in_one_float64_update():
    setup, case, fixed, ours, rows = _one_float64_update("scpl", SCPL)
    assert [row.quantity for row in rows if row.kind == "loss"] == [
        "loss_critic (critic step)", "loss_actor (actor step)", "loss_alpha (alpha step)", "loss_dynamics (dynamics step)"]
    assert not [row for row in rows if row.kind == "stray"]
    assert max(row.rel for row in rows) < 1e-10
    assert ours.normals == 2 * setup.batch_size * setup.action_dim  # B next actions, B actor actions
    assert fixed.normals == ours.normals + case.unused_normals and fixed.uniforms == ours.uniforms == 1


@pytest.mark.parametrize("name, path", [
    pytest.param("madi", MADI, marks=pytest.mark.skipif(not MADI, reason="set VIGEN_PARITY_MADI to a checkout of bramgrooten/mask-distractions")),
    pytest.param("simgrl", SIMGRL, marks=pytest.mark.skipif(not SIMGRL, reason="set VIGEN_PARITY_SIMGRL to a checkout of W-Song11/SimGRL-Code")),
])
def test_dmcgb_svea_forks_match_their_originals_in_one_float64_update(name, path):
    setup, case, fixed, ours, rows = _one_float64_update(name, path)
    assert [row.quantity for row in rows if row.kind == "loss"] == [
        "loss_critic (critic step)", "loss_actor (actor step)", "loss_alpha (alpha step)"]
    assert not [row for row in rows if row.kind == "stray"]
    assert max(row.rel for row in rows) < 1e-10
    assert fixed.normals == ours.normals == 2 * setup.batch_size * setup.action_dim  # B next actions, B actor actions


def test_two_checkouts_with_the_same_package_names_load_apart(tmp_path):
    """MaDi, SimGRL and SCPL all have src/algorithms/modules.py: each import sees its own."""
    for name in ("one", "two"):
        (tmp_path / name / "algorithms").mkdir(parents=True)
        (tmp_path / name / "algorithms" / "modules.py").write_text(f"WHO = {name!r}\n")
    first = checkout.import_reference(tmp_path / "one", ["algorithms.modules"])
    second = checkout.import_reference(tmp_path / "two", ["algorithms.modules"])
    assert first.modules["algorithms.modules"].WHO == "one" and second.modules["algorithms.modules"].WHO == "two"
