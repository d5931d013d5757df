"""An exciting trajectory for identifying an arm's dynamic parameters (issue 29).

Swevers, Ganseman, Tukel, De Schutter and Van Brussel, "Optimal robot excitation and
identification", IEEE Trans. Robotics and Automation 13(5), 1997: each joint follows a
finite Fourier series of base angular frequency ``w_f = 2 pi / T_p`` (``T_p`` the period),
``k = 1..H`` harmonics::

    q_j(t)   = q0_j + sum_k  a_jk/(w_f k) sin(w_f k t) - b_jk/(w_f k) cos(w_f k t)
    q_j'(t)  =        sum_k  a_jk cos(w_f k t) + b_jk sin(w_f k t)
    q_j''(t) =        sum_k -a_jk w_f k sin(w_f k t) + b_jk w_f k cos(w_f k t)

and the coefficients are chosen to minimise the condition number of the identification
regressor ``Y`` (``u = Y(q, q', q'') theta``, stacked over the samples) subject to the
arm's limits. The series is periodic and band-limited: the measurement can be averaged
over periods and nothing above ``H w_f`` is excited.

Rest at both ends. The duration is a whole number of periods (``base_period`` defaults
to the duration), so ``t = T`` repeats ``t = 0``, and at ``t = 0`` three linear equality
conditions on the coefficients of every joint give the rest::

    q_j'(0)  = sum_k a_jk = 0
    q_j''(0) = w_f sum_k k b_jk = 0
    q_j(0)   = q0_j - sum_k b_jk/(w_f k) = rest_j   (q0_j follows from the b_jk)

The optimiser never sees the first two: the ``a_j`` and ``b_j`` are written in an
orthonormal basis of the null spaces of ``[1 .. 1]`` and ``[1 .. H]`` (``H - 1`` free
coordinates each), so they hold to round-off, not to a solver tolerance. The series is
smooth, and at both ends its position is the rest position and its velocity and
acceleration are zero, so holding the rest position before ``t = 0`` and after ``t = T``
keeps position, velocity and acceleration continuous: what a drive can play, and what
posfb's ``!CsvFile`` reader keeps (its not-a-knot cubic spline is itself continuous up
to the acceleration). The jerk at the ends, ``-w_f^2 sum_k k^2 a_jk``, is not zeroed.

The objective (``plan_excitation``) is ``log10 cond(Y_s)``: ``Y`` evaluated on
``GRID_POINTS`` midpoints of one period, ``t_i = (i + 1/2) T_p / GRID_POINTS`` (the
midpoints miss ``t = 0``, where the velocity is zero to round-off and a Coulomb column's
``sgn q'`` would follow the round-off), stacked into ``(GRID_POINTS n, p)``, each column
divided by its Euclidean norm. A change of a parameter's unit multiplies its column by a
constant, which the normalisation removes, so the number does not depend on units
(V s^2/rad against V); among all column scalings, equal column norms come within a factor
``sqrt(p)`` of the smallest condition number (van der Sluis, Numer. Math. 14, 1969).
SLSQP minimises it under the limits on the same grid, each tightened by ``margin``:
joint limits (``margin`` of each joint's range inside each end), ``|q'| <= (1 - margin)
velocity_limit`` and ``|u| <= (1 - margin) voltage_limit``. The position and velocity
constraints are linear in the coefficients (exact Jacobians). The voltage and the
regressor are the caller's functions, sample by sample; their derivatives in the state
come from one batched call on the grid's motion and its ``3 n`` forward-difference steps
(``q_j``, ``q_j'``, ``q_j''``), the chain rule through the linear map from coefficients to
motion gives them in the coefficients, and ``d sigma = u^T dA v`` of the extreme singular
values gives the objective's gradient. The plan is then checked at every sample time of
the whole run against the limits themselves, and shrunk towards rest if it fails there.
"""

from __future__ import annotations

import functools
import itertools
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from scipy.linalg import null_space
from scipy.optimize import minimize
from threadpoolctl import threadpool_limits

from posfb.models.validation import (
    require_nonnegative,
    require_positive,
    require_vector,
    shown,
)

#: Points per period of the grid the objective and the constraints are evaluated on.
GRID_POINTS = 200

#: Most harmonics: 10 grid points per cycle of the highest one.
MAX_HARMONICS = GRID_POINTS // 10

#: Default number of random starts ``plan_excitation`` optimises from.
STARTS = 3

