"""The report of ``posfb design`` and ``posfb scenario check``: the controller design of
Sec. 3 for a scenario (``nominal_design``: its sampled-data checks on the nominal loop with
the scenario's linear effects), as text (``format_report``) or as the ``--json`` object
(``design_to_dict``), with the checks its controller entry determines (``relevant_checks``).
"""

from __future__ import annotations

from dataclasses import asdict
from typing import TYPE_CHECKING

from posfb.analysis.common.errors import UsageError

if TYPE_CHECKING:
    import numpy as np

    from posfb.diagrams.loop_config import ClosedLoopConfig
    from posfb.diagrams.resolve import ResolvedScenario
    from posfb.models.design import Design
    from posfb.models.design.common_lyapunov import LyapunovCertificate


def relevant_checks(config: ClosedLoopConfig) -> tuple[str, ...]:
    """The design checks the controller entry of a resolved ``config`` determines
    (``models.controllers.design_checks``); PID and the plug-ins (PD + gravity, ADRC, a
    ``!Python`` class) have no Sec. 3 design: refused."""
    from posfb.models.controllers import design_checks, loop_kinds

    relevant = design_checks(config.controller)
    if not relevant:
        raise UsageError(
            f"controller {config.controller!r} ({config.spec.label}) has no Sec. 3 design; "
            "posfb design designs the paper's controller and Lin+LC "
            f"(--set controller.kind={' or '.join(loop_kinds().values())})"
        )
    return relevant


def nominal_design(resolved: ResolvedScenario) -> Design:
    """The design of the scenario's entry, its sampled-data checks on the nominal loop with
    the scenario's linear effects (``analysis.common.loop_effects``; a compliant gear the
    nominal model cannot carry is refused), at ``M0*`` and with ``M*(q)`` frozen at every
    configuration of the scenario's path (``analysis.common.configurations``)."""
    from posfb.analysis.common.configurations import scenario_configurations
    from posfb.analysis.common.loop_effects import nominal_effects
    from posfb.models.design import DESIGNED_LOOPS, cached_design, with_configurations

    config = resolved.config
    return with_configurations(
        cached_design(config.design),
        nominal_effects(resolved),
        scenario_configurations(config),
        certify=tuple(loop for loop in DESIGNED_LOOPS if loop in config.spec.checks),
    )


def _poles(poles: np.ndarray) -> list[list[float]]:
    return [[float(p.real), float(p.imag)] for p in poles]


#: The checks that need the nonlinear torque's inputs (an entry without them, Lin+LC's,
#: shows none of its numbers).
NONLINEAR_CHECKS = frozenset({"spr", "bound_filter", "continuous_with_nc", "sampled_data"})

#: The ``--json`` keys that belong to the nonlinear torque.
_NONLINEAR_KEYS = ("alpha_star", "E", "E1", "E2", "E3", "Gamma", "kyp_gamma", "P2_M0inv_norm",
                   "continuous_poles_with_nc", "sampled_data_spectral_radius",
                   "sampled_data_spectral_radius_at_M0", "bound_filter",
                   "uncertainty_bounds")  # fmt: skip

def _configurations_dict(design: Design) -> dict:
    """The ``--json`` keys of the configuration set: each loop's radius at ``M0*``
    (``..._at_M0``) and ``configurations``: their count, the eigenvalue range of
    ``M0*^-1 M*(q)`` over them and, per loop, where its worst radius is; a loop is keyed
    by the kind of the controller it belongs to (``ControllerSpec.design_loop``)."""
    from posfb.models.controllers import loop_kinds
    from posfb.models.design import DESIGNED_LOOPS

    if design.frozen_radii is None or design.configurations is None:
        return {}
    configurations, kind = design.configurations, loop_kinds()
    worst = {}
    for name, figures in design.frozen_radii.items():
        where = configurations.configurations[figures.worst_index]
        worst[kind[name]] = {"radius": figures.worst, "time": where.time, "q": list(where.q),
                       "role": where.role}  # fmt: skip
    certificates = {
        kind[name]: {"feasible": c.feasible, "decay": c.decay if c.feasible else None,
               "condition": c.condition if c.feasible else None, "loops": c.loops,
               "message": c.message}
        for name, c in (design.certificates or {}).items()
    }  # fmt: skip
    return {
        **{f"{loop.radius}_at_M0": design.frozen_radii[name].at_M0
           for name, loop in DESIGNED_LOOPS.items()},  # fmt: skip
        "configurations": {
            "count": len(configurations),
            "eigenvalue_range": list(configurations.eigenvalue_range()),
            "worst": worst,
            "certificates": certificates,
        },
    }


