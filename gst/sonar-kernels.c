/* sonar-kernels.c: see sonar-kernels.h. Built with -O3 (gst/meson.build)
 * so that the lane loops are vectorised. */
#include "sonar-kernels.h"
#include "sonar-orc.h"

#include <orc/orc.h>

#include <math.h>
#include <string.h>

/* Re-seeding the rotation from double precision every this many bins keeps
 * float rounding from accumulating. */
#define RESEED_INTERVAL 64
/* Independent phase lanes of the fast kernels: one AVX register of floats,
 * two SSE registers. RESEED_INTERVAL is a multiple of it. */
#define LANES 8

static inline SonarComplex
unit_phasor (double phase)
{
  return (float) cos (phase) + I * (float) sin (phase);
}

/* References -------------------------------------------------------------*/

/* acc[k] += x[k] * exp(i (phase0 + k * dphase)), one channel. */
static void
steer_accumulate_generic (float *acc_re, float *acc_im,
    const float *x_re, const float *x_im, guint n, double phase0,
    double dphase, gboolean conj_x)
{
  const SonarComplex rotation = unit_phasor (dphase);
  const float sign = conj_x ? -1.0f : 1.0f;

  for (guint k0 = 0; k0 < n; k0 += RESEED_INTERVAL) {
    const guint k1 = MIN (n, k0 + RESEED_INTERVAL);
    SonarComplex p = unit_phasor (phase0 + k0 * dphase);
    for (guint k = k0; k < k1; k++) {
      const SonarComplex y = (x_re[k] + I * sign * x_im[k]) * p;
      acc_re[k] += crealf (y);
      acc_im[k] += cimagf (y);
      p *= rotation;
    }
  }
}

static void
steer_sum_split_generic (float *out_re, float *out_im, const float *x_re,
    const float *x_im, gsize stride, guint n_channels, guint n,
    const double *phase0, const double *dphase, gboolean conj_x)
{
  memset (out_re, 0, sizeof (float) * n);
  memset (out_im, 0, sizeof (float) * n);
  for (guint c = 0; c < n_channels; c++)
    steer_accumulate_generic (out_re, out_im, x_re + c * stride,
        x_im + c * stride, n, phase0[c], dphase[c], conj_x);
}

void
sonar_kernel_split (float *re, float *im, const SonarComplex * x, gsize n)
{
  for (gsize k = 0; k < n; k++) {
    re[k] = crealf (x[k]);
    im[k] = cimagf (x[k]);
  }
}

static void
steer_block_sums_conj_generic (SonarComplex * out,
    const float *a_re, const float *a_im, const float *b_re,
    const float *b_im, guint n, double phase0, double dphase, guint block)
{
  const SonarComplex rotation = unit_phasor (dphase);

  g_return_if_fail (block % LANES == 0 && RESEED_INTERVAL % block == 0);
  for (guint k0 = 0; k0 < n; k0 += RESEED_INTERVAL) {
    const guint k1 = MIN (n, k0 + RESEED_INTERVAL);
    SonarComplex p = unit_phasor (phase0 + k0 * dphase);
    for (guint k = k0; k < k1; k++) {
      if (k % block == 0)
        out[k / block] = 0.0f;
      out[k / block] += (a_re[k] + I * a_im[k]) * (b_re[k] - I * b_im[k]) *
          p;
      p *= rotation;
    }
  }
}

/* Bin by bin in their order, each read where the block8 layout holds it. */
G_STATIC_ASSERT (SONAR_BLOCK8_CHUNK == RESEED_INTERVAL
    && RESEED_INTERVAL == 8 * LANES);
static void
block8_sums_conj_generic (SonarComplex * out, const float *a_re,
    const float *a_im, const float *b_re, const float *b_im, guint n,
    double phase0, double dphase)
{
  const SonarComplex rotation = unit_phasor (dphase);

  for (guint k0 = 0; k0 < n; k0 += RESEED_INTERVAL) {
    SonarComplex p = unit_phasor (phase0 + k0 * dphase);
    for (guint k = k0; k < k0 + RESEED_INTERVAL; k++) {
      const guint i = SONAR_BLOCK8_INDEX (k);
      if (k % 8 == 0)
        out[k / 8] = 0.0f;
      out[k / 8] += (a_re[i] + I * a_im[i]) * (b_re[i] - I * b_im[i]) * p;
      p *= rotation;
    }
  }
}

static SonarComplex
steer_sum_generic (const SonarComplex * x, guint n,
    double phase0, double dphase)
{
  const SonarComplex rotation = unit_phasor (dphase);
  SonarComplex sum = 0.0f;

  for (guint k0 = 0; k0 < n; k0 += RESEED_INTERVAL) {
    const guint k1 = MIN (n, k0 + RESEED_INTERVAL);
    SonarComplex p = unit_phasor (phase0 + k0 * dphase);
    for (guint k = k0; k < k1; k++) {
      sum += x[k] * p;
      p *= rotation;
    }
  }
  return sum;
}

/* steer_sum_generic ()'s phasors, bin by bin. */
static void
steer_phasors_generic (float *re, float *im, guint n, double phase0,
    double dphase)
{
  const SonarComplex rotation = unit_phasor (dphase);

  for (guint k0 = 0; k0 < n; k0 += RESEED_INTERVAL) {
    const guint k1 = MIN (n, k0 + RESEED_INTERVAL);
    SonarComplex p = unit_phasor (phase0 + k0 * dphase);
    for (guint k = k0; k < k1; k++) {
      re[k] = crealf (p);
      im[k] = cimagf (p);
      p *= rotation;
    }
  }
}

/* steer_sum_generic () on the phasors of steer_phasors_generic (). */
static SonarComplex
steer_sum_phasors_generic (const SonarComplex * x, const float *re,
    const float *im, guint n)
{
  SonarComplex sum = 0.0f;

  for (guint k = 0; k < n; k++)
    sum += x[k] * CMPLXF (re[k], im[k]);
  return sum;
}

static void
steer_sums_phasors_generic (SonarComplex * out, const SonarComplex * x,
    const float *const *re, const float *const *im, guint n_tables, guint n)
{
  for (guint t = 0; t < n_tables; t++)
    out[t] = steer_sum_phasors_generic (x, re[t], im[t], n);
}

/* The weights of 6-point Lagrange interpolation at @f in [0, 1) through
 * the nodes -2 .. 3: w[t] = prod over m != t of (f - m) / (t - m), from
 * the products of the factors before and after each node. */
static inline void
lagrange6_weights (float f, float w[6])
{
  const float d[6] = { f + 2.0f, f + 1.0f, f, f - 1.0f, f - 2.0f, f - 3.0f };
  /* prod over m != t of (t - m), t = -2 .. 3. */
  static const float denominator[6] = { -120.0f, 24.0f, -12.0f, 12.0f,
    -24.0f, 120.0f
  };
  float before[6], after = 1.0f;

  before[0] = 1.0f;
  for (guint t = 1; t < 6; t++)
    before[t] = before[t - 1] * d[t - 1];
  for (int t = 5; t >= 0; t--) {
    w[t] = before[t] * after / denominator[t];
    after *= d[t];
  }
}

static void
scaled_product_generic (SonarComplex * out, const float *r_re,
    const float *r_im, const float *v_re, const float *v_im, guint n,
    double x0, double step, double phase0, double dphase, float gain)
{
  const SonarComplex rotation = unit_phasor (dphase);

  for (guint k0 = 0; k0 < n; k0 += RESEED_INTERVAL) {
    const guint k1 = MIN (n, k0 + RESEED_INTERVAL);
    SonarComplex p = gain * unit_phasor (phase0 + k0 * dphase);
    for (guint k = k0; k < k1; k++) {
      const double x = x0 + k * step;
      const double node = floor (x);
      const gsize i = (gsize) node - 2;
      float w[6];
      SonarComplex v = 0.0f;

      lagrange6_weights ((float) (x - node), w);
      for (guint t = 0; t < 6; t++)
        v += w[t] * (v_re[i + t] + I * v_im[i + t]);
      out[k] = (r_re[k] + I * r_im[k]) * v * p;
      p *= rotation;
    }
  }
}

/* Not inlined into the vector versions' tails: compiled there, for a CPU
 * with FMA, a compiler that contracts across statements (clang at
 * -ffp-contract=fast) fused re * re into the sum, and a tail's envelope
 * moved by an ulp from the reference's (the datacube's maximum was not
 * the detection image bit for bit, /elements/datacube). */
static __attribute__ ((noinline)) void
envelope_generic (float *out, const SonarComplex * x, guint n,
    float scale, gboolean accumulate)
{
  for (guint k = 0; k < n; k++) {
    const float re = crealf (x[k]), im = cimagf (x[k]);
    const float v = scale * sqrtf (re * re + im * im);
    out[k] = accumulate ? MAX (out[k], v) : v;
  }
}

static float
peak_generic (const float *x, const float *w, guint n)
{
  float top = 0.0f;

  for (guint k = 0; k < n; k++) {
    const float v = w ? x[k] * w[k] : x[k];
    top = v > top ? v : top;
  }
  return top;
}

static void
block_peaks_generic (float *out, const float *x, guint n, guint block)
{
  for (guint b = 0; (gsize) b * block < n; b++)
    out[b] = peak_generic (x + (gsize) b * block, NULL, MIN (block,
            n - b * block));
}

static void
max_generic (float *out, const float *x, guint n)
{
  for (guint k = 0; k < n; k++)
    out[k] = MAX (out[k], x[k]);
}

static void
correlate_generic (float *out, const float *x, const float *w, guint n,
    guint n_lags)
{
  for (guint l = 0; l < n_lags; l++) {
    double sum = 0.0;
    for (guint i = 0; i < n; i++)
      sum += (double) x[i + l] * w[i];
    out[l] = (float) sum;
  }
}

static void
axpy_generic (float *y, const float *x, float a, guint n)
{
  for (guint i = 0; i < n; i++)
    y[i] += a * x[i];
}

static void
rank_pass_generic (const float *x, gsize stride, guint n_rows,
    const float *level, guint32 * below, float *under, float *over,
    guint32 * finite)
{
  const guint L = SONAR_RANK_LANES;

  for (guint j = 0; j < L; j++) {
    below[j] = 0;
    under[j] = under[L + j] = -INFINITY;
    over[j] = over[L + j] = INFINITY;
    if (finite)
      finite[j] = 0;
  }
  for (guint r = 0; r < n_rows; r++) {
    const float *row = x + r * stride;
    for (guint j = 0; j < L; j++) {
      const float v = row[j];
      if (v < level[j]) {
        below[j]++;
        if (v > under[j]) {
          under[L + j] = under[j];
          under[j] = v;
        } else if (v > under[L + j]) {
          under[L + j] = v;
        }
      } else if (v >= level[j]) {
        if (v < over[j]) {
          over[L + j] = over[j];
          over[j] = v;
        } else if (v < over[L + j]) {
          over[L + j] = v;
        }
      }
      if (finite)
        finite[j] += isfinite (v) ? 1 : 0;
    }
  }
}

/* Frames @from to @to of sonar_kernel_deinterleave (): the reference,
 * and the fast versions' edges. */
static inline guint
deinterleave_frames (float *const *out, guint n_out, const float *frames,
    gsize stride, gsize from, gsize to)
{
  guint bad = 0;

  for (gsize i = from; i < to; i++) {
    const float *frame = frames + i * stride;
    for (guint k = 0; k < n_out; k++) {
      const float x = frame[k];
      if (G_LIKELY (isfinite (x)))
        out[k][i] = x;
      else {
        out[k][i] = 0.0f;
        bad++;
      }
    }
  }
  return bad;
}

static guint
deinterleave_generic (float *const *out, guint n_out, const float *frames,
    gsize stride, gsize n)
{
  return deinterleave_frames (out, n_out, frames, stride, 0, n);
}

/* AVX2 versions ----------------------------------------------------------*/

/* The lane kernels are compiled for AVX2 and FMA, for the CPUs that have
 * them; elsewhere the references run (the lane code emulated on 128-bit
 * SSE2 is slower than the scalar reference). */
#if defined(__x86_64__) && defined(__GNUC__)
#define HAVE_AVX2_KERNELS 1
#define AVX2_TARGET __attribute__ ((target ("avx2,fma")))
#define AVX512_TARGET __attribute__ ((target ("avx512f")))
#include <immintrin.h>

/* Lane l holds the phasor of bin k0 + l; one step moves every lane LANES
 * bins on. Vectors of LANES floats hold real and imaginary parts apart, so
 * a complex product is four multiplies and two adds per lane. */
typedef float Vec __attribute__ ((vector_size (LANES * sizeof (float))));

/* The seeds of successive reseeds come from a rotation in double
 * precision, not from a sincos each: over a spectrum's few dozen reseeds
 * its rounding stays near 1e-15, and the sincos calls cost as much as the
 * bins between them. A ramp takes two sincos in all (its start and its
 * step); the rotations by LANES and RESEED_INTERVAL bins are powers of
 * the step, and the bins after the last whole vector read the lanes. */
typedef struct
{
  Vec re, im;
  double offset_re[LANES], offset_im[LANES];    /* exp(i l dphase) */
  float step_re, step_im;       /* rotation by LANES bins */
  double seed_re, seed_im;      /* exp(i phase) of the next reseed's bin */
  double jump_re, jump_im;      /* rotation by RESEED_INTERVAL bins */
} Lanes;

/* Lanes for a ramp starting at @phase0. */
static inline void
lanes_init (Lanes * p, double phase0, double dphase)
{
  const double c = cos (dphase), s = sin (dphase);

  p->offset_re[0] = 1.0;
  p->offset_im[0] = 0.0;
  for (int l = 1; l < LANES; l++) {
    p->offset_re[l] = p->offset_re[l - 1] * c - p->offset_im[l - 1] * s;
    p->offset_im[l] = p->offset_re[l - 1] * s + p->offset_im[l - 1] * c;
  }
  /* exp(i LANES dphase), then squared up to exp(i RESEED_INTERVAL dphase). */
  p->jump_re = p->offset_re[LANES - 1] * c - p->offset_im[LANES - 1] * s;
  p->jump_im = p->offset_re[LANES - 1] * s + p->offset_im[LANES - 1] * c;
  p->step_re = (float) p->jump_re;
  p->step_im = (float) p->jump_im;
  for (int k = LANES; k < RESEED_INTERVAL; k *= 2) {
    const double re = p->jump_re * p->jump_re - p->jump_im * p->jump_im;
    p->jump_im = 2.0 * p->jump_re * p->jump_im;
    p->jump_re = re;
  }
  p->seed_re = cos (phase0);
  p->seed_im = sin (phase0);
}

/* Lane l = exp(i (phase + l dphase)) at the next reseed's bin (every
 * RESEED_INTERVAL bins from the first): the lanes in double vectors, four
 * at a time (lane by lane, in scalar code, a receive sum's reseeds took
 * nearly as many operations as its sums). */
