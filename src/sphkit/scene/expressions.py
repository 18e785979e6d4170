"""Expressions in scene files: SPlisHSPlasH's tinyexpr strings of its animation fields
(``AnimationFields[].expression_x`` ...), parsed once with Python's ``ast`` into a NumPy
function of whole arrays (no ``eval``): numbers, ``+ - * / ^`` (power; ``**`` too),
parentheses, the :data:`VARIABLES`, the functions of :data:`FUNCTIONS` (``log`` is log10, as in
tinyexpr; ``ln`` the natural one) and the constants ``pi, e``. Anything else is refused.
"""

from __future__ import annotations

import ast
import math
from collections.abc import Callable
from typing import Any

import numpy as np

#: the variables an expression may read
VARIABLES = ("t", "dt", "x", "y", "z", "vx", "vy", "vz", "valuex", "valuey", "valuez")
FUNCTIONS: dict[str, Callable[..., Any]] = {
    "abs": np.abs, "acos": np.arccos, "asin": np.arcsin, "atan": np.arctan,
    "atan2": np.arctan2, "ceil": np.ceil, "cos": np.cos, "cosh": np.cosh, "exp": np.exp,
    "floor": np.floor, "ln": np.log, "log": np.log10, "log10": np.log10, "pow": np.power,
    "sin": np.sin, "sinh": np.sinh, "sqrt": np.sqrt, "tan": np.tan, "tanh": np.tanh,
}
_CONSTANTS = {"pi": math.pi, "e": math.e}
_BINARY = {ast.Add: np.add, ast.Sub: np.subtract, ast.Mult: np.multiply,
           ast.Div: np.divide, ast.Pow: np.power, ast.Mod: np.mod}
_UNARY = {ast.USub: np.negative, ast.UAdd: np.positive}


class ExpressionError(ValueError):
    """An expression that is not one of the accepted form (the message says why)."""


def compile_expression(text: str) -> Callable[[dict[str, Any]], Any]:
    """A function of a dict of the :data:`VARIABLES` (scalars or arrays) evaluating ``text``;
    raises :class:`ExpressionError` for anything outside the accepted grammar."""
    src = text.replace("^", "**")
    try:
        tree = ast.parse(src, mode="eval")
    except SyntaxError as e:
        raise ExpressionError(f"not an expression ({e.msg})") from None

    def build(node: ast.AST) -> Callable[[dict[str, Any]], Any]:
        if isinstance(node, ast.Expression):
            return build(node.body)
        if isinstance(node, ast.Constant) and isinstance(node.value, (int, float)) \
                and not isinstance(node.value, bool):
            value = float(node.value)
            return lambda env: value
        if isinstance(node, ast.Name):
            name = node.id
            if name in VARIABLES:
                return lambda env: env[name]
            if name in _CONSTANTS:
                value = _CONSTANTS[name]
                return lambda env: value
            raise ExpressionError(f"unknown name {name!r}; expected one of "
                                  f"{', '.join(VARIABLES)}, pi, e")
        if isinstance(node, ast.BinOp) and type(node.op) in _BINARY:
            op, a, b = _BINARY[type(node.op)], build(node.left), build(node.right)
            return lambda env: op(a(env), b(env))
        if isinstance(node, ast.UnaryOp) and type(node.op) in _UNARY:
            op, a = _UNARY[type(node.op)], build(node.operand)
            return lambda env: op(a(env))
        if isinstance(node, ast.Call) and isinstance(node.func, ast.Name) and not node.keywords:
            fn = FUNCTIONS.get(node.func.id)
            if fn is None:
                raise ExpressionError(f"unknown function {node.func.id!r}; expected one of "
                                      f"{', '.join(FUNCTIONS)}")
            args = [build(a) for a in node.args]
            return lambda env: fn(*(a(env) for a in args))
        raise ExpressionError(f"{ast.unparse(node)!r} is not a number, variable, operator "
                              "(+ - * / ^) or function call")

    return build(tree)
