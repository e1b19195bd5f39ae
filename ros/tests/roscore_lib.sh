# Shared by the ROS tests' scripts (sourced): a fresh work directory, a roscore of their own, and
# stopping everything they started.
#
#   fresh_work_dir DIR      empties DIR and sets WORK to its absolute path
#   start_roscore           roscore on a free loopback port (ROS_MASTER_URI, ROS_HOME and ROS_LOG_DIR
#                           under WORK), waits until the master answers, sets PORT
#   PIDS+=($!)              a process cleanup stops on exit (SIGINT, then SIGKILL)
PIDS=()
cleanup() {
  for p in "${PIDS[@]}"; do kill -INT "$p" 2>/dev/null || true; done
  sleep 1
  for p in "${PIDS[@]}"; do kill -KILL "$p" 2>/dev/null || true; done
  wait 2>/dev/null || true
}
trap cleanup EXIT

fresh_work_dir() {
  rm -rf "$1"
  mkdir -p "$1"
  WORK=$(cd "$1" && pwd)
}

start_roscore() {
  PORT=$(python3 -c 'import socket; s = socket.socket(); s.bind(("127.0.0.1", 0)); print(s.getsockname()[1])')
  export ROS_MASTER_URI="http://127.0.0.1:$PORT" ROS_IP=127.0.0.1 ROS_HOME="$WORK/ros_home" ROS_LOG_DIR="$WORK/ros_log"
  roscore -p "$PORT" > "$WORK/roscore.log" 2>&1 &
  PIDS+=($!)
  for _ in $(seq 1 100); do
    if python3 -c "import xmlrpc.client; xmlrpc.client.ServerProxy('$ROS_MASTER_URI').getSystemState('/t')" \
         2>/dev/null; then break; fi
    sleep 0.3
  done
}
