#!/usr/bin/env bash
# Build the C++ baseline (benchmarks/cpp/panda_impedance.cpp) against the Pinocchio of the pin wheels.
#
# Needs g++ (C++17) and, in the Python environment, the wheels pin/libpinocchio (headers and
# libraries under the cmeel prefix) and cmeel-eigen (Eigen's headers: pip install 'cmeel-eigen>=3.4.1').
# The paths are found from Python at build time. Usage: benchmarks/cpp/build.sh [python] [output]
set -euo pipefail
PY=${1:-python}
HERE=$(cd "$(dirname "$0")" && pwd)
OUT=${2:-$HERE/panda_impedance}
PREFIX=$("$PY" -c "import cmeel, os; print(os.path.join(os.path.dirname(os.path.dirname(cmeel.__file__)), 'cmeel.prefix'))")
if [ ! -f "$PREFIX/include/pinocchio/config.hpp" ]; then
  echo "build.sh: Pinocchio's headers are not under $PREFIX/include (pip install pin)" >&2; exit 3
fi
if [ ! -f "$PREFIX/include/eigen3/Eigen/Core" ]; then
  echo "build.sh: Eigen's headers are not under $PREFIX/include/eigen3 (pip install 'cmeel-eigen>=3.4.1')" >&2; exit 3
fi
command -v g++ >/dev/null || { echo "build.sh: g++ not found" >&2; exit 3; }
g++ -std=c++17 -O3 -march=native -DNDEBUG -w -DBOOST_MPL_CFG_NO_PREPROCESSED_HEADERS -DBOOST_MPL_LIMIT_LIST_SIZE=30 \
  -I"$PREFIX/include" -I"$PREFIX/include/eigen3" \
  "$HERE/panda_impedance.cpp" -o "$OUT" \
  -L"$PREFIX/lib" -Wl,-rpath,"$PREFIX/lib" -lpinocchio_default
echo "$OUT"
