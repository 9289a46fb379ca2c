"""The ``dmc`` suite: dm_control tasks as pixel envs.

* :mod:`vigen.envs.dmc.suite`: the suite record :data:`~vigen.envs.dmc.suite.DMC` (task names, level table, groups,
  factors, builder);
* :mod:`vigen.envs.dmc.env`: the simulator side, DrQ-v2's action repeat and pixel chain as a TorchRL base env.
"""
