"""The laws written into the CPython loop (mjbench/kernel/inline.py): the same bits as the loop that
calls them, a failing law still named with its own line, and a law whose file no longer matches its
running code called, never inlined from the edited text."""
import importlib.util
import sys
import textwrap

import numpy as np
import pytest

from mjbench import scenario as S
from mjbench.backends import multibody, reduced
from mjbench.kernel import choice, inline

#: (scenario, mode, backend, t_end): one-motor machines on both plants, a drive train, two motors
CASES = [("press-slidercrank", None, "multibody", 0.05), ("incerti2012", "pid", "reduced", 0.3),
         ("incerti-bezier", None, "reduced", 0.2), ("fivebar", "pid", "reduced", 0.05),
         ("fivebar", "pid", "multibody", 0.02)]


def _run(name, mode, backend, t_end, inline_laws, monkeypatch):
    """A whole run through the public path with the CPython loop, laws inlined or called."""
    real = choice.python_loop
    monkeypatch.setattr(choice, "python_loop", lambda pr, inline_laws=inline_laws: real(pr, inline_laws))
    import mjbench.kernel.running as R
    monkeypatch.setattr(R, "python_loop", lambda pr, inline_laws=inline_laws: real(pr, inline_laws))
    monkeypatch.setattr(R, "loop_function", lambda pr, mode: real(pr, inline_laws))
    scn = S.load(name)
    sim = multibody.simulate if backend == "multibody" else reduced.simulate
    kw = {"options": scn.multibody_options()} if backend == "multibody" else {}
    tr = sim(S.make_machine(scn, mode), t_end, record_dt=scn.simulation.record_dt, loop="python", **kw)
    assert tr.meta["loop"] == "python"
    return tr


@pytest.mark.parametrize("name,mode,backend,t_end", CASES)
def test_inlined_laws_give_the_bits_of_called_laws(name, mode, backend, t_end, monkeypatch):
    called = _run(name, mode, backend, t_end, False, monkeypatch)
    fused = _run(name, mode, backend, t_end, True, monkeypatch)
    assert called.data.shape == fused.data.shape
    assert np.array_equal(called.data.view(np.uint64), fused.data.view(np.uint64))


def test_the_press_loop_calls_only_what_cannot_be_inlined():
    """The press's co-step: the reference, the PI law and their adapters, the drive's laws, the plant
    step and the press load are written into the loop; what stays a call is ``mj_step`` and ``sgn``
    inside an expression (a call is inlined only as a statement of its own)."""
    import ast
    from mjbench.kernel import pyloop, unroll
    from mjbench.kernel.running import run_many  # noqa: F401 - the kernel loaded as a run loads it
    scn = S.load("press-slidercrank")
    mc = S.make_machine(scn, None)
    _, model = multibody.build_model(mc, scn.multibody_options())
    seen = {}
    real = choice.python_loop

    def spy(pr, inline_laws=True):
        seen["pr"] = pr
        return real(pr, inline_laws)

    import mjbench.kernel.running as R
    orig = R.loop_function
    R.loop_function = lambda pr, mode: spy(pr) if mode == "python" else orig(pr, mode)
    try:
        multibody.simulate(S.make_machine(scn, None), 0.01, record_dt=scn.simulation.record_dt, model=model,
                           options=scn.multibody_options(), loop="python")
    finally:
        R.loop_function = orig
    pr = seen["pr"]
    env = {**choice.loop_env(), **pr.env()}
    tree = ast.parse(pyloop.specialise(unroll.source(pr.naxes, pr.nctrl), dict(pyloop.constants(pr.flags))))
    aliases, laws = inline.fuse(tree, env)
    loop = next(n for n in ast.walk(tree) if isinstance(n, ast.While))
    called = {c.func.id for c in ast.walk(loop) if isinstance(c, ast.Call) and isinstance(c.func, ast.Name)}
    names = {getattr(inline.resolve(aliases[c], env), "__name__", c) if c in aliases else c for c in called}
    slots = {"REF_0", "CTRL_0", "DLIMIT_0", "DMEAN_0", "DSTEP_0", "DTORQUE_0", "PLANT", "clip"}
    assert not names & slots, names
    assert {"mj_step", "sgn"} <= names
    assert len(laws) >= 10


def _module(tmp_path, text, name):
    path = tmp_path / f"{name}.py"
    path.write_text(textwrap.dedent(text))
    spec = importlib.util.spec_from_file_location(name, path)
    mod = importlib.util.module_from_spec(spec)
    sys.modules[name] = mod
    spec.loader.exec_module(mod)
    return mod, path


def test_a_law_is_inlined_only_from_the_text_of_its_running_code(tmp_path):
    mod, path = _module(tmp_path, """
        import math
        def law(x, P, S):
            S[0] = math.sqrt(x) + P
            return S[0] * 2.0
        def early(x):
            if x > 0.0:
                return 1.0
            return -1.0
        """, "mjbench_inline_probe")
    assert inline._source(mod.law) is not None  # (math.sqrt: a module's attribute, spelled either way)
    fdef, first = inline._source(mod.law)
    assert first == 3 and inline._inlinable(mod.law, fdef, 3)
    f2, _ = inline._source(mod.early)
    assert not inline._inlinable(mod.early, f2, 1)  # an early return: called
    path.write_text(path.read_text().replace("* 2.0", "* 3.0"))  # edited on disk after the import
    assert inline._source(mod.law) is None


def test_inlined_and_called_give_the_same_values_and_errors(tmp_path):
    """A small loop with a law inlined twice: the same values, and a failure inside the inlined law
    carries the law's own line (what names it in a run's error)."""
    import ast
    mod, _ = _module(tmp_path, """
        def clip(x, lo, hi):
            return lo if x < lo else (hi if x > hi else x)
        def law(x, P, S):
            S[0] = S[0] + x
            y = clip(S[0] * P, -1.0, 1.0)
            S[int(S[0])] = y
            return y
        """, "mjbench_inline_probe2")
    src = textwrap.dedent("""
        def _loop(n0, n1, K, X):
            S = K
            out = []
            n = n0
            while n < n1:
                y = LAW(0.25, 3.0, S)
                out.append(y)
                n += 1
            return out
        """)
    env = {"LAW": mod.law}
    plain = {}
    exec(compile(src, "<plain>", "exec"), dict(env), plain)  # noqa: S102
    tree = ast.parse(src)
    aliases, laws = inline.fuse(tree, env)
    assert len(laws) == 2  # the law and the clip it calls
    g = dict(env)
    g.update({a: inline.resolve(p, env) for a, p in aliases.items()})
    fused = {}
    exec(compile(tree, "<fused>", "exec"), g, fused)  # noqa: S102
    S1, S2 = [0.0] * 4, [0.0] * 4
    assert plain["_loop"](0, 12, S1, None) == fused["_loop"](0, 12, S2, None) and S1 == S2
    with pytest.raises(IndexError) as e:
        fused["_loop"](0, 40, [0.0] * 4, None)
    tb = e.value.__traceback__
    while tb.tb_next is not None:
        tb = tb.tb_next
    k, line = divmod(tb.tb_lineno, inline.LINE_BASE)
    fn, first = inline.resolve(laws[k - 1][0], env), laws[k - 1][1]
    assert fn is mod.law and first + line - 1 == 7  # `S[int(S[0])] = y`, line 7 of the file
