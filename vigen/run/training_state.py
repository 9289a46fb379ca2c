"""What a training run's checkpoint holds, written at the end of each segment and restored by ``--resume``.

:class:`TrainingState` names the parts of a run of ``examples/train.py`` that a checkpoint saves and a
resume puts back, exactly as they were: the loss (networks, target networks, the log-temperature),
the optimizer's moments, the acting policy (its exploration noise's step), the seeded augmentations'
generators, every global random state (torch, CUDA, NumPy, Python), the n-step window held back in
TorchRL's ``MultiStepTransform``, the replay buffer's cursor and length, and the counters. The replay
storage and the CSV logs live on disk beside it; a resume rolls the storage back to the
checkpoint (:class:`vigen.run.checkpoint.ReplayJournal`) and drops the log rows written after it.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

from torch import nn

from vigen.losses import UpdateStep
from vigen.run.checkpoint import (checkpoint_path, generator_states, load_optimizer_state, multistep_state, newest_checkpoint,
                                  random_states, remove_temporary_files, replay_state, restore_replay, save_checkpoint,
                                  set_generator_states, set_multistep_state, set_random_states, truncate_csv_logs)
from vigen.run.replay import RunReplay


@dataclass
class Resumed:
    """Where a resumed run goes on from: its checkpoint and counters, and what the resume had to say."""

    checkpoint: Path
    frames: int
    steps: int
    """Agent steps collected."""
    updates: int
    """Gradient updates made."""
    notes: list[str] = field(default_factory=list)
    """Checkpoints skipped (and why), files left by a killed run and removed, the journal's and the logs' rewinding."""


@dataclass
class TrainingState:
    """The parts of a run that its checkpoints hold, in its run folder's ``checkpoints/``.

    Args:
        run_dir: the run folder (``checkpoints/``, ``logs/`` in it).
        loss: the loss module (networks, targets, temperature, augmentations' generators).
        policy: the acting policy.
        update: the update step (its optimizer; its count, the schedule's phase).
        replay: the replay buffer (its n-step transform and journal).
    """

    run_dir: Path
    loss: nn.Module
    policy: nn.Module
    update: UpdateStep
    replay: RunReplay

    def save(self, frames: int, steps: int, updates: int) -> Path:
        """Write the checkpoint of ``frames`` (atomically), then let the journal count it as the state to roll back to."""
        state = {"loss": self.loss.state_dict(), "optimizer": self.update.optimizer.state_dict(),
                 "policy": self.policy.state_dict(), "generators": generator_states(self.loss),
                 "random": random_states(), "n_step": multistep_state(self.replay.n_step), "replay": replay_state(self.replay.disk),
                 "frames": frames, "steps": steps, "updates": updates}
        (self.run_dir / "checkpoints").mkdir(exist_ok=True)
        path = save_checkpoint(checkpoint_path(self.run_dir / "checkpoints", frames), state)
        if self.replay.journal is not None:
            self.replay.journal.commit(state["replay"])
        return path

    def restore(self) -> Resumed:
        """Put everything back as it was when the newest checkpoint that loads was written.

        Raises:
            CheckpointError: no checkpoint loads.
        """
        checkpoints = self.run_dir / "checkpoints"
        path, checkpoint, skipped = newest_checkpoint(checkpoints)
        notes = [f"skipped checkpoint {bad.name}: {why}" for bad, why in skipped]
        notes += [f"removed {leftover.name}, left by a run killed while writing a checkpoint"
                  for leftover in remove_temporary_files(checkpoints)]
        self.loss.load_state_dict(checkpoint["loss"])
        load_optimizer_state(self.update.optimizer, checkpoint["optimizer"])  # this run's device flags, the file's moments
        self.policy.load_state_dict(checkpoint["policy"])
        set_generator_states(self.loss, checkpoint["generators"])
        set_random_states(checkpoint["random"])
        set_multistep_state(self.replay.n_step, checkpoint["n_step"])
        restore_replay(self.replay.disk, checkpoint["replay"], self.replay.storage_dir)
        if self.replay.journal is not None:
            notes += self.replay.journal.rollback(checkpoint["replay"])
        self.replay.reload()  # the device copy, from the restored memory map
        notes += [f"logs: {note}" for note in truncate_csv_logs(self.run_dir / "logs", checkpoint["frames"])]
        self.update.count = checkpoint["updates"]  # the schedule's phase (actor / target every N updates)
        return Resumed(path, checkpoint["frames"], checkpoint["steps"], checkpoint["updates"], notes)
