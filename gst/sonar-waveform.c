/* sonar-waveform.c: see sonar-waveform.h.
 *
 * Every kind shares one envelope and one spectral shape:
 *  - a raised-cosine taper over the first and last 5 % of the samples, so
 *    the emission starts and stops smoothly;
 *  - a band gain that is 1 inside [band_low, band_high] and falls to 0 at
 *    the band edges along a raised cosine about 1.5 sample_rate / taper
 *    wide.
 * The two are sized together on purpose: a taper of T samples spreads every
 * spectral line over about sample_rate / T, so a brick-wall band under a
 * 1 % taper puts only 24-30 dB less energy outside the band than inside.
 * A 5 % taper and a 3.4 kHz roll-off (the defaults) bring that to about
 * -50 dB, while the -3 dB autocorrelation main lobe stays about 7 samples
 * wide (6.8 with the brick wall).
 */
#include "sonar-waveform.h"
#include "sonar-error.h"
#include "sonar-fftw.h"
#include "sonar-rng.h"
#include "sonar-setup.h"

#include <fftw3.h>
#include <gio/gio.h>
#include <math.h>
#include <string.h>

#define SET_ERROR(error, ...) \
  g_set_error (error, SONAR_ERROR, SONAR_ERROR_SETTINGS, __VA_ARGS__)

#define MIN_LENGTH 16
/* Fewer FFT bins in the band is a tone, not a wideband emission. */
#define MIN_BAND_BINS 4
#define TAPER_FRACTION 0.05
#define MIN_TAPER 4
#define ROLLOFF_PER_TAPER 1.5
/* The roll-off never eats more than this share of the band per edge. */
#define MAX_ROLLOFF_FRACTION 0.25

/* Noise decorrelation (see decorrelate_noise): stop once every pair's
 * cross-correlation envelope is CROSS_TARGET_DB below the autocorrelation
 * peak and every autocorrelation sidelobe SIDELOBE_TARGET_DB; the excess is
 * pushed down to the CLIP levels, a little lower, so the last step lands
 * below the targets with room to spare. */
#define CROSS_TARGET_DB (-23.0)
#define CROSS_CLIP_DB (-24.0)
#define SIDELOBE_TARGET_DB (-14.0)
#define SIDELOBE_CLIP_DB (-15.0)
#define DECORRELATION_MAX_ITERATIONS 50
#define DECORRELATION_STEP 0.2
/* A step halved this far means the descent is stuck at a kink. */
#define DECORRELATION_MIN_STEP (DECORRELATION_STEP / 64)
/* Work (correlations times FFT size) all iterations together may cost, so
 * that set-up stays within a few seconds: an iteration correlates every
 * pair and every emission with itself at 2 FFTs each (8 emitters of 4000
 * samples: 36 correlations of 8000 points, about 10 ms). Counting work
 * rather than time keeps the result independent of the machine. Long sets
 * get few iterations or none; they need few, their time-bandwidth product
 * alone clears the cross-correlation target. */
#define DECORRELATION_BUDGET (1u << 26)

void
sonar_waveform_params_init_default (SonarWaveformParams * params)
{
  params->kind = SONAR_WAVEFORM_NOISE;
  params->n_emitters = SONAR_DEFAULT_N_EMITTERS;
  params->length = SONAR_DEFAULT_WAVEFORM_LENGTH;
  params->sample_rate = SONAR_DEFAULT_SAMPLE_RATE;
  params->band_low = SONAR_DEFAULT_BAND_LOW;
  params->band_high = SONAR_DEFAULT_BAND_HIGH;
  params->seed = 1;
}

/* Bins of a length-point FFT strictly inside the band: the ones the band
 * gain (shape_init) does not zero. */
static guint
count_band_bins (const SonarWaveformParams * p)
{
  guint count = 0;

  for (guint k = 0; k <= p->length / 2; k++) {
    const double f = k * p->sample_rate / p->length;
    count += f > p->band_low && f < p->band_high;
  }
  return count;
}

