"""``run_objective NAME|FILE.xml``: runs a tree of built-in nodes without ROS and prints one JSON
line with the final status and the root blackboard; refuses bad input with file:line."""
from __future__ import annotations

import json
import signal
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

COMMAND = [sys.executable, "-m", "mycobot_planning.nodes.run_objective"]


def write(path: Path, xml: str) -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(textwrap.dedent(xml).strip() + "\n")
    return path


def run(*args: str, timeout: float = 60) -> tuple[int, dict, str]:
    result = subprocess.run([*COMMAND, *map(str, args)], capture_output=True, text=True, timeout=timeout)
    lines = result.stdout.strip().splitlines()
    assert lines, result.stderr
    return result.returncode, json.loads(lines[-1]), result.stderr


COUNT = """
<root BTCPP_format="4" main_tree_to_execute="Count Things">
  <BehaviorTree ID="Count Things">
    <Sequence>
      <Script code="count := 0; ratio := 0.5; name := 'demo'; flag := true"/>
      <Repeat num_cycles="{cycles}"><Script code="count += 1"/></Repeat>
      <Sleep msec="5"/>
    </Sequence>
  </BehaviorTree>
</root>"""


def test_a_built_in_tree_runs_and_prints_status_and_blackboard_as_json(tmp_path):
    path = write(tmp_path / "count.xml", COUNT)
    code, record, _ = run(path, "--set", "cycles=3")
    assert code == 0
    assert record == {"objective": "Count Things", "status": "SUCCESS",
                      "blackboard": {"count": 3, "cycles": "3", "flag": 1, "name": "demo", "ratio": 0.5}}


def test_failure_and_runtime_errors(tmp_path):
    code, record, _ = run(write(tmp_path / "fail.xml", '<root BTCPP_format="4"><BehaviorTree ID="F"><Sequence>'
                                                        '<Script code="x := 1"/><AlwaysFailure/></Sequence>'
                                                        "</BehaviorTree></root>"))
    assert (code, record["status"], record["blackboard"]) == (1, "FAILURE", {"x": 1})
    code, record, stderr = run(write(tmp_path / "error.xml", '<root BTCPP_format="4"><BehaviorTree ID="E">'
                                                             '<Script name="bad" code="y := nothing + 1"/>'
                                                             "</BehaviorTree></root>"))
    assert (code, record["status"]) == (1, "FAILURE")
    assert "node 'bad'" in record["error"] and "Variable not found: nothing" in record["error"]


def test_objectives_by_name_from_a_library_with_subtrees_in_other_files(tmp_path):
    library = tmp_path / "objectives"
    write(library / "pick.xml", """
        <root BTCPP_format="4">
          <BehaviorTree ID="Pick Object" _description="picks">
            <Sequence><SubTree ID="Open Gripper" width="{w}"/><Script code="@picked := true"/></Sequence>
          </BehaviorTree>
        </root>""")
    write(library / "gripper" / "open.xml", """
        <root BTCPP_format="4">
          <BehaviorTree ID="Open Gripper"><Script code="width := 0.04"/></BehaviorTree>
          <TreeNodesModel><SubTree ID="Open Gripper"><output_port name="width" default="{width}"/></SubTree>
          </TreeNodesModel>
        </root>""")
    write(library / "broken.xml", "<root><BehaviorTree ID=")  # another objective's problem is not ours
    code, record, stderr = run("Pick Object", "--library", library)
    assert code == 0, stderr
    assert record == {"objective": "Pick Object", "status": "SUCCESS", "blackboard": {"picked": 1, "w": 0.04}}
    assert "broken.xml" in stderr
    code, record, _ = run("pick", "--library", library)  # the file's name works too
    assert record["objective"] == "Pick Object"
    code, record, _ = run("Place Object", "--library", library)
    assert code == 2 and "no objective named 'Place Object'" in record["error"] and "Pick Object" in record["error"]


