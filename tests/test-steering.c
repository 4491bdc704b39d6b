/* test-steering.c: the steering module against its documented equations
 * (sonar-steering.h), evaluated here directly in double precision: the
 * legs, the stretch, the factored receive x transmit sum against the
 * N x J double sum, and one emitter's output at a lag. */
#include <complex.h>
#include <math.h>

#include "sonar-doppler-bank.h"
#include "sonar-rng.h"
#include "sonar-steering.h"
#include "sonar-test-util.h"

/* 20-80 kHz at 450 kHz in a 21600-point FFT, as the default sensor's band,
 * but only its first 203 bins (not a multiple of the kernels' lanes). */
static const SonarBand band = { 450000.0, 21600, 960, 203 };

typedef struct
{
  SonarSetup *setup;
  SonarSteering steering;
  SonarRng rng;
} Fixture;

static void
fixture_init (Fixture * f)
{
  f->setup = sonar_test_default_setup (17500);
  sonar_steering_init (&f->steering, f->setup, &band);
  sonar_rng_init (&f->rng, 21, 0);
}

static void
random_split (SonarRng * rng, float *re, float *im, gsize n)
{
  for (gsize k = 0; k < n; k++) {
    re[k] = (float) sonar_rng_gaussian (rng);
    im[k] = (float) sonar_rng_gaussian (rng);
  }
}

/* Phase of @path m of path at bin @k, straight from the band. */
static double
phase (const Fixture * f, guint k, double path)
{
  return 2.0 * M_PI * sonar_band_frequency (&band, k) /
      f->setup->speed_of_sound * path;
}

/* The legs are |p - x| - r; far away they tend to -u . x (plane wave). */
static void
test_legs_and_stretch (void)
{
  Fixture f;
  const SonarGeometry *g;
  const SonarVec3 u = sonar_vec3_from_direction (35.0, -10.0);
  const double c = 343.0;
  double *mic = NULL, *emitter = NULL;

  fixture_init (&f);
  g = &f.setup->geometry;
  mic = g_new (double, g->n_microphones);
  emitter = g_new (double, g->n_emitters);
  sonar_steering_legs (&f.steering, u, 1.7, mic, emitter);
  for (guint j = 0; j < g->n_microphones; j++) {
    const SonarVec3 d = sonar_vec3_sub (sonar_vec3_scale (u, 1.7),
        g->microphones[j]);
    g_assert_cmpfloat_with_epsilon (mic[j], sqrt (d.x * d.x + d.y * d.y +
            d.z * d.z) - 1.7, 1e-12);
    g_assert_cmpfloat (fabs (mic[j]), <=, 0.2);   /* the array is small */
  }
  sonar_steering_legs (&f.steering, u, 1e5, NULL, emitter);
  for (guint n = 0; n < g->n_emitters; n++) {
    g_assert_cmpfloat_with_epsilon (emitter[n], -sonar_vec3_dot (u,
            g->emitters[n]), 1e-6);
  }
  g_assert_cmpfloat (f.setup->speed_of_sound, ==, c);
  g_assert_cmpfloat (sonar_steering_stretch (&f.steering, 0.0), ==, 1.0);
  g_assert_cmpfloat_with_epsilon (sonar_steering_stretch (&f.steering, 3.0),
      (c + 3.0) / (c - 3.0), 1e-15);
  /* Receding: the reflector meets later pulses, the legs stretch. */
  g_assert_cmpfloat (sonar_steering_stretch (&f.steering, 3.0), >, 1.0);
  g_free (mic);
  g_free (emitter);
  sonar_setup_unref (f.setup);
}

/* R(k) T(k) = sum_nj X_j(k) conj (S_n(k)) exp(i phase (m_j + e_n / alpha))
 * at bins @first_bin .. + @n_part (the whole band's sums when @n_part is
 * 0, else their sub-band versions), for every emitter and for one alone,
 * against the N x J double sum. */
