"""The papers' networks, one family per file; everything a loss or a user builds is exported here.

``networks``: DrQ-v2's encoder, actor and twin critic, SVEA's 11-layer CNN, the CURL/SGQN
projection encoder, SGQN's attribution decoder, CURL's bilinear head and the SAC actor.
"""

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

__all__ = [
    "Actor",
    "AttributionDecoder",
    "CURLHead",
    "Critic",
    "DrQv2Encoder",
    "GaussianActor",
    "ProjectedEncoder",
    "SharedCNN",
    "weight_init",
]
