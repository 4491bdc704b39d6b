/* test-kernels.c: every implementation of every kernel in the tables of
 * sonar-kernels.h against the plain C reference (the table's first
 * entry) and against double precision, on random data, awkward lengths
 * and large phases (VOLK's way). One test case per implementation, named
 * after it; an implementation the CPU lacks is reported as skipped. */
#include <complex.h>
#include <float.h>
#include <math.h>
#include <string.h>

#include "sonar-kernels.h"
#include "sonar-rng.h"

#ifdef G_OS_UNIX
#include <sys/mman.h>
#include <unistd.h>
#endif

static const guint lengths[] = { 0, 1, 7, 8, 9, 63, 64, 65, 200, 2882 };

static void
random_spectrum (SonarRng * rng, SonarComplex * x, guint n)
{
  for (guint k = 0; k < n; k++)
    x[k] = (float) sonar_rng_gaussian (rng) + I * (float)
        sonar_rng_gaussian (rng);
}

/* Sum of |x|: the scale the accumulated rounding is measured against. */
static double
magnitude_sum (const SonarComplex * x, guint n)
{
  double s = 0.0;
  for (guint k = 0; k < n; k++)
    s += cabsf (x[k]);
  return s;
}

/* sum over k < n of a[k] conj (b[k]) exp(i (phase0 + k dphase)), in
 * double precision: the exact value the kernels' sums approximate. */
static double complex
exact_dot_conj (const SonarComplex * a, const SonarComplex * b, guint n,
    double phase0, double dphase, double *magnitudes)
{
  double complex sum = 0.0;

  *magnitudes = 0.0;
  for (guint k = 0; k < n; k++) {
    const double complex ak = a[k], bk = b[k];
    const double complex term = ak * conj (bk) * cexp (I * (phase0 +
            k * dphase));
    sum += term;
    *magnitudes += cabs (term);
  }
  return sum;
}

/* Skips the test case (visibly) when the CPU lacks @impl. */
#define SKIP_UNLESS_AVAILABLE(impl) G_STMT_START {                      \
  if (!(impl)->available ()) {                                          \
    g_test_skip_printf ("the CPU lacks what \"%s\" needs", (impl)->name); \
    return;                                                             \
  }                                                                     \
} G_STMT_END

/* The steering sum over channels against the reference and the sum in
 * double precision: every group size of the fast versions (1 to 19
 * channels: whole groups of four or eight and each remainder, alone and
 * after whole groups), plain and conjugated, at every length (and at
 * lengths either side of the AVX-512 version's 16-bin vectors, and
 * fig10's odd count of bins). */
static void
test_steer_sum_split (gconstpointer data)
{
  static const guint split_lengths[] = { 0, 1, 7, 8, 9, 15, 16, 17, 63, 64,
    65, 200, 2882, 2883
  };
  enum { MAX_CH = 19, N = 2883 };
  const SonarSteerSumSplitImpl *impl = data;
  const SonarSteerSumSplitFn reference =
      sonar_kernel_steer_sum_split_impls[0].fn;
  SonarRng rng;
  g_autofree SonarComplex *x = g_new (SonarComplex, MAX_CH * N);
  g_autofree float *x_re = g_new (float, MAX_CH * N);
  g_autofree float *x_im = g_new (float, MAX_CH * N);
  g_autofree double complex *exact = g_new (double complex, N);
  g_autofree double *magnitude = g_new (double, N);
  float fast_re[N], fast_im[N], ref_re[N], ref_im[N];
  double phase0[MAX_CH], dphase[MAX_CH];
  double worst = 0.0;

  SKIP_UNLESS_AVAILABLE (impl);
  sonar_rng_init (&rng, 18, 0);
  for (guint t = 0; t < G_N_ELEMENTS (split_lengths); t++) {
    const guint n = split_lengths[t];
    for (guint channels = 0; channels <= MAX_CH; channels++) {
      for (int conj_x = 0; conj_x < 2; conj_x++) {
        for (guint c = 0; c < channels; c++) {
          phase0[c] = -321.5 * (t + 1) + 17.1 * c;
          dphase[c] = 0.053 * (t + 1) - 0.011 * c;
          random_spectrum (&rng, x + c * N, n);
          sonar_kernel_split (x_re + c * N, x_im + c * N, x + c * N, n);
        }
        /* What was in the output before does not count. */
        for (guint k = 0; k < n; k++)
          fast_re[k] = fast_im[k] = ref_re[k] = ref_im[k] = 1e3f;
        impl->fn (fast_re, fast_im, x_re, x_im, N, channels, n, phase0,
            dphase, conj_x);
        reference (ref_re, ref_im, x_re, x_im, N, channels, n, phase0,
            dphase, conj_x);
        for (guint k = 0; k < n; k++) {
          exact[k] = 0.0;
          magnitude[k] = 1e-6;
          for (guint c = 0; c < channels; c++) {
            const double complex xk = x[c * N + k];
            exact[k] += (conj_x ? conj (xk) : xk) * cexp (I * (phase0[c] +
                    k * dphase[c]));
            magnitude[k] += cabs (xk);
          }
        }
        for (guint k = 0; k < n; k++) {
          const double error = cabs (fast_re[k] + I * fast_im[k] -
              exact[k]) / magnitude[k];
          g_assert_cmpfloat (cabsf (fast_re[k] + I * fast_im[k] -
                  (ref_re[k] + I * ref_im[k])) / magnitude[k], <, 2e-5);
          g_assert_cmpfloat (error, <, 2e-5);
          worst = MAX (worst, error);
        }
      }
    }
  }
  g_test_message ("worst error against double precision, relative to the "
      "sum of |x|: %.2e", worst);
  /* The fast versions' phasors come from double precision every 64 bins,
   * a few float rotations from it (avx2 4.5e-7 here, avx512 1.8e-7); the
   * reference rotates bin after bin (2.4e-6). */
  if (impl != &sonar_kernel_steer_sum_split_impls[0])
    g_assert_cmpfloat (worst, <, 1e-6);
}

static void
test_steer_block_sums (gconstpointer data)
{
  static const guint blocks[] = { 8, 16, 32, 64 };
  const SonarSteerBlockSumsConjImpl *impl = data;
  const SonarSteerBlockSumsConjFn reference =
      sonar_kernel_steer_block_sums_conj_impls[0].fn;
  SonarRng rng;
  SonarComplex a[2882], b[2882], prod[2882], fast[361], ref[361];
  float a_re[2882], a_im[2882], b_re[2882], b_im[2882];

  SKIP_UNLESS_AVAILABLE (impl);
  sonar_rng_init (&rng, 14, 0);
  for (guint t = 0; t < G_N_ELEMENTS (lengths); t++) {
    for (guint i = 0; i < G_N_ELEMENTS (blocks); i++) {
      const guint n = lengths[t], block = blocks[i];
      const guint n_blocks = (n + block - 1) / block;
      const double phase0 = 55.5 * (t + 1), dphase = 0.29 / (i + 1);
      double worst = 0.0;
      SonarComplex total = 0.0f;

      random_spectrum (&rng, a, n);
      random_spectrum (&rng, b, n);
      for (guint k = 0; k < n; k++)
        prod[k] = a[k] * conjf (b[k]);
      sonar_kernel_split (a_re, a_im, a, n);
      sonar_kernel_split (b_re, b_im, b, n);
      impl->fn (fast, a_re, a_im, b_re, b_im, n, phase0, dphase, block);
      reference (ref, a_re, a_im, b_re, b_im, n, phase0, dphase, block);
      for (guint j = 0; j < n_blocks; j++) {
        const double scale = MAX (magnitude_sum (prod + j * block,
                MIN (block, n - j * block)), 1e-6);
        worst = MAX (worst, cabsf (fast[j] - ref[j]) / scale);
        total += fast[j];
      }
      g_test_message ("n %u block %u: worst relative error %.2e", n, block,
          worst);
      g_assert_cmpfloat (worst, <, 1e-5);
      /* The blocks add up to the whole dot product. */
      {
        double magnitudes;
        const double complex exact = exact_dot_conj (a, b, n, phase0, dphase,
            &magnitudes);
        g_assert_cmpfloat (cabs (total - exact), <=, 1e-5 * MAX (magnitudes,
                1e-6));
      }
    }
  }
}

/* The block8 layout's sums against the reference and, block by block,
 * against double precision: whole chunks, data ending inside a block
 * (the rest padded with zeros), large phases. */