#: Default share of each limit the optimiser keeps free (joint range, velocity, voltage).
LIMIT_MARGIN = 0.05

#: Forward-difference step of the state (rad, rad/s, rad/s^2) for the callers' functions.
DIFFERENCE_STEP = 1e-7

#: log10 of the condition number taken for a singular regressor.
SINGULAR = 16.0

#: A regressor whose start condition number exceeds this has dependent columns.
MAX_START_CONDITION = 1e10

#: Factor a random start or a finished plan is shrunk by per try, and the tries allowed.
SHRINK = 0.8
SHRINK_TRIES = 40

#: One of the caller's functions of the motion: ``(q, q', q'')``, each ``(N, n)``.
MotionFunction = Callable[[np.ndarray, np.ndarray, np.ndarray], np.ndarray]
Derivatives = tuple[np.ndarray, np.ndarray, np.ndarray]


@dataclass(frozen=True)
class FourierTrajectory:
    """The finite Fourier series of Swevers et al. (1997), per joint ``j`` (module
    docstring): ``q0[j]`` (rad), ``a[j][k - 1]`` and ``b[j][k - 1]`` (rad/s, the
    velocity amplitudes of harmonic ``k``), ``period`` ``T_p = 2 pi / w_f`` (s).

    Tuples, so the trajectory compares and hashes by value (``from_arrays`` builds one
    from arrays). It answers posfb's ``Trajectory`` protocol (``joints``, ``evaluate``)
    and is periodic for every ``t``."""

    q0: tuple[float, ...]
    a: tuple[tuple[float, ...], ...]
    b: tuple[tuple[float, ...], ...]
    period: float

    def __post_init__(self) -> None:
        require_positive("period", self.period)
        q0, a, b = self._arrays
        if a.ndim != 2 or a.shape[0] == 0 or a.shape[1] == 0 or a.shape != b.shape:
            raise ValueError(
                f"a has shape {list(a.shape)} and b {list(b.shape)}; equal shapes "
                "(joints, harmonics), both at least 1, are required"
            )
        if q0.shape != (a.shape[0],):
            raise ValueError(
                f"q0 has shape {list(q0.shape)}; one entry per joint ({a.shape[0]}) is required"
            )
        if not all(np.all(np.isfinite(x)) for x in (q0, a, b)):
            raise ValueError("q0, a or b has a non-finite entry; finite coefficients are required")

    @classmethod
    def from_arrays(
        cls, q0: np.ndarray, a: np.ndarray, b: np.ndarray, period: float
    ) -> FourierTrajectory:
        """The trajectory of ``(n,)`` offsets and ``(n, H)`` coefficient arrays."""
        return cls(
            tuple(float(v) for v in np.ravel(q0)),
            tuple(tuple(float(v) for v in row) for row in np.atleast_2d(a)),
            tuple(tuple(float(v) for v in row) for row in np.atleast_2d(b)),
            float(period),
        )

    @functools.cached_property
    def _arrays(self) -> Derivatives:
        return tuple(np.asarray(x, dtype=float) for x in (self.q0, self.a, self.b))

    @property
    def joints(self) -> int:
        return len(self.q0)

    @property
    def harmonics(self) -> int:
        return len(self.a[0])

    @property
    def base_frequency(self) -> float:
        """``w_f = 2 pi / T_p`` (rad/s)."""
        return 2.0 * math.pi / self.period

    def sample(self, t: float | np.ndarray) -> Derivatives:
        """``(q, q', q'')`` at the times ``t`` (s), each of shape ``(N, n)``: the series
        and its analytic derivatives (module docstring)."""
        q0, a, b = self._arrays
        times = np.atleast_1d(np.asarray(t, dtype=float)).ravel()
        frequency = self.base_frequency * np.arange(1, self.harmonics + 1)  # w_f k
        phase = times[:, None] * frequency[None, :]
        sine, cosine = np.sin(phase), np.cos(phase)
        q = q0 + (sine / frequency) @ a.T - (cosine / frequency) @ b.T
        qdot = cosine @ a.T + sine @ b.T
        qddot = -(sine * frequency) @ a.T + (cosine * frequency) @ b.T
        return q, qdot, qddot

    def evaluate(self, t: float) -> Derivatives:
        """``(q, q', q'')`` at one time ``t`` (s), each of shape ``(n,)``."""
        q, qdot, qddot = self.sample(t)
        return q[0], qdot[0], qddot[0]