static gboolean
validate_params (const SonarWaveformParams * p, GError ** error)
{
  const char *kind_name = sonar_waveform_kind_to_string (p->kind);
  guint band_bins;

  if (!kind_name) {
    g_autofree char *nicks = sonar_waveform_kind_nicks (", ");
    SET_ERROR (error, "kind is %d; it must be one of %s", (int) p->kind,
        nicks);
    return FALSE;
  }
  if (p->n_emitters < 1 || p->n_emitters > SONAR_MAX_EMITTERS) {
    SET_ERROR (error, "n_emitters is %u; it must be 1 to %u", p->n_emitters,
        SONAR_MAX_EMITTERS);
    return FALSE;
  }
  if (p->length < MIN_LENGTH || p->length > SONAR_MAX_WAVEFORM_LENGTH) {
    SET_ERROR (error, "length is %u samples; it must be %u to %u",
        p->length, MIN_LENGTH, SONAR_MAX_WAVEFORM_LENGTH);
    return FALSE;
  }
  if (!isfinite (p->sample_rate) || !(p->sample_rate > 0.0)) {
    SET_ERROR (error, "sample_rate is %g Hz; it must be finite and > 0",
        p->sample_rate);
    return FALSE;
  }
  if (!isfinite (p->band_low) || !(p->band_low > 0.0)) {
    SET_ERROR (error, "band_low is %g Hz; it must be finite and > 0",
        p->band_low);
    return FALSE;
  }
  if (!(p->band_high > p->band_low) || !(p->band_high <= p->sample_rate / 2)) {
    SET_ERROR (error, "band_high is %g Hz; it must be above band_low "
        "(%g Hz) and at most sample_rate / 2 (%g Hz)", p->band_high,
        p->band_low, p->sample_rate / 2);
    return FALSE;
  }
  band_bins = count_band_bins (p);
  if (band_bins < MIN_BAND_BINS) {
    SET_ERROR (error, "band_low to band_high (%g to %g Hz) holds %u FFT "
        "bins of a %u-sample waveform; at least %u are needed: widen the "
        "band or lengthen the waveform", p->band_low, p->band_high,
        band_bins, p->length, MIN_BAND_BINS);
    return FALSE;
  }
  if (p->kind == SONAR_WAVEFORM_MULTISINE && band_bins < 2 * p->n_emitters) {
    SET_ERROR (error, "multisine: band_low to band_high (%g to %g Hz) holds "
        "%u FFT bins, too few to give each of n_emitters = %u its own "
        "(at least 2 each)", p->band_low, p->band_high, band_bins,
        p->n_emitters);
    return FALSE;
  }
  return TRUE;
}

/* The envelope and spectral shape shared by every kind. */
typedef struct
{
  guint length;
  guint taper_length;
  double rolloff;               /* Hz, width of each band edge */
  float *taper;                 /* taper_length rising raised-cosine values */
  float *band_gain;             /* length / 2 + 1 bins */
} Shape;

static void
shape_init (Shape * shape, const SonarWaveformParams * p)
{
  const guint n_bins = p->length / 2 + 1;
  const guint taper_length = MAX (MIN_TAPER,
      (guint) lround (TAPER_FRACTION * p->length));
  const double rolloff = MIN (ROLLOFF_PER_TAPER * p->sample_rate /
      taper_length, MAX_ROLLOFF_FRACTION * (p->band_high - p->band_low));

  shape->length = p->length;
  shape->taper_length = taper_length;
  shape->rolloff = rolloff;
  shape->taper = g_new (float, taper_length);
  for (guint i = 0; i < taper_length; i++)
    shape->taper[i] = 0.5 - 0.5 * cos (G_PI * (i + 0.5) / taper_length);

  shape->band_gain = g_new (float, n_bins);
  for (guint k = 0; k < n_bins; k++) {
    const double f = k * p->sample_rate / p->length;
    const double inside = MIN (f - p->band_low, p->band_high - f);
    if (inside <= 0.0)
      shape->band_gain[k] = 0.0;
    else if (inside >= rolloff)
      shape->band_gain[k] = 1.0;
    else
      shape->band_gain[k] = 0.5 - 0.5 * cos (G_PI * inside / rolloff);
  }
}

static void
shape_clear (Shape * shape)
{
  g_free (shape->taper);
  g_free (shape->band_gain);
}

static void
apply_taper (const Shape * shape, float *x)
{
  for (guint i = 0; i < shape->taper_length; i++) {
    x[i] *= shape->taper[i];
    x[shape->length - 1 - i] *= shape->taper[i];
  }
}

static void
normalise_peak (float *x, guint length)
{
  float peak = 0.0f;
  for (guint i = 0; i < length; i++)
    peak = MAX (peak, fabsf (x[i]));
  for (guint i = 0; i < length; i++)
    x[i] /= peak;
}

