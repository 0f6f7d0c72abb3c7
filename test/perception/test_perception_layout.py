"""PointCloud2 byte layout: packing, unpacking any reasonable layout, and clear errors."""
from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from mycobot_planning.perception.errors import CloudFormatError
from mycobot_planning.perception.pointcloud_layout import (
    FLOAT32, FLOAT64, INT16, UINT8, UINT32, PointFieldSpec, pack_rgb, pack_xyzrgb, unpack_cloud, unpack_message,
    unpack_rgb,
)


def _message(packed, **overrides):
    fields = dict(height=packed.height, width=packed.width, fields=list(packed.fields),
                  point_step=packed.point_step, row_step=packed.row_step, data=packed.data,
                  is_bigendian=packed.is_bigendian)
    fields.update(overrides)
    return SimpleNamespace(**fields)


def test_organised_round_trip_keeps_nans_and_colours():
    rng = np.random.default_rng(0)
    pts = rng.normal(size=(4, 5, 3)).astype(np.float32)
    pts[1, 2] = np.nan
    cols = rng.integers(0, 256, size=(4, 5, 3), dtype=np.uint8)
    packed = pack_xyzrgb(pts, cols)
    assert (packed.height, packed.width, packed.point_step, packed.row_step) == (4, 5, 16, 80)
    assert [f.name for f in packed.fields] == ["x", "y", "z", "rgb"]
    assert [f.offset for f in packed.fields] == [0, 4, 8, 12]
    assert all(f.datatype == FLOAT32 for f in packed.fields)
    assert not packed.is_dense and len(packed.data) == 4 * 5 * 16
    out, out_cols = unpack_message(_message(packed), keep_organized=True)
    assert out.shape == (4, 5, 3) and out.dtype == np.float64
    np.testing.assert_array_equal(np.isnan(out), np.isnan(pts))
    np.testing.assert_allclose(out[~np.isnan(out)], pts[~np.isnan(pts)])
    np.testing.assert_array_equal(out_cols, cols)
    flat, flat_cols = unpack_message(_message(packed))
    assert flat.shape == (20, 3) and flat_cols.shape == (20, 3)


def test_packed_rgb_is_pcl_layout():
    packed = pack_rgb(np.array([[255, 128, 1]], dtype=np.uint8))
    assert packed.dtype == np.float32
    assert packed.view(np.uint32)[0] == 0x00FF8001
    np.testing.assert_array_equal(unpack_rgb(packed), [[255, 128, 1]])


def test_missing_colours_are_white_and_dense_flag():
    packed = pack_xyzrgb(np.zeros((3, 3)))
    assert packed.is_dense
    _, cols = unpack_cloud(1, 3, packed.fields, 16, 48, packed.data)
    np.testing.assert_array_equal(cols, np.full((3, 3), 255))


def test_foreign_layout_float64_big_endian_padding_and_row_padding():
    """x/y/z as FLOAT64 at odd offsets, an extra intensity field, big-endian, padded rows."""
    n = 3
    dtype = np.dtype({"names": ["i", "z", "y", "x", "rgba"], "formats": [">i2", ">f8", ">f8", ">f8", ">u4"],
                      "offsets": [0, 2, 10, 18, 26], "itemsize": 32})
    rec = np.zeros(n, dtype=dtype)
    rec["x"], rec["y"], rec["z"] = [1.5, 2.5, 3.5], [-1, -2, -3], [0.25, 0.5, 0.75]
    rec["rgba"] = [0xFF102030, 0x00FFFFFF, 0x00000000]
    row = rec.tobytes() + b"\x00" * 8  # row_step larger than width * point_step
    fields = [{"name": "intensity", "offset": 0, "datatype": INT16, "count": 1},
              {"name": "z", "offset": 2, "datatype": FLOAT64, "count": 1},
              {"name": "y", "offset": 10, "datatype": FLOAT64, "count": 1},
              {"name": "x", "offset": 18, "datatype": FLOAT64, "count": 1},
              {"name": "rgba", "offset": 26, "datatype": UINT32, "count": 1}]
    pts, cols = unpack_cloud(1, n, fields, 32, 32 * n + 8, row, is_bigendian=True)
    np.testing.assert_allclose(pts, [[1.5, -1, 0.25], [2.5, -2, 0.5], [3.5, -3, 0.75]])
    np.testing.assert_array_equal(cols, [[0x10, 0x20, 0x30], [255, 255, 255], [0, 0, 0]])


def test_xyz_only_cloud_has_no_colours_and_accepts_array_data():
    data = np.arange(6, dtype="<f4")
    pts, cols = unpack_cloud(1, 2, [PointFieldSpec("x", 0, FLOAT32), PointFieldSpec("y", 4, FLOAT32),
                                    PointFieldSpec("z", 8, FLOAT32)], 12, 24, list(data.tobytes()))
    assert cols is None
    np.testing.assert_allclose(pts, [[0, 1, 2], [3, 4, 5]])


XYZ = [PointFieldSpec("x", 0, FLOAT32), PointFieldSpec("y", 4, FLOAT32), PointFieldSpec("z", 8, FLOAT32)]


@pytest.mark.parametrize("kwargs, message", [
    (dict(fields=XYZ[:2]), "no 'z' field; fields are \\['x', 'y'\\]"),
    (dict(fields=[]), "no 'x', 'y', 'z' field"),
    (dict(height=0), "empty"),
    (dict(data=b"\x00" * 20), "has 20 bytes, expected 24"),
    (dict(point_step=8, row_step=16), "field 'z' at offset 8 does not fit in point_step 8"),
    (dict(row_step=10), "row_step 10 is smaller than width \\* point_step = 24"),
    (dict(point_step=0), "point_step must be positive"),
    (dict(fields=XYZ[:2] + [PointFieldSpec("z", 8, 42)]), "unknown datatype 42"),
    (dict(fields=XYZ + [PointFieldSpec("rgb", 12, UINT8)], point_step=13, row_step=26, data=b"\x00" * 26),
     "'rgb' must be a packed 4-byte value"),
    (dict(fields=[{"offset": 0, "datatype": FLOAT32}]), "field 0 has no name"),
    (dict(data=object()), "not a byte buffer"),
])
def test_malformed_clouds_raise_clear_errors(kwargs, message):
    args = dict(height=1, width=2, fields=XYZ, point_step=12, row_step=24, data=b"\x00" * 24)
    args.update(kwargs)
    with pytest.raises(CloudFormatError, match=message):
        unpack_cloud(**args)


def test_not_a_message_and_bad_pack_inputs():
    with pytest.raises(CloudFormatError, match="not a PointCloud2-like message"):
        unpack_message(object())
    with pytest.raises(CloudFormatError, match=r"shape \(N, 3\) or \(H, W, 3\)"):
        pack_xyzrgb(np.zeros((4, 2)))
    with pytest.raises(CloudFormatError, match="does not match"):
        pack_xyzrgb(np.zeros((4, 3)), np.zeros((3, 3)))
    with pytest.raises(CloudFormatError, match="0..255"):
        pack_xyzrgb(np.zeros((1, 3)), np.array([[300.0, 0, 0]]))
