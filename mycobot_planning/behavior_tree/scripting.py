"""BehaviorTree.CPP's scripting language: the ``Script`` node, ``ScriptCondition``,
``Precondition`` and the ``_skipIf``/``_onSuccess``/... attributes.

Statements are separated by ``;``. Operators, loosest first: assignment (``:=`` creates an
entry, ``=`` needs an existing one, ``+= -= *= /=``), ternary ``c ? a : b``, ``||``, ``&&``,
comparisons (chainable: ``1 < x < 3``), ``| ^``, ``&``, string concatenation ``..``, ``+ -``,
``* /``, prefix ``- ~ !``. Literals: integers (also ``0x1F``), reals, ``'strings'``
(or ``"strings"``), ``true``/``false``; names are blackboard entries (``@name`` in the root
blackboard) or registered enums. Values follow BT.CPP: arithmetic gives doubles, comparisons
and logic give 1.0/0.0, a number meets a string only through ``..`` or a comparison (the
string is read as a number), an entry's type does not change once it holds a value.

Written by hand because BT.CPP's grammar (a lexy grammar up to 4.8, a Pratt parser since 4.10)
has no Python package; see docs/behavior_tree.md for the few places where BT.CPP 4.6-4.8
behave differently (and were fixed upstream later).
"""
from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any

from .blackboard import EMPTY, Blackboard, coerce_for_entry
from .exceptions import BehaviorTreeRuntimeError, PortError, ScriptError, ScriptSyntaxError
from .ports import ANY, ConversionError, cast_bool, cast_int, number_to_string

#: BT.CPP compares doubles with the float epsilon.
_EPS = 1.1920928955078125e-07


@dataclass
class Environment:
    """What a script sees: the node's blackboard and the factory's scripting enums."""

    vars: Blackboard
    enums: Mapping[str, int] | None = None


class _ScriptRuntimeError(BehaviorTreeRuntimeError):
    pass


def _fail(message: str) -> None:
    raise _ScriptRuntimeError(message)


def is_number(value: Any) -> bool:
    return isinstance(value, (int, float))


def _not_init(side: str, op: str) -> str:
    return f"The {side} operand of the operator [{op}] is not initialized"


def string_to_double(text: str, env: Environment) -> float:
    """A string met by a number: ``true``/``false``, an enum name or a number."""
    if text == "true":
        return 1.0
    if text == "false":
        return 0.0
    if env.enums and text in env.enums:
        return float(env.enums[text])
    try:
        return float(text)
    except ValueError:
        _fail(f"can't convert the string '{text}' to a number")
    return 0.0  # not reached


def script_truth(value: Any) -> bool:
    """A script's result read as a condition (BT.CPP's ``cast<bool>``)."""
    if value is EMPTY:
        _fail("the script returned no value")
    if isinstance(value, str):
        _fail(f"the script returned the string '{value}', not a boolean")
    try:
        return cast_bool(value)
    except ConversionError as exc:
        _fail(f"the script's result is not a boolean: {exc}")
    return False  # not reached


def _type_name(value: Any) -> str:
    if isinstance(value, bool):
        return "bool"
    if isinstance(value, int):
        return "int64_t"
    if isinstance(value, float):
        return "double"
    if isinstance(value, str):
        return "std::string"
    return type(value).__name__


def copy_into(value: Any, dst: Any) -> Any:
    """BT.CPP's Any::copyInto: the new value in the kind the destination already has."""
    if dst is EMPTY:
        return value
    if isinstance(value, str) and isinstance(dst, str):
        return value
    if is_number(value) and is_number(dst):
        if isinstance(dst, bool):
            return cast_bool(value)
        if isinstance(dst, int):
            return cast_int(value)
        return float(value)
    if type(value) is type(dst):
        return value
    raise ConversionError(f"the right operand has type [{_type_name(value)}] and can't be converted "
                          f"to [{_type_name(dst)}]")


# ----------------------------------------------------------------------------- AST


class Expr:
    __slots__ = ()

    def evaluate(self, env: Environment) -> Any:  # pragma: no cover - abstract
        raise NotImplementedError


class Literal(Expr):
    __slots__ = ("value",)

    def __init__(self, value: Any):
        self.value = value

    def evaluate(self, env: Environment) -> Any:
        return self.value