static inline AVX2_TARGET void
lanes_seed (Lanes * p)
{
  const double c = p->seed_re, s = p->seed_im;
  const __m256d c4 = _mm256_set1_pd (c), s4 = _mm256_set1_pd (s);
  __m128 re[2], im[2];

  for (int h = 0; h < 2; h++) {
    const __m256d o_re = _mm256_loadu_pd (p->offset_re + 4 * h);
    const __m256d o_im = _mm256_loadu_pd (p->offset_im + 4 * h);
    re[h] = _mm256_cvtpd_ps (_mm256_fmsub_pd (c4, o_re, _mm256_mul_pd (s4,
                o_im)));
    im[h] = _mm256_cvtpd_ps (_mm256_fmadd_pd (c4, o_im, _mm256_mul_pd (s4,
                o_re)));
  }
  p->re = (Vec) _mm256_set_m128 (re[1], re[0]);
  p->im = (Vec) _mm256_set_m128 (im[1], im[0]);
  p->seed_re = c * p->jump_re - s * p->jump_im;
  p->seed_im = c * p->jump_im + s * p->jump_re;
}

/* The phasor of bin @k, after the whole vectors up to bin @whole: lane
 * (k - whole) % LANES, the lanes moved on every LANES bins (and seeded
 * first when @whole starts a reseed interval, the last vector having
 * ended one). */
#define LANES_TAIL_PHASOR(p, k, whole) ({                                 \
  const guint t_ = (k) - (whole);                                        \
  if (t_ == 0 && (whole) % RESEED_INTERVAL == 0)                         \
    lanes_seed (&(p));                                                   \
  else if (t_ > 0 && t_ % LANES == 0)                                    \
    LANES_ADVANCE (p);                                                   \
  (p).re[t_ % LANES] + I * (p).im[t_ % LANES];                           \
})

/* The vector helpers are macros, not functions: a function compiled for the
 * baseline would not be inlined into the AVX2 clones. */

/* The sum of the lanes of (@re, @im) as a complex number, by halves: a
 * block's sum is made once per block, and a sum lane by lane (two chains
 * of 8 dependent additions) took longer than a block of 8 or 16 bins. */
#define LANES_SUM(re, im) ({                                             \
  const Vec h_ = __builtin_shufflevector ((re), (im), 0, 1, 2, 3, 8, 9,  \
      10, 11) + __builtin_shufflevector ((re), (im), 4, 5, 6, 7, 12, 13, \
      14, 15);                                                           \
  const Vec q_ = h_ + __builtin_shufflevector (h_, h_, 2, 3, 0, 1, 6, 7, \
      4, 5);                                                             \
  const Vec e_ = q_ + __builtin_shufflevector (q_, q_, 1, 0, 3, 2, 5, 4, \
      7, 6);                                                             \
  (SonarComplex) (e_[0] + I * e_[4]);                                    \
})

/* Every lane moves LANES bins on. */
#define LANES_ADVANCE(p) G_STMT_START {                                 \
  const Vec re_ = (p).re * (p).step_re - (p).im * (p).step_im;          \
  (p).im = (p).re * (p).step_im + (p).im * (p).step_re;                 \
  (p).re = re_;                                                         \
} G_STMT_END

/* LANES complex values at x, as real and imaginary vectors. */
#define LOAD_SPLIT(x, re, im) G_STMT_START {                            \
  Vec a_, b_;                                                           \
  memcpy (&a_, (x), sizeof a_);                                         \
  memcpy (&b_, (x) + LANES / 2, sizeof b_);                             \
  (re) = __builtin_shufflevector (a_, b_, 0, 2, 4, 6, 8, 10, 12, 14);    \
  (im) = __builtin_shufflevector (a_, b_, 1, 3, 5, 7, 9, 11, 13, 15);   \
} G_STMT_END


/* out (= when @first, else +=) the @group (1 to 4, a constant where it is
 * inlined) channels' ramps: the sums are loaded and stored once per
 * vector for the group, the phasors of its channels held in registers. */
static inline __attribute__ ((always_inline)) AVX2_TARGET void
steer_group_avx2 (float *out_re, float *out_im, const float *x_re,
    const float *x_im, gsize stride, const guint group, guint n,
    const double *phase0, const double *dphase, float sign, gboolean first)
{
  const guint whole = n - n % LANES;
  Lanes p[4];

  for (guint g = 0; g < group; g++)
    lanes_init (&p[g], phase0[g], dphase[g]);
  for (guint k0 = 0; k0 < whole; k0 += RESEED_INTERVAL) {
    const guint k1 = MIN (whole, k0 + RESEED_INTERVAL);
    for (guint g = 0; g < group; g++)
      lanes_seed (&p[g]);
    for (guint k = k0; k < k1; k += LANES) {
      Vec ar = { 0 }, ai = { 0 };
      if (!first) {
        memcpy (&ar, out_re + k, sizeof ar);
        memcpy (&ai, out_im + k, sizeof ai);
      }
      for (guint g = 0; g < group; g++) {
        Vec xr, xi;
        memcpy (&xr, x_re + g * stride + k, sizeof xr);
        memcpy (&xi, x_im + g * stride + k, sizeof xi);
        xi *= sign;
        ar += xr * p[g].re - xi * p[g].im;
        ai += xr * p[g].im + xi * p[g].re;
        LANES_ADVANCE (p[g]);
      }
      memcpy (out_re + k, &ar, sizeof ar);
      memcpy (out_im + k, &ai, sizeof ai);
    }
  }
  for (guint k = whole; k < n; k++) {
    if (first)
      out_re[k] = out_im[k] = 0.0f;
  }
  for (guint g = 0; g < group; g++)
    for (guint k = whole; k < n; k++) {
      const SonarComplex y = (x_re[g * stride + k] + I * sign *
          x_im[g * stride + k]) * LANES_TAIL_PHASOR (p[g], k, whole);
      out_re[k] += crealf (y);
      out_im[k] += cimagf (y);
    }
}

AVX2_TARGET static void
steer_sum_split_avx2 (float *out_re, float *out_im, const float *x_re,
    const float *x_im, gsize stride, guint n_channels, guint n,
    const double *phase0, const double *dphase, gboolean conj_x)
{
  const float sign = conj_x ? -1.0f : 1.0f;

  if (n_channels == 0) {
    memset (out_re, 0, sizeof (float) * n);
    memset (out_im, 0, sizeof (float) * n);
  }
  for (guint c = 0; c < n_channels; c += 4) {
    const float *re = x_re + c * stride, *im = x_im + c * stride;
    switch (MIN (4, n_channels - c)) {
      case 4:
        steer_group_avx2 (out_re, out_im, re, im, stride, 4, n, phase0 + c,
            dphase + c, sign, c == 0);
        break;
      case 3:
        steer_group_avx2 (out_re, out_im, re, im, stride, 3, n, phase0 + c,
            dphase + c, sign, c == 0);
        break;
      case 2:
        steer_group_avx2 (out_re, out_im, re, im, stride, 2, n, phase0 + c,
            dphase + c, sign, c == 0);
        break;
      default:
        steer_group_avx2 (out_re, out_im, re, im, stride, 1, n, phase0 + c,
            dphase + c, sign, c == 0);
        break;
    }
  }
}

/* The last, shorter block of steer_block_sums_conj_avx2 (): the sum of
 * (a_re + i a_im) conj (b_re + i b_im) (lane_re + i lane_im) over @n
 * bins, spelt out as GCC compiled its complex products when this block
 * was inline ((x + 0 y) for x + I y, the first product fused, the
 * second not), so that the block sums stay bit for bit what they were
 * then: an inline loop's fusing changes with the code around it. */
#if defined(__clang__)
#define NO_CONTRACT
#else
#define NO_CONTRACT __attribute__ ((optimize ("fp-contract=off")))
#endif
static AVX2_TARGET NO_CONTRACT __attribute__ ((noinline)) SonarComplex
block_tail_avx2 (const float *a_re, const float *a_im, const float *b_re,
    const float *b_im, const float *lane_re, const float *lane_im, guint n)
{
  float sum_re = 0.0f, sum_im = 0.0f;

  for (guint k = 0; k < n; k++) {
    const float are = fmaf (a_im[k], 0.0f, a_re[k]);
    const float bre = fmaf (-b_im[k], 0.0f, b_re[k]);
    const float tre = fmaf (bre, are, a_im[k] * b_im[k]);
    const float tim = fmaf (-are, b_im[k], a_im[k] * bre);
    const float pre = fmaf (lane_im[k], 0.0f, lane_re[k]);
    sum_re += tre * pre - tim * lane_im[k];
    sum_im += tre * lane_im[k] + tim * pre;
  }
  return CMPLXF (sum_re, sum_im);
}

/* Block sums: the lane products are summed over a block, then across the
 * lanes. */
AVX2_TARGET static void
steer_block_sums_conj_avx2 (SonarComplex * out, const float *a_re,
    const float *a_im, const float *b_re, const float *b_im, guint n,
    double phase0, double dphase, guint block)
{
  const guint whole = n - n % block;
  Lanes p;

  lanes_init (&p, phase0, dphase);
  for (guint k0 = 0; k0 < whole; k0 += RESEED_INTERVAL) {
    const guint k1 = MIN (whole, k0 + RESEED_INTERVAL);
    lanes_seed (&p);
    for (guint kb = k0; kb < k1; kb += block) {
      Vec sum_re = { 0 }, sum_im = { 0 };
      for (guint k = kb; k < kb + block; k += LANES) {
        Vec ar, ai, br, bi, tr, ti;
        memcpy (&ar, a_re + k, sizeof ar);
        memcpy (&ai, a_im + k, sizeof ai);
        memcpy (&br, b_re + k, sizeof br);
        memcpy (&bi, b_im + k, sizeof bi);
        tr = ar * br + ai * bi;
        ti = ai * br - ar * bi;
        sum_re += tr * p.re - ti * p.im;
        sum_im += tr * p.im + ti * p.re;
        LANES_ADVANCE (p);
      }
      out[kb / block] = LANES_SUM (sum_re, sum_im);
    }
  }
  /* The last, shorter block. */
  if (whole < n) {
    float lane_re[RESEED_INTERVAL], lane_im[RESEED_INTERVAL];
    for (guint t = 0; t < n - whole; t++) {
      if (t == 0 && whole % RESEED_INTERVAL == 0)
        lanes_seed (&p);
      else if (t > 0 && t % LANES == 0)
        LANES_ADVANCE (p);
      lane_re[t] = p.re[t % LANES];
      lane_im[t] = p.im[t % LANES];
    }
    out[whole / block] = block_tail_avx2 (a_re + whole, a_im + whole,
        b_re + whole, b_im + whole, lane_re, lane_im, n - whole);
  }
}

/* Half a Vec in float and in double: the lanes' seeds, in two halves. */
typedef float Vec4f __attribute__ ((vector_size (LANES / 2 * sizeof (float))));
typedef double Vec4d
    __attribute__ ((vector_size (LANES / 2 * sizeof (double))));

/* exp(i 8 x) from (cos x, sin x) in (*re, *im), by squaring. */
static inline void
power8 (double *re, double *im)
{
  for (int q = 1; q < 8; q *= 2) {
    const double r = *re * *re - *im * *im;
    *im = 2.0 * *re * *im;
    *re = r;
  }
}

/* Lane j holds block j of a chunk: bin 8 j + t at step t. The lanes'
 * phasors are seeded at every chunk from seeds kept in double precision
 * (exp(i (phase0 + 8 j dphase)) at first, rotated a chunk on each time)
 * and rotated by one bin in float over the chunk's 8 steps: the float
 * rounding of 8 rotations, and double's over the chunks (near 1e-15),
 * for the vector work of a rotation per chunk (a seed per lane from a
 * sincos cost as much as the chunk's products). */
AVX2_TARGET static void
block8_sums_conj_avx2 (SonarComplex * out, const float *a_re,
    const float *a_im, const float *b_re, const float *b_im, guint n,
    double phase0, double dphase)
{
  const double c = cos (dphase), s = sin (dphase);
  const float step_re = (float) c, step_im = (float) s;
  double c8 = c, s8 = s, chunk_re, chunk_im;
  double lane_re = cos (phase0), lane_im = sin (phase0);
  Vec4d seed_re[2], seed_im[2];

  power8 (&c8, &s8);
  chunk_re = c8;
  chunk_im = s8;
  power8 (&chunk_re, &chunk_im);
  for (int j = 0; j < LANES; j++) {
    const double re = lane_re * c8 - lane_im * s8;
    seed_re[j / 4][j % 4] = lane_re;
    seed_im[j / 4][j % 4] = lane_im;
    lane_im = lane_re * s8 + lane_im * c8;
    lane_re = re;
  }

  for (guint k0 = 0; k0 < n; k0 += RESEED_INTERVAL) {
    Vec pr = __builtin_shufflevector (__builtin_convertvector (seed_re[0],
            Vec4f), __builtin_convertvector (seed_re[1], Vec4f), 0, 1, 2, 3,
        4, 5, 6, 7);
    Vec pi = __builtin_shufflevector (__builtin_convertvector (seed_im[0],
            Vec4f), __builtin_convertvector (seed_im[1], Vec4f), 0, 1, 2, 3,
        4, 5, 6, 7);
    Vec sum_re = { 0 }, sum_im = { 0 };
    for (int h = 0; h < 2; h++) {
      const Vec4d re = seed_re[h] * chunk_re - seed_im[h] * chunk_im;
      seed_im[h] = seed_re[h] * chunk_im + seed_im[h] * chunk_re;
      seed_re[h] = re;
    }
    for (guint k = k0; k < k0 + RESEED_INTERVAL; k += LANES) {
      Vec ar, ai, br, bi, tr, ti, next;
      memcpy (&ar, a_re + k, sizeof ar);
      memcpy (&ai, a_im + k, sizeof ai);
      memcpy (&br, b_re + k, sizeof br);
      memcpy (&bi, b_im + k, sizeof bi);
      tr = ar * br + ai * bi;
      ti = ai * br - ar * bi;
      /* Each term a fused multiply-add into its sum. */
      sum_re += tr * pr;
      sum_re -= ti * pi;
      sum_im += tr * pi;
      sum_im += ti * pr;
      next = pr * step_re - pi * step_im;
      pi = pr * step_im + pi * step_re;
      pr = next;
    }
    {
      /* The eight sums, interleaved. */
      const Vec first = __builtin_shufflevector (sum_re, sum_im, 0, 8, 1, 9,
          2, 10, 3, 11);
      const Vec second = __builtin_shufflevector (sum_re, sum_im, 4, 12, 5,
          13, 6, 14, 7, 15);
      memcpy (out + k0 / LANES, &first, sizeof first);
      memcpy (out + k0 / LANES + LANES / 2, &second, sizeof second);
    }
  }
}

/* The steering sum's pieces, shared by steer_sum_avx2 () and the sum on
 * a phasor table (steer_phasors_avx2 (), steer_sum_phasors_avx2 ()), so
 * that the two are the same operations bit for bit whatever the compiler
 * fuses: not inlined, each compiled once. */

/* Lanes for a ramp from @phase0. */
static AVX2_TARGET __attribute__ ((noinline)) void
ramp_start_avx2 (Lanes * p, double phase0, double dphase)
{
  lanes_init (p, phase0, dphase);
}

/* The phasors of the @count (a multiple of LANES, at most
 * RESEED_INTERVAL) bins from a reseed into @re, @im. */
