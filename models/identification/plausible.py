"""Whether identified first moments and inertias are ones the arm's links can have
(issue 42).

A fitted parameter can be identifiable, tightly bounded and still absurd: a first moment
of kg m for a 0.1 kg link of 5 cm (a regressor column the log barely excites, a log in
the wrong units, a description whose geometry is not the arm's). The bound comes from
the description: each link ``i``, of nominal mass ``m_i``, is taken to lie in a ball of
radius ``r_i`` about its frame's origin, ``r_i`` the largest of the distance to the next
joint's origin, the nominal centre of mass's and the nominal radius of gyration about
the origin ``sqrt(tr(I_O) / 2 m)``. A link of at most ``PLAUSIBLE_FACTOR`` times that
mass within ``PLAUSIBLE_FACTOR`` times that radius has (in its frame)::

    |m c_x| <= m r,   |I_xx| <= m r^2,   |I_xy| <= m r^2 / 2 <= m r^2

(``I`` about the origin, ``I_xx = sum m (y^2 + z^2)``). A base parameter ``beta_k =
K_k pi`` then has ``|beta_k| <= sum_j |K_kj| bound_j``. ``implausible`` flags, by name,
each first-moment or inertia base parameter whose estimate exceeds that bound by more
than ``SIGMAS`` standard errors, and each link of the consistent model whose first
moment or inertia exceeds its own. A parameter that regroups a drive's (a rotor inertia
with the base link's ``Izz``) or a link the description gives no mass has no bound.
"""

from __future__ import annotations

import numpy as np

from posfb.models.identification.serial_regressor import (
    INERTIAL_PARAMETERS,
    BaseParameters,
    SerialRegressor,
)

#: How many times the description's link mass and extent a fitted link may reach before
#: it is flagged (module docstring): a generous margin for a description that is only
#: roughly the arm, far below the factors of a wrong unit or an unexcited column.
PLAUSIBLE_FACTOR = 3.0

#: How many standard errors beyond the bound an estimate must lie to be flagged.
SIGMAS = 3.0

#: The standard parameters (of ``INERTIAL_PARAMETERS``) the check bounds.
FIRST_MOMENTS = ("mcx", "mcy", "mcz")
INERTIAS = ("Ixx", "Iyy", "Izz", "Ixy", "Ixz", "Iyz")


def link_extents(regressor: SerialRegressor, nominal: np.ndarray) -> np.ndarray:
    """``r_i`` of each link (module docstring), m; 0 for a link with no nominal mass."""
    extents = []
    for i in range(regressor.size):
        link = nominal[10 * i : 10 * i + 10]
        mass = float(link[0])
        if mass <= 0.0:
            extents.append(0.0)
            continue
        gyration = np.sqrt(max(float(link[4] + link[5] + link[6]), 0.0) / (2.0 * mass))
        following = (
            np.linalg.norm(regressor.parent_position[i + 1]) if i + 1 < regressor.size else 0.0
        )
        extents.append(max(following, np.linalg.norm(link[1:4]) / mass, gyration))
    return np.asarray(extents)


def standard_bounds(regressor: SerialRegressor, nominal: np.ndarray) -> np.ndarray:
    """The bound on each standard parameter's magnitude (module docstring); ``inf`` for a
    mass, a drive parameter and every parameter of a link with no nominal mass."""
    bounds = np.full(13 * regressor.size, np.inf)
    for i, extent in enumerate(link_extents(regressor, nominal)):
        mass = float(nominal[10 * i])
        if mass <= 0.0:
            continue
        m, r = PLAUSIBLE_FACTOR * mass, PLAUSIBLE_FACTOR * extent
        for k, name in enumerate(INERTIAL_PARAMETERS):
            if name in FIRST_MOMENTS:
                bounds[10 * i + k] = m * r
            elif name in INERTIAS:
                bounds[10 * i + k] = m * r * r
    return bounds


def _bounded(name: str) -> bool:
    return name.rsplit(".", 1)[-1] in (*FIRST_MOMENTS, *INERTIAS)


def implausible(
    base: BaseParameters,
    bounds: np.ndarray,
    values: np.ndarray,
    std: np.ndarray,
    standard: np.ndarray,
) -> list[str]:
    """The warnings of the module docstring for a base estimate ``values +- std`` and the
    consistent model's standard vector ``standard``."""
    warnings = []
    for k, name in enumerate(base.names):
        involved = base.K[k] != 0.0
        if not _bounded(name) or not np.all(np.isfinite(bounds[involved])):
            continue
        bound = float(np.abs(base.K[k, involved]) @ bounds[involved])
        if abs(values[k]) - SIGMAS * std[k] > bound:
            warnings.append(
                f"{name} = {values[k]:.4g} +- {std[k]:.2g} is beyond what the description's "
                f"links allow (|{name}| <= {bound:.3g}: {PLAUSIBLE_FACTOR:g} times their "
                "masses and sizes); the log's units, the description's geometry or an "
                "unexcited column is the likely cause"
            )
    beyond = [
        f"{name} = {value:.4g} (bound {bound:.3g})"
        for name, value, bound in zip(base.standard_names, standard, bounds, strict=True)
        if _bounded(name) and abs(value) > bound
    ]
    if beyond:
        warnings.append(
            f"the model written has links beyond what the description allows "
            f"({PLAUSIBLE_FACTOR:g} times their masses and sizes): {', '.join(beyond)}"
        )
    return warnings
