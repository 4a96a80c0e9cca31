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

from mjbench.errors import MjbenchError, ParameterError, RunFailed
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


def _first_line(e) -> str:
    text = (str(e).strip().splitlines() or [""])[0][:300]
    return f"{type(e).__name__}: {text}" if text else type(e).__name__


def _model_description(read, path: str, where: str):
    """FMPy's reading of the FMU's modelDescription.xml, its failures as one line naming the mode."""
    import zipfile

    try:
        return read(path)
    except zipfile.BadZipFile:
        raise ParameterError(f"{where}.path = {path!r}: not an FMU (an FMU is a zip archive; this file is not "
                             f"one)") from None
    except KeyError:
        raise ParameterError(f"{where}.path = {path!r}: not an FMU (the archive holds no modelDescription.xml)") from None
    except Exception as e:  # noqa: BLE001 - lxml, FMPy's schema checks: the file is not a usable FMU
        raise ParameterError(f"{where}.path = {path!r}: invalid modelDescription.xml ({_first_line(e)})") from None


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
            except Exception:  # noqa: BLE001 - an instance in the error/fatal state may refuse; it is freed anyway
                pass
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

    def __init__(self, path, inputs, output, period, parameters=None, omega0=None, mode=None):
        from fmpy import read_model_description

        #: how messages name this controller: its scenario mode, ``modes.NAME``
        self.where = f"modes.{mode}" if mode else "the FMU controller"
        where = self.where
        if os.path.isdir(path):
            raise ParameterError(f"{where}.path = {os.fspath(path)!r} is a folder, not an .fmu file")
        if not os.path.isfile(path):
            raise ParameterError(f"{where}.path = {os.fspath(path)!r}: no such FMU file")
        self.path, self.output, self.period = os.fspath(path), str(output), float(period)
        if not (math.isfinite(self.period) and self.period > 0):
            raise ParameterError(f"FMU controller period = {period!r}: must be a time > 0 [s]")
        self.inputs = dict(inputs or {})
        self.parameters_start = {k: float(v) for k, v in (parameters or {}).items()}
        self.omega0 = omega0
        md = _model_description(read_model_description, self.path, where)
        if md.coSimulation is None:
            raise ParameterError(f"{where}.path = {self.path!r}: not a co-simulation FMU (FMI 2.0 CS needed)")
        if not str(md.fmiVersion).startswith("2."):
            raise ParameterError(f"{where}.path = {self.path!r}: FMI {md.fmiVersion}; the FMU controller supports "
                                 f"FMI 2.0")
        from fmpy import platform, supported_platforms

        have = [x for x in supported_platforms(self.path) if x != "c-code"]
        if platform not in have:
            raise ParameterError(f"{where}.path = {self.path!r}: the FMU has no binary for this platform ({platform}; "
                                 f"it has {', '.join(have) or 'none'}): export it for {platform}, or build it from "
                                 f"its sources")
        var = {v.name: v for v in md.modelVariables}
        for name, sig in self.inputs.items():
            v = var.get(name)
            if v is None or v.causality != "input":
                raise ParameterError(f"{where}.inputs.{name}: {self.path} has no input variable of that name; inputs: "
                                     f"{', '.join(k for k, x in var.items() if x.causality == 'input') or 'none'}")
            if v.type != "Real":
                raise ParameterError(f"{where}.inputs.{name}: the FMU's input is of type {v.type}; a measurement "
                                     f"signal needs a Real input")
            allowed = SIGNALS + (REF_SIGNALS if omega0 is not None else ())
            if sig not in allowed:
                raise ParameterError(f"{where}.inputs.{name} = {sig!r}: choose one of {', '.join(allowed)}"
                                     + ("" if omega0 is not None else " (phi_ref, omega_ref, omega_dot_ref need omega0)"))
        v = var.get(self.output)
        if v is None or v.causality != "output":
            raise ParameterError(f"{where}.output = {self.output!r}: {self.path} has no output variable of that name; "
                                 f"outputs: {', '.join(k for k, x in var.items() if x.causality == 'output') or 'none'}")
        if v.type != "Real":
            raise ParameterError(f"{where}.output = {self.output!r}: the FMU's output is of type {v.type}; the drive "
                                 f"needs a Real output")
        for name, value in self.parameters_start.items():
            p = var.get(name)
            if p is None or p.causality not in ("parameter", "input"):
                raise ParameterError(f"{where}.parameters.{name}: {self.path} has no parameter of that name")
            if p.type in ("Integer", "Enumeration") and value != int(value):
                raise ParameterError(f"{where}.parameters.{name} = {value!r}: the FMU's parameter is an {p.type}; give "
                                     f"a whole number")
            if p.type == "String":
                raise ParameterError(f"{where}.parameters.{name}: the FMU's parameter is a String; only numbers and "
                                     f"booleans can be set")
        self._md = md
        self._vr_in = [var[n].valueReference for n in self.inputs]
        self._sig = [self.inputs[n] for n in self.inputs]
        self._vr_out = [var[self.output].valueReference]
        self._par = {}  # FMI type → ([value references], [values])
        for n, x in self.parameters_start.items():
            kind = {"Enumeration": "Integer"}.get(var[n].type, var[n].type)
            refs, vals = self._par.setdefault(kind, ([], []))
            refs.append(var[n].valueReference)
            vals.append(int(x) if kind == "Integer" else (bool(x) if kind == "Boolean" else float(x)))
        self.reference = None
        if omega0 is not None:

            self.reference = ConstantSpeed(omega0)
        self._h = _Handle()
        self._t_last = None
        weakref.finalize(self, self._h.close)

    @classmethod
    def from_params(cls, p, drive=None, mechanism=None, scenario=None):
        source = getattr(scenario, "source", "") if scenario is not None else ""
        modes = getattr(scenario, "modes", None) or {}
        mode = next((k for k, v in modes.items() if v is p), None)  # (its name, for the messages)
        return cls(_resolve(p.path, source), p.inputs, p.output, p.period, p.parameters, p.omega0, mode=mode)

    # ------------------------------------------------------------------ the FMU instance
    def _open(self, t0: float):
        from fmpy import extract
        from fmpy.fmi2 import FMU2Slave

        h = self._h
        h.close(free_library=False)
        try:
            if h.dir is None:
                h.dir = extract(self.path)
            md = self._md
            if h.fmu is None:
                h.fmu = FMU2Slave(guid=md.guid, unzipDirectory=h.dir, modelIdentifier=md.coSimulation.modelIdentifier,
                                  instanceName="mjbench_controller")
            f = h.fmu
            f.instantiate()
            h.live = True
            for kind, (refs, vals) in self._par.items():  # setReal, setInteger, setBoolean
                getattr(f, f"set{kind}")(refs, vals)
            f.setupExperiment(startTime=t0)
            f.enterInitializationMode()
            f.exitInitializationMode()
        except MjbenchError:
            raise
        except Exception as e:  # noqa: BLE001 - FMPy and the FMU's own library: one line naming the mode
            why = _first_line(e)
        else:
            why = None
        if why is not None:  # (raised outside the handler: no reference to FMPy's exception and its frames)
            self._release()
            raise RunFailed(f"{self.where} ({self.path}): the FMU could not be started at t = {t0:.6g} s ({why})", t=t0)
        if self.reference is not None:
            self.reference.reset()

    def _release(self) -> None:
        import contextlib

        with contextlib.suppress(Exception):
            self.close()

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
        try:
            if self._vr_in:
                f.setReal(self._vr_in, vals)
            f.doStep(currentCommunicationPoint=t, communicationStepSize=self.period)  # FMPy raises on a status
            u = float(f.getReal(self._vr_out)[0])  # above warning (discard, error, fatal)
        except Exception as e:  # noqa: BLE001 - FMPy and the FMU's own library: one line naming the mode, the time
            why = _first_line(e)
        else:
            why = None
        if why is not None:
            # the instance is unusable (error, fatal, discard): released here, now, not by the garbage
            # collector (a pythonfmu FMU's library must not be unloaded from inside a collection)
            self._release()
            raise RunFailed(f"{self.where} ({self.path}): the FMU's doStep at t = {t:.6g} s (step {self.period:g} s) "
                            f"failed: {why}", t=t)
        if not math.isfinite(u):
            raise RunFailed(f"{self.where} ({self.path}): the FMU's output {self.output!r} is {u} after its doStep at "
                            f"t = {t:.6g} s", t=t)
        return u

    def describe(self) -> dict:
        return {"type": self.type_name, "period_s": self.period, "path": self.path, "inputs": dict(self.inputs),
                "output": self.output, "parameters": dict(self.parameters_start), "omega0": self.omega0,
                "fmu": {"model_name": self._md.modelName, "generation_tool": self._md.generationTool,
                        "fmi_version": self._md.fmiVersion}}