/* Length-point FFT filter through the band gain, in place. The filter is
 * circular, but the gain is smooth, so its impulse response is short and
 * the wrap-around stays inside the tapered ends. */
typedef struct
{
  guint length;
  float *time;
  fftwf_complex *freq;
  fftwf_plan forward, inverse;
} BandFilter;

static void
band_filter_init (BandFilter * filter, guint length)
{
  filter->length = length;
  filter->time = fftwf_alloc_real (length);
  filter->freq = fftwf_alloc_complex (length / 2 + 1);
  sonar_fftw_lock ();
  filter->forward = fftwf_plan_dft_r2c_1d (length, filter->time,
      filter->freq, FFTW_ESTIMATE);
  filter->inverse = fftwf_plan_dft_c2r_1d (length, filter->freq,
      filter->time, FFTW_ESTIMATE);
  sonar_fftw_unlock ();
}

static void
band_filter_clear (BandFilter * filter)
{
  sonar_fftw_lock ();
  fftwf_destroy_plan (filter->forward);
  fftwf_destroy_plan (filter->inverse);
  sonar_fftw_unlock ();
  fftwf_free (filter->time);
  fftwf_free (filter->freq);
}

static void
band_filter_apply (BandFilter * filter, const Shape * shape, float *x)
{
  const guint n_bins = filter->length / 2 + 1;
  const float scale = 1.0f / filter->length;

  memcpy (filter->time, x, filter->length * sizeof (float));
  fftwf_execute (filter->forward);
  for (guint k = 0; k < n_bins; k++) {
    filter->freq[k][0] *= shape->band_gain[k] * scale;
    filter->freq[k][1] *= shape->band_gain[k] * scale;
  }
  fftwf_execute (filter->inverse);
  memcpy (x, filter->time, filter->length * sizeof (float));
}

/* Noise ------------------------------------------------------------------*/

/* Linear (zero-padded) correlations of all emissions, and the gradient of
 * the decorrelation cost with respect to each emission. */
typedef struct
{
  guint n, length, fft_size, n_bins;
  guint main_lobe;              /* lags of the autocorrelation left alone */
  double cross_clip, sidelobe_clip;
  float *padded;
  fftwf_complex **spectra;      /* n of n_bins */
  fftwf_complex **gradients;    /* n of n_bins */
  double *energies;
  double *radial;               /* n: gradient part along the emission */
  fftwf_complex *lags;          /* fft_size: one pair's analytic correlation */
  fftwf_plan forward, inverse, lags_to_time, lags_to_freq;
} Correlator;

typedef struct
{
  double cost;                  /* sum of squared excess, relative */
  double worst_cross;           /* envelope peak / autocorrelation peak */
  double worst_sidelobe;
} CorrelationStats;

static void
correlator_init (Correlator * c, const SonarWaveformParams * p,
    const Shape * shape)
{
  /* Linear correlation of two length-sample signals spans 2 length - 1
   * lags; one more makes the size even. */
  c->n = p->n_emitters;
  c->length = p->length;
  c->fft_size = 2 * p->length;
  c->n_bins = c->fft_size / 2 + 1;
  /* The autocorrelation envelope first falls to zero one over the band's
   * width at half amplitude from its peak. */
  c->main_lobe = (guint) ceil (p->sample_rate /
      (p->band_high - p->band_low - shape->rolloff));
  c->cross_clip = pow (10.0, CROSS_CLIP_DB / 20.0);
  c->sidelobe_clip = pow (10.0, SIDELOBE_CLIP_DB / 20.0);
  c->padded = fftwf_alloc_real (c->fft_size);
  c->spectra = g_new (fftwf_complex *, c->n);
  c->gradients = g_new (fftwf_complex *, c->n);
  for (guint i = 0; i < c->n; i++) {
    c->spectra[i] = fftwf_alloc_complex (c->n_bins);
    c->gradients[i] = fftwf_alloc_complex (c->n_bins);
  }
  c->energies = g_new (double, c->n);
  c->radial = g_new (double, c->n);
  c->lags = fftwf_alloc_complex (c->fft_size);
  sonar_fftw_lock ();
  c->forward = fftwf_plan_dft_r2c_1d (c->fft_size, c->padded, c->spectra[0],
      FFTW_ESTIMATE);
  c->inverse = fftwf_plan_dft_c2r_1d (c->fft_size, c->gradients[0],
      c->padded, FFTW_ESTIMATE);
  c->lags_to_time = fftwf_plan_dft_1d (c->fft_size, c->lags, c->lags,
      FFTW_BACKWARD, FFTW_ESTIMATE);
  c->lags_to_freq = fftwf_plan_dft_1d (c->fft_size, c->lags, c->lags,
      FFTW_FORWARD, FFTW_ESTIMATE);
  sonar_fftw_unlock ();
}

