"""Build the folder that travels with the repository to the lent GPU machine for ``benchmarks/gpu_check.sh``.

The GPU machine has Python 3.12 with torch 2.11 (CUDA), numpy 2, scipy, opencv, pytest and more
(``GPU_MACHINE_HAS`` below), no internet, and takes the working tree plus up to 8 carried ignored
paths, 64 MiB in all. This script, run on a development machine, puts in one ignored folder
(default ``.gpu-carry/``):

* ``wheels/``: every distribution vigen needs that the GPU machine lacks, for CPython 3.12 on
  manylinux x86-64, at the versions installed in this environment (``pip download --no-deps``). The
  list is vigen's requirements and their requirements, read from this environment's metadata, less
  torch and what the machine has;
* ``dm_control-<version>-trimmed.zip``: dm-control's wheel (56 MB) without the dog's, the soccer
  and the locomotion walkers' assets and the Blender files, which vigen never loads (about 12 MB
  unpacked, less zipped);
* ``gl/``: the GL loader packages MuJoCo's EGL needs (Debian's ``libegl1``, ``libopengl0``,
  ``libglvnd0``, ...), unpacked by the device check only where the machine has no ``libEGL.so.1``;
* ``MANIFEST.json``: what is there (files, sizes, sha256), the modules the check imports after
  installing, the commit it was built at, and the measured sizes.

    python scripts/gpu_carry.py                  # builds or refreshes .gpu-carry (downloads only what is missing)
    python scripts/gpu_carry.py --out DIR        # elsewhere (inside the repository and ignored, to be carried)

It prints the folder's size and the size of what a device call sends (tracked and untracked,
not ignored files plus the folder) and fails if that is over 64 MiB.
"""

from __future__ import annotations

import argparse
import datetime
import importlib.metadata as metadata
import json
import os
import re
import shutil
import subprocess
import sys
import tempfile
import zipfile
from pathlib import Path

from packaging.markers import Marker
from packaging.requirements import Requirement
from packaging.utils import canonicalize_name

from vigen.datasets.verify import sha256_file

ROOT = Path(__file__).resolve().parents[1]
TRAVEL_LIMIT = 64 * 2**20  # what one device call may send: the working tree and the carried paths

# What vigen's core needs (setup.py's install_requires, less what is checked separately below); the closure of their
# requirements is read from this environment's metadata.
ROOTS = ["torchrl", "tensordict", "mujoco", "dm-control", "gymnasium"]
# The GPU machine's Python packages (.library/device/KINDS.md, "Python packages already there", read 2026-11-17).
GPU_MACHINE_HAS = {canonicalize_name(name) for name in """
absl-py accelerate aiofiles aiohappyeyeballs aiohttp aiosignal annotated-doc anyio attrs botorch build certifi
charset-normalizer chex click cloudpickle cmake colorama contourpy coverage cuda-bindings cuda-core cuda-pathfinder
cuda-toolkit cupy-cuda13x cycler cython diffrax e3nn einops equinox etils execnet filelock flatbuffers flax fonttools
formulaic frozenlist fsspec gpytorch grpcio h11 h5py hf-xet httpcore httpx huggingface-hub humanize hypothesis idna
imageio iniconfig interface-meta jax jax-cuda13-pjrt jax-cuda13-plugin jaxlib jaxtyping jinja2 joblib kiwisolver
lazy-loader lightning lightning-utilities linear-operator lineax llvmlite lxml markdown markdown-it-py markupsafe
matplotlib mdurl meson ml-dtypes mpi4py mpmath msgpack multidict multipledispatch mypy-extensions nanobind narwhals
networkx ninja numba numba-cuda numpy numpyro nvidia-ml-py onnx onnx-ir onnxruntime onnxscript
opencv-python-headless optax opt-einsum opt-einsum-fx optimistix orbax-checkpoint packaging pandas pathspec patsy peft
pillow pip pluggy portalocker prometheus-client propcache protobuf psutil pyarrow pybind11 py-cpuinfo pygments
pyre-extensions pyparsing pyproject-hooks pytest pytest-benchmark pytest-cov pytest-mock pytest-timeout pytest-xdist
python-dateutil pytorch-lightning pyyaml regex requests rich sacrebleu safetensors scikit-build-core scikit-image
scikit-learn scipy seaborn sentencepiece sentence-transformers setuptools shellingham simplejson six sortedcontainers
statsmodels sympy tabulate tensorboard tensorboard-data-server tensorstore threadpoolctl tifffile tiktoken timm
tokenizers toolz torch torchaudio torchdiffeq torch-geometric torchmetrics torchvision tqdm transformers treescope
triton typer typing-extensions typing-inspect urllib3 uvloop wadler-lindig werkzeug wheel wrapt xarray xxhash yarl
zipp""".split()}
# dm-control's folders that vigen never loads (the dog's, soccer's and the locomotion walkers' assets, Blender sources)
DM_CONTROL_LEFT_OUT = ("dm_control/suite/dog_assets/", "dm_control/locomotion/soccer/",
                       "dm_control/locomotion/walkers/assets/", "dm_control/blender/")
