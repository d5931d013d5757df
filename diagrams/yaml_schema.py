"""Checks a YAML document against a dataclass schema before Drake loads it.

Drake's ``yaml_load_typed`` refuses unknown keys, but its messages do not say
where, and it pours a scalar into a dataclass's first field. ``load_typed``
first parses the document on its own (YAML 1.2 numbers, ``!Tag`` unions), checks
its structure against the schema naming the dotted key of any misfit, and only
then lets Drake fill the dataclasses. Every problem is one ``ValueError`` line.
"""

from __future__ import annotations

import dataclasses
import json
import re
import types
import typing
from dataclasses import fields
from pathlib import Path

import yaml
from pydrake.common.yaml import yaml_load_typed

from posfb.models.validation import require_regular_file


def _require(condition: bool, message: str) -> None:
    if not condition:
        raise ValueError(message)


class _TaggedLoader(yaml.SafeLoader):
    """Reads ``!Tag {map}`` as the map with ``"_tag": "Tag"`` (for ``check_shape``),
    numbers as YAML 1.2 does (``1e-3`` and ``2e1`` are floats, as Drake reads them),
    and refuses a key given twice in one map (PyYAML would keep the last silently)."""

    def construct_mapping(self, node: yaml.MappingNode, deep: bool = False) -> dict:
        seen: dict[object, int] = {}
        for key_node, _ in node.value:
            key = self.construct_object(key_node, deep=True)
            line = key_node.start_mark.line + 1
            if key in seen:
                raise yaml.constructor.ConstructorError(
                    None, None, f"key {key!r} is given twice (lines {seen[key]} and {line})",
                    key_node.start_mark,
                )  # fmt: skip
            seen[key] = line
        return super().construct_mapping(node, deep=deep)


_TaggedLoader.add_multi_constructor(
    "!",
    lambda loader, tag, node: {
        **(loader.construct_mapping(node, deep=True) if isinstance(node, yaml.MappingNode) else {}),
        "_tag": tag.lstrip("!"),
    },
)


def _field_types(schema: type) -> dict[str, object]:
    """The fields of a dataclass or of a Drake config (``__fields__``) and their types."""
    if dataclasses.is_dataclass(schema):
        hints = typing.get_type_hints(schema)
        return {f.name: hints[f.name] for f in fields(schema)}
    return {f.name: f.type for f in schema.__fields__}


#: How a scalar type is named in messages.
_KINDS = {bool: "true or false", int: "an integer", float: "a number", str: "a string"}


def _scalar_ok(value: object, schema: type) -> bool:
    if isinstance(value, bool):
        return schema is bool
    if schema is float:
        return isinstance(value, int | float)
    return isinstance(value, schema)


