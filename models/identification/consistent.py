"""A physically consistent standard model whose base parameters match an estimate (issue 29).

An estimate ``beta_hat`` of the base parameters (``serial_regressor.base_parameters``:
``beta = K pi``) says nothing about the standard parameters ``pi`` outside ``K``'s row
space, and a least-squares ``beta_hat`` may even lie where no physical arm does.
``fit_consistent`` finds a standard vector that is physically consistent (Wensing, Kim &
Slotine 2017, "Linear matrix inequalities for physically consistent inertial parameter
identification") and whose ``K pi`` is closest to ``beta_hat`` in the estimate's own
metric, the rest of it held near a prior (the nominal URDF's).

Consistency: each link's 4 x 4 pseudo-inertia (``pseudo_inertia``)::

    J = [[Sigma, h], [h^T, m]],   Sigma = tr(I)/2 E - I = sum m r r^T

(``h = m c``, ``I`` about the link origin, as in ``pi``) is positive definite, which holds
exactly when the link's mass, centre of mass and inertia are those of a positive density
(the triangle inequalities on the principal moments included). Every consistent link is
one point of the log-Cholesky coordinates (Rucker & Wensing 2022, "Smooth
parameterization of rigid-body inertia"), ``theta = (alpha, d1, d2, d3, s12, s23, s13,
t1, t2, t3)`` (``LOG_CHOLESKY``)::

    J = U U^T,   U = e^alpha [[e^d1, s12, s13, t1],
                              [0,    e^d2, s23, t2],
                              [0,    0,    e^d3, t3],
                              [0,    0,    0,    1 ]]

and every real ``theta`` is a consistent link (``m = e^(2 alpha) > 0``):
``log_cholesky_parameters`` and ``log_cholesky_coordinates`` map between them, e.g. to
draw or perturb consistent links. ``fit_consistent`` itself works on the standard
parameters, where its problem is convex (its docstring says why).

``write_urdf`` writes the fitted model as a URDF that ``models.plant`` loads.
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import scipy.linalg

from posfb.models.description import Description, prepare_urdf
from posfb.models.identification.serial_regressor import DRIVE_PARAMETERS, BaseParameters
from posfb.models.urdf_check import check_serial_urdf
from posfb.models.urdf_tree import (
    DRAKE_NS,
    POSFB_NAMESPACES,
    POSFB_NS,
    actuator_of,
    parse_robot,
)
from posfb.models.validation import require_finite, shown

#: How far ``beta_cov`` may be from symmetric, relative to ``sigma_i sigma_j``: far above
#: the round-off of any covariance computed in double precision, far below a mistake.
SYMMETRY_TOLERANCE = 1e-8

#: The log-Cholesky coordinates of one link, in order (module docstring).
LOG_CHOLESKY = ("alpha", "d1", "d2", "d3", "s12", "s23", "s13", "t1", "t2", "t3")

#: A prior link whose pseudo-inertia has an eigenvalue below this share of its largest
#: (a point mass, a thin rod) is moved to the nearest one with that share
#: (``consistent_link``).
PRIOR_MARGIN = 1e-6

#: ``fit_consistent``'s default weight of the pull towards the prior.
DEFAULT_REGULARISATION = 1e-4

#: The barrier method of ``fit_consistent``: the factor its barrier weight falls by per
#: stage, the Newton decrement (squared, over the weight) that ends a stage and the last
#: one, and the Newton steps allowed per stage.
BARRIER_FACTOR = 10.0
CENTRING = 1e-2
FINAL_DECREMENT = 1e-12
NEWTON_STEPS = 100

#: The link named so is a tip payload point; ``write_urdf`` leaves it as it is if it has
#: no mass (``models.plant.PAYLOAD_BODY``).
PAYLOAD_LINK = "payload"


def _link_vector(name: str, value: object) -> np.ndarray:
    array = np.asarray(value, dtype=float)
    if array.shape != (10,) or not np.all(np.isfinite(array)):
        raise ValueError(
            f"{name} = {shown(array)}; 10 finite values (one link's {name}) are required"
        )
    return array


def _split(link: np.ndarray) -> tuple[float, np.ndarray, np.ndarray]:
    """``(m, h, I)`` of one link's standard parameters."""
    xx, yy, zz, xy, xz, yz = link[4:]
    return float(link[0]), link[1:4], np.array([[xx, xy, xz], [xy, yy, yz], [xz, yz, zz]])


