"""Analyses without a long simulation: the linear model, loop and margins (:func:`linearize`,
python-control objects) and the revolution analysis of a mechanism (:func:`analyze_mechanism`)."""
from __future__ import annotations

import math
import os
from collections.abc import Iterable, Iterator, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from ..errors import ParameterError, SimulationDiverged
from ..machine import Machine
from ..mechanisms.base import Mechanism
from .results import require_pandas
from .scenarios import Scenario, as_scenario, warn
from .. import linear as LN
from ..kernel import memory_limit
from .. import units as U
from .. import analyze as A
from .. import scenario as S
from .simulation import MACHINE_DT, machine_options
from ..plausibility import reduced_vs_mujoco
from ..linear import running_speed
from .. import linear_plots as LP
from .. import plotstyle
from ..outputs import staged_dir, write_json
from ..plausibility import model_warnings
from ..outputs import staged_dir

if TYPE_CHECKING:
    import pandas

    from ..machine import Machine
    from ..mechanisms.base import Mechanism

#: bytes of one analysis sample per speed (measured ≈ 1.3 kB per point, press-slidercrank; ×3 margin)
POINT_BYTES = 4096


# ====================================================================== linearize
class FrozenAngleFamily:
    """The loop at frozen input angles over one turn (python-control objects, one per angle).

    A linkage's inertia J(q) changes as it turns, so its loop does too: at each of ``n`` angles
    ``angles[k]`` [rad] over [0, 2π) the machine is linearised at the running speed ``speeds[k]``
    [rad/s] with the angle frozen (docs/linear.md §5).  Indexing gives one angle's
    :class:`mjbench.linear.Loop` (``family[k].L``); iterating gives ``(angle, loop)`` pairs.

    Attributes
    ----------
    angles, speeds : numpy.ndarray, shape (n,)
        Frozen input angles [rad] and the input speed at each [rad/s].
    loops : tuple of mjbench.linear.Loop
        ``plant``, ``controller``, ``L``, ``S``, ``T``, ``closed``, ``feedback`` at each angle
        (``control.StateSpace``, discrete time at the controller period).
    margins : tuple of mjbench.linear.Margins
        Gain/phase margins, peak |S|, bandwidth, closed-loop poles at each angle.
    worst : dict
        The worst figure over the angles and where it occurs: ``worst["phase_margin_deg"]`` =
        ``{"value": deg, "at_q_rad": rad}``, also ``gain_margin_dB``, ``peak_sensitivity``,
        ``bandwidth_rad_s``, ``spectral_radius``, ``all_stable``.
    validity : dict
        The frozen-angle validity number ν (``ratio``) and its ``verdict`` (valid / marginal /
        fails).
    """

    def __init__(self, angles: np.ndarray, speeds: np.ndarray, loops: Iterable[Any], margins: Iterable[Any],
                 worst: Mapping[str, Any], validity: Mapping[str, Any]) -> None:
        self.angles = np.asarray(angles, dtype=float)
        self.speeds = np.asarray(speeds, dtype=float)
        self.loops: tuple[Any, ...] = tuple(loops)
        self.margins: tuple[Any, ...] = tuple(margins)
        self.worst: dict[str, Any] = dict(worst)
        self.validity: dict[str, Any] = dict(validity)
        if not (len(self.angles) == len(self.speeds) == len(self.loops) == len(self.margins)):
            raise ParameterError("FrozenAngleFamily: angles, speeds, loops and margins must have one entry per angle")

    @classmethod
    def from_family(cls, fam: Any) -> FrozenAngleFamily:
        """From a :class:`mjbench.linear.Family` (:func:`mjbench.linear.frozen_angle_family`)."""
        if any(lp is None for lp in fam.loops):
            raise ParameterError("FrozenAngleFamily: the family was computed without its loops (keep_loops=False)")
        return cls(fam.angles, fam.speeds, fam.loops, fam.margins, fam.worst, fam.validity)

    def __len__(self) -> int:
        return len(self.angles)

    def __getitem__(self, k: int) -> Any:
        """The :class:`mjbench.linear.Loop` at ``angles[k]``."""
        return self.loops[k]

    def __iter__(self) -> Iterator[tuple[float, Any]]:
        """``(angle [rad], Loop)`` for every frozen angle."""
        return iter(zip((float(a) for a in self.angles), self.loops))

    def __repr__(self) -> str:
        return f"<mjbench.FrozenAngleFamily {len(self)} angles, worst PM {self.worst['phase_margin_deg']['value']:.4g}°>"

    @property
    def L(self) -> list[Any]:
        """The loop at the plant input at each angle (``control.StateSpace``, SISO V → V)."""
        return [lp.L for lp in self.loops]

    @property
    def plants(self) -> list[Any]:
        """The sampled plant at each angle (``control.StateSpace``: V → q, qd, I, ..., qd_prev)."""
        return [lp.plant for lp in self.loops]

    @property
    def controllers(self) -> list[Any]:
        """The controller's counterpart at each angle (``control.StateSpace``; the same system
        unless the controller reads the angle)."""
        return [lp.controller for lp in self.loops]

    @property
    def phase_margins_deg(self) -> np.ndarray:
        """Phase margin at each angle [deg], shape (n,)."""
        return np.array([m.phase_margin_deg for m in self.margins], dtype=float)

    @property
    def gain_margins_dB(self) -> np.ndarray:
        """Gain margin at each angle [dB] (inf: none), shape (n,)."""
        return np.array([m.gain_margin_dB for m in self.margins], dtype=float)

    @property
    def peak_sensitivities(self) -> np.ndarray:
        """Peak |S| at each angle, shape (n,)."""
        return np.array([m.Ms for m in self.margins], dtype=float)

    @property
    def stable(self) -> np.ndarray:
        """Whether each frozen loop is stable, shape (n,) bool."""
        return np.array([bool(m.stable) for m in self.margins], dtype=bool)

    def nearest(self, q: float) -> int:
        """Index of the frozen angle nearest to the input angle ``q`` [rad] (modulo 2π)."""
        d = np.abs((self.angles - float(q) + math.pi) % (2.0 * math.pi) - math.pi)
        return int(np.argmin(d))