static void
test_block8_sums (gconstpointer data)
{
  /* 130 and 2990: odd numbers of chunks past one (3 and 47), for the
   * versions that take a chunk's vectors in pairs. */
  static const guint sizes[] = { 0, 1, 8, 63, 64, 65, 130, 200, 722, 2882,
    2990
  };
  enum { N = SONAR_BLOCK8_PADDED (2990) };
  const SonarBlock8SumsConjImpl *impl = data;
  const SonarBlock8SumsConjFn reference =
      sonar_kernel_block8_sums_conj_impls[0].fn;
  SonarRng rng;
  SonarComplex a[N], b[N], fast[N / 8], ref[N / 8];
  float a_re[N], a_im[N], b_re[N], b_im[N];

  SKIP_UNLESS_AVAILABLE (impl);
  sonar_rng_init (&rng, 21, 0);
  for (guint t = 0; t < G_N_ELEMENTS (sizes); t++) {
    const guint size = sizes[t], n = SONAR_BLOCK8_PADDED (size);
    const double phase0 = -412.25 * (t + 1), dphase = 0.023 * (t + 1);
    double worst = 0.0, worst_exact = 0.0;

    random_spectrum (&rng, a, size);
    random_spectrum (&rng, b, size);
    for (guint k = 0; k < n; k++) {
      const guint i = SONAR_BLOCK8_INDEX (k);
      g_assert_cmpuint (i, <, n);
      a_re[i] = k < size ? crealf (a[k]) : 0.0f;
      a_im[i] = k < size ? cimagf (a[k]) : 0.0f;
      b_re[i] = k < size ? crealf (b[k]) : 0.0f;
      b_im[i] = k < size ? cimagf (b[k]) : 0.0f;
    }
    impl->fn (fast, a_re, a_im, b_re, b_im, n, phase0, dphase);
    reference (ref, a_re, a_im, b_re, b_im, n, phase0, dphase);
    for (guint j = 0; j < n / 8; j++) {
      const guint first = MIN (8 * j, size), count = MIN (8, size - first);
      double magnitudes;
      const double complex exact = exact_dot_conj (a + first, b + first,
          count, phase0 + first * dphase, dphase, &magnitudes);
      const double scale = MAX (magnitudes, 1e-6);
      worst = MAX (worst, cabsf (fast[j] - ref[j]) / scale);
      worst_exact = MAX (worst_exact, cabs (fast[j] - exact) / scale);
    }
    g_test_message ("%u bins: worst relative error %.2e against the "
        "reference, %.2e against double", size, worst, worst_exact);
    g_assert_cmpfloat (worst, <, 1e-5);
    g_assert_cmpfloat (worst_exact, <, 1e-5);
  }
}

static void
test_steer_sum (gconstpointer data)
{
  const SonarSteerSumImpl *impl = data;
  const SonarSteerSumFn reference = sonar_kernel_steer_sum_impls[0].fn;
  SonarRng rng;
  SonarComplex x[2882], ones[2882];

  SKIP_UNLESS_AVAILABLE (impl);
  sonar_rng_init (&rng, 15, 0);
  for (guint k = 0; k < G_N_ELEMENTS (ones); k++)
    ones[k] = 1.0f;
  for (guint t = 0; t < G_N_ELEMENTS (lengths); t++) {
    const guint n = lengths[t];
    const double phase0 = -3.25 * (t + 1), dphase = 0.7 / (t + 1);
    SonarComplex fast;
    double scale, magnitudes;

    random_spectrum (&rng, x, n);
    scale = MAX (magnitude_sum (x, n), 1e-6);
    fast = impl->fn (x, n, phase0, dphase);
    g_assert_cmpfloat (cabsf (fast - reference (x, n, phase0, dphase)) /
        scale, <, 1e-5);
    /* The same sum as the exact dot product with ones. */
    g_assert_cmpfloat (cabs (fast - exact_dot_conj (x, ones, n, phase0,
                dphase, &magnitudes)) / scale, <, 1e-5);
  }
}

/* The phasor tables and the sums on them against the steering sum of
 * the same name, bit for bit (the velocity stage reads its lags either
 * way), at every length and at phases of the lag reads' size and far
 * larger; and the generic phasors against exp(i phase) in double. */
static void
test_steer_phasors (gconstpointer data)
{
  const SonarSteerPhasorsImpl *impl = data;
  const guint i = impl - sonar_kernel_steer_phasors_impls;
  const SonarSteerSumPhasorsImpl *sum = &sonar_kernel_steer_sum_phasors_impls[i];
  const SonarSteerSumImpl *direct = &sonar_kernel_steer_sum_impls[i];
  static const double offsets[] = { 0.0, -0.0049, 0.0025, 0.0098, -0.0196,
    0.37, -3.25, 1000.5
  };
  SonarRng rng;
  SonarComplex x[2882];
  float re[2882], im[2882];

  g_assert_cmpstr (sum->name, ==, impl->name);
  g_assert_cmpstr (direct->name, ==, impl->name);
  SKIP_UNLESS_AVAILABLE (impl);
  sonar_rng_init (&rng, 21, 0);
  for (guint t = 0; t < G_N_ELEMENTS (lengths); t++) {
    for (guint o = 0; o < G_N_ELEMENTS (offsets); o++) {
      const guint n = lengths[t];
      /* The lag reads' ramps: the band's centre phase per block and
       * 8 or 16 bins' steps, times two ways of the offset. */
      const double phase0 = 366.4 * 2.0 * offsets[o];
      const double dphase = 0.3814 * 16.0 * 2.0 * offsets[o];
      SonarComplex a, b;

      impl->fn (re, im, n, phase0, dphase);
      for (guint k = 0; k < n; k++) {
        g_assert_cmpfloat (fabs (re[k] - cos (phase0 + k * dphase)), <, 1e-5);
        g_assert_cmpfloat (fabs (im[k] - sin (phase0 + k * dphase)), <, 1e-5);
      }
      for (int r = 0; r < 3; r++) {
        random_spectrum (&rng, x, n);
        a = sum->fn (x, re, im, n);
        b = direct->fn (x, n, phase0, dphase);
        g_assert_cmpmem (&a, sizeof a, &b, sizeof b);
      }
    }
  }
}

/* The sums on several tables at once against the sum on each alone, bit
 * for bit (the velocity stage reads its lags either way): every group of
 * the fast versions (1 to 9 tables: whole groups of four and each
 * remainder), at every length. */
static void
test_steer_sums_phasors (gconstpointer data)
{
  const SonarSteerSumsPhasorsImpl *impl = data;
  const guint i = impl - sonar_kernel_steer_sums_phasors_impls;
  const SonarSteerSumPhasorsImpl *one =
      &sonar_kernel_steer_sum_phasors_impls[i];
  SonarRng rng;
  SonarComplex x[2882], sums[9];
  float re[9][2882], im[9][2882];
  const float *re_of[9], *im_of[9];

  g_assert_cmpstr (one->name, ==, impl->name);
  SKIP_UNLESS_AVAILABLE (impl);
  sonar_rng_init (&rng, 22, 0);
  for (guint t = 0; t < G_N_ELEMENTS (lengths); t++) {
    const guint n = lengths[t];
    for (guint j = 0; j < 9; j++) {
      sonar_kernel_steer_phasors_impls[i].fn (re[j], im[j], n,
          366.4 * 0.01 * (j - 4.0), 0.3814 * 8.0 * 0.01 * (j - 4.0));
      re_of[j] = re[j];
      im_of[j] = im[j];
    }
    for (guint n_tables = 0; n_tables <= 9; n_tables++) {
      random_spectrum (&rng, x, n);
      impl->fn (sums, x, re_of, im_of, n_tables, n);
      for (guint j = 0; j < n_tables; j++) {
        const SonarComplex alone = one->fn (x, re[j], im[j], n);
        g_assert_cmpmem (&sums[j], sizeof sums[j], &alone, sizeof alone);
      }
    }
  }
}

/* The use the block sums are made for: a matched filter's output at lag
 * offsets of up to two range bins (the velocity stage's window and its
 * quarter-bin refinement), summed over 16-bin blocks at the blocks'
 * centre frequencies, against the exact output. The signal is an echo of
 * the template (b) half a bin off the ramp's lag, in noise 10 dB below it
 * per bin. The band and phase steps are the default sensor's: 2882 bins
 * from 20 kHz, 0.38 rad per metre of path and bin. */
