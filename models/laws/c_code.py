"""A law (``models.laws.law``) printed as C99: ``NAME.h`` and ``NAME.c`` with the fixed
interface of ``posfb codegen``::

    #define NAME_JOINTS  n          /* the arm's joints */
    #define NAME_MEMORY  m          /* numbers kept between samples */
    typedef struct { double memory[NAME_MEMORY]; } name_state;
    void name_start(name_state *s, const double q[NAME_JOINTS],
                    const double desired[3 * NAME_JOINTS]);
    void name_step(name_state *s, const double q[NAME_JOINTS],
                   const double desired[3 * NAME_JOINTS], double voltage[NAME_JOINTS]);

(``float`` throughout with ``precision = "float"``). The bodies are the law's CasADi
algorithm, one C statement per instruction in CasADi's own order, so a double build
performs the operations the simulation's evaluation performs. No dynamic memory, no
mutable global: the design's numbers are literals, the work variables locals; only
``<math.h>`` and ``<string.h>`` are included.
"""

from __future__ import annotations

import re
from collections.abc import Callable

import casadi as ca
import numpy as np

from posfb.models.laws.law import Law

#: The C types of the two precisions.
PRECISIONS = ("double", "float")

#: C identifiers posfb accepts as ``--name`` (they prefix every symbol).
NAME_PATTERN = re.compile(r"[a-z][a-z0-9_]{0,30}")


def _unary(function: str) -> Callable[[list[str], str], str]:
    return lambda args, suffix: f"{function}{suffix}({args[0]})"


def _binary(function: str) -> Callable[[list[str], str], str]:
    return lambda args, suffix: f"{function}{suffix}({args[0]}, {args[1]})"


def _infix(operator: str) -> Callable[[list[str], str], str]:
    return lambda args, suffix: f"{args[0]} {operator} {args[1]}"


#: C of each CasADi operation a law may use (``suffix``: ``f`` for float's math functions).
OPERATIONS: dict[int, Callable[[list[str], str], str]] = {
    ca.OP_ASSIGN: lambda a, s: a[0],
    ca.OP_ADD: _infix("+"),
    ca.OP_SUB: _infix("-"),
    ca.OP_MUL: _infix("*"),
    ca.OP_DIV: _infix("/"),
    ca.OP_NEG: lambda a, s: f"-{a[0]}",
    ca.OP_TWICE: lambda a, s: f"{a[0]} + {a[0]}",
    ca.OP_SQ: lambda a, s: f"{a[0]} * {a[0]}",
    ca.OP_INV: lambda a, s: f"1 / {a[0]}",
    ca.OP_SQRT: _unary("sqrt"),
    ca.OP_SIN: _unary("sin"),
    ca.OP_COS: _unary("cos"),
    ca.OP_TAN: _unary("tan"),
    ca.OP_EXP: _unary("exp"),
    ca.OP_LOG: _unary("log"),
    ca.OP_TANH: _unary("tanh"),
    ca.OP_ATAN: _unary("atan"),
    ca.OP_FABS: _unary("fabs"),
    ca.OP_FLOOR: _unary("floor"),
    ca.OP_POW: _binary("pow"),
    ca.OP_CONSTPOW: _binary("pow"),
    ca.OP_ATAN2: _binary("atan2"),
    ca.OP_FMIN: _binary("fmin"),
    ca.OP_FMAX: _binary("fmax"),
    ca.OP_COPYSIGN: _binary("copysign"),
    ca.OP_SIGN: lambda a, s: f"({a[0]} < 0 ? -1 : ({a[0]} > 0 ? 1 : {a[0]}))",
    ca.OP_LT: lambda a, s: f"({a[0]} < {a[1]})",
    ca.OP_LE: lambda a, s: f"({a[0]} <= {a[1]})",
    ca.OP_EQ: lambda a, s: f"({a[0]} == {a[1]})",
    ca.OP_NE: lambda a, s: f"({a[0]} != {a[1]})",
    ca.OP_NOT: lambda a, s: f"(!{a[0]})",
    ca.OP_AND: lambda a, s: f"({a[0]} && {a[1]})",
    ca.OP_OR: lambda a, s: f"({a[0]} || {a[1]})",
    ca.OP_IF_ELSE_ZERO: lambda a, s: f"({a[0]} ? {a[1]} : 0)",
}


def _literal(value: float, precision: str) -> str:
    """``value`` as a C literal of ``precision``; in float, a value below float's range is
    written as its rounding, zero (a literal that underflows is an error under
    ``-Werror``), and one beyond it refused."""
    if not np.isfinite(value):
        raise ValueError(f"the law holds the constant {value}; a finite design is required")
    if precision == "float":
        rounded = np.float32(value)
        if not np.isfinite(rounded):
            raise ValueError(f"the law holds the constant {value!r}, beyond float's range; "
                             "--precision double is required")  # fmt: skip
        if rounded == 0.0:
            value = float(rounded)
    text = repr(float(value))
    if "e" not in text and "." not in text:
        text += ".0"
    return f"({text}f)" if precision == "float" else f"({text})"


