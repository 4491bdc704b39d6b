/* test-waveform.c: the emission waveforms have the paper's properties
 * (unit peak, tapered, in band, near-orthogonal, sharp autocorrelation),
 * are reproducible, and bad parameters are refused with a clear error.
 * Everything is measured here in double precision, independently of the
 * code under test. */
#include <fftw3.h>
#include <gio/gio.h>
#include <math.h>
#include <string.h>

#include "sonar-test-util.h"
#include "sonar-error.h"
#include "sonar-waveform.h"

#define N_EMITTERS 8
#define LENGTH 4000
#define SAMPLE_RATE 450000.0
#define BAND_LOW 20000.0
#define BAND_HIGH 80000.0

static double
to_db (double ratio)
{
  return 20.0 * log10 (ratio);
}

static float *
generate (SonarWaveformKind kind, guint64 seed)
{
  SonarWaveformParams params;
  GError *error = NULL;
  float *out;

  sonar_waveform_params_init_default (&params);
  params.kind = kind;
  params.seed = seed;
  out = g_new (float, (gsize) params.n_emitters * params.length);
  g_assert_true (sonar_waveform_generate (&params, out, &error));
  g_assert_no_error (error);
  return out;
}

static const float *
row (const float *waveforms, guint n)
{
  return waveforms + (gsize) n * LENGTH;
}

static double
energy (const float *x, gsize n)
{
  double sum = 0.0;
  for (gsize i = 0; i < n; i++)
    sum += (double) x[i] * x[i];
  return sum;
}

/* Envelope (magnitude of the analytic signal) of v[n], zero-padded so
 * that the Hilbert transform does not wrap. */
static double *
envelope (const double *v, gsize n)
{
  const gsize size = 4 * n;
  fftw_complex *a = fftw_alloc_complex (size);
  fftw_plan forward = fftw_plan_dft_1d (size, a, a, FFTW_FORWARD,
      FFTW_ESTIMATE);
  fftw_plan inverse = fftw_plan_dft_1d (size, a, a, FFTW_BACKWARD,
      FFTW_ESTIMATE);
  double *env = g_new (double, n);

  memset (a, 0, size * sizeof (fftw_complex));
  for (gsize i = 0; i < n; i++)
    a[i][0] = v[i];
  fftw_execute (forward);
  for (gsize k = 1; k < size / 2; k++) {
    a[k][0] *= 2.0;
    a[k][1] *= 2.0;
  }
  memset (a + size / 2 + 1, 0, (size / 2 - 1) * sizeof (fftw_complex));
  fftw_execute (inverse);
  for (gsize i = 0; i < n; i++)
    env[i] = hypot (a[i][0], a[i][1]) / size;
  fftw_destroy_plan (forward);
  fftw_destroy_plan (inverse);
  fftw_free (a);
  return env;
}

/* Share of the energy of the emission (zero-padded 8 times: the burst
 * between silences, not its periodic repetition) outside [low, high]. */
static double
out_of_band_db (const float *x, gsize n, double low, double high)
{
  const gsize size = 8 * n;
  double *a = fftw_alloc_real (size);
  fftw_complex *spectrum = fftw_alloc_complex (size / 2 + 1);
  fftw_plan plan = fftw_plan_dft_r2c_1d (size, a, spectrum, FFTW_ESTIMATE);
  double inside = 0.0, outside = 0.0;

  memset (a, 0, size * sizeof (double));
  for (gsize i = 0; i < n; i++)
    a[i] = x[i];
  fftw_execute (plan);
  for (gsize k = 0; k <= size / 2; k++) {
    const double f = k * SAMPLE_RATE / size;
    const double e = spectrum[k][0] * spectrum[k][0]
        + spectrum[k][1] * spectrum[k][1];
    if (f < low || f > high)
      outside += e;
    else
      inside += e;
  }
  fftw_destroy_plan (plan);
  fftw_free (a);
  fftw_free (spectrum);
  return 10.0 * log10 (outside / (inside + outside));
}

/* Smallest margin, in dB, between the autocorrelation peaks and the
 * largest |cross-correlation| over all lags and pairs. */
