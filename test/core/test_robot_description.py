"""Tests for the robot description in config/ (URDF, SRDF, joint_limits.yaml, kinematics.yaml).

The description was written by hand from shared/docs/robot_facts.md. These tests transcribe the
facts tables a second time, independently, as plain Python data, and check the files against
them. Forward kinematics is done twice: once by an independent numpy implementation of the facts
table (xyz + fixed-axis rpy origin, then a rotation about z by the joint angle), once by pinocchio
from the URDF, so a typo in either shows up as a mismatch.

Pinocchio is used directly (not mycobot_planning's RobotModel) so these tests pin down the data
files on their own. The model is built with ``mimic=False`` and the mimic finger joints are set
from the URDF's <mimic> tags: pinocchio 4.1's ``mimic=True`` parser needs each mimicked joint to
come before its mimic joints in its name-sorted depth-first traversal, and the myCobot's joint
names (fixed by the facts) put ``gripper_base_to_gripper_left2`` etc. before
``gripper_controller``, so ``buildModelFromXML(xml, mimic=True)`` refuses this URDF.
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from dataclasses import dataclass
from pathlib import Path

import coal
import numpy as np
import pinocchio as pin
import pytest
import yaml

PI2 = math.pi / 2
TOL = 1e-9

# --------------------------------------------------------------------------------------------
# Facts, transcribed from shared/docs/robot_facts.md (independently of config/).
# --------------------------------------------------------------------------------------------

ARM_JOINTS = [
    "link1_to_link2",
    "link2_to_link3",
    "link3_to_link4",
    "link4_to_link5",
    "link5_to_link6",
    "link6_to_link6_flange",
]
GRIPPER_JOINT = "gripper_controller"


@dataclass(frozen=True)
class FactJoint:
    name: str
    type: str
    parent: str
    child: str
    xyz: tuple[float, float, float]
    rpy: tuple[float, float, float]
    limits: tuple[float, float] | None = None
    mimic_multiplier: float | None = None  # mimics gripper_controller when set


ARM_LIMIT = (-2.879793, 2.879793)

# In topological order (every parent link is placed before its child), so FK can run top-down.
FACT_JOINTS = [
    FactJoint("link1_to_link2", "revolute", "link1", "link2", (0, 0, 0.13156), (0, 0, PI2), ARM_LIMIT),
    FactJoint("link2_to_link3", "revolute", "link2", "link3", (0, 0, -0.001), (0, PI2, -PI2), ARM_LIMIT),
    FactJoint("link3_to_link4", "revolute", "link3", "link4", (-0.1104, 0, 0), (0, 0, 0), ARM_LIMIT),
    FactJoint("link4_to_link5", "revolute", "link4", "link5", (-0.096, 0, 0.06062), (0, 0, -PI2), ARM_LIMIT),
    FactJoint("link5_to_link6", "revolute", "link5", "link6", (0, -0.07318, 0), (PI2, -PI2, 0), ARM_LIMIT),
    FactJoint("link6_to_link6_flange", "revolute", "link6", "link6_flange", (0, 0.0456, 0), (-PI2, 0, 0), (-3.05, 3.05)),
    FactJoint("link6_flange_to_gripper_base", "fixed", "link6_flange", "gripper_base", (0, 0, 0.034), (1.579, 0, 0)),
    FactJoint("gripper_controller", "revolute", "gripper_base", "gripper_left3", (-0.012, 0.005, 0), (0, 0, 0), (-0.7, 0.15)),
    FactJoint("gripper_base_to_gripper_left2", "revolute", "gripper_base", "gripper_left2", (-0.005, 0.027, 0), (0, 0, 0), (-0.8, 0.5), 1.0),
    FactJoint("gripper_left3_to_gripper_left1", "revolute", "gripper_left3", "gripper_left1", (-0.027, 0.016, 0), (0, 0, 0), (-0.5, 0.5), -1.0),
    FactJoint("gripper_base_to_gripper_right3", "revolute", "gripper_base", "gripper_right3", (0.012, 0.005, 0), (0, 0, 0), (-0.15, 0.7), -1.0),
    FactJoint("gripper_base_to_gripper_right2", "revolute", "gripper_base", "gripper_right2", (0.005, 0.027, 0), (0, 0, 0), (-0.5, 0.8), -1.0),
    FactJoint("gripper_right3_to_gripper_right1", "revolute", "gripper_right3", "gripper_right1", (0.027, 0.016, 0), (0, 0, 0), (-0.5, 0.5), 1.0),
]
FACT_JOINT_BY_NAME = {j.name: j for j in FACT_JOINTS}
MIMIC_JOINTS = [j.name for j in FACT_JOINTS if j.mimic_multiplier is not None]

# link: (shape, dims, origin xyz, origin rpy); box dims = size, cylinder dims = (radius, length)
FACT_SHAPES = {
    "base_link": ("box", (0.105, 0.14, 0.02), (0, 0, -0.015), (0, 0, 0)),
    "link1": ("box", (0.08, 0.12, 0.075), (0, -0.01, 0.034), (0, 0, 0)),
    "link2": ("cylinder", (0.025, 0.085), (0, 0, -0.02), (0, 0, -PI2)),
    "link3": ("cylinder", (0.025, 0.15), (-0.058, 0, 0.059), (0, -PI2, 0)),
    "link4": ("cylinder", (0.025, 0.125), (-0.05, 0, 0), (0, -PI2, 0)),
    "link5": ("box", (0.03, 0.035, 0.05), (0, 0, -0.005), (0, 0, 0)),
    "link6": ("cylinder", (0.025, 0.06), (0, 0, 0), (-PI2, 0, 0)),
    "link6_flange": ("cylinder", (0.02, 0.02), (0, 0, 0), (0, 0, 0)),
    "gripper_base": ("box", (0.065, 0.025, 0.025), (0, 0, 0), (0, 0, 0)),
    "gripper_left1": ("box", (0.013, 0.02, 0.015), (0.013, 0.042, -0.010), (0, 0, 0)),
    "gripper_left2": ("box", (0.02, 0.02, 0.02), (-0.025, 0, -0.010), (0, 0, 0)),
    "gripper_left3": ("box", (0.01, 0.01, 0.01), (-0.014, 0.005, 0.005), (0, 0, 0)),
    "gripper_right1": ("box", (0.013, 0.02, 0.015), (-0.013, 0.042, -0.010), (0, 0, 0)),
    "gripper_right2": ("box", (0.02, 0.02, 0.02), (0.025, 0, -0.010), (0, 0, 0)),
    "gripper_right3": ("box", (0.01, 0.01, 0.01), (0.014, 0.005, 0.005), (0, 0, 0)),
}
FACT_LINKS = {"world", *FACT_SHAPES}
GRIPPER_LINKS = [
    "gripper_base",
    "gripper_left1",
    "gripper_left2",
    "gripper_left3",
    "gripper_right1",
    "gripper_right2",
    "gripper_right3",
]
FINGER_LINKS = GRIPPER_LINKS[1:]

ARM_STATES = {
    "home": dict.fromkeys(ARM_JOINTS, 0.0),
    "ready": {**dict.fromkeys(ARM_JOINTS, 0.0), "link3_to_link4": 1.5708, "link4_to_link5": 1.5708},
}
GRIPPER_STATES = {"open": 0.0, "half_closed": -0.34, "closed": -0.50}

FACT_DISABLED_PAIRS = {
    frozenset(p)
    for p in [
        ("base_link", "link1"), ("base_link", "link2"), ("base_link", "link3"), ("link1", "link2"),
        ("link2", "link3"), ("link2", "link5"), ("link3", "link4"), ("link4", "link5"),
        ("link5", "link6"), ("link6", "link6_flange"), ("link6_flange", "gripper_base"),
        ("gripper_left2", "gripper_left1"), ("gripper_left2", "gripper_left3"),
        ("gripper_left2", "gripper_right1"), ("gripper_left2", "gripper_right2"),
        ("gripper_left2", "gripper_right3"), ("gripper_left3", "gripper_left1"),
        ("gripper_right1", "gripper_left3"), ("gripper_right2", "gripper_left1"),
        ("gripper_right2", "gripper_left3"), ("gripper_right2", "gripper_right3"),
    ]
}
FACT_DISABLED_PAIRS |= {frozenset((w, g)) for w in ("link5", "link6", "link6_flange") for g in GRIPPER_LINKS}
FACT_DISABLED_PAIRS |= {frozenset(("gripper_base", f)) for f in FINGER_LINKS}

ARM_MAX_VELOCITY = 2.792527
ARM_MAX_ACCELERATION = 5.0


# --------------------------------------------------------------------------------------------
# Independent numpy forward kinematics of the facts table.
# --------------------------------------------------------------------------------------------


def rpy_matrix(roll: float, pitch: float, yaw: float) -> np.ndarray:
    """Fixed-axis roll-pitch-yaw, as URDF defines it: R = Rz(yaw) @ Ry(pitch) @ Rx(roll)."""
    cr, sr = math.cos(roll), math.sin(roll)
    cp, sp = math.cos(pitch), math.sin(pitch)
    cy, sy = math.cos(yaw), math.sin(yaw)
    rx = np.array([[1, 0, 0], [0, cr, -sr], [0, sr, cr]])
    ry = np.array([[cp, 0, sp], [0, 1, 0], [-sp, 0, cp]])
    rz = np.array([[cy, -sy, 0], [sy, cy, 0], [0, 0, 1]])
    return rz @ ry @ rx


def origin_transform(xyz, rpy) -> np.ndarray:
    t = np.eye(4)
    t[:3, :3] = rpy_matrix(*rpy)
    t[:3, 3] = xyz
    return t


def rot_z(angle: float) -> np.ndarray:
    t = np.eye(4)
    c, s = math.cos(angle), math.sin(angle)
    t[:2, :2] = [[c, -s], [s, c]]
    return t


def full_positions(arm: dict[str, float], gripper: float) -> dict[str, float]:
    """Every moving joint's angle; mimic joints from the facts' multipliers."""
    positions = dict(arm)
    positions[GRIPPER_JOINT] = gripper
    for name in MIMIC_JOINTS:
        positions[name] = FACT_JOINT_BY_NAME[name].mimic_multiplier * gripper
    return positions


def numpy_fk(positions: dict[str, float]) -> dict[str, np.ndarray]:
    """World pose of every link. world -> base_link -> link1 are identity per the facts."""
    poses = {"world": np.eye(4), "base_link": np.eye(4), "link1": np.eye(4)}
    for joint in FACT_JOINTS:
        t = poses[joint.parent] @ origin_transform(joint.xyz, joint.rpy)
        if joint.type == "revolute":
            t = t @ rot_z(positions[joint.name])
        poses[joint.child] = t
    return poses


# --------------------------------------------------------------------------------------------
# Fixtures: config/ located relative to this file; pinocchio model built from the URDF.
# --------------------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def config_dir() -> Path:
    path = Path(__file__).resolve().parents[2] / "config"
    assert path.is_dir(), f"config directory not found at {path}"
    return path


@pytest.fixture(scope="module")
def urdf_xml(config_dir: Path) -> str:
    return (config_dir / "mycobot_280.urdf").read_text()


@pytest.fixture(scope="module")
def srdf_xml(config_dir: Path) -> str:
    return (config_dir / "mycobot_280.srdf").read_text()


@pytest.fixture(scope="module")
def urdf_root(urdf_xml: str) -> ET.Element:
    return ET.fromstring(urdf_xml)


@pytest.fixture(scope="module")
def srdf_root(srdf_xml: str) -> ET.Element:
    return ET.fromstring(srdf_xml)


class PinRobot:
    """Pinocchio model + collision model of the URDF, mimic joints driven by its <mimic> tags."""

    def __init__(self, urdf_xml: str, srdf_xml: str) -> None:
        self.model = pin.buildModelFromXML(urdf_xml)
        self.data = self.model.createData()
        self.geom = pin.buildGeomFromUrdfString(self.model, urdf_xml, pin.GeometryType.COLLISION)
        self.geom.addAllCollisionPairs()
        pin.removeCollisionPairsFromXML(self.model, self.geom, srdf_xml)
        self.geom_data = self.geom.createData()
        self.mimic: dict[str, tuple[str, float, float]] = {}
        for joint in ET.fromstring(urdf_xml).findall("joint"):
            tag = joint.find("mimic")
            if tag is not None:
                self.mimic[joint.get("name")] = (
                    tag.get("joint"),
                    float(tag.get("multiplier", "1")),
                    float(tag.get("offset", "0")),
                )

    def q(self, active: dict[str, float]) -> np.ndarray:
        """Full pinocchio configuration from the active joints' values (mimics derived)."""
        values = dict(active)
        for name, (source, multiplier, offset) in self.mimic.items():
            values[name] = multiplier * active[source] + offset
        q = np.zeros(self.model.nq)
        for name, value in values.items():
            q[self.model.idx_qs[self.model.getJointId(name)]] = value
        return q

    def frame_pose(self, q: np.ndarray, link: str) -> np.ndarray:
        pin.framesForwardKinematics(self.model, self.data, q)
        frame_id = self.model.getFrameId(link, pin.FrameType.BODY)
        assert frame_id < len(self.model.frames), f"no frame for link {link}"
        return self.data.oMf[frame_id].homogeneous

    def pair_names(self, pair) -> tuple[str, str]:
        objects = self.geom.geometryObjects
        return (
            self.model.frames[objects[pair.first].parentFrame].name,
            self.model.frames[objects[pair.second].parentFrame].name,
        )

    def colliding_pairs(self, q: np.ndarray) -> list[tuple[str, str]]:
        pin.computeCollisions(self.model, self.data, self.geom, self.geom_data, q, False)
        return [
            self.pair_names(pair)
            for k, pair in enumerate(self.geom.collisionPairs)
            if self.geom_data.collisionResults[k].isCollision()
        ]


