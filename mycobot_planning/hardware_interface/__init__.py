"""What stands behind the controllers (ROS-free): the Plant interface, ros2_control's hardware
interface. The controller manager node (mycobot_planning.ros.controllers.controller_manager) is
written once over it; the mock's simulation, the myCobot over pymycobot and the MuJoCo twin are
plants. See docs/nodes.md (controller manager and plants)."""
from .plant import ControllerSpec, Plant, PlantHost

__all__ = ["ControllerSpec", "Plant", "PlantHost"]
