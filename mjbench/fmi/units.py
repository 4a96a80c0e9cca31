"""FMI units of mjbench's quantity kinds (:data:`mjbench.units.KINDS`) and of the FMU's signals.

FMI 2.0 names a unit by a free string and defines it once in ``<UnitDefinitions>`` by the exponents
of the SI base units (plus ``rad``).  The names follow Modelica's notation (``N.m``, ``rad/s``,
``kg.m2``) so that Dymola, OpenModelica and Simulink display them as their users expect."""
from __future__ import annotations

#: kind → (FMI unit name, base-unit exponents); kinds without a unit ("ratio") are absent
UNITS: dict[str, tuple[str, dict[str, int]]] = {
    "length": ("m", {"m": 1}),
    "mass": ("kg", {"kg": 1}),
    "inertia": ("kg.m2", {"kg": 1, "m": 2}),
    "resistance": ("Ohm", {"kg": 1, "m": 2, "s": -3, "A": -2}),
    "inductance": ("H", {"kg": 1, "m": 2, "s": -2, "A": -2}),
    "motor_constant": ("N.m/A", {"kg": 1, "m": 2, "s": -2, "A": -1}),
    "angle": ("rad", {"rad": 1}),
    "angular_velocity": ("rad/s", {"rad": 1, "s": -1}),
    "angular_acceleration": ("rad/s2", {"rad": 1, "s": -2}),
    "time": ("s", {"s": 1}),
    "frequency": ("Hz", {"s": -1}),
    "voltage": ("V", {"kg": 1, "m": 2, "s": -3, "A": -1}),
    "current": ("A", {"A": 1}),
    "torque": ("N.m", {"kg": 1, "m": 2, "s": -2}),
    "force": ("N", {"kg": 1, "m": 1, "s": -2}),
    "rot_damping": ("N.m.s/rad", {"kg": 1, "m": 2, "s": -1, "rad": -1}),
    "rot_stiffness": ("N.m/rad", {"kg": 1, "m": 2, "s": -2, "rad": -1}),
    "lin_stiffness": ("N/m", {"kg": 1, "s": -2}),
    "lin_damping": ("N.s/m", {"kg": 1, "s": -1}),
    "acceleration": ("m/s2", {"m": 1, "s": -2}),
    "speed": ("m/s", {"m": 1, "s": -1}),
    "power": ("W", {"kg": 1, "m": 2, "s": -3}),
    "gain_v_per_rad_s": ("V.s/rad", {"kg": 1, "m": 2, "s": -2, "A": -1, "rad": -1}),
    "gain_v_per_rad": ("V/rad", {"kg": 1, "m": 2, "s": -3, "A": -1, "rad": -1}),
    "gain_v_per_rad_s2": ("V.s2/rad", {"kg": 1, "m": 2, "s": -1, "A": -1, "rad": -1}),
    "gain_per_s": ("1/s", {"s": -1}),
    "gain_v_per_a": ("V/A", {"kg": 1, "m": 2, "s": -3, "A": -2}),
    "gain_v_per_a_s": ("V/(A.s)", {"kg": 1, "m": 2, "s": -4, "A": -2}),
}


def unit_of(kind: str | None) -> str | None:
    """The FMI unit name of a quantity kind (None: dimensionless or unknown)."""
    if kind is None:
        return None
    u = UNITS.get(kind)
    return u[0] if u else None


def definitions(used) -> list[tuple[str, dict[str, int]]]:
    """(name, exponents) of every unit name in ``used`` (in first-use order)."""
    by_name = {name: exps for name, exps in UNITS.values()}
    out, seen = [], set()
    for u in used:
        if u and u not in seen and u in by_name:
            seen.add(u)
            out.append((u, by_name[u]))
    return out
