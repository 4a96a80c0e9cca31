"""The FMI 2.0 co-simulation shells (pythonfmu ``Fmi2Slave``) around :mod:`mjbench.fmi.session`.

This module is imported by pythonfmu inside the importing tool's Python (the FMU's binary embeds
the Python it finds: the host's own when the host is Python, e.g. FMPy; ``libpython`` preloaded
otherwise).  Each exported FMU carries ``mjbench_fmu.json`` in its ``resources`` folder — the
resolved scenario and the export's choices — and a copy of mjbench's own Python sources, so the
importing side needs only Python ≥ 3.10 with the third-party packages of ``requirements.txt``.
"""
from __future__ import annotations

import json
import os
import sys
import traceback

from pythonfmu import Fmi2Causality, Fmi2Slave, Fmi2Variability, Real
from pythonfmu.enums import Fmi2Initial, Fmi2Status

from mjbench import scenario as S
from mjbench.errors import MjbenchError
from mjbench.fmi.session import CONTROLLER_INPUTS, ControllerSession, PlantSession
from mjbench.fmi.units import definitions, unit_of

CONFIG = "mjbench_fmu.json"
#: extra references to the entry modules' namespaces (see :func:`keep_namespace`)
_KEEP: list = []


def keep_namespace(ns: dict, n: int = 1) -> None:
    """Hold ``n`` more references to an FMU entry module's namespace.  pythonfmu 0.7.0's wrapper
    releases a reference to that dict which it does not own each time it looks the slave class up
    (once per instantiation); without these the namespace of a module still listed in sys.modules
    is freed, and the next instance in the same process finds a reused object ("module has no
    attribute ...") or crashes.  The entry script holds a few at import, every instance adds one."""
    _KEEP.extend([ns] * n)


def _resources_on_path(resources):
    """The mjbench sources shipped in the FMU, when the importing Python has none of its own."""
    if resources and os.path.isdir(os.path.join(resources, "mjbench")) and resources not in sys.path:
        try:
            import mjbench  # noqa: F401 - probe: the host's own mjbench wins over the FMU's copy
        except ImportError:
            sys.path.append(resources)


class UnitReal(Real):
    """A pythonfmu Real with an FMI ``unit`` attribute."""

    def __init__(self, name, unit=None, **kw):
        super().__init__(name, **kw)
        self.unit = unit

    def to_xml(self):
        node = super().to_xml()
        if self.unit:
            node.find("Real").set("unit", self.unit)
        return node