GL_PACKAGES = ["libegl1", "libglvnd0", "libopengl0", "libgl1", "libglx0", "libgles2"]
TARGET = {"python_version": "3.12", "python_full_version": "3.12.3", "implementation_name": "cpython",
          "platform_python_implementation": "CPython", "sys_platform": "linux", "platform_system": "Linux",
          "platform_machine": "x86_64", "os_name": "posix"}
PLATFORMS = ["manylinux1_x86_64", "manylinux2010_x86_64", "manylinux2014_x86_64",
             *(f"manylinux_2_{n}_x86_64" for n in range(17, 40))]


def needed_distributions() -> dict[str, str]:
    """name -> version: the closure of ROOTS' requirements (for Python 3.12 on Linux) that the GPU machine lacks."""
    found: dict[str, str] = {}
    queue = [(Requirement(name), None) for name in ROOTS]
    while queue:
        requirement, _ = queue.pop()
        name = canonicalize_name(requirement.name)
        if name in GPU_MACHINE_HAS or name.startswith("nvidia-"):
            continue
        try:
            dist = metadata.distribution(requirement.name)
        except metadata.PackageNotFoundError:
            raise SystemExit(f"gpu_carry: {requirement.name} is not installed in this environment ({sys.executable}), so its "
                             "version and requirements are unknown: install vigen here first (bash scripts/setup_env.sh test)")
        if name in found:
            continue
        found[name] = dist.version
        for line in dist.requires or []:
            needed = Requirement(line)
            extras = requirement.extras or {""}
            if needed.marker is None or any(needed.marker.evaluate({**TARGET, "extra": extra}) for extra in extras):
                queue.append((needed, name))
    return dict(sorted(found.items()))


def archive_modules(path: Path) -> set[str]:
    """The top-level modules a wheel (or zip of an unpacked wheel) installs: packages and ``.py`` files, public ones."""
    with zipfile.ZipFile(path) as archive:
        names = archive.namelist()
    packages = {name.split("/")[0] for name in names if name.count("/") == 1 and name.endswith("/__init__.py")}
    files = {name[:-3] for name in names if "/" not in name and name.endswith(".py")}
    return {module for module in packages | files if not module.startswith("_") and module.isidentifier()}


def pip_download(specs: list[str], folder: Path) -> None:
    folder.mkdir(parents=True, exist_ok=True)
    command = [sys.executable, "-m", "pip", "download", "--quiet", "--no-deps", "--only-binary=:all:", "--python-version",
               TARGET["python_version"], "--implementation", "cp", *(f"--platform={p}" for p in PLATFORMS), "-d", str(folder),
               *specs]
    result = subprocess.run(command, capture_output=True, text=True)
    if result.returncode:
        raise SystemExit(f"gpu_carry: pip download failed ({' '.join(command)}):\n{result.stderr[-3000:]}")


def wheel_name(path: Path) -> tuple[str, str]:
    name, version = path.name.split("-")[:2]
    return canonicalize_name(name), version


def trimmed_dm_control(version: str, cache: Path, out: Path) -> tuple[Path, int]:
    """dm-control's wheel, rezipped without DM_CONTROL_LEFT_OUT; (the zip, its unpacked size)."""
    pip_download([f"dm-control=={version}"], cache)
    (wheel,) = [p for p in cache.glob("dm_control-*.whl") if wheel_name(p) == ("dm-control", version)]
    target = out / f"dm_control-{version}-trimmed.zip"
    unpacked = 0
    with zipfile.ZipFile(wheel) as source, tempfile.NamedTemporaryFile(dir=out, suffix=".zip", delete=False) as tmp:
        with zipfile.ZipFile(tmp, "w", zipfile.ZIP_DEFLATED, compresslevel=9) as trimmed:
            for item in source.infolist():
                if not item.filename.startswith(DM_CONTROL_LEFT_OUT):
                    trimmed.writestr(item, source.read(item))
                    unpacked += item.file_size
    os.replace(tmp.name, target)
    return target, unpacked


def gl_packages(folder: Path) -> list[Path]:
    """Debian's GL loader packages (amd64), downloaded with apt-get unless already there."""
    folder.mkdir(parents=True, exist_ok=True)
    missing = [name for name in GL_PACKAGES if not list(folder.glob(f"{name}_*.deb"))]
    if missing:
        lists = Path(tempfile.gettempdir()) / "vigen-apt-amd64"
        (lists / "partial").mkdir(parents=True, exist_ok=True)
        options = ["-oAPT::Architecture=amd64", "-oAPT::Architectures=amd64", f"-oDir::State::Lists={lists}"]
        for command, cwd in ((["apt-get", *options, "update"], None), (["apt-get", *options, "download", *missing], folder)):
            result = subprocess.run(command, capture_output=True, text=True, cwd=cwd)
            if result.returncode:
                raise SystemExit(f"gpu_carry: {' '.join(command)} failed:\n{result.stderr[-2000:]}")
    return sorted(path for name in GL_PACKAGES for path in folder.glob(f"{name}_*.deb"))


