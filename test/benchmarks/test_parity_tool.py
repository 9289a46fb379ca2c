"""The helpers of benchmarks/parity.py, without a checkout of any original repository.

One end-to-end run (SADA against DMC-GB2) needs a checkout: it is skipped unless the environment
variable VIGEN_PARITY_DMCGB2 names one.
"""

from __future__ import annotations

import importlib.util
import math
import os
import random
import sys
import types
from pathlib import Path

import pytest
import torch
from torch import nn

PARITY = Path(__file__).resolve().parents[2] / "benchmarks" / "parity.py"


@pytest.fixture(scope="module")
def parity() -> types.ModuleType:
    spec = importlib.util.spec_from_file_location("vigen_benchmarks_parity", PARITY)
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module  # dataclasses resolve their module while the class body runs
    spec.loader.exec_module(module)
    yield module
    del sys.modules[spec.name]


def test_relative_difference_is_max_abs_error_over_max_abs_reference(parity):
    assert parity.relative(1.0 + 1e-12, 1.0) == pytest.approx(1e-12, rel=1e-3)
    a, b = torch.tensor([1.0, 10.0]), torch.tensor([1.5, 10.0])
    assert parity.relative(a, b) == pytest.approx(0.5 / 10.0)  # the error of one element, over the tensor's scale
    assert parity.relative(torch.zeros(3), torch.zeros(3)) == 0.0
    assert parity.relative(1.0, 0.0) == 1.0 / torch.finfo(torch.float64).tiny  # no reference scale: huge, not NaN


def test_canonical_names_drop_the_params_suffix(parity):
    assert parity.canonical("encoder_params.convnet.0.weight") == "encoder.convnet.0.weight"
    assert parity.canonical("critic_params.q1.4.bias") == "critic.q1.4.bias"
    assert parity.canonical("head.W") == "head.W"
    assert parity.canonical("log_alpha") == "log_alpha"


def test_module_map_renames_leading_parts_and_maps_plain_tensors(parity):
    critic = nn.Module()
    critic.Q1 = nn.Linear(2, 1)
    critic.Q10 = nn.Linear(2, 1)  # "Q1" must not rename "Q10"
    agent = types.SimpleNamespace(critic=critic, log_alpha=torch.zeros(()))
    names = parity.ModuleMap("critic", "critic", (("Q1", "q1"),)).resolve(agent)
    assert sorted(names) == ["critic.Q10.bias", "critic.Q10.weight", "critic.q1.bias", "critic.q1.weight"]
    assert names["critic.q1.weight"] is critic.Q1.weight
    assert parity.ModuleMap("log_alpha", "log_alpha").resolve(agent) == {"log_alpha": agent.log_alpha}


def test_replay_returns_each_sources_view_once_in_order_and_refuses_other_inputs(parity):
    source, other = torch.zeros(2, 3, 4, 4), torch.ones(2, 3, 4, 4)
    first, second = torch.full_like(source, 5.0), torch.full_like(source, 7.0)
    replay = parity.ReplayCallable([(source, first), (other, second), (source.clone(), second)], "aug")
    assert torch.equal(replay(source), first)
    assert torch.equal(replay(other), second)
    out = replay(source)  # the same source again: its next view
    assert torch.equal(out, second)
    out.add_(1)  # a clone: the stored view is untouched
    assert torch.equal(second, torch.full_like(source, 7.0))
    with pytest.raises(RuntimeError, match="none of its expected sources"):
        replay(source)  # both views of `source` are used up


def test_replay_augmentation_is_a_vigen_augmentation_returning_the_view(parity):
    from vigen.transforms import ImageAugmentation

    source = torch.randint(0, 256, (2, 9, 8, 8)).double()
    view = (source + 1).clamp(max=255)
    augmentation = parity.replay_augmentation([(source, view)], "shift")
    assert isinstance(augmentation, ImageAugmentation)
    assert torch.equal(augmentation.augment(source), view)
    with pytest.raises(RuntimeError, match="vigen shift"):
        augmentation.augment(view)


def test_draws_hand_out_one_normal_stream_in_call_order(parity):
    draws = parity.Draws(seed=3)
    one_call = draws.normal((2, 3), torch.float64)
    draws.reset()
    two_calls = torch.cat([draws.normal((1, 3), torch.float64), draws.normal((1, 3), torch.float64)])
    assert torch.equal(one_call, two_calls)  # DrQ: vigen draws [2B, A] once, RL-ViGen [B, A] twice
    two_calls.mul_(0)  # RL-ViGen's TruncatedNormal scales its noise in place
    draws.reset()
    assert torch.equal(draws.normal((2, 3), torch.float64), one_call)


def test_draws_patch_both_sides_samplers_and_restore_them(parity):
    draws = parity.Draws(seed=0)
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


