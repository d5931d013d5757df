"""The model-error study file (issue 29, item 5).

::

    study:                  # the experiments' shared Monte-Carlo study (as a realism
      seed: 2013            # study's: analysis.realism.spec), without draws
      sampling: random
      scenario: ../../scenarios/paper_nominal.yaml   # Table 3's experiment
      duration: 20.0
      controllers: [proposed, lin_lc, pid]
    payload_scenario: ../../scenarios/paper_payload.yaml   # Table 4's experiment
    identification:         # (a): each plan identified at each resolution
      encoder_counts: [1024, 4096, 20000]
      plans: 10             # planned excitations, seeds 0 .. plans - 1
      duration: 60.0        # s of each planned excitation
      controller: lin_lc    # the loop that plays the plan on the arm
    posterior_samples: 40   # (b): plants drawn from plan 0's identification, per resolution
    sizes: [0.05, 0.1, 0.2, 0.4]   # (c): every physical parameter +-size (uniform)
    size_samples: 40

Paths are relative to the file. The identification runs on the study's scenario (its arm,
sample time and start position) with the plan as its trajectory; every number is checked
here, in one line naming the file and the key.
"""

import math
from dataclasses import dataclass, field, replace
from pathlib import Path

from posfb.analysis.uncertainty.study import Study
from posfb.diagrams.yaml_schema import load_typed, read_text


@dataclass
class IdentificationRuns:
    """Part (a): every planned excitation (seeds ``0 .. plans - 1``, ``duration`` s)
    played on the arm by ``controller`` and identified at each of ``encoder_counts``."""

    encoder_counts: list[int] = field(default_factory=list)
    plans: int = 1
    duration: float = 0.0
    controller: str = ""


@dataclass
class ModelErrorSpec:
    """The study file (module docstring)."""

    study: Study = field(default_factory=Study)
    payload_scenario: str = ""
    identification: IdentificationRuns = field(default_factory=IdentificationRuns)
    posterior_samples: int = 1
    sizes: list[float] = field(default_factory=list)
    size_samples: int = 1


def _check(spec: ModelErrorSpec, source: str) -> None:
    def require(condition: bool, key: str, value: object, allowed: str) -> None:
        if not condition:
            raise ValueError(f"{source}: {key} = {value!r}; {allowed} is required")

    runs = spec.identification
    counts = runs.encoder_counts
    require(
        bool(counts) and all(isinstance(c, int) and c > 0 for c in counts),
        "identification.encoder_counts", counts, "a list of counts per revolution > 0",
    )  # fmt: skip
    require(len(set(counts)) == len(counts), "identification.encoder_counts", counts,
            "a list without repeats")  # fmt: skip
    require(isinstance(runs.plans, int) and runs.plans >= 1, "identification.plans",
            runs.plans, "an integer >= 1")  # fmt: skip
    require(math.isfinite(runs.duration) and runs.duration > 0.0, "identification.duration",
            runs.duration, "a duration in s > 0")  # fmt: skip
    require(bool(runs.controller.strip()), "identification.controller", runs.controller,
            "a controller name")  # fmt: skip
    for key in ("posterior_samples", "size_samples"):
        value = getattr(spec, key)
        require(isinstance(value, int) and value >= 1, key, value, "an integer >= 1")
    sizes = spec.sizes
    require(
        bool(sizes) and all(0.0 < s < 1.0 for s in sizes) and sizes == sorted(set(sizes)),
        "sizes", sizes, "an increasing list of relative spreads in (0, 1)",
    )  # fmt: skip
    require(not spec.study.draws_anything(), "study", "draws", "a study that draws nothing")
    require(spec.study.sampling == "random", "study.sampling", spec.study.sampling,
            "random (the posterior draws of part b)")  # fmt: skip


def _absolute(text: str, folder: Path) -> str:
    return text if not text or Path(text).is_absolute() else str((folder / text).resolve())


def load_model_error(path: str | Path) -> ModelErrorSpec:
    """The checked spec of the file ``path``, its paths made absolute."""
    path = Path(path)
    source = f"model-error study {path}"
    text = read_text(path, "model-error study", missing=FileNotFoundError)
    spec = load_typed(ModelErrorSpec, text, source)
    _check(spec, source)
    folder = path.resolve().parent
    return replace(
        spec,
        study=replace(spec.study, scenario=_absolute(spec.study.scenario, folder)),
        payload_scenario=_absolute(spec.payload_scenario, folder),
    )
