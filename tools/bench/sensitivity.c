/* sonar-bench's sensitivity sweeps: noise, detection and split.
 *
 * Pings rendered one at a time (a thousand pings would not fit in memory),
 * at the elements' defaults: the -7..7 m/s bank at 0.05 m/s and its 47
 * detection hypotheses.
 *
 * noise: sonarsrc scene=empty. (1) The false-alarm model: per range bin,
 * every pixel over the bin's lower quartile over the directions, as
 * wardcluster's noise-floor test sees it; the share of pixels above the
 * factor sonar_cluster_floor_gain () gives for a design pfa, against
 * that pfa, on the dense image (coarse-spacing=0: every pixel a true
 * envelope) and on the defaults' (coarse to fine: pixels far below the
 * maximum are interpolated, which narrows their spread). The effective
 * number of independent hypotheses K_eff is the one whose factor makes
 * the dense image's measured exceedance equal the design pfa (bisection),
 * at 1e-3 and 1e-4, where thousands of pixels exceed. (2) False objects:
 * the whole chain's valid detections on every ping.
 *
 * detection: one point reflector per ping, strength set for a per-channel
 * SNR (below), at 2, 5 and 8 m (+-5 cm), a random azimuth in -60..60
 * degrees and radial velocity in -1..1 m/s, noise seed = ping; found when
 * a valid detection lies within MATCH_DISTANCE. Per-channel SNR: the
 * echo's mean power at a microphone while it lasts, over the noise power
 * per sample: (strength / (2 r)^2)^2 x sum over the emitters of the mean
 * square of their emissions, over noise-amplitude^2 (every sample, the
 * whole 0-225 kHz band). The sensor records to 8.5 m for it. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "bench.h"
#include "sonar-rng.h"
#include "sonar-uncertainty.h"

#define NOISE_PINGS 1000
#define NOISE_DENSE_PINGS 100
#define DETECTION_PINGS 20
#define GOAL_PINGS 50
#define GOAL_RANGE 7.0
#define GOAL_SNR_DB -28.0
#define SENSITIVITY_MAX_RANGE 8.5
#define SENSITIVITY_AZIMUTH 60.0
#define SENSITIVITY_SPEED 1.0
#define SENSITIVITY_RANGE_JITTER 0.05
/* Exceedance histogram of 20 log10 (pixel / quartile): dB. */
#define RATIO_DB_MIN -60.0
#define RATIO_DB_STEP 0.01
#define RATIO_BINS 10000

guint noise_pings = NOISE_PINGS;
guint detection_pings = DETECTION_PINGS;

static const double design_pfas[] = { 1e-2, 1e-3, 1e-4, 1e-5, 1e-6, 1e-7 };
static const double detection_snrs_db[] =
    { -35, -33, -31, -29, -28, -27, -25, -20, -15 };
static const double detection_ranges[] = { 2.0, 5.0, 8.0 };

typedef struct
{
  guint64 counts[RATIO_BINS];   /* [bin of 20 log10 (v / q)] */
  guint64 above;                /* beyond the last bin */
  guint64 total;
} RatioHistogram;

static int
compare_floats (const void *a, const void *b)
{
  const float x = *(const float *) a, y = *(const float *) b;

  return (x > y) - (x < y);
}

/* Every finite pixel of @image over its range bin's lower quartile over
 * the directions (the quartile as wardcluster takes it: element n / 4 of
 * the sorted column). */
static void
histogram_add_image (RatioHistogram * h, const float *image,
    const SonarImageGrid * g, float *column)
{
  const gsize n_dirs = (gsize) g->n_azimuth * g->n_elevation;

  for (guint i = 0; i < g->n_range; i++) {
    gsize n = 0;
    float q;

    for (gsize d = 0; d < n_dirs; d++)
      if (isfinite (image[d * g->n_range + i]))
        column[n++] = image[d * g->n_range + i];
    if (n < 4)
      continue;
    qsort (column, n, sizeof (float), compare_floats);
    q = column[n / 4];
    if (!(q > 0.0f))
      continue;
    for (gsize k = 0; k < n; k++) {
      const double db = 20.0 * log10 (column[k] / q);
      const double bin = floor ((db - RATIO_DB_MIN) / RATIO_DB_STEP);

      h->total++;
      if (bin >= RATIO_BINS)
        h->above++;
      else if (bin >= 0)
        h->counts[(gsize) bin]++;
    }
  }
}

/* Share of the pixels above @gain (amplitude) times their quartile. */
static double
histogram_exceedance (const RatioHistogram * h, double gain)
{
  const double db = 20.0 * log10 (gain);
  const double first = ceil ((db - RATIO_DB_MIN) / RATIO_DB_STEP);
  guint64 n = h->above;

  for (gsize k = (gsize) MAX (first, 0.0); k < RATIO_BINS; k++)
    n += h->counts[k];
  return h->total ? (double) n / h->total : NAN;
}

/* K_eff for which the measured exceedance at the design @pfa's factor is
 * @pfa (bisection between 1 and @k_max). */
static double
fit_effective_hypotheses (const RatioHistogram * h, double pfa, double k_max)
{
  double lo = 1.0, hi = k_max;

  if (histogram_exceedance (h, sonar_cluster_floor_gain (pfa, lo)) > pfa)
    return lo;
  if (histogram_exceedance (h, sonar_cluster_floor_gain (pfa, hi)) < pfa)
    return hi;
  for (int it = 0; it < 40; it++) {
    const double mid = 0.5 * (lo + hi);
    if (histogram_exceedance (h, sonar_cluster_floor_gain (pfa, mid)) < pfa)
      lo = mid;
    else
      hi = mid;
  }
  return 0.5 * (lo + hi);
}