def _pseudo_inertia(link: np.ndarray) -> np.ndarray:
    m, h, I = _split(link)
    J = np.zeros((4, 4))
    J[:3, :3] = 0.5 * np.trace(I) * np.eye(3) - I
    J[:3, 3] = J[3, :3] = h
    J[3, 3] = m
    return J


def pseudo_inertia(link: np.ndarray) -> np.ndarray:
    """The 4 x 4 pseudo-inertia ``J`` of one link's standard parameters ``[m, m cx, m cy,
    m cz, Ixx, Iyy, Izz, Ixy, Ixz, Iyz]`` (about and in the link frame; module
    docstring)."""
    return _pseudo_inertia(_link_vector("link", link))


def _standard_of(J: np.ndarray) -> np.ndarray:
    """The standard parameters of pseudo-inertias ``(..., 4, 4)`` (linear in ``J``)."""
    sigma = J[..., :3, :3]
    I = np.trace(sigma, axis1=-2, axis2=-1)[..., None, None] * np.eye(3) - sigma
    return np.stack(
        [J[..., 3, 3], J[..., 0, 3], J[..., 1, 3], J[..., 2, 3], I[..., 0, 0], I[..., 1, 1],
         I[..., 2, 2], I[..., 0, 1], I[..., 0, 2], I[..., 1, 2]],
        axis=-1,
    )  # fmt: skip


#: ``J = sum_k pi_k _BASIS[k]`` for one link's standard parameters ``pi``.
_BASIS = np.stack([_pseudo_inertia(unit) for unit in np.eye(10)])

#: Where each of ``LOG_CHOLESKY``'s ``d``, ``s`` and ``t`` sits in ``U`` (row, column).
_ENTRIES = ((0, 0), (1, 1), (2, 2), (0, 1), (1, 2), (0, 2), (0, 3), (1, 3), (2, 3))


def log_cholesky_parameters(theta: np.ndarray) -> np.ndarray:
    """One link's standard parameters from its log-Cholesky coordinates ``theta``
    (``LOG_CHOLESKY``; module docstring): consistent for every finite ``theta``."""
    theta = _link_vector("theta", theta)
    U = np.eye(4)
    with np.errstate(over="ignore", invalid="ignore"):
        for (row, column), value in zip(_ENTRIES, theta[1:], strict=True):
            U[row, column] = np.exp(value) if row == column else value
        link = _standard_of(np.exp(theta[0]) ** 2 * (U @ U.T))
    if not np.all(np.isfinite(link)):
        raise ValueError(
            f"theta = {shown(theta)} overflows; coordinates whose link is finite are required"
        )
    return link


def log_cholesky_coordinates(link: np.ndarray) -> np.ndarray:
    """The log-Cholesky coordinates of one consistent link (the inverse of
    ``log_cholesky_parameters``): ``U`` is the upper-triangular factor of ``J = U U^T``,
    the Cholesky factor of ``J`` with its rows and columns reversed."""
    J = pseudo_inertia(link)
    reverse = np.eye(4)[::-1]
    try:
        L = np.linalg.cholesky(reverse @ J @ reverse)
    except np.linalg.LinAlgError:
        raise ValueError(
            f"link = {shown(np.asarray(link))}; a physically consistent link (positive-"
            "definite pseudo-inertia) is required"
        ) from None
    U = reverse @ L @ reverse
    V = U / U[3, 3]
    rest = [math.log(V[r, c]) if r == c else V[r, c] for r, c in _ENTRIES]
    return np.array([math.log(U[3, 3]), *rest])


def consistent_link(link: np.ndarray, margin: float = PRIOR_MARGIN) -> np.ndarray:
    """``link`` (standard parameters) if its pseudo-inertia's eigenvalues all exceed
    ``margin`` times the largest; otherwise the link whose pseudo-inertia has those
    eigenvalues raised to that bound (same eigenvectors: the nearest such link in the
    Frobenius norm of ``J``). ``margin`` in ``(0, 1)``."""
    if not (isinstance(margin, float | int) and 0.0 < margin < 1.0):
        raise ValueError(f"margin = {margin!r}; a number in (0, 1) is required")
    values, vectors = np.linalg.eigh(pseudo_inertia(link))
    floor = margin * max(float(values[-1]), 0.0)
    if floor == 0.0:
        raise ValueError(
            f"link = {shown(np.asarray(link))}: its pseudo-inertia has no positive "
            "eigenvalue; a link with some mass is required"
        )
    if values[0] > floor:
        return np.asarray(link, dtype=float).copy()
    return _standard_of((vectors * np.maximum(values, floor)) @ vectors.T)


