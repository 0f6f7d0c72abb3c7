"""``moveit.task_constructor.core``: Task, containers, solvers, cost terms (mycobot_planning.task.core)."""
from mycobot_planning.task.core import *  # noqa: F401,F403 - MTC's namespace, re-exported as a whole
from mycobot_planning.task.core import __all__  # noqa: F401