static void
check_factored_sum (double azimuth, double elevation, double range,
    double stretch, guint first_bin, guint n_part)
{
  Fixture f;
  const SonarGeometry *g;
  const guint K = band.n_bins, n = n_part ? n_part : K;
  float *x_re, *x_im, *s_re, *s_im, *r_re, *r_im, *t_re, *t_im;
  double *mic, *emitter, worst = 0.0;

  fixture_init (&f);
  g = &f.setup->geometry;
  x_re = g_new (float, (gsize) g->n_microphones * K);
  x_im = g_new (float, (gsize) g->n_microphones * K);
  s_re = g_new (float, (gsize) g->n_emitters * K);
  s_im = g_new (float, (gsize) g->n_emitters * K);
  r_re = g_new (float, n);
  r_im = g_new (float, n);
  t_re = g_new (float, K);
  t_im = g_new (float, K);
  mic = g_new (double, g->n_microphones);
  emitter = g_new (double, g->n_emitters);
  random_split (&f.rng, x_re, x_im, (gsize) g->n_microphones * K);
  random_split (&f.rng, s_re, s_im, (gsize) g->n_emitters * K);
  sonar_steering_legs (&f.steering, sonar_vec3_from_direction (azimuth,
          elevation), range, mic, emitter);

  for (int alone = -1; alone < 2; alone++) {
    const guint first = alone < 0 ? 0 : (guint) alone;
    const guint end = alone < 0 ? g->n_emitters : (guint) alone + 1;
    const SonarSplitSpectra x = { x_re, x_im }, s = { s_re, s_im };

    if (n_part)
      sonar_steering_receive_sum_part (&f.steering, &x, mic, first_bin,
          n_part, r_re, r_im);
    else
      sonar_steering_receive_sum (&f.steering, &x, mic, r_re, r_im);
    sonar_steering_transmit_sum (&f.steering, &s, emitter, stretch, first,
        end, t_re, t_im);
    for (guint t = 0; t < n; t++) {
      const guint k = first_bin + t;
      double complex exact = 0.0;
      double magnitudes = 0.0;
      for (guint e = first; e < end; e++)
        for (guint j = 0; j < g->n_microphones; j++) {
          const gsize xj = (gsize) j * K + k, sn = (gsize) e * K + k;
          const double complex term = (x_re[xj] + I * x_im[xj]) *
              (s_re[sn] - I * s_im[sn]) * cexp (I * phase (&f, k, mic[j] +
                  emitter[e] * stretch));
          exact += term;
          magnitudes += cabs (term);
        }
      worst = MAX (worst, cabs ((r_re[t] + I * r_im[t]) * (t_re[k] +
                  I * t_im[k]) - exact) / magnitudes);
    }
  }
  g_test_message ("worst error relative to the sum of |terms|: %.2e", worst);
  g_assert_cmpfloat (worst, <, 1e-5);
  g_free (x_re);
  g_free (x_im);
  g_free (s_re);
  g_free (s_im);
  g_free (r_re);
  g_free (r_im);
  g_free (t_re);
  g_free (t_im);
  g_free (mic);
  g_free (emitter);
  sonar_setup_unref (f.setup);
}

/* The whole band's sums. */
static void
test_factored_sum (void)
{
  check_factored_sum (-62.0, 0.0, 0.8, 1.0123, 0, 0);
}

/* The same sums on part of the band (the imager's sub-band coarse pass):
 * bins 37 to 137. */
static void
test_factored_sum_part (void)
{
  check_factored_sum (41.0, 12.0, 1.3, 0.9871, 37, 101);
}

/* Emitter n's output at the lag of range r, and 3 mm further:
 * sum_k R(k) conj (S_n(k)) exp(i phase (2 (r + offset) + e_n / alpha)). */
