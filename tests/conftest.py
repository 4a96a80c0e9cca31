import os

os.environ.setdefault("MUJOCO_GL", "egl")

from mjbench.outputs import route_mujoco_log  # noqa: E402

route_mujoco_log()  # MuJoCo warnings are recorded, never appended to ./MUJOCO_LOG.TXT
