"""The layers of mjbench, one way (docs/engine.md "Layers"): the import-linter contract of
pyproject.toml ([tool.importlinter]) and no import cycle, imports inside functions included.

grimp (import-linter's graph) reads every import statement of mjbench/ and controllers/, at module
level and inside functions; TYPE_CHECKING imports are annotations, never executed, and are left
out as in the contract.  A lazy face (``mjbench.api``'s ``PUBLIC`` table) imports by name on
first use: the module that asks the face depends on the face only."""
import ast
import os
import subprocess
import sys
from pathlib import Path

import grimp

ROOT = Path(__file__).resolve().parents[1]
#: imports of our own modules inside functions: each has a one-line reason (a comment on its line)
MAX_FUNCTION_IMPORTS = 20


def _graph():
    return grimp.build_graph("mjbench", "controllers", cache_dir=None, exclude_type_checking_imports=True)


def _cycles(graph) -> list:
    """The strongly connected components of more than one module (Tarjan, iterative)."""
    adj = {m: sorted(graph.find_modules_directly_imported_by(m)) for m in graph.modules}
    index, low, on, stack, out, counter = {}, {}, set(), [], [], [0]
    for root in sorted(adj):
        if root in index:
            continue
        work = [(root, iter(adj[root]))]
        index[root] = low[root] = counter[0]
        counter[0] += 1
        stack.append(root)
        on.add(root)
        while work:
            v, it = work[-1]
            for w in it:
                if w not in index:
                    index[w] = low[w] = counter[0]
                    counter[0] += 1
                    stack.append(w)
                    on.add(w)
                    work.append((w, iter(adj[w])))
                    break
                if w in on:
                    low[v] = min(low[v], index[w])
            else:
                work.pop()
                if work:
                    low[work[-1][0]] = min(low[work[-1][0]], low[v])
                if low[v] == index[v]:
                    comp = []
                    while True:
                        w = stack.pop()
                        on.discard(w)
                        comp.append(w)
                        if w == v:
                            break
                    if len(comp) > 1:
                        out.append(sorted(comp))
    return out


def test_no_import_cycle():
    cycles = _cycles(_graph())
    assert not cycles, "import cycles (imports inside functions included): " + "; ".join(
        " ↔ ".join(c) for c in cycles)


def test_cycle_finder_finds_a_cycle():
    g = grimp.ImportGraph()
    for m in ("a", "a.x", "a.y", "a.z"):
        g.add_module(m)
    g.add_import(importer="a.x", imported="a.y")
    g.add_import(importer="a.y", imported="a.z")
    g.add_import(importer="a.z", imported="a.x")
    assert _cycles(g) == [["a.x", "a.y", "a.z"]]


def test_layers_contract():
    """``lint-imports`` (import-linter) with the contracts of pyproject.toml: the layers, mjbench
    never importing ``controllers`` by name, ``controllers`` on the component interface only."""
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    r = subprocess.run([sys.executable, "-c", "import sys; from importlinter.cli import lint_imports; "
                        "sys.exit(lint_imports(config_filename='pyproject.toml', no_cache=True, no_logo=True))"],
                       cwd=ROOT, env=env, capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stdout[-4000:] + r.stderr[-2000:]
    assert "broken" in r.stdout and "0 broken" in r.stdout, r.stdout[-2000:]


def _function_imports():
    """(file, line, text) of every import of mjbench/controllers inside a function."""
    out = []
    for p in sorted(list((ROOT / "mjbench").rglob("*.py")) + list((ROOT / "controllers").rglob("*.py"))):
        text = p.read_text(encoding="utf-8")
        lines = text.splitlines()
        for f in ast.walk(ast.parse(text)):
            if not isinstance(f, (ast.FunctionDef, ast.AsyncFunctionDef)):
                continue
            for i in ast.walk(f):
                own = ((isinstance(i, ast.ImportFrom) and (i.level or (i.module or "").split(".")[0] in
                                                           ("mjbench", "controllers")))
                       or (isinstance(i, ast.Import) and any(a.name.split(".")[0] in ("mjbench", "controllers")
                                                             for a in i.names)))
                if own:
                    out.append((p.relative_to(ROOT), i.lineno, lines[i.lineno - 1]))
    return sorted(set(out))


def test_few_function_level_imports_each_with_its_reason():
    found = _function_imports()
    assert len(found) <= MAX_FUNCTION_IMPORTS, f"{len(found)} imports of our own modules inside functions " \
        f"(at most {MAX_FUNCTION_IMPORTS}): " + "; ".join(f"{p}:{n}" for p, n, _ in found[:40])
    missing = [f"{p}:{n}" for p, n, line in found if "#" not in line]
    assert not missing, "a function-level import without its one-line reason (# ...): " + ", ".join(missing)
