/* sonar-kernels.h: the hot loops of the imaging chain, VOLK's way.
 *
 * Every kernel has a table of implementations (sonar_kernel_<name>_impls,
 * ended by an entry without a name): first its plain C reference,
 * "generic", always available; then the faster ones, each with a run-time
 * check of the CPU: "avx2" (AVX2 and FMA, written for the vectoriser: the
 * phase ramp advances in LANES independent lanes instead of one serial
 * recurrence), "avx512" after it where there is one (AVX-512F
 * intrinsics, 16 lanes a vector: steer_sum_split, scaled_product,
 * block8_sums_conj, rank_pass) or "orc" (an ORC program of sonar-orc.orc, which ORC
 * compiles for the running CPU or runs as its C backup). The kernel's
 * entry point, sonar_kernel_<name> (), calls the last implementation the
 * CPU has. tests/test-kernels.c checks every implementation the CPU has
 * against the reference and reports the others as skipped.
 */
#ifndef SONAR_KERNELS_H
#define SONAR_KERNELS_H

#include "sonar-spectrum.h"

G_BEGIN_DECLS

/* One implementation of a kernel of function type @Fn. */
#define SONAR_KERNEL_IMPL(Fn) \
  struct { const char *name; Fn fn; gboolean (*available) (void); }

/* out[k] = the sum over channels c < n_channels of x_c[k] * exp(i
 * (phase0[c] + k * dphase[c])), k < n, on split arrays (x_c[k] =
 * x_re[c * stride + k] + i x_im[c * stride + k], its conjugate when
 * @conj_x; out alike, overwritten): delaying a signal by a time tau on a
 * band is a phase ramp, phase = omega_k * tau, and a steering sum adds
 * one ramp per microphone (or emitter). Each exponential is advanced by a
 * rotation per bin (no sincos per bin), re-seeded every 64 bins so that
 * float rounding does not accumulate. Real and imaginary parts apart, the
 * vector code needs no shuffling of interleaved pairs (1.5x faster); the
 * avx2 version adds four channels per pass over the bins (the sums are
 * loaded and stored once for four: 1.7x faster than one at a time). The
 * avx512 version does 16 bins a vector and eight channels a pass, each
 * phasor its 64-bin chunk's seed (rotated in double from chunk to chunk)
 * times exp(i j dphase) from a table made once per call: one float
 * rotation from double precision, not a chain of them (1.8e-7 of the
 * sum of |x| from the double-precision sum, avx2 4.5e-7). CPU time per
 * call on this Xeon (best of 9 runs, shared machine): the imager's
 * receive sum, 32 microphones by 2883 bins, 13.0-13.1 us against avx2's
 * 18.8-19.1; the transmit table, 8 emitters by 5824 bins, 5.9-6.1 us
 * against 9.1-9.2 (1.5x). */
void sonar_kernel_steer_sum_split (float *out_re, float *out_im,
    const float *x_re, const float *x_im, gsize stride, guint n_channels,
    guint n, const double *phase0, const double *dphase, gboolean conj_x);
typedef void (*SonarSteerSumSplitFn) (float *out_re, float *out_im,
    const float *x_re, const float *x_im, gsize stride, guint n_channels,
    guint n, const double *phase0, const double *dphase, gboolean conj_x);
typedef SONAR_KERNEL_IMPL (SonarSteerSumSplitFn) SonarSteerSumSplitImpl;
extern const SonarSteerSumSplitImpl sonar_kernel_steer_sum_split_impls[];

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
typedef void (*SonarSteerBlockSumsConjFn) (SonarComplex * out,
    const float *a_re, const float *a_im, const float *b_re,
    const float *b_im, guint n, double phase0, double dphase, guint block);
typedef SONAR_KERNEL_IMPL (SonarSteerBlockSumsConjFn)
    SonarSteerBlockSumsConjImpl;
extern const SonarSteerBlockSumsConjImpl
    sonar_kernel_steer_block_sums_conj_impls[];

/* The bins of a block8 layout (sonar_kernel_block8_sums_conj ()): a
 * length padded to whole chunks of SONAR_BLOCK8_CHUNK bins, and the
 * index there of bin @k (in chunk c, bin t of its block j goes to
 * 64 c + 8 t + j). */