@dataclass(frozen=True)
class ExcitationPlan:
    """An optimised excitation (``plan_excitation``): the ``trajectory``, at rest at
    ``rest`` (rad) at ``t = 0`` and ``t = duration`` (s); the scaled-column condition
    number of its regressor at the random start it was optimised from and after; and the
    check at every ``sample_time`` of ``[0, duration]`` against the limits themselves:
    ``limits_met``, per joint the smallest distance to a joint limit ``position_margin``
    (rad, negative outside), the peaks of ``|q'|`` (rad/s) and ``|u|`` (V). ``iterations``
    and ``message`` are the optimiser's (the best start's)."""

    trajectory: FourierTrajectory
    rest: tuple[float, ...]
    duration: float
    sample_time: float
    condition_start: float
    condition: float
    limits_met: bool
    position_margin: tuple[float, ...]
    peak_velocity: tuple[float, ...]
    peak_voltage: tuple[float, ...]
    iterations: int
    message: str

    def sample_times(self, sample_time: float | None = None) -> np.ndarray:
        """``0, T_s, .., duration`` (s; default ``T_s``: the plan's), ending exactly at
        the duration, which must be a whole number of them."""
        step = self.sample_time if sample_time is None else sample_time
        return _sample_times(self.duration, step, "sample_time")


def per_sample(function: Callable[..., np.ndarray]) -> MotionFunction:
    """The vectorised form of a per-sample ``function(q, q', q'')`` (one state of
    ``(n,)`` vectors, as ``LumpedModel.inverse_dynamics`` or
    ``SerialArmModel.inverse_dynamics``): its results stacked over the rows of the
    ``(N, n)`` arrays."""

    def vectorised(q: np.ndarray, qdot: np.ndarray, qddot: np.ndarray) -> np.ndarray:
        return np.array([function(*state) for state in zip(q, qdot, qddot, strict=True)])

    return vectorised


@dataclass(frozen=True, eq=False)
class _Limits:
    """The limits as the optimiser and the final check use them (``(n,)`` arrays)."""

    lower: np.ndarray
    upper: np.ndarray
    velocity: np.ndarray
    voltage: np.ndarray

    def tightened(self, margin: float) -> _Limits:
        inset = margin * (self.upper - self.lower)
        return _Limits(
            self.lower + inset,
            self.upper - inset,
            (1.0 - margin) * self.velocity,
            (1.0 - margin) * self.voltage,
        )

    def met(self, q: np.ndarray, qdot: np.ndarray, u: np.ndarray) -> bool:
        return bool(
            np.all(q >= self.lower)
            and np.all(q <= self.upper)
            and np.all(np.abs(qdot) <= self.velocity)
            and np.all(np.abs(u) <= self.voltage)
        )