gboolean
run_noise (Bench * b)
{
  const guint n_mics = b->setup->geometry.n_microphones;
  const gsize length = b->setup->ping_length;
  const guint n_dense = MIN (noise_pings, NOISE_DENSE_PINGS);
  g_autoptr (GError) error = NULL;
  g_autoptr (SonarSimulator) sim = NULL;
  g_autofree Chain *dense = g_new0 (Chain, 1);
  g_autofree Chain *chain = g_new0 (Chain, 1);
  g_autofree RatioHistogram *h_dense = g_new0 (RatioHistogram, 1);
  g_autofree RatioHistogram *h_chain = g_new0 (RatioHistogram, 1);
  g_autofree float *planar = g_new (float, length * n_mics);
  g_autofree float *samples = g_new (float, length * n_mics);
  g_autofree float *column = NULL;
  g_autofree double *times = g_new (double, MAX (noise_pings, 1));
  Result r_dense = { 0 }, r_chain = { 0 };
  Config c_dense, c_chain;
  SonarScene scene;
  guint centroids = 0, false_objects = 0, pings_with_false = 0;
  guint max_centroids = 0;
  double k, k_eff;

  config_init (&c_chain, &scenes[SCENE_FIG9]);
  c_dense = c_chain;
  c_dense.imager.coarse_spacing = 0.0;
  sim = bench_simulator_new (b->setup, NOISE_AMPLITUDE, &error);
  if (!sim || !chain_init (dense, b, &c_dense, &r_dense, &error)
      || !chain_init (chain, b, &c_chain, &r_chain, &error)) {
    g_printerr ("noise: %s\n", error->message);
    return FALSE;
  }
  column = g_new (float, (gsize) chain->grid->n_azimuth *
      chain->grid->n_elevation);
  sonar_scene_init_preset (&scene, SONAR_SCENE_PRESET_EMPTY);
  g_printerr ("noise: %u noise-only pings (%u dense)\n", noise_pings,
      n_dense);
  for (guint p = 0; p < noise_pings; p++) {
    double start;
    guint n;

    sonar_simulator_render (sim, &scene, p, p / PING_RATE, planar, NULL);
    interleave (planar, n_mics, length, samples);
    if (p < n_dense) {
      chain_spectra (dense, samples, length);
      chain_imaging (dense);
      histogram_add_image (h_dense, dense->image, dense->grid, column);
    }
    start = now_ms ();
    n = chain_run_ping (chain, samples, n_mics, length);
    times[p] = now_ms () - start;
    histogram_add_image (h_chain, chain->image, chain->grid, column);
    centroids += n;
    max_centroids = MAX (max_centroids, n);

    false_objects += chain->n_detections;
    pings_with_false += chain->n_detections > 0;
    for (guint d = 0; d < chain->n_detections; d++)
      g_printerr ("noise: ping %u: false object at %.3f m, %+.4f m/s\n", p,
          sonar_vec3_norm (chain->positions[d]), chain->velocities[d]);
  }
  k = chain->n_templates;
  k_eff = sonar_cluster_effective_hypotheses (chain->n_templates);
  g_print ("\nnoise (sonarsrc scene=empty, bank -7..7 / 0.05 m/s, %g "
      "detection hypotheses; %u pings, the first %u also imaged dense; "
      "%.3g pixels per ping)\n", k, noise_pings, n_dense,
      (double) h_chain->total / MAX (noise_pings, 1));
  g_print ("K_eff used %.1f (share %.2f of each further hypothesis); "
      "fitted on the dense images: %.1f at 1e-3, %.1f at 1e-4\n", k_eff,
      SONAR_CLUSTER_HYPOTHESIS_SHARE, fit_effective_hypotheses (h_dense,
          1e-3, k), fit_effective_hypotheses (h_dense, 1e-4, k));
  g_print ("%10s %12s %12s %12s %14s %14s\n", "design pfa", "factor dB",
      "K=1 dB", "K=47 iid dB", "dense measured", "chain measured");
  for (guint i = 0; i < G_N_ELEMENTS (design_pfas); i++) {
    const double pfa = design_pfas[i];
    const double gain = sonar_cluster_floor_gain (pfa, k_eff);
    g_print ("%10.0e %12.2f %12.2f %12.2f %14.3g %14.3g\n", pfa,
        20.0 * log10 (gain), 20.0 * log10 (sonar_cluster_floor_gain (pfa,
                1.0)), 20.0 * log10 (sonar_cluster_floor_gain (pfa, k)),
        histogram_exceedance (h_dense, gain),
        histogram_exceedance (h_chain, gain));
  }
  g_print ("whole chain at the defaults: %.2f centroids per ping (at most "
      "%u), %u false objects on %u pings (%u pings with any); %.1f ms per "
      "ping (median)\n", (double) centroids / MAX (noise_pings, 1),
      max_centroids, false_objects, noise_pings, pings_with_false,
      median (times, noise_pings));
  if (b->csv)
    write_sensitivity_row (b->csv, "noise", "false-objects", "empty",
        noise_pings, 0, 0, false_objects, NAN, NAN);
  sonar_scene_clear (&scene);
  chain_clear (dense);
  chain_clear (chain);
  return TRUE;
}

