"""Hybrid planning on MoveIt's names and types (moveit_hybrid_planning): the hybrid planning
manager, the global planner and the local planner components. docs/hybrid_planning.md."""
