"""A gantry (a prismatic joint on a tilted axis, then three revolute joints) for the tests of
the compiled kinematics: the prismatic case none of the example robots' arm groups has."""

GANTRY_URDF = """<robot name="gantry">
  <link name="base"/><link name="carriage"/><link name="upper"/><link name="fore"/><link name="tool"/>
  <joint name="rail" type="prismatic"><parent link="base"/><child link="carriage"/>
    <origin xyz="0 0 0.5"/><axis xyz="0.6 0.8 0"/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint>
  <joint name="shoulder" type="revolute"><parent link="carriage"/><child link="upper"/>
    <origin xyz="0 0 0.1" rpy="0.3 0 0.2"/><axis xyz="0 0 1"/><limit lower="-3" upper="3" effort="1" velocity="1"/></joint>
  <joint name="elbow" type="revolute"><parent link="upper"/><child link="fore"/>
    <origin xyz="0.3 0 0"/><axis xyz="0 1 0"/><limit lower="-2.5" upper="2.5" effort="1" velocity="1"/></joint>
  <joint name="wrist" type="revolute"><parent link="fore"/><child link="tool"/>
    <origin xyz="0.25 0 0" rpy="0 0.4 0"/><axis xyz="1 0 0"/><limit lower="-3" upper="3" effort="1" velocity="1"/></joint>
</robot>"""
GANTRY_SRDF = """<robot name="gantry"><group name="arm"><chain base_link="base" tip_link="tool"/></group></robot>"""
