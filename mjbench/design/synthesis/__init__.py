"""Kinematic synthesis of planar linkages: closed forms, Freudenstein, three-position motion generation.

Every routine returns a :class:`Synthesis`: the geometry (a :class:`SliderCrank` or a
:class:`FourBar`, each with its own closed-form position analysis), the targets, what the geometry
achieves (computed by that closed-form analysis, not copied from the targets) and the constraints
with a computed pass/fail.  No simulation, no mjbench mechanism: pure NumPy (the conversion to a
``[mechanism] type = "linkage"`` table is :mod:`mjbench.design.build`; the tests solve that table
with mjbench's own position solver and compare).

Conventions: lengths in metres, angles in radians, counter-clockwise positive; the input crank
turns counter-clockwise (q increasing, as mjbench drives it).

* **Slider-crank with offset** from stroke S and time ratio Q (Norton, *Design of Machinery*,
  ch. 3, quick-return mechanisms: Q = (180° + α)/(180° − α); Hartenberg & Denavit, *Kinematic
  Synthesis of Linkages*, 1964): with the two dead-centre distances
  A₁ = l + r, A₂ = l − r, the triangle crank centre / dead-centre slider positions gives
  S² = A₁² + A₂² − 2A₁A₂cos α and A₁A₂ sin α = S·e (twice its area), so for any offset
  0 < e < S/(2 tan(α/2)): A₁ ± A₂ = √(S² + 2A₁A₂(1 ± cos α)).  The offset is chosen to maximise
  the minimum transmission angle μ_min = 90° − asin((r + e)/l) unless given.
* **Crank-rocker** from rocker swing ψ and time ratio Q (the same references: two-position
  synthesis with quick return): the crank pivot A sees the chord C₁C₂ of the rocker's extreme
  positions under the imbalance angle α (inscribed angle), |AC_ext| = a + b, |AC_fold| = b − a;
  the one free parameter (the angle β at C₁ of the triangle AC₁C₂) maximises μ_min.
* **Function generation** (Freudenstein 1955, *Trans. ASME* 77:853): K₁cos φ − K₂cos ψ + cos(φ − ψ)
  = K₃ with K₁ = d/c, K₂ = d/a, K₃ = (a² − b² + c² + d²)/(2ac); three precision points at
  Chebyshev spacing x_j = (x₀ + x₁)/2 − (x₁ − x₀)/2·cos((2j − 1)π/6), or least squares over N
  points; the structural error ψ_generated − ψ_desired is computed by position analysis.
* **Motion generation** through three coupler poses (Sandor & Erdman, *Advanced Mechanism Design*
  vol. 2; Hartenberg & Denavit: circle points / centre points): a moving pivot fixed in the
  coupler is at its three positions on a circle whose centre is the ground pivot (circumcentre);
  with the ground pivot given, the moving pivot is the circumcentre of the ground pivot's three
  positions seen from the coupler (inversion).

Constraints reported for every design: Grashof type and full rotation of the input, branch defect
(precision positions on different assembly branches), order defect (poses not reached in their
order turning the crank forward), minimum transmission angle, link-length ratio, envelope.

The package: :mod:`.common` (helpers, constraint rows, :class:`Synthesis`), :mod:`.geometry`
(:class:`FourBar`, :class:`SliderCrank` and their closed-form analysis), one module per routine
(:mod:`.slider_crank`, :mod:`.crank_rocker`, :mod:`.function_generator`, :mod:`.motion_generator`);
every name is importable from here (``from mjbench.design import synthesis as S``).
"""
from __future__ import annotations

from .common import (CHANGE_POINT, TOL, TWO_PI, Synthesis, chebyshev_points, circumcentre, constraint, fold,
                     imbalance_angle, time_ratio, wrap)
from .crank_rocker import crank_rocker
from .function_generator import (FunctionSpec, _fg_linkage, freudenstein_solve, function_generator, lengths_from_K,
                                 structural_error)
from .geometry import FourBar, SliderCrank, fourbar_envelope
from .motion_generator import _rotT, centre_point, circle_point, motion_generator
from .slider_crank import slider_crank, slider_crank_from

__all__ = ["TWO_PI", "TOL", "CHANGE_POINT", "imbalance_angle", "time_ratio", "chebyshev_points", "wrap", "fold",
           "circumcentre", "constraint", "Synthesis", "FourBar", "SliderCrank", "fourbar_envelope",
           "slider_crank_from", "slider_crank", "crank_rocker", "freudenstein_solve", "lengths_from_K", "FunctionSpec",
           "structural_error", "function_generator", "centre_point", "circle_point", "motion_generator"]
# (_fg_linkage, _rotT: used by tests/test_design_synthesis.py)