class _Problem:
    """The optimisation in free coordinates ``x`` (``n`` blocks of ``2 (H - 1)``, joint
    ``j``'s scaled by its velocity limit): ``a_j = s_j N_a x_j[:H-1]``, ``b_j = s_j N_b
    x_j[H-1:]`` (module docstring), the grid's motion linear in ``x``."""

    def __init__(
        self,
        regressor: MotionFunction,
        voltage: MotionFunction,
        rest: np.ndarray,
        period: float,
        harmonics: int,
        scale: np.ndarray,
        limits: _Limits,
    ) -> None:
        self.regressor, self.voltage = regressor, voltage
        self.rest, self.period, self.scale = rest, period, scale
        self.joints, self.free = len(rest), 2 * (harmonics - 1)
        k = np.arange(1, harmonics + 1, dtype=float)
        self.null = (null_space(np.ones((1, harmonics))), null_space(k[None, :]))
        frequency = 2.0 * math.pi / period * k
        phase = (np.arange(GRID_POINTS) + 0.5) / GRID_POINTS * period * frequency[:, None]
        sine, cosine = np.sin(phase).T, np.cos(phase).T  # (GRID_POINTS, H)
        na, nb = self.null
        self.bases = tuple(  # position (less rest), velocity, acceleration per free coordinate
            np.hstack([sa @ na, sb @ nb])
            for sa, sb in (
                (sine / frequency, (1.0 - cosine) / frequency),
                (cosine, sine),
                (-sine * frequency, cosine * frequency),
            )
        )
        # Linear constraints G x + h >= 0: joint limits, then velocity limits, joint-major.
        jq, jv = (np.kron(np.diag(scale), basis) for basis in self.bases[:2])
        low, high = (
            np.repeat(limits.lower - rest, GRID_POINTS),
            np.repeat(limits.upper - rest, GRID_POINTS),
        )
        speed = np.repeat(limits.velocity, GRID_POINTS)
        self.linear_matrix = np.vstack([-jq, jq, -jv, jv])
        self.linear_offset = np.concatenate([high, -low, speed, speed])
        self.voltage_bound = np.repeat(limits.voltage, GRID_POINTS)
        self._cache: dict[str, tuple[bytes, object]] = {}

    def coefficients(self, x: np.ndarray) -> FourierTrajectory:
        """The trajectory of free coordinates ``x``, at rest at ``rest`` at ``t = 0``."""
        blocks = x.reshape(self.joints, self.free) * self.scale[:, None]
        half = self.free // 2
        na, nb = self.null
        a, b = blocks[:, :half] @ na.T, blocks[:, half:] @ nb.T
        frequency = 2.0 * math.pi / self.period * np.arange(1, a.shape[1] + 1)
        q0 = self.rest + (b / frequency).sum(axis=1)
        return FourierTrajectory.from_arrays(q0, a, b, self.period)

    def _motion(self, x: np.ndarray) -> tuple[np.ndarray, ...]:
        """The grid's ``(q, q', q'')`` at ``x``, each ``(GRID_POINTS, n)``."""
        blocks = x.reshape(self.joints, self.free)
        velocity, acceleration = ((basis @ blocks.T) * self.scale for basis in self.bases[1:])
        return self.rest + (self.bases[0] @ blocks.T) * self.scale, velocity, acceleration

    def _call(self, motion: tuple[np.ndarray, ...]) -> tuple[np.ndarray, np.ndarray]:
        """The regressor ``(B, GRID_POINTS, n, p)`` and the voltages ``(B, GRID_POINTS, n)``
        of ``B`` grid motions stacked in ``(B GRID_POINTS, n)`` arrays."""
        rows = motion[0].shape[0]
        Y = checked_output("regressor", self.regressor(*motion), (rows, self.joints), 3)
        u = checked_output("voltage", self.voltage(*motion), (rows, self.joints), 2)
        count = rows // GRID_POINTS
        return Y.reshape(count, GRID_POINTS, *Y.shape[1:]), u.reshape(count, GRID_POINTS, -1)

    def _stacked(self, Y: np.ndarray) -> np.ndarray:
        return Y.reshape(GRID_POINTS * self.joints, Y.shape[-1])

    def evaluate(self, x: np.ndarray) -> tuple[float, np.ndarray]:
        """``(log10 cond, voltages on the grid (GRID_POINTS, n))`` at ``x``."""
        key = x.tobytes()
        cached = self._cache.get("value")
        if cached is None or cached[0] != key:
            Y, u = self._call(self._motion(x))
            cached = (key, (float(log_condition(self._stacked(Y[0])[None])[0]), u[0]))
            self._cache["value"] = cached
        return cached[1]  # type: ignore[return-value]

    def linearise(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The gradient of ``log10 cond`` ``(n_x,)`` and the Jacobian of the grid's
        voltages ``(n GRID_POINTS, n_x)`` (rows joint-major) at ``x``.

        The caller's functions act sample by sample, so one call on the grid's motion and
        on its ``3 n`` forward-difference steps in ``q_j``, ``q_j'`` and ``q_j''`` gives
        their derivatives in the state; the chain rule through the (linear) bases gives
        those in ``x``, and the singular values' own derivatives (``d sigma = u^T dA v``
        of the column-normalised ``A``) the objective's."""
        key = x.tobytes()
        cached = self._cache.get("slope")
        if cached is None or cached[0] != key:
            motion = self._motion(x)
            steps = 3 * self.joints
            stacks = []
            for order, state in enumerate(motion):
                stack = np.repeat(state[None], steps + 1, axis=0)
                joint = np.arange(self.joints)
                stack[1 + order * self.joints + joint, :, joint] += DIFFERENCE_STEP
                stacks.append(stack.reshape(-1, self.joints))
            Y, u = self._call(tuple(stacks))
            shape = (3, self.joints, GRID_POINTS)
            dY = ((Y[1:] - Y[0]) / DIFFERENCE_STEP).reshape(*shape, *Y.shape[2:])
            du = ((u[1:] - u[0]) / DIFFERENCE_STEP).reshape(*shape, self.joints)
            bases, scale = np.stack(self.bases), self.scale[:, None, None, None]
            dY_x = np.einsum("otl,ojtrc->jltrc", bases, dY) * scale[..., None]
            du_x = np.einsum("otl,ojtr->jltr", bases, du) * scale
            gradient = log_condition_gradient(
                self._stacked(Y[0]), dY_x.reshape(x.size, GRID_POINTS * self.joints, -1)
            )
            rows = du_x.reshape(x.size, GRID_POINTS, self.joints).transpose(2, 1, 0)
            cached = (key, (gradient, rows.reshape(-1, x.size)))
            self._cache["slope"] = cached
        return cached[1]  # type: ignore[return-value]

    def voltage_margin(self, x: np.ndarray) -> np.ndarray:
        """``(1 - margin) voltage_limit -+ u`` on the grid (>= 0 where met)."""
        u = self.evaluate(x)[1].T.ravel()
        return np.concatenate([self.voltage_bound - u, self.voltage_bound + u])

    def voltage_margin_jacobian(self, x: np.ndarray) -> np.ndarray:
        """The Jacobian of ``voltage_margin``."""
        slope = self.linearise(x)[1]
        return np.vstack([-slope, slope])

    def largest_linear_scale(self, x: np.ndarray) -> float:
        """The largest ``s`` for which ``s x`` meets the (tightened) position and velocity
        limits on the grid (``h > 0``: the rest meets them)."""
        rate = self.linear_matrix @ x
        shrinking = rate < 0.0
        return float(np.min(self.linear_offset[shrinking] / -rate[shrinking], initial=np.inf))

    def optimise(
        self, start: np.ndarray, max_iterations: int, step: Callable[[], None] | None = None
    ) -> tuple[np.ndarray, int, str]:
        """SLSQP from ``start``: ``(x, iterations, message)``; ``step()`` after each
        iteration."""
        constraints = [
            {
                "type": "ineq",
                "fun": lambda x: self.linear_matrix @ x + self.linear_offset,
                "jac": lambda x: self.linear_matrix,
            },
            {
                "type": "ineq",
                "fun": self.voltage_margin,
                "jac": self.voltage_margin_jacobian,
            },
        ]
        result = minimize(
            lambda x: self.evaluate(x)[0],
            start,
            jac=lambda x: self.linearise(x)[0],
            method="SLSQP",
            constraints=constraints,
            options={"maxiter": max_iterations, "ftol": 1e-6},
            callback=None if step is None else (lambda *_: step()),
        )
        return np.asarray(result.x, dtype=float), int(result.nit), str(result.message)


