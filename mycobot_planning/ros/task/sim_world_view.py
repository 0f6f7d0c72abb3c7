"""The viewer's simulated world fed from a physics twin (mujoco_sim): the objects' true poses from
``<sim>/object_poses`` (tf2_msgs/TFMessage, one transform per object), their shapes and colours
from the simulator's JSON ``world`` method, asked again whenever an object id appears that it has
not described (an object spawned or the world reset). The robot needs nothing of its own here: in
the twin, /joint_states are the simulated joints, so the live robot is the simulated one.

What the page then shows side by side: the planning scene (what move_group believes) and the
simulated world (what the physics has): a cylinder that slipped or toppled shows where it really is.
"""
from __future__ import annotations

import threading
import time
from typing import Any

from rclpy.node import Node
from tf2_msgs.msg import TFMessage

from interfaces_py.json_rpc import JsonRpcClient, RpcError
from interfaces_py.msgs import CollisionObject
from mycobot_planning.core.transforms import make_pose

#: s between two descriptions asked of the simulator while ids stay unknown
DESCRIBE_RETRY = 2.0


def world_object(description: dict[str, Any], pose: Any) -> CollisionObject | None:
    """The CollisionObject of one entry of the simulator's ``world`` answer at ``pose`` (None for
    a shape it does not know)."""
    shape, size, object_id = description.get("shape"), description.get("size") or [], str(description.get("id"))
    if shape == "box" and len(size) == 3:
        return CollisionObject.box(object_id, size, pose)
    if shape == "cylinder" and len(size) == 2:
        return CollisionObject.cylinder(object_id, size[0], size[1], pose)
    if shape == "sphere" and len(size) == 1:
        return CollisionObject.sphere(object_id, size[0], pose)
    return None


class SimWorldView:
    """Feeds ``viewer.on_sim_world`` from the simulator node ``sim`` (e.g. /mujoco_sim)."""

    def __init__(self, node: Node, viewer: Any, sim: str) -> None:
        self.node = node
        self.viewer = viewer
        self.sim = sim.rstrip("/")
        self._rpc = JsonRpcClient(node, self.sim)
        self._lock = threading.Lock()
        self._shapes: dict[str, dict[str, Any]] = {}
        self._asking = False
        self._asked_at = -DESCRIBE_RETRY
        self.received = 0
        node.create_subscription(TFMessage, f"{self.sim}/object_poses", self._on_poses, 10)

    def _on_poses(self, msg: TFMessage) -> None:
        poses = {}
        for t in msg.transforms:
            r, p = t.transform.rotation, t.transform.translation
            poses[t.child_frame_id] = make_pose([p.x, p.y, p.z], quat_xyzw=[r.x, r.y, r.z, r.w])
        with self._lock:
            self.received += 1
            unknown = [name for name in poses if name not in self._shapes]
            shapes = dict(self._shapes)
        if unknown:
            self._describe()
        objects, colours = {}, {}
        for name, pose in poses.items():
            description = shapes.get(name)
            if description is None:
                continue
            obj = world_object(description, pose)
            if obj is not None:
                objects[name] = obj
                colours[name] = tuple(int(round(255 * float(c))) for c in description.get("color", [])[:3]) or None
        self.viewer.on_sim_world(objects, {k: v for k, v in colours.items() if v})

    def _describe(self) -> None:
        """Ask the simulator for its objects' shapes, in the background, at most every DESCRIBE_RETRY."""
        now = time.monotonic()
        with self._lock:
            if self._asking or now - self._asked_at < DESCRIBE_RETRY:
                return
            self._asking, self._asked_at = True, now

        def work() -> None:
            try:
                answer = self._rpc.call("world", {}, timeout=10.0)
                shapes = {str(o["id"]): o for o in answer.get("objects", []) if isinstance(o, dict) and "id" in o}
                with self._lock:
                    self._shapes = shapes
            except (RpcError, AttributeError, TypeError, KeyError) as exc:
                self.node.get_logger().warning(f"could not read the simulated world's objects from {self.sim}: {exc}")
            finally:
                with self._lock:
                    self._asking = False
        threading.Thread(target=work, name="sim world describe", daemon=True).start()
