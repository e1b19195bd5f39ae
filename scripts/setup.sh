#!/usr/bin/env bash
# One-command set-up for a fresh Debian 12 machine: installs every Debian package the build and the
# tests need (idempotent; as root or through sudo), fetches the benchmark meshes, installs the
# report's front-end packages from npm, then configures and builds a Release build in build/ and
# installs the Python module (`python3 -c "import autoscan"`, docs/python.md).
#
#   scripts/setup.sh            install + build (then: build/autoscan demo)
#   scripts/setup.sh --test     install + build + run the whole test suite, then a minute of
#                               fuzzing (scripts/fuzz.sh --ci, clang in build-fuzz/) (what CI runs)
#   scripts/setup.sh --sanitize install + ASan/UBSan build in build-asan/ + run the test suite
#   scripts/setup.sh --with-open3d  also install Open3D and build the peer benchmarks
set -euo pipefail
cd "$(dirname "$0")/.."
ROOT=$(pwd)

RUN_TESTS=0
SANITIZE=0
WITH_OPEN3D=0
for arg in "$@"; do
  case "$arg" in
    --test) RUN_TESTS=1 ;;
    --sanitize) SANITIZE=1; RUN_TESTS=1 ;;
    --with-open3d) WITH_OPEN3D=1 ;;
    -h|--help) sed -n '2,11p' "$0"; exit 0 ;;
    *) echo "setup.sh: unknown option '$arg'" >&2; exit 2 ;;
  esac
done

SUDO=""
if [ "$(id -u)" != 0 ]; then SUDO="sudo"; fi

PACKAGES=(
  build-essential cmake ninja-build pkg-config git ca-certificates
  libeigen3-dev libtbb-dev libembree-dev libnanoflann-dev libcgal-dev libgmp-dev libmpfr-dev
  libceres-dev libcli11-dev nlohmann-json3-dev libspdlog-dev libfmt-dev libpng-dev zlib1g-dev
  libgtest-dev libgmock-dev libbenchmark-dev
  python3-dev pybind11-dev python3-numpy python3-pytest
  clang-14 libclang-rt-14-dev
  chromium
  # The ROS 1 node (ros/, docs/ros.md; -DAUTOSCAN_ROS, on when these are found) and roscore for its test.
  ros-core libroscpp-dev librosconsole-dev libmessage-filters-dev libtf2-dev libtf2-ros-dev libtf2-msgs-dev
  libstd-msgs-dev libstd-srvs-dev libsensor-msgs-dev libgeometry-msgs-dev libnav-msgs-dev libvisualization-msgs-dev
  python3-rospy python3-rosbag python3-std-srvs
)
# The report's front end is bundled with npm and tested in headless Chromium (Playwright).
command -v node >/dev/null 2>&1 || PACKAGES+=(nodejs)
command -v npm >/dev/null 2>&1 || PACKAGES+=(npm)
if [ "$WITH_OPEN3D" = 1 ]; then PACKAGES+=(libopen3d-dev); fi

missing=()
for p in "${PACKAGES[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -gt 0 ]; then
  echo "setup: installing ${missing[*]}"
  export DEBIAN_FRONTEND=noninteractive
  $SUDO apt-get update -qq
  $SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}"
fi

bash scripts/fetch-models

if [ -f report/package.json ] && [ ! -d report/node_modules ]; then
  (cd report && npm ci --no-audit --no-fund --loglevel=error)
fi

JOBS=${AUTOSCAN_JOBS:-$(nproc)}
if [ "$SANITIZE" = 1 ]; then
  BUILD=build-asan
  cmake -S . -B "$BUILD" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo -DAUTOSCAN_SANITIZE=ON \
        -DAUTOSCAN_BUILD_BENCHMARKS=OFF
else
  BUILD=build
  cmake -S . -B "$BUILD" -G Ninja -DCMAKE_BUILD_TYPE=Release -DAUTOSCAN_WITH_OPEN3D=$([ "$WITH_OPEN3D" = 1 ] && echo ON || echo OFF)
fi
cmake --build "$BUILD" -j "$JOBS"

# The Python module (built unless the build has it off, e.g. the sanitizer build) goes into the
# interpreter's site directory for local packages (Debian 12: /usr/local/lib/python3.11/dist-packages).
if [ -d "$BUILD/python/autoscan" ]; then
  $SUDO cmake --install "$BUILD" --component python
  PY=$(sed -n 's/^Python3_EXECUTABLE:[A-Z]*=//p' "$BUILD/CMakeCache.txt")
  (cd /tmp && "${PY:-python3}" -c "import autoscan; print('setup: Python module autoscan', autoscan.__version__)")
fi

if [ "$RUN_TESTS" = 1 ]; then
  if [ "$SANITIZE" = 1 ]; then
    export ASAN_OPTIONS=detect_leaks=0:abort_on_error=1
    export UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1
  fi
  ctest --test-dir "$BUILD" --output-on-failure -j "$JOBS" --timeout 900
  if [ "$SANITIZE" = 0 ]; then
    # libFuzzer targets of every parser (fuzz/, docs/reliability.md), about a minute in all.
    bash scripts/fuzz.sh --ci
  fi
fi
