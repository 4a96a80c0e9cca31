"""A built linkage is kept in the user cache: a second command reads it back (the same bits) instead
of assembling it again — one input or several (the five-bar's grid tables) —; a corrupted entry is
rebuilt and said; an unwritable cache leaves nothing."""
import json
import os
import pickle
import subprocess
import sys

import numpy as np

SCRIPT = """
import json, sys, hashlib, pickle
import numpy as np
from mjbench import scenario as S
from mjbench.compiled import cache
from mjbench.mechanisms.linkage import model
if {fresh}:
    model.DISK_FOLDER = None
m = S.make_mechanism(S.load("{name}"))
c = m.c
digest = hashlib.sha256()
for a in ({arrays}):
    digest.update(np.ascontiguousarray(a).tobytes())
print(json.dumps({{"digest": digest.hexdigest(), "scipy": "scipy.optimize" in sys.modules, "notes": cache.NOTES,
                  "info": {{k: str(v) for k, v in c.table_info.items()}}, "key": getattr(c, "content_key", "")}}))
"""
PRESS = {"name": "press-slidercrank", "arrays": "c.z_ref, c.table.P.rows, *c.coarse, c.table.coef"}
FIVEBAR = {"name": "fivebar", "arrays": "c.z_ref, c.table_n.P.rows, c.table_n.coef"}


def _run(env, fresh=False, name=PRESS["name"], arrays=PRESS["arrays"]):
    p = subprocess.run([sys.executable, "-c", SCRIPT.format(fresh=fresh, name=name, arrays=arrays)],
                       capture_output=True, text=True, timeout=600, env={**os.environ, "MUJOCO_GL": "egl", **env})
    assert p.returncode == 0, p.stderr[-3000:]
    return json.loads(p.stdout.strip().splitlines()[-1])


def test_a_built_linkage_is_read_back_with_the_same_bits(tmp_path):
    env = {"MJBENCH_CACHE_DIR": str(tmp_path / "cache")}
    first = _run(env)
    assert first["scipy"] and first["notes"] == []  # assembled: least squares
    entries = list((tmp_path / "cache" / "linkages").glob("*.pickle"))
    assert len(entries) == 1
    second = _run(env)
    assert not second["scipy"] and second["notes"] == []  # read back: no assembly, no scipy.optimize
    fresh = _run(env, fresh=True)  # built again without the cache
    assert first["digest"] == second["digest"] == fresh["digest"]
    assert first["info"] == second["info"] == fresh["info"]
    assert not list((tmp_path / "cache" / "linkages").glob(".*.tmp"))


def test_a_machine_with_several_inputs_is_read_back_with_the_same_bits(tmp_path):
    """The five-bar's assembly, grid and 2-input tables: built by the first command, read back by the
    second (no least squares, no grid solve), the same bits as a build without the cache, and the
    same tables' key."""
    env = {"MJBENCH_CACHE_DIR": str(tmp_path / "cache")}
    first, second, fresh = (_run(env, fresh=f, **FIVEBAR) for f in (False, False, True))
    assert first["scipy"] and not second["scipy"] and first["notes"] == second["notes"] == []
    assert len(list((tmp_path / "cache" / "linkages").glob("*.pickle"))) == 1
    assert first["digest"] == second["digest"] == fresh["digest"]
    assert first["info"] == second["info"] == fresh["info"] and first["key"] == second["key"] == fresh["key"]


def test_a_corrupted_entry_is_rebuilt_and_said(tmp_path):
    env = {"MJBENCH_CACHE_DIR": str(tmp_path / "cache")}
    ref = _run(env)
    (entry,) = (tmp_path / "cache" / "linkages").glob("*.pickle")
    raw = entry.read_bytes()
    entry.write_bytes(raw[: len(raw) // 2])  # truncated
    again = _run(env)
    assert again["digest"] == ref["digest"] and again["scipy"]
    assert any("built linkage 'press': its cache entry could not be read (checksum); rebuilt" in n
               for n in again["notes"]), again["notes"]
    # rewritten whole: the next command reads it back
    third = _run(env)
    assert third["digest"] == ref["digest"] and not third["scipy"] and third["notes"] == []
    # garbage with a valid checksum (an entry written by other code): not a linkage, rebuilt
    from mjbench.compiled import cache

    body = pickle.dumps({"not": "a linkage"})
    entry.write_bytes(cache.OBJECT_MAGIC + cache.checksum(body) + body)
    fourth = _run(env)
    assert fourth["digest"] == ref["digest"] and fourth["scipy"]


def test_an_unwritable_cache_keeps_nothing(tmp_path):
    (tmp_path / "afile").write_text("")
    tmpd = tmp_path / "tmp"
    tmpd.mkdir()
    env = {"MJBENCH_CACHE_DIR": str(tmp_path / "afile" / "cache"), "TMPDIR": str(tmpd)}
    out = _run(env)
    assert out["scipy"] and any("not writable" in n for n in out["notes"]), out["notes"]
    assert list(tmpd.iterdir()) == [] and sorted(p.name for p in tmp_path.iterdir()) == ["afile", "tmp"]


def test_the_cache_keeps_a_bounded_number_of_entries(tmp_path, monkeypatch):
    from mjbench.compiled import cache

    monkeypatch.setattr(cache, "_ROOT", tmp_path)
    monkeypatch.setattr(cache, "_CHECKED", True)
    monkeypatch.setattr(cache, "KEEP_OBJECTS", 3)
    for i in range(5):
        assert cache.store_object("things", f"k{i}", np.arange(i))
        os.utime(tmp_path / "things" / f"k{i}.pickle", ns=(i * 10**9, i * 10**9))
    assert sorted(p.name for p in (tmp_path / "things").iterdir()) == ["k2.pickle", "k3.pickle", "k4.pickle"]
    assert np.array_equal(cache.load_object("things", "k4"), np.arange(4))
    assert cache.load_object("things", "k0") is None


def test_an_entry_with_one_byte_changed_or_of_an_older_format(tmp_path, monkeypatch):
    """A byte flipped inside the pickle fails the check (a note, the entry removed); an entry of the
    format's earlier version (SHA-256 header) is absent, removed without a note."""
    import hashlib

    from mjbench.compiled import cache

    monkeypatch.setattr(cache, "_ROOT", tmp_path)
    monkeypatch.setattr(cache, "_CHECKED", True)
    monkeypatch.setattr(cache, "NOTES", [])
    assert cache.store_object("things", "a", np.arange(1000.0))
    path = tmp_path / "things" / "a.pickle"
    raw = bytearray(path.read_bytes())
    raw[len(raw) // 2] ^= 0x10
    path.write_bytes(bytes(raw))
    assert cache.load_object("things", "a", "thing") is None
    assert cache.NOTES == ["thing: its cache entry could not be read (checksum); rebuilt"] and not path.exists()
    body = pickle.dumps(np.arange(3.0))
    path.write_bytes(b"mjbench-object-1\n" + hashlib.sha256(body).digest() + body)
    assert cache.load_object("things", "a", "thing") is None and not path.exists()
    assert len(cache.NOTES) == 1
    assert cache.store_object("things", "a", np.arange(3.0))
    assert np.array_equal(cache.load_object("things", "a"), np.arange(3.0))
