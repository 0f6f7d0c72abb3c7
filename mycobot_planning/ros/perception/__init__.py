"""Perception nodes: the simulated depth camera, the perception_server, their shared parameter
conversions, and the object source that task nodes take detected objects from."""