static AVX2_TARGET __attribute__ ((noinline)) void
ramp_fill_avx2 (Lanes * p, float *re, float *im, guint count)
{
  lanes_seed (p);
  for (guint k = 0; k < count; k += LANES) {
    memcpy (re + k, &p->re, sizeof p->re);
    memcpy (im + k, &p->im, sizeof p->im);
    LANES_ADVANCE (*p);
  }
}

/* The phasors of the bins @whole to @n - 1 after the whole vectors. */
static AVX2_TARGET __attribute__ ((noinline)) void
ramp_tail_avx2 (Lanes * p, float *re, float *im, guint whole, guint n)
{
  for (guint k = whole; k < n; k++) {
    const SonarComplex phasor = LANES_TAIL_PHASOR (*p, k, whole);
    re[k - whole] = crealf (phasor);
    im[k - whole] = cimagf (phasor);
  }
}

/* (@sum_re, @sum_im) += the lane products of @count (a multiple of
 * LANES) values of @x and phasors. */
static AVX2_TARGET __attribute__ ((noinline)) void
ramp_accumulate_avx2 (Vec * sum_re, Vec * sum_im, const SonarComplex * x,
    const float *re, const float *im, guint count)
{
  for (guint k = 0; k < count; k += LANES) {
    Vec xr, xi, pr, pi;
    LOAD_SPLIT (x + k, xr, xi);
    memcpy (&pr, re + k, sizeof pr);
    memcpy (&pi, im + k, sizeof pi);
    *sum_re += xr * pr - xi * pi;
    *sum_im += xr * pi + xi * pr;
  }
}

/* The lanes' sum (by halves: lane by lane took a chain of 8 dependent
 * additions per table read), then the @count tail values of @x on their
 * phasors. The lanes come by address: taken by value, in 256-bit
 * registers, the function returned with their upper halves set (gcc puts
 * no vzeroupper where 256-bit values may be live across the call or the
 * return), and every SSE instruction of its callers' callers (the
 * velocity stage's scalar code, libm's log and exp) then waited on those
 * halves: the velocity stage took 2.2-2.6 times its CPU time. By address
 * gcc ends it with its vzeroupper, as every other kernel here
 * (tests/test-kernels.c's upper-clean cases check them all). */
static AVX2_TARGET __attribute__ ((noinline)) SonarComplex
ramp_finish_avx2 (const Vec * sum_re, const Vec * sum_im,
    const SonarComplex * x, const float *re, const float *im, guint count)
{
  SonarComplex sum = LANES_SUM (*sum_re, *sum_im);

  for (guint k = 0; k < count; k++)
    sum += x[k] * (re[k] + I * im[k]);
  return sum;
}

AVX2_TARGET static SonarComplex
steer_sum_avx2 (const SonarComplex * x, guint n, double phase0,
    double dphase)
{
  const guint whole = n - n % LANES;
  float re[RESEED_INTERVAL], im[RESEED_INTERVAL];
  Vec sum_re = { 0 }, sum_im = { 0 };
  Lanes p;

  ramp_start_avx2 (&p, phase0, dphase);
  for (guint k0 = 0; k0 < whole; k0 += RESEED_INTERVAL) {
    const guint count = MIN (whole, k0 + RESEED_INTERVAL) - k0;
    ramp_fill_avx2 (&p, re, im, count);
    ramp_accumulate_avx2 (&sum_re, &sum_im, x + k0, re, im, count);
  }
  ramp_tail_avx2 (&p, re, im, whole, n);
  return ramp_finish_avx2 (&sum_re, &sum_im, x + whole, re, im, n - whole);
}

/* steer_sum_avx2 ()'s phasors. */
AVX2_TARGET static void
steer_phasors_avx2 (float *re, float *im, guint n, double phase0,
    double dphase)
{
  const guint whole = n - n % LANES;
  Lanes p;

  ramp_start_avx2 (&p, phase0, dphase);
  for (guint k0 = 0; k0 < whole; k0 += RESEED_INTERVAL)
    ramp_fill_avx2 (&p, re + k0, im + k0, MIN (whole, k0 +
            RESEED_INTERVAL) - k0);
  ramp_tail_avx2 (&p, re + whole, im + whole, whole, n);
}

/* steer_sum_avx2 () on the phasors of steer_phasors_avx2 (). */
AVX2_TARGET static SonarComplex
steer_sum_phasors_avx2 (const SonarComplex * x, const float *re,
    const float *im, guint n)
{
  const guint whole = n - n % LANES;
  Vec sum_re = { 0 }, sum_im = { 0 };

  ramp_accumulate_avx2 (&sum_re, &sum_im, x, re, im, whole);
  return ramp_finish_avx2 (&sum_re, &sum_im, x + whole, re + whole,
      im + whole, n - whole);
}

/* ramp_accumulate_avx2 () from zero on @group (1 to 4, a constant where
 * it is inlined) tables at once, @x loaded once for the group: each
 * table's sums spelt as there, which the compiler fuses alike
 * (tests/test-kernels.c compares the two bit for bit). */
static inline __attribute__ ((always_inline)) AVX2_TARGET void
ramp_accumulate_group_avx2 (Vec * sum_re, Vec * sum_im,
    const SonarComplex * x, const float *const *re, const float *const *im,
    const guint group, guint count)
{
  Vec acc_re[4], acc_im[4];

  for (guint g = 0; g < group; g++) {
    acc_re[g] = (Vec) { 0 };
    acc_im[g] = (Vec) { 0 };
  }
  for (guint k = 0; k < count; k += LANES) {
    Vec xr, xi;
    LOAD_SPLIT (x + k, xr, xi);
    for (guint g = 0; g < group; g++) {
      Vec pr, pi;
      memcpy (&pr, re[g] + k, sizeof pr);
      memcpy (&pi, im[g] + k, sizeof pi);
      acc_re[g] += xr * pr - xi * pi;
      acc_im[g] += xr * pi + xi * pr;
    }
  }
  for (guint g = 0; g < group; g++) {
    sum_re[g] = acc_re[g];
    sum_im[g] = acc_im[g];
  }
}

/* steer_sum_phasors_avx2 () on each table, four tables a pass. */
AVX2_TARGET static void
steer_sums_phasors_avx2 (SonarComplex * out, const SonarComplex * x,
    const float *const *re, const float *const *im, guint n_tables, guint n)
{
  const guint whole = n - n % LANES;

  for (guint t = 0; t < n_tables; t += 4) {
    const guint group = MIN (4, n_tables - t);
    Vec sum_re[4], sum_im[4];
    switch (group) {
      case 4:
        ramp_accumulate_group_avx2 (sum_re, sum_im, x, re + t, im + t, 4,
            whole);
        break;
      case 3:
        ramp_accumulate_group_avx2 (sum_re, sum_im, x, re + t, im + t, 3,
            whole);
        break;
      case 2:
        ramp_accumulate_group_avx2 (sum_re, sum_im, x, re + t, im + t, 2,
            whole);
        break;
      default:
        ramp_accumulate_group_avx2 (sum_re, sum_im, x, re + t, im + t, 1,
            whole);
        break;
    }
    /* Without a tail ramp_finish_avx2 () is the lanes' sum alone, whose
     * additions nothing can fuse: inline, the same numbers without a call
     * per table (the velocity stage's gated blocks fill whole vectors). */
    for (guint g = 0; g < group; g++)
      out[t + g] = whole == n ? LANES_SUM (sum_re[g], sum_im[g]) :
          ramp_finish_avx2 (&sum_re[g], &sum_im[g], x + whole, re[t + g] +
          whole, im[t + g] + whole, n - whole);
  }
}

/* x0 + k step as the reference rounds it, not fused into one FMA (which
 * -ffp-contract=fast would do here): the same positions, so the same
 * nodes, whose taps the caller checked are inside the table. */
#define POSITION_UNFUSED(x0, k, step) ({                                  \
  __typeof__ ((k) * (step)) product_ = (k) * (step);                     \
  __asm__ ("" : "+x" (product_));                                        \
  (x0) + product_;                                                       \
})

/* scaled_product_generic () by vectors of LANES bins. Lane l's node is
 * node_0 + l + delta_l; when every delta_l is lo or lo + 1 (lo = 0 for
 * step >= 1, -1 below; so whenever |step - 1| < 1/8), the taps come from
 * seven unaligned loads L_j = v[node_0 - 2 + lo + j + l], j = 0 .. 6,
 * lane l weighting L_j by w_j (delta lo) or w_(j-1) (delta lo + 1): the
 * weights are chosen, once for both parts, not the taps. Only the lanes
 * of one kind have a tap in L_0 (in L_6): masked loads, so that nothing
 * outside the taps is read (a lane not loaded reads 0, times a finite
 * weight). When every lane has the same delta, six plain loads and the
 * weights as they are (no choice, no masked load). Other vectors gather
 * their taps, 12 gathers (slower). */
AVX2_TARGET static void
scaled_product_avx2 (SonarComplex * out, const float *r_re,
    const float *r_im, const float *v_re, const float *v_im, guint n,
    double x0, double step, double phase0, double dphase, float gain)
{
  const guint whole = n - n % LANES;
  const int lo = step >= 1.0 ? 0 : -1;
  const __m256d step_d = _mm256_set1_pd (step), x0_d = _mm256_set1_pd (x0);
  const __m256d lanes_first = _mm256_setr_pd (0.0, 1.0, 2.0, 3.0);
  const __m256d lanes_second = _mm256_setr_pd (4.0, 5.0, 6.0, 7.0);
  const __m256i lane_index = _mm256_setr_epi32 (0, 1, 2, 3, 4, 5, 6, 7);
  const __m256i delta_lo = _mm256_set1_epi32 (lo);
  const __m256i delta_hi = _mm256_set1_epi32 (lo + 1);
  __m256 step_re, step_im;
  float tail_gain = 1.0f;       /* the lanes hold gain times the phasors */
  Lanes p;

  /* The nodes are int32 lanes: a table past 2^30 (never, in practice)
   * takes the reference. */
  if (n > 0 && !(fmax (x0, x0 + (n - 1) * step) < (double) (1 << 30))) {
    scaled_product_generic (out, r_re, r_im, v_re, v_im, n, x0, step, phase0,
        dphase, gain);
    return;
  }
  lanes_init (&p, phase0, dphase);
  step_re = _mm256_set1_ps (p.step_re);
  step_im = _mm256_set1_ps (p.step_im);
  for (guint k0 = 0; k0 < whole; k0 += RESEED_INTERVAL) {
    const guint k1 = MIN (whole, k0 + RESEED_INTERVAL);
    __m256 phasor_re, phasor_im;
    lanes_seed (&p);
    /* The phasors times gain, in registers: in the struct, each vector's
     * rotation waited on a store and a load. */
    phasor_re = _mm256_mul_ps ((__m256) p.re, _mm256_set1_ps (gain));
    phasor_im = _mm256_mul_ps ((__m256) p.im, _mm256_set1_ps (gain));
    for (guint k = k0; k < k1; k += LANES) {
      const __m256d k_d = _mm256_set1_pd ((double) k);
      const __m256d x_first = POSITION_UNFUSED (x0_d,
          _mm256_add_pd (k_d, lanes_first), step_d);
      const __m256d x_second = POSITION_UNFUSED (x0_d,
          _mm256_add_pd (k_d, lanes_second), step_d);
      const __m256d node_first = _mm256_floor_pd (x_first);
      const __m256d node_second = _mm256_floor_pd (x_second);
      const __m256 f = _mm256_set_m128 (_mm256_cvtpd_ps (_mm256_sub_pd
              (x_second, node_second)), _mm256_cvtpd_ps (_mm256_sub_pd
              (x_first, node_first)));
      const __m256i node = _mm256_set_m128i (_mm256_cvttpd_epi32
          (node_second), _mm256_cvttpd_epi32 (node_first));
      const int node0 = _mm_cvtsi128_si32 (_mm256_castsi256_si128 (node));
      const __m256i delta = _mm256_sub_epi32 (_mm256_sub_epi32 (node,
              _mm256_set1_epi32 (node0)), lane_index);
      const __m256i is_lo = _mm256_cmpeq_epi32 (delta, delta_lo);
      const __m256i is_hi = _mm256_cmpeq_epi32 (delta, delta_hi);
      __m256 w[6], sum_re, sum_im, rr, ri, tr, ti, out_re, out_im, low,
          high, next_re;
      int lo_lanes, hi_lanes;

      /* lagrange6_weights (), lane by lane, in fewer operations (the
       * vector's time goes in its arithmetic): the factors (f - m) by
       * pairs as fused quadratics, 1 / denominator folded into one. */
      {
        const __m256 d01 = _mm256_fmadd_ps (f, _mm256_add_ps (f,
                _mm256_set1_ps (3.0f)), _mm256_set1_ps (2.0f));
        const __m256 d23 = _mm256_fmsub_ps (f, f, f);
        const __m256 d45 = _mm256_fmadd_ps (f, _mm256_sub_ps (f,
                _mm256_set1_ps (5.0f)), _mm256_set1_ps (6.0f));
        const __m256 d0123 = _mm256_mul_ps (d01, d23);
        const __m256 d2345 = _mm256_mul_ps (d23, d45);
        /* c_t (f - m) for c_t = 1 / prod over m' != t of (t - m'). */
#define SCALED_FACTOR(m, c) \
  _mm256_fmadd_ps (f, _mm256_set1_ps (c), _mm256_set1_ps (-(m) * (c)))
        w[0] = _mm256_mul_ps (SCALED_FACTOR (-1, -1.0f / 120.0f), d2345);
        w[1] = _mm256_mul_ps (SCALED_FACTOR (-2, 1.0f / 24.0f), d2345);
        w[2] = _mm256_mul_ps (d01, _mm256_mul_ps (SCALED_FACTOR (1,
                    -1.0f / 12.0f), d45));
        w[3] = _mm256_mul_ps (d01, _mm256_mul_ps (SCALED_FACTOR (0,
                    1.0f / 12.0f), d45));
        w[4] = _mm256_mul_ps (d0123, SCALED_FACTOR (3, -1.0f / 24.0f));
        w[5] = _mm256_mul_ps (d0123, SCALED_FACTOR (2, 1.0f / 120.0f));
#undef SCALED_FACTOR
      }

      /* Each tap into the sums as it is loaded: tap arrays held across
       * the two ways were kept in memory. */
      lo_lanes = _mm256_movemask_ps (_mm256_castsi256_ps (is_lo));
      hi_lanes = _mm256_movemask_ps (_mm256_castsi256_ps (is_hi));
      if (lo_lanes == 0xff || hi_lanes == 0xff) {
        /* Every lane's node at node_0 + l + delta, one delta: tap t of
         * every lane in one plain load, its weight as it is (most vectors
         * when |step - 1| is small). */
        const int delta0 = hi_lanes == 0xff ? lo + 1 : lo;
        const float *base_re = v_re + (node0 - 2 + delta0);
        const float *base_im = v_im + (node0 - 2 + delta0);
        sum_re = _mm256_mul_ps (w[0], _mm256_loadu_ps (base_re));
        sum_im = _mm256_mul_ps (w[0], _mm256_loadu_ps (base_im));
        for (int t = 1; t < 6; t++) {
          sum_re = _mm256_fmadd_ps (w[t], _mm256_loadu_ps (base_re + t),
              sum_re);
          sum_im = _mm256_fmadd_ps (w[t], _mm256_loadu_ps (base_im + t),
              sum_im);
        }
      } else if ((lo_lanes | hi_lanes) == 0xff) {
        const float *base_re = v_re + (node0 - 2 + lo);
        const float *base_im = v_im + (node0 - 2 + lo);
        /* 1 in the lanes of node_0 + l + lo + 1, 0 in the others: a
         * weight's choice as one fused multiply-add, which took less time
         * than a blend (vblendvps). */
        const __m256 hi = _mm256_and_ps (_mm256_castsi256_ps (is_hi),
            _mm256_set1_ps (1.0f));
        sum_re = _mm256_mul_ps (w[0], _mm256_maskload_ps (base_re, is_lo));
        sum_im = _mm256_mul_ps (w[0], _mm256_maskload_ps (base_im, is_lo));
        for (int j = 1; j < 6; j++) {
          const __m256 weight = _mm256_fmadd_ps (hi, _mm256_sub_ps (w[j - 1],
                  w[j]), w[j]);
          sum_re = _mm256_fmadd_ps (weight, _mm256_loadu_ps (base_re + j),
              sum_re);
          sum_im = _mm256_fmadd_ps (weight, _mm256_loadu_ps (base_im + j),
              sum_im);
        }
        sum_re = _mm256_fmadd_ps (w[5], _mm256_maskload_ps (base_re + 6,
                is_hi), sum_re);
        sum_im = _mm256_fmadd_ps (w[5], _mm256_maskload_ps (base_im + 6,
                is_hi), sum_im);
      } else {
        sum_re = sum_im = _mm256_setzero_ps ();
        for (int t = 0; t < 6; t++) {
          const __m256i index = _mm256_add_epi32 (node,
              _mm256_set1_epi32 (t - 2));
          sum_re = _mm256_fmadd_ps (w[t], _mm256_i32gather_ps (v_re, index,
                  4), sum_re);
          sum_im = _mm256_fmadd_ps (w[t], _mm256_i32gather_ps (v_im, index,
                  4), sum_im);
        }
      }

      /* (r V) (gain phasor), as the reference groups it. */
      rr = _mm256_loadu_ps (r_re + k);
      ri = _mm256_loadu_ps (r_im + k);
      tr = _mm256_fmsub_ps (rr, sum_re, _mm256_mul_ps (ri, sum_im));
      ti = _mm256_fmadd_ps (rr, sum_im, _mm256_mul_ps (ri, sum_re));
      out_re = _mm256_fmsub_ps (tr, phasor_re, _mm256_mul_ps (ti,
              phasor_im));
      out_im = _mm256_fmadd_ps (tr, phasor_im, _mm256_mul_ps (ti,
              phasor_re));
      /* Interleaved: bins 0 1 4 5 and 2 3 6 7, then in order. */
      low = _mm256_unpacklo_ps (out_re, out_im);
      high = _mm256_unpackhi_ps (out_re, out_im);
      _mm256_storeu_ps ((float *) (out + k), _mm256_permute2f128_ps (low,
              high, 0x20));
      _mm256_storeu_ps ((float *) (out + k + LANES / 2),
          _mm256_permute2f128_ps (low, high, 0x31));
      /* LANES_ADVANCE (). */
      next_re = _mm256_fmsub_ps (phasor_re, step_re, _mm256_mul_ps
          (phasor_im, step_im));
      phasor_im = _mm256_fmadd_ps (phasor_re, step_im, _mm256_mul_ps
          (phasor_im, step_re));
      phasor_re = next_re;
    }
    p.re = (Vec) phasor_re;
    p.im = (Vec) phasor_im;
  }
  /* The bins after the whole vectors, as the reference does them, on
   * the lanes' phasors: times gain after the vectors, seeded if a
   * reseed's bin starts them. The gain is applied in scalar: a vector
   * product there left the upper halves set at the return (gcc put no
   * vzeroupper on the way out without a tail; tests/test_vzeroupper.py). */
  if (whole < n && whole % RESEED_INTERVAL == 0) {
    lanes_seed (&p);
    tail_gain = gain;
  }
  for (guint k = whole; k < n; k++) {
    const SonarComplex phasor = tail_gain * (p.re[k - whole] + I *
        p.im[k - whole]);
    const double x = POSITION_UNFUSED (x0, (double) k, step);
    const double node = floor (x);
    const gsize i = (gsize) node - 2;
    float wt[6];
    SonarComplex v = 0.0f;

    lagrange6_weights ((float) (x - node), wt);
    for (guint t = 0; t < 6; t++)
      v += wt[t] * (v_re[i + t] + I * v_im[i + t]);
    out[k] = (r_re[k] + I * r_im[k]) * v * phasor;
  }
}

