"""The on-disk cache (``models.disk_cache``) and the Assumption-1 bounds it keeps: a
design computes them only when read (the paper's controller), and an unchanged arm
reads them back instead of searching its workspace again (issue 27)."""

from __future__ import annotations

import hashlib
import json
import logging
import os
import stat
from pathlib import Path

import pytest

from helpers.paths import REPO
from posfb.diagrams.resolve import load_scenario, resolve
from posfb.models.design import bounds as bounds_module
from posfb.models.design.bounds import resolve_bounds
from posfb.models.design.config import UncertaintyBounds
from posfb.models.design.synthesis import compute_design
from posfb.models.disk_cache import CACHE_ENV, HASH_PREFIX, cached_floats
from posfb.models.nominal import UrdfNominal
from posfb.models.plant import DEFAULT_URDF
from posfb.models.serial_bounds import model_norms
from posfb.models.serial_model import SerialArmModel

THREE_LINK = DEFAULT_URDF.with_name("three_link_arm.urdf")
THREE_LINK_SCENARIO = REPO / "analysis/scenarios/three_link_nominal.yaml"


@pytest.fixture()
def cache(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    """An empty cache folder of this test's own."""
    monkeypatch.setenv(CACHE_ENV, str(tmp_path / "cache"))
    return tmp_path / "cache"


def counted(values: dict[str, float]):
    """A ``compute`` callable returning ``values`` and the list that counts its calls."""
    calls: list[int] = []

    def compute() -> dict[str, float]:
        calls.append(1)
        return values

    return compute, calls


def test_an_entry_is_computed_once_per_key(cache: Path) -> None:
    compute, calls = counted({"a": 1.5})
    assert cached_floats("kind", {"x": 1}, compute) == {"a": 1.5}
    assert cached_floats("kind", {"x": 1}, compute) == {"a": 1.5}
    assert len(calls) == 1
    cached_floats("kind", {"x": 2}, compute)
    assert len(calls) == 2
    assert len(list((cache / "kind").glob("*.entry"))) == 2


def payload(entry: Path) -> bytes:
    """The entry's payload after its hash line (``models.disk_cache``)."""
    return entry.read_bytes().partition(b"\n")[2]


def with_hash(data: bytes) -> bytes:
    """``data`` as an entry whose hash line matches it."""
    return HASH_PREFIX + hashlib.sha256(data).hexdigest().encode() + b"\n" + data


def test_a_damaged_or_edited_entry_is_recomputed_and_replaced(cache: Path) -> None:
    """Issue 43: an entry whose bytes are not those it was written with (truncated, edited
    as the numbers of a design's bounds scaled by 1e-6, not JSON) is never used."""
    compute, calls = counted({"a": 2.0})
    cached_floats("kind", {"x": 1}, compute)
    (entry,) = (cache / "kind").glob("*.entry")
    written = entry.read_bytes()
    damages = [
        written[: len(written) // 2],  # truncated
        written.replace(payload(entry), json.dumps({"a": 2e-6}).encode()),  # edited
        b"",
        with_hash(b"{not json"),  # whole, but not what a cache entry holds
        with_hash(json.dumps({"a": "text"}).encode()),
        with_hash(json.dumps([1.0]).encode()),
    ]
    for damage in damages:
        entry.write_bytes(damage)
        assert cached_floats("kind", {"x": 1}, compute) == {"a": 2.0}
    assert len(calls) == 1 + len(damages)
    assert json.loads(payload(entry)) == {"a": 2.0}


def test_the_cache_folders_are_created_private(cache: Path) -> None:
    cached_floats("kind", {"x": 1}, counted({"a": 1.0})[0])
    for folder in (cache, cache / "kind"):
        assert stat.S_IMODE(folder.stat().st_mode) == 0o700


def refused(cache: Path, caplog: pytest.LogCaptureFixture, why: str) -> None:
    """The cache at ``cache`` is not used: each call computes, nothing is read or written
    there, and one warning line names the folder and ``why``."""
    (cache / "kind").mkdir(exist_ok=True)
    before = {p.name: p.read_bytes() for p in (cache / "kind").iterdir()}
    compute, calls = counted({"a": 4.0})
    with caplog.at_level(logging.WARNING, logger="posfb"):
        for _ in range(2):
            assert cached_floats("kind", {"x": 1}, compute) == {"a": 4.0}
    assert len(calls) == 2
    assert {p.name: p.read_bytes() for p in (cache / "kind").iterdir()} == before
    lines = [r.getMessage() for r in caplog.records if "cache folder" in r.getMessage()]
    assert len(lines) == 1 and str(cache) in lines[0] and why in lines[0], lines


def test_a_cache_others_may_write_to_is_not_used(cache: Path, caplog) -> None:
    """Issue 43: a world-writable cache (a shared ``POSFB_CACHE_DIR``) could hold anyone's
    entries; an entry planted there with the right key is not read."""
    compute, _ = counted({"a": 4.0})
    cached_floats("kind", {"x": 1}, compute)
    (entry,) = (cache / "kind").glob("*.entry")
    entry.write_bytes(with_hash(json.dumps({"a": 4e-6}).encode()))  # a consistent plant
    cache.chmod(0o777)
    try:
        refused(cache, caplog, "may be written by others (mode 777)")
    finally:
        cache.chmod(0o700)


@pytest.mark.skipif(not hasattr(os, "geteuid") or os.geteuid() != 0,
                    reason="making a folder another user's needs root")  # fmt: skip
def test_a_cache_of_another_user_is_not_used(cache: Path, caplog) -> None:
    cache.mkdir(mode=0o700)
    os.chown(cache, 65534, 65534)  # nobody
    refused(cache, caplog, "belongs to another user (uid 65534)")


def test_off_and_unwritable_caches_still_answer(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    compute, calls = counted({"a": 3.0})
    monkeypatch.setenv(CACHE_ENV, "off")
    assert cached_floats("kind", {"x": 1}, compute) == {"a": 3.0}
    assert cached_floats("kind", {"x": 1}, compute) == {"a": 3.0}
    assert len(calls) == 2
    blocker = tmp_path / "a_file"
    blocker.write_text("a file where the cache folder should be")
    monkeypatch.setenv(CACHE_ENV, str(blocker))
    assert cached_floats("kind", {"x": 1}, compute) == {"a": 3.0}


def test_cached_bounds_equal_the_search_and_skip_it(
    cache: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The bounds read back from the cache equal the workspace search's own numbers
    (``model_norms`` called directly); the second resolve does not search."""
    nominal = UrdfNominal(str(THREE_LINK))
    searched = model_norms(SerialArmModel(THREE_LINK))
    resolve_bounds.cache_clear()
    first = resolve_bounds(UncertaintyBounds(), nominal)
    resolve_bounds.cache_clear()

    def no_search(*_args: object, **_kwargs: object) -> dict[str, float]:
        raise AssertionError("the workspace search ran although the cache holds its result")

    monkeypatch.setattr(bounds_module, "model_norms", no_search)
    second = resolve_bounds(UncertaintyBounds(), nominal)
    resolve_bounds.cache_clear()
    assert first == second
    relative = UncertaintyBounds().relative
    assert second.delta_M1 == pytest.approx(relative * searched["delta_M1"], rel=1e-15)
    assert second.delta_G == pytest.approx(relative * searched["delta_G"], rel=1e-15)
    assert second.k_C1 == pytest.approx(searched["delta_C"], rel=1e-15)


def test_a_changed_urdf_is_searched_again(cache: Path, tmp_path: Path) -> None:
    """The cache key is the file's content, not its name: a copy of the arm reads the
    entry back, the arm with a heavier link is a new entry, with other bounds."""
    text = THREE_LINK.read_text()
    heavier = text.replace('<mass value="', '<mass value="2', 1)
    assert heavier != text
    (tmp_path / "copy.urdf").write_text(text)
    (tmp_path / "heavier.urdf").write_text(heavier)
    resolve_bounds.cache_clear()
    before = resolve_bounds(UncertaintyBounds(), UrdfNominal(str(THREE_LINK)))
    copy = resolve_bounds(UncertaintyBounds(), UrdfNominal(str(tmp_path / "copy.urdf")))
    assert len(list((cache / "model_norms").glob("*.entry"))) == 1
    assert copy == before
    after = resolve_bounds(UncertaintyBounds(), UrdfNominal(str(tmp_path / "heavier.urdf")))
    resolve_bounds.cache_clear()
    assert len(list((cache / "model_norms").glob("*.entry"))) == 2
    assert after.delta_G != before.delta_G


@pytest.mark.slow
def test_a_design_resolves_its_bounds_only_when_read(
    cache: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Lin+LC, PID and plug-ins use a design without its bounds: computing one runs no
    workspace search; reading ``bounds`` (the proposed controller's Eq. 18) does."""
    calls: list[int] = []
    search = bounds_module.model_norms

    def counting(*args: object, **kwargs: object) -> dict[str, float]:
        calls.append(1)
        return search(*args, **kwargs)

    monkeypatch.setattr(bounds_module, "model_norms", counting)
    resolve_bounds.cache_clear()
    design = compute_design(resolve(load_scenario(THREE_LINK_SCENARIO)).config.design)
    assert calls == []
    assert design.bounds.delta_G > 0.0
    assert calls == [1]
    resolve_bounds.cache_clear()
