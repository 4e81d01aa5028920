"""Paper 002's meta-language: specialize() against the C preprocessor and a tree evaluator."""
from __future__ import annotations

import shutil
import subprocess
from dataclasses import dataclass

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import oclshade
from oclshade import OclshadeError
from oclshade.runtime import kernel_source
from oclshade.specialize import SpecializeError, from_ifdefs, specialize

NAMES = ("A", "B", "C", "D")
CPP = shutil.which("gcc") or shutil.which("cpp")


# ----------------------------------------------------------------------------- generated programs
@dataclass
class If:
    conds: list[tuple[bool, str]]      # (negated, name)
    then: list
    orelse: list | None


def programs(depth: int = 4):
    """Nested blocks of body lines and @IF blocks (bodies numbered later)."""
    conds = st.lists(st.tuples(st.booleans(), st.sampled_from(NAMES)), min_size=1, max_size=3)
    return st.recursive(
        st.lists(st.just("line"), max_size=3),
        lambda inner: st.lists(st.one_of(st.just("line"),
                                         st.builds(If, conds, inner, st.one_of(st.none(), inner))),
                               max_size=4),
        max_leaves=25)


def render(block: list, style: str, counter: list[int], indent: str = "") -> list[str]:
    """Lines in the meta-language ('meta') or as #if defined(...) ('cpp')."""
    lines = []
    for item in block:
        if item == "line":
            counter[0] += 1
            lines.append(f"{indent}x{counter[0]} = {counter[0]};")
            continue
        if style == "meta":
            lines.append(f"{indent}@IF " + " ".join(("!" if n else "") + c for n, c in item.conds) + ";")
        else:
            lines.append("#if " + " || ".join(("!" if n else "") + f"defined({c})" for n, c in item.conds))
        lines += render(item.then, style, counter, indent + "  ")
        if item.orelse is not None:
            lines.append(f"{indent}@ELSE;" if style == "meta" else "#else")
            lines += render(item.orelse, style, counter, indent + "  ")
        lines.append(f"{indent}@ENDIF;" if style == "meta" else "#endif")
    return lines


def text(prog: list, style: str) -> str:
    return "".join(line + "\n" for line in render(prog, style, [0]))


def evaluate(block: list, vector: set[str], counter: list[int], indent: str = "") -> list[str]:
    """Independent evaluator of a generated program (same numbering as render)."""
    out = []
    for item in block:
        if item == "line":
            counter[0] += 1
            out.append(f"{indent}x{counter[0]} = {counter[0]};")
            continue
        taken = any((c in vector) != n for n, c in item.conds)
        then = evaluate(item.then, vector, counter, indent + "  ")
        orelse = evaluate(item.orelse, vector, counter, indent + "  ") if item.orelse is not None else []
        out += then if taken else orelse
    return out


def body_lines(text: str) -> list[str]:
    return [ln.strip() for ln in text.splitlines() if ln.strip()]


def run_cpp(text: str, vector: set[str]) -> list[str]:
    cmd = [CPP, "-E", "-P", "-undef", "-x", "c", *[f"-D{v}" for v in sorted(vector)], "-"]
    proc = subprocess.run(cmd, input=text, capture_output=True, text=True, check=True)
    return body_lines(proc.stdout)


vectors = st.sets(st.sampled_from(NAMES))


@settings(max_examples=200, deadline=None)
@given(prog=programs(), vector=vectors)
def test_specialize_equals_independent_evaluator(prog, vector):
    meta = text(prog, "meta")
    got = specialize(meta, " ".join(sorted(vector)))
    assert got.splitlines() == evaluate(prog, vector, [0])
    assert "@" not in got


