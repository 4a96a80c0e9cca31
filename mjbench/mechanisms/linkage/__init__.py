"""Generic single-DOF planar linkage from a link/joint description (``[mechanism] type = "linkage"``).

Description (docs/linkages.md has the full reference and examples; :mod:`.description`):

* ``ground``: named points of the frame (pivots, points on slide lines) [m];
* ``links.NAME``: rigid links — ``mass``, ``com`` (mass centre in the link frame), ``inertia``
  (about the mass centre, normal to the plane), ``points`` (named, in the link frame), optional
  ``point_masses`` (bearings, tools at named points) and ``angle`` (approximate angle of the link
  frame in the stated pose: it picks the assembly branch);
* ``joints``: revolute (``at = ["crank.B", "coupler.B"]``) or prismatic (``at = ["ground.G",
  "ram.P"]``, ``axis`` = slide direction in the first link's frame, ``angle`` = fixed θ₂ − θ₁);
  optional viscous ``damping``;
* ``input``: the driven joint (revolute, ground → input link; q = angle of the input link's frame);
  ``input_angle``: q of the stated pose; ``gravity`` (vector in the plane);
* optional ``springs`` (linear spring + damper between two points) and ``loads`` (a force on a
  point along a fixed direction or a torque on a link, constant or a table, optionally only on
  one stroke).

From that one description come two independent models:

* the **reduced model** from our own kinematics (:mod:`mjbench.mechanisms.linkage_kin`): Newton
  position solve of the loop-closure equations in body coordinates, branch followed by
  continuation from the stated pose over one input turn; velocity coefficients v = dz/dq from the
  constraint Jacobian and their derivatives a = dv/dq from the velocity-product terms (analytic,
  no differencing); then J = vᵀMv, J' = 2vᵀMa, E_p' = −Σ m g·v_G + Σ k (ℓ − ℓ₀) ℓ'.  Tabulated on
  a uniform grid over one turn (periodic cubic splines; accuracy measured at the interval
  midpoints against the exact solve and stored in ``table_info``);
* the **MJCF** (:meth:`Linkage.build_spec`): a kinematic tree (spanning tree of the joint graph,
  prismatic joints preferred as tree joints) with every other joint closed by a ``connect``
  equality between sites (solref/solimp as fourbar.py), springs as spatial tendons, point loads
  and the damping of loop-closing hinges as generalised forces (``load_form``, from the tree's own
  kinematics; only the on/off stroke of a gated load is read from the description's kinematics).

The plane convention is the one of :mod:`mjbench.mechanisms.base`: the plane (x, y) maps to
MuJoCo's (x, z), hinges turn about ``HINGE_AXIS`` = −y (angles counter-clockwise as in the
description), so gravity (g_x, g_y) becomes (g_x, 0, g_y).

The package, by concern:

| module | what |
|---|---|
| :mod:`.description` | the ``[mechanism]`` table: links, joints, springs, loads (pydantic models) |
| :mod:`.topology` | structural checks of a description; the MJCF's spanning tree |
| :mod:`.model` | the compiled description (mass properties, solver joints, tree), cached |
| :mod:`.kinematics` | configurations from body coordinates: frames, points, joint rates, exact solve |
| :mod:`.assembly` | assembly, mobility, the branch over one turn, and the errors naming joints |
| :mod:`.reduced` | the reduced-model channels and their periodic table |
| :mod:`.loads` | loads and the external torque as laws (reduced model) |
| :mod:`.multibody_loads` | the same loads on the MuJoCo tree, as laws |
| :mod:`.mjspec` | the MJCF builder |
| :mod:`.view` | the kinematic analysis (``mjbench analyze``) |
| :mod:`.equivalents` | the four-bar and quick-return written as generic linkages |
| :mod:`.mechanism` | :class:`Linkage`, the mechanism |

Every public name of these modules is importable from here (``from mjbench.mechanisms.linkage
import Linkage, LinkageParams, linkage_load``).
"""
from __future__ import annotations

from ..linkage_kin import TWO_PI, KJoint, PeriodicTable, PlanarSystem, SolveError, ptable_channel
from .assembly import COARSE_STEPS, COND_TOL, AssemblyMixin
from .description import JointSpec, Length, LinkageParams, LinkSpec, LoadSpec, Point, SpringSpec
from .equivalents import equivalent, table_from_fourbar, table_from_quickreturn
from .kinematics import KinematicsMixin
from .loads import LinkageExtP, LinkageModelP, LoadsP, linkage_model, linkage_torque, load_abscissa, load_force
from .mechanism import Linkage
from .mjspec import PALETTE, MjSpecMixin
from .multi_mechanism import MultiLinkage, cbar, unpack
from .model import _CACHE, compiled
from .multibody_loads import (LinkageLoadP, MultibodyLoadsMixin, chain_load_forces, closure_damping_forces,
                              link_torque_forces, linkage_load, slide_load_forces, write_forces)
from .reduced import TABLE_NODES, TABLE_TARGET, ReducedMixin
from .topology import GROUND, TreeMixin, topology_problems
from .view import AnalysisViewMixin

__all__ = [
    # description and structure
    "LinkageParams", "LinkSpec", "JointSpec", "SpringSpec", "LoadSpec", "Length", "Point", "GROUND",
    "topology_problems",
    # the compiled description and its parts
    "compiled", "TreeMixin", "KinematicsMixin", "AssemblyMixin", "ReducedMixin", "COARSE_STEPS", "COND_TOL",
    "TABLE_NODES", "TABLE_TARGET",
    # the mechanism and its parts
    "Linkage", "MultiLinkage", "unpack", "cbar", "MjSpecMixin", "MultibodyLoadsMixin", "AnalysisViewMixin", "PALETTE",
    # laws
    "LoadsP", "LinkageExtP", "LinkageModelP", "LinkageLoadP", "load_force", "load_abscissa", "linkage_torque",
    "linkage_model", "linkage_load", "closure_damping_forces", "slide_load_forces", "chain_load_forces",
    "link_torque_forces", "write_forces",
    # equivalents of the hand-coded mechanisms
    "table_from_fourbar", "table_from_quickreturn", "equivalent",
    # the solver's names (mjbench.mechanisms.linkage_kin)
    "TWO_PI", "KJoint", "PeriodicTable", "PlanarSystem", "SolveError", "ptable_channel",
]
# (_CACHE: the built descriptions, cleared by scripts/bench_parts/linkage.py to time a build)
