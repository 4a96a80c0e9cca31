"""A machine's plant (or a mode's controller) run one communication step at a time.

This is what an exported FMU executes (:mod:`mjbench.fmi.slave` is only the FMI shell around it),
so it is tested without any FMI library: :class:`PlantSession` drives the co-step kernel's
:class:`~mjbench.kernel.Stepper` — the same loop, laws and plants as ``mjbench run`` — with a
*held input* in the controller slot (:class:`HeldInput`), and :class:`ControllerSession` calls a
mode's controller object once per communication step.

Parameters are the scenario's numeric physical fields (``[drive]`` with its drive-train tables,
``[mechanism]``, ``[initial]``; a controller's ``[modes.NAME]``) by their dotted TOML path, in SI
units (:func:`parameters`); setting one re-validates the scenario before the run is built, so a
value the machine cannot be built with is refused with the scenario's own message.
"""
from __future__ import annotations

import math
from collections import namedtuple
from dataclasses import dataclass

import numpy as np

from ..control import REGISTRY as CONTROLLERS
from ..control import Controller, Measurement

from .. import compiled as C
from ..errors import ParameterError, SimulationDiverged
from ..fields import UnitMeta
from .. import scenario as S
from ..machine import Machine
from .. import kernel
from ..runner import backend_options
from ..backends.multibody import MultibodyPlant
from ..backends.reduced import ReducedPlant
from ..kernel import KS_K
from ..drive import drive_torque

INPUTS = ("voltage", "torque")
BACKENDS = ("multibody", "reduced")
#: co-steps a stepper runs between two resets of its scratch record
_CHUNK = 4096


# ============================================================================ parameters
@dataclass
class Param:
    """One scalar parameter: dotted TOML ``path``, value [SI], quantity ``kind`` (None: a number
    without unit), description."""

    path: str
    value: float
    kind: str | None
    description: str = ""


def _unit_kind(field) -> str | None:

    for m in field.metadata:
        if isinstance(m, UnitMeta):
            return m.kind
    return None


def model_parameters(model, prefix: str) -> list[Param]:
    """The finite float fields of a validated pydantic table (and of its sub-tables), by path."""
    from pydantic import BaseModel

    out = []
    if model is None:
        return out
    for name, f in type(model).model_fields.items():
        v = getattr(model, name)
        path = f"{prefix}.{name}"
        if isinstance(v, BaseModel):
            out += model_parameters(v, path)
        elif isinstance(v, float) and not isinstance(v, bool) and math.isfinite(v):
            out.append(Param(path, float(v), _unit_kind(f), f.description or ""))
    return out


def parameters(scn, mode: str | None = None) -> list[Param]:
    """The plant's parameters (``drive.*``, ``mechanism.*``, ``initial.*``), or with ``mode`` the
    controller's (``modes.MODE.*``)."""
    if mode is not None:
        return model_parameters(scn.modes[mode], f"modes.{mode}")
    return (model_parameters(scn.drive, "drive") + model_parameters(scn.mechanism, "mechanism")
            + model_parameters(scn.initial, "initial"))


def with_parameters(scn, base: list[Param], values: dict):
    """The scenario with the parameters that differ from ``base`` set (validated again)."""

    changed = {p.path: float(values[p.path]) for p in base
               if p.path in values and float(values[p.path]) != p.value}
    return S.with_values(scn, changed) if changed else scn


# ============================================================================ the held input
HeldP = namedtuple("HeldP", "R k_m z w")


@C.law
def held_voltage_law(t, q, qd, qdd, I, phi_r, om_r, acc_r, P, S):
    """The armature voltage set from outside (S[0] [V]), held until the next communication point."""
    return S[0]


@C.law
def held_torque_law(t, q, qd, qdd, I, phi_r, om_r, acc_r, P, S):
    """An ideal current source: the voltage whose exact step-mean current is T/k_m for the motor
    torque T = S[0] [N·m] — Ī = I_ss + (I − I_ss)·w (:func:`mjbench.drive.current_mean`) solved for
    I_ss, V = R·I_ss + k_m·φ̇ (L = 0: w = 0, I_ss = T/k_m)."""
    i_bar = S[0] / P.k_m
    i_ss = (i_bar - I * P.w) / (1.0 - P.w)
    return P.R * i_ss + P.k_m * P.z * qd


class HeldInput(Controller):
    """The FMU's input in the kernel's controller slot: a held voltage, or a motor torque made by an
    ideal current source (:func:`held_torque_law`); sampled at every co-step."""

    type_name = "fmu-input"
    STATE = ("input",)

    def __init__(self, kind: str, drive):
        if kind not in INPUTS:
            raise ParameterError(f"input = {kind!r}: choose one of {', '.join(INPUTS)}")
        self.kind = kind
        self.law = held_voltage_law if kind == "voltage" else held_torque_law
        self._drive = drive
        self.period = 0.0

    @classmethod
    def from_params(cls, params, drive=None, mechanism=None, scenario=None):  # pragma: no cover - not a mode
        raise ParameterError("the FMU input is not a scenario mode")

    def parameters(self, T, z):
        d = self._drive
        L, R = float(d.L), float(d.R)
        w = -math.expm1(-T * R / L) / (T * R / L) if L > 0 else 0.0
        return HeldP(R, float(d.k_m), float(z), w)

    def form(self, T, machine):
        return C.Form(self.law, self.parameters(T, float(machine.drive.z)), self.initial_state())