def check_shape(value: object, schema: object, key: str) -> None:
    """Refuse YAML whose structure does not fit ``schema``, naming the key.

    ``yaml_load_typed`` refuses unknown keys but neither says where nor refuses
    every misfit (it pours a scalar into a dataclass's first field), so the raw
    document is checked against the dataclasses first. A dataclass may name keys it
    has renamed (``RENAMED``: old -> new) and tags it replaces (``FORMERLY``); those
    are refused with the new spelling."""
    where = key or "the document"
    origin, args = typing.get_origin(schema), typing.get_args(schema)
    if dataclasses.is_dataclass(schema) or hasattr(schema, "__fields__"):
        _require(isinstance(value, dict), f"{where} = {value!r}; a map of keys is required")
        allowed = _field_types(schema)
        for name, item in value.items():
            if name == "_tag":
                continue
            path = f"{key}.{name}" if key else str(name)
            removed = getattr(schema, "REMOVED", {})
            _require(name not in removed, f"{path}: {removed.get(name)}")
            renamed = getattr(schema, "RENAMED", {}).get(name)
            _require(
                renamed is None or renamed in value,
                f"{path}: {name!r} is now spelled {renamed!r} (Drake's name); write {renamed}:",
            )
            _require(name in allowed, f"{path}: unknown key; known keys: {', '.join(allowed)}")
            check_shape(item, allowed[name], path)
    elif origin in (typing.Union, types.UnionType):
        if value is None and types.NoneType in args:
            return
        options = [a for a in args if a is not types.NoneType]
        if not dataclasses.is_dataclass(options[0]):
            check_shape(value, options[0], key)
            return
        tags = {option.__name__: option for option in options}
        _require(
            isinstance(value, dict),
            f"{where} = {value!r}; a distribution (!{' {...}, !'.join(tags)} {{...}}) is required",
        )
        tag = value.get("_tag", options[0].__name__)
        for name, option in tags.items():
            _require(
                tag not in getattr(option, "FORMERLY", ()),
                f"{where}: !{tag} is now !{name} {{{', '.join(_field_types(option))}}} "
                "(Drake's name)",
            )
        _require(tag in tags, f"{where}: unknown tag !{tag}; one of !{', !'.join(tags)}")
        check_shape(value, tags[tag], key)
    elif origin is list:
        _require(isinstance(value, list), f"{where} = {value!r}; a list [...] is required")
        for i, item in enumerate(value):
            check_shape(item, args[0], f"{key}[{i}]")
    elif origin is dict:
        _require(isinstance(value, dict), f"{where} = {value!r}; a map is required")
        for name, item in value.items():
            check_shape(item, args[1], f"{key}.{name}")
    else:
        _require(_scalar_ok(value, schema), f"{where} = {value!r}; {_KINDS[schema]} is required")


#: YAML 1.2 floats that YAML 1.1 (PyYAML) would read as strings: ``1e-3``, ``2E5``.
_FLOAT = re.compile(r"^[-+]?(\.[0-9]+|[0-9]+(\.[0-9]*)?)([eE][-+]?[0-9]+)?$")
_TaggedLoader.add_implicit_resolver("tag:yaml.org,2002:float", _FLOAT, list("-+0123456789."))


def read_text(path: Path, what: str, missing: type[Exception] = ValueError) -> str:
    """The text of the YAML file ``path`` (a ``what`` such as "scenario"); a folder, a
    missing file (``missing`` is raised), a binary or unreadable file is one line."""
    require_regular_file(what, path, missing)
    try:
        return path.read_text()
    except UnicodeDecodeError:
        raise ValueError(f"{what} {path} is not a text file; a YAML file is required") from None
    except OSError as error:
        raise ValueError(f"{what} {path} cannot be read: {error.strerror}") from None


def parse(text: str, source: str) -> object:
    """The raw YAML document (``None`` if empty); a syntax error is one line."""
    try:
        return yaml.load(text, Loader=_TaggedLoader)
    except yaml.MarkedYAMLError as error:
        mark = error.problem_mark
        at = f" at line {mark.line + 1}, column {mark.column + 1}" if mark else ""
        raise ValueError(f"{source}: YAML syntax error{at}: {error.problem}") from None
    except yaml.YAMLError as error:
        raise ValueError(f"{source}: not a YAML document ({type(error).__name__})") from None


class _TaggedDumper(yaml.SafeDumper):
    """Writes the nodes ``prepare`` rewrote, with YAML 1.2 floats left plain."""


_TaggedDumper.add_implicit_resolver("tag:yaml.org,2002:float", _FLOAT, list("-+0123456789."))

#: Scalar types of a per-joint list (``list[float]``, ``list[int]``).
_SCALARS = (float, int)


def _list_of_scalars(schema: object) -> bool:
    """Whether ``schema`` is ``list[float]``/``list[int]`` (or that ``| None``)."""
    options = typing.get_args(schema) if typing.get_origin(schema) in (
        typing.Union, types.UnionType) else (schema,)  # fmt: skip
    return any(
        typing.get_origin(option) is list and typing.get_args(option)[0] in _SCALARS
        for option in options
    )