@pytest.mark.skipif(CPP is None, reason="no C preprocessor (gcc/cpp) on this machine")
@settings(max_examples=80, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(prog=programs(), vector=vectors)
def test_specialize_equals_c_preprocessor(prog, vector):
    meta = text(prog, "meta")
    cpp = text(prog, "cpp")
    assert body_lines(specialize(meta, sorted(vector))) == run_cpp(cpp, vector)


@settings(max_examples=100, deadline=None)
@given(prog=programs(), vector=vectors)
def test_from_ifdefs_round_trip(prog, vector):
    """#if defined(..) blocks rewritten to @IF resolve as the evaluator says."""
    cpp = text(prog, "cpp")
    got = specialize(from_ifdefs(cpp, NAMES), vector)
    assert body_lines(got) == [ln.strip() for ln in evaluate(prog, vector, [0])]


@settings(max_examples=50, deadline=None)
@given(prog=programs(), vector=vectors)
def test_keep_line_numbers(prog, vector):
    meta = text(prog, "meta")
    kept = specialize(meta, vector, keep_line_numbers=True)
    assert len(kept.splitlines()) == len(meta.splitlines())
    for src, out in zip(meta.splitlines(), kept.splitlines()):
        assert out in ("", src)
    assert body_lines(kept) == body_lines(specialize(meta, vector))


def test_paper_example_and_public_name():
    src = ("a;\n@IF BUMP SPECULAR;\n b;\n @IF !SPOT;\n  c;\n @ELSE;\n  d;\n @ENDIF;\n"
           "@ELSE;\n e;\n@ENDIF;\nf;\n")
    assert oclshade.specialize(src, "BUMP SPECULAR SPOT") == "a;\n b;\n  d;\nf;\n"
    assert oclshade.specialize(src, "SPECULAR") == "a;\n b;\n  c;\nf;\n"
    assert oclshade.specialize(src, "") == "a;\n e;\nf;\n"
    assert specialize("x;\r\n@IF A;\r\ny;\r\n@ENDIF;\r\n", "A") == "x;\r\ny;\r\n"


@pytest.mark.parametrize("src, line, words", [
    ("a\n@IF A;\nb\n", 2, "not closed"),
    ("a\n@IF A;\n@IF B;\n@ENDIF;\n", 2, "not closed"),
    ("a\n@ENDIF;\n", 2, "without a matching @IF"),
    ("@ELSE;\n", 1, "without a matching @IF"),
    ("@IF A;\n@ELSE;\n@ELSE;\n@ENDIF;\n", 3, "second @ELSE"),
    ("x\n\n@IF;\n@ENDIF;\n", 3, "at least one condition"),
    ("@IF A;\n  @FOO;\n@ENDIF;\n", 2, "unknown directive '@FOO'"),
    ("@if A;\n@ENDIF;\n", 1, "unknown directive"),
    ("@IF A\n@ENDIF;\n", 1, "must end with ';'"),
    ("@IF A; x\n@ENDIF;\n", 1, "after ';'"),
    ("@IF A-B;\n@ENDIF;\n", 1, "bad condition"),
    ("@IF !;\n@ENDIF;\n", 1, "bad condition"),
    ("@IF A;\n@ENDIF B;\n", 2, "takes no condition"),
    ("@;\n", 1, "empty directive"),
])
def test_malformed_input_names_the_line(src, line, words):
    with pytest.raises(SpecializeError, match=words) as info:
        specialize(src, "A")
    assert info.value.line == line and str(info.value).startswith(f"line {line}:")
    assert isinstance(info.value, ValueError) and isinstance(info.value, OclshadeError)


def test_errors_inside_untaken_branches_are_still_errors():
    with pytest.raises(SpecializeError, match="unknown directive"):
        specialize("@IF A;\n@IF B;\n@BAD;\n@ENDIF;\n@ENDIF;\n", "")


@pytest.mark.parametrize("vector", ["A !B", "A,B", ["A", 3]])
def test_bad_condition_vector(vector):
    with pytest.raises(SpecializeError, match="conditions must be names"):
        specialize("x\n", vector)


def test_shadow_kernel_stripped_of_a_feature():
    """The shadow kernel's OCLS_STATS code is physically absent after from_ifdefs + specialize,
    while the #if OCLS_METHOD blocks stay for the compiler."""
    src = kernel_source("shadow.cl")
    names = ("OCLS_STATS", "OCLS_OUT_SELF", "OCLS_OUT_COEF", "OCLS_OUT_MASK")
    stripped = specialize(from_ifdefs(src, names), "OCLS_OUT_MASK")
    assert "atomic_add" in src and "atomic_add" not in stripped
    assert "self_shadowed(h, H, W, i, j" not in stripped and "coef[idx]" not in stripped
    assert "mask[idx]" in stripped and "#if OCLS_METHOD == OCLS_PAPER" in stripped
    assert "@" not in stripped
