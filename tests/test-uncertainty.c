/* test-uncertainty.c: the detections' uncertainties (sonar-uncertainty.h):
 * the curvature fit, the noise read off an image of known noise, the
 * sigmas of a peak of known shape, the bound they use against the
 * scatter of the peak's estimate over many noisy trials, and the linear
 * propagation of correlated noise through the three-sample parabola. The whole
 * chain's sigmas against its scatter: tests/test_results.py and
 * sonar-bench --sweep uncertainty. */
#include <math.h>

#include "sonar-rng.h"
#include "sonar-uncertainty.h"

/* A parabola's second derivative, exactly, wherever the span is cut by
 * the ends; too few values give NaN. */
static void
test_curvature (void)
{
  double values[9];

  for (int i = 0; i < 9; i++)
    values[i] = 3.0 + 0.4 * (i - 5) - 0.7 * (i - 5) * (i - 5);
  g_assert_cmpfloat_with_epsilon (sonar_uncertainty_curvature (values, 9, 5,
          3), -1.4, 1e-9);
  g_assert_cmpfloat_with_epsilon (sonar_uncertainty_curvature (values, 9, 8,
          3), -1.4, 1e-9);
  g_assert_true (isnan (sonar_uncertainty_curvature (values, 2, 1, 3)));
}

/* An image of Rayleigh envelopes of scale s (complex Gaussian noise of
 * power 2 s^2 per pixel) and one strong echo: the noise power read is
 * 2 s^2 within the quartile's statistical spread (4096 samples: 3 %). */
static void
test_noise_power (void)
{
  const SonarImageGrid grid = {.n_azimuth = 91,.n_elevation = 1,
    .n_range = 600,.azimuth_first = -45,.azimuth_step = 1,
    .range_first = 0.3,.range_step = 0.005
  };
  const double s = 0.02;
  g_autofree float *image = g_new (float, 91 * 600);
  g_autoptr (SonarNoiseMeter) meter = sonar_noise_meter_new (&grid, 1);
  SonarRng rng;

  sonar_rng_init (&rng, 3, 0);
  for (gsize i = 0; i < 91 * 600; i++) {
    const double re = s * sonar_rng_gaussian (&rng);
    const double im = s * sonar_rng_gaussian (&rng);
    image[i] = (float) hypot (re, im);
  }
  /* An echo's range sidelobes over every direction at 1 m: left out. */
  for (guint a = 0; a < 91; a++)
    for (guint i = 140; i < 170; i++)
      image[a * 600 + i] = 1.0f;
  g_assert_cmpfloat_with_epsilon (sonar_noise_meter_power (meter, image) /
      (2 * s * s), 1.0, 0.06);
}

/* Objects spread over a short window (a 20 Hz sensor's 8.6 m): their
 * cross-talk through the other emitters' templates lifts every direction
 * within a pulse length of each, here to 4 times the noise power over 4
 * in 5 blocks; the near range is blanked (zeros), and so is every fifth
 * direction (not imaged). The noise read is still 2 s^2: the cleanest
 * blocks' (the median of the blocks read 4 times it), and the zeros are
 * not noise at all (counted, a fifth of each block's pixels at zero
 * pulled the reading to an eighth of the noise). Within 12 %: the block
 * read lies a few per cent under the noise on noise alone. */
static void
test_noise_power_short_window (void)
{
  const SonarImageGrid grid = {.n_azimuth = 91,.n_elevation = 1,
    .n_range = 1660,.azimuth_first = -45,.azimuth_step = 1,
    .range_first = 0.3,.range_step = 0.005
  };
  const guint block = 50, lifted = 27, blanked = 4;     /* of 34 blocks */
  const double s = 0.02;
  g_autofree float *image = g_new (float, 91 * 1660);
  g_autoptr (SonarNoiseMeter) meter = sonar_noise_meter_new (&grid, 1);
  SonarRng rng;

  sonar_rng_init (&rng, 5, 0);
  for (guint a = 0; a < 91; a++)
    for (guint i = 0; i < 1660; i++) {
      const double scale = i < lifted * block ? 2.0 * s : s;
      const double re = scale * sonar_rng_gaussian (&rng);
      const double im = scale * sonar_rng_gaussian (&rng);
      image[a * 1660 + i] = i < blanked * block || a % 5 == 0 ? 0.0f :
          (float) hypot (re, im);
    }
  g_assert_cmpfloat_with_epsilon (sonar_noise_meter_power (meter, image) /
      (2 * s * s), 1.0, 0.12);
}

