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


# ============================================================================ the code blocks run
"""Every fenced block of README.md and docs/*.md says what it is (python, sh, toml, text) and runs as
written: the Python blocks of a document in one fresh interpreter, in an empty folder; every shell
line through bash with ``mjbench`` and ``make`` stubbed (no file may appear — an unquoted ``>`` or
``<`` is a redirection — and the arguments must pass mjbench's own parser), and the cheap lines for
real (the others are listed in :data:`NOT_RUN` with the reason, docs/CONTRIBUTING.md); every TOML
block parses, and a ``[drive]`` table in one builds its drive."""
import json as _json
import subprocess
import sys
import tomllib

FENCE = re.compile(r"^```(\w*)\n(.*?)^```", re.S | re.M)
LANGS = {"python", "sh", "toml", "text"}
BIN = Path(sys.executable).parent
#: shell lines the tests do not run for real (they are still parsed): (regex, why)
NOT_RUN = [
    (r"^make (demo|test)$", "the whole report (minutes) / the test suite itself"),
    (r"^mjbench reproduce (?!--list)", "every paper case end to end: minutes (make demo runs it)"),
    (r"^mjbench (design|paper yigit2023 design|paper incerti2012 calibrate|calibrate|tune|optimize-law) ",
     "a design, calibration, tuning or optimisation loop: 30 s to minutes (tests/test_design_*.py, test_calibrate.py, "
     "test_tune.py, test_vibration.py run them on small cases)"),
    (r"^mjbench (render|export-fmu|frest) ", "a video, an FMU build or a frequency sweep: tens of seconds "
                                              "(tests/test_render.py, test_fmi.py, test_frest.py)"),
    (r"^mjbench sweep ", "a batch of simulations (tests/test_sweep.py runs small ones)"),
    (r"(my_machine|my_linkage|my_requirements)\.toml|motor_log\.csv|record\.csv|pid\.fmu|tcp://",
     "a placeholder for your own file or a cluster"),
    (r"^mjbench linearize (?!incerti2012 --at q=2\.1,t=0\.5 )", "one linearize line runs (README's); the others are "
                                                              "the same command at other points, ~15 s each with their "
                                                              "figures (tests/test_linear.py checks the numbers)"),
    (r"^mjbench (run|analyze) out/", "runs what an earlier line (a design) writes"),
    (r"^mjbench analyze fivebar --out out/fivebar-an$", "the same analysis as README's `mjbench analyze fivebar` line, "
                                                        "which runs"),
]
#: exit status of a documented line that is not 0 (and why: the docs say so)
STATUS = {r"^mjbench paper hulako2025 demand ": (1, "V_C = 0.4 m/s saturates the 12 V supply: a check, stated")}
#: the commands that simulate 2 s and more on both backends stay below this each [s] (a guard, not a timing test)
TIMEOUT = 300


def blocks(doc: Path) -> list:
    """(language, text, first line) of every fenced block."""
    t = doc.read_text()
    return [(m.group(1), m.group(2), t[:m.start()].count("\n") + 1) for m in FENCE.finditer(t)]


def strip_comment(line: str) -> str:
    """The line without its comment (a # at a word's start, outside quotes), as written otherwise."""
    quote = None
    for i, c in enumerate(line):
        if quote:
            quote = None if c == quote else quote
        elif c in "'\"":
            quote = c
        elif c == "#" and (i == 0 or line[i - 1].isspace()):
            return line[:i].rstrip()
    return line.rstrip()


def shell_lines(text: str) -> list:
    """The commands of a shell block, as written: continuation lines joined, comments and blank
    lines dropped."""
    return [x for x in (strip_comment(line).strip() for line in text.replace("\\\n", " ").splitlines()) if x]


def not_run(line: str):
    return next((why for pat, why in NOT_RUN if re.search(pat, line)), None)


DOCS_WITH = {lang: [d for d in DOCS if any(b[0] == lang for b in blocks(d))] for lang in LANGS}


@pytest.mark.parametrize("doc", DOCS, ids=[d.name for d in DOCS])
def test_every_block_says_what_it_is(doc):
    bad = [(line, lang or "(none)") for lang, _, line in blocks(doc) if lang not in LANGS]
    assert not bad, f"{doc.name}: blocks without a language of {sorted(LANGS)}: {bad}"


