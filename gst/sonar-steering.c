/* sonar-steering.c: see sonar-steering.h. */
#include "sonar-steering.h"
#include "sonar-kernels.h"

#include <complex.h>
#include <math.h>
#include <string.h>

void
sonar_steering_init (SonarSteering * s, const SonarSetup * setup,
    const SonarBand * band)
{
  const double c = setup->speed_of_sound;

  s->geometry = &setup->geometry;
  s->speed_of_sound = c;
  s->n_bins = band->n_bins;
  s->k0 = 2.0 * M_PI * sonar_band_frequency (band, 0) / c;
  s->dk = 2.0 * M_PI * band->sample_rate / band->fft_size / c;
}

void
sonar_steering_legs (const SonarSteering * s, SonarVec3 direction,
    double range, double *mic_legs, double *emitter_legs)
{
  const SonarGeometry *g = s->geometry;
  const SonarVec3 point = sonar_vec3_scale (direction, range);

  for (guint j = 0; mic_legs && j < g->n_microphones; j++)
    mic_legs[j] = sonar_vec3_norm (sonar_vec3_sub (point,
            g->microphones[j])) - range;
  for (guint n = 0; emitter_legs && n < g->n_emitters; n++)
    emitter_legs[n] = sonar_vec3_norm (sonar_vec3_sub (point,
            g->emitters[n])) - range;
}

double
sonar_steering_stretch (const SonarSteering * s, double velocity)
{
  const double c = s->speed_of_sound;

  return (c + velocity) / (c - velocity);
}

void
sonar_steering_receive_sum (const SonarSteering * s,
    const SonarSplitSpectra * mic_spectra, const double *mic_legs,
    float *receive_re, float *receive_im)
{
  const guint n_mics = s->geometry->n_microphones;
  double phase0[SONAR_MAX_MICROPHONES], dphase[SONAR_MAX_MICROPHONES];

  for (guint j = 0; j < n_mics; j++) {
    phase0[j] = s->k0 * mic_legs[j];
    dphase[j] = s->dk * mic_legs[j];
  }
  sonar_kernel_steer_sum_split (receive_re, receive_im, mic_spectra->re,
      mic_spectra->im, s->n_bins, n_mics, s->n_bins, phase0, dphase, FALSE);
}

void
sonar_steering_transmit_sum (const SonarSteering * s,
    const SonarSplitSpectra * templates, const double *emitter_legs,
    double stretch, guint first, guint end, float *transmit_re,
    float *transmit_im)
{
  const gsize at = (gsize) first * s->n_bins;
  double phase0[SONAR_MAX_EMITTERS], dphase[SONAR_MAX_EMITTERS];

  for (guint n = first; n < end; n++) {
    const double path = emitter_legs[n] * stretch;
    phase0[n - first] = s->k0 * path;
    dphase[n - first] = s->dk * path;
  }
  sonar_kernel_steer_sum_split (transmit_re, transmit_im, templates->re + at,
      templates->im + at, s->n_bins, end - first, s->n_bins, phase0, dphase,
      TRUE);
}

void
sonar_steering_receive_sum_part (const SonarSteering * s,
    const SonarSplitSpectra * mic_spectra, const double *mic_legs,
    guint first, guint n, float *receive_re, float *receive_im)
{
  const guint n_mics = s->geometry->n_microphones;
  const double k_first = s->k0 + first * s->dk;
  double phase0[SONAR_MAX_MICROPHONES], dphase[SONAR_MAX_MICROPHONES];

  g_return_if_fail (first + n <= s->n_bins);
  for (guint j = 0; j < n_mics; j++) {
    phase0[j] = k_first * mic_legs[j];
    dphase[j] = s->dk * mic_legs[j];
  }
  sonar_kernel_steer_sum_split (receive_re, receive_im, mic_spectra->re +
      first, mic_spectra->im + first, s->n_bins, n_mics, n, phase0, dphase,
      FALSE);
}

/* The path of an emitter's output at the lag of @range: the two-way
 * range plus the stretched emitter leg (the receive sum already holds the
 * microphone legs). */
static double
emitter_path (double emitter_leg, double stretch, double range)
{
  return 2.0 * range + emitter_leg * stretch;
}

