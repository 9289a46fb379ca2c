"""Parity of vigen's losses with the original implementations: one update, same weights, same draws.

For each algorithm the tool imports the ORIGINAL agent from a user-given checkout (by path: nothing
of it is copied into vigen), builds it and vigen's loss with the same architecture, copies the
original's weights into vigen's networks (mapping the parameter names), gives both sides the same
pre-drawn augmented views, the same action noise and the same scalar draws, runs ONE update on the
same batch in float64 and compares every loss value and every parameter gradient.

How the update is compared:

* the original's optimizer steps are *recorded, not taken*: each ``step()`` saves the gradients of
  its parameters and leaves them unchanged, and each ``backward()`` saves its loss value. So every
  quantity of the original is measured at the same parameters as vigen's single forward pass; the
  ordering departures (RL-ViGen's actor loss, CURL anchor and SGQN mask are computed after its
  critic step) become comparable. The column "steps taken" repeats the original's update with its
  real Adam steps and shows how much that order changes each quantity (a departure by design);
* vigen's gradients are taken per ``loss_*`` entry (``autograd.grad``) and matched with the
  original's optimizer step that consumes that loss (e.g. ``loss_curl`` with CURL's second
  ``encoder_opt`` step). A gradient that vigen's loss sends to a parameter the original's step does
  not own is reported as a stray row;
* views: drawn once with vigen's augmentations (seeded) and replayed: the original's ``aug``,
  ``random_overlay`` and ``random_mask_freq_v2`` return them, and vigen's loss gets replay
  augmentations (``make_params``/``apply``) that return them. A replay checks that it is asked
  to augment the expected source (e.g. the strong view is built on the weak view). The
  augmentation kernels themselves are compared with the originals in vigen's transform tests;
* noise: one stream of standard normals hands out values in call order to ``torch.randn_like`` /
  ``torch.randn`` (vigen) and ``_standard_normal`` (the originals' ``TruncatedNormal`` and
  ``Normal.rsample``); one scalar ``u`` serves SGQN's fill value (``random.uniform`` there,
  ``torch.rand(())`` in vigen);
* float64: ``torch.set_default_dtype(torch.float64)``, ``Tensor.float()`` keeps float64 and
  ``torch.FloatTensor(...)`` builds float64 while the tool runs (both sides call ``.float()`` on
  their pixels; VRL3's original adds a ``torch.FloatTensor([0])`` to its actor loss).

Per quantity the relative difference is ``max|a − b| / max(max|b|, tiny)`` (b = original; for a
gradient tensor the max runs over its elements, and the value columns show its L2 norm). A gradient
that is 0 in exact arithmetic (VRL3's stem bias, before a training-mode BatchNorm: both sides are
rounding noise) is measured against the largest gradient of its step instead, and its row says so.

Missing imports of the originals that their update does not use (hydra, omegaconf, torchvision,
kornia) are stubbed in ``sys.modules`` while they load; every stub is listed in the output. PIE-G's
original builds torchvision's ResNet-18 and VRL3's normalises with torchvision's ``Normalize``: for
them torchvision is the tool's stand-in (:func:`~benchmarks.parity.stand_ins.torchvision_substitute`; said so in the output): a
ResNet-18 written here in torchvision's layout, whose random BatchNorm weights and statistics stand
in for ImageNet's (vigen's ``PIEGEncoder`` loads the same state dict from a file), and ``Normalize``
as ``(x − mean) / std``.
RL-ViGen's SGQN needs captum's ``GuidedBackprop``: if captum does not import, a stand-in with
captum's rule (at every ``nn.ReLU`` the gradient is clamped at 0 before the ReLU's own backward)
is used and said so; put captum on the path (``--pythonpath DIR``) to use the real one.

Reproduce (RL-ViGen master, https://github.com/gemcollector/RL-ViGen; the tool runs from vigen's repository root as
``python -m benchmarks.parity``):

    # a plain checkout of the original (outside the vigen tree); only its code is needed
    git clone https://github.com/gemcollector/RL-ViGen /work/refs/RL-ViGen
    # or from a bare mirror: git --git-dir=<mirror> archive HEAD algos utils.py rl_utils.py cfgs | tar -x -C /work/refs/RL-ViGen
    cd /work/main && OMP_NUM_THREADS=1 .venv/bin/python -m benchmarks.parity --reference /work/refs/RL-ViGen
    # real captum, installed outside the venv:
    pip install --no-deps --target /work/refs/pydeps captum
    OMP_NUM_THREADS=1 .venv/bin/python -m benchmarks.parity --reference /work/refs/RL-ViGen --pythonpath /work/refs/pydeps
    # some algorithms, a reference per algorithm:
    .venv/bin/python -m benchmarks.parity --algos curl sgqn --reference curl=/path/RL-ViGen --reference sgqn=/path/RL-ViGen

SADA's original is DMC-GB2's (https://github.com/aalmuzairee/dmcgb2, algos/sada.py): give it as
``--reference sada=PATH``. Without ``--algos`` every algorithm whose reference holds its original
runs; the others are listed as skipped (``sada`` and ``vrl3`` beside a plain RL-ViGen ``PATH``):

    # a plain checkout of DMC-GB2's code (its envs and data are not needed)
    git clone https://github.com/aalmuzairee/dmcgb2 /work/refs/dmcgb2
    # or from a bare mirror: git --git-dir=<mirror> archive HEAD algos augmentations.py utils.py | tar -x -C /work/refs/dmcgb2
    OMP_NUM_THREADS=1 .venv/bin/python -m benchmarks.parity --algos sada --reference sada=/work/refs/dmcgb2
    # RL-ViGen's seven (with PIE-G) and SADA
    OMP_NUM_THREADS=1 .venv/bin/python -m benchmarks.parity --reference /work/refs/RL-ViGen --reference sada=/work/refs/dmcgb2 --pythonpath /work/refs/pydeps

VRL3's original lives only on RL-ViGen's ViGen-adroit branch (``src/algos/vrl3_agent.py``): give
its ``src`` folder as ``--reference vrl3=PATH``. (That folder also has agents named ``svea``,
``pieg``, ... built on VRL3's update: it never counts as a master checkout.)

    git clone -b ViGen-adroit https://github.com/gemcollector/RL-ViGen /work/refs/RL-ViGen-adroit
    # or from a bare mirror: git --git-dir=<mirror> archive ViGen-adroit src | tar -x -C /work/refs/RL-ViGen-adroit
    OMP_NUM_THREADS=1 .venv/bin/python -m benchmarks.parity --algos vrl3 --reference vrl3=/work/refs/RL-ViGen-adroit/src

MaDi, SimGRL and SCPL are their authors' forks of DMC-GB (SAC agents with ``update(replay_buffer, L,
step)``, built with ``.cuda()``, which the tool maps to the CPU while they are built): give each
repository's root as ``--reference NAME=PATH`` (their ``src/algorithms`` need captum). SCPL's draws
of actions it never uses are counted apart (``unused_normals``).

    git clone https://github.com/bramgrooten/mask-distractions /work/refs/MaDi
    git clone https://github.com/W-Song11/SimGRL-Code /work/refs/SimGRL
    git clone https://github.com/bofusun/SCPL /work/refs/SCPL
    # or from bare mirrors: git --git-dir=<mirror> archive HEAD src/algorithms src/augmentations.py src/utils.py | tar -x -C <dir>
    OMP_NUM_THREADS=1 .venv/bin/python -m benchmarks.parity --algos madi simgrl scpl --reference madi=/work/refs/MaDi \\
        --reference simgrl=/work/refs/SimGRL --reference scpl=/work/refs/SCPL --pythonpath /work/refs/pydeps
    # everything: RL-ViGen's seven, SADA, VRL3, MaDi, SimGRL and SCPL
    OMP_NUM_THREADS=1 .venv/bin/python -m benchmarks.parity --reference /work/refs/RL-ViGen --reference sada=/work/refs/dmcgb2 \\
        --reference vrl3=/work/refs/RL-ViGen-adroit/src --reference madi=/work/refs/MaDi --reference simgrl=/work/refs/SimGRL \\
        --reference scpl=/work/refs/SCPL --pythonpath /work/refs/pydeps

Layout: :mod:`~benchmarks.parity.harness` (settings, float64 mode, draws and replays, what a case
declares, running both sides, comparing and reporting), :mod:`~benchmarks.parity.checkout` (importing
an original checkout), :mod:`~benchmarks.parity.stand_ins` (stubs, captum's and torchvision's
stand-ins), :mod:`~benchmarks.parity.batchnorm_statistics` (the BatchNorm measure), one module per
original codebase (:mod:`~benchmarks.parity.rlvigen`, :mod:`~benchmarks.parity.dmcgb2`,
:mod:`~benchmarks.parity.rlvigen_adroit`, and the DMC-GB forks :mod:`~benchmarks.parity.madi`,
:mod:`~benchmarks.parity.simgrl`, :mod:`~benchmarks.parity.scpl` on the shared
:mod:`~benchmarks.parity.dmcgb`), :mod:`~benchmarks.parity.algorithms` (the registry) and
:mod:`~benchmarks.parity.cli` (the command line).

Adding an algorithm: write one ``build_<name>(reference, setup) -> Case`` function, in the module of
its original's codebase, that imports the original's modules with
:func:`~benchmarks.parity.checkout.import_reference`, builds its agent and vigen's loss, and says which
original module maps to which vigen network (:class:`~benchmarks.parity.harness.ModuleMap`), which
optimizer step consumes which ``loss_*`` (:class:`~benchmarks.parity.harness.StepMap`), which
callables of the original are replaced by view replays, and its documented departures (optionally:
extra arguments of the original's ``update``, gradients that are 0 in exact arithmetic, and measures
of what the update leaves behind, such as BatchNorm statistics); then add it to ``ALGORITHMS`` and
its repository and identifying files to ``ORIGINALS`` (both in :mod:`~benchmarks.parity.algorithms`).
"""
