"""Our own `ros2` command for the pip environment, where ros2cli cannot be installed.

ROS users drive nodes with `ros2 run`, `ros2 param`, `ros2 topic`, `ros2 service`, `ros2 node`,
`ros2 interface` and `ros2 pkg`. ros2cli is not published on PyPI, so this package rebuilds the
verbs our users type on rclpy, with the same syntax, the same output and the same error sentences
as ros2cli on Jazzy. On a machine with a real ROS 2 install the real `ros2` works the same way
with our nodes; nothing here is needed there.

Differences from ros2cli, on purpose:
- There is no daemon. Each call starts its own participant and waits for discovery: a named
  node, topic or service is waited for (default 4 s, `--spin-time` to change) before it is
  reported missing; list verbs wait until the graph has been quiet for a moment, or exactly
  `--spin-time` seconds when given (see _common.py for why).
- `ros2 param set`, `ros2 param load` and `ros2 param delete` exit 1 when the node refuses the
  value (ros2cli prints the refusal and exits 0), so that scripts can check the result.
  `ros2 param load` loads the node's own section of the file and leaves out read-only
  parameters whose value is unchanged, so a `ros2 param dump` file loads back cleanly.
- `ros2 run` replaces itself with the executable (exec) instead of waiting on a child, so
  signals reach the node directly.
- Streaming verbs (echo, hz, pub, call) stopped with Ctrl-C or SIGTERM exit 0, quietly.
- `rosidl_runtime_py` is not on PyPI either: `_message.py` holds the few functions we need from
  it (message to YAML/CSV, YAML to message fields, type lookup by name).

Verb modules import rclpy only inside the functions that need it, so `ros2 run`, `ros2 pkg` and
`ros2 interface` start without loading the ROS client library.
"""
