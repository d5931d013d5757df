"""argparse types for numeric options, refused in one line that names the value and what
is allowed (argparse adds the option's name). Cheap to import: a command's parser uses
them before anything heavy loads."""

from __future__ import annotations

import argparse
import math
from collections.abc import Callable


def finite_above(lowest: float, inclusive: bool) -> Callable[[str], float]:
    """An argparse type: a finite number above ``lowest`` (or equal, ``inclusive``),
    refused in one line otherwise."""
    relation = ">=" if inclusive else ">"

    def number(text: str) -> float:  # argparse names a non-number "invalid number value"
        value = float(text)
        if not (math.isfinite(value) and (value >= lowest if inclusive else value > lowest)):
            raise argparse.ArgumentTypeError(
                f"{text!r}: a finite number {relation} {lowest:g} is required"
            )
        return value

    return number


#: A finite number > 0.
positive = finite_above(0.0, inclusive=False)

#: A finite number >= 0.
nonnegative = finite_above(0.0, inclusive=True)