@dataclass(frozen=True)
class LinkInertia:
    """One link of a consistent model: ``mass`` (kg), centre of mass ``com`` (m, in the
    link frame) and ``inertia`` about the centre of mass in the link frame (kg m^2, 3 x 3;
    what a URDF's ``<inertial>`` with ``rpy = 0`` holds)."""

    name: str
    mass: float
    com: np.ndarray
    inertia: np.ndarray


@dataclass(frozen=True)
class DriveParameters:
    """One joint's drive: the reflected ``rotor_inertia`` (kg m^2, rotor inertia x gear
    ratio^2), the viscous ``damping`` (N m s/rad) and the Coulomb level ``coulomb`` (N m)."""

    joint: str
    rotor_inertia: float
    damping: float
    coulomb: float


@dataclass(frozen=True, eq=False)
class ConsistentModel:
    """A consistent standard model (``fit_consistent``).

    ``standard``: the standard vector ``pi`` (``names``, ``serial_regressor``'s order);
    ``links`` and ``drives``: the same per link and per joint. ``beta``: its base
    parameters ``K pi``; ``standard_errors``: ``(beta - beta_hat) / sqrt(diag cov)``, each
    base parameter's misfit in its estimate's standard errors; ``mahalanobis``:
    ``|| L^-1 (beta - beta_hat) ||`` with ``cov = L L^T`` (about ``sqrt(p_base)`` for an
    estimate with that covariance around a consistent arm). ``converged``: whether the
    solver reached its final tolerance; ``newton_steps``: the Newton steps it took."""

    standard: np.ndarray
    names: tuple[str, ...]
    links: tuple[LinkInertia, ...]
    drives: tuple[DriveParameters, ...]
    beta: np.ndarray
    standard_errors: np.ndarray
    mahalanobis: float
    converged: bool
    newton_steps: int


def _covariance_factor(beta_cov: object, size: int) -> tuple[np.ndarray, np.ndarray]:
    """The lower Cholesky factor of ``beta_cov`` (variances ``(size,)`` or a covariance
    ``(size, size)``) and the standard deviations."""
    cov = np.asarray(beta_cov, dtype=float)
    if cov.shape == (size,):
        cov = np.diag(cov)
    if cov.shape != (size, size) or not np.all(np.isfinite(cov)):
        raise ValueError(
            f"beta_cov has shape {np.shape(beta_cov)}; {size} finite variances or a finite "
            f"({size}, {size}) covariance (one row per base parameter) is required"
        )
    scale = np.sqrt(np.abs(np.outer(np.diag(cov), np.diag(cov))))
    asymmetry = np.abs(cov - cov.T)
    if np.any(asymmetry > SYMMETRY_TOLERANCE * scale):
        worst = np.unravel_index(int(np.argmax(asymmetry - SYMMETRY_TOLERANCE * scale)), cov.shape)
        raise ValueError(
            f"beta_cov is not symmetric: entries {worst} and {worst[::-1]} differ by "
            f"{asymmetry[worst]:.3g}; a symmetric covariance (within {SYMMETRY_TOLERANCE:g} "
            "of sigma_i sigma_j) is required"
        )
    cov = 0.5 * (cov + cov.T)
    try:
        factor = np.linalg.cholesky(cov)
    except np.linalg.LinAlgError:
        raise ValueError(
            f"beta_cov has eigenvalues down to {np.linalg.eigvalsh(cov)[0]:g}; a positive-"
            "definite covariance is required"
        ) from None
    return factor, np.sqrt(np.diag(cov))


def _drive_priors(drive: np.ndarray) -> np.ndarray:
    """The drive priors ``r0`` (``(n, 3)``) the divergence measures from: the prior's
    values, negative ones raised to 0, and a 0 replaced by the largest prior of its kind
    (1 where all are 0), since ``r / r0`` needs ``r0 > 0``."""
    drive = np.maximum(drive, 0.0)
    largest = drive.max(axis=0)
    return np.where(drive > 0.0, drive, np.where(largest > 0.0, largest, 1.0))