def log_condition(stacked: np.ndarray) -> np.ndarray:
    """``log10 cond`` of each ``(rows, p)`` matrix of ``stacked`` ``(B, rows, p)`` with its
    columns divided by their Euclidean norms; ``SINGULAR`` where one is singular."""
    norms = np.linalg.norm(stacked, axis=1, keepdims=True)
    singular = np.linalg.svd(stacked / np.where(norms > 0.0, norms, 1.0), compute_uv=False)
    with np.errstate(divide="ignore", invalid="ignore"):
        value = np.log10(singular[:, 0]) - np.log10(singular[:, -1])
    return np.nan_to_num(np.minimum(value, SINGULAR), nan=SINGULAR)


def log_condition_gradient(Y: np.ndarray, directions: np.ndarray) -> np.ndarray:
    """The derivative of ``log_condition`` of ``Y`` ``(rows, p)`` along each of
    ``directions`` ``(K, rows, p)``: with ``A = Y diag(1/|y_c|)`` and its extreme singular
    triplets ``(sigma, u, v)``, ``d sigma = u^T dA v``, ``dA_c = (dy_c - a_c a_c^T dy_c) /
    |y_c|``, ``d log10 cond = (d sigma_1/sigma_1 - d sigma_p/sigma_p) / ln 10``."""
    norms = np.linalg.norm(Y, axis=0)
    A = Y / norms
    U, singular, Vt = np.linalg.svd(A, full_matrices=False)
    dA = (directions - A * np.einsum("rc,krc->kc", A, directions)[:, None, :]) / norms
    largest = np.einsum("r,krc,c->k", U[:, 0], dA, Vt[0])
    smallest = np.einsum("r,krc,c->k", U[:, -1], dA, Vt[-1])
    return (largest / singular[0] - smallest / singular[-1]) / math.log(10.0)


