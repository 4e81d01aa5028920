"""Paper 002's static shader optimisation: one source, branches resolved before compilation.

The meta-language, as the paper writes it (a directive is a line whose first
non-blank character is ``@``; each ends with ``;``)::

    @IF cond1 [cond2 ...];     true if ANY listed condition holds; "!cond" negates one
    ...
    [@ELSE;
    ...]
    @ENDIF;

Blocks nest to any depth.  The condition vector is a string of names such as
``"BUMP SPECULAR SPOT"`` (or any iterable of names).  :func:`specialize`
copies the lines outside ``@IF`` blocks, keeps the taken branch of each block
and drops the other, recursively: a branch-free source for that vector.
Malformed input raises :class:`SpecializeError` with the line number:
unknown directive, missing or extra text after ``;``, empty condition, a
condition that is not a name, ``@ELSE;`` or ``@ENDIF;`` without ``@IF``, a
second ``@ELSE;``, an ``@IF`` left open at the end.

Do the kernels use it?  No: they keep ``#if`` / ``#ifdef`` on ``-D OCLS_...``
options, for three reasons.

1. Nothing is gained in the compiled program.  OpenCL C compilers run the C
   preprocessor on every build, so a block under ``#ifdef OCLS_X`` without
   ``-D OCLS_X`` is removed before compilation exactly as ``@IF OCLS_X;``
   would remove it; the program cache is already keyed on the options.
   bench/skipping.py measures it: the shadow kernel built with a feature's
   ``-D`` off runs as fast as the same kernel with the feature's code
   physically removed by :func:`specialize` (see ``bench/results/skipping.md``).
2. The kernels are shared with C/C++ pipelines that build them with their own
   ``clBuildProgram`` (DESIGN.md, host API).  ``#if`` is understood by every
   OpenCL compiler; ``@IF`` lines would need this preprocessor ported to C.
3. ``#if`` says more: ``OCLS_METHOD == OCLS_PAPER`` selects one of several
   values, which a disjunction of names cannot express without one name per
   value.

The meta-language is kept for sources written in it (paper 002's shaders,
users' own kernels) and to produce physically stripped variants of our
kernels for measurements: :func:`from_ifdefs` rewrites the ``#ifdef`` /
``#if defined(..) || ..`` blocks on chosen names into ``@IF`` blocks, which
:func:`specialize` then resolves.
"""
from __future__ import annotations

import re
from dataclasses import dataclass
from typing import Iterable

from .runtime import OclshadeError

_NAME = re.compile(r"[A-Za-z_][A-Za-z0-9_]*\Z")
_DIRECTIVE = re.compile(r"\s*@")


class SpecializeError(OclshadeError, ValueError):
    """Malformed meta-language source; ``line`` is 1-based (None for a bad condition vector)."""

    def __init__(self, message: str, line: int | None = None):
        self.line = line
        super().__init__(f"line {line}: {message}" if line is not None else message)


def condition_names(conditions: str | Iterable[str]) -> frozenset[str]:
    """The set of names in a condition vector ("A B C" or an iterable of names)."""
    items = conditions.split() if isinstance(conditions, str) else list(conditions)
    bad = [c for c in items if not isinstance(c, str) or not _NAME.match(c)]
    if bad:
        raise SpecializeError(f"conditions must be names like 'BUMP SPECULAR' (letters, digits, _); got {bad!r}")
    return frozenset(items)


@dataclass
class _Block:
    line: int            # line of its @IF
    parent_on: bool      # the enclosing text is kept
    taken: bool          # the @IF condition holds
    in_else: bool = False

    @property
    def on(self) -> bool:
        return self.parent_on and (self.taken != self.in_else)


def _parse_directive(text: str, line: int) -> tuple[str, list[tuple[bool, str]]]:
    """('IF' | 'ELSE' | 'ENDIF', [(negated, name), ...]) of one directive line."""
    body = text.strip()[1:]
    if ";" not in body:
        raise SpecializeError(f"directive {text.strip()!r} must end with ';'", line)
    head, rest = body.split(";", 1)
    if rest.strip():
        raise SpecializeError(f"unexpected text {rest.strip()!r} after ';' in {text.strip()!r}", line)
    words = head.split()
    if not words:
        raise SpecializeError("empty directive '@;'", line)
    keyword, args = words[0], words[1:]
    if keyword not in ("IF", "ELSE", "ENDIF"):
        raise SpecializeError(f"unknown directive '@{keyword}'; expected @IF, @ELSE or @ENDIF", line)
    if keyword != "IF":
        if args:
            raise SpecializeError(f"@{keyword} takes no condition, got {' '.join(args)!r}", line)
        return keyword, []
    if not args:
        raise SpecializeError("@IF needs at least one condition, e.g. '@IF BUMP !SPOT;'", line)
    conds = []
    for a in args:
        neg, name = a.startswith("!"), a[1:] if a.startswith("!") else a
        if not _NAME.match(name):
            raise SpecializeError(f"bad condition {a!r} in @IF: expected NAME or !NAME", line)
        conds.append((neg, name))
    return keyword, conds


