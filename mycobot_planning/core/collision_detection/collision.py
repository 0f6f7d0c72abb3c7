"""Collision geometry of a planning scene, compiled for one-call-per-state checking.

The full story: docs/core.md, section mycobot_planning.core.collision_detection.collision.
"""
from __future__ import annotations

import logging
import math
import threading
import weakref
from typing import TYPE_CHECKING, Callable, Mapping

import coal
import numpy as np
import pinocchio as pin
from scipy.spatial import ConvexHull

from .batch_check import BATCH_MARGIN, BatchCheck, build_batch_check
from .collision_common import (
    KIND_ORDER,
    OBJECT,
    ROBOT_ATTACHED,
    ROBOT_LINK,
    SECURITY_MARGIN,
    Contact,
    DistanceReport,
)
from .sphere_cover import enclosing_spheres
from .world import AttachedBody, SceneObject

if TYPE_CHECKING:  # pragma: no cover
    from .acm import AllowedCollisionMatrix
    from ..robot_model.robot_model import RobotModel

_LOG = logging.getLogger(__name__)

#: Above this many geometry objects the dynamic AABB tree beats the naive broad phase.
_AABB_TREE_THRESHOLD = 150


# ---------------------------------------------------------------------------------------------
# Per-robot data shared by every scene of a model
# ---------------------------------------------------------------------------------------------


class RobotCollisionInfo:
    """What every compiled scene of one RobotModel reuses: geometries, link names, pair candidates,
    and a fast variables -> Pinocchio q mapping (affine for revolute/prismatic/mimic joints)."""

    _cache: "weakref.WeakKeyDictionary[RobotModel, RobotCollisionInfo]" = weakref.WeakKeyDictionary()
    _lock = threading.Lock()

    @classmethod
    def for_model(cls, model: "RobotModel") -> "RobotCollisionInfo":
        with cls._lock:
            info = cls._cache.get(model)
            if info is None:
                info = cls(model)
                cls._cache[model] = info
            return info

    def __init__(self, model: "RobotModel") -> None:
        self.model = model
        pin_model = model.pin_model
        source = model.pin_collision_model
        self.geometry_objects: list[pin.GeometryObject] = []
        self.geometry_links: list[str] = []
        self.geometry_joints: list[int] = []
        for geom in source.geometryObjects:  # local AABBs computed by the model (the broad phase needs them)
            self.geometry_objects.append(geom)
            self.geometry_links.append(pin_model.frames[geom.parentFrame].name)
            self.geometry_joints.append(int(geom.parentJoint))
        n = len(self.geometry_objects)
        self.candidate_pairs: list[tuple[int, int]] = [
            (i, j) for i in range(n) for j in range(i + 1, n) if self.geometry_links[i] != self.geometry_links[j]
        ]
        self.links_with_geometry = list(dict.fromkeys(self.geometry_links))
        # Convex hulls of the link meshes, for the exact check's pre-test (see CompiledScene).
        self.hull_geometries: list[coal.CollisionGeometry | None] = [
            _convex_hull(g.geometry) for g in self.geometry_objects]
        self.lower = [float(x) for x in model.lower_limits]
        self.upper = [float(x) for x in model.upper_limits]
        self.neutral_q = np.asarray(pin.neutral(pin_model), dtype=float)
        self._build_q_map()
        self._link_covers: list[tuple[np.ndarray, np.ndarray] | None] | None = None

    @property
    def link_covers(self) -> list[tuple[np.ndarray, np.ndarray] | None]:
        """Each robot geometry's enclosing spheres in its shape frame (sphere_cover), made once."""
        with self._lock:
            if self._link_covers is None:
                self._link_covers = [enclosing_spheres(g.geometry) for g in self.geometry_objects]
            return self._link_covers

    def _build_q_map(self) -> None:
        model = self.model
        n = len(model.variable_names)
        nq = model.pin_model.nq
        self.q_matrix: np.ndarray | None = None
        self.q_offset: np.ndarray | None = None
        self.q_identity = False
        base = np.array(model.to_q(np.zeros(n)), dtype=float)
        columns = [np.array(model.to_q(np.eye(n)[i]), dtype=float) - base for i in range(n)]
        matrix = np.column_stack(columns) if columns else np.zeros((nq, 0))
        rng = np.random.default_rng(12345)
        for _ in range(3):  # verify the map is affine (continuous joints are not)
            p = rng.uniform(-1.0, 1.0, n)
            if not np.allclose(matrix @ p + base, np.asarray(model.to_q(p), dtype=float), atol=1e-12):
                return
        if matrix.shape == (n, n) and np.array_equal(matrix, np.eye(n)) and not base.any():
            self.q_identity = True
        self.q_matrix = np.ascontiguousarray(matrix)
        self.q_offset = base if base.any() else None

    def to_q(self, positions: np.ndarray) -> np.ndarray:
        """Variables -> Pinocchio configuration, without Python loops when the map is affine."""
        if self.q_identity:
            return positions if positions.flags.c_contiguous else np.ascontiguousarray(positions)
        if self.q_matrix is None:
            return np.asarray(self.model.to_q(positions), dtype=float)
        q = self.q_matrix.dot(positions)
        if self.q_offset is not None:
            q += self.q_offset
        return q