static double
worst_cross_margin_db (const float *waveforms)
{
  double worst = INFINITY;

  for (guint i = 0; i < N_EMITTERS; i++) {
    for (guint j = i + 1; j < N_EMITTERS; j++) {
      double *r = sonar_test_xcorr (row (waveforms, i), LENGTH,
          row (waveforms, j), LENGTH);
      const double peak = sonar_test_max_abs (r, 2 * LENGTH - 1, NULL);
      const double reference = sqrt (energy (row (waveforms, i), LENGTH)
          * energy (row (waveforms, j), LENGTH));
      worst = MIN (worst, to_db (reference / peak));
      g_free (r);
    }
  }
  return worst;
}

static void
test_default_params (void)
{
  SonarWaveformParams params;

  sonar_waveform_params_init_default (&params);
  g_assert_cmpint (params.kind, ==, SONAR_WAVEFORM_NOISE);
  g_assert_cmpuint (params.n_emitters, ==, N_EMITTERS);
  g_assert_cmpuint (params.length, ==, LENGTH);
  g_assert_cmpfloat (params.sample_rate, ==, SAMPLE_RATE);
  g_assert_cmpfloat (params.band_low, ==, BAND_LOW);
  g_assert_cmpfloat (params.band_high, ==, BAND_HIGH);
}

/* Every kind: finite, unit peak, and silent at both ends (taper). */
static void
test_unit_peak_and_taper (void)
{
  guint n_kinds;
  const SonarWaveformKindInfo *kinds = sonar_waveform_kinds (&n_kinds);

  for (guint k = 0; k < n_kinds; k++) {
    float *w = generate (kinds[k].kind, 1);

    for (guint n = 0; n < N_EMITTERS; n++) {
      const float *x = row (w, n);
      double peak = 0.0, edge = 0.0;

      for (guint i = 0; i < LENGTH; i++) {
        g_assert_true (isfinite (x[i]));
        peak = MAX (peak, fabs (x[i]));
      }
      g_assert_cmpfloat_with_epsilon (peak, 1.0, 1e-6);
      for (guint i = 0; i < 10; i++)
        edge = MAX (edge, MAX (fabs (x[i]), fabs (x[LENGTH - 1 - i])));
      g_assert_cmpfloat (edge, <, 0.01);
      /* ... and not silent in the middle. */
      g_assert_cmpfloat (energy (x, LENGTH) / LENGTH, >, 0.01);
    }
    g_free (w);
  }
}

static void
test_noise_orthogonality (void)
{
  const guint64 seeds[] = { 1, 2, 3, 42 };

  for (guint s = 0; s < G_N_ELEMENTS (seeds); s++) {
    float *w = generate (SONAR_WAVEFORM_NOISE, seeds[s]);
    const double margin = worst_cross_margin_db (w);

    g_test_message ("seed %" G_GUINT64_FORMAT ": worst cross-correlation "
        "peak %.2f dB below the autocorrelation peak", seeds[s], margin);
    g_assert_cmpfloat (margin, >=, 20.0);
    g_free (w);
  }
}

static void
test_band (void)
{
  /* Bounds measured with some room: noise about -51 dB, multisine -53 dB;
   * the chirp -25 dB, its sweep starting and ending on the band edges. */
  const struct
  {
    SonarWaveformKind kind;
    double bound_db;
  } cases[] = {
    {SONAR_WAVEFORM_NOISE, -45.0},
    {SONAR_WAVEFORM_MULTISINE, -45.0},
    {SONAR_WAVEFORM_HYPERBOLIC_CHIRP, -24.0},
  };

  for (guint c = 0; c < G_N_ELEMENTS (cases); c++) {
    float *w = generate (cases[c].kind, 1);
    double worst = -INFINITY;

    for (guint n = 0; n < N_EMITTERS; n++)
      worst = MAX (worst, out_of_band_db (row (w, n), LENGTH, BAND_LOW,
              BAND_HIGH));
    g_test_message ("%s: worst energy outside the band %.1f dB",
        sonar_waveform_kind_to_string (cases[c].kind), worst);
    g_assert_cmpfloat (worst, <, cases[c].bound_db);
    g_free (w);
  }
}

static void
test_reproducible (void)
{
  const gsize size = (gsize) N_EMITTERS * LENGTH * sizeof (float);
  guint n_kinds;
  const SonarWaveformKindInfo *kinds = sonar_waveform_kinds (&n_kinds);

  for (guint k = 0; k < n_kinds; k++) {
    float *a = generate (kinds[k].kind, 7);
    float *b = generate (kinds[k].kind, 7);
    float *c = generate (kinds[k].kind, 8);

    g_assert_cmpmem (a, size, b, size);
    for (guint n = 0; n < N_EMITTERS; n++)
      g_assert_true (memcmp (row (a, n), row (c, n),
              LENGTH * sizeof (float)) != 0);
    g_free (a);
    g_free (b);
    g_free (c);
  }
}