/* A Gaussian peak exp (-x^2 / (2 w^2)) in range and azimuth: its log
 * curvature is -1 / w^2, so sigma = w / sqrt (2 SNR); the velocity's from
 * the estimate's curvature, over N emitters with g / N of the SNR each;
 * a 2-D image has no elevation sigma. */
static void
test_sigmas_of_a_known_peak (void)
{
  const SonarImageGrid grid = {.n_azimuth = 41,.n_elevation = 1,
    .n_range = 200,.azimuth_first = -20,.azimuth_step = 1,
    .range_first = 1.0,.range_step = 0.002
  };
  const double amplitude = 50.0, noise_power = 0.25, wr = 0.003, wa = 1.5;
  const double snr = amplitude * amplitude / noise_power;
  g_autofree float *image = g_new (float, 41 * 200);
  SonarCentroid c = {.range = 1.2,.azimuth = 0.0,.peak_azimuth_index = 20,
    .peak_range_index = 100
  };
  SonarVelocityEstimate e = {.range = 1.2,.azimuth = 0.0,
    .velocity_curvature = -400.0
  };
  SonarUncertainty u;

  for (guint a = 0; a < 41; a++)
    for (guint i = 0; i < 200; i++) {
      const double x = (i - 100.0) * grid.range_step;
      const double y = a - 20.0;
      image[a * 200 + i] = (float) (amplitude * exp (-x * x / (2 * wr * wr)
              - y * y / (2 * wa * wa)));
    }
  sonar_uncertainty_measure (image, &grid, noise_power, &c, &e, 8, &u);
  g_assert_cmpfloat_with_epsilon (u.amplitude_db, 20 * log10 (amplitude),
      1e-4);
  g_assert_cmpfloat_with_epsilon (u.snr_db, 10 * log10 (snr), 1e-4);
  g_assert_cmpfloat_with_epsilon (u.range_sigma, wr / sqrt (2 * snr),
      1e-4 * wr);
  g_assert_cmpfloat_with_epsilon (u.azimuth_sigma, wa / sqrt (2 * snr),
      1e-4 * wa);
  g_assert_true (isnan (u.elevation_sigma));
  g_assert_cmpfloat_with_epsilon (u.radial_velocity_sigma, sqrt (8.0 /
          (2 * SONAR_UNCERTAINTY_EMITTER_SNR_GAIN * snr * 400.0)), 1e-9);
  /* No curvature measured (a prescreen rejection): no velocity sigma. */
  e.velocity_curvature = NAN;
  sonar_uncertainty_measure (image, &grid, noise_power, &c, &e, 8, &u);
  g_assert_true (isnan (u.radial_velocity_sigma));
}

/* Where velocityest fitted the direction (SonarVelocityEstimate's
 * direction_curvature), its sigmas are that fit's: the marginals of
 * (2 g SNR (-K))^-1, wider than each axis' own curvature says where the
 * beam lies tilted (K's cross term); along azimuth alone on a 2-D grid.
 * The image's curvature is not read then (an image that says otherwise). */
static void
test_sigmas_of_the_direction_fit (void)
{
  const SonarImageGrid grid = {.n_azimuth = 41,.n_elevation = 1,
    .n_range = 200,.azimuth_first = -20,.azimuth_step = 1,
    .range_first = 1.0,.range_step = 0.002
  };
  const double amplitude = 50.0, noise_power = 0.25;
  const double snr = amplitude * amplitude / noise_power *
      SONAR_UNCERTAINTY_FIT_SNR_GAIN;
  const double kaa = -0.9, kae = 0.3, kee = -0.5;
  const double det = kaa * kee - kae * kae;
  g_autofree float *image = g_new (float, 41 * 200);
  SonarCentroid c = {.range = 1.2,.peak_azimuth_index = 20,
    .peak_range_index = 100
  };
  SonarVelocityEstimate e = {.range = 1.2,.velocity_curvature = NAN,
    .direction_curvature = {kaa, NAN, NAN}
  };
  SonarUncertainty u;

  for (guint a = 0; a < 41; a++)
    for (guint i = 0; i < 200; i++) {
      const double x = (i - 100.0) * grid.range_step, y = a - 20.0;
      image[a * 200 + i] = (float) (amplitude * exp (-x * x / (2 * 0.003 *
                  0.003) - y * y / (2 * 4.0 * 4.0)));
    }
  sonar_uncertainty_measure (image, &grid, noise_power, &c, &e, 8, &u);
  g_assert_cmpfloat_with_epsilon (u.azimuth_sigma, 1.0 / sqrt (2 * snr *
          -kaa), 1e-12);
  g_assert_true (isnan (u.elevation_sigma));

  e.direction_curvature[1] = kae;
  e.direction_curvature[2] = kee;
  sonar_uncertainty_measure (image, &grid, noise_power, &c, &e, 8, &u);
  g_assert_cmpfloat_with_epsilon (u.azimuth_sigma, sqrt (-kee / det /
          (2 * snr)), 1e-12);
  g_assert_cmpfloat_with_epsilon (u.elevation_sigma, sqrt (-kaa / det /
          (2 * snr)), 1e-12);
  g_assert_cmpfloat (u.azimuth_sigma, >, 1.0 / sqrt (2 * snr * -kaa));

  /* No maximum (not negative definite): no direction sigma. */
  e.direction_curvature[1] = 1.0;
  sonar_uncertainty_measure (image, &grid, noise_power, &c, &e, 8, &u);
  g_assert_true (isnan (u.azimuth_sigma) && isnan (u.elevation_sigma));
}

