"""``analysis.common.tables``: the side-by-side Markdown tables."""

from __future__ import annotations

from posfb.analysis.common.tables import PAPER_TABLE3, ranking, ratios, side_by_side


def _entry(q1, q2, u1, u2):
    return {"rms_q": [q1, q2], "rms_u": [u1, u2], "status": "ok"}


def test_side_by_side_lists_simulated_and_paper_values():
    runs = {"pid": _entry(0.001, 0.002, 4.5, 3.0), "proposed": _entry(0.0005, 0.001, 4.4, 2.9)}
    text = side_by_side(runs, PAPER_TABLE3)
    assert text.count("\n") == 3  # header, rule, two rows
    assert "| computed torque + PID | 0.00100 | 0.0026 | 0.00200 | 0.0060 |" in text
    assert "Lin + LC + NC (paper)" in text and "Lin + LC |" not in text


def test_side_by_side_names_a_run_that_is_not_ok_by_its_status():
    runs = {"pid": _entry(0.001, 0.002, 4.5, 3.0), "proposed": _entry(0.4, 0.1, 23.0, 4.0)}
    for status in ("saturated", "lost", "diverged"):
        runs["proposed"]["status"] = status
        rows = side_by_side(runs, PAPER_TABLE3).splitlines()[2:]
        assert rows[1].startswith(f"| Lin + LC + NC (paper) ({status}) |")
        assert f"({status})" not in rows[0]


def test_ratios_and_ranking():
    runs = {"pid": _entry(0.002, 0.004, 1, 1), "lin_lc": _entry(0.001, 0.008, 1, 1)}
    text = ratios(runs, PAPER_TABLE3)
    assert "| Lin + LC | 0.50 | 1.42 | 2.00 | 0.98 |" in text
    assert ranking({"pid": 2.0, "lin_lc": 1.0, "proposed": 3.0}) == "lin_lc < pid < proposed"