def check_torque_input(dp) -> None:
    """The torque input is exact for the rigid, ideal electrical path only (the law needs the
    motor speed at the step start and commands the armature voltage directly); ``dp``: the
    scenario's validated ``[drive]``."""
    bad = [f"drive.{k}" for k in ("pwm", "current_loop", "encoder", "sensor") if getattr(dp, k, None) is not None]
    gear = getattr(dp, "gear", None)
    if gear is not None and gear.compliant:
        bad.append("drive.gear (compliant: backlash/stiffness)")
    if bad:
        raise ParameterError(f"input = 'torque' is an ideal current source on the rigid drive; it cannot be combined "
                             f"with {', '.join(bad)} (use input = 'voltage')")


# ============================================================================ plant
OUTPUTS = (("crank_angle", "angle", "input (crank) angle q"),
           ("crank_speed", "angular_velocity", "input (crank) speed q̇"),
           ("motor_speed", "angular_velocity", "motor speed φ̇ = z·q̇ (a compliant gear: the motor's own)"),
           ("current", "current", "armature current I"),
           ("voltage", "voltage", "armature voltage commanded (after the ±v_max limiter)"),
           ("crank_torque", "torque", "drive torque on the crank z·(k_m·I − T_0·sgn φ̇ − λ·φ̇)"))


def _ident(s: str) -> str:
    out = "".join(c if (c.isalnum() or c == "_") else "_" for c in str(s))
    return out if out and not out[0].isdigit() else f"_{out}"


