"""The docs name only what exists: every module, file and environment variable that README.md and
docs/*.md mention.

* dotted names ``mjbench.x.y`` / ``controllers.x.y``: the longest importable module prefix is
  imported and the rest looked up on it (a function, a class, a constant);
* paths ``dir/.../file.ext`` and folders ``dir/`` starting with a folder of the repository (or of
  the ``mjbench`` and ``controllers`` packages, which the docs use as a prefix-free shorthand:
  ``backends/table.py``, ``commands/run.py``): they exist, relative to the repository, to
  ``mjbench/`` or to ``controllers/``;
* bare module file names ``name.py``: a file of that name exists in the repository;
* ``MJBENCH_*`` environment variables: read somewhere in the code;
* the entry-point groups of plugins (``mjbench.controllers`` …) are names too (``mjbench.registry.GROUPS``).

Placeholders (``<name>``, ``*``, ``{a,b}``) and output folders of the examples (``out/…``,
``results/…``) are not paths of the repository and are skipped.
"""
import importlib
import os
import re
from pathlib import Path

import pytest

from mjbench.registry import GROUPS

ROOT = Path(__file__).resolve().parents[1]
DOCS = [ROOT / "README.md"] + sorted((ROOT / "docs").glob("*.md"))
SKIP_DIRS = {".git", ".venv", "__pycache__", "node_modules", "out", "results"}
DOTTED = re.compile(r"(?<![\w./-])((?:mjbench|controllers)(?:\.[A-Za-z_]\w*)+)")
EXT = r"(?:py|md|toml|xml|json|csv|txt|yml|yaml|cfg|ini|sh|ipynb|fmu|mp4|png|html|typed)"
PATH = re.compile(r"(?<![\w./<{*-])((?:[\w.-]+/)+(?:[\w.-]+\." + EXT + r")?)(?![\w/<>{}*-])")
PYFILE = re.compile(r"(?<![\w./<{*-])([\w-]+\.py)(?![\w/-])")
ENVVAR = re.compile(r"\b(MJBENCH_[A-Z0-9_]+)\b")


def _files():
    for dirpath, dirnames, files in os.walk(ROOT):
        dirnames[:] = [d for d in dirnames if d not in SKIP_DIRS and not d.endswith(".egg-info")]
        for f in files:
            yield Path(dirpath) / f


FILES = list(_files())
NAMES = {p.name for p in FILES}
TOPS = ({p.name for p in ROOT.iterdir() if p.name not in SKIP_DIRS}
        | {p.name for pkg in ("mjbench", "controllers") for p in (ROOT / pkg).iterdir() if p.is_dir()})
SOURCE = "\n".join(p.read_text(errors="replace") for p in FILES
                   if p.suffix == ".py" and p.parts[len(ROOT.parts)] in ("mjbench", "controllers", "scripts"))


def _resolves(dotted: str) -> bool:
    if dotted in GROUPS:  # an entry-point group of plugins, not a module
        return True
    parts = dotted.split(".")
    for i in range(len(parts), 0, -1):
        try:
            obj = importlib.import_module(".".join(parts[:i]))
        except ImportError:
            continue
        try:
            for p in parts[i:]:
                obj = getattr(obj, p)
        except AttributeError:
            return False
        return True
    return False


def _exists(path: str, doc: Path) -> bool:
    return any((base / path).exists() for base in (ROOT, ROOT / "mjbench", ROOT / "controllers", doc.parent))


def mentions(doc: Path) -> dict:
    text = doc.read_text()
    paths = {p for p in PATH.findall(text) if p.split("/")[0] in TOPS}
    return {"dotted": sorted(set(DOTTED.findall(text))), "paths": sorted(paths),
            "pyfiles": sorted(set(PYFILE.findall(text))), "env": sorted(set(ENVVAR.findall(text)))}


@pytest.mark.parametrize("doc", DOCS, ids=[d.name for d in DOCS])
def test_every_name_the_docs_mention_exists(doc):
    m = mentions(doc)
    missing = ([f"module/name {d}" for d in m["dotted"] if not _resolves(d)]
               + [f"path {p}" for p in m["paths"] if not _exists(p, doc)]
               + [f"file {f}" for f in m["pyfiles"] if f not in NAMES]
               + [f"environment variable {v}" for v in m["env"] if v not in SOURCE])
    assert not missing, f"{doc.relative_to(ROOT)} names what does not exist: " + "; ".join(missing)


def test_the_check_sees_names():
    """The patterns find what the docs write (else the test above would pass on nothing)."""
    m = mentions(ROOT / "README.md")
    assert "mjbench/kernel/" in m["paths"] and "mjbench/mechanisms/" in m["paths"]
    assert any(d.startswith("mjbench.") for d in m["dotted"]) and m["pyfiles"]
    fake = ROOT / "docs" / "CONTRIBUTING.md"
    assert not _exists("mjbench/no_such_module.py", fake) and not _resolves("mjbench.no_such_module")
    assert not _resolves("mjbench.scenario.no_such_function") and _resolves("mjbench.scenario.load")
