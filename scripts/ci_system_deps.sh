#!/bin/sh
# System packages for offscreen rendering (MuJoCo EGL / OSMesa through Mesa's llvmpipe, CPU only)
# and for the headless-Chromium check of the HTML report (tests/test_report.py).
# Debian/Ubuntu, run as root (CI).  Idempotent: installs only what is missing, quietly.
#   libegl1 libegl-mesa0 libopengl0 libgl1 libgl1-mesa-dri  → MUJOCO_GL=egl (default)
#   libosmesa6                                               → MUJOCO_GL=osmesa fallback
#   chromium fonts-dejavu-core                               → headless HTML report check
set -eu
PKGS="libegl1 libegl-mesa0 libopengl0 libgl1 libgl1-mesa-dri libglx-mesa0 libosmesa6 chromium fonts-dejavu-core"
missing=""
for p in $PKGS; do
    if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
        missing="$missing $p"
    fi
done
if [ -z "$missing" ]; then
    echo "ci_system_deps: all present ($PKGS)"
    exit 0
fi
if [ "$(id -u)" != "0" ]; then
    SUDO="sudo"
else
    SUDO=""
fi
echo "ci_system_deps: installing$missing"
export DEBIAN_FRONTEND=noninteractive
$SUDO apt-get update -qq
# shellcheck disable=SC2086
$SUDO apt-get install -y -qq --no-install-recommends $missing >/dev/null
echo "ci_system_deps: done"
