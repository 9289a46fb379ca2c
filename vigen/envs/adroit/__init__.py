"""The ``adroit`` suite: gymnasium-robotics' Adroit hand tasks as pixel envs.

* :mod:`vigen.envs.adroit.suite`: the suite record :data:`~vigen.envs.adroit.suite.ADROIT` (task names, level
  table, groups, factors, builder);
* :mod:`vigen.envs.adroit.env`: the simulator side, a TorchRL wrapper of the gymnasium-robotics models
  (imported when the first env is built).
"""
