"""Reading and writing BehaviorTree.CPP v4 XML (BT.CPP's xml_parsing.cpp).

Reads ``<root BTCPP_format="4" main_tree_to_execute=...>`` with ``<include path=...>``,
``<BehaviorTree ID=...>`` (one root node each), ``<TreeNodesModel>`` (SubTree port models give
defaults and mandatory ports; the others are kept as declarations), nodes in the compact
(``<Sequence>``) and the generic (``<Control ID="Sequence">``) form, SubTrees with port
remapping and ``_autoremap``, and the ``_uid``/``_fullpath`` attributes of a running tree's XML.

Everything is checked before a tree exists: malformed XML, unknown node IDs, ports a node does
not have, missing required ports, literal values that do not convert to their port's type,
output ports given a literal, script syntax errors, SubTrees that include each other and include
cycles. Each error names the file, the line and the node (TreeLoadError).

Writes the TreeNodesModel of a factory (what Groot2 needs to edit our trees) and a running
tree's XML with ``_uid``/``_fullpath`` (what Groot2 shows when it monitors a tree).
"""
from __future__ import annotations

import difflib
import logging
import os
import xml.parsers.expat
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any
from xml.etree import ElementTree as ET

from .basic_types import (
    POST_CONDITION_NAMES,
    PRE_CONDITION_NAMES,
    NodeType,
    PortDirection,
    PostCond,
    PreCond,
    is_allowed_port_name,
    is_reserved_attribute,
)
from .blackboard import Blackboard
from .exceptions import BehaviorTreeException, ScriptSyntaxError, TreeLoadError
from .ports import (
    NO_DEFAULT,
    STRING,
    ConversionError,
    PortInfo,
    is_blackboard_pointer,
    parse_bool,
    remapped_key,
    strip_blackboard_pointer,
)
from .scripting import parse_script
from .tree import Subtree, Tree
from .tree_node import NodeConfig, TreeNode

if TYPE_CHECKING:
    from .bt_factory import BehaviorTreeFactory

_LOG = logging.getLogger("mycobot_planning.behavior_tree")

#: a behavior tree file larger than this is refused (a mistake, not an objective)
MAX_XML_BYTES = 16 * 1024 * 1024
#: attributes of a running tree's XML that carry no meaning for loading
METADATA_ATTRIBUTES = ("_uid", "_fullpath")


@dataclass
class XmlElement:
    """An XML element with the line it starts on and the file it comes from."""

    tag: str
    attrib: list[tuple[str, str]]
    line: int
    file: str
    children: list[XmlElement] = field(default_factory=list)
    text: str = ""

    def get(self, name: str, default: str | None = None) -> str | None:
        for key, value in self.attrib:
            if key == name:
                return value
        return default

    def describe(self) -> str:
        """``<Action ID="MoveTo" name="approach">``: how error messages name the node."""
        parts = [self.tag]
        for key in ("ID", "name"):
            value = self.get(key)
            if value is not None:
                parts.append(f'{key}="{value}"')
        return "<" + " ".join(parts) + ">"

    def signature(self) -> tuple:
        """The element without the metadata attributes, to compare two copies of a tree."""
        attrib = tuple(sorted((k, v) for k, v in self.attrib if k not in METADATA_ATTRIBUTES))
        return (self.tag, attrib, tuple(child.signature() for child in self.children))


def _error(element: XmlElement, message: str, **kwargs: Any) -> TreeLoadError:
    return TreeLoadError(message, file=element.file, line=element.line, node=element.describe(), **kwargs)


def parse_xml(data: str | bytes, source: str) -> XmlElement:
    """Parse an XML document (expat, no DTD) into XmlElements with line numbers."""
    parser = xml.parsers.expat.ParserCreate()
    parser.ordered_attributes = True
    stack: list[XmlElement] = []
    roots: list[XmlElement] = []

    def start(tag: str, attrs: list[str]) -> None:
        element = XmlElement(tag, list(zip(attrs[::2], attrs[1::2])), parser.CurrentLineNumber, source)
        (stack[-1].children if stack else roots).append(element)
        stack.append(element)

    def end(tag: str) -> None:
        stack.pop()

    def text(data: str) -> None:
        if stack:
            stack[-1].text += data

    def doctype(*args: Any) -> None:
        raise TreeLoadError("a DOCTYPE is not allowed in a behavior tree file", file=source,
                            line=parser.CurrentLineNumber)

    parser.StartElementHandler = start
    parser.EndElementHandler = end
    parser.CharacterDataHandler = text
    parser.StartDoctypeDeclHandler = doctype
    try:
        parser.Parse(data, True)
    except xml.parsers.expat.ExpatError as exc:
        message = xml.parsers.expat.errors.messages.get(exc.code, str(exc))
        raise TreeLoadError(f"malformed XML: {message} (column {exc.offset + 1})", file=source,
                            line=exc.lineno) from None
    if not roots:
        raise TreeLoadError("invalid XML: missing root element", file=source)
    return roots[0]


