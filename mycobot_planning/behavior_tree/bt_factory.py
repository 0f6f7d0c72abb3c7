"""BehaviorTreeFactory: where nodes are registered (with their ports and descriptions) and
trees are created from XML (BT.CPP's bt_factory.h).

A behavior is a TreeNode subclass registered under an ID::

    factory.register_node_type(MoveToWaypoint, "MoveToWaypoint", context,   # extra ctor args
                               description="Plans and executes a motion to a saved waypoint")

its ports come from its ``provided_ports()``; its description and ``metadata`` go to the
TreeNodesModel Groot2 reads. Functions can be registered as simple actions, conditions and
decorators. The built-in nodes of BT.CPP 4.6-4.8 are registered by the constructor.
"""
from __future__ import annotations

import inspect
import os
from collections.abc import Callable, Iterable, Mapping
from typing import Any

from . import actions, controls, decorators
from .action_node import SimpleActionNode
from .basic_types import NodeStatus, NodeType
from .blackboard import Blackboard
from .condition_node import SimpleConditionNode
from .decorator_node import SimpleDecoratorNode
from .exceptions import LogicError
from .ports import PortInfo, ports_list
from .tree import Tree
from .tree_node import NodeConfig, TreeNode, TreeNodeManifest
from .xml_parsing import XMLParser, write_tree_nodes_model_xml

NodeBuilder = Callable[[str, NodeConfig], TreeNode]

#: BT.CPP 4.6-4.8's built-in node IDs and the classes that implement them here
BUILTIN_NODES: dict[str, tuple[type[TreeNode], dict[str, Any]]] = {
    "Fallback": (controls.FallbackNode, {}),
    "AsyncFallback": (controls.FallbackNode, {"make_async": True}),
    "Sequence": (controls.SequenceNode, {}),
    "AsyncSequence": (controls.SequenceNode, {"make_async": True}),
    "SequenceWithMemory": (controls.SequenceWithMemoryNode, {}),
    "Parallel": (controls.ParallelNode, {}),
    "ParallelAll": (controls.ParallelAllNode, {}),
    "ReactiveSequence": (controls.ReactiveSequenceNode, {}),
    "ReactiveFallback": (controls.ReactiveFallbackNode, {}),
    "IfThenElse": (controls.IfThenElseNode, {}),
    "WhileDoElse": (controls.WhileDoElseNode, {}),
    "Inverter": (decorators.InverterNode, {}),
    "RetryUntilSuccessful": (decorators.RetryNode, {}),
    "KeepRunningUntilFailure": (decorators.KeepRunningUntilFailureNode, {}),
    "Repeat": (decorators.RepeatNode, {}),
    "Timeout": (decorators.TimeoutNode, {}),
    "Delay": (decorators.DelayNode, {}),
    "RunOnce": (decorators.RunOnceNode, {}),
    "ForceSuccess": (decorators.ForceSuccessNode, {}),
    "ForceFailure": (decorators.ForceFailureNode, {}),
    "AlwaysSuccess": (actions.AlwaysSuccessNode, {}),
    "AlwaysFailure": (actions.AlwaysFailureNode, {}),
    "Script": (actions.ScriptNode, {}),
    "ScriptCondition": (actions.ScriptConditionNode, {}),
    "SetBlackboard": (actions.SetBlackboardNode, {}),
    "Sleep": (actions.SleepNode, {}),
    "UnsetBlackboard": (actions.UnsetBlackboardNode, {}),
    "SubTree": (decorators.SubTreeNode, {}),
    "Precondition": (decorators.PreconditionNode, {}),
    **{f"Switch{n}": (controls.switch_class(n), {}) for n in range(2, 7)},
    "LoopInt": (decorators.LoopIntNode, {}),
    "LoopBool": (decorators.LoopBoolNode, {}),
    "LoopDouble": (decorators.LoopDoubleNode, {}),
    "LoopString": (decorators.LoopStringNode, {}),
    "WasEntryUpdated": (actions.WasEntryUpdatedNode, {}),
    "SkipUnlessUpdated": (decorators.SkipUnlessUpdatedNode, {}),
    "WaitValueUpdate": (decorators.WaitValueUpdateNode, {}),
}


