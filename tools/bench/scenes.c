/* sonar-bench's scenes: the fig10, fig9 and crossing presets and seeded random
 * scenes, their pings rendered once, before anything is timed; the
 * sensor; the Doppler banks, made once per velocity grid and shared by
 * the configurations.
 *
 * The sensor is sonarsrc's default (sonar_setup_new_default ()). */
#include <complex.h>
#include <math.h>

#include "bench.h"
#include "sonar-interp.h"
#include "sonar-rng.h"
#include "sonar-waveform.h"

/* The random scenes: point reflectors at 0.5-4.5 m, -60..60 degrees, radial
 * velocities -0.4..0.4 m/s, far enough apart to be objects of their own
 * (seed RANDOM_SCENE_SEED). */
#define RANDOM_RANGE_MIN 0.5
#define RANDOM_RANGE_MAX 4.5
#define RANDOM_AZIMUTH 60.0
#define RANDOM_SPEED 0.4
#define RANDOM_SEPARATION 0.25

BenchScene scenes[N_SCENES] = {
  {"fig10", SONAR_SCENE_PRESET_FIG10, 0, -0.4, 0.4, 0.02, 9},
  {"fig9", SONAR_SCENE_PRESET_FIG9, 0, -7.0, 7.0, 0.05, 5},
  /* sonartrack's test: its bank and 30 pings (tests/test-sonartrack.c),
   * the walkers crossing at ping 15. */
  {"crossing", SONAR_SCENE_PRESET_CROSSING, 0, -1.5, 1.5, 0.02, 30},
  {"empty", SONAR_SCENE_PRESET_EMPTY, 0, -0.4, 0.4, 0.02, 2},
  {"rand1", SONAR_SCENE_PRESET_EMPTY, 1, -0.4, 0.4, 0.02, 2},
  {"rand5", SONAR_SCENE_PRESET_EMPTY, 5, -0.4, 0.4, 0.02, 2},
  {"rand20", SONAR_SCENE_PRESET_EMPTY, 20, -0.4, 0.4, 0.02, 2},
  {"rand50", SONAR_SCENE_PRESET_EMPTY, 50, -0.4, 0.4, 0.02, 2},
};

/* @n seeded point reflectors in the y = 0 plane, moving radially. */
void
random_scene_init (SonarScene * scene, guint n)
{
  SonarRng rng;

  sonar_scene_init_preset (scene, SONAR_SCENE_PRESET_EMPTY);
  sonar_rng_init (&rng, RANDOM_SCENE_SEED, n);
  scene->reflectors = g_new0 (SonarReflector, n);
  while (scene->n_reflectors < n) {
    SonarReflector *r = &scene->reflectors[scene->n_reflectors];
    const double range = RANDOM_RANGE_MIN + (RANDOM_RANGE_MAX -
        RANDOM_RANGE_MIN) * sonar_rng_uniform (&rng);
    const double azimuth = RANDOM_AZIMUTH * (2.0 * sonar_rng_uniform (&rng)
        - 1.0);
    const double speed = RANDOM_SPEED * (2.0 * sonar_rng_uniform (&rng) -
        1.0);
    const SonarVec3 direction = sonar_vec3_from_direction (azimuth, 0.0);
    gboolean apart = TRUE;

    r->kind = SONAR_REFLECTOR_POINT;
    r->position = sonar_vec3_scale (direction, range);
    r->velocity = sonar_vec3_scale (direction, speed);
    r->strength = 1.0;
    for (guint k = 0; k < scene->n_reflectors && apart; k++)
      apart = sonar_vec3_norm (sonar_vec3_sub (r->position,
              scene->reflectors[k].position)) >= RANDOM_SEPARATION;
    scene->n_reflectors += apart;
  }
}

void
interleave (const float *planar, guint n_mics, gsize length, float *out)
{
  for (guint j = 0; j < n_mics; j++)
    for (gsize i = 0; i < length; i++)
      out[i * n_mics + j] = planar[j * length + i];
}