class LinearResult:
    """The machine's linear model at an operating point, its loop, margins and the frozen-angle
    family (python-control objects).

    Attributes
    ----------
    data : dict
        What ``linear.json`` holds: operating point, matrices, modes, agreement of the reduced and
        multibody linearisations, loop margins, frozen-angle margins and validity, K_p·t limit.
    objects : dict
        Every object computed (``plant_reduced``, ``plant_multibody``, ``loop``, ``margins``,
        ``family``, ``op`` ...); the typed attributes below read them.
    scenario : Scenario
    """

    def __init__(self, scenario: Scenario, data: dict[str, Any], objects: dict[str, Any]) -> None:
        self.scenario, self.data, self.objects = scenario, data, objects
        self._family: FrozenAngleFamily | None = None

    @property
    def plant(self) -> Any:
        """The reduced plant, continuous time (``control.StateSpace``; input V [V], outputs q [rad],
        q̇ [rad/s], I [A] ...)."""
        return self.objects["plant_reduced"]

    @property
    def plant_multibody(self) -> Any:
        """The MuJoCo plant (``mjd_transitionFD``, discrete time, ``control.StateSpace``), or None."""
        return self.objects.get("plant_multibody")

    @property
    def loop(self) -> Any:
        """The sampled loop (:class:`mjbench.linear.Loop`: ``plant``, ``controller``, ``L`` at the
        plant input, ``S``, ``T``, ``closed``, ``feedback`` — ``control.StateSpace`` each), or None
        for a controller without a linear counterpart (see ``data["loop_note"]``)."""
        return self.objects.get("loop")

    @property
    def controller(self) -> Any:
        """The controller's discrete-time counterpart (``control.StateSpace``), or None."""
        lp = self.loop
        return None if lp is None else lp.controller

    @property
    def margins(self) -> Any:
        """Gain/phase margins, peak |S|, bandwidth, closed-loop poles (:class:`mjbench.linear.Margins`)."""
        return self.objects.get("margins")

    @property
    def operating_point(self) -> Any:
        """Where it was linearised: q [rad], qd [rad/s], I [A], V [V], t [s]."""
        return self.objects["op"]

    @property
    def family(self) -> FrozenAngleFamily | None:
        """The loop at ``angles`` frozen input angles over one turn (:class:`FrozenAngleFamily`:
        ``angles`` [rad], ``L``, ``plants``, ``loops``, ``margins``, ``worst``, ``validity``), or
        None (``angles=0``, or a controller without a linear counterpart)."""
        fam = self.objects.get("family")
        if fam is None:
            return None
        if self._family is None:
            self._family = FrozenAngleFamily.from_family(fam)
        return self._family

    def summary(self) -> str:
        """The text ``mjbench linearize`` prints."""
        return linear_summary(self.data)

    def save(self, path: str | os.PathLike[str], *, force: bool = False, what: str = "save") -> Path:
        """Write ``linear.json`` and the figures (bode.png, nyquist.png, poles.png, plant.png) into
        the folder ``path``, whole or not at all (``mjbench linearize --out``)."""

        with staged_dir(path, force=force, what=what) as out:
            write_json(os.path.join(out, "linear.json"), self.data, indent=1)
            with plotstyle.context():
                LP.family_figures(self.objects, os.fspath(out), self.scenario.name)
        return Path(os.path.abspath(os.fspath(path)))


