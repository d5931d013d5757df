"""Parts (b) and (c): the Monte-Carlo studies, as realism studies (``analysis.realism``:
the ideal arm, then one study per "effect", each a resumable store).

- (b) ``identified_<counts>``: the true arm drawn from the posterior of plan 0's
  identification at that resolution (``accuracy.posterior_path``), the controllers
  designed on that identification's model (``nominal_model: !Identified``), the
  experiment of Table 3 (the study's scenario) and of Table 4 (``payload_scenario``).
  The experiment's own encoder is the scenario's, so the change from the ideal arm is
  the model error alone.
- (c) ``size_<percent>``: every physical parameter of the true arm (each joint's link
  mass, centre of mass, inertia, rotor inertia, damping, Coulomb level and motor
  constant) drawn uniformly within +-size of its value, the controllers on the
  scenario's model (Table 1), Table 3's experiment. The same seed at every size: a
  sample's draw is the same uniform number scaled, so the sizes differ only in size.
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

from posfb.analysis.model_error.accuracy import (
    model_path,
    posterior_path,
    read_posterior,
    read_recorded,
)
from posfb.analysis.model_error.spec import ModelErrorSpec
from posfb.analysis.realism.spec import Effect, RealismSpec, RealismStudies, realism_studies
from posfb.analysis.uncertainty.study import ParameterDistributions, Posterior, Study, Uniform
from posfb.models.plant import JOINT_PARAMETERS

#: Where each part's stores go (``OUT/stores/<name>/``) and which paper table it is
#: compared with.
TABLE3, TABLE4, SIZES = "table3", "table4", "size"


def identified_name(counts: int) -> str:
    return f"identified_{counts}"


def size_name(size: float) -> str:
    """``size_5`` for +-5 %; a fraction of a percent as ``size_2p5``."""
    return "size_" + f"{100.0 * size:g}".replace(".", "p")


def _identified_effects(spec: ModelErrorSpec, folder: Path) -> list[Effect]:
    effects = []
    for counts in spec.identification.encoder_counts:
        posterior = read_recorded(posterior_path(folder, counts), read_posterior)
        effects.append(
            Effect(
                name=identified_name(counts),
                label=f"identified at {counts} counts",
                source=f"posfb identify of plan 0 at {counts} counts (part a)",
                samples=spec.posterior_samples,
                settings=[f"nominal_model=!Identified {{file: {model_path(folder, counts)}}}"],
                posterior=Posterior(**posterior),
            )
        )
    return effects


def _size_effect(spec: ModelErrorSpec, size: float) -> Effect:
    spread = [Uniform(min=-size, max=size, relative=True)]
    return Effect(
        name=size_name(size),
        label=f"every physical parameter +-{100.0 * size:g} %",
        source="a chosen size, the scan of part c",
        samples=spec.size_samples,
        parameters=ParameterDistributions(**{name: spread for name in JOINT_PARAMETERS}),
    )


def _studies(study: Study, table: str, effects: list[Effect], what: str) -> RealismStudies:
    realism = RealismSpec(study=study, paper_table=table, effects=effects)
    return realism_studies(realism, f"model-error study: {what}", Path.cwd())


def model_error_studies(spec: ModelErrorSpec, folder: Path) -> dict[str, RealismStudies]:
    """The studies of parts (b) and (c) by part (``TABLE3``, ``TABLE4``, ``SIZES``),
    from the identifications recorded in ``folder``."""
    identified = _identified_effects(spec, folder.resolve())  # the settings name it
    studies = {TABLE3: _studies(spec.study, "nominal", identified, "Table 3")}
    if spec.payload_scenario:
        payload = replace(spec.study, scenario=spec.payload_scenario)
        studies[TABLE4] = _studies(payload, "payload", identified, "Table 4")
    sizes = [_size_effect(spec, size) for size in spec.sizes]
    studies[SIZES] = _studies(spec.study, "nominal", sizes, "sizes")
    return studies