class Name(Expr):
    __slots__ = ("name",)

    def __init__(self, name: str):
        self.name = name

    def evaluate(self, env: Environment) -> Any:
        enums = env.enums
        if enums and self.name in enums:
            return float(enums[self.name])
        entry = env.vars.get_entry(self.name)
        if entry is None:
            _fail(f"Variable not found: {self.name}")
        return entry.value


class Unary(Expr):
    __slots__ = ("op", "operand")

    def __init__(self, op: str, operand: Expr):
        self.op = op
        self.operand = operand

    def evaluate(self, env: Environment) -> Any:
        value = self.operand.evaluate(env)
        if is_number(value):
            if self.op == "-":
                return -float(value)
            if self.op == "~":
                if not -(2 ** 63) <= value < 2 ** 63:
                    _fail("Number out of range for bitwise operation")
                return float(~int(value))
            return 0.0 if value else 1.0
        if isinstance(value, str):
            _fail(f"Invalid operator [{self.op}] for std::string")
        if value is EMPTY:
            _fail(_not_init("right", self.op))
        _fail(f"operator [{self.op}] is not defined for {_type_name(value)}")


class Binary(Expr):
    __slots__ = ("op", "lhs", "rhs")

    def __init__(self, op: str, lhs: Expr, rhs: Expr):
        self.op = op
        self.lhs = lhs
        self.rhs = rhs

    def evaluate(self, env: Environment) -> Any:
        op = self.op
        lv = self.lhs.evaluate(env)
        rv = self.rhs.evaluate(env)
        if lv is EMPTY:
            _fail(_not_init("left", op))
        if rv is EMPTY:
            _fail(_not_init("right", op))
        if is_number(lv) and is_number(rv):
            if op == "+":
                return float(lv) + float(rv)
            if op == "-":
                return float(lv) - float(rv)
            if op == "*":
                return float(lv) * float(rv)
            if op == "/":
                return _divide(float(lv), float(rv))
            if op in ("&", "|", "^"):
                try:
                    li, ri = cast_int(lv), cast_int(rv)
                except ConversionError:
                    _fail("Binary operators are not allowed if one of the operands is not an integer")
                return float(li & ri if op == "&" else li | ri if op == "|" else li ^ ri)
            if op in ("&&", "||"):
                try:
                    lb, rb = cast_bool(lv), cast_bool(rv)
                except ConversionError:
                    _fail("Logic operators are not allowed if one of the operands is not castable to bool")
                return float(lb and rb) if op == "&&" else float(lb or rb)
            _fail(f"Operation [{op}] not permitted between two numbers")
        if op == "+" and isinstance(lv, str) and isinstance(rv, str):
            return lv + rv
        if op == ".." and (isinstance(lv, str) or is_number(lv)) and (isinstance(rv, str) or is_number(rv)) \
                and (isinstance(lv, str) or isinstance(rv, str)):
            return _as_string(lv) + _as_string(rv)
        _fail(f"Operation [{op}] not permitted between {_type_name(lv)} and {_type_name(rv)}")


def _as_string(value: Any) -> str:
    return value if isinstance(value, str) else number_to_string(value)


def _divide(a: float, b: float) -> float:
    if b != 0.0:
        return a / b
    if a == 0.0 or math.isnan(a):
        return math.nan
    return math.copysign(math.inf, a) * math.copysign(1.0, b)


_COMPARE: dict[str, Callable[[Any, Any], bool]] = {
    "<": lambda a, b: a < b,
    ">": lambda a, b: a > b,
    "<=": lambda a, b: a <= b,
    ">=": lambda a, b: a >= b,
}


class Comparison(Expr):
    __slots__ = ("ops", "operands")

    def __init__(self, ops: list[str], operands: list[Expr]):
        self.ops = ops
        self.operands = operands

    def evaluate(self, env: Environment) -> Any:
        lv = self.operands[0].evaluate(env)
        for op, operand in zip(self.ops, self.operands[1:]):
            rv = operand.evaluate(env)
            if lv is EMPTY:
                _fail(_not_init("left", op))
            if rv is EMPTY:
                _fail(_not_init("right", op))
            if is_number(lv) and is_number(rv):
                a, b = float(lv), float(rv)
            elif isinstance(lv, str) and isinstance(rv, str):
                a, b = lv, rv
            elif isinstance(lv, str) and is_number(rv):
                a, b = string_to_double(lv, env), float(rv)
            elif is_number(lv) and isinstance(rv, str):
                a, b = float(lv), string_to_double(rv, env)
            else:
                _fail(f"Can't mix different types in Comparison. Left operand [{_type_name(lv)}] "
                      f"right operand [{_type_name(rv)}]")
            if not _compare(op, a, b):
                return 0.0
            lv = rv
        return 1.0