static void
test_emitter_output_at_lag (void)
{
  Fixture f;
  const guint K = band.n_bins, block = 16, n = 5;
  const double range = 2.4, stretch = 0.98;
  float r_re[203], r_im[203], *s_re, *s_im;
  SonarComplex blocks[13];
  double *emitter;

  fixture_init (&f);
  s_re = g_new (float, (gsize) f.setup->geometry.n_emitters * K);
  s_im = g_new (float, (gsize) f.setup->geometry.n_emitters * K);
  emitter = g_new (double, f.setup->geometry.n_emitters);
  random_split (&f.rng, r_re, r_im, K);
  random_split (&f.rng, s_re, s_im, (gsize) f.setup->geometry.n_emitters * K);
  sonar_steering_legs (&f.steering, sonar_vec3_from_direction (20.0, 5.0),
      range, NULL, emitter);
  {
    const SonarSplitSpectra s = { s_re, s_im };
    sonar_steering_emitter_blocks (&f.steering, r_re, r_im, &s, n,
        emitter[n], stretch, range, block, blocks);
  }
  for (int q = 0; q < 2; q++) {
    const double offset = q * 0.003;
    double complex exact = 0.0;
    double magnitudes = 0.0;
    SonarComplex approx;

    for (guint k = 0; k < K; k++) {
      const gsize sn = (gsize) n * K + k;
      const double complex term = (r_re[k] + I * r_im[k]) * (s_re[sn] -
          I * s_im[sn]) * cexp (I * phase (&f, k, 2.0 * (range + offset) +
              emitter[n] * stretch));
      exact += term;
      magnitudes += cabs (term);
    }
    approx = sonar_steering_blocks_at (&f.steering, blocks, block, offset);
    g_test_message ("offset %.3f m: error relative to the sum of |terms| "
        "%.2e", offset, cabs (approx - exact) / magnitudes);
    /* Exact at the lag itself; at an offset, the blocks' phase is taken
     * at their centre (-60 dB in tests/test-kernels.c). */
    g_assert_cmpfloat (cabs (approx - exact) / magnitudes, <,
        q == 0 ? 1e-5 : 2e-3);
  }
  g_free (s_re);
  g_free (s_im);
  g_free (emitter);
  sonar_setup_unref (f.setup);
}

/* A Doppler bank of @setup from @v_min to @v_max m/s on its ping's band,
 * and the steering and scaled transmit sums on that band (the transmit
 * borrows the steering: the fixture stays where it was made). */
typedef struct
{
  SonarDopplerBank *bank;
  const SonarBand *band;
  SonarSteering steering;
  SonarScaledTransmit *transmit;
} TransmitFixture;

static void
transmit_fixture_init (TransmitFixture * f, SonarSetup * setup,
    double v_min, double v_max)
{
  f->bank = sonar_doppler_bank_new (setup, v_min, v_max, 0.01, NULL);
  g_assert_nonnull (f->bank);
  sonar_doppler_bank_prepare_ping_band (f->bank);
  f->band = sonar_doppler_bank_band (f->bank);
  sonar_steering_init (&f->steering, setup, f->band);
  f->transmit = sonar_scaled_transmit_new (&f->steering, setup, f->band);
}

static void
transmit_fixture_clear (TransmitFixture * f)
{
  sonar_scaled_transmit_free (f->transmit);
  sonar_doppler_bank_unref (f->bank);
}

/* A hypothesis's transmit product read from the zero-velocity table
 * (sonar_scaled_transmit_product ()) against the direct sum over the
 * bank's own templates of that velocity, on the whole ping band, every
 * emitter and one alone, near field and far, receding and approaching
 * up to 30 m/s; and on part of the band. The two differ by the
 * interpolation and the templates' own (sonar-interp.h): both far below
 * the -30 dB rms sidelobes of the waveform. */