static void
test_block_sums_at_lag_offsets (void)
{
  const guint n = 2882, block = 16, n_blocks = (n + block - 1) / block;
  const double k0 = 366.4, dk = 0.3814, path = 3.217, bin = 0.0098;
  SonarRng rng;
  SonarComplex a[2882], b[2882], noise[2882], sums[181];
  float a_re[2882], a_im[2882], b_re[2882], b_im[2882];
  double peak = 0.0, worst = 0.0;

  sonar_rng_init (&rng, 16, 0);
  random_spectrum (&rng, b, n);
  random_spectrum (&rng, noise, n);
  for (guint k = 0; k < n; k++)
    a[k] = b[k] * cexp (-I * (k0 + dk * k) * (path + 0.5 * bin))
        + 0.3f * noise[k];
  sonar_kernel_split (a_re, a_im, a, n);
  sonar_kernel_split (b_re, b_im, b, n);
  sonar_kernel_steer_block_sums_conj (sums, a_re, a_im, b_re, b_im, n,
      k0 * path, dk * path, block);
  for (int q = -8; q <= 8; q++) {
    /* Quarter bins of 4.9 mm of range, 9.8 mm of path. */
    const double offset = q * 0.25 * bin;
    double magnitudes;
    const double complex exact = exact_dot_conj (a, b, n, k0 * (path +
            offset), dk * (path + offset), &magnitudes);
    const SonarComplex approx = sonar_kernel_steer_sum (sums, n_blocks,
        (k0 + dk * 0.5 * (block - 1)) * offset, dk * block * offset);
    peak = MAX (peak, cabs (exact));
    worst = MAX (worst, cabs (approx - exact));
  }
  g_test_message ("worst error relative to the peak: %.2e", worst / peak);
  /* 1e-3 measured: -60 dB, far below what moves a Doppler-ACF peak. */
  g_assert_cmpfloat (worst / peak, <, 2e-3);
}

/* The cases of the scaled product: Doppler stretches near 1 (the vector
 * code's loads), at its bounds (|step - 1| just under 1/8), exactly 1,
 * and far from it (0.6, 1.7: gathers); positions at the table's start
 * (x0 in [2, 3): the first tap is v[0]) and far in; slow and fast phase
 * ramps, one from a large phase. */
typedef struct
{
  double x0, step, phase0, dphase;
  float gain;
} ScaledCase;

static const ScaledCase scaled_cases[] = {
  {2.0, 1.0, 0.0, 0.0, 1.0f},
  {2.37, 1.02, 0.3, 0.01, 1.0f},
  {2.999, 0.98, -1.2, 0.7, 0.5f},
  {1000.5, 1.04, 1e4 + 0.3, -2.9, 2.0f},
  {3999.9, 0.96, 0.2, 0.001, 1.0f},
  {2.5, 1.124, 0.1, 0.05, 1.0f},
  {2.5, 0.876, 0.1, -0.05, 1.0f},
  {17.25, 1.0 + 1e-9, 0.4, 0.3, 1.0f},
  {3000.0, 1.0, 0.4, 1.3, 3.0f},
  {2.0, 1.3, 0.6, 0.02, 1.0f},
  {2.1, 0.6, 0.6, 2.0, 1.0f},
  {4000.75, 1.7, 0.6, 0.2, 0.25f},
  /* The AVX-512 version's bounds: its loads' way (every lane's node
   * within one of node_0 + l over 16 bins: |step - 1| < 1/15), its
   * permutes' (step < 1.73) and its gathers (up to 2). */
  {2.93, 1.0 + 1.0 / 15.0 - 1e-6, 0.2, 0.4, 1.0f},
  {2.01, 1.0 + 1.0 / 15.0 + 1e-6, 0.2, -0.4, 1.0f},
  {2.99, 1.0 - 1.0 / 15.0 + 1e-6, 0.2, 0.1, 1.0f},
  {2.0, 1.0 - 1.0 / 15.0 - 1e-6, 0.2, 0.1, 1.0f},
  {2.7, 1.729, 0.0, 0.3, 1.0f},
  {2.2, 1.731, 0.0, 0.3, 1.0f},
  {2.0, 2.0, 0.5, 0.5, 1.0f},
  {2.5, 0.5, 0.5, 0.5, 1.0f},
};

/* floor (x0 + k step) as the kernels compute it: the table holds the
 * taps of every bin k < n, v[0] .. v[node + 3] of the last bin. */
static gsize
scaled_table_length (const ScaledCase * c, guint n)
{
  return (gsize) floor (c->x0 + (n - 1) * c->step) + 4;
}

/* Every implementation against the reference on random data (tables of
 * the exact length the taps need, so that a read past them shows under
 * AddressSanitizer), bin by bin, within 1e-5 of max |r| max |v| gain: a
 * different order of float operations, no more. */
static void
test_scaled_product (gconstpointer data)
{
  enum { N = 2883 };
  static const guint scaled_lengths[] = { 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11,
    12, 13, 14, 15, 16, 17, 18, 23, 24, 25, 31, 32, 33, 47, 48, 49, 63, 64,
    65, 72, 79, 80, 81, 200, N
  };
  const SonarScaledProductImpl *impl = data;
  const SonarScaledProductFn reference =
      sonar_kernel_scaled_product_impls[0].fn;
  SonarRng rng;
  float r_re[N], r_im[N];
  SonarComplex fast[N], ref[N];

  SKIP_UNLESS_AVAILABLE (impl);
  sonar_rng_init (&rng, 41, 0);
  for (guint c = 0; c < G_N_ELEMENTS (scaled_cases); c++) {
    const ScaledCase *sc = &scaled_cases[c];
    for (guint t = 0; t < G_N_ELEMENTS (scaled_lengths); t++) {
      const guint n = scaled_lengths[t];
      const gsize length = scaled_table_length (sc, n);
      g_autofree float *v_re = g_new (float, length);
      g_autofree float *v_im = g_new (float, length);
      double r_max = 0.0, v_max = 0.0, scale;

      for (guint k = 0; k < n; k++) {
        r_re[k] = (float) sonar_rng_gaussian (&rng);
        r_im[k] = (float) sonar_rng_gaussian (&rng);
        r_max = MAX (r_max, hypot (r_re[k], r_im[k]));
      }
      for (gsize m = 0; m < length; m++) {
        v_re[m] = (float) sonar_rng_gaussian (&rng);
        v_im[m] = (float) sonar_rng_gaussian (&rng);
        v_max = MAX (v_max, hypot (v_re[m], v_im[m]));
      }
      scale = r_max * v_max * sc->gain;
      impl->fn (fast, r_re, r_im, v_re, v_im, n, sc->x0, sc->step,
          sc->phase0, sc->dphase, sc->gain);
      reference (ref, r_re, r_im, v_re, v_im, n, sc->x0, sc->step,
          sc->phase0, sc->dphase, sc->gain);
      for (guint k = 0; k < n; k++)
        if (!(cabsf (fast[k] - ref[k]) <= 1e-5 * scale)) {
          g_test_fail_printf ("x0 %g step %.10g n %u: bin %u is %g%+gi, "
              "the reference's %g%+gi (scale %g)", sc->x0, sc->step, n, k,
              crealf (fast[k]), cimagf (fast[k]), crealf (ref[k]),
              cimagf (ref[k]), scale);
          return;
        }
    }
  }
}

/* Every implementation against the product in double precision, V exact:
 * a table sampled from a sum of complex exponentials exp(i w x), |w| <=
 * 0.6 rad a sample, is interpolated within 3e-4 of the sum of their
 * amplitudes (6-point Lagrange's error there: at most 0.6^6 / 6! times
 * 3.5, 2.3e-4); a polynomial of degree 5 exactly, to float rounding, over
 * a stretch of a few dozen samples where each of its terms counts. */
