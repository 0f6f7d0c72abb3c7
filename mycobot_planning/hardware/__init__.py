"""The real myCobot 280 over its serial protocol (ROS-free): frames, an emulated arm on a
pseudo-terminal, and the driver core that follows trajectories through pymycobot.

The full story: docs/hardware.md.
"""
