"""Verdicts: how a number we computed compares with what a paper states — always computed from
the two numbers, never typed in.

A paper states a figure in one of four ways (``compare``):

* ``"value"``: a point value v_p.  Ours *agrees* when |ours − v_p| ≤ ``tolerance``·|v_p|
  (relative, default :data:`TOLERANCE` = 5 %), else it *differs* by the signed relative amount
  (or, beyond a factor 2, by the ratio);
* ``"band"``: a range [lo, hi] ("the speed varies between 6.1 and 6.4 rad/s").  Ours is *inside*,
  *below* (by lo − ours) or *above* (by ours − hi);
* ``"max"``: an upper bound ("under 0.1 rad/s", "maximum deviation 0.01 m/s").  Ours *meets* it
  when ours ≤ bound, else *exceeds* it by ours − bound;
* ``"min"``: a lower bound, the mirror image (*meets* / *falls short*).

A row may hold several of our numbers (one per backend, e.g. ``{"multibody": x, "reduced": y}``):
each is judged; when they give the same status the verdict is that of the number farthest from
the paper, when they do not the verdict is ``"backends disagree"`` and lists each one.  A row
without a paper figure is ``"no paper value"``; a row whose number is missing or not finite is
``"not computed"``.  ``fitted = true`` marks a figure our parameters were fitted to (agreement by
construction, not a prediction): the verdict says so and the report counts it apart.

Everything here is plain functions on plain dicts (the report's rows, ``[[paper.figures]]``
entries), so that ``mjbench run`` (metrics.json) and ``mjbench reproduce`` (report) give the
same verdict for the same numbers.
"""
from __future__ import annotations

import math

import numpy as np

TOLERANCE = 0.05  #: relative tolerance of a point value (|ours − paper| ≤ 5 % of |paper|)
COMPARES = ("value", "band", "max", "min")
OK_STATUSES = ("agrees", "inside", "meets")  #: statuses that count as meeting the paper


def _num(x) -> bool:
    return isinstance(x, (int, float, np.integer, np.floating)) and not isinstance(x, bool)


def fmt(v) -> str:
    """A number as every table of the report prints it (4 significant digits)."""
    if v is None:
        return "—"
    if isinstance(v, bool):
        return str(v)
    if _num(v):
        v = float(v)
        if math.isnan(v):
            return "nan"
        return f"{v:.4g}"
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(fmt(x) for x in v) + "]"
    return str(v)


def _u(unit: str) -> str:
    """Unit suffix of a number in a sentence ('' for dimensionless)."""
    if not unit or unit == "1":
        return ""
    return unit if unit == "%" else " " + unit


def expectation(paper, compare=None) -> tuple:
    """(compare, paper) normalised: a 2-list/tuple is a band, a number a value (or the bound
    named by ``compare``), None no paper figure.  Raises ValueError on anything else."""
    if paper is None:
        return None, None
    if isinstance(paper, (list, tuple)):
        if len(paper) != 2 or not all(_num(x) for x in paper):
            raise ValueError(f"a paper band must be two numbers [lo, hi], got {paper!r}")
        lo, hi = float(paper[0]), float(paper[1])
        if not lo <= hi:
            raise ValueError(f"a paper band [lo, hi] needs lo <= hi, got {paper!r}")
        if compare not in (None, "band"):
            raise ValueError(f"compare = {compare!r} with a band {paper!r}")
        return "band", [lo, hi]
    if not _num(paper):
        raise ValueError(f"a paper figure must be a number, a band [lo, hi] or None, got {paper!r}")
    compare = compare or "value"
    if compare not in COMPARES or compare == "band":
        raise ValueError(f"compare = {compare!r}: choose value, max or min for a number (a band is [lo, hi])")
    return compare, float(paper)


def paper_text(paper, compare=None, fitted=False) -> str:
    """How the paper column shows the figure: '6.25', '6.1–6.4', '≤ 0.01', '≥ 3'."""
    compare, paper = expectation(paper, compare)
    if compare is None:
        return "—"
    if compare == "band":
        txt = f"{fmt(paper[0])}–{fmt(paper[1])}"
    elif compare == "max":
        txt = f"≤ {fmt(paper)}"
    elif compare == "min":
        txt = f"≥ {fmt(paper)}"
    else:
        txt = fmt(paper)
    return txt + (" (fitted)" if fitted else "")


