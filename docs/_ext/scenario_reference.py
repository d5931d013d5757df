"""The ``scenario-reference`` directive: every key of a scenario file, generated.

The scenario is one typed settings tree (``posfb.diagrams.scenario.Scenario``, loaded with
Drake's YAML): nested dataclasses, tagged unions of dataclasses (``controller: !Proposed
{...}``, ``plant.friction: !Stribeck {...}``, ``trajectory: !Waypoints {...}``), lists of
them and Drake's ``SimulatorConfig``. This directive walks that tree with
``dataclasses.fields`` (recursively, through every union member), so a key added to the
code appears here by itself, and writes one section per top-level key and one per tagged
entry, each listing its keys:

* **type**, from the field's annotation;
* **default**, from a default-constructed object (the values ``posfb scenario dump``
  writes out);
* **unit** and **description**, from the code's own documentation: a ``#:`` comment above
  the field where there is one, otherwise the clause of the class docstring that names the
  field (``name``, or its words, e.g. "zero offset (rad)"), with the unit read from the
  first parenthesis of that clause that starts with an SI unit; the per-joint parameters'
  units come from ``posfb.models.plant.PARAMETER_UNITS``;
* each controller entry names its registered kind and label (``posfb.models.controllers``
  registry), each friction law its kind (``posfb.models.friction`` registry).

The generated text is reST (the directive lives on an ``.rst`` page); every docstring
fragment is escaped, so nothing in a docstring can break the build. The page is rebuilt
when any module the tree is defined in changes.
"""

from __future__ import annotations

import dataclasses
import importlib
import inspect
import re
import types
import typing
from collections.abc import Iterator
from pathlib import Path

from docutils import nodes
from docutils.statemachine import StringList
from sphinx.application import Sphinx
from sphinx.pycode import ModuleAnalyzer
from sphinx.util.docutils import SphinxDirective
from sphinx.util.nodes import nested_parse_with_titles

#: Where a section's fields are documented besides its own docstring: the classes that
#: consume them (a scenario section is turned into these, and their docstrings describe
#: the same names), or the class a ``make_dataclass`` section is made from
#: (``ParameterOverrides`` from ``ArmParameters``, ``Bounds`` from ``UncertaintyBounds``,
#: ``TimingSection`` from ``Timing``).
#: Looked up by field name, so that a key added to either appears with its text.
DOCUMENTED_BY = {
    "PlantSettings": ["posfb.models.plant:PlantConfig", "posfb.models.plant:ArmParameters",
                      "posfb.models.gear:GearConfig"],
    "ParameterOverrides": ["posfb.models.plant:ArmParameters"],
    "Bounds": ["posfb.models.design.config:UncertaintyBounds"],
    "Proposed": ["posfb.models.design.config:NonlinearTorqueConfig",
                 "posfb.models.design.config:LqrWeights"],
    "LinLc": ["posfb.models.design.config:LqrWeights"],
    "Pid": ["posfb.models.design.config:PidGains"],
    "TimingSection": ["posfb.diagrams.sections:Timing"],
}  # fmt: skip

#: Classes whose field units a table in the code gives (column-name suffixes).
UNIT_TABLES = {"ParameterOverrides": "posfb.models.plant:PARAMETER_UNITS"}

#: A unit at the start of a parenthesis: ``(s)``, ``(rad/s, > 0)``, ``(N m s/rad)``.
_UNIT = re.compile(
    r"^(?:N m s/rad|N m/rad|N m/V|N m s|N m|kg m\^?2|kg m²|V s\^?2/rad|rad/s\^?2|rad/s|rad|"
    r"kg|m|s|V|Hz|J|A)(?=$|[ ,;)])"
)

#: ``literal`` spans of a docstring.
_LITERAL = re.compile(r"``.+?``")


def _resolve(spec: str) -> object:
    module, _, name = spec.partition(":")
    return getattr(importlib.import_module(module), name)


# --- text -----------------------------------------------------------------------------


