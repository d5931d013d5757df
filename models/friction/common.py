"""Symbolic pieces the friction laws share."""

from __future__ import annotations

import functools
import operator

from pydrake.symbolic import Expression, Variable


def total(terms: list) -> Expression:
    """``terms[0] + terms[1] + ...`` in that order."""
    return functools.reduce(operator.add, terms)


def joint_variables(prefix: str, joints: int) -> list[Variable]:
    """``prefix1 .. prefixN``."""
    return [Variable(f"{prefix}{j + 1}") for j in range(joints)]