@pytest.fixture(scope="module")
def robot(urdf_xml: str, srdf_xml: str) -> PinRobot:
    return PinRobot(urdf_xml, srdf_xml)


def random_arm_states(count: int, seed: int) -> list[dict[str, float]]:
    rng = np.random.default_rng(seed)
    states = []
    for _ in range(count):
        states.append(
            {n: float(rng.uniform(*FACT_JOINT_BY_NAME[n].limits)) for n in ARM_JOINTS}
        )
    return states


def vec(text: str | None) -> np.ndarray:
    return np.array([float(v) for v in (text or "0 0 0").split()])


# --------------------------------------------------------------------------------------------
# URDF structure and limits
# --------------------------------------------------------------------------------------------


def test_urdf_links_and_joints_are_exactly_the_facts(urdf_root):
    assert urdf_root.get("name") == "mycobot_280"
    links = {link.get("name") for link in urdf_root.findall("link")}
    assert links == FACT_LINKS
    joints = {j.get("name"): j for j in urdf_root.findall("joint")}
    # Fixed joints world->base_link->link1 are identity.
    for parent, child in (("world", "base_link"), ("base_link", "link1")):
        matching = [
            j for j in joints.values()
            if j.find("parent").get("link") == parent and j.find("child").get("link") == child
        ]
        assert len(matching) == 1, f"expected one joint {parent} -> {child}"
        joint = matching[0]
        assert joint.get("type") == "fixed"
        origin = joint.find("origin")
        if origin is not None:
            np.testing.assert_allclose(vec(origin.get("xyz")), 0, atol=TOL)
            np.testing.assert_allclose(vec(origin.get("rpy")), 0, atol=TOL)
    assert set(FACT_JOINT_BY_NAME) <= set(joints)
    assert len(joints) == len(FACT_JOINTS) + 2