def _escape(text: str) -> str:
    """``text`` (a docstring fragment: plain words and ````literal```` spans) as inline
    reST that renders as written: literals kept, every markup character escaped."""
    out, last = [], 0
    for match in _LITERAL.finditer(text):
        out.append(_escape_plain(text[last : match.start()]))
        out.append(match.group(0))
        last = match.end()
    out.append(_escape_plain(text[last:]))
    return "".join(out).strip()


def _escape_plain(text: str) -> str:
    return re.sub(r"([\\`*_|\[\]<>:])", r"\\\1", text)


def _cell(text: str) -> str:
    """One line of inline reST for a table cell (a leading character escaped, so that a
    cell never starts a list)."""
    text = " ".join(text.split())
    return f"\\{text}" if text and text[0] in "-+*#0123456789" else text


def _flat(doc: str | None) -> str:
    """A docstring as one paragraph of text (its first block, the summary and body of a
    class docstring; numpydoc sections and ``::`` blocks left out)."""
    if not doc:
        return ""
    doc = inspect.cleandoc(doc)
    kept = []
    for block in re.split(r"\n\s*\n", doc):
        if re.match(r"^\s*[-=]{3,}\s*$", block.splitlines()[-1] if block else ""):
            break  # a numpydoc section heading
        if block.startswith(" "):
            continue  # an indented (literal) block
        kept.append(" ".join(block.split()))
    text = " ".join(kept)
    return text.replace("::", ":")


def _masked(text: str) -> str:
    """``text`` with every ````literal```` span blanked (same length), so that the
    punctuation inside literals is not read as the prose's."""
    return _LITERAL.sub(lambda m: "\0" * len(m.group(0)), text)


#: Words after which ``. `` does not end a sentence.
_ABBREVIATIONS = ("Sec", "Eq", "Eqs", "Fig", "e.g", "i.e", "al", "cf", "vs", "Tab")


def _boundary(masked: str, i: int) -> int:
    """The length of the clause end at ``masked[i]`` (0: none): ``;``, ``, ``, `` and ``, a
    sentence's ``. `` or a lead-in's ``: `` (``Joint encoders: ...``; not the colon after a
    field's own name, ````name````: its text)."""
    char, after = masked[i], masked[i + 1 : i + 2]
    if masked.startswith(" and ", i):
        return 5
    if char == ";" or (char == "," and after in (" ", "")):
        return 1
    if char == "." and after in (" ", ""):
        word = re.search(r"[\w.]*$", masked[:i]).group(0)
        following = masked[i + 2 : i + 3]
        starts = not following or not (following.islower() or following.isdigit())
        return 1 if word not in _ABBREVIATIONS and starts else 0
    return 1 if char == ":" and after == " " and not masked[:i].endswith("\0") else 0


def _clause_at(text: str, position: int) -> str:
    """The clause of ``text`` around ``position``: bounded by the nearest clause ends at the
    same parenthesis depth, or by the parenthesis that encloses it."""
    masked = _masked(text)
    depth, start = 0, 0
    for i in range(position - 1, -1, -1):
        char = masked[i]
        if char == ")":
            depth += 1
        elif char == "(":
            if depth == 0:
                start = i + 1
                break
            depth -= 1
        elif depth == 0 and _boundary(masked, i):
            start = i + _boundary(masked, i)
            break
    depth, end = 0, len(text)
    for i in range(position, len(text)):
        char = masked[i]
        if char == "(":
            depth += 1
        elif char == ")":
            if depth == 0:
                end = i
                break
            depth -= 1
        elif depth == 0 and _boundary(masked, i):
            end = i
            break
    return text[start:end].strip()


def _mention(text: str, name: str, yaml_name: str) -> int | None:
    """Where ``text`` first names the field: as a literal (````name````), or, for a name of
    several words (``zero_offset``), in plain words ("zero offset")."""
    for match in _LITERAL.finditer(text):
        literal = match.group(0)[2:-2]
        if literal in (name, yaml_name) or re.match(rf"{re.escape(name)} ?[=(]", literal):
            return match.start()
    if "_" in name:
        words = name.replace("_", " ")
        found = re.search(rf"\b{re.escape(words)}\b", _masked(text), re.IGNORECASE)
        if found:
            return found.start()
    return None


