"""Doctest collection over the package (modules of an extra that is not installed are skipped: their tests skip with the
reason; their temporary folders go in pytest's), and the test run's parallel workers (``scripts/test.sh`` runs
pytest-xdist, one worker per core)."""

import importlib.util
import os
import tempfile

import pytest
from _pytest.doctest import DoctestItem

collect_ignore = [] if importlib.util.find_spec("ray") else ["vigen/ray_cluster.py", "vigen/evaluation/ray_backend.py"]

RAY_PATHS = ("test/ray/", "vigen/ray_cluster.py", "vigen/evaluation/ray_backend.py")

CI_SAMPLE: dict[str, tuple[str, ...]] = {
    # test function -> the parameter ids the default run keeps; the others (and a whole test mapped to ()) run with
    # -m matrix. Each family keeps the cases that exercise a different code path; the rest repeat them on other levels,
    # robots or tasks. Chosen by CPU seconds per test (2026-11-27 profile), to keep .ci/run under 20 minutes.
    # parallel envs: test_dmc's seeding and collector tests and test_worker_errors' failure paths stay
    "test/envs/test_seeds.py::test_parallel_env_set_seed_reproduces_and_workers_differ": (),
    "test/envs/test_loco.py::test_parallel_env_workers_build_loco_envs": (),
    "test/transforms/test_scene.py::test_inside_parallel_env_workers": (),
    "test/envs/test_worker_errors.py::test_a_normal_rollout_equals_torchrl_parallel_env": (),
    "test/envs/test_loco.py::test_rising_scores_above_lying_folded_and_lying_above_flailing": (),
    "test/envs/test_loco.py::test_each_level_changes_the_unitree_frame": ("hard", "texture_hard", "robot_go2", "camera_hard"),
    "test/envs/test_loco.py::test_twenty_resets_do_not_drift_and_restore_to_train": ("hard",),
    "test/envs/test_loco.py::test_moving_lights_change_the_frame_as_they_move": ("moving_light_hard",),
    "test/envs/test_loco.py::test_cross_embodiment_keeps_the_action_space": ("robot_go2-go2",),
    "test/envs/test_loco.py::test_random_arm_policy_earns_little": ("franka-push",),
    "test/envs/test_loco.py::test_levels_change_the_franka_frame": ("hard-1.0", "camera_hard-1.0"),
    "test/envs/test_robosuite.py::test_each_level_changes_the_first_frame": ("hard", "robot_iiwa"),
    "test/envs/test_robosuite.py::test_twenty_resets_do_not_drift": ("hard",),
    "test/envs/test_robosuite.py::test_set_seed_equals_seed_at_build_scene_included": ("hard",),
    "test/envs/test_robosuite.py::test_check_env_specs": ("two-arm-peg-in-hole",),
    "test/envs/test_adroit.py::test_each_level_changes_the_first_frame": ("color_hard", "video_hard", "camera_hard"),
    "test/envs/test_suites.py::test_every_manipulation_factor_changes_the_frames": (),
    "test/envs/test_suites.py::test_every_dm_control_factor_changes_the_frames": (
        "background_color", "video_background", "light_color", "camera_rotation", "dynamic_camera", "dynamic_color",
        "jpeg_compression"),
    "test/envs/test_levels.py::test_each_level_changes_the_first_frame_and_passes_specs": (
        "color_hard", "objects_color_hard", "floor_texture", "video_hard", "light_hard", "camera_hard", "gaussian_blur_1"),
    # TorchRL's transform contract on 2-worker ParallelEnvs: inside the workers, a plain, a banked, a resizing, a composite
    # and a per-sample transform; in the parent (the serial check's path on batched data), a banked and a resizing one
    "test/transforms/test_contract.py::TestTorchRLProtocol::test_parallel_trans_env_check": (
        "shift", "overlay", "crop", "rotate_or_conv", "frequency_per_sample_noise"),
    "test/transforms/test_contract.py::TestTorchRLProtocol::test_trans_parallel_env_check": ("overlay", "crop"),
    # end to end through the example scripts: the drqv2 run, its resume, evaluation, crash safety, workers and
    # protocol stay; other algorithms, robosuite, the TorchRL composition example and --compare's report go to matrix
    "test/examples/test_train_evaluate.py::test_train_every_algorithm": (),
    "test/examples/test_train_evaluate.py::test_compose_example_trains_and_tests": (),
    "test/examples/test_train_evaluate.py::test_robosuite_train_then_evaluate_reports_success": (),
    "test/examples/test_train_evaluate.py::test_compare_puts_the_run_beside_the_published_curve": (),
    "test/examples/test_train_evaluate.py::test_an_exported_agent_evaluates_as_its_run_does": (),
    "test/examples/test_sweep.py::test_sweep_example_writes_table_and_curve": (),
    "test/examples/test_gallery.py::test_factor_gallery_grid": (),
    "test/test_readme.py::test_manipulation_example_runs": (),
    "test/test_readme.py::test_sweep_example_runs": (),
    "test/test_readme.py::test_evaluation_example_runs": (),
    "test/ray/test_ray_collector.py::test_each_actor_explores_with_its_own_seeded_noise": (),
    # learning and compiled updates: one DDPG and one SAC algorithm (SVEA is DrQ-v2's update on one more view, its
    # weighting checked by test_loss_values.py's test_svea_weights_the_weak_and_strong_views); the compiled-equals-eager check
    "test/losses/test_losses_learn.py::test_loss_learns_the_dot_task": ("drqv2", "drq"),
    "test/losses/test_update.py::test_each_update_step_compiles_on_its_own_cache": (),
    "test/losses/test_update.py::test_a_nan_loss_in_a_compiled_update_leaves_the_parameters_finite_and_is_reported": (),
}


