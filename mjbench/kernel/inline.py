"""The laws written into the CPython loop (:func:`fuse`): a slot's call replaced by the law's own body.

A CPython function call costs about as much as ten arithmetic operations, and one co-step of a
one-motor machine calls about fifteen laws (the reference and the controller with their signal
adapters, the drive's laws, the plant step and its load, ``clip``).  Numba inlines them into the
compiled loop; this does the same for the loop CPython runs: a statement ``x = LAW(a, b)`` or
``LAW(a, b)`` whose ``LAW`` is a plain Python function becomes the law's body, its parameters bound
to the arguments, its locals renamed apart, its globals reached through names of the loop's own,
its final ``return v`` an assignment ``x = v``; laws called by an inlined body are inlined in turn.

Nothing is computed differently: the same operations on the same values in the same order (the
arguments are evaluated first, in order, as a call does), so the loop gives the same bits; a law
is inlined only when its source, compiled again, is its running code (an edited file is not read
as the code that runs).  A law with an early ``return``, a closure, a nested function, a
comprehension, ``try``/``with``, keyword or default arguments is called as before.  Each inlined
statement keeps its law and its line (:data:`LINE_BASE`): a law that fails inside the loop is
named with its own line (:func:`mjbench.kernel.checks.law_failure_message`).

Each inlined global is recorded as a path from the loop's globals (:func:`resolve`), so a fused
loop kept on disk is bound again to the objects of the process that loads it.
"""
from __future__ import annotations

import ast
import builtins
import copy
import dis
import functools
import hashlib
import marshal
import types

from .loop import def_source

#: line numbers of inlined statements: (k + 1)·LINE_BASE + the statement's line in the k-th inlined
#: law's source (1: its ``def`` line)
LINE_BASE = 100_000
#: laws inlined into laws inlined into the loop …: at most this deep
MAX_DEPTH = 5

_REFUSED = (ast.Yield, ast.YieldFrom, ast.Await, ast.Lambda, ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef,
            ast.Global, ast.Nonlocal, ast.ListComp, ast.SetComp, ast.DictComp, ast.GeneratorExp, ast.Try,
            ast.With, ast.AsyncWith, ast.Import, ast.ImportFrom, ast.Delete, ast.NamedExpr)
_SCOPE_NAMES = {"locals", "vars", "super", "__class__", "eval", "exec", "globals", "dir"}


def _target(obj):
    """(function, bound leading arguments) of a slot value: a plain function or a ``functools.partial``
    of one (a law with its function arguments bound in front), else None."""
    if isinstance(obj, functools.partial) and not obj.keywords and isinstance(obj.func, types.FunctionType):
        return obj.func, tuple(obj.args)
    if isinstance(obj, types.FunctionType):
        return obj, ()
    return None


def _source(fn):
    """(the parsed ``def`` of ``fn``, the file line of its ``def``) when its source can be read and,
    compiled again, is the code that runs; else None."""
    code = fn.__code__
    src = getattr(fn, "source", None)  # generated functions carry their source
    first = 1
    if not isinstance(src, str):
        found = def_source(code.co_filename, code.co_firstlineno)
        if found is None:
            return None
        src, first = found
    try:
        tree = ast.parse(src)
        fdef = next(n for n in tree.body if isinstance(n, ast.FunctionDef) and n.name == code.co_name)
        fdef.decorator_list = []
        again = compile(ast.Module([fdef], []), code.co_filename, "exec")
        c = next(x for x in again.co_consts if isinstance(x, types.CodeType))
    except (SyntaxError, StopIteration, ValueError, TypeError):
        return None
    if (c.co_consts, c.co_names, c.co_varnames) != (code.co_consts, code.co_names, code.co_varnames) \
            or _ops(c) != _ops(code):
        return None
    return fdef, first


