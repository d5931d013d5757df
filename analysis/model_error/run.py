"""Run (or resume) the model-error study into a folder: ``identification/`` (part a's
records, plan 0's model files and posteriors), ``logs/`` (plan 0's logs), ``stores/``
(parts b and c, one folder of realism stores each), then the report."""

from __future__ import annotations

import sys
from pathlib import Path

from posfb.analysis.model_error.accuracy import run_identifications
from posfb.analysis.model_error.experiments import model_error_studies
from posfb.analysis.model_error.spec import ModelErrorSpec
from posfb.analysis.realism.run import run_realism


def run_model_error(
    spec: ModelErrorSpec, out: Path, workers: int = 1, progress: bool = True
) -> dict[str, tuple[int, ...]]:
    """Every part not yet finished in ``out`` (finished records and samples are kept);
    returns, by ``part/study``, the samples recorded as errors because their worker
    died."""
    run_identifications(spec, out / "identification", out / "logs")
    sys.stderr.write("posfb model-error: identifications done\n")
    died = {}
    for part, studies in model_error_studies(spec, out / "identification").items():
        for name, samples in run_realism(studies, out / "stores" / part, workers, progress).items():
            died[f"{part}/{name}"] = samples
    return died