/* Sum over the emitters of the mean square of their emissions. */
static double
emission_power (const SonarSetup * setup)
{
  double sum = 0.0;

  for (gsize i = 0; i < (gsize) setup->geometry.n_emitters *
      setup->waveform_length; i++)
    sum += (double) setup->waveforms[i] * setup->waveforms[i];
  return sum / setup->waveform_length;
}

/* Detections of one point reflector over @n_pings pings (seeds from
 * @seed): *found, *false_objects, *sum_error and *max_error (m/s). */
static void
detect_reflector (Chain * ch, SonarSimulator * sim, const SonarSetup * setup,
    double range, double snr_db, guint n_pings, guint64 seed, guint * found,
    guint * false_objects, double *sum_error, double *max_error,
    double *times)
{
  const guint n_mics = setup->geometry.n_microphones;
  const gsize length = setup->ping_length;
  g_autofree float *planar = g_new (float, length * n_mics);
  g_autofree float *samples = g_new (float, length * n_mics);
  /* SNR = (s / (2 r)^2)^2 P_emitted / noise^2, solved for s. */
  const double strength = NOISE_AMPLITUDE * pow (10.0, snr_db / 20.0) *
      4.0 * range * range / sqrt (emission_power (setup));
  SonarReflector reflector = { 0 };
  SonarScene scene;
  SonarRng rng;

  sonar_scene_init_preset (&scene, SONAR_SCENE_PRESET_EMPTY);
  scene.reflectors = &reflector;
  scene.n_reflectors = 1;
  *found = *false_objects = 0;
  *sum_error = *max_error = 0.0;
  for (guint p = 0; p < n_pings; p++) {
    const guint64 ping = seed + p;
    SonarTruth truth;
    double azimuth, speed, r, start;
    SonarVec3 u;
    gboolean hit = FALSE;

    sonar_rng_init (&rng, RANDOM_SCENE_SEED, ping);
    azimuth = SENSITIVITY_AZIMUTH * (2.0 * sonar_rng_uniform (&rng) - 1.0);
    speed = SENSITIVITY_SPEED * (2.0 * sonar_rng_uniform (&rng) - 1.0);
    r = range + SENSITIVITY_RANGE_JITTER * (2.0 * sonar_rng_uniform (&rng)
        - 1.0);
    u = sonar_vec3_from_direction (azimuth, 0.0);
    reflector.kind = SONAR_REFLECTOR_POINT;
    reflector.position = sonar_vec3_scale (u, r);
    reflector.velocity = sonar_vec3_scale (u, speed);
    reflector.strength = strength;
    sonar_simulator_render (sim, &scene, ping, 0.0, planar, &truth);
    interleave (planar, n_mics, length, samples);
    start = now_ms ();
    chain_run_ping (ch, samples, n_mics, length);
    if (times)
      times[p] = now_ms () - start;
    for (guint d = 0; d < ch->n_detections; d++) {
      if (!hit && sonar_vec3_norm (sonar_vec3_sub (ch->positions[d],
                  truth.position)) < MATCH_DISTANCE) {
        const double err = fabs (ch->velocities[d] - truth.radial_velocity);
        hit = TRUE;
        *sum_error += err;
        *max_error = MAX (*max_error, err);
      } else {
        (*false_objects)++;
        g_printerr ("detection: ping %" G_GUINT64_FORMAT ": false object at "
            "%.3f m, %+.4f m/s (the object: %.3f m, %+.1f deg)\n", ping,
            sonar_vec3_norm (ch->positions[d]), ch->velocities[d],
            truth.range, truth.azimuth);
      }
    }
    *found += hit;
  }
  scene.reflectors = NULL;
  scene.n_reflectors = 0;
  sonar_scene_clear (&scene);
}

gboolean
run_detection (Bench * b)
{
  g_autoptr (GError) error = NULL;
  g_autoptr (SonarSetup) setup = sonar_setup_new_default (SENSITIVITY_MAX_RANGE, &error);
  g_autoptr (SonarSimulator) sim = NULL;
  g_autofree Chain *ch = g_new0 (Chain, 1);
  g_autofree double *times = g_new (double, MAX (GOAL_PINGS, 1));
  SonarSetup *saved = b->setup;
  Result r = { 0 };
  Config c;
  guint found, false_objects, total_false = 0;
  double sum_error, max_error, worst = 0.0, sum_all = 0.0;
  guint found_all = 0;
  gboolean ok;

  if (!setup)
    goto fail;
  sim = bench_simulator_new (setup, NOISE_AMPLITUDE, &error);
  if (!sim)
    goto fail;
  config_init (&c, &scenes[SCENE_FIG9]);
  b->setup = setup;
  ok = chain_init (ch, b, &c, &r, &error);
  b->setup = saved;
  if (!ok)
    goto fail;
  g_printerr ("detection: %u pings per cell\n", detection_pings);
  g_print ("\ndetection (one point reflector, -60..60 deg, -1..1 m/s; "
      "%u pings per cell; the elements' defaults, bank -7..7 / 0.05)\n"
      "probability of detection against per-channel SNR (false objects):"
      "\n%8s",
      detection_pings, "SNR dB");
  for (guint j = 0; j < G_N_ELEMENTS (detection_ranges); j++)
    g_print (" %8.0f m  ", detection_ranges[j]);
  g_print ("\n");
  for (guint i = 0; i < G_N_ELEMENTS (detection_snrs_db); i++) {
    g_print ("%8.0f", detection_snrs_db[i]);
    for (guint j = 0; j < G_N_ELEMENTS (detection_ranges); j++) {
      detect_reflector (ch, sim, setup, detection_ranges[j],
          detection_snrs_db[i], detection_pings, 1000 * (j + 1),
          &found, &false_objects, &sum_error, &max_error, NULL);
      g_print (" %6.2f (%u)", (double) found / detection_pings,
          false_objects);
      total_false += false_objects;
      found_all += found;
      sum_all += sum_error;
      worst = MAX (worst, max_error);
      if (b->csv) {
        g_autofree char *value = g_strdup_printf ("%g dB %g m",
            detection_snrs_db[i], detection_ranges[j]);
        write_sensitivity_row (b->csv, "detection", value, "point",
            detection_pings, found, detection_pings, false_objects,
            found ? sum_error / found : NAN, max_error);
      }
    }
    g_print ("\n");
  }
  g_print ("false objects %u; velocity error of the found: mean %.4f, "
      "worst %.4f m/s\n", total_false, found_all ? sum_all / found_all :
      NAN, worst);
  detect_reflector (ch, sim, setup, GOAL_RANGE, GOAL_SNR_DB, GOAL_PINGS,
      100000, &found, &false_objects, &sum_error, &max_error, times);
  g_print ("goal: %g dB at %g m: found %u of %u (Pd %.2f), %u false "
      "objects, velocity error mean %.4f worst %.4f m/s; %.1f ms per ping "
      "(median, 8.5 m window)\n", GOAL_SNR_DB, GOAL_RANGE, found,
      GOAL_PINGS, (double) found / GOAL_PINGS, false_objects,
      found ? sum_error / found : NAN, max_error, median (times,
          GOAL_PINGS));
  chain_clear (ch);
  return TRUE;
fail:
  g_printerr ("detection: %s\n", error->message);
  chain_clear (ch);
  return FALSE;
}

