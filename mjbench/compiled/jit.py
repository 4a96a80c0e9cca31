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

from .. import compiled as C
from . import BRIDGES, LAWS
from . import cache as _cache
from ..errors import MjbenchError

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

        from . import _numba  # noqa: F401 - numba's compiled bridges: imports numba, the first compiled run only

        for fn in list(LAWS):
            register(fn)
        for fn, impl in list(BRIDGES):
            register_bridge(fn, impl)
        C._JIT_HOOKS = (register, register_bridge)
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

    register_jitable(**law_options(fn))(fn)
    _REGISTERED.add(id(fn))


def law_options(fn) -> dict:
    """numba's options for a law: :data:`LAW_OPTIONS`, without forced inlining for a law that asks
    (``@law(inline=False)``: a large law called from several places, compiled once)."""
    if getattr(fn, "__mjbench_inline__", True):
        return dict(LAW_OPTIONS)
    return {**LAW_OPTIONS, "forceinline": False}


def register_bridge(fn, impl_name):
    from numba.extending import overload

    from . import _numba  # numba's compiled bridges: imports numba, the first compiled run only

    overload(fn)(getattr(_numba, impl_name))


def _importable(fn) -> bool:
    mod, qual = getattr(fn, "__module__", None), getattr(fn, "__qualname__", "")
    if not mod or mod == "__main__" or "<" in qual or "." in qual:
        return False
    m = sys.modules.get(mod)
    return m is not None and getattr(m, qual, None) is fn and getattr(m, "__file__", None) is not None


def _package_hash(pkg) -> str:
    """Hash of every source file of a package (laws call helpers of their package by name)."""
    h = hashlib.sha256()
    root = os.path.dirname(pkg.__file__)
    for dirpath, dirnames, files in os.walk(root):
        dirnames[:] = sorted(d for d in dirnames if d != "__pycache__")
        for f in sorted(files):
            if f.endswith(".py"):
                p = os.path.join(dirpath, f)
                h.update(p[len(root):].encode())
                with open(p, "rb") as fh:
                    h.update(fh.read())
    return h.hexdigest()


def _fingerprint() -> str:
    """Hash of every source file of mjbench, numba's and Python's versions."""
    global _FINGERPRINT
    if _FINGERPRINT is None:
        import numba

        h = hashlib.sha256(_package_hash(sys.modules["mjbench"]).encode())  # (our root package: always loaded)
        h.update(numba.__version__.encode())
        h.update(sys.version.encode())
        _FINGERPRINT = h.hexdigest()
    return _FINGERPRINT


def _module_hash(modname: str) -> str:
    """Hash of the package a law's module belongs to (a module of mjbench: in the fingerprint), or
    of the module alone when it is not in a package; read at every build (an edited law is a new
    composition: its module's text is part of the kernel's name)."""
    top = modname.split(".")[0]
    if top == "mjbench":
        return ""
    m = sys.modules.get(top)
    f = getattr(m, "__file__", None)
    try:
        if f and os.path.basename(f) == "__init__.py":
            return _package_hash(m)
        if f:
            with open(f, "rb") as fh:
                return hashlib.sha256(fh.read()).hexdigest()
    except OSError:
        pass
    return ""


def loop_for(program, loop_source: str, check: bool = False):
    """The compiled loop of ``program``'s composition (generated, cached, loaded on first use).
    ``check``: every array access bounds-checked (``MJBENCH_JIT=check``: a law writing past its
    state raises instead of corrupting memory)."""
    init()
    key = (program.key, bool(check))
    fn = _LOOPS.get(key)
    if fn is not None:
        return fn
    with _LOCK:
        fn = _LOOPS.get(key)
        if fn is None:
            fn = _LOOPS[key] = _Guarded(program, _build(program, loop_source, check), key, check)
            _KEEP.append((dict(program.slots), dict(program.wired)))  # the key holds the laws' ids: keep them alive
    return fn


#: compositions whose laws numba refused in this process: key → the one-line reason
_FAILED: dict = {}


def law_failure(program) -> str:
    """Why numba refused this composition's laws earlier in this process ('' if it did not)."""
    return _FAILED.get(program.key, "")


class LawCompileError(Exception):
    """numba refused a law of the composition (``reason``: one line naming the component and the law)."""

    def __init__(self, reason):
        super().__init__(reason)
        self.reason = reason


