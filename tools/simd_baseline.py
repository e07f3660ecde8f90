"""Prints, for NPY_DISABLE_CPU_FEATURES, the SIMD features numpy dispatches to on this machine above SSE4.2 and
AVX (AVX2, FMA3, the AVX-512 families...): the Python tier run again with them off computes its references
with another processor family's kernels, so a bound set on one machine's last digits fails here too. Only
features this machine has are named (numpy warns about the others)."""
from numpy.core import _multiarray_umath as umath

ABOVE = ("AVX2", "FMA3", "F16C", "AVX512")
print(" ".join(f for f in umath.__cpu_dispatch__ if umath.__cpu_features__.get(f) and f.startswith(ABOVE)))