def linearize(scenario: Scenario | str | os.PathLike[str] | Mapping[str, Any], mode: str | None = None, *,
              q: float | None = None, qd: float | None = None, I: float | None = None, t: float | None = None,
              angles: int = 36, multibody: bool = True) -> LinearResult:
    """Linearise a scenario's machine: plant (reduced and MuJoCo), controller, loop, margins.

    Parameters
    ----------
    scenario : Scenario, str, path or dict
    mode : str, optional
        The controller's mode (default: the scenario's).
    q, qd, I, t : float, optional
        Operating point: input angle [rad], input speed [rad/s], current [A], time [s] of a K_p·t
        gain.  Default: the initial angle, the controller's running speed there, the current
        that sustains the speed on average over a turn (at rest: the one holding q̈ = 0; a running
        linkage's q̈* ≠ 0 at the point), ``simulation.t_end`` for a K_p·t PID (else 0).
    angles : int
        Frozen angles over one turn for the family of loops (0: none).
    multibody : bool
        Also linearise the MuJoCo model (``mjd_transitionFD``) and compare.

    Returns
    -------
    LinearResult
        ``plant``, ``plant_multibody``, ``controller``, ``loop`` (python-control objects),
        ``margins``, ``data`` (linear.json), ``summary()``, ``save(dir)``.

    Raises
    ------
    mjbench.errors.SimulationDiverged
        The point is out of the model's numerical range.
    """

    at = {k: v for k, v in (("q", q), ("qd", qd), ("I", I), ("t", t)) if v is not None}
    for k, v in at.items():
        if not math.isfinite(float(v)):
            raise ParameterError(f"linearize: {k} = {v!r} must be finite")
    if at.get("t", 0.0) < 0:
        raise ParameterError(f"linearize: t = {at['t']:g} must be >= 0 s (the time of the run)")
    if int(angles) < 0:
        raise ParameterError(f"linearize: angles = {angles} must be >= 0")
    scn = as_scenario(scenario)
    mode = scn.mode(mode)
    scn.check(mode)
    try:
        res = LN.study(scn.spec, mode, n_angles=int(angles), multibody=multibody, **at)
    except ArithmeticError as e:  # (ZeroDivisionError, OverflowError, FloatingPointError)
        point = ", ".join(f"{k}={v:g}" for k, v in at.items()) or "the default operating point"
        raise SimulationDiverged(f"linearize at {point}: the linear model cannot be computed there "
                                 f"({type(e).__name__}: {e}); the state is out of the model's numerical range "
                                 f"(a speed or current far beyond the motor's?)") from None
    return LinearResult(scn, res["json"], res["objects"])


def number_text(v: Any, fmt: str = "{:.4g}") -> str:
    """A figure of a summary: "—" for None or NaN, "∞" for ±inf, else ``fmt``."""
    return "—" if v is None or v != v else ("∞" if v in (float("inf"), float("-inf")) else fmt.format(v))