static void
correlator_clear (Correlator * c)
{
  for (guint i = 0; i < c->n; i++) {
    fftwf_free (c->spectra[i]);
    fftwf_free (c->gradients[i]);
  }
  g_free (c->spectra);
  g_free (c->gradients);
  g_free (c->energies);
  g_free (c->radial);
  sonar_fftw_lock ();
  fftwf_destroy_plan (c->forward);
  fftwf_destroy_plan (c->inverse);
  fftwf_destroy_plan (c->lags_to_time);
  fftwf_destroy_plan (c->lags_to_freq);
  sonar_fftw_unlock ();
  fftwf_free (c->padded);
  fftwf_free (c->lags);
}

static void
correlator_set_signal (Correlator * c, guint i, const float *x)
{
  double energy = 0.0;

  for (guint t = 0; t < c->length; t++)
    energy += (double) x[t] * x[t];
  c->energies[i] = energy;
  c->radial[i] = 0.0;
  memcpy (c->padded, x, c->length * sizeof (float));
  memset (c->padded + c->length, 0,
      (c->fft_size - c->length) * sizeof (float));
  fftwf_execute_dft_r2c (c->forward, c->padded, c->spectra[i]);
  memset (c->gradients[i], 0, c->n_bins * sizeof (fftwf_complex));
}

/* Correlates emissions i and j (i == j: the autocorrelation outside its
 * main lobe) and adds to their gradients the part of the cost
 * sum_lag (|r_ij (lag)| - clip)_+^2 they carry. |r_ij| is the envelope (the
 * analytic correlation), so that a peak between samples counts too.
 * Returns the envelope peak relative to the autocorrelation peaks. */
static double
correlator_add_pair (Correlator * c, guint i, guint j, double *cost)
{
  fftwf_complex *xi = c->spectra[i], *xj = c->spectra[j];
  const double norm = sqrt (c->energies[i] * c->energies[j]);
  const double threshold = (i == j ? c->sidelobe_clip : c->cross_clip) * norm;
  const guint skipped = i == j ? c->main_lobe : 0;
  const float scale = 1.0f / c->fft_size;
  double peak = 0.0, excess_energy = 0.0, excess_product = 0.0;

  /* Analytic cross spectrum: positive frequencies only, doubled. The
   * sonar band excludes DC and Nyquist, so they are left out. */
  memset (c->lags, 0, c->fft_size * sizeof (fftwf_complex));
  for (guint k = 1; k < c->fft_size / 2; k++) {
    c->lags[k][0] = 2.0f * scale * (xi[k][0] * xj[k][0] + xi[k][1] * xj[k][1]);
    c->lags[k][1] = 2.0f * scale * (xi[k][1] * xj[k][0] - xi[k][0] * xj[k][1]);
  }
  fftwf_execute (c->lags_to_time);

  /* Index lag mod fft_size holds lag; lag = +-length does not exist. */
  for (guint t = 0; t < c->fft_size; t++) {
    const guint lag = MIN (t, c->fft_size - t);
    const double magnitude = hypot (c->lags[t][0], c->lags[t][1]);
    double excess = 0.0;

    if (lag >= skipped && lag < c->length) {
      peak = MAX (peak, magnitude);
      excess = MAX (magnitude - threshold, 0.0);
    }
    excess_energy += excess * excess;
    excess_product += excess * magnitude;
    c->lags[t][0] *= excess > 0.0 ? excess / magnitude : 0.0;
    c->lags[t][1] *= excess > 0.0 ? excess / magnitude : 0.0;
  }
  *cost += excess_energy / (norm * norm);
  if (excess_energy == 0.0)
    return peak / norm;
  /* The cost is relative to the autocorrelation peaks, so it does not
   * change with the scale of an emission: this part of the gradient
   * cancels the component along the emission itself. */
  c->radial[i] += excess_product / (norm * norm);
  c->radial[j] += excess_product / (norm * norm);

  /* The gradient of the cost with respect to r_ij is the real signal
   * whose positive-frequency spectrum is that of the complex excess. */
  fftwf_execute (c->lags_to_freq);
  for (guint k = 0; k < c->n_bins; k++) {
    const double er = c->lags[k][0] * scale, ei = c->lags[k][1] * scale;
    /* d r_ij / d x_i convolves with x_j, d r_ij / d x_j correlates with
     * x_i. Dividing by the partner's energy makes the step size
     * independent of the signal scale. */
    const double wi = 1.0 / c->energies[j], wj = 1.0 / c->energies[i];
    c->gradients[i][k][0] += wi * (er * xj[k][0] - ei * xj[k][1]);
    c->gradients[i][k][1] += wi * (er * xj[k][1] + ei * xj[k][0]);
    c->gradients[j][k][0] += wj * (er * xi[k][0] + ei * xi[k][1]);
    c->gradients[j][k][1] += wj * (er * xi[k][1] - ei * xi[k][0]);
  }
  return peak / norm;
}