static void
test_scaled_transmit (void)
{
  g_autoptr (SonarSetup) setup = sonar_test_default_setup (17262);
  const double velocities[] = { 0.0, 0.02, -0.4, 3.0, -7.0, 7.0, 30.0,
    -30.0
  };
  const SonarGeometry *g = &setup->geometry;
  TransmitFixture fixture;
  SonarDopplerBank *bank;
  SonarScaledTransmit *transmit;
  SonarSteering steering;
  SonarRng rng;
  double emitter[SONAR_MAX_EMITTERS];
  float *r_re, *r_im, *t_re, *t_im, *v_re, *v_im;
  SonarComplex *out;
  guint K, max_window;
  double worst_db = -400.0;

  transmit_fixture_init (&fixture, setup, -30.0, 30.0);
  bank = fixture.bank;
  transmit = fixture.transmit;
  steering = fixture.steering;
  K = fixture.band->n_bins;
  max_window = sonar_scaled_transmit_max_window (transmit);
  r_re = g_new (float, K);
  r_im = g_new (float, K);
  t_re = g_new (float, K);
  t_im = g_new (float, K);
  v_re = g_new (float, max_window);
  v_im = g_new (float, max_window);
  out = g_new (SonarComplex, K);
  sonar_rng_init (&rng, 5, 0);
  random_split (&rng, r_re, r_im, K);

  for (guint p = 0; p < 3; p++) {
    const double range = p == 0 ? 0.35 : p == 1 ? 1.5 : 40.0;
    sonar_steering_legs (&steering, sonar_vec3_from_direction (-40.0 + 35.0
            * p, 20.0 - 15.0 * p), range, NULL, emitter);
    for (guint v = 0; v < G_N_ELEMENTS (velocities); v++) {
      const guint i = sonar_doppler_bank_nearest (bank, velocities[v]);
      const SonarHypothesis h = sonar_doppler_bank_hypothesis (bank, i);
      const double stretch = sonar_steering_stretch (&steering, h.velocity);
      int window_first;
      guint window_n;

      sonar_scaled_transmit_window (transmit, stretch, &window_first,
          &window_n);
      g_assert_cmpuint (window_n, <=, max_window);
      for (int alone = -1; alone < 8; alone += 5) {
        const guint first = alone < 0 ? 0 : (guint) alone;
        const guint end = alone < 0 ? g->n_emitters : (guint) alone + 1;
        /* The whole band, then its bins 100 to 1100. */
        for (guint part = 0; part < 2; part++) {
          const guint b0 = part ? 100 : 0, n = part ? 1000 : K;
          double err = 0.0, energy = 0.0;

          sonar_steering_transmit_sum (&steering, &h.templates, emitter,
              stretch, first, end, t_re, t_im);
          sonar_scaled_transmit_table (transmit, emitter, first, end,
              window_first, window_n, v_re, v_im);
          sonar_scaled_transmit_product (transmit, v_re, v_im, window_first,
              stretch, r_re + b0, r_im + b0, b0, n, out);
          for (guint k = 0; k < n; k++) {
            const double complex direct = (r_re[b0 + k] + I * r_im[b0 +
                    k]) * (t_re[b0 + k] + I * t_im[b0 + k]);
            err += pow (cabs (out[k] - direct), 2.0);
            energy += pow (cabs (direct), 2.0);
          }
          g_assert_cmpfloat (energy, >, 0.0);
          worst_db = MAX (worst_db, 10.0 * log10 (err / energy));
        }
      }
    }
  }
  /* A table's values are its window's, not its call's: a wider window
   * (faster hypotheses in the call) holds the same values bit for bit. */
  {
    int first_slow, first_fast;
    guint n_slow, n_fast;
    float *w_re = g_new (float, max_window), *w_im = g_new (float,
        max_window);

    sonar_scaled_transmit_window (transmit, 1.0, &first_slow, &n_slow);
    sonar_scaled_transmit_window (transmit, sonar_steering_stretch
        (&steering, 30.0), &first_fast, &n_fast);
    g_assert_cmpint (first_slow, ==, first_fast);
    g_assert_cmpuint (n_slow, <, n_fast);
    sonar_scaled_transmit_table (transmit, emitter, 0, g->n_emitters,
        first_slow, n_slow, v_re, v_im);
    sonar_scaled_transmit_table (transmit, emitter, 0, g->n_emitters,
        first_fast, n_fast, w_re, w_im);
    g_assert_cmpmem (v_re, n_slow * sizeof (float), w_re,
        n_slow * sizeof (float));
    g_assert_cmpmem (v_im, n_slow * sizeof (float), w_im,
        n_slow * sizeof (float));
    g_free (w_re);
    g_free (w_im);
  }
  g_test_message ("worst error of the scaled transmit products: %.1f dB",
      worst_db);
  g_assert_cmpfloat (worst_db, <, -60.0);
  g_free (r_re);
  g_free (r_im);
  g_free (t_re);
  g_free (t_im);
  g_free (v_re);
  g_free (v_im);
  g_free (out);
  transmit_fixture_clear (&fixture);
}

