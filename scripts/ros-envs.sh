#!/usr/bin/env bash
# Real ROS 2 nodes for the ROS 2 tests: rclpy and the message packages from PyPI's ROS 2 wheels,
# Jazzy (Fast DDS 2.14) and Kilted (Fast DDS 3.2), each in its own venv under build/ros-<release>/
# (never the main venv: both releases install modules of the same names, e.g. `rclpy`).
# Idempotent: a stamp per env records what was installed; downloads are kept in
# build/ros-<release>/wheels and reused (pip install --no-index from there).
# PyPI has no tf2_msgs wheel for either release: /tf is checked with our own DDS participant.
set -euo pipefail
cd "$(dirname "$0")/.."
PYTHON=${PYTHON:-python3}

install_release() {
  local release=$1; shift
  local dir=build/ros-$release
  local stamp=$dir/venv/.installed
  local want="$*"
  if [[ -f $stamp && "$(cat "$stamp")" == "$want" ]] && "$dir/venv/bin/python" -c "import rclpy" 2>/dev/null; then
    echo "ros-envs: $release ready ($dir/venv)"
    return
  fi
  rm -rf "$dir/venv"
  mkdir -p "$dir/wheels"
  "$PYTHON" -m venv "$dir/venv"
  local pip=("$dir/venv/bin/python" -m pip --disable-pip-version-check)
  # the download, retried: a registry hiccup must not fail the run
  local attempt
  for attempt in 1 2 3; do
    if "${pip[@]}" download --quiet --dest "$dir/wheels" "$@"; then break; fi
    [[ $attempt == 3 ]] && { echo "ros-envs: could not download the $release wheels" >&2; exit 1; }
    sleep $((attempt * 5))
  done
  # empy comes as an sdist only: build its wheel once, into the cache
  local sdist
  for sdist in "$dir"/wheels/*.tar.gz; do
    [[ -e $sdist ]] || continue
    local base
    base=$(basename "$sdist" .tar.gz)
    ls "$dir"/wheels/"${base//-/_}"-*.whl >/dev/null 2>&1 || ls "$dir"/wheels/"$base"-*.whl >/dev/null 2>&1 ||
      "${pip[@]}" wheel --quiet --use-pep517 --no-deps --wheel-dir "$dir/wheels" "$sdist"
  done
  "${pip[@]}" install --quiet --no-index --find-links "$dir/wheels" "$@"
  "$dir/venv/bin/python" -c "import rclpy, sensor_msgs.msg, nav_msgs.msg, geometry_msgs.msg, diagnostic_msgs.msg, std_srvs.srv, rcl_interfaces.srv"
  echo "$want" >"$stamp"
  echo "ros-envs: $release installed ($dir/venv)"
}

install_release jazzy ros-jazzy-rclpy ros-jazzy-rmw-fastrtps-cpp ros-jazzy-sensor-msgs ros-jazzy-std-msgs ros-jazzy-std-srvs \
  ros-jazzy-diagnostic-msgs ros-jazzy-nav-msgs ros-jazzy-geometry-msgs
install_release kilted ros-rclpy ros-rmw-fastrtps-cpp ros-sensor-msgs ros-std-msgs ros-std-srvs ros-diagnostic-msgs \
  ros-nav-msgs ros-geometry-msgs