void
render_alone (Chain * ch, SonarSimulator * quiet, const SonarSetup * setup,
    const SonarScene * scene, const SonarReflector * object)
{
  const guint n_mics = setup->geometry.n_microphones;
  const gsize length = setup->ping_length;
  g_autofree float *planar = g_new (float, length * n_mics);
  g_autofree float *samples = g_new (float, length * n_mics);
  SonarScene one;

  if (scene)
    one = *scene;
  else
    sonar_scene_init_preset (&one, SONAR_SCENE_PRESET_EMPTY);
  one.reflectors = (SonarReflector *) object;
  one.n_reflectors = 1;
  sonar_simulator_render (quiet, &one, 0, 0.0, planar, NULL);
  if (!scene) {
    one.reflectors = NULL;
    one.n_reflectors = 0;
    sonar_scene_clear (&one);
  }
  interleave (planar, n_mics, length, samples);
  chain_spectra (ch, samples, length);
}

float *
direct_path_ping (SonarSetup * setup, double coupling, GError ** error)
{
  const guint n_mics = setup->geometry.n_microphones;
  const gsize length = setup->ping_length;
  SonarSimulatorParams params;
  SonarScene empty;
  g_autoptr (SonarSimulator) sim = NULL;
  g_autofree float *planar = NULL;
  float *ping;

  sonar_simulator_params_init_default (&params);
  params.noise_amplitude = 0.0;
  params.direct_path = coupling;
  sim = sonar_simulator_new (setup, &params, error);
  if (!sim)
    return NULL;
  planar = g_new (float, length * n_mics);
  ping = g_new (float, length * n_mics);
  sonar_scene_init_preset (&empty, SONAR_SCENE_PRESET_EMPTY);
  sonar_simulator_render (sim, &empty, 0, 0.0, planar, NULL);
  sonar_scene_clear (&empty);
  interleave (planar, n_mics, length, ping);
  return ping;
}

SonarSimulator *
bench_simulator_new (SonarSetup * setup, double noise_amplitude,
    GError ** error)
{
  SonarSimulatorParams params;

  sonar_simulator_params_init_default (&params);
  params.noise_amplitude = noise_amplitude;
  params.seed = NOISE_SEED;
  return sonar_simulator_new (setup, &params, error);
}

/* Renders the scene's pings as sonarsrc emits them (interleaved, ping p
 * at p / ping-rate s), with their truth. */
gboolean
render_scene (BenchScene * s, SonarSetup * setup, GError ** error)
{
  const guint n_mics = setup->geometry.n_microphones;
  const gsize length = setup->ping_length;
  g_autoptr (SonarSimulator) sim = NULL;
  g_autofree float *planar = NULL;
  SonarScene scene;

  sim = bench_simulator_new (setup, NOISE_AMPLITUDE, error);
  if (!sim)
    return FALSE;
  if (s->n_random)
    random_scene_init (&scene, s->n_random);
  else
    sonar_scene_init_preset (&scene, s->preset);
  s->n_reflectors = scene.n_reflectors;
  s->pings = g_new (float, s->n_pings * length * n_mics);
  s->truths = g_new (SonarTruth, MAX (s->n_pings * s->n_reflectors, 1));
  planar = g_new (float, length * n_mics);
  for (guint p = 0; p < s->n_pings; p++) {
    float *out = s->pings + p * length * n_mics;

    sonar_simulator_render (sim, &scene, p, p / PING_RATE, planar,
        s->truths + p * s->n_reflectors);
    interleave (planar, n_mics, length, out);
  }
  sonar_scene_clear (&scene);
  return TRUE;
}

/* The bank's templates of emitter 0 at its first, middle and last velocity
 * against exact ones: the emission's band-limited continuation as
 * sonar-interp.h defines it (the zero-extended signal's periodic
 * interpolation), summed as a Fourier series in double precision. Returns
 * the rms error over the templates' rms, dB. */