/* _mm256_max_ps (a, b) is a > b ? a : b lane by lane: with the new
 * values first a NaN never wins, with the kept ones first it is
 * max_generic (). Two vectors of lanes: a comparison's latency is a few
 * cycles, its throughput two a cycle. */
AVX2_TARGET static float
peak_avx2 (const float *x, const float *w, guint n)
{
  const guint whole = n - n % (2 * LANES);
  __m256 top0 = _mm256_setzero_ps (), top1 = _mm256_setzero_ps ();
  float lanes[LANES], top;

  if (w) {
    for (guint k = 0; k < whole; k += 2 * LANES) {
      top0 = _mm256_max_ps (_mm256_mul_ps (_mm256_loadu_ps (x + k),
              _mm256_loadu_ps (w + k)), top0);
      top1 = _mm256_max_ps (_mm256_mul_ps (_mm256_loadu_ps (x + k + LANES),
              _mm256_loadu_ps (w + k + LANES)), top1);
    }
  } else {
    for (guint k = 0; k < whole; k += 2 * LANES) {
      top0 = _mm256_max_ps (_mm256_loadu_ps (x + k), top0);
      top1 = _mm256_max_ps (_mm256_loadu_ps (x + k + LANES), top1);
    }
  }
  _mm256_storeu_ps (lanes, _mm256_max_ps (top0, top1));
  top = peak_generic (x + whole, w ? w + whole : NULL, n - whole);
  for (guint l = 0; l < LANES; l++)
    top = lanes[l] > top ? lanes[l] : top;
  return top;
}

/* Each block's lanes, then across them: after the first maximum with 0
 * no NaN is left, and a maximum is exact in any order. */
AVX2_TARGET static void
block_peaks_avx2 (float *out, const float *x, guint n, guint block)
{
  guint b = 0;

  if (block % LANES == 0) {
    for (; (gsize) (b + 1) * block <= n; b++) {
      __m256 top = _mm256_setzero_ps ();
      for (guint k = b * block; k < (b + 1) * block; k += LANES)
        top = _mm256_max_ps (_mm256_loadu_ps (x + k), top);
      top = _mm256_max_ps (top, _mm256_permute2f128_ps (top, top, 1));
      top = _mm256_max_ps (top, _mm256_shuffle_ps (top, top,
              _MM_SHUFFLE (1, 0, 3, 2)));
      top = _mm256_max_ps (top, _mm256_shuffle_ps (top, top,
              _MM_SHUFFLE (2, 3, 0, 1)));
      out[b] = _mm_cvtss_f32 (_mm256_castps256_ps128 (top));
    }
  }
  block_peaks_generic (out + b, x + (gsize) b * block, n - b * block, block);
}

/* LANES bins from two vectors of interleaved pairs: hadd sums each pair
 * (im^2 + re^2: the reference's sum, unfused, which IEEE addition gives
 * alike in either order) two pairs per half, and a permute puts the
 * halves' pairs back in bin order. */
AVX2_TARGET static void
envelope_avx2 (float *out, const SonarComplex * x, guint n, float scale,
    gboolean accumulate)
{
  const float *f = (const float *) x;
  const __m256 s = _mm256_set1_ps (scale);
  const guint whole = n - n % LANES;

  for (guint k = 0; k < whole; k += LANES) {
    const __m256 a = _mm256_loadu_ps (f + 2 * k);
    const __m256 b = _mm256_loadu_ps (f + 2 * k + LANES);
    __m256 m = _mm256_hadd_ps (_mm256_mul_ps (a, a), _mm256_mul_ps (b, b));
    m = _mm256_castpd_ps (_mm256_permute4x64_pd (_mm256_castps_pd (m),
            _MM_SHUFFLE (3, 1, 2, 0)));
    m = _mm256_mul_ps (s, _mm256_sqrt_ps (m));
    if (accumulate)
      m = _mm256_max_ps (_mm256_loadu_ps (out + k), m);
    _mm256_storeu_ps (out + k, m);
  }
  envelope_generic (out + whole, x + whole, n - whole, scale, accumulate);
}

AVX2_TARGET static void
max_avx2 (float *out, const float *x, guint n)
{
  const guint whole = n - n % LANES;

  for (guint k = 0; k < whole; k += LANES)
    _mm256_storeu_ps (out + k, _mm256_max_ps (_mm256_loadu_ps (out + k),
            _mm256_loadu_ps (x + k)));
  max_generic (out + whole, x + whole, n - whole);
}

/* rank_pass_generic () on two vectors of lanes a row: the comparisons
 * are ordered (false for a NaN), a lane's count goes up by subtracting
 * its mask (-1), and the values kept are blended with -inf or +inf, then
 * sorted into the two largest (smallest) by a max and a min each. */
G_STATIC_ASSERT (SONAR_RANK_LANES == 2 * LANES);
AVX2_TARGET static void
rank_pass_avx2 (const float *x, gsize stride, guint n_rows,
    const float *level, guint32 * below, float *under, float *over,
    guint32 * finite)
{
  const __m256 minus_inf = _mm256_set1_ps (-INFINITY);
  const __m256 plus_inf = _mm256_set1_ps (INFINITY);
  const __m256 abs_mask = _mm256_castsi256_ps (_mm256_set1_epi32
      (0x7fffffff));
  const __m256 l0 = _mm256_loadu_ps (level);
  const __m256 l1 = _mm256_loadu_ps (level + LANES);
  __m256i b0 = _mm256_setzero_si256 (), b1 = _mm256_setzero_si256 ();
  __m256i f0 = _mm256_setzero_si256 (), f1 = _mm256_setzero_si256 ();
  __m256 u0 = minus_inf, u1 = minus_inf, o0 = plus_inf, o1 = plus_inf;
  __m256 uu0 = minus_inf, uu1 = minus_inf, oo0 = plus_inf, oo1 = plus_inf;

  for (guint r = 0; r < n_rows; r++) {
    const float *row = x + r * stride;
    const __m256 v0 = _mm256_loadu_ps (row);
    const __m256 v1 = _mm256_loadu_ps (row + LANES);
    const __m256 lt0 = _mm256_cmp_ps (v0, l0, _CMP_LT_OQ);
    const __m256 lt1 = _mm256_cmp_ps (v1, l1, _CMP_LT_OQ);
    const __m256 ge0 = _mm256_cmp_ps (v0, l0, _CMP_GE_OQ);
    const __m256 ge1 = _mm256_cmp_ps (v1, l1, _CMP_GE_OQ);
    const __m256 below0 = _mm256_blendv_ps (minus_inf, v0, lt0);
    const __m256 below1 = _mm256_blendv_ps (minus_inf, v1, lt1);
    const __m256 above0 = _mm256_blendv_ps (plus_inf, v0, ge0);
    const __m256 above1 = _mm256_blendv_ps (plus_inf, v1, ge1);
    b0 = _mm256_sub_epi32 (b0, _mm256_castps_si256 (lt0));
    b1 = _mm256_sub_epi32 (b1, _mm256_castps_si256 (lt1));
    uu0 = _mm256_max_ps (uu0, _mm256_min_ps (u0, below0));
    uu1 = _mm256_max_ps (uu1, _mm256_min_ps (u1, below1));
    u0 = _mm256_max_ps (u0, below0);
    u1 = _mm256_max_ps (u1, below1);
    oo0 = _mm256_min_ps (oo0, _mm256_max_ps (o0, above0));
    oo1 = _mm256_min_ps (oo1, _mm256_max_ps (o1, above1));
    o0 = _mm256_min_ps (o0, above0);
    o1 = _mm256_min_ps (o1, above1);
    if (finite) {
      f0 = _mm256_sub_epi32 (f0, _mm256_castps_si256 (_mm256_cmp_ps
              (_mm256_and_ps (v0, abs_mask), plus_inf, _CMP_LT_OQ)));
      f1 = _mm256_sub_epi32 (f1, _mm256_castps_si256 (_mm256_cmp_ps
              (_mm256_and_ps (v1, abs_mask), plus_inf, _CMP_LT_OQ)));
    }
  }
  _mm256_storeu_si256 ((__m256i *) below, b0);
  _mm256_storeu_si256 ((__m256i *) (below + LANES), b1);
  _mm256_storeu_ps (under, u0);
  _mm256_storeu_ps (under + LANES, u1);
  _mm256_storeu_ps (under + 2 * LANES, uu0);
  _mm256_storeu_ps (under + 3 * LANES, uu1);
  _mm256_storeu_ps (over, o0);
  _mm256_storeu_ps (over + LANES, o1);
  _mm256_storeu_ps (over + 2 * LANES, oo0);
  _mm256_storeu_ps (over + 3 * LANES, oo1);
  if (finite) {
    _mm256_storeu_si256 ((__m256i *) finite, f0);
    _mm256_storeu_si256 ((__m256i *) (finite + LANES), f1);
  }
}

/* rank_pass_generic () on AVX-512: the sixteen lanes in one vector, the
 * comparisons into masks that select which lanes each count, maximum and
 * minimum take (no blends: a third of rank_pass_avx2 ()'s operations);
 * two sets of sums on alternate rows, merged at the end, so that each
 * row does not wait on the last one's maxima. */
G_STATIC_ASSERT (SONAR_RANK_LANES == 16);

/* One row into a set of sums. */
#define RANK_ROW_AVX512(v, b, u, uu, o, oo, f) G_STMT_START {           \
  const __mmask16 lt_ = _mm512_cmp_ps_mask ((v), l, _CMP_LT_OQ);        \
  const __mmask16 ge_ = _mm512_cmp_ps_mask ((v), l, _CMP_GE_OQ);        \
  (b) = _mm512_mask_add_epi32 ((b), lt_, (b), one);                     \
  (uu) = _mm512_mask_max_ps ((uu), lt_, (uu), _mm512_min_ps ((u), (v))); \
  (u) = _mm512_mask_max_ps ((u), lt_, (u), (v));                        \
  (oo) = _mm512_mask_min_ps ((oo), ge_, (oo), _mm512_max_ps ((o), (v))); \
  (o) = _mm512_mask_min_ps ((o), ge_, (o), (v));                        \
  if (finite)                                                           \
    (f) = _mm512_mask_add_epi32 ((f), _mm512_cmp_ps_mask                \
        (_mm512_abs_ps (v), plus_inf, _CMP_LT_OQ), (f), one);           \
} G_STMT_END

