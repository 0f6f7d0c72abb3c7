"""The byte layout of sensor_msgs/PointCloud2, packed and unpacked with NumPy (no ROS import).

Why here and not in the node: reading a PointCloud2 is where garbage input arrives (missing
fields, truncated buffers, odd datatypes), and the checks deserve unit tests without a ROS
graph. The nodes call :func:`pack_xyzrgb` / :func:`unpack_cloud` and copy the result into or
out of the message.

Layout written by :func:`pack_xyzrgb` (what depth camera drivers and PCL's PointXYZRGB use):
fields ``x``, ``y``, ``z`` (FLOAT32 at offsets 0, 4, 8) and ``rgb`` (FLOAT32 at 12 whose bits
are the uint32 ``0x00RRGGBB``), ``point_step`` 16, little-endian; organised clouds keep
``height`` > 1 and NaN coordinates for pixels without a return (``is_dense`` false).

:func:`unpack_cloud` reads any layout that has x, y and z of any numeric PointField datatype,
at any offsets and point step, either byte order, with an optional packed ``rgb``/``rgba``
field. Anything else raises :class:`CloudFormatError` naming the problem.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Iterable, Mapping

import numpy as np

from .errors import CloudFormatError

# sensor_msgs/PointField datatypes
INT8, UINT8, INT16, UINT16, INT32, UINT32, FLOAT32, FLOAT64 = 1, 2, 3, 4, 5, 6, 7, 8
_DTYPES = {INT8: "i1", UINT8: "u1", INT16: "i2", UINT16: "u2", INT32: "i4", UINT32: "u4",
           FLOAT32: "f4", FLOAT64: "f8"}
_NAMES = {INT8: "INT8", UINT8: "UINT8", INT16: "INT16", UINT16: "UINT16", INT32: "INT32",
          UINT32: "UINT32", FLOAT32: "FLOAT32", FLOAT64: "FLOAT64"}


@dataclass(frozen=True)
class PointFieldSpec:
    """One sensor_msgs/PointField: name, byte offset in a point, datatype constant, count."""

    name: str
    offset: int
    datatype: int
    count: int = 1

    def as_dict(self) -> dict[str, Any]:
        return {"name": self.name, "offset": self.offset, "datatype": self.datatype, "count": self.count}


XYZRGB_FIELDS = (
    PointFieldSpec("x", 0, FLOAT32),
    PointFieldSpec("y", 4, FLOAT32),
    PointFieldSpec("z", 8, FLOAT32),
    PointFieldSpec("rgb", 12, FLOAT32),
)


@dataclass
class PackedCloud:
    """Everything a PointCloud2 needs except the header (frame and stamp are the node's)."""

    height: int
    width: int
    fields: tuple[PointFieldSpec, ...]
    is_bigendian: bool
    point_step: int
    row_step: int
    data: bytes
    is_dense: bool


def pack_rgb(colors: np.ndarray) -> np.ndarray:
    """(..., 3) uint8 colours → float32 whose bits are 0x00RRGGBB (PCL's packed rgb)."""
    c = np.asarray(colors).astype(np.uint32)
    return ((c[..., 0] << 16) | (c[..., 1] << 8) | c[..., 2]).astype(np.uint32).view(np.float32)


def unpack_rgb(packed: np.ndarray) -> np.ndarray:
    """Inverse of :func:`pack_rgb` (float32 or uint32 input) → (..., 3) uint8."""
    bits = np.ascontiguousarray(packed).view(np.uint32) if packed.dtype.itemsize == 4 else packed.astype(np.uint32)
    return np.stack([(bits >> 16) & 0xFF, (bits >> 8) & 0xFF, bits & 0xFF], axis=-1).astype(np.uint8)


def pack_xyzrgb(points: np.ndarray, colors: np.ndarray | None = None) -> PackedCloud:
    """Pack (N, 3) or organised (H, W, 3) points (+ colours of the same leading shape, uint8 or
    floats in 0..255) into the XYZRGB layout above. Missing colours are written as white."""
    pts = np.asarray(points)
    if pts.ndim not in (2, 3) or pts.shape[-1] != 3:
        raise CloudFormatError(f"points must have shape (N, 3) or (H, W, 3), got {pts.shape}")
    if not np.issubdtype(pts.dtype, np.number):
        raise CloudFormatError(f"points must be numeric, got dtype {pts.dtype}")
    height, width = (1, pts.shape[0]) if pts.ndim == 2 else pts.shape[:2]
    if colors is None:
        cols = np.full(pts.shape, 255, dtype=np.uint8)
    else:
        cols = np.asarray(colors)
        if cols.shape != pts.shape:
            raise CloudFormatError(f"colors shape {cols.shape} does not match points shape {pts.shape}")
        if not np.issubdtype(cols.dtype, np.number):
            raise CloudFormatError(f"colors must be numeric, got dtype {cols.dtype}")
        if cols.dtype != np.uint8:
            if np.any(~np.isfinite(cols)) or np.any(cols < 0) or np.any(cols > 255):
                raise CloudFormatError("colors must be finite values in 0..255")
            cols = np.round(cols).astype(np.uint8)
    rec = np.empty(height * width, dtype=np.dtype({"names": ["x", "y", "z", "rgb"],
                                                   "formats": ["<f4", "<f4", "<f4", "<f4"],
                                                   "offsets": [0, 4, 8, 12], "itemsize": 16}))
    flat = pts.reshape(-1, 3)
    rec["x"], rec["y"], rec["z"] = flat[:, 0], flat[:, 1], flat[:, 2]
    rec["rgb"] = pack_rgb(cols.reshape(-1, 3))
    dense = bool(np.all(np.isfinite(flat)))
    return PackedCloud(int(height), int(width), XYZRGB_FIELDS, False, 16, 16 * int(width), rec.tobytes(), dense)


def _field_attr(field: Any, name: str) -> Any:
    if isinstance(field, Mapping):
        return field.get(name)
    return getattr(field, name, None)


def _read_fields(fields: Iterable[Any]) -> dict[str, PointFieldSpec]:
    out: dict[str, PointFieldSpec] = {}
    for i, f in enumerate(fields):
        name, offset, datatype, count = (_field_attr(f, k) for k in ("name", "offset", "datatype", "count"))
        if not isinstance(name, str) or not name:
            raise CloudFormatError(f"PointCloud2 field {i} has no name")
        try:
            offset, datatype = int(offset), int(datatype)
            count = 1 if count is None else int(count)
        except (TypeError, ValueError):
            raise CloudFormatError(f"PointCloud2 field '{name}' has a non-integer offset/datatype/count") from None
        out[name] = PointFieldSpec(name, offset, datatype, count)
    return out


def unpack_cloud(height: int, width: int, fields: Iterable[Any], point_step: int, row_step: int,
                 data: bytes | bytearray | memoryview | np.ndarray | Iterable[int],
                 is_bigendian: bool = False, *, keep_organized: bool = False) -> tuple[np.ndarray, np.ndarray | None]:
    """Read points and colours out of a PointCloud2's fields.

    ``fields`` are PointField messages or mappings with name/offset/datatype/count. Returns
    ``(points, colors)``: points float64 (N, 3) — or (H, W, 3) with ``keep_organized`` — with
    invalid pixels left as NaN (removing them is the pipeline's job); colours uint8 of the same
    leading shape, or None when the cloud has no rgb/rgba field."""
    try:
        height, width, point_step, row_step = int(height), int(width), int(point_step), int(row_step)
    except (TypeError, ValueError):
        raise CloudFormatError("PointCloud2 height/width/point_step/row_step must be integers") from None
    if height < 0 or width < 0:
        raise CloudFormatError(f"PointCloud2 has a negative size {height}x{width}")
    specs = _read_fields(fields)
    missing = [axis for axis in "xyz" if axis not in specs]
    if missing:
        raise CloudFormatError(f"PointCloud2 has no {', '.join(repr(m) for m in missing)} field; "
                               f"fields are {sorted(specs)}")
    n = height * width
    if n == 0:
        raise CloudFormatError("PointCloud2 is empty (height * width = 0)")
    if point_step <= 0:
        raise CloudFormatError(f"PointCloud2 point_step must be positive, got {point_step}")
    if row_step < point_step * width:
        raise CloudFormatError(f"PointCloud2 row_step {row_step} is smaller than width * point_step "
                               f"= {point_step * width}")
    if isinstance(data, np.ndarray):
        buf = np.ascontiguousarray(data).view(np.uint8).reshape(-1)
    elif isinstance(data, (bytes, bytearray, memoryview)):
        buf = np.frombuffer(data, dtype=np.uint8)
    else:  # rclpy hands out array.array('B') or a list of ints
        try:
            buf = np.frombuffer(bytes(data), dtype=np.uint8)
        except (TypeError, ValueError):
            raise CloudFormatError("PointCloud2 data is not a byte buffer") from None
    need = row_step * height
    if buf.size < need:
        raise CloudFormatError(f"PointCloud2 data has {buf.size} bytes, expected {need} "
                               f"(height {height} x row_step {row_step})")
    order = ">" if is_bigendian else "<"
    names, formats, offsets = [], [], []
    for name in ("x", "y", "z"):
        spec = specs[name]
        if spec.datatype not in _DTYPES:
            raise CloudFormatError(f"PointCloud2 field '{name}' has unknown datatype {spec.datatype}")
        names.append(name)
        formats.append(order + _DTYPES[spec.datatype])
        offsets.append(spec.offset)
    color_name = next((c for c in ("rgb", "rgba") if c in specs), None)
    if color_name is not None:
        spec = specs[color_name]
        if spec.datatype not in (FLOAT32, UINT32, INT32):
            raise CloudFormatError(f"PointCloud2 field '{color_name}' must be a packed 4-byte value "
                                   f"(FLOAT32 or UINT32), got {_NAMES.get(spec.datatype, spec.datatype)}")
        names.append("rgb")
        formats.append(order + "u4")
        offsets.append(spec.offset)
    for name, fmt, off in zip(names, formats, offsets):
        if off < 0 or off + np.dtype(fmt).itemsize > point_step:
            raise CloudFormatError(f"PointCloud2 field '{name}' at offset {off} does not fit in "
                                   f"point_step {point_step}")
    dtype = np.dtype({"names": names, "formats": formats, "offsets": offsets, "itemsize": point_step})
    rows = buf[:need].reshape(height, row_step)[:, : point_step * width]
    rec = np.ascontiguousarray(rows).view(dtype).reshape(height, width)
    points = np.stack([rec["x"], rec["y"], rec["z"]], axis=-1).astype(np.float64)
    colors = unpack_rgb(rec["rgb"].astype(np.uint32)) if color_name is not None else None
    if not keep_organized:
        points = points.reshape(-1, 3)
        colors = None if colors is None else colors.reshape(-1, 3)
    return points, colors


def unpack_message(msg: Any, *, keep_organized: bool = False) -> tuple[np.ndarray, np.ndarray | None]:
    """:func:`unpack_cloud` on anything shaped like a sensor_msgs/PointCloud2 (duck-typed, so
    this module never imports ROS)."""
    try:
        args = (msg.height, msg.width, msg.fields, msg.point_step, msg.row_step, msg.data, msg.is_bigendian)
    except AttributeError as err:
        raise CloudFormatError(f"not a PointCloud2-like message: {err}") from None
    return unpack_cloud(*args, keep_organized=keep_organized)

