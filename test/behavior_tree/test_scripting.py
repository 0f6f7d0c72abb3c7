"""BehaviorTree.CPP's scripting language: literals, every operator, assignment rules, errors
(the expectations are BT.CPP's own tests' facts, tests/script_parser_test.cpp)."""
from __future__ import annotations

import math

import pytest

from mycobot_planning.behavior_tree import (
    INT,
    Blackboard,
    ScriptError,
    ScriptSyntaxError,
    parse_script,
    run_script,
    validate_script,
)


@pytest.fixture
def bb() -> Blackboard:
    return Blackboard.create()


def run(bb: Blackboard, text: str, enums=None):
    return run_script(text, bb, enums)


@pytest.mark.parametrize("text, value", [
    ("628", 628), ("-628", -628), ("0x100", 256), ("0X100", 256), ("3.14", 3.14), ("-3.14", -3.14),
    ("3.14e2", 314.0), ("3.14e-2", 0.0314), ("3e2", 300.0), ("3e-2", 0.03), ("'hello world '", "hello world "),
    ('"double quoted"', "double quoted"), ("true", 1), ("false", 0)])
def test_literals(bb, text, value):
    result = run(bb, text)
    assert result == value and type(result) is type(value)


@pytest.mark.parametrize("text", ["0X100g", "0X100.", "3foo", "65.", "65.43foo", "0x", "3e", "3e+", "'hello",
                                  "", "   ", "\t\n\r", "x := ", "(1 + 2", "1 +* 2", "x := 1 y := 2", "#"])
def test_invalid_scripts_are_syntax_errors(text):
    with pytest.raises(ScriptSyntaxError):
        parse_script(text)
    assert validate_script(text) is not None


def test_syntax_errors_say_where():
    with pytest.raises(ScriptSyntaxError) as caught:
        parse_script("a := 1; b := (2 + )")
    assert caught.value.column == 19
    assert "column 19" in str(caught.value) and "a := 1; b := (2 + )" in str(caught.value)


def test_equations(bb):
    assert run(bb, "x:= 3; y:=5; x+y") == 8.0
    assert sorted(bb.keys()) == ["x", "y"] and bb.get("x") == 3 and bb.get("y") == 5
    assert run(bb, "x+=1") == 4 and bb.get("x") == 4
    assert run(bb, "x -= 1") == 3
    assert run(bb, "x*=2") == 6
    assert run(bb, "-x") == -6.0
    assert run(bb, "x/=2") == 3 and bb.get("x") == 3
    assert run(bb, "y/2") == 2.5 and run(bb, "y*2") == 10.0 and run(bb, "y-x") == 2.0
    assert run(bb, "y & x") == (5 & 3) and run(bb, "y | x") == (5 | 3) and run(bb, "y ^ x") == (5 ^ 3)
    assert run(bb, "~0") == -1.0
    with pytest.raises(ScriptError, match="not an integer"):
        run(bb, "y ^ 5.1")


def test_arithmetic_gives_doubles_and_assignment_keeps_the_entry_kind(bb):
    assert run(bb, "1 + 2") == 3.0 and isinstance(run(bb, "1 + 2"), float)
    assert run(bb, "n := 10; n /= 2") == 5 and isinstance(bb.get("n"), int)
    with pytest.raises(ScriptError, match=r"entry \[n\].*2\.5"):
        run(bb, "n /= 2")  # 2.5 does not fit the integer n
    assert run(bb, "d := 10.0; d /= 4") == 2.5


def test_string_operators(bb):
    assert run(bb, "A:='hello'; B:=' '; C:='world'; A+B+C") == "hello world"
    assert run(bb, "A .. ' ' .. C") == "hello world"
    assert run(bb, "'n=' .. 3") == "n=3"
    assert run(bb, "'v=' .. 1.5") == "v=1.500000"  # a double as std::to_string writes it
    assert run(bb, "'x' .. 1 + 2") == "x3.000000"  # + binds tighter than ..
    assert run(bb, "A += '!'") == "hello!"
    with pytest.raises(ScriptError, match="not permitted"):
        run(bb, "A - 'x'")
    with pytest.raises(ScriptError, match="not supported for strings"):
        run(bb, "A *= 'x'")


def test_whitespace_inside_strings_is_kept(bb):
    run(bb, "A:=''; B:=''; C:=''")
    assert run(bb, "A= '   right'; B= ' center '; C= 'left    '  ") == "left    "
    assert (bb.get("A"), bb.get("B"), bb.get("C")) == ("   right", " center ", "left    ")


def test_an_entry_does_not_change_type(bb):
    run(bb, "x := 3; A := 'text'")
    for text in ("x=A", "x='msg'", "A=1.0", "x = 2.5"):
        with pytest.raises(ScriptError):
            run(bb, text)
    assert bb.get("x") == 3 and bb.get("A") == "text"
    assert run(bb, "x = '7'") == 7.0  # a numeric string is read as a number


def test_assign_existing_needs_an_entry_create_makes_one(bb):
    with pytest.raises(ScriptError, match=r"use the operator \[:=\]"):
        run(bb, "new_var=69")
    assert "new_var" not in bb.keys()
    assert run(bb, "new_var := 69") == 69 and bb.get("new_var") == 69


@pytest.mark.parametrize("text", ["'hello' = 'world'", "'hello' = 2.0", "3.0 = 2.0", "x + 1 := 3"])
def test_only_an_entry_can_be_assigned(text):
    with pytest.raises(ScriptSyntaxError, match="must be a blackboard entry"):
        parse_script(text)