@dataclass(frozen=True, eq=False)
class _Problem:
    """``fit_consistent``'s objective at barrier weight ``t``, in ``x = [pi_links, r / r0]``
    (``rows``: the whitened ``K`` with its drive columns times ``r0``)::

        Phi_t(x) = |rows x - target|^2 / 2 + weight (sum_i tr(J0_i^-1 J_i) + sum_j y_j)
                   - t (sum_i log det J_i + sum_j log y_j)

    ``Phi_t`` at ``t = weight`` is the fit's objective up to a constant."""

    rows: np.ndarray
    target: np.ndarray
    prior_inverse: np.ndarray
    weight: float

    @property
    def links(self) -> int:
        return self.prior_inverse.shape[0]

    def evaluate(self, x: np.ndarray, t: float) -> tuple[float, np.ndarray, np.ndarray] | None:
        """``Phi_t(x)`` and the Newton step's least squares ``A d ~ b`` (``A^T A`` is the
        Hessian, ``A^T b`` the gradient): the data rows, then per link
        ``sqrt(t) L^-1 dJ L^-T`` (``J = L L^T``), then ``sqrt(t) dy / y``. ``None`` outside
        the domain (a pseudo-inertia not positive definite, a drive parameter <= 0)."""
        n = self.links
        J = np.einsum("nk,kij->nij", x[: 10 * n].reshape(n, 10), _BASIS)
        y = x[10 * n :]
        try:
            L = np.linalg.cholesky(J)
        except np.linalg.LinAlgError:
            return None
        if np.any(y <= 0.0):
            return None
        misfit = self.rows @ x - self.target
        log_det = 2.0 * np.log(np.diagonal(L, axis1=1, axis2=2)).sum()
        linear = np.einsum("nij,nji->", self.prior_inverse, J) + y.sum()
        value = 0.5 * misfit @ misfit + self.weight * linear - t * (log_det + np.log(y).sum())
        root, ratio = math.sqrt(t), self.weight / t
        L_inv = np.linalg.inv(L)
        blocks = root * np.einsum("nai,kij,nbj->nabk", L_inv, _BASIS, L_inv).reshape(n, 16, 10)
        A = np.zeros((misfit.size + 19 * n, x.size))
        A[: misfit.size] = self.rows
        A[misfit.size : misfit.size + 16 * n, : 10 * n] = scipy.linalg.block_diag(*blocks)
        A[misfit.size + 16 * n :, 10 * n :] = np.diag(root / y)
        centred = np.swapaxes(L, 1, 2) @ (ratio * self.prior_inverse) @ L - np.eye(4)
        b = np.concatenate([misfit, root * centred.ravel(), root * (ratio * y - 1.0)])
        return value, A, b


def _newton(problem: _Problem, x: np.ndarray, t: float, tolerance: float) -> tuple:
    """Damped Newton on ``Phi_t`` from ``x`` (inside the domain) until the squared Newton
    decrement is ``<= tolerance * t``: ``(x, steps, reached)``. Each step solves its least
    squares with the rows sorted by norm and the columns scaled (accurate with the stiff
    weights of a tight covariance) and is halved until it stays inside and decreases
    ``Phi_t`` by at least ``1e-4`` of the decrement (Armijo)."""
    value, A, b = problem.evaluate(x, t)
    for steps in range(NEWTON_STEPS):
        order = np.argsort(-np.linalg.norm(A, axis=1))
        scale = np.linalg.norm(A, axis=0)
        step = scipy.linalg.lstsq(A[order] / scale, -b[order], lapack_driver="gelsy")[0] / scale
        decrement = -float((A.T @ b) @ step)
        if decrement <= tolerance * t:
            return x, steps, True
        length = 1.0
        while length > 1e-12:
            trial = x + length * step
            evaluated = problem.evaluate(trial, t)
            if evaluated is not None and evaluated[0] <= value - 1e-4 * length * decrement:
                break
            length *= 0.5
        else:
            return x, steps, False
        x, (value, A, b) = trial, evaluated
    return x, NEWTON_STEPS, False


def _link_inertia(name: str, link: np.ndarray) -> LinkInertia:
    m, h, I = _split(link)
    com = h / m
    central = I - m * (com @ com * np.eye(3) - np.outer(com, com))
    return LinkInertia(name=name, mass=m, com=com, inertia=central)