def linear_summary(js: dict[str, Any]) -> str:
    """Text summary of a linear.json."""
    f = number_text

    op = js["operating_point"]
    lines = [f"{js['scenario']} (mode {js['mode']}, {js['controller']}): q* = {f(op['q_rad'])} rad, "
             f"q̇* = {f(op['qd_rad_s'])} rad/s, I* = {f(op['I_A'])} A, V* = {f(op['V_V'])} V, "
             f"q̈* = {f(op['qdd_rad_s2'])} rad/s²"
             + (f", t = {f(op['t_s'])} s" if op["t_s"] else "") + f"; angle model: {js['angle_model']}"]
    for w in js.get("warnings", []):
        lines.append(f"WARNING: {w}")
    ag = js.get("agreement", {})
    if "reduced_vs_multibody_input_coordinates" in ag:
        a = ag["reduced_vs_multibody_input_coordinates"]
        lines.append(f"  plant q̇/V, reduced vs multibody (input coordinates): max relative difference "
                     f"{f(a['max_rel'], '{:.2e}')} over {f(a['omega_lo_rad_s'])}-{f(a['omega_hi_rad_s'])} rad/s")
    for k, v in (js.get("transmission_modes") or {}).items():
        lines.append(f"  transmission mode, {k:<7s}: " + ", ".join(
            f"ω_n = {f(m['omega_n_rad_s'])} rad/s, ζ = {f(m['zeta'])}" for m in v))
    lp = js.get("loop")
    if lp:
        lines.append(f"  loop: GM = {f(lp['gain_margin_dB'])} dB, PM = {f(lp['phase_margin_deg'])}°, "
                     f"peak |S| = {f(lp['peak_sensitivity'])}, bandwidth = {f(lp['bandwidth_rad_s'])} rad/s, "
                     f"{'stable' if lp['stable'] else 'UNSTABLE'} (spectral radius {f(lp['spectral_radius'], '{:.6f}')})")
    elif js.get("loop_note"):
        lines.append(f"  no loop analysis: {js['loop_note']}")
    fa = js.get("frozen_angle")
    if fa:
        w, v = fa["worst"], fa["validity"]
        lines.append(f"  frozen angles ({len(fa['angles_rad'])}): worst PM {f(w['phase_margin_deg']['value'])}° at q = "
                     f"{f(w['phase_margin_deg']['at_q_rad'])} rad, worst GM {f(w['gain_margin_dB']['value'])} dB at q = "
                     f"{f(w['gain_margin_dB']['at_q_rad'])} rad, max peak |S| {f(w['peak_sensitivity']['value'])}"
                     f"{'' if w['all_stable'] else ', some frozen loops UNSTABLE'}")
        lines.append(f"  frozen-angle validity ν = {f(v['ratio'])} ({v['verdict']}): inertia/reference change rate "
                     f"{f(max(v['inertia_rate_max_1_s'] or 0, v['reference_rate_max_1_s'] or 0))} 1/s vs bandwidth "
                     f"{f(v['bandwidth_min_rad_s'])} rad/s")
    kr = js.get("kp_ramp")
    if kr:
        lim = kr["limit"]
        lines.append(f"  K_p·t = {f(kr['kp_eff'])} V·s/rad at t = {f(kr['t_s'])} s; the sampled loop loses stability at "
                     f"t = {f(lim['t_s'])} s (K_p·t = {f(lim['kp_eff'])}, q = {f(lim['at_q_rad'])} rad)")
    return "\n".join(lines)


# ====================================================================== analyze
@dataclass(frozen=True)
class TransmissionAngle:
    """One transmission angle of a mechanism over the revolution.

    Attributes
    ----------
    key : str
        Stable key: the name of the joint where it is measured (``"C"``); it does not change when
        a link is renamed.
    label : str
        Display label: the joint and the two links (``"C (coupler on rocker)"``).
    q : numpy.ndarray, shape (points,)
        Input angles [rad].
    mu : numpy.ndarray, shape (points,)
        The transmission angle [rad] at each.
    min_deg, max_deg : float
        Its range [deg].
    q_at_min : float
        Input angle of the minimum [rad].
    """

    key: str
    label: str
    q: np.ndarray
    mu: np.ndarray
    min_deg: float
    max_deg: float
    q_at_min: float


