"""Recipes: every value against docs/recipes.md (and, where the originals are checked out, against their lines), the layers
of a run that names one, what it records and builds."""

from __future__ import annotations

import ast
import json
import re
import warnings
from dataclasses import replace
from pathlib import Path

import pytest
import torch
from torchrl.data import Bounded

from vigen.losses import SplitSoftUpdate, SquashedGaussian, example_batch
from vigen.run import (RECIPES, TrainConfig, build_agent, check_runnable, list_recipes, make_update, new_config,
                       recipe_weights, resumed_config)
from vigen.run.recipes import AUGMENTATION_NAMES, TRAIN_KEYS, differences
from vigen.transforms import RandomConv

ROOT = Path(__file__).resolve().parents[2]
DOC = ROOT / "docs" / "recipes.md"
REFS = ROOT.parent / "refs"  # the originals' checkouts, where a machine has them (they are never copied into vigen)
ENVS = {"vrl3-rlvigen": "adroit/door"}


def table() -> dict[tuple[str, str], tuple[object, str]]:
    """docs/recipes.md's settings table: (recipe, setting) -> (value, source)."""
    rows, seen = {}, False
    for line in DOC.read_text().splitlines():
        if line.startswith("| recipe | setting | value | source |"):
            seen = True
            continue
        if seen and line.startswith("|---"):
            continue
        if seen and not line.startswith("|"):
            break
        if seen:
            recipe, setting, value, source = (cell.strip() for cell in line.strip("|").split("|"))
            key = (recipe, setting.strip("`"))
            assert key not in rows, f"{key} is listed twice"
            rows[key] = (ast.literal_eval(value.strip("`")), source)
    assert rows, "docs/recipes.md has no settings table"
    return rows


def plain(value):
    return tuple(plain(item) for item in value) if isinstance(value, (list, tuple)) else value


def test_every_recipe_value_is_the_docs_tables_and_the_table_holds_nothing_else():
    """The table is the reference a reviewer checks against the sources; code and table must agree both ways."""
    documented = table()
    in_code = {(recipe.name, setting): value for recipe in RECIPES.values() for setting, value in recipe.rows()}
    assert sorted(set(in_code) - set(documented)) == [], "settings of vigen.run.RECIPES missing from docs/recipes.md"
    assert sorted(set(documented) - set(in_code)) == [], "docs/recipes.md lists settings no recipe has"
    wrong = {key: (value, documented[key][0]) for key, value in in_code.items() if plain(value) != plain(documented[key][0])}
    assert wrong == {}, "(recipe, setting): (code, docs/recipes.md)"


def test_every_departure_and_note_is_in_the_docs():
    text = DOC.read_text()
    for recipe in RECIPES.values():
        for name in (*recipe.departures, *recipe.notes):
            assert f"| {recipe.name} | `{name}` |" in text, (recipe.name, name)


def is_setting_line(path: str, line: str) -> bool:
    """A line of a config or argument file (or a plain ``name = value`` assignment of SCPL's launch script)."""
    return path.endswith((".yaml", "arguments.py")) or (path.endswith("my_train_all.py") and re.match(r"\s*\w+ = \S", line))


def forms(value: float) -> set[str]:
    """How a source may write a number: 0.001, 1e-3, 1e-03, 500000, 500k, 500_000."""
    found = {repr(value), str(value), f"{value:g}", f"{value:.0e}".replace("e-0", "e-"), f"{value:.0e}"}
    if float(value).is_integer():
        found |= {str(int(value)), f"{int(value):_}", f"{int(value) // 1000}k"}
    return found


@pytest.mark.skipif(not REFS.is_dir(), reason="the originals' checkouts (../refs) are not on this machine; "
                                                 "docs/recipes.md is the committed reference")