def test_float64_mode_makes_float_keep_float64_and_restores(parity):
    default = torch.get_default_dtype()
    with parity.float64_mode():
        assert torch.zeros(1).dtype == torch.float64
        assert torch.zeros(1, dtype=torch.uint8).float().dtype == torch.float64
        assert torch.tensor([1 + 2j]).float().tolist() == [1.0]
        assert nn.Linear(2, 2).weight.dtype == torch.float64
    assert torch.get_default_dtype() == default
    assert torch.zeros(1, dtype=torch.uint8).float().dtype == torch.float32


def test_import_reference_loads_a_checkout_in_isolation_with_stubs(parity, tmp_path):
    (tmp_path / "algos").mkdir()
    (tmp_path / "utils.py").write_text(
        "import not_installed_pkg_xyz\nfrom not_installed_pkg_xyz.sub import helper\nVALUE = 1\n"
    )
    (tmp_path / "algos" / "agent.py").write_text("import utils\nX = utils.VALUE + 1\n")
    before_path, before_utils = list(sys.path), sys.modules.get("utils")
    ref = parity.import_reference(tmp_path, ["utils", "agent"], paths=("", "algos"),
                                  optional=("not_installed_pkg_xyz", "not_installed_pkg_xyz.sub"))
    assert ref.modules["agent"].X == 2
    assert ref.stubbed == ["not_installed_pkg_xyz", "not_installed_pkg_xyz.sub"]
    with pytest.raises(RuntimeError, match="stubbed not_installed_pkg_xyz.sub.helper"):
        ref.modules["utils"].helper()
    assert sys.path == before_path
    assert sys.modules.get("utils") is before_utils and "agent" not in sys.modules
    assert "not_installed_pkg_xyz" not in sys.modules
    with pytest.raises(FileNotFoundError, match="plain checkout"):
        parity.import_reference(tmp_path / "missing", ["utils"])


@pytest.mark.parametrize("inplace", [False, True])
def test_guided_backprop_stand_in_clamps_negative_gradients_at_relus(parity, inplace):
    # x = [1, 2]; h = W1 x = [1, 2, 3] (all active); dQ/dh = W2 = [1, -1, 2].
    # Guided: dQ/dh clamped at 0 → [1, 0, 2]; dQ/dx = W1ᵀ [1, 0, 2] = [3, 2] (the plain gradient is [3, 1]).
    first, second = nn.Linear(2, 3, bias=False), nn.Linear(3, 1, bias=False)
    with torch.no_grad():
        first.weight.copy_(torch.tensor([[1.0, 0.0], [0.0, 1.0], [1.0, 1.0]]))
        second.weight.copy_(torch.tensor([[1.0, -1.0, 2.0]]))
    model = nn.Sequential(first, nn.ReLU(inplace=inplace), second)
    x = torch.tensor([[1.0, 2.0]])
    assert parity.GuidedBackpropStandIn(model).attribute(x).tolist() == [[3.0, 2.0]]
    assert x.grad is None and not x.requires_grad  # the input is left as it was


def test_parse_references_gives_every_algorithm_a_path_and_per_name_overrides(parity, tmp_path):
    refs = parity.parse_references([str(tmp_path), f"curl={tmp_path / 'curl'}"], ["drqv2", "curl"])
    assert refs == {"drqv2": tmp_path, "curl": tmp_path / "curl"}
    assert parity.parse_references([f"sgqn={tmp_path}"], ["drqv2", "sgqn"]) == {"sgqn": tmp_path}
    with pytest.raises(ValueError, match="'pieg_x' is not an algorithm"):
        parity.parse_references([f"pieg_x={tmp_path}"], ["drqv2"])


def _runs(parity, vigen_grads, original_grads):
    weight = nn.Parameter(torch.zeros(2))
    original = parity.OriginalRun(
        losses=[torch.tensor(2.0)], steps=[parity.StepRecord("critic_opt", 0, {id(weight): original_grads})],
        metrics={}, names={id(weight): "critic.w"}, normals=0, uniforms=0,
    )
    ours = parity.VigenRun({"loss_critic": 2.0}, {"loss_critic": vigen_grads}, 0, 0)
    case = types.SimpleNamespace(name="toy", metrics=[], steps=[parity.StepMap("critic", "loss_critic", (("critic_opt", 0),))])
    return case, original, ours


def test_compare_matches_steps_with_losses_and_flags_stray_gradients(parity):
    case, original, ours = _runs(parity, {"critic.w": torch.tensor([1.0, 2.0]), "actor.w": torch.tensor([0.5])},
                                 torch.tensor([1.0, 2.5]))
    rows = {row.quantity: row for row in parity.compare(case, original, original, ours)}
    assert rows["loss_critic (critic step)"].rel == 0.0
    assert rows["∂loss_critic/∂critic.w"].rel == pytest.approx(0.5 / 2.5)
    assert math.isinf(rows["stray ∂loss_critic/∂actor.w"].rel)  # vigen's critic loss reaches the actor: reported