static double
template_error_db (SonarDopplerBank * bank)
{
  const SonarSetup *setup = sonar_doppler_bank_get_setup (bank);
  const float *emission = sonar_setup_waveform (setup, 0);
  const guint length = setup->waveform_length;
  const guint n = sonar_fft_good_size (length + 2 * SONAR_INTERP_PAD);
  /* No Nyquist term: the emission is band-limited far below it. */
  const guint n_bins = (n + 1) / 2;
  const guint nv = sonar_doppler_bank_n_velocities (bank);
  const guint indices[] = { 0, nv / 2, nv - 1 };
  g_autofree double complex *spectrum = g_new (double complex, n_bins);
  double error2 = 0.0, exact2 = 0.0;

  for (guint k = 0; k < n_bins; k++) {
    const double complex step = cexp (-2.0 * G_PI * I * k / n);
    double complex w = cexp (-2.0 * G_PI * I * k * SONAR_INTERP_PAD / n);
    double complex sum = 0.0;

    for (guint m = 0; m < length; m++, w *= step)
      sum += emission[m] * w;
    spectrum[k] = sum;
  }
  for (guint i = 0; i < G_N_ELEMENTS (indices); i++) {
    const double alpha = sonar_doppler_scale (setup->speed_of_sound,
        sonar_doppler_bank_velocity (bank, indices[i]));
    guint t_length;
    const float *t = sonar_doppler_bank_template (bank, 0, indices[i],
        &t_length);

    for (guint j = 0; j < t_length; j++) {
      const double complex step = cexp (2.0 * G_PI * I * (alpha * j +
              SONAR_INTERP_PAD) / n);
      double complex w = step;
      double sum = creal (spectrum[0]), exact;

      for (guint k = 1; k < n_bins; k++, w *= step)
        sum += 2.0 * creal (spectrum[k] * w);
      exact = sqrt (alpha) * sum / n;
      error2 += (t[j] - exact) * (t[j] - exact);
      exact2 += exact * exact;
    }
  }
  return 10.0 * log10 (error2 / exact2);
}

const char *const template_interp_names[] = {
  [SONAR_TEMPLATE_BAND_LIMITED] = "hermite4x",
  [SONAR_TEMPLATE_LINEAR] = "linear",
  [SONAR_TEMPLATE_NEAREST] = "nearest",
};

void
bank_entry_free (gpointer data)
{
  BankEntry *e = data;

  sonar_doppler_bank_unref (e->bank);
  g_free (e);
}

/* Banks are set-up work: made once per sensor set-up and velocity grid
 * and shared (the detection sweep's longer pings need a bank of their
 * own: its band has another FFT size). */
BankEntry *
get_bank (Bench * b, const Config * c, GError ** error)
{
  g_autofree char *key = g_strdup_printf ("%p/%u/%.17g/%.17g/%.17g/%d",
      (void *) b->setup, b->setup->ping_length, c->v_min, c->v_max,
      c->v_step, c->template_interp);
  BankEntry *e = g_hash_table_lookup (b->banks, key);
  const SonarBand *band;
  double start, heap;

  if (e)
    return e;
  start = now_ms ();
  heap = heap_mb ();
  e = g_new0 (BankEntry, 1);
  e->bank = sonar_doppler_bank_new_with_interp (b->setup, c->v_min,
      c->v_max, c->v_step, c->template_interp, error);
  if (!e->bank) {
    g_free (e);
    return NULL;
  }
  sonar_doppler_bank_prepare_ping_band (e->bank);
  e->mb = heap_mb () - heap;
  e->template_error_db = template_error_db (e->bank);
  band = sonar_doppler_bank_band (e->bank);
  g_printerr ("bank %g..%g / %g m/s, %s templates (%.1f dB): %u "
      "velocities, FFT %u, %u bins, %.1f MB, made in %.1f s\n", c->v_min,
      c->v_max, c->v_step, template_interp_names[c->template_interp],
      e->template_error_db, sonar_doppler_bank_n_velocities (e->bank),
      band->fft_size, band->n_bins, e->mb, (now_ms () - start) * 1e-3);
  g_hash_table_insert (b->banks, g_steal_pointer (&key), e);
  return e;
}