static void
test_scaled_product_exact (gconstpointer data)
{
  enum { N = 2883, WAVES = 4, POLY_N = 24 };
  const SonarScaledProductImpl *impl = data;
  SonarRng rng;
  float r_re[N], r_im[N];
  SonarComplex out[N];

  SKIP_UNLESS_AVAILABLE (impl);
  sonar_rng_init (&rng, 43, 0);
  for (guint c = 0; c < G_N_ELEMENTS (scaled_cases); c++) {
    const ScaledCase *sc = &scaled_cases[c];
    double complex amplitude[WAVES], coefficient[6];
    double omega[WAVES], amplitudes = 0.0;

    for (guint k = 0; k < N; k++) {
      r_re[k] = (float) sonar_rng_gaussian (&rng);
      r_im[k] = (float) sonar_rng_gaussian (&rng);
    }
    for (guint j = 0; j < WAVES; j++) {
      /* The last at the bound, 0.6 or -0.6. */
      omega[j] = j == WAVES - 1 ? (c % 2 ? 0.6 : -0.6) :
          0.6 * (2.0 * sonar_rng_uniform (&rng) - 1.0);
      amplitude[j] = sonar_rng_gaussian (&rng) + I * sonar_rng_gaussian (&rng);
      amplitudes += cabs (amplitude[j]);
    }
    for (guint j = 0; j < 6; j++)
      coefficient[j] = sonar_rng_gaussian (&rng) + I *
          sonar_rng_gaussian (&rng);

    for (int polynomial = 0; polynomial < 2; polynomial++) {
      const guint n = polynomial ? POLY_N : c % 2 ? N : 1001;
      const gsize length = scaled_table_length (sc, n);
      /* The polynomial's variable, (x - centre) / quarter: within [-2,
       * 2] over the bins' positions. */
      const double centre = sc->x0 + 0.5 * (n - 1) * sc->step;
      const double quarter = 0.25 * n * sc->step;
      g_autofree float *v_re = g_new (float, length);
      g_autofree float *v_im = g_new (float, length);
      double worst = 0.0, tolerance;
      guint worst_k = 0;

      for (gsize m = 0; m < length; m++) {
        double complex v = 0.0;
        if (polynomial)
          for (int j = 5; j >= 0; j--)
            v = v * ((m - centre) / quarter) + coefficient[j];
        else
          for (guint j = 0; j < WAVES; j++)
            v += amplitude[j] * cexp (I * omega[j] * m);
        v_re[m] = (float) creal (v);
        v_im[m] = (float) cimag (v);
      }
      impl->fn (out, r_re, r_im, v_re, v_im, n, sc->x0, sc->step,
          sc->phase0, sc->dphase, sc->gain);
      for (guint k = 0; k < n; k++) {
        const double x = sc->x0 + k * sc->step;
        const double complex r = r_re[k] + I * (double) r_im[k];
        double complex v = 0.0, exact;
        double scale = 0.0, error;
        if (polynomial) {
          /* Against the largest of the bin's taps: float rounding's
           * scale. */
          const gsize node = (gsize) floor (x);
          for (gsize m = node - 2; m <= node + 3; m++)
            scale = MAX (scale, hypot (v_re[m], v_im[m]));
          for (int j = 5; j >= 0; j--)
            v = v * ((x - centre) / quarter) + coefficient[j];
        } else {
          scale = amplitudes;
          for (guint j = 0; j < WAVES; j++)
            v += amplitude[j] * cexp (I * omega[j] * x);
        }
        exact = sc->gain * cexp (I * (sc->phase0 + k * sc->dphase)) * r * v;
        error = cabs (out[k] - exact) / (sc->gain * cabs (r) * scale);
        if (error > worst) {
          worst = error;
          worst_k = k;
        }
      }
      tolerance = polynomial ? 2e-6 : 3e-4;
      g_test_message ("%s, x0 %g step %g: worst relative error %.3g at "
          "bin %u", polynomial ? "polynomial" : "exponentials", sc->x0,
          sc->step, worst, worst_k);
      if (!(worst <= tolerance)) {
        g_test_fail_printf ("%s, x0 %g step %g n %u: bin %u's relative "
            "error %.3g is above %.3g", polynomial ? "a polynomial" :
            "exponentials", sc->x0, sc->step, n, worst_k, worst, tolerance);
        return;
      }
    }
  }
}

#ifdef G_OS_UNIX
/* @length floats with an inaccessible page right after them (@after) or
 * right before them: a read past the table's end (start) faults even
 * from a masked load's lanes that are not masked, which AddressSanitizer
 * does not follow. Freed by guarded_free (). */
static float *
guarded_new (gsize length, gboolean after, gpointer * mapping, gsize * size)
{
  const gsize page = (gsize) sysconf (_SC_PAGESIZE);
  const gsize data = (length * sizeof (float) + page - 1) / page * page;
  guint8 *base;

  *size = data + page;
  base = mmap (NULL, *size, PROT_READ | PROT_WRITE, MAP_PRIVATE |
      MAP_ANONYMOUS, -1, 0);
  g_assert_true (base != MAP_FAILED);
  *mapping = base;
  if (after) {
    g_assert_cmpint (mprotect (base + data, page, PROT_NONE), ==, 0);
    return (float *) (base + data) - length;
  }
  g_assert_cmpint (mprotect (base, page, PROT_NONE), ==, 0);
  return (float *) (base + page);
}

/* Every implementation on tables of exactly the taps' length, their end
 * (their start) against an inaccessible page: none reads a float outside
 * them, masked loads included. */
static void
test_scaled_product_guarded (gconstpointer data)
{
  enum { N = 700 };
  static const guint guarded_lengths[] = { 1, 5, 15, 16, 17, 31, 32, 33,
    64, 65, 79, 80, 81, N
  };
  const SonarScaledProductImpl *impl = data;
  const SonarScaledProductFn reference =
      sonar_kernel_scaled_product_impls[0].fn;
  SonarRng rng;
  float r_re[N], r_im[N];
  SonarComplex fast[N], ref[N];
  double r_max = 0.0;

  SKIP_UNLESS_AVAILABLE (impl);
  sonar_rng_init (&rng, 47, 0);
  for (guint k = 0; k < N; k++) {
    r_re[k] = (float) sonar_rng_gaussian (&rng);
    r_im[k] = (float) sonar_rng_gaussian (&rng);
    r_max = MAX (r_max, hypot (r_re[k], r_im[k]));
  }
  for (guint c = 0; c < G_N_ELEMENTS (scaled_cases); c++) {
    ScaledCase sc = scaled_cases[c];
    /* Near the table's start, where its first tap is v[0]. */
    sc.x0 = 2.0 + fmod (sc.x0, 1.0);
    for (guint t = 0; t < G_N_ELEMENTS (guarded_lengths); t++) {
      for (int after = 0; after < 2; after++) {
        const guint n = guarded_lengths[t];
        const gsize length = scaled_table_length (&sc, n);
        gpointer map_re, map_im;
        gsize size_re, size_im;
        float *v_re = guarded_new (length, after, &map_re, &size_re);
        float *v_im = guarded_new (length, after, &map_im, &size_im);
        double v_max = 0.0, scale;

        for (gsize m = 0; m < length; m++) {
          v_re[m] = (float) sonar_rng_gaussian (&rng);
          v_im[m] = (float) sonar_rng_gaussian (&rng);
          v_max = MAX (v_max, hypot (v_re[m], v_im[m]));
        }
        scale = r_max * v_max * sc.gain;
        impl->fn (fast, r_re, r_im, v_re, v_im, n, sc.x0, sc.step,
            sc.phase0, sc.dphase, sc.gain);
        reference (ref, r_re, r_im, v_re, v_im, n, sc.x0, sc.step,
            sc.phase0, sc.dphase, sc.gain);
        munmap (map_re, size_re);
        munmap (map_im, size_im);
        for (guint k = 0; k < n; k++)
          if (!(cabsf (fast[k] - ref[k]) <= 1e-5 * scale)) {
            g_test_fail_printf ("x0 %g step %.10g n %u: bin %u is "
                "%g%+gi, the reference's %g%+gi", sc.x0, sc.step, n, k,
                crealf (fast[k]), cimagf (fast[k]), crealf (ref[k]),
                cimagf (ref[k]));
            return;
          }
      }
    }
  }
}
#endif

/* The envelope against its reference: the same float operations, so
 * equal to a rounding (ORC's sqrt may differ in the last bit), and bit for
 * bit for the others (their squares summed unfused, as the reference's).
 * tools/test runs the suite under ORC_CODE=backup too, so ORC's C backup
 * is checked as well. */
static void
test_envelope (gconstpointer data)
{
  const SonarEnvelopeImpl *impl = data;
  const SonarEnvelopeFn reference = sonar_kernel_envelope_impls[0].fn;
  SonarRng rng;
  SonarComplex a[2882];
  float env[2882], ref[2882];

  SKIP_UNLESS_AVAILABLE (impl);
  sonar_rng_init (&rng, 19, 0);
  for (guint t = 0; t < G_N_ELEMENTS (lengths); t++) {
    const guint n = lengths[t];
    random_spectrum (&rng, a, n);
    for (int accumulate = 0; accumulate < 2; accumulate++) {
      for (guint k = 0; k < n; k++)
        env[k] = ref[k] = (float) (k % 5);
      impl->fn (env, a, n, 0.75f, accumulate);
      reference (ref, a, n, 0.75f, accumulate);
      for (guint k = 0; k < n; k++) {
        const float want = accumulate ? MAX ((float) (k % 5),
            0.75f * cabsf (a[k])) : 0.75f * cabsf (a[k]);
        g_assert_cmpfloat (fabsf (env[k] - ref[k]), <=, 1e-6f * ref[k]);
        g_assert_cmpfloat (fabsf (env[k] - want), <=, 1e-6f * want);
        if (strcmp (impl->name, "orc") != 0)
          g_assert_cmpmem (&env[k], sizeof (float), &ref[k], sizeof (float));
      }
    }
  }
}

