"""Cost of one residual-energy evaluation E(T): closed form vs reduced ODE vs MuJoCo (seeds 001/003)."""
import math
from bench_parts import best_time


_best = best_time


def run(args):
    from mjbench import vibration
    from mjbench.mechanisms.platform import BeltPlatform, ElasticPlatform
    from mjbench.motionlaws import BezierLaw, PseudoPolynomialLaw

    rep = max(1, getattr(args, "repeat", 3))
    rows = []
    cases = (("belt_pseudopoly", BeltPlatform(), PseudoPolynomialLaw(30 * math.pi, 1.0, (3.024, 4.565, 5.874))),
             ("elastic_bezier", ElasticPlatform(), BezierLaw(40 * math.pi, 1.0, 2, 3)))
    for name, plat, law in cases:
        osc = plat.oscillator()
        tc = _best(lambda: vibration.residual_energy(law, osc), rep * 10)
        to = _best(lambda: vibration.residual_energy_ode(law, osc), rep)
        tm = _best(lambda: vibration.residual_energy_multibody(plat, law, dt=1e-3), rep)
        rows += [(f"vib_{name}_closed_ms", 1e3 * tc, "E(T) closed form (Gauss-Jacobi / by-parts series) [ms]"),
                 (f"vib_{name}_ode_ms", 1e3 * to, "E(T) reduced ODE, DOP853 rtol 1e-12 [ms]"),
                 (f"vib_{name}_mujoco_ms", 1e3 * tm, "E(T) MuJoCo RK4 1 ms, driven joint per stage [ms]"),
                 (f"vib_{name}_ode_over_closed", to / tc, "ratio ODE / closed form"),
                 (f"vib_{name}_mujoco_over_closed", tm / tc, "ratio MuJoCo / closed form")]
    return rows