/* The bound itself: a matched filter's output, A rho (x - x0) plus noise
 * correlated as rho (white noise through the same filter), sampled
 * finely; the peak read off a parabola through the log envelope's three
 * top samples. Over 3000 trials at an SNR of 20 dB the estimate's scatter
 * matches 1 / sqrt (2 SNR |kappa|) within 10 %. */
#define TRIALS 3000
#define N_SAMPLES 64
#define KERNEL 10

static void
test_bound_against_scatter (void)
{
  /* rho (x) = exp (-x^2 / (4 a^2)): a Gaussian pulse's autocorrelation. */
  const double a = 1.5, amplitude = 1.0, x0 = 31.3;
  double kernel[2 * KERNEL + 1], norm = 0.0;
  double sum = 0.0, sum2 = 0.0, noise_power, snr, kappa, bound;
  SonarRng rng;

  for (int k = -KERNEL; k <= KERNEL; k++) {
    kernel[k + KERNEL] = exp (-k * k / (2 * a * a));
    norm += kernel[k + KERNEL] * kernel[k + KERNEL];
  }
  /* White noise of unit power per sample through the kernel: power norm
   * per output sample; the output's correlation is the kernel's
   * autocorrelation, rho. Scaled for an SNR of 100. */
  noise_power = amplitude * amplitude / 100.0;
  sonar_rng_init (&rng, 11, 0);
  for (guint t = 0; t < TRIALS; t++) {
    double re[N_SAMPLES + 2 * KERNEL], im[N_SAMPLES + 2 * KERNEL];
    double envelope[N_SAMPLES];
    guint best = 1;
    for (guint i = 0; i < N_SAMPLES + 2 * KERNEL; i++) {
      re[i] = sonar_rng_gaussian (&rng) * sqrt (noise_power / (2 * norm));
      im[i] = sonar_rng_gaussian (&rng) * sqrt (noise_power / (2 * norm));
    }
    for (guint i = 0; i < N_SAMPLES; i++) {
      double r = amplitude * exp (-(i - x0) * (i - x0) / (4 * a * a));
      double q = 0.0;
      for (int k = -KERNEL; k <= KERNEL; k++) {
        r += kernel[k + KERNEL] * re[i + KERNEL + k];
        q += kernel[k + KERNEL] * im[i + KERNEL + k];
      }
      envelope[i] = hypot (r, q);
    }
    for (guint i = 1; i + 1 < N_SAMPLES; i++)
      if (envelope[i] > envelope[best])
        best = i;
    {
      const double l0 = log (envelope[best - 1]), l1 = log (envelope[best]);
      const double l2 = log (envelope[best + 1]);
      const double x = best + 0.5 * (l0 - l2) / (l0 - 2 * l1 + l2);
      sum += x;
      sum2 += x * x;
    }
  }
  snr = amplitude * amplitude / noise_power;
  kappa = -1.0 / (2 * a * a);
  bound = sqrt (1.0 / (2 * snr * -kappa));
  {
    const double mean = sum / TRIALS;
    const double scatter = sqrt (sum2 / TRIALS - mean * mean);
    g_test_message ("bound %.4f, scatter %.4f samples", bound, scatter);
    g_assert_cmpfloat_with_epsilon (scatter / bound, 1.0, 0.1);
  }
}

