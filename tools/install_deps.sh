#!/usr/bin/env bash
# Install the Debian packages the stack needs. Idempotent: apt is only called for missing ones.
case "${1:-}" in -h|--help) awk 'NR > 1 && !/^#/ {exit} NR > 1 {sub(/^# ?/, ""); print}' "$0"; exit 0 ;; esac
set -euo pipefail
PKGS=(build-essential cmake ros-base-dev catkin python3-rospy python3-rostest librostest-dev
      libtf2-ros-dev libnav-msgs-dev python3-nav-msgs libactionlib-dev python3-actionlib
      libvisualization-msgs-dev python3-visualization-msgs libgeometry-msgs-dev
      libompl-dev libeigen3-dev libgtest-dev libyaml-cpp-dev libtinyxml2-dev gringo
      python3-numpy python3-scipy python3-matplotlib python3-yaml python3-distributed
      python3-tf2-ros libroslib-dev rosbash libpng-dev python3-rosbag python3-rospkg
      rviz xvfb python3-pil libmove-base-msgs-dev python3-move-base-msgs tf-tools)
missing=()
for p in "${PKGS[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -gt 0 ]; then
  echo "[install_deps] installing: ${missing[*]}"
  SUDO=""; [ "$(id -u)" -eq 0 ] || SUDO="sudo"
  # Another install running at the same time (a second build, a CI step) holds dpkg's lock:
  # wait for it (up to 20 minutes) instead of failing at once.
  LOCK=(-o DPkg::Lock::Timeout=1200)
  $SUDO apt-get "${LOCK[@]}" update -qq
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get "${LOCK[@]}" install -y -qq --no-install-recommends \
    "${missing[@]}" >/dev/null
fi
echo "[install_deps] all ${#PKGS[@]} packages present"
