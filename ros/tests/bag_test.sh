#!/usr/bin/env bash
# A recorded run replayed gives the same session (docs/ros.md, issue 46): the loop of loop_test.sh
# (autoscan_node + autoscan_sim_robot on `autoscan demo`'s object) recorded with `rosbag record`
# (/tf, /input/points, /refused_view, /status), then replayed by bag_replay.py into a second node on
# a fresh session with the same settings. Passes when both sessions have the same scans (poses to
# the bit), the same iterations and bit-identical final models. Stops all it started.
#
#   bag_test.sh AUTOSCAN_CLI AUTOSCAN_NODE AUTOSCAN_SIM_ROBOT WORK_DIR [MAX_VIEWS]
set -euo pipefail
CLI=$1 NODE=$2 ROBOT=$3 WORK=$4 MAX_VIEWS=${5:-6}
HERE=$(cd "$(dirname "$0")" && pwd)
# shellcheck source=roscore_lib.sh
source "$HERE/roscore_lib.sh"
fresh_work_dir "$WORK"

echo '{"session": {"stop": {"truth_fscore_tolerance": 0}}}' > "$WORK/config.json"
"$CLI" demo --out "$WORK/ref" --max-views "$MAX_VIEWS" --depth 7 --seed 1 --no-report \
  --config "$WORK/config.json" > "$WORK/ref.log" 2>&1

start_roscore

# The recorded run.
"$NODE" __name:=autoscan_node _session_dir:="$WORK/session_a" _config:="$WORK/ref/session.json" \
  > "$WORK/node_a.log" 2>&1 &
NODE_A=$!
PIDS+=($NODE_A)
rosbag record -O "$WORK/run.bag" /tf /input/points /refused_view /status __name:=autoscan_bag_record \
  > "$WORK/record.log" 2>&1 &
RECORD=$!
PIDS+=($RECORD)
for _ in $(seq 1 100); do
  if rosnode info /autoscan_bag_record 2>/dev/null | grep -q "/input/points"; then break; fi
  sleep 0.3
done
sleep 1
if ! timeout 900 "$ROBOT" __name:=autoscan_sim_robot _simulation:="$WORK/ref" _timeout:=300 > "$WORK/robot.log" 2>&1; then
  echo "bag_test: the simulated robot failed"; tail -20 "$WORK/robot.log"; exit 1
fi
sleep 1
kill -INT "$RECORD" "$NODE_A"
wait "$RECORD" "$NODE_A" 2>/dev/null || true
rosbag info "$WORK/run.bag" | grep -E "messages|topics|/" | head -12

# The replay into a fresh session with the same settings.
"$NODE" __name:=autoscan_node _session_dir:="$WORK/session_b" _config:="$WORK/ref/session.json" \
  > "$WORK/node_b.log" 2>&1 &
PIDS+=($!)
if ! timeout 900 /usr/bin/python3 "$HERE/bag_replay.py" "$WORK/run.bag" 300; then
  echo "bag_test: the replay failed"; tail -20 "$WORK/node_b.log"; exit 1
fi

python3 - "$WORK" <<'PY'
import hashlib, json, sys
work = sys.argv[1]
a = json.load(open(f"{work}/session_a/session.json"))
b = json.load(open(f"{work}/session_b/session.json"))
assert len(a["scans"]) == len(b["scans"]), f"scans {len(a['scans'])} recorded, {len(b['scans'])} replayed"
for sa, sb in zip(a["scans"], b["scans"]):
    assert sa["pose"] == sb["pose"], f"scan {sa.get('id')}: poses differ"
assert len(a["iterations"]) == len(b["iterations"]), "iterations differ"
last = len(a["iterations"]) - 1
digest = lambda s: hashlib.sha256(open(f"{work}/{s}/iterations/iter_{last:03d}/cloud.ply", "rb").read()).hexdigest()
assert digest("session_a") == digest("session_b"), "the final models differ"
print(f"bag_test: passed: {len(a['scans'])} scans, {len(a['iterations'])} iterations, final models bit-identical")
PY