#define SONAR_BLOCK8_CHUNK 64
#define SONAR_BLOCK8_PADDED(n) \
  (((n) + SONAR_BLOCK8_CHUNK - 1) / SONAR_BLOCK8_CHUNK * SONAR_BLOCK8_CHUNK)
#define SONAR_BLOCK8_INDEX(k) \
  ((k) - ((k) & 63u) + (((k) & 7u) << 3) + (((k) >> 3) & 7u))

/* sonar_kernel_steer_block_sums_conj () by blocks of 8 bins, a and b in
 * the block8 layout (SONAR_BLOCK8_INDEX (); @n a multiple of
 * SONAR_BLOCK8_CHUNK, the bins past the data zero): writes n / 8 sums.
 * Each vector then holds one bin of eight blocks, whose sums build up in
 * its lanes: no sum across the lanes per block (that and its shuffles
 * cost as much as the products in the contiguous layout), and the phase
 * ramp rotates by one bin per step, re-seeded every chunk. The velocity
 * stage's gated blocks: it makes their spectra, so it lays them out so. */
void sonar_kernel_block8_sums_conj (SonarComplex * out, const float *a_re,
    const float *a_im, const float *b_re, const float *b_im, guint n,
    double phase0, double dphase);
typedef void (*SonarBlock8SumsConjFn) (SonarComplex * out,
    const float *a_re, const float *a_im, const float *b_re,
    const float *b_im, guint n, double phase0, double dphase);
typedef SONAR_KERNEL_IMPL (SonarBlock8SumsConjFn) SonarBlock8SumsConjImpl;
extern const SonarBlock8SumsConjImpl sonar_kernel_block8_sums_conj_impls[];

/* sum over k < n of x[k] * exp(i (phase0 + k * dphase)). */
SonarComplex sonar_kernel_steer_sum (const SonarComplex * x, guint n,
    double phase0, double dphase);
typedef SonarComplex (*SonarSteerSumFn) (const SonarComplex * x, guint n,
    double phase0, double dphase);
typedef SONAR_KERNEL_IMPL (SonarSteerSumFn) SonarSteerSumImpl;
extern const SonarSteerSumImpl sonar_kernel_steer_sum_impls[];

/* The phasors sonar_kernel_steer_sum () applies to bins 0 to @n - 1 for
 * @phase0 and @dphase, into @re and @im (n each), and that sum on them
 * (a SonarSteerSumPhasorsFn): its sum (x, re, im, n) is bit for bit
 * sonar_kernel_steer_sum (x, n, phase0, dphase) (each implementation
 * reproduces its own namesake's phasors and order of operations). A
 * caller that sums many inputs on one ramp (the velocity stage's lag
 * reads, whose ramps depend on the lag offset only) makes the phasors
 * once: the ramp's set-up (its sincos and reseeds) costs more than the
 * sum of a few dozen bins. */
void sonar_kernel_steer_phasors (float *re, float *im, guint n,
    double phase0, double dphase);
typedef void (*SonarSteerPhasorsFn) (float *re, float *im, guint n,
    double phase0, double dphase);
typedef SONAR_KERNEL_IMPL (SonarSteerPhasorsFn) SonarSteerPhasorsImpl;
extern const SonarSteerPhasorsImpl sonar_kernel_steer_phasors_impls[];

typedef SonarComplex (*SonarSteerSumPhasorsFn) (const SonarComplex * x,
    const float *re, const float *im, guint n);
typedef SONAR_KERNEL_IMPL (SonarSteerSumPhasorsFn) SonarSteerSumPhasorsImpl;
extern const SonarSteerSumPhasorsImpl sonar_kernel_steer_sum_phasors_impls[];

/* The sums of @x on @n_tables phasor tables (re[t], im[t], n each) into
 * out[t], bit for bit those of the SonarSteerSumPhasorsFn of the same
 * name on each table. The tables' sums run side by side: a lone sum
 * waits on its own chain of additions, and the velocity stage reads each
 * set of blocks at several lags. */
void sonar_kernel_steer_sums_phasors (SonarComplex * out,
    const SonarComplex * x, const float *const *re, const float *const *im,
    guint n_tables, guint n);
