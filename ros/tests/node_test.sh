#!/usr/bin/env bash
# autoscan_node's refusals against a real roscore (docs/ros.md, issue 46): roscore on the loopback on
# a port of its own, the node on a fresh session (world frame "world", tf_timeout 0.5 s) and a second
# one under "tool" with output_frame tool0, then the gtest client test_ros_node. Bounded in time; stops all it started.
#
#   node_test.sh AUTOSCAN_NODE TEST_ROS_NODE WORK_DIR
set -euo pipefail
NODE=$1 CLIENT=$2 WORK=$3
# shellcheck source=roscore_lib.sh
source "$(dirname "$0")/roscore_lib.sh"
fresh_work_dir "$WORK"

start_roscore
echo "node_test: roscore on port $PORT"

"$NODE" __name:=autoscan_node _session_dir:="$WORK/session" _world_frame:=world _tf_timeout:=0.5 \
  > "$WORK/node.log" 2>&1 &
PIDS+=($!)
# The same node under "tool", its views as the poses of tool0 (output_frame).
"$NODE" __name:=autoscan_tool __ns:=tool _session_dir:="$WORK/session_tool" _world_frame:=world _tf_timeout:=0.5 \
  _output_frame:=tool0 > "$WORK/node_tool.log" 2>&1 &
PIDS+=($!)
if ! timeout 300 "$CLIENT"; then
  echo "node_test: failed; the nodes' logs:"; for f in "$WORK/node.log" "$WORK/node_tool.log"; do tail -n 30 "$f"; done; exit 1
fi