@dataclass
class _Document:
    file: str
    root: XmlElement


class XMLParser:
    """Keeps the BehaviorTrees of the documents loaded so far and instantiates them."""

    def __init__(self, factory: BehaviorTreeFactory):
        self._factory = factory
        self.clear_internal_state()

    def clear_internal_state(self) -> None:
        self._documents: list[_Document] = []
        self._tree_roots: dict[str, XmlElement] = {}
        self._subtree_models: dict[str, dict[str, PortInfo]] = {}
        self._declared_models: dict[str, XmlElement] = {}
        self._loaded_files: set[str] = set()
        self._suffix = 0

    # -- loading -----------------------------------------------------------------------------

    def registered_behavior_trees(self) -> list[str]:
        return list(self._tree_roots)

    def tree_element(self, tree_id: str) -> XmlElement | None:
        """The ``<BehaviorTree>`` element of a registered tree (its file and line)."""
        return self._tree_roots.get(tree_id)

    @property
    def declared_models(self) -> dict[str, XmlElement]:
        """Every node a loaded TreeNodesModel declares (``ID`` -> its model element)."""
        return dict(self._declared_models)

    def load_from_file(self, path: str | os.PathLike, *, skip_existing: bool = False) -> None:
        """Load a file (and what it includes). ``skip_existing`` keeps trees already registered
        under the same ID instead of refusing the duplicate (an objective library loaded after
        the objective being run)."""
        self._load_file(Path(path), [], None, skip_existing)

    def load_from_text(self, text: str | bytes, *, source: str = "<xml text>",
                       base_dir: str | os.PathLike | None = None, skip_existing: bool = False) -> None:
        """Load XML text; relative includes are resolved from ``base_dir`` (default: cwd)."""
        if len(text) > MAX_XML_BYTES:
            raise TreeLoadError(f"the XML is larger than {MAX_XML_BYTES // (1024 * 1024)} MiB", file=source)
        root = parse_xml(text, source)
        self._load_document(root, Path(base_dir) if base_dir is not None else Path.cwd(), [], skip_existing)

    def _load_file(self, path: Path, stack: list[tuple[str, XmlElement]], include: XmlElement | None,
                   skip_existing: bool) -> None:
        resolved = str(path.resolve())
        where = {"file": include.file, "line": include.line, "node": include.describe()} if include else {}
        for index, (file, element) in enumerate(stack):
            if file == resolved:
                chain = " -> ".join(Path(f).name for f, _ in stack[index:]) + " -> " + path.name
                raise TreeLoadError(f"include cycle: {chain}", **where)
        if resolved in self._loaded_files:
            return
        try:
            size = path.stat().st_size
            if size > MAX_XML_BYTES:
                raise TreeLoadError(f"{path} is larger than {MAX_XML_BYTES // (1024 * 1024)} MiB", **where)
            data = path.read_bytes()
        except FileNotFoundError:
            raise TreeLoadError(f"no such file: {path}", **where) from None
        except IsADirectoryError:
            raise TreeLoadError(f"{path} is a directory, not an XML file", **where) from None
        except OSError as exc:
            raise TreeLoadError(f"can't read {path}: {exc.strerror}", **where) from None
        root = parse_xml(data, resolved)
        self._loaded_files.add(resolved)
        self._load_document(root, path.resolve().parent, stack + [(resolved, include)], skip_existing)

    def _load_document(self, root: XmlElement, base_dir: Path, stack: list[tuple[str, XmlElement | None]],
                       skip_existing: bool) -> None:
        if root.tag != "root":
            raise _error(root, "the XML must have a root node called <root>")
        version = root.get("BTCPP_format")
        if version is None:
            _LOG.warning("%s: the first tag of the XML (<root>) should contain the attribute "
                         "[BTCPP_format=\"4\"]; reading it as version 4", root.file)
        elif version.strip() != "4":
            raise _error(root, f"BTCPP_format=\"{version}\": only BehaviorTree.CPP's version 4 XML is supported")
        self._documents.append(_Document(root.file, root))

        for element in root.children:
            if element.tag == "include":
                self._include(element, base_dir, stack, skip_existing)

        models = [e for e in root.children if e.tag == "TreeNodesModel"]
        if len(models) > 1:
            raise _error(models[1], "only a single node <TreeNodesModel> is supported")
        if models:
            self._load_models(models[0])

        new_trees: dict[str, XmlElement] = {}
        for element in root.children:
            if element.tag != "BehaviorTree":
                continue
            tree_id = element.get("ID")
            if tree_id is None:
                if len(root.children) > 1:
                    raise _error(element, "the tag <BehaviorTree> must have the attribute [ID]")
                tree_id = f"BehaviorTree_{self._suffix}"
                self._suffix += 1
            if len(element.children) != 1:
                raise _error(element, f"the tag <BehaviorTree> with ID '{tree_id}' must have exactly 1 child "
                                      f"(it has {len(element.children)})")
            if tree_id in self._factory.manifests:
                raise _error(element, "the attribute [ID] of tag <BehaviorTree> must not use the name of a "
                                      f"registered node ('{tree_id}')")
            earlier = new_trees.get(tree_id)
            if earlier is not None:
                # a running tree's XML repeats a SubTree once per instance: the same tree again
                if earlier.children[0].signature() != element.children[0].signature():
                    raise _error(element, f"BehaviorTree '{tree_id}' is defined twice in this file (line "
                                          f"{earlier.line} and here) with different contents")
                continue
            registered = self._tree_roots.get(tree_id)
            if registered is not None:
                if skip_existing:
                    continue
                raise _error(element, f"BehaviorTree '{tree_id}' is already defined in {registered.file}:"
                                      f"{registered.line}")
            new_trees[tree_id] = element
        self._tree_roots.update(new_trees)

    def _include(self, element: XmlElement, base_dir: Path, stack: list, skip_existing: bool) -> None:
        path_attr = element.get("path")
        if not path_attr:
            raise _error(element, "invalid <include> tag: missing 'path' attribute")
        path = Path(path_attr)
        package = element.get("ros_pkg")
        if package and not path.is_absolute():
            try:
                from ament_index_python.packages import get_package_share_directory
                path = Path(get_package_share_directory(package)) / path
            except Exception as exc:  # ImportError, PackageNotFoundError
                raise _error(element, f"can't find the package '{package}' of this include: {exc}") from None
        if not path.is_absolute():
            path = base_dir / path
        self._load_file(path, stack, element, skip_existing)

    def _load_models(self, models: XmlElement) -> None:
        for model in models.children:
            if model.tag not in ("Action", "Condition", "Control", "Decorator", "SubTree"):
                continue
            model_id = model.get("ID")
            if not model_id:
                raise _error(model, "the attribute [ID] is mandatory in a <TreeNodesModel> entry")
            self._declared_models[model_id] = model
            if model.tag != "SubTree":
                continue
            ports: dict[str, PortInfo] = {}
            for port in model.children:
                direction = {"input_port": PortDirection.INPUT, "output_port": PortDirection.OUTPUT,
                             "inout_port": PortDirection.INOUT}.get(port.tag)
                if direction is None:
                    continue
                name = port.get("name")
                if not name:
                    raise _error(port, "missing attribute [name] in port (SubTree model)")
                default = port.get("default")
                description = port.get("description") or port.text.strip()
                try:
                    ports[name] = PortInfo(name, direction, default=default if default is not None else NO_DEFAULT,
                                           description=description)
                except BehaviorTreeException as exc:
                    raise _error(port, str(exc)) from None
            self._subtree_models[model_id] = ports

    # -- instantiation -----------------------------------------------------------------------

    def main_tree_id(self) -> str:
        if self._documents:
            main = self._documents[0].root.get("main_tree_to_execute")
            if main:
                return main
        if len(self._tree_roots) == 1:
            return next(iter(self._tree_roots))
        where = {"file": self._documents[0].file} if self._documents else {}
        raise TreeLoadError("[main_tree_to_execute] was not specified and there is more than one "
                            f"BehaviorTree: {', '.join(self._tree_roots) or 'none'}", **where)

    def instantiate_tree(self, blackboard: Blackboard | None = None, main_tree_id: str | None = None,
                         clock: Any = None) -> Tree:
        """Build the tree ``main_tree_id`` (default: the first document's main_tree_to_execute,
        or its only tree). Raises TreeLoadError and leaves ``blackboard`` as it was if anything
        is wrong."""
        tree_id = main_tree_id or self.main_tree_id()
        if tree_id not in self._tree_roots:
            where = {"file": self._documents[0].file} if self._documents else {}
            raise TreeLoadError(f"can't find a tree with name '{tree_id}' (loaded: "
                                f"{', '.join(self._tree_roots) or 'none'})", **where)
        blackboard = blackboard if blackboard is not None else Blackboard.create()
        saved = dict(blackboard._storage)
        tree = Tree(clock)
        try:
            self._create_subtree(tree_id, "", "", tree, blackboard, None, [(tree_id, self._tree_roots[tree_id])])
        except BaseException:
            blackboard._storage = saved
            raise
        tree.manifests = dict(self._factory.manifests)
        tree.builtin_ids = set(self._factory.builtin_nodes)
        tree.initialize()
        return tree

    def _create_subtree(self, tree_id: str, tree_path: str, prefix: str, tree: Tree, blackboard: Blackboard,
                        parent: TreeNode | None, stack: list[tuple[str, XmlElement]]) -> None:
        element = self._tree_roots[tree_id]
        subtree = Subtree(blackboard, tree_path, tree_id)
        tree.subtrees.append(subtree)
        self._create_recursively(element.children[0], parent, subtree, prefix, tree, stack)

    def _create_recursively(self, element: XmlElement, parent: TreeNode | None, subtree: Subtree, prefix: str,
                            tree: Tree, stack: list[tuple[str, XmlElement]]) -> None:
        node = self._create_node(element, subtree.blackboard, parent, prefix, tree)
        subtree.nodes.append(node)
        if node.type is not NodeType.SUBTREE:
            for child in element.children:
                self._create_recursively(child, node, subtree, prefix, tree, stack)
            try:
                validate = getattr(node, "validate", None)
                if validate is not None:
                    validate()
            except (BehaviorTreeException, ConversionError) as exc:
                raise _error(element, str(exc)) from None
            return
        self._create_subtree_instance(element, node, subtree, tree, stack)

    def _create_subtree_instance(self, element: XmlElement, node: TreeNode, subtree: Subtree, tree: Tree,
                                 stack: list[tuple[str, XmlElement]]) -> None:
        subtree_id = element.get("ID")
        for index, (tree_id, _) in enumerate(stack):
            if tree_id == subtree_id:
                chain = " -> ".join([t for t, _ in stack[index:]] + [subtree_id])
                raise _error(element, f"SubTrees include each other (recursion): {chain}")
        new_bb = Blackboard.create(subtree.blackboard)
        remapping: dict[str, str] = {}
        autoremap = False
        for name, value in element.attrib:
            if value == "{=}":
                value = "{" + name + "}"
            if name == "_autoremap":
                try:
                    autoremap = parse_bool(value.strip())
                except ConversionError as exc:
                    raise _error(element, f"_autoremap: {exc}") from None
                new_bb.enable_auto_remapping(autoremap)
                node.autoremap = autoremap
                continue
            if is_allowed_port_name(name):
                remapping[name] = value
        for port_name, port in self._subtree_models.get(subtree_id, {}).items():
            if port_name in remapping or autoremap:
                continue
            if not port.has_default:
                raise _error(element, f"in the <TreeNodesModel> the <SubTree ID=\"{subtree_id}\"> is defining a "
                                      f"mandatory port called [{port_name}], but you are not remapping it")
            remapping[port_name] = port.default_string
        for name, value in remapping.items():
            if is_blackboard_pointer(value):
                new_bb.add_subtree_remapping(name, strip_blackboard_pointer(value))
            else:
                new_bb.enable_auto_remapping(False)
                new_bb.set(name, value)
                new_bb.enable_auto_remapping(autoremap)
        path = subtree.instance_name
        if path:
            path += "/"
        name_attr = element.get("name")
        path += name_attr if name_attr is not None else f"{subtree_id}::{node.uid}"
        self._create_subtree(subtree_id, path, path + "/", tree, new_bb, node, stack + [(subtree_id, element)])

    def _unknown(self, element: XmlElement, type_id: str, what: str) -> TreeLoadError:
        known = list(self._factory.manifests)
        close = difflib.get_close_matches(type_id, known, n=3)
        hint = f" (did you mean {' or '.join(repr(c) for c in close)}?)" if close else ""
        return _error(element, f"{what} '{type_id}' is not a registered node{hint}", unknown_node_id=type_id)

    def _create_node(self, element: XmlElement, blackboard: Blackboard, parent: TreeNode | None, prefix: str,
                     tree: Tree) -> TreeNode:
        factory = self._factory
        manifests = factory.manifests
        node_type = NodeType.from_tag(element.tag)
        element_id = element.get("ID")
        if node_type is NodeType.UNDEFINED:
            type_id = element.tag
            if type_id in ("BehaviorTree", "TreeNodesModel", "include", "root"):
                raise _error(element, f"<{type_id}> can't be a node of a tree")
            if type_id not in manifests:
                raise self._unknown(element, type_id, "node")
            if element_id is not None:
                raise _error(element, f"attribute [ID] is not allowed in <{type_id}> (the compact form names "
                                      f"the node by its tag; the generic form is <Action ID=\"...\">)")
        else:
            if not element_id:
                raise _error(element, f"the tag <{element.tag}> must have the attribute [ID]")
            type_id = element_id
            if node_type is NodeType.SUBTREE:
                if element.children:
                    raise _error(element, f"<SubTree> with ID '{type_id}' should not have any child")
                if type_id in manifests:
                    raise _error(element, "the attribute [ID] of tag <SubTree> must not use the name of a "
                                          f"registered node ('{type_id}')")
                if type_id not in self._tree_roots:
                    close = difflib.get_close_matches(type_id, list(self._tree_roots), n=3)
                    hint = f" (did you mean {' or '.join(repr(c) for c in close)}?)" if close else ""
                    raise _error(element, f"SubTree '{type_id}': no <BehaviorTree ID=\"{type_id}\"> was loaded"
                                          f"{hint}")
            elif type_id not in manifests:
                raise self._unknown(element, type_id, f"<{element.tag}> ID")
        manifest = manifests["SubTree" if node_type is NodeType.SUBTREE else type_id]
        name_attr = element.get("name")
        instance_name = name_attr if name_attr is not None else type_id

        port_remap: dict[str, str] = {}
        other_attributes: dict[str, str] = {}
        for name, value in element.attrib:
            if is_allowed_port_name(name):
                if node_type is not NodeType.SUBTREE:
                    port = manifest.ports.get(name)
                    if port is None:
                        ports = ", ".join(manifest.ports) or "none"
                        raise _error(element, f"a port with name [{name}] is found in the XML but not in the "
                                              f"ports of the registered node '{type_id}' (its ports: {ports})")
                    self._check_literal(element, port, value)
                port_remap[name] = value
            elif not is_reserved_attribute(name):
                other_attributes[name] = value

        config = NodeConfig(blackboard=blackboard, enums=factory.scripting_enums, manifest=manifest,
                            uid=tree.get_uid(), path=prefix + instance_name, other_attributes=other_attributes,
                            clock=tree.clock, source=(element.file, element.line))
        if type_id == instance_name:
            config.path += f"::{config.uid}"
        pre_scripts, post_scripts = self._parse_conditions(element, config)

        if node_type is NodeType.SUBTREE:
            config.input_ports = dict(port_remap)
            node = self._instantiate(element, factory, instance_name, "SubTree", config)
            node.subtree_id = type_id
        else:
            self._declare_entries(element, manifest.ports, port_remap, blackboard)
            for name, value in port_remap.items():
                direction = manifest.ports[name].direction
                if direction is not PortDirection.OUTPUT:
                    config.input_ports[name] = value
                if direction is not PortDirection.INPUT:
                    config.output_ports[name] = value
            for name, port in manifest.ports.items():
                if name in port_remap:
                    continue
                if port.has_default:
                    text = port.default_text()
                    if text is None:
                        continue  # an object default: get_input hands it out as it is
                    if port.direction is not PortDirection.OUTPUT:
                        config.input_ports[name] = text
                    if port.direction is not PortDirection.INPUT and is_blackboard_pointer(text):
                        config.output_ports[name] = text
                elif port.is_required:
                    what = f"{port.type.name}" + (f": {port.description}" if port.description else "")
                    raise _error(element, f"missing required input port [{name}] ({what})")
            node = self._instantiate(element, factory, instance_name, type_id, config)
        node.set_conditions(pre_scripts, post_scripts)
        self._check_children(element, node)
        if parent is not None:
            if parent.type is NodeType.CONTROL:
                parent.add_child(node)
            else:
                parent.set_child(node)
        return node

    @staticmethod
    def _instantiate(element: XmlElement, factory: BehaviorTreeFactory, name: str, type_id: str,
                     config: NodeConfig) -> TreeNode:
        try:
            return factory.instantiate_tree_node(name, type_id, config)
        except ScriptSyntaxError as exc:
            raise _error(element, f"script error: {exc}") from None
        except (BehaviorTreeException, ConversionError) as exc:
            raise _error(element, str(exc)) from None

    @staticmethod
    def _check_literal(element: XmlElement, port: PortInfo, value: str) -> None:
        if remapped_key(port.name, value) is not None:
            return
        if port.direction is PortDirection.OUTPUT:
            raise _error(element, f"output port [{port.name}] must name a blackboard entry, e.g. "
                                  f"\"{{{port.name}}}\", not \"{value}\"")
        if port.type.strongly_typed and port.type.parse is not None:
            try:
                port.type.from_string(value)
            except ConversionError as exc:
                raise _error(element, f"the port with name \"{port.name}\" and value \"{value}\" can not be "
                                      f"converted to {port.type.name}: {exc}") from None

    @staticmethod
    def _declare_entries(element: XmlElement, ports: dict[str, PortInfo], remap: dict[str, str],
                         blackboard: Blackboard) -> None:
        """Create the entries the ports point to, typed; refuse a port that would change the
        type an earlier port gave the same entry."""
        for name, value in remap.items():
            port = ports[name]
            key = remapped_key(name, value)
            if key is None:
                continue
            try:
                previous = blackboard.get_entry(key)
                if previous is None:
                    blackboard.create_entry(key, port.type)
                elif (previous.type.strongly_typed and port.type.strongly_typed
                      and previous.type.name != port.type.name and previous.type.name != STRING.name):
                    raise _error(element, f"the port [{name}] uses the blackboard entry [{key}] as "
                                          f"{port.type.name}, but it was created with type {previous.type.name}")
            except BehaviorTreeException as exc:
                if isinstance(exc, TreeLoadError):
                    raise
                raise _error(element, str(exc)) from None

    @staticmethod
    def _parse_conditions(element: XmlElement, config: NodeConfig) -> tuple[dict, dict]:
        pre, post = {}, {}
        for condition in PreCond:
            text = element.get(PRE_CONDITION_NAMES[condition])
            if text is not None:
                config.pre_conditions[condition] = text
                pre[condition] = XMLParser._script(element, PRE_CONDITION_NAMES[condition], text)
        for condition in PostCond:
            text = element.get(POST_CONDITION_NAMES[condition])
            if text is not None:
                config.post_conditions[condition] = text
                post[condition] = XMLParser._script(element, POST_CONDITION_NAMES[condition], text)
        return pre, post

    @staticmethod
    def _script(element: XmlElement, attribute: str, text: str):
        try:
            return parse_script(text)
        except ScriptSyntaxError as exc:
            raise _error(element, f"script error in {attribute}: {exc}") from None

    @staticmethod
    def _check_children(element: XmlElement, node: TreeNode) -> None:
        count = len(element.children)
        node_type = node.type
        label = node.registration_id
        if node_type is NodeType.DECORATOR and count != 1:
            raise _error(element, f"the node '{label}' must have exactly 1 child (it has {count})")
        if node_type is NodeType.CONTROL:
            low, high = getattr(node, "CHILDREN", (1, None))
            if count < low or (high is not None and count > high):
                wanted = f"{low} or more" if high is None else (str(low) if low == high else f"{low} to {high}")
                raise _error(element, f"the node '{label}' must have {wanted} children (it has {count})")
        if node_type in (NodeType.ACTION, NodeType.CONDITION) and count:
            raise _error(element, f"the node '{label}' must not have any child (it has {count})")


