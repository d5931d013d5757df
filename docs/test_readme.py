"""The README's Python example runs (it is the front page's promise)."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

README = Path(__file__).resolve().parents[1] / "README.md"


def test_the_readme_python_example_runs(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    blocks = re.findall(r"```python\n(.*?)```", README.read_text(), re.DOTALL)
    assert blocks, "the README has a Python example"
    monkeypatch.chdir(tmp_path)  # a block may write files
    for block in blocks:
        exec(compile(block, str(README), "exec"), {"__name__": "readme"})
