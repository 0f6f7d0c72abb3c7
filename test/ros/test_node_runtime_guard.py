"""run_node keeps a node alive when one of its callbacks raises (issue 13: no message can take a
node down). A node whose subscription raises on every message is fed a message; it must log the
exception and go on answering."""
from __future__ import annotations

import subprocess
import sys
import textwrap
import time

import rclpy
from rclpy.node import Node
from std_msgs.msg import String

from ros_testing import REPO, ros_env, session_domain_id, use_session_domain, wait_until

NODE = textwrap.dedent('''
    import sys
    from rclpy.node import Node
    from std_msgs.msg import String
    from mycobot_planning.ros.node_runtime import run_node

    class Fragile(Node):
        def __init__(self):
            super().__init__("fragile_node")
            self.pub = self.create_publisher(String, "/fragile/echo", 10)
            self.create_subscription(String, "/fragile/in", self.on_message, 10)

        def on_message(self, msg):
            if msg.data == "boom":
                raise ValueError("a careless callback")
            self.pub.publish(String(data="echo " + msg.data))

    sys.exit(run_node(Fragile))
''')


def test_a_raising_callback_is_logged_and_the_node_goes_on():
    use_session_domain()
    log = open(f"/tmp/mycobot_test_logs/fragile-{time.monotonic_ns()}.log", "w+")
    proc = subprocess.Popen([sys.executable, "-c", NODE], cwd=REPO, env=ros_env(session_domain_id()),
                            stdout=log, stderr=subprocess.STDOUT, start_new_session=True)
    context = rclpy.Context()
    rclpy.init(context=context)
    node = Node("fragile_probe", context=context)
    echoes: list[str] = []
    node.create_subscription(String, "/fragile/echo", lambda m: echoes.append(m.data), 10)
    pub = node.create_publisher(String, "/fragile/in", 10)
    executor = rclpy.executors.SingleThreadedExecutor(context=context)
    executor.add_node(node)

    def spin_until(predicate, timeout):
        return wait_until(lambda: (executor.spin_once(timeout_sec=0.05), predicate())[1], timeout)

    try:
        assert spin_until(lambda: pub.get_subscription_count() > 0 and node.count_publishers("/fragile/echo") > 0, 30)
        pub.publish(String(data="boom"))
        assert spin_until(lambda: "a callback raised ValueError: a careless callback" in open(log.name).read(), 20)
        assert proc.poll() is None, "the node died"
        assert spin_until(lambda: (pub.publish(String(data="after")), "echo after" in echoes)[1], 20)
    finally:
        proc.terminate()
        proc.wait(10)
        node.destroy_node()
        rclpy.shutdown(context=context)
        log.close()


def test_sigterm_ends_a_node_that_has_nothing_to_wake_its_executor():
    """mtc_node without a planning_server has no timer: before, SIGTERM's Python handler never
    ran while spin() waited in C, and the node lived on (issue 14, item 8). rclpy's own handler
    wakes the executor; the node exits cleanly with code 0."""
    import os
    import signal

    from ros_testing import NodeProcess

    node = NodeProcess("mycobot_planning.nodes.mtc_node", ["--ros-args", "-p", "server_timeout:=1.0"])
    try:
        assert node.wait_for_output("MTC pick and place completed", 60), node.output()
        os.killpg(node.proc.pid, signal.SIGTERM)
        assert wait_until(lambda: node.proc.poll() is not None, 10.0), "still alive 10 s after SIGTERM"
        assert node.proc.returncode == 0, node.output()[-2000:]
        assert "Traceback" not in node.output()
    finally:
        node.stop()