void
sonar_steering_emitter_blocks (const SonarSteering * s,
    const float *receive_re, const float *receive_im,
    const SonarSplitSpectra * templates, guint emitter, double emitter_leg,
    double stretch, double range, guint block, SonarComplex * blocks)
{
  const double path = emitter_path (emitter_leg, stretch, range);
  const gsize at = (gsize) emitter * s->n_bins;

  sonar_kernel_steer_block_sums_conj (blocks, receive_re, receive_im,
      templates->re + at, templates->im + at, s->n_bins, s->k0 * path,
      s->dk * path, block);
}

void
sonar_steering_emitter_blocks8 (const SonarSteering * s,
    const float *receive_re, const float *receive_im,
    const SonarSplitSpectra * templates, guint emitter, double emitter_leg,
    double stretch, double range, SonarComplex * blocks)
{
  const double path = emitter_path (emitter_leg, stretch, range);
  const guint n = SONAR_BLOCK8_PADDED (s->n_bins);

  sonar_kernel_block8_sums_conj (blocks, receive_re, receive_im,
      templates->re + (gsize) emitter * n, templates->im + (gsize) emitter *
      n, n, s->k0 * path, s->dk * path);
}

/* The ramp of sonar_steering_blocks_at (): the phase at each block's
 * centre bin, stepping a block at a time. */
static void
blocks_ramp (const SonarSteering * s, guint block, double offset,
    double *phase0, double *dphase)
{
  const double path = 2.0 * offset;

  *phase0 = (s->k0 + s->dk * 0.5 * (block - 1)) * path;
  *dphase = s->dk * block * path;
}

SonarComplex
sonar_steering_blocks_at (const SonarSteering * s,
    const SonarComplex * blocks, guint block, double offset)
{
  double phase0, dphase;

  blocks_ramp (s, block, offset, &phase0, &dphase);
  return sonar_kernel_steer_sum (blocks, sonar_steering_n_blocks (s, block),
      phase0, dphase);
}

guint
sonar_steering_n_blocks (const SonarSteering * s, guint block)
{
  return (s->n_bins + block - 1) / block;
}

void
sonar_steering_blocks_phasors (const SonarSteering * s, guint block,
    double offset, float *re, float *im)
{
  double phase0, dphase;

  blocks_ramp (s, block, offset, &phase0, &dphase);
  sonar_kernel_steer_phasors (re, im, sonar_steering_n_blocks (s, block),
      phase0, dphase);
}

void
sonar_steering_blocks_sums (const SonarSteering * s,
    const SonarComplex * blocks, guint block, const float *const *re,
    const float *const *im, guint n_tables, SonarComplex * out)
{
  sonar_kernel_steer_sums_phasors (out, blocks, re, im, n_tables,
      sonar_steering_n_blocks (s, block));
}

/* Taps of the interpolation either side of its node, and a bin of slack
 * for the rounding of s k. */
#define TAPS_BEFORE 3
#define TAPS_AFTER 4
/* Windows are whole multiples of the kernels' reseed interval. */
#define WINDOW_QUANTUM 64

struct _SonarScaledTransmit
{
  const SonarSteering *steering;
  guint n_emitters;
  guint first_bin;              /* the band's, on the FFT grid */
  guint n_spectrum;             /* FFT bins 0 .. fft_size / 2 */
  float *spectra_re, *spectra_im;       /* [emitter][bin] */
  double centre;                /* c0: the emissions' centre, m of path */
  double stretch_min, stretch_max;      /* of |v| < c / 4 */
};

SonarScaledTransmit *
sonar_scaled_transmit_new (const SonarSteering * steering,
    const SonarSetup * setup, const SonarBand * band)
{
  SonarScaledTransmit *t = g_new0 (SonarScaledTransmit, 1);
  const double c = setup->speed_of_sound;
  SonarBand whole = *band;
  g_autoptr (SonarSpectrum) analyzer = NULL;
  g_autofree SonarComplex *spectrum = NULL;

  t->steering = steering;
  t->n_emitters = setup->geometry.n_emitters;
  t->first_bin = band->first_bin;
  t->n_spectrum = band->fft_size / 2 + 1;
  t->centre = 0.5 * (setup->waveform_length - 1) * c / setup->sample_rate;
  t->stretch_min = (c - 0.25 * c) / (c + 0.25 * c);
  t->stretch_max = 1.0 / t->stretch_min;
  whole.first_bin = 0;
  whole.n_bins = t->n_spectrum;
  analyzer = sonar_spectrum_new (&whole);
  spectrum = g_new (SonarComplex, t->n_spectrum);
  t->spectra_re = g_new (float, (gsize) t->n_emitters * t->n_spectrum);
  t->spectra_im = g_new (float, (gsize) t->n_emitters * t->n_spectrum);
  for (guint n = 0; n < t->n_emitters; n++) {
    sonar_spectrum_process (analyzer, sonar_setup_waveform (setup, n),
        setup->waveform_length, 1, spectrum, NULL);
    sonar_kernel_split (t->spectra_re + (gsize) n * t->n_spectrum,
        t->spectra_im + (gsize) n * t->n_spectrum, spectrum, t->n_spectrum);
  }
  return t;
}

