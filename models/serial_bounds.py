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
  scrambled Sobol' sequence over every joint angle, then a local search (BFGS) from the
  ``STARTS`` best points. For ``dC`` the largest gain over the direction ``x`` at each
  ``q`` is ``tensor_norms``' alternating maximisation, batched over points and starts.
  The search climbs the exact gradient of each maximum where it is attained (Danskin's
  theorem: ``u^T dM1/dq v`` at the top singular pair, Drake's exact ``dM/dq``;
  ``u^T dC(q, x)/dq v`` at the maximising ``(x, u, v)``, a forward difference of the
  Christoffel symbols; ``dG/dq`` by differences). ``M1`` and ``C`` do not depend on the
  first joint angle (``LEADING_INVARIANT``: turning the whole arm about its base joint
  changes no inertia), so their search runs over the other angles.
  ``coarse`` repeats this with the first half of the points: where the two agree
  (``converged``) the maximum was found from two starting sets.

A sampled maximum is a lower bound of the true one (every value is the norm at a
configuration the search reached); the local search makes it exact when a start lies in
the global maximum's basin, which the convergence check and the two-link test (against
the closed forms) support. The gradient search reaches maxima that the earlier
Nelder-Mead search (issue 13) stopped short of: on the published Panda ``max ||M1*||``
is 1.1764 where Nelder-Mead stopped at 1.1726, in 1.5 s instead of 74 s; on the shipped
six-joint arm the two agree to round-off (``bench/bench_norms.py`` compares them).
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


#: Starting points of each local search: the best samples.
STARTS = 4

#: Iterations of each local search (BFGS), by default.
SEARCH_STEPS = 200

#: The gradient norm at which a local search stops (the value is then exact to about its
#: square, far below the 1e-9 the tests ask of a maximum).
GRADIENT_TOLERANCE = 1e-8

#: Step (rad) of the forward differences in ``dC/dq`` and ``dG/dq``.
DIFFERENCE_STEP = 1e-7

#: The maxima that do not depend on the first joint angle: ``M(q)`` and so ``M1`` and the
#: Christoffel symbols are the same after the whole arm turns about (or slides along) its
#: base joint, whose axis is fixed in the world (``tests/models/test_serial_bounds.py``).
LEADING_INVARIANT = ("delta_M1", "delta_C")


@dataclass(frozen=True)
class _Objective:
    """A function of the joint angles to maximise: ``values`` at many points (P x n) at
    once, ``value_and_gradient`` at one."""

    values: Callable[[np.ndarray], np.ndarray]
    value_and_gradient: Callable[[np.ndarray], tuple[float, np.ndarray]]


def _maximum(
    objective: _Objective, points: np.ndarray, steps: int, leading_invariant: bool
) -> float:
    """The largest ``objective`` over ``points``, refined by at most ``steps`` BFGS
    iterations from each of the ``STARTS`` best; with ``leading_invariant``, read at
    ``q_1 = 0`` and searched over the other angles."""
    import scipy.optimize  # on use: the CLI's start-up does not pay for it

    if leading_invariant:
        points = np.column_stack([np.zeros(len(points)), points[:, 1:]])
    values = objective.values(points)
    best = float(values.max())
    if steps == 0:
        return best
    fixed = 1 if leading_invariant else 0

    def negated(free: np.ndarray) -> tuple[float, np.ndarray]:
        value, gradient = objective.value_and_gradient(np.concatenate((points[0, :fixed], free)))
        return -value, -gradient[fixed:]

    for start in points[np.argsort(values)[::-1][:STARTS]]:
        result = scipy.optimize.minimize(
            negated, start[fixed:], jac=True, method="BFGS",
            options={"maxiter": steps, "gtol": GRADIENT_TOLERANCE},
        )
        best = max(best, -float(result.fun))
    return best


