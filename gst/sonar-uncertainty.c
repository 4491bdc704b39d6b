/* sonar-uncertainty.c: see sonar-uncertainty.h. */
#include "sonar-uncertainty.h"

#include <math.h>

/* Pixels, about, in each block's noise quartile: from a thousand samples
 * a quartile is steady to a few per cent. */
#define NOISE_SAMPLES 1024
/* The noise is read in the cleanest blocks: the one with a tenth of the
 * blocks (rounded down) below it, the cleanest of fewer than ten. Echoes
 * only add power, and their cross-talk through the other emitters'
 * templates lifts every direction within about a pulse length (+-1.5 m)
 * of each: with objects spread over a short window that is most of the
 * blocks, and their median read that cross-talk as noise (14 dB over it
 * with six objects in a 20 Hz sensor's 8.6 m; 13-19 dB on the default
 * and Fig. 10 scenes), where this one read it within 0.5 dB. Over noise
 * alone the blocks' quartiles agree within a few per cent, and this one
 * reads 0.1-0.25 dB under their median on recordings without echoes, up
 * to 0.4 dB on fewer, independent blocks (8-34). */
#define NOISE_BLOCKS_BELOW_SHARE 10

struct _SonarNoiseMeter
{
  SonarImageGrid grid;
  gsize n_dirs, stride;         /* every stride-th direction is read */
  guint block, n_blocks;        /* range bins per block, blocks */
  double k;                     /* K_eff at the quartile */
  float *values;                /* a block's sample */
  float *quartiles;             /* per block */
};

SonarNoiseMeter *
sonar_noise_meter_new (const SonarImageGrid * grid, guint hypotheses)
{
  SonarNoiseMeter *m = g_new0 (SonarNoiseMeter, 1);

  m->grid = *grid;
  m->n_dirs = (gsize) grid->n_azimuth * grid->n_elevation;
  m->block = MAX (1, (guint) ceil (SONAR_UNCERTAINTY_NOISE_BLOCK /
          MAX (grid->range_step, 1e-9)));
  m->n_blocks = (grid->n_range + m->block - 1) / m->block;
  /* Every stride-th direction, each one's run of range bins read in one
   * go (a sample's worth of reads, in cache lines). */
  m->stride = MAX (1, m->n_dirs * m->block / NOISE_SAMPLES);
  m->k = 1.0 + (MAX (hypotheses, 1) - 1.0) *
      SONAR_UNCERTAINTY_QUARTILE_SHARE;
  m->values = g_new (float, (m->n_dirs / m->stride + 1) * m->block);
  m->quartiles = g_new (float, MAX (m->n_blocks, 1));
  return m;
}

void
sonar_noise_meter_free (SonarNoiseMeter * m)
{
  if (!m)
    return;
  g_free (m->values);
  g_free (m->quartiles);
  g_free (m);
}

double
sonar_noise_meter_power (SonarNoiseMeter * m, const float *image)
{
  const SonarImageGrid *grid = &m->grid;
  guint n_quartiles = 0;
  double q;

  for (guint b = 0; b < m->n_blocks; b++) {
    const guint first = b * m->block;
    const guint rows = MIN (m->block, grid->n_range - first);
    gsize n = 0;
    /* Offset by block, so that the blocks see different directions. */
    for (gsize d = b % m->stride; d < m->n_dirs; d += m->stride) {
      const float *run = image + d * grid->n_range + first;
      /* Zeros are no noise (an image blanked there, wholly or in part):
       * they would pull the block's quartile down. */
      for (guint i = 0; i < rows; i++)
        if (isfinite (run[i]) && run[i] > 0.0f)
          m->values[n++] = run[i];
    }
    if (n < 4)
      continue;
    m->quartiles[n_quartiles++] = sonar_select_kth (m->values, n, n / 4);
  }
  if (n_quartiles == 0)
    return 0.0;
  q = sonar_select_kth (m->quartiles, n_quartiles, n_quartiles /
      NOISE_BLOCKS_BELOW_SHARE);
  /* The quartile of the maximum of K Rayleigh envelopes of scale s:
   * q^2 = -2 s^2 ln (1 - 4^(-1/K)); E|n|^2 = 2 s^2. */
  return q * q / -log (-expm1 (log (0.25) / m->k));
}

