"""The loop template unrolled for a composition's axes and controllers (:func:`source`): ``for _a in
AXES:`` and ``for _c in CONTROLLERS:`` of :data:`.loop.TEMPLATE` become their bodies once per index,
every name ending in ``_a`` (``_c``) renamed for it.  CPython (:mod:`.pyloop`) and numba
(:func:`mjbench.compiled.jit.loop_for`) run this source."""
from __future__ import annotations

import ast

from .loop import TEMPLATE


class _Unroll(ast.NodeTransformer):
    """``for _a in AXES:`` / ``for _c in CONTROLLERS:`` → the body once per index, renamed."""

    def __init__(self, naxes: int, nctrl: int):
        self.counts = {"AXES": ("_a", naxes), "CONTROLLERS": ("_c", nctrl)}

    def _body(self, body):
        out = []
        for node in body:
            node = self.visit(node)
            out.extend(node if isinstance(node, list) else [node])
        return out

    def generic_visit(self, node):
        for field in ("body", "orelse"):
            if isinstance(getattr(node, field, None), list):
                setattr(node, field, self._body(getattr(node, field)))
        for field, value in ast.iter_fields(node):
            if field in ("body", "orelse"):
                continue
            if isinstance(value, list):
                setattr(node, field, [self.visit(v) if isinstance(v, ast.AST) else v for v in value])
            elif isinstance(value, ast.AST):
                setattr(node, field, self.visit(value))
        return node

    def visit_For(self, node):
        it = node.iter
        if isinstance(it, ast.Name) and it.id in self.counts:
            var, count = self.counts[it.id]
            if not (isinstance(node.target, ast.Name) and node.target.id == var):
                raise SyntaxError(f"loop template: iterate {it.id} with {var}")
            out = []
            for i in range(count):
                for stmt in node.body:
                    new = _Rename(var, i).visit(_copy(stmt))
                    new = self.visit(new)
                    out.extend(new if isinstance(new, list) else [new])
            return out or [ast.Pass()]
        return self.generic_visit(node)


class _Rename(ast.NodeTransformer):
    def __init__(self, var: str, i: int):
        self.var, self.i = var, i

    def visit_Name(self, node):
        if node.id == self.var:
            return ast.copy_location(ast.Constant(self.i), node)
        if node.id.endswith(self.var[-2:]) and node.id != self.var:
            node.id = node.id[:-2] + f"_{self.i}"
        return node


def _copy(node):
    return ast.parse(ast.unparse(node)).body[0]


_SOURCES: dict = {}


def source(naxes: int, nctrl: int) -> str:
    """The loop's source unrolled for ``naxes`` axes and ``nctrl`` controllers (cached)."""
    key = (int(naxes), int(nctrl))
    src = _SOURCES.get(key)
    if src is None:
        tree = ast.parse(TEMPLATE)
        fdef = tree.body[0]
        fdef.body = _Unroll(*key)._body(fdef.body)
        ast.fix_missing_locations(tree)
        src = _SOURCES[key] = ast.unparse(tree) + "\n"
    return src


__all__ = ["source"]