def _unit(clause: str) -> str:
    """The unit of the first parenthesis in ``clause`` that starts with one."""
    for match in re.finditer(r"\(([^()]*)\)", _masked(clause)):
        found = _UNIT.match(clause[match.start(1) : match.end(1)])
        if found:
            return found.group(0)
    return ""


def _unit_from_suffix(suffix: str) -> str:
    """``N_m_s_per_rad`` -> ``N m s/rad``, ``kg_m2`` -> ``kg m²``."""
    return suffix.replace("_per_", "/").replace("_", " ").replace("m2", "m²")


# --- the tree -------------------------------------------------------------------------


@dataclasses.dataclass
class Row:
    key: str
    kind: str
    default: str
    unit: str
    doc: str


@dataclasses.dataclass
class Entry:
    """A section: a top-level key or one tagged entry, with its rows and sub-entries."""

    title: str
    label: str
    intro: list[str]
    rows: list[Row]
    children: list[Entry]


class Walker:
    """Walks the scenario's dataclasses; remembers the files they are defined in."""

    def __init__(self) -> None:
        self.files: set[str] = set()
        self._attr_docs: dict[str, dict] = {}
        from posfb.models import controllers, friction

        self.registries = {s.settings: ("controller", s) for s in controllers.REGISTRY.values()}
        self.registries |= {s.settings: ("friction law", s) for s in friction.REGISTRY.values()}

    # documentation of one class ------------------------------------------------------

    def _note(self, cls: type) -> None:
        try:
            path = inspect.getsourcefile(cls)
        except TypeError:
            return
        if path:
            self.files.add(path)

    def _comment_docs(self, cls: type) -> dict[str, str]:
        """``#:`` comments above the fields of ``cls`` (Sphinx's source analyser)."""
        module = cls.__module__
        if module not in self._attr_docs:
            try:
                self._attr_docs[module] = ModuleAnalyzer.for_module(module).find_attr_docs()
            except Exception:  # a class made at run time has no source to analyse
                self._attr_docs[module] = {}
        found = self._attr_docs[module]
        return {
            attr: " ".join(" ".join(lines).split())
            for (owner, attr), lines in found.items()
            if owner == cls.__qualname__
        }

    def _doc_classes(self, cls: type) -> list[type]:
        classes = [cls]
        classes += [_resolve(spec) for spec in DOCUMENTED_BY.get(cls.__name__, ())]
        return classes

    def field_doc(self, cls: type, name: str, yaml_name: str) -> tuple[str, str]:
        """``(description, unit)`` of field ``name`` of ``cls`` from the code's text."""
        units = _resolve(UNIT_TABLES[cls.__name__]) if cls.__name__ in UNIT_TABLES else {}
        table_unit = _unit_from_suffix(units[name]) if name in units else ""
        for owner in self._doc_classes(cls):
            comment = self._comment_docs(owner).get(name)
            if comment:
                return comment, table_unit or _unit(comment)
            text = _flat(owner.__doc__)
            position = _mention(text, name, yaml_name)
            if position is not None:
                clause = _clause_at(text, position)
                if re.fullmatch(r"(?:the |its |then )?``[^`]+``", clause):
                    clause = ""  # the name alone says nothing
                return clause, table_unit or _unit(clause[position - text.find(clause) :])
        return "", table_unit

    # types and values ----------------------------------------------------------------

    @staticmethod
    def hints(cls: type) -> dict[str, object]:
        if dataclasses.is_dataclass(cls):
            hints = typing.get_type_hints(cls)
            return {f.name: hints[f.name] for f in dataclasses.fields(cls)}
        return {f.name: f.type for f in cls.__fields__}  # a Drake config

    @staticmethod
    def members(kind: object) -> list[type]:
        """The dataclass members of a union type (``[]`` for anything else)."""
        args = typing.get_args(kind)
        if typing.get_origin(kind) in (typing.Union, types.UnionType):
            return [a for a in args if dataclasses.is_dataclass(a)]
        return []

    def type_text(self, cls: type, name: str, kind: object) -> str:
        freeform = name in getattr(cls, "FREEFORM", ())
        if freeform:
            return "map (free form)"
        members = self.members(kind)
        if len(members) > 1:
            return "one tagged entry: " + ", ".join(f"``!{m.__name__}``" for m in members)
        origin, args = typing.get_origin(kind), typing.get_args(kind)
        if origin is dict:
            values = self.members(args[1])
            return "map: name → tagged entry" if values else "map"
        if origin is list:
            item = args[0]
            if dataclasses.is_dataclass(item):
                return "list of maps"
            return f"list of {self.type_text(cls, '', item).replace('list of ', 'lists of ')}"
        if args and type(None) in args:
            rest = [a for a in args if a is not type(None)]
            return f"{self.type_text(cls, '', rest[0])} or null"
        names = {float: "float", int: "int", str: "string", bool: "bool"}
        if kind in names:
            return names[kind]
        if dataclasses.is_dataclass(kind) or hasattr(kind, "__fields__"):
            return "map"
        return str(kind)

    def value_text(self, cls: type, value: object) -> str:
        if value is None:
            return "(from the arm)" if hasattr(cls, "with_arm_defaults") else "null"
        if dataclasses.is_dataclass(value):
            return f"``!{type(value).__name__}``"
        if hasattr(type(value), "__fields__"):  # a Drake config: its keys follow
            return "(its keys below)"
        if isinstance(value, dict) and not value:
            return "``{}``"
        if isinstance(value, list) and value and dataclasses.is_dataclass(value[0]):
            return f"{len(value)} entries (the paper's)"
        if isinstance(value, str) and not value:
            return "``''``"
        import yaml

        text = yaml.safe_dump(value, default_flow_style=True, width=10**6).strip()
        text = text.removesuffix("...").strip()
        if len(text) > 60:
            text = text[:57] + "..."
        return f"``{text}``"

    # walking -------------------------------------------------------------------------

    def entry(
        self, cls: type, value: object, title: str, label: str, intro: list[str], prefix: str
    ) -> Entry:
        """The section of dataclass ``cls`` (its rows, flattening nested plain sections,
        and one child section per member of each union field)."""
        self._note(cls)
        doc = _flat(cls.__doc__)
        registered = self.registries.get(cls)
        if registered:
            what, spec = registered
            intro = [*intro, f"Registered {what} ``{spec.kind}``: {_escape(spec.label)}."]
        if doc:
            intro = [*intro, _escape(doc)]
        result = Entry(title, label, intro, [], [])
        self._rows(cls, value, prefix, result, label)
        return result

    def _rows(self, cls: type, value: object, prefix: str, entry: Entry, label: str) -> None:
        aliases = {v: k for k, v in getattr(cls, "ALIASES", {}).items()}
        for name, kind in self.hints(cls).items():
            yaml_name = aliases.get(name, name)
            key = f"{prefix}{yaml_name}"
            current = getattr(value, name)
            doc, unit = self.field_doc(cls, name, yaml_name)
            members = self.members(kind)
            origin = typing.get_origin(kind)
            if origin is dict:
                members = self.members(typing.get_args(kind)[1])
            entry.rows.append(
                Row(
                    key,
                    self.type_text(cls, name, kind),
                    self.value_text(cls, current),
                    unit,
                    _escape(doc),
                )  # fmt: skip
            )
            if len(members) > 1 and origin is not dict:
                for member in members:
                    default = current if type(current) is member else member()
                    tag = f"!{member.__name__}"
                    entry.children.append(
                        self.entry(
                            member,
                            default,
                            f"``{key}: {tag}``",
                            f"scenario-{key.replace('.', '-')}-{member.__name__}".lower(),
                            [],
                            f"{key}.",
                        )  # fmt: skip
                    )
            elif origin is list and dataclasses.is_dataclass(typing.get_args(kind)[0]):
                item = typing.get_args(kind)[0]
                self._note(item)
                first = current[0] if current else item()
                self._rows(item, first, f"{key}[i].", entry, label)
            elif dataclasses.is_dataclass(kind):
                self._note(kind)
                self._rows(kind, current, f"{key}.", entry, label)
            elif hasattr(kind, "__fields__") and not isinstance(current, (int, float, str)):
                self._rows(kind, current, f"{key}.", entry, label)