class _Base(Fmi2Slave):
    """What the plant and the controller FMUs share: the configuration, units, logging."""

    description = "mjbench export"
    author = "mjbench"

    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        mod = sys.modules.get(type(self).__module__)
        if mod is not None:
            keep_namespace(vars(mod), 1)
        _KEEP.append(self)  # the wrapper may release the instance once more than it owns (see keep_namespace)
        res = self.resources or ""
        _resources_on_path(res)
        with open(os.path.join(res, CONFIG), encoding="utf-8") as f:
            self.config = json.load(f)
        raw = self.config["scenario"]
        mech = raw.get("mechanism")
        if isinstance(mech, dict) and isinstance(mech.get("file"), str) and not os.path.isabs(mech["file"]):
            mech["file"] = os.path.join(res, mech["file"])  # a model file shipped in resources/models
        self.scn = S.from_raw(raw, self.config.get("source", ""))
        self.modelName = self.config["model_name"]
        self.description = self.config.get("description", self.description)
        from pythonfmu.default_experiment import DefaultExperiment

        sim = self.scn.simulation
        self.default_experiment = DefaultExperiment(0.0, float(sim.t_end), float(sim.record_dt))
        self._units = []
        self.t0 = 0.0
        self.t_stop = None

    def _var(self, name, kind, causality, getter, setter=None, description="", start_from_getter=False):
        unit = unit_of(kind)
        self._units.append(unit)
        kw = {"causality": causality, "description": description or None, "getter": getter, "setter": setter}
        if causality == Fmi2Causality.parameter:
            kw.update(variability=Fmi2Variability.fixed, initial=Fmi2Initial.exact)
        elif causality == Fmi2Causality.input:
            kw.update(variability=Fmi2Variability.continuous)
        else:
            kw.update(variability=Fmi2Variability.continuous, initial=Fmi2Initial.calculated)
        self.register_variable(UnitReal(name, unit=unit, **kw), nested=False)

    def to_xml(self, model_options=dict()):  # noqa: B006 - pythonfmu's signature
        from xml.etree.ElementTree import Element, SubElement

        root = super().to_xml(model_options)
        root.set("description", self.config.get("description", ""))
        defs = definitions(self._units)
        if defs:
            ud = Element("UnitDefinitions")
            for name, exps in defs:
                u = SubElement(ud, "Unit", {"name": name})
                SubElement(u, "BaseUnit", {k: str(v) for k, v in exps.items()})
            kids = list(root)
            at = next((i + 1 for i, c in enumerate(kids) if c.tag in ("CoSimulation", "ModelExchange")), 0)
            root.insert(at, ud)
        # every output is computed in initialisation mode: list them as initial unknowns
        st = root.find("ModelStructure")
        outs = st.find("Outputs") if st is not None else None
        if outs is not None and st.find("InitialUnknowns") is None:
            iu = SubElement(st, "InitialUnknowns")
            for u in outs:
                SubElement(iu, "Unknown", {"index": u.get("index")})
        return root

    def setup_experiment(self, start_time, stop_time, tolerance):
        self.t0 = float(start_time or 0.0)
        self.t_stop = None if stop_time is None else float(stop_time) - self.t0

    def do_step(self, current_time, step_size):
        """One communication step: the session advances from current_time by step_size (an error is
        logged through the FMI logger and reported as a failed step)."""
        try:
            self.session.step(float(current_time) - self.t0, float(step_size))
            return True
        except Exception as e:  # noqa: BLE001
            return self._fail(e)

    def _fail(self, e) -> bool:
        self.log(f"{type(e).__name__}: {e}", Fmi2Status.error)
        if not isinstance(e, MjbenchError):
            self.log(traceback.format_exc(), Fmi2Status.error, "logAll")
        return False


class PlantSlave(_Base):
    """Co-simulation FMU of a machine's plant: mechanism + drive (+ drive train)."""

    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        c = self.config
        self.session = s = PlantSession(self.scn, c["input"], c["backend"])
        if c["input"] == "voltage":
            self._var("voltage_in", "voltage", Fmi2Causality.input, lambda: s.input, s.set_input,
                      "armature voltage (held over the communication step; limited to ±drive.v_max)")
        else:
            self._var("torque_in", "torque", Fmi2Causality.input, lambda: s.input, s.set_input,
                      "motor torque k_m·I (ideal current source; held over the communication step)")
        for name, kind, desc in s.outputs_table():
            self._var(name, kind, Fmi2Causality.output, (lambda n=name: s.output(n)), None, desc)
        for p in s.params:
            self._var(p.path, p.kind, Fmi2Causality.parameter, (lambda k=p.path: s.values[k]),
                      (lambda v, k=p.path: s.values.__setitem__(k, float(v))), p.description)

    def exit_initialization_mode(self):
        try:
            self.session.start(self.t_stop)
        except Exception as e:  # noqa: BLE001 - reported through the FMI logger
            self._fail(e)
            raise


    def terminate(self):
        self.session.finish()
        self.session.stepper = self.session.plant = self.session.machine = self.session.program = None


class ControllerSlave(_Base):
    """Co-simulation FMU of a mode's controller: measurement in, armature voltage (or current
    reference) out, one control sample per communication step at the step's start time."""

    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        self.session = s = ControllerSession(self.scn, self.config["mode"])
        for name, kind, desc in CONTROLLER_INPUTS:
            self._var(name, kind, Fmi2Causality.input, (lambda n=name: s.inputs[n]),
                      (lambda v, n=name: s.inputs.__setitem__(n, float(v))), desc)
        out_kind = "current" if self.scn.drive.current_loop is not None else "voltage"
        self._var("u", out_kind, Fmi2Causality.output, lambda: s.u, None,
                  "controller output (armature voltage; current reference with a current loop)")
        for p in s.params:
            self._var(p.path, p.kind, Fmi2Causality.parameter, (lambda k=p.path: s.values[k]),
                      (lambda v, k=p.path: s.values.__setitem__(k, float(v))), p.description)

    def exit_initialization_mode(self):
        self.session.start()

