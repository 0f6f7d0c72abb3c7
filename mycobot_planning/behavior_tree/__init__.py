"""A BehaviorTree.CPP v4 engine in Python, without ROS: loads BT.CPP's XML (as Groot2 and
MoveIt Pro write it) and runs it with BT.CPP 4.6-4.8's semantics. See docs/behavior_tree.md.

    from mycobot_planning.behavior_tree import BehaviorTreeFactory
    tree = BehaviorTreeFactory().create_tree_from_text(xml)
    status = tree.tick_while_running()
"""
from .action_node import SimpleActionNode, StatefulActionNode, SyncActionNode, ThreadedAction
from .basic_types import (
    FAILURE,
    IDLE,
    RUNNING,
    SKIPPED,
    SUCCESS,
    NodeStatus,
    NodeType,
    PortDirection,
    PostCond,
    PreCond,
)
from .blackboard import Blackboard
from .bt_factory import BUILTIN_NODES, BehaviorTreeFactory
from .clock import FakeClock, SystemClock
from .condition_node import ConditionNode, SimpleConditionNode
from .control_node import ControlNode
from .decorator_node import DecoratorNode, SimpleDecoratorNode
from .exceptions import (
    BehaviorTreeException,
    BehaviorTreeRuntimeError,
    LogicError,
    PortError,
    ScriptError,
    ScriptSyntaxError,
    TreeLoadError,
)
from .ports import (
    ANY,
    BOOL,
    DOUBLE,
    INT,
    NODE_STATUS,
    POSE,
    POSE_STAMPED,
    STRING,
    UINT,
    VECTOR_BOOL,
    VECTOR_DOUBLE,
    VECTOR_INT,
    VECTOR_STRING,
    PortInfo,
    PortType,
    PoseStamped,
    bidirectional_port,
    enum_type,
    input_port,
    output_port,
)
from .scripting import parse_script, run_script, validate_script
from .tree import Tree
from .tree_node import NodeConfig, TreeNode, TreeNodeManifest
from .xml_parsing import write_tree_nodes_model_xml, write_tree_to_xml

__all__ = [
    "ANY", "BOOL", "DOUBLE", "INT", "NODE_STATUS", "POSE", "POSE_STAMPED", "STRING", "UINT", "VECTOR_BOOL",
    "VECTOR_DOUBLE", "VECTOR_INT", "VECTOR_STRING", "BUILTIN_NODES", "FAILURE", "IDLE", "RUNNING", "SKIPPED",
    "SUCCESS", "BehaviorTreeException", "BehaviorTreeFactory", "BehaviorTreeRuntimeError", "Blackboard",
    "ConditionNode", "ControlNode", "DecoratorNode", "FakeClock", "LogicError", "NodeConfig", "NodeStatus",
    "NodeType", "PortDirection", "PortError", "PortInfo", "PortType", "PoseStamped", "PostCond", "PreCond",
    "ScriptError", "ScriptSyntaxError", "SimpleActionNode", "SimpleConditionNode", "SimpleDecoratorNode",
    "StatefulActionNode", "SyncActionNode", "SystemClock", "ThreadedAction", "Tree", "TreeLoadError",
    "TreeNode", "TreeNodeManifest", "bidirectional_port", "enum_type", "input_port", "output_port",
    "parse_script", "run_script", "validate_script", "write_tree_nodes_model_xml", "write_tree_to_xml",
]
