"""The ``robosuite`` suite: robosuite manipulation tasks as pixel envs.

* :mod:`vigen.envs.robosuite.suite`: the suite record :data:`~vigen.envs.robosuite.suite.ROBOSUITE` (task names,
  level table, groups, factors, builder);
* :mod:`vigen.envs.robosuite.env`: the simulator side, a TorchRL wrapper of robosuite (imported when the first env
  is built).
"""
