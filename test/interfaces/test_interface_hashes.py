"""Our interface definitions are wire-compatible with MoveIt's, ros2_control's and MTC's exactly
when every RIHS01 type hash matches the reference table (test/data/moveit_type_hashes.json,
computed from the upstream sources listed in interfaces_py/ros_packages/README.md). The build
writes each type's hashes into share/<package>/<kind>/<Type>.json; rclpy also carries them on
the generated classes, which is what goes on the wire, so both are compared."""
from __future__ import annotations

import importlib
import json
import os
import sys
from pathlib import Path



REFERENCE = json.loads((Path(__file__).resolve().parents[1] / "data" / "moveit_type_hashes.json").read_text())
PACKAGES = sorted({name.split("/")[0] for name in REFERENCE})


def _share_dir(package: str) -> Path:
    """Where the package is installed: a sourced ROS install's prefix or the venv itself."""
    prefixes = [p for p in os.environ.get("AMENT_PREFIX_PATH", "").split(os.pathsep) if p] + [sys.prefix]
    for prefix in prefixes:
        share = Path(prefix) / "share" / package
        if (share / "package.xml").is_file():
            return share
    raise AssertionError(f"{package} is not installed in any of {prefixes} (scripts/build_interfaces.sh builds it)")


def _built_hashes() -> dict[str, str]:
    hashes: dict[str, str] = {}
    for package in PACKAGES:
        share = _share_dir(package)
        for kind in ("msg", "srv", "action"):
            for description in sorted((share / kind).glob("*.json")):
                for entry in json.loads(description.read_text())["type_hashes"]:
                    hashes[entry["type_name"]] = entry["hash_string"]
    return hashes


def test_reference_table_is_complete() -> None:
    assert len(REFERENCE) == 460
    assert PACKAGES == ["control_msgs", "moveit_msgs", "moveit_task_constructor_msgs",
                        "object_recognition_msgs", "octomap_msgs", "tf2_msgs"]


def test_every_generated_type_hash_matches_the_reference() -> None:
    built = _built_hashes()
    ours = {name: value for name, value in built.items() if name.split("/")[0] in PACKAGES}
    missing = sorted(set(REFERENCE) - set(ours))
    extra = sorted(set(ours) - set(REFERENCE))
    wrong = sorted(name for name in REFERENCE if name in ours and ours[name] != REFERENCE[name])
    assert (missing, extra, wrong) == ([], [], [])
    assert len(ours) == 460


def test_hashes_on_the_wire_match_the_reference() -> None:
    """What discovery announces: a publisher of each message type, read back from the graph."""
    import rclpy
    from rclpy.node import Node

    from ros_testing import use_session_domain

    use_session_domain()

    messages = sorted(n for n in REFERENCE if n.split("/")[1] == "msg")
    assert len(messages) == 94
    context = rclpy.Context()
    rclpy.init(context=context)
    try:
        node = Node("type_hash_probe", context=context)
        for i, name in enumerate(messages):
            pkg, _, type_name = name.split("/")
            cls = getattr(importlib.import_module(f"{pkg}.msg"), type_name)
            node.create_publisher(cls, f"/type_hash_probe/t{i}", 1)
        announced = {}
        for i, name in enumerate(messages):
            (info,) = node.get_publishers_info_by_topic(f"/type_hash_probe/t{i}")
            announced[name] = str(info.topic_type_hash)
        assert announced == {name: REFERENCE[name] for name in messages}
        node.destroy_node()
    finally:
        rclpy.shutdown(context=context)