def fit_consistent(
    base: BaseParameters,
    beta_hat: np.ndarray,
    beta_cov: np.ndarray,
    prior: np.ndarray,
    regularisation: float = DEFAULT_REGULARISATION,
) -> ConsistentModel:
    """The consistent standard model closest to the estimate ``beta_hat`` (module
    docstring): the minimiser over the standard parameters ``pi`` (links ``J_i``, drive
    parameters ``r_j``) of::

        || L^-1 (K pi - beta_hat) ||^2 / 2
            + regularisation (sum_i d(J_i || J0_i) + sum_j phi(r_j / r0_j))

        d(J || J0) = tr(J0^-1 J) - log det(J0^-1 J) - 4,   phi(y) = y - log y - 1

    with ``beta_cov = L L^T`` (``(p_base,)`` variances or a ``(p_base, p_base)``
    covariance), ``J0_i`` the ``prior``'s links (the nominal standard vector,
    ``serial_regressor.true_parameters`` of the nominal arm) made consistent by
    ``consistent_link``, ``r0`` its drive parameters (negative ones raised to 0, a 0
    replaced by the largest prior of its kind, 1 where all are 0). The first term
    is the misfit in the estimate's standard errors. The second (``regularisation > 0``)
    is the entropic divergence of each pseudo-inertia from the prior's (Lee, Wensing &
    Park 2020, "Geometric robot dynamic identification: a convex programming approach")
    and its one-dimensional analogue for the drive: 0 at the prior, about half the
    squared relative change near it, infinite at the boundary (a pseudo-inertia losing
    rank, a drive parameter reaching 0), so the fit is strictly consistent and holds the
    directions ``K`` does not see at the prior; elsewhere it costs ``regularisation``
    times that change.

    The problem is convex in ``pi`` (a quadratic, linear terms and ``-log det``), solved
    by the barrier method (Boyd & Vandenberghe 2004, "Convex optimization", Sec. 11.3):
    damped Newton (``_newton``) on ``_Problem``'s ``Phi_t`` for barrier weights ``t``
    from ``|misfit at the prior|^2`` down by ``BARRIER_FACTOR`` per stage to
    ``regularisation``, each stage from the last one's solution. (In the log-Cholesky
    coordinates the same problem is unconstrained but not convex, and stiff with a
    tight covariance: ``scipy.optimize.least_squares`` took thousands of evaluations
    without converging on a four-link arm, where this takes about a hundred Newton
    steps.)"""
    if not isinstance(base, BaseParameters):
        raise ValueError(f"base = {base!r}; a BaseParameters (base_parameters) is required")
    n, size, full = len(base.links), base.size, len(base.standard_names)
    beta_hat = np.asarray(beta_hat, dtype=float)
    if beta_hat.shape != (size,) or not np.all(np.isfinite(beta_hat)):
        raise ValueError(
            f"beta_hat = {shown(beta_hat)}; {size} finite values (one per base parameter) "
            "are required"
        )
    factor, deviations = _covariance_factor(beta_cov, size)
    prior = np.asarray(prior, dtype=float)
    if prior.shape != (full,) or not np.all(np.isfinite(prior)):
        raise ValueError(
            f"prior has shape {prior.shape}; ({full},) finite values (one per standard "
            "parameter) are required"
        )
    weight = require_finite("regularisation", regularisation)
    if weight <= 0.0:
        raise ValueError(f"regularisation = {regularisation!r}; a value > 0 is required")
    links = np.array([consistent_link(prior[10 * i : 10 * i + 10]) for i in range(n)])
    drive0 = _drive_priors(prior[10 * n :].reshape(n, len(DRIVE_PARAMETERS))).ravel()
    scale = np.concatenate([np.ones(10 * n), drive0])
    problem = _Problem(
        rows=scipy.linalg.solve_triangular(factor, base.K * scale, lower=True),
        target=scipy.linalg.solve_triangular(factor, beta_hat, lower=True),
        prior_inverse=np.linalg.inv(np.einsum("nk,kij->nij", links, _BASIS)),
        weight=weight,
    )
    x = np.concatenate([links.ravel(), np.ones(full - 10 * n)])
    misfit = problem.rows @ x - problem.target
    t, total = float(misfit @ misfit), 0
    while t > weight:
        x, steps, _ = _newton(problem, x, t, CENTRING)
        total += steps
        t /= BARRIER_FACTOR
    x, steps, reached = _newton(problem, x, weight, FINAL_DECREMENT)
    total += steps
    pi = x * scale
    beta = base.K @ pi
    drive = pi[10 * n :].reshape(n, len(DRIVE_PARAMETERS))
    return ConsistentModel(
        standard=pi,
        names=base.standard_names,
        links=tuple(
            _link_inertia(name, pi[10 * i : 10 * i + 10]) for i, name in enumerate(base.links)
        ),
        drives=tuple(
            DriveParameters(joint, float(r), float(b), float(f))
            for joint, (r, b, f) in zip(base.joints, drive, strict=True)
        ),
        beta=beta,
        standard_errors=(beta - beta_hat) / deviations,
        mahalanobis=float(
            np.linalg.norm(scipy.linalg.solve_triangular(factor, beta - beta_hat, lower=True))
        ),
        converged=reached,
        newton_steps=total,
    )