def tensor_norms(
    tensors: np.ndarray, iterations: int = 100
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """``max_{||x|| = 1} ||tensor @ x||_2`` of each ``tensors[p, i, j, k]`` (``C*(q, x)``'s
    largest gain) and its maximiser: ``(values, x, u, v)``, ``u^T (tensor @ x) v =
    value``. Alternating maximisation (the top singular pair ``(u, v)`` of ``tensor @
    x``, then ``x`` along ``u^T tensor v``), which never decreases the value, from every
    unit vector and their normalised sum; all points and starts at once (one batched SVD
    per iteration), a start stopping where its value no longer grows."""
    points, n = tensors.shape[0], tensors.shape[3]
    flat = tensors.reshape(points, n * n, n)
    starts = np.vstack([np.eye(n), np.ones(n) / np.sqrt(n)])
    x = np.tile(starts, (points, 1))
    owner = np.repeat(np.arange(points), len(starts))
    value = np.zeros(len(x))
    going = np.arange(len(x))
    for _ in range(iterations):
        tensor = flat[owner[going]]
        left, singular, right = np.linalg.svd(np.einsum("gmk,gk->gm", tensor, x[going])
                                              .reshape(-1, n, n))  # fmt: skip
        top = singular[:, 0]
        outer = (left[:, :, 0, None] * right[:, 0, None, :]).reshape(-1, n * n)
        gradient = np.einsum("gm,gmk->gk", outer, tensor)
        length = np.linalg.norm(gradient, axis=1)
        stopped = (length == 0.0) | (top - value[going] <= 1e-15 * np.maximum(top, 1.0))
        value[going] = top
        moving = ~stopped
        x[going[moving]] = gradient[moving] / length[moving, None]
        going = going[moving]
        if going.size == 0:
            break
    left, singular, right = np.linalg.svd(np.einsum("gmk,gk->gm", flat[owner], x)
                                          .reshape(-1, n, n))  # fmt: skip
    best = singular[:, 0].reshape(points, len(starts)).argmax(axis=1)
    chosen = np.arange(points) * len(starts) + best
    return singular[chosen, 0], x[chosen], left[chosen, :, 0], right[chosen, 0]


def tensor_norm(tensor: np.ndarray, iterations: int = 100) -> float:
    """``max_{||x|| = 1} ||tensor @ x||_2`` of one ``tensor[i, j, k]`` (``tensor_norms``)."""
    return float(tensor_norms(tensor[None], iterations)[0][0])


def _spectral(
    m1: Callable[[np.ndarray], np.ndarray], derivatives: Callable[[np.ndarray], np.ndarray]
) -> _Objective:
    """``||m1(q)||_2`` (``M*``'s rows are scaled per joint, so ``m1`` need not be
    symmetric), with the gradient ``u^T (dm1/dq_k) v`` at its top singular pair
    ``(u, v)``, from ``derivatives(q)[i, j, k]``."""

    def value_and_gradient(q: np.ndarray) -> tuple[float, np.ndarray]:
        left, singular, right = np.linalg.svd(m1(q))
        gradient = np.einsum("i,ijk,j->k", left[:, 0], derivatives(q), right[0])
        return float(singular[0]), gradient

    return _Objective(
        lambda points: np.array([float(np.linalg.norm(m1(q), 2)) for q in points]),
        value_and_gradient,
    )


def _coriolis(christoffel: Callable[[np.ndarray], np.ndarray]) -> _Objective:
    """``tensor_norms(christoffel(q))`` with the gradient ``u^T dC(q, x)/dq v`` at the
    maximiser (forward differences of ``christoffel``)."""

    def value_and_gradient(q: np.ndarray) -> tuple[float, np.ndarray]:
        symbols = christoffel(q)
        values, x, u, v = tensor_norms(symbols[None])
        gain = u[0] @ (symbols @ x[0]) @ v[0]
        gradient = np.array([
            (u[0] @ (christoffel(q + DIFFERENCE_STEP * e) @ x[0]) @ v[0] - gain)
            / DIFFERENCE_STEP
            for e in np.eye(len(q))
        ])  # fmt: skip
        return float(values[0]), gradient

    return _Objective(
        lambda points: tensor_norms(np.array([christoffel(q) for q in points]))[0],
        value_and_gradient,
    )


def _euclidean(gravity: Callable[[np.ndarray], np.ndarray]) -> _Objective:
    """``||gravity(q)||`` with its gradient by forward differences of ``gravity``."""

    def value_and_gradient(q: np.ndarray) -> tuple[float, np.ndarray]:
        force = gravity(q)
        norm = float(np.linalg.norm(force))
        jacobian = np.column_stack(
            [(gravity(q + DIFFERENCE_STEP * e) - force) / DIFFERENCE_STEP for e in np.eye(len(q))]
        )
        return norm, (jacobian.T @ force / norm if norm > 0.0 else np.zeros(len(q)))

    return _Objective(
        lambda points: np.array([float(np.linalg.norm(gravity(q))) for q in points]),
        value_and_gradient,
    )


def _workspace_maxima(
    m1: _Objective, christoffel: _Objective, gravity: _Objective, angles: np.ndarray,
    steps: int = SEARCH_STEPS,
) -> dict[str, float]:  # fmt: skip
    """The largest ``||M1||_2``, ``C``'s tensor norm and ``||G||`` over the joint angles
    ``angles`` (named ``delta_M1``, ``delta_C``, ``delta_G``)."""
    objectives = {"delta_M1": m1, "delta_C": christoffel, "delta_G": gravity}
    return {
        name: _maximum(objective, angles, steps, name in LEADING_INVARIANT)
        for name, objective in objectives.items()
    }


def _sobol_angles(joints: int, samples: int, seed: int) -> np.ndarray:
    if samples < 2 or samples & (samples - 1):
        raise ValueError(f"samples = {samples!r}; a power of 2 >= 2 is required")
    from scipy.stats import qmc  # on use: the CLI's start-up does not pay for it

    sobol = qmc.Sobol(joints, scramble=True, rng=np.random.default_rng(seed))
    return 2.0 * np.pi * sobol.random(samples)


#: Workspace points and seed of the nominal norms' search (``model_norms``).
MODEL_NORM_SAMPLES = 256
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
        _spectral(lambda q: model.M(q) - M0, model.mass_matrix_derivatives),
        _coriolis(model.christoffel),
        _euclidean(model.G),
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
            _spectral(
                lambda q: (nominal.M(q) - M0_nominal) - (true.M(q) - M0_true),
                lambda q: nominal.mass_matrix_derivatives(q) - true.mass_matrix_derivatives(q),
            ),
            _coriolis(lambda q: nominal.christoffel(q) - true.christoffel(q)),
            _euclidean(lambda q: nominal.G(q) - true.G(q)),
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
