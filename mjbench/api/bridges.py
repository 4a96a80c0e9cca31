"""Bridges from Python: the measured frequency response of the running nonlinear machine
(:func:`frequency_response`) and FMI export (:func:`export_fmu`)."""
from __future__ import annotations

import math
import os
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

from ..errors import ParameterError
from .scenarios import Scenario, as_scenario
from .. import frest as F
from .analysis import number_text as f
from ..fmi import export_fmu as export
from ..outputs import output_file
from ..outputs import staged_dir, write_json


class FrequencyResponse:
    """The plant q̇/V and the loop L at the plant input measured on the nonlinear machine, with
    coherence, margins read from the measured loop and the linearisation overlaid.

    Attributes
    ----------
    data : dict
        What ``frest.json`` holds.
    frd : dict
        python-control ``FrequencyResponseData``: ``plant``, ``S``, ``loop`` (closed loops).
    omega : numpy.ndarray, shape (lines,)
        The excited frequencies [rad/s].
    """

    def __init__(self, scenario: Scenario, backend: str, raw: dict[str, Any]) -> None:
        self.scenario, self.backend, self.raw = scenario, backend, raw
        self.data: dict[str, Any] = raw["json"]
        self.frd: dict[str, Any] = raw["frd"]
        self.omega: Any = raw["omega"]

    def summary(self) -> str:
        """The text ``mjbench frest`` prints."""
        return frest_summary(self.data)

    def save(self, path: str | os.PathLike[str], *, force: bool = False, what: str = "save") -> Path:
        """Write ``frest.json`` and ``bode.png`` into the folder ``path``, whole or not at all."""

        with staged_dir(path, force=force, what=what) as out:
            write_json(os.path.join(out, "frest.json"), self.data, indent=1)
            F.figure(self.raw, os.path.join(out, "bode.png"), f"{self.scenario.name} ({self.data['mode']}, "
                                                               f"{self.backend})")
        return Path(os.path.abspath(os.fspath(path)))


def frequency_response(scenario: Scenario | str | os.PathLike[str] | Mapping[str, Any], mode: str | None = None, *,
                       q: float | None = None, qd: float | None = None, I: float | None = None,
                       t: float | None = None, backend: str = "reduced", signal: str = "multisine",
                       amplitude: float | None = None, band: Sequence[float] | None = None, lines: int = 30,
                       periods: int = 3, period: float | None = None, settle: float | None = None) -> FrequencyResponse:
    """Measure the frequency response of a scenario's running machine (docs/bridges.md).

    Parameters
    ----------
    scenario : Scenario, str, path or dict
    mode : str, optional
        The controller's mode (default: the scenario's).
    q, qd, I, t : float, optional
        Operating point (input angle [rad], speed [rad/s], current [A], time [s] of a K_p·t gain);
        default: the initial angle at the controller's running speed.
    backend : {"reduced", "multibody"}
    signal : {"multisine", "sine"}
        One multisine run, or one run per frequency.
    amplitude : float, optional
        Excitation peak [V] (default: 2 % of the operating voltage, within the limiter's headroom).
    band : (float, float), optional
        Frequency band [rad/s].
    lines, periods, period, settle
        Excited frequencies, measured periods (>= 2), multisine period [s], settling time [s].

    Returns
    -------
    FrequencyResponse
        ``frd`` (python-control FRD objects), ``data`` (frest.json), ``summary()``, ``save(dir)``.
    """

    if band is not None:
        try:
            lo, hi = (float(x) for x in band)
        except (TypeError, ValueError):
            raise ParameterError(f"band = {band!r}: expected (lo, hi) [rad/s]") from None
        if not (0 < lo < hi and math.isfinite(hi)):
            raise ParameterError(f"band = {tuple(band)!r}: need 0 < lo < hi [rad/s]")
        band = (lo, hi)
    F.check_options(amplitude, band, period, periods, settle, lines)  # every value, before any work
    at = {k: v for k, v in (("q", q), ("qd", qd), ("I", I), ("t", t)) if v is not None}
    scn = as_scenario(scenario)
    mode = scn.mode(mode)
    scn.check(mode)
    res = F.measure(scn.spec, mode, backend=backend, signal=signal, amplitude=amplitude, band=band, period=period,
                    periods=periods, settle=settle, n_lines=lines, **at)
    return FrequencyResponse(scn, backend, res)