typedef void (*SonarSteerSumsPhasorsFn) (SonarComplex * out,
    const SonarComplex * x, const float *const *re, const float *const *im,
    guint n_tables, guint n);
typedef SONAR_KERNEL_IMPL (SonarSteerSumsPhasorsFn)
    SonarSteerSumsPhasorsImpl;
extern const SonarSteerSumsPhasorsImpl
    sonar_kernel_steer_sums_phasors_impls[];

/* out[k] = gain * exp(i (phase0 + k * dphase)) * (r_re[k] + i r_im[k]) *
 * V(x0 + k * step), k < n: V the 6-point Lagrange interpolation of the
 * split table (v_re, v_im) through v[floor (x) - 2 .. floor (x) + 3], all
 * of which the caller keeps inside the table. A Doppler hypothesis's
 * transmit sum is the zero-velocity one read at scaled frequencies
 * (sonar-steering.h, sonar_scaled_transmit_product ()): one interpolation
 * per bin instead of a sum over the emitters. The exponential advances by
 * a rotation per bin, re-seeded every 64 bins. The fast version reads a
 * vector's taps from contiguous loads when |step - 1| < 1/8 (over 8
 * bins the nodes then step by one a bin but once at most, by 0 or 2),
 * and gathers them otherwise (about 1.6 times as long). The AVX-512
 * version does 16 bins a vector, from loads (|step - 1| < 1/15), from
 * permutes of a 32-float window (step < 1.73) or gathers (up to 2; other
 * steps take the reference); its positions are float offsets from an
 * exact node (within 1e-6). */
void sonar_kernel_scaled_product (SonarComplex * out, const float *r_re,
    const float *r_im, const float *v_re, const float *v_im, guint n,
    double x0, double step, double phase0, double dphase, float gain);
typedef void (*SonarScaledProductFn) (SonarComplex * out, const float *r_re,
    const float *r_im, const float *v_re, const float *v_im, guint n,
    double x0, double step, double phase0, double dphase, float gain);
typedef SONAR_KERNEL_IMPL (SonarScaledProductFn) SonarScaledProductImpl;
extern const SonarScaledProductImpl sonar_kernel_scaled_product_impls[];

/* out[k] = max (out[k], scale * |x[k]|) (or = when !accumulate). */
void sonar_kernel_envelope (float *out, const SonarComplex * x, guint n,
    float scale, gboolean accumulate);
typedef void (*SonarEnvelopeFn) (float *out, const SonarComplex * x, guint n,
    float scale, gboolean accumulate);
typedef SONAR_KERNEL_IMPL (SonarEnvelopeFn) SonarEnvelopeImpl;
extern const SonarEnvelopeImpl sonar_kernel_envelope_impls[];

/* The largest of 0 and x[k] * w[k], k < n (of x[k] when @w is NULL); a
 * NaN never wins. The coarse image's peaks per zone and range block for
 * each hypothesis (sonar-imager.c): one chain of comparisons waits on
 * each, lanes of them do not. */
float sonar_kernel_peak (const float *x, const float *w, guint n);
typedef float (*SonarPeakFn) (const float *x, const float *w, guint n);
typedef SONAR_KERNEL_IMPL (SonarPeakFn) SonarPeakImpl;
extern const SonarPeakImpl sonar_kernel_peak_impls[];

/* out[b] = sonar_kernel_peak (x + b * block, NULL, the block's length)
 * for the ceil (n / block) blocks of @block values (the last takes what
 * is left): the coarse image's strongest hypothesis is kept per block of
 * range bins (sonar-imager.c), a hundred blocks a pass. */
void sonar_kernel_block_peaks (float *out, const float *x, guint n,
    guint block);
typedef void (*SonarBlockPeaksFn) (float *out, const float *x, guint n,
    guint block);
typedef SONAR_KERNEL_IMPL (SonarBlockPeaksFn) SonarBlockPeaksImpl;
extern const SonarBlockPeaksImpl sonar_kernel_block_peaks_impls[];