def test_each_cited_line_exists_and_a_config_line_holds_its_value():
    """Every ``repo path:line`` of the table is a line of the original; a number read from a config or argument file
    is written on that line (the first of a pair, e.g. Adam's beta1 or the log-std minimum)."""
    problems = []
    for (recipe, setting), (value, source) in table().items():
        match = re.match(r"(\S+) (\S+):(\d+)", source)
        if match is None or "<task>" in source:
            continue
        repo, path, number = match.group(1), match.group(2), int(match.group(3))
        file = REFS / repo / path
        if not file.is_file():
            problems.append(f"{recipe} {setting}: no {repo}/{path}")
            continue
        lines = file.read_text(errors="replace").splitlines()
        if number > len(lines):
            problems.append(f"{recipe} {setting}: {repo}/{path} has {len(lines)} lines, not {number}")
            continue
        first = value[0] if isinstance(value, tuple) else value
        if is_setting_line(path, lines[number - 1]) and isinstance(first, (int, float)) and not isinstance(first, bool):
            line = lines[number - 1].replace(" ", "")
            if not any(form.replace(" ", "") in line for form in forms(first)):
                problems.append(f"{recipe} {setting}: {repo}/{path}:{number} does not hold {first}: {lines[number - 1]!r}")
    assert problems == []


def test_a_recipe_sets_its_settings_and_protocol_and_records_the_flags_that_override_it():
    config = new_config({"recipe": "svea-dmcgb", "env": "dmc/cartpole-swingup", "seed_steps": 10, "batch_size": 128,
                         "frames": 2000})
    assert (config.algo, config.protocol, config.batch_size, config.lr, config.tau, config.encoder_tau) == \
        ("svea", "dmcgb", 128, 1e-3, 0.01, 0.05)
    assert (config.update_every, config.actor_update_every, config.target_update_every, config.seed_catch_up) == (1, 2, 2, True)
    assert (config.seed_steps, config.n_step, config.buffer_size, config.feature_dim) == (10, 1, 500_000, 100)
    assert config.recipe_overrides == {"seed_steps": {"recipe": 1000, "flag": 10}}, "a flag equal to the recipe's is none"
    assert config.action_repeat == 8 and config.protocol_overrides == {"frames": {"protocol": 4_000_000, "flag": 2000}}
    assert config.recipe_settings == {key: plain_json(value) for key, value in RECIPES["svea-dmcgb"].settings(
        "dmc/cartpole-swingup").items()}
    other = new_config({"recipe": "svea-dmcgb", "env": "dmc/walker-walk", "protocol": "rlvigen"})
    assert other.protocol == "rlvigen" and other.recipe_overrides == {"protocol": {"recipe": "dmcgb", "flag": "rlvigen"}}
    schedule = new_config({"recipe": "drqv2", "env": "dmc/walker-walk", "actor_update_every": 2})
    assert schedule.recipe_overrides == {"actor_update_every": {"recipe": 1, "flag": 2}}, "a setting the recipe leaves unset"


def plain_json(value):
    return list(value) if isinstance(value, tuple) else value


@pytest.mark.parametrize("flags, message", [
    ({"recipe": "nope"}, "--recipe nope: no such recipe; choose one of drqv2, "),
    ({"recipe": "svea-dmcgb", "algo": "drqv2"}, "--algo drqv2 and --recipe svea-dmcgb: the recipe trains vigen's svea"),
    ({"recipe": "svea-dmcgb", "seed_frames": 80}, "the recipe counts its seed phase in agent steps (1000); give --seed-steps"),
    ({"recipe": "drqv2", "env": "dmc/dog-run"}, "--recipe drqv2: recipe drqv2: facebookresearch/drqv2@c0c650b has no "
                                                "config for dmc/dog-run"),
    ({"recipe": "vrl3-rlvigen", "env": "dmc/walker-walk"}, "recipe vrl3-rlvigen covers the adroit suite(s), not 'dmc'"),
])
def test_a_recipe_that_cannot_apply_is_refused_naming_the_fix(flags, message):
    with pytest.raises(ValueError, match=re.escape(message)):
        new_config(flags)