@pytest.mark.parametrize("fact", FACT_JOINTS, ids=lambda j: j.name)
def test_urdf_joint_matches_facts(urdf_root, fact: FactJoint):
    joint = next(j for j in urdf_root.findall("joint") if j.get("name") == fact.name)
    assert joint.get("type") == fact.type
    assert joint.find("parent").get("link") == fact.parent
    assert joint.find("child").get("link") == fact.child
    origin = joint.find("origin")
    np.testing.assert_allclose(vec(origin.get("xyz")), fact.xyz, atol=TOL)
    np.testing.assert_allclose(vec(origin.get("rpy")), fact.rpy, atol=TOL)
    mimic = joint.find("mimic")
    if fact.type == "fixed":
        assert joint.find("limit") is None and mimic is None
        return
    np.testing.assert_allclose(vec(joint.find("axis").get("xyz")), (0, 0, 1), atol=TOL)
    limit = joint.find("limit")
    assert float(limit.get("lower")) == pytest.approx(fact.limits[0], abs=TOL)
    assert float(limit.get("upper")) == pytest.approx(fact.limits[1], abs=TOL)
    assert float(limit.get("velocity")) == pytest.approx(ARM_MAX_VELOCITY, abs=TOL)
    assert float(limit.get("effort")) > 0
    if fact.mimic_multiplier is None:
        assert mimic is None
    else:
        assert mimic is not None, f"{fact.name} must mimic gripper_controller"
        assert mimic.get("joint") == GRIPPER_JOINT
        assert float(mimic.get("multiplier")) == pytest.approx(fact.mimic_multiplier, abs=TOL)
        assert float(mimic.get("offset", "0")) == pytest.approx(0.0, abs=TOL)


