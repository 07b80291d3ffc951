#!/usr/bin/env bash
# Independent reference for the radiosity renderer (issue 13): the Cornell box fixture
# rendered with Mitsuba 3 (path tracer, max depth 64, Y only) beside `lumiwall render`,
# compared on 16×16-pixel block means. A probe, not yet a test: about 5 min on 2 cores.
# Needs: apt-get install -y libllvm19 (the llvm_ad_mono variant aborts with LLVM 15;
# PyPI mitsuba 3.9 has no scalar_mono), and a venv with
#   pip install mitsuba numpy openexr pillow matplotlib scipy
# Usage: tests/reference/mitsuba/run.sh VENV_PYTHON   (from the repository root, after
# cargo build --release -p lumiwall)
set -euo pipefail
PY=${1:?path to the venv python}
HERE=$(cd "$(dirname "$0")" && pwd)
ROOT=$(cd "$HERE/../../.." && pwd)
OUT=${OUT:-$ROOT/out/mitsuba}
mkdir -p "$OUT"
export DRJIT_LIBLLVM_PATH=${DRJIT_LIBLLVM_PATH:-/usr/lib/x86_64-linux-gnu/libLLVM.so.19.1}
F=$ROOT/fixtures/scenes/cornell
L=$ROOT/target/release/lumiwall
"$L" render "$F/cornell.toml" --error 2% --out "$OUT/lw2.exr"
"$L" render "$F/cornell.toml" --error 1% --out "$OUT/lw1.exr"
"$PY" "$HERE/mitsuba_ref.py" "$F/cornell.toml" 1024 4 "$OUT/mi4k.npy"
"$PY" "$HERE/compare.py" "$OUT/mi4k.npy" "$OUT/lw2.exr" "$OUT/lw1.exr"
# the empty box (units and geometry): agrees to 0.7 %
"$L" render "$F/cornell_empty.toml" --error 1% --out "$OUT/lwE1.exr"
"$PY" "$HERE/mitsuba_ref.py" "$F/cornell_empty.toml" 64 4 "$OUT/miE.npy"
"$PY" "$HERE/compare.py" "$OUT/miE.npy" "$OUT/lwE1.exr"
# diagnostics: the variants in diag/ (their OBJs beside them)
for s in talltopblack tallplate inset split split2; do
  "$L" render "$HERE/diag/cornell_$s.toml" --error 1% --out "$OUT/lw_$s.exr"
  "$PY" "$HERE/mitsuba_ref.py" "$HERE/diag/cornell_$s.toml" 512 2 "$OUT/mi_$s.npy"
  "$PY" "$HERE/compare.py" "$OUT/mi_$s.npy" "$OUT/lw_$s.exr"
done