void
sonar_scaled_transmit_free (SonarScaledTransmit * t)
{
  if (!t)
    return;
  g_free (t->spectra_re);
  g_free (t->spectra_im);
  g_free (t);
}

void
sonar_scaled_transmit_window (const SonarScaledTransmit * t,
    double stretch_max, int *first, guint * n)
{
  const double low = t->first_bin, high = t->first_bin +
      t->steering->n_bins - 1.0;
  const int last = (int) floor (stretch_max * high) + TAPS_AFTER;

  /* The table's phase ramps run from its first bin: fixed (the slowest
   * stretch's), and whole reseed intervals of the kernels, so that a
   * bin's value does not depend on the other hypotheses of the call (the
   * same image bit for bit in every mode). */
  *first = (int) floor (t->stretch_min * low) - TAPS_BEFORE;
  *n = (guint) (last - *first + 1);
  *n = (*n + WINDOW_QUANTUM - 1) / WINDOW_QUANTUM * WINDOW_QUANTUM;
}

guint
sonar_scaled_transmit_max_window (const SonarScaledTransmit * t)
{
  int first;
  guint n;

  sonar_scaled_transmit_window (t, t->stretch_max, &first, &n);
  return n;
}

void
sonar_scaled_transmit_table (const SonarScaledTransmit * t,
    const double *emitter_legs, guint first_emitter, guint end_emitter,
    int first, guint n, float *v_re, float *v_im)
{
  const SonarSteering *s = t->steering;
  /* The bins of the window the spectra hold; zeros outside. */
  const int lo = MAX (first, 0);
  const int hi = MIN (first + (int) n, (int) t->n_spectrum);
  double phase0[SONAR_MAX_EMITTERS], dphase[SONAR_MAX_EMITTERS];

  if (hi <= lo) {
    memset (v_re, 0, sizeof (float) * n);
    memset (v_im, 0, sizeof (float) * n);
    return;
  }
  for (guint e = first_emitter; e < end_emitter; e++) {
    const double path = emitter_legs[e] - t->centre;
    phase0[e - first_emitter] = lo * s->dk * path;
    dphase[e - first_emitter] = s->dk * path;
  }
  memset (v_re, 0, sizeof (float) * (lo - first));
  memset (v_im, 0, sizeof (float) * (lo - first));
  sonar_kernel_steer_sum_split (v_re + (lo - first), v_im + (lo - first),
      t->spectra_re + (gsize) first_emitter * t->n_spectrum + lo,
      t->spectra_im + (gsize) first_emitter * t->n_spectrum + lo,
      t->n_spectrum, end_emitter - first_emitter, hi - lo, phase0, dphase,
      TRUE);
  memset (v_re + (hi - first), 0, sizeof (float) * (first + (int) n - hi));
  memset (v_im + (hi - first), 0, sizeof (float) * (first + (int) n - hi));
}

void
sonar_scaled_transmit_product (const SonarScaledTransmit * t,
    const float *v_re, const float *v_im, int window_first, double stretch,
    const float *receive_re, const float *receive_im, guint first, guint n,
    SonarComplex * out)
{
  const SonarSteering *s = t->steering;
  /* Band bin first + b is FFT bin first_bin + first + b; read at
   * stretch times that, in the window's coordinates. */
  const double x0 = stretch * (t->first_bin + first) - window_first;
  /* exp(i s kappa c0): the centre's ramp put back, at the scaled
   * frequency. */
  const double k_first = s->k0 + first * s->dk;

  sonar_kernel_scaled_product (out, receive_re, receive_im, v_re, v_im, n,
      x0, stretch, stretch * k_first * t->centre,
      stretch * s->dk * t->centre, (float) sqrt (stretch));
}

/* Bins of the band the beam is summed over, at most: it changes little
 * from bin to bin. */
