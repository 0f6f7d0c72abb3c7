"""Task introspection topics: how a node shows its tasks to the task viewer (MTC's introspection).

The full story: docs/nodes.md, section mycobot_planning.ros.task.task_topics.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Iterable

from moveit_task_constructor_msgs.msg import Solution, TaskDescription as MtcDescription
from moveit_task_constructor_msgs.msg import TaskStatistics as MtcStatistics
from moveit_task_constructor_msgs.srv import GetSolution
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
from std_msgs.msg import String

from interfaces_py.msgs import TaskDescription, TaskSolution, TaskStatistics
from interfaces_py.mtc_conversions import task_description_to_msg, task_solution_to_msg, task_statistics_to_msg

if TYPE_CHECKING:  # pragma: no cover
    from mycobot_planning.task import Task

__all__ = [
    "DESCRIPTION_QOS",
    "SOLUTION_QOS",
    "STATISTICS_QOS",
    "TASK_SUFFIXES",
    "TaskIntrospection",
    "TaskTopics",
    "parse_task_topic",
    "task_topics",
]

MAX_LATCHED_SOLUTIONS = 16
#: MTC's introspection names (Task with the default, empty namespace) and QoS
MTC_DESCRIPTION_TOPIC = "/description"
MTC_STATISTICS_TOPIC = "/statistics"
MTC_SOLUTION_TOPIC = "/solution"
MTC_GET_SOLUTION_SERVICE = "/get_solution"
MAX_KEPT_SOLUTIONS = 64  # solutions get_solution can still answer
DESCRIPTION_QOS = QoSProfile(depth=1, history=HistoryPolicy.KEEP_LAST, reliability=ReliabilityPolicy.RELIABLE,
                             durability=DurabilityPolicy.TRANSIENT_LOCAL)
STATISTICS_QOS = DESCRIPTION_QOS
MTC_DESCRIPTION_QOS = QoSProfile(depth=2, history=HistoryPolicy.KEEP_LAST, reliability=ReliabilityPolicy.RELIABLE,
                                 durability=DurabilityPolicy.TRANSIENT_LOCAL)
MTC_LATCHED_QOS = QoSProfile(depth=1, history=HistoryPolicy.KEEP_LAST, reliability=ReliabilityPolicy.RELIABLE,
                             durability=DurabilityPolicy.TRANSIENT_LOCAL)
SOLUTION_QOS = QoSProfile(depth=MAX_LATCHED_SOLUTIONS, history=HistoryPolicy.KEEP_LAST,
                          reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.TRANSIENT_LOCAL)
#: topic suffix -> (kind, message class)
TASK_SUFFIXES = {
    "/task/description": ("description", TaskDescription),
    "/task/statistics": ("statistics", TaskStatistics),
    "/task/solution": ("solution", TaskSolution),
}


@dataclass(frozen=True)
class TaskTopics:
    description: str
    statistics: str
    solution: str


def task_topics(node_name: str) -> TaskTopics:
    """The three topic names of a node ("/mtc_node" or "mtc_node")."""
    base = node_name if node_name.startswith("/") else f"/{node_name}"
    base = base.rstrip("/")
    return TaskTopics(f"{base}/task/description", f"{base}/task/statistics", f"{base}/task/solution")


def parse_task_topic(topic: str) -> tuple[str, str] | None:
    """(source prefix, kind) of a task topic name, or None: "/mtc_node/task/solution" ->
    ("/mtc_node", "solution")."""
    for suffix, (kind, _cls) in TASK_SUFFIXES.items():
        if topic.endswith(suffix) and len(topic) > len(suffix):
            return topic[: -len(suffix)], kind
    return None


class TaskIntrospection:
    """Publishes a node's tasks on the three task topics (see docs/nodes.md (mycobot_planning.ros.task.task_topics)), and on MTC's
    own introspection interface (moveit_task_constructor_msgs on ``/description``,
    ``/statistics``, ``/solution``, and the ``/get_solution`` service), as an MTC task with the
    default namespace does, so RViz's Motion Planning Tasks panel shows our tasks."""

    def __init__(self, node: Node, name: str | None = None) -> None:
        """``name``: the topic prefix (default: the node's fully qualified name)."""
        self.topics = task_topics(name or node.get_fully_qualified_name())
        self._node = node
        self._description = node.create_publisher(String, self.topics.description, DESCRIPTION_QOS)
        self._statistics = node.create_publisher(String, self.topics.statistics, STATISTICS_QOS)
        self._solution = node.create_publisher(String, self.topics.solution, SOLUTION_QOS)
        self._mtc_description = node.create_publisher(MtcDescription, MTC_DESCRIPTION_TOPIC, MTC_DESCRIPTION_QOS)
        self._mtc_statistics = node.create_publisher(MtcStatistics, MTC_STATISTICS_TOPIC, MTC_LATCHED_QOS)
        self._mtc_solution = node.create_publisher(Solution, MTC_SOLUTION_TOPIC, MTC_LATCHED_QOS)
        self._solutions: dict[int, Any] = {}  # solution id -> moveit_task_constructor_msgs/Solution
        self._get_solution = node.create_service(GetSolution, MTC_GET_SOLUTION_SERVICE, self._on_get_solution)

    def _on_get_solution(self, request: Any, response: Any) -> Any:
        """MTC's get_solution: a solution published before, by id (an unknown id gets an empty
        solution and a warning, as MTC answers)."""
        solution = self._solutions.get(int(request.solution_id))
        if solution is None:
            self._node.get_logger().warning(f"get_solution: no published solution has id {request.solution_id}; "
                                            f"known: {sorted(self._solutions)}")
        else:
            response.solution = solution
        return response

    def publish_description(self, msg: TaskDescription) -> None:
        self._description.publish(String(data=msg.to_json()))
        self._mtc_description.publish(task_description_to_msg(msg))

    def publish_statistics(self, msg: TaskStatistics) -> None:
        self._statistics.publish(String(data=msg.to_json()))
        self._mtc_statistics.publish(task_statistics_to_msg(msg))

    def publish_solution(self, msg: TaskSolution, solution_id: int = 0) -> None:
        self._solution.publish(String(data=msg.to_json()))
        mtc = task_solution_to_msg(msg, solution_id)
        self._solutions[int(solution_id)] = mtc
        while len(self._solutions) > MAX_KEPT_SOLUTIONS:
            self._solutions.pop(next(iter(self._solutions)))
        self._mtc_solution.publish(mtc)

    def publish(self, task: "Task", solutions: int | Iterable = 1) -> int:
        """Description and statistics of ``task``, and its ``solutions`` cheapest complete
        solutions (an int), or the given solutions of the task. Returns how many solutions
        were published."""
        self.publish_description(task.description())
        self.publish_statistics(task.statistics())
        chosen = task.solutions[: max(0, solutions)] if isinstance(solutions, int) else list(solutions)
        for solution in chosen:
            self.publish_solution(task.to_msg(solution), getattr(solution, "id", 0))
        return len(chosen)
