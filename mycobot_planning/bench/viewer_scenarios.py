"""viewer_lag: does the task viewer keep up with /joint_states at 100 Hz?

A real ``task_viewer`` process (own ROS domain, discovery limited to localhost) and, like a
browser tab, a websocket client of its page that receives every update the page would draw.
This process publishes /joint_states at 100 Hz with the current time as header stamp (a moving
arm, so every message changes the picture) for ``SECONDS`` per repeat; the viewer records, for
each state it applies, the time from the stamp to the update being handed to the page, and the
bench reads those lags back over JSON-RPC (``get_display_lags``).

Summary keys (a contract, keep them stable): ``median_ms`` (display lag), ``p90_ms``,
``max_ms``, ``applied_ratio`` (states drawn / states received: below 1 when the viewer coalesces
a burst, which is how it avoids falling behind), ``drift_ms`` (median lag of the last quarter
of each run minus the first quarter: about 0 when it keeps up, growing when a queue builds),
``page_mb_per_s`` (what one page receives), the publish rate achieved, the spread of
per-repeat medians and the machine.

Register in scenarios.SCENARIOS as "viewer_lag".
"""
from __future__ import annotations

import math
import os
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

import numpy as np

from .common import emit, machine, spread

SECONDS = 5.0
RATE_HZ = 100.0


class _PageClient:
    """A websocket client of the viewer's page: receives (and counts) what a browser would."""

    def __init__(self, url: str) -> None:
        import viser
        from websockets.sync.client import connect

        ws_url = url.replace("http://", "ws://")
        self._ws = connect(ws_url, subprotocols=[f"viser-v{viser.__version__}"], max_size=None,
                           open_timeout=20, compression=None)
        self.bytes = 0
        self.messages = 0
        self._stop = False
        self._thread = threading.Thread(target=self._run, daemon=True)
        self._thread.start()

    def _run(self) -> None:
        while not self._stop:
            try:
                data = self._ws.recv(timeout=0.5)
            except TimeoutError:
                continue
            except Exception:  # connection closed by close() or by the viewer: the reader is done
                return
            self.bytes += len(data)
            self.messages += 1

    def close(self) -> None:
        self._stop = True
        try:
            self._ws.close()
        except Exception:  # already closed by the viewer going away
            pass
        self._thread.join(timeout=2.0)