def _compare(op: str, a: Any, b: Any) -> bool:
    if op in ("==", "!="):
        same = abs(a - b) <= _EPS if isinstance(a, float) else a == b
        return same if op == "==" else not same
    return _COMPARE[op](a, b)


class Conditional(Expr):
    __slots__ = ("condition", "then", "otherwise")

    def __init__(self, condition: Expr, then: Expr, otherwise: Expr):
        self.condition = condition
        self.then = then
        self.otherwise = otherwise

    def evaluate(self, env: Environment) -> Any:
        value = self.condition.evaluate(env)
        if value is EMPTY:
            _fail(_not_init("condition", "?"))
        if isinstance(value, str):
            truth = string_to_double(value, env) != 0.0
        elif is_number(value):
            truth = float(value) != 0.0
        else:
            _fail(f"the condition of [?] is a {_type_name(value)}, not a number")
        return (self.then if truth else self.otherwise).evaluate(env)


class Assignment(Expr):
    __slots__ = ("op", "key", "rhs")

    def __init__(self, op: str, key: str, rhs: Expr):
        self.op = op
        self.key = key
        self.rhs = rhs

    def evaluate(self, env: Environment) -> Any:
        key, op = self.key, self.op
        entry = env.vars.get_entry(key)
        if entry is None:
            if op != ":=":
                _fail(f"The blackboard entry [{key}] doesn't exist, yet. If you want to create a new one, "
                      f"use the operator [:=] instead of [{op}]")
            entry = env.vars.create_entry(key, ANY)
        value = self.rhs.evaluate(env)
        if value is EMPTY:
            _fail(_not_init("right", op))
        dst = entry.value
        try:
            if op in (":=", "="):
                new = self._assigned(value, dst, env)
            else:
                new = self._updated(value, dst)
            if entry.type.strongly_typed:
                new = coerce_for_entry(entry.type, new, key)
        except ConversionError as exc:
            _fail(f"Error assigning a value to entry [{key}] with type [{_type_name(dst) if dst is not EMPTY else entry.type.name}]. {exc}")
        except PortError as exc:
            _fail(str(exc))
        entry.value = new
        entry.touch()
        return new

    @staticmethod
    def _assigned(value: Any, dst: Any, env: Environment) -> Any:
        if dst is EMPTY:
            return value
        if isinstance(value, str) and not isinstance(dst, str):
            if is_number(dst):
                return string_to_double(value, env)
            raise ConversionError(f"the right operand is a string, can't convert to {_type_name(dst)}")
        return copy_into(value, dst)

    def _updated(self, value: Any, dst: Any) -> Any:
        op = self.op
        if dst is EMPTY:
            _fail(_not_init("left", op))
        if is_number(value):
            if not is_number(dst):
                _fail("This Assignment operator can't be used with a non-numeric type")
            lv, rv = float(dst), float(value)
            result = lv + rv if op == "+=" else lv - rv if op == "-=" else lv * rv if op == "*=" else _divide(lv, rv)
            return copy_into(result, dst)
        if isinstance(value, str):
            if op != "+=":
                _fail("Operator not supported for strings")
            return copy_into(_as_string(dst) + value, dst)
        _fail(f"operator [{op}] is not defined for {_type_name(value)}")
        return None  # not reached


# ----------------------------------------------------------------------------- tokenizer

_TWO_CHAR_OPS = ("..", "&&", "||", "==", "!=", "<=", ">=", ":=", "+=", "-=", "*=", "/=")
_ONE_CHAR_OPS = "+-*/&|^~!<>=?:();"
_ASSIGNMENT_OPS = (":=", "=", "+=", "-=", "*=", "/=")
_COMPARISON_OPS = ("==", "!=", "<", ">", "<=", ">=")
#: left binding powers of the infix operators
_BINDING = {"||": 6, "&&": 8, "|": 12, "^": 12, "&": 14, "..": 15, "+": 16, "-": 16, "*": 18, "/": 18}
_ASSIGNMENT_BP = 2
_TERNARY_BP = 4
_COMPARISON_BP = 10
_PREFIX_BP = 20