# ----------------------------------------------------------------------------- writing


def _port_element(parent: ET.Element, name: str, direction: str, type_name: str, default: str | None,
                  description: str) -> None:
    port = ET.SubElement(parent, direction, {"name": name})
    if type_name:
        port.set("type", type_name)
    if default is not None:
        port.set("default", default)
    if description:
        port.text = description


def _model_element(parent: ET.Element, manifest: Any) -> None:
    element = ET.SubElement(parent, str(manifest.type), {"ID": manifest.registration_id})
    if manifest.registration_id == "SubTree":
        from .decorators import SubTreeNode
        _port_element(element, "_autoremap", "input_port", "bool", "false", SubTreeNode.AUTOREMAP_DESCRIPTION)
    for port in manifest.ports.values():
        _port_element(element, port.name, port.direction.value, port.type.name,
                      port.default_string if port.has_default else None, port.description)
    if manifest.metadata:
        fields = ET.SubElement(element, "MetadataFields")
        for key, value in manifest.metadata:
            ET.SubElement(fields, "Metadata", {key: value})
    if manifest.description:
        ET.SubElement(element, "description").text = manifest.description


def _to_string(root: ET.Element) -> str:
    ET.indent(root, space="  ")
    return ET.tostring(root, encoding="unicode")


def write_tree_nodes_model_xml(factory: BehaviorTreeFactory, include_builtin: bool = False) -> str:
    """``<root BTCPP_format="4"><TreeNodesModel>...`` of the registered nodes, sorted by ID:
    the file Groot2 loads to edit trees that use them."""
    root = ET.Element("root", {"BTCPP_format": "4"})
    models = ET.SubElement(root, "TreeNodesModel")
    for registration_id in sorted(factory.manifests):
        if include_builtin or registration_id not in factory.builtin_nodes:
            _model_element(models, factory.manifests[registration_id])
    return _to_string(root)


