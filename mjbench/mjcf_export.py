"""The stand-alone MJCF of a machine as mjbench simulates it (:func:`machine_xml`); the exporter itself
(assembled ``qpos0`` and the keyframe ``initial``) is :mod:`mjbench.mechanisms.mjcf_export`."""
from __future__ import annotations

from .backends.multibody import build_model
from .mechanisms.mjcf_export import CLOSURE_TOL, assemble, closure_of, standalone_xml  # noqa: F401 - the exporter's face

__all__ = ["CLOSURE_TOL", "assemble", "closure_of", "machine_xml", "standalone_xml"]


def machine_xml(machine, options=None, header: str = "") -> str:
    """:func:`standalone_xml` of a machine's model as mjbench simulates it (reflected drive inertia
    and viscous friction on the input joint), at the machine's initial state (q0, q̇0, x0, ẋ0)."""
    spec, model = build_model(machine, options)
    mech = machine.mechanism
    qpos = mech.initial_qpos(model, machine.q0, machine.x0)
    qvel = mech.initial_qvel(model, machine.q0, machine.qd0, machine.x0, machine.xd0)
    return standalone_xml(spec, model, qpos, qvel, mech.input_joints, header)