def test_pinocchio_model_limits_match_facts(robot: PinRobot):
    model = robot.model
    for fact in FACT_JOINTS:
        if fact.type != "revolute":
            continue
        jid = model.getJointId(fact.name)
        assert jid < model.njoints, f"pinocchio has no joint {fact.name}"
        iq = model.idx_qs[jid]
        assert model.lowerPositionLimit[iq] == pytest.approx(fact.limits[0], abs=TOL)
        assert model.upperPositionLimit[iq] == pytest.approx(fact.limits[1], abs=TOL)
        assert model.velocityLimit[model.idx_vs[jid]] == pytest.approx(ARM_MAX_VELOCITY, abs=TOL)


def test_every_link_has_plausible_inertia_so_dynamics_run(urdf_root, robot: PinRobot):
    for link in urdf_root.findall("link"):
        if link.get("name") == "world":
            continue
        inertial = link.find("inertial")
        assert inertial is not None, f"{link.get('name')} has no <inertial>"
        mass = float(inertial.find("mass").get("value"))
        assert 0 < mass < 1.0
        i = inertial.find("inertia")
        tensor = np.array(
            [
                [float(i.get("ixx")), float(i.get("ixy")), float(i.get("ixz"))],
                [float(i.get("ixy")), float(i.get("iyy")), float(i.get("iyz"))],
                [float(i.get("ixz")), float(i.get("iyz")), float(i.get("izz"))],
            ]
        )
        assert np.all(np.linalg.eigvalsh(tensor) > 0)
    model = robot.model
    data = model.createData()
    q = robot.q({**ARM_STATES["ready"], GRIPPER_JOINT: -0.34})
    tau = pin.rnea(model, data, q, np.zeros(model.nv), np.zeros(model.nv))
    assert np.all(np.isfinite(tau))
    # Gravity loads the shoulder when the forearm is held out horizontally.
    assert abs(tau[model.idx_vs[model.getJointId("link2_to_link3")]]) > 1e-3


