#!/usr/bin/env bash
# The tests marked `other_machines` (two arithmetic paths held together through a
# recursion, closed loop or long accumulation) under arithmetic another x86 CPU would do:
#
#   1. numba compiling for a generic x86-64 (no AVX, no FMA) and NumPy's own loops without
#      their AVX2/AVX-512 variants (NPY_DISABLE_CPU_FEATURES), as on an older machine;
#   2. numba compiling for skylake-avx512 (haswell or nehalem where the CPU lacks AVX-512
#      or AVX2: code for a wider target would not run) and OpenBLAS's most generic kernel
#      (Prescott), as a machine whose BLAS rounds the reference's products otherwise.
#      OPENBLAS_CORETYPE is left alone where the machine presets it (some processors need
#      a given kernel): then this variant keeps the preset kernel and changes numba's
#      target only.
#
# The first variant keeps the machine's own OpenBLAS kernel (SkylakeX here), under which
# the vector-tracking PCRB test failed; the second is the one ins-ekf's oracle failed.
#
# Each variant compiles the kernels afresh (its own NUMBA_CACHE_DIR), so no cached machine
# code of another target is reused. Found this way (issue 21): the vector-tracking PCRB of
# both backends (OpenBLAS SkylakeX kernel) and ins-ekf against its 17-state oracle
# (Prescott), held to fixed tolerances below their reference's own rounding.
# Usage: bash .ci/other_machines.sh   (after the venv of .ci/run)
set -euo pipefail
cd "$(dirname "$0")/.."
PY=.venv/bin/python
LOGS=$(mktemp -d)
PIDS=()
LABELS=()
# Each variant is one pytest process compiling the kernels for its own target: the two run at
# the same time (one per core of CI's 2; about 1 minute saved), each into its own log, printed
# whole when both have ended so their lines do not interleave.
run_variant() {
    local label=$1; shift
    local cache
    cache=$(mktemp -d)
    ( status=0
      env "$@" NUMBA_CACHE_DIR="$cache" "$PY" -m pytest -q -p no:cacheprovider -m other_machines tests || status=$?
      rm -rf "$cache"; exit $status ) >"$LOGS/${#PIDS[@]}.log" 2>&1 &
    PIDS+=("$!")
    LABELS+=("$label")
}
# Waits for every variant, prints its log under its label; fails if any variant failed.
join_variants() {
    local i failed=0
    for i in "${!PIDS[@]}"; do
        echo "== other machines: ${LABELS[$i]}"
        wait "${PIDS[$i]}" || failed=1
        cat "$LOGS/$i.log"
    done
    rm -rf "$LOGS"
    return $failed
}
# NumPy's dispatched SIMD targets this CPU has (X86_V3, X86_V4, ... on NumPy 2), all disabled.
SIMD=$("$PY" -c "
import numpy as np
m = getattr(np, '_core', None) or np.core
u = m._multiarray_umath
print(' '.join(k for k in u.__cpu_dispatch__ if u.__cpu_features__.get(k)))")
run_variant "generic x86-64 numba, NumPy without its dispatched SIMD loops (${SIMD:-none})" \
    NUMBA_CPU_NAME=generic NPY_DISABLE_CPU_FEATURES="$SIMD"
# numba's second target: one this CPU can run (code for a wider one would die of SIGILL).
if [ "$(uname -m)" != x86_64 ]; then
    join_variants
    echo "== other machines: second variant is for x86-64 only (this is $(uname -m))"
    exit 0
fi
FLAGS=$(grep -m1 '^flags' /proc/cpuinfo 2>/dev/null || true)
if [[ " $FLAGS " == *" avx512f "* ]]; then TARGET=skylake-avx512
elif [[ " $FLAGS " == *" avx2 "* && " $FLAGS " == *" fma "* ]]; then TARGET=haswell
else TARGET=nehalem
fi
if [ -n "${OPENBLAS_CORETYPE:-}" ]; then
    run_variant "$TARGET numba, the machine's preset OpenBLAS kernel ($OPENBLAS_CORETYPE)" \
        NUMBA_CPU_NAME=$TARGET
else
    run_variant "$TARGET numba, OpenBLAS Prescott kernel" \
        NUMBA_CPU_NAME=$TARGET OPENBLAS_CORETYPE=Prescott
fi
join_variants