AVX512_TARGET static void
rank_pass_avx512 (const float *x, gsize stride, guint n_rows,
    const float *level, guint32 * below, float *under, float *over,
    guint32 * finite)
{
  const __m512 minus_inf = _mm512_set1_ps (-INFINITY);
  const __m512 plus_inf = _mm512_set1_ps (INFINITY);
  const __m512i one = _mm512_set1_epi32 (1);
  const __m512 l = _mm512_loadu_ps (level);
  __m512i b0 = _mm512_setzero_si512 (), b1 = _mm512_setzero_si512 ();
  __m512i f0 = _mm512_setzero_si512 (), f1 = _mm512_setzero_si512 ();
  __m512 u0 = minus_inf, u1 = minus_inf, uu0 = minus_inf, uu1 = minus_inf;
  __m512 o0 = plus_inf, o1 = plus_inf, oo0 = plus_inf, oo1 = plus_inf;
  guint r = 0;

  for (; r + 2 <= n_rows; r += 2) {
    const __m512 v0 = _mm512_loadu_ps (x + r * stride);
    const __m512 v1 = _mm512_loadu_ps (x + (r + 1) * stride);
    RANK_ROW_AVX512 (v0, b0, u0, uu0, o0, oo0, f0);
    RANK_ROW_AVX512 (v1, b1, u1, uu1, o1, oo1, f1);
  }
  if (r < n_rows) {
    const __m512 v0 = _mm512_loadu_ps (x + r * stride);
    RANK_ROW_AVX512 (v0, b0, u0, uu0, o0, oo0, f0);
  }
  /* The two largest of both sets: the larger largest, and the larger of
   * the smaller largest and both second largest (the smallest alike). */
  _mm512_storeu_si512 (below, _mm512_add_epi32 (b0, b1));
  _mm512_storeu_ps (under, _mm512_max_ps (u0, u1));
  _mm512_storeu_ps (under + 16, _mm512_max_ps (_mm512_min_ps (u0, u1),
          _mm512_max_ps (uu0, uu1)));
  _mm512_storeu_ps (over, _mm512_min_ps (o0, o1));
  _mm512_storeu_ps (over + 16, _mm512_min_ps (_mm512_max_ps (o0, o1),
          _mm512_min_ps (oo0, oo1)));
  if (finite)
    _mm512_storeu_si512 (finite, _mm512_add_epi32 (f0, f1));
}

#undef RANK_ROW_AVX512

/* scaled_product_generic () by vectors of 16 bins. Bin k0 + l is at
 * base + l step, base = x0 + k0 step; with node_0 = floor (base) and fb =
 * base - node_0 (exact, as the reference computes them), lane l's node is
 * node_0 + l + delta_l, delta_l = floor (s_l), and its fraction s_l -
 * delta_l, s_l = fb + l (step - 1) in float: a few operations for the 16
 * positions, within 1e-6 of the exact ones (the excess l (step - 1) is
 * small). A lane within that of a node may take the node next to it with
 * a fraction near 1 (near 0): the same value, V being continuous there,
 * and only its tap 0 (tap 5) can fall outside the call's taps, with a
 * weight near 0: those are masked (read as 0).
 *
 * The taps, by the fastest way that holds:
 * - when every delta_l is lo or lo + 1 (|step - 1| < 1/15), seven
 *   unaligned loads L_j = v[node_0 - 2 + lo + j + l], lane l weighting L_j
 *   by w_j (delta lo) or w_(j-1) (delta lo + 1), the weights chosen once
 *   for both parts as in scaled_product_avx2 () (L_0 and L_6 masked loads);
 * - for steps in [0.5, 1.73), the 32 floats from node_0 - 2 hold every
 *   tap of the vector: two registers a part, each tap a permute of them
 *   (loaded with masks up to the call's last tap);
 * - for steps in [1.73, 2], gathers.
 * Other steps take the reference (the float positions' error grows with
 * |step - 1|). */
#define SCALED_LANES 16
G_STATIC_ASSERT (RESEED_INTERVAL % SCALED_LANES == 0);

typedef struct
{
  __m512 excess;                /* l (step - 1), lane l */
  double x0, step;
  gssize first, last;           /* the call's first and last taps */
  float lo;                     /* the smaller delta of the loads' way */
  gboolean near;                /* the loads' way may hold */
  gboolean permute;             /* the permutes' way holds */
} ScaledCall;

/* Bins k .. k + m - 1 (m <= SCALED_LANES, a constant where it is
 * inlined; bin k's node @node0, its fraction @fraction) on the gain times
 * the phasors at *phasor_re, *phasor_im. */
static inline __attribute__ ((always_inline)) AVX512_TARGET void
scaled_vector_avx512 (SonarComplex * out, const float *r_re,
    const float *r_im, const float *v_re, const float *v_im, guint k,
    guint m, gssize node0, float fraction, const ScaledCall * c,
    const __m512 * phasor_re, const __m512 * phasor_im)
{
  const __mmask16 lanes = m >= 16 ? 0xffff : (1u << m) - 1;
  const __m512 s = _mm512_add_ps (_mm512_set1_ps (fraction), c->excess);
  const __m512 delta = _mm512_roundscale_ps (s, _MM_FROUND_TO_NEG_INF |
      _MM_FROUND_NO_EXC);
  const __m512 f = _mm512_sub_ps (s, delta);
  gboolean loaded = FALSE;
  __m512 w[6], sum_re, sum_im, rr, ri, tr, ti, o_re, o_im;

  /* The weights as in scaled_product_avx2 (). */
  {
    const __m512 d01 = _mm512_fmadd_ps (f, _mm512_add_ps (f,
            _mm512_set1_ps (3.0f)), _mm512_set1_ps (2.0f));
    const __m512 d23 = _mm512_fmsub_ps (f, f, f);
    const __m512 d45 = _mm512_fmadd_ps (f, _mm512_sub_ps (f,
            _mm512_set1_ps (5.0f)), _mm512_set1_ps (6.0f));
    const __m512 d0123 = _mm512_mul_ps (d01, d23);
    const __m512 d2345 = _mm512_mul_ps (d23, d45);
    const __m512 d0145 = _mm512_mul_ps (d01, d45);
#define SCALED_FACTOR(m, c) \
  _mm512_fmadd_ps (f, _mm512_set1_ps (c), _mm512_set1_ps (-(m) * (c)))
    w[0] = _mm512_mul_ps (SCALED_FACTOR (-1, -1.0f / 120.0f), d2345);
    w[1] = _mm512_mul_ps (SCALED_FACTOR (-2, 1.0f / 24.0f), d2345);
    w[2] = _mm512_mul_ps (SCALED_FACTOR (1, -1.0f / 12.0f), d0145);
    w[3] = _mm512_mul_ps (SCALED_FACTOR (0, 1.0f / 12.0f), d0145);
    w[4] = _mm512_mul_ps (d0123, SCALED_FACTOR (3, -1.0f / 24.0f));
    w[5] = _mm512_mul_ps (d0123, SCALED_FACTOR (2, 1.0f / 120.0f));
#undef SCALED_FACTOR
  }

  /* The loads' way, when its loads (up to node_0 + 19 + lo) stay within
   * the call's taps. */
  if (m == SCALED_LANES && c->near && node0 + 19 + (gssize) c->lo <= c->last) {
    const __mmask16 is_lo = _mm512_cmp_ps_mask (delta,
        _mm512_set1_ps (c->lo), _CMP_EQ_OQ);
    const __mmask16 is_hi = _mm512_cmp_ps_mask (delta,
        _mm512_set1_ps (c->lo + 1.0f), _CMP_EQ_OQ);
    if (_mm512_kortestc (is_lo, is_hi)) {
      const float *base_re = v_re + (node0 - 2 + (gssize) c->lo);
      const float *base_im = v_im + (node0 - 2 + (gssize) c->lo);
      sum_re = _mm512_mul_ps (w[0], _mm512_maskz_loadu_ps (is_lo, base_re));
      sum_im = _mm512_mul_ps (w[0], _mm512_maskz_loadu_ps (is_lo, base_im));
      for (int j = 1; j < 6; j++) {
        const __m512 weight = _mm512_mask_blend_ps (is_hi, w[j], w[j - 1]);
        sum_re = _mm512_fmadd_ps (weight, _mm512_loadu_ps (base_re + j),
            sum_re);
        sum_im = _mm512_fmadd_ps (weight, _mm512_loadu_ps (base_im + j),
            sum_im);
      }
      sum_re = _mm512_fmadd_ps (w[5], _mm512_maskz_loadu_ps (is_hi,
              base_re + 6), sum_re);
      sum_im = _mm512_fmadd_ps (w[5], _mm512_maskz_loadu_ps (is_hi,
              base_im + 6), sum_im);
      loaded = TRUE;
    }
  }
  if (!loaded) {
    /* node_l - node_0 */
    const __m512i rel = _mm512_add_epi32 (_mm512_cvtps_epi32 (delta),
        _mm512_setr_epi32 (0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13,
            14, 15));
    if (c->permute) {
      /* The window's floats up to the call's last tap; a lane's tap past
       * it (or past the window: the index wraps) has a weight near 0. */
      const gssize count = c->last - (node0 - 2) + 1;
      const __mmask16 low = count >= 16 ? 0xffff : (1u << count) - 1;
      const __mmask16 high = count >= 32 ? 0xffff : count <= 16 ? 0 :
          (1u << (count - 16)) - 1;
      const float *wr = v_re + (node0 - 2);
      const float *wi = v_im + (node0 - 2);
      const __m512 lo_re = _mm512_maskz_loadu_ps (low, wr);
      const __m512 hi_re = _mm512_maskz_loadu_ps (high, wr + 16);
      const __m512 lo_im = _mm512_maskz_loadu_ps (low, wi);
      const __m512 hi_im = _mm512_maskz_loadu_ps (high, wi + 16);

      sum_re = _mm512_mul_ps (w[0], _mm512_permutex2var_ps (lo_re, rel,
              hi_re));
      sum_im = _mm512_mul_ps (w[0], _mm512_permutex2var_ps (lo_im, rel,
              hi_im));
      for (int t = 1; t < 6; t++) {
        const __m512i index = _mm512_add_epi32 (rel, _mm512_set1_epi32 (t));
        sum_re = _mm512_fmadd_ps (w[t], _mm512_permutex2var_ps (lo_re,
                index, hi_re), sum_re);
        sum_im = _mm512_fmadd_ps (w[t], _mm512_permutex2var_ps (lo_im,
                index, hi_im), sum_im);
      }
    } else {
      const __m512i first = _mm512_add_epi32 (rel,
          _mm512_set1_epi32 ((int) node0 - 2));
      sum_re = sum_im = _mm512_setzero_ps ();
      for (int t = 0; t < 6; t++) {
        const __m512i index = _mm512_add_epi32 (first,
            _mm512_set1_epi32 (t));
        const __mmask16 in = t == 0 ? _mm512_mask_cmpge_epi32_mask (lanes,
            index, _mm512_set1_epi32 ((int) c->first)) : t == 5 ?
            _mm512_mask_cmple_epi32_mask (lanes, index,
            _mm512_set1_epi32 ((int) c->last)) : lanes;
        sum_re = _mm512_fmadd_ps (w[t], _mm512_mask_i32gather_ps
            (_mm512_setzero_ps (), in, index, v_re, 4), sum_re);
        sum_im = _mm512_fmadd_ps (w[t], _mm512_mask_i32gather_ps
            (_mm512_setzero_ps (), in, index, v_im, 4), sum_im);
      }
    }
  }

  /* (r V) (gain phasor), as the reference groups it. */
  rr = _mm512_maskz_loadu_ps (lanes, r_re + k);
  ri = _mm512_maskz_loadu_ps (lanes, r_im + k);
  tr = _mm512_fmsub_ps (rr, sum_re, _mm512_mul_ps (ri, sum_im));
  ti = _mm512_fmadd_ps (rr, sum_im, _mm512_mul_ps (ri, sum_re));
  o_re = _mm512_fmsub_ps (tr, *phasor_re, _mm512_mul_ps (ti, *phasor_im));
  o_im = _mm512_fmadd_ps (tr, *phasor_im, _mm512_mul_ps (ti, *phasor_re));
  {
    const __m512i first_half = _mm512_setr_epi32 (0, 16, 1, 17, 2, 18, 3,
        19, 4, 20, 5, 21, 6, 22, 7, 23);
    const __m512i second_half = _mm512_setr_epi32 (8, 24, 9, 25, 10, 26,
        11, 27, 12, 28, 13, 29, 14, 30, 15, 31);
    const __m512 a = _mm512_permutex2var_ps (o_re, first_half, o_im);
    const __m512 b = _mm512_permutex2var_ps (o_re, second_half, o_im);
    if (m >= 16) {
      _mm512_storeu_ps ((float *) (out + k), a);
      _mm512_storeu_ps ((float *) (out + k + 8), b);
    } else {
      _mm512_mask_storeu_ps ((float *) (out + k), m >= 8 ? 0xffff :
          (1u << (2 * m)) - 1, a);
      if (m > 8)
        _mm512_mask_storeu_ps ((float *) (out + k + 8),
            (1u << (2 * (m - 8))) - 1, b);
    }
  }
}

