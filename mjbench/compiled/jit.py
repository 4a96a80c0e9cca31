"""The compiled loop: numba compiles the kernel's loop with a composition's laws, cached on disk.

For a composition (:class:`mjbench.kernel.Program`) a small module is generated into the user
cache folder (:mod:`mjbench.compiled.cache`): it imports the slot laws, binds the flags as
constants, copies the source of :func:`mjbench.kernel._loop` and compiles it with
``numba.njit(cache=True)``.  The module's name is a hash of its text and of the source of every
module a law may come from (mjbench, controllers, and each law's own module), so an edited law
never reuses stale machine code.  A law that cannot be imported by name (defined in ``__main__``
or inside a function) is compiled in memory instead (not cached: compiled once per process).

numba is imported here only, on the first compiled run.
"""
from __future__ import annotations

import hashlib
import importlib
import importlib.util
import inspect
import os
import sys
import threading

from . import BRIDGES, LAWS
from . import cache as _cache

_AVAILABLE = None


def available() -> bool:
    """Whether numba is installed (looked up once, when a run could be compiled)."""
    global _AVAILABLE
    if _AVAILABLE is None:
        _AVAILABLE = "numba" in sys.modules or importlib.util.find_spec("numba") is not None
    return _AVAILABLE
_LOCK = threading.Lock()
_READY = False
_LOOPS: dict = {}
_KEEP: list = []
_FINGERPRINT = None


def loaded() -> bool:
    """Whether numba is imported in this process (then compiling costs no extra start-up)."""
    return "numba" in sys.modules


def init():
    """Import numba (cache folder set first) and register every law and bridge with it."""
    global _READY
    with _LOCK:
        if _READY:
            return
        _cache.configure_numba()
        import numba  # noqa: F401

        from . import _numba  # noqa: F401 - the bridges' compiled implementations
        from .. import compiled as C

        for fn in list(LAWS):
            register(fn)
        for fn, impl in list(BRIDGES):
            register_bridge(fn, impl)
        C._jit_ready = True
        _READY = True


_REGISTERED = set()


#: numba's options for every law: no reference counting (laws never allocate; the arrays belong to
#: the caller for the whole call) and LLVM's ``alwaysinline``.  A law that LLVM chose not to inline
#: (a law called from several places, or one grown past the inliner's threshold by the laws it
#: calls) is a real call per use, its parameter tuples flattened into one argument per array field
#: (pointer, shape, strides …) — the generic linkage's loads were ≈ 330 stack arguments per step;
#: the table's lookup four calls per RK4 step.  Inlined, the loop is one function and a law costs its
#: arithmetic (the same operations: inlining changes no floating-point result).
LAW_OPTIONS = {"_nrt": False, "forceinline": True}
_LAW_OPTIONS_TEXT = ", ".join(f"{k}={v!r}" for k, v in LAW_OPTIONS.items())


def register(fn):
    """Make the law ``fn`` callable by name from compiled code (numba's ``register_jitable``)."""
    if id(fn) in _REGISTERED:
        return
    from numba.extending import register_jitable

    register_jitable(**LAW_OPTIONS)(fn)
    _REGISTERED.add(id(fn))


def register_bridge(fn, impl_name):
    from numba.extending import overload

    from . import _numba

    overload(fn)(getattr(_numba, impl_name))


def _importable(fn) -> bool:
    mod, qual = getattr(fn, "__module__", None), getattr(fn, "__qualname__", "")
    if not mod or mod == "__main__" or "<" in qual or "." in qual:
        return False
    m = sys.modules.get(mod)
    return m is not None and getattr(m, qual, None) is fn and getattr(m, "__file__", None) is not None


def _fingerprint() -> str:
    """Hash of every source file of mjbench and controllers (laws call helpers by name)."""
    global _FINGERPRINT
    if _FINGERPRINT is None:
        import mjbench
        import controllers

        h = hashlib.sha256()
        for pkg in (mjbench, controllers):
            root = os.path.dirname(pkg.__file__)
            for dirpath, dirnames, files in os.walk(root):
                dirnames[:] = sorted(d for d in dirnames if d != "__pycache__")
                for f in sorted(files):
                    if f.endswith(".py"):
                        p = os.path.join(dirpath, f)
                        h.update(p[len(root):].encode())
                        with open(p, "rb") as fh:
                            h.update(fh.read())
        import numba

        h.update(numba.__version__.encode())
        h.update(sys.version.encode())
        _FINGERPRINT = h.hexdigest()
    return _FINGERPRINT


def _module_hash(modname: str) -> str:
    m = sys.modules.get(modname)
    f = getattr(m, "__file__", None)
    if not f or modname.split(".")[0] in ("mjbench", "controllers"):
        return ""
    try:
        with open(f, "rb") as fh:
            return hashlib.sha256(fh.read()).hexdigest()
    except OSError:
        return ""


def loop_for(program, loop_fn, loop_source: str | None = None):
    """The compiled loop of ``program``'s composition (generated, cached, loaded on first use)."""
    init()
    key = program.key
    fn = _LOOPS.get(key)
    if fn is not None:
        return fn
    with _LOCK:
        fn = _LOOPS.get(key)
        if fn is None:
            fn = _LOOPS[key] = _build(program, loop_source or inspect.getsource(loop_fn))
            _KEEP.append(dict(program.slots))  # the key holds the laws' ids: keep them alive
    return fn