def test_the_task_configs_of_drqv2_and_rlvigen_apply_by_task_domain_and_difficulty():
    """DrQ-v2's cfgs/task: walker_* n-step 1 and batch 512; humanoid lr 8e-5, feature_dim 100; medium std over 500k."""
    drqv2 = RECIPES["drqv2"]
    assert {key: drqv2.settings("dmc/walker-run")[key] for key in ("n_step", "batch_size", "std_duration")} == \
        {"n_step": 1, "batch_size": 512, "std_duration": 500_000}
    assert (drqv2.settings("dmc/humanoid-run")["lr"], drqv2.settings("dmc/humanoid-run")["std_duration"]) == (8e-5, 2_000_000)
    assert drqv2.settings("dmc/quadruped-run")["buffer_size"] == 100_000 and drqv2.settings("dmc/quadruped-walk")["buffer_size"] == 10**6
    assert RECIPES["vrl3-rlvigen"].settings("adroit/door")["optimizer.encoder.lr_scale"] == 1.0
    assert RECIPES["drqv2-rlvigen"].protocol_for("loco/unitree-walk") == "rlvigen_loco"


def test_every_recipe_builds_its_networks_and_makes_one_update():
    """Each recipe on a task it covers: the agent, Adam's groups with their lr, betas and schedule, and one update."""
    spec = Bounded(-1.0, 1.0, shape=(2,))
    for name, recipe in RECIPES.items():
        env = ENVS.get(name, "dmc/walker-walk")
        flags = {"recipe": name, "env": env, "hidden_dim": 16}
        if name == "pieg-rlvigen":
            flags["encoder_weights"] = "unused"  # the weights come below (a random ResNet-18, no ImageNet file in tests)
        config = replace(new_config(flags), observation_shape=(9, 64, 64), action_dim=2)
        settings = recipe.settings(env)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            agent = build_agent(config, spec, pretrained=name != "pieg-rlvigen")
        update = make_update(config, agent.loss)
        groups = {group_name(agent.loss, group): group for group in update.optimizer.param_groups}
        for key, value in settings.items():
            parts = key.split(".")
            if parts[0] == "optimizer" and len(parts) == 3 and parts[2] != "lr_scale":
                assert plain(groups[parts[1]][parts[2]]) == plain(value), (name, key)
        assert groups["rest"]["lr"] == config.lr and tuple(groups["rest"]["betas"]) == tuple(settings["optimizer.betas"])
        expected_every = settings.get("actor_update_every", 1)
        assert groups["actor"].get("every", 1) == expected_every if "actor" in groups else expected_every == 1, name
        assert update.target_every == settings.get("target_update_every", 1)
        assert isinstance(update.target_update, SplitSoftUpdate) == ("encoder_tau" in settings), name
        if settings.get("loss.sampler_type") == "squashed_gaussian" or settings.get("loss.init_temperature"):
            assert isinstance(agent.loss.sampler, SquashedGaussian) and float(agent.loss.alpha) == pytest.approx(0.1), name
        if "loss.log_std_bounds" in settings:
            assert agent.loss.actor.log_std_bounds == plain(settings["loss.log_std_bounds"]), name
        out = update(example_batch(4, (9, 64, 64)))
        assert all(torch.isfinite(value).all() for key, value in out.items() if key.startswith("loss_")), name


def group_name(loss, group) -> str:
    """Which module an optimizer group holds (``"rest"``: the group of the base lr)."""
    params = {id(parameter) for parameter in group["params"]}
    for name in ("actor", "sampler", "input_mask", "dynamics", "decoder", "head"):
        module = getattr(loss, name, None)
        if module is not None and {id(parameter) for parameter in module.parameters()} == params:
            return name
    if {id(parameter) for parameter in loss.encoder_params.values(True, True)} == params:
        return "encoder"
    return "rest"


def test_svea_dmcgb_is_dmcgbs_sac_svea():
    """SAC on SharedCNN(x / 255, 11 layers of 32), a projected Gaussian actor with log σ in [-10, 2], random convolution
    on the shifted view, the next view shifted (DMC-GB ff9c0aa's sample_svea is sample_drq), a target encoder."""
    config = replace(new_config({"recipe": "svea-dmcgb", "env": "dmc/walker-walk", "hidden_dim": 16}),
                     observation_shape=(9, 84, 84), action_dim=2)
    loss = build_agent(config, Bounded(-1.0, 1.0, shape=(2,))).loss
    assert type(loss.encoder).__name__ == "SharedCNN" and not loss.encoder.centered
    assert sum(isinstance(module, torch.nn.Conv2d) for module in loss.encoder.modules()) == 11
    assert type(loss.actor).__name__ == "GaussianActor" and loss.actor.trunk[0].out_features == 100
    assert [type(augmentation) for augmentation in loss.strong_augmentation] == [RandomConv]
    assert loss.augment_next and loss.scores_on_target_encoder and loss.sampler.squash_epsilon == 1e-6
    update = make_update(config, loss)
    assert update.target_update.rates() == {"encoder": 0.05, "critic.trunk": 0.05, "critic.q1": 0.01, "critic.q2": 0.01}
    assert set(AUGMENTATION_NAMES) >= {"random_conv", "overlay", "dmcgb2_all", "shifted_overlay"}


