"""The linear verdict confirmed on the exact arm (issue 40): ``posfb scenario check`` and
``posfb design`` end with a simulation of the scenario's own arm (its URDF in Drake, the
motor stage, friction, encoder, saturation: the closed loop ``posfb simulate`` runs) over
the scenario's path, judged by ``analysis.common.metrics.run_verdict``, and one line that
says whether it agrees with the linear checks (``agreement``). ``--no-sim`` skips it.
"""

from __future__ import annotations

from dataclasses import dataclass

from posfb.analysis.common.metrics import Verdict, run_verdict
from posfb.diagrams.resolve import ResolvedScenario
from posfb.diagrams.runner import ClosedLoopRunner


@dataclass(frozen=True)
class ExactArmRun:
    """The exact arm's run: its ``verdict``, the seconds it ``reached`` and the
    ``duration`` it was asked for."""

    verdict: Verdict
    reached: float
    duration: float

    @property
    def ok(self) -> bool:
        return self.verdict.status == "ok"

    def to_dict(self) -> dict[str, object]:
        return {"status": self.verdict.status, "message": self.verdict.message,
                "reached_s": self.reached, "duration_s": self.duration}  # fmt: skip


#: The status of a run the controller refused to start (a setting its design refuses, such
#: as a ``G(s)`` pole below ``ln 2 / T_s``: the design report names it as a failed check).
REFUSED = "refused"


def exact_arm_run(resolved: ResolvedScenario) -> ExactArmRun:
    """Simulate the scenario's closed loop on its arm over its duration and judge it; a
    controller that refuses its settings gives a ``REFUSED`` run that reached 0 s."""
    config = resolved.config
    try:
        result = ClosedLoopRunner(config).run()
    except ValueError as error:
        return ExactArmRun(Verdict(REFUSED, str(error)), 0.0, config.timing.duration)
    return ExactArmRun(run_verdict(result), float(result.times[-1]), config.timing.duration)


def agreement(linear_passed: bool, run: ExactArmRun) -> str:
    """One line: the exact arm's verdict beside the linear one, and where they disagree."""
    span = f"{run.duration:g} s"
    if run.ok:
        said = (
            "as the linear checks say"
            if linear_passed
            else (
                "though the linear checks fail: a linear instability may settle into a small "
                "limit cycle, or the arm pass the failing configurations quickly; the run "
                "verdict's bounds are not a stability proof"
            )
        )
        return f"exact arm: the {span} run of the scenario's arm is ok ({said})"
    if run.verdict.status == REFUSED:
        return f"exact arm: not run: the controller refuses the scenario ({run.verdict.message})"
    what = f"{run.verdict.status}: {run.verdict.message}"
    if linear_passed:
        return f"exact arm: the linear checks pass; the {span} run of the scenario's arm is {what}"
    return f"exact arm: the {span} run of the scenario's arm is {what}, as the linear checks say"
