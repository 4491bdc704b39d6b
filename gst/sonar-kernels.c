/* sonar-kernels.c: see sonar-kernels.h. */
#include "sonar-kernels.h"

#include <math.h>

/* Re-seeding the rotation from double precision every this many bins keeps
 * float rounding from accumulating. */
#define RESEED_INTERVAL 64

static inline SonarComplex
unit_phasor (double phase)
{
  return (float) cos (phase) + I * (float) sin (phase);
}

void
sonar_kernel_steer_accumulate (SonarComplex * acc, const SonarComplex * x,
    guint n, double phase0, double dphase)
{
  const SonarComplex rotation = unit_phasor (dphase);

  for (guint k0 = 0; k0 < n; k0 += RESEED_INTERVAL) {
    const guint k1 = MIN (n, k0 + RESEED_INTERVAL);
    SonarComplex p = unit_phasor (phase0 + k0 * dphase);
    for (guint k = k0; k < k1; k++) {
      acc[k] += x[k] * p;
      p *= rotation;
    }
  }
}

void
sonar_kernel_steer_accumulate_conj (SonarComplex * acc,
    const SonarComplex * x, guint n, double phase0, double dphase)
{
  const SonarComplex rotation = unit_phasor (dphase);

  for (guint k0 = 0; k0 < n; k0 += RESEED_INTERVAL) {
    const guint k1 = MIN (n, k0 + RESEED_INTERVAL);
    SonarComplex p = unit_phasor (phase0 + k0 * dphase);
    for (guint k = k0; k < k1; k++) {
      acc[k] += conjf (x[k]) * p;
      p *= rotation;
    }
  }
}

SonarComplex
sonar_kernel_steer_dot_conj (const SonarComplex * a, const SonarComplex * b,
    guint n, double phase0, double dphase)
{
  const SonarComplex rotation = unit_phasor (dphase);
  SonarComplex sum = 0.0f;

  for (guint k0 = 0; k0 < n; k0 += RESEED_INTERVAL) {
    const guint k1 = MIN (n, k0 + RESEED_INTERVAL);
    SonarComplex p = unit_phasor (phase0 + k0 * dphase);
    for (guint k = k0; k < k1; k++) {
      sum += a[k] * conjf (b[k]) * p;
      p *= rotation;
    }
  }
  return sum;
}

void
sonar_kernel_multiply (SonarComplex * out, const SonarComplex * a,
    const SonarComplex * b, guint n)
{
  for (guint k = 0; k < n; k++)
    out[k] = a[k] * b[k];
}

void
sonar_kernel_envelope (float *out, const SonarComplex * x, guint n,
    float scale, gboolean accumulate)
{
  for (guint k = 0; k < n; k++) {
    const float re = crealf (x[k]), im = cimagf (x[k]);
    const float v = scale * sqrtf (re * re + im * im);
    out[k] = accumulate ? MAX (out[k], v) : v;
  }
}