/* -3 dB width and peak sidelobe of the autocorrelation envelope. */
static void
measure_autocorrelation (const float *x, double *width, double *sidelobe_db)
{
  const gsize n = 2 * LENGTH - 1, centre = LENGTH - 1;
  double *r = sonar_test_xcorr (x, LENGTH, x, LENGTH);
  double *env = envelope (r, n);
  const double half_power = env[centre] / G_SQRT2;
  gsize right = centre, left = centre, first_null_right, first_null_left;
  double sidelobe = 0.0;

  while (env[right] > half_power)
    right++;
  while (env[left] > half_power)
    left--;
  /* Linear interpolation of the crossings. */
  *width = (right - (half_power - env[right]) / (env[right - 1] - env[right]))
      - (left + (half_power - env[left]) / (env[left + 1] - env[left]));

  first_null_right = right;
  while (first_null_right + 1 < n
      && env[first_null_right + 1] < env[first_null_right])
    first_null_right++;
  first_null_left = left;
  while (first_null_left > 0 && env[first_null_left - 1] < env[first_null_left])
    first_null_left--;
  for (gsize i = 0; i < n; i++)
    if (i > first_null_right || i < first_null_left)
      sidelobe = MAX (sidelobe, env[i]);
  *sidelobe_db = to_db (sidelobe / env[centre]);
  g_free (env);
  g_free (r);
}

static void
test_noise_autocorrelation (void)
{
  float *w = generate (SONAR_WAVEFORM_NOISE, 1);

  for (guint n = 0; n < N_EMITTERS; n++) {
    double width, sidelobe_db;

    measure_autocorrelation (row (w, n), &width, &sidelobe_db);
    g_test_message ("emitter %u: main lobe %.2f samples at -3 dB, peak "
        "sidelobe %.1f dB", n, width, sidelobe_db);
    g_assert_cmpfloat (width, >, 4.0);
    g_assert_cmpfloat (width, <, 12.0);
    g_assert_cmpfloat (sidelobe_db, <=, -10.0);
  }
  g_free (w);
}

static void
test_multisine_orthogonal (void)
{
  float *w = generate (SONAR_WAVEFORM_MULTISINE, 1);
  double worst = -INFINITY;

  for (guint i = 0; i < N_EMITTERS; i++) {
    for (guint j = i + 1; j < N_EMITTERS; j++) {
      double dot = 0.0;
      for (guint t = 0; t < LENGTH; t++)
        dot += (double) row (w, i)[t] * row (w, j)[t];
      worst = MAX (worst, to_db (fabs (dot) / sqrt (energy (row (w, i),
                      LENGTH) * energy (row (w, j), LENGTH))));
    }
  }
  /* Disjoint frequency sets: only the taper breaks the orthogonality. */
  g_test_message ("multisine: worst zero-lag cross-correlation %.1f dB",
      worst);
  g_assert_cmpfloat (worst, <, -33.0);
  g_free (w);
}

/* Mean frequency over samples [first, last) from the zero crossings. */
static double
zero_crossing_frequency (const float *x, guint first, guint last)
{
  guint crossings = 0;

  for (guint i = first + 1; i < last; i++)
    crossings += (x[i - 1] < 0.0f) != (x[i] < 0.0f);
  return crossings * SAMPLE_RATE / (2.0 * (last - first - 1));
}

/* Mean frequency of the hyperbolic sweep from f_start to f_end over
 * [t0, t1] (fractions of its duration): cycles over time. */
static double
hyperbolic_mean_frequency (double f_start, double f_end, double t0,
    double t1)
{
  const double duration = LENGTH / SAMPLE_RATE;
  const double b = (1.0 / f_end - 1.0 / f_start) / duration;
  const double cycles = (log1p (b * t1 * duration * f_start)
      - log1p (b * t0 * duration * f_start)) / b;
  return cycles / ((t1 - t0) * duration);
}