class _Guarded:
    """The compiled loop; its first call compiles it (numba compiles on first use): a law numba
    refuses becomes :class:`LawCompileError` naming the component and the law, and a corrupted
    cache entry is rebuilt once (``NOTES``)."""

    def __init__(self, program, dispatcher, key, check=False):
        self.program, self.fn, self.key, self.ok, self.check = program, dispatcher, key, False, check

    def __call__(self, n0, n1, K, X):
        if self.ok:
            return self.fn(n0, n1, K, X)
        from numba.core import config

        before = config.BOUNDSCHECK
        if self.check:  # every array access of the loop and its inlined laws is bounds-checked
            config.BOUNDSCHECK = 1
        try:
            r = self.fn(n0, n1, K, X)
        except Exception as e:  # noqa: BLE001 - numba's errors become one line
            import numba

            if isinstance(e, (numba.core.errors.TypingError, numba.core.errors.LoweringError,
                              numba.core.errors.UnsupportedError)):
                reason = _explain(self.program, e)
                _FAILED[self.program.key] = reason
                _LOOPS.pop(self.key, None)
                raise LawCompileError(reason) from None
            name = getattr(self.fn, "_mjbench_module", None)
            if name is None or isinstance(e, (IndexError, ZeroDivisionError, ArithmeticError)):
                raise
            _cache.purge(name)  # a corrupted cache entry (numba's index or data): rebuild once
            _cache.note(f"compiled kernel {name}: its cache entry could not be loaded ({type(e).__name__}); rebuilt")
            sys.modules.pop(name, None)
            self.fn = _build(self.program, getattr(self.fn, "_mjbench_source"), getattr(self.fn, "_mjbench_check"))
            r = self.fn(n0, n1, K, X)
        finally:
            config.BOUNDSCHECK = before
        self.ok = True
        return r


def _explain(program, e) -> str:
    """One line naming the component and the law numba refused, the line and numba's first words."""
    import re

    text = str(e)
    forms = []
    for s, f in program.slots.items():
        forms.append((s, f))
    for s, (f, w) in program.wired.items():
        forms.append((s, f))
    where, comp = "", "a component"
    for s, f in forms:
        laws = [f.law] + [g.law for g in f.fn_args]
        for fn in laws:
            code = getattr(fn, "__code__", None)
            if code is None:
                continue
            m = re.search(re.escape(code.co_filename) + r'", line (\d+)', text)
            if m:
                comp = f.what or s.split("_")[0].lower()
                where = f"law {fn.__module__}.{fn.__qualname__} (line {m.group(1)})"
                break
        if where:
            break
    first = next((ln.strip() for ln in text.splitlines() if ln.strip() and not ln.startswith("During")), text[:200])
    first = re.sub(r"\x1b\[[0-9;]*m", "", first)
    return (f"{comp}: {where or 'a law'} cannot be compiled by numba: {first[:300]} "
            f"(a law uses floats, math and other laws only: docs/CONTRIBUTING.md)")


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
    opts = ", ".join(f"{k}={v!r}" for k, v in law_options(fn).items())
    return imports + ["", "", f"@register_jitable({opts})", ast.unparse(fdef), ""]


def _build(program, loop_source: str, check: bool = False):
    flags = program.flags
    header = ["import math", "import numba", "from numba.extending import register_jitable",
              "from mjbench.kernel.loop import MAX_SPEED, MAX_CURRENT",
              "from mjbench.compiled import clip, isfinite, track", ""]
    header += [f"{f} = {flags[f]!r}" for f in sorted(flags)]
    inmemory = {}
    mods = set()
    for s in sorted(program.slots):
        _bind_text(s, program.slots[s], header, mods, inmemory)
    for s in sorted(program.wired):
        form, w = program.wired[s]
        if w is None:  # an absent control slot
            _bind_text(s, form, header, mods, inmemory)
            continue
        _bind_text(f"_law_{s}", form, header, mods, inmemory)
        header += ["", f"@register_jitable({_LAW_OPTIONS_TEXT})", w.source(s, f"_law_{s}")]
    opts = "cache=True, nogil=True, _nrt=False" + (", boundscheck=True" if check else "")
    src = "\n".join(header) + "\n\n\n" + loop_source + f"\n\nrun = numba.njit({opts})(_loop)\n"
    folder = None if inmemory else _cache.kernels()
    if folder is None:  # a law numba cannot import by name, or no writable cache: compile in memory
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
    path = folder / f"{name}.py"
    if path.exists() and not _cache.intact(path):
        _cache.purge(name)
        _cache.note(f"compiled kernel {name}: its cache entry was corrupted (checksum); rebuilt")
    if not path.exists():
        tmp = folder / f".{name}.{os.getpid()}.tmp"
        try:
            tmp.write_text(_cache.stamp(src), encoding="utf-8")
            os.replace(tmp, path)
        except OSError as e:  # the disk filled: compile in memory, leave nothing half-written
            try:
                tmp.unlink()
            except OSError:
                pass
            _cache.note(f"compiled kernel {name} not cached ({e.strerror}): built in memory")
            env = {"__name__": "mjbench_kernel_inmemory"}
            exec(compile(src.replace("cache=True", "cache=False"), "<mjbench compiled loop>", "exec"), env)  # noqa: S102
            return env["run"]
    try:
        mod = importlib.import_module(name)
    except Exception as e:  # noqa: BLE001 - a module that cannot be loaded: rebuilt once
        sys.modules.pop(name, None)
        _cache.purge(name)
        _cache.note(f"compiled kernel {name}: its cache entry could not be loaded ({type(e).__name__}); rebuilt")
        path.write_text(_cache.stamp(src), encoding="utf-8")
        importlib.invalidate_caches()
        mod = importlib.import_module(name)
    run = mod.run
    try:
        run._mjbench_module, run._mjbench_source, run._mjbench_check = name, loop_source, check
    except AttributeError:  # pragma: no cover - a dispatcher without a __dict__
        pass
    return run