def specialize(source: str, conditions: str | Iterable[str] = "", *, keep_line_numbers: bool = False) -> str:
    """The branch-free source for a condition vector (see the module docstring).

    keep_line_numbers: dropped lines (directives, untaken branches) become empty
    lines, so a compiler's line numbers still point into ``source``.
    """
    names = condition_names(conditions)
    out: list[str] = []
    stack: list[_Block] = []
    for n, text in enumerate(source.splitlines(keepends=True), start=1):
        on = stack[-1].on if stack else True
        if not _DIRECTIVE.match(text):
            if on:
                out.append(text)
            elif keep_line_numbers:
                out.append("\n" if text.endswith(("\n", "\r")) else "")
            continue
        keyword, conds = _parse_directive(text, n)
        if keyword == "IF":
            stack.append(_Block(n, on, any((name in names) != neg for neg, name in conds)))
        elif not stack:
            raise SpecializeError(f"@{keyword}; without a matching @IF", n)
        elif keyword == "ELSE":
            if stack[-1].in_else:
                raise SpecializeError(f"second @ELSE; for the @IF on line {stack[-1].line}", n)
            stack[-1].in_else = True
        else:
            stack.pop()
        if keep_line_numbers:
            out.append("\n" if text.endswith(("\n", "\r")) else "")
    if stack:
        raise SpecializeError(f"@IF not closed by @ENDIF; before the end of the source ({len(stack)} open)",
                              stack[-1].line)
    return "".join(out)


_IFDEF = re.compile(r"\s*#\s*ifdef\s+([A-Za-z_]\w*)\s*$")
_IFNDEF = re.compile(r"\s*#\s*ifndef\s+([A-Za-z_]\w*)\s*$")
_IF_DEFINED = re.compile(r"\s*#\s*if\s+(!?\s*defined\s*\(\s*[A-Za-z_]\w*\s*\)(\s*\|\|\s*!?\s*defined\s*\(\s*[A-Za-z_]\w*\s*\))*)\s*$")
_DEFINED = re.compile(r"(!?)\s*defined\s*\(\s*([A-Za-z_]\w*)\s*\)")
_IF_ANY = re.compile(r"\s*#\s*if(n?def)?\b")
_ELSE = re.compile(r"\s*#\s*else\b")
_ENDIF = re.compile(r"\s*#\s*endif\b")


def from_ifdefs(source: str, names: Iterable[str]) -> str:
    """Rewrite preprocessor blocks that test only ``names`` into ``@IF`` blocks.

    A block is rewritten when its opening line is ``#ifdef N``, ``#ifndef N``
    or ``#if [!]defined(N) || [!]defined(M) ...`` and every name is in
    ``names``; its ``#else`` / ``#endif`` follow.  Every other ``#if`` block
    (``#if OCLS_METHOD == 2``, include guards, ...) and its lines are left as
    they are, so ``specialize(from_ifdefs(src, names), vector)`` equals the
    preprocessor's resolution of those names alone.  ``#elif`` inside a
    rewritten block is not supported (SpecializeError).
    """
    wanted = condition_names(names)
    out: list[str] = []
    stack: list[bool] = []          # per open #if: rewritten?
    for n, text in enumerate(source.splitlines(keepends=True), start=1):
        end = "\n" if text.endswith("\n") else ""
        conds = None
        if m := _IFDEF.match(text):
            conds = [("", m.group(1))]
        elif m := _IFNDEF.match(text):
            conds = [("!", m.group(1))]
        elif m := _IF_DEFINED.match(text):
            conds = _DEFINED.findall(m.group(1))
        if conds is not None and all(name in wanted for _, name in conds):
            stack.append(True)
            out.append("@IF " + " ".join(neg + name for neg, name in conds) + ";" + end)
            continue
        if _IF_ANY.match(text):
            stack.append(False)
        elif re.match(r"\s*#\s*elif\b", text) and stack and stack[-1]:
            raise SpecializeError("#elif in a block on the given names is not supported", n)
        elif _ELSE.match(text) and stack and stack[-1]:
            out.append("@ELSE;" + end)
            continue
        elif _ENDIF.match(text) and stack:
            if stack.pop():
                out.append("@ENDIF;" + end)
                continue
        out.append(text)
    return "".join(out)