#define BEAM_BINS 256
/* Lags searched for the envelope's peak, over +-BEAM_REACH of the band's
 * range resolution (a few millimetres of path). */
#define BEAM_LAGS 41
#define BEAM_REACH 0.5
/* A range far enough for plane waves, m. */
#define BEAM_FAR 1e4

/* The MIMO envelope of a still far point at boresight, delayed and summed
 * for the direction @look: the emitters' echoes, each weighted by its
 * power spectrum, and the microphones' phasors of the legs' differences
 * between @look and boresight, summed over the band at the lag where that
 * is largest. */
static double
beam_envelope (const SonarScaledTransmit * t, SonarVec3 look)
{
  const SonarSteering *s = t->steering;
  const SonarGeometry *g = s->geometry;
  const guint stride = MAX (1u, s->n_bins / BEAM_BINS);
  const guint n = (s->n_bins + stride - 1) / stride;
  const double reach = BEAM_REACH * 2.0 * G_PI / (s->dk * s->n_bins);
  double mic_look[SONAR_MAX_MICROPHONES], mic_zero[SONAR_MAX_MICROPHONES];
  double em_look[SONAR_MAX_EMITTERS], em_zero[SONAR_MAX_EMITTERS];
  g_autofree double complex *beam = g_new (double complex, n);
  double best = 0.0;

  sonar_steering_legs (s, look, BEAM_FAR, mic_look, em_look);
  sonar_steering_legs (s, sonar_vec3 (0.0, 0.0, 1.0), BEAM_FAR, mic_zero,
      em_zero);
  for (guint b = 0; b < n; b++) {
    const guint bin = t->first_bin + b * stride;
    const double kappa = s->k0 + (double) b * stride * s->dk;
    double complex e = 0.0, m = 0.0;
    for (guint i = 0; i < t->n_emitters; i++) {
      const float re = t->spectra_re[(gsize) i * t->n_spectrum + bin];
      const float im = t->spectra_im[(gsize) i * t->n_spectrum + bin];
      e += (re * re + im * im) * cexp (I * kappa * (em_look[i] -
              em_zero[i]));
    }
    for (guint j = 0; j < g->n_microphones; j++)
      m += cexp (I * kappa * (mic_look[j] - mic_zero[j]));
    beam[b] = e * m;
  }
  for (guint l = 0; l < BEAM_LAGS; l++) {
    const double lag = reach * (2.0 * l / (BEAM_LAGS - 1) - 1.0);
    double complex sum = 0.0;
    for (guint b = 0; b < n; b++)
      sum += beam[b] * cexp (-I * (s->k0 + (double) b * stride * s->dk) *
          lag);
    best = MAX (best, cabs (sum));
  }
  return best;
}

static double
loss_below (const SonarScaledTransmit * t, double peak, double azimuth_step,
    double elevation_step)
{
  const double off = beam_envelope (t, sonar_vec3_from_direction (0.5 *
          MAX (azimuth_step, 0.0), 0.5 * MAX (elevation_step, 0.0)));

  return peak > 0.0 && off > 0.0 ? 20.0 * log10 (peak / off) : 0.0;
}

double
sonar_scaled_transmit_sampling_loss (const SonarScaledTransmit * t,
    double azimuth_step, double elevation_step)
{
  return loss_below (t, beam_envelope (t, sonar_vec3 (0.0, 0.0, 1.0)),
      azimuth_step, elevation_step);
}

double
sonar_scaled_transmit_step_factor (const SonarScaledTransmit * t,
    double azimuth_step, double elevation_step, double loss_db)
{
  const double peak = beam_envelope (t, sonar_vec3 (0.0, 0.0, 1.0));
  double lo = 0.0, hi = 1.0;

  if (loss_below (t, peak, azimuth_step, elevation_step) <= loss_db)
    return 1.0;
  /* Within the main lobe, where grids are set, the loss grows with the
   * step: bisection, to a millionth. */
  for (int k = 0; k < 20; k++) {
    const double f = 0.5 * (lo + hi);
    if (loss_below (t, peak, f * azimuth_step, f * elevation_step) <=
        loss_db)
      lo = f;
    else
      hi = f;
  }
  return lo;
}

double
sonar_scaled_transmit_lobe_width (const SonarScaledTransmit * t,
    gboolean elevation, double at_most)
{
  return at_most * sonar_scaled_transmit_step_factor (t, elevation ? 0.0 :
      at_most, elevation ? at_most : 0.0, 6.0);
}
