"""Outputs unchanged bit for bit: every shipped scenario and mode, and the drive-train compositions
of the docs and the study, on both backends and both loops (CPython and compiled), against SHA-256
digests of their records recorded before the kernel's signal interface was introduced
(``tests/data/output_digests.json``).

A digest covers the column names and every float64 of a 0.2 s run recorded every 0.1 ms.  It is a
regression guard, not a physics check (those are in the mechanisms' and drives' own test files):
a change to a law or to the kernel's order of operations that moves any bit shows here.  When such
a change is intended (a physics fix), regenerate with ``python tests/test_digests.py --write`` and
say why in the commit.
"""
from __future__ import annotations

import hashlib
import json
import sys
from pathlib import Path

import pytest

DATA = Path(__file__).parent / "data" / "output_digests.json"
T_END = 0.2
RECORD_DT = 1e-4
BACKENDS = ("reduced", "multibody")

PWM_SW = ['drive.pwm.model="switching"', 'drive.pwm.frequency="20 kHz"', "drive.pwm.v_bus=48",
          'drive.pwm.dead_time="1 us"']
#: drive-train compositions on the seed-000 four-bar (mode pid), as in tests/test_compiled_drivetrain.py
VARIANTS = {
    "pwm_averaged": ['drive.pwm.frequency="20 kHz"', "drive.pwm.v_bus=48", 'drive.pwm.dead_time="1 us"',
                     "drive.i_max=6"],
    "pwm_switching": PWM_SW,
    "encoder_mt": ["drive.encoder.lines=500", 'drive.sensor.speed="mt"', "modes.pid.period=5e-4"],
    "encoder_observer_output": ["drive.encoder.lines=2000", 'drive.encoder.side="output"',
                                'drive.sensor.speed="observer"'],
    "noise_delay": ['drive.sensor.noise_angle="0.01 deg"', "drive.sensor.noise_speed=0.1",
                    'drive.sensor.noise_current="20 mA"', "drive.sensor.seed=1", "drive.sensor.delay=true"],
    "efficiency": ["drive.gear.efficiency=0.9", "drive.gear.efficiency_back=0.7"],
    "current_loop": ['drive.current_loop.bandwidth="1 kHz"', "drive.i_max=20", 'drive.sensor.noise_current="20 mA"'],
    "backlash": ['drive.gear.backlash="0.1 deg"', "drive.encoder.lines=2000", 'drive.sensor.speed="observer"'],
    "vlimit_imax": ["drive.v_max=30", "drive.i_max=4"],
}


def cases() -> list:
    from mjbench import scenario as S

    out = [(name, mode, ()) for name in S.builtin_names() for mode in S.modes(S.load(name))]
    out += [("incerti2012", "pid", tuple(v)) for v in VARIANTS.values()]
    return out


def case_id(name, mode, sets) -> str:
    tag = next((k for k, v in VARIANTS.items() if tuple(v) == tuple(sets)), "")
    return f"{name}/{mode}" + (f"+{tag}" if tag else "")


def digest(name, mode, sets, backend, loop) -> str:
    from mjbench import scenario as S
    from mjbench.backends import simulate
    from mjbench.runner import backend_options

    scn = S.load(name, list(sets))
    tr = simulate(S.make_machine(scn, mode), backend, T_END, record_dt=RECORD_DT,
                  options=backend_options(scn, backend), loop=loop)
    assert tr.meta["loop"] == loop, tr.meta["loop_reason"]
    h = hashlib.sha256(",".join(tr.columns).encode())
    h.update(tr.data[:tr.n].tobytes())
    return h.hexdigest()


def _expected() -> dict:
    return json.loads(DATA.read_text())


CASES = cases()


#: machines with several motors: their compiled loops (≈ 30 s of compilation each) are checked against
#: the CPython loop in tests/test_multi_axis.py; here the CPython loop's digests
MULTI_AXIS = {"fivebar", "arm2r"}


@pytest.mark.parametrize("loop", ("python", "compiled"))
@pytest.mark.parametrize("backend", BACKENDS)
@pytest.mark.parametrize("name,mode,sets", CASES, ids=[case_id(*c) for c in CASES])
def test_outputs_equal_the_recorded_digests(name, mode, sets, backend, loop):
    if loop == "compiled":
        pytest.importorskip("numba")
        if name in MULTI_AXIS:
            pytest.skip("several motors: compiled = CPython in tests/test_multi_axis.py")
    key = f"{case_id(name, mode, sets)}/{backend}"
    want = _expected().get(key)
    assert want is not None, f"no recorded digest for {key}: regenerate tests/data/output_digests.json"
    assert digest(name, mode, sets, backend, loop) == want, key


def test_every_shipped_mode_has_a_digest():
    want = _expected()
    for c in CASES:
        for b in BACKENDS:
            assert f"{case_id(*c)}/{b}" in want


if __name__ == "__main__":  # python tests/test_digests.py --write: record the digests (CPython loop)
    if "--write" not in sys.argv and "--add" not in sys.argv:
        sys.exit("usage: python tests/test_digests.py --write (all) | --add (the missing ones only)")
    res = _expected() if "--add" in sys.argv else {}
    for c in CASES:
        for b in BACKENDS:
            key = f"{case_id(*c)}/{b}"
            if key in res:
                continue
            res[key] = digest(*c, b, "python")
            print(key, res[key][:16], flush=True)
    DATA.write_text(json.dumps(res, indent=1, sort_keys=True) + "\n")
