"""Batch collision check: many states of one group in one compiled call over sphere models.

The exact check (Pinocchio + Coal) costs 5-11 µs a state, most of it per-state overhead; an
edge's states are known together, so they are first tested together here: forward kinematics
of the robot's joint tree and the world positions of spheres that contain every link (and
attached object) for N states at once, then each state's spheres against the world's objects
(distance to a box, sphere, cylinder or capsule; any other object as its bounding box) and
against each other for the self pairs the allowed collision matrix leaves active. A state whose
spheres are clear of everything by more than the security margin is collision-free, because the
spheres contain the geometry; any other state is undecided and goes to the exact check. So the
answer is never a false "free" and the verdicts are the exact check's.

Compiled with numba (``cache=True``: the first call of a fresh install compiles for a few
seconds, later processes load the cached machine code; ``nogil=True``: threads run it at once).
When numba or a supported model is missing, ``build_batch_check`` returns None and callers
check state by state as before. The full story: docs/core.md, section
mycobot_planning.core.collision_detection.batch_check.
"""
from __future__ import annotations

import logging
import math
import dataclasses
from dataclasses import dataclass
from typing import Sequence

import coal
import numpy as np
import pinocchio as pin

from ..jit import compiled, numba_available

__all__ = ["BATCH_MARGIN", "BATCH_RULE_SAMPLES", "MIN_FREE_SHARE", "BatchCheck", "build_batch_check", "joint_kind",
           "joint_kinematics", "joint_tables", "numba_available", "one_state_free"]

_LOG = logging.getLogger(__name__)

#: A state is free only when every sphere is this much further from everything than the exact
#: check's security margin asks (m; the caller adds it to the margin it passes): room for the rounding of two forward kinematics and of
#: Coal's distance, far above both and far below anything a planner could notice.
BATCH_MARGIN = 1e-5
#: The batch test is used for a group only when it calls at least this share of random states of
#: the group free (sampled once when it is built): below that, most states pay the sphere test
#: and the exact check both (on a cluttered scene, or a robot whose spheres always overlap).
MIN_FREE_SHARE = 0.1
#: how many random states that rule samples
BATCH_RULE_SAMPLES = 256

# joint kinds of the compiled forward kinematics
_FIXED, _REVOLUTE, _PRISMATIC, _UNBOUNDED = 0, 1, 2, 3
# obstacle kinds: the world's objects as distance functions in their own frame
_BOX, _SPHERE, _CYLINDER, _CAPSULE = 0, 1, 2, 3
_AXES = {"X": (1.0, 0.0, 0.0), "Y": (0.0, 1.0, 0.0), "Z": (0.0, 0.0, 1.0)}
# the int table's header: joint, body, sphere, world test, self test and obstacle counts, the
# int tables' offsets (6-15), and last where the float tables' offsets are
_HEADER = 17


def joint_kind(joint: pin.JointModel) -> tuple[int, tuple[float, float, float]] | None:
    """(kind, axis) of one Pinocchio joint as the compiled forward kinematics sees it; None
    when it is neither revolute, prismatic nor unbounded revolute about one axis (free flyers,
    planar, spherical, mimic...)."""
    name = joint.shortname()
    if name in ("JointModelRX", "JointModelRY", "JointModelRZ"):
        return _REVOLUTE, _AXES[name[-1]]
    if name in ("JointModelPX", "JointModelPY", "JointModelPZ"):
        return _PRISMATIC, _AXES[name[-1]]
    if name in ("JointModelRUBX", "JointModelRUBY", "JointModelRUBZ"):
        return _UNBOUNDED, _AXES[name[-1]]
    if name == "JointModelRevoluteUnaligned":
        return _REVOLUTE, tuple(joint.extract().axis)
    if name == "JointModelPrismaticUnaligned":
        return _PRISMATIC, tuple(joint.extract().axis)
    if name == "JointModelRevoluteUnboundedUnaligned":
        return _UNBOUNDED, tuple(joint.extract().axis)
    return None


