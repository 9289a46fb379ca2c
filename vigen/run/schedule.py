"""A training run's schedule in agent steps: its collector batches, and its segments, one per checkpoint.

``examples/train.py`` collects whole collector batches of ``50 × --update-every`` agent steps per
worker, and evaluates and checkpoints after the first batch that crosses a multiple of
``--eval-every`` (or ends the run): each checkpoint ends a *segment*, whose last batch cuts the
episode in progress, in a run never killed and in a resumed one alike.
"""

from __future__ import annotations

from dataclasses import dataclass

from vigen.run.config import TrainConfig


@dataclass(frozen=True)
class RunSchedule:
    """The agent steps of a run: in all, of random actions first, between checkpoints, per collector batch.

    Examples:
        >>> schedule = RunSchedule(action_repeat=2, frames=600, seed_steps=20, eval_every=150, worker_batch_steps=100)
        >>> schedule.segment_batches(0), schedule.segment_batches(200)  # a checkpoint after 200 steps, then after 300
        (2, 1)
        >>> schedule.ends_segment(100, 200), schedule.ends_segment(0, 100)
        (True, False)
    """

    action_repeat: int
    frames: int
    """``--frames``: environment frames in all."""
    seed_steps: int
    """Agent steps of random actions before the first update."""
    eval_every: int
    """``--eval-every`` in agent steps."""
    worker_batch_steps: int
    """Agent steps per collector batch and worker: 50 × ``--update-every``."""
    workers: int = 1

    @classmethod
    def of(cls, config: TrainConfig, action_repeat: int) -> RunSchedule:
        """The schedule of ``config`` on an env of ``action_repeat``."""
        seed_steps = config.seed_steps if config.seed_steps is not None else config.seed_frames // action_repeat
        return cls(action_repeat, config.frames, seed_steps, config.eval_every // action_repeat,
                   50 * config.update_every, config.workers)

    @property
    def total_steps(self) -> int:
        """``--frames`` in whole agent steps."""
        return self.frames // self.action_repeat

    @property
    def batch_steps(self) -> int:
        """Agent steps per collector batch, all workers together."""
        return self.worker_batch_steps * self.workers

    def segment_batches(self, steps: int) -> int:
        """Collector batches from ``steps`` to the next checkpoint: the first batch that crosses a multiple of eval_every
        or ends the run."""
        batches = 1
        while ((steps + batches * self.batch_steps) // self.eval_every == steps // self.eval_every
               and steps + batches * self.batch_steps < self.total_steps):
            batches += 1
        return batches

    def ends_segment(self, before: int, after: int) -> bool:
        """Whether the batch that took the run from ``before`` to ``after`` agent steps is its segment's last."""
        return after // self.eval_every > before // self.eval_every or after >= self.total_steps

    def frames_note(self, steps: int = 0) -> str | None:
        """What the run trains when it is not ``--frames``, from ``steps`` agent steps already done: the collector gathers
        whole batches. ``None`` when the run trains exactly ``--frames``.

        Examples:
            >>> RunSchedule(action_repeat=2, frames=300, seed_steps=20, eval_every=2500, worker_batch_steps=100).frames_note()
            '--frames 300: training 400 frames, not 300: the collector gathers whole batches of 100 agent steps (200 frames at action repeat 2).'
        """
        frames, total, done = self.frames, self.total_steps, steps
        while done < total:
            done += self.segment_batches(done) * self.batch_steps
        if done * self.action_repeat == frames:
            return None
        if done == steps:
            return f"--frames {frames}: the run has trained {steps * self.action_repeat} frames already; nothing to train."
        rounded = f"; {frames} frames are {total} whole agent steps" if frames % self.action_repeat else ""
        return (f"--frames {frames}: training {done * self.action_repeat} frames, not {frames}: the collector gathers whole "
                f"batches of {self.batch_steps} agent steps ({self.batch_steps * self.action_repeat} frames at action repeat "
                f"{self.action_repeat}){rounded}.")