/* Bit for bit over many bins: a fused square differs from the
 * reference's after the square root once in thousands of bins (clang at
 * -ffp-contract=fast fused them, and the lengths above all matched). */
static void
test_envelope_unfused (gconstpointer data)
{
  const SonarEnvelopeImpl *impl = data;
  const guint n = 200000;
  SonarRng rng;
  g_autofree SonarComplex *a = g_new (SonarComplex, n);
  g_autofree float *env = g_new (float, n);
  g_autofree float *ref = g_new (float, n);

  SKIP_UNLESS_AVAILABLE (impl);
  if (strcmp (impl->name, "orc") == 0) {
    g_test_skip ("ORC's sqrt may differ in the last bit");
    return;
  }
  sonar_rng_init (&rng, 31, 0);
  random_spectrum (&rng, a, n);
  /* Whole vectors, then calls of 7 bins: tails alone. */
  for (guint tail = 0; tail < 2; tail++)
    for (int accumulate = 0; accumulate < 2; accumulate++) {
      const guint step = tail ? 7 : n;
      for (guint k = 0; k < n; k++)
        env[k] = ref[k] = 0.5f;
      for (guint k = 0; k + step <= n; k += step) {
        impl->fn (env + k, a + k, step, 0.75f, accumulate);
        sonar_kernel_envelope_impls[0].fn (ref + k, a + k, step, 0.75f,
            accumulate);
      }
      g_assert_cmpmem (env, n * sizeof (float), ref, n * sizeof (float));
    }
}

/* The phase ramp is right in absolute terms: a single bin recovers
 * exp(i phase) to float precision. */
static void
test_phase_ramp_exact (gconstpointer data)
{
  const SonarSteerSumSplitImpl *impl = data;
  const double phase0 = 0.25, dphase = 0.01;
  float one[70], zero[70] = { 0 }, acc_re[70], acc_im[70];

  SKIP_UNLESS_AVAILABLE (impl);
  for (guint k = 0; k < 70; k++)
    one[k] = 1.0f;
  impl->fn (acc_re, acc_im, one, zero, 70, 1, 70, &phase0, &dphase, FALSE);
  for (guint k = 0; k < 70; k++)
    g_assert_cmpfloat (cabs (acc_re[k] + I * acc_im[k] - cexp (I * (0.25 +
                    0.01 * k))), <, 1e-6);
}

/* Single-precision accumulation over long sums against a double-precision
 * evaluation of the same sum: the error stays near float's resolution of
 * the sum's scale, not growing with the length. The velocity stage's sum:
 * 16-bin blocks (@data's implementation), then the sum over the blocks. */
static void
test_long_sums_against_double (gconstpointer data)
{
  const SonarSteerBlockSumsConjImpl *impl = data;
  const guint lengths_long[] = { 2882, 20000, 100000 };
  SonarRng rng;

  SKIP_UNLESS_AVAILABLE (impl);
  sonar_rng_init (&rng, 13, 0);
  for (guint t = 0; t < G_N_ELEMENTS (lengths_long); t++) {
    const guint n = lengths_long[t];
    const double phase0 = 3.0, dphase = 0.0123;
    const guint n_blocks = (n + 15) / 16;
    SonarComplex *a = g_new (SonarComplex, n), *b = g_new (SonarComplex, n);
    SonarComplex *blocks = g_new (SonarComplex, n_blocks);
    float *a_re = g_new (float, n), *a_im = g_new (float, n);
    float *b_re = g_new (float, n), *b_im = g_new (float, n);
    double complex exact;
    double scale, error;

    random_spectrum (&rng, a, n);
    random_spectrum (&rng, b, n);
    exact = exact_dot_conj (a, b, n, phase0, dphase, &scale);
    sonar_kernel_split (a_re, a_im, a, n);
    sonar_kernel_split (b_re, b_im, b, n);
    impl->fn (blocks, a_re, a_im, b_re, b_im, n, phase0, dphase, 16);
    error = cabs (sonar_kernel_steer_sum (blocks, n_blocks, 0.0, 0.0) -
        exact) / scale;
    g_test_message ("n %u: error relative to sum |terms|: %.2e", n, error);
    g_assert_cmpfloat (error, <, 2e-6);
    g_free (a);
    g_free (b);
    g_free (blocks);
    g_free (a_re);
    g_free (a_im);
    g_free (b_re);
    g_free (b_im);
  }
}

/* The entry points call the last implementation the CPU has, not the
 * reference behind its back: their results are bit-identical to it. */
static void
test_entry_points_choose_best (void)
{
  const SonarSteerSumImpl *best = NULL;
  SonarRng rng;
  SonarComplex x[200];
  SonarComplex via_entry, via_table;

  for (const SonarSteerSumImpl * i = sonar_kernel_steer_sum_impls; i->name;
      i++)
    if (i->available ())
      best = i;
  g_test_message ("steer_sum runs \"%s\"", best->name);
  sonar_rng_init (&rng, 20, 0);
  random_spectrum (&rng, x, 200);
  via_entry = sonar_kernel_steer_sum (x, 200, 1.25, 0.37);
  via_table = best->fn (x, 200, 1.25, 0.37);
  g_assert_cmpmem (&via_entry, sizeof via_entry, &via_table,
      sizeof via_table);
}

/* The peak of non-negative values (an envelope, r^2 weights), weighted
 * or not, equal to the reference bit for bit (a maximum and one product
 * each: no rounding to differ in), every length's tail included; a NaN
 * never wins, wherever it lies. */
static void
test_peak (gconstpointer data)
{
  const SonarPeakImpl *impl = data;
  const SonarPeakFn reference = sonar_kernel_peak_impls[0].fn;
  SonarRng rng;
  float x[2882], w[2882];

  SKIP_UNLESS_AVAILABLE (impl);
  sonar_rng_init (&rng, 23, 0);
  for (guint t = 0; t < G_N_ELEMENTS (lengths); t++) {
    const guint n = lengths[t];
    for (guint k = 0; k < n; k++) {
      x[k] = (float) sonar_rng_uniform (&rng);
      w[k] = (float) (1.0 + 25.0 * sonar_rng_uniform (&rng));
    }
    for (guint top = 0; top < n; top += MAX (1u, n / 7)) {
      float want = 0.0f, want_weighted = 0.0f, peak, weighted;
      x[top] += 2.0f;
      for (guint k = 0; k < n; k++) {
        want = MAX (want, x[k]);
        want_weighted = MAX (want_weighted, x[k] * w[k]);
      }
      peak = impl->fn (x, NULL, n);
      weighted = impl->fn (x, w, n);
      g_assert_cmpfloat (peak, ==, want);
      g_assert_cmpfloat (weighted, ==, want_weighted);
      g_assert_cmpfloat (peak, ==, reference (x, NULL, n));
      g_assert_cmpfloat (weighted, ==, reference (x, w, n));
      x[top] = NAN;
      peak = impl->fn (x, NULL, n);
      g_assert_false (isnan (peak));
      g_assert_cmpfloat (peak, <=, want);
      x[top] = want - 2.0f;
    }
    g_assert_cmpfloat (impl->fn (x, NULL, 0), ==, 0.0f);
  }
}

/* The correlation at consecutive lags against the reference's double
 * sums, every length's tail and 1-9 lags: within 1e-6 of the sum of |x
 * w| (float lanes over up to 4100 samples). */
static void
test_correlate (gconstpointer data)
{
  const SonarCorrelateImpl *impl = data;
  const guint sizes[] = { 0, 1, 7, 16, 17, 63, 200, 4000, 4100 };
  const guint max_lags = 9;
  SonarRng rng;
  g_autofree float *x = g_new (float, 4100 + max_lags);
  g_autofree float *w = g_new (float, 4100);
  float got[9], want[9];

  SKIP_UNLESS_AVAILABLE (impl);
  sonar_rng_init (&rng, 41, 0);
  for (guint i = 0; i < 4100 + max_lags; i++)
    x[i] = (float) (100.0 * sonar_rng_gaussian (&rng));
  for (guint i = 0; i < 4100; i++)
    w[i] = (float) sonar_rng_gaussian (&rng);
  for (guint t = 0; t < G_N_ELEMENTS (sizes); t++)
    for (guint lags = 1; lags <= max_lags; lags += 4) {
      const guint n = sizes[t];
      impl->fn (got, x, w, n, lags);
      sonar_kernel_correlate_impls[0].fn (want, x, w, n, lags);
      for (guint l = 0; l < lags; l++) {
        double scale = 0.0, exact = 0.0;
        for (guint i = 0; i < n; i++) {
          scale += fabs ((double) x[i + l] * w[i]);
          exact += (double) x[i + l] * w[i];
        }
        g_assert_cmpfloat (fabs (want[l] - exact), <=, 1e-7 * scale + 1e-30);
        g_assert_cmpfloat (fabs (got[l] - exact), <=, 1e-6 * scale + 1e-30);
      }
    }
}