double
sonar_uncertainty_curvature (const double *values, guint n, guint p,
    guint half)
{
  const int lo = -(int) MIN (half, p);
  const int hi = (int) MIN (half, n - 1 - p);
  double s[5] = { 0 }, t[3] = { 0 }, det, c;

  if (hi - lo < 2)
    return NAN;
  /* Normal equations of y = a + b x + c x^2. */
  for (int x = lo; x <= hi; x++) {
    double xp = 1.0;
    for (int k = 0; k < 5; k++) {
      s[k] += xp;
      if (k < 3)
        t[k] += xp * values[p + x];
      xp *= x;
    }
  }
  det = s[0] * (s[2] * s[4] - s[3] * s[3]) - s[1] * (s[1] * s[4] - s[3] *
      s[2]) + s[2] * (s[1] * s[3] - s[2] * s[2]);
  if (fabs (det) < 1e-12)
    return NAN;
  c = (s[0] * (s[2] * t[2] - t[1] * s[3]) - s[1] * (s[1] * t[2] - t[1] *
          s[2]) + t[0] * (s[1] * s[3] - s[2] * s[2])) / det;
  return 2.0 * c;
}

double
sonar_uncertainty_parabola_sigma (const double y[3], const double var[3],
    double rho1, double rho2)
{
  const double c = y[0] - 2.0 * y[1] + y[2];
  double u, w[3], v;

  if (!(c < 0.0))
    return NAN;
  u = 0.5 * (y[0] - y[2]) / c;
  /* du/dy of u = (y- - y+) / (2 c). */
  w[0] = (1.0 - 2.0 * u) / (2.0 * c);
  w[1] = 4.0 * u / (2.0 * c);
  w[2] = -(1.0 + 2.0 * u) / (2.0 * c);
  v = w[0] * w[0] * var[0] + w[1] * w[1] * var[1] + w[2] * w[2] * var[2] +
      2.0 * rho1 * (w[0] * w[1] * sqrt (var[0] * var[1]) +
      w[1] * w[2] * sqrt (var[1] * var[2])) +
      2.0 * rho2 * w[0] * w[2] * sqrt (var[0] * var[2]);
  return v > 0.0 ? sqrt (v) : NAN;
}

/* Second derivative of ln (image) at pixel @p along an axis of @stride
 * (index @i of @n along it), per step^2; NaN at an edge or where the
 * samples are no peak. */
static double
log_curvature (const float *image, gsize p, gsize stride, guint i, guint n)
{
  double k;

  if (i == 0 || i + 1 >= n || !(image[p - stride] > 0.0f)
      || !(image[p] > 0.0f) || !(image[p + stride] > 0.0f))
    return NAN;
  k = log (image[p - stride]) - 2.0 * log (image[p]) +
      log (image[p + stride]);
  return k < 0.0 ? k : NAN;
}

/* With SONAR_UNCERTAINTY_SAMPLES set (read once), each measurement
 * prints its inputs to stderr, one line: "sonar-uncertainty-samples:",
 * the noise power, the peak's range, azimuth and elevation indices, the
 * centroid's range, azimuth, elevation, the estimate's, then the image at
 * -2 .. 2 steps from the peak along range, azimuth and elevation (NaN off
 * the grid). tools/uncertainty-3d.py --samples reads them. */
static gboolean
print_samples (void)
{
  static gsize once = 0;

  if (g_once_init_enter (&once))
    g_once_init_leave (&once, g_getenv ("SONAR_UNCERTAINTY_SAMPLES") ? 2 :
        1);
  return once == 2;
}