AVX512_TARGET static void
scaled_product_avx512 (SonarComplex * out, const float *r_re,
    const float *r_im, const float *v_re, const float *v_im, guint n,
    double x0, double step, double phase0, double dphase, float gain)
{
  const double cd = cos (dphase), sd = sin (dphase);
  double offset_re[SCALED_LANES], offset_im[SCALED_LANES];
  double seed_re = cos (phase0), seed_im = sin (phase0);
  double jump_re, jump_im;      /* rotation by RESEED_INTERVAL bins */
  float excess[SCALED_LANES];
  __m512 step_re, step_im;
  ScaledCall c;

  /* The nodes are int32 lanes: a table past 2^30 takes the reference, as
   * do the steps the float positions do not cover. */
  if (n == 0)
    return;
  if (!(fmax (x0, x0 + (n - 1) * step) < (double) (1 << 30))
      || !(step >= 0.5 && step <= 2.0)) {
    scaled_product_generic (out, r_re, r_im, v_re, v_im, n, x0, step, phase0,
        dphase, gain);
    return;
  }
  c.x0 = x0;
  c.step = step;
  c.first = (gssize) floor (x0) - 2;
  c.last = (gssize) floor (POSITION_UNFUSED (x0, (double) (n - 1),
          step)) + 3;
  c.lo = step >= 1.0 ? 0.0f : -1.0f;
  c.near = fabs (step - 1.0) < 1.0 / 15.0;
  /* The last lane's node is below node_0 + 1 + 15 step: node_0 + 26 at
   * most, its tap 5 the window's last float. */
  c.permute = step < 1.73;
  for (int l = 0; l < SCALED_LANES; l++)
    excess[l] = (float) (l * (step - 1.0));
  c.excess = _mm512_loadu_ps (excess);

  /* exp(i l dphase) in double; exp(i 16 dphase) in float for the steps,
   * squared in double up to the reseeds' rotation. */
  offset_re[0] = 1.0;
  offset_im[0] = 0.0;
  for (int l = 1; l < SCALED_LANES; l++) {
    offset_re[l] = offset_re[l - 1] * cd - offset_im[l - 1] * sd;
    offset_im[l] = offset_re[l - 1] * sd + offset_im[l - 1] * cd;
  }
  jump_re = offset_re[SCALED_LANES - 1] * cd - offset_im[SCALED_LANES - 1]
      * sd;
  jump_im = offset_re[SCALED_LANES - 1] * sd + offset_im[SCALED_LANES - 1]
      * cd;
  step_re = _mm512_set1_ps ((float) jump_re);
  step_im = _mm512_set1_ps ((float) jump_im);
  for (int k = SCALED_LANES; k < RESEED_INTERVAL; k *= 2) {
    const double re = jump_re * jump_re - jump_im * jump_im;
    jump_im = 2.0 * jump_re * jump_im;
    jump_re = re;
  }

  for (guint k0 = 0; k0 < n; k0 += RESEED_INTERVAL) {
    const guint k1 = MIN (n, k0 + RESEED_INTERVAL);
    __m256 seeded_re[2], seeded_im[2];
    float fraction[RESEED_INTERVAL / SCALED_LANES];
    int node[RESEED_INTERVAL / SCALED_LANES];
    __m512 phasor_re, phasor_im;
    double next_re;
    guint v = 0;

    /* The lanes' phasors times the gain, which the interval's four
     * vectors start from, in double, eight lanes a vector: lane by lane,
     * in scalar code, they took a sixth of the call. The halves are
     * joined in registers: a vector loaded over two stores of half of it
     * waits for them to retire. */
    for (int half = 0; half < 2; half++) {
      const __m512d o_re = _mm512_loadu_pd (offset_re + 8 * half);
      const __m512d o_im = _mm512_loadu_pd (offset_im + 8 * half);
      const __m512d s_re = _mm512_set1_pd (seed_re);
      const __m512d s_im = _mm512_set1_pd (seed_im);
      const __m512d g = _mm512_set1_pd (gain);
      seeded_re[half] = _mm512_cvtpd_ps (_mm512_mul_pd (g, _mm512_fmsub_pd
              (s_re, o_re, _mm512_mul_pd (s_im, o_im))));
      seeded_im[half] = _mm512_cvtpd_ps (_mm512_mul_pd (g, _mm512_fmadd_pd
              (s_re, o_im, _mm512_mul_pd (s_im, o_re))));
    }
    next_re = seed_re * jump_re - seed_im * jump_im;
    seed_im = seed_re * jump_im + seed_im * jump_re;
    seed_re = next_re;
    phasor_re = _mm512_castpd_ps (_mm512_insertf64x4 (_mm512_castps_pd
            (_mm512_castps256_ps512 (seeded_re[0])),
            _mm256_castps_pd (seeded_re[1]), 1));
    phasor_im = _mm512_castpd_ps (_mm512_insertf64x4 (_mm512_castps_pd
            (_mm512_castps256_ps512 (seeded_im[0])),
            _mm256_castps_pd (seeded_im[1]), 1));
    /* The interval's vectors' first positions at once, as the reference
     * computes them (the scalar work of one took a few percent). */
    {
      const __m256d x = POSITION_UNFUSED (_mm256_set1_pd (x0),
          _mm256_add_pd (_mm256_set1_pd ((double) k0), _mm256_setr_pd (0.0,
                  SCALED_LANES, 2 * SCALED_LANES, 3 * SCALED_LANES)),
          _mm256_set1_pd (step));
      const __m256d floor_x = _mm256_floor_pd (x);
      G_STATIC_ASSERT (RESEED_INTERVAL == 4 * SCALED_LANES);
      _mm_storeu_ps (fraction, _mm256_cvtpd_ps (_mm256_sub_pd (x,
                  floor_x)));
      _mm_storeu_si128 ((__m128i *) node, _mm256_cvttpd_epi32 (floor_x));
    }
    for (guint k = k0; k < k1; k += SCALED_LANES, v++) {
      __m512 rotated;
      if (k1 - k >= SCALED_LANES)
        scaled_vector_avx512 (out, r_re, r_im, v_re, v_im, k, SCALED_LANES,
            node[v], fraction[v], &c, &phasor_re, &phasor_im);
      else
        scaled_vector_avx512 (out, r_re, r_im, v_re, v_im, k, k1 - k,
            node[v], fraction[v], &c, &phasor_re, &phasor_im);
      rotated = _mm512_fmsub_ps (phasor_re, step_re, _mm512_mul_ps
          (phasor_im, step_im));
      phasor_im = _mm512_fmadd_ps (phasor_re, step_im, _mm512_mul_ps
          (phasor_im, step_re));
      phasor_re = rotated;
    }
  }
}

#undef SCALED_LANES

/* block8_sums_conj_avx2 () on 512-bit vectors, the layout unchanged: a
 * load covers two consecutive steps of a chunk (lanes j: block j at step
 * t, lanes 8 + j: at step t + 1). The phasors of the chunk's four such
 * pairs differ from the first pair's by exp(i 2 q dphase), the same in
 * every lane: the pairs' products are summed, each rotated by its pair's
 * constant (exact in double, rounded to float once), and the sum is
 * multiplied by the first pair's phasors once, with no rotation of the
 * phasors; the two halves' sums are added when interleaved for the
 * store. 49 vector operations a chunk where the AVX2 version takes 100
 * of half the width (CPU time per call on the velocity stage's 768-bin
 * gates: 1.4 times faster in cache; cycling through fig10's 2 MB of gate
 * templates 1.25, crossing's 7 MB 1.05, the loads bounding both; in the
 * velocity stage 1.15, by profile). The seeds are kept in double as there,
 * the upper lanes' a bin on in double; the lanes' offsets, exp(i 8 j
 * dphase), are products of the step's powers a few deep, not a chain of
 * 8 rotations. Against double, at least as close as the AVX2 version
 * (which rotates in float up to 7 times). */
AVX512_TARGET static void
block8_sums_conj_avx512 (SonarComplex * out, const float *a_re,
    const float *a_im, const float *b_re, const float *b_im, guint n,
    double phase0, double dphase)
{
  /* Lanes j < 8 of the 8 sums' re and im, then the interleaving of the
   * halves' sums into out[j] = re_j + i im_j. */
  const __m512i first = _mm512_setr_epi32 (0, 16, 1, 17, 2, 18, 3, 19, 4,
      20, 5, 21, 6, 22, 7, 23);
  const __m512i second = _mm512_setr_epi32 (8, 24, 9, 25, 10, 26, 11, 27,
      12, 28, 13, 29, 14, 30, 15, 31);
  /* p[m] = exp(i 2^m dphase), squared up from the step, m <= 6. */
  double p_re[7], p_im[7], start_re, start_im;
  __m512d one_re, one_im, seed_re, seed_im, jump_re, jump_im, off_re, off_im;
  __m512 rot_re[RESEED_INTERVAL / (2 * LANES)];
  __m512 rot_im[RESEED_INTERVAL / (2 * LANES)];

  G_STATIC_ASSERT (RESEED_INTERVAL == 64 && LANES == 8);
  p_re[0] = cos (dphase);
  p_im[0] = sin (dphase);
  for (int m = 1; m < 7; m++) {
    p_re[m] = p_re[m - 1] * p_re[m - 1] - p_im[m - 1] * p_im[m - 1];
    p_im[m] = 2.0 * p_re[m - 1] * p_im[m - 1];
  }
  /* The lanes' offsets exp(i 8 j dphase) as products of p[3], p[4] and
   * p[5] (a few products deep, not a chain of 8 rotations), and the pairs'
   * rotations exp(i 2 q dphase), q < 4, rounded to float once. */
  {
    const double r48 = p_re[4] * p_re[5] - p_im[4] * p_im[5];
    const double i48 = p_re[4] * p_im[5] + p_im[4] * p_re[5];
    const double r6 = p_re[1] * p_re[2] - p_im[1] * p_im[2];
    const double i6 = p_re[1] * p_im[2] + p_im[1] * p_re[2];
    off_re = _mm512_setr_pd (1.0, p_re[3], p_re[4],
        p_re[3] * p_re[4] - p_im[3] * p_im[4], p_re[5],
        p_re[3] * p_re[5] - p_im[3] * p_im[5], r48,
        p_re[3] * r48 - p_im[3] * i48);
    off_im = _mm512_setr_pd (0.0, p_im[3], p_im[4],
        p_re[3] * p_im[4] + p_im[3] * p_re[4], p_im[5],
        p_re[3] * p_im[5] + p_im[3] * p_re[5], i48,
        p_re[3] * i48 + p_im[3] * r48);
    rot_re[0] = rot_im[0] = _mm512_setzero_ps ();     /* unused */
    rot_re[1] = _mm512_set1_ps ((float) p_re[1]);
    rot_im[1] = _mm512_set1_ps ((float) p_im[1]);
    rot_re[2] = _mm512_set1_ps ((float) p_re[2]);
    rot_im[2] = _mm512_set1_ps ((float) p_im[2]);
    rot_re[3] = _mm512_set1_ps ((float) r6);
    rot_im[3] = _mm512_set1_ps ((float) i6);
  }
  one_re = _mm512_set1_pd (p_re[0]);
  one_im = _mm512_set1_pd (p_im[0]);
  jump_re = _mm512_set1_pd (p_re[6]);
  jump_im = _mm512_set1_pd (p_im[6]);
  start_re = cos (phase0);
  start_im = sin (phase0);
  seed_re = _mm512_fmsub_pd (off_re, _mm512_set1_pd (start_re),
      _mm512_mul_pd (off_im, _mm512_set1_pd (start_im)));
  seed_im = _mm512_fmadd_pd (off_im, _mm512_set1_pd (start_re),
      _mm512_mul_pd (off_re, _mm512_set1_pd (start_im)));

  for (guint k0 = 0; k0 < n; k0 += RESEED_INTERVAL) {
    /* Step 0 in the lower lanes, step 1 (one bin on) in the upper. */
    const __m512d next_re = _mm512_fmsub_pd (seed_re, one_re,
        _mm512_mul_pd (seed_im, one_im));
    const __m512d next_im = _mm512_fmadd_pd (seed_re, one_im,
        _mm512_mul_pd (seed_im, one_re));
    const __m512 pr = _mm512_castpd_ps (_mm512_insertf64x4
        (_mm512_castps_pd (_mm512_castps256_ps512 (_mm512_cvtpd_ps
                    (seed_re))),
            _mm256_castps_pd (_mm512_cvtpd_ps (next_re)), 1));
    const __m512 pi = _mm512_castpd_ps (_mm512_insertf64x4
        (_mm512_castps_pd (_mm512_castps256_ps512 (_mm512_cvtpd_ps
                    (seed_im))),
            _mm256_castps_pd (_mm512_cvtpd_ps (next_im)), 1));
    __m512 sum_re, sum_im, out_re, out_im;
    {
      const __m512d re = _mm512_fmsub_pd (seed_re, jump_re, _mm512_mul_pd
          (seed_im, jump_im));
      seed_im = _mm512_fmadd_pd (seed_re, jump_im, _mm512_mul_pd (seed_im,
              jump_re));
      seed_re = re;
    }
    /* Pair q's phasors are pair 0's times exp(i 2 q dphase), the same in
     * every lane: the sum of the pairs' products, each rotated by its
     * pair's constant, times pair 0's phasors once. */
    for (int q = 0; q < RESEED_INTERVAL / (2 * LANES); q++) {
      const guint k = k0 + 2 * LANES * q;
      const __m512 ar = _mm512_loadu_ps (a_re + k);
      const __m512 ai = _mm512_loadu_ps (a_im + k);
      const __m512 br = _mm512_loadu_ps (b_re + k);
      const __m512 bi = _mm512_loadu_ps (b_im + k);
      const __m512 tr = _mm512_fmadd_ps (ar, br, _mm512_mul_ps (ai, bi));
      const __m512 ti = _mm512_fmsub_ps (ai, br, _mm512_mul_ps (ar, bi));
      if (q == 0) {
        sum_re = tr;
        sum_im = ti;
      } else {
        sum_re = _mm512_fmadd_ps (tr, rot_re[q], sum_re);
        sum_re = _mm512_fnmadd_ps (ti, rot_im[q], sum_re);
        sum_im = _mm512_fmadd_ps (tr, rot_im[q], sum_im);
        sum_im = _mm512_fmadd_ps (ti, rot_re[q], sum_im);
      }
    }
    out_re = _mm512_fmsub_ps (sum_re, pr, _mm512_mul_ps (sum_im, pi));
    out_im = _mm512_fmadd_ps (sum_re, pi, _mm512_mul_ps (sum_im, pr));
    /* The halves' sums added, interleaved. */
    _mm512_storeu_ps ((float *) (out + k0 / LANES), _mm512_add_ps
        (_mm512_permutex2var_ps (out_re, first, out_im),
            _mm512_permutex2var_ps (out_re, second, out_im)));
  }
}

/* deinterleave_generic () by blocks of 8 channels of 8 frames: 8 loads
 * of a frame's 8 samples, an 8 x 8 transpose (unpacks, shuffles and
 * lane swaps) and 8 stores of a channel's 8 samples. A sample is finite
 * when x - x == 0 (NaN otherwise); the others are masked to +0, as the
 * reference writes them. The channels after the last whole 8 and the
 * frames after the last whole 8 take the reference. A ping is read
 * once, from memory rather than cache: its frames are prefetched
 * DEINTERLEAVE_AHEAD frames ahead, a cache line (16 samples) at a time
 * (the spectra of a ping out of cache, 32 channels on one thread, took
 * 1.53-1.63 ms of CPU against 1.66-1.74 with the hardware's prefetching
 * alone; no change on a ping in cache). */
#define DEINTERLEAVE_AHEAD 128
AVX2_TARGET static guint
deinterleave_avx2 (float *const *out, guint n_out, const float *frames,
    gsize stride, gsize n)
{
  const gsize whole = n - n % 8;
  const guint whole_out = n_out - n_out % 8;
  guint bad = 0;

  /* Frames outside: a frame's samples (a cache line for 16 channels)
   * are read once for all the channels. */
  for (gsize i = 0; i < whole; i += 8) {
    for (guint k = 0; k < whole_out; k += 8) {
      __m256 r[8], t[8];
      for (int f = 0; f < 8; f++) {
        const __m256 x = _mm256_loadu_ps (frames + (i + f) * stride + k);
        const __m256 finite = _mm256_cmp_ps (_mm256_sub_ps (x, x),
            _mm256_setzero_ps (), _CMP_EQ_OQ);
        const int mask = _mm256_movemask_ps (finite);
        if (k % 16 == 0 && i + 8 + DEINTERLEAVE_AHEAD <= n)
          _mm_prefetch ((const char *) (frames + (i + f +
                      DEINTERLEAVE_AHEAD) * stride + k), _MM_HINT_T0);
        if (G_UNLIKELY (mask != 0xff))
          bad += 8 - __builtin_popcount (mask);
        r[f] = _mm256_and_ps (x, finite);
      }
      /* t: pairs of frames interleaved; r: quads; then the 128-bit
       * halves of frames 0-3 and 4-7 joined: channel c of the 8 frames. */
      for (int f = 0; f < 8; f += 2) {
        t[f] = _mm256_unpacklo_ps (r[f], r[f + 1]);
        t[f + 1] = _mm256_unpackhi_ps (r[f], r[f + 1]);
      }
      for (int f = 0; f < 8; f += 4) {
        r[f] = _mm256_shuffle_ps (t[f], t[f + 2], 0x44);
        r[f + 1] = _mm256_shuffle_ps (t[f], t[f + 2], 0xee);
        r[f + 2] = _mm256_shuffle_ps (t[f + 1], t[f + 3], 0x44);
        r[f + 3] = _mm256_shuffle_ps (t[f + 1], t[f + 3], 0xee);
      }
      for (int c = 0; c < 4; c++) {
        _mm256_storeu_ps (out[k + c] + i,
            _mm256_permute2f128_ps (r[c], r[c + 4], 0x20));
        _mm256_storeu_ps (out[k + c + 4] + i,
            _mm256_permute2f128_ps (r[c], r[c + 4], 0x31));
      }
    }
  }
  bad += deinterleave_frames (out + whole_out, n_out - whole_out,
      frames + whole_out, stride, 0, whole);
  return bad + deinterleave_frames (out, n_out, frames, stride, whole, n);
}