class Token:
    __slots__ = ("kind", "text", "value", "pos")

    def __init__(self, kind: str, text: str, pos: int, value: Any = None):
        self.kind = kind  # "int", "real", "str", "bool", "name", "op", "end"
        self.text = text
        self.value = value
        self.pos = pos

    def __repr__(self) -> str:
        return f"Token({self.kind}, {self.text!r})"


def _is_ident_start(c: str) -> bool:
    return c.isalpha() or c == "_" or c == "@"


def _is_ident_char(c: str) -> bool:
    return c.isalnum() or c == "_"


def tokenize(script: str) -> list[Token]:
    tokens: list[Token] = []
    i, n = 0, len(script)

    def error(message: str, pos: int) -> ScriptSyntaxError:
        return ScriptSyntaxError(message, script, pos + 1)

    while i < n:
        c = script[i]
        if c in " \t\r\n":
            i += 1
            continue
        start = i
        if c in "'\"":
            end = script.find(c, i + 1)
            if end < 0:
                raise error("unterminated string literal", start)
            tokens.append(Token("str", script[start:end + 1], start, script[i + 1:end]))
            i = end + 1
            continue
        if c.isdigit():
            i, token = _scan_number(script, i, error)
            tokens.append(token)
            continue
        if _is_ident_start(c):
            i += 1
            while i < n and _is_ident_char(script[i]):
                i += 1
            text = script[start:i]
            if text == "@":
                raise error("'@' must be followed by the name of a root blackboard entry", start)
            if text in ("true", "false"):
                tokens.append(Token("bool", text, start, 1 if text == "true" else 0))
            else:
                tokens.append(Token("name", text, start, text))
            continue
        two = script[i:i + 2]
        if two in _TWO_CHAR_OPS:
            tokens.append(Token("op", two, start))
            i += 2
            continue
        if c in _ONE_CHAR_OPS:
            tokens.append(Token("op", c, start))
            i += 1
            continue
        raise error(f"unexpected character '{c}'", start)
    tokens.append(Token("end", "", n))
    return tokens


def _scan_number(script: str, i: int, error: Callable[[str, int], ScriptSyntaxError]) -> tuple[int, Token]:
    n, start = len(script), i
    if script[i] == "0" and i + 1 < n and script[i + 1] in "xX":
        i += 2
        while i < n and script[i] in "0123456789abcdefABCDEF":
            i += 1
        if i == start + 2 or (i < n and (_is_ident_char(script[i]) or script[i] == ".")):
            raise error(f"invalid hexadecimal literal '{script[start:i + 1]}'", start)
        return i, Token("int", script[start:i], start, int(script[start + 2:i], 16))
    while i < n and script[i].isdigit():
        i += 1
    real = False
    if i < n and script[i] == "." and not script.startswith("..", i):
        if i + 1 < n and script[i + 1].isdigit():
            real = True
            i += 1
            while i < n and script[i].isdigit():
                i += 1
        else:
            raise error(f"invalid suffix on number literal '{script[start:i + 1]}'", start)
    if i < n and script[i] in "eE":
        j = i + 1
        if j < n and script[j] in "+-":
            j += 1
        if j >= n or not script[j].isdigit():
            raise error(f"exponent without digits in '{script[start:j]}'", start)
        while j < n and script[j].isdigit():
            j += 1
        real, i = True, j
    if i < n and (_is_ident_char(script[i]) or script[i] == "@"):
        raise error(f"invalid suffix on number literal '{script[start:i + 1]}'", start)
    text = script[start:i]
    return i, (Token("real", text, start, float(text)) if real else Token("int", text, start, int(text)))


# ----------------------------------------------------------------------------- parser


