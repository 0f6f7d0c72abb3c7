"""The mock ros2_control stack's simulation (no rclpy): a joint trajectory follower per
controller, with fault injection, and the controllers file it reads. Kept out of the planning
core: nothing that plans or executes depends on it; only ros/controllers/mock_controllers.py does."""
