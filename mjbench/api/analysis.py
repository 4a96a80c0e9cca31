"""Analyses without a long simulation: the linear model, loop and margins (:func:`linearize`,
python-control objects) and the revolution analysis of a mechanism (:func:`analyze_mechanism`)."""
from __future__ import annotations

import math
import os
from collections.abc import Iterable, Mapping
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from ..errors import ParameterError, SimulationDiverged
from .results import require_pandas
from .scenarios import Scenario, as_scenario, warn

if TYPE_CHECKING:
    import pandas

#: bytes of one analysis sample per speed (measured ≈ 1.3 kB per point, press-slidercrank; ×3 margin)
POINT_BYTES = 4096


# ====================================================================== linearize
class LinearResult:
    """The machine's linear model at an operating point, its loop, margins and the frozen-angle
    family (python-control objects).

    Attributes
    ----------
    data : dict
        What ``linear.json`` holds: operating point, matrices, modes, agreement of the reduced and
        multibody linearisations, loop margins, frozen-angle margins and validity, K_p·t limit.
    objects : dict
        Every python-control object computed (``plant_reduced``, ``plant_multibody``, ``loop``,
        ``margins``, ``family``, ``op`` ...).
    scenario : Scenario
    """

    def __init__(self, scenario: Scenario, data: dict[str, Any], objects: dict[str, Any]) -> None:
        self.scenario, self.data, self.objects = scenario, data, objects

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

    def summary(self) -> str:
        """The text ``mjbench linearize`` prints."""
        return linear_summary(self.data)

    def save(self, path: str | os.PathLike[str], *, force: bool = False, what: str = "save") -> Path:
        """Write ``linear.json`` and the figures (bode.png, nyquist.png, poles.png, plant.png) into
        the folder ``path``, whole or not at all (``mjbench linearize --out``)."""
        from .. import linear_plots as LP
        from .. import plotstyle
        from ..outputs import staged_dir, write_json

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
        holding q̈ = 0, ``simulation.t_end`` for a K_p·t PID (else 0).
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
    from .. import linear as LN

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


def linear_summary(js: dict[str, Any]) -> str:
    """Text summary of a linear.json."""
    def f(v: Any, fmt: str = "{:.4g}") -> str:
        return "—" if v is None or v != v else ("∞" if v in (float("inf"), float("-inf")) else fmt.format(v))

    op = js["operating_point"]
    lines = [f"{js['scenario']} (mode {js['mode']}, {js['controller']}): q* = {f(op['q_rad'])} rad, "
             f"q̇* = {f(op['qd_rad_s'])} rad/s, I* = {f(op['I_A'])} A, V* = {f(op['V_V'])} V"
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
class Analysis:
    """The revolution analysis of a mechanism and its drive (no simulation).

    Attributes
    ----------
    data : dict
        What ``analysis.json`` holds: reduced-model ranges, velocity ratios, transmission angles,
        toggles and limit positions (``flags``), per speed the input torque, motor torque,
        current and voltage; ``plausibility["model"]``: the reduced model against MuJoCo's.
    scenario : Scenario
    """

    def __init__(self, scenario: Scenario, data: dict[str, Any]) -> None:
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
    def warnings(self) -> list[str]:
        """The reduced model's disagreement with MuJoCo's, if any."""
        from ..plausibility import model_warnings

        m = (self.data.get("plausibility") or {}).get("model")
        return [w.replace("metrics.json", "analysis.json") for w in model_warnings(m)] if m else []

    def to_pandas(self) -> pandas.DataFrame:
        """:attr:`curves` as a DataFrame, one row per angle."""
        return require_pandas().DataFrame(self.curves)

    def summary(self) -> str:
        """The text ``mjbench analyze`` prints."""
        from .. import analyze as A

        lines = [A.summary_text(self.data)]
        m = (self.data.get("plausibility") or {}).get("model") or {}
        if m.get("applicable"):
            lines.append(f"  reduced model vs MuJoCo at {m['n_angles']} angles: J {m['J_rel_err']:.2g}, J' "
                         f"{m['dJ_rel_err']:.2g}, E_p' {m['dEp_rel_err']:.2g} (relative; tolerance {m['tolerance']:g})")
        return "\n".join(lines)

    def save(self, path: str | os.PathLike[str], *, force: bool = False, what: str = "save") -> Path:
        """Write ``analysis.json`` and the figures into the folder ``path``, whole or not at all
        (``mjbench analyze --out``)."""
        from .. import analyze as A
        from ..outputs import staged_dir

        with staged_dir(path, force=force, what=what) as out:
            A.write(self.data, out)
        return Path(os.path.abspath(os.fspath(path)))


def analysis_size(points: int, nspeeds: int, what: str = "points") -> None:
    """Refuse an analysis larger than half the available memory (before computing)."""
    from ..kernel import memory_limit

    need, lim = points * POINT_BYTES * max(1, nspeeds), memory_limit()
    if need > lim:
        raise ParameterError(f"{what} {points:,}: the analysis would need about {need / 2 ** 20:,.0f} MiB, more "
                             f"than {lim / 2 ** 20:,.0f} MiB (half the available memory; MJBENCH_MAX_RECORD_MB "
                             f"overrides): use fewer points")


def input_speed(value: float | str, what: str = "speeds") -> float:
    """An input speed [rad/s] from a number (SI) or a string with a unit ("60 rpm")."""
    from .. import units as U

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


def analyze_mechanism(scenario: Scenario | str | os.PathLike[str] | Mapping[str, Any],
                      speeds: Iterable[float | str] | None = None, *, points: int = 720, mu_min_deg: float = 40.0,
                      check_model: bool = True) -> Analysis:
    """Analyse a scenario's mechanism over one input revolution (no simulation).

    Parameters
    ----------
    scenario : Scenario, str, path or dict
    speeds : iterable of float or str, optional
        Constant input speeds [rad/s] (``"60 rpm"`` accepted); default: the set-points of the
        scenario's modes.
    points : int
        Samples over the revolution (16 to 1 000 000).
    mu_min_deg : float
        Transmission angle [deg] flagged as poor.
    check_model : bool
        Compare the reduced model's J, J', E_p' with MuJoCo's at 24 angles.

    Returns
    -------
    Analysis
        ``data`` (analysis.json), ``curves`` (arrays), ``summary()``, ``to_pandas()``, ``save(dir)``.
    """
    from .. import analyze as A
    from .. import scenario as S

    if not 16 <= int(points) <= 1_000_000:
        raise ParameterError(f"points = {points}: must be 16 to 1,000,000")
    if not 0.0 <= float(mu_min_deg) <= 90.0:
        raise ParameterError(f"mu_min_deg = {mu_min_deg}: must be 0 to 90 [deg]")
    ws = [input_speed(v) for v in (speeds or ())]
    analysis_size(int(points), len(ws))
    scn = as_scenario(scenario)
    res = A.analyze(scn.spec, ws or None, n=int(points), mu_min_deg=float(mu_min_deg))
    if res.get("applicable") and check_model:
        from ..plausibility import reduced_vs_mujoco

        # the reduced model against MuJoCo's mass matrix and bias forces (analysis.json "plausibility")
        res["plausibility"] = {"model": reduced_vs_mujoco(S.make_mechanism(scn.spec), scn.spec.multibody_options())}
    out = Analysis(scn, res)
    warn(out.warnings)
    return out
