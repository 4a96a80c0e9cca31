"""A DC motor from its datasheet: ``[drive.datasheet]`` → the drive's R, k_m, L, J_m, λ, z, gear.

A catalogue states a motor by its rated (nominal) voltage V_n, no-load speed ω_0 (and often the
no-load current I_0), stall torque T_s or stall current I_s, terminal resistance R, terminal
inductance L and rotor inertia J_m, and its gearhead by its ratio and efficiency.  The drive model
(:mod:`mjbench.drive`, seed 000 Eqs 6-9) needs R, k_m, L, J_m, λ and z.  The conversion (SI
values; ``conversion()`` states each with its source):

* R = terminal_resistance; else R = V_n / I_s (stall current); else, from the stall torque,
  T_s = k_m·V_n/R with k_m below: R = k_m·V_n / T_s;
* k_m = (V_n − R·I_0) / ω_0: at no load the back-EMF k_m·ω_0 is the rated voltage less the
  resistive drop of the no-load current; without I_0, k_m = V_n / ω_0 (the no-load current
  neglected).  With R from the stall torque both hold at once: k_m = V_n / (ω_0 + V_n·I_0/T_s).
  The torque constant and the back-EMF constant are the same number in SI (N·m/A = V·s/rad);
* λ = k_m·I_0 / ω_0: the no-load friction torque k_m·I_0 taken as viscous (proportional to the
  speed, equal at ω_0); 0 without I_0.  A dry part goes to ``drive.T_0`` directly;
* L = inductance, J_m = rotor_inertia, z = gear_ratio (or ``drive.z``), ``[drive.gear]
  efficiency`` = gear_efficiency (a rigid gear; < 1 scales the motor torque by the power flow's
  direction), ``drive.i_rated`` = rated_current (the continuous current rating the duty figures'
  RMS current is compared with).

A value the datasheet gives may also be written in ``[drive]`` only if equal (a run's manifest
holds both); a different one is an error naming both.  Redundant datasheet values that disagree
(a stall torque and a stall current that do not match k_m and R by more than 10 %, catalogues
often state them at different temperatures) are warnings naming the values.
"""

import math

from pydantic import Field, model_validator
from pydantic_core import PydanticCustomError

from ..fields import OptQ, Q, Strict, format_errors
from ..units import to_si

#: redundant datasheet values further apart than this are a warning (:meth:`MotorDatasheet.consistency`)
MISMATCH = 0.10


