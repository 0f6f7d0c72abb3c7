"""Bring-up in Python (no launch system): start, check and stop a robot's nodes; robot.sh, the
demos, the test fixtures and the benchmarks use it. See robot.py."""