def _judge_value(v, paper, tolerance, u):
    d = v - paper
    r = d / abs(paper) if paper else None
    ok = abs(r) <= tolerance * (1 + 1e-12) if r is not None else d == 0.0  # the edge counts (rounding)
    tol = "" if tolerance == TOLERANCE else f" (tolerance ±{100 * tolerance:g} %)"
    if ok:
        status, text = "agrees", (f"agrees: {100 * r:+.1f} %{tol}" if r is not None else "agrees: equal")
    else:
        status = "differs"
        if r is None:
            text = f"differs: ours − paper = {fmt(d)}{u}"
        elif abs(r) > 1.0:
            text = f"differs: ours is {v / paper:.3g}× the paper's value{tol}"
        else:
            text = f"differs: {100 * r:+.1f} %, ours {'higher' if d > 0 else 'lower'}{tol}"
    return {"status": status, "ok": ok, "text": text, "distance": 0.0 if ok else abs(d), "signed": d, "relative": r}


def _amount(r, amount, u):
    """'1.4 % (0.000137 m/s)': a distance to a bound or band edge, relative first."""
    return f"{fmt(amount)}{u}" if r is None else f"{100 * abs(r):.3g} % ({fmt(amount)}{u})"


def _judge_band(v, lo, hi, u):
    if v < lo:
        d = v - lo
        r = d / abs(lo) if lo else None
        return {"status": "below", "ok": False, "distance": -d, "signed": d, "relative": r,
                "text": f"below the band by {fmt(-d)}{u}" + ("" if r is None else f" ({100 * abs(r):.3g} % of its lower edge)")}
    if v > hi:
        d = v - hi
        r = d / abs(hi) if hi else None
        return {"status": "above", "ok": False, "distance": d, "signed": d, "relative": r,
                "text": f"above the band by {fmt(d)}{u}" + ("" if r is None else f" ({100 * abs(r):.3g} % of its upper edge)")}
    return {"status": "inside", "ok": True, "distance": 0.0, "signed": 0.0, "relative": 0.0,
            "text": f"inside the band ({fmt(v - lo)}{u} above its lower edge, {fmt(hi - v)}{u} below its upper)"}


def _judge_bound(v, bound, compare, u):
    d = v - bound
    r = d / abs(bound) if bound else None
    if compare == "max":
        if v <= bound:
            return {"status": "meets", "ok": True, "distance": 0.0, "signed": d, "relative": r,
                    "text": f"meets the upper bound: {_amount(r, -d, u)} below it"}
        return {"status": "exceeds", "ok": False, "distance": d, "signed": d, "relative": r,
                "text": f"exceeds the upper bound by {_amount(r, d, u)}"}
    if v >= bound:
        return {"status": "meets", "ok": True, "distance": 0.0, "signed": d, "relative": r,
                "text": f"meets the lower bound: {_amount(r, d, u)} above it"}
    return {"status": "falls short", "ok": False, "distance": -d, "signed": d, "relative": r,
            "text": f"falls short of the lower bound by {_amount(r, -d, u)}"}


def judge(value, paper, compare=None, tolerance=TOLERANCE, unit="") -> dict:
    """Verdict of one number against the paper's figure.

    Returns {"status", "ok" (True / False / None when there is nothing to judge), "text",
    "distance" (≥ 0: how far outside the tolerance, band or bound; 0 when met), "signed" (ours −
    paper for a value or a bound; ours − the nearest band edge, negative below), "relative"
    (signed / |reference|, None when the reference is 0)}."""
    compare, paper = expectation(paper, compare)
    if compare is None:
        return {"status": "no paper value", "ok": None, "text": "no paper value (ours for reference)",
                "distance": None, "signed": None, "relative": None}
    if value is None or not _num(value) or not math.isfinite(float(value)):
        return {"status": "not computed", "ok": None, "text": "not computed (no finite number of ours)",
                "distance": None, "signed": None, "relative": None}
    v, u = float(value), _u(unit)
    if compare == "value":
        return _judge_value(v, paper, TOLERANCE if tolerance is None else float(tolerance), u)
    if compare == "band":
        return _judge_band(v, paper[0], paper[1], u)
    return _judge_bound(v, paper, compare, u)


