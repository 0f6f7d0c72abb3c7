"""TreeNode: what every node of a tree is (BT.CPP's tree_node.h) — a name, a status, a
configuration (blackboard, ports, pre/post conditions), ``tick``/``halt``, and the port
accessors a behavior uses: ``get_input`` and ``set_output``.

``execute_tick`` is BT.CPP's executeTick: the pre-conditions (``_failureIf``, ``_successIf``,
``_skipIf``, ``_while``) may answer instead of ``tick``; a completed status runs the
post-conditions (``_onSuccess``/``_onFailure``, then ``_post``); SKIPPED is returned to the
parent but the node stays IDLE. ``halt_node`` halts and runs ``_onHalted``.
"""
from __future__ import annotations

from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass, field
from typing import Any, ClassVar

from .basic_types import (
    FAILURE,
    IDLE,
    RUNNING,
    SKIPPED,
    SUCCESS,
    NodeStatus,
    NodeType,
    PostCond,
    PreCond,
)
from .blackboard import EMPTY, Blackboard
from .clock import SystemClock, WakeUpSignal
from .exceptions import BehaviorTreeRuntimeError, LogicError, PortError, ScriptError
from .ports import ANY, ConversionError, PortInfo, remapped_key
from .scripting import Environment, Script, script_truth

_MISSING: Any = object()
_DEFAULT_CLOCK = SystemClock()

StatusChangeCallback = Callable[[float, "TreeNode", NodeStatus, NodeStatus], None]


@dataclass
class TreeNodeManifest:
    """What the factory knows of a registered node: type, ID, ports, description, metadata."""

    type: NodeType
    registration_id: str
    ports: dict[str, PortInfo] = field(default_factory=dict)
    description: str = ""
    metadata: list[tuple[str, str]] = field(default_factory=list)


@dataclass
class NodeConfig:
    """A node instance's configuration, filled by the XML parser (BT.CPP's NodeConfig)."""

    blackboard: Blackboard | None = None
    enums: Mapping[str, int] | None = None
    input_ports: dict[str, str] = field(default_factory=dict)
    output_ports: dict[str, str] = field(default_factory=dict)
    other_attributes: dict[str, str] = field(default_factory=dict)
    manifest: TreeNodeManifest | None = None
    uid: int = 0
    path: str = ""
    pre_conditions: dict[PreCond, str] = field(default_factory=dict)
    post_conditions: dict[PostCond, str] = field(default_factory=dict)
    clock: Any = None
    #: where the node comes from, for error messages: (file, line)
    source: tuple[str, int] | None = None


