"""interfaces_py: the message schema of mycobot_planning (MoveIt message equivalents as JSON).

Importing this package never imports ROS: ``interfaces_py.msgs`` depends only on numpy, so
core code and offline tools can build and parse messages. ROS message conversions live in
``interfaces_py.ros_conversions``, imported explicitly by the nodes that need them.
"""

from interfaces_py.msgs import *  # noqa: F401,F403 - the message classes
from interfaces_py.msgs import __all__  # noqa: F401