/* The propagation through the three-sample parabola
 * (sonar_uncertainty_parabola_sigma ()): three samples of a Gaussian peak
 * A_k = exp (-(k - x0)^2 / (2 s^2)) plus circular complex noise
 * correlated rho1 between neighbours and rho2 between the outer two (the
 * Cholesky factor of that matrix applied to white noise), at 40 dB. Over
 * 4000 trials the offset's scatter matches the formula within 5 % (its
 * own statistical spread 1.1 %), while the formula without the
 * correlations misses it by more than 15 %: the test sees the
 * correlations. */
#define PROPAGATION_TRIALS 4000

static void
check_propagation (double x0, double s, double rho1, double rho2)
{
  const double power = 1e-4;
  /* Cholesky factor of [[1 r1 r2] [r1 1 r1] [r2 r1 1]]. */
  const double l10 = rho1, l11 = sqrt (1.0 - rho1 * rho1);
  const double l20 = rho2, l21 = (rho1 - rho2 * rho1) / l11;
  const double l22 = sqrt (1.0 - l20 * l20 - l21 * l21);
  double a[3], y[3], var[3], sum = 0.0, sum2 = 0.0, scatter, sigma, plain;
  SonarRng rng;

  for (int k = 0; k < 3; k++) {
    a[k] = exp (-(k - 1 - x0) * (k - 1 - x0) / (2 * s * s));
    y[k] = log (a[k]);
    var[k] = power / (2 * a[k] * a[k]);
  }
  sonar_rng_init (&rng, 17, 0);
  for (guint t = 0; t < PROPAGATION_TRIALS; t++) {
    double z[2][3], l[3], u;
    for (int part = 0; part < 2; part++)
      for (int k = 0; k < 3; k++)
        z[part][k] = sqrt (power / 2) * sonar_rng_gaussian (&rng);
    for (int k = 0; k < 3; k++) {
      const double *lk = k == 0 ? (double[]) { 1, 0, 0 } : k == 1 ?
          (double[]) { l10, l11, 0 } : (double[]) { l20, l21, l22 };
      const double re = lk[0] * z[0][0] + lk[1] * z[0][1] + lk[2] * z[0][2];
      const double im = lk[0] * z[1][0] + lk[1] * z[1][1] + lk[2] * z[1][2];
      l[k] = log (hypot (a[k] + re, im));
    }
    u = 0.5 * (l[0] - l[2]) / (l[0] - 2 * l[1] + l[2]);
    sum += u;
    sum2 += u * u;
  }
  scatter = sqrt (sum2 / PROPAGATION_TRIALS - (sum / PROPAGATION_TRIALS) *
      (sum / PROPAGATION_TRIALS));
  sigma = sonar_uncertainty_parabola_sigma (y, var, rho1, rho2);
  plain = sonar_uncertainty_parabola_sigma (y, var, 0.0, 0.0);
  g_test_message ("x0 %.2f rho %.2f %.2f: scatter %.5f, propagated %.5f, "
      "uncorrelated %.5f steps", x0, rho1, rho2, scatter, sigma, plain);
  g_assert_cmpfloat_with_epsilon (scatter / sigma, 1.0, 0.05);
  g_assert_cmpfloat (fabs (scatter / plain - 1.0), >, 0.15);
}

static void
test_propagation (void)
{
  const double flat[3] = { 0.0, 0.0, 0.0 }, var[3] = { 1, 1, 1 };

  check_propagation (0.2, 1.0, 0.6, 0.2);
  check_propagation (0.0, 0.8, 0.2, -0.5);
  /* No peak, no sigma. */
  g_assert_true (isnan (sonar_uncertainty_parabola_sigma (flat, var, 0.5,
              0.1)));
}

int
main (int argc, char **argv)
{
  g_test_init (&argc, &argv, NULL);
  g_test_add_func ("/uncertainty/curvature", test_curvature);
  g_test_add_func ("/uncertainty/noise-power", test_noise_power);
  g_test_add_func ("/uncertainty/noise-power-short-window",
      test_noise_power_short_window);
  g_test_add_func ("/uncertainty/known-peak", test_sigmas_of_a_known_peak);
  g_test_add_func ("/uncertainty/direction-fit",
      test_sigmas_of_the_direction_fit);
  g_test_add_func ("/uncertainty/bound", test_bound_against_scatter);
  g_test_add_func ("/uncertainty/propagation", test_propagation);
  return g_test_run ();
}