/* The split sweep (issue 12): two point reflectors of unit strength at
 * one azimuth, @separation apart in range, whose radial velocities differ
 * by more than a Doppler main lobe (0.33 m/s); per ping a random range in
 * 1-4 m, azimuth in -60..60 degrees, the first one's velocity in -1..1
 * m/s and the second's that plus or minus the difference, the nearer one
 * either; noise seed = ping. Each object takes the valid detection within
 * MATCH_DISTANCE nearest to it in velocity, if within half a main lobe;
 * the pair is split when both are found. A detection left within
 * MATCH_DISTANCE of an object is a duplicate (a false split), any other a
 * false object. Then single objects at the defaults: one of the same
 * reflectors alone, the presets (default, fig9, fig10) and random
 * scenes, where every duplicate is a false split. CSV rows: "S cm D m/s"
 * and "weaker W dB" count the pairs split (found) of the pings (total);
 * "pairs", "single" and the scenes the objects found of the objects;
 * false_positives is duplicates and false objects. */
#define SPLIT_PINGS 10
#define SPLIT_RANGE_MIN 1.0
#define SPLIT_RANGE_MAX 4.0
#define SPLIT_BASE_SPEED 1.0
#define SPLIT_VELOCITY_MATCH 0.15
/* m/s: a worse error is printed. */
#define SPLIT_USUAL_ERROR 0.02
#define SPLIT_SCENE_PINGS 4

#define N_SPLIT_SEPARATIONS 5
#define N_SPLIT_DIFFERENCES 7

guint split_pings = SPLIT_PINGS;
static const double split_separations[N_SPLIT_SEPARATIONS] =
    { 0.005, 0.01, 0.015, 0.02, 0.03 };
static const double split_differences[N_SPLIT_DIFFERENCES] =
    { 0.4, 0.7, 1.0, 1.5, 2.0, 3.0, 5.0 };
static const double split_weaker_db[] = { 3.0, 6.0, 10.0, 14.0 };

typedef struct
{
  guint pings, objects, found, duplicates, false_objects;
  double sum_error, max_error;
} SplitTally;

/* Scores the chain's detections of one ping against @truths (see above);
 * returns the objects found. */
static guint
tally_ping (SplitTally * t, const Chain * ch, const SonarTruth * truths,
    guint n_truths)
{
  gboolean used[2 * MAX_CENTROIDS] = { FALSE };
  guint found = 0;

  t->pings++;
  for (guint k = 0; k < n_truths; k++) {
    int best = -1;

    t->objects++;
    for (guint d = 0; d < ch->n_detections; d++) {
      const double dv = fabs (ch->velocities[d] -
          truths[k].radial_velocity);
      if (!used[d] && dv <= SPLIT_VELOCITY_MATCH
          && sonar_vec3_norm (sonar_vec3_sub (ch->positions[d],
                  truths[k].position)) < MATCH_DISTANCE
          && (best < 0 || dv < fabs (ch->velocities[best] -
                  truths[k].radial_velocity)))
        best = d;
    }
    if (best >= 0) {
      const double err = fabs (ch->velocities[best] -
          truths[k].radial_velocity);
      used[best] = TRUE;
      found++;
      t->sum_error += err;
      t->max_error = MAX (t->max_error, err);
    }
  }
  t->found += found;
  for (guint d = 0; d < ch->n_detections; d++) {
    gboolean near = FALSE;

    if (used[d])
      continue;
    for (guint k = 0; k < n_truths && !near; k++)
      near = sonar_vec3_norm (sonar_vec3_sub (ch->positions[d],
              truths[k].position)) < MATCH_DISTANCE;
    t->duplicates += near;
    t->false_objects += !near;
  }
  return found;
}

/* One ping of @n (1 or 2) reflectors of the split sweep through @ch;
 * returns the objects found, *@worst (may be NULL) their worst velocity
 * error. */
