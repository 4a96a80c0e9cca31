"""A controller from an FMU (FMI 2.0 co-simulation) run through FMPy: ``[modes.NAME] type = "fmu"``.

    [modes.ext]
    type = "fmu"
    path = "pid.fmu"                 # relative to the scenario file
    period = "0.1 ms"                # sampling period (> 0): one doStep per sample
    output = "V"                     # the FMU output that drives the motor (voltage, or current
                                     # reference with [drive.current_loop])
    omega0 = 30.0                    # optional motor-speed set-point: signals phi_ref, omega_ref, omega_dot_ref
    [modes.ext.inputs]               # FMU input variable = measurement signal
    omega = "omega"
    phi = "phi"
    [modes.ext.parameters]           # FMU parameter start values (SI)
    kp = 80.0

At each control sample t (every ``period``) the controller sets the FMU's inputs from the
measurement (:class:`controllers.base.Measurement`: ``t``, ``q``, ``qd``, ``qdd``, ``phi``,
``omega``, ``omega_dot``, ``current``; with ``omega0`` the constant-speed reference ``phi_ref``,
``omega_ref``, ``omega_dot_ref`` of :class:`controllers.reference.ConstantSpeed`), calls
``doStep(t, period)`` and reads ``output`` after the step: the value the FMU computed from the
inputs at t, applied over [t, t + period) — the kernel's sample-and-hold, as for every built-in
controller.  A run starting again at an earlier time re-instantiates the FMU (``reset()`` too).

The controller has no compiled form (its law is inside the FMU): runs with it use the CPython
kernel loop (``meta["loop_reason"]`` says so).  Needs FMPy (``pip install 'mjbench[fmi]'``).
"""
from __future__ import annotations

import math
import os
import shutil
import weakref
from typing import Literal

from pydantic import Field

from mjbench.errors import ParameterError
from mjbench.fields import OptQ, Q, Strict

from . import register
from .base import Controller, Measurement
from .reference import ConstantSpeed

#: measurement signals an FMU input may take
SIGNALS = ("t", "q", "qd", "qdd", "phi", "omega", "omega_dot", "current")
REF_SIGNALS = ("phi_ref", "omega_ref", "omega_dot_ref")


class FMUParams(Strict):
    """``[modes.NAME] type = "fmu"``: a controller FMU (FMI 2.0 co-simulation) run by FMPy."""

    type: Literal["fmu"] = "fmu"
    path: str = Field(description="the .fmu file (relative to the scenario file)")
    inputs: dict[str, str] = Field(default_factory=dict,
                                   description="FMU input variable = signal (t, q, qd, qdd, phi, omega, omega_dot, "
                                               "current; with omega0: phi_ref, omega_ref, omega_dot_ref)")
    output: str = Field(description="the FMU output variable driving the motor [V] (current reference [A] with "
                                    "a current loop)")
    period: Q("time", gt=0.0, plausible=False) = Field(description="sampling period: one doStep per sample")
    parameters: dict[str, float] = Field(default_factory=dict, description="FMU parameter start values (SI)")
    omega0: OptQ("angular_velocity") = Field(None, description="motor-speed set-point for the *_ref signals")


def _resolve(path: str, source: str) -> str:
    if os.path.isabs(path):
        return path
    if source and source.startswith("builtin:"):
        import importlib.resources

        return str(importlib.resources.files("mjbench").joinpath("scenarios", path))
    if source and os.path.exists(source):
        return os.path.normpath(os.path.join(os.path.dirname(source), path))
    return os.path.abspath(path)


class _Handle:
    """The FMU instance, its library and its extracted folder (released by :meth:`close`, also when
    the controller is garbage-collected or at exit: a pythonfmu FMU's library must be released
    before the interpreter finalises)."""

    def __init__(self):
        self.fmu = None
        self.dir = None
        self.live = False

    def close(self, free_library: bool = True) -> None:
        f = self.fmu
        if f is not None and self.live:
            try:
                f.terminate()
            finally:
                f.freeInstance()
                self.live = False
        if free_library and f is not None:
            try:
                f.freeLibrary()
            finally:
                self.fmu = None
        if free_library and self.dir is not None:
            shutil.rmtree(self.dir, ignore_errors=True)
            self.dir = None


