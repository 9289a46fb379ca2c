"""The ``loco`` suite: RL-ViGen's locomotion and manipulation tasks on real robot models.

* :mod:`vigen.envs.loco.suite`: the suite record :data:`~vigen.envs.loco.suite.LOCO` (task names, level table,
  groups, factors, builder);
* :mod:`vigen.envs.loco.env`: the simulator side, the ``dmc`` pixel chain around a loco scene and task;
* :mod:`vigen.envs.loco.scene`: the MuJoCo scenes built around an installed robot model;
* :mod:`vigen.envs.loco.tasks`: RL-ViGen's tasks and rewards;
* :mod:`vigen.envs.loco.robot_models`: where the robot models come from (installed packages or a Menagerie checkout).
"""