static guint
split_ping (Chain * ch, SonarSimulator * sim, const SonarSetup * setup,
    guint n, double separation, double difference, double weaker_db,
    guint64 ping, SplitTally * t, float *planar, float *samples,
    double *worst)
{
  const guint n_mics = setup->geometry.n_microphones;
  SonarReflector reflectors[2] = { 0 };
  SonarTruth truths[2];
  SonarScene scene;
  SonarRng rng;
  double range, azimuth, speed, sign, near;
  SonarVec3 u;
  const double max_error = t->max_error;
  const guint extra = t->duplicates + t->false_objects;
  guint found;

  sonar_rng_init (&rng, RANDOM_SCENE_SEED, ping);
  range = SPLIT_RANGE_MIN + (SPLIT_RANGE_MAX - SPLIT_RANGE_MIN) *
      sonar_rng_uniform (&rng);
  azimuth = SENSITIVITY_AZIMUTH * (2.0 * sonar_rng_uniform (&rng) - 1.0);
  speed = SPLIT_BASE_SPEED * (2.0 * sonar_rng_uniform (&rng) - 1.0);
  sign = sonar_rng_uniform (&rng) < 0.5 ? -1.0 : 1.0;
  near = sonar_rng_uniform (&rng) < 0.5 ? 0.0 : separation;
  u = sonar_vec3_from_direction (azimuth, 0.0);
  for (guint k = 0; k < n; k++) {
    const double r = range + (k == 0 ? near : separation - near);
    reflectors[k].kind = SONAR_REFLECTOR_POINT;
    reflectors[k].position = sonar_vec3_scale (u, r);
    reflectors[k].velocity = sonar_vec3_scale (u, speed + k * sign *
        difference);
    reflectors[k].strength = k ? pow (10.0, -weaker_db / 20.0) : 1.0;
  }
  sonar_scene_init_preset (&scene, SONAR_SCENE_PRESET_EMPTY);
  scene.reflectors = reflectors;
  scene.n_reflectors = n;
  sonar_simulator_render (sim, &scene, ping, 0.0, planar, truths);
  scene.reflectors = NULL;
  scene.n_reflectors = 0;
  sonar_scene_clear (&scene);
  interleave (planar, n_mics, setup->ping_length, samples);
  chain_run_ping (ch, samples, n_mics, setup->ping_length);
  t->max_error = 0.0;
  found = tally_ping (t, ch, truths, n);
  if (found < n || t->duplicates + t->false_objects > extra
      || t->max_error > SPLIT_USUAL_ERROR) {
    g_printerr ("split: ping %" G_GUINT64_FORMAT ": %u of %u found at %.3f "
        "m %+.1f deg (", ping, found, n, truths[0].range, truths[0].azimuth);
    for (guint k = 0; k < n; k++)
      g_printerr ("%s%.4f m %+.3f m/s", k ? ", " : "", truths[k].range,
          truths[k].radial_velocity);
    g_printerr ("); detections:");
    for (guint d = 0; d < ch->n_detections; d++)
      g_printerr (" %.4f m %+.4f m/s;", sonar_vec3_norm (ch->positions[d]),
          ch->velocities[d]);
    g_printerr ("\n");
  }
  if (worst)
    *worst = t->max_error;
  t->max_error = MAX (t->max_error, max_error);
  return found;
}

/* A separation x velocity difference table of @cells, shares (2
 * decimals) or errors (3 digits). */
static void
print_split_table (const char *title,
    double cells[N_SPLIT_SEPARATIONS][N_SPLIT_DIFFERENCES], gboolean shares)
{
  g_print ("%s:\n%10s", title, "sep \\ dv");
  for (guint j = 0; j < N_SPLIT_DIFFERENCES; j++)
    g_print (" %5.1f m/s", split_differences[j]);
  g_print ("\n");
  for (guint i = 0; i < N_SPLIT_SEPARATIONS; i++) {
    g_print ("%7.1f cm", 100.0 * split_separations[i]);
    for (guint j = 0; j < N_SPLIT_DIFFERENCES; j++)
      g_print (shares ? " %9.2f" : " %9.3g", cells[i][j]);
    g_print ("\n");
  }
}

static void
print_tally (const char *name, const SplitTally * t)
{
  g_print ("  %-22s %5u %8u/%-5u %10u %6u %9.4f %9.4f\n", name, t->pings,
      t->found, t->objects, t->duplicates, t->false_objects,
      t->found ? t->sum_error / t->found : NAN, t->max_error);
}

/* @t as a CSV row: pairs split (or objects found) of @total, duplicates
 * and false objects as its false positives. */
static void
write_tally_csv (FILE * csv, const char *value, const char *scene,
    const SplitTally * t, guint found, guint total)
{
  write_sensitivity_row (csv, "split", value, scene, t->pings, found, total,
      t->duplicates + t->false_objects, t->found ? t->sum_error / t->found :
      NAN, t->max_error);
}

