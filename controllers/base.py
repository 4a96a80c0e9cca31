"""The controller protocol, as controllers see it: :mod:`mjbench.control` (the component interface).

Kept as this package's name for it: ``from controllers.base import Controller, Measurement``.
"""
from __future__ import annotations

from mjbench.control import Controller, Measurement, controller_form, reference_form

__all__ = ["Controller", "Measurement", "controller_form", "reference_form"]
