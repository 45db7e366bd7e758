# Source this file for a shell with the rig's virtualenv and built workspace:
#   source scripts/env.sh
_rig_root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
export VIRTUAL_ENV="$_rig_root/.venv"
export PATH="$VIRTUAL_ENV/bin:$PATH"
export RIG_ROOT="$_rig_root"
export RMW_IMPLEMENTATION=rmw_fastrtps_cpp
export ROS_AUTOMATIC_DISCOVERY_RANGE="${ROS_AUTOMATIC_DISCOVERY_RANGE:-LOCALHOST}"
# colcon's setup script reads unset variables: relax `set -u` while sourcing it
case $- in *u*) _rig_nounset=1; set +u ;; *) _rig_nounset= ;; esac
# shellcheck disable=SC1091
source "$_rig_root/ros_ws/install/setup.bash"
[ -n "$_rig_nounset" ] && set -u
export AMENT_PREFIX_PATH="${AMENT_PREFIX_PATH:+$AMENT_PREFIX_PATH:}$VIRTUAL_ENV"
unset _rig_root _rig_nounset
