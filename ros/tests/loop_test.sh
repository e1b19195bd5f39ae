#!/usr/bin/env bash
# The whole loop over ROS 1 (docs/ros.md, issue 46): roscore on the loopback on a port of its own,
# autoscan_node and autoscan_sim_robot on the demo object, against `autoscan demo` on the same
# object, seed and settings. Passes when the ROS run ends (done) with the same scans and iterations
# and the same coverage of the truth by the final model's points within 0.5 %; bounded in time; stops
# all it started.
#
# With MODE "depth" the robot sends each scan as a 32FC1 depth image with its camera_info instead of
# a cloud (the node estimates the normals from the image); the coverage must then agree within 1 %.
#
#   loop_test.sh AUTOSCAN_CLI AUTOSCAN_NODE AUTOSCAN_SIM_ROBOT WORK_DIR [MAX_VIEWS] [MODE: cloud|depth]
set -euo pipefail
CLI=$1 NODE=$2 ROBOT=$3 WORK=$4 MAX_VIEWS=${5:-10} MODE=${6:-cloud}
DEPTH=false TOLERANCE=0.005
if [ "$MODE" = depth ]; then DEPTH=true TOLERANCE=0.01; fi
# shellcheck source=roscore_lib.sh
source "$(dirname "$0")/roscore_lib.sh"
fresh_work_dir "$WORK"

# The reference: the demo with the truth's stop off (a session without the truth cannot have it).
cat > "$WORK/config.json" <<'JSON'
{"session": {"stop": {"truth_fscore_tolerance": 0}}}
JSON
echo "loop_test: reference run (autoscan demo, $MAX_VIEWS views)"
"$CLI" demo --out "$WORK/ref" --max-views "$MAX_VIEWS" --depth 7 --seed 1 --no-report \
  --config "$WORK/config.json" > "$WORK/ref.log" 2>&1

start_roscore
echo "loop_test: roscore on port $PORT"

"$NODE" __name:=autoscan_node _session_dir:="$WORK/ros_session" _config:="$WORK/ref/session.json" \
  > "$WORK/node.log" 2>&1 &
PIDS+=($!)
if ! timeout 900 "$ROBOT" __name:=autoscan_sim_robot _simulation:="$WORK/ref" _summary:="$WORK/summary.json" \
       _timeout:=300 _depth_images:=$DEPTH > "$WORK/robot.log" 2>&1; then
  echo "loop_test: the simulated robot failed"; tail -20 "$WORK/robot.log"; tail -20 "$WORK/node.log"; exit 1
fi

# The comparison: scans, iterations, stop reason, and the coverage of the last iteration's points.
python3 - "$CLI" "$WORK" "$TOLERANCE" "$MODE" <<'PY'
import json, subprocess, sys
cli, work, tolerance, mode = sys.argv[1], sys.argv[2], float(sys.argv[3]), sys.argv[4]
ref = json.load(open(f"{work}/ref/session.json"))
ros = json.load(open(f"{work}/ros_session/session.json"))
summary = json.load(open(f"{work}/summary.json"))
def coverage(session_dir, iteration):
    out = subprocess.run([cli, "evaluate", "--truth", f"{work}/ref/truth.ply", "--cloud",
                          f"{session_dir}/iterations/iter_{iteration:03d}/cloud.ply", "--json"],
                         check=True, capture_output=True, text=True).stdout
    return json.loads(out)["cloud"]["coverage"]
n_ref, n_ros = len(ref["scans"]), len(ros["scans"])
it_ref, it_ros = len(ref["iterations"]), len(ros["iterations"])
print(f"loop_test: scans {n_ros} over ROS, {n_ref} in simulate; iterations {it_ros} / {it_ref}; "
      f"stop {ros['stop_reason']} / {ref['stop_reason']}; robot summary {summary['scans']} scans, {summary['views']} views")
assert ros["stopped"], "the ROS session did not stop"
assert it_ros == it_ref, "iterations differ"
c_ref, c_ros = coverage(f"{work}/ref", it_ref - 1), coverage(f"{work}/ros_session", it_ros - 1)
print(f"loop_test: coverage of the truth {c_ros:.4f} over ROS ({mode}), {c_ref:.4f} in simulate "
      f"(difference {100 * abs(c_ros - c_ref):.3f} %)")
assert abs(c_ros - c_ref) <= tolerance, f"coverage differs by more than {100 * tolerance} %"
print(f"loop_test: passed in {summary['seconds']:.1f} s of ROS loop")
PY
