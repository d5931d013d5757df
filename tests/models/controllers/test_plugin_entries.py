"""A scenario's ``!Python`` entries as a user meets them: named entries of one class keep
apart in tables, choosing one by its class says which names to use, a bad ``file:`` is
named by its own key, and a ``ValueError`` in the plug-in's code is one line naming the
plug-in's file and line."""

from __future__ import annotations

from pathlib import Path

import pytest

import posfb
from helpers.plugin_helpers import P_GRAVITY, write_plugin
from posfb.models.controllers import PluginError


def _two_entries_of_one_class(folder: Path) -> str:
    """A scenario of Lin+LC with the named entries ``soft`` and ``stiff``, both of the
    class ``PGravity``, and ``pid``."""
    path = Path(write_plugin(folder))
    path.write_text(
        "controller: !LinLc {}\ntiming: {duration: 0.2}\ncontrollers:\n"
        "  soft: !Python {file: my_controller.py, class: PGravity, settings: {Kp: 5}}\n"
        "  stiff: !Python {file: my_controller.py, class: PGravity, settings: {Kp: 50}}\n"
        "  pid: !Pid {}\n"
    )
    return str(path)


def test_two_entries_of_one_class_keep_their_names_in_the_table(tmp_path):
    comparison = posfb.compare(_two_entries_of_one_class(tmp_path), ["soft", "stiff"])
    assert comparison.table()["label"].tolist() == ["soft", "stiff"]
    assert comparison.runs["soft"].rms_u != comparison.runs["stiff"].rms_u  # own settings


def test_choosing_a_named_entry_by_its_class_names_each_choice_once(tmp_path):
    path = _two_entries_of_one_class(tmp_path)
    with pytest.raises(ValueError) as refused:
        posfb.load_scenario(path, ["controller.kind=PGravity"])
    message = str(refused.value)
    names = message.split("one of ")[1].split(" is required")[0].split(", ")
    assert len(names) == len(set(names)) and {"soft", "stiff", "pid", "lin_lc"} <= set(names)
    assert "PGravity is the class of the named entries soft, stiff: choose one by its name" in (
        message
    )


@pytest.mark.parametrize(
    ("file", "needle"),
    [
        ("gone.py", "controller.file = 'gone.py': "),
        (".", "is a directory; a Python file defining the class is required"),
    ],
)
def test_a_bad_plugin_file_is_named_by_its_own_key(tmp_path, file, needle):
    path = Path(write_plugin(tmp_path))
    path.write_text(path.read_text().replace("file: my_controller.py", f"file: {file}"))
    with pytest.raises(PluginError) as refused:
        posfb.load_scenario(path)
    assert str(refused.value).startswith("controller.file = "), refused.value
    assert needle in str(refused.value)


BROADCAST = P_GRAVITY.replace(
    "return self.Kp * (desired", "return np.ones(len(q) + 1) + self.Kp * (desired"
)


def test_a_value_error_in_the_plugins_step_names_its_file_and_line(tmp_path):
    path = write_plugin(tmp_path, body=BROADCAST)
    line = next(
        number for number, text in enumerate(BROADCAST.splitlines(), start=1)
        if "np.ones(len(q) + 1)" in text
    )  # fmt: skip
    with pytest.raises(PluginError) as refused:
        posfb.simulate(path)
    message = str(refused.value)
    assert message.startswith(f"PGravity ({tmp_path / 'my_controller.py'}, line {line}): ")
    assert "ValueError: operands could not be broadcast" in message


def test_a_value_error_in_the_plugins_constructor_is_not_put_under_controller(tmp_path):
    body = P_GRAVITY.replace("super().__init__(setup)", "super().__init__(setup)\n        int('x')")
    path = write_plugin(tmp_path, body=body)
    with pytest.raises(PluginError) as refused:
        posfb.load_scenario(path)
    assert str(refused.value).startswith(f"PGravity ({tmp_path / 'my_controller.py'}, line ")
    assert "invalid literal for int()" in str(refused.value)