def joint_tables(pin_model: pin.Model) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray] | None:
    """(parents, kinds, configuration index, axes (nj, 3), placements (nj, 4, 4)) of every joint,
    read from the Pinocchio model; None when a joint is one joint_kind does not know."""
    nj = pin_model.njoints
    parents = np.zeros(nj, dtype=np.int64)
    kinds = np.zeros(nj, dtype=np.int64)
    index = np.zeros(nj, dtype=np.int64)
    axes = np.zeros((nj, 3))
    placements = np.tile(np.eye(4), (nj, 1, 1))
    for j in range(1, nj):
        joint = pin_model.joints[j]
        kind = joint_kind(joint)
        if kind is None:
            return None
        parents[j] = pin_model.parents[j]
        index[j] = joint.idx_q
        placements[j] = pin_model.jointPlacements[j].homogeneous
        kinds[j], axes[j] = kind
    return parents, kinds, index, axes, placements


def _obstacle(geometry: coal.CollisionGeometry, placement: np.ndarray) -> tuple[int, np.ndarray, np.ndarray] | None:
    """(kind, world pose 4x4, dimensions) of a world object's shape as the batch test sees it:
    boxes, spheres, cylinders and capsules as they are, a cone as its cylinder, a mesh, convex or
    ellipsoid as its bounding box (each contains the shape, so clear of it is clear of the
    shape); None for anything else (octree, plane, half-space, height field)."""
    if isinstance(geometry, coal.Box):
        return _BOX, placement, np.asarray(geometry.halfSide, dtype=float)
    if isinstance(geometry, coal.Sphere):
        return _SPHERE, placement, np.array([geometry.radius, 0.0, 0.0])
    if isinstance(geometry, (coal.Cylinder, coal.Cone)):
        return _CYLINDER, placement, np.array([geometry.radius, geometry.halfLength, 0.0])
    if isinstance(geometry, coal.Capsule):
        return _CAPSULE, placement, np.array([geometry.radius, geometry.halfLength, 0.0])
    if isinstance(geometry, (coal.BVHModelBase, coal.ConvexBase, coal.Ellipsoid)):
        geometry.computeLocalAABB()
        box = geometry.aabb_local
        low, high = np.asarray(box.min_, dtype=float), np.asarray(box.max_, dtype=float)
        if not (np.all(np.isfinite(low)) and np.all(high >= low)):
            return None
        shifted = placement.copy()
        shifted[:3, 3] = placement[:3, :3] @ (0.5 * (low + high)) + placement[:3, 3]
        return _BOX, shifted, 0.5 * (high - low)
    return None


@dataclass(frozen=True)
class BatchCheck:
    """A compiled scene's sphere test for one group: states that differ from ``q_ref`` in the
    Pinocchio configuration ``slots`` only. ``free(values)`` takes (N, len(slots)) values and
    says, per state, whether it is certainly collision-free (False: undecided)."""

    q_ref: np.ndarray
    slots: np.ndarray
    ints: np.ndarray
    floats: np.ndarray
    spheres: int
    world_tests: int
    self_tests: int
    #: the tables with ``slots`` and ``q_ref`` appended (see _one_state_tables): the one-state
    #: call then takes three arguments, and a compiled call's cost grows with their count
    one_ints: np.ndarray = dataclasses.field(init=False, repr=False, compare=False)
    one_floats: np.ndarray = dataclasses.field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        one_ints, one_floats = _one_state_tables(self.ints, self.floats, self.slots, self.q_ref)
        object.__setattr__(self, "one_ints", one_ints)
        object.__setattr__(self, "one_floats", one_floats)

    def free(self, values: np.ndarray) -> np.ndarray:
        values = np.ascontiguousarray(values, dtype=np.float64)
        if values.ndim == 1:
            values = values.reshape(1, -1)
        if values.ndim != 2 or values.shape[1] != len(self.slots):
            raise ValueError(f"expected (N, {len(self.slots)}) states, got shape {values.shape}")
        out = np.empty(values.shape[0], dtype=np.bool_)
        _free_states(values, self.q_ref, self.slots, self.ints, self.floats, out)
        return out