def _ops(code) -> list:
    """The instructions of ``code`` up to how a call of a module's attribute is spelled (its own
    module's compiler knows ``math`` is an import and loads ``math.isnan`` as an attribute, a
    function compiled alone as a method) and where jumps land."""
    out = []
    for i in dis.get_instructions(code):
        op = "LOAD_ATTR" if i.opname == "LOAD_METHOD" else i.opname
        out.append((op, None if i.opcode in dis.hasjrel or i.opcode in dis.hasjabs else i.argval))
    return out


def _inlinable(fn, fdef, nargs: int) -> bool:
    code = fn.__code__
    if fn.__closure__ or code.co_freevars or code.co_cellvars or fn.__defaults__ or fn.__kwdefaults__:
        return False
    a = fdef.args
    if a.vararg or a.kwarg or a.kwonlyargs or a.posonlyargs or len(a.args) != nargs:
        return False
    body = fdef.body
    for node in ast.walk(fdef):
        if node is fdef:
            continue
        if isinstance(node, _REFUSED) or (isinstance(node, ast.Name) and node.id in _SCOPE_NAMES):
            return False
        if isinstance(node, ast.Return) and node is not body[-1]:
            return False
    return True


class _Rename(ast.NodeTransformer):
    def __init__(self, local: dict, subst: dict, glob: dict):
        self.local, self.subst, self.glob = local, subst, glob

    def visit_Name(self, node):
        if node.id in self.subst and isinstance(node.ctx, ast.Load):
            return ast.copy_location(_copy(self.subst[node.id]), node)
        new = self.local.get(node.id) or self.glob.get(node.id)
        if new is not None:
            node.id = new
        return node


def _copy(node):
    return copy.deepcopy(node)


def _stored(fdef) -> set:
    out = set()
    for n in ast.walk(fdef):
        if isinstance(n, ast.Name) and not isinstance(n.ctx, ast.Load):
            out.add(n.id)
        elif isinstance(n, ast.AugAssign) and isinstance(n.target, ast.Name):
            out.add(n.target.id)
    return out


