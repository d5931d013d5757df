"""``analysis.common.side_by_side``: calls in processes of their own, their results and
their errors in the order of a loop that makes them one after the other."""

from __future__ import annotations

import os
import time

import pytest

from posfb.analysis.common.side_by_side import Call, beside, side_by_side, start_forkserver


def _square(value: int, say) -> int:
    say(f"squaring {value}")
    return value * value


def _fail_after(seconds: float, text: str, say) -> None:
    time.sleep(seconds)
    raise ValueError(text)


def _exit_without_result(say) -> None:
    os._exit(3)


class _UnpicklableError(Exception):
    def __init__(self, first: str, second: str) -> None:  # pickle passes one argument
        super().__init__(f"{first} {second}")


def _raise_unpicklable(say) -> None:
    raise _UnpicklableError("cannot", "travel")


def test_results_and_lines_come_back_in_the_calls_order():
    lines: list[str] = []
    calls = [Call(f"square {v}", _square, (v,)) for v in (2, 3, 4)]
    assert side_by_side(calls, workers=2, say=lines.append) == [4, 9, 16]
    assert sorted(lines) == ["squaring 2", "squaring 3", "squaring 4"]


def test_the_first_failing_call_in_order_raises_as_a_loop_would():
    # The second call fails at once, the first a moment later: a loop would have raised
    # the first's error, and so does the side-by-side run.
    calls = [Call("slow", _fail_after, (1.0, "first")), Call("fast", _fail_after, (0.0, "second"))]
    with pytest.raises(ValueError, match="^first$"):
        side_by_side(calls, workers=2)
    # a call after the failing one is not waited for
    calls = [Call("fails", _fail_after, (0.0, "early")), Call("sleeps", _fail_after, (60.0, "x"))]
    began = time.monotonic()
    with pytest.raises(ValueError, match="^early$"):
        side_by_side(calls, workers=2)
    assert time.monotonic() - began < 30.0


def test_a_process_that_dies_and_an_error_that_cannot_travel_are_named():
    with pytest.raises(RuntimeError, match=r"the process of killed ended \(exit code 3\)"):
        side_by_side([Call("killed", _exit_without_result, ())], workers=1)
    with pytest.raises(RuntimeError, match="_UnpicklableError: cannot travel"):
        side_by_side([Call("odd error", _raise_unpicklable, ())], workers=1)


@pytest.mark.parametrize("workers", [0, -1, 1.5, None])
def test_workers_must_be_a_positive_integer(workers):
    with pytest.raises(ValueError, match=rf"workers = {workers!r}; an integer >= 1 is required"):
        side_by_side([Call("square", _square, (1,))], workers=workers)


def test_beside_hands_back_the_results_or_the_error_when_asked():
    start_forkserver([])  # the first call then forks at once; nothing else changes
    pending = beside([Call(f"square {v}", _square, (v,)) for v in (5, 6)], workers=2)
    assert pending() == [25, 36]
    failing = beside([Call("fails", _fail_after, (0.0, "late"))], workers=1)
    with pytest.raises(ValueError, match="^late$"):
        failing()
