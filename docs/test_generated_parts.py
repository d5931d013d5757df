"""The guide's generated parts cover what the code has: every key ``posfb scenario dump``
writes is in the scenario reference, the CLI reference's parser says every exit code, and
the gallery runs each example with options its own parser defines."""

from __future__ import annotations

import re
import sys
from pathlib import Path

import pytest
import yaml

import posfb

DOCS = Path(__file__).resolve().parent
sys.path.insert(0, str(DOCS / "_ext"))

import gallery_hooks  # noqa: E402
import scenario_reference  # noqa: E402


class _AnyTag(yaml.SafeLoader):
    """YAML with Drake's tags (``!Proposed``) read as plain maps."""


_AnyTag.add_multi_constructor("!", lambda loader, tag, node: loader.construct_mapping(node))


def _leaves(value: object, prefix: str = "") -> set[str]:
    """The dotted keys of a dumped scenario's leaves (a list of maps as ``key[i].x``; an
    empty map is a leaf)."""
    if isinstance(value, dict) and value:
        return {key for name, item in value.items() for key in _leaves(item, f"{prefix}{name}.")}
    if isinstance(value, list) and value and isinstance(value[0], dict):
        return _leaves(value[0], f"{prefix.rstrip('.')}[i].")
    return {prefix.rstrip(".")}


def _documented() -> set[str]:
    entries, _ = scenario_reference.scenario_entries()
    keys: set[str] = set()
    stack = list(entries)
    while stack:
        entry = stack.pop()
        keys |= {row.key for row in entry.rows}
        keys.add(entry.title.strip("`").split(":")[0])  # a section: ``nominal_model``
        stack += entry.children
    return keys


def _dumps() -> list[str]:
    """The dump of the default scenario, of every registered controller kind and of every
    friction law: together they write every key of every tagged entry."""
    from posfb.models import controllers, friction

    dumps = [posfb.load_scenario(set={"controller.kind": kind}).dump()
             for kind in controllers.REGISTRY]  # fmt: skip
    dumps += [posfb.load_scenario(set={"plant.friction": f"!{spec.settings.__name__} {{}}"}).dump()
              for spec in friction.REGISTRY.values()]  # fmt: skip
    return dumps


def test_every_dumped_key_is_in_the_scenario_reference() -> None:
    documented = _documented()
    for text in _dumps():
        dumped = _leaves(yaml.load(text, Loader=_AnyTag))
        # ``controllers`` is an empty map of named entries (documented as a section)
        missing = {k for k in dumped if k and k != "controllers"} - documented
        assert not missing, f"keys missing from the scenario reference: {sorted(missing)}"


def test_a_key_documented_in_its_class_docstring_gets_its_text_and_unit() -> None:
    rows = {row.key: row for row in _rows()}
    assert rows["timing.duration"].unit == "s"
    assert "whole number of periods" in rows["timing.duration"].doc
    assert rows["plant.gear_stiffness"].unit == "N m/rad"
    assert rows["plant.parameters.link_inertia"].unit == "kg m²"  # PARAMETER_UNITS


def _rows() -> list[scenario_reference.Row]:
    entries, _ = scenario_reference.scenario_entries()
    rows, stack = [], list(entries)
    while stack:
        entry = stack.pop()
        rows += entry.rows
        stack += entry.children
    return rows


@pytest.mark.parametrize("text", ["a |q~| and x_ or *y*", "`tick` [1] <b> :role:"])
def test_docstring_text_is_escaped_for_rest(text: str) -> None:
    """Markup characters outside literals are escaped, literals kept as they are."""
    escaped = scenario_reference._escape(f"{text} ``a|b``")
    assert "``a|b``" in escaped
    assert re.sub(r"\\(.)", r"\1", escaped.replace("``a|b``", "")).strip() == text


def test_the_cli_reference_says_every_exit_code() -> None:
    from posfb.analysis.cli import full_parser

    parser = full_parser()
    assert parser.prog == "posfb"
    for code in ("0 done", "1 ", "2 bad input", "3 a bug", "4 a run diverged", "5 ", "6 ",
                 "7 ", "8 ", "9 ", "130 interrupted", "143 terminated"):  # fmt: skip
        assert code in parser.epilog


def test_the_gallery_runs_every_example_with_its_own_options() -> None:
    examples = {path.stem: path for path in (DOCS.parent / "examples").glob("*.py")}
    assert set(gallery_hooks.ARGUMENTS) == set(examples)
    for name, options in gallery_hooks.ARGUMENTS.items():
        source = examples[name].read_text()
        first = source.split('"""')[1].splitlines()
        assert len(first) > 1 and set(first[1]) == {"="}, f"{name}: no reST title"
        for option in options:
            if option.startswith("--"):
                assert f'add_argument("{option}"' in source, f"{name} has no {option}"