def _number(value: float) -> str:
    return repr(float(value))


def _child(parent: ET.Element, tag: str, index: int | None = None) -> ET.Element:
    """``parent``'s first ``<tag>``, created (at ``index``, or last) if it has none."""
    element = parent.find(tag)
    if element is None:
        element = ET.Element(tag)
        parent.insert(len(parent) if index is None else index, element)
    return element


def _set_inertial(link: ET.Element, mass: float, com: np.ndarray, inertia: np.ndarray) -> None:
    inertial = _child(link, "inertial", 0)
    for note in [child for child in inertial if child.tag is ET.Comment]:
        inertial.remove(note)  # it describes the nominal values
    origin = _child(inertial, "origin")
    origin.attrib = {"xyz": " ".join(_number(x) for x in com), "rpy": "0 0 0"}
    _child(inertial, "mass").attrib = {"value": _number(mass)}
    _child(inertial, "inertia").attrib = {
        name: _number(inertia[r, c])
        for name, (r, c) in (
            ("ixx", (0, 0)), ("ixy", (0, 1)), ("ixz", (0, 2)),
            ("iyy", (1, 1)), ("iyz", (1, 2)), ("izz", (2, 2)),
        )
    }  # fmt: skip


def _welded_children(robot: ET.Element, link: str) -> list[str]:
    """The links welded (by fixed joints, at any depth) below ``link``."""
    fixed = [
        (joint.find("parent").get("link"), joint.find("child").get("link"))
        for joint in robot.findall("joint")
        if joint.get("type") == "fixed"
    ]
    found, frontier = [], [link]
    while frontier:
        parent = frontier.pop()
        children = [child for above, child in fixed if above == parent]
        found += children
        frontier += children
    return found


def _massless(link: ET.Element) -> bool:
    mass = link.find("inertial/mass")
    return mass is None or float(mass.get("value", "0")) == 0.0


def _posfb_element(parent: ET.Element, tag: str) -> ET.Element:
    """``parent``'s ``posfb:<tag>`` in any of the namespaces posfb reads, or a new one."""
    for namespace in POSFB_NAMESPACES:
        element = parent.find(f"{{{namespace}}}{tag}")
        if element is not None:
            return element
    return ET.SubElement(parent, f"{{{POSFB_NS}}}{tag}")


def _set_drive(
    robot: ET.Element, joint: ET.Element, drive: DriveParameters, motor_constant: float | None
) -> None:
    _child(joint, "dynamics").set("damping", _number(drive.damping))
    _posfb_element(joint, "coulomb_friction").set("value", _number(drive.coulomb))
    actuator = next(
        transmission.find("actuator")
        for transmission in robot.findall("transmission")
        if transmission.find("joint") is not None
        and transmission.find("joint").get("name") == drive.joint
    )
    ratio = actuator.find(f"{{{DRAKE_NS}}}gear_ratio")
    gear = 1.0 if ratio is None else float(ratio.get("value"))
    _child(actuator, f"{{{DRAKE_NS}}}rotor_inertia", 0).set(
        "value", _number(drive.rotor_inertia / gear**2)
    )
    if motor_constant is not None:
        _posfb_element(actuator, "motor_constant").set("value", _number(motor_constant))


#: The comment ``write_urdf`` puts in the actuator of a joint whose motor constant the
#: log did not identify.
DECLARED_COMMENT = (
    " posfb identify: this motor constant is the description's; the log did not identify "
    "its ratio to joint 1's "
)