class BehaviorTreeFactory:
    """Registered nodes, scripting enums and loaded BehaviorTrees; creates Trees."""

    def __init__(self) -> None:
        self._builders: dict[str, NodeBuilder] = {}
        self._manifests: dict[str, TreeNodeManifest] = {}
        self._enums: dict[str, int] = {}
        for registration_id, (cls, kwargs) in BUILTIN_NODES.items():
            self.register_node_type(cls, registration_id, **kwargs)
        self._builtin_ids = frozenset(self._builders)
        self._parser = XMLParser(self)

    # -- registration ------------------------------------------------------------------------

    @property
    def manifests(self) -> Mapping[str, TreeNodeManifest]:
        return self._manifests

    @property
    def builtin_nodes(self) -> frozenset[str]:
        return self._builtin_ids

    @property
    def scripting_enums(self) -> dict[str, int]:
        return self._enums

    def register_builder(self, manifest: TreeNodeManifest, builder: NodeBuilder) -> None:
        """Register ``builder(name, config) -> TreeNode`` under ``manifest.registration_id``."""
        registration_id = manifest.registration_id
        if not registration_id or not isinstance(registration_id, str):
            raise LogicError(f"a registration ID must be a non-empty string, got {registration_id!r}")
        if registration_id in self._builders:
            raise LogicError(f"ID [{registration_id}] already registered")
        if manifest.type not in (NodeType.ACTION, NodeType.CONDITION, NodeType.CONTROL, NodeType.DECORATOR,
                                 NodeType.SUBTREE):
            raise LogicError(f"[{registration_id}]: a node must be an action, a condition, a control or "
                             "a decorator")
        self._builders[registration_id] = builder
        self._manifests[registration_id] = manifest

    def register_node_type(self, cls: type[TreeNode], registration_id: str | None = None, *args: Any,
                           description: str | None = None, metadata: Iterable[tuple[str, str]] | Mapping | None = None,
                           ports: Iterable[PortInfo] | None = None, **kwargs: Any) -> None:
        """Register a TreeNode subclass; ``args``/``kwargs`` are passed to its constructor after
        ``(name, config)`` (the context a behavior needs: a ROS node, a planning interface...).

        Ports are ``cls.provided_ports()`` unless ``ports`` is given; ``description`` defaults
        to the class's ``DESCRIPTION`` attribute.
        """
        if not (inspect.isclass(cls) and issubclass(cls, TreeNode)):
            raise LogicError(f"register_node_type needs a TreeNode subclass, got {cls!r}")
        registration_id = registration_id or cls.__name__
        node_type = cls.NODE_TYPE
        manifest = TreeNodeManifest(
            node_type, registration_id, ports_list(cls.provided_ports() if ports is None else ports),
            description if description is not None else getattr(cls, "DESCRIPTION", ""),
            _metadata(metadata))

        def builder(name: str, config: NodeConfig) -> TreeNode:
            return cls(name, config, *args, **kwargs)

        self.register_builder(manifest, builder)

    def register_simple_action(self, registration_id: str, tick: Callable[[TreeNode], NodeStatus | bool],
                               ports: Iterable[PortInfo] = (), description: str = "",
                               metadata: Iterable[tuple[str, str]] | Mapping | None = None) -> None:
        """A function ``tick(node) -> NodeStatus`` (or bool) as a synchronous action."""
        self._register_simple(SimpleActionNode, registration_id, tick, ports, description, metadata)

    def register_simple_condition(self, registration_id: str, tick: Callable[[TreeNode], NodeStatus | bool],
                                  ports: Iterable[PortInfo] = (), description: str = "",
                                  metadata: Iterable[tuple[str, str]] | Mapping | None = None) -> None:
        """A function ``tick(node) -> NodeStatus`` (or bool) as a condition."""
        self._register_simple(SimpleConditionNode, registration_id, tick, ports, description, metadata)

    def register_simple_decorator(self, registration_id: str,
                                  tick: Callable[[NodeStatus, TreeNode], NodeStatus | bool],
                                  ports: Iterable[PortInfo] = (), description: str = "",
                                  metadata: Iterable[tuple[str, str]] | Mapping | None = None) -> None:
        """A function ``tick(child_status, node) -> NodeStatus`` as a decorator."""
        self._register_simple(SimpleDecoratorNode, registration_id, tick, ports, description, metadata)

    def _register_simple(self, node_cls: type[TreeNode], registration_id: str, tick: Callable[..., Any],
                         ports: Iterable[PortInfo], description: str,
                         metadata: Iterable[tuple[str, str]] | Mapping | None) -> None:
        """Register ``node_cls(name, config, tick)`` (a Simple*Node of its NODE_TYPE) under
        ``registration_id``."""
        manifest = TreeNodeManifest(node_cls.NODE_TYPE, registration_id, ports_list(ports), description,
                                    _metadata(metadata))
        self.register_builder(manifest, lambda name, config: node_cls(name, config, tick))

    def unregister_builder(self, registration_id: str) -> bool:
        if registration_id in self._builtin_ids:
            raise LogicError(f"you can not remove the builtin registration ID [{registration_id}]")
        if registration_id not in self._builders:
            return False
        del self._builders[registration_id]
        del self._manifests[registration_id]
        return True

    def add_metadata_to_manifest(self, registration_id: str, metadata: Iterable[tuple[str, str]] | Mapping) -> None:
        if registration_id not in self._manifests:
            raise LogicError(f"add_metadata_to_manifest: unknown ID [{registration_id}]")
        self._manifests[registration_id].metadata = _metadata(metadata)

    def register_scripting_enum(self, name: str, value: int) -> None:
        """A name scripts can use for a number (BT.CPP's registerScriptingEnum)."""
        previous = self._enums.get(name)
        if previous is not None and previous != int(value):
            raise LogicError(f"Registering the enum [{name}] twice with different values, first {previous} "
                             f"and later {int(value)}")
        self._enums[name] = int(value)

    def register_scripting_enums(self, enum_cls: type) -> None:
        """Every member of an IntEnum as a scripting enum."""
        for name, member in enum_cls.__members__.items():
            self.register_scripting_enum(name, int(member))

    def instantiate_tree_node(self, name: str, registration_id: str, config: NodeConfig) -> TreeNode:
        """Build one node (the XML parser calls this)."""
        builder = self._builders.get(registration_id)
        if builder is None:
            raise LogicError(f"BehaviorTreeFactory: ID [{registration_id}] not registered")
        config.enums = self._enums
        config.manifest = config.manifest or self._manifests[registration_id]
        node = builder(name, config)
        node.registration_id = registration_id
        return node

    # -- trees -------------------------------------------------------------------------------

    def register_behavior_tree_from_file(self, path: str | os.PathLike, *, skip_existing: bool = False) -> None:
        self._parser.load_from_file(path, skip_existing=skip_existing)

    def register_behavior_tree_from_text(self, text: str, *, source: str = "<xml text>",
                                         base_dir: str | os.PathLike | None = None) -> None:
        self._parser.load_from_text(text, source=source, base_dir=base_dir)

    def registered_behavior_trees(self) -> list[str]:
        return self._parser.registered_behavior_trees()

    def clear_registered_behavior_trees(self) -> None:
        self._parser.clear_internal_state()

    @property
    def parser(self) -> XMLParser:
        return self._parser

    def create_tree(self, tree_id: str | None = None, blackboard: Blackboard | None = None, clock: Any = None) -> Tree:
        """Instantiate a registered tree (default: the main tree of the first loaded file)."""
        return self._parser.instantiate_tree(blackboard, tree_id, clock)

    def create_tree_from_text(self, text: str, blackboard: Blackboard | None = None, clock: Any = None, *,
                              source: str = "<xml text>", base_dir: str | os.PathLike | None = None,
                              main_tree_id: str | None = None) -> Tree:
        """Load ``text`` on its own (the trees registered before are not visible) and build its
        main tree."""
        parser = XMLParser(self)
        parser.load_from_text(text, source=source, base_dir=base_dir)
        return parser.instantiate_tree(blackboard, main_tree_id, clock)

    def create_tree_from_file(self, path: str | os.PathLike, blackboard: Blackboard | None = None,
                              clock: Any = None, *, main_tree_id: str | None = None) -> Tree:
        parser = XMLParser(self)
        parser.load_from_file(path)
        return parser.instantiate_tree(blackboard, main_tree_id, clock)

    def write_tree_nodes_model_xml(self, include_builtin: bool = False) -> str:
        return write_tree_nodes_model_xml(self, include_builtin)


def _metadata(metadata: Iterable[tuple[str, str]] | Mapping | None) -> list[tuple[str, str]]:
    if metadata is None:
        return []
    items = metadata.items() if isinstance(metadata, Mapping) else metadata
    return [(str(k), str(v)) for k, v in items]