def travel_bytes() -> int:
    """What a device call sends besides carried paths: tracked and untracked files that git does not ignore."""
    listed = subprocess.run(["git", "ls-files", "-z", "--cached", "--others", "--exclude-standard"], cwd=ROOT,
                            capture_output=True, check=True).stdout.decode().split("\0")
    return sum((ROOT / name).stat().st_size for name in listed if name and (ROOT / name).is_file())


def folder_bytes(folder: Path) -> int:
    return sum(path.stat().st_size for path in folder.rglob("*") if path.is_file())


def git_state() -> dict[str, object]:
    def git(*args: str) -> str:
        return subprocess.run(["git", *args], cwd=ROOT, capture_output=True, text=True).stdout.strip()
    return {"commit": git("rev-parse", "HEAD") or None, "dirty": bool(git("status", "--porcelain", "--untracked-files=no"))}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--out", type=Path, default=ROOT / ".gpu-carry", help="the folder to build (default .gpu-carry)")
    parser.add_argument("--cache", type=Path, default=Path(tempfile.gettempdir()) / "vigen-gpu-carry-cache",
                        help="where dm-control's full wheel is kept between builds")
    args = parser.parse_args()
    out = args.out.resolve()
    out.mkdir(parents=True, exist_ok=True)  # git reads a folder pattern (.gpu-carry/) only for an existing folder
    if out.is_relative_to(ROOT) and subprocess.run(["git", "check-ignore", "-q", str(out)], cwd=ROOT).returncode:
        raise SystemExit(f"gpu_carry: {out} is inside the repository but not ignored by git: it would travel twice and "
                         "could be committed; use the default .gpu-carry (ignored in .gitignore) or an ignored folder")
    needed = needed_distributions()
    dm_version = needed.pop("dm-control")
    wheels_dir = out / "wheels"
    pip_download([f"{name}=={version}" for name, version in needed.items()], wheels_dir)
    wheels = []
    for path in sorted(wheels_dir.glob("*.whl")):
        if needed.get(wheel_name(path)[0]) != wheel_name(path)[1]:
            path.unlink()  # another version, or no longer needed: two versions of one stop the install
        else:
            wheels.append(path)
    if missing := sorted(set(needed) - {wheel_name(path)[0] for path in wheels}):
        raise SystemExit(f"gpu_carry: pip download left no wheel for {', '.join(missing)}")
    for stale in out.glob("dm_control-*-trimmed.zip"):
        stale.unlink()
    dm_zip, dm_unpacked = trimmed_dm_control(dm_version, args.cache, out)
    debs = gl_packages(out / "gl")

    def entry(path: Path, **more: object) -> dict[str, object]:
        return {"file": str(path.relative_to(out)), "bytes": path.stat().st_size, "sha256": sha256_file(path), **more}
    modules = sorted(set().union(*(archive_modules(path) for path in [*wheels, dm_zip])))
    carry = folder_bytes(out) - ((out / "MANIFEST.json").stat().st_size if (out / "MANIFEST.json").exists() else 0)
    tree = travel_bytes()
    manifest = {
        "built": datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds"),
        "built_with": f"python scripts/gpu_carry.py (Python {sys.version.split()[0]}, {sys.executable})",
        "target": "CPython 3.12, manylinux x86-64; torch comes from the GPU machine",
        **git_state(),
        "wheels": [entry(path, name=wheel_name(path)[0], version=wheel_name(path)[1]) for path in wheels],
        "dm_control": entry(dm_zip, version=dm_version, unpacked_bytes=dm_unpacked, left_out=list(DM_CONTROL_LEFT_OUT)),
        "gl": [entry(path) for path in debs],
        "modules": [*modules, "vigen"],
        "carry_bytes": carry,
        "tree_bytes": tree,
    }
    with tempfile.NamedTemporaryFile("w", dir=out, suffix=".json", delete=False) as tmp:
        json.dump(manifest, tmp, indent=1)
    os.replace(tmp.name, out / "MANIFEST.json")
    total = tree + folder_bytes(out)
    mib = lambda n: f"{n / 2**20:.1f} MiB"  # noqa: E731
    print(f"{out}: {len(wheels)} wheels, dm-control {dm_version} trimmed ({mib(dm_zip.stat().st_size)} zipped, "
          f"{mib(dm_unpacked)} unpacked), {len(debs)} GL packages; {mib(folder_bytes(out))} in all")
    print(f"a device call sends {mib(total)} (the working tree {mib(tree)} + this folder) of its {mib(TRAVEL_LIMIT)}")
    if total > TRAVEL_LIMIT:
        raise SystemExit(f"gpu_carry: {mib(total)} is over the {mib(TRAVEL_LIMIT)} a device call may send")
    if re.search(r"\s", str(out)):
        print("note: the folder's path has spaces; carry it by its path relative to the repository")


if __name__ == "__main__":
    main()