/* y += a x, every length's tail, against the reference within a rounding
 * of each element (the fast version may fuse the product and the sum);
 * y beyond n untouched. */
static void
test_axpy (gconstpointer data)
{
  const SonarAxpyImpl *impl = data;
  SonarRng rng;
  float x[2883], y[2883], want[2883];

  SKIP_UNLESS_AVAILABLE (impl);
  sonar_rng_init (&rng, 43, 0);
  for (guint t = 0; t < G_N_ELEMENTS (lengths); t++) {
    const guint n = lengths[t];
    for (guint i = 0; i <= n; i++) {
      x[i] = (float) sonar_rng_gaussian (&rng);
      y[i] = want[i] = (float) sonar_rng_gaussian (&rng);
    }
    impl->fn (y, x, -0.37f, n);
    sonar_kernel_axpy_impls[0].fn (want, x, -0.37f, n);
    for (guint i = 0; i < n; i++)
      g_assert_cmpfloat (fabsf (y[i] - want[i]), <=,
          2e-7f * (fabsf (want[i]) + 0.37f * fabsf (x[i])));
    g_assert_cmpfloat (y[n], ==, want[n]);
  }
}

/* Each block's peak, the reference's peak of it bit for bit, for blocks
 * of whole vectors and not, every length's tail included: a NaN never
 * wins, -0 gives +0, a block of negatives 0. */
static void
test_block_peaks (gconstpointer data)
{
  const SonarBlockPeaksImpl *impl = data;
  const guint blocks[] = { 16, 8, 32, 12, 1 };
  SonarRng rng;
  float x[2882], out[2882];

  SKIP_UNLESS_AVAILABLE (impl);
  sonar_rng_init (&rng, 29, 0);
  for (guint t = 0; t < G_N_ELEMENTS (lengths); t++) {
    const guint n = lengths[t];
    for (guint k = 0; k < n; k++)
      x[k] = (float) (sonar_rng_uniform (&rng) - 0.25);
    for (guint k = 0; k < n; k += 7)
      x[k] = k % 3 ? NAN : -0.0f;
    for (guint c = 0; c < G_N_ELEMENTS (blocks); c++) {
      const guint block = blocks[c];
      impl->fn (out, x, n, block);
      for (guint b = 0; b * block < n; b++) {
        const float want = sonar_kernel_peak_impls[0].fn (x + b * block,
            NULL, MIN (block, n - b * block));
        g_assert_false (isnan (out[b]));
        g_assert_cmpmem (&out[b], sizeof (float), &want, sizeof (float));
      }
    }
  }
}

/* The running maximum, bit for bit, every length's tail included. */
static void
test_max (gconstpointer data)
{
  const SonarMaxImpl *impl = data;
  SonarRng rng;
  float x[2882], out[2882], kept[2882];

  SKIP_UNLESS_AVAILABLE (impl);
  sonar_rng_init (&rng, 29, 0);
  for (guint t = 0; t < G_N_ELEMENTS (lengths); t++) {
    const guint n = lengths[t];
    for (guint k = 0; k < n; k++) {
      x[k] = (float) sonar_rng_uniform (&rng);
      out[k] = kept[k] = (float) sonar_rng_uniform (&rng);
    }
    impl->fn (out, x, n);
    for (guint k = 0; k < n; k++)
      g_assert_cmpfloat (out[k], ==, MAX (kept[k], x[k]));
  }
}

/* Channels of interleaved frames made contiguous, bit for bit (-0, a
 * denormal and the largest float kept as they are, NaNs and infinities
 * written as +0 and counted), for channel counts around the fast
 * versions' blocks of 8 and every length's tail, in frames wider than
 * the channels; nothing is written past a channel's @n samples. */
static void
test_deinterleave (gconstpointer data)
{
  const SonarDeinterleaveImpl *impl = data;
  const guint channels[] = { 1, 7, 8, 9, 16, 17 };
  const float special[] = { NAN, INFINITY, -INFINITY, -0.0f, 1e-40f,
    FLT_MAX
  };
  const float guard = 12345.0f;
  const gsize stride = 17 + 5;
  SonarRng rng;
  g_autofree float *frames = g_new (float, 2882 * stride);
  g_autofree float *want = g_new (float, 2882);
  float *out[17];

  SKIP_UNLESS_AVAILABLE (impl);
  sonar_rng_init (&rng, 41, 0);
  for (gsize k = 0; k < 2882 * stride; k++)
    frames[k] = (float) sonar_rng_gaussian (&rng);
  for (guint s = 0; s < 40; s++)
    frames[sonar_rng_next (&rng) % (2882 * stride)] =
        special[s % G_N_ELEMENTS (special)];
  for (guint k = 0; k < G_N_ELEMENTS (out); k++)
    out[k] = g_new (float, 2882 + 1);
  for (guint c = 0; c < G_N_ELEMENTS (channels); c++) {
    const guint n_out = channels[c];
    for (guint t = 0; t < G_N_ELEMENTS (lengths); t++) {
      const guint n = lengths[t];
      guint bad = 0, counted;
      for (guint k = 0; k < n_out; k++)
        out[k][n] = guard;
      counted = impl->fn (out, n_out, frames, stride, n);
      for (guint k = 0; k < n_out; k++) {
        for (guint i = 0; i < n; i++) {
          const float x = frames[i * stride + k];
          want[i] = isfinite (x) ? x : 0.0f;
          bad += isfinite (x) ? 0 : 1;
        }
        g_assert_cmpmem (out[k], sizeof (float) * n, want,
            sizeof (float) * n);
        g_assert_cmpfloat (out[k][n], ==, guard);
      }
      g_assert_cmpuint (counted, ==, bad);
    }
  }
  for (guint k = 0; k < G_N_ELEMENTS (out); k++)
    g_free (out[k]);
}

/* One pass of the order statistics over a block of lanes, against the
 * definition counted lane by lane: the count below each lane's level,
 * the two largest values below it and the two smallest at or above it
 * (a tie is two values), the finite count; with ties at the level, NaNs and infinities among the rows, a
 * stride wider than the lanes, levels of +-inf and no rows at all. */
static void
test_rank_pass (gconstpointer data)
{
  const SonarRankPassImpl *impl = data;
  const guint rows_tried[] = { 0, 1, 3, 181, 921 };
  const gsize stride = SONAR_RANK_LANES + 5;
  SonarRng rng;
  g_autofree float *x = g_new (float, 921 * stride);

  SKIP_UNLESS_AVAILABLE (impl);
  sonar_rng_init (&rng, 31, 0);
  for (guint t = 0; t < G_N_ELEMENTS (rows_tried); t++) {
    const guint n = rows_tried[t];
    for (int with_specials = 0; with_specials < 2; with_specials++) {
      float level[SONAR_RANK_LANES], under[2 * SONAR_RANK_LANES],
          over[2 * SONAR_RANK_LANES];
      guint32 below[SONAR_RANK_LANES], finite[SONAR_RANK_LANES];

      for (gsize k = 0; k < n * stride; k++) {
        /* Coarse values: many ties, some at the levels. */
        x[k] = (float) floor (16.0 * sonar_rng_uniform (&rng)) * 0.25f;
        if (with_specials && sonar_rng_uniform (&rng) < 0.05)
          x[k] = sonar_rng_uniform (&rng) < 0.5 ? NAN :
              (sonar_rng_uniform (&rng) < 0.5 ? INFINITY : -INFINITY);
      }
      for (guint j = 0; j < SONAR_RANK_LANES; j++)
        level[j] = j == 0 ? -INFINITY : j == 1 ? INFINITY :
            (float) floor (16.0 * sonar_rng_uniform (&rng)) * 0.25f;
      for (int with_finite = 0; with_finite < 2; with_finite++) {
        impl->fn (x, stride, n, level, below, under, over,
            with_finite ? finite : NULL);
        for (guint j = 0; j < SONAR_RANK_LANES; j++) {
          guint32 want_below = 0, want_finite = 0;
          float want_under[2] = { -INFINITY, -INFINITY };
          float want_over[2] = { INFINITY, INFINITY };
          for (guint r = 0; r < n; r++) {
            const float v = x[r * stride + j];
            if (v < level[j]) {
              want_below++;
              if (v > want_under[0]) {
                want_under[1] = want_under[0];
                want_under[0] = v;
              } else
                want_under[1] = MAX (want_under[1], v);
            } else if (v >= level[j]) {
              if (v < want_over[0]) {
                want_over[1] = want_over[0];
                want_over[0] = v;
              } else
                want_over[1] = MIN (want_over[1], v);
            }
            want_finite += isfinite (v);
          }
          g_assert_cmpuint (below[j], ==, want_below);
          for (guint k = 0; k < 2; k++) {
            g_assert_cmpfloat (under[k * SONAR_RANK_LANES + j], ==,
                want_under[k]);
            g_assert_cmpfloat (over[k * SONAR_RANK_LANES + j], ==,
                want_over[k]);
          }
          if (with_finite)
            g_assert_cmpuint (finite[j], ==, want_finite);
        }
      }
    }
  }
}