def scenario_entries() -> tuple[list[Entry], set[str]]:
    """One entry per top-level key of the scenario, and the files that define them."""
    from posfb.diagrams.scenario import Scenario

    walker = Walker()
    walker._note(Scenario)
    scenario = Scenario()
    entries = []
    for name, kind in walker.hints(Scenario).items():
        current = getattr(scenario, name)
        doc, _ = walker.field_doc(Scenario, name, name)
        intro = [_escape(doc)] if doc else []
        label = f"scenario-{name}".replace("_", "-")
        members = walker.members(kind)
        if typing.get_origin(kind) is dict:
            members = walker.members(typing.get_args(kind)[1])
            intro.append(
                "A map of named entries, each written as one entry of ``controller`` "
                f"(one of {', '.join(f'``!{m.__name__}``' for m in members)}; see "
                ":ref:`scenario-controller`). Default ``{}``."
            )
            entries.append(Entry(f"``{name}``", label, intro, [], []))
            continue
        if members:
            default = f"``!{type(current).__name__}``"
            intro.append(
                f"One tagged entry, one of {', '.join(f'``!{m.__name__}``' for m in members)} "
                f"(default {default}; an untagged map is ``!{members[0].__name__}``)."
            )
            section = Entry(f"``{name}``", label, intro, [], [])
            for member in members:
                value = current if type(current) is member else member()
                section.children.append(
                    walker.entry(
                        member,
                        value,
                        f"``{name}: !{member.__name__}``",
                        f"{label}-{member.__name__}".lower(),
                        [],
                        f"{name}.",
                    )  # fmt: skip
                )
            entries.append(section)
            continue
        entries.append(walker.entry(kind, current, f"``{name}``", label, intro, f"{name}."))
    return entries, walker.files


