"""The papers' networks, one family per file; everything a loss or a user builds is exported here.

``networks``: DrQ-v2's encoder, actor and twin critic, SVEA's 11-layer CNN, the CURL/SGQN
projection encoder, SGQN's attribution decoder, CURL's bilinear head and the SAC actor.
``masker``: MaDi's per-frame masker. ``per_frame``: SimGRL's encoder with feature-level frame stacking.
``vrl3``: VRL3's small ResNet encoder (BatchNorm, ImageNet normalisation, optional stage-1 weights).
``resnet``: PIE-G's encoder on frozen ImageNet ResNet-18 layers (torchvision's names, weights from a file).
``dynamics``: SCPL's latent transition and reward model.
"""

from vigen.models.dynamics import LatentDynamics
from vigen.models.masker import MaDiMasker
from vigen.models.networks import (
    Actor,
    AttributionDecoder,
    Critic,
    CURLHead,
    DrQv2Encoder,
    GaussianActor,
    ProjectedEncoder,
    SharedCNN,
    weight_init,
)
from vigen.models.per_frame import PerFrameEncoder
from vigen.models.resnet import PIEGEncoder
from vigen.models.vrl3 import VRL3Encoder

__all__ = [
    "Actor",
    "AttributionDecoder",
    "CURLHead",
    "Critic",
    "DrQv2Encoder",
    "GaussianActor",
    "LatentDynamics",
    "MaDiMasker",
    "PerFrameEncoder",
    "PIEGEncoder",
    "ProjectedEncoder",
    "SharedCNN",
    "VRL3Encoder",
    "weight_init",
]