/* out[k] = max (out[k], x[k]) (out[k] > x[k] ? out[k] : x[k]), k < n. */
void sonar_kernel_max (float *out, const float *x, guint n);
typedef void (*SonarMaxFn) (float *out, const float *x, guint n);
typedef SONAR_KERNEL_IMPL (SonarMaxFn) SonarMaxImpl;
extern const SonarMaxImpl sonar_kernel_max_impls[];

/* out[k][i] = frames[i * stride + k], k < n_out, i < n: @n_out channels
 * of interleaved frames of @stride samples, each channel's samples made
 * contiguous, a non-finite sample written as 0 (one NaN would spread
 * over every bin of a spectrum). Returns how many were not finite. The
 * ping's deinterleaving before its spectra (sonar-spectrum.c): the fast
 * version transposes blocks of 8 frames of 8 channels in registers and
 * stores 8 samples of a channel at once where the reference stores one
 * (on a ping of 32 channels of 17262 frames 1.3 to 1.9 times faster;
 * the rest is memory traffic, the ping's 2.2 MB read and as much
 * written). */
guint sonar_kernel_deinterleave (float *const *out, guint n_out,
    const float *frames, gsize stride, gsize n);
typedef guint (*SonarDeinterleaveFn) (float *const *out, guint n_out,
    const float *frames, gsize stride, gsize n);
typedef SONAR_KERNEL_IMPL (SonarDeinterleaveFn) SonarDeinterleaveImpl;
extern const SonarDeinterleaveImpl sonar_kernel_deinterleave_impls[];

/* out[l] = the sum over i < n of x[i + l] * w[i], l < n_lags (@x holds
 * n + n_lags - 1 samples): @x's correlation with @w at @n_lags
 * consecutive lags. The direct path's fit (sonar-direct-path.c): each
 * emitter's waveform against a microphone's ping at the lags around its
 * path. The reference sums in double; the fast version in float lanes
 * (two vectors of 8 a lag: within 1e-6 of the sum of |x w| over a
 * waveform's 4000 samples). */
void sonar_kernel_correlate (float *out, const float *x, const float *w,
    guint n, guint n_lags);
typedef void (*SonarCorrelateFn) (float *out, const float *x,
    const float *w, guint n, guint n_lags);
typedef SONAR_KERNEL_IMPL (SonarCorrelateFn) SonarCorrelateImpl;
extern const SonarCorrelateImpl sonar_kernel_correlate_impls[];

/* y[i] += a * x[i], i < n: the direct path's subtraction, a tap of a
 * waveform at a time (the fast version may fuse the product and the sum:
 * within a rounding of the reference). */
void sonar_kernel_axpy (float *y, const float *x, float a, guint n);
typedef void (*SonarAxpyFn) (float *y, const float *x, float a, guint n);
typedef SONAR_KERNEL_IMPL (SonarAxpyFn) SonarAxpyImpl;
extern const SonarAxpyImpl sonar_kernel_axpy_impls[];

/* Lanes of sonar_kernel_rank_pass (): a block of range bins. */
#define SONAR_RANK_LANES 16

/* Per lane j < SONAR_RANK_LANES, over the rows r < n_rows (lane j of row
 * r at x[r * stride + j]): below[j] = how many are below level[j];
 * under[j] and under[SONAR_RANK_LANES + j] the largest and second largest
 * of those (-inf for none), over[j] and over[SONAR_RANK_LANES + j] the
 * smallest and second smallest of the others, at or above it (+inf for
 * none); a NaN counts in neither. When @finite is not NULL, finite[j] =
 * how many are finite. One pass of wardcluster's order statistics over a
 * block of range bins (a lane each; the directions are its rows): with
 * the count below a level, the two values either side of it are the
 * elements of four ranks, and a few levels find the element of any rank
 * (sonar-cluster.c), with no copy of the columns. */
void sonar_kernel_rank_pass (const float *x, gsize stride, guint n_rows,
    const float *level, guint32 * below, float *under, float *over,
    guint32 * finite);
typedef void (*SonarRankPassFn) (const float *x, gsize stride,
    guint n_rows, const float *level, guint32 * below, float *under,
    float *over, guint32 * finite);
typedef SONAR_KERNEL_IMPL (SonarRankPassFn) SonarRankPassImpl;
extern const SonarRankPassImpl sonar_kernel_rank_pass_impls[];

G_END_DECLS

#endif