static CorrelationStats
correlator_evaluate (Correlator * c, const float *x)
{
  CorrelationStats stats = { 0.0, 0.0, 0.0 };

  for (guint i = 0; i < c->n; i++)
    correlator_set_signal (c, i, x + (gsize) i * c->length);
  for (guint i = 0; i < c->n; i++) {
    const double sidelobe = correlator_add_pair (c, i, i, &stats.cost);
    stats.worst_sidelobe = MAX (stats.worst_sidelobe, sidelobe);
    for (guint j = i + 1; j < c->n; j++) {
      const double cross = correlator_add_pair (c, i, j, &stats.cost);
      stats.worst_cross = MAX (stats.worst_cross, cross);
    }
  }
  return stats;
}

/* Time-domain gradient of emission i, length samples, into out. */
static void
correlator_get_gradient (Correlator * c, guint i, float *out)
{
  fftwf_complex *gradient = c->gradients[i];
  fftwf_complex *spectrum = c->spectra[i];
  /* The c2r transform is not normalised. */
  const double radial = c->radial[i] / c->fft_size;

  for (guint k = 0; k < c->n_bins; k++) {
    gradient[k][0] -= radial * spectrum[k][0];
    gradient[k][1] -= radial * spectrum[k][1];
  }
  fftwf_execute_dft_c2r (c->inverse, gradient, c->padded);
  memcpy (out, c->padded, c->length * sizeof (float));
}

static void
shape_noise (const Shape * shape, BandFilter * filter, const float *noise,
    float *x)
{
  memcpy (x, noise, shape->length * sizeof (float));
  band_filter_apply (filter, shape, x);
  apply_taper (shape, x);
}

static gboolean
decorrelated (const CorrelationStats * stats)
{
  return stats->worst_cross <= pow (10.0, CROSS_TARGET_DB / 20.0)
      && stats->worst_sidelobe <= pow (10.0, SIDELOBE_TARGET_DB / 20.0);
}

/* Independent band-passed noise sequences of 4000 samples leave only
 * 16-18 dB between the autocorrelation peak and the worst cross-correlation
 * peak of 28 pairs. That peak is the maximum over about a thousand
 * independent lags, so it hardly varies between draws: picking the best of
 * a few draws gains well under 1 dB. Instead the drawn noise is nudged by
 * gradient descent on the parts of the correlation envelopes above
 * CROSS_CLIP_DB (every pair) and SIDELOBE_CLIP_DB (every autocorrelation
 * outside its main lobe), through the same band filter and taper, until
 * they are below the targets. A step that raises the cost is retried at
 * half the size. The changes are small (the excess is a few lags per pair
 * out of thousands), so the result keeps the spectrum and the Gaussian
 * character of the draw; and it is deterministic, like the draw. Short
 * waveforms (small time-bandwidth product) cannot reach the targets; they
 * get as close as the iteration limit allows. */