class Fuser:
    """One fusion: the loop's globals ``env`` in, the aliases it adds and the inlined laws out."""

    def __init__(self, env: dict):
        self.env = env
        self.paths: dict = {}  # alias → path from the loop's globals (resolve)
        self.objs: dict = {}  # alias → object
        self.laws: list = []  # k → (path of the inlined function, file line of its def)
        self._sources: dict = {}

    # -------------------------------------------------------------- names
    def _alias(self, path, obj) -> str:
        for a, p in self.paths.items():
            if p == path:
                return a
        name = f"_il{len(self.paths)}"
        while name in self.env:
            name += "_"
        self.paths[name], self.objs[name] = path, obj
        return name

    def _lookup(self, name):
        """(object, path) of a global name of the loop or of an alias, else None."""
        if name in self.objs:
            return self.objs[name], self.paths[name]
        if name in self.env:
            return self.env[name], (("env", name),)
        return None

    # -------------------------------------------------------------- the pass
    def body(self, stmts: list, depth: int = 0) -> list:
        out = []
        for st in stmts:
            for field in ("body", "orelse"):
                blk = getattr(st, field, None)
                if isinstance(blk, list) and blk and isinstance(blk[0], ast.stmt):
                    setattr(st, field, self.body(blk, depth))
            out.extend(self._statement(st, depth))
        return out

    def _statement(self, st, depth):
        call = None
        if isinstance(st, ast.Expr) and isinstance(st.value, ast.Call):
            call = st.value
        elif isinstance(st, ast.Assign) and len(st.targets) == 1 and isinstance(st.value, ast.Call):
            call = st.value
        if call is None or depth >= MAX_DEPTH or not isinstance(call.func, ast.Name) or call.keywords \
                or any(isinstance(a, ast.Starred) for a in call.args):
            return [st]
        hit = self._lookup(call.func.id)
        tgt = _target(hit[0]) if hit is not None else None
        if tgt is None:
            return [st]
        fn, bound = tgt
        path = hit[1]
        src = self._sources.get(fn)
        if src is None:
            src = self._sources[fn] = _source(fn) or (None, 0)
        fdef, first = src
        nargs = len(bound) + len(call.args)
        if fdef is None or not _inlinable(fn, fdef, nargs):
            return [st]
        fpath = path + ((("func",),) if bound else ())
        return self._inline(st, call, fn, fdef, first, bound, path, fpath, depth)

    def _inline(self, st, call, fn, fdef, first, bound, path, fpath, depth):
        k = len(self.laws)
        self.laws.append((fpath, first))
        fdef = copy.deepcopy(fdef)  # a fresh tree (its lines: 1 = the def)
        params = [x.arg for x in fdef.args.args]
        stored = _stored(fdef)
        local = {v: f"{v}__{k}" for v in fn.__code__.co_varnames}
        pre, subst = [], {}
        args = [None] * len(bound) + list(call.args)
        for i, p in enumerate(params):
            if i < len(bound):  # a bound function argument: a global of the loop
                subst[p] = ast.Name(self._alias(path + (("arg", i),), bound[i]), ast.Load())
            elif isinstance(args[i], (ast.Name, ast.Constant)) and p not in stored:
                subst[p] = args[i]
            else:
                pre.append(ast.Assign([ast.Name(local[p], ast.Store())], args[i]))
        glob = {}
        for node in ast.walk(fdef):
            if isinstance(node, ast.Name) and node.id not in local and node.id not in glob:
                g = fn.__globals__
                if node.id in g:
                    glob[node.id] = self._alias(fpath + (("global", node.id),), g[node.id])
                elif hasattr(builtins, node.id):
                    if node.id in self.env or node.id in self.objs:
                        glob[node.id] = self._alias((("builtin", node.id),), getattr(builtins, node.id))
        body = [s for s in fdef.body if not (isinstance(s, ast.Expr) and isinstance(s.value, ast.Constant)
                                             and isinstance(s.value.value, str))]
        ret = body.pop() if body and isinstance(body[-1], ast.Return) else None
        body = [_Rename(local, subst, glob).visit(s) for s in body]
        value = _Rename(local, subst, glob).visit(ret.value) if ret is not None and ret.value is not None else None
        if isinstance(st, ast.Assign):
            targets = copy.deepcopy(st.targets)
            for n in (n for t in targets for n in ast.walk(t)):
                if hasattr(n, "lineno"):
                    ast.copy_location(n, ret or fdef)
            tail = [ast.copy_location(ast.Assign(targets, value if value is not None else ast.Constant(None)),
                                      ret or fdef)]
        else:
            tail = [ast.copy_location(ast.Expr(value), ret)] if value is not None and not isinstance(
                value, (ast.Name, ast.Constant)) else []
        body = body + tail
        base = (k + 1) * LINE_BASE
        for s in body:
            for n in ast.walk(s):
                if getattr(n, "lineno", None) is not None and n.lineno < LINE_BASE:
                    n.lineno = n.end_lineno = base + n.lineno
        for s in pre:
            ast.copy_location(s, st)
            ast.fix_missing_locations(s)
        return pre + self.body(body, depth + 1)


def fuse(tree: ast.Module, env: dict) -> tuple:
    """Inline the laws called by the loop function of ``tree`` (in place): (aliases {name: path},
    inlined laws [(path of the function, file line of its def)])."""
    f = Fuser(env)
    fdef = next(n for n in tree.body if isinstance(n, ast.FunctionDef))
    fdef.body = f.body(fdef.body)
    ast.fix_missing_locations(tree)
    return f.paths, f.laws


#: the fields of the loop's ``X`` (:class:`mjbench.kernel.program.Parts`) that hold parameters: namedtuples
#: (the law contract), whose fields cannot be rebound while a run lives
PARAM_FIELDS = {"drive", "sense_P", "ref_P", "ctrl_P", "cloop_P", "amp_P", "eff_P", "plant_P"}


