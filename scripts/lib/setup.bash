# Shared set-up for scripts/test and scripts/demo (sourced, not run).
# Installs the Debian 12 packages the project needs (only those missing), then
# configures and builds the workspace in $BUILD_DIR.

REPO_ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)"
BUILD_DIR="${BUILD_DIR:-$REPO_ROOT/build}"
# Debian's ROS modules belong to the system interpreter, not to a pyenv one.
export PYENV_VERSION=system
SYSTEM_PYTHON=/usr/bin/python3

# Everything comes from Debian 12's own archive (ROS 1 as Debian ships it).
DEBIAN_PACKAGES=(
  # build tools and the ROS 1 core
  build-essential cmake git clang-format catkin catkin-lint ros-core-dev rosbash python3-catkin-pkg
  # C++ libraries of the nodelets
  libroscpp-dev libnodeletlib-dev libnodelet-dev libnodeletlib-tools pluginlib-dev
  libtf2-ros-dev libtf2-eigen-dev libtf2-sensor-msgs-dev tf2-tools libeigen3-dev
  libpcl-dev libpcl-conversions-dev libsensor-msgs-dev libnav-msgs-dev libmessage-filters-dev
  libdynamic-reconfigure-config-init-mutex-dev python3-dynamic-reconfigure
  libdiagnostic-updater-dev python3-diagnostic-updater libdepth-image-proc-dev
  liblaser-geometry-dev
  # the self filter's robot description (URDF collision elements)
  liburdfdom-dev
  # SLAM and localization experiment: MRPT 2 (rbpf-slam, pf-localization, ros-map-yaml2mrpt;
  # the rawlog converter's libraries) and rosbag's C++ reader
  mrpt-apps mrpt-common libmrpt-obs-dev libmrpt-ros1bridge-dev librosbag-storage-dev
  libtf2-dev libtf2-msgs-dev
  # the 3D method the unified scan is compared with (bag_to_octomap, docs/octomap.md)
  liboctomap-dev
  # the navigation experiment's navigator (reactive_navigator: MRPT's TP-Space navigators)
  libmrpt-nav-dev libmrpt-kinematics-dev libstd-msgs-dev libgeometry-msgs-dev
  # tests and benchmarks
  librostest-dev googletest libgtest-dev libbenchmark-dev pybind11-dev python3-dev python3-pytest
  python3-pytest-xdist
  # Python side: rospy tools, evaluation, plots
  python3-rospy python3-rosbag python3-rostest python3-roslaunch python3-rosmaster
  python3-rostopic python3-nodelet python3-tf2-ros python3-sensor-msgs python3-nav-msgs
  python3-diagnostic-msgs python3-numpy python3-yaml python3-matplotlib python3-tqdm
  python3-psutil
  # rviz screenshot check
  rviz xvfb xauth imagemagick
)

# Each step with the minutes since the script started (the test suite has a time budget).
log() { printf '\033[1m== %s\033[0m (%d:%02d)\n' "$*" $((SECONDS / 60)) $((SECONDS % 60)); }

install_debian_packages() {
  local missing=() pkg
  for pkg in "${DEBIAN_PACKAGES[@]}"; do
    dpkg-query -W -f='${Status}' "$pkg" 2>/dev/null | grep -q '^install ok installed$' || missing+=("$pkg")
  done
  if [ ${#missing[@]} -eq 0 ]; then
    log "all ${#DEBIAN_PACKAGES[@]} Debian packages present"
    return 0
  fi
  local sudo=()
  [ "$(id -u)" -eq 0 ] || sudo=(sudo)
  log "installing ${#missing[@]} Debian packages: ${missing[*]}"
  "${sudo[@]}" apt-get update -qq
  DEBIAN_FRONTEND=noninteractive "${sudo[@]}" apt-get install -y -qq --no-install-recommends "${missing[@]}"
}

build_workspace() {
  log "configuring and building in $BUILD_DIR (Release)"
  mkdir -p "$BUILD_DIR"
  # The install target writes to $BUILD_DIR/install (test/test_install_space.py checks that
  # install space), never to /usr/local.
  cmake -S "$REPO_ROOT" -B "$BUILD_DIR" -DCMAKE_BUILD_TYPE=Release \
    -DCATKIN_ENABLE_TESTING=ON -DCMAKE_INSTALL_PREFIX="$BUILD_DIR/install" \
    -DPYTHON_EXECUTABLE="$SYSTEM_PYTHON" -DPython3_EXECUTABLE="$SYSTEM_PYTHON" >"$BUILD_DIR/configure.log" 2>&1 \
    || { cat "$BUILD_DIR/configure.log"; return 1; }
  cmake --build "$BUILD_DIR" -j"$(nproc)" "$@"
}

source_workspace() {
  # setup.bash reads unset variables; keep `set -u` out of it.
  set +u
  # shellcheck disable=SC1091
  source "$BUILD_DIR/devel/setup.bash"
  set -u
}
