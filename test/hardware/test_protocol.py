"""The myCobot 280 serial frames: layout, angle encoding, resynchronisation on garbage."""
from __future__ import annotations

import pytest

from mycobot_planning.hardware.protocol import (
    Cmd,
    Frame,
    FrameParser,
    decode_angles,
    encode_angles,
    encode_frame,
    wire_seconds,
)
from mycobot_planning.hardware.servo_model import ServoConfig, ServoModel, deg_per_s_to_speed


def test_frame_layout_is_header_length_command_data_footer():
    # get_angles request as pymycobot sends it: FE FE 02 20 FA
    assert encode_frame(Cmd.GET_ANGLES) == bytes([0xFE, 0xFE, 0x02, 0x20, 0xFA])
    # send_angles: 12 bytes of angles + speed -> LEN = 15
    frame = encode_frame(Cmd.SEND_ANGLES, encode_angles([10, -20.5, 0, 0, 0, 165]) + bytes([50]))
    assert frame[:4] == bytes([0xFE, 0xFE, 15, 0x22]) and frame[-1] == 0xFA and len(frame) == 18


def test_angles_are_int16_big_endian_hundredths_of_a_degree():
    data = encode_angles([10.0, -20.5, 0.01, -0.01, 168.0, -180.0])
    assert data[:2] == bytes([0x03, 0xE8])  # 1000
    assert data[2:4] == (-2050).to_bytes(2, "big", signed=True)
    assert decode_angles(data) == [10.0, -20.5, 0.01, -0.01, 168.0, -180.0]
    with pytest.raises(ValueError):
        decode_angles(b"\x00")


def test_parser_splits_a_stream_and_skips_garbage():
    parser = FrameParser()
    a = encode_frame(Cmd.GET_ANGLES)
    b = encode_frame(Cmd.SET_GRIPPER_VALUE, [30, 50])
    stream = b"\x00\x13" + a + b"\xfe\x42" + b
    frames = parser.feed(stream[:5]) + parser.feed(stream[5:])
    assert frames == [Frame(Cmd.GET_ANGLES), Frame(Cmd.SET_GRIPPER_VALUE, bytes([30, 50]))]
    assert parser.skipped == 4
    assert frames[1].name == "SET_GRIPPER_VALUE"


def test_wire_time_at_115200_baud():
    assert wire_seconds(18, 115200) == pytest.approx(18 * 10 / 115200)


def test_servo_model_moves_each_joint_at_the_commanded_speed_and_stalls_on_request():
    model = ServoModel(ServoConfig(noise_deg=0.0, readback_latency=0.0), now=0.0)
    model.send_angles([80, -10, 0, 0, 0, 0], 50)  # 50 % of 160 deg/s = 80 deg/s
    model.advance(0.5)
    assert model.true_angles()[0] == pytest.approx(40.0)
    assert model.true_angles()[1] == pytest.approx(-10.0)
    model.stall(1)
    model.advance(1.0)
    assert model.true_angles()[0] == pytest.approx(40.0)
    model.clear_faults()
    model.stop()
    model.advance(2.0)
    assert model.true_angles()[0] == pytest.approx(40.0)  # stop: targets are where the joints are
    model.send_angles([500, 0, 0, 0, 0, 0], 100)  # clamped to the firmware's limit (168 deg)
    model.advance(10.0)
    assert model.true_angles()[0] == pytest.approx(168.0)


def test_readback_lags_by_the_latency():
    model = ServoModel(ServoConfig(noise_deg=0.0, readback_latency=0.1), now=0.0)
    model.send_angles([160, 0, 0, 0, 0, 0], 100)
    for i in range(1, 11):
        model.advance(i * 0.05)
    assert model.read_angles()[0] == pytest.approx(64.0)  # state at 0.4 s, not at 0.5 s (80 deg)


def test_speed_byte_for_a_joint_speed():
    assert deg_per_s_to_speed(80.0, 160.0) == 50
    assert deg_per_s_to_speed(80.1, 160.0) == 51
    assert deg_per_s_to_speed(0.0, 160.0) == 1
    assert deg_per_s_to_speed(1000.0, 160.0) == 100