static void
decorrelate_noise (const SonarWaveformParams * p, const Shape * shape,
    BandFilter * filter, float *noise, float *out, guint max_iterations)
{
  const gsize total = (gsize) p->n_emitters * p->length;
  float *accepted = g_new (float, total);
  float *direction = g_new (float, total);
  double accepted_cost = INFINITY, step = DECORRELATION_STEP;
  CorrelationStats stats;
  Correlator c;

  correlator_init (&c, p, shape);
  stats = correlator_evaluate (&c, out);
  for (guint iteration = 0; !decorrelated (&stats); iteration++) {
    if (stats.cost <= accepted_cost) {
      accepted_cost = stats.cost;
      memcpy (accepted, noise, total * sizeof (float));
      /* The emission is taper (filter (noise)) and both are symmetric,
       * so the gradient reaches the noise through the same two steps. */
      for (guint i = 0; i < p->n_emitters; i++) {
        float *d = direction + (gsize) i * p->length;
        correlator_get_gradient (&c, i, d);
        apply_taper (shape, d);
        band_filter_apply (filter, shape, d);
      }
    } else {
      step /= 2.0;
    }
    if (iteration == max_iterations || step < DECORRELATION_MIN_STEP)
      break;
    for (gsize t = 0; t < total; t++)
      noise[t] = accepted[t] - step * direction[t];
    for (guint i = 0; i < p->n_emitters; i++)
      shape_noise (shape, filter, noise + (gsize) i * p->length,
          out + (gsize) i * p->length);
    stats = correlator_evaluate (&c, out);
  }
  /* Out of iterations: keep the best set seen. */
  if (!decorrelated (&stats) && stats.cost > accepted_cost) {
    for (guint i = 0; i < p->n_emitters; i++)
      shape_noise (shape, filter, accepted + (gsize) i * p->length,
          out + (gsize) i * p->length);
  }
  correlator_clear (&c);
  g_free (direction);
  g_free (accepted);
}

static void
generate_noise (const SonarWaveformParams * p, const Shape * shape,
    float *out)
{
  const guint length = p->length;
  const guint64 work_per_iteration =
      (guint64) p->n_emitters * (p->n_emitters + 1) / 2 * 2 * length;
  const guint max_iterations = MIN (DECORRELATION_MAX_ITERATIONS,
      DECORRELATION_BUDGET / work_per_iteration);
  float *noise = g_new (float, (gsize) p->n_emitters * length);
  BandFilter filter;

  band_filter_init (&filter, length);
  for (guint n = 0; n < p->n_emitters; n++) {
    float *y = noise + (gsize) n * length;
    SonarRng rng;

    sonar_rng_init (&rng, p->seed, n);
    for (guint t = 0; t < length; t++)
      y[t] = sonar_rng_gaussian (&rng);
    shape_noise (shape, &filter, y, out + (gsize) n * length);
  }
  if (max_iterations > 0)
    decorrelate_noise (p, shape, &filter, noise, out, max_iterations);
  band_filter_clear (&filter);
  g_free (noise);
}

/* Chirp ------------------------------------------------------------------*/

/* Hyperbolic FM: f(t) = 1 / (1 / f_start + (1 / f_end - 1 / f_start) t / T),
 * whose period grows linearly with time; its phase is the integral
 * 2 pi ln (1 + b t f_start) / b with b = (1 / f_end - 1 / f_start) / T.
 * Even emitters sweep down (the bat-like eRTIS call), odd ones up, each
 * from a seeded start phase. Chirps sharing a band are far from
 * orthogonal: they are the paper's Doppler-tolerant comparison, not a MIMO
 * set. The sweep starts and ends on the band edges, so about -25 dB of its
 * energy falls outside the band; the taper softens the edges but cannot
 * remove that. */
static void
generate_chirp (const SonarWaveformParams * p, const Shape * shape,
    float *out)
{
  const double duration = p->length / p->sample_rate;

  for (guint n = 0; n < p->n_emitters; n++) {
    const gboolean down = n % 2 == 0;
    const double f_start = down ? p->band_high : p->band_low;
    const double f_end = down ? p->band_low : p->band_high;
    const double b = (1.0 / f_end - 1.0 / f_start) / duration;
    float *x = out + (gsize) n * p->length;
    SonarRng rng;
    double phase0;

    sonar_rng_init (&rng, p->seed, n);
    phase0 = 2.0 * G_PI * sonar_rng_uniform (&rng);
    for (guint i = 0; i < p->length; i++) {
      const double t = i / p->sample_rate;
      x[i] = cos (phase0 + 2.0 * G_PI * log1p (b * t * f_start) / b);
    }
    apply_taper (shape, x);
  }
}

/* Multisine --------------------------------------------------------------*/

/* Sines on the length-point FFT bins of the band, weighted by the band
 * gain, with seeded random phases. Emitter n takes every n_emitters-th
 * in-band bin, so the sets are disjoint: the emissions are orthogonal over
 * the full length (exactly so before the taper, to about -35 dB after).
 * The price is that each emission repeats every length / n_emitters
 * samples, which shows as grating lobes in its autocorrelation. */
