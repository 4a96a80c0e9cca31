"""mjbench — a MuJoCo testbed for machines driven by an electric motor under feedback control.

Data path: scenario (TOML) → mechanism + drive + controller (Machine) → backend (multibody or
reduced) → Trajectory → metrics, plots, video, report.
"""
__version__ = "0.1.0"
