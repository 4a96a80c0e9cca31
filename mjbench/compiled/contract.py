"""The law contract, checked when a component's law is first used (its run is composed), not when a
run gets long enough to be compiled.

A control law (a controller's, a reference's; docs/CONTRIBUTING.md) is a plain function of floats:
it reads the signals its parameters name, its parameter tuple ``P`` (a namedtuple of numbers and
NumPy arrays, from the component's ``parameters()``) and its state ``S`` (a float array laid out as
the component's ``STATE``), computes with ``+ − × ÷``, comparisons, ``math`` and other laws, writes
its state only as ``S[i] = …`` and returns a float or a tuple of floats.

:func:`check` reads the law's source and its ``P`` and ``S`` once and returns what breaks the
contract, each as one line naming the component, the law, the rule and the line:

* *fatal* — the law cannot run in any loop: ``parameters()`` returned something else than a
  namedtuple (a dict …), the law reads ``P.x`` that ``parameters()`` does not give, or reads or
  writes ``S[k]`` past its state;
* *not compilable* — the CPython loop runs it but numba cannot: a NumPy call, a list, dict or set,
  an import, a call of a function that is not a law (or ``math``, or a built-in numba knows),
  try/with/lambda/f-strings.  The run then uses the CPython loop and says why (``loop_reason``);
  asking for the compiled loop (``MJBENCH_JIT=1``) is an error with the same line.

A state index computed at run time cannot be checked here: ``MJBENCH_JIT=check`` (or ``mjbench
check``) runs the compiled loop with bounds checks, so an overflow is an error, never a crash.
"""
from __future__ import annotations

import ast
import builtins
import inspect
import math
import textwrap
import types

import numpy as np

#: built-ins numba compiles in a law
ALLOWED_BUILTINS = {"abs", "min", "max", "int", "float", "bool", "range", "len", "round", "divmod", "pow"}
_CACHE: dict = {}


class Verdict:
    """What :func:`check` found: ``fatal`` and ``not_compilable`` one-line reasons ('' if none)."""

    def __init__(self, fatal: str = "", not_compilable: str = ""):
        self.fatal, self.not_compilable = fatal, not_compilable


def _is_law(obj) -> bool:
    return bool(getattr(obj, "__mjbench_law__", False))


def _p_problem(P, path="P") -> str:
    """Why ``P`` is not a parameter tuple ('' if it is): a namedtuple of numbers, bools, numeric
    arrays and namedtuples."""
    if isinstance(P, dict):
        return f"parameters() returned a dict ({path}); return a namedtuple (collections.namedtuple)"
    if not (isinstance(P, tuple) and hasattr(P, "_fields")):
        return f"parameters() returned {type(P).__name__} ({path}); return a namedtuple (collections.namedtuple)"
    for name, v in zip(P._fields, P):
        if isinstance(v, (bool, int, float, np.integer, np.floating, np.bool_)):
            continue
        if isinstance(v, np.ndarray):
            if v.dtype.kind not in "fiub":
                return f"{path}.{name} is an array of {v.dtype} (numbers only)"
            continue
        if isinstance(v, tuple) and hasattr(v, "_fields"):
            sub = _p_problem(v, f"{path}.{name}")
            if sub:
                return sub
            continue
        if isinstance(v, memoryview):
            continue
        return f"{path}.{name} is a {type(v).__name__} (a law's parameters are numbers, arrays and namedtuples)"
    return ""


def _source(fn):
    try:
        src = textwrap.dedent(inspect.getsource(fn))
        first = inspect.getsourcelines(fn)[1]
    except (OSError, TypeError):
        return None, 0
    try:
        return ast.parse(src), first
    except SyntaxError:
        return None, 0


def _root(node):
    while isinstance(node, ast.Attribute):
        node = node.value
    return node


def check(fn, P, S0, nfn: int, what: str) -> Verdict:
    """The contract of the control law ``fn`` with parameters ``P``, initial state ``S0`` and
    ``nfn`` leading function arguments (cached per law, parameter layout and state size)."""
    shape = _shape(P)
    key = (id(fn), shape, len(S0))
    hit = _CACHE.get(key)
    if hit is not None and hit[0] is fn:
        return hit[1]
    v = _check(fn, P, S0, nfn, what)
    _CACHE[key] = (fn, v)
    return v


def _shape(P):
    if isinstance(P, tuple) and hasattr(P, "_fields"):
        return (type(P), tuple(_shape(v) for v in P))
    return type(P)