class Analysis:
    """The revolution analysis of a mechanism and its drive (no simulation).

    Attributes
    ----------
    data : dict
        What ``analysis.json`` holds: reduced-model ranges, velocity ratios, transmission angles
        (``transmission``: by stable key, the joint's name; ``transmission_angles_deg``: by
        display label), toggles and limit positions (``flags``), per speed the input torque,
        motor torque, current and voltage (without a drive: the input torque only);
        ``plausibility["model"]``: the reduced model against MuJoCo's.
    scenario : Scenario or None
        The scenario analysed (None for a mechanism or machine built in code).
    """

    def __init__(self, scenario: Scenario | None, data: dict[str, Any]) -> None:
        self.scenario, self.data = scenario, data

    @property
    def applicable(self) -> bool:
        """False for mechanisms a constant-speed revolution does not describe (``data["reason"]``)."""
        return bool(self.data.get("applicable"))

    @property
    def curves(self) -> dict[str, np.ndarray]:
        """Curves over the revolution, each shape (points,): ``q`` [rad], ``J`` [kg·m²], ``dJ``,
        ``dEp``, ``Ep``, ``ratio:JOINT``, ``mu:JOINT`` [rad], per speed ``T_in@W``, ``T_m@W`` [N·m],
        ``I@W`` [A], ``V@W`` [V]."""
        return {k: np.asarray(v, float) for k, v in (self.data.get("curves") or {}).items()}

    @property
    def transmission(self) -> dict[str, TransmissionAngle]:
        """The transmission angles by stable key (the joint's name, e.g. ``an.transmission["C"]``);
        each has its display ``label``, the curve ``mu`` [rad] over ``q`` and its range [deg]."""
        c = self.curves
        out: dict[str, TransmissionAngle] = {}
        for key, v in (self.data.get("transmission") or {}).items():
            out[key] = TransmissionAngle(key, str(v["label"]), c["q"], c[v["curve"]], float(v["min_deg"]),
                                         float(v["max_deg"]), float(v["q_at_min_rad"]))
        return out

    @property
    def warnings(self) -> list[str]:
        """The reduced model's disagreement with MuJoCo's, if any."""

        m = (self.data.get("plausibility") or {}).get("model")
        return [w.replace("metrics.json", "analysis.json") for w in model_warnings(m)] if m else []

    def to_pandas(self) -> pandas.DataFrame:
        """:attr:`curves` as a DataFrame, one row per angle."""
        return require_pandas().DataFrame(self.curves)

    def summary(self) -> str:
        """The text ``mjbench analyze`` prints."""

        lines = [A.summary_text(self.data)]
        m = (self.data.get("plausibility") or {}).get("model") or {}
        if m.get("applicable"):
            lines.append(f"  reduced model vs MuJoCo at {m['n_angles']} angles: J {m['J_rel_err']:.2g}, J' "
                         f"{m['dJ_rel_err']:.2g}, E_p' {m['dEp_rel_err']:.2g} (relative; tolerance {m['tolerance']:g})")
        return "\n".join(lines)

    def save(self, path: str | os.PathLike[str], *, force: bool = False, what: str = "save") -> Path:
        """Write ``analysis.json`` and the figures into the folder ``path``, whole or not at all
        (``mjbench analyze --out``)."""

        with staged_dir(path, force=force, what=what) as out:
            A.write(self.data, out)
        return Path(os.path.abspath(os.fspath(path)))


def analysis_size(points: int, nspeeds: int, what: str = "points") -> None:
    """Refuse an analysis larger than half the available memory (before computing)."""

    need, lim = points * POINT_BYTES * max(1, nspeeds), memory_limit()
    if need > lim:
        raise ParameterError(f"{what} {points:,}: the analysis would need about {need / 2 ** 20:,.0f} MiB, more "
                             f"than {lim / 2 ** 20:,.0f} MiB (half the available memory; MJBENCH_MAX_RECORD_MB "
                             f"overrides): use fewer points")


