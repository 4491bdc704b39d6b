/* test-interp.c: the band-limited interpolator against analytic references:
 * accuracy at random fractional positions, zero outside its support, the
 * per-bin filter, and positions that are not numbers. */
#include <math.h>

#include "sonar-interp.h"
#include "sonar-setup.h"

#define FS SONAR_DEFAULT_SAMPLE_RATE
#define L 4000
#define N_POSITIONS 200000

/* In-band tones up to 80 kHz under a Gaussian window of sigma L / 12: at
 * the ends the window is 1.5e-8 and its spectrum is 215 Hz wide, so the
 * sampled signal is band-limited to far below float precision and its
 * value at any fractional position is known exactly. */
static const double tone_freqs[] = { 21.3e3, 37.9e3, 52.1e3, 66.7e3, 79.2e3 };
static const double tone_phases[] = { 0.3, 2.1, 4.0, 1.2, 5.5 };

static double
window (double x)
{
  const double u = (x - 0.5 * (L - 1)) / (L / 12.0);
  return exp (-0.5 * u * u);
}

/* The tones below @max_freq. */
static double
tones (double x, double max_freq)
{
  double sum = 0.0;

  for (guint k = 0; k < G_N_ELEMENTS (tone_freqs); k++) {
    if (tone_freqs[k] < max_freq)
      sum += sin (2.0 * M_PI * tone_freqs[k] * x / FS + tone_phases[k]);
  }
  return window (x) * sum;
}

static double
unit_tone (double x, double max_freq)
{
  (void) max_freq;
  return window (x) * sin (2.0 * M_PI * 80e3 * x / FS + 0.7);
}

typedef double (*Reference) (double x, double max_freq);

static float *
sample (Reference f, double *peak)
{
  float *signal = g_new (float, L);

  *peak = 0.0;
  for (guint i = 0; i < L; i++) {
    signal[i] = (float) f (i, INFINITY);
    *peak = MAX (*peak, fabs (signal[i]));
  }
  return signal;
}

/* Worst |interp - f| in dB of @peak at random positions over the whole
 * support, tails included. */
static double
worst_error_db (const SonarInterp * interp, Reference f, double max_freq,
    double peak)
{
  GRand *rand = g_rand_new_with_seed (7);
  double worst = 0.0;

  for (guint i = 0; i < N_POSITIONS; i++) {
    const double x = g_rand_double_range (rand, -SONAR_INTERP_PAD,
        L - 1 + SONAR_INTERP_PAD);
    worst = MAX (worst, fabs (sonar_interp_at (interp, x) - f (x, max_freq)));
  }
  g_rand_free (rand);
  return 20.0 * log10 (worst / peak);
}

static void
test_accuracy (void)
{
  static const struct
  {
    const char *name;
    Reference f;
  } cases[] = {
    {"five tones of 21 to 79 kHz", tones},
    {"one tone at 80 kHz", unit_tone},
  };

  for (guint c = 0; c < G_N_ELEMENTS (cases); c++) {
    double peak, db;
    g_autofree float *signal = sample (cases[c].f, &peak);
    g_autoptr (SonarInterp) interp = sonar_interp_new (signal, L);

    db = worst_error_db (interp, cases[c].f, INFINITY, peak);
    g_test_message ("%s: worst error %.1f dB of the peak", cases[c].name, db);
    g_assert_cmpfloat (db, <, -90.0);
  }
}

static void
test_outside (void)
{
  static const double positions[] = { -SONAR_INTERP_PAD - 0.01, -1000.0,
    L - 1 + SONAR_INTERP_PAD + 0.01, L + 1000.0, -1e9, 1e9
  };
  double peak;
  g_autofree float *signal = sample (tones, &peak);
  g_autoptr (SonarInterp) interp = sonar_interp_new (signal, L);

  for (guint i = 0; i < G_N_ELEMENTS (positions); i++)
    g_assert_cmpfloat (sonar_interp_at (interp, positions[i]), ==, 0.0f);
}

static void
test_not_numbers (void)
{
  const double positions[] = { NAN, -NAN, INFINITY, -INFINITY, 1e300,
    -1e300, G_MAXDOUBLE, -G_MAXDOUBLE, 1e20, -1e20, 4.5e15
  };
  double peak;
  g_autofree float *signal = sample (tones, &peak);
  g_autoptr (SonarInterp) interp = sonar_interp_new (signal, L);

  for (guint i = 0; i < G_N_ELEMENTS (positions); i++)
    g_assert_cmpfloat (sonar_interp_at (interp, positions[i]), ==, 0.0f);
}