# --------------------------------------------------------------------------------------------
# Forward kinematics: independent numpy vs pinocchio
# --------------------------------------------------------------------------------------------

FK_CASES = [("home", ARM_STATES["home"]), ("ready", ARM_STATES["ready"])] + [
    (f"random{i}", s) for i, s in enumerate(random_arm_states(20, seed=20240501))
]


@pytest.mark.parametrize("label,arm", FK_CASES, ids=[c[0] for c in FK_CASES])
def test_flange_and_gripper_base_fk_match_independent_numpy(robot: PinRobot, label, arm):
    q = robot.q({**arm, GRIPPER_JOINT: 0.0})
    expected = numpy_fk(full_positions(arm, 0.0))
    for link in ("link6_flange", "gripper_base"):
        got = robot.frame_pose(q, link)
        np.testing.assert_allclose(got[:3, 3], expected[link][:3, 3], atol=TOL, err_msg=f"{label} {link} position")
        np.testing.assert_allclose(got[:3, :3], expected[link][:3, :3], atol=TOL, err_msg=f"{label} {link} rotation")


def test_home_and_ready_poses_are_where_the_arm_geometry_puts_them():
    """Hand-checkable numbers: at home the arm stands straight up, the flange facing +y."""
    home = numpy_fk(full_positions(ARM_STATES["home"], 0.0))
    # Height: 0.13156 - 0.001 + 0.1104 + 0.096 + 0.07318 (links 2..6 stacked vertically).
    np.testing.assert_allclose(home["link6_flange"][:3, 3], (0.06062, 0.0456, 0.41014), atol=1e-9)
    np.testing.assert_allclose(home["link6_flange"][:3, 2], (0, 1, 0), atol=1e-9)
    np.testing.assert_allclose(home["gripper_base"][:3, 3], (0.06062, 0.0796, 0.41014), atol=1e-9)
    ready = numpy_fk(full_positions(ARM_STATES["ready"], 0.0))
    # Ready: upper arm up to the elbow at z = 0.13056 + 0.1104, forearm out along -y (0.096),
    # wrist down (0.07318), flange offset 0.0456 further along -y, facing -y.
    # (1.5708 is not exactly pi/2, hence the 1e-6 tolerance.)
    np.testing.assert_allclose(ready["link6_flange"][:3, 3], (0.06062, -0.1416, 0.16778), atol=1e-6)
    np.testing.assert_allclose(ready["link6_flange"][:3, 2], (0, -1, 0), atol=1e-5)
    # Within the ~0.28 m reach from the base axis.
    assert np.linalg.norm(ready["link6_flange"][:2, 3]) < 0.28