def hoist(tree: ast.Module) -> int:
    """Read each parameter ``P.name`` that the loop's ``while`` reads once, before it: ``Pd_0.k_m`` →
    ``Pd_0__k_m`` (a namedtuple's field is the same object for the whole run).  → how many."""
    fdef = next(n for n in tree.body if isinstance(n, ast.FunctionDef))
    X = fdef.args.args[3].arg
    i_loop = next((i for i, n in enumerate(fdef.body) if isinstance(n, ast.While)), None)
    if i_loop is None:
        return 0
    loop = fdef.body[i_loop]
    stored = {n.id for n in ast.walk(loop) if isinstance(n, ast.Name) and not isinstance(n.ctx, ast.Load)}
    params = set()
    for st in fdef.body[:i_loop]:
        if isinstance(st, ast.Assign) and len(st.targets) == 1 and isinstance(st.targets[0], ast.Name):
            v = st.value.value if isinstance(st.value, ast.Subscript) else st.value
            if isinstance(v, ast.Attribute) and isinstance(v.value, ast.Name) and v.value.id == X \
                    and v.attr in PARAM_FIELDS:
                params.add(st.targets[0].id)
    params -= stored
    reads: dict = {}

    class _Sub(ast.NodeTransformer):
        def visit_Attribute(self, node):
            self.generic_visit(node)
            if isinstance(node.ctx, ast.Load) and isinstance(node.value, ast.Name) and node.value.id in params:
                name = reads.setdefault((node.value.id, node.attr), f"{node.value.id}__{node.attr}")
                return ast.copy_location(ast.Name(name, ast.Load()), node)
            return node

    fdef.body[i_loop] = _Sub().visit(loop)
    pre = [ast.copy_location(ast.Assign([ast.Name(new, ast.Store())],
                                         ast.Attribute(ast.Name(p, ast.Load()), a, ast.Load())), loop)
           for (p, a), new in reads.items()]
    fdef.body[i_loop:i_loop] = pre
    ast.fix_missing_locations(tree)
    return len(pre)


def resolve(path: tuple, env: dict):
    """The object at ``path`` from the loop's globals ``env`` (what :meth:`Fuser._alias` recorded)."""
    obj = None
    for step in path:
        kind = step[0]
        if kind == "env":
            obj = env[step[1]]
        elif kind == "builtin":
            obj = getattr(builtins, step[1])
        elif kind == "func":
            obj = obj.func
        elif kind == "arg":
            obj = obj.args[step[1]]
        elif kind == "global":
            obj = obj.__globals__[step[1]]
    return obj


def law_key(env: dict) -> str:
    """A digest of every function the loop's globals reach (slot functions, the laws they call,
    their bound function arguments): a fused loop is reused only with the same code."""
    h = hashlib.sha256()
    seen, stack = set(), sorted(env.items())
    depth = {}
    while stack:
        name, obj = stack.pop()
        tgt = _target(obj)
        if tgt is None or id(tgt[0]) in seen:
            continue
        fn, bound = tgt
        seen.add(id(fn))
        d = depth.get(id(obj), 0)
        h.update(f"{name}:{fn.__module__}.{fn.__qualname__}:".encode())
        try:
            h.update(marshal.dumps(fn.__code__))
        except ValueError:
            h.update(repr(fn.__code__).encode())
        if d >= MAX_DEPTH:
            continue
        for b in bound:
            depth[id(b)] = d + 1
            stack.append((f"{name}.arg", b))
        g = fn.__globals__
        for n in fn.__code__.co_names:
            v = g.get(n)
            if v is not None and _target(v) is not None:
                depth[id(v)] = d + 1
                stack.append((f"{name}.{n}", v))
    return h.hexdigest()


__all__ = ["fuse", "hoist", "resolve", "law_key", "LINE_BASE", "MAX_DEPTH"]