def design_to_dict(design: Design, relevant: tuple[str, ...] | None = None) -> dict:
    """The JSON object of ``posfb design --json``; with ``relevant``, only those checks, and
    the nonlinear torque's numbers ``null`` when none of its checks is relevant."""
    constants = design.bound_filter
    result = {
        "sample_time": design.config.sample_time,
        "alpha_star": design.config.nonlinear.alpha_star,
        "discretisation": design.config.discretisation,
        "M0": design.M0.tolist(),
        "B": design.B.tolist(),
        "K": design.K.tolist(),
        "K1": design.K1.tolist(),
        "K2": design.K2.tolist(),
        "K3": design.K3.tolist(),
        "P": design.P.tolist(),
        "E": design.E.tolist(),
        "E1": design.E1.tolist(),
        "E2": design.E2.tolist(),
        "E3": design.E3.tolist(),
        "Gamma": None if design.Gamma is None else design.Gamma.tolist(),
        "kyp_gamma": design.kyp_gamma,
        "P2_M0inv_norm": design.coupling_norm,
        "continuous_poles": _poles(design.continuous_poles),
        "continuous_poles_with_nc": _poles(design.continuous_poles_with_nc),
        "lc_filter_poles": _poles(design.lc_filter_poles),
        "sampled_data_spectral_radius": design.sampled_data_spectral_radius,
        "sampled_data_spectral_radius_lin_lc": design.sampled_data_spectral_radius_lin_lc,
        "bound_filter": {
            "a": constants.a,
            "abar": constants.abar,
            "c": constants.c,
            "min_a": constants.min_a,
        },
        "uncertainty_bounds": asdict(design.bounds),
        "checks": {c.name: {"passed": c.passed, "detail": c.detail} for c in design.checks},
        "warnings": design.warnings,
        **_configurations_dict(design),
    }
    if relevant is None:
        return result
    checks = [c for c in design.checks if c.name in relevant]
    result["checks"] = {c.name: {"passed": c.passed, "detail": c.detail} for c in checks}
    result["warnings"] = [c.detail for c in checks if not c.passed]
    if not NONLINEAR_CHECKS & set(relevant):
        result |= dict.fromkeys(_NONLINEAR_KEYS)
    return result


def _matrix(name: str, matrix: np.ndarray) -> list[str]:
    rows = ["  ".join(f"{value:12.5g}" for value in row) for row in matrix]
    return [f"{name} ="] + [f"    {row}" for row in rows]


def _pole_text(poles: np.ndarray) -> str:
    return ", ".join(
        f"{p.real:.4g}" if p.imag == 0 else f"{p.real:.4g}{p.imag:+.4g}j" for p in poles
    )


def _certificate_text(certificate: LyapunovCertificate) -> str:
    """One line: what a common Lyapunov function certifies, or why there is none."""
    if certificate.feasible:
        return (f"{certificate.message}: stable for every M* in the hull of these loops, "
                "however fast it varies among them (Coriolis terms, friction and saturation "
                "left out)")  # fmt: skip
    return (f"{certificate.message}; no certificate for M*(q) varying: the frozen-"
            "configuration figures above are what holds")  # fmt: skip


def _radius_text(design: Design, loop: str) -> str:
    """The radius of designed ``loop``, and with a configuration set its radius at ``M0*``
    beside it."""
    from posfb.models.design import DESIGNED_LOOPS

    radius = getattr(design, DESIGNED_LOOPS[loop].radius)
    if design.frozen_radii is None:
        return f"{radius:.4f}"
    return (
        f"{radius:.4f} (worst over the path's configurations; at M0*: "
        f"{design.frozen_radii[loop].at_M0:.4f})"
    )


def format_report(design: Design, relevant: tuple[str, ...] | None = None) -> str:
    """The readable report: the design, then every check (``relevant``: those only) with
    ``ok`` or ``FAILED``; an entry without the nonlinear torque (Lin+LC's) shows only the
    linear torque's numbers."""
    from posfb.models.design import DESIGNED_LOOPS
    from posfb.models.design.discretise import DISCRETISATION_NAMES

    config = design.config
    checks = [c for c in design.checks if relevant is None or c.name in relevant]
    nonlinear = relevant is None or bool(NONLINEAR_CHECKS & set(relevant))
    header = f"Design of Sec. 3 at T_s = {config.sample_time:g} s"
    if nonlinear:
        header += (
            f", alpha* = {config.nonlinear.alpha_star:g}, K_alpha = "
            f"{config.nonlinear.K_alpha:g}, G(s) pole a = {config.nonlinear.filter_a:g}"
        )
    lines = [
        f"{header}, filters discretised by {DISCRETISATION_NAMES[config.discretisation]}",
        *_matrix("K = [K1 K2 K3] (Eq. 14)", design.K),
        *_matrix("P (Eq. 15)", design.P),
        f"continuous poles of A_a - B_a1 K: {_pole_text(design.continuous_poles)}",
    ]
    if nonlinear:
        lines[-1:-1] = _matrix("E = (M0*)^-T P2^T = [E1 E2 E3] (Eq. 20)", design.E)
        lines += [
            f"continuous poles with tau_NC at alpha*: "
            f"{_pole_text(design.continuous_poles_with_nc)}",
            f"sampled-data spectral radius (proposed, alpha = alpha*): "
            f"{_radius_text(design, 'sampled_data')}",
        ]
    lines.append(
        "sampled-data spectral radius (Lin+LC): "
        + _radius_text(design, "sampled_data_lin_lc")
    )
    if design.configurations is not None:
        lines.append(f"configurations: {design.configurations.describe_range()}")
    for name, certificate in (design.certificates or {}).items():
        lines.append(
            f"certificate ({DESIGNED_LOOPS[name].label}): {_certificate_text(certificate)}"
        )
    if nonlinear:
        lines.append(
            f"||P2 (M0*)^-1|| = {design.coupling_norm:.4g}, k_C1 = {design.bounds.k_C1:.4g}"
        )
    lines.append("checks:")
    lines += [f"  [{'ok' if c.passed else 'FAILED'}] {c.detail}" for c in checks]
    failed = sum(not c.passed for c in checks)
    lines.append(f"{failed} check(s) FAILED" if failed else "all checks passed")
    return "\n".join(lines)
