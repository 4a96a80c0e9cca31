"""A machine built in code, without TOML: the same tables a scenario holds, given as keyword
arguments (units allowed), validated by the same schema."""
from __future__ import annotations

from typing import TYPE_CHECKING, Any

from .. import control
from ..errors import MjbenchError, ParameterError, ScenarioError
from .. import mechanisms
from ..drive import DriveParams
from ..schema import format_errors

if TYPE_CHECKING:
    from ..control import Controller

    from ..drive import DCMotorDrive
    from ..mechanisms.base import Mechanism


def make_mechanism(type: str, /, **params: Any) -> Mechanism:
    """A mechanism from the keys of a ``[mechanism]`` table.

    Parameters
    ----------
    type : str
        A registered mechanism type: ``"fourbar"``, ``"quickreturn"``, ``"linkage"``, ``"mjcf"``,
        ``"platform"``, ``"rotor"`` or your own (``@mjbench.mechanisms.register``).
    **params
        The table's keys; numbers are SI, strings may carry units (``a="60 mm"``,
        ``m2="0.3 kg"``).  A ``linkage`` takes ``links=[{...}, ...]`` and ``joints=[...]``
        (docs/linkages.md).

    Returns
    -------
    mjbench.mechanisms.Mechanism
        The mechanism: kinematics, reduced model J(q), J'(q), E_p'(q) and its MuJoCo model.

    Raises
    ------
    mjbench.errors.ScenarioError
        Unknown type or keys, wrong units, values out of range (every problem listed).
    mjbench.errors.GeometryError
        A linkage that cannot be assembled or whose input cannot make the full turn.
    """

    mech: Mechanism = _built(lambda: mechanisms.from_dict({"type": type, **params}), f"make_mechanism({type!r})")
    return mech


def make_drive(**params: Any) -> DCMotorDrive:
    """A DC motor + gearbox (and optional drive train) from the keys of a ``[drive]`` table.

    Parameters
    ----------
    **params
        The keys of ``[drive]`` (docs/engine.md, "The [drive] table"); numbers SI, strings with
        units (``L="9 mH"``):

        - ``R`` [Ω] armature resistance; ``L`` [H] armature inductance; ``k_m`` [N·m/A = V·s/rad]
          torque = back-EMF constant; ``J_m`` [kg·m²] rotor inertia; ``lam`` [N·m·s/rad] viscous
          friction on the motor shaft; ``z`` gear ratio φ̇/α̇ (motor turns per crank turn) —
          required unless ``datasheet`` gives them;
        - ``J_a`` [kg·m²] inertia on the motor shaft (pinion; a flywheel there), default 0;
          ``J_b`` [kg·m²] inertia on the crank (input) shaft: the gear, **a flywheel on the
          crankshaft**, default 0;
        - ``T_0`` [N·m] Coulomb friction on the motor shaft, default 0;
        - ``v_max`` [V] voltage limiter (the supply), ``i_max`` [A] amplifier current limit,
          default inf; ``i_rated`` [A] the motor's continuous current rating (the duty figures
          compare the RMS current with it), default inf;
        - ``datasheet={...}``: the motor by its catalogue values — ``rated_voltage``,
          ``no_load_speed``, ``no_load_current``, ``stall_torque``, ``stall_current``,
          ``terminal_resistance``, ``inductance``, ``rotor_inertia``, ``gear_ratio``,
          ``gear_efficiency``, ``rated_current`` — converted to R, k_m, lam, L, J_m (z, gear
          efficiency, i_rated): R = terminal resistance, else V_n/I_stall, else k_m·V_n/T_stall;
          k_m = (V_n − R·I_0)/ω_0; λ = k_m·I_0/ω_0 (:mod:`mjbench.drives.datasheet`);
        - drive-train elements as nested tables: ``pwm={...}``, ``encoder={...}``,
          ``sensor={...}``, ``gear={...}``, ``friction={...}``, ``current_loop={...}``
          (docs/drivetrain.md).

        The ideal drives' keys (``type="torque"``: ``J``, ``damping``, ``T_max``; ``type="speed"``:
        ``k_v``, ``k_i``, ``J``, ``speed_max``) belong to their tables in a scenario.

    Returns
    -------
    mjbench.drive.DCMotorDrive

    Raises
    ------
    mjbench.errors.ScenarioError
        Missing, unknown or invalid keys (every problem listed, as ``drive.KEY: ...``).
    """
    from pydantic import ValidationError


    table, problems = DriveParams.expand(params)
    if problems:
        raise ScenarioError("invalid [drive] table:\n  " + "\n  ".join(problems), problems=problems)
    try:
        p = DriveParams.model_validate(table)
    except ValidationError as e:
        lines = format_errors(e, ("drive",), DriveParams)
        raise ScenarioError("invalid [drive] table:\n  " + "\n  ".join(lines), problems=lines) from None
    drive: DCMotorDrive = _built(p.build, "make_drive")
    return drive


def make_controller(type: str, /, *, drive: DCMotorDrive | None = None, mechanism: Mechanism | None = None,
                    **params: Any) -> Controller:
    """A controller from the keys of a ``[modes.NAME]`` table.

    Parameters
    ----------
    type : str
        A registered controller type: ``"open"``, ``"pid"``, ``"smc"``, ``"servo"``, ``"fmu"`` or
        your own (``@controllers.register``).
    drive, mechanism : optional
        The machine's drive and mechanism, for controllers that need them (a PID's speed
        reference in motor units, a coupler-speed reference, the SMC's model).
    **params
        The table's keys (``kp=80``, ``omega0="286.5 rpm"``, ``period="1 ms"``, ``reference={...}``).

    Returns
    -------
    controllers.Controller
        ``controller(t, y)`` gives the voltage [V]; ``period`` [s]; ``reset()``.

    Raises
    ------
    mjbench.errors.ScenarioError
        Unknown type or keys, invalid values (every problem listed).
    """
    ctrl: Controller = _built(lambda: control.REGISTRY.from_dict({"type": type, **params}, drive=drive, mechanism=mechanism),
                              f"make_controller({type!r})")
    return ctrl


def _built(make: Any, what: str) -> Any:
    """``make()``, with a plain ValueError/TypeError from deeper code reported as a ParameterError."""
    try:
        return make()
    except MjbenchError:
        raise
    except (ValueError, TypeError, KeyError, ArithmeticError) as e:
        raise ParameterError(f"{what}: cannot be built ({type(e).__name__}: {e})") from None