def test_comparisons(bb):
    run(bb, "x := 3; y := 5")
    for text, value in [("x < y", 1), ("y > x", 1), ("y != x", 1), ("y == x", 0), ("x <= 3", 1), ("x >= 4", 0),
                        ("x > y", 0), ("y < x", 0), ("y == 5", 1), ("x == 3", 1),
                        ("'hello' == 'hello'", 1), ("'hello' != 'world'", 1), ("'hello' < 'world'", 1),
                        ("'hello' > 'world'", 0), ("1 < 2 < 3", 1), ("3 > 2 > 1", 1), ("1 < 2 > 3", 0),
                        ("5 == 5 == 5", 1), ("5 == 5 != 3", 1), ("1 <= 2 <= 3", 1), ("3 >= 2 >= 1", 1),
                        ("0.1 + 0.2 == 0.3", 1)]:
        assert run(bb, text) == value, text
    # a string meets a number as a number
    assert run(bb, "par1:='3'; par2:=3; par1==par2") == 1
    assert run(bb, "par1:='3'; par2:=4; par1!=par2") == 1
    assert run(bb, "'true' == 1") == 1
    with pytest.raises(ScriptError):
        run(bb, "'abc' == 1")


def test_comparison_with_negative_numbers(bb):
    assert run(bb, "A:=0; A!=-1") == 1 and run(bb, "A:=-1; A!=-1") == 0
    assert run(bb, "A:=0; A>-1") == 1 and run(bb, "A:=0; A<-1") == 0


def test_logic_and_booleans(bb):
    run(bb, "v1:= true; v2:= false")
    assert bb.get("v1") == 1 and bb.get("v2") == 0
    assert run(bb, " v2 = true ") == 1
    assert run(bb, " v2 = !false ") == 1
    assert run(bb, " v2 = !v2 ") == 0
    assert run(bb, "v1 && v2") == 0 and run(bb, "v1 || v2") == 1
    run(bb, "x := 3; y := 5")
    assert run(bb, "(y == x) && (x == 3)") == 0 and run(bb, "(y == x) || (x == 3)") == 1
    assert run(bb, " y == x  &&  x == 3 ") == 0 and run(bb, " y == x  ||  x == 3 ") == 1
    assert run(bb, "!true") == 0 and run(bb, "!!true") == 1
    with pytest.raises(ScriptError, match="castable to bool"):
        run(bb, "x && true")  # 3 is not a bool (only 0 and 1 are)


def test_precedence_and_associativity(bb):
    assert run(bb, "5 - 2 + 1") == 4.0
    assert run(bb, "10 - 3 - 2") == 5.0
    assert run(bb, "12 / 3 / 2") == 2.0
    assert run(bb, "12 / 3 * 2") == 8.0
    assert run(bb, "2 + 3 * 4 - 1") == 13.0
    assert run(bb, "(2 + 3) * 4") == 20.0 and run(bb, "2 * (3 + 4)") == 14.0
    assert run(bb, "6 | 3 & 5") == 7.0
    assert run(bb, "true && (6 | 0) == 6") == 1
    assert run(bb, "false || true && true") == 1 and run(bb, "false && true || true") == 1
    assert run(bb, "true || false && false") == 1  # && binds tighter than ||
    assert run(bb, "-(3 + 2)") == -5.0 and run(bb, "10 + -3") == 7.0
    assert run(bb, "x := 1 + 2 * 3") == 7.0 and bb.get("x") == 7.0


def test_ternary(bb):
    assert run(bb, "true ? 1 : 2") == 1 and run(bb, "false ? 1 : 2") == 2
    assert run(bb, "true ? 2 + 3 : 10") == 5.0 and run(bb, "false ? 10 : 2 + 3") == 5.0
    assert run(bb, "3 > 2 ? 'yes' : 'no'") == "yes" and run(bb, "3 < 2 ? 'yes' : 'no'") == "no"
    assert run(bb, "0 ? 'a' : 1 ? 'b' : 'c'") == "b"
    assert run(bb, "mode := 2 > 1 ? 'fast' : 'slow'") == "fast" and bb.get("mode") == "fast"


def test_multiple_statements_return_the_last_value(bb):
    run(bb, "a:=1;;; b:=2;;")
    assert (bb.get("a"), bb.get("b")) == (1, 2)
    assert run(bb, "a:=10; b:=20; a+b") == 30.0
    assert run(bb, "A:=5;\nB:=6") == 6


def test_uninitialized_entries_are_errors(bb):
    bb.create_entry("x", INT)
    for text in ("x < 0", "x == 0", "x > 0", "x + 1", "x += 1"):
        with pytest.raises(ScriptError, match="not initialized"):
            run(bb, text)
    with pytest.raises(ScriptError, match="Variable not found: nope"):
        run(bb, "nope + 1")


def test_enums(bb):
    enums = {"RED": 1, "BLUE": 3, "GREEN": 5}
    run(bb, "A:=RED; B:=RED; C:=BLUE", enums)
    assert run(bb, "A==B", enums) == 1 and run(bb, "A!=C", enums) == 1
    assert bb.get("C") == 3.0
    assert run(bb, "color := 'GREEN'; color == GREEN", enums) == 1  # an enum name in a string is its value


def test_root_entries_with_at(bb):
    child = Blackboard.create(bb)
    run(child, "@shared := 7; local := @shared + 1")
    assert bb.get("shared") == 7 and "local" not in bb.keys() and child.get("local") == 8.0


def test_division_by_zero_is_ieee(bb):
    assert run(bb, "1 / 0") == math.inf and run(bb, "-1 / 0") == -math.inf and math.isnan(run(bb, "0 / 0"))


def test_runtime_errors_name_the_script(bb):
    with pytest.raises(ScriptError) as caught:
        run(bb, "x := 'a' - 1")
    assert "x := 'a' - 1" in str(caught.value)