/* The upper halves of the vector registers after a kernel ---------------*/

/* An AVX kernel that returns with the upper halves of the ymm (zmm)
 * registers set leaves every SSE and scalar float instruction after it
 * (the callers' code, libm's log and exp: they are built for the
 * baseline) paying the AVX-SSE transition until some other code clears
 * them: ramp_finish_avx2 () did, and the velocity stage took twice its
 * CPU time. XGETBV with ECX = 1 reads XINUSE, the state components not
 * in their initial state: bit 2 is the upper halves of ymm0-15, bit 6
 * those of zmm0-15, both cleared by VZEROUPPER. (Bit 7, zmm16-31, is
 * not: SSE code cannot reach them, and no penalty is paid for them.) */
#if defined(__x86_64__) && defined(__GNUC__)
#include <cpuid.h>
#define XINUSE_DIRTY ((1u << 2) | (1u << 6))

/* The helpers spell AVX instructions: clang checks inline assembly
 * against the function's target. */
__attribute__ ((target ("avx,xsave"), noinline)) static guint32
xinuse (void)
{
  guint32 lo, hi;
  __asm__ volatile ("xgetbv" : "=a" (lo), "=d" (hi) : "c" (1));
  return lo;
}

__attribute__ ((target ("avx"), noinline)) static void
upper_clear (void)
{
  __asm__ volatile ("vzeroupper" ::: "memory");
}

/* XINUSE with an upper half set: read in the same statement, since gcc
 * ends a function whose assembly clobbers a vector register with a
 * vzeroupper. */
__attribute__ ((target ("avx,xsave"), noinline)) static guint32
xinuse_upper_set (void)
{
  guint32 lo, hi;
  __asm__ volatile ("vpcmpeqd %%ymm15, %%ymm15, %%ymm15\n\t"
      "xgetbv" : "=a" (lo), "=d" (hi) : "c" (1) : "xmm15");
  return lo;
}

/* Whether XINUSE can be read, and tracks the upper halves here (a
 * virtual machine or an emulator may report them always in use). */
static gboolean
xinuse_usable (void)
{
  guint a, b, c, d;

  if (!__get_cpuid (1, &a, &b, &c, &d) || !(c & bit_OSXSAVE)
      || !(c & bit_AVX))
    return FALSE;
  if (__get_cpuid_max (0, NULL) < 0xd)
    return FALSE;
  __cpuid_count (0xd, 1, a, b, c, d);
  if (!(a & (1u << 2)))         /* XGETBV with ECX = 1 */
    return FALSE;
  upper_clear ();
  if (xinuse () & XINUSE_DIRTY)
    return FALSE;
  if (!(xinuse_upper_set () & (1u << 2)))
    return FALSE;
  upper_clear ();
  return TRUE;
}

/* Fails unless @call (a statement calling the kernel on @n bins) returns with the
 * upper halves clear; they are cleared before it, so that it is the
 * kernel's state that is read. */
#define ASSERT_UPPER_CLEAN_AFTER(what, call) G_STMT_START {            \
  guint32 state_;                                                       \
  upper_clear ();                                                       \
  call;                                                                 \
  state_ = xinuse ();                                                   \
  if (state_ & XINUSE_DIRTY) {                                          \
    g_test_fail_printf ("%s (n %u) returned with the upper halves of "  \
        "the vector registers in use (XINUSE 0x%x): it needs a "        \
        "vzeroupper", (what), n, state_);                               \
    return;                                                             \
  }                                                                     \
} G_STMT_END
#define HAVE_XINUSE 1
#endif

/* Every implementation of every kernel of the tables, on a length with a
 * tail after the whole vectors and on one without (their return paths
 * differ), returns with the upper halves of the vector registers clear. */
typedef struct
{
  const char *kernel;
  const char *name;
    gboolean (*available) (void);
  guint table;
  guint index;
} UpperCase;

static void
test_upper_clean (gconstpointer data)
{
#ifdef HAVE_XINUSE
  const UpperCase *u = data;
  const guint lengths_tried[] = { 2882, 2880, 64, 9 };
  const float *re_tables[5], *im_tables[5];
  const gsize stride = 2882;
  g_autofree float *a = g_new0 (float, 9 * stride);
  g_autofree float *b = g_new0 (float, 9 * stride);
  g_autofree float *re = g_new0 (float, 5 * stride);
  g_autofree float *im = g_new0 (float, 5 * stride);
  g_autofree float *f = g_new0 (float, 9 * stride);
  g_autofree SonarComplex *x = g_new0 (SonarComplex, stride);
  g_autofree SonarComplex *out = g_new0 (SonarComplex, stride);
  const double phase0[9] = { 0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8, 0.9 };
  const double dphase[9] = { 0.01, 0.02, 0.03, 0.04, 0.05, 0.06, 0.07,
    0.08, 0.09
  };
  float level[SONAR_RANK_LANES], under[2 * SONAR_RANK_LANES],
      over[2 * SONAR_RANK_LANES];
  guint32 below[SONAR_RANK_LANES], finite[SONAR_RANK_LANES];
  float *deinterleaved[9];
  volatile float sink = 0.0f;
  SonarRng rng;

  if (!u->available ()) {
    g_test_skip_printf ("the CPU lacks what \"%s\" needs", u->name);
    return;
  }
  if (!xinuse_usable ()) {
    g_test_skip ("XGETBV cannot read XINUSE's AVX state here");
    return;
  }
  sonar_rng_init (&rng, 37, 0);
  random_spectrum (&rng, x, stride);
  for (gsize k = 0; k < 9 * stride; k++) {
    a[k] = (float) sonar_rng_gaussian (&rng);
    b[k] = (float) sonar_rng_gaussian (&rng);
    f[k] = (float) sonar_rng_uniform (&rng);
  }
  for (guint j = 0; j < SONAR_RANK_LANES; j++)
    level[j] = 0.5f;
  for (guint k = 0; k < G_N_ELEMENTS (deinterleaved); k++)
    deinterleaved[k] = a + k * stride;
  for (guint t = 0; t < 5; t++) {
    re_tables[t] = re + t * stride;
    im_tables[t] = im + t * stride;
    sonar_kernel_steer_phasors_impls[0].fn (re + t * stride,
        im + t * stride, stride, phase0[t], dphase[t]);
  }

  for (guint l = 0; l < G_N_ELEMENTS (lengths_tried); l++) {
    const guint n = lengths_tried[l];
    const guint i = u->index;
    SonarComplex z = 0.0f;
    switch (u->table) {
      case 0:
        for (guint c = 1; c <= 9; c++)
          ASSERT_UPPER_CLEAN_AFTER (u->kernel,
              sonar_kernel_steer_sum_split_impls[i].fn (f, f + stride, a,
                  b, stride, c, n, phase0, dphase, c % 2));
        break;
      case 1:
        ASSERT_UPPER_CLEAN_AFTER (u->kernel,
            sonar_kernel_steer_block_sums_conj_impls[i].fn (out, a, a +
                stride, b, b + stride, n, 0.3, 0.01, 16));
        break;
      case 2:
        ASSERT_UPPER_CLEAN_AFTER (u->kernel,
            sonar_kernel_block8_sums_conj_impls[i].fn (out, a, a + stride,
                b, b + stride, SONAR_BLOCK8_PADDED (n), 0.3, 0.01));
        break;
      case 3:
        ASSERT_UPPER_CLEAN_AFTER (u->kernel, z =
            sonar_kernel_steer_sum_impls[i].fn (x, n, 0.3, 0.01));
        break;
      case 4:
        ASSERT_UPPER_CLEAN_AFTER (u->kernel,
            sonar_kernel_steer_phasors_impls[i].fn (f, f + stride, n, 0.3,
                0.01));
        break;
      case 5:
        ASSERT_UPPER_CLEAN_AFTER (u->kernel, z =
            sonar_kernel_steer_sum_phasors_impls[i].fn (x, re, im, n));
        break;
      case 6:
        for (guint t = 1; t <= 5; t++)
          ASSERT_UPPER_CLEAN_AFTER (u->kernel,
              sonar_kernel_steer_sums_phasors_impls[i].fn (out, x,
                  re_tables, im_tables, t, n));
        break;
      case 8:
        for (int acc = 0; acc < 2; acc++)
          ASSERT_UPPER_CLEAN_AFTER (u->kernel,
              sonar_kernel_envelope_impls[i].fn (f, x, n, 0.5f, acc));
        break;
      case 9:
        ASSERT_UPPER_CLEAN_AFTER (u->kernel, sink +=
            sonar_kernel_peak_impls[i].fn (f, NULL, n));
        ASSERT_UPPER_CLEAN_AFTER (u->kernel, sink +=
            sonar_kernel_peak_impls[i].fn (f, f + stride, n));
        break;
      case 10:
        ASSERT_UPPER_CLEAN_AFTER (u->kernel,
            sonar_kernel_max_impls[i].fn (f, f + stride, n));
        break;
      case 11:
        for (int with_finite = 0; with_finite < 2; with_finite++)
          ASSERT_UPPER_CLEAN_AFTER (u->kernel,
              sonar_kernel_rank_pass_impls[i].fn (f, SONAR_RANK_LANES + 3,
                  n / 8, level, below, under, over,
                  with_finite ? finite : NULL));
        break;
      case 13:
        ASSERT_UPPER_CLEAN_AFTER (u->kernel, sink +=
            sonar_kernel_deinterleave_impls[i].fn (deinterleaved, 9, f, 9,
                n));
        break;
      case 14:
        ASSERT_UPPER_CLEAN_AFTER (u->kernel,
            sonar_kernel_block_peaks_impls[i].fn (f + stride, f, n, 16));
        break;
      case 15:
        ASSERT_UPPER_CLEAN_AFTER (u->kernel,
            sonar_kernel_correlate_impls[i].fn (f + 8 * stride, a, b, n, 7));
        break;
      case 16:
        ASSERT_UPPER_CLEAN_AFTER (u->kernel,
            sonar_kernel_axpy_impls[i].fn (f, a, 0.5f, n));
        break;
      default:
        /* A stretch of the vector loads, then one of the gathers; the
         * tables' taps reach 1.3 n + 5 < 5 stride. */
        for (int gathered = 0; gathered < 2; gathered++)
          ASSERT_UPPER_CLEAN_AFTER (u->kernel,
              sonar_kernel_scaled_product_impls[i].fn (out, a, a + stride,
                  re, im, n, 2.5, gathered ? 1.3 : 1.02, 0.3, 0.01, 1.0f));
        break;
    }
    sink += crealf (z);
  }
  (void) sink;
#else
  (void) data;
  g_test_skip ("not an x86-64 build: no AVX kernels");
#endif
}