def test_config_json_keeps_the_recipe_and_a_resumed_run_builds_what_it_recorded():
    config = replace(new_config({"recipe": "svea-dmcgb", "env": "dmc/walker-walk", "hidden_dim": 16, "seed_steps": 10}),
                     observation_shape=(9, 84, 84), action_dim=2)
    saved = json.loads(json.dumps(config.to_json()))
    assert saved["recipe"] == "svea-dmcgb" and saved["recipe_overrides"] == {"seed_steps": {"recipe": 1000, "flag": 10},
                                                                            "hidden_dim": {"recipe": 1024, "flag": 16}}
    assert TrainConfig.from_json(saved) == replace(config, frames=TrainConfig.frames, recipe_settings=saved["recipe_settings"])
    with pytest.raises(ValueError, match="--actor-update-every 1 \\(the run has 2\\)"):
        resumed_config(saved, {"actor_update_every": 1})
    edited = dict(saved, recipe_settings={**saved["recipe_settings"], "optimizer.sampler.lr": 3e-4})
    resumed = resumed_config(edited, {})
    update = make_update(resumed, build_agent(resumed, Bounded(-1.0, 1.0, shape=(2,))).loss)
    assert 3e-4 in [group["lr"] for group in update.optimizer.param_groups], "the recorded recipe, not today's RECIPES"
    plain_config = new_config({"algo": "svea"}).to_json()
    assert not {"recipe", "recipe_settings", "recipe_overrides", "seed_steps", "encoder_tau"} & set(plain_config)


def test_a_recipe_cannot_claim_networks_vigen_does_not_build():
    config = replace(new_config({"recipe": "svea-dmcgb", "env": "dmc/walker-walk", "hidden_dim": 16}),
                     observation_shape=(9, 84, 84), action_dim=2)
    claimed = replace(config, recipe_settings={**config.recipe_settings, "network.encoder_layers": 4})
    with pytest.raises(ValueError, match="the recipe's encoder has 4 convolutions, vigen's SharedCNN 11"):
        build_agent(claimed, Bounded(-1.0, 1.0, shape=(2,)))


def test_pieg_rlvigen_finds_torchvisions_resnet18_in_the_data_cache_or_names_the_fetch_command(tmp_path, monkeypatch):
    monkeypatch.setenv("VIGEN_DATA", str(tmp_path))
    config = new_config({"recipe": "pieg-rlvigen", "env": "dmc/walker-walk"})
    with pytest.raises(ValueError, match=re.escape("Fetch it (checked by its sha256) with `python -m vigen.datasets fetch "
                                                   "torchvision-resnet18`, or pass --encoder-weights PATH")):
        check_runnable(config)
    fetched = tmp_path / "torchvision-resnet18" / "resnet18-f37072fd.pth"
    fetched.parent.mkdir()
    with fetched.open("wb") as file:  # what the data command leaves there, as far as locate() looks (name and size)
        file.truncate(46_830_571)
    assert recipe_weights(config) == fetched
    assert recipe_weights(replace(config, encoder_weights="/given.pth")) is None, "--encoder-weights wins"


def test_differences_name_each_setting_and_list_recipes_lists_every_recipe():
    assert differences({"lr": 1e-4, "betas": [0.9, 0.999]}, {"lr": 1e-3, "betas": (0.9, 0.999)}) == \
        ["lr: 0.0001 in the run, 0.001 in the published recipe"]
    text = list_recipes()
    assert all(f"recipe {name}:" in text for name in RECIPES)
    assert "departs (one-step)" in text and "note (batch_size)" in text
    assert set(TRAIN_KEYS) <= {field for field in TrainConfig.__dataclass_fields__}