def checked_output(name: str, value: object, leading: tuple[int, int], ndim: int) -> np.ndarray:
    """``value`` of the caller's function ``name`` as a finite float array of ``ndim``
    dimensions starting with ``leading`` (samples, joints)."""
    array = np.asarray(value, dtype=float)
    if array.ndim != ndim or array.shape[:2] != leading or (ndim == 3 and array.shape[2] == 0):
        wanted = "(N, joints, parameters)" if ndim == 3 else "(N, joints)"
        raise ValueError(
            f"{name} returned shape {list(array.shape)} for N = {leading[0]} samples; "
            f"{wanted} = {list(leading)}{' + [p >= 1]' if ndim == 3 else ''} is required"
        )
    if not np.all(np.isfinite(array)):
        raise ValueError(f"{name} returned a non-finite entry; finite values are required")
    return array


def _whole(name: str, value: float, unit_name: str, unit: float) -> int:
    """``value / unit`` when it is a whole number >= 1 (to 1e-9 relative)."""
    count = round(value / unit)
    if count < 1 or abs(count * unit - value) > 1e-9 * value:
        raise ValueError(
            f"{name} = {shown(value)} s is not a whole number (>= 1) of {unit_name} = "
            f"{shown(unit)} s; a whole number of them is required"
        )
    return count


def _sample_times(duration: float, sample_time: float, name: str) -> np.ndarray:
    require_positive(name, sample_time)
    samples = _whole("duration", duration, name, sample_time)
    return np.linspace(0.0, duration, samples + 1)


def _require_count(
    name: str, value: object, fewest: int, most: int | None = None, reason: str = ""
) -> int:
    if isinstance(value, bool) or not isinstance(value, int | np.integer):
        raise ValueError(f"{name} = {shown(value)} is not an integer; an integer is required")
    if value < fewest or (most is not None and value > most):
        allowed = f"at least {fewest}" if most is None else f"{fewest} to {most}"
        raise ValueError(f"{name} = {shown(value)}; an integer {allowed} is required{reason}")
    return int(value)


def _per_joint_positive(name: str, value: Sequence[float] | np.ndarray, joints: int) -> np.ndarray:
    array = require_vector(name, value, joints)
    if np.any(array <= 0.0):
        raise ValueError(f"{name} = {array.tolist()}; values > 0 are required")
    return array


def _validated_limits(
    joints: int,
    rest: np.ndarray,
    joint_limits: tuple[Sequence[float], Sequence[float]],
    velocity_limit: Sequence[float] | np.ndarray,
    voltage_limit: Sequence[float] | np.ndarray,
    margin: float,
) -> _Limits:
    if len(joint_limits) != 2:
        raise ValueError(
            f"joint_limits has {len(joint_limits)} entries; (lower, upper) is required"
        )
    lower = require_vector("joint_limits lower", joint_limits[0], joints)
    upper = require_vector("joint_limits upper", joint_limits[1], joints)
    if np.any(lower >= upper):
        raise ValueError(
            f"joint_limits = ({lower.tolist()}, {upper.tolist()}); lower < upper is required"
        )
    limits = _Limits(
        lower,
        upper,
        _per_joint_positive("velocity_limit", velocity_limit, joints),
        _per_joint_positive("voltage_limit", voltage_limit, joints),
    )
    inner = limits.tightened(margin)
    outside = (rest <= inner.lower) | (rest >= inner.upper)
    if np.any(outside):
        j = int(np.argmax(outside))
        raise ValueError(
            f"joint_limits[{j}] = [{lower[j]:g}, {upper[j]:g}] rad: rest[{j}] = {rest[j]:g} rad "
            f"is not inside [{inner.lower[j]:g}, {inner.upper[j]:g}] (the range less the margin "
            f"{margin:g} of it at each end); limits holding the rest with that margin are required"
        )
    return limits