def build_batch_check(
    pin_model: pin.Model,
    geometry_model: pin.GeometryModel,
    pairs: Sequence[tuple[int, int]],
    robot_geometries: Sequence[bool],
    q_ref: np.ndarray,
    slots: np.ndarray,
    covers: Sequence[tuple[np.ndarray, np.ndarray] | None],
    margin: float,
    sample: np.ndarray,
) -> BatchCheck | None:
    """The batch test of ``pairs`` (geometry index pairs: robot-robot, robot-world), or None
    when it cannot be built (no numba, a joint or shape it does not model) or does not pay
    (it calls less than MIN_FREE_SHARE of the ``sample`` rows of slot values free: random
    states of the group, BATCH_RULE_SAMPLES of them).
    ``robot_geometries[g]``: geometry g moves with the robot (link or attached object), and
    ``covers[g]`` is then its enclosing spheres in its own shape frame."""
    if not numba_available() or not len(slots):
        return None
    tables = joint_tables(pin_model)
    if tables is None:
        return None
    parents, kinds, index, axes, placements = tables
    objects = geometry_model.geometryObjects
    body_of: dict[int, int] = {}  # geometry -> body (a covered geometry) index
    bodies: list[tuple[int, np.ndarray, np.ndarray]] = []  # (joint, centres in its frame, radii)
    obstacle_of: dict[int, int] = {}
    obstacles: list[tuple[int, np.ndarray, np.ndarray]] = []
    world_pairs: list[tuple[int, int]] = []
    self_pairs: list[tuple[int, int]] = []

    def body(g: int) -> int | None:
        found = body_of.get(g)
        if found is None:
            cover = covers[g]
            if cover is None:
                return None
            local, r = cover
            placement = objects[g].placement.homogeneous
            found = body_of[g] = len(bodies)
            bodies.append((int(objects[g].parentJoint), local @ placement[:3, :3].T + placement[:3, 3],
                           np.asarray(r, dtype=float)))
        return found

    for i, j in pairs:
        if robot_geometries[i] and robot_geometries[j]:
            a, b = body(i), body(j)
            if a is None or b is None:
                return None
            self_pairs.append((a, b))
            continue
        mover, world = (i, j) if robot_geometries[i] else (j, i)
        if robot_geometries[world] or not robot_geometries[mover]:
            return None  # world-world pairs are never checked; anything else is not modelled
        a = body(mover)
        if a is None:
            return None
        o = obstacle_of.get(world)
        if o is None:
            shape = _obstacle(objects[world].geometry, objects[world].placement.homogeneous)
            if shape is None:
                return None
            o = obstacle_of[world] = len(obstacles)
            obstacles.append(shape)
        world_pairs.append((a, o))
    ints, floats = _pack(parents, kinds, index, axes, placements, bodies, world_pairs, obstacles, self_pairs, margin)
    spheres = sum(len(r) for _, _, r in bodies)
    check = BatchCheck(np.ascontiguousarray(q_ref, dtype=np.float64), np.asarray(slots, dtype=np.int64),
                       ints, floats, spheres, len(world_pairs), len(self_pairs))
    share = float(np.mean(check.free(sample)))
    if share < MIN_FREE_SHARE:
        _LOG.debug("batch collision check not used: it decides %.0f%% of random states", 100.0 * share)
        return None
    return check


def _outer_spheres(centres: np.ndarray, radii: np.ndarray, counts: np.ndarray) -> np.ndarray:
    """Each body's bounding sphere (centre, radius) around its ``counts[k]`` consecutive spheres:
    the centre of their bounding box, the radius reaching the farthest sphere's far side. One
    reduction per quantity over all bodies (a loop per body cost ~20 us a body in NumPy calls)."""
    outer = np.zeros((len(counts), 4))
    if not len(counts):
        return outer
    if np.any(counts < 1):
        raise ValueError("every covered body needs at least one sphere")
    starts = np.concatenate([[0], np.cumsum(counts)[:-1]])
    middle = 0.5 * (np.minimum.reduceat(centres - radii[:, None], starts, axis=0)
                    + np.maximum.reduceat(centres + radii[:, None], starts, axis=0))
    reach = np.linalg.norm(centres - np.repeat(middle, counts, axis=0), axis=1) + radii
    outer[:, :3] = middle
    outer[:, 3] = np.maximum.reduceat(reach, starts) * (1.0 + 1e-12)
    return outer


