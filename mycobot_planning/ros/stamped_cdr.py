"""A message published many times a second with only its stamp changing, kept serialized.

The controller manager publishes /joint_states and each controller's controller_state a hundred
times a second, and while the joints hold still nothing but header.stamp changes. rclpy converts
a message field by field into C on every publish (names, three trajectory points); publishing
the serialized bytes with the stamp written in place skips that, and was the largest part of the
idle mock_controllers' CPU (bench idle_cpu). rclpy publishes ``bytes`` as a serialized message.
"""
from __future__ import annotations

import struct
from typing import Any

from rclpy.serialization import serialize_message

#: where header.stamp is in a CDR (little-endian) message whose first field is a std_msgs/Header:
#: after the 4-byte encapsulation header, sec (int32) then nanosec (uint32)
CDR_STAMP_OFFSET = 4
_STAMP = struct.Struct("<iI")


class StampedCdr:
    """One message's serialized bytes; ``publish`` writes a new stamp into them and sends them."""

    def __init__(self) -> None:
        self._cdr = bytearray()

    def update(self, msg: Any) -> None:
        """Serialize ``msg`` (whose first field is a std_msgs/Header) after a change of its content."""
        cdr = bytearray(serialize_message(msg))
        if cdr[:2] != b"\x00\x01":  # not CDR little-endian: the offset below would be wrong
            raise ValueError(f"unexpected CDR encapsulation {bytes(cdr[:4])!r}")
        self._cdr = cdr

    def publish(self, publisher: Any, sec: int, nanosec: int) -> None:
        """Send the bytes stamped ``sec``, ``nanosec``."""
        _STAMP.pack_into(self._cdr, CDR_STAMP_OFFSET, sec, nanosec)
        publisher.publish(bytes(self._cdr))
