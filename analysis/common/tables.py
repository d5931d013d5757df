"""Markdown tables: simulated RMS values beside the paper's Tables 3 and 4.

The paper's numbers are hardware measurements (Sec. 4.2-4.3); a simulation is
compared on orderings and ratios, not digit by digit (reading note 11).
"""

from __future__ import annotations

from collections.abc import Mapping

from posfb.models.controllers import PAPER_BASELINE, PAPER_CONTROLLERS, spec
from posfb.models.lumped import TABLE1, LumpedParameters

#: ``{controller: (RMS(q~1), RMS(q~2), RMS(u1), RMS(u2))}``: Table 3 (nominal), rows in
#: ``PAPER_CONTROLLERS`` order (PID, Lin+LC, the paper's).
PAPER_TABLE3 = dict(zip(PAPER_CONTROLLERS, (
    (0.0026, 0.0060, 4.6392, 2.8659),
    (0.0037, 0.0059, 4.5017, 2.8639),
    (0.0021, 0.0032, 4.5251, 2.8373),
), strict=True))  # fmt: skip

#: Table 4 (0.288 kg payload), same layout.
PAPER_TABLE4 = dict(zip(PAPER_CONTROLLERS, (
    (0.0028, 0.0076, 4.6457, 3.3094),
    (0.0045, 0.0129, 4.5621, 3.2736),
    (0.0025, 0.0058, 4.6574, 3.4224),
), strict=True))  # fmt: skip

#: The paper's table of each case.
PAPER_TABLES = {"nominal": PAPER_TABLE3, "payload": PAPER_TABLE4}

#: Column headers of the four figures of merit.
COLUMNS = ("RMS(q~1) rad", "RMS(q~2) rad", "RMS(u1) V", "RMS(u2) V")


def row_values(entry: Mapping[str, object]) -> tuple[float, float, float, float]:
    """``(rms_q1, rms_q2, rms_u1, rms_u2)`` of a ``results.json`` run entry."""
    q, u = entry["rms_q"], entry["rms_u"]
    return (q[0], q[1], u[0], u[1])


def _number(value: float | None, digits: int) -> str:
    return "n/a" if value is None else f"{value:.{digits}f}"


def side_by_side(
    simulated: Mapping[str, Mapping[str, object]],
    paper: Mapping[str, tuple[float, float, float, float]],
) -> str:
    """One row per controller: each figure of merit simulated | paper."""
    header = "| controller | " + " | ".join(f"{c} sim | paper" for c in COLUMNS) + " |"
    lines = [header, "|---|" + "---:|---:|" * len(COLUMNS)]
    for kind in PAPER_CONTROLLERS:
        if kind not in simulated:
            continue
        entry = simulated[kind]
        values = row_values(entry)
        cells = []
        for i, value in enumerate(values):
            cells += [_number(value, 5 if i < 2 else 3), f"{paper[kind][i]:.4f}"]
        status = "" if entry.get("status", "ok") == "ok" else f" ({entry['status']})"
        lines.append(f"| {spec(kind).label}{status} | " + " | ".join(cells) + " |")
    return "\n".join(lines)


def ratios(
    simulated: Mapping[str, Mapping[str, object]],
    paper: Mapping[str, tuple[float, float, float, float]],
    reference: str = PAPER_BASELINE,
) -> str:
    """Each controller's RMS errors relative to ``reference``'s, simulated | paper."""
    lines = [
        f"| controller | RMS(q~1) / {reference} sim | paper | RMS(q~2) / {reference} sim | paper |",
        "|---|---:|---:|---:|---:|",
    ]
    base = row_values(simulated[reference])
    for kind in PAPER_CONTROLLERS:
        if kind not in simulated:
            continue
        values = row_values(simulated[kind])
        cells = []
        for j in range(2):
            cells += [f"{values[j] / base[j]:.2f}", f"{paper[kind][j] / paper[reference][j]:.2f}"]
        lines.append(f"| {spec(kind).label} | " + " | ".join(cells) + " |")
    return "\n".join(lines)


def ranking(values: Mapping[str, float]) -> str:
    """Controllers from smallest to largest value, e.g. ``proposed < lin_lc < pid``."""
    return " < ".join(kind for kind, _ in sorted(values.items(), key=lambda item: item[1]))


def theta_table(
    identified: Mapping[str, LumpedParameters], reference: LumpedParameters = TABLE1
) -> str:
    """theta_1..theta_11 identified from one or more plants (columns, e.g.
    ``{"nominal": .., "payload": ..}``) beside Table 1, with relative differences."""
    header = "| parameter | Table 1 | " + " | ".join(
        f"{label} | difference" for label in identified
    )
    lines = [header + " |", "|---|---:|" + "---:|---:|" * len(identified)]
    for i in range(1, 12):
        name = f"theta{i}"
        paper = getattr(reference, name)
        cells = [
            f"{getattr(theta, name):.6g} | {100 * (getattr(theta, name) / paper - 1):+.2f} %"
            for theta in identified.values()
        ]
        lines.append(f"| {name} | {paper:.6g} | " + " | ".join(cells) + " |")
    cells = [f"{theta.l1:.6g} | " for theta in identified.values()]
    lines.append("| l1 (m) | (not printed) | " + " | ".join(cells) + " |")
    return "\n".join(lines)