gboolean
run_split (Bench * b)
{
  const guint n_mics = b->setup->geometry.n_microphones;
  const gsize length = b->setup->ping_length;
  const SonarScenePreset presets[] = { SONAR_SCENE_PRESET_DEFAULT,
    SONAR_SCENE_PRESET_FIG9, SONAR_SCENE_PRESET_FIG10
  };
  const char *const preset_names[] = { "default", "fig9", "fig10" };
  const guint random_sizes[] = { 5, 20 };
  g_autoptr (GError) error = NULL;
  g_autoptr (SonarSimulator) sim = NULL;
  g_autofree Chain *ch = g_new0 (Chain, 1);
  g_autofree float *planar = g_new (float, length * n_mics);
  g_autofree float *samples = g_new (float, length * n_mics);
  g_autofree SonarTruth *truths = NULL;
  SplitTally pairs = { 0 }, singles = { 0 }, scenes_tally = { 0 };
  double rates[N_SPLIT_SEPARATIONS][N_SPLIT_DIFFERENCES];
  double usual_rates[N_SPLIT_SEPARATIONS][N_SPLIT_DIFFERENCES];
  double worst_errors[N_SPLIT_SEPARATIONS][N_SPLIT_DIFFERENCES];
  Result r = { 0 };
  Config c;

  sim = bench_simulator_new (b->setup, NOISE_AMPLITUDE, &error);
  config_init (&c, &scenes[SCENE_FIG9]);
  if (!sim || !chain_init (ch, b, &c, &r, &error)) {
    g_printerr ("split: %s\n", error->message);
    chain_clear (ch);
    return FALSE;
  }
  g_printerr ("split: %u pings per cell\n", split_pings);
  for (guint i = 0; i < G_N_ELEMENTS (split_separations); i++) {
    for (guint j = 0; j < G_N_ELEMENTS (split_differences); j++) {
      SplitTally t = { 0 };
      guint splits = 0, usual = 0;

      for (guint p = 0; p < split_pings; p++) {
        const guint64 ping = 10000 * (i + 1) + 100 * j + p;
        double worst;
        const gboolean split = split_ping (ch, sim, b->setup, 2,
            split_separations[i], split_differences[j], 0.0, ping, &t,
            planar, samples, &worst) == 2;
        splits += split;
        usual += split && worst <= SPLIT_USUAL_ERROR;
      }
      rates[i][j] = (double) splits / split_pings;
      usual_rates[i][j] = (double) usual / split_pings;
      worst_errors[i][j] = t.max_error;
      if (b->csv) {
        g_autofree char *value = g_strdup_printf ("%g cm %g m/s",
            100.0 * split_separations[i], split_differences[j]);
        write_tally_csv (b->csv, value, "pair", &t, splits, split_pings);
      }
      pairs.pings += t.pings;
      pairs.objects += t.objects;
      pairs.found += t.found;
      pairs.duplicates += t.duplicates;
      pairs.false_objects += t.false_objects;
      pairs.sum_error += t.sum_error;
      pairs.max_error = MAX (pairs.max_error, t.max_error);
    }
  }
  g_print ("\nsplit (two unit point reflectors at one azimuth, 1-4 m, "
      "-60..60 deg; %u pings per cell; the elements' defaults, bank "
      "-7..7 / 0.05)\n", split_pings);
  print_split_table ("share of the pairs split into two objects, each "
      "within 0.15 m/s of its velocity", rates, TRUE);
  print_split_table ("share split with both within 0.02 m/s", usual_rates,
      TRUE);
  print_split_table ("worst velocity error of the objects found, m/s",
      worst_errors, FALSE);

  /* The second object weaker: every separation, the differences in
   * turn. */
  g_print ("the second object weaker (every separation, the velocity "
      "differences in turn, %u pings each):\n%10s %9s %9s %9s\n",
      split_pings * (guint) G_N_ELEMENTS (split_separations), "weaker",
      "split", "mean m/s", "max m/s");
  for (guint w = 0; w < G_N_ELEMENTS (split_weaker_db); w++) {
    SplitTally t = { 0 };
    guint splits = 0, n = 0;

    for (guint i = 0; i < G_N_ELEMENTS (split_separations); i++)
      for (guint p = 0; p < split_pings; p++, n++)
        splits += split_ping (ch, sim, b->setup, 2, split_separations[i],
            split_differences[n % G_N_ELEMENTS (split_differences)],
            split_weaker_db[w], 90000 + 1000 * w + n, &t, planar,
            samples, NULL) == 2;
    g_print ("%7.0f dB %9.2f %9.4f %9.4f\n", split_weaker_db[w],
        (double) splits / n, t.found ? t.sum_error / t.found : NAN,
        t.max_error);
    if (b->csv) {
      g_autofree char *value = g_strdup_printf ("weaker %g dB",
          split_weaker_db[w]);
      write_tally_csv (b->csv, value, "pair", &t, splits, n);
    }
  }

  /* Single objects: the same reflectors alone, then scenes. */
  for (guint i = 0; i < G_N_ELEMENTS (split_separations); i++)
    for (guint j = 0; j < G_N_ELEMENTS (split_differences); j++)
      for (guint p = 0; p < split_pings; p++)
        split_ping (ch, sim, b->setup, 1, 0.0, 0.0, 0.0, 10000 * (i + 1) +
            100 * j + p, &singles, planar, samples, NULL);
  g_print ("%-24s %5s %14s %10s %6s %9s %9s\n", "", "pings", "found",
      "duplicates", "false", "mean m/s", "max m/s");
  print_tally ("pairs (objects)", &pairs);
  print_tally ("single objects", &singles);
  if (b->csv) {
    write_tally_csv (b->csv, "pairs", "pair", &pairs, pairs.found,
        pairs.objects);
    write_tally_csv (b->csv, "single", "point", &singles, singles.found,
        singles.objects);
  }
  for (guint s = 0; s < G_N_ELEMENTS (presets) + G_N_ELEMENTS
      (random_sizes); s++) {
    const gboolean preset = s < G_N_ELEMENTS (presets);
    g_autofree char *name = preset ? g_strdup (preset_names[s]) :
        g_strdup_printf ("rand%u", random_sizes[s - G_N_ELEMENTS (presets)]);
    SplitTally t = { 0 };
    SonarScene scene;

    if (preset)
      sonar_scene_init_preset (&scene, presets[s]);
    else
      random_scene_init (&scene, random_sizes[s - G_N_ELEMENTS (presets)]);
    truths = g_renew (SonarTruth, truths, MAX (scene.n_reflectors, 1));
    for (guint p = 0; p < SPLIT_SCENE_PINGS; p++) {
      sonar_simulator_render (sim, &scene, p, p / PING_RATE, planar, truths);
      interleave (planar, n_mics, length, samples);
      chain_run_ping (ch, samples, n_mics, length);
      tally_ping (&t, ch, truths, scene.n_reflectors);
    }
    print_tally (name, &t);
    if (b->csv)
      write_tally_csv (b->csv, name, name, &t, t.found, t.objects);
    scenes_tally.duplicates += t.duplicates;
    sonar_scene_clear (&scene);
  }
  g_print ("false splits (duplicates) on single objects: %u of %u single "
      "reflectors, %u on the scenes\n", singles.duplicates, singles.pings,
      scenes_tally.duplicates);
  chain_clear (ch);
  return TRUE;
}

