"""The depth camera of the simulated world: MuJoCo renders depth headless (EGL), we turn it into
a point cloud in the frame perception expects.

The camera's pose, intrinsics and frame come from the perception layer's DepthCameraConfig (the
seeds' camera_head, ``config/camera_scene.yaml``), so the rendered cloud and the ray-cast
camera_simulator see the world from the same place. MuJoCo's renderer returns metric depth
along the optical axis; each pixel (u, v) with depth z back-projects to
``((u - cx) z / fx, (v - cy) z / fy, z)`` in the optical frame. Pixels at the far plane (nothing
there) are NaN, as an organised cloud from a real driver has them. With ``noise`` the config's
sensor model is applied as the ray-cast camera applies it: depth noise of standard deviation
``depth_noise_stddev + depth_noise_quadratic z^2`` and random dropouts (the grazing-incidence
dropout is not modelled here: it needs surface normals the depth image does not carry).
"""
from __future__ import annotations

import os
import threading
import time
from collections import deque
from dataclasses import dataclass

import mujoco
import numpy as np

from ..perception.depth_camera import DepthCameraConfig
from .errors import SimulationError
from .model_builder import CAMERA_NAME, ROBOT_GROUP, WORLD_GROUP


def _backend_hint() -> str:
    """Why rendering may have failed: the OpenGL backend MuJoCo chose when it was imported."""
    try:
        from mujoco.rendering.classic import gl_context
        chosen = getattr(gl_context, "_MUJOCO_GL", "")
    except ImportError:
        chosen = os.environ.get("MUJOCO_GL", "")
    if chosen != "egl":
        return (f"MuJoCo was imported with MUJOCO_GL={chosen!r}; headless rendering needs MUJOCO_GL=egl in the "
                "environment (or import mycobot_planning.simulation before mujoco)")
    return "EGL needs Debian's libegl1 and libegl-mesa0 with Mesa's drivers (scripts/setup.sh installs them)"


@dataclass(frozen=True)
class DepthFrame:
    """One rendered frame. ``depth`` (H, W) metres along the optical axis, NaN where nothing was
    hit; ``points`` (H, W, 3) float32 organised cloud in ``frame_id`` (NaN where no return);
    ``camera_pose`` the optical frame in the world; ``stamp`` the simulation time."""

    depth: np.ndarray
    points: np.ndarray
    frame_id: str
    camera_pose: np.ndarray
    stamp: float

    def cloud(self) -> np.ndarray:
        """(N, 3) points of the returns only (NaNs dropped)."""
        flat = self.points.reshape(-1, 3)
        return flat[~np.isnan(flat[:, 0])]


class SimDepthCamera:
    """Renders the model's ``depth_camera`` into DepthFrames. The GL context is made current on
    every render; use one camera from one thread at a time (``render`` holds a lock)."""

    def __init__(self, model: mujoco.MjModel, config: DepthCameraConfig, frame: str = "world",
                 world_frame: str = "world", noise: bool = True, seed: int | None = 0) -> None:
        if frame not in ("world", "camera"):
            raise SimulationError(f"camera frame must be 'world' or 'camera', got {frame!r}")
        self.config = config
        self.frame = frame
        self.world_frame = world_frame
        self.noise = noise
        self._rng = np.random.default_rng(seed)
        self._lock = threading.Lock()
        intr = config.intrinsics
        u, v = np.meshgrid(np.arange(intr.width, dtype=np.float64), np.arange(intr.height, dtype=np.float64))
        # Ray per pixel with optical z component 1 (the point is depth x ray), in the output frame;
        # the points are then origin + depth x ray: one pass over the image.
        rays = np.stack([(u - intr.cx) / intr.fx, (v - intr.cy) / intr.fy, np.ones_like(u)], axis=-1)
        if frame == "world":
            rays = rays @ config.pose[:3, :3].T
            self._origin = config.pose[:3, 3].astype(np.float32)
        else:
            self._origin = np.zeros(3, dtype=np.float32)
        self._rays = rays.astype(np.float32)
        self._renderer: mujoco.Renderer | None = None
        self._option = mujoco.MjvOption()
        self.attach(model)

    def attach(self, model: mujoco.MjModel) -> None:
        """Render ``model`` (after a recompile: spawned or removed objects)."""
        camera = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_CAMERA, CAMERA_NAME)
        if camera < 0:
            raise SimulationError("the model has no depth camera (the scene has no camera)")
        intr = self.config.intrinsics
        # The renderer reads near/far as fractions of the model's extent.
        model.vis.map.znear = self.config.near / model.stat.extent
        model.vis.map.zfar = self.config.far / model.stat.extent
        with self._lock:
            old, self._renderer = self._renderer, None
            if old is not None:
                old.close()
            try:
                self._renderer = mujoco.Renderer(model, height=intr.height, width=intr.width)
            except Exception as exc:  # noqa: BLE001 - MuJoCo raises several kinds when GL is missing
                raise SimulationError(f"cannot render the depth camera headless ({type(exc).__name__}: "
                                      f"{' '.join(str(exc).split())}); {_backend_hint()}") from None
            self._renderer.enable_depth_rendering()
        self._camera = camera
        self._option.geomgroup[:] = 0
        self._option.geomgroup[ROBOT_GROUP] = 1
        self._option.geomgroup[WORLD_GROUP] = 1

    def close(self) -> None:
        with self._lock:
            if self._renderer is not None:
                self._renderer.close()
                self._renderer = None

    def render(self, data: mujoco.MjData, stamp: float) -> DepthFrame:
        """One frame of the world as ``data`` has it."""
        with self._lock:
            if self._renderer is None:
                raise SimulationError("the depth camera is closed")
            self._renderer.update_scene(data, camera=self._camera, scene_option=self._option)
            depth = self._renderer.render()  # float32 metres
        cfg = self.config
        depth[(depth >= cfg.far * (1.0 - 1e-6)) | (depth <= cfg.near)] = np.nan
        if self.noise:
            sigma = cfg.depth_noise_stddev + cfg.depth_noise_quadratic * np.square(depth)
            depth += self._rng.standard_normal(depth.shape, dtype=np.float32) * sigma
            if cfg.dropout_probability > 0:
                depth[self._rng.random(depth.shape, dtype=np.float32) < cfg.dropout_probability] = np.nan
        points = depth[..., None] * self._rays
        points += self._origin
        frame_id = self.world_frame if self.frame == "world" else cfg.frame_id
        return DepthFrame(depth, points, frame_id, cfg.pose.copy(), stamp)


