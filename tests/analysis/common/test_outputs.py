"""Every ``--out`` (issue 27, item 11): an existing file, or the command's own input, is
refused before the work without ``--force`` and left byte for byte; with ``--force`` it is
replaced. Files are written atomically and folders staged (``analysis.common.outputs``): a write
that the disk refuses half-way (a real full disk: a tmpfs, or a file-size limit) leaves
the old file, or the old folder, as it was, and no partial file or folder beside it."""

from __future__ import annotations

import hashlib
from pathlib import Path

import pytest

from helpers.montecarlo_helpers import TINY_STUDY, SmallDisk, run_into_store
from helpers.output_checks import read_only_folder, tree_digest
from helpers.paths import REPO
from posfb.analysis.cli import main
from posfb.analysis.common.errors import EXIT_DISK_FULL, UsageError
from posfb.analysis.common.outputs import atomic_file, output_file, staged_folder
from posfb.models.plant import DEFAULT_URDF

SCENARIOS = REPO / "analysis" / "scenarios"
NOMINAL = str(SCENARIOS / "paper_nominal.yaml")
THREE_LINK_URDF = str(DEFAULT_URDF.parent / "three_link_arm.urdf")

#: ``posfb tune`` settings small enough for a few seconds' search.
SMALL_TUNE = ("--plants", "2", "--generations", "2", "--epsilon", "0.5", "--beta", "0.5",
              "--rounds", "1")  # fmt: skip

#: Bytes an earlier run left in a file: never a valid output of any command.
OLD = b"# written by an earlier run\n" * 8


@pytest.fixture()
def disk(tmp_path):
    disk = SmallDisk(tmp_path / "disk")
    yield disk
    disk.close()


@pytest.fixture(scope="module")
def store(tmp_path_factory) -> Path:
    """A one-sample Monte-Carlo store (the real closed loop), for ``montecarlo export``."""
    one = TINY_STUDY.replace("samples: 4", "samples: 1").replace("duration: 1.0", "duration: 0.2")
    return run_into_store(tmp_path_factory.mktemp("store") / "s.sqlite", one)