class _Parser:
    def __init__(self, script: str):
        self.script = script
        self.tokens = tokenize(script)
        self.index = 0

    def peek(self) -> Token:
        return self.tokens[self.index]

    def advance(self) -> Token:
        token = self.tokens[self.index]
        if token.kind != "end":
            self.index += 1
        return token

    def error(self, message: str, token: Token | None = None) -> ScriptSyntaxError:
        token = token or self.peek()
        return ScriptSyntaxError(message, self.script, token.pos + 1)

    def is_op(self, *ops: str) -> bool:
        token = self.peek()
        return token.kind == "op" and token.text in ops

    def statements(self) -> list[Expr]:
        statements: list[Expr] = []
        while self.is_op(";"):
            self.advance()
        while self.peek().kind != "end":
            statements.append(self.expression(0))
            if self.peek().kind == "end":
                break
            if not self.is_op(";"):
                raise self.error(f"expected ';' or an operator before '{self.peek().text}'")
            while self.is_op(";"):
                self.advance()
        if not statements:
            raise ScriptSyntaxError("Empty Script", self.script)
        return statements

    def prefix(self) -> Expr:
        token = self.advance()
        kind = token.kind
        if kind in ("int", "real", "str", "bool"):
            return Literal(token.value)
        if kind == "name":
            return Name(token.value)
        if kind == "op":
            if token.text in ("-", "~", "!"):
                operand = self.expression(_PREFIX_BP)
                if token.text == "-" and isinstance(operand, Literal) and is_number(operand.value) \
                        and not isinstance(operand.value, bool):
                    return Literal(-operand.value)  # a negative literal keeps its kind (int stays int)
                return Unary(token.text, operand)
            if token.text == "(":
                inner = self.expression(0)
                if not self.is_op(")"):
                    raise self.error("expected ')'")
                self.advance()
                return inner
        if kind == "end":
            raise self.error("expected an operand at the end of the script", token)
        raise self.error(f"expected an operand, got '{token.text}'", token)

    def expression(self, min_bp: int) -> Expr:
        left = self.prefix()
        while True:
            token = self.peek()
            if token.kind != "op":
                break
            op = token.text
            if op in _ASSIGNMENT_OPS:
                if _ASSIGNMENT_BP < min_bp:
                    break
                if not isinstance(left, Name):
                    raise self.error(f"the left operand of [{op}] must be a blackboard entry", token)
                self.advance()
                return Assignment(op, left.name, self.expression(0))
            if op == "?":
                if _TERNARY_BP < min_bp:
                    break
                self.advance()
                then = self.expression(0)
                if not self.is_op(":"):
                    raise self.error("expected ':' in the ternary expression")
                self.advance()
                left = Conditional(left, then, self.expression(_TERNARY_BP))
                continue
            if op in _COMPARISON_OPS:
                if _COMPARISON_BP < min_bp:
                    break
                ops, operands = [], [left]
                while self.is_op(*_COMPARISON_OPS):
                    ops.append(self.advance().text)
                    operands.append(self.expression(_COMPARISON_BP + 1))
                left = Comparison(ops, operands)
                continue
            bp = _BINDING.get(op)
            if bp is None or bp < min_bp:
                break
            self.advance()
            left = Binary(op, left, self.expression(bp + 1))
        return left


class Script:
    """A parsed script; call it with an Environment to run it (the last statement's value)."""

    __slots__ = ("source", "statements")

    def __init__(self, source: str, statements: list[Expr]):
        self.source = source
        self.statements = statements

    def __call__(self, env: Environment) -> Any:
        try:
            result = EMPTY
            for statement in self.statements:
                result = statement.evaluate(env)
            return result
        except _ScriptRuntimeError as exc:
            raise ScriptError(exc.message, self.source) from None

    def __repr__(self) -> str:
        return f"Script({self.source!r})"


def parse_script(source: str) -> Script:
    """Parse ``source``; raises ScriptSyntaxError (with the column) if it is not a script."""
    if not isinstance(source, str):
        raise ScriptSyntaxError(f"a script must be a string, got {type(source).__name__}")
    return Script(source, _Parser(source).statements())


def validate_script(source: str) -> str | None:
    """None if ``source`` parses, else the error message (BT.CPP's ValidateScript)."""
    try:
        parse_script(source)
    except ScriptSyntaxError as exc:
        return str(exc)
    return None


def run_script(source: str, blackboard: Blackboard, enums: Mapping[str, int] | None = None) -> Any:
    """Parse and run ``source`` on ``blackboard`` (BT.CPP's ParseScriptAndExecute)."""
    return parse_script(source)(Environment(blackboard, enums))
