"""The on-disk cache (``models.disk_cache``) and the Assumption-1 bounds it keeps: a
design computes them only when read (the paper's controller), and an unchanged arm
reads them back instead of searching its workspace again (issue 27)."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from posfb.diagrams.resolve import load_scenario, resolve
from posfb.models.design import bounds as bounds_module
from posfb.models.design.bounds import resolve_bounds
from posfb.models.design.config import UncertaintyBounds
from posfb.models.design.synthesis import compute_design
from posfb.models.disk_cache import CACHE_ENV, cached_floats
from posfb.models.nominal import UrdfNominal
from posfb.models.plant import DEFAULT_URDF
from posfb.models.serial_bounds import model_norms
from posfb.models.serial_model import SerialArmModel

THREE_LINK = DEFAULT_URDF.with_name("three_link_arm.urdf")
THREE_LINK_SCENARIO = (
    Path(__file__).resolve().parent.parent / "analysis/scenarios/three_link_nominal.yaml"
)


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
    assert len(list((cache / "kind").glob("*.json"))) == 2


def test_a_damaged_entry_is_recomputed_and_replaced(cache: Path) -> None:
    compute, calls = counted({"a": 2.0})
    cached_floats("kind", {"x": 1}, compute)
    (entry,) = (cache / "kind").glob("*.json")
    for damage in ("{not json", json.dumps({"a": "text"}), json.dumps([1.0])):
        entry.write_text(damage)
        assert cached_floats("kind", {"x": 1}, compute) == {"a": 2.0}
    assert len(calls) == 4
    assert json.loads(entry.read_text()) == {"a": 2.0}


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
    assert len(list((cache / "model_norms").glob("*.json"))) == 1
    assert copy == before
    after = resolve_bounds(UncertaintyBounds(), UrdfNominal(str(tmp_path / "heavier.urdf")))
    resolve_bounds.cache_clear()
    assert len(list((cache / "model_norms").glob("*.json"))) == 2
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
