"""The MuJoCo twin's world services: reset, pause and step, spawn and remove objects.

What Gazebo's world control gives its users, on this node's names. Requests with data go through
the JSON face (``/mujoco_sim/requests``, interfaces_py.json_rpc: methods ``reset_world``,
``pause``, ``resume``, ``step`` {steps}, ``spawn_object`` {object: an entry of the scene file's
``objects:`` list}, ``remove_object`` {id}, ``sim_status``, ``world``: the objects' shapes); the data-free ones are std_srvs
services as well (``~/reset_world`` Trigger, ``~/pause`` SetBool: true pauses, false resumes).

Nothing here moves the arm by surprise: reset and pause are refused while a controller follows a
goal (a reset would snap the joints under a running trajectory, a pause would freeze the physics
while the controllers' clock runs on), stepping only runs while paused, and a spawned object that
would overlap anything is refused with what it overlaps (simulation.simulator).
"""
from __future__ import annotations

from typing import Any

from std_srvs.srv import SetBool, Trigger

from interfaces_py.json_rpc import BAD_REQUEST, JsonRpcServer, RpcError
from mycobot_planning.simulation.errors import SimulationError
from mycobot_planning.simulation.scene import SceneObject

#: JSON-face error codes of the world services (BAD_REQUEST for malformed parameters)
SIM_BUSY = -1  # a controller is following a goal, or the simulation runs when it must be paused
SPAWN_REFUSED = -2  # the object cannot be built or would overlap something (the message says which)
NO_SUCH_OBJECT = -3
#: most physics steps one ``step`` request may ask for (10 s at the default 1 ms step)
MAX_STEPS = 10_000


class SimServices:
    """The world services of ``node`` (a MujocoSimNode: its controller manager lock, its plant's
    simulator and grasp watch)."""

    def __init__(self, node: Any) -> None:
        self._node = node
        self._sim = node.sim
        rpc = JsonRpcServer(node)
        for name, handler in (("reset_world", self._reset), ("pause", self._pause), ("resume", self._resume),
                              ("step", self._step), ("spawn_object", self._spawn), ("remove_object", self._remove),
                              ("sim_status", self._status), ("world", self._world)):
            rpc.register(name, handler)
        self.rpc = rpc
        node.create_service(Trigger, "~/reset_world", self._srv_reset)
        node.create_service(SetBool, "~/pause", self._srv_pause)

    # ------------------------------------------------------------------ checks
    def _goal_running(self) -> str:
        """The controller following a goal ("" when none). Under the manager's lock."""
        for name, (follower, _) in self._node.plant.followers.items():
            if follower.active:
                return f"{name} is executing goal {follower.goal_id}"
        return ""

    @staticmethod
    def _no_params(method: str, params: dict) -> None:
        if params:
            raise RpcError(BAD_REQUEST, f"{method}: takes no parameters, got {sorted(params)}")

    # ------------------------------------------------------------------ world
    def reset_world(self) -> str:
        """Objects back to the scene file, the robot to its initial positions, time 0."""
        with self._node._lock:
            busy = self._goal_running()
            if busy:
                raise RpcError(SIM_BUSY, f"cannot reset the world: {busy}; stop it first")
            self._node.plant.reset_world()
        text = "the world is back as the scene file has it (robot at its initial positions, time 0)"
        self._node.get_logger().info(text)
        return text

    def set_paused(self, paused: bool) -> str:
        with self._node._lock:
            if paused:
                busy = self._goal_running()
                if busy:
                    raise RpcError(SIM_BUSY, f"cannot pause the simulation: {busy}; stop it first")
                self._sim.pause()
            else:
                self._sim.resume()
        text = (f"the simulation is paused at t = {self._sim.time:.3f} s" if paused
                else f"the simulation runs again from t = {self._sim.time:.3f} s")
        self._node.get_logger().info(text)
        return text

    # ------------------------------------------------------------------ JSON face
    def _reset(self, params: dict) -> dict:
        self._no_params("reset_world", params)
        return {"message": self.reset_world(), "time": self._sim.time}

    def _pause(self, params: dict) -> dict:
        self._no_params("pause", params)
        return {"message": self.set_paused(True), "time": self._sim.time}

    def _resume(self, params: dict) -> dict:
        self._no_params("resume", params)
        return {"message": self.set_paused(False), "time": self._sim.time}

    def _step(self, params: dict) -> dict:
        unknown = sorted(set(params) - {"steps"})
        if unknown:
            raise RpcError(BAD_REQUEST, f"step: unknown parameters {unknown}; known: ['steps']")
        steps = params.get("steps", 1)
        if isinstance(steps, bool) or not isinstance(steps, int) or not 1 <= steps <= MAX_STEPS:
            raise RpcError(BAD_REQUEST, f"step: steps must be an integer within [1, {MAX_STEPS}], got {steps!r}")
        if not self._sim.paused:
            raise RpcError(SIM_BUSY, "step: the simulation runs in real time; pause it first")
        try:
            self._sim.step(steps)
        except SimulationError as exc:
            raise RpcError(SIM_BUSY, f"step: {exc}") from None
        return {"steps": steps, "time": self._sim.time}

    def _spawn(self, params: dict) -> dict:
        unknown = sorted(set(params) - {"object"})
        if unknown or "object" not in params:
            raise RpcError(BAD_REQUEST, "spawn_object: takes one parameter, object (an entry of the scene file's "
                                        f"objects: list){f'; unknown: {unknown}' if unknown else ''}")
        try:
            obj = SceneObject.from_dict(params["object"])
            self._sim.spawn_object(obj)
        except SimulationError as exc:
            raise RpcError(SPAWN_REFUSED, f"spawn_object: {exc}") from None
        self._node.get_logger().info(f"spawned '{obj.id}' ({obj.shape}) in the simulation")
        return {"id": obj.id, "objects": list(self._sim.object_poses())}

    def _remove(self, params: dict) -> dict:
        name = params.get("id")
        if set(params) != {"id"} or not isinstance(name, str) or not name:
            raise RpcError(BAD_REQUEST, f"remove_object: takes one parameter, id (an object's name), got {params!r}")
        try:
            self._sim.remove_object(name)
        except KeyError as exc:
            raise RpcError(NO_SUCH_OBJECT, f"remove_object: {exc.args[0]}") from None
        self._node.get_logger().info(f"removed '{name}' from the simulation")
        return {"id": name, "objects": list(self._sim.object_poses())}

    def _world(self, params: dict) -> dict:
        """The world's objects as the simulation has them: id, shape, size (the scene file's
        conventions), RGBA colour, fixed (what a viewer needs to draw the true poses of
        ``/mujoco_sim/object_poses``)."""
        self._no_params("world", params)
        return {"frame_id": self._sim.scene.frame_id,
                "objects": [{"id": o.id, "shape": o.shape, "size": list(o.size), "color": list(o.color),
                             "fixed": o.fixed} for o in self._sim.world_objects()]}

    def _status(self, params: dict) -> dict:
        self._no_params("sim_status", params)
        return self._node.status_dict()

    # ------------------------------------------------------------------ std_srvs face
    def _srv_reset(self, request: Trigger.Request, response: Trigger.Response) -> Trigger.Response:
        return self._answer(response, self.reset_world)

    def _srv_pause(self, request: SetBool.Request, response: SetBool.Response) -> SetBool.Response:
        return self._answer(response, lambda: self.set_paused(bool(request.data)))

    def _answer(self, response: Any, call: Any) -> Any:
        try:
            response.message, response.success = call(), True
        except RpcError as exc:
            self._node.get_logger().warning(exc.message)
            response.message, response.success = exc.message, False
        return response
