"""The shipped scenario files of the experiments of Sec. 4, by case name.

Names and paths only (no Drake, no numpy): the command line offers ``--case`` from
here without loading the models; ``analysis.paper.experiment`` builds the cases on them."""

from __future__ import annotations

from posfb.analysis.common.shipped import SCENARIO_DIR

#: The shipped scenario files of the two experiments of Sec. 4.
CASE_FILES = {
    "nominal": SCENARIO_DIR / "paper_nominal.yaml",
    "payload": SCENARIO_DIR / "paper_payload.yaml",
}
CASES = tuple(CASE_FILES)
