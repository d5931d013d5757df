"""Symbolic pieces the friction laws share."""

from __future__ import annotations

import functools
import operator

from pydrake.symbolic import Expression, Variable
from pydrake.systems.primitives import SymbolicVectorSystem


def total(terms: list) -> Expression:
    """``terms[0] + terms[1] + ...`` in that order."""
    return functools.reduce(operator.add, terms)


def joint_variables(prefix: str, joints: int) -> list[Variable]:
    """``prefix1 .. prefixN``."""
    return [Variable(f"{prefix}{j + 1}") for j in range(joints)]


def friction_system(
    name: str,
    velocities: list[Variable],
    parameters: list[Variable],
    force: list[Expression],
    states: list[Variable] | None = None,
    rates: list[Expression] | None = None,
) -> SymbolicVectorSystem:
    """A law's block: input the joint ``velocities``, output the applied ``force``;
    state 0 integrates the work the joints do against friction, ``-sum_j f_j v_j`` (J),
    and the law's own ``states`` (LuGre's bristles) follow with their ``rates``."""
    loss = Variable("friction_loss")
    power = total([force[j] * velocities[j] for j in range(len(velocities))])
    system = SymbolicVectorSystem(
        state=[loss, *(states or [])],
        input=velocities,
        parameter=parameters,
        dynamics=[-power, *(rates or [])],
        output=force,
    )
    system.set_name(name)
    return system