def _pack(parents, kinds, index, axes, placements, bodies, world_pairs, obstacles, self_pairs,
          margin) -> tuple[np.ndarray, np.ndarray]:
    """Every table in one int and one float array (a compiled call's cost grows with its
    argument count): the int table's header holds the counts and each table's offset. Each
    body (a covered geometry) has its spheres, consecutive, and one sphere around them all
    that the tests try first."""
    nj = len(parents)
    joints = np.asarray([b[0] for b in bodies], dtype=np.int64)
    counts = np.asarray([len(b[2]) for b in bodies], dtype=np.int64)
    first = np.concatenate([[0], np.cumsum(counts)]).astype(np.int64)
    centres = np.vstack([b[1] for b in bodies]) if bodies else np.zeros((0, 3))
    radii = np.concatenate([b[2] for b in bodies]) if bodies else np.zeros(0)
    outer = _outer_spheres(centres, radii, counts)
    world = np.asarray(world_pairs, dtype=np.int64).reshape(-1, 2)
    pairs = np.asarray(self_pairs, dtype=np.int64).reshape(-1, 2)
    obstacle_kinds = np.asarray([o[0] for o in obstacles], dtype=np.int64)
    poses = np.asarray([o[1] for o in obstacles], dtype=float).reshape(-1, 4, 4)
    dims = np.asarray([o[2] for o in obstacles], dtype=float).reshape(-1, 3)
    int_parts = [parents, kinds, index, joints, first, world[:, 0], world[:, 1], obstacle_kinds, pairs[:, 0],
                 pairs[:, 1]]
    float_parts = [np.array([margin]), axes.ravel(), placements[:, :3, :3].ravel(), placements[:, :3, 3].ravel(),
                   centres.ravel(), radii, outer.ravel(), poses[:, :3, :3].ravel(), poses[:, :3, 3].ravel(),
                   dims.ravel()]
    header = np.zeros(_HEADER, dtype=np.int64)
    header[:6] = nj, len(bodies), len(radii), len(world), len(pairs), len(obstacles)
    offset = _HEADER + len(int_parts) + len(float_parts)
    for k, part in enumerate(int_parts):
        header[6 + k] = offset
        offset += len(part)
    float_offsets = np.zeros(len(float_parts), dtype=np.int64)
    offset = 0
    for k, part in enumerate(float_parts):
        float_offsets[k] = offset
        offset += len(part)
    ints = np.concatenate([header, np.zeros(len(int_parts), dtype=np.int64), float_offsets]
                          + [np.asarray(p, dtype=np.int64) for p in int_parts])
    ints[_HEADER - 1] = _HEADER + len(int_parts)  # where the float offsets are
    return np.ascontiguousarray(ints), np.ascontiguousarray(np.concatenate(float_parts), dtype=np.float64)


