"""Every algorithm the parity tool compares: its case builder, and the repository its original lives in."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from benchmarks.parity.dmcgb2 import build_sada
from benchmarks.parity.harness import Case, Setup
from benchmarks.parity.madi import build_madi
from benchmarks.parity.rlvigen import build_curl, build_drq, build_drqv2, build_pieg, build_sgqn, build_srm, build_svea
from benchmarks.parity.rlvigen_adroit import build_vrl3
from benchmarks.parity.scpl import build_scpl
from benchmarks.parity.simgrl import build_simgrl

ALGORITHMS: dict[str, Callable[[Path, Setup], Case]] = {
    "drqv2": build_drqv2,
    "svea": build_svea,
    "srm": build_srm,
    "sgqn": build_sgqn,
    "curl": build_curl,
    "drq": build_drq,
    "sada": build_sada,
    "pieg": build_pieg,
    "vrl3": build_vrl3,
    "madi": build_madi,
    "simgrl": build_simgrl,
    "scpl": build_scpl,
}


@dataclass(frozen=True)
class Original:
    """The repository an algorithm's original lives in, and files that tell a checkout of it apart."""

    repository: str
    url: str
    files: tuple[str, ...]


RLVIGEN_URL, DMCGB2_URL = "https://github.com/gemcollector/RL-ViGen", "https://github.com/aalmuzairee/dmcgb2"
RLVIGEN_ADROIT_URL = "https://github.com/gemcollector/RL-ViGen/tree/ViGen-adroit"
SCPL_URL = "https://github.com/bofusun/SCPL"
MADI_URL, SIMGRL_URL = "https://github.com/bramgrooten/mask-distractions", "https://github.com/W-Song11/SimGRL-Code"
ORIGINALS: dict[str, Original] = {
    # cfgs/config.yaml tells master from the ViGen-adroit branch's src/, which has other agents under the same names
    **{name: Original("RL-ViGen", RLVIGEN_URL, ("rl_utils.py", "cfgs/config.yaml", f"algos/{name}.py"))
       for name in ("drqv2", "svea", "srm", "sgqn", "curl", "drq", "pieg")},
    "sada": Original("DMC-GB2", DMCGB2_URL, ("augmentations.py", "algos/sada.py")),
    "vrl3": Original("RL-ViGen ViGen-adroit/src", RLVIGEN_ADROIT_URL,
                     ("stage1_models.py", "cfgs_adroit/config.yaml", "algos/vrl3_agent.py")),
    "madi": Original("MaDi", MADI_URL, ("src/augmentations.py", "src/algorithms/madi.py")),
    "simgrl": Original("SimGRL", SIMGRL_URL, ("src/augmentations.py", "src/algorithms/simgrl.py")),
    "scpl": Original("SCPL", SCPL_URL, ("src/augmentations.py", "src/algorithms/SCPL.py")),
}