GRIPPER_CASES = [(name, value) for name, value in GRIPPER_STATES.items()] + [
    ("lower_limit", -0.7),
    ("upper_limit", 0.15),
    ("random", float(np.random.default_rng(7).uniform(-0.7, 0.15))),
]


@pytest.mark.parametrize("label,gripper", GRIPPER_CASES, ids=[c[0] for c in GRIPPER_CASES])
def test_mimic_fingers_fk_match_independent_numpy(robot: PinRobot, label, gripper):
    """Fingers are placed through the URDF's <mimic> tags on the pinocchio side and through the
    facts' multipliers on the numpy side; random arm states check the whole chain to the tips."""
    arms = [ARM_STATES["home"], ARM_STATES["ready"], *random_arm_states(3, seed=99)]
    for arm in arms:
        q = robot.q({**arm, GRIPPER_JOINT: gripper})
        expected = numpy_fk(full_positions(arm, gripper))
        for link in GRIPPER_LINKS:
            got = robot.frame_pose(q, link)
            np.testing.assert_allclose(got, expected[link], atol=TOL, err_msg=f"{label}: {link}")


def test_gripper_closing_moves_fingertips_together(robot: PinRobot):
    """Sanity of the mimic signs: from open to closed the fingertip boxes approach each other."""

    def tip_gap(gripper: float) -> float:
        q = robot.q({**ARM_STATES["home"], GRIPPER_JOINT: gripper})
        left = robot.frame_pose(q, "gripper_left1") @ origin_transform(FACT_SHAPES["gripper_left1"][2], (0, 0, 0))
        right = robot.frame_pose(q, "gripper_right1") @ origin_transform(FACT_SHAPES["gripper_right1"][2], (0, 0, 0))
        return float(np.linalg.norm(left[:3, 3] - right[:3, 3]))

    assert tip_gap(GRIPPER_STATES["closed"]) < tip_gap(GRIPPER_STATES["half_closed"]) < tip_gap(GRIPPER_STATES["open"])


# --------------------------------------------------------------------------------------------
# Collision shapes
# --------------------------------------------------------------------------------------------


def _geometry_of(element: ET.Element) -> tuple[str, tuple[float, ...], np.ndarray, np.ndarray]:
    geometry = element.find("geometry")
    shapes = list(geometry)
    assert len(shapes) == 1
    shape = shapes[0]
    if shape.tag == "box":
        dims = tuple(vec(shape.get("size")))
    elif shape.tag == "cylinder":
        dims = (float(shape.get("radius")), float(shape.get("length")))
    else:
        raise AssertionError(f"unexpected shape <{shape.tag}>")
    origin = element.find("origin")
    xyz = vec(origin.get("xyz") if origin is not None else None)
    rpy = vec(origin.get("rpy") if origin is not None else None)
    return shape.tag, dims, xyz, rpy


@pytest.mark.parametrize("link_name", sorted(FACT_SHAPES))
def test_link_collision_and_visual_shapes_match_facts(urdf_root, link_name):
    kind, dims, xyz, rpy = FACT_SHAPES[link_name]
    link = next(link for link in urdf_root.findall("link") if link.get("name") == link_name)
    collisions = link.findall("collision")
    assert len(collisions) == 1, f"{link_name} needs exactly one collision primitive"
    got_kind, got_dims, got_xyz, got_rpy = _geometry_of(collisions[0])
    assert got_kind == kind
    np.testing.assert_allclose(got_dims, dims, atol=TOL)
    np.testing.assert_allclose(got_xyz, xyz, atol=TOL)
    np.testing.assert_allclose(got_rpy, rpy, atol=TOL)
    # Visual repeats the primitive so a viewer draws what collision checking uses.
    visuals = link.findall("visual")
    assert len(visuals) == 1
    v_kind, v_dims, v_xyz, v_rpy = _geometry_of(visuals[0])
    assert (v_kind, v_dims) == (got_kind, got_dims)
    np.testing.assert_allclose(v_xyz, got_xyz, atol=TOL)
    np.testing.assert_allclose(v_rpy, got_rpy, atol=TOL)