/* A window reaching below bin 0 or past Nyquist (a band near either edge,
 * a fast stretch) holds zeros there, as the emissions' band-limited
 * templates do, and the same values as a window inside it elsewhere. */
static void
test_scaled_transmit_edges (void)
{
  g_autoptr (SonarSetup) setup = sonar_test_default_setup (17262);
  const SonarBand ping_band = { 450000.0, 21600, 960, 2883 };
  const guint n_spectrum = ping_band.fft_size / 2 + 1;
  const int first = -70, inside = 128;
  const guint n = n_spectrum + 140;
  g_autoptr (SonarScaledTransmit) transmit = NULL;
  SonarSteering steering;
  double emitter[SONAR_MAX_EMITTERS];
  float *v_re = g_new (float, n), *v_im = g_new (float, n);
  float *w_re = g_new (float, 512), *w_im = g_new (float, 512);

  sonar_steering_init (&steering, setup, &ping_band);
  transmit = sonar_scaled_transmit_new (&steering, setup, &ping_band);
  sonar_steering_legs (&steering, sonar_vec3_from_direction (20.0, -5.0),
      1.2, NULL, emitter);
  sonar_scaled_transmit_table (transmit, emitter, 0,
      setup->geometry.n_emitters, first, n, v_re, v_im);
  for (int j = first; j < first + (int) n; j++) {
    const float re = v_re[j - first], im = v_im[j - first];
    g_assert_true (isfinite (re) && isfinite (im));
    if (j < 0 || j >= (int) n_spectrum) {
      g_assert_cmpfloat (re, ==, 0.0f);
      g_assert_cmpfloat (im, ==, 0.0f);
    }
  }
  /* Inside, the band's bins hold the emissions' energy. */
  {
    double energy = 0.0;
    for (guint j = ping_band.first_bin; j < ping_band.first_bin + ping_band.n_bins; j++)
      energy += v_re[j - first] * v_re[j - first] + v_im[j - first] *
          v_im[j - first];
    g_assert_cmpfloat (energy, >, 0.0);
  }
  /* The interior of a window from bin 0 against one from bin 128: equal
   * to float rounding (their ramps start at different bins). */
  sonar_scaled_transmit_table (transmit, emitter, 0,
      setup->geometry.n_emitters, inside, 512, w_re, w_im);
  for (guint k = 0; k < 512; k++) {
    const float scale = 1e-5f * (1.0f + fabsf (w_re[k]) + fabsf (w_im[k]));
    g_assert_cmpfloat (fabsf (w_re[k] - v_re[inside - first + k]), <=, scale);
    g_assert_cmpfloat (fabsf (w_im[k] - v_im[inside - first + k]), <=, scale);
  }
  g_free (v_re);
  g_free (v_im);
  g_free (w_re);
  g_free (w_im);
}

/* The largest envelope of the product @p_re, _im (@n bins of @steering's
 * band) over the lags within 3 mm of path of zero. */
static double
envelope_near_zero (const SonarSteering * steering, const float *p_re,
    const float *p_im, guint n)
{
  double best = 0.0;

  for (int l = -60; l <= 60; l++) {
    const double lag = 5e-5 * l;
    double complex sum = 0.0;
    for (guint k = 0; k < n; k++)
      sum += (p_re[k] + I * p_im[k]) * cexp (-I * (steering->k0 + k *
              steering->dk) * lag);
    best = MAX (best, cabs (sum));
  }
  return best;
}

/* What a grid loses between its directions, against the delay-and-sum of
 * a far still point's echoes (every emitter's at every microphone, the
 * emitters' cross-talk included) halfway between two directions, or at
 * the centre of a cell of four, imaged there and at the direction next
 * to it: within 0.3 dB from 1 to 4 degrees, 2-D and 3-D. The loss grows
 * with the step, a cell's centre loses more than a step's middle, and
 * the step factor lands on the loss it is asked for. */
