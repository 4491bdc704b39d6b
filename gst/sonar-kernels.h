/* sonar-kernels.h: the hot loops of the imaging chain.
 *
 * Each kernel has a plain scalar reference definition (_generic) and the
 * version the chain calls, written for the vectoriser: the phase ramp
 * advances in LANES independent lanes instead of one serial recurrence.
 * The simplest (complex products, envelopes) are ORC programs
 * (sonar-orc.orc), compiled for the running CPU. tests/test-kernels.c
 * checks every fast kernel against its reference, as VOLK does.
 */
#ifndef SONAR_KERNELS_H
#define SONAR_KERNELS_H

#include "sonar-spectrum.h"

G_BEGIN_DECLS

/* acc[k] += x[k] * exp(i (phase0 + k * dphase)), k < n, on split arrays
 * (x[k] = x_re[k] + i x_im[k], its conjugate when @conj_x; acc alike):
 * delaying a signal by a time tau on a band is a phase ramp, phase =
 * omega_k * tau. The exponential is advanced by a rotation per bin (no
 * sincos per bin), re-seeded every 64 bins so that float rounding does
 * not accumulate. Real and imaginary parts apart, the vector code needs
 * no shuffling of interleaved pairs (1.5x faster). */
void sonar_kernel_steer_accumulate_split (float *acc_re, float *acc_im,
    const float *x_re, const float *x_im, guint n, double phase0,
    double dphase, gboolean conj_x);
void sonar_kernel_steer_accumulate_split_generic (float *acc_re,
    float *acc_im, const float *x_re, const float *x_im, guint n,
    double phase0, double dphase, gboolean conj_x);

/* re[k] = creal (x[k]), im[k] = cimag (x[k]). */
void sonar_kernel_split (float *re, float *im, const SonarComplex * x,
    gsize n);

/* out[i] = the sum over the bins k of block i (block bins from i * block;
 * the last block takes what is left) of a[k] * conj (b[k]) * exp(i
 * (phase0 + k * dphase)), a and b split (a[k] = a_re[k] + i a_im[k]):
 * writes ceil (n / block) sums. @block divides 64 and is a multiple of
 * 8. A matched filter's output at lags near the one the phase ramp
 * delays to is then a short sum over the blocks (see
 * sonar_kernel_steer_sum): over a block the extra phase of a small lag
 * offset barely turns. */
void sonar_kernel_steer_block_sums_conj (SonarComplex * out,
    const float *a_re, const float *a_im, const float *b_re,
    const float *b_im, guint n, double phase0, double dphase, guint block);
void sonar_kernel_steer_block_sums_conj_generic (SonarComplex * out,
    const float *a_re, const float *a_im, const float *b_re,
    const float *b_im, guint n, double phase0, double dphase, guint block);

/* sum over k < n of x[k] * exp(i (phase0 + k * dphase)). */
SonarComplex sonar_kernel_steer_sum (const SonarComplex * x, guint n,
    double phase0, double dphase);
SonarComplex sonar_kernel_steer_sum_generic (const SonarComplex * x, guint n,
    double phase0, double dphase);

/* out[k] = (a_re[k] + i a_im[k]) (b_re[k] + i b_im[k]): split operands,
 * interleaved product. An ORC kernel (sonar-orc.orc). */
void sonar_kernel_multiply_split (SonarComplex * out, const float *a_re,
    const float *a_im, const float *b_re, const float *b_im, guint n);
void sonar_kernel_multiply_split_generic (SonarComplex * out,
    const float *a_re, const float *a_im, const float *b_re,
    const float *b_im, guint n);

/* out[k] = max (out[k], scale * |x[k]|) (or = when !accumulate). An ORC
 * kernel. */
void sonar_kernel_envelope (float *out, const SonarComplex * x, guint n,
    float scale, gboolean accumulate);
void sonar_kernel_envelope_generic (float *out, const SonarComplex * x,
    guint n, float scale, gboolean accumulate);

G_END_DECLS

#endif
