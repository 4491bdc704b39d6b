/* sonar-kernels.h: the hot loops of the imaging chain.
 *
 * Each kernel has a plain scalar reference definition (_generic) and the
 * version the chain calls, written for the vectoriser: the phase ramp
 * advances in LANES independent lanes instead of one serial recurrence.
 * tests/test-kernels.c checks every fast kernel against its reference, as
 * VOLK does.
 */
#ifndef SONAR_KERNELS_H
#define SONAR_KERNELS_H

#include "sonar-spectrum.h"

G_BEGIN_DECLS

/* acc[k] += x[k] * exp(i (phase0 + k * dphase)), k < n: delaying a signal
 * by a time tau on a band is a phase ramp, phase = omega_k * tau. The
 * exponential is advanced by a rotation per bin (no sincos per bin),
 * re-seeded in double precision every 64 bins so that float rounding does
 * not accumulate. */
void sonar_kernel_steer_accumulate (SonarComplex * acc, const SonarComplex * x,
    guint n, double phase0, double dphase);
void sonar_kernel_steer_accumulate_generic (SonarComplex * acc,
    const SonarComplex * x, guint n, double phase0, double dphase);

/* Same with conj (x[k]): the matched filter's conjugated template. */
void sonar_kernel_steer_accumulate_conj (SonarComplex * acc,
    const SonarComplex * x, guint n, double phase0, double dphase);
void sonar_kernel_steer_accumulate_conj_generic (SonarComplex * acc,
    const SonarComplex * x, guint n, double phase0, double dphase);

/* sum over k < n of a[k] * conj (b[k]) * exp(i (phase0 + k * dphase)):
 * one output sample of a matched filter (template b) of a delayed signal
 * (a), without transforming the whole spectrum back. */
SonarComplex sonar_kernel_steer_dot_conj (const SonarComplex * a,
    const SonarComplex * b, guint n, double phase0, double dphase);
SonarComplex sonar_kernel_steer_dot_conj_generic (const SonarComplex * a,
    const SonarComplex * b, guint n, double phase0, double dphase);

/* out[k] = a[k] * b[k]. */
void sonar_kernel_multiply (SonarComplex * out, const SonarComplex * a,
    const SonarComplex * b, guint n);

/* out[k] = max (out[k], scale * |x[k]|) (or = when !accumulate). */
void sonar_kernel_envelope (float *out, const SonarComplex * x, guint n,
    float scale, gboolean accumulate);

G_END_DECLS

#endif
