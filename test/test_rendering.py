"""GL backend selection and render-quality settings."""

from __future__ import annotations

import os
import subprocess
import sys
import types

import mujoco
import pytest

from vigen.rendering import RenderSettings, configure_mujoco_gl

MODEL_XML = "<mujoco><worldbody><geom type='sphere' size='.1'/></worldbody></mujoco>"


def _import_vigen_then_print_backend(env: dict[str, str]) -> str:
    code = "import vigen, os; print(os.environ['MUJOCO_GL'])"
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, check=True)
    return out.stdout.strip()


def test_import_selects_egl_when_unset():
    env = {k: v for k, v in os.environ.items() if k != "MUJOCO_GL"}
    assert _import_vigen_then_print_backend(env) == "egl"


def test_import_keeps_the_users_backend():
    assert _import_vigen_then_print_backend({**os.environ, "MUJOCO_GL": "osmesa"}) == "osmesa"


def test_warns_when_dm_control_chose_its_renderer_first(monkeypatch):
    monkeypatch.delenv("MUJOCO_GL", raising=False)
    monkeypatch.setitem(sys.modules, "dm_control._render", types.ModuleType("dm_control._render"))
    with pytest.warns(UserWarning, match="Import vigen first"):
        assert configure_mujoco_gl() == "egl"
    assert os.environ["MUJOCO_GL"] == "egl"


def test_torchrl_first_is_fine():
    """TorchRL imports mujoco (not dm_control's renderer): importing it before vigen must not warn."""
    env = {k: v for k, v in os.environ.items() if k != "MUJOCO_GL"}
    code = "import warnings; warnings.filterwarnings('error', message='.*Import vigen first'); import torchrl.envs, vigen.envs; print('ok')"
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True)
    assert out.returncode == 0 and out.stdout.strip() == "ok", out.stderr


def test_default_settings_keep_the_model():
    model = mujoco.MjModel.from_xml_string(MODEL_XML)
    before = (model.vis.quality.shadowsize, model.vis.quality.offsamples, model.vis.global_.offwidth)
    RenderSettings().apply(model, 84, 84)
    assert (model.vis.quality.shadowsize, model.vis.quality.offsamples, model.vis.global_.offwidth) == before
    assert RenderSettings().is_default and not RenderSettings.fast().is_default


def test_fast_settings():
    model = mujoco.MjModel.from_xml_string(MODEL_XML)
    RenderSettings.fast().apply(model, 64, 96)
    assert model.vis.quality.shadowsize == 256
    assert model.vis.quality.offsamples == 0
    assert (model.vis.global_.offheight, model.vis.global_.offwidth) == (64, 96)


def test_buffer_grows_to_fit_a_large_image():
    model = mujoco.MjModel.from_xml_string(MODEL_XML)
    RenderSettings().apply(model, 1000, 1200)
    assert (model.vis.global_.offheight, model.vis.global_.offwidth) == (1000, 1200)