def write_tree_to_xml(tree: Tree, add_metadata: bool = False, add_builtin_models: bool = False) -> str:
    """The XML of an instantiated tree (BT.CPP's WriteTreeToXML): one ``<BehaviorTree>`` per
    SubTree instance, nodes in the compact form with their ports, and with ``add_metadata``
    the ``_uid`` of each node and the ``_fullpath`` of each SubTree, as Groot2 receives it."""
    from .decorators import SubTreeNode

    root = ET.Element("root", {"BTCPP_format": "4"})

    def add(node: TreeNode, parent: ET.Element) -> None:
        if isinstance(node, SubTreeNode):
            element = ET.SubElement(parent, node.registration_id or "SubTree", {"ID": node.subtree_id})
            if node.name != node.subtree_id:
                element.set("name", node.name)  # BT.CPP drops it; kept so that paths survive a reload
            if node.autoremap:
                element.set("_autoremap", "true")  # idem: without it the reloaded SubTree would not share
            if add_metadata:
                element.set("_fullpath", node.config.path)
        else:
            element = ET.SubElement(parent, node.registration_id, {"name": node.name})
        if add_metadata:
            element.set("_uid", str(node.uid))
        for name, value in node.config.input_ports.items():
            element.set(name, value)
        for name, value in node.config.output_ports.items():
            if name not in node.config.input_ports:
                element.set(name, value)
        for condition, script in node.config.pre_conditions.items():
            element.set(PRE_CONDITION_NAMES[condition], script)
        for condition, script in node.config.post_conditions.items():
            element.set(POST_CONDITION_NAMES[condition], script)
        if not isinstance(node, SubTreeNode):
            for child in node.children_nodes():
                add(child, element)

    for subtree in tree.subtrees:
        element = ET.SubElement(root, "BehaviorTree", {"ID": subtree.tree_id, "_fullpath": subtree.instance_name})
        add(subtree.nodes[0], element)
    models = ET.SubElement(root, "TreeNodesModel")
    builtin = tree.builtin_ids
    for registration_id in sorted(tree.manifests):
        if add_builtin_models or registration_id not in builtin:
            _model_element(models, tree.manifests[registration_id])
    return _to_string(root)