def _prepare_node(node: yaml.Node, schema: object) -> None:
    """Rewrite ``node`` in place for ``schema`` (``prepare``)."""
    origin, args = typing.get_origin(schema), typing.get_args(schema)
    if dataclasses.is_dataclass(schema) or hasattr(schema, "__fields__"):
        if not isinstance(node, yaml.MappingNode):
            return
        allowed = _field_types(schema)
        aliases = getattr(schema, "ALIASES", {})
        freeform = getattr(schema, "FREEFORM", ())
        for index, (key, value) in enumerate(node.value):
            if not isinstance(key, yaml.ScalarNode):
                continue
            key.value = aliases.get(key.value, key.value)
            if key.value in freeform and not isinstance(value, yaml.ScalarNode):
                data = yaml.load(yaml.serialize(value, Dumper=_TaggedDumper), Loader=_TaggedLoader)
                text = json.dumps(data)
                node.value[index] = (key, yaml.ScalarNode("tag:yaml.org,2002:str", text))
            elif key.value in allowed:
                _prepare_node(value, allowed[key.value])
    elif origin in (typing.Union, types.UnionType):
        options = [a for a in args if a is not types.NoneType]
        if _list_of_scalars(schema):
            _prepare_node(node, next(o for o in options if typing.get_origin(o) is list))
            return
        by_tag = {f"!{o.__name__}": o for o in options if dataclasses.is_dataclass(o)}
        _prepare_node(node, by_tag.get(node.tag, options[0]))
    elif origin is list:
        if isinstance(node, yaml.SequenceNode):
            for item in node.value:
                _prepare_node(item, args[0])
        elif (
            isinstance(node, yaml.ScalarNode)
            and args[0] in _SCALARS
            and node.tag != "tag:yaml.org,2002:null"
        ):
            # A per-joint key given one value: every joint (as --set does).
            scalar = yaml.ScalarNode(node.tag, node.value, style=node.style)
            node.__class__, node.tag = yaml.SequenceNode, "tag:yaml.org,2002:seq"
            node.value, node.flow_style = [scalar], True
    elif origin is dict and isinstance(node, yaml.MappingNode):
        for _, value in node.value:
            _prepare_node(value, args[1])


def prepare(text: str, schema: type) -> str:
    """``text`` rewritten for ``schema`` before it is checked and loaded: a scalar where
    a per-joint list (``list[float]``) is expected becomes a one-value list (one value
    means every joint); a key in a dataclass's ``ALIASES`` is renamed (``class`` ->
    ``class_name``); a map under a ``FREEFORM`` key (a plug-in's ``settings``) becomes its
    JSON text, for the plug-in to read. A document that does not parse is returned as
    it is, for ``parse`` to report."""
    try:
        root = yaml.compose(text, Loader=_TaggedLoader)
    except yaml.YAMLError:
        return text
    if root is None:
        return text
    _prepare_node(root, schema)
    return yaml.serialize(root, Dumper=_TaggedDumper)


def load_typed(
    schema: type, text: str, source: str, defaults: object | None = None, empty_ok: bool = False
) -> object:
    """``text`` loaded into ``schema`` (over ``defaults`` where given) after ``check_shape``.
    A document with no content (empty or comments only) is ``schema()`` where
    ``empty_ok``, and an error otherwise."""
    text = prepare(text, schema)
    raw = parse(text, source)
    if raw is None:
        if empty_ok:
            return schema() if defaults is None else defaults
        raise ValueError(f"{source} is empty (no keys); a YAML map of keys is required")
    try:
        check_shape({} if raw is None else raw, schema, "")
        if defaults is None:
            return yaml_load_typed(schema=schema, data=text)
        return yaml_load_typed(schema=schema, data=text, defaults=defaults)
    except Exception as error:  # shape, and yaml_load_typed's own errors
        first = str(error).strip().splitlines()[0] if str(error).strip() else type(error).__name__
        raise ValueError(f"{source}: {first}") from None