def write_urdf(
    nominal_urdf: str | Path,
    model: ConsistentModel,
    out: str | Path,
    motor_constant: np.ndarray | None = None,
    description: Description | None = None,
    declared: tuple[str, ...] = (),
) -> Path:
    """Write ``nominal_urdf`` with ``model``'s parameters to ``out`` and return ``out``.

    Each moving link gets ``model``'s ``<inertial>`` (mass, ``origin xyz`` = the centre
    of mass, ``rpy = 0``, the inertia about it in the link frame); the bodies welded to it
    get mass and inertia 0, since ``model`` holds them folded into it, except a massless
    ``payload`` link, which is left as it is. Each arm joint gets its ``<dynamics
    damping>`` and ``posfb:coulomb_friction``, its actuator ``drake:rotor_inertia =
    rotor_inertia / gear_ratio^2`` (the URDF's ``drake:gear_ratio`` kept, 1 where it has
    none), and ``posfb:motor_constant`` where ``motor_constant`` (one per joint, N m/V)
    is given; the actuator of each joint in ``declared`` gets a comment saying its motor
    constant is the description's (not identifiable from the log). Everything else
    (geometry, limits, the motor constants otherwise, the comments inside ``<robot>`` but
    those of a rewritten ``<inertial>``) is the nominal file's, re-indented, under a
    comment that names the fit. The file is the nominal one as posfb hands it
    to Drake with what ``description`` (the scenario's) adds (``models.description``:
    welded joints fixed, meshes as absolute URIs, the scenario's drives written in), so
    ``out`` loads with no description. ``nominal_urdf`` must pass
    ``models.urdf_check.check_serial_urdf`` with the model's joints and links; ``out``'s
    folder must exist."""
    if not isinstance(model, ConsistentModel):
        raise ValueError(f"model = {model!r}; a ConsistentModel (fit_consistent) is required")
    nominal_urdf, out = Path(nominal_urdf), Path(out)
    chain = check_serial_urdf(nominal_urdf, description)
    if not out.parent.is_dir():
        raise ValueError(
            f"out = {str(out)!r}: its folder does not exist; an existing one is required"
        )
    prepared = prepare_urdf(nominal_urdf, description)
    robot = parse_robot(nominal_urdf, prepared.text.encode(), comments=True)
    tree = ET.ElementTree(robot)
    links = {element.get("name"): element for element in robot.findall("link")}
    by_name = {element.get("name"): element for element in robot.findall("joint")}
    moved = tuple((name, by_name[name].find("child").get("link")) for name in chain.joints)
    wanted = tuple(
        (drive.joint, link.name) for drive, link in zip(model.drives, model.links, strict=True)
    )
    if moved != wanted:
        raise ValueError(
            f"nominal_urdf = {str(nominal_urdf)!r} has the arm joints and links {list(moved)}; "
            f"the model's {list(wanted)} are required"
        )
    for link in model.links:
        _set_inertial(links[link.name], link.mass, link.com, link.inertia)
        for name in _welded_children(robot, link.name):
            welded = links[name]
            if welded.find("inertial") is None or (name == PAYLOAD_LINK and _massless(welded)):
                continue
            _set_inertial(welded, 0.0, np.zeros(3), np.zeros((3, 3)))
    constants = [None] * len(model.drives) if motor_constant is None else list(motor_constant)
    if len(constants) != len(model.drives):
        raise ValueError(
            f"motor_constant has {len(constants)} entries; one per joint "
            f"({len(model.drives)}) is required"
        )
    for drive, constant in zip(model.drives, constants, strict=True):
        value = None if constant is None else float(constant)
        _set_drive(robot, by_name[drive.joint], drive, value)
        if drive.joint in declared:
            actuator_of(robot, drive.joint).insert(0, ET.Comment(DECLARED_COMMENT))
    robot.insert(
        0,
        ET.Comment(
            " Link inertias and drive parameters: a physically consistent fit "
            f"(posfb.models.identification.consistent; misfit {model.mahalanobis:.3g} in "
            "the estimate's standard errors). "
        ),
    )
    ET.register_namespace("drake", DRAKE_NS)
    ET.register_namespace("posfb", POSFB_NS)
    ET.indent(tree, space="  ")
    tree.write(out, encoding="utf-8", xml_declaration=True)
    return out
