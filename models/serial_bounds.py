"""Assumption 1's constants for any serial arm, by sampling the workspace (issue 13).

Assumption 1 (Sec. 2) bounds the differences between a nominal model ``*`` and
the true arm, both as ``models.serial_model.SerialArmModel``::

    ||dM0|| <= D_M0,  ||dM1(q)|| <= D_M1,  ||dC(q, x)|| <= D_C ||x||,
    ||dG(q)|| <= D_G,  ||dB|| <= D_B,  ||dF(q')|| <= D_F     for all q, q', x

with ``M1 = M - M0`` and ``C`` in Christoffel form (``SerialArmModel.C``). For the
two-link arm ``analysis.montecarlo.coverage`` has them in closed form; for any
other arm:

* ``dM0``, ``dB`` (spectral norms of constant matrices) and ``dF`` (the largest
  ``||diag(df) s||`` over ``|s_i| = 1``: ``||df||``) are exact;
* ``dM1``, ``dG`` and ``dC`` are maxima over the workspace: ``samples`` points of a
  scrambled Sobol' sequence over every joint angle, then a local search
  (Nelder-Mead) from the ``STARTS`` best points; for ``dC`` the largest gain over the
  direction ``x`` at each ``q`` is ``tensor_norm``'s alternating maximisation.
  ``coarse`` repeats this with the first half of the points: where the two agree
  (``converged``) the maximum was found from two starting sets.

A sampled maximum is a lower bound of the true one; the local search makes it
exact when the best sample lies in the global maximum's basin, which the
convergence check and the two-link test (against the closed forms) support.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from posfb.models.serial_model import SerialArmModel

#: The constants, in the paper's order (the names of ``analysis.montecarlo.coverage``).
BOUND_NAMES = ("delta_M0", "delta_M1", "delta_C", "delta_G", "delta_B", "delta_F")


@dataclass(frozen=True)
class SampledNorms:
    """``norms[name]`` with ``samples`` workspace points; ``coarse`` with half of them."""

    norms: dict[str, float]
    coarse: dict[str, float]
    samples: int

    def converged(self, tolerance: float = 1e-6) -> bool:
        """Whether both point sets found the same maxima (relative ``tolerance``)."""
        return all(
            abs(self.norms[name] - self.coarse[name]) <= tolerance * max(self.norms[name], 1e-300)
            for name in BOUND_NAMES
        )


#: Starting points of the local search: the best samples.
STARTS = 3


#: Nelder-Mead iterations of each local search, by default.
SEARCH_STEPS = 4000


def _maximum(
    function: Callable[[np.ndarray], float], points: np.ndarray, steps: int = SEARCH_STEPS
) -> float:
    """The largest ``function`` over ``points``, refined by at most ``steps`` Nelder-Mead
    iterations from each of the ``STARTS`` best."""
    import scipy.optimize  # on use: the CLI's start-up does not pay for it

    values = np.array([function(point) for point in points])
    best = float(values.max())
    for start in points[np.argsort(values)[::-1][:STARTS]]:
        result = scipy.optimize.minimize(
            lambda point: -function(point), start, method="Nelder-Mead",
            options={"xatol": 1e-10, "fatol": 1e-15, "maxiter": steps},
        )  # fmt: skip
        best = max(best, -float(result.fun))
    return best


def tensor_norm(tensor: np.ndarray, iterations: int = 100) -> float:
    """``max_{||x|| = 1} ||tensor @ x||_2`` for ``tensor[i, j, k]`` (``C*(q, x)``'s
    largest gain): alternating maximisation (the top singular pair ``(u, v)`` of
    ``tensor @ x``, then ``x`` along ``u^T tensor v``), which never decreases the value,
    from every unit vector and their normalised sum."""
    n = tensor.shape[2]
    starts = [*np.eye(n), np.ones(n) / np.sqrt(n)]
    best = 0.0
    for x in starts:
        value = 0.0
        for _ in range(iterations):
            left, singular, right = np.linalg.svd(tensor @ x)
            gradient = np.einsum("i,ijk,j->k", left[:, 0], tensor, right[0])
            length = float(np.linalg.norm(gradient))
            if length == 0.0 or singular[0] - value <= 1e-15 * max(singular[0], 1.0):
                value = max(value, float(singular[0]))
                break
            value, x = float(singular[0]), gradient / length
        best = max(best, value, float(np.linalg.norm(tensor @ x, 2)))
    return best


def _workspace_maxima(
    m1: Callable[[np.ndarray], np.ndarray],
    christoffel: Callable[[np.ndarray], np.ndarray],
    gravity: Callable[[np.ndarray], np.ndarray],
    angles: np.ndarray,
    steps: int = SEARCH_STEPS,
) -> dict[str, float]:
    """The largest ``||m1(q)||_2``, ``tensor_norm(christoffel(q))`` and ``||gravity(q)||``
    over the joint angles ``angles`` (named ``delta_M1``, ``delta_C``, ``delta_G``)."""
    return {
        "delta_M1": _maximum(lambda q: float(np.linalg.norm(m1(q), 2)), angles, steps),
        "delta_C": _maximum(lambda q: tensor_norm(christoffel(q)), angles, steps),
        "delta_G": _maximum(lambda q: float(np.linalg.norm(gravity(q))), angles, steps),
    }


def _sobol_angles(joints: int, samples: int, seed: int) -> np.ndarray:
    if samples < 2 or samples & (samples - 1):
        raise ValueError(f"samples = {samples!r}; a power of 2 >= 2 is required")
    from scipy.stats import qmc  # on use: the CLI's start-up does not pay for it

    sobol = qmc.Sobol(joints, scramble=True, rng=np.random.default_rng(seed))
    return 2.0 * np.pi * sobol.random(samples)


#: Workspace points and seed of the nominal norms' search (``model_norms``).
MODEL_NORM_SAMPLES = 64
MODEL_NORM_SEED = 0


def model_norms(
    model: SerialArmModel, samples: int = MODEL_NORM_SAMPLES, seed: int = MODEL_NORM_SEED
) -> dict[str, float]:
    """The nominal norms the design's bounds scale (``models.design.bounds``):
    ``max_q ||M1*(q)||``, ``k_C1 = max_q max_{|x| = 1} ||C*(q, x)||`` and
    ``max_q ||G*(q)||`` (named ``delta_M1``, ``delta_C``, ``delta_G``), by the same
    workspace search as ``uncertainty_norms`` over ``samples`` points."""
    M0 = model.M0()
    return _workspace_maxima(
        lambda q: model.M(q) - M0,
        model.christoffel,
        model.G,
        _sobol_angles(model.size, samples, seed),
    )


def _check_sizes(true: SerialArmModel, nominal: SerialArmModel) -> None:
    if true.size != nominal.size:
        raise ValueError(
            f"the true arm has {true.size} joints and the nominal model {nominal.size}; "
            "the same number is required"
        )


def _constants(
    true: SerialArmModel, nominal: SerialArmModel, angles: np.ndarray, steps: int
) -> dict[str, float]:
    """The six constants, in ``BOUND_NAMES`` order, with the workspace maxima over
    ``angles``."""
    M0_true, M0_nominal = true.M0(), nominal.M0()
    found = {
        "delta_M0": float(np.linalg.norm(M0_nominal - M0_true, 2)),
        "delta_B": float(np.linalg.norm(nominal.B() - true.B(), 2)),
        "delta_F": float(np.linalg.norm(nominal.coulomb_levels() - true.coulomb_levels())),
        **_workspace_maxima(
            lambda q: (nominal.M(q) - M0_nominal) - (true.M(q) - M0_true),
            lambda q: nominal.christoffel(q) - true.christoffel(q),
            lambda q: nominal.G(q) - true.G(q),
            angles,
            steps,
        ),
    }
    return {name: found[name] for name in BOUND_NAMES}


def uncertainty_constants(
    true: SerialArmModel,
    nominal: SerialArmModel,
    samples: int = 256,
    seed: int = 0,
    steps: int = SEARCH_STEPS,
) -> dict[str, float]:
    """Assumption 1's smallest constants for ``true`` against ``nominal`` from one
    search over ``samples`` (a power of 2) workspace points, at most ``steps``
    iterations of each local search (``uncertainty_norms`` without its check)."""
    _check_sizes(true, nominal)
    return _constants(true, nominal, _sobol_angles(true.size, samples, seed), steps)


def uncertainty_norms(
    true: SerialArmModel,
    nominal: SerialArmModel,
    samples: int = 256,
    seed: int = 0,
    steps: int = SEARCH_STEPS,
) -> SampledNorms:
    """Assumption 1's smallest constants for ``true`` against ``nominal`` (module
    docstring); ``samples`` (a power of 2) workspace points, at most ``steps``
    iterations of each local search, and the same search on the first half of the
    points as the convergence check."""
    _check_sizes(true, nominal)
    angles = _sobol_angles(true.size, samples, seed)
    fine = _constants(true, nominal, angles, steps)
    coarse = _constants(true, nominal, angles[: samples // 2], steps)
    return SampledNorms(fine, coarse, samples)