# ---------------------------------------------------------------------------------------------
# Compiled scene
# ---------------------------------------------------------------------------------------------


_WARNED: set[tuple[str, frozenset[str]]] = set()


def _warn_always_colliding(robot: str, a: str, b: str) -> None:
    """Say once per pair why every state of a scene is invalid (e.g. an incomplete SRDF)."""
    key = (robot, frozenset((a, b)))
    if key in _WARNED:
        return
    _WARNED.add(key)
    _LOG.warning(
        "'%s' and '%s' are fixed relative to each other and overlap, so every state of robot '%s' is in "
        "collision in this scene; disable the pair in the SRDF or allow it in the allowed collision matrix",
        a, b, robot,
    )


#: How far outside its hull a mesh vertex may lie (m) for the hull still to be used: qhull may
#: leave a vertex a rounding error outside a merged facet; the pre-test margin covers far more.
_HULL_CONTAINMENT_TOLERANCE = 1e-9
#: A mesh is pre-tested as its hull only when no vertex lies deeper inside the hull than this (m):
#: the mesh is convex (the Panda's, Talos's), so the hull is the same solid. A concave mesh's
#: hull touches its neighbours' in many free states (the UR5's links, 1-4 cm deep), each costing
#: the pre-test and then the exact check: slower than the exact check alone (docs/core.md).
_HULL_TIGHTNESS = 1e-3
#: Meshes of more vertices, or whose check needs more vertex-facet products (about 0.1 s), are
#: not pre-tested: convex meshes that large are rare, and their exact check stays what it was.
_HULL_MAX_VERTICES = 5000
_HULL_CHECK_PRODUCTS = 20_000_000
#: The hull pre-test calls a pair apart only when the hulls are further apart than this (m), far
#: above GJK's relative tolerance (1e-6) and the containment tolerance: hulls that merely touch,
#: or that GJK leaves a rounding error apart, send the state to the exact check.
HULL_PRE_TEST_MARGIN = 1e-4