@pytest.mark.parametrize("doc", DOCS_WITH["toml"], ids=[d.name for d in DOCS_WITH["toml"]])
def test_toml_blocks_parse(doc):
    import mjbench as mjb

    for lang, text, line in blocks(doc):
        if lang != "toml":
            continue
        data = tomllib.loads(text)  # a syntax error names the line
        if isinstance(data.get("drive"), dict) and "R" not in data["drive"] and "datasheet" in data["drive"]:
            mjb.make_drive(**data["drive"])  # a motor from its datasheet builds as written


STUB = """
mjbench() { python3 -c 'import json, sys; print(json.dumps(sys.argv[1:]))' "$@" >> "$ARGV"; }
make() { echo "make $*" >> "$ARGV.make"; }
"""


@pytest.mark.parametrize("doc", DOCS_WITH["sh"], ids=[d.name for d in DOCS_WITH["sh"]])
def test_shell_lines_parse_as_written(doc, tmp_path):
    """Through bash, with the commands stubbed: nothing but the stub's record appears (an unquoted
    `>=` writes a file "=45"), and mjbench's parser accepts every argument list."""
    from mjbench.cli import build_parser

    lines = [x for lang, text, _ in blocks(doc) if lang == "sh" for x in shell_lines(text)]
    assert lines
    for k, line in enumerate(lines):
        work = tmp_path / f"l{k}"
        work.mkdir()
        argv = tmp_path / f"argv{k}"
        r = subprocess.run(["bash", "-c", STUB + line], cwd=work, env={"PATH": os.environ["PATH"], "ARGV": str(argv)},
                           capture_output=True, text=True, timeout=60)
        assert r.returncode == 0, f"{doc.name}: `{line}`: bash: {r.stderr.strip()}"
        assert not list(work.iterdir()), f"{doc.name}: `{line}` wrote {sorted(p.name for p in work.iterdir())}: " \
                                         f"a redirection (quote arguments with < or >)"
        for rec in (argv.read_text().splitlines() if argv.exists() else []):
            args = _json.loads(rec)
            try:
                build_parser(args).parse_args(args)
            except SystemExit as e:
                assert e.code == 0, f"{doc.name}: `{line}`: mjbench's parser refuses {args}"


_RAN: set = set()


def _cheap(doc) -> list:
    return [x for lang, text, _ in blocks(doc) if lang == "sh" for x in shell_lines(text) if not not_run(x)]


@pytest.mark.parametrize("doc", [d for d in DOCS_WITH["sh"] if _cheap(d)], ids=[d.name for d in DOCS_WITH["sh"] if _cheap(d)])
def test_cheap_shell_lines_run(doc, tmp_path):
    """The lines not in :data:`NOT_RUN`, for real, one after the other in one empty folder (a line
    may read what an earlier one wrote); exit status 0 unless :data:`STATUS` documents another."""
    env = {**os.environ, "PATH": f"{BIN}{os.pathsep}{os.environ['PATH']}", "MUJOCO_GL": os.environ.get("MUJOCO_GL", "egl")}
    for line in _cheap(doc):
        if line in _RAN:  # the same line in another document: run once
            continue
        _RAN.add(line)
        want = next((st for pat, (st, _) in STATUS.items() if re.search(pat, line)), 0)
        r = subprocess.run(["bash", "-c", line], cwd=tmp_path, env=env, capture_output=True, text=True, timeout=TIMEOUT)
        assert r.returncode == want, f"{doc.name}: `{line}` exited {r.returncode}:\n{r.stderr[-2000:]}"


@pytest.mark.parametrize("doc", DOCS_WITH["python"], ids=[d.name for d in DOCS_WITH["python"]])
def test_python_blocks_run(doc, tmp_path):
    """The document's Python blocks, in order, in one fresh interpreter in an empty folder."""
    code = "\n\n".join(text for lang, text, _ in blocks(doc) if lang == "python")
    env = {**os.environ, "MUJOCO_GL": os.environ.get("MUJOCO_GL", "egl")}
    r = subprocess.run([sys.executable, "-c", code], cwd=tmp_path, env=env, capture_output=True, text=True,
                       timeout=TIMEOUT)
    assert r.returncode == 0, f"{doc.name}: its Python blocks fail:\n{r.stderr[-3000:]}"


def test_not_run_is_documented():
    """Every reason a documented line is not run is in docs/CONTRIBUTING.md's list."""
    text = (ROOT / "docs" / "CONTRIBUTING.md").read_text()
    assert "Docs that run" in text and "NOT_RUN" in text