/* The uncertainty sweep (issue 14): does the 1-sigma each detection
 * reports (sonar_uncertainty_measure (), as velocityest fills the
 * detections) match the scatter of its estimates? One point reflector per
 * ping, at UNCERTAINTY_PLACES places (range 1.5-4 m, azimuth -50..50
 * degrees, radial velocity -1..1 m/s, drawn from RANDOM_SCENE_SEED: the
 * estimators' errors depend on where the peak falls between the grid's
 * samples), each rendered UNCERTAINTY_SEEDS times with a new noise seed,
 * at each per-channel SNR (as the detection sweep's). Per place, the
 * deviations of the valid detection's range (imaged, before velocityest
 * moves it to the velocity's instant), azimuth and radial velocity from
 * their mean over the seeds, each over the sigma reported with it; pooled
 * over the places (N - 1 degrees of freedom each), their rms is the
 * measured scatter in units of the reported sigma: 1 is a calibrated
 * sigma. Printed as reported / measured (the ratio of sigmas) beside the
 * median reported sigma. The ratio's own uncertainty from M pooled
 * degrees of freedom is about 1 / sqrt (2 M): 4 % at 300. */
#define UNCERTAINTY_PLACES 8
#define UNCERTAINTY_SEEDS 12
#define UNCERTAINTY_RANGE_MIN 1.5
#define UNCERTAINTY_RANGE_MAX 4.0
#define UNCERTAINTY_AZIMUTH 50.0
#define UNCERTAINTY_SPEED 1.0

guint uncertainty_seeds = UNCERTAINTY_SEEDS;
static const double uncertainty_snrs_db[] =
    { -30, -27, -24, -20, -15, -10, -5, 0 };

typedef struct
{
  guint found, dof;
  double sum_z2[3];             /* range, azimuth, velocity */
  GArray *sigmas[3];            /* reported, per found ping */
  GArray *snrs;
} UncertaintyTally;

/* One SNR's pings into @t. */
static void
uncertainty_pings_at (Chain * ch, SonarSimulator * sim,
    const SonarSetup * setup, double snr_db, UncertaintyTally * t)
{
  const guint n_mics = setup->geometry.n_microphones;
  const gsize length = setup->ping_length;
  g_autofree float *planar = g_new (float, length * n_mics);
  g_autofree float *samples = g_new (float, length * n_mics);
  g_autofree double *values = g_new (double, 3 * uncertainty_seeds);
  g_autofree double *sigmas = g_new (double, 3 * uncertainty_seeds);
  g_autoptr (SonarNoiseMeter) noise = sonar_noise_meter_new (ch->grid,
      ch->n_templates);
  SonarReflector reflector = {.kind = SONAR_REFLECTOR_POINT };
  SonarScene scene;
  SonarRng rng;

  sonar_scene_init_preset (&scene, SONAR_SCENE_PRESET_EMPTY);
  scene.reflectors = &reflector;
  scene.n_reflectors = 1;
  for (guint place = 0; place < UNCERTAINTY_PLACES; place++) {
    double range, azimuth, speed;
    SonarVec3 u;
    guint n = 0;

    sonar_rng_init (&rng, RANDOM_SCENE_SEED, 5000 + place);
    range = UNCERTAINTY_RANGE_MIN + (UNCERTAINTY_RANGE_MAX -
        UNCERTAINTY_RANGE_MIN) * sonar_rng_uniform (&rng);
    azimuth = UNCERTAINTY_AZIMUTH * (2.0 * sonar_rng_uniform (&rng) - 1.0);
    speed = UNCERTAINTY_SPEED * (2.0 * sonar_rng_uniform (&rng) - 1.0);
    u = sonar_vec3_from_direction (azimuth, 0.0);
    reflector.position = sonar_vec3_scale (u, range);
    reflector.velocity = sonar_vec3_scale (u, speed);
    /* SNR = (s / (2 r)^2)^2 P_emitted / noise^2, solved for s. */
    reflector.strength = NOISE_AMPLITUDE * pow (10.0, snr_db / 20.0) *
        4.0 * range * range / sqrt (emission_power (setup));
    for (guint seed = 0; seed < uncertainty_seeds; seed++) {
      SonarTruth truth;
      guint n_centroids;
      gboolean hit = FALSE;

      /* The same instant (t = 0) every time; only the noise changes. */
      sonar_simulator_render (sim, &scene, 7000 + 100 * place + seed, 0.0,
          planar, &truth);
      interleave (planar, n_mics, length, samples);
      n_centroids = chain_run_ping (ch, samples, n_mics, length);
      for (guint k = 0; k < n_centroids && !hit; k++) {
        for (guint j = 0; j < ch->counts[k] && !hit; j++) {
          const SonarVelocityEstimate *e = &ch->results[2 * k + j];
          SonarUncertainty s;
          if (!e->valid
              || fabs (e->echo_range - truth.range) > MATCH_DISTANCE
              || fabs (e->echo_azimuth - truth.azimuth) > 3.0)
            continue;
          sonar_uncertainty_measure (ch->image, ch->grid,
              sonar_noise_meter_power (noise, ch->image),
              &ch->centroids[k], e, ch->n_emitters, &s);
          values[3 * n] = e->echo_range;
          values[3 * n + 1] = e->echo_azimuth;
          values[3 * n + 2] = e->radial_velocity;
          sigmas[3 * n] = s.range_sigma;
          sigmas[3 * n + 1] = s.azimuth_sigma;
          sigmas[3 * n + 2] = s.radial_velocity_sigma;
          for (guint i = 0; i < 3; i++)
            g_array_append_val (t->sigmas[i], sigmas[3 * n + i]);
          g_array_append_val (t->snrs, s.snr_db);
          n++;
          hit = TRUE;
        }
      }
    }
    t->found += n;
    if (n < 2)
      continue;
    t->dof += n - 1;
    for (guint i = 0; i < 3; i++) {
      double mean = 0.0;
      for (guint m = 0; m < n; m++)
        mean += values[3 * m + i] / n;
      for (guint m = 0; m < n; m++) {
        const double z = (values[3 * m + i] - mean) / sigmas[3 * m + i];
        t->sum_z2[i] += z * z;
      }
    }
  }
  scene.reflectors = NULL;
  scene.n_reflectors = 0;
  sonar_scene_clear (&scene);
}