@register
class FMUController(Controller):
    """A controller FMU sampled every ``period`` s (see the module doc)."""

    type_name = "fmu"
    Params = FMUParams

    def __init__(self, path, inputs, output, period, parameters=None, omega0=None):
        from fmpy import read_model_description

        if not os.path.isfile(path):
            raise ParameterError(f"modes.<mode>.path = {path!r}: no such FMU file")
        self.path, self.output, self.period = os.fspath(path), str(output), float(period)
        if not (math.isfinite(self.period) and self.period > 0):
            raise ParameterError(f"FMU controller period = {period!r}: must be a time > 0 [s]")
        self.inputs = dict(inputs or {})
        self.parameters_start = {k: float(v) for k, v in (parameters or {}).items()}
        self.omega0 = omega0
        md = read_model_description(self.path)
        if md.coSimulation is None:
            raise ParameterError(f"{path}: not a co-simulation FMU (FMI 2.0 CS needed)")
        if not md.fmiVersion.startswith("2."):
            raise ParameterError(f"{path}: FMI {md.fmiVersion}; the FMU controller supports FMI 2.0")
        var = {v.name: v for v in md.modelVariables}
        for name, sig in self.inputs.items():
            v = var.get(name)
            if v is None or v.causality != "input":
                raise ParameterError(f"FMU input {name!r}: {path} has no input variable of that name; inputs: "
                                     f"{', '.join(k for k, x in var.items() if x.causality == 'input')}")
            allowed = SIGNALS + (REF_SIGNALS if omega0 is not None else ())
            if sig not in allowed:
                raise ParameterError(f"FMU input {name} = {sig!r}: choose one of {', '.join(allowed)}"
                                     + ("" if omega0 is not None else " (phi_ref, omega_ref, omega_dot_ref need omega0)"))
        v = var.get(self.output)
        if v is None or v.causality != "output":
            raise ParameterError(f"FMU output {self.output!r}: {path} has no output variable of that name; outputs: "
                                 f"{', '.join(k for k, x in var.items() if x.causality == 'output')}")
        for name in self.parameters_start:
            p = var.get(name)
            if p is None or p.causality not in ("parameter", "input"):
                raise ParameterError(f"FMU parameter {name!r}: {path} has no parameter of that name")
        self._md = md
        self._vr_in = [var[n].valueReference for n in self.inputs]
        self._sig = [self.inputs[n] for n in self.inputs]
        self._vr_out = [var[self.output].valueReference]
        self._vr_par = [var[n].valueReference for n in self.parameters_start]
        self._par = list(self.parameters_start.values())
        self.reference = None
        if omega0 is not None:

            self.reference = ConstantSpeed(omega0)
        self._h = _Handle()
        self._t_last = None
        weakref.finalize(self, self._h.close)

    @classmethod
    def from_params(cls, p, drive=None, mechanism=None, scenario=None):
        source = getattr(scenario, "source", "") if scenario is not None else ""
        return cls(_resolve(p.path, source), p.inputs, p.output, p.period, p.parameters, p.omega0)

    # ------------------------------------------------------------------ the FMU instance
    def _open(self, t0: float):
        from fmpy import extract
        from fmpy.fmi2 import FMU2Slave

        h = self._h
        h.close(free_library=False)
        if h.dir is None:
            h.dir = extract(self.path)
        md = self._md
        if h.fmu is None:
            h.fmu = FMU2Slave(guid=md.guid, unzipDirectory=h.dir, modelIdentifier=md.coSimulation.modelIdentifier,
                              instanceName="mjbench_controller")
        f = h.fmu
        f.instantiate()
        h.live = True
        if self._vr_par:
            f.setReal(self._vr_par, self._par)
        f.setupExperiment(startTime=t0)
        f.enterInitializationMode()
        f.exitInitializationMode()
        if self.reference is not None:
            self.reference.reset()

    def close(self) -> None:
        """Terminate the FMU instance and release its library and extracted files (a later call
        instantiates it again)."""
        self._h.close()
        self._t_last = None

    def reset(self) -> None:
        self._t_last = None
        if self.reference is not None:
            self.reference.reset()

    def __call__(self, t, y: Measurement):
        t = float(t)
        if self._t_last is None or t < self._t_last or not self._h.live:
            self._open(t)
        self._t_last = t
        ref = self.reference(t, y) if self.reference is not None else (0.0, 0.0, 0.0)
        vals = []
        for s in self._sig:
            if s in REF_SIGNALS:
                vals.append(float(ref[REF_SIGNALS.index(s)]))
            else:
                vals.append(float(getattr(y, s)))
        f = self._h.fmu
        if self._vr_in:
            f.setReal(self._vr_in, vals)
        f.doStep(currentCommunicationPoint=t, communicationStepSize=self.period)  # FMPy raises on an error status
        return float(f.getReal(self._vr_out)[0])

    def describe(self) -> dict:
        return {"type": self.type_name, "period_s": self.period, "path": self.path, "inputs": dict(self.inputs),
                "output": self.output, "parameters": dict(self.parameters_start), "omega0": self.omega0,
                "fmu": {"model_name": self._md.modelName, "generation_tool": self._md.generationTool,
                        "fmi_version": self._md.fmiVersion}}
