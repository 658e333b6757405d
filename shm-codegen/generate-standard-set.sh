#!/usr/bin/env bash
# Regenerates shm-cdr/src/msgs/ (the standard interfaces), shm-runtime/src/msgs/
# (their shared-memory forms) and the per-package
# features in both Cargo.tomls from the interface definitions in the ROS 2
# Kilted wheels on PyPI (for tf2_msgs, which has no wheel, rosbags' type
# store; for example_interfaces and rosbag2_interfaces, which have neither,
# the files this project writes in shm-codegen/interfaces, whose hashes
# tests/ros2/check.py has rosidl's own tools compute). CI runs it and fails if the result differs from
# what is committed.
#
#   shm-codegen/generate-standard-set.sh
set -euo pipefail
cd "$(dirname "$0")/.."

venv=target/interfaces-venv
src=target/interfaces-src
# Interface packages from the Kilted wheels, each pinned.
wheels=(
    action_msgs==2.3.0 actionlib_msgs==5.5.1 builtin_interfaces==2.3.0
    diagnostic_msgs==5.5.1 geometry_msgs==5.5.1 lifecycle_msgs==2.3.0
    nav_msgs==5.5.1 rcl_interfaces==2.3.0 rosgraph_msgs==2.3.0
    sensor_msgs==5.5.1 service_msgs==2.3.0 shape_msgs==5.5.1 std_msgs==5.5.1
    std_srvs==5.5.1 stereo_msgs==5.5.1 test_msgs==2.3.0
    trajectory_msgs==5.5.1 type_description_interfaces==2.3.0
    unique_identifier_msgs==2.7.0 visualization_msgs==5.5.1
)
from_rosbags=(tf2_msgs)
# The same packages from the Jazzy wheels: where Jazzy words an interface file
# differently (its comments), shm-cdr/src/distro_sources.rs keeps Jazzy's text.
jazzy_venv=target/interfaces-jazzy-venv
jazzy_src=target/interfaces-src-jazzy
jazzy_wheels=(
    action_msgs==2.0.3 actionlib_msgs==5.3.6 builtin_interfaces==2.0.3
    diagnostic_msgs==5.3.6 geometry_msgs==5.3.6 lifecycle_msgs==2.0.3
    nav_msgs==5.3.6 rcl_interfaces==2.0.3 rosgraph_msgs==2.0.3
    sensor_msgs==5.3.6 service_msgs==2.0.3 shape_msgs==5.3.6 std_msgs==5.3.6
    std_srvs==5.3.6 stereo_msgs==5.3.6 test_msgs==2.0.3
    trajectory_msgs==5.3.6 type_description_interfaces==2.0.3
    unique_identifier_msgs==2.5.0 visualization_msgs==5.3.6
)

if [ ! -x "$venv/bin/python" ]; then
    python3 -m venv "$venv"
fi
specs=()
for w in "${wheels[@]}"; do specs+=("ros-${w//_/-}"); done
"$venv/bin/pip" install --quiet --disable-pip-version-check --no-deps "${specs[@]}"
"$venv/bin/pip" install --quiet --disable-pip-version-check rosbags==0.11.9


if [ ! -x "$jazzy_venv/bin/python" ]; then
    python3 -m venv "$jazzy_venv"
fi
specs=()
# (`ros-jazzy-<pkg>` only requires `ros-<pkg>` at Jazzy's version, which holds the files.)
for w in "${jazzy_wheels[@]}"; do specs+=("ros-${w//_/-}"); done
"$jazzy_venv/bin/pip" install --quiet --disable-pip-version-check --no-deps "${specs[@]}"

# The interface files of each wheel, one folder per package.
copy_interfaces() {
    local from=$1 to=$2
    shift 2
    rm -rf "$to"
    mkdir -p "$to"
    for w in "$@"; do
        pkg=${w%%==*}
        for kind in msg srv action; do
            if [ -d "$from/share/$pkg/$kind" ]; then
                mkdir -p "$to/$pkg/$kind"
                cp "$from/share/$pkg/$kind/"*."$kind" "$to/$pkg/$kind/" 2>/dev/null || true
            fi
        done
    done
}
copy_interfaces "$venv" "$src" "${wheels[@]}"
copy_interfaces "$jazzy_venv" "$jazzy_src" "${jazzy_wheels[@]}"
dirs=()
for w in "${wheels[@]}"; do dirs+=("$src/${w%%==*}"); done
"$venv/bin/python" shm-codegen/rosbags_to_msg.py "$src" "${from_rosbags[@]}"
for pkg in "${from_rosbags[@]}"; do dirs+=("$src/$pkg"); done
dirs+=(shm-codegen/interfaces/example_interfaces shm-codegen/interfaces/rosbag2_interfaces)

cargo run --quiet -p shm-codegen -- --crate-path crate --extern-root crate::msgs --arbitrary \
    --features shm-cdr/Cargo.toml --registry shm-cdr/src/registry.rs \
    --distro-sources shm-cdr/src/distro_sources.rs --sources-of jazzy="$jazzy_src" \
    --out-dir shm-cdr/src/msgs "${dirs[@]}"

# shm-runtime's `…Shm` forms (byte sequences as `ShmBytes`) of the packages
# whose messages carry big byte payloads.
cargo run --quiet -p shm-codegen -- --crate-path ::shm_cdr --extern-root ::shm_cdr::msgs \
    --shm-bytes crate::ShmBytes --shm-forms-only \
    --features shm-runtime/Cargo.toml --forward-features shm-cdr \
    --out-dir shm-runtime/src/msgs "$src/sensor_msgs" "$src/std_msgs"
