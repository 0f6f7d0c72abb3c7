"""ros.stamped_cdr: a message kept serialized with its stamp written in place reads back, through
rclpy's own deserialization, as the same message with the new stamp, for the two messages the
controller manager publishes that way (and for a stamp past 2038 in nanoseconds' range)."""
from __future__ import annotations

import pytest
from control_msgs.msg import JointTrajectoryControllerState
from rclpy.serialization import deserialize_message
from sensor_msgs.msg import JointState
from trajectory_msgs.msg import JointTrajectoryPoint

from mycobot_planning.ros.stamped_cdr import StampedCdr


class Recorder:
    def __init__(self) -> None:
        self.sent: list[bytes] = []

    def publish(self, data: bytes) -> None:
        self.sent.append(data)


def joint_state() -> JointState:
    msg = JointState()
    msg.name = [f"joint{i}" for i in range(12)]
    msg.position = [0.1 * i for i in range(12)]
    msg.velocity = [-0.01 * i for i in range(12)]
    return msg


def controller_state() -> JointTrajectoryControllerState:
    msg = JointTrajectoryControllerState()
    msg.joint_names = ["a", "b"]
    point = JointTrajectoryPoint(positions=[0.5, -0.25], velocities=[0.0, 1.0], accelerations=[2.0, 3.0])
    point.time_from_start.sec, point.time_from_start.nanosec = 3, 7
    msg.reference = msg.feedback = msg.error = msg.output = point
    return msg


@pytest.mark.parametrize("make", [joint_state, controller_state])
@pytest.mark.parametrize("sec, nanosec", [(0, 1), (1_795_834_683, 185_039_988), (2_147_483_647, 999_999_999)])
def test_the_bytes_read_back_as_the_message_with_the_new_stamp(make, sec, nanosec):
    msg = make()
    cdr, out = StampedCdr(), Recorder()
    cdr.update(msg)
    cdr.publish(out, 12, 34)  # an earlier stamp, overwritten by the next publication
    cdr.publish(out, sec, nanosec)
    first, back = (deserialize_message(data, type(msg)) for data in out.sent)
    assert (first.header.stamp.sec, first.header.stamp.nanosec) == (12, 34)
    assert (back.header.stamp.sec, back.header.stamp.nanosec) == (sec, nanosec)
    msg.header.stamp.sec, msg.header.stamp.nanosec = sec, nanosec
    assert back == msg