/* steer_sum_split_avx2 () by vectors of 16 bins. Each chunk of
 * RESEED_INTERVAL bins starts from a seed exp(i (phase0 + k0 dphase))
 * rotated in double precision from chunk to chunk, as lanes_seed ()
 * does; bin k0 + j's phasor is that seed, rounded to float, turned by
 * exp(i j dphase), j < RESEED_INTERVAL, from a table made in double once
 * per call and rounded to float: a rotation in float within the chunk,
 * as the lanes' steps are, but one per phasor instead of a chain of
 * them (the error against double precision is below the avx2 version's,
 * test-kernels: 1.8e-7 relative, against 4.5e-7), and no conversion from
 * double per chunk but the seed's: sixteen lanes seeded from double each
 * chunk (lanes_seed ()'s way) took 17 us a call at fig10's 32 channels
 * of 2883 bins, against 14. A group of up to STEER_GROUP channels adds
 * up per pass over the bins (the sums loaded and stored once per vector
 * for the group; its phasors' seeds in registers, 16 of the 32); the
 * last chunk's bins past @n are masked, with no scalar tail. The
 * conjugate and the plain sums are apart, fused multiply-adds each,
 * neither multiplying the imaginary parts by a sign. */
#define STEER_LANES 16
#define STEER_GROUP 8
G_STATIC_ASSERT (RESEED_INTERVAL == 64 && RESEED_INTERVAL == 4 * STEER_LANES);

/* A channel's ramp: exp(i j dphase), j < RESEED_INTERVAL, in float; the
 * seed of its first chunk and the rotation by a chunk, in double (which
 * steer_group_avx512 () turns for its channels together). */
typedef struct
{
  float turn_re[RESEED_INTERVAL] __attribute__ ((aligned (64)));
  float turn_im[RESEED_INTERVAL] __attribute__ ((aligned (64)));
  double seed_re, seed_im;
  double jump_re, jump_im;
} SteerRamp;

/* a (= a b, complex) in the lanes of @mask, the others kept. */
#define STEER_TURN_PD(a_re, a_im, mask, b_re, b_im) G_STMT_START {      \
  const __m512d wr_ = _mm512_mask_mov_pd (_mm512_set1_pd (1.0), (mask), \
      _mm512_set1_pd (b_re));                                           \
  const __m512d wi_ = _mm512_maskz_mov_pd ((mask), _mm512_set1_pd (b_im)); \
  const __m512d re_ = _mm512_fmsub_pd ((a_re), wr_, _mm512_mul_pd ((a_im), \
          wi_));                                                        \
  (a_im) = _mm512_fmadd_pd ((a_re), wi_, _mm512_mul_pd ((a_im), wr_));  \
  (a_re) = re_;                                                         \
} G_STMT_END

/* The ramp of a channel from @phase0. exp(i 2^j dphase) by squaring
 * (its error near 1e-16 still); the table's exp(i j dphase) are products
 * of them, eight lanes at once, not a chain of products lane after lane
 * (each waiting on the last: 32 channels' set-ups took 4.8 us so, 1.7 with
 * the sincos calls this way). */
static inline __attribute__ ((always_inline)) AVX512_TARGET void
steer_ramp_init (SteerRamp * r, double phase0, double dphase)
{
  double e_re[7], e_im[7];      /* exp(i 2^j dphase) */
  __m512d lo_re, lo_im, hi_re, hi_im;

  e_re[0] = cos (dphase);
  e_im[0] = sin (dphase);
  for (int j = 1; j < 7; j++) {
    e_re[j] = e_re[j - 1] * e_re[j - 1] - e_im[j - 1] * e_im[j - 1];
    e_im[j] = 2.0 * e_re[j - 1] * e_im[j - 1];
  }
  /* Lanes 0 to 7, then 8 to 15. */
  lo_re = _mm512_mask_mov_pd (_mm512_set1_pd (1.0), 0xaa,
      _mm512_set1_pd (e_re[0]));
  lo_im = _mm512_maskz_mov_pd (0xaa, _mm512_set1_pd (e_im[0]));
  STEER_TURN_PD (lo_re, lo_im, 0xcc, e_re[1], e_im[1]);
  STEER_TURN_PD (lo_re, lo_im, 0xf0, e_re[2], e_im[2]);
  hi_re = lo_re;
  hi_im = lo_im;
  STEER_TURN_PD (hi_re, hi_im, 0xff, e_re[3], e_im[3]);
  for (int v = 0; v < RESEED_INTERVAL / STEER_LANES; v++) {
    __m512d qlo_re = lo_re, qlo_im = lo_im, qhi_re = hi_re, qhi_im = hi_im;
    /* exp(i 16 v dphase) */
    double p_re = v & 1 ? e_re[4] : 1.0, p_im = v & 1 ? e_im[4] : 0.0;
    if (v & 2) {
      const double t = p_re * e_re[5] - p_im * e_im[5];
      p_im = p_re * e_im[5] + p_im * e_re[5];
      p_re = t;
    }
    if (v > 0) {
      STEER_TURN_PD (qlo_re, qlo_im, 0xff, p_re, p_im);
      STEER_TURN_PD (qhi_re, qhi_im, 0xff, p_re, p_im);
    }
    _mm256_store_ps (r->turn_re + STEER_LANES * v, _mm512_cvtpd_ps (qlo_re));
    _mm256_store_ps (r->turn_re + STEER_LANES * v + 8,
        _mm512_cvtpd_ps (qhi_re));
    _mm256_store_ps (r->turn_im + STEER_LANES * v, _mm512_cvtpd_ps (qlo_im));
    _mm256_store_ps (r->turn_im + STEER_LANES * v + 8,
        _mm512_cvtpd_ps (qhi_im));
  }
  r->jump_re = e_re[6];
  r->jump_im = e_im[6];
  r->seed_re = cos (phase0);
  r->seed_im = sin (phase0);
}

#undef STEER_TURN_PD

/* One vector of bins k = k0 + v .. (lanes @mask) for the group: out (=
 * when @first, else +=) the sum of x p over its channels. */
#define STEER_VECTOR_AVX512(k0, v, mask) G_STMT_START {                 \
  __m512 ar_, ai_, br_, bi_;                                            \
  if (first) {                                                          \
    ar_ = ai_ = _mm512_setzero_ps ();                                   \
  } else {                                                              \
    ar_ = _mm512_maskz_loadu_ps ((mask), out_re + (k0) + (v));          \
    ai_ = _mm512_maskz_loadu_ps ((mask), out_im + (k0) + (v));          \
  }                                                                     \
  br_ = bi_ = _mm512_setzero_ps ();                                     \
  for (guint g = 0; g < group; g++) {                                   \
    const __m512 xr_ = _mm512_maskz_loadu_ps ((mask), x_re + g * stride \
        + (k0) + (v));                                                  \
    const __m512 xi_ = _mm512_maskz_loadu_ps ((mask), x_im + g * stride \
        + (k0) + (v));                                                  \
    const __m512 tr_ = _mm512_load_ps (r[g].turn_re + (v));             \
    const __m512 ti_ = _mm512_load_ps (r[g].turn_im + (v));             \
    const __m512 pr_ = _mm512_fmsub_ps (seed_re[g], tr_,                \
        _mm512_mul_ps (seed_im[g], ti_));                               \
    const __m512 pi_ = _mm512_fmadd_ps (seed_re[g], ti_,                \
        _mm512_mul_ps (seed_im[g], tr_));                               \
    __m512 *sr_ = g % 2 ? &br_ : &ar_, *si_ = g % 2 ? &bi_ : &ai_;      \
    *sr_ = _mm512_fmadd_ps (xr_, pr_, *sr_);                            \
    *si_ = _mm512_fmadd_ps (xr_, pi_, *si_);                            \
    if (conj_x) {                                                       \
      *sr_ = _mm512_fmadd_ps (xi_, pi_, *sr_);                          \
      *si_ = _mm512_fnmadd_ps (xi_, pr_, *si_);                         \
    } else {                                                            \
      *sr_ = _mm512_fnmadd_ps (xi_, pi_, *sr_);                         \
      *si_ = _mm512_fmadd_ps (xi_, pr_, *si_);                          \
    }                                                                   \
  }                                                                     \
  _mm512_mask_storeu_ps (out_re + (k0) + (v), (mask),                   \
      _mm512_add_ps (ar_, br_));                                        \
  _mm512_mask_storeu_ps (out_im + (k0) + (v), (mask),                   \
      _mm512_add_ps (ai_, bi_));                                        \
} G_STMT_END

/* The seeds of the chunk from @k0, in float, into seed_re, seed_im; the
 * group's seeds (s_re, s_im) turned by a chunk (j_re, j_im) in double,
 * eight channels a vector: one by one, in scalar code, they took a
 * twelfth of the call. */
#define STEER_SEED_AVX512() G_STMT_START {                              \
  float f_re_[STEER_GROUP] __attribute__ ((aligned (32)));              \
  float f_im_[STEER_GROUP] __attribute__ ((aligned (32)));              \
  const __m512d t_ = _mm512_fmsub_pd (s_re, j_re, _mm512_mul_pd (s_im,  \
          j_im));                                                       \
  _mm256_store_ps (f_re_, _mm512_cvtpd_ps (s_re));                      \
  _mm256_store_ps (f_im_, _mm512_cvtpd_ps (s_im));                      \
  s_im = _mm512_fmadd_pd (s_re, j_im, _mm512_mul_pd (s_im, j_re));      \
  s_re = t_;                                                            \
  for (guint g = 0; g < group; g++) {                                   \
    seed_re[g] = _mm512_set1_ps (f_re_[g]);                             \
    seed_im[g] = _mm512_set1_ps (f_im_[g]);                             \
  }                                                                     \
} G_STMT_END

/* out (= when @first, else +=) the @group (1 to STEER_GROUP) channels'
 * ramps; @group and @conj_x constants where it is inlined. */
static inline __attribute__ ((always_inline)) AVX512_TARGET void
steer_group_avx512 (float *out_re, float *out_im, const float *x_re,
    const float *x_im, gsize stride, const guint group, guint n,
    const double *phase0, const double *dphase, const gboolean conj_x,
    gboolean first)
{
  SteerRamp r[STEER_GROUP] __attribute__ ((aligned (64)));
  __m512 seed_re[STEER_GROUP], seed_im[STEER_GROUP];
  double seeds_re[STEER_GROUP] = { 0 }, seeds_im[STEER_GROUP] = { 0 };
  double jumps_re[STEER_GROUP] = { 0 }, jumps_im[STEER_GROUP] = { 0 };
  __m512d s_re, s_im, j_re, j_im;
  guint k0;

  for (guint g = 0; g < group; g++) {
    steer_ramp_init (&r[g], phase0[g], dphase[g]);
    seeds_re[g] = r[g].seed_re;
    seeds_im[g] = r[g].seed_im;
    jumps_re[g] = r[g].jump_re;
    jumps_im[g] = r[g].jump_im;
  }
  s_re = _mm512_loadu_pd (seeds_re);
  s_im = _mm512_loadu_pd (seeds_im);
  j_re = _mm512_loadu_pd (jumps_re);
  j_im = _mm512_loadu_pd (jumps_im);
  for (k0 = 0; k0 + RESEED_INTERVAL <= n; k0 += RESEED_INTERVAL) {
    STEER_SEED_AVX512 ();
#pragma GCC unroll 4
    for (guint v = 0; v < RESEED_INTERVAL; v += STEER_LANES)
      STEER_VECTOR_AVX512 (k0, v, 0xffff);
  }
  if (k0 < n) {
    STEER_SEED_AVX512 ();
    for (guint v = 0; k0 + v < n; v += STEER_LANES) {
      const __mmask16 mask = n - k0 - v >= STEER_LANES ? 0xffff :
          (__mmask16) ((1u << (n - k0 - v)) - 1);
      STEER_VECTOR_AVX512 (k0, v, mask);
    }
  }
}

#undef STEER_SEED_AVX512
#undef STEER_VECTOR_AVX512

/* The group of @group channels from channel c, for either conj_x. */
#define STEER_GROUP_CALL(group) G_STMT_START {                          \
  const float *re_ = x_re + c * stride, *im_ = x_im + c * stride;       \
  if (conj_x)                                                           \
    steer_group_avx512 (out_re, out_im, re_, im_, stride, (group), n,   \
        phase0 + c, dphase + c, TRUE, c == 0);                          \
  else                                                                  \
    steer_group_avx512 (out_re, out_im, re_, im_, stride, (group), n,   \
        phase0 + c, dphase + c, FALSE, c == 0);                         \
  c += (group);                                                         \
} G_STMT_END

/* Whole groups of eight, then one of four, then the three channels at
 * most left: each group size and conjugation is a copy of the code (4-5
 * kB; 83 kB with every size to eight), and five to seven channels left
 * take two passes. No switch on the size: clang makes it an indirect
 * jump, which test_vzeroupper.py cannot follow. */
AVX512_TARGET static void
steer_sum_split_avx512 (float *out_re, float *out_im, const float *x_re,
    const float *x_im, gsize stride, guint n_channels, guint n,
    const double *phase0, const double *dphase, gboolean conj_x)
{
  guint c = 0;

  if (n_channels == 0) {
    memset (out_re, 0, sizeof (float) * n);
    memset (out_im, 0, sizeof (float) * n);
  }
  while (n_channels - c >= STEER_GROUP)
    STEER_GROUP_CALL (STEER_GROUP);
  if (n_channels - c >= 4)
    STEER_GROUP_CALL (4);
  if (n_channels - c == 3)
    STEER_GROUP_CALL (3);
  else if (n_channels - c == 2)
    STEER_GROUP_CALL (2);
  else if (n_channels - c == 1)
    STEER_GROUP_CALL (1);
}

#undef STEER_GROUP_CALL
#undef STEER_GROUP
#undef STEER_LANES

/* Two vectors of partial sums a lag (one chain of dependent sums waits on
 * each addition), added across at the end. */