static void
generate_multisine (const SonarWaveformParams * p, const Shape * shape,
    float *out)
{
  const guint n_bins = p->length / 2 + 1;
  BandFilter filter;

  band_filter_init (&filter, p->length);
  for (guint n = 0; n < p->n_emitters; n++) {
    float *x = out + (gsize) n * p->length;
    guint in_band = 0;
    SonarRng rng;

    sonar_rng_init (&rng, p->seed, n);
    memset (filter.freq, 0, n_bins * sizeof (fftwf_complex));
    for (guint k = 0; k < n_bins; k++) {
      double phase;

      if (shape->band_gain[k] <= 0.0f)
        continue;
      if (in_band++ % p->n_emitters != n)
        continue;
      phase = 2.0 * G_PI * sonar_rng_uniform (&rng);
      filter.freq[k][0] = shape->band_gain[k] * cos (phase);
      filter.freq[k][1] = shape->band_gain[k] * sin (phase);
    }
    fftwf_execute (filter.inverse);
    memcpy (x, filter.time, p->length * sizeof (float));
    apply_taper (shape, x);
  }
  band_filter_clear (&filter);
}

/* The kinds ---------------------------------------------------------------*/

typedef void (*Generator) (const SonarWaveformParams * params,
    const Shape * shape, float *out);

/* The one table of the kinds, in the enum's order: what names them and
 * what makes them. */
static const struct
{
  SonarWaveformKindInfo info;
  Generator generate;
} kinds[] = {
  {{SONAR_WAVEFORM_NOISE, "noise", "Band-passed pseudo-random Gaussian "
              "noise (PR-AWGN, near-orthogonal)"}, generate_noise},
  {{SONAR_WAVEFORM_HYPERBOLIC_CHIRP, "hyperbolic-chirp", "Hyperbolic FM "
              "chirp (Doppler tolerant)"}, generate_chirp},
  {{SONAR_WAVEFORM_MULTISINE, "multisine", "Multisine, interleaved "
              "frequencies per emitter"}, generate_multisine},
};

const SonarWaveformKindInfo *
sonar_waveform_kinds (guint * n_kinds)
{
  static SonarWaveformKindInfo infos[G_N_ELEMENTS (kinds)];
  static gsize done = 0;

  if (g_once_init_enter (&done)) {
    for (guint i = 0; i < G_N_ELEMENTS (kinds); i++) {
      g_assert ((guint) kinds[i].info.kind == i);
      infos[i] = kinds[i].info;
    }
    g_once_init_leave (&done, 1);
  }
  *n_kinds = G_N_ELEMENTS (kinds);
  return infos;
}

const char *
sonar_waveform_kind_to_string (SonarWaveformKind kind)
{
  if ((guint) kind >= G_N_ELEMENTS (kinds))
    return NULL;
  return kinds[kind].info.nick;
}

gboolean
sonar_waveform_kind_from_string (const char *name, SonarWaveformKind * kind)
{
  g_return_val_if_fail (kind != NULL, FALSE);

  for (guint i = 0; name && i < G_N_ELEMENTS (kinds); i++) {
    if (strcmp (name, kinds[i].info.nick) == 0) {
      *kind = kinds[i].info.kind;
      return TRUE;
    }
  }
  return FALSE;
}

char *
sonar_waveform_kind_nicks (const char *separator)
{
  GString *nicks = g_string_new (NULL);

  for (guint i = 0; i < G_N_ELEMENTS (kinds); i++)
    g_string_append_printf (nicks, "%s%s", i ? separator : "",
        kinds[i].info.nick);
  return g_string_free (nicks, FALSE);
}

gboolean
sonar_waveform_generate (const SonarWaveformParams * params, float *out,
    GError ** error)
{
  Shape shape;

  g_return_val_if_fail (params != NULL, FALSE);
  g_return_val_if_fail (out != NULL, FALSE);
  g_return_val_if_fail (error == NULL || *error == NULL, FALSE);

  if (!validate_params (params, error))
    return FALSE;

  shape_init (&shape, params);
  kinds[params->kind].generate (params, &shape, out);
  shape_clear (&shape);
  for (guint n = 0; n < params->n_emitters; n++)
    normalise_peak (out + (gsize) n * params->length, params->length);
  return TRUE;
}
