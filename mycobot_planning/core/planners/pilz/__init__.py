"""Industrial motion generation: MoveIt's Pilz planner (PTP, LIN, CIRC) rebuilt on our core.

One module per generator as in pilz_industrial_motion_planner (ptp, lin_circ), their shared
trapezoidal profile, the Cartesian limits file, and the pipeline front (planner).
The full story: docs/core.md, section mycobot_planning.core.planners.pilz.
"""
from .common import COLLISION_ERROR_CODE, CIRC, DEFAULT_SAMPLE_TIME, KNOWN_PLANNER_IDS, LIN, PILZ_PIPELINE_ID, PTP
from .limits import CartesianLimits, CartesianLimitsError, load_cartesian_limits
from .planner import IndustrialMotionPlanner, plan_industrial
from .trapezoid_profile import TrapezoidProfile, sample_times