static void
write_samples (const float *image, const SonarImageGrid * grid, gsize p,
    const guint index[3], double noise_power,
    const SonarCentroid * centroid, const SonarVelocityEstimate * e)
{
  const gsize strides[3] = { 1, grid->n_range,
    (gsize) grid->n_azimuth * grid->n_range
  };
  const guint sizes[3] = { grid->n_range, grid->n_azimuth,
    grid->n_elevation
  };
  double v[15];

  for (int axis = 0; axis < 3; axis++)
    for (int k = -2; k <= 2; k++) {
      const long j = (long) index[axis] + k;
      v[5 * axis + k + 2] = j >= 0 && j < (long) sizes[axis] ?
          image[(gssize) p + k * (gssize) strides[axis]] : NAN;
    }
  g_printerr ("sonar-uncertainty-samples: %.9g %u %u %u %.6f %.4f %.4f "
      "%.6f %.4f %.4f", noise_power, index[0], index[1], index[2],
      centroid->range, centroid->azimuth, centroid->elevation, e->range,
      e->azimuth, e->elevation);
  for (int k = 0; k < 15; k++)
    g_printerr (" %.9g", v[k]);
  g_printerr ("\n");
}

/* sqrt (1 / (2 snr |kappa|)), NaN without a curvature. */
static double
sigma (double snr, double kappa)
{
  if (!(kappa < 0.0) || !(snr > 0.0))
    return NAN;
  return sqrt (1.0 / (2.0 * snr * -kappa));
}

void
sonar_uncertainty_measure (const float *image, const SonarImageGrid * grid,
    double noise_power, const SonarCentroid * centroid,
    const SonarVelocityEstimate * e, guint n_emitters, SonarUncertainty * out)
{
  const gsize stride_e = (gsize) grid->n_azimuth * grid->n_range;
  const guint a = MIN (centroid->peak_azimuth_index, grid->n_azimuth - 1);
  const guint el = MIN (centroid->peak_elevation_index,
      grid->n_elevation - 1);
  const gsize row = ((gsize) el * grid->n_azimuth + a) * grid->n_range;
  const double nearest = (e->range - grid->range_first) /
      MAX (grid->range_step, 1e-12);
  const guint i0 = (guint) CLAMP (lround (nearest), 0,
      (long) grid->n_range - 1);
  guint i = i0;
  double amplitude, snr;
  gsize p;

  /* The echo's own peak along range, within 2 bins of its range (a second
   * reflector in the centroid lies off the strongest member's). */
  for (guint j = (guint) MAX ((long) i0 - 2, 0); j <= MIN (i0 + 2,
          grid->n_range - 1); j++)
    if (image[row + j] > image[row + i])
      i = j;
  p = row + i;
  amplitude = image[p];
  snr = noise_power > 0.0 ? amplitude * amplitude / noise_power : NAN;
  out->amplitude_db = amplitude > 0.0f ? 20.0 * log10 (amplitude) : NAN;
  out->snr_db = 10.0 * log10 (snr);
  out->range_sigma = grid->range_step * sigma (snr, log_curvature (image,
          p, 1, i, grid->n_range));
  out->azimuth_sigma = fabs (grid->azimuth_step) * sigma (snr,
      log_curvature (image, p, grid->n_range, a, grid->n_azimuth));
  out->elevation_sigma = grid->n_elevation > 1 ?
      fabs (grid->elevation_step) * sigma (snr, log_curvature (image, p,
          stride_e, el, grid->n_elevation)) :
      NAN;
  if (e->direction_curvature[0] < 0.0) {
    /* velocityest's fit, which the direction is: in 3-D the covariance
     * (2 g SNR (-K))^-1 of its Hessian K (sonar-uncertainty.h); along
     * azimuth alone where it fitted azimuth alone. */
    const double *k = e->direction_curvature;
    const double det = k[0] * k[2] - k[1] * k[1];
    const double fit_snr = snr * SONAR_UNCERTAINTY_FIT_SNR_GAIN;
    if (isfinite (k[2])) {
      out->azimuth_sigma = det > 0.0 ? sigma (fit_snr, det / k[2]) : NAN;
      out->elevation_sigma = det > 0.0 ? sigma (fit_snr, det / k[0]) : NAN;
    } else {
      out->azimuth_sigma = sigma (fit_snr, k[0]);
    }
  }
  if (print_samples ()) {
    const guint index[3] = { i, a, el };
    write_samples (image, grid, p, index, noise_power, centroid, e);
  }
  /* Each emitter's curve carries g / N of the MIMO image's SNR. */
  out->radial_velocity_sigma = n_emitters > 0 ? sigma (snr *
      SONAR_UNCERTAINTY_EMITTER_SNR_GAIN / n_emitters,
      e->velocity_curvature) :
      NAN;
}