def _one_state_tables(ints: np.ndarray, floats: np.ndarray, slots: np.ndarray,
                      q_ref: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``ints`` + ``slots`` + [where q_ref starts in the floats, where the slots start] and
    ``floats`` + ``q_ref``: one_state_free reads them from the ends."""
    one_ints = np.concatenate([ints, np.asarray(slots, dtype=np.int64), [len(floats), len(ints)]]).astype(np.int64)
    one_floats = np.concatenate([floats, np.asarray(q_ref, dtype=np.float64)])
    return np.ascontiguousarray(one_ints), np.ascontiguousarray(one_floats)


@compiled
def _obstacle_distance(kind, dims, px, py, pz):  # pragma: no cover - compiled
    """Distance from a point (in the obstacle's frame) to a box, sphere, cylinder or capsule
    (0 inside a box or cylinder, negative inside a sphere or capsule)."""
    if kind == 0:
        ex = max(abs(px) - dims[0], 0.0)
        ey = max(abs(py) - dims[1], 0.0)
        ez = max(abs(pz) - dims[2], 0.0)
        return math.sqrt(ex * ex + ey * ey + ez * ez)
    if kind == 1:
        return math.sqrt(px * px + py * py + pz * pz) - dims[0]
    if kind == 2:
        er = max(math.sqrt(px * px + py * py) - dims[0], 0.0)
        ez = max(abs(pz) - dims[1], 0.0)
        return math.sqrt(er * er + ez * ez)
    zc = min(max(pz, -dims[1]), dims[1])
    return math.sqrt(px * px + py * py + (pz - zc) * (pz - zc)) - dims[0]


@compiled
def _place(rot, trans, j, local, out):  # pragma: no cover - compiled
    for i in range(3):
        out[i] = rot[j, i, 0] * local[0] + rot[j, i, 1] * local[1] + rot[j, i, 2] * local[2] + trans[j, i]


@compiled
def joint_kinematics(q, parents, kinds, index, axes, rot0, trans0, rot, trans, base, local_rot):  # pragma: no cover
    """Every joint's world rotation and translation at configuration q, joints in tree order
    (a parent before its children; row 0 is the root, set by the caller)."""
    for j in range(1, parents.shape[0]):
        p = parents[j]
        for i in range(3):  # base = rot[p] @ rot0[j]; trans[j] = rot[p] @ trans0[j] + trans[p]
            t = trans[p, i]
            for k in range(3):
                base[i, k] = rot[p, i, 0] * rot0[j, 0, k] + rot[p, i, 1] * rot0[j, 1, k] + rot[p, i, 2] * rot0[j, 2, k]
                t += rot[p, i, k] * trans0[j, k]
            trans[j, i] = t
        kind = kinds[j]
        if kind == 1 or kind == 3:
            if kind == 1:
                c = math.cos(q[index[j]])
                sn = math.sin(q[index[j]])
            else:
                c = q[index[j]]
                sn = q[index[j] + 1]
            x, y, z = axes[j, 0], axes[j, 1], axes[j, 2]
            # about a coordinate axis k (either sign: most URDF joints), the next two columns of
            # the parent's rotation (cyclically) mix and column k stays
            k = 2 if x == 0.0 and y == 0.0 else (0 if y == 0.0 and z == 0.0 else (1 if x == 0.0 and z == 0.0 else -1))
            if k >= 0:
                sn *= axes[j, k]
                u = (k + 1) % 3
                w = (k + 2) % 3
                for i in range(3):
                    bu = base[i, u]
                    bw = base[i, w]
                    rot[j, i, u] = c * bu + sn * bw
                    rot[j, i, w] = c * bw - sn * bu
                    rot[j, i, k] = base[i, k]
                continue
            v = 1.0 - c
            local_rot[0, 0] = c + x * x * v
            local_rot[0, 1] = x * y * v - z * sn
            local_rot[0, 2] = x * z * v + y * sn
            local_rot[1, 0] = y * x * v + z * sn
            local_rot[1, 1] = c + y * y * v
            local_rot[1, 2] = y * z * v - x * sn
            local_rot[2, 0] = z * x * v - y * sn
            local_rot[2, 1] = z * y * v + x * sn
            local_rot[2, 2] = c + z * z * v
            for i in range(3):
                for k in range(3):
                    rot[j, i, k] = base[i, 0] * local_rot[0, k] + base[i, 1] * local_rot[1, k] + \
                        base[i, 2] * local_rot[2, k]
        else:
            for i in range(3):
                for k in range(3):
                    rot[j, i, k] = base[i, k]
            if kind == 2:
                d = q[index[j]]
                for i in range(3):
                    trans[j, i] += d * (base[i, 0] * axes[j, 0] + base[i, 1] * axes[j, 1] + base[i, 2] * axes[j, 2])


#: states per call from which _free_states first folds the joints no slot drives into their
#: parents' placements (one kinematics pass at q_ref): below it the pass costs what it saves
HOLD_MIN_STATES = 16


@compiled
def _held_joints(q, slots, parents, kinds, index, axes, rot0, trans0, rot, trans, base, local_rot):  # pragma: no cover
    """(kinds, rot0, trans0) with every joint that no slot drives made fixed at its place in
    ``q`` (its placement and motion folded into one: the transform from its parent's frame at
    ``q``), so the kinematics of each state skip their trigonometry and one product; the
    joints the slots drive are unchanged."""
    joint_kinematics(q, parents, kinds, index, axes, rot0, trans0, rot, trans, base, local_rot)
    held_kinds = kinds.copy()
    held_rot = rot0.copy()
    held_trans = trans0.copy()
    for j in range(1, parents.shape[0]):
        kind = kinds[j]
        if kind == 0:
            continue
        driven = False
        for k in range(slots.shape[0]):
            if slots[k] == index[j] or (kind == 3 and slots[k] == index[j] + 1):
                driven = True
        if driven:
            continue
        p = parents[j]
        held_kinds[j] = 0
        for i in range(3):  # rot[p]^T rot[j] and rot[p]^T (trans[j] - trans[p])
            held_trans[j, i] = rot[p, 0, i] * (trans[j, 0] - trans[p, 0]) + rot[p, 1, i] * (trans[j, 1] - trans[p, 1]) \
                + rot[p, 2, i] * (trans[j, 2] - trans[p, 2])
            for k in range(3):
                held_rot[j, i, k] = rot[p, 0, i] * rot[j, 0, k] + rot[p, 1, i] * rot[j, 1, k] + rot[p, 2, i] * rot[j, 2, k]
    return held_kinds, held_rot, held_trans


@compiled
def _free_states(values, q_ref, slots, ints, floats, out):  # pragma: no cover - compiled
    """out[s]: state s (q_ref with ``slots`` set to values[s]) is clear of everything."""
    nj, nb, ns, nw, npairs, no = ints[0], ints[1], ints[2], ints[3], ints[4], ints[5]
    parents = ints[ints[6]:ints[6] + nj]
    kinds = ints[ints[7]:ints[7] + nj]
    index = ints[ints[8]:ints[8] + nj]
    body_joint = ints[ints[9]:ints[9] + nb]
    first = ints[ints[10]:ints[10] + nb + 1]
    world_body = ints[ints[11]:ints[11] + nw]
    world_obstacle = ints[ints[12]:ints[12] + nw]
    obstacle_kind = ints[ints[13]:ints[13] + no]
    pair_a = ints[ints[14]:ints[14] + npairs]
    pair_b = ints[ints[15]:ints[15] + npairs]
    fo = ints[16]
    margin = floats[0]
    axes = floats[ints[fo + 1]:ints[fo + 1] + 3 * nj].reshape((nj, 3))
    rot0 = floats[ints[fo + 2]:ints[fo + 2] + 9 * nj].reshape((nj, 3, 3))
    trans0 = floats[ints[fo + 3]:ints[fo + 3] + 3 * nj].reshape((nj, 3))
    local = floats[ints[fo + 4]:ints[fo + 4] + 3 * ns].reshape((ns, 3))
    radius = floats[ints[fo + 5]:ints[fo + 5] + ns]
    outer = floats[ints[fo + 6]:ints[fo + 6] + 4 * nb].reshape((nb, 4))
    obstacle_rot = floats[ints[fo + 7]:ints[fo + 7] + 9 * no].reshape((no, 3, 3))
    obstacle_trans = floats[ints[fo + 8]:ints[fo + 8] + 3 * no].reshape((no, 3))
    dims = floats[ints[fo + 9]:ints[fo + 9] + 3 * no].reshape((no, 3))

    q = q_ref.copy()
    rot = np.empty((nj, 3, 3))
    trans = np.zeros((nj, 3))
    centre = np.empty((ns, 3))
    outer_centre = np.empty((nb, 3))
    placed = np.zeros(nb, dtype=np.bool_)  # the body's spheres are placed for this state
    for i in range(3):
        for k in range(3):
            rot[0, i, k] = 1.0 if i == k else 0.0
    base = np.empty((3, 3))
    local_rot = np.empty((3, 3))
    if values.shape[0] >= HOLD_MIN_STATES:
        kinds, rot0, trans0 = _held_joints(q, slots, parents, kinds, index, axes, rot0, trans0, rot, trans, base,
                                           local_rot)
    for s in range(values.shape[0]):
        finite = True
        for k in range(slots.shape[0]):
            q[slots[k]] = values[s, k]
            if not math.isfinite(values[s, k]):
                finite = False
        if not finite:  # NaN would slip through every comparison below: undecided
            out[s] = False
            continue
        joint_kinematics(q, parents, kinds, index, axes, rot0, trans0, rot, trans, base, local_rot)
        for b in range(nb):
            _place(rot, trans, body_joint[b], outer[b, :3], outer_centre[b])
            placed[b] = False
        free = True
        for w in range(nw):
            b = world_body[w]
            o = world_obstacle[w]
            rows = obstacle_rot[o]
            dx = outer_centre[b, 0] - obstacle_trans[o, 0]
            dy = outer_centre[b, 1] - obstacle_trans[o, 1]
            dz = outer_centre[b, 2] - obstacle_trans[o, 2]
            distance = _obstacle_distance(obstacle_kind[o], dims[o], rows[0, 0] * dx + rows[1, 0] * dy + rows[2, 0] * dz,
                                          rows[0, 1] * dx + rows[1, 1] * dy + rows[2, 1] * dz,
                                          rows[0, 2] * dx + rows[1, 2] * dy + rows[2, 2] * dz)
            if distance - outer[b, 3] > margin:
                continue
            if not placed[b]:
                for n in range(first[b], first[b + 1]):
                    _place(rot, trans, body_joint[b], local[n], centre[n])
                placed[b] = True
            for n in range(first[b], first[b + 1]):
                dx = centre[n, 0] - obstacle_trans[o, 0]
                dy = centre[n, 1] - obstacle_trans[o, 1]
                dz = centre[n, 2] - obstacle_trans[o, 2]
                distance = _obstacle_distance(obstacle_kind[o], dims[o],
                                              rows[0, 0] * dx + rows[1, 0] * dy + rows[2, 0] * dz,
                                              rows[0, 1] * dx + rows[1, 1] * dy + rows[2, 1] * dz,
                                              rows[0, 2] * dx + rows[1, 2] * dy + rows[2, 2] * dz)
                if distance - radius[n] <= margin:
                    free = False
                    break
            if not free:
                break
        if free:
            for k in range(npairs):
                a = pair_a[k]
                b = pair_b[k]
                dx = outer_centre[a, 0] - outer_centre[b, 0]
                dy = outer_centre[a, 1] - outer_centre[b, 1]
                dz = outer_centre[a, 2] - outer_centre[b, 2]
                reach = outer[a, 3] + outer[b, 3] + margin
                if dx * dx + dy * dy + dz * dz > reach * reach:
                    continue
                for c in (a, b):
                    if not placed[c]:
                        for n in range(first[c], first[c + 1]):
                            _place(rot, trans, body_joint[c], local[n], centre[n])
                        placed[c] = True
                bx, by, bz = outer_centre[b, 0], outer_centre[b, 1], outer_centre[b, 2]
                for m in range(first[a], first[a + 1]):
                    # this sphere against b's bounding sphere first: most are clear of it
                    dx = centre[m, 0] - bx
                    dy = centre[m, 1] - by
                    dz = centre[m, 2] - bz
                    reach = radius[m] + outer[b, 3] + margin
                    if dx * dx + dy * dy + dz * dz > reach * reach:
                        continue
                    for n in range(first[b], first[b + 1]):
                        dx = centre[m, 0] - centre[n, 0]
                        dy = centre[m, 1] - centre[n, 1]
                        dz = centre[m, 2] - centre[n, 2]
                        reach = radius[m] + radius[n] + margin
                        if dx * dx + dy * dy + dz * dz <= reach * reach:
                            free = False
                            break
                    if not free:
                        break
                if not free:
                    break
        out[s] = free


@compiled
def one_state_free(values, one_ints, one_floats):  # pragma: no cover - compiled
    """``free`` of one state, a float64 vector (callers check that: PlanningScene.
    batch_free_checker's one-state form), on a BatchCheck's ``one_ints`` and ``one_floats``: one
    compiled call, no arrays made by the caller."""
    n = one_ints.shape[0]
    slots = one_ints[one_ints[n - 1]:n - 2]
    if values.ndim != 1 or values.shape[0] != slots.shape[0]:
        return False  # the exact check says what is wrong
    q_ref = one_floats[one_ints[n - 2]:]
    out = np.empty(1, dtype=np.bool_)
    _free_states(values.reshape((1, values.shape[0])), q_ref, slots, one_ints, one_floats, out)
    return out[0]