AVX2_TARGET static void
correlate_avx2 (float *out, const float *x, const float *w, guint n,
    guint n_lags)
{
  const guint whole = n - n % (2 * LANES);

  for (guint l = 0; l < n_lags; l++) {
    const float *xl = x + l;
    __m256 s0 = _mm256_setzero_ps (), s1 = _mm256_setzero_ps ();
    float lanes[LANES], sum = 0.0f;

    for (guint i = 0; i < whole; i += 2 * LANES) {
      s0 = _mm256_fmadd_ps (_mm256_loadu_ps (xl + i), _mm256_loadu_ps (w + i),
          s0);
      s1 = _mm256_fmadd_ps (_mm256_loadu_ps (xl + i + LANES),
          _mm256_loadu_ps (w + i + LANES), s1);
    }
    _mm256_storeu_ps (lanes, _mm256_add_ps (s0, s1));
    for (guint i = whole; i < n; i++)
      sum += xl[i] * w[i];
    for (guint k = 0; k < LANES; k++)
      sum += lanes[k];
    out[l] = sum;
  }
}

AVX2_TARGET static void
axpy_avx2 (float *y, const float *x, float a, guint n)
{
  const __m256 va = _mm256_set1_ps (a);
  const guint whole = n - n % LANES;

  for (guint i = 0; i < whole; i += LANES)
    _mm256_storeu_ps (y + i, _mm256_add_ps (_mm256_loadu_ps (y + i),
            _mm256_mul_ps (va, _mm256_loadu_ps (x + i))));
  axpy_generic (y + whole, x + whole, a, n - whole);
}

#endif /* HAVE_AVX2_KERNELS */

/* ORC versions -----------------------------------------------------------*/

/* ORC's compiled x86 code turns on flush-to-zero and denormals-are-zero
 * in MXCSR and leaves them on: every float operation after it on that
 * thread would then read a recording near 1e-40 as silence (seen in
 * test-stability's denormals case). The calls keep the caller's MXCSR. */
#if defined(__SSE__)
#include <xmmintrin.h>
#define FLOAT_MODE_SAVE() const unsigned int float_mode_ = _mm_getcsr ()
#define FLOAT_MODE_RESTORE() _mm_setcsr (float_mode_)
#else
#define FLOAT_MODE_SAVE() do { } while (0)
#define FLOAT_MODE_RESTORE() do { } while (0)
#endif

/* ORC's opcode tables, once per process. */
static void
orc_ready (void)
{
  static gsize done = 0;

  if (g_once_init_enter (&done)) {
    orc_init ();
    g_once_init_leave (&done, 1);
  }
}

static void
envelope_orc (float *out, const SonarComplex * x, guint n,
    float scale, gboolean accumulate)
{
  FLOAT_MODE_SAVE ();

  orc_ready ();
  if (accumulate)
    sonar_orc_envelope_max (out, (const float *) x, scale, (int) n);
  else
    sonar_orc_envelope (out, (const float *) x, scale, (int) n);
  FLOAT_MODE_RESTORE ();
}

/* The tables and the entry points --------------------------------------*/

static gboolean
always_available (void)
{
  return TRUE;
}

#ifdef HAVE_AVX2_KERNELS
static gboolean
cpu_has_avx2_fma (void)
{
  return __builtin_cpu_supports ("avx2") && __builtin_cpu_supports ("fma");
}

static gboolean
cpu_has_avx512f (void)
{
  return __builtin_cpu_supports ("avx512f");
}
#endif

const SonarSteerSumSplitImpl sonar_kernel_steer_sum_split_impls[] = {
  {"generic", steer_sum_split_generic, always_available},
#ifdef HAVE_AVX2_KERNELS
  {"avx2", steer_sum_split_avx2, cpu_has_avx2_fma},
  {"avx512", steer_sum_split_avx512, cpu_has_avx512f},
#endif
  {NULL, NULL, NULL}
};

const SonarSteerBlockSumsConjImpl sonar_kernel_steer_block_sums_conj_impls[]
    = {
  {"generic", steer_block_sums_conj_generic, always_available},
#ifdef HAVE_AVX2_KERNELS
  {"avx2", steer_block_sums_conj_avx2, cpu_has_avx2_fma},
#endif
  {NULL, NULL, NULL}
};

const SonarBlock8SumsConjImpl sonar_kernel_block8_sums_conj_impls[] = {
  {"generic", block8_sums_conj_generic, always_available},
#ifdef HAVE_AVX2_KERNELS
  {"avx2", block8_sums_conj_avx2, cpu_has_avx2_fma},
  {"avx512", block8_sums_conj_avx512, cpu_has_avx512f},
#endif
  {NULL, NULL, NULL}
};

const SonarSteerSumImpl sonar_kernel_steer_sum_impls[] = {
  {"generic", steer_sum_generic, always_available},
#ifdef HAVE_AVX2_KERNELS
  {"avx2", steer_sum_avx2, cpu_has_avx2_fma},
#endif
  {NULL, NULL, NULL}
};

const SonarSteerPhasorsImpl sonar_kernel_steer_phasors_impls[] = {
  {"generic", steer_phasors_generic, always_available},
#ifdef HAVE_AVX2_KERNELS
  {"avx2", steer_phasors_avx2, cpu_has_avx2_fma},
#endif
  {NULL, NULL, NULL}
};

const SonarSteerSumPhasorsImpl sonar_kernel_steer_sum_phasors_impls[] = {
  {"generic", steer_sum_phasors_generic, always_available},
#ifdef HAVE_AVX2_KERNELS
  {"avx2", steer_sum_phasors_avx2, cpu_has_avx2_fma},
#endif
  {NULL, NULL, NULL}
};

const SonarSteerSumsPhasorsImpl sonar_kernel_steer_sums_phasors_impls[] = {
  {"generic", steer_sums_phasors_generic, always_available},
#ifdef HAVE_AVX2_KERNELS
  {"avx2", steer_sums_phasors_avx2, cpu_has_avx2_fma},
#endif
  {NULL, NULL, NULL}
};

/* ORC compiles for the running CPU, or runs its C backup where it cannot:
 * always available. */
const SonarScaledProductImpl sonar_kernel_scaled_product_impls[] = {
  {"generic", scaled_product_generic, always_available},
#ifdef HAVE_AVX2_KERNELS
  {"avx2", scaled_product_avx2, cpu_has_avx2_fma},
  {"avx512", scaled_product_avx512, cpu_has_avx512f},
#endif
  {NULL, NULL, NULL}
};

const SonarEnvelopeImpl sonar_kernel_envelope_impls[] = {
  {"generic", envelope_generic, always_available},
  {"orc", envelope_orc, always_available},
#ifdef HAVE_AVX2_KERNELS
  {"avx2", envelope_avx2, cpu_has_avx2_fma},
#endif
  {NULL, NULL, NULL}
};

const SonarPeakImpl sonar_kernel_peak_impls[] = {
  {"generic", peak_generic, always_available},
#ifdef HAVE_AVX2_KERNELS
  {"avx2", peak_avx2, cpu_has_avx2_fma},
#endif
  {NULL, NULL, NULL}
};

const SonarBlockPeaksImpl sonar_kernel_block_peaks_impls[] = {
  {"generic", block_peaks_generic, always_available},
#ifdef HAVE_AVX2_KERNELS
  {"avx2", block_peaks_avx2, cpu_has_avx2_fma},
#endif
  {NULL, NULL, NULL}
};

const SonarMaxImpl sonar_kernel_max_impls[] = {
  {"generic", max_generic, always_available},
#ifdef HAVE_AVX2_KERNELS
  {"avx2", max_avx2, cpu_has_avx2_fma},
#endif
  {NULL, NULL, NULL}
};

const SonarCorrelateImpl sonar_kernel_correlate_impls[] = {
  {"generic", correlate_generic, always_available},
#ifdef HAVE_AVX2_KERNELS
  {"avx2", correlate_avx2, cpu_has_avx2_fma},
#endif
  {NULL, NULL, NULL}
};

const SonarAxpyImpl sonar_kernel_axpy_impls[] = {
  {"generic", axpy_generic, always_available},
#ifdef HAVE_AVX2_KERNELS
  {"avx2", axpy_avx2, cpu_has_avx2_fma},
#endif
  {NULL, NULL, NULL}
};

const SonarRankPassImpl sonar_kernel_rank_pass_impls[] = {
  {"generic", rank_pass_generic, always_available},
#ifdef HAVE_AVX2_KERNELS
  {"avx2", rank_pass_avx2, cpu_has_avx2_fma},
  {"avx512", rank_pass_avx512, cpu_has_avx512f},
#endif
  {NULL, NULL, NULL}
};

const SonarDeinterleaveImpl sonar_kernel_deinterleave_impls[] = {
  {"generic", deinterleave_generic, always_available},
#ifdef HAVE_AVX2_KERNELS
  {"avx2", deinterleave_avx2, cpu_has_avx2_fma},
#endif
  {NULL, NULL, NULL}
};

/* The implementation each entry point calls, chosen once per process. */
static struct
{
  SonarSteerSumSplitFn steer_sum_split;
  SonarSteerBlockSumsConjFn steer_block_sums_conj;
  SonarBlock8SumsConjFn block8_sums_conj;
  SonarSteerSumFn steer_sum;
  SonarSteerPhasorsFn steer_phasors;
  SonarSteerSumsPhasorsFn steer_sums_phasors;
  SonarScaledProductFn scaled_product;
  SonarEnvelopeFn envelope;
  SonarPeakFn peak;
  SonarBlockPeaksFn block_peaks;
  SonarMaxFn max;
  SonarRankPassFn rank_pass;
  SonarDeinterleaveFn deinterleave;
  SonarCorrelateFn correlate;
  SonarAxpyFn axpy;
} chosen;

/* The last implementation of @impls the CPU has. */
#define LAST_AVAILABLE(impls, choice) G_STMT_START {                    \
  for (guint i_ = 0; (impls)[i_].name; i_++)                            \
    if ((impls)[i_].available ())                                       \
      (choice) = (impls)[i_].fn;                                        \
} G_STMT_END

static inline void
choose (void)
{
  static gsize done = 0;

  if (g_once_init_enter (&done)) {
    LAST_AVAILABLE (sonar_kernel_steer_sum_split_impls,
        chosen.steer_sum_split);
    LAST_AVAILABLE (sonar_kernel_steer_block_sums_conj_impls,
        chosen.steer_block_sums_conj);
    LAST_AVAILABLE (sonar_kernel_block8_sums_conj_impls,
        chosen.block8_sums_conj);
    LAST_AVAILABLE (sonar_kernel_steer_sum_impls, chosen.steer_sum);
    LAST_AVAILABLE (sonar_kernel_steer_phasors_impls, chosen.steer_phasors);
    LAST_AVAILABLE (sonar_kernel_steer_sums_phasors_impls,
        chosen.steer_sums_phasors);
    LAST_AVAILABLE (sonar_kernel_scaled_product_impls,
        chosen.scaled_product);
    LAST_AVAILABLE (sonar_kernel_envelope_impls, chosen.envelope);
    LAST_AVAILABLE (sonar_kernel_peak_impls, chosen.peak);
    LAST_AVAILABLE (sonar_kernel_block_peaks_impls, chosen.block_peaks);
    LAST_AVAILABLE (sonar_kernel_max_impls, chosen.max);
    LAST_AVAILABLE (sonar_kernel_rank_pass_impls, chosen.rank_pass);
    LAST_AVAILABLE (sonar_kernel_deinterleave_impls, chosen.deinterleave);
    LAST_AVAILABLE (sonar_kernel_correlate_impls, chosen.correlate);
    LAST_AVAILABLE (sonar_kernel_axpy_impls, chosen.axpy);
    g_once_init_leave (&done, 1);
  }
}

void
sonar_kernel_steer_sum_split (float *out_re, float *out_im,
    const float *x_re, const float *x_im, gsize stride, guint n_channels,
    guint n, const double *phase0, const double *dphase, gboolean conj_x)
{
  choose ();
  chosen.steer_sum_split (out_re, out_im, x_re, x_im, stride, n_channels, n,
      phase0, dphase, conj_x);
}

void
sonar_kernel_steer_block_sums_conj (SonarComplex * out, const float *a_re,
    const float *a_im, const float *b_re, const float *b_im, guint n,
    double phase0, double dphase, guint block)
{
  g_return_if_fail (block % LANES == 0 && RESEED_INTERVAL % block == 0);
  choose ();
  chosen.steer_block_sums_conj (out, a_re, a_im, b_re, b_im, n, phase0,
      dphase, block);
}

void
sonar_kernel_block8_sums_conj (SonarComplex * out, const float *a_re,
    const float *a_im, const float *b_re, const float *b_im, guint n,
    double phase0, double dphase)
{
  g_return_if_fail (n % SONAR_BLOCK8_CHUNK == 0);
  choose ();
  chosen.block8_sums_conj (out, a_re, a_im, b_re, b_im, n, phase0, dphase);
}

SonarComplex
sonar_kernel_steer_sum (const SonarComplex * x, guint n, double phase0,
    double dphase)
{
  choose ();
  return chosen.steer_sum (x, n, phase0, dphase);
}

void
sonar_kernel_steer_phasors (float *re, float *im, guint n, double phase0,
    double dphase)
{
  choose ();
  chosen.steer_phasors (re, im, n, phase0, dphase);
}

void
sonar_kernel_steer_sums_phasors (SonarComplex * out, const SonarComplex * x,
    const float *const *re, const float *const *im, guint n_tables, guint n)
{
  choose ();
  chosen.steer_sums_phasors (out, x, re, im, n_tables, n);
}

void
sonar_kernel_scaled_product (SonarComplex * out, const float *r_re,
    const float *r_im, const float *v_re, const float *v_im, guint n,
    double x0, double step, double phase0, double dphase, float gain)
{
  choose ();
  chosen.scaled_product (out, r_re, r_im, v_re, v_im, n, x0, step, phase0,
      dphase, gain);
}

void
sonar_kernel_envelope (float *out, const SonarComplex * x, guint n,
    float scale, gboolean accumulate)
{
  choose ();
  chosen.envelope (out, x, n, scale, accumulate);
}

float
sonar_kernel_peak (const float *x, const float *w, guint n)
{
  choose ();
  return chosen.peak (x, w, n);
}

void
sonar_kernel_block_peaks (float *out, const float *x, guint n, guint block)
{
  choose ();
  chosen.block_peaks (out, x, n, block);
}

void
sonar_kernel_max (float *out, const float *x, guint n)
{
  choose ();
  chosen.max (out, x, n);
}

void
sonar_kernel_rank_pass (const float *x, gsize stride, guint n_rows,
    const float *level, guint32 * below, float *under, float *over,
    guint32 * finite)
{
  choose ();
  chosen.rank_pass (x, stride, n_rows, level, below, under, over, finite);
}

guint
sonar_kernel_deinterleave (float *const *out, guint n_out,
    const float *frames, gsize stride, gsize n)
{
  choose ();
  return chosen.deinterleave (out, n_out, frames, stride, n);
}

void
sonar_kernel_correlate (float *out, const float *x, const float *w, guint n,
    guint n_lags)
{
  choose ();
  chosen.correlate (out, x, w, n, n_lags);
}

void
sonar_kernel_axpy (float *y, const float *x, float a, guint n)
{
  choose ();
  chosen.axpy (y, x, a, n);
}