class PlantSession:
    """The plant of a scenario — mechanism + drive (+ drive train) on one backend — advanced by
    :meth:`step`; its input (``voltage`` [V] or ``torque`` [N·m]) is held over each step.

    ``scn``: a validated scenario; ``t_stop`` (optional) lets the kernel decide once whether the
    compiled loop pays (:func:`mjbench.kernel.choose_loop`)."""

    def __init__(self, scn, input: str = "voltage", backend: str = "multibody", loop: str | None = None):
        if backend not in BACKENDS:
            raise ParameterError(f"backend = {backend!r}: choose one of {', '.join(BACKENDS)}")
        if input not in INPUTS:
            raise ParameterError(f"input = {input!r}: choose one of {', '.join(INPUTS)}")
        self.scn0 = scn
        self.input_kind, self.backend, self.loop = input, backend, loop
        self.params = parameters(scn)
        self.values = {p.path: p.value for p in self.params}
        self.h = float(scn.simulation.dt)
        self.input = 0.0
        self.stepper = None
        mech = self._machine(scn).mechanism
        self.internal = tuple(mech.internal)
        self.point_names = tuple(mech.points(float(scn.initial.q0)).keys())
        self._out = {}

    # ---------------------------------------------------------------- description
    def outputs_table(self) -> list[tuple[str, str | None, str]]:
        """(name, kind, description) of every output."""
        rows = list(OUTPUTS)
        for n in self.internal:
            rows += [(_ident(n), "angle", f"internal coordinate {n}"),
                     (f"{_ident(n)}_rate", "angular_velocity", f"rate of {n}")]
        for p in self.point_names:
            rows += [(f"points.{_ident(p)}.x", "length", f"point {p}, x (mechanism plane)"),
                     (f"points.{_ident(p)}.y", "length", f"point {p}, y (mechanism plane)")]
        return rows

    # ---------------------------------------------------------------- run
    def _machine(self, scn):

        if self.input_kind == "torque":
            check_torque_input(scn.drive)
        drive = S.make_drive(scn)
        if self.input_kind == "torque":
            drive.v_max = math.inf  # an ideal current source: the voltage it needs is not limited
        ctrl = HeldInput(self.input_kind, drive)
        init = scn.initial
        return Machine(S.make_mechanism(scn), drive, ctrl, q0=init.q0, qd0=init.qd0, I0=init.I0)

    def start(self, t_stop: float | None = None) -> None:
        """Build the machine with the current parameter values and start a run at t = 0."""

        self.finish()
        scn = with_parameters(self.scn0, self.params, self.values)
        self.scn = scn
        self.h = h = float(scn.simulation.dt)
        mc = self._machine(scn)
        if self.backend == "multibody":
            plant = MultibodyPlant(mc, backend_options(scn, "multibody"))
        else:
            o = backend_options(scn, "reduced")
            plant = ReducedPlant(mc, o["timestep"], o["method"], o["rtol"], o["atol"], o["model"])
        plant.start()
        pr = kernel.Program.build(plant, mc, h, 1)
        steps = int(round(t_stop / h)) if t_stop and math.isfinite(t_stop) else 0
        mode, self.loop_reason = kernel.choose_loop(pr, steps, self.loop)
        out = np.full((_CHUNK + 1) * len(pr.columns), np.nan)
        # nsteps: never reached (an FMU has no end); decim 1: the divergence check at every co-step
        self.stepper = st = kernel.Stepper(plant, mc, h, 2 ** 62, 1, mode, pr, out)
        self.plant, self.machine, self.program = plant, mc, pr
        self._write = pr.slots["PWRITE"].bound() if pr.flags["NEXTRA"] else None
        self._extra = np.zeros(max(1, pr.flags["NEXTRA"]))
        self._pd = pr.drive_P[0]
        self.set_input(self.input)
        self._update()

    def set_input(self, value: float) -> None:
        """The input held from now on (voltage [V] or motor torque [N·m])."""
        self.input = float(value)
        if self.stepper is not None:
            self.stepper.parts.ctrl_S[0][0] = self.input

    @property
    def n(self) -> int:
        return 0 if self.stepper is None else self.stepper.n

    @property
    def time(self) -> float:
        return self.n * self.h

    def steps_for(self, t: float, dt: float) -> int:
        """The co-step index at t + dt; ParameterError unless both are whole multiples of the step."""
        n1 = (t + dt) / self.h
        k = int(round(n1))
        if abs(n1 - k) > 1e-6 * max(1.0, abs(n1)) or abs(t / self.h - self.n) > 1e-6 * max(1.0, self.n):
            raise ParameterError(f"communication point {t:g} s + {dt:g} s is not on the plant's co-simulation "
                                 f"step grid (simulation.dt = {self.h:g} s, now at {self.time:g} s)")
        return k

    def step(self, t: float, dt: float) -> None:
        """Advance from the communication point t by dt (both whole multiples of the co-step)."""

        st = self.stepper
        if st is None:
            raise ParameterError("the plant was not started (start() / exitInitializationMode)")
        target = self.steps_for(t, dt)
        while st.n < target and not st.diverged:
            st.ks[KS_K] = 0  # the record is scratch: the outputs are read from the state
            st.advance(min(target, st.n + _CHUNK))
        if st.diverged:
            raise SimulationDiverged(st.message(self.backend), t=float(st.div[1]))
        self._update()

    def _update(self):

        st = self.stepper
        s = st.state()
        z = float(self.machine.drive.z)
        w = z * (s["qd"] + s["deflection_rate"])
        o = {"crank_angle": s["q"], "crank_speed": s["qd"], "motor_speed": w, "current": s["I"],
             "voltage": s["u"] if self.input_kind == "voltage" or st.n > 0 else 0.0,
             "crank_torque": float(drive_torque(s["I"], w, self._pd))}
        nx = len(self.internal)
        if nx:
            X = st.parts
            self._write(self._extra, 0, X.plant_P, X.plant_S)
            for i, n in enumerate(self.internal):
                o[_ident(n)] = float(self._extra[i])
                o[f"{_ident(n)}_rate"] = float(self._extra[nx + i])
        if self.point_names:
            pts = self.machine.mechanism.points(s["q"])
            for p in self.point_names:
                x, y = pts.get(p, (math.nan, math.nan))
                o[f"points.{_ident(p)}.x"], o[f"points.{_ident(p)}.y"] = float(x), float(y)
        self._out = o

    def output(self, name: str) -> float:
        return float(self._out.get(name, math.nan))

    def outputs(self) -> dict:
        return dict(self._out)

    def finish(self) -> None:
        if self.stepper is not None:
            fin = getattr(self.plant, "finish", None)
            if fin is not None:
                fin()
            self.stepper = None


# ============================================================================ controller
#: the measurement signals a controller FMU takes (name, kind, description)
CONTROLLER_INPUTS = (("q", "angle", "input (crank) angle"), ("qd", "angular_velocity", "input (crank) speed"),
                     ("qdd", "angular_acceleration", "input (crank) acceleration, backward difference over one co-step"),
                     ("current", "current", "armature current"))


class ControllerSession:
    """A mode's controller called once per communication step: the inputs (crank angle, speed,
    acceleration, current) set before the step, the output (voltage [V], or a current reference
    [A] when the scenario's drive has a current loop) computed at the step's start time."""

    def __init__(self, scn, mode: str):
        self.scn0, self.mode = scn, scn.mode(mode)
        self.params = parameters(scn, self.mode)
        self.values = {p.path: p.value for p in self.params}
        self.inputs = {k: 0.0 for k, _, _ in CONTROLLER_INPUTS}
        self.u = 0.0
        self.ctrl = None

    def start(self) -> None:

        scn = with_parameters(self.scn0, self.params, self.values)
        drive = S.make_drive(scn)
        self.ctrl = CONTROLLERS.build(scn.modes[self.mode], drive=drive, mechanism=S.make_mechanism(scn), scenario=scn)
        self.ctrl.reset()
        self.y = Measurement(z=float(drive.z))
        self.u = 0.0

    def step(self, t: float, dt: float) -> None:
        if self.ctrl is None:
            raise ParameterError("the controller was not started (start() / exitInitializationMode)")
        i = self.inputs
        self.u = float(self.ctrl(t, self.y.set(t, i["q"], i["qd"], i["qdd"], i["current"])))