/* One test case per implementation: /kernels/<kernel>/<implementation>. */
#define ADD_IMPL_TESTS(path, impls, func) G_STMT_START {                \
  for (guint i_ = 0; (impls)[i_].name; i_++) {                          \
    g_autofree char *name_ = g_strdup_printf ("/kernels/%s/%s", (path),  \
        (impls)[i_].name);                                              \
    g_test_add_data_func (name_, &(impls)[i_], (func));                 \
  }                                                                     \
} G_STMT_END

/* /kernels/upper-clean/<kernel>/<implementation>, for every table. */
#define ADD_UPPER_TESTS(path, impls, table_) G_STMT_START {             \
  for (guint i_ = 0; (impls)[i_].name; i_++) {                          \
    UpperCase *u_ = g_new0 (UpperCase, 1);                              \
    g_autofree char *name_ = g_strdup_printf ("/kernels/upper-clean/%s/%s", \
        (path), (impls)[i_].name);                                      \
    u_->kernel = (path);                                                \
    u_->name = (impls)[i_].name;                                        \
    u_->available = (impls)[i_].available;                              \
    u_->table = (table_);                                               \
    u_->index = i_;                                                     \
    g_test_add_data_func_full (name_, u_, test_upper_clean, g_free);    \
  }                                                                     \
} G_STMT_END

int
main (int argc, char **argv)
{
  g_test_init (&argc, &argv, NULL);
  ADD_IMPL_TESTS ("steer-sum-split", sonar_kernel_steer_sum_split_impls,
      test_steer_sum_split);
  ADD_IMPL_TESTS ("phase-ramp-exact", sonar_kernel_steer_sum_split_impls,
      test_phase_ramp_exact);
  ADD_IMPL_TESTS ("steer-block-sums",
      sonar_kernel_steer_block_sums_conj_impls, test_steer_block_sums);
  ADD_IMPL_TESTS ("block8-sums", sonar_kernel_block8_sums_conj_impls,
      test_block8_sums);
  ADD_IMPL_TESTS ("long-sums-against-double",
      sonar_kernel_steer_block_sums_conj_impls,
      test_long_sums_against_double);
  ADD_IMPL_TESTS ("steer-sum", sonar_kernel_steer_sum_impls, test_steer_sum);
  ADD_IMPL_TESTS ("steer-phasors", sonar_kernel_steer_phasors_impls,
      test_steer_phasors);
  ADD_IMPL_TESTS ("steer-sums-phasors",
      sonar_kernel_steer_sums_phasors_impls, test_steer_sums_phasors);
  ADD_IMPL_TESTS ("scaled-product", sonar_kernel_scaled_product_impls,
      test_scaled_product);
  ADD_IMPL_TESTS ("scaled-product-exact", sonar_kernel_scaled_product_impls,
      test_scaled_product_exact);
#ifdef G_OS_UNIX
  ADD_IMPL_TESTS ("scaled-product-guarded", sonar_kernel_scaled_product_impls,
      test_scaled_product_guarded);
#endif
  ADD_IMPL_TESTS ("envelope", sonar_kernel_envelope_impls, test_envelope);
  ADD_IMPL_TESTS ("envelope-unfused", sonar_kernel_envelope_impls,
      test_envelope_unfused);
  ADD_IMPL_TESTS ("peak", sonar_kernel_peak_impls, test_peak);
  ADD_IMPL_TESTS ("block-peaks", sonar_kernel_block_peaks_impls,
      test_block_peaks);
  ADD_IMPL_TESTS ("max", sonar_kernel_max_impls, test_max);
  ADD_IMPL_TESTS ("rank-pass", sonar_kernel_rank_pass_impls,
      test_rank_pass);
  ADD_IMPL_TESTS ("correlate", sonar_kernel_correlate_impls,
      test_correlate);
  ADD_IMPL_TESTS ("axpy", sonar_kernel_axpy_impls, test_axpy);
  ADD_IMPL_TESTS ("deinterleave", sonar_kernel_deinterleave_impls,
      test_deinterleave);
  ADD_UPPER_TESTS ("steer-sum-split", sonar_kernel_steer_sum_split_impls, 0);
  ADD_UPPER_TESTS ("steer-block-sums",
      sonar_kernel_steer_block_sums_conj_impls, 1);
  ADD_UPPER_TESTS ("block8-sums", sonar_kernel_block8_sums_conj_impls, 2);
  ADD_UPPER_TESTS ("steer-sum", sonar_kernel_steer_sum_impls, 3);
  ADD_UPPER_TESTS ("steer-phasors", sonar_kernel_steer_phasors_impls, 4);
  ADD_UPPER_TESTS ("steer-sum-phasors", sonar_kernel_steer_sum_phasors_impls,
      5);
  ADD_UPPER_TESTS ("steer-sums-phasors",
      sonar_kernel_steer_sums_phasors_impls, 6);
  ADD_UPPER_TESTS ("envelope", sonar_kernel_envelope_impls, 8);
  ADD_UPPER_TESTS ("peak", sonar_kernel_peak_impls, 9);
  ADD_UPPER_TESTS ("block-peaks", sonar_kernel_block_peaks_impls, 14);
  ADD_UPPER_TESTS ("max", sonar_kernel_max_impls, 10);
  ADD_UPPER_TESTS ("rank-pass", sonar_kernel_rank_pass_impls, 11);
  ADD_UPPER_TESTS ("scaled-product", sonar_kernel_scaled_product_impls, 12);
  ADD_UPPER_TESTS ("deinterleave", sonar_kernel_deinterleave_impls, 13);
  ADD_UPPER_TESTS ("correlate", sonar_kernel_correlate_impls, 15);
  ADD_UPPER_TESTS ("axpy", sonar_kernel_axpy_impls, 16);
  g_test_add_func ("/kernels/block-sums-at-lag-offsets",
      test_block_sums_at_lag_offsets);
  g_test_add_func ("/kernels/entry-points-choose-best",
      test_entry_points_choose_best);
  return g_test_run ();
}