def function_body(function: ca.Function, arguments: list[str], results: list[str],
                  precision: str, real: str) -> list[str]:  # fmt: skip
    """The statements of ``function``'s algorithm: input ``i`` is the array
    ``arguments[i]``, output ``i`` the array ``results[i]``."""
    suffix = "f" if precision == "float" else ""
    size = int(function.sz_w())
    lines = [f"  {real} w[{max(size, 1)}];"]
    used = set()
    for k in range(function.n_instructions()):
        op = function.instruction_id(k)
        inputs = list(function.instruction_input(k))
        outputs = list(function.instruction_output(k))
        if op == ca.OP_INPUT:
            lines.append(f"  w[{outputs[0]}] = {arguments[inputs[0]]}[{inputs[1]}];")
            used.add(inputs[0])
        elif op == ca.OP_OUTPUT:
            lines.append(f"  {results[outputs[0]]}[{outputs[1]}] = w[{inputs[0]}];")
        elif op == ca.OP_CONST:
            value = _literal(function.instruction_constant(k), precision)
            lines.append(f"  w[{outputs[0]}] = {value};")
        elif op in OPERATIONS:
            expression = OPERATIONS[op]([f"w[{i}]" for i in inputs], suffix)
            lines.append(f"  w[{outputs[0]}] = {expression};")
        else:
            raise ValueError(f"CasADi operation {op} of {function.name()} has no C form here")
    unused = [name for i, name in enumerate(arguments) if i not in used]
    lines[1:1] = [f"  (void){name};" for name in unused]
    if size == 0:
        lines.insert(1, "  (void)w;")
    return lines


def c_sources(law: Law, name: str, precision: str = "double") -> dict[str, str]:
    """``{"NAME.h": ..., "NAME.c": ...}`` of ``law`` (module docstring)."""
    if not NAME_PATTERN.fullmatch(name):
        raise ValueError(f"name = {name!r}; a lower-case C identifier (a-z, 0-9, _; 31 at most) "
                         "is required")  # fmt: skip
    if precision not in PRECISIONS:
        raise ValueError(f"precision = {precision!r}; one of {', '.join(PRECISIONS)} is required")
    if not all(f.is_a("SXFunction") for f in (law.start, law.step)):
        raise ValueError(f"the {law.name} law is not an SX expression graph; C prints SX only")
    if law.memory == 0:
        raise ValueError(f"the {law.name} law keeps no memory; the state struct needs one")
    upper, real = name.upper(), precision
    n = law.joints
    if law.internals == 0:
        raise ValueError(f"the {law.name} law has no internals; C needs at least one")
    internals = law.internals
    header = f"""/* {name}.h: the {law.name} controller of posfb, generated by `posfb codegen`. */
#ifndef {upper}_H
#define {upper}_H

#define {upper}_JOINTS {n} /* the arm's joints */
#define {upper}_MEMORY {law.memory} /* numbers kept between samples */

typedef struct {{ {real} memory[{upper}_MEMORY]; }} {name}_state;

/* Sample 0: the memory from the held quantised position q (rad) and the desired
   [q_d, qdot_d, qddot_d]; then {name}_step at every sample k = 0, 1, ... */
void {name}_start({name}_state *s, const {real} q[{upper}_JOINTS],
{" " * (len(name) + 12)}const {real} desired[3 * {upper}_JOINTS]);

/* The armature voltage (V) before the +-limit saturation; advances s. */
void {name}_step({name}_state *s, const {real} q[{upper}_JOINTS],
{" " * (len(name) + 11)}const {real} desired[3 * {upper}_JOINTS], {real} voltage[{upper}_JOINTS]);

/* {name}_step that also gives the controller's internals (posfb's log columns). */
#define {upper}_INTERNALS {internals} /* internals of {name}_step_internals */
void {name}_step_internals({name}_state *s, const {real} q[{upper}_JOINTS],
{" " * (len(name) + 21)}const {real} desired[3 * {upper}_JOINTS], {real} voltage[{upper}_JOINTS],
{" " * (len(name) + 21)}{real} internals[{upper}_INTERNALS]);

#endif
"""
    start = function_body(law.start, ["q", "desired"], ["memory"], precision, real)
    step = function_body(law.step, ["memory", "q", "desired"],
                         ["voltage", "internals", "next"], precision, real)  # fmt: skip
    source = f"""/* {name}.c: the {law.name} controller of posfb, generated by `posfb codegen`
   from the law the simulation evaluates (models/laws). C99, no dynamic memory. */
#include <math.h>
#include <string.h>

#include "{name}.h"

static void {name}_start_law(const {real} *q, const {real} *desired, {real} *memory) {{
{chr(10).join(start)}
}}

static void {name}_step_law(const {real} *memory, const {real} *q, const {real} *desired,
                            {real} *voltage, {real} *internals, {real} *next) {{
{chr(10).join(step)}
}}

void {name}_start({name}_state *s, const {real} q[{upper}_JOINTS],
{" " * (len(name) + 12)}const {real} desired[3 * {upper}_JOINTS]) {{
  {name}_start_law(q, desired, s->memory);
}}

void {name}_step_internals({name}_state *s, const {real} q[{upper}_JOINTS],
{" " * (len(name) + 21)}const {real} desired[3 * {upper}_JOINTS], {real} voltage[{upper}_JOINTS],
{" " * (len(name) + 21)}{real} internals[{upper}_INTERNALS]) {{
  {real} next[{upper}_MEMORY];
  {name}_step_law(s->memory, q, desired, voltage, internals, next);
  memcpy(s->memory, next, sizeof next);
}}

void {name}_step({name}_state *s, const {real} q[{upper}_JOINTS],
{" " * (len(name) + 11)}const {real} desired[3 * {upper}_JOINTS], {real} voltage[{upper}_JOINTS]) {{
  {real} internals[{upper}_INTERNALS];
  {name}_step_internals(s, q, desired, voltage, internals);
}}
"""
    return {f"{name}.h": header, f"{name}.c": source}