def plan_excitation(
    regressor: MotionFunction,
    voltage: MotionFunction,
    *,
    joints: int,
    rest: Sequence[float] | np.ndarray,
    duration: float,
    harmonics: int,
    base_period: float | None = None,
    sample_time: float,
    joint_limits: tuple[Sequence[float], Sequence[float]],
    velocity_limit: Sequence[float] | np.ndarray,
    voltage_limit: Sequence[float] | np.ndarray,
    seed: int,
    max_iterations: int = 100,
    starts: int = STARTS,
    margin: float = LIMIT_MARGIN,
    progress: Callable[[int, int], None] | None = None,
) -> ExcitationPlan:
    """The Fourier excitation of ``harmonics`` harmonics per joint (module docstring)
    that minimises the scaled-column condition number of the stacked regressor, at rest
    at ``rest`` (rad) at ``t = 0`` and ``t = duration`` (s), within ``joint_limits``
    (``(lower, upper)``, rad), ``velocity_limit`` (rad/s) and ``voltage_limit`` (V), one
    entry per joint.

    ``regressor(q, q', q'')`` returns ``(N, joints, p)`` and ``voltage(q, q', q'')``
    ``(N, joints)`` for ``(N, joints)`` motions (``per_sample`` vectorises a per-sample
    model; row ``i`` of either may depend on sample ``i``'s state only, as any inverse
    dynamics does); the regressor's ``p`` parameters must be identifiable (base
    parameters: its columns independent on an exciting motion).
    ``base_period`` (default: the duration) must divide the duration into whole periods;
    ``sample_time`` (s) is the CSV's and the final check's step, a whole fraction of the
    duration and at most ``base_period / (10 harmonics)`` (ten samples per cycle of the
    highest harmonic, so also at most ``duration / 10``). ``starts`` random starts are drawn
    from ``numpy.random.default_rng(seed)``, each scaled towards rest until it meets the
    tightened limits on the grid, each optimised by SLSQP for at most ``max_iterations``
    iterations; the plan is the best that meets the limits at every sample time.
    ``progress(start, iteration)`` (0-based start, iterations done) is called as the
    search goes; it does not change the plan.

    Every argument is checked; limits that no motion meets (a rest outside the joint
    limits, a voltage limit below the voltage that holds the arm at rest) raise a
    ValueError naming the argument."""
    joints = _require_count("joints", joints, 1)
    rest_array = require_vector("rest", rest, joints)
    duration = require_positive("duration", duration)
    harmonics = _require_count(
        "harmonics",
        harmonics,
        2,
        MAX_HARMONICS,
        " (the rest conditions leave 2 (harmonics - 1) free coefficients per joint; the grid "
        f"has {GRID_POINTS} points per period)",
    )
    period = duration if base_period is None else require_positive("base_period", base_period)
    _whole("duration", duration, "base_period", period)
    sample_time = require_positive("sample_time", sample_time)
    if sample_time > period / (10 * harmonics):
        raise ValueError(
            f"sample_time = {shown(sample_time)} s; at most base_period / (10 harmonics) = "
            f"{period / (10 * harmonics):g} s is required (10 samples per cycle of the "
            "highest harmonic)"
        )
    times = _sample_times(duration, sample_time, "sample_time")
    _require_count("seed", seed, 0)
    max_iterations = _require_count("max_iterations", max_iterations, 1)
    starts = _require_count("starts", starts, 1)
    margin = require_nonnegative("margin", margin)
    if margin >= 0.5:
        raise ValueError(f"margin = {shown(margin)}; a share in [0, 0.5) is required")
    if not callable(regressor) or not callable(voltage):
        raise ValueError("regressor and voltage must be callable (q, qdot, qddot) -> array")
    limits = _validated_limits(
        joints, rest_array, joint_limits, velocity_limit, voltage_limit, margin
    )
    inner = limits.tightened(margin)
    zero = np.zeros((1, joints))
    hold = checked_output("voltage", voltage(rest_array[None], zero, zero), (1, joints), 2)[0]
    if np.any(np.abs(hold) >= inner.voltage):
        j = int(np.argmax(np.abs(hold) >= inner.voltage))
        raise ValueError(
            f"voltage_limit[{j}] = {limits.voltage[j]:g} V is not above the "
            f"{abs(hold[j]):.4g} V that holds joint {j + 1} at rest with the margin "
            f"{margin:g}; a limit above {abs(hold[j]) / (1.0 - margin):.4g} V is required"
        )
    problem = _Problem(regressor, voltage, rest_array, period, harmonics, limits.velocity, inner)
    rng = np.random.default_rng(seed)
    plans = []
    with threadpool_limits(1):  # small matrices: one BLAS thread is faster, and repeatable
        for index in range(starts):
            start = _feasible_start(problem, rng, limits)
            start_value = problem.evaluate(start)[0]
            if 10.0**start_value > MAX_START_CONDITION:
                raise ValueError(
                    f"regressor has condition number {10.0**start_value:.3g} on the random "
                    f"start (above {MAX_START_CONDITION:g}): its columns are dependent; a "
                    "regressor of identifiable (base) parameters is required"
                )
            x, iterations, message = problem.optimise(
                start, max_iterations, None if progress is None else _counted(progress, index)
            )
            checked = _checked(problem, x, start, times, limits)
            plans.append(
                ExcitationPlan(
                    **checked,
                    rest=tuple(float(v) for v in rest_array),
                    duration=duration,
                    sample_time=sample_time,
                    condition_start=10.0**start_value,
                    iterations=iterations,
                    message=message,
                )
            )
    return max(plans, key=lambda plan: (plan.limits_met, -plan.condition))