def _digest(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def _one_line(text: str) -> str:
    lines = text.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in text, text
    return lines[0]


# --- the checks, as a function ------------------------------------------------------------


def test_output_file_refuses_an_existing_file_and_the_input_unless_forced(tmp_path, monkeypatch):
    taken = tmp_path / "taken.yaml"
    taken.write_bytes(OLD)
    with pytest.raises(UsageError, match=r"^--out .*taken.yaml exists; .*--force"):
        output_file("--out", str(taken))
    assert output_file("--out", str(taken), force=True) == taken
    # The input named another way (relative, through a link) is still the input.
    link = tmp_path / "link.yaml"
    link.symlink_to(taken)
    monkeypatch.chdir(tmp_path)
    for spelling in ("taken.yaml", "./taken.yaml", str(link)):
        with pytest.raises(UsageError, match="is this command's own input"):
            output_file("--out", spelling, inputs=(str(taken),))
        assert output_file("--out", spelling, force=True, inputs=(str(taken),))
    # A new file beside the input is neither.
    assert output_file("--out", "new.yaml", inputs=(str(taken),)) == Path("new.yaml")
    for empty in ("", " "):
        with pytest.raises(UsageError, match="a file name is required"):
            output_file("--out", empty)
    assert taken.read_bytes() == OLD


def test_a_staged_folder_replaces_only_its_own_files_and_leaves_nothing_on_failure(tmp_path):
    target = tmp_path / "results"
    target.mkdir()
    (target / "kept.md").write_bytes(OLD)
    (target / "table.md").write_bytes(OLD)
    with staged_folder(target) as staged:
        (staged.path / "table.md").write_text("new\n")
        (staged.path / "figures").mkdir()
        (staged.path / "figures" / "a.svg").write_text("<svg/>\n")
        assert not (target / "figures").exists()  # nothing moves before the end
    assert staged.final([staged.path / "figures" / "a.svg"]) == [target / "figures" / "a.svg"]
    assert (target / "table.md").read_text() == "new\n" and (target / "kept.md").read_bytes() == OLD
    assert (target / "figures" / "a.svg").read_text() == "<svg/>\n"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["results"]  # the staging is gone
    before = tree_digest(target)
    for failure in (KeyboardInterrupt, OSError):
        with pytest.raises(failure), staged_folder(target) as staged:
            (staged.path / "table.md").write_text("half")
            raise failure()
        assert tree_digest(target) == before
        with pytest.raises(failure), staged_folder(tmp_path / "fresh" / "out") as staged:
            (staged.path / "x.md").write_text("half")
            raise failure()
        assert sorted(p.name for p in tmp_path.iterdir()) == ["results"]  # no partial folder


def test_an_interrupted_atomic_write_keeps_the_old_file(tmp_path):
    path = tmp_path / "t.yaml"
    path.write_bytes(OLD)
    path.chmod(0o640)
    with pytest.raises(KeyboardInterrupt), atomic_file(path) as temporary:
        temporary.write_text("half")
        raise KeyboardInterrupt
    assert path.read_bytes() == OLD and sorted(tmp_path.iterdir()) == [path]
    with atomic_file(path) as temporary:
        assert temporary.parent == path.parent and temporary.suffix == ".yaml"
        temporary.write_text("new\n")
    assert path.read_text() == "new\n" and (path.stat().st_mode & 0o777) == 0o640
    assert sorted(tmp_path.iterdir()) == [path]


# --- every file --out: refused when it exists, replaced with --force ------------------------

#: Per command: its arguments before ``--out`` and the suffix of its file.
FILE_COMMANDS = {
    "simulate": (("simulate", "--duration", "0.2", "--controller", "pid", "--no-progress"),
                 ".csv"),
    "graph": (("graph", "--controller", "pid"), ".svg"),
    "animate": (("animate", "--duration", "0.2", "--controller", "pid", "--no-progress"),
                ".html"),
    "tune": (("tune", NOMINAL, *SMALL_TUNE), ".yaml"),
    "montecarlo export": (("montecarlo", "export", "--db", "{store}"), ".csv"),
}  # fmt: skip


@pytest.mark.slow
@pytest.mark.parametrize("command", list(FILE_COMMANDS))
def test_an_existing_out_is_refused_without_force_and_replaced_with_it(
    command, tmp_path, capsys, store
):
    head, suffix = FILE_COMMANDS[command]
    args = [arg.replace("{store}", str(store)) for arg in head]
    out = tmp_path / f"out{suffix}"
    out.write_bytes(OLD)
    assert main([*args, "--out", str(out)]) == 2
    line = _one_line(capsys.readouterr().err)
    assert f"--out {out} exists" in line and "--force" in line
    assert out.read_bytes() == OLD
    assert main([*args, "--out", str(out), "--force"]) == 0
    assert out.read_bytes() != OLD and out.stat().st_size > 100
    assert sorted(tmp_path.iterdir()) == [out]  # no temporary left beside it


@pytest.mark.slow
def test_tune_refuses_its_own_input_and_replaces_it_only_with_force(tmp_path, capsys, monkeypatch):
    scenario = tmp_path / "arm.yaml"
    scenario.write_text(Path(NOMINAL).read_text())
    before = _digest(scenario)
    monkeypatch.chdir(tmp_path)
    for spelling in (str(scenario), "arm.yaml", "./arm.yaml"):
        assert main(["tune", "arm.yaml", *SMALL_TUNE, "--out", spelling]) == 2
        line = _one_line(capsys.readouterr().err)
        assert "is this command's own input" in line and "--force" in line
        assert _digest(scenario) == before
    assert main(["tune", "arm.yaml", *SMALL_TUNE, "--out", "arm.yaml", "--force"]) == 0
    assert _digest(scenario) != before and "# posfb tune" in scenario.read_text()


def test_compare_with_an_empty_controller_list_is_refused(capsys, tmp_path):
    assert main(["compare", "--controllers", "", "--out", str(tmp_path / "cmp")]) == 2
    assert "--controllers ''" in _one_line(capsys.readouterr().err)
    assert not (tmp_path / "cmp").exists()


# --- a real full disk ----------------------------------------------------------------------


@pytest.mark.slow  # over 10 s on 2 cores (issue 45, item 4)
def test_a_tuned_file_is_kept_whole_when_the_disk_fills(tmp_path, disk):
    """The issue's case: a full disk truncated an existing tuned file to partial YAML."""
    out = disk.folder / "tuned.yaml"
    out.write_bytes(OLD)
    disk.fill()
    result = disk.run(["tune", NOMINAL, *SMALL_TUNE, "--out", str(out), "--force"], tmp_path)
    assert out.read_bytes() == OLD, result.stderr
    assert {p.name for p in disk.folder.iterdir()} - {"filler"} == {"tuned.yaml"}
    line = _one_line(result.stderr)
    assert result.returncode == EXIT_DISK_FULL and str(out) in line, result.stderr


@pytest.mark.slow
@pytest.mark.parametrize("command", ["compare", "design --map"])
def test_a_folder_is_left_as_it_was_when_the_disk_fills(command, tmp_path, disk):
    args = {
        "compare": ["compare", "--duration", "0.2", "--controllers", "pid,lin_lc", "--no-progress"],
        "design --map": ["design", "--map", "--map-points", "3", "--plants", "2"],
    }[command]
    old = disk.folder / "old"
    old.mkdir()
    for name in ("comparison.md", "stability_map.json", "mine.txt"):
        (old / name).write_bytes(OLD)
    before = tree_digest(old)
    disk.fill()
    results = [disk.run([*args, "--out", str(out)], tmp_path) for out in (old, disk.folder / "new")]
    assert tree_digest(old) == before  # no file of the old folder replaced or truncated
    left = {p.name for p in disk.folder.iterdir()} - {"filler"}
    assert left == {"old"}, left  # no partial folder, no staging folder
    for result in results:
        assert result.returncode == EXIT_DISK_FULL and "Traceback" not in result.stderr


def test_scenario_init_refuses_an_unwritable_out_before_the_work(tmp_path, capsys):
    with read_only_folder(tmp_path / "ro") as folder:
        out = folder / "arm.yaml"
        assert main(["scenario", "init", "--urdf", THREE_LINK_URDF, "--out", str(out)]) == 2
        line = _one_line(capsys.readouterr().err)
        assert f"--out {out}" in line and "is not writable" in line
        assert not list(folder.iterdir())


@pytest.mark.slow
def test_scenario_init_on_a_full_disk_leaves_nothing_behind(tmp_path, disk):
    disk.fill()
    out = disk.folder / "arm.yaml"
    result = disk.run(["scenario", "init", "--urdf", THREE_LINK_URDF, "--out", str(out)], tmp_path)
    assert {p.name for p in disk.folder.iterdir()} <= {"filler"}  # no .arm.yaml.init
    line = _one_line(result.stderr)
    assert result.returncode == EXIT_DISK_FULL and str(out) in line, result.stderr
