"""The calibration's result as a table of the fitted values against the a-priori ones."""
from __future__ import annotations

import numpy as np


UNITS = {"a": "m", "b": "m", "c": "m", "h_x": "m", "f1": "m", "f2": "m", "f3": "m",
         "m1": "kg", "m2": "kg", "m3": "kg", "R": "Ω"}


def table(res):
    """Plain-text report: distinct solutions, residuals, Jacobian rank."""
    names = res["params"]
    lines = [f"calibration of {res['scenario']}: params {','.join(names)}, {res['starts']} starts, "
             f"search dt = {res['dt_search_s'] * 1e3:g} ms; converged (all |r| <= {res['accept_max_abs_residual']}): "
             f"{res['n_converged']}/{len(res['solutions'])}, distinct: {len(res['distinct'])}"]
    hdr = ["start"] + names + ["chi_open", "chi_pid", "w_mean", "max|r|", "nfev", "d_prior"]
    lines.append(" ".join(f"{h:>8}" for h in hdr))
    for s in sorted(res["solutions"], key=lambda s: s["cost"]):
        m = s["measured"] or {}
        row = [f"{s['start']:>8d}"] + [f"{s['values'][n]:8.4g}" for n in names]
        row += [f"{m.get('chi_open', float('nan')):8.4f}", f"{m.get('chi_pid_window', float('nan')):8.4f}",
                f"{m.get('mean_speed_open', float('nan')):8.3f}", f"{s['max_abs_residual']:8.3g}",
                f"{s['nfev']:8d}"]
        row += [f"{s.get('distance_to_prior', float('nan')):8.3f}"]
        lines.append(" ".join(row) + ("" if s["converged"] else "  (not converged)")
                     + ("  <- chosen" if s["start"] == res.get("chosen_start") else ""))
    sen = res.get("sensitivity") or {}
    if sen:
        lines.append(f"Jacobian at the best solution: rank {sen['rank']} of {sen['n_params']} parameters, "
                     f"singular values {np.round(sen['singular_values'], 3).tolist()}")
    r = res["result"]
    how = "polished at" if "polished" in res else "not polished, search"
    lines.append(f"result (start {r.get('start')}, rule '{res.get('select')}', {how} dt = "
                 f"{1e3 * r.get('dt_s', res['dt_search_s']):g} ms): "
                 + ", ".join(f"{n} = {r['values'][n]:.5g} {UNITS[n]}" for n in names))
    m = r["measured"] or {}
    lines.append(f"  χ open = {100 * m.get('chi_open', float('nan')):.2f} % (paper 54.3), χ PID window = "
                 f"{100 * m.get('chi_pid_window', float('nan')):.2f} % (paper 2.6), mean speed = "
                 f"{m.get('mean_speed_open', float('nan')):.2f} rad/s (Fig. 4a ≈ 30); residuals "
                 f"{np.round(r['residuals'], 3).tolist()} (units of the tolerances)")
    v = res.get("verification") or {}
    if "multibody" in v:
        lines.append(f"  verification at dt = {1e3 * v['dt_s']:g} ms (search on the {res.get('search_backend')} "
                     f"backend): reduced → multibody")
        for k, unit in (("chi_open", "%"), ("chi_pid_window", "%"), ("mean_speed_open", "rad/s")):
            f = 100.0 if unit == "%" else 1.0
            lines.append(f"    {k:<16s} {f * v['reduced'][k]:9.4f} → {f * v['multibody'][k]:9.4f} {unit}  "
                         f"(difference {f * v['difference'][k]:+.3g} {unit}, {100 * v['relative'][k]:+.3g} % relative)")
    elif v.get("error"):
        lines.append(f"  verification on the multibody backend failed: {v['error']}")
    if "seconds" in res:
        lines.append(f"  {res['seconds']:.1f} s (search {res.get('seconds_search', 0):.1f} s)")
    return "\n".join(lines)