static void
test_sampling_loss (void)
{
  g_autoptr (SonarSetup) setup = sonar_test_default_setup (17262);
  const SonarGeometry *g = &setup->geometry;
  TransmitFixture fixture;
  SonarScaledTransmit *transmit;
  SonarSteering steering;
  SonarHypothesis still;
  double last[2] = { 0.0, 0.0 };
  guint K;

  transmit_fixture_init (&fixture, setup, 0.0, 0.0);
  transmit = fixture.transmit;
  steering = fixture.steering;
  K = fixture.band->n_bins;
  still = sonar_doppler_bank_hypothesis (fixture.bank, 0);
  g_assert_cmpfloat (sonar_scaled_transmit_sampling_loss (transmit, 0.0,
          0.0), ==, 0.0);

  for (guint step = 1; step <= 4; step++)
    for (guint cell = 0; cell < 2; cell++) {
      const double az = 0.5 * step, el = cell ? 0.5 * step : 0.0;
      const SonarVec3 point = sonar_vec3_from_direction (az, el);
      const double loss = sonar_scaled_transmit_sampling_loss (transmit,
          step, cell ? step : 0.0);
      double mic[SONAR_MAX_MICROPHONES], em[SONAR_MAX_EMITTERS];
      float *x_re = g_new0 (float, (gsize) g->n_microphones * K);
      float *x_im = g_new0 (float, (gsize) g->n_microphones * K);
      float *r_re = g_new (float, K), *r_im = g_new (float, K);
      float *t_re = g_new (float, K), *t_im = g_new (float, K);
      float *p_re = g_new (float, K), *p_im = g_new (float, K);
      SonarSplitSpectra echoes = { x_re, x_im };
      double envelope[2], imaged;

      /* The echoes: each emission delayed by its legs to the point. */
      sonar_steering_legs (&steering, point, 1e4, mic, em);
      for (guint j = 0; j < g->n_microphones; j++)
        for (guint n = 0; n < g->n_emitters; n++)
          for (guint k = 0; k < K; k++) {
            const double complex x = (still.templates.re[(gsize) n * K + k] +
                I * still.templates.im[(gsize) n * K + k]) * cexp (-I *
                (steering.k0 + k * steering.dk) * (em[n] + mic[j]));
            x_re[(gsize) j * K + k] += (float) creal (x);
            x_im[(gsize) j * K + k] += (float) cimag (x);
          }
      /* Imaged at the point, then at the grid's direction (boresight). */
      for (guint look = 0; look < 2; look++) {
        sonar_steering_legs (&steering, look ? sonar_vec3 (0.0, 0.0, 1.0) :
            point, 1e4, mic, em);
        sonar_steering_receive_sum (&steering, &echoes, mic, r_re, r_im);
        sonar_steering_transmit_sum (&steering, &still.templates, em, 1.0, 0,
            g->n_emitters, t_re, t_im);
        for (guint k = 0; k < K; k++) {
          p_re[k] = r_re[k] * t_re[k] - r_im[k] * t_im[k];
          p_im[k] = r_re[k] * t_im[k] + r_im[k] * t_re[k];
        }
        envelope[look] = envelope_near_zero (&steering, p_re, p_im, K);
      }
      imaged = 20.0 * log10 (envelope[0] / envelope[1]);
      g_test_message ("%u degree %s: %.2f dB, imaged %.2f dB", step,
          cell ? "cell" : "step", loss, imaged);
      g_assert_cmpfloat (loss, >, imaged - 0.1);
      g_assert_cmpfloat (loss, <, imaged + 1.0);
      g_assert_cmpfloat (loss, >, last[cell]);
      last[cell] = loss;
      if (cell)
        g_assert_cmpfloat (loss, >,
            sonar_scaled_transmit_sampling_loss (transmit, step, 0.0));
      g_free (x_re);
      g_free (x_im);
      g_free (r_re);
      g_free (r_im);
      g_free (t_re);
      g_free (t_im);
      g_free (p_re);
      g_free (p_im);
    }
  {
    const double f = sonar_scaled_transmit_step_factor (transmit, 4.0, 0.0,
        6.0);
    g_assert_cmpfloat (f, >, 0.5);
    g_assert_cmpfloat (f, <, 1.0);
    g_assert_cmpfloat (fabs (sonar_scaled_transmit_sampling_loss (transmit,
                4.0 * f, 0.0) - 6.0), <, 0.05);
    g_assert_cmpfloat (sonar_scaled_transmit_step_factor (transmit, 1.0,
            0.0, 6.0), ==, 1.0);
  }
  transmit_fixture_clear (&fixture);
}

