"""The CPython loop of a composition: the template unrolled, specialised to its constants, compiled once.

CPython executes :func:`mjbench.kernel.unroll.source` (the template unrolled for the machine's axes and
controllers) with a composition's laws, flags and layout offsets as globals.  Before it is compiled
the source is specialised to the composition's constants, as numba does with the same source: every
flag and offset (the integers and booleans of :attr:`Program.flags`) becomes a constant, every test
on constants is decided and the branch it never takes is dropped.  No floating-point operation is
changed, moved or removed (only tests on constants and integer index arithmetic are evaluated), so
the loop gives the template's bits.

The code object is kept in memory per composition's constants and in the user cache
(:func:`mjbench.compiled.cache.store_object`, folder ``loops``), keyed by the template's text, the
sources of this module, of :mod:`.loop` and of :mod:`.unroll` as imported, Python's version and the constants: a second
command neither unrolls the template nor compiles it.
"""
from __future__ import annotations

import ast
import hashlib
import marshal
import os
import sys
import types

from ..compiled import cache
from . import inline
from . import loop as LP
from . import unroll

#: the code objects of the compositions met in this process: (axes, controllers, constants) → code
_CODE: dict = {}


def _stamp() -> str:
    """The template's text and the modules' files as imported (size, modification time)."""
    h = hashlib.sha256(LP.TEMPLATE.encode())
    for f in (LP.__file__, unroll.__file__, inline.__file__, __file__):
        try:
            st = os.stat(f)
            h.update(f"{os.path.basename(f)}:{st.st_size}:{st.st_mtime_ns}".encode())
        except OSError:
            h.update(f.encode())
    h.update(sys.version.encode())
    return h.hexdigest()


_STAMP = _stamp()


def constants(flags: dict) -> tuple:
    """The flags and layout offsets that become constants: integers and booleans, sorted by name."""
    return tuple(sorted((k, v) for k, v in flags.items() if isinstance(v, (bool, int))))


def code(naxes: int, nctrl: int, flags: dict, env: dict | None = None) -> tuple:
    """The compiled, specialised loop function's code for these axes, controllers and flags, with
    the laws of the loop's globals ``env`` inlined (:mod:`.inline`; None: none): (code, the aliases
    it adds to the globals {name: path}, the inlined laws [(path, file line of the def)])."""
    consts = constants(flags)
    lkey = inline.law_key(env) if env is not None else ""
    key = (int(naxes), int(nctrl), consts, lkey)
    hit = _CODE.get(key)
    if hit is None:
        disk = hashlib.sha256(f"{_STAMP}\n{key!r}".encode()).hexdigest()[:40]
        blob = cache.load_object("loops", disk, "CPython loop")
        try:
            hit = marshal.loads(blob) if isinstance(blob, bytes) else None
        except (ValueError, EOFError, TypeError):
            hit = None
        if not (isinstance(hit, tuple) and len(hit) == 3 and isinstance(hit[0], types.CodeType)
                and hit[0].co_name == "_loop"):
            tree = ast.parse(specialise(unroll.source(naxes, nctrl), dict(consts)))
            aliases, laws = inline.fuse(tree, env) if env is not None else ({}, [])
            if env is not None:
                inline.hoist(tree)
            mod = compile(tree, f"<mjbench loop {naxes} axis(es), {nctrl} controller(s)>", "exec")
            c = next(x for x in mod.co_consts if isinstance(x, types.CodeType))
            hit = (c, aliases, laws)
            cache.store_object("loops", disk, marshal.dumps(hit))
        _CODE[key] = hit
    return hit


def specialise(src: str, consts: dict) -> str:
    """``src`` (a loop source) with the names of ``consts`` replaced by their values, the tests on
    constants decided and the branches never taken dropped."""
    tree = ast.parse(src)
    stored = {n.id for n in ast.walk(tree) if isinstance(n, ast.Name) and not isinstance(n.ctx, ast.Load)}
    tree = _Fold({k: v for k, v in consts.items() if k not in stored}).visit(tree)
    _fill(tree)
    ast.fix_missing_locations(tree)
    return ast.unparse(tree) + "\n"


def _const(node) -> bool:
    return isinstance(node, ast.Constant)


class _Fold(ast.NodeTransformer):
    """Constants in, tests on constants decided (exact: what Python would compute at run time)."""

    def __init__(self, consts: dict):
        self.consts = consts

    def visit_Name(self, node):
        if isinstance(node.ctx, ast.Load) and node.id in self.consts:
            return ast.copy_location(ast.Constant(self.consts[node.id]), node)
        return node

    def _value(self, node):
        """``node`` evaluated (every operand a constant), or ``node`` if it cannot be."""
        try:
            value = eval(compile(ast.Expression(node), "<fold>", "eval"), {"__builtins__": {}})  # noqa: S307
        except Exception:  # noqa: BLE001 - left to run time (e.g. a division by zero)
            return node
        if isinstance(value, (bool, int, float)):
            return ast.copy_location(ast.Constant(value), node)
        return node

    def visit_BinOp(self, node):
        self.generic_visit(node)
        if _const(node.left) and _const(node.right) and not isinstance(node.left.value, float) \
                and not isinstance(node.right.value, float):
            return self._value(node)
        return node

    def visit_UnaryOp(self, node):
        self.generic_visit(node)
        if _const(node.operand) and (isinstance(node.op, ast.Not) or not isinstance(node.operand.value, float)):
            return self._value(node)
        return node

    def visit_Compare(self, node):
        self.generic_visit(node)
        if _const(node.left) and all(_const(c) for c in node.comparators):
            return self._value(node)
        return node

    def visit_BoolOp(self, node):
        """``a and True and b`` is ``a and b``; ``a and False and b`` is ``a and False``; the same for
        ``or`` with the truth values swapped (exact: the same operands evaluated, the same value)."""
        self.generic_visit(node)
        decides = isinstance(node.op, ast.Or)  # the truth value that ends the evaluation
        vals = []
        for i, v in enumerate(node.values):
            last = i == len(node.values) - 1
            if _const(v) and bool(v.value) is not decides and not last:
                continue  # never decides, never the value: dropped
            vals.append(v)
            if _const(v) and bool(v.value) is decides:
                break  # decides: what follows is never evaluated
        if len(vals) == 1:
            return vals[0]
        node.values = vals
        return node

    def visit_If(self, node):
        self.generic_visit(node)
        if _const(node.test):
            return node.body if node.test.value else node.orelse
        return node

    def visit_IfExp(self, node):
        self.generic_visit(node)
        if _const(node.test):
            return node.body if node.test.value else node.orelse
        return node


def _fill(tree) -> None:
    """A block left empty by a dropped branch gets a ``pass``."""
    for node in ast.walk(tree):
        for field in ("body", "orelse", "finalbody"):
            block = getattr(node, field, None)
            if isinstance(block, list) and field == "body" and not block:
                block.append(ast.Pass())


__all__ = ["code", "specialise", "constants"]
