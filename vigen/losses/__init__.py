"""Augmentation-based actor-critic algorithms (DrQ-v2, SVEA, SRM, SGQN, CURL, DrQ) as TorchRL LossModules."""

__all__: list[str] = []