def test_pinocchio_collision_geometry_matches_facts(robot: PinRobot):
    by_link = {}
    for obj in robot.geom.geometryObjects:
        by_link.setdefault(robot.model.frames[obj.parentFrame].name, []).append(obj)
    assert set(by_link) == set(FACT_SHAPES)
    for link, (kind, dims, xyz, rpy) in FACT_SHAPES.items():
        (obj,) = by_link[link]
        shape = obj.geometry
        if kind == "box":
            assert isinstance(shape, coal.Box)
            np.testing.assert_allclose(2 * np.asarray(shape.halfSide), dims, atol=TOL)
        else:
            assert isinstance(shape, coal.Cylinder)
            assert shape.radius == pytest.approx(dims[0], abs=TOL)
            assert 2 * shape.halfLength == pytest.approx(dims[1], abs=TOL)
        # Link frames in pinocchio sit at their joint with identity placement for these URDF
        # joints, so the geometry placement relative to the joint is the facts' shape origin.
        frame = robot.model.frames[obj.parentFrame]
        expected = frame.placement.homogeneous @ origin_transform(xyz, rpy)
        np.testing.assert_allclose(obj.placement.homogeneous, expected, atol=TOL)


# --------------------------------------------------------------------------------------------
# SRDF
# --------------------------------------------------------------------------------------------


def test_srdf_names_only_existing_links_joints_and_groups(srdf_root, urdf_root):
    links = {link.get("name") for link in urdf_root.findall("link")}
    joints = {j.get("name") for j in urdf_root.findall("joint")}
    assert srdf_root.get("name") == "mycobot_280"
    groups = {g.get("name") for g in srdf_root.findall("group")}
    for group in srdf_root.findall("group"):
        for child in group:
            if child.tag == "joint":
                assert child.get("name") in joints, child.get("name")
            elif child.tag == "link":
                assert child.get("name") in links, child.get("name")
            elif child.tag == "chain":
                assert child.get("base_link") in links and child.get("tip_link") in links
            elif child.tag == "group":
                assert child.get("name") in groups
    for state in srdf_root.findall("group_state"):
        assert state.get("group") in groups
        for joint in state.findall("joint"):
            assert joint.get("name") in joints, joint.get("name")
    for ee in srdf_root.findall("end_effector"):
        assert ee.get("parent_link") in links
        assert ee.get("group") in groups
        assert ee.get("parent_group") in groups
    for vj in srdf_root.findall("virtual_joint"):
        assert vj.get("child_link") in links
    for pair in srdf_root.findall("disable_collisions"):
        assert pair.get("link1") in links and pair.get("link2") in links
        assert pair.get("reason"), "every disabled pair needs a reason"


def test_srdf_semantics_match_facts(srdf_root):
    groups = {g.get("name"): g for g in srdf_root.findall("group")}
    assert set(groups) == {"arm", "gripper", "arm_with_gripper"}
    assert [j.get("name") for j in groups["arm"].findall("joint")] == ARM_JOINTS + ["link6_flange_to_gripper_base"]
    assert [j.get("name") for j in groups["gripper"].findall("joint")] == [GRIPPER_JOINT]
    assert sorted(g.get("name") for g in groups["arm_with_gripper"].findall("group")) == ["arm", "gripper"]

    (vj,) = srdf_root.findall("virtual_joint")
    assert (vj.get("type"), vj.get("parent_frame"), vj.get("child_link")) == ("fixed", "world", "base_link")

    (ee,) = srdf_root.findall("end_effector")
    assert ee.get("name") == "gripper"
    assert ee.get("parent_link") == "link6_flange"
    assert ee.get("group") == "gripper"
    assert ee.get("parent_group") == "arm"

    states = {
        (s.get("group"), s.get("name")): {j.get("name"): float(j.get("value")) for j in s.findall("joint")}
        for s in srdf_root.findall("group_state")
    }
    expected = {("arm", n): v for n, v in ARM_STATES.items()}
    expected.update({("gripper", n): {GRIPPER_JOINT: v} for n, v in GRIPPER_STATES.items()})
    expected.update({("arm_with_gripper", n): {**v, GRIPPER_JOINT: 0.0} for n, v in ARM_STATES.items()})
    assert set(states) == set(expected)
    for key, values in expected.items():
        assert states[key].keys() == values.keys(), key
        for joint, value in values.items():
            assert states[key][joint] == pytest.approx(value, abs=TOL), (key, joint)


