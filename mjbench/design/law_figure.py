"""The figure of a motion-law design (reference and crank angle, tracking error, current, gearbox torque
over one cycle: predicted and simulated), drawn by the report (:mod:`.report`)."""
from __future__ import annotations

import math

import numpy as np
from .. import plotstyle as ps
from ..plots import save
from .. import scenario as SC

TWO_PI = 2.0 * math.pi


def _cycle(tr, a, b):
    return (tr.t >= a - 1e-9) & (tr.t <= b + 1e-9)


def figure(res, path):
    """Reference and crank angle, tracking error, motor current and gearbox torque over one cycle:
    predicted (harmonic balance) and simulated (multibody, last cycle)."""

    ch = res.get("_final")
    tr = (res.get("_trajectories") or {}).get("multibody")
    with ps.context():
        fig, ax = ps.new(2, 2, figsize=(11, 8))
        if ch is not None and ch.ss is not None:
            ss = ch.ss
            tau = ss["tau"]
            ax[0][0].plot(tau, np.degrees(ss["q_ref"]), color="0.5", label="reference (the law)")
            ax[0][0].plot(tau, np.degrees(ss["q"]), color="C0", label="predicted")
            ax[0][1].plot(tau, np.degrees(ss["delta"]), color="C0", label="predicted (harmonic balance)")
            ax[1][0].plot(tau, ss["I"], color="C0", label="predicted (harmonic balance)")
            ax[1][1].plot(tau, ss["T_gear"], color="C0", label="predicted (harmonic balance)")
            ver = res.get("verification", {}).get("achieved", {})
            if tr is not None and ver:
                a, b = ver["cycle_s"]
                sel = _cycle(tr, a, b)
                ts = tr.t[sel] - a
                z = float(ch.drive.z)

                ref = SC.make_machine(SC.from_raw(res["machine"], "design")).controller.reference
                e = tr.q[sel] - ref.reference_angle(tr.t[sel]) / z
                k0 = np.floor(tr.q[sel][0] / TWO_PI + 0.5) * TWO_PI
                ax[0][0].plot(ts, np.degrees(tr.q[sel] - k0), "--", color="C1", label="multibody")
                ax[0][1].plot(ts, np.degrees(e), "--", color="C1", label="multibody")
                ax[1][0].plot(ts, tr.current[sel], "--", color="C1", label="multibody")
                ax[1][1].plot(ts, ch.drive.gear_output_of_run(tr.current[sel], tr.omega[sel], tr.qdd[sel]), "--", color="C1",
                              label="multibody")
        for a2, lab in ((ax[0][0], ps.label("crank angle", "°")), (ax[0][1], ps.label("tracking error q − q_ref", "°")),
                        (ax[1][0], ps.label("motor current", "A")), (ax[1][1], ps.label("gearbox output torque", "N·m"))):
            a2.set_xlabel(ps.label("time in the cycle", "s"))
            a2.set_ylabel(lab)
            if a2.get_legend_handles_labels()[0]:  # (no candidate chosen: empty panels, no legend)
                a2.legend(loc="best", fontsize=7)
        ps.finish(fig, f"mjbench design {res['name']} (motion law per cycle): {res['status']}")
        return save(fig, path)