def bench_viewer_lag(repeat: int, seed: int) -> None:
    """Display lag of /joint_states at 100 Hz in a running task_viewer with one page open."""
    rng = np.random.default_rng(seed)
    domain = str(150 + (os.getpid() + seed) % 80)  # a ROS domain of its own (valid: 0..232)
    os.environ["ROS_DOMAIN_ID"] = domain
    os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
    os.environ.pop("ROS_LOCALHOST_ONLY", None)

    import rclpy
    from rclpy.context import Context
    from rclpy.executors import SingleThreadedExecutor
    from rclpy.node import Node
    from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
    from sensor_msgs.msg import JointState
    from std_msgs.msg import String
    from interfaces_py.background_spin import BackgroundSpin

    from interfaces_py.json_rpc import JsonRpcClient
    from mycobot_planning.core.robot_model.robot_model import RobotModel
    from mycobot_planning.paths import use_fast_discovery

    use_fast_discovery()
    model = RobotModel.mycobot()
    names = list(model.variable_names)
    low, high = model.lower_limits, model.upper_limits
    phase = rng.uniform(0.0, 2 * math.pi, len(names))

    log = tempfile.NamedTemporaryFile("w+", prefix="viewer_lag-", suffix=".log", delete=False)
    viewer = subprocess.Popen([sys.executable, "-m", "mycobot_planning.nodes.task_viewer", "--ros-args",
                               "-p", "port:=0"], stdout=log, stderr=subprocess.STDOUT, env=dict(os.environ),
                              start_new_session=True)
    context = Context()
    rclpy.init(context=context)
    node = Node("viewer_lag_bench", context=context)
    executor = SingleThreadedExecutor(context=context)
    executor.add_node(node)
    spinner = BackgroundSpin(executor, name="viewer bench probe")
    page = None
    try:
        url_box: list[str] = []
        latched = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.TRANSIENT_LOCAL)
        node.create_subscription(String, "/task_viewer/url", lambda m: url_box.append(m.data), latched)
        publisher = node.create_publisher(JointState, "/joint_states", 10)
        rpc = JsonRpcClient(node, "/task_viewer")
        deadline = time.monotonic() + 60.0
        while not url_box or not rpc.wait_for_server(0.5):
            if viewer.poll() is not None or time.monotonic() > deadline:
                raise RuntimeError(f"task_viewer did not start: {Path(log.name).read_text()[-2000:]}")
            time.sleep(0.1)
        while publisher.get_subscription_count() == 0 and time.monotonic() < deadline:
            time.sleep(0.05)
        page = _PageClient(url_box[-1])

        def publish_for(seconds: float) -> int:
            count, start = 0, time.monotonic()
            next_time = start
            while time.monotonic() - start < seconds:
                t = time.monotonic() - start
                positions = low + (high - low) * (0.5 + 0.3 * np.sin(2 * math.pi * 0.5 * t + phase))
                msg = JointState(name=names, position=positions.tolist())
                msg.header.stamp = node.get_clock().now().to_msg()
                publisher.publish(msg)
                count += 1
                next_time += 1.0 / RATE_HZ
                time.sleep(max(0.0, next_time - time.monotonic()))
            return count

        publish_for(1.0)  # warm-up: discovery settled, first page updates sent
        rpc.call("get_display_lags", {"reset": True}, timeout=20.0)
        all_lags: list[float] = []
        medians: list[float] = []
        drifts: list[float] = []
        ratios: list[float] = []
        rates: list[float] = []
        bytes_per_s: list[float] = []
        for index in range(repeat):
            before = rpc.call("get_display_lags", {"reset": True}, timeout=20.0)
            page_bytes = page.bytes
            started = time.monotonic()
            published = publish_for(SECONDS)
            elapsed = time.monotonic() - started
            time.sleep(0.2)  # the last states reach the viewer
            result = rpc.call("get_display_lags", {"reset": True}, timeout=20.0)
            lags = np.asarray(result["lags_ms"], dtype=float)
            received = result["received"] - before["received"]
            applied = result["applied"] - before["applied"]
            quarter = max(1, len(lags) // 4)
            drift = float(np.median(lags[-quarter:]) - np.median(lags[:quarter])) if len(lags) else float("nan")
            record = {
                "scenario": "viewer_lag", "repeat": index, "published": published, "received": received,
                "applied": applied, "rate_hz": round(published / elapsed, 2),
                "median_ms": round(float(np.median(lags)), 3) if len(lags) else float("nan"),
                "p90_ms": round(float(np.percentile(lags, 90)), 3) if len(lags) else float("nan"),
                "max_ms": round(float(lags.max()), 3) if len(lags) else float("nan"),
                "drift_ms": round(drift, 3),
                "page_mb_per_s": round((page.bytes - page_bytes) / elapsed / 1e6, 3),
            }
            emit(record)
            all_lags += lags.tolist()
            medians.append(record["median_ms"])
            drifts.append(drift)
            ratios.append(applied / received if received else float("nan"))
            rates.append(record["rate_hz"])
            bytes_per_s.append(record["page_mb_per_s"])
        lags = np.asarray(all_lags)
        summary = {
            "scenario": "viewer_lag", "summary": True,
            "median_ms": round(float(np.median(lags)), 3),
            "p90_ms": round(float(np.percentile(lags, 90)), 3),
            "max_ms": round(float(lags.max()), 3),
            "applied_ratio": round(float(np.nanmean(ratios)), 4),
            "drift_ms": round(float(np.nanmedian(drifts)), 3),
            "rate_hz": round(float(np.median(rates)), 2),
            "page_mb_per_s": round(float(np.median(bytes_per_s)), 3),
            "samples": int(len(lags)),
        }
        emit({**summary, **spread(medians), **machine()})
    finally:
        if page is not None:
            page.close()
        spinner.stop()
        node.destroy_node()
        rclpy.try_shutdown(context=context)
        if viewer.poll() is None:
            os.killpg(viewer.pid, 2)
            try:
                viewer.wait(10)
            except subprocess.TimeoutExpired:
                os.killpg(viewer.pid, 9)
                viewer.wait(5)
        log.close()
        os.unlink(log.name)


VIEWER_SCENARIOS = {"viewer_lag": bench_viewer_lag}