def input_speed(value: float | str, what: str = "speeds") -> float:
    """An input speed [rad/s] from a number (SI) or a string with a unit ("60 rpm")."""

    try:
        v = float(value) if not isinstance(value, str) or _is_number(value) else U.to_si(value, "angular_velocity")
    except U.UnitError as e:
        raise ParameterError(f"{what} {value!r}: {e}") from None
    if not (math.isfinite(v) and abs(v) <= 1e5):
        raise ParameterError(f"{what} {value!r}: must be a finite input speed up to 1e5 rad/s in magnitude")
    return float(v)


def _is_number(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True


def analyze_mechanism(target: Scenario | str | os.PathLike[str] | Mapping[str, Any] | Mechanism | Machine,
                      speeds: Iterable[float | str] | None = None, *, points: int = 720, mu_min_deg: float = 40.0,
                      check_model: bool = True, name: str | None = None,
                      options: Mapping[str, Any] | None = None) -> Analysis:
    """Analyse a mechanism over one input revolution (no simulation).

    Parameters
    ----------
    target : Scenario, str, path, dict, Mechanism or Machine
        A scenario (its mechanism and drive), a :class:`~mjbench.Machine` built in code (its
        mechanism and drive), or a mechanism alone (:func:`mjbench.make_mechanism`: the input
        torque only, no motor rows).
    speeds : iterable of float or str, optional
        Constant input speeds [rad/s] (``"60 rpm"`` accepted); default: the set-points of the
        scenario's modes (a machine: its controller's running speed; a mechanism: one turn per
        second).
    points : int
        Samples over the revolution (16 to 1 000 000).
    mu_min_deg : float
        Transmission angle [deg] flagged as poor.
    check_model : bool
        Compare the reduced model's J, J', E_p' with MuJoCo's at 24 angles.
    name : str, optional
        What the outputs call a mechanism or machine built in code (default: its type).
    options : mapping, optional
        A mechanism's or machine's ``[multibody]`` options for that comparison (a scenario has its
        own table).

    Returns
    -------
    Analysis
        ``data`` (analysis.json), ``curves`` (arrays), ``transmission`` (by stable key),
        ``summary()``, ``to_pandas()``, ``save(dir)``.
    """

    if not 16 <= int(points) <= 1_000_000:
        raise ParameterError(f"points = {points}: must be 16 to 1,000,000")
    if not 0.0 <= float(mu_min_deg) <= 90.0:
        raise ParameterError(f"mu_min_deg = {mu_min_deg}: must be 0 to 90 [deg]")
    ws = [input_speed(v) for v in (speeds or ())]
    analysis_size(int(points), len(ws))
    if isinstance(target, (Mechanism, Machine)):

        mech = target.mechanism if isinstance(target, Machine) else target
        drive = target.drive if isinstance(target, Machine) else None
        label = name or ("machine built in code" if isinstance(target, Machine) else "mechanism built in code")
        res = A.analyze_parts(mech, drive, label, ws or (lambda: _default_speeds(target)), n=int(points),
                              mu_min_deg=float(mu_min_deg))
        res["built_in_code"] = True
        opts = machine_options(MACHINE_DT, {"multibody": options or {}})["multibody"]
        scn: Scenario | None = None
    else:
        if options is not None:
            raise ParameterError("analyze_mechanism: options are a mechanism's or machine's; a scenario has its "
                                 "[multibody] table")
        scn = as_scenario(target)
        mech = S.make_mechanism(scn.spec)
        res = A.analyze(scn.spec, ws or None, n=int(points), mu_min_deg=float(mu_min_deg))
        if name:
            res["scenario"] = name
        opts = scn.spec.multibody_options()
    if res.get("applicable") and check_model:

        # the reduced model against MuJoCo's mass matrix and bias forces (analysis.json "plausibility")
        res["plausibility"] = {"model": reduced_vs_mujoco(mech, opts)}
    out = Analysis(scn, res)
    warn(out.warnings)
    return out


def _default_speeds(target: Any) -> list[float]:
    """A machine's running speed (its controller's set-point), else one turn per second."""

    if isinstance(target, Machine):

        w = abs(float(running_speed(target, float(target.q0))))
        if math.isfinite(w) and w > 0:
            return [w]
    return [2.0 * math.pi]