static void
test_chirp_sweep (void)
{
  float *w = generate (SONAR_WAVEFORM_HYPERBOLIC_CHIRP, 1);
  const guint tenth = LENGTH / 10;

  /* Emitter 0 sweeps down, emitter 1 up. */
  for (guint n = 0; n < 2; n++) {
    const double f_start = n == 0 ? BAND_HIGH : BAND_LOW;
    const double f_end = n == 0 ? BAND_LOW : BAND_HIGH;
    const double head = zero_crossing_frequency (row (w, n), 0, tenth);
    const double tail = zero_crossing_frequency (row (w, n), LENGTH - tenth,
        LENGTH);

    g_test_message ("chirp %u: %.1f kHz in the first tenth, %.1f kHz in "
        "the last", n, head / 1000, tail / 1000);
    g_assert_cmpfloat_with_epsilon (head,
        hyperbolic_mean_frequency (f_start, f_end, 0.0, 0.1), 1500.0);
    g_assert_cmpfloat_with_epsilon (tail,
        hyperbolic_mean_frequency (f_start, f_end, 0.9, 1.0), 1500.0);
  }
  g_assert_cmpfloat (zero_crossing_frequency (row (w, 0), 0, tenth), >,
      60000.0);
  g_assert_cmpfloat (zero_crossing_frequency (row (w, 0), LENGTH - tenth,
          LENGTH), <, 23000.0);
  g_free (w);
}

/* Unusual but valid set-ups still give finite, unit-peak waveforms. */
static void
test_edge_params (void)
{
  const struct
  {
    guint n_emitters, length;
    double sample_rate, band_low, band_high;
  } cases[] = {
    {1, 16, 160000.0, 10000.0, 80000.0},        /* shortest, band to Nyquist */
    {3, 1001, 450000.0, 20000.0, 80000.0},      /* odd length */
    {2, 4000, 96000.0, 30000.0, 48000.0},
  };

  guint n_kinds;
  const SonarWaveformKindInfo *kinds = sonar_waveform_kinds (&n_kinds);

  for (guint c = 0; c < G_N_ELEMENTS (cases); c++) {
    for (guint k = 0; k < n_kinds; k++) {
      SonarWaveformParams params;
      GError *error = NULL;
      float *out;

      sonar_waveform_params_init_default (&params);
      params.kind = kinds[k].kind;
      params.n_emitters = cases[c].n_emitters;
      params.length = cases[c].length;
      params.sample_rate = cases[c].sample_rate;
      params.band_low = cases[c].band_low;
      params.band_high = cases[c].band_high;
      out = g_new (float, (gsize) params.n_emitters * params.length);
      g_assert_true (sonar_waveform_generate (&params, out, &error));
      g_assert_no_error (error);
      for (guint n = 0; n < params.n_emitters; n++) {
        double peak = 0.0;
        for (guint i = 0; i < params.length; i++) {
          g_assert_true (isfinite (out[n * params.length + i]));
          peak = MAX (peak, fabs (out[n * params.length + i]));
        }
        g_assert_cmpfloat_with_epsilon (peak, 1.0, 1e-6);
      }
      g_free (out);
    }
  }
}

typedef struct
{
  const char *parameter;        /* the error message must name it */
  SonarWaveformParams params;
} InvalidCase;

static void
test_invalid_params (void)
{
  SonarWaveformParams d;
  float *out = g_new (float, (gsize) N_EMITTERS * LENGTH);
  InvalidCase cases[32];
  guint n_cases = 0;

#define ADD_CASE(name, field, value)                 \
  G_STMT_START {                                     \
    g_assert_cmpuint (n_cases, <, G_N_ELEMENTS (cases)); \
    cases[n_cases].parameter = name;                 \
    cases[n_cases].params = d;                       \
    cases[n_cases].params.field = value;             \
    n_cases++;                                       \
  } G_STMT_END

  sonar_waveform_params_init_default (&d);
  ADD_CASE ("kind", kind, (SonarWaveformKind) 42);
  ADD_CASE ("n_emitters", n_emitters, 0);
  ADD_CASE ("n_emitters", n_emitters, 65);
  ADD_CASE ("length", length, 15);
  ADD_CASE ("length", length, (1u << 20) + 1);
  ADD_CASE ("sample_rate", sample_rate, 0.0);
  ADD_CASE ("sample_rate", sample_rate, -450000.0);
  ADD_CASE ("sample_rate", sample_rate, NAN);
  ADD_CASE ("sample_rate", sample_rate, INFINITY);
  ADD_CASE ("band_low", band_low, 0.0);
  ADD_CASE ("band_low", band_low, -20000.0);
  ADD_CASE ("band_low", band_low, NAN);
  ADD_CASE ("band_high", band_high, BAND_LOW);
  ADD_CASE ("band_high", band_high, 10000.0);
  ADD_CASE ("band_high", band_high, 225001.0);
  ADD_CASE ("band_high", band_high, NAN);
  /* 20 000 to 20 200 Hz holds two bins of a 4000-sample FFT. */
  ADD_CASE ("band_high", band_high, 20200.0);
  /* 8 multisine emitters need 16 bins; 64 samples hold 9. */
  ADD_CASE ("n_emitters", length, 64);
  cases[n_cases - 1].params.kind = SONAR_WAVEFORM_MULTISINE;
#undef ADD_CASE

  for (guint c = 0; c < n_cases; c++) {
    GError *error = NULL;

    memset (out, 0, (gsize) N_EMITTERS * LENGTH * sizeof (float));
    g_assert_false (sonar_waveform_generate (&cases[c].params, out, &error));
    g_assert_error (error, SONAR_ERROR, SONAR_ERROR_SETTINGS);
    g_test_message ("%s", error->message);
    g_assert_nonnull (strstr (error->message, cases[c].parameter));
    /* Nothing written on failure. */
    g_assert_cmpfloat (energy (out, (gsize) N_EMITTERS * LENGTH), ==, 0.0);
    g_clear_error (&error);
  }
  g_free (out);
}