# --- reST -----------------------------------------------------------------------------

_UNDERLINES = "-~^'"


def _rst(entry: Entry, depth: int = 0) -> Iterator[str]:
    title = entry.title
    yield f".. _{entry.label}:"
    yield ""
    yield title
    yield _UNDERLINES[min(depth, len(_UNDERLINES) - 1)] * max(len(title), 4)
    yield ""
    for paragraph in entry.intro:
        yield paragraph
        yield ""
    for row in entry.rows:
        facts = [f"type: {row.kind}", f"default: {row.default}"]
        if row.unit:
            facts.append(f"unit: {_escape(row.unit)}")
        yield f"``{row.key}``"
        yield f"   {'; '.join(facts)}"
        if row.doc:
            yield ""
            yield f"   {_cell(row.doc)}"
        yield ""
    for child in entry.children:
        yield from _rst(child, depth + 1)


class ScenarioReference(SphinxDirective):
    """``.. scenario-reference::``: the generated reference of every scenario key."""

    has_content = False

    def run(self) -> list:
        entries, files = scenario_entries()
        for path in sorted({*files, __file__}):
            self.env.note_dependency(str(Path(path).resolve()))
        lines = [line for entry in entries for line in _rst(entry)]
        container = nodes.section()
        nested_parse_with_titles(self.state, StringList(lines, source="scenario-reference"),
                                 container)  # fmt: skip
        return container.children


def setup(app: Sphinx) -> dict:
    app.add_directive("scenario-reference", ScenarioReference)
    return {"version": "1", "parallel_read_safe": True, "parallel_write_safe": True}
