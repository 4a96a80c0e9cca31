"""Motor-side references φ_ref(t), φ̇_ref(t), φ̈_ref(t) for speed controllers.

A reference is a *law* (:mod:`mjbench.compiled`) reading named signals (:mod:`mjbench.signals`) and
writing ``phi_ref``, ``om_ref``, ``acc_ref`` [rad, rad/s, rad/s², motor side]; the base class and
the constant speed of seed 000 are part of the component interface (:mod:`mjbench.control`).
"""
from __future__ import annotations

from mjbench.control import ConstantSpeed, ConstantSpeedP, Reference, constant_speed_law

__all__ = ["Reference", "ConstantSpeed", "ConstantSpeedP", "constant_speed_law"]