def test_bad_input_is_refused_before_running_with_file_and_line(tmp_path):
    path = write(tmp_path / "bad.xml", """
        <root BTCPP_format="4">
          <BehaviorTree ID="Bad">
            <Sequence>
              <Script code="ran := true"/>
              <Sleep msec="soon"/>
            </Sequence>
          </BehaviorTree>
        </root>""")
    code, record, stderr = run(path)
    assert code == 2 and record["status"] == "REFUSED" and record["blackboard"] == {}
    assert f"{path}:5: <Sleep>: " in record["error"] and 'value "soon" can not be converted' in record["error"]
    assert "refused" in stderr
    code, record, _ = run(write(tmp_path / "malformed.xml", '<root BTCPP_format="4">\n<BehaviorTree ID="M">\n'
                                                            "<Sequence>\n</BehaviorTree></root>"))
    assert code == 2 and ":4: malformed XML" in record["error"]
    code, record, _ = run(tmp_path / "missing.xml")
    assert code == 2 and "no such file" in record["error"]


def test_behaviors_need_the_objective_server(tmp_path):
    path = write(tmp_path / "motion.xml", """
        <root BTCPP_format="4">
          <BehaviorTree ID="Motion">
            <Sequence>
              <Action ID="MoveToWaypoint" waypoint_name="home"/>
            </Sequence>
          </BehaviorTree>
          <TreeNodesModel><Action ID="MoveToWaypoint"><input_port name="waypoint_name"/></Action></TreeNodesModel>
        </root>""")
    code, record, _ = run(path)
    assert code == 2
    assert f"{path}:4: node 'MoveToWaypoint' is not a built-in node" in record["error"]
    assert "needs the objective server" in record["error"]
    code, record, _ = run(write(tmp_path / "typo.xml", '<root BTCPP_format="4"><BehaviorTree ID="T">'
                                                      "<Sequense><AlwaysSuccess/></Sequense></BehaviorTree></root>"))
    assert code == 2 and "did you mean 'Sequence'" in record["error"]


def test_the_ros_free_path_does_not_import_rclpy(tmp_path):
    path = write(tmp_path / "count.xml", COUNT)
    check = ("import sys; from mycobot_planning.nodes.run_objective import main; "
             f"code = main([{str(path)!r}, '--set', 'cycles=2']); "
             "assert code == 0, code; "
             "assert not [m for m in sys.modules if m.split('.')[0] in ('rclpy', 'rcl_interfaces')], 'rclpy imported'")
    result = subprocess.run([sys.executable, "-c", check], capture_output=True, text=True, timeout=60)
    assert result.returncode == 0, result.stderr
    assert json.loads(result.stdout.strip().splitlines()[-1])["blackboard"]["count"] == 2


def test_an_interrupt_halts_the_tree_and_reports_cancelled(tmp_path):
    path = write(tmp_path / "long.xml", """
        <root BTCPP_format="4">
          <BehaviorTree ID="Long">
            <Sleep msec="600000" _onHalted="halted := true"/>
          </BehaviorTree>
        </root>""")
    process = subprocess.Popen([*COMMAND, str(path)], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        assert "running objective 'Long'" in process.stderr.readline()
        process.send_signal(signal.SIGINT)
        stdout, _ = process.communicate(timeout=60)
    finally:
        process.kill()
    assert process.returncode == 130
    assert json.loads(stdout.strip().splitlines()[-1]) == {"objective": "Long", "status": "CANCELLED",
                                                          "blackboard": {"halted": 1}}


def test_tree_nodes_model_option_prints_every_built_in_node():
    result = subprocess.run([*COMMAND, "--tree-nodes-model"], capture_output=True, text=True, timeout=60)
    assert result.returncode == 0
    assert '<Control ID="ReactiveSequence" />' in result.stdout and '<Decorator ID="Timeout">' in result.stdout


@pytest.mark.parametrize("args, message", [([], "an objective name or file is required"),
                                           (["x.xml", "--set", "novalue"], "--set expects KEY=VALUE")])
def test_usage_errors(args, message):
    result = subprocess.run([*COMMAND, *args], capture_output=True, text=True, timeout=60)
    assert result.returncode == 2 and message in result.stderr


def test_ros2_run_finds_the_command(tmp_path):
    path = write(tmp_path / "count.xml", COUNT)
    result = subprocess.run([sys.executable, "-m", "mycobot_planning.ros2cli", "run", "mycobot_planning",
                             "run_objective", str(path), "--set", "cycles=1"], capture_output=True, text=True,
                            timeout=120)
    assert result.returncode == 0, result.stderr
    assert json.loads(result.stdout.strip().splitlines()[-1])["blackboard"]["count"] == 1