def _counted(progress: Callable[[int, int], None], start: int) -> Callable[[], None]:
    """A step callback that tells ``progress(start, iterations done)``, beginning at 0."""
    done = itertools.count(1)
    progress(start, 0)
    return lambda: progress(start, next(done))


def _feasible_start(problem: _Problem, rng: np.random.Generator, limits: _Limits) -> np.ndarray:
    """A random ``x`` (standard normal over ``sqrt(n_x / n)``: velocity amplitudes of the
    order of the limits) scaled to 90 % of the largest that meets the tightened position
    and velocity limits on the grid, then by ``SHRINK`` until it meets the voltage limit."""
    x = rng.standard_normal(problem.joints * problem.free) / math.sqrt(problem.free)
    x *= 0.9 * min(1.0, problem.largest_linear_scale(x))
    for _ in range(SHRINK_TRIES):
        if np.all(problem.voltage_margin(x) >= 0.0):
            return x
        x = x * SHRINK
    peak = np.max(np.abs(problem.evaluate(x)[1]), axis=0)
    raise ValueError(
        f"voltage_limit = {limits.voltage.tolist()} V leaves the arm no motion: the "
        f"smallest tried needs up to {np.round(peak, 4).tolist()} V (gravity and friction "
        "near rest); limits above that are required"
    )


def _checked(
    problem: _Problem, x: np.ndarray, start: np.ndarray, times: np.ndarray, limits: _Limits
) -> dict[str, object]:
    """The trajectory of ``x`` checked at ``times`` against ``limits`` (the plan's fields
    ``trajectory``, ``condition`` and the check's); shrunk towards rest by ``SHRINK``
    until it meets them there, else ``start``'s."""
    for candidate in [x * SHRINK**i for i in range(SHRINK_TRIES)] + [start]:
        trajectory = problem.coefficients(candidate)
        q, qdot, qddot = trajectory.sample(times)
        u = checked_output("voltage", problem.voltage(q, qdot, qddot), q.shape, 2)
        if limits.met(q, qdot, u):
            break
    return {
        "trajectory": trajectory,
        "condition": 10.0 ** problem.evaluate(candidate)[0],
        "limits_met": limits.met(q, qdot, u),
        "position_margin": tuple(
            float(v) for v in np.minimum(q - limits.lower, limits.upper - q).min(axis=0)
        ),
        "peak_velocity": tuple(float(v) for v in np.abs(qdot).max(axis=0)),
        "peak_voltage": tuple(float(v) for v in np.abs(u).max(axis=0)),
    }


def write_trajectory_csv(
    plan: ExcitationPlan, path: str | Path, sample_time: float | None = None
) -> Path:
    """Write the plan's positions as posfb's ``trajectory: !CsvFile {path: ...}`` reads
    them (``diagrams.resolve.read_csv_trajectory``): a header ``time_s,q1_rad,..,qn_rad``,
    then one row per sample time ``0, T_s, .., duration`` (s; default ``T_s``: the plan's)
    with the positions (rad), every number in its shortest exact decimal form. The reader
    takes positions only (it refuses other columns; velocity and acceleration are its
    spline's derivatives), so the file holds nothing else. The first and last rows are
    the rest position."""
    times = plan.sample_times(sample_time)
    q = plan.trajectory.sample(times)[0]
    header = ",".join(["time_s", *(f"q{j + 1}_rad" for j in range(q.shape[1]))])
    rows = (",".join(repr(float(v)) for v in (t, *row)) for t, row in zip(times, q, strict=True))
    target = Path(path)
    target.write_text("\n".join([header, *rows]) + "\n")
    return target