def _bind_text(name, form, lines, mods, inmemory):
    """Source lines defining ``name``, a compiled function of the generated module that runs
    ``form``'s law.  A plain law is called by name (numba's ``register_jitable``).  A law with
    function arguments (``Form.fn_args``) is *specialised*: its own source, with those parameters
    removed and renamed to module globals bound to the arguments' functions (defined the same way),
    so every call is static: numba inlines it and can cache the loop (it cannot cache a loop that
    passes a function as a value)."""
    fn = form.law
    if not _importable(fn):
        inmemory[f"_{name}_law"] = fn
        lines.append(f"{name} = numba.njit(forceinline=True)(_{name}_law)")
        return
    if not form.fn_args:  # the registered law itself: compiled once per process, whatever the composition
        lines.append(f"from {fn.__module__} import {fn.__qualname__} as {name}")
        mods.add(fn.__module__)
        return
    argn = [f"_{name}_a{i}" for i in range(len(form.fn_args))]
    for a, child in zip(argn, form.fn_args):
        _bind_text(a, child, lines, mods, inmemory)
    lines += _specialise(name, fn, argn, mods)


def _check_source(fn, tree, fdef) -> None:
    """The source read from disk is the law that runs: its file may have changed since the module was
    imported (an edit during a run: the lines then name another function, or other code).  The source
    read, compiled, must define the function's name with its parameters, names and constants (its
    bytecode itself may differ: the interpreter can rewrite a running function's)."""
    import types

    code = compile(tree, inspect.getsourcefile(fn) or "<law>", "exec")
    consts = [c for c in code.co_consts if isinstance(c, types.CodeType)]

    def sig(c):
        return (c.co_name, c.co_argcount, c.co_varnames, c.co_names,
                tuple(repr(k) for k in c.co_consts if not isinstance(k, types.CodeType)))

    same = getattr(fdef, "name", None) == fn.__name__ and len(consts) == 1 and sig(consts[0]) == sig(fn.__code__)
    if not same:
        from ..errors import MjbenchError

        raise MjbenchError(f"law {fn.__module__}.{fn.__qualname__}: its source file changed after it was imported; "
                           "start the command again (the compiled loop is built from the law's source)")


def _specialise(name, fn, argn, mods):
    """The law ``fn`` re-defined as ``name`` with its first len(argn) parameters bound to the
    globals ``argn`` and its own free globals imported from its module under private names."""
    import ast
    import textwrap

    tree = ast.parse(textwrap.dedent(inspect.getsource(fn)))
    fdef = tree.body[0]
    _check_source(fn, tree, fdef)
    fdef.decorator_list = []
    fdef.name = name
    removed = [a.arg for a in fdef.args.args[:len(argn)]]
    fdef.args.args = fdef.args.args[len(argn):]
    ren = dict(zip(removed, argn))
    glob = fn.__globals__
    imports = []
    for n in sorted(set(fn.__code__.co_names)):
        if n in glob and n not in ren:
            ren[n] = f"_{name}_g_{n}"
            imports.append(f"from {fn.__module__} import {n} as _{name}_g_{n}")

    class Rename(ast.NodeTransformer):
        def visit_Name(self, node):
            if node.id in ren:
                node.id = ren[node.id]
            return node

    Rename().visit(fdef)
    mods.add(fn.__module__)
    return imports + ["", "", f"@register_jitable({_LAW_OPTIONS_TEXT})", ast.unparse(fdef), ""]


def _build(program, loop_source: str):
    flags = program.flags
    header = ["import numba", "from numba.extending import register_jitable",
              "from mjbench.kernel import MAX_SPEED, MAX_CURRENT",
              "from mjbench.compiled import clip, isfinite", ""]
    header += [f"{f} = {flags[f]!r}" for f in sorted(flags)]
    inmemory = {}
    mods = set()
    for s in sorted(program.slots):
        _bind_text(s, program.slots[s], header, mods, inmemory)
    src = "\n".join(header) + "\n\n\n" + loop_source + \
        "\n\nrun = numba.njit(cache=True, nogil=True, _nrt=False)(_loop)\n"
    if inmemory:  # a law numba cannot import by name: compile in memory (no disk cache)
        env = {"__name__": "mjbench_kernel_inmemory", **inmemory}
        src = src.replace("cache=True", "cache=False")
        src = "\n".join(ln for ln in src.split("\n")
                        if not (ln.startswith("from ") and ln.split(" as ")[-1].strip() in inmemory))
        exec(compile(src, "<mjbench compiled loop>", "exec"), env)  # noqa: S102 - our own generated source
        return env["run"]
    h = hashlib.sha256(src.encode())
    h.update(_fingerprint().encode())
    for m in sorted(mods):
        h.update(_module_hash(m).encode())
    name = "mjbench_loop_" + h.hexdigest()[:20]
    folder = _cache.kernels()
    path = folder / f"{name}.py"
    if not path.exists():
        tmp = folder / f".{name}.{os.getpid()}.tmp"
        tmp.write_text(src, encoding="utf-8")
        os.replace(tmp, path)
    mod = importlib.import_module(name)
    return mod.run