def _check(fn, P, S0, nfn, what) -> Verdict:
    name = f"{getattr(fn, '__module__', '?')}.{getattr(fn, '__qualname__', repr(fn))}"
    head = f"{what}: law {name}"
    bad_p = _p_problem(P)
    if bad_p:
        return Verdict(fatal=f"{head}: {bad_p}")
    tree, first = _source(fn)
    if tree is None or not tree.body or not isinstance(tree.body[0], (ast.FunctionDef,)):
        return Verdict()  # no source to read (a law built by exec): numba reads its bytecode, and says the rest
    fdef = tree.body[0]
    params = [a.arg for a in fdef.args.args]
    if len(params) < nfn + 2:
        return Verdict(fatal=f"{head}: a law takes its signals, then its parameter tuple and its state (… P, S)")
    pname, sname = params[-2], params[-1]
    fnames = set(params[:nfn])
    glob = getattr(fn, "__globals__", {})
    nstate = len(S0)
    fields = set(P._fields)

    def line(node):
        return f"line {first + node.lineno - 1}"

    fatal, nc = [], []
    body = [n for stmt in fdef.body for n in ast.walk(stmt)]  # (not its decorators)
    for node in body:
        if isinstance(node, (ast.Import, ast.ImportFrom)):
            nc.append(f"{line(node)}: imports a module")
        elif isinstance(node, (ast.List, ast.ListComp, ast.Dict, ast.DictComp, ast.Set, ast.SetComp,
                               ast.GeneratorExp)):
            nc.append(f"{line(node)}: builds a {type(node).__name__.replace('Comp', ' comprehension').lower()}")
        elif isinstance(node, (ast.Try, ast.With, ast.Lambda, ast.Yield, ast.YieldFrom, ast.JoinedStr, ast.Global,
                               ast.Nonlocal, ast.AsyncFunctionDef, ast.Await)) or \
                (isinstance(node, ast.FunctionDef) and node is not fdef):
            nc.append(f"{line(node)}: uses {type(node).__name__} (not in a law)")
        elif isinstance(node, ast.Call):
            why = _call_problem(node.func, glob, fnames, params)
            if why:
                nc.append(f"{line(node)}: {why}")
        elif isinstance(node, ast.Attribute) and isinstance(node.value, ast.Name) and node.value.id == pname:
            if node.attr not in fields and not node.attr.startswith("_"):
                fatal.append(f"{line(node)}: reads {pname}.{node.attr}, which parameters() does not give "
                             f"(it gives {', '.join(P._fields) or 'nothing'})")
        elif isinstance(node, ast.Subscript) and isinstance(node.value, ast.Name) and node.value.id == sname:
            k = _const_index(node.slice)
            if k is not None and not (-nstate <= k < nstate):
                act = "writes" if isinstance(node.ctx, ast.Store) else "reads"
                fatal.append(f"{line(node)}: {act} {sname}[{k}] past its state of {nstate} entr"
                             f"{'y' if nstate == 1 else 'ies'} (STATE)")
    tail = " — a law uses floats, math and other laws only (docs/CONTRIBUTING.md)"
    return Verdict(fatal=f"{head} breaks the law contract at {fatal[0]}" if fatal else "",
                   not_compilable=f"{head} cannot be compiled: {nc[0]}{tail}" if nc else "")


def _const_index(node):
    if isinstance(node, ast.Constant) and isinstance(node.value, int):
        return node.value
    if isinstance(node, ast.UnaryOp) and isinstance(node.op, ast.USub) and isinstance(node.operand, ast.Constant) \
            and isinstance(node.operand.value, int):
        return -node.operand.value
    return None


def _call_problem(func, glob, fnames, params) -> str:
    root = _root(func)
    if isinstance(func, ast.Name):
        n = func.id
        if n in fnames or n in params:
            return ""
        obj = glob.get(n, getattr(builtins, n, None))
        if obj is None:
            return f"calls {n}, which is not defined"
        if _is_law(obj) or getattr(obj, "__mjbench_bridge__", False):
            return ""
        if getattr(builtins, n, None) is obj and n in ALLOWED_BUILTINS:
            return ""
        if isinstance(obj, types.BuiltinFunctionType) and getattr(obj, "__module__", "") == "math":
            return ""
        return f"calls {n}, which is not a law (@mjbench.compiled.law) nor a math function"
    if isinstance(root, ast.Name):
        obj = glob.get(root.id)
        if obj is math:
            return ""
        if obj is np or (isinstance(obj, types.ModuleType) and obj.__name__.split(".")[0] == "numpy"):
            return f"calls NumPy ({ast.unparse(func)})"
        if isinstance(obj, types.ModuleType):
            target = obj
            for part in ast.unparse(func).split(".")[1:]:
                target = getattr(target, part, None)
            if _is_law(target):
                return ""
            return f"calls {ast.unparse(func)}, which is not a law nor a math function"
        if root.id in params:  # a method of an argument (e.g. S.sum())
            return f"calls a method ({ast.unparse(func)})"
    return ""


__all__ = ["check", "Verdict", "ALLOWED_BUILTINS"]