class TreeNode:
    """Base of every node. Subclasses implement ``tick`` (and ``halt`` if they can be RUNNING)
    and declare their ports in ``provided_ports()``."""

    NODE_TYPE: ClassVar[NodeType] = NodeType.UNDEFINED

    def __init__(self, name: str, config: NodeConfig | None = None):
        self.name = name
        self.config = config if config is not None else NodeConfig()
        self._status = IDLE
        self.registration_id = ""
        self._pre: list[tuple[PreCond, Script]] | None = None
        self._post: dict[PostCond, Script] | None = None
        self._observers: tuple[StatusChangeCallback, ...] = ()
        self._wake_up: WakeUpSignal | None = None
        self._literal_cache: dict[str, Any] = {}

    # -- model -------------------------------------------------------------------------------

    @classmethod
    def provided_ports(cls) -> Iterable[PortInfo]:
        """The node's ports (BT.CPP's static providedPorts()); none by default."""
        return ()

    @property
    def type(self) -> NodeType:
        return self.NODE_TYPE

    @property
    def uid(self) -> int:
        return self.config.uid

    @property
    def full_path(self) -> str:
        return self.config.path

    @property
    def status(self) -> NodeStatus:
        return self._status

    def children_nodes(self) -> list[TreeNode]:
        return []

    def __repr__(self) -> str:
        return f"<{type(self).__name__} {self.config.path or self.name!r} {self._status.name}>"

    # -- ticking -----------------------------------------------------------------------------

    def tick(self) -> NodeStatus:  # pragma: no cover - abstract
        raise NotImplementedError

    def halt(self) -> None:  # pragma: no cover - abstract
        raise NotImplementedError

    def execute_tick(self) -> NodeStatus:
        """Tick with the pre/post conditions around it (see the module docstring).

        An error raised below names the innermost node it came from (``node_path``).
        """
        try:
            new_status = None
            if self._pre is not None:
                new_status = self._check_pre_conditions()
            if new_status is None:
                new_status = self.tick()
            if self._post is not None and (new_status is SUCCESS or new_status is FAILURE):
                self._run_post_conditions(new_status)
        except BehaviorTreeRuntimeError as exc:
            if exc.node_path is None:
                exc.node_path = self.config.path or self.name
            raise
        except (ScriptError, LogicError, ConversionError) as exc:
            raise BehaviorTreeRuntimeError(str(exc), self.config.path or self.name) from exc
        if new_status is not SKIPPED:
            self.set_status(new_status)
        return new_status

    def halt_node(self) -> None:
        """Halt the node, then run its ``_onHalted`` script."""
        self.halt()
        if self._post is not None:
            script = self._post.get(PostCond.ON_HALTED)
            if script is not None:
                script(self._environment())

    def set_status(self, new_status: NodeStatus) -> None:
        if new_status is IDLE:
            raise LogicError(f"node [{self.name}]: you are not allowed to set the status to IDLE; "
                             "use reset_status()")
        self._change_status(new_status)

    def reset_status(self) -> None:
        self._change_status(IDLE)

    def _change_status(self, new_status: NodeStatus) -> None:
        """Set the status and tell the observers, if it changes (IDLE included)."""
        previous = self._status
        if previous is not new_status:
            self._status = new_status
            if self._observers:
                self._notify(previous, new_status)

    def is_halted(self) -> bool:
        return self._status is IDLE

    def subscribe_to_status_change(self, callback: StatusChangeCallback) -> Callable[[], None]:
        """Call ``callback(time, node, previous, new)`` on every status change; returns the
        function that unsubscribes."""
        self._observers = self._observers + (callback,)

        def unsubscribe() -> None:
            self._observers = tuple(c for c in self._observers if c is not callback)

        return unsubscribe

    def _notify(self, previous: NodeStatus, new: NodeStatus) -> None:
        now = self.now()
        for callback in self._observers:
            callback(now, self, previous, new)

    # -- pre/post conditions -----------------------------------------------------------------

    def set_conditions(self, pre: Mapping[PreCond, Script], post: Mapping[PostCond, Script]) -> None:
        """Install parsed pre/post-condition scripts (the parser calls this)."""
        self._pre = sorted(pre.items()) if pre else None
        self._post = dict(post) if post else None

    def _environment(self) -> Environment:
        return Environment(self.config.blackboard, self.config.enums)

    def _check_pre_conditions(self) -> NodeStatus | None:
        env = self._environment()
        status = self._status
        for condition, script in self._pre:
            if status is IDLE or status is SKIPPED:
                if script_truth(script(env)):
                    if condition is PreCond.FAILURE_IF:
                        return FAILURE
                    if condition is PreCond.SUCCESS_IF:
                        return SUCCESS
                    if condition is PreCond.SKIP_IF:
                        return SKIPPED
                elif condition is PreCond.WHILE_TRUE:
                    return SKIPPED
            elif status is RUNNING and condition is PreCond.WHILE_TRUE:
                if not script_truth(script(env)):
                    self.halt_node()
                    return SKIPPED
        return None

    def _run_post_conditions(self, status: NodeStatus) -> None:
        post = self._post
        env = None
        which = PostCond.ON_SUCCESS if status is SUCCESS else PostCond.ON_FAILURE
        for condition in (which, PostCond.ALWAYS):
            script = post.get(condition)
            if script is not None:
                env = env or self._environment()
                script(env)

    # -- ports -------------------------------------------------------------------------------

    def _port_info(self, key: str) -> PortInfo | None:
        manifest = self.config.manifest
        return None if manifest is None else manifest.ports.get(key)

    def get_raw_port_value(self, key: str) -> str:
        """The port's text in the XML (or its default), before any conversion."""
        text = self.config.input_ports.get(key)
        if text is None:
            text = self.config.output_ports.get(key)
        if text is None:
            raise PortError(f"port [{key}] not found", self.config.path)
        return text

    def get_input(self, key: str, default: Any = _MISSING) -> Any:
        """The value of input port ``key`` as the port's type: a literal from the XML (or the
        port's default) converted, or the blackboard entry ``{key}`` points to.

        If the port has no value (entry missing or never written) ``default`` is returned when
        given; otherwise a PortError names the node, the port and the entry.
        """
        config = self.config
        text = config.input_ports.get(key)
        port = self._port_info(key)
        if text is None:
            if port is None or not port.has_default:
                if default is not _MISSING:
                    return default
                why = ("the manifest doesn't contain the key" if port is None
                       else "neither the XML nor the manifest contain a value for the key")
                raise PortError(f"get_input() failed because {why}: [{key}]", config.path)
            if not isinstance(port.default, str):
                return port.default
            text = port.default
        port_type = port.type if port is not None else ANY
        key_in_bb = remapped_key(key, text)
        if key_in_bb is None:
            cached = self._literal_cache.get(key, _MISSING)
            if cached is not _MISSING and cached[0] == text:
                return cached[1]
            try:
                value = port_type.from_string(text)
            except ConversionError as exc:
                raise PortError(f"get_input(): port [{key}] value '{text}' can not be converted to "
                                f"{port_type.name}: {exc}", config.path) from None
            self._literal_cache[key] = (text, value)
            return value
        entry = config.blackboard.get_entry(key_in_bb)
        if entry is None or entry.value is EMPTY:
            if default is not _MISSING:
                return default
            raise PortError(f"get_input() failed because it was unable to find the key [{key}] remapped "
                            f"to [{key_in_bb}]" + ("" if entry is None else " (the entry was never written)"),
                            config.path)
        value = entry.value
        if port_type.strongly_typed:
            try:
                value = port_type.convert(value)
            except ConversionError as exc:
                raise PortError(f"get_input(): port [{key}] reads blackboard entry [{key_in_bb}] = {value!r}, "
                                f"which is not a {port_type.name}: {exc}", config.path) from None
        return value

    def has_input(self, key: str) -> bool:
        """True if ``get_input(key)`` would find a value."""
        return self.get_input(key, _MISSING_INPUT) is not _MISSING_INPUT

    def set_output(self, key: str, value: Any) -> bool:
        """Write ``value`` to the blackboard entry output port ``key`` points to.

        Returns False when the port is not connected in the XML (nothing is written); raises
        PortError if the entry's type refuses the value.
        """
        config = self.config
        text = config.output_ports.get(key)
        if text is None:
            if self._port_info(key) is None:
                raise PortError(f"set_output(): node has no output port [{key}]", config.path)
            return False
        key_in_bb = remapped_key(key, text)
        if key_in_bb is None:
            raise PortError(f"set_output(): port [{key}] is '{text}', not a blackboard entry {{key}}",
                            config.path)
        try:
            config.blackboard.set(key_in_bb, value)
        except PortError as exc:
            raise PortError(exc.message, config.path) from None
        return True

    def get_remapped_key(self, key: str) -> str | None:
        """The blackboard key port ``key`` points to, None if its value is a literal."""
        return remapped_key(key, self.get_raw_port_value(key))

    # -- time and wake-up --------------------------------------------------------------------

    @property
    def clock(self) -> Any:
        return self.config.clock or _DEFAULT_CLOCK

    def now(self) -> float:
        return (self.config.clock or _DEFAULT_CLOCK).now()

    def requires_wake_up(self) -> bool:
        return self._wake_up is not None

    def emit_wake_up_signal(self) -> None:
        """Ask the tree to tick again now (from any thread): an async node's result arrived."""
        if self._wake_up is not None:
            self._wake_up.emit()

    def wake_up_at(self, when: float) -> None:
        """Ask the tree to tick again at clock time ``when`` (a timer ran out)."""
        if self._wake_up is not None:
            self._wake_up.wake_at(when)

    def set_wake_up_instance(self, signal: WakeUpSignal | None) -> None:
        self._wake_up = signal


_MISSING_INPUT: Any = object()
