/* sonar-steering.c: see sonar-steering.h. */
#include "sonar-steering.h"
#include "sonar-kernels.h"

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

void
sonar_steering_transmit_sum_part (const SonarSteering * s,
    const SonarSplitSpectra * templates, const double *emitter_legs,
    double stretch, guint first_emitter, guint end_emitter, guint first,
    guint n, float *transmit_re, float *transmit_im)
{
  const gsize at = (gsize) first_emitter * s->n_bins + first;
  const double k_first = s->k0 + first * s->dk;
  double phase0[SONAR_MAX_EMITTERS], dphase[SONAR_MAX_EMITTERS];

  g_return_if_fail (first + n <= s->n_bins);
  for (guint e = first_emitter; e < end_emitter; e++) {
    const double path = emitter_legs[e] * stretch;
    phase0[e - first_emitter] = k_first * path;
    dphase[e - first_emitter] = s->dk * path;
  }
  sonar_kernel_steer_sum_split (transmit_re, transmit_im, templates->re + at,
      templates->im + at, s->n_bins, end_emitter - first_emitter, n, phase0,
      dphase, TRUE);
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
