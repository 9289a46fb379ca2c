"""A robustness curve from your own code: one factor at several intensities, return against intensity.

    python examples/sweep.py [REPORT_FOLDER]     # a random policy on walker-walk, camera_rotation 0 .. 0.5

The same as ``examples/evaluate.py RUN --levels train --sweep camera_rotation 0 0.1 0.3 0.5`` for a trained run (any
TorchRL policy goes where ``None`` is). The random policy plays the same seeded actions at every intensity, so its curve
is flat: the reference of an agent blind to pixels.
"""

import sys
from pathlib import Path

from vigen.evaluation import evaluate, markdown_table, plot_intensity, summarize, sweep, write_csv
from vigen.io import unused_path
from vigen.rendering import RenderSettings

levels = sweep("camera_rotation", [0.0, 0.1, 0.3, 0.5])  # one level per intensity (the Distracting Control Suite's factor)
rows = evaluate(None, "dmc/walker-walk", levels, episodes=1, seeds=[0, 1], tags={"method": "random"},
                env_options={"render_settings": RenderSettings.fast(), "episode_length": 100})
lines = summarize(rows)  # IQM with its 95 % stratified-bootstrap CI per intensity, RL-ViGen's mean ± std
out = unused_path(Path(sys.argv[1] if len(sys.argv) > 1 else "reports/sweep"))
write_csv(rows, out / "episodes.csv")
curve = plot_intensity(lines, out / "intensity_camera_rotation.png", factor="camera_rotation")
print(markdown_table(lines))
print(f"\nwrote {out}/: episodes.csv, {curve.name}")