/* The main lobe's width (sonar_scaled_transmit_lobe_width ()): on the
 * eRTIS array 3.0-3.1 degrees along azimuth, where a grid of that step
 * loses 6 dB, and wider along elevation (the array is 8 cm wide, 4 cm
 * high); on the same array twice as large, half as wide (the main lobe
 * narrows as the aperture grows). */
static void
test_lobe_width (void)
{
  double width[2][2];

  for (guint scale = 0; scale < 2; scale++) {
    SonarGeometry g;
    SonarSetup *setup;
    TransmitFixture fixture;

    sonar_geometry_init_default (&g);
    for (guint j = 0; j < g.n_microphones; j++)
      g.microphones[j] = sonar_vec3_scale (g.microphones[j], 1.0 + scale);
    for (guint n = 0; n < g.n_emitters; n++)
      g.emitters[n] = sonar_vec3_scale (g.emitters[n], 1.0 + scale);
    setup = sonar_test_setup_new (&g, 17262);
    transmit_fixture_init (&fixture, setup, 0.0, 0.0);
    for (guint axis = 0; axis < 2; axis++)
      width[scale][axis] = sonar_scaled_transmit_lobe_width
          (fixture.transmit, axis, 30.0);
    /* At most what it is asked for. */
    g_assert_cmpfloat (sonar_scaled_transmit_lobe_width (fixture.transmit,
            FALSE, 1.0), ==, 1.0);
    g_test_message ("array x %u: main lobe %.3f degrees along azimuth, "
        "%.3f along elevation", 1 + scale, width[scale][0],
        width[scale][1]);
    g_assert_cmpfloat (fabs (sonar_scaled_transmit_sampling_loss
            (fixture.transmit, width[scale][0], 0.0) - 6.0), <, 0.05);
    g_assert_cmpfloat (fabs (sonar_scaled_transmit_sampling_loss
            (fixture.transmit, 0.0, width[scale][1]) - 6.0), <, 0.05);
    transmit_fixture_clear (&fixture);
    sonar_setup_unref (setup);
    sonar_geometry_clear (&g);
  }
  g_assert_cmpfloat (width[0][0], >, 3.0);
  g_assert_cmpfloat (width[0][0], <, 3.1);
  g_assert_cmpfloat (width[0][1], >, 1.2 * width[0][0]);
  for (guint axis = 0; axis < 2; axis++)
    g_assert_cmpfloat (fabs (width[1][axis] / width[0][axis] - 0.5), <,
        0.02);
}

int
main (int argc, char **argv)
{
  g_test_init (&argc, &argv, NULL);
  g_test_add_func ("/steering/legs-and-stretch", test_legs_and_stretch);
  g_test_add_func ("/steering/factored-sum", test_factored_sum);
  g_test_add_func ("/steering/scaled-transmit", test_scaled_transmit);
  g_test_add_func ("/steering/scaled-transmit-edges",
      test_scaled_transmit_edges);
  g_test_add_func ("/steering/factored-sum-part", test_factored_sum_part);
  g_test_add_func ("/steering/emitter-output-at-lag",
      test_emitter_output_at_lag);
  g_test_add_func ("/steering/sampling-loss", test_sampling_loss);
  g_test_add_func ("/steering/lobe-width", test_lobe_width);
  return g_test_run ();
}