def frest_summary(js: dict[str, Any]) -> str:
    """Text summary of a frest.json."""

    op = js["operating_point"]
    lines = [f"{js['scenario']} (mode {js['mode']}, {js['backend']}, {js['signal']}): q* = {f(op['q_rad'])} rad, "
             f"q̇* = {f(op['qd_rad_s'])} rad/s, V* = {f(op['V_V'])} V; amplitude {f(js['amplitude_V'])} V, "
             f"{len(js['lines_rad_s'])} lines {f(js['lines_rad_s'][0])}-{f(js['lines_rad_s'][-1])} rad/s"]
    c = js.get("comparison", {})
    for k in ("plant", "loop"):
        if k in c and c[k]["max_rel_diff"] is not None:
            lines.append(f"  {k} vs linearisation over {f(js['band_rad_s'][0])}-{f(js['band_rad_s'][1])} rad/s: "
                         f"max rel {f(c[k]['max_rel_diff'], '{:.2e}')}, |mag| {f(100 * c[k]['max_mag_diff'], '{:.3g}')} %, "
                         f"phase {f(c[k]['max_phase_diff_deg'], '{:.3g}')}°")
    for k in ("plant", "loop"):  # a running linkage: against the frozen-angle family followed along the turn
        x = c.get(f"{k}_vs_family_along_turn")
        if x and x["max_rel_diff"] is not None:
            lines.append(f"  {k} vs the frozen-angle family along the turn: max rel {f(x['max_rel_diff'], '{:.2e}')}, "
                         f"|mag| {f(100 * x['max_mag_diff'], '{:.3g}')} %, phase {f(x['max_phase_diff_deg'], '{:.3g}')}°")
    sb = (js.get("frozen_family") or {}).get("sidebands")
    if sb:
        lines.append(f"  rotation sidebands ω ± Ω of the speed response: up to {f(100 * sb['speed_measured_max_rel'], '{:.3g}')} % "
                     f"of the line (frozen family along the turn: {f(100 * sb['speed_frozen_max_rel'], '{:.3g}')} %)")
    sat = js.get("saturation") or {}
    if sat.get("saturated"):
        lines.insert(1, f"  SATURATED: {sat['note']}")
    lp = js.get("loop")
    if lp:
        m, ml = lp["margins"], lp.get("margins_linear") or {}
        lines.append(f"  measured loop{' (NOT VALID: saturated)' if sat.get('saturated') else ''}: "
                     f"GM {f(m['gain_margin_dB'])} dB, PM {f(m['phase_margin_deg'])}°, peak |S| "
                     f"{f(m['peak_sensitivity'])}" + (f" (linear: {f(ml.get('gain_margin_dB'))} dB, "
                                                       f"{f(ml.get('phase_margin_deg'))}°, {f(ml.get('peak_sensitivity'))})"
                                                       if ml else ""))
    lines.append(f"  min coherence {f(min(js['plant']['coherence']), '{:.4f}')}, distortion ratio "
                 f"{f(js['distortion_ratio'], '{:.2e}')}; {js['band_note']}")
    st = js.get("settling")
    if st and st.get("settled"):
        lines.append(f"  settling: {st['note']}")  # (not settled: among the warnings below)
    for n in js.get("notes", []):
        lines.append(f"  {n}" if n.startswith("warning: ") else f"  note: {n}")
    return "\n".join(lines)


def export_fmu(scenario: Scenario | str | os.PathLike[str] | Mapping[str, Any], path: str | os.PathLike[str], *,
               controller: str | None = None, input: str = "voltage", backend: str = "multibody",
               force: bool = False, what: str = "path") -> Path:
    """Write an FMI 2.0 co-simulation FMU of the scenario's plant, or of a mode's controller.

    Parameters
    ----------
    scenario : Scenario, str, path or dict
    path : str or path
        The ``.fmu`` file (written under a temporary name, then renamed).
    controller : str, optional
        Export the controller of this mode (inputs q, q̇, q̈, I; output u) instead of the plant.
    input : {"voltage", "torque"}
        The plant's input: armature voltage [V] or motor torque [N·m].
    backend : {"multibody", "reduced"}
        The plant's mechanics.
    force : bool
        Replace an existing file.

    Returns
    -------
    pathlib.Path
        The FMU (needs ``pip install 'mjbench[fmi]'``; docs/bridges.md).
    """
    try:
        import pythonfmu  # noqa: F401
    except ImportError:
        raise ParameterError("export-fmu needs pythonfmu: pip install 'mjbench[fmi]' (or pip install pythonfmu)") from None

    scn = as_scenario(scenario)
    if controller:
        scn.mode(controller)  # an unknown mode: one error before any work
    with output_file(path, what, suffixes=(".fmu",)) as out:
        if out.exists() and not force:
            how = "--force" if what.startswith("--") else "force=True"
            raise ParameterError(f"{what} {os.fspath(path)} exists; use {how} to replace it")
        tmp = out.with_name(f".{out.stem}.tmp-{os.getpid()}.fmu")
        try:
            if controller:
                export(scn.spec, tmp, kind="controller", mode=controller)
            else:
                export(scn.spec, tmp, kind="plant", input=input, backend=backend)
            os.replace(tmp, out)
        finally:
            if tmp.exists():
                tmp.unlink()
    return Path(out)
