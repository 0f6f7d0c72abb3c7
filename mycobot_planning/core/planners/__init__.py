"""The planners behind the planning pipeline, one package each as moveit_planners has them: ompl
(OMPL's sampling planners), pilz (the industrial PTP/LIN/CIRC planner), joint_interpolation
(MTC's JointInterpolationPlanner), stomp (MoveIt's STOMP), chomp (MoveIt's CHOMP) and cartesian (Cartesian paths and MTC's relative motion).
Nothing is imported here, so using one planner does not load the others."""
