"""A simulated RGB-D camera: pinhole rays cast against a :class:`GroundTruthScene`.

Why a simulator: the perception pipeline and the perception_server must run (and be tested)
without Gazebo. The simulator reproduces what matters for segmentation: only the surfaces the
camera can see return points (self-occlusion and occlusion between objects fall out of keeping
the nearest hit per pixel), depth noise grows with depth as on structured-light and stereo
sensors (sigma = base + quadratic * z^2), returns at grazing incidence and random pixels drop
out (NaN in an organised cloud, as real drivers publish), and every point carries its shape's
colour, shaded by incidence.

Everything is vectorised over the whole image (one NumPy pass per shape), so a 640x480 frame
takes tens of milliseconds.

Frames: the camera pose is the pose of the *optical* frame (z forward, x right, y down) in the
world. :meth:`DepthCamera.capture` returns points in the world frame or in the optical frame.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Mapping, Sequence

import numpy as np

from .errors import PerceptionError
from .scene_model import GroundTruthScene, SceneBox, SceneCylinder, _load_yaml, pose_from_vector

# Optical frame (z forward, x right, y down) expressed in a ROS camera link frame (x forward,
# y left, z up): the fixed rotation every ROS camera driver publishes as *_optical_frame.
LINK_TO_OPTICAL = np.array([[0.0, 0.0, 1.0], [-1.0, 0.0, 0.0], [0.0, -1.0, 0.0]])


@dataclass(frozen=True)
class CameraIntrinsics:
    """Pinhole intrinsics in pixels (no distortion: depth clouds are published rectified)."""

    width: int = 640
    height: int = 480
    fx: float = 554.256
    fy: float = 554.256
    cx: float = 319.5
    cy: float = 239.5

    def __post_init__(self) -> None:
        if int(self.width) < 1 or int(self.height) < 1:
            raise PerceptionError(f"camera: image size must be positive, got {self.width}x{self.height}")
        for name in ("fx", "fy", "cx", "cy"):
            if not np.isfinite(getattr(self, name)):
                raise PerceptionError(f"camera: {name} must be finite")
        if self.fx <= 0 or self.fy <= 0:
            raise PerceptionError(f"camera: focal lengths must be positive, got fx={self.fx}, fy={self.fy}")

    @classmethod
    def from_fov(cls, width: int = 640, height: int = 480, horizontal_fov: float = 1.0472) -> CameraIntrinsics:
        """Square pixels, principal point at the image centre, given the horizontal field of view."""
        if not 0.0 < horizontal_fov < np.pi:
            raise PerceptionError(f"camera: horizontal_fov must be in (0, pi), got {horizontal_fov}")
        f = (width / 2.0) / np.tan(horizontal_fov / 2.0)
        return cls(int(width), int(height), f, f, (width - 1) / 2.0, (height - 1) / 2.0)


def look_at(eye: Sequence[float], target: Sequence[float], up: Sequence[float] = (0.0, 0.0, 1.0)) -> np.ndarray:
    """Optical-frame pose at ``eye`` looking at ``target`` (image "up" towards ``up``)."""
    eye, target, up = (np.asarray(v, dtype=float) for v in (eye, target, up))
    forward = target - eye
    if np.linalg.norm(forward) < 1e-9:
        raise PerceptionError("camera look_at: eye and target coincide")
    forward /= np.linalg.norm(forward)
    right = np.cross(forward, up)
    if np.linalg.norm(right) < 1e-9:
        raise PerceptionError("camera look_at: viewing direction is parallel to 'up'")
    right /= np.linalg.norm(right)
    down = np.cross(forward, right)
    T = np.eye(4)
    T[:3, :3] = np.column_stack([right, down, forward])
    T[:3, 3] = eye
    return T


def optical_pose_from_link(link_pose: np.ndarray) -> np.ndarray:
    """Optical-frame pose from a ROS camera *link* pose (x forward, y left, z up)."""
    T = np.array(link_pose, dtype=float)
    T[:3, :3] = T[:3, :3] @ LINK_TO_OPTICAL
    return T


@dataclass
class DepthCameraConfig:
    """Intrinsics, pose and sensor model of the simulated camera."""

    intrinsics: CameraIntrinsics = field(default_factory=CameraIntrinsics)
    pose: np.ndarray = field(default_factory=lambda: look_at((0.22, -0.25, 0.45), (0.4, 0.3, 0.0)))
    near: float = 0.05
    far: float = 1.5
    depth_noise_stddev: float = 0.0002
    """Depth noise at zero depth, metres."""
    depth_noise_quadratic: float = 0.0012
    """Growth of the depth noise with depth: sigma(z) = depth_noise_stddev + depth_noise_quadratic * z^2."""
    dropout_probability: float = 0.02
    """Probability that a valid pixel returns nothing."""
    max_incidence_angle: float = np.deg2rad(80.0)
    """Returns whose ray meets the surface more obliquely than this are dropped (radians)."""
    frame_id: str = "camera_head_depth_optical_frame"

    def __post_init__(self) -> None:
        self.pose = np.asarray(self.pose, dtype=float)
        if self.pose.shape != (4, 4) or not np.all(np.isfinite(self.pose)):
            raise PerceptionError("camera: pose must be a finite 4x4 matrix")
        R = self.pose[:3, :3]
        if not np.allclose(R.T @ R, np.eye(3), atol=1e-6) or np.linalg.det(R) <= 0:
            raise PerceptionError("camera: pose rotation is not a proper rotation")
        if not 0 < self.near < self.far:
            raise PerceptionError(f"camera: need 0 < near < far, got near={self.near}, far={self.far}")
        if self.depth_noise_stddev < 0 or self.depth_noise_quadratic < 0:
            raise PerceptionError("camera: noise parameters must be >= 0")
        if not 0.0 <= self.dropout_probability < 1.0:
            raise PerceptionError(f"camera: dropout_probability must be in [0, 1), got {self.dropout_probability}")
        if not 0.0 < self.max_incidence_angle <= np.pi / 2:
            raise PerceptionError("camera: max_incidence_angle must be in (0, pi/2]")

    def noiseless(self) -> DepthCameraConfig:
        """The same camera without noise or dropouts (for checks against exact geometry)."""
        return DepthCameraConfig(self.intrinsics, self.pose, self.near, self.far, 0.0, 0.0, 0.0,
                                 np.pi / 2, self.frame_id)

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> DepthCameraConfig:
        """Camera from the ``camera:`` mapping of a camera-scene YAML.

        Keys: width, height, and either horizontal_fov or fx, fy, cx, cy; the pose as
        ``position`` + ``look_at`` or as ``link_pose: [x, y, z, roll, pitch, yaw]`` of a ROS camera
        link; near, far, depth_noise_stddev, depth_noise_quadratic, dropout_probability,
        max_incidence_angle_deg, frame_id."""
        if not isinstance(data, Mapping):
            raise PerceptionError(f"camera: expected a mapping, got {type(data).__name__}")
        allowed = {"width", "height", "horizontal_fov", "fx", "fy", "cx", "cy", "position", "look_at",
                   "link_pose", "near", "far", "depth_noise_stddev", "depth_noise_quadratic",
                   "dropout_probability", "max_incidence_angle_deg", "frame_id"}
        unknown = sorted(set(data) - allowed)
        if unknown:
            raise PerceptionError(f"camera: unknown keys {unknown}")
        width, height = int(data.get("width", 640)), int(data.get("height", 480))
        if "fx" in data:
            intr = CameraIntrinsics(width, height, float(data["fx"]), float(data.get("fy", data["fx"])),
                                    float(data.get("cx", (width - 1) / 2)), float(data.get("cy", (height - 1) / 2)))
        else:
            intr = CameraIntrinsics.from_fov(width, height, float(data.get("horizontal_fov", 1.0472)))
        if "link_pose" in data:
            pose = optical_pose_from_link(pose_from_vector(data["link_pose"], "camera.link_pose"))
        elif "position" in data and "look_at" in data:
            pose = look_at(data["position"], data["look_at"])
        else:
            raise PerceptionError("camera: give either link_pose or position + look_at")
        defaults = cls.__dataclass_fields__
        return cls(
            intr, pose,
            float(data.get("near", defaults["near"].default)),
            float(data.get("far", defaults["far"].default)),
            float(data.get("depth_noise_stddev", defaults["depth_noise_stddev"].default)),
            float(data.get("depth_noise_quadratic", defaults["depth_noise_quadratic"].default)),
            float(data.get("dropout_probability", defaults["dropout_probability"].default)),
            float(np.deg2rad(data.get("max_incidence_angle_deg", 80.0))),
            str(data.get("frame_id", defaults["frame_id"].default)),
        )


@dataclass
class SimulatedCloud:
    """One frame. ``points`` (H, W, 3) float32 with NaN where there is no return, ``colors``
    (H, W, 3) uint8, ``labels`` (H, W) index into ``scene.shapes()`` (-1 no return, -2 floor),
    ``frame_id`` the frame of ``points``, ``camera_pose`` the optical frame in the world."""

    points: np.ndarray
    colors: np.ndarray
    labels: np.ndarray
    frame_id: str
    camera_pose: np.ndarray

    @property
    def valid(self) -> np.ndarray:
        return self.labels != -1

    def unorganized(self) -> tuple[np.ndarray, np.ndarray]:
        """(N, 3) points and (N, 3) colours of the returns only (NaNs dropped)."""
        mask = ~np.isnan(self.points[..., 0])
        return self.points[mask], self.colors[mask]


class DepthCamera:
    """Renders a :class:`GroundTruthScene` into point clouds (see module docstring)."""

    def __init__(self, config: DepthCameraConfig | None = None) -> None:
        self.config = config or DepthCameraConfig()
        intr = self.config.intrinsics
        u, v = np.meshgrid(np.arange(intr.width, dtype=float), np.arange(intr.height, dtype=float))
        # Ray directions in the optical frame scaled so that their z component is 1: the ray
        # parameter t of every intersection below is then directly the depth z.
        self._rays_cam = np.stack([(u - intr.cx) / intr.fx, (v - intr.cy) / intr.fy, np.ones_like(u)], axis=-1)
        self._rays_cam = self._rays_cam.reshape(-1, 3)
        self._ray_norm = np.linalg.norm(self._rays_cam, axis=1)

    def _candidate_rays(self, shape: SceneBox | SceneCylinder, R: np.ndarray, eye: np.ndarray) -> np.ndarray | slice:
        """Indices of the pixels whose rays can hit ``shape``: the image rectangle covering the
        projection of its bounding box (all pixels if the box reaches behind the camera).
        Intersecting only those rays keeps a frame cheap when objects are small in the image."""
        intr = self.config.intrinsics
        half = shape.size / 2.0 if isinstance(shape, SceneBox) else np.array([shape.radius, shape.radius, shape.height / 2.0])
        corners = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)]) * half
        world = corners @ shape.pose[:3, :3].T + shape.pose[:3, 3]
        cam = (world - eye) @ R
        if np.any(cam[:, 2] <= 1e-6):
            return slice(None)
        u = intr.fx * cam[:, 0] / cam[:, 2] + intr.cx
        v = intr.fy * cam[:, 1] / cam[:, 2] + intr.cy
        u0, u1 = int(max(0, np.floor(u.min()) - 1)), int(min(intr.width - 1, np.ceil(u.max()) + 1))
        v0, v1 = int(max(0, np.floor(v.min()) - 1)), int(min(intr.height - 1, np.ceil(v.max()) + 1))
        if u0 > u1 or v0 > v1:
            return np.zeros(0, dtype=np.int64)
        if u0 == 0 and v0 == 0 and u1 == intr.width - 1 and v1 == intr.height - 1:
            return slice(None)
        cols = np.arange(u0, u1 + 1)
        rows = np.arange(v0, v1 + 1)
        return (rows[:, None] * intr.width + cols[None, :]).reshape(-1)

    def capture(self, scene: GroundTruthScene, rng: np.random.Generator | int | None = None,
                frame: str = "world") -> SimulatedCloud:
        """Render one noisy frame. ``frame``: "world" (points in the scene's frame, ``frame_id``
        = ``scene.frame_id``) or "camera" (points in the optical frame, ``config.frame_id``)."""
        if frame not in ("world", "camera"):
            raise PerceptionError(f"capture: frame must be 'world' or 'camera', got {frame!r}")
        cfg, intr = self.config, self.config.intrinsics
        rng = rng if isinstance(rng, np.random.Generator) else np.random.default_rng(rng)
        R, eye = cfg.pose[:3, :3], cfg.pose[:3, 3]
        dirs = self._rays_cam @ R.T  # world directions, z-depth parametrised
        n_rays = dirs.shape[0]
        depth = np.full(n_rays, np.inf)
        label = np.full(n_rays, -1, dtype=np.int32)
        shapes = scene.shapes()
        # Pass 1: the nearest depth per pixel (a z-buffer), each shape on the pixels it can cover.
        for index, shape in enumerate(shapes):
            rays = self._candidate_rays(shape, R, eye)
            if isinstance(rays, np.ndarray) and rays.size == 0:
                continue
            intersect = _intersect_box if isinstance(shape, SceneBox) else _intersect_cylinder
            t, _ = intersect(eye, dirs[rays], shape, cfg.near, with_normals=False)
            closer = t < depth[rays]
            if isinstance(rays, slice):
                depth[closer], label[closer] = t[closer], index
            else:
                depth[rays[closer]], label[rays[closer]] = t[closer], index
        if scene.ground_plane_z is not None:
            t, _ = _intersect_ground(eye, dirs, scene.ground_plane_z, cfg.near)
            closer = t < depth
            depth[closer], label[closer] = t[closer], -2
        # Pass 2: surface normals only where each shape won.
        normal = np.zeros((n_rays, 3))
        for index, shape in enumerate(shapes):
            won = np.flatnonzero(label == index)
            if won.size:
                intersect = _intersect_box if isinstance(shape, SceneBox) else _intersect_cylinder
                normal[won] = intersect(eye, dirs[won], shape, cfg.near, with_normals=True)[1]
        if scene.ground_plane_z is not None:
            normal[label == -2, 2] = 1.0 if eye[2] > scene.ground_plane_z else -1.0

        hit = np.isfinite(depth) & (depth <= cfg.far)
        unit = dirs / self._ray_norm[:, None]
        cos_inc = np.abs(np.einsum("ij,ij->i", normal, unit))
        hit &= cos_inc >= np.cos(cfg.max_incidence_angle)
        if cfg.dropout_probability > 0:
            hit &= rng.random(n_rays) >= cfg.dropout_probability
        z = np.where(hit, depth, np.nan)
        sigma = cfg.depth_noise_stddev + cfg.depth_noise_quadratic * np.square(np.nan_to_num(z))
        if np.any(sigma > 0):
            z = z + rng.standard_normal(n_rays) * sigma
        hit &= z > cfg.near
        z = np.where(hit, z, np.nan)

        colors = np.zeros((n_rays, 3), dtype=np.uint8)
        palette = {i: s.color for i, s in enumerate(scene.shapes())}
        palette[-2] = scene.ground_color
        shade = 0.55 + 0.45 * cos_inc
        for index, rgb in palette.items():
            sel = hit & (label == index)
            if np.any(sel):
                colors[sel] = np.clip(np.outer(shade[sel], rgb), 0, 255).astype(np.uint8)
        label = np.where(hit, label, -1)
        # The floor keeps label -2 so callers can tell it from "no return".
        if frame == "world":
            pts = eye + z[:, None] * dirs
            frame_id = scene.frame_id
        else:
            pts = z[:, None] * self._rays_cam
            frame_id = cfg.frame_id
        shape_hw = (intr.height, intr.width)
        return SimulatedCloud(pts.reshape(*shape_hw, 3).astype(np.float32), colors.reshape(*shape_hw, 3),
                              label.reshape(shape_hw), frame_id, cfg.pose.copy())


def _to_local(eye: np.ndarray, dirs: np.ndarray, pose: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    R, c = pose[:3, :3], pose[:3, 3]
    return R.T @ (eye - c), dirs @ R


def _intersect_box(eye: np.ndarray, dirs: np.ndarray, box: SceneBox, near: float,
                   with_normals: bool = True) -> tuple[np.ndarray, np.ndarray | None]:
    """Slab test: entry depth (inf on a miss) and the world normal of the entry face."""
    o, d = _to_local(eye, dirs, box.pose)
    half = box.size / 2.0
    with np.errstate(divide="ignore", invalid="ignore"):
        inv = 1.0 / d
        t1 = (-half - o) * inv
        t2 = (half - o) * inv
    tlo = np.fmin(t1, t2)
    thi = np.fmax(t1, t2)
    # A ray parallel to a slab and outside it gives nan/inf pairs: treat as a miss.
    tlo = np.where(np.isnan(tlo), -np.inf, tlo)
    thi = np.where(np.isnan(thi), np.inf, thi)
    t_enter = tlo.max(axis=1)
    t_exit = thi.min(axis=1)
    hit = (t_enter <= t_exit) & (t_enter > near)
    t = np.where(hit, t_enter, np.inf)
    if not with_normals:
        return t, None
    axis = tlo.argmax(axis=1)
    n_local = np.zeros_like(d)
    rows = np.arange(d.shape[0])
    n_local[rows, axis] = -np.sign(d[rows, axis])
    return t, n_local @ box.pose[:3, :3].T


def _intersect_cylinder(eye: np.ndarray, dirs: np.ndarray, cyl: SceneCylinder, near: float,
                        with_normals: bool = True) -> tuple[np.ndarray, np.ndarray | None]:
    """Nearest hit on the side or the caps of a finite cylinder (axis = local z)."""
    o, d = _to_local(eye, dirs, cyl.pose)
    r, h2 = cyl.radius, cyl.height / 2.0
    a = d[:, 0] ** 2 + d[:, 1] ** 2
    b = 2.0 * (o[0] * d[:, 0] + o[1] * d[:, 1])
    c = o[0] ** 2 + o[1] ** 2 - r * r
    disc = b * b - 4 * a * c
    with np.errstate(divide="ignore", invalid="ignore"):
        t_side = (-b - np.sqrt(disc)) / (2 * a)
    z_side = o[2] + t_side * d[:, 2]
    side_ok = (disc >= 0) & (a > 1e-15) & (t_side > near) & (np.abs(z_side) <= h2)
    t_side = np.where(side_ok, t_side, np.inf)
    # Only the cap facing the eye can be the first hit from outside.
    cap_z = h2 if o[2] > 0 else -h2
    with np.errstate(divide="ignore", invalid="ignore"):
        t_cap = (cap_z - o[2]) / d[:, 2]
    px, py = o[0] + t_cap * d[:, 0], o[1] + t_cap * d[:, 1]
    cap_ok = np.isfinite(t_cap) & (t_cap > near) & (px * px + py * py <= r * r)
    t_cap = np.where(cap_ok, t_cap, np.inf)
    use_cap = t_cap < t_side
    t = np.where(use_cap, t_cap, t_side)
    if not with_normals:
        return t, None
    hit_pts = o + np.where(np.isfinite(t), t, 0.0)[:, None] * d
    n_local = np.zeros_like(d)
    n_local[:, 0] = np.where(use_cap, 0.0, hit_pts[:, 0] / r)
    n_local[:, 1] = np.where(use_cap, 0.0, hit_pts[:, 1] / r)
    n_local[:, 2] = np.where(use_cap, np.sign(cap_z), 0.0)
    return t, n_local @ cyl.pose[:3, :3].T


def _intersect_ground(eye: np.ndarray, dirs: np.ndarray, z0: float, near: float) -> tuple[np.ndarray, np.ndarray]:
    with np.errstate(divide="ignore", invalid="ignore"):
        t = (z0 - eye[2]) / dirs[:, 2]
    t = np.where(np.isfinite(t) & (t > near), t, np.inf)
    n = np.zeros_like(dirs)
    n[:, 2] = 1.0 if eye[2] > z0 else -1.0
    return t, n


def load_camera_scene(path: str | Path) -> tuple[DepthCameraConfig, GroundTruthScene]:
    """The ``camera:`` and ``scene:`` sections of a camera-scene YAML (``config/camera_scene.yaml``)."""
    data = _load_yaml(path)
    for key in ("camera", "scene"):
        if key not in data:
            raise PerceptionError(f"{path}: no '{key}' section")
    return DepthCameraConfig.from_dict(data["camera"]), GroundTruthScene.from_dict(data["scene"])
