"""``mjbench export-fmu SCENARIO --out machine.fmu``: the scenario's plant (or a mode's controller)
as an FMI 2.0 co-simulation FMU (:mod:`mjbench.fmi`, docs/bridges.md)."""
from __future__ import annotations

from . import cli_command
from .. import api
from ..errors import ParameterError


def register(sub):
    p = sub.add_parser(
        "export-fmu", help="FMI 2.0 co-simulation FMU of the plant (or of a mode's controller), for Simulink, "
                           "OpenModelica, FMPy …",
        description="Write an FMI 2.0 co-simulation FMU of SCENARIO's plant: mechanism + drive (+ the drive train), "
                    "input the armature voltage (or a motor torque), outputs crank angle/speed, motor speed, current, "
                    "voltage, crank torque, the mechanism's internal coordinates and named points; the scenario's "
                    "physical parameters as FMU parameters with units. With --controller MODE the FMU is that mode's "
                    "controller instead (inputs q, qd, qdd, current; output u). The FMU runs mjbench's own kernel "
                    "through pythonfmu: the importing side needs Python with the packages of the FMU's "
                    "resources/requirements.txt (docs/bridges.md).")
    p.add_argument("scenario", help="built-in scenario name or TOML path")
    p.add_argument("--out", required=True, help="the .fmu file to write")
    p.add_argument("--input", choices=["voltage", "torque"], default="voltage",
                   help="plant input: armature voltage [V] (default) or motor torque [N·m] (ideal current source)")
    p.add_argument("--backend", choices=["multibody", "reduced"], default="multibody",
                   help="the plant's mechanics: MuJoCo (default) or the reduced model")
    p.add_argument("--controller", metavar="MODE", default=None,
                   help="export the controller of this mode instead of the plant")
    p.add_argument("--set", dest="overrides", action="append", default=[], metavar="KEY=VALUE")
    p.add_argument("--force", action="store_true", help="replace an existing --out file")
    p.set_defaults(func=cmd_export_fmu)


@cli_command
def cmd_export_fmu(args):
    """``mjbench export-fmu`` = ``mjbench.export_fmu`` (docs/api.md)."""
    import os


    try:
        import pythonfmu  # noqa: F401
    except ImportError:
        raise ParameterError("export-fmu needs pythonfmu: pip install 'mjbench[fmi]' (or pip install pythonfmu)") from None
    out = api.export_fmu(api.load(args.scenario, args.overrides), args.out, controller=args.controller,
                         input=args.input, backend=args.backend, force=args.force, what="--out")
    note = ""
    try:
        import fmpy.validation as V
    except ImportError:
        note = " (FMPy not installed: not validated)"
    else:
        problems = V.validate_fmu(os.fspath(out))
        note = " — FMPy validation: " + ("passed" if not problems else "; ".join(problems))
    print(f"FMU written to {args.out}{note}")
    return 0
