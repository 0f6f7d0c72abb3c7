"""The three hybrid planning components in one process, as MoveIt's launch files compose them
into one component container: the manager is the process's main node, the global and local
planners its extra nodes (run_node spins all three on one multi-threaded executor)."""
from __future__ import annotations

from typing import Any

from mycobot_planning.ros.hybrid_planning.global_planner import GlobalPlannerComponent
from mycobot_planning.ros.hybrid_planning.local_planner import LocalPlannerComponent
from mycobot_planning.ros.hybrid_planning.manager import HybridPlanningManager

__all__ = ["HybridPlanningContainer"]


class HybridPlanningContainer(HybridPlanningManager):
    """hybrid_planning_manager, with global_planner_component and local_planner_component beside it."""

    def __init__(self, **kwargs: Any) -> None:
        super().__init__(**kwargs)
        self.global_planner = GlobalPlannerComponent(context=self.context)
        self.local_planner = LocalPlannerComponent(context=self.context)
        self.extra_nodes = [self.global_planner, self.local_planner]

    def close(self) -> None:
        super().close()
        for node in self.extra_nodes:
            node.close()
            node.destroy_node()