static void
test_kind_strings (void)
{
  SonarWaveformKind kind = SONAR_WAVEFORM_MULTISINE;
  guint n_kinds;
  const SonarWaveformKindInfo *kinds = sonar_waveform_kinds (&n_kinds);
  g_autofree char *nicks = sonar_waveform_kind_nicks (", ");

  /* The table: every enum value once, in order, named and described. */
  g_assert_cmpuint (n_kinds, ==, SONAR_WAVEFORM_MULTISINE + 1);
  for (guint k = 0; k < n_kinds; k++) {
    const char *name = sonar_waveform_kind_to_string (kinds[k].kind);
    g_assert_cmpint (kinds[k].kind, ==, k);
    g_assert_cmpstr (name, ==, kinds[k].nick);
    g_assert_cmpuint (strlen (kinds[k].description), >, 10);
    g_assert_true (sonar_waveform_kind_from_string (name, &kind));
    g_assert_cmpint (kind, ==, kinds[k].kind);
  }
  g_assert_cmpstr (nicks, ==, "noise, hyperbolic-chirp, multisine");
  g_assert_cmpstr (sonar_waveform_kind_to_string (SONAR_WAVEFORM_NOISE), ==,
      "noise");
  g_assert_cmpstr (sonar_waveform_kind_to_string
      (SONAR_WAVEFORM_HYPERBOLIC_CHIRP), ==, "hyperbolic-chirp");
  g_assert_cmpstr (sonar_waveform_kind_to_string (SONAR_WAVEFORM_MULTISINE),
      ==, "multisine");
  g_assert_null (sonar_waveform_kind_to_string ((SonarWaveformKind) 42));

  kind = SONAR_WAVEFORM_HYPERBOLIC_CHIRP;
  g_assert_false (sonar_waveform_kind_from_string ("chirp", &kind));
  g_assert_false (sonar_waveform_kind_from_string ("Noise", &kind));
  g_assert_false (sonar_waveform_kind_from_string ("", &kind));
  g_assert_false (sonar_waveform_kind_from_string (NULL, &kind));
  g_assert_cmpint (kind, ==, SONAR_WAVEFORM_HYPERBOLIC_CHIRP);
}

int
main (int argc, char **argv)
{
  g_test_init (&argc, &argv, NULL);
  g_test_add_func ("/waveform/default-params", test_default_params);
  g_test_add_func ("/waveform/unit-peak-and-taper", test_unit_peak_and_taper);
  g_test_add_func ("/waveform/noise-orthogonality", test_noise_orthogonality);
  g_test_add_func ("/waveform/band", test_band);
  g_test_add_func ("/waveform/reproducible", test_reproducible);
  g_test_add_func ("/waveform/noise-autocorrelation",
      test_noise_autocorrelation);
  g_test_add_func ("/waveform/multisine-orthogonal",
      test_multisine_orthogonal);
  g_test_add_func ("/waveform/chirp-sweep", test_chirp_sweep);
  g_test_add_func ("/waveform/edge-params", test_edge_params);
  g_test_add_func ("/waveform/invalid-params", test_invalid_params);
  g_test_add_func ("/waveform/kind-strings", test_kind_strings);
  return g_test_run ();
}