def test_srdf_disables_every_facts_pair_once(srdf_root):
    pairs = [frozenset((p.get("link1"), p.get("link2"))) for p in srdf_root.findall("disable_collisions")]
    assert len(pairs) == len(set(pairs)), "duplicate disable_collisions entries"
    assert all(len(p) == 2 for p in pairs), "a link paired with itself"
    missing = FACT_DISABLED_PAIRS - set(pairs)
    assert not missing, f"facts pairs not disabled: {sorted(tuple(sorted(p)) for p in missing)}"


def test_named_states_lie_within_limits():
    for arm in ARM_STATES.values():
        for joint, value in arm.items():
            lo, hi = FACT_JOINT_BY_NAME[joint].limits
            assert lo <= value <= hi
    for value in GRIPPER_STATES.values():
        lo, hi = FACT_JOINT_BY_NAME[GRIPPER_JOINT].limits
        assert lo <= value <= hi


# --------------------------------------------------------------------------------------------
# Self-collision with the SRDF's allowed pairs removed
# --------------------------------------------------------------------------------------------


@pytest.mark.parametrize("gripper_state", sorted(GRIPPER_STATES))
@pytest.mark.parametrize("arm_state", sorted(ARM_STATES))
def test_no_self_collision_in_named_states(robot: PinRobot, arm_state, gripper_state):
    q = robot.q({**ARM_STATES[arm_state], GRIPPER_JOINT: GRIPPER_STATES[gripper_state]})
    assert robot.colliding_pairs(q) == []


def test_active_pairs_do_detect_self_collision(robot: PinRobot):
    """Guards against the named-state test passing vacuously (e.g. every pair disabled): folding
    the upper arm back down onto the base must be reported, by pairs that are still checked."""
    active = {frozenset(robot.pair_names(p)) for p in robot.geom.collisionPairs}
    assert frozenset(("link1", "link4")) in active
    assert frozenset(("link3", "link6")) in active
    folded = {**ARM_STATES["home"], "link2_to_link3": 2.6, "link3_to_link4": 2.6}
    hits = robot.colliding_pairs(robot.q({**folded, GRIPPER_JOINT: 0.0}))
    assert hits, "folded arm must collide with itself"
    disabled = FACT_DISABLED_PAIRS
    assert all(frozenset(h) not in disabled for h in hits)


def test_srdf_removes_exactly_its_pairs(robot: PinRobot, srdf_root):
    n = len(FACT_SHAPES)
    disabled = {frozenset((p.get("link1"), p.get("link2"))) for p in srdf_root.findall("disable_collisions")}
    assert len(robot.geom.collisionPairs) == n * (n - 1) // 2 - len(disabled)
    active = {frozenset(robot.pair_names(p)) for p in robot.geom.collisionPairs}
    assert not active & disabled


# --------------------------------------------------------------------------------------------
# YAML files
# --------------------------------------------------------------------------------------------


def test_joint_limits_yaml(config_dir: Path, urdf_root):
    data = yaml.safe_load((config_dir / "joint_limits.yaml").read_text())
    assert data["default_velocity_scaling_factor"] == 1.0
    assert data["default_acceleration_scaling_factor"] == 1.0
    limits = data["joint_limits"]
    assert set(ARM_JOINTS) <= set(limits)
    assert GRIPPER_JOINT in limits
    urdf_joints = {j.get("name") for j in urdf_root.findall("joint")}
    assert set(limits) <= urdf_joints
    for joint in ARM_JOINTS:
        entry = limits[joint]
        assert entry["has_velocity_limits"] is True
        assert entry["max_velocity"] == pytest.approx(ARM_MAX_VELOCITY, abs=TOL)
        assert entry["has_acceleration_limits"] is True
        assert entry["max_acceleration"] == pytest.approx(ARM_MAX_ACCELERATION, abs=TOL)
        assert entry["has_jerk_limits"] is False
    for joint, entry in limits.items():
        for key in ("max_velocity", "max_acceleration"):
            assert isinstance(entry[key], float) and entry[key] > 0, (joint, key)


def test_kinematics_yaml(config_dir: Path):
    data = yaml.safe_load((config_dir / "kinematics.yaml").read_text())
    assert set(data) == {"arm", "gripper"}
    for group, attempts in (("arm", 5), ("gripper", 3)):
        entry = data[group]
        assert isinstance(entry["kinematics_solver"], str) and entry["kinematics_solver"]
        assert entry["kinematics_solver_search_resolution"] == pytest.approx(0.005)
        assert entry["kinematics_solver_timeout"] == pytest.approx(0.05)
        assert entry["kinematics_solver_attempts"] == attempts
        assert entry.get("position_only_ik", False) is False