/* Unit gains rebuild the same table and 0.5 halves it, exactly (halving
 * commutes with rounding); a low-pass leaves the tones below its cut-off;
 * NULL restores the signal. */
static void
test_filter (void)
{
  const double cutoff = 60e3;
  double peak, db;
  g_autofree float *signal = sample (tones, &peak);
  g_autoptr (SonarInterp) fixed = sonar_interp_new (signal, L);
  g_autoptr (SonarInterp) interp = sonar_interp_new_filterable (signal, L,
      NULL);
  const guint n_bins = sonar_interp_n_bins (interp);
  g_autofree float *gains = g_new (float, n_bins);
  GRand *rand = g_rand_new_with_seed (11);
  g_autofree double *x = g_new (double, 1000);
  g_autofree float *before = g_new (float, 1000);

  g_assert_cmpfloat (sonar_interp_bin_frequency (interp, 0), ==, 0.0);
  g_assert_cmpfloat (fabs (sonar_interp_bin_frequency (interp, n_bins - 1)
          - 0.5), <, 1.0 / L);
  for (guint i = 0; i < 1000; i++) {
    x[i] = g_rand_double_range (rand, -SONAR_INTERP_PAD,
        L - 1 + SONAR_INTERP_PAD);
    before[i] = sonar_interp_at (interp, x[i]);
    g_assert_cmpfloat (before[i], ==, sonar_interp_at (fixed, x[i]));
  }
  g_rand_free (rand);

  for (guint k = 0; k < n_bins; k++)
    gains[k] = 1.0f;
  sonar_interp_filter (interp, gains);
  for (guint i = 0; i < 1000; i++)
    g_assert_cmpfloat (sonar_interp_at (interp, x[i]), ==, before[i]);

  for (guint k = 0; k < n_bins; k++)
    gains[k] = 0.5f;
  sonar_interp_filter (interp, gains);
  for (guint i = 0; i < 1000; i++)
    g_assert_cmpfloat (sonar_interp_at (interp, x[i]), ==, 0.5f * before[i]);

  for (guint k = 0; k < n_bins; k++)
    gains[k] = sonar_interp_bin_frequency (interp, k) * FS < cutoff ? 1.0f : 0.0f;
  sonar_interp_filter (interp, gains);
  db = worst_error_db (interp, tones, cutoff, peak);
  g_test_message ("low-pass at %.0f kHz: worst error %.1f dB of the peak",
      cutoff / 1e3, db);
  g_assert_cmpfloat (db, <, -90.0);

  sonar_interp_filter (interp, NULL);
  for (guint i = 0; i < 1000; i++)
    g_assert_cmpfloat (sonar_interp_at (interp, x[i]), ==, before[i]);
}

/* Interpolators sharing rebuild buffers keep their own tables. */
static void
test_shared (void)
{
  double peak_a, peak_b;
  g_autofree float *a_signal = sample (tones, &peak_a);
  g_autofree float *b_signal = sample (unit_tone, &peak_b);
  g_autoptr (SonarInterp) a = sonar_interp_new_filterable (a_signal, L, NULL);
  g_autoptr (SonarInterp) b = sonar_interp_new_filterable (b_signal, L, a);
  const guint n_bins = sonar_interp_n_bins (a);
  g_autofree float *gains = g_new (float, n_bins);

  for (guint k = 0; k < n_bins; k++)
    gains[k] = 1.0f;
  sonar_interp_filter (b, gains);
  g_clear_pointer (&a, sonar_interp_free);
  g_assert_cmpfloat (worst_error_db (b, unit_tone, INFINITY, peak_b), <,
      -90.0);

  a = sonar_interp_new_filterable (a_signal, L, b);
  sonar_interp_filter (a, gains);
  sonar_interp_filter (b, gains);
  g_assert_cmpfloat (worst_error_db (a, tones, INFINITY, peak_a), <, -90.0);
  g_assert_cmpfloat (worst_error_db (b, unit_tone, INFINITY, peak_b), <,
      -90.0);
}

int
main (int argc, char **argv)
{
  g_test_init (&argc, &argv, NULL);
  g_test_add_func ("/interp/accuracy", test_accuracy);
  g_test_add_func ("/interp/outside", test_outside);
  g_test_add_func ("/interp/not-numbers", test_not_numbers);
  g_test_add_func ("/interp/filter", test_filter);
  g_test_add_func ("/interp/shared", test_shared);
  return g_test_run ();
}