class CameraWorker:
    """Renders in a thread of its own, from snapshots of the simulation state.

    The GL context lives in that thread (EGL binds a context to one thread), and rendering a
    640x480 frame with Mesa's software rasteriser takes tens of milliseconds: meanwhile the
    physics steps on in the simulator's thread. ``submit`` waits for the previous frame to be
    done (no frame is dropped; a camera slower than its rate makes the simulation fall behind
    real time, which the simulator reports), copies the state and returns at once.
    """

    def __init__(self, model: mujoco.MjModel, config: DepthCameraConfig, frame: str = "world",
                 world_frame: str = "world", noise: bool = True, seed: int | None = 0,
                 on_frame=None, start_timeout: float = 30.0) -> None:
        self._args = (config, frame, world_frame, noise, seed)
        self._on_frame = on_frame
        self._model = model
        self._snapshot = mujoco.MjData(model)
        self._stamp = 0.0
        self._request = threading.Event()
        self._idle = threading.Event()
        self._idle.set()
        self._ready = threading.Event()
        self._closing = False
        self._error: BaseException | None = None
        self.latest: DepthFrame | None = None
        self.frames = 0
        self._durations: deque[float] = deque(maxlen=50)
        self._thread = threading.Thread(target=self._run, name="mujoco_sim_camera", daemon=True)
        self._thread.start()
        if not self._ready.wait(start_timeout):
            raise SimulationError(f"the depth camera did not start within {start_timeout:g} s")
        if self._error is not None:
            raise self._error

    def _run(self) -> None:
        try:
            camera = SimDepthCamera(self._model, *self._args)
        except BaseException as exc:  # noqa: BLE001 - handed to the thread that started us
            self._error = exc
            self._ready.set()
            return
        attached = self._model
        self._ready.set()
        try:
            while True:
                self._request.wait()
                self._request.clear()
                if self._closing:
                    break
                try:
                    if self._model is not attached:
                        camera.attach(self._model)
                        attached = self._model
                    started = time.perf_counter()
                    frame = camera.render(self._snapshot, self._stamp)
                    self._durations.append(time.perf_counter() - started)
                    self.latest = frame
                    self.frames += 1
                    if self._on_frame is not None:
                        self._on_frame(frame)
                except BaseException as exc:  # noqa: BLE001 - reported by the next submit/wait
                    self._error = exc
                finally:
                    self._idle.set()
        finally:
            camera.close()

    def submit(self, model: mujoco.MjModel, data: mujoco.MjData, stamp: float) -> None:
        """Render the state in ``data`` (copied now); returns once the copy is taken."""
        self.wait()
        if model is not self._model:
            self._model = model
            self._snapshot = mujoco.MjData(model)
        mujoco.mj_copyData(self._snapshot, model, data)
        self._stamp = stamp
        self._idle.clear()
        self._request.set()

    def wait(self, timeout: float = 30.0) -> DepthFrame | None:
        """Wait for the frame being rendered; returns the latest frame."""
        if not self._idle.wait(timeout):
            raise SimulationError(f"the depth camera did not finish a frame within {timeout:g} s")
        if self._error is not None:
            error, self._error = self._error, None
            raise SimulationError(f"the depth camera failed: {error}") from None
        return self.latest

    @property
    def frame_seconds(self) -> float:
        """Median time to render and back-project a frame over the last 50 (0: none yet)."""
        return float(np.median(self._durations)) if self._durations else 0.0

    def close(self) -> None:
        self._closing = True
        self._request.set()
        self._thread.join(timeout=5.0)