def _convex_hull(geometry: coal.CollisionGeometry) -> coal.CollisionGeometry | None:
    """The convex hull of a convex triangle mesh, checked to contain every vertex; None for shapes
    that are not meshes, concave meshes (see _HULL_TIGHTNESS), or when no hull can be made or
    checked (a flat or degenerate mesh).

    Coal's ``buildConvexHull`` runs qhull; every mesh vertex is then tested against the facet
    planes of the hull's own points (scipy's qhull, on those points only), so the hull is used
    only when it contains the mesh as loaded (same frame, scale already applied). Not
    ``buildConvexRepresentation``: that wraps the mesh's own vertices and triangles as a Convex
    without computing a hull, and GJK's support function, which climbs from vertex to
    neighbouring vertex, stops at the first local maximum of a non-convex mesh (docs/core.md)."""
    if not isinstance(geometry, coal.BVHModelBase) or not 4 <= geometry.num_vertices <= _HULL_MAX_VERTICES:
        return None
    try:
        copy = geometry.clone()
        copy.buildConvexHull(True, "Qt")
        hull = copy.convex
        points = np.array(hull.points(), dtype=float)
        planes = ConvexHull(points).equations  # (n, 4): outward unit normal, offset
    except Exception:  # qhull refuses flat or degenerate point sets (and "too many neighbors")
        return None
    vertices = np.asarray(geometry.vertices(), dtype=float)
    if len(vertices) * len(planes) > _HULL_CHECK_PRODUCTS:
        return None
    sample = vertices[::max(1, len(vertices) // 1000)]  # a concave mesh shows on a few vertices
    if _signed_distances(sample, planes).min() < -_HULL_TIGHTNESS:
        return None
    signed = _signed_distances(vertices, planes)
    if not (signed.max() <= _HULL_CONTAINMENT_TOLERANCE and signed.min() >= -_HULL_TIGHTNESS):
        return None
    hull.computeLocalAABB()
    if not hull.aabb_local.volume() > 0.0:
        return None
    return hull


def _signed_distances(points: np.ndarray, planes: np.ndarray) -> np.ndarray:
    """Each point's signed distance to a convex hull's boundary (> 0 outside): its largest value
    over the hull's facet planes (unit normal, offset), in blocks of at most a million products."""
    out = np.full(len(points), -np.inf)
    step = max(1, 1_000_000 // max(1, len(points)))
    for k in range(0, len(planes), step):
        block = planes[k:k + step]
        np.maximum(out, np.max(points @ block[:, :3].T + block[:, 3], axis=1), out=out)
    return out


def _set_collision_requests(data: pin.GeometryData, margin: float) -> None:
    """Every pair's request: first contact only, no contact details, the given margin, and GJK
    started afresh. Pinocchio's own requests warm-start GJK from the pair's previous answer, which
    only the all-pairs loop updates (the broad phase works on a copy of the request), so a state
    near the margin got a verdict that depended on which states had been checked before, by which
    path (a myCobot state 1.04 µm from contact: free for the planner, colliding for the validator
    after it had checked the states before it)."""
    request = coal.CollisionRequest(coal.CollisionRequestFlag.NO_REQUEST, 1)
    request.security_margin = margin
    requests = data.collisionRequests
    for k in range(len(requests)):
        requests[k] = request  # the vector stores a copy of it


def _se3(matrix: np.ndarray) -> pin.SE3:
    return pin.SE3(np.array(matrix[:3, :3]), np.array(matrix[:3, 3]))


class _SceneData:
    """One thread's buffers for a CompiledScene: what every collision or distance call writes
    (Pinocchio data, geometry data, the broad phases over them) and the checker closure bound to
    them. Pinocchio's model/data split: the CompiledScene is the model, this is the data."""

    __slots__ = ("data", "geometry_data", "manager", "hull_data", "hull_geometry_data", "hull_manager", "check",
                 "all_pairs", "distance_data", "group_checkers")

    def __init__(self, scene: "CompiledScene", data: pin.Data | None = None,
                 geometry_data: pin.GeometryData | None = None) -> None:
        pin_model, gm = scene.pin_model, scene.geometry_model
        self.data = data if data is not None else pin_model.createData()
        self.geometry_data = geometry_data if geometry_data is not None else scene._geometry_data_of(gm)
        self.manager = self.hull_manager = self.hull_data = self.hull_geometry_data = None
        if scene._manager_type is not None:
            self.manager = scene._manager_type(pin_model, gm, self.geometry_data)
            if scene._hull_model is not None:
                self.hull_data = pin_model.createData()
                self.hull_geometry_data = scene._geometry_data_of(scene._hull_model,
                                                                  SECURITY_MARGIN + HULL_PRE_TEST_MARGIN)
                self.hull_manager = scene._manager_type(pin_model, scene._hull_model, self.hull_geometry_data)
        self.distance_data: dict[tuple, tuple[pin.GeometryData, list[int]]] = {}
        #: group_collides' checkers, by (moving joints, reference configuration): each owns its buffers
        self.group_checkers: dict[tuple, Callable[[np.ndarray], bool]] = {}
        self.all_pairs = self._all_pairs_checker(scene)
        self.check = self._checker(scene) if self.manager is not None else self.all_pairs

    def _all_pairs_checker(self, scene: "CompiledScene"):
        """The plain exact check: every active pair's narrow phase in turn (no broad phase, no
        pre-test), one Pinocchio call per configuration. What judges the fast path: the
        trajectory validator decides with it, so it never shares the checker it judges."""
        compute = pin.computeCollisions
        pin_model, data = scene.pin_model, self.data
        gm, gd = scene.geometry_model, self.geometry_data
        if not scene.pairs:
            def no_pairs(q: np.ndarray) -> bool:
                return False

            return no_pairs

        def all_pairs(q: np.ndarray) -> bool:
            return compute(pin_model, data, gm, gd, q, True)

        return all_pairs

    def _checker(self, scene: "CompiledScene"):
        """The hot path: a closure doing exactly one Pinocchio call per configuration."""
        compute = pin.computeCollisions
        pin_model, data = scene.pin_model, self.data
        if not scene.pairs:
            def no_pairs(q: np.ndarray) -> bool:
                return False

            return no_pairs
        if self.manager is not None:
            manager = self.manager
            hull_manager = self.hull_manager
            if hull_manager is not None:
                hull_data = self.hull_data

                def hulls_then_meshes(q: np.ndarray) -> bool:
                    return compute(pin_model, hull_data, hull_manager, q, True) and \
                        compute(pin_model, data, manager, q, True)

                return hulls_then_meshes

            def broadphase(q: np.ndarray) -> bool:
                return compute(pin_model, data, manager, q, True)

            return broadphase
        gm, gd = scene.geometry_model, self.geometry_data

        def plain(q: np.ndarray) -> bool:
            return compute(pin_model, data, gm, gd, q, True)

        return plain


class CompiledScene:
    """A scene's geometry as one Pinocchio GeometryModel + broad phase, ready for per-state calls.

    Shared by every thread and every copy of the scene: the buffers a check writes (Pinocchio
    and geometry data, the broad phases) are each thread's own (_SceneData, made on the thread's
    first check), so concurrent plans on copies of one scene never touch each other's data.
    """

    def __init__(
        self,
        robot: RobotCollisionInfo,
        world: Mapping[str, SceneObject],
        attached: Mapping[str, AttachedBody],
        acm: "AllowedCollisionMatrix",
    ) -> None:
        self.robot = robot
        model = robot.model
        pin_model = model.pin_model
        self.pin_model = pin_model
        self._local = threading.local()
        gm = pin.GeometryModel()
        names: list[str] = []  # body name per geometry
        kinds: list[str] = []  # body kind per geometry
        for index, geom in enumerate(robot.geometry_objects):
            gm.addGeometryObject(geom)
            names.append(robot.geometry_links[index])
            kinds.append(ROBOT_LINK)
        n_robot = len(names)
        for obj in world.values():
            for k, shape in enumerate(obj.shapes):
                placement = _se3(obj.pose @ shape.pose)
                gm.addGeometryObject(pin.GeometryObject(f"world/{obj.id}/{k}", 0, 0, placement, shape.geometry))
                names.append(obj.id)
                kinds.append(OBJECT)
        n_world_end = len(names)
        self.attached_links: dict[str, str] = {}
        touch: dict[str, frozenset[str]] = {}
        for body in attached.values():
            frame_id = model.frame_id(body.link)
            frame = pin_model.frames[frame_id]
            joint_to_link = frame.placement.homogeneous
            for k, shape in enumerate(body.object.shapes):
                placement = _se3(joint_to_link @ body.object.pose @ shape.pose)
                gm.addGeometryObject(
                    pin.GeometryObject(
                        f"attached/{body.id}/{k}", int(frame.parentJoint), int(frame_id), placement, shape.geometry
                    )
                )
                names.append(body.id)
                kinds.append(ROBOT_ATTACHED)
            self.attached_links[body.id] = body.link
            touch[body.id] = body.touch_links | {body.link}
        self.geometry_names = names
        self.geometry_kinds = kinds
        joints = [int(g.parentJoint) for g in gm.geometryObjects]

        allowed_cache: dict[tuple[str, str], bool] = {}

        def allowed(a: str, b: str) -> bool:
            key = (a, b)
            value = allowed_cache.get(key)
            if value is None:
                value = acm.is_allowed(a, b)
                allowed_cache[key] = value
            return value

        pairs: list[tuple[int, int]] = []
        for i, j in robot.candidate_pairs:
            if not allowed(names[i], names[j]):
                pairs.append((i, j))
        world_range = range(n_robot, n_world_end)
        attached_range = range(n_world_end, len(names))
        for g in world_range:
            for i in range(n_robot):
                if not allowed(names[g], names[i]):
                    pairs.append((i, g))
        for g in attached_range:
            body_touch = touch[names[g]]
            for i in range(n_robot):
                if names[i] not in body_touch and not allowed(names[g], names[i]):
                    pairs.append((i, g))
            for w in world_range:
                if not allowed(names[g], names[w]):
                    pairs.append((w, g))
            for h in range(n_world_end, g):
                if names[h] != names[g] and not allowed(names[g], names[h]):
                    pairs.append((h, g))
        for i, j in pairs:
            gm.addCollisionPair(pin.CollisionPair(i, j))
        self.pairs = pairs
        self.geometry_model = gm
        self._inactive_pairs: list[int] = []
        gd = self._geometry_data_of(gm)
        data = pin_model.createData()
        self._pair_is_world = [kinds[i] == OBJECT or kinds[j] == OBJECT for i, j in pairs]

        # Pairs fixed relative to each other: decide once, drop from the per-state check if free.
        self.constant_colliding: list[int] = []
        constant = [k for k, (i, j) in enumerate(pairs) if joints[i] == joints[j]]
        if constant:
            pin.updateGeometryPlacements(pin_model, data, gm, gd, robot.neutral_q)
            for k in constant:
                if pin.computeCollision(gm, gd, k):
                    self.constant_colliding.append(k)
                    _warn_always_colliding(model.name, names[pairs[k][0]], names[pairs[k][1]])
                else:
                    self._inactive_pairs.append(k)
        inactive = set(self._inactive_pairs)
        self.active_pairs = [k for k in range(len(pairs)) if k not in inactive]
        for k in self._inactive_pairs:  # gd is now what _geometry_data_of makes: the thread's below
            gd.deactivateCollisionPair(k)

        # Broad phase when every geometry has a proper AABB (the manager silently ignores
        # degenerate ones, e.g. a flat mesh); otherwise the plain all-pairs loop.
        degenerate = any(not g.geometry.aabb_local.volume() > 0.0 for g in gm.geometryObjects)
        self._manager_type = None
        if not degenerate and pairs:
            self._manager_type = (
                pin.BroadPhaseManager_NaiveCollisionManager
                if gm.ngeoms <= _AABB_TREE_THRESHOLD
                else pin.BroadPhaseManager_DynamicAABBTreeCollisionManager
            )
        self._hull_model = self._hull_geometry(robot, gm) if self._manager_type is not None else None
        # the constructing thread's buffers: the ones made above
        self._local.scene_data = _SceneData(self, data, gd)
        #: batch_check's tests by (moving joints, reference configuration, slots); None: no batch path
        self._batch_checks: dict[tuple, BatchCheck | None] = {}
        self._batch_lock = threading.Lock()
        # fixed_pairs per set of moving joints: a fact of this compiled scene (every plan of a
        # group asks it again; 0.4 ms for the Panda's 60 pairs)
        self._fixed_pairs: dict[frozenset[int], tuple[int, ...]] = {}
        # the configuration entries each set of moving joints writes (batch_check's cache key)
        self._moved_q: dict[frozenset[int], np.ndarray] = {}

    def _geometry_data_of(self, gm: pin.GeometryModel, margin: float = SECURITY_MARGIN) -> pin.GeometryData:
        """Fresh geometry data for this scene's geometry (or its hulls', with the pre-test's wider
        margin): every request as _set_collision_requests makes it, the pairs found free once and
        for all switched off."""
        gd = gm.createData()
        _set_collision_requests(gd, margin)
        for k in self._inactive_pairs:
            gd.deactivateCollisionPair(k)
        return gd

    def _thread_data(self) -> _SceneData:
        """The calling thread's buffers (made on its first call)."""
        local = self._local
        try:
            return local.scene_data
        except AttributeError:
            local.scene_data = _SceneData(self)
            return local.scene_data

    @property
    def collides(self) -> Callable[[np.ndarray], bool]:
        """The calling thread's collision test: ``collides(q)`` is True when the Pinocchio
        configuration q collides. Use it in the thread that asked for it."""
        try:
            return self._local.scene_data.check
        except AttributeError:
            return self._thread_data().check

    @property
    def collides_all_pairs(self) -> Callable[[np.ndarray], bool]:
        """The calling thread's plain exact all-pairs check (no broad phase, no pre-test): the
        judge of the fast path (see _SceneData._all_pairs_checker)."""
        return self._thread_data().all_pairs

    @property
    def manager(self):
        """The calling thread's broad phase (None when the scene has none)."""
        return self._thread_data().manager

    @property
    def hull_manager(self):
        """The calling thread's broad phase over the hulls (None when there is no hull pre-test)."""
        return self._thread_data().hull_manager

    @property
    def data(self) -> pin.Data:
        """The calling thread's Pinocchio data for this scene's checks."""
        return self._thread_data().data

    @property
    def geometry_data(self) -> pin.GeometryData:
        """The calling thread's geometry data."""
        return self._thread_data().geometry_data

    def _hull_geometry(self, robot: RobotCollisionInfo, gm: pin.GeometryModel) -> pin.GeometryModel | None:
        """The same geometry and pairs with every link mesh replaced by its checked hull
        (_convex_hull), behind a broad phase of its own with the margin widened by
        HULL_PRE_TEST_MARGIN; None unless every mesh of the scene has a hull (convex link meshes,
        no world or attached mesh): a hull against a mesh is tested triangle by triangle, which on
        Tiago (some link meshes convex, some not) made a free state near the torso cost 5.6 ms
        instead of 16 µs.

        A hull contains its mesh, so a state the hulls find more than the margin apart is free,
        and the meshes decide every other state: every verdict is still the meshes' own.
        Convex-convex tests (GJK) are cheaper than mesh-mesh BVH traversals: on the Panda with a
        box, a free state within 2 cm of a contact costs 9.4 µs instead of 17.3 µs; a colliding
        state costs both checks (34 µs instead of 25 µs)."""
        hulls = robot.hull_geometries
        meshes = [k for k, g in enumerate(gm.geometryObjects) if isinstance(g.geometry, coal.BVHModelBase)]
        if not meshes or any(k >= len(hulls) or hulls[k] is None for k in meshes):
            return None
        hull_gm = pin.GeometryModel()
        for index, geom in enumerate(gm.geometryObjects):
            hull = hulls[index] if index < len(hulls) else None
            if hull is None:
                hull_gm.addGeometryObject(geom)
            else:
                hull_gm.addGeometryObject(pin.GeometryObject(
                    geom.name, int(geom.parentJoint), int(geom.parentFrame), geom.placement, hull))
        for i, j in self.pairs:
            hull_gm.addCollisionPair(pin.CollisionPair(i, j))
        return hull_gm

    # ------------------------------------------------------------------ collision
    def group_collides(self, moving_joints: frozenset[int], q_ref: np.ndarray) -> Callable[[np.ndarray], bool]:
        """The collision test for states that differ from ``q_ref`` only in the Pinocchio joints
        ``moving_joints`` (a planning group's joints and the mimic followers they drive): a pair
        of bodies whose kinematic path holds none of them keeps its relative pose in every such
        state, so it is checked once here, exactly, and left out of the per-state check. If one
        of them collides, every such state collides and the test says so for every state.

        Exact for those states only: planners of one group use it (PlanningScene's group
        validity checker); anything judging arbitrary states uses collides/collides_all_pairs.
        Built once per group and reference configuration in the calling thread (a few kept per
        thread), and used in that thread."""
        checkers = self._thread_data().group_checkers
        key = (moving_joints, np.asarray(q_ref, dtype=float).tobytes())
        cached = checkers.get(key)
        if cached is None:
            cached = self._build_group_collides(moving_joints, np.array(q_ref, dtype=float))
            if len(checkers) >= 8:
                checkers.pop(next(iter(checkers)))
            checkers[key] = cached
        return cached

    def batch_check(self, moving_joints: frozenset[int], q_ref: np.ndarray, slots: np.ndarray,
                    sample: Callable[[], np.ndarray]) -> BatchCheck | None:
        """The sphere test (batch_check.py) for states that differ from ``q_ref`` only in the
        configuration ``slots`` (a group's joints: ``moving_joints``, as group_collides), judged
        on ``sample()`` (rows of slot values, asked only to build) whether it pays; None when there is none for this scene (a shape or joint it does not
        model, a fixed pair that collides, or it would not pay: batch_check.MIN_FREE_SHARE).
        Built once per key (q_ref counts only at the joints that do not move: the others are
        overwritten by every state) and shared by every thread (it holds no buffers)."""
        # the test depends on q_ref only where no moving joint is: plans from other starts share it
        moved = self._moved_q.get(moving_joints)
        if moved is None:  # (Pinocchio's index vectors are copied on every read from Python: once)
            idx_qs, nqs = self.pin_model.idx_qs, self.pin_model.nqs
            moved = np.zeros(self.pin_model.nq, dtype=bool)
            for j in moving_joints:
                moved[idx_qs[j]:idx_qs[j] + nqs[j]] = True
            self._moved_q[moving_joints] = moved
        held = np.where(moved, 0.0, np.asarray(q_ref, dtype=float))
        key = (moving_joints, held.tobytes(), np.asarray(slots).tobytes())
        with self._batch_lock:
            if key in self._batch_checks:
                return self._batch_checks[key]
        check = self._build_batch_check(moving_joints, np.array(q_ref, dtype=float), slots, sample())
        with self._batch_lock:
            if len(self._batch_checks) >= 8:
                self._batch_checks.pop(next(iter(self._batch_checks)))
            self._batch_checks[key] = check
        return check

    def _build_batch_check(self, moving_joints: frozenset[int], q_ref: np.ndarray, slots: np.ndarray,
                           sample: np.ndarray) -> BatchCheck | None:
        fixed = self.fixed_pairs(moving_joints)
        pin_model, gm = self.pin_model, self.geometry_model
        if fixed:  # decided once, as group_collides does: if one collides every state does
            # on the calling thread's buffers (its checks set their own placements first; making
            # geometry data for every pair costs ~0.3 ms, and a pick and place builds many tests)
            gd = self._thread_data().geometry_data
            pin.updateGeometryPlacements(pin_model, pin_model.createData(), gm, gd, q_ref)
            if any(pin.computeCollision(gm, gd, k) for k in fixed):
                return None
        skip = set(fixed)
        pairs = [self.pairs[k] for k in self.active_pairs if k not in skip]
        robot_covers = self.robot.link_covers
        n_robot = len(robot_covers)
        covers: list[tuple[np.ndarray, np.ndarray] | None] = []
        for g, geom in enumerate(gm.geometryObjects):
            if g < n_robot:
                covers.append(robot_covers[g])
            elif self.geometry_kinds[g] == ROBOT_ATTACHED:
                covers.append(enclosing_spheres(geom.geometry))
            else:
                covers.append(None)
        movers = [kind != OBJECT for kind in self.geometry_kinds]
        return build_batch_check(pin_model, gm, pairs, movers, q_ref, slots, covers, SECURITY_MARGIN + BATCH_MARGIN,
                                 sample)

    def fixed_pairs(self, moving_joints: frozenset[int]) -> list[int]:
        """Active pair indices whose two bodies are linked by a kinematic path without any of
        ``moving_joints`` (the path between parent joints a and b: the joints supporting one but
        not the other; a world object hangs on the universe, an attached object on its link's
        joint). Computed once per set of moving joints."""
        known = self._fixed_pairs.get(moving_joints)
        if known is None:
            known = self._fixed_pairs[moving_joints] = tuple(self._compute_fixed_pairs(moving_joints))
        return list(known)

    def _compute_fixed_pairs(self, moving_joints: frozenset[int]) -> list[int]:
        pin_model = self.pin_model
        # each joint's supporting joints as sets, once per model (read from Pinocchio per pair
        # they cost 0.8 ms a compiled scene of the myCobot)
        supports = self.robot.model.cached(
            ("joint_supports",), lambda: tuple(frozenset(int(j) for j in s) for s in pin_model.supports))
        joints = [int(g.parentJoint) for g in self.geometry_model.geometryObjects]
        path_moves: dict[tuple[int, int], bool] = {}
        fixed = []
        for k in self.active_pairs:
            i, j = self.pairs[k]
            a, b = joints[i], joints[j]
            key = (a, b) if a <= b else (b, a)
            moves = path_moves.get(key)
            if moves is None:
                path = supports[a] ^ supports[b]
                moves = bool(path & moving_joints)
                path_moves[key] = moves
            if not moves:
                fixed.append(k)
        return fixed

    def _build_group_collides(self, moving_joints: frozenset[int], q_ref: np.ndarray) -> Callable[[np.ndarray], bool]:
        fixed = self.fixed_pairs(moving_joints)
        if not fixed:
            return self.collides
        pin_model, gm = self.pin_model, self.geometry_model
        gd = self._geometry_data_of(gm)
        pin.updateGeometryPlacements(pin_model, pin_model.createData(), gm, gd, q_ref)
        if any(pin.computeCollision(gm, gd, k) for k in fixed):
            def always(q: np.ndarray) -> bool:
                return True

            return always
        for k in fixed:
            gd.deactivateCollisionPair(k)
        if not any(gd.activeCollisionPairs):
            def never(q: np.ndarray) -> bool:
                return False

            return never
        compute = pin.computeCollisions
        data = pin_model.createData()
        if self._manager_type is None:
            def remaining_pairs(q: np.ndarray) -> bool:
                return compute(pin_model, data, gm, gd, q, True)

            return remaining_pairs
        manager = self._manager_type(pin_model, gm, gd)
        if self._hull_model is not None:
            hull_gd = self._geometry_data_of(self._hull_model, SECURITY_MARGIN + HULL_PRE_TEST_MARGIN)
            for k in fixed:
                hull_gd.deactivateCollisionPair(k)
            hull_manager = self._manager_type(pin_model, self._hull_model, hull_gd)
            hull_data = pin_model.createData()

            def hulls_then_meshes(q: np.ndarray) -> bool:
                return compute(pin_model, hull_data, hull_manager, q, True) and \
                    compute(pin_model, data, manager, q, True)

            hulls_then_meshes.keep = (gd, hull_gd)  # the managers hold references only
            return hulls_then_meshes

        def broadphase(q: np.ndarray) -> bool:
            return compute(pin_model, data, manager, q, True)

        broadphase.keep = gd
        return broadphase

    def contacts(self, q: np.ndarray, max_contacts: int | None = None) -> list[Contact]:
        """Every colliding active pair at q (a full pass without early exit), with depths."""
        buffers = self._thread_data()
        gm, gd = self.geometry_model, buffers.geometry_data
        pin.updateGeometryPlacements(self.pin_model, buffers.data, gm, gd, q)
        if not self.pairs:
            return []
        pin.computeCollisions(gm, gd, False)
        results = gd.collisionResults
        out: list[Contact] = []
        for k in self.active_pairs:
            if not results[k].isCollision():
                continue
            i, j = self.pairs[k]
            distance = pin.computeDistance(gm, gd, k)
            depth = max(0.0, -float(distance.min_distance))
            p1, p2 = distance.getNearestPoint1(), distance.getNearestPoint2()
            position = None
            if np.all(np.isfinite(p1)) and np.all(np.isfinite(p2)):
                mid = 0.5 * (np.asarray(p1) + np.asarray(p2))
                position = (float(mid[0]), float(mid[1]), float(mid[2]))
            out.append(self._contact(i, j, depth, position))
            if max_contacts is not None and len(out) >= max_contacts:
                break
        return out

    def _contact(self, i: int, j: int, depth: float, position) -> Contact:
        names, kinds = self.geometry_names, self.geometry_kinds
        if KIND_ORDER[kinds[j]] < KIND_ORDER[kinds[i]]:
            i, j = j, i
        return Contact(names[i], kinds[i], names[j], kinds[j], depth, position)

    # ------------------------------------------------------------------ distance
    def distance(
        self,
        q: np.ndarray,
        include_self: bool = True,
        include_world: bool = True,
        bodies: frozenset[str] | None = None,
    ) -> DistanceReport:
        """Minimum distance over the selected active pairs, and per robot body."""
        key = (include_self, include_world, bodies)
        buffers = self._thread_data()
        entry = buffers.distance_data.get(key)
        if entry is None:
            entry = self._distance_selection(include_self, include_world, bodies)
            if len(buffers.distance_data) > 16:
                buffers.distance_data.clear()
            buffers.distance_data[key] = entry
        gd, selected = entry
        if not selected:
            return DistanceReport(math.inf)
        pin.computeDistances(self.pin_model, buffers.data, self.geometry_model, gd, q)
        results = gd.distanceResults
        names, kinds = self.geometry_names, self.geometry_kinds
        best = math.inf
        best_pair = -1
        per_link: dict[str, tuple[float, str]] = {}
        for k in selected:
            d = float(results[k].min_distance)
            i, j = self.pairs[k]
            if d < best:
                best, best_pair = d, k
            for me, other in ((i, j), (j, i)):
                if kinds[me] == OBJECT:
                    continue
                current = per_link.get(names[me])
                if current is None or d < current[0]:
                    per_link[names[me]] = (d, names[other])
        i, j = self.pairs[best_pair]
        result = results[best_pair]
        p1 = tuple(float(x) for x in result.getNearestPoint1())
        p2 = tuple(float(x) for x in result.getNearestPoint2())
        if KIND_ORDER[kinds[j]] < KIND_ORDER[kinds[i]]:
            i, j, p1, p2 = j, i, p2, p1
        return DistanceReport(best, names[i], kinds[i], names[j], kinds[j], p1, p2, per_link)

    def _distance_selection(
        self, include_self: bool, include_world: bool, bodies: frozenset[str] | None
    ) -> tuple[pin.GeometryData, list[int]]:
        gd = self.geometry_model.createData()
        names = self.geometry_names
        selected = []
        for k, (i, j) in enumerate(self.pairs):
            is_world = self._pair_is_world[k]
            keep = include_world if is_world else include_self
            if keep and bodies is not None:
                keep = any(
                    self.geometry_kinds[g] != OBJECT
                    and (names[g] in bodies or self.attached_links.get(names[g]) in bodies)
                    for g in (i, j)
                )
            if keep:
                selected.append(k)
            else:
                gd.deactivateCollisionPair(k)
        return gd, selected

    # ------------------------------------------------------------------ introspection
    @property
    def num_geometries(self) -> int:
        return self.geometry_model.ngeoms

    def pair_names(self, active_only: bool = True) -> list[tuple[str, str]]:
        """Body-name pairs checked per state (for debugging which pairs the ACM leaves active)."""
        indices = self.active_pairs if active_only else range(len(self.pairs))
        return [(self.geometry_names[self.pairs[k][0]], self.geometry_names[self.pairs[k][1]]) for k in indices]