def test_compare_counts_a_missing_vigen_gradient_as_zero(parity):
    case, original, ours = _runs(parity, {"critic.w": None}, torch.tensor([1.0, 2.0]))
    (loss_row, grad_row) = parity.compare(case, original, original, ours)
    assert grad_row.rel == pytest.approx(1.0)


def test_step_map_refuses_a_call_the_original_did_not_make(parity):
    case, original, ours = _runs(parity, {"critic.w": None}, torch.tensor([1.0, 2.0]))
    case.steps = [parity.StepMap("curl", "loss_critic", (("critic_opt", 1),))]
    with pytest.raises(RuntimeError, match="called critic_opt.step\\(\\) 1 times"):
        parity.compare(case, original, original, ours)


def _checkout(root, *files):
    for name in files:
        (root / name).parent.mkdir(parents=True, exist_ok=True)
        (root / name).write_text("")
    return root


def test_select_algorithms_runs_what_each_checkout_holds_and_notes_the_rest(parity, tmp_path):
    rlvigen = _checkout(tmp_path / "rlvigen", "rl_utils.py", "algos/drqv2.py", "algos/drq.py")
    dmcgb2 = _checkout(tmp_path / "dmcgb2", "augmentations.py", "algos/sada.py", "algos/drq.py", "algos/svea.py")
    run, skipped = parity.select_algorithms(None, {**dict.fromkeys(parity.ALGORITHMS, rlvigen), "sada": dmcgb2})
    assert run == ["drqv2", "drq", "sada"]
    assert len(skipped) == len(parity.ALGORITHMS) - 3 and all("RL-ViGen" in note for note in skipped)
    # DMC-GB2 also has algos/drq.py and algos/svea.py, with other agents: a DMC-GB2 path runs only SADA
    run, skipped = parity.select_algorithms(None, dict.fromkeys(parity.ALGORITHMS, dmcgb2))
    assert run == ["sada"]
    assert any(note.startswith("skipped drq:") and "rl_utils.py" in note for note in skipped)


def test_select_algorithms_refuses_a_requested_algorithm_without_its_original(parity, tmp_path):
    rlvigen = _checkout(tmp_path / "rlvigen", "rl_utils.py", "algos/drqv2.py")
    assert parity.select_algorithms(["drqv2"], {"drqv2": rlvigen}) == (["drqv2"], [])
    with pytest.raises(ValueError, match=r"sada: .* no augmentations.py, algos/sada.py .*--reference sada=PATH .*DMC-GB2"):
        parity.select_algorithms(["drqv2", "sada"], {"drqv2": rlvigen, "sada": rlvigen})
    with pytest.raises(ValueError, match="sada: no --reference"):
        parity.select_algorithms(["sada"], {})
    with pytest.raises(ValueError, match="no algorithm has a checkout of its original"):
        parity.select_algorithms(None, dict.fromkeys(parity.ALGORITHMS, tmp_path))


def test_parse_references_takes_sada_by_name(parity, tmp_path):
    refs = parity.parse_references([str(tmp_path / "rlvigen"), f"sada={tmp_path / 'dmcgb2'}"], ["drq", "sada"])
    assert refs == {"drq": tmp_path / "rlvigen", "sada": tmp_path / "dmcgb2"}


DMCGB2 = os.environ.get("VIGEN_PARITY_DMCGB2")


@pytest.mark.skipif(not DMCGB2, reason="set VIGEN_PARITY_DMCGB2 to a checkout of DMC-GB2 (algos/, augmentations.py, utils.py)")
def test_sada_matches_dmcgb2_in_one_float64_update(parity):
    setup = parity.Setup(batch_size=2)
    with parity.float64_mode():
        case = parity.build_sada(Path(DMCGB2), setup)
        parity.copy_weights(case)  # every vigen parameter has a DMC-GB2 counterpart of the same shape
        draws = parity.Draws(setup.seed)
        fixed = parity.run_original(case, draws, take_steps=False)
        ours = parity.run_vigen(case, draws)
    rows = parity.compare(case, fixed, fixed, ours)
    assert [row.quantity for row in rows if row.kind == "loss"] == [
        "loss_critic (critic step)", "loss_actor (actor step)", "loss_alpha (alpha step)"]
    assert not [row for row in rows if row.kind == "stray"]
    assert max(row.rel for row in rows) < 1e-10
    assert fixed.normals == ours.normals == 3 * setup.batch_size * setup.action_dim  # B next actions, 2B actor actions