def pytest_configure(config: pytest.Config) -> None:
    """Each xdist worker gets its share of the cores for torch's intra-op threads (two 2-thread workers on 2 cores crawl),
    and an empty data cache: levels that find fetched data (``vigen.datasets``) show their stand-ins in tests, whatever the
    user's own cache holds (the data tests point ``VIGEN_DATA`` at their own folders)."""
    os.environ["VIGEN_DATA"] = tempfile.mkdtemp(prefix="vigen-test-data-")
    workers = int(os.environ.get("PYTEST_XDIST_WORKER_COUNT", "1"))
    if workers > 1:
        import torch

        torch.set_num_threads(max(1, (os.cpu_count() or 1) // workers))


@pytest.fixture(autouse=True)
def doctest_temporary_folders(request: pytest.FixtureRequest, monkeypatch: pytest.MonkeyPatch) -> None:
    """The examples' ``tempfile.mkdtemp()`` folders go in the doctest's ``tmp_path``, which pytest prunes, not in /tmp for good."""
    if isinstance(request.node, DoctestItem):
        monkeypatch.setattr(tempfile, "tempdir", str(request.getfixturevalue("tmp_path")))


@pytest.hookimpl(tryfirst=True)  # before pytest's -m deselection reads the markers
def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    """The CI sample (:data:`CI_SAMPLE`); tests that start a Ray cluster in one worker, one after another (``--dist loadgroup``)."""
    found: dict[str, set[str]] = {name: set() for name in CI_SAMPLE}
    for item in items:
        function, _, param = item.nodeid.partition("[")
        if function in CI_SAMPLE:
            found[function].add(param[:-1])
            if param[:-1] not in CI_SAMPLE[function]:
                item.add_marker(pytest.mark.matrix)
    collected = {name: ids for name, ids in found.items() if ids}  # a file not collected in this run is not checked
    stale = {name: sorted(set(CI_SAMPLE[name]) - ids) for name, ids in collected.items() if set(CI_SAMPLE[name]) - ids}
    if stale:
        raise pytest.UsageError(f"CI_SAMPLE in conftest.py keeps parameter ids that no longer exist: {stale}")
    for item in items:
        path = item.nodeid.split("::")[0]
        words = item.name.replace("[", "_").replace("-", "_").lower().split("_")
        if path.startswith(RAY_PATHS) or "ray" in words:
            item.add_marker(pytest.mark.xdist_group("ray"))