def judge_row(ours: dict, paper, compare=None, tolerance=TOLERANCE, unit="", fitted=False) -> dict:
    """Verdict of a row holding several numbers of ours ({label: number}); see the module doc.
    The result also lists each number's status under "by"."""
    per = {k: judge(v, paper, compare, tolerance, unit) for k, v in (ours or {}).items()}
    judged = {k: j for k, j in per.items() if j["ok"] is not None}
    if not judged:
        out = dict(next(iter(per.values()))) if per else judge(None, paper, compare, tolerance, unit)
    elif len({j["status"] for j in judged.values()}) == 1:
        key = max(judged, key=lambda k: (judged[k]["distance"], abs(judged[k]["signed"] or 0.0)))
        out = dict(judged[key])
        if len(judged) > 1:
            out["worst"] = key
    else:
        out = {"status": "backends disagree", "ok": False, "distance": max(j["distance"] for j in judged.values()),
               "signed": None, "relative": None,
               "text": "ours disagree: " + "; ".join(f"{k}: {j['text']}" for k, j in judged.items())}
    if fitted and out["ok"] is not None:
        out["text"] += " — FITTED to this figure: agreement by construction, not a prediction"
        out["fitted"] = True
    out["by"] = {k: j["status"] for k, j in per.items()}
    return out


def finish_row(row: dict) -> dict:
    """Add to a report row ({"name", "unit", "paper", "compare"?, "tolerance"?, "fitted"?,
    "ours": {label: number}, "reason"}) its "paper_text", "verdict" and, for a point value, the
    "difference" (first finite number of ours − paper) and "rel_difference"."""
    compare, paper = expectation(row.get("paper"), row.get("compare"))
    row["paper"], row["compare"] = paper, compare
    tol = row.get("tolerance")
    row["tolerance"] = TOLERANCE if tol is None else float(tol)
    fitted = bool(row.get("fitted", False))
    row["fitted"] = fitted
    row["paper_text"] = paper_text(paper, compare, fitted)
    row["verdict"] = judge_row(row.get("ours") or {}, paper, compare, row["tolerance"], row.get("unit", ""), fitted)
    first = next((float(v) for v in (row.get("ours") or {}).values() if _num(v) and math.isfinite(float(v))), None)
    if compare == "value" and first is not None:
        row["difference"] = first - paper
        row["rel_difference"] = row["difference"] / abs(paper) if paper else None
    else:
        row["difference"] = row["rel_difference"] = None
    return row


def counts(rows) -> dict:
    """Tally of a case's verdicts: meet (met, not fitted), fitted (met, fitted), differ (not met),
    unjudged (no paper value / not computed)."""
    c = {"meet": 0, "fitted": 0, "differ": 0, "unjudged": 0}
    for r in rows:
        v = r.get("verdict") or {}
        if v.get("ok") is None:
            c["unjudged"] += 1
        elif v["ok"]:
            c["fitted" if v.get("fitted") else "meet"] += 1
        else:
            c["differ"] += 1
    return c


def from_figure(fig: dict) -> dict:
    """The expectation of a scenario's ``[[paper.figures]]`` entry: exactly one of ``value``,
    ``band = [lo, hi]``, ``max`` (upper bound), ``min`` (lower bound); optional ``tolerance``
    (relative, point values), ``fitted``, ``unit`` ("%": the metric is a fraction shown in
    percent, the paper's figure is given in percent)."""
    given = [k for k in COMPARES if fig.get(k) is not None]
    name = fig.get("name", "?")
    if len(given) != 1:
        raise ValueError(f"[[paper.figures]] {name!r}: give exactly one of value, band, max, min (got {given or 'none'})")
    k = given[0]
    compare, paper = expectation(fig[k], None if k == "band" else k)
    return {"paper": paper, "compare": compare, "tolerance": fig.get("tolerance"),
            "fitted": bool(fig.get("fitted", False)), "unit": fig.get("unit", "")}