static double
array_median (GArray * a)
{
  return a->len ? median ((double *) a->data, a->len) : NAN;
}

gboolean
run_uncertainty (Bench * b)
{
  static const char *const names[3] = { "range", "azimuth", "velocity" };
  static const char *const units[3] = { "mm", "mdeg", "mm/s" };
  g_autoptr (GError) error = NULL;
  g_autoptr (SonarSetup) setup = sonar_setup_new_default (MAX_RANGE, &error);
  g_autoptr (SonarSimulator) sim = NULL;
  g_autofree Chain *ch = g_new0 (Chain, 1);
  SonarSetup *saved = b->setup;
  Result r = { 0 };
  Config c;
  gboolean ok;

  if (!setup)
    goto fail;
  sim = bench_simulator_new (setup, NOISE_AMPLITUDE, &error);
  if (!sim)
    goto fail;
  config_init (&c, &scenes[SCENE_FIG9]);
  b->setup = setup;
  ok = chain_init (ch, b, &c, &r, &error);
  b->setup = saved;
  if (!ok)
    goto fail;
  g_print ("\nuncertainty (one point reflector at %u places, 1.5-4 m, "
      "-50..50 deg, -1..1 m/s, %u noise seeds each; the elements' "
      "defaults)\nratio = reported 1-sigma / measured scatter about each "
      "place's mean (pooled rms of deviation / reported sigma); sigma: the "
      "median reported\n%7s %7s %9s", UNCERTAINTY_PLACES, uncertainty_seeds,
      "SNR dB", "found", "image SNR");
  for (guint i = 0; i < 3; i++)
    g_print ("  %8s %4s ratio", names[i], units[i]);
  g_print ("\n");
  for (guint s = 0; s < G_N_ELEMENTS (uncertainty_snrs_db); s++) {
    UncertaintyTally t = { 0 };
    for (guint i = 0; i < 3; i++)
      t.sigmas[i] = g_array_new (FALSE, FALSE, sizeof (double));
    t.snrs = g_array_new (FALSE, FALSE, sizeof (double));
    uncertainty_pings_at (ch, sim, setup, uncertainty_snrs_db[s], &t);
    g_print ("%7.0f %3u/%-3u %9.1f", uncertainty_snrs_db[s], t.found,
        UNCERTAINTY_PLACES * uncertainty_seeds, array_median (t.snrs));
    for (guint i = 0; i < 3; i++) {
      const double ratio = t.dof ? 1.0 / sqrt (t.sum_z2[i] / t.dof) : NAN;
      g_print ("  %13.3f %5.2f", 1e3 * array_median (t.sigmas[i]), ratio);
      if (b->csv) {
        g_autofree char *value = g_strdup_printf ("%g dB %s",
            uncertainty_snrs_db[s], names[i]);
        write_sensitivity_row (b->csv, "uncertainty", value, "point",
            UNCERTAINTY_PLACES * uncertainty_seeds, t.found,
            UNCERTAINTY_PLACES * uncertainty_seeds, 0,
            array_median (t.sigmas[i]), ratio);
      }
      g_array_unref (t.sigmas[i]);
    }
    g_array_unref (t.snrs);
    g_print ("\n");
  }
  (void) units;
  chain_clear (ch);
  return TRUE;
fail:
  g_printerr ("uncertainty: %s\n", error->message);
  chain_clear (ch);
  return FALSE;
}