class MotorDatasheet(Strict):
    """``[drive.datasheet]``: a DC motor (and gearhead) by its catalogue values (module doc)."""

    rated_voltage: Q("voltage", gt=0.0) = Field(description="rated (nominal) voltage V_n")
    no_load_speed: Q("angular_velocity", gt=0.0) = Field(description="no-load speed ω_0 at V_n (motor shaft)")
    no_load_current: OptQ("current", ge=0.0) = Field(None, description="no-load current I_0 at V_n (friction)")
    stall_torque: OptQ("torque", gt=0.0) = Field(None, description="stall torque T_s at V_n (motor shaft)")
    stall_current: OptQ("current", gt=0.0) = Field(None, description="stall (starting) current I_s at V_n")
    terminal_resistance: OptQ("resistance", gt=0.0) = Field(None, description="terminal resistance R")
    inductance: Q("inductance", ge=0.0) = Field(description="terminal inductance L")
    rotor_inertia: Q("inertia", ge=0.0) = Field(description="rotor inertia J_m")
    gear_ratio: float | None = Field(None, gt=0.0, description="gearhead reduction z (else drive.z)")
    gear_efficiency: float | None = Field(None, gt=0.0, le=1.0, description="gearhead efficiency η (max. 1)")
    rated_current: OptQ("current", gt=0.0) = Field(None, description="continuous (thermal) current rating")

    @model_validator(mode="after")
    def _enough(self):
        if self.terminal_resistance is None and self.stall_current is None and self.stall_torque is None:
            raise PydanticCustomError("mjbench_value", "needs terminal_resistance, stall_current or stall_torque "
                                      "(the winding's resistance comes from one of them)")
        if self.no_load_current is not None and self.stall_current is not None \
                and not self.no_load_current < self.stall_current:
            raise PydanticCustomError("mjbench_value", "no_load_current must be below stall_current")
        return self

    # ------------------------------------------------------------------ conversion
    def derive(self) -> dict:
        """{drive key: (SI value, how it was obtained)} for R, k_m, lam, L, J_m and, when given,
        z, gear.efficiency, i_rated (module doc)."""
        V, w0 = float(self.rated_voltage), float(self.no_load_speed)
        I0 = float(self.no_load_current or 0.0)
        out = {}
        if self.terminal_resistance is not None or self.stall_current is not None:
            if self.terminal_resistance is not None:
                R, how = float(self.terminal_resistance), "terminal_resistance"
            else:
                R, how = V / float(self.stall_current), "rated_voltage / stall_current"
            km = (V - R * I0) / w0
            km_how = "(rated_voltage − R·no_load_current) / no_load_speed" if I0 else "rated_voltage / no_load_speed"
        else:  # R from the stall torque: T_s = k_m·V/R and k_m = (V − R·I0)/ω0 at once
            Ts = float(self.stall_torque)
            km = V / (w0 + V * I0 / Ts)
            R = km * V / Ts
            how = "k_m·rated_voltage / stall_torque"
            km_how = ("rated_voltage / (no_load_speed + rated_voltage·no_load_current/stall_torque)" if I0
                      else "rated_voltage / no_load_speed")
        if not km > 0:
            raise PydanticCustomError("mjbench_value", "R·no_load_current = {d:.4g} V is not below rated_voltage: "
                                      "no positive motor constant", {"d": R * I0})
        out["R"] = (R, how)
        out["k_m"] = (km, km_how + " (torque constant = back-EMF constant in SI)")
        out["lam"] = (km * I0 / w0, "k_m·no_load_current / no_load_speed (no-load friction as viscous)" if I0
                      else "0: no no_load_current given (friction neglected)")
        out["L"] = (float(self.inductance), "inductance")
        out["J_m"] = (float(self.rotor_inertia), "rotor_inertia")
        if self.gear_ratio is not None:
            out["z"] = (float(self.gear_ratio), "gear_ratio")
        if self.gear_efficiency is not None:
            out["gear.efficiency"] = (float(self.gear_efficiency), "gear_efficiency")
        if self.rated_current is not None:
            out["i_rated"] = (float(self.rated_current), "rated_current")
        return out

    def conversion(self) -> dict:
        """{drive key: "value unit = formula"} of :meth:`derive` (the manifest's record)."""
        units = {"R": "Ω", "k_m": "V·s/rad", "lam": "N·m·s/rad", "L": "H", "J_m": "kg·m²", "z": "",
                 "gear.efficiency": "", "i_rated": "A"}
        return {k: f"{v:.10g}{(' ' + units[k]) if units[k] else ''} = {how}" for k, (v, how) in self.derive().items()}

    def consistency(self) -> list[str]:
        """Warnings for redundant values that disagree by more than :data:`MISMATCH`."""
        d = self.derive()
        R, km = d["R"][0], d["k_m"][0]
        V = float(self.rated_voltage)
        out = []
        if self.stall_torque is not None and self.stall_current is not None:
            if _apart(float(self.stall_torque), km * float(self.stall_current)):
                out.append(f"stall_torque {float(self.stall_torque):.4g} N·m and k_m·stall_current = "
                           f"{km * float(self.stall_current):.4g} N·m differ by more than {MISMATCH:.0%}")
        if self.stall_torque is not None and self.terminal_resistance is not None:
            if _apart(float(self.stall_torque), km * V / R):
                out.append(f"stall_torque {float(self.stall_torque):.4g} N·m and k_m·rated_voltage/R = {km * V / R:.4g} "
                           f"N·m differ by more than {MISMATCH:.0%} (the conversion uses R = {d['R'][1]})")
        if self.stall_current is not None and self.terminal_resistance is not None:
            if _apart(float(self.stall_current), V / R):
                out.append(f"stall_current {float(self.stall_current):.4g} A and rated_voltage/terminal_resistance = "
                           f"{V / R:.4g} A differ by more than {MISMATCH:.0%} (the conversion uses terminal_resistance)")
        return [f"drive.datasheet: {w}" for w in out]


def _apart(a: float, b: float) -> bool:
    return abs(a - b) > MISMATCH * max(abs(a), abs(b))


def expand(draw: dict) -> tuple[dict, list[str]]:
    """The ``[drive]`` table with the keys its ``datasheet`` gives filled in, and the problems
    (``drive.<key>: ...``); unchanged without a datasheet.  A key given both ways must be equal."""
    from pydantic import ValidationError

    ds_raw = draw.get("datasheet") if isinstance(draw, dict) else None
    if ds_raw is None:
        return draw, []
    try:
        ds = MotorDatasheet.model_validate(ds_raw)
        derived = ds.derive()
    except ValidationError as e:
        return draw, format_errors(e, ("drive", "datasheet"), MotorDatasheet)
    except PydanticCustomError as e:
        return draw, [f"drive.datasheet: {e.message()}"]
    out = {k: (dict(v) if isinstance(v, dict) else v) for k, v in draw.items()}
    problems = []
    for key, (value, how) in derived.items():
        table, _, name = key.rpartition(".")
        dest = out.setdefault(table, {}) if table else out
        if table and not isinstance(dest, dict):
            continue  # a malformed sub-table: the schema says so
        given = dest.get(name)
        if given is None:
            dest[name] = value
            continue
        try:
            same = math.isclose(float(to_si(given, _KIND.get(key, "ratio")) if isinstance(given, str)
                                      else given), value, rel_tol=1e-9)
        except Exception:  # noqa: BLE001 - a bad value: the schema names it
            continue
        if not same:
            unit = {"R": " Ω", "k_m": " V·s/rad", "lam": " N·m·s/rad", "L": " H", "J_m": " kg·m²", "i_rated": " A"}
            problems.append(f"drive.{key} = {given!r} differs from the datasheet's {value:.6g}{unit.get(key, '')} "
                            f"({how}); give the value one way (change drive.datasheet, or remove drive.{key})")
    return out, problems


#: the unit kind of each derived key (a value given with a unit in [drive])
_KIND = {"R": "resistance", "k_m": "motor_constant", "lam": "rot_damping", "L": "inductance", "J_m": "inertia",
         "i_rated": "current"}
