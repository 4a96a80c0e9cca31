"""Bridges to FMI tools (docs/bridges.md): export a scenario's plant or a mode's controller as an
FMI 2.0 co-simulation FMU (:func:`export_fmu`, pythonfmu) and run controller FMUs in the kernel
(``[modes.NAME] type = "fmu"``, ``controllers/fmu.py``, FMPy).

Heavy imports (pythonfmu, fmpy) happen inside the functions that need them."""
from __future__ import annotations
from .export import export_fmu as _export


def export_fmu(scn, out, **kw):
    """Write an FMU of ``scn`` (see :func:`mjbench.fmi.export.export_fmu`)."""

    return _export(scn, out, **kw)


__all__ = ["export_fmu"]
