#!/usr/bin/env bash
# The tests marked `other_machines` (two arithmetic paths held together through a
# recursion, closed loop or long accumulation) under arithmetic another x86 CPU would do:
#
#   1. numba compiling for a generic x86-64 (no AVX, no FMA) and NumPy's own loops without
#      their AVX2/AVX-512 variants (NPY_DISABLE_CPU_FEATURES), as on an older machine;
#   2. numba compiling for skylake-avx512 and OpenBLAS's most generic kernel (Prescott), as
#      a machine whose BLAS rounds the reference's products otherwise. OPENBLAS_CORETYPE is
#      left alone where the machine presets it (some processors need a given kernel): then
#      this variant keeps the preset kernel and changes numba's target only.
#
# Each variant compiles the kernels afresh (its own NUMBA_CACHE_DIR), so no cached machine
# code of another target is reused. Found by this: the vector-tracking PCRB of both
# backends (OpenBLAS SkylakeX kernel) and ins-ekf against its 17-state oracle (Prescott)
# held to fixed tolerances below their reference's own rounding (issue 21).
# Usage: bash .ci/other_machines.sh   (after the venv of .ci/run)
set -euo pipefail
cd "$(dirname "$0")/.."
PY=.venv/bin/python
run_variant() {
    local label=$1; shift
    local cache
    cache=$(mktemp -d)
    echo "== other machines: $label"
    env "$@" NUMBA_CACHE_DIR="$cache" "$PY" -m pytest -q -p no:cacheprovider -m other_machines tests
    rm -rf "$cache"
}
# NumPy's dispatched SIMD targets this CPU has (X86_V3, X86_V4, ... on NumPy 2), all disabled.
SIMD=$("$PY" -c "
import numpy as np
m = getattr(np, '_core', None) or np.core
u = m._multiarray_umath
print(' '.join(k for k in u.__cpu_dispatch__ if u.__cpu_features__.get(k)))")
run_variant "generic x86-64 numba, NumPy without its dispatched SIMD loops (${SIMD:-none})" \
    NUMBA_CPU_NAME=generic NPY_DISABLE_CPU_FEATURES="$SIMD"
if [ -n "${OPENBLAS_CORETYPE:-}" ]; then
    run_variant "skylake-avx512 numba, the machine's preset OpenBLAS kernel ($OPENBLAS_CORETYPE)" \
        NUMBA_CPU_NAME=skylake-avx512
else
    run_variant "skylake-avx512 numba, OpenBLAS Prescott kernel" \
        NUMBA_CPU_NAME=skylake-avx512 OPENBLAS_CORETYPE=Prescott
fi
