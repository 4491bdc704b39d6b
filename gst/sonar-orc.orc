# sonar-orc.orc: the kernels simple enough for ORC, which compiles them for
# the running CPU (SSE, AVX, NEON) or runs its C backup (ORC_CODE=backup).
# Interleaved complex arrays are pairs of floats: real in the low half of each 8-byte
# element, imaginary in the high half. sonar-kernels.c has the plain C
# reference of each; tests/test-kernels.c compares them.

# out = scale * |x|.
.function sonar_orc_envelope
.dest 4 out float
.source 8 x float
.floatparam 4 scale
.temp 8 sq
.temp 4 re
.temp 4 im
.temp 4 m

x2 mulf sq, x, x
splitql im, re, sq
addf m, re, im
sqrtf m, m
mulf out, m, scale

# out = max (out, scale * |x|).
.function sonar_orc_envelope_max
.dest 4 out float
.source 8 x float
.floatparam 4 scale
.temp 8 sq
.temp 4 re
.temp 4 im
.temp 4 m

x2 mulf sq, x, x
splitql im, re, sq
addf m, re, im
sqrtf m, m
mulf m, m, scale
maxf out, out, m
