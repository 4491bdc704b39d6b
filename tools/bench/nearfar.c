/* sonar-bench's near-far sweep (issue 12): the dynamic range between a
 * strong near object and a normal one.
 *
 * Per ping: a point NEAR_RANGE from the array, azimuth in
 * -NEAR_AZIMUTH..NEAR_AZIMUTH, and a unit point behind it, azimuth in
 * -FAR_AZIMUTH..FAR_AZIMUTH and at least APART_AZIMUTH from the first;
 * both radial velocities in -1..1 m/s. The near one stands D dB above
 * the other in the range-compensated image (strength 10^(D/20): an echo's
 * amplitude is strength / (2 r)^2 and the image compensates r^2); noise
 * seed = ping. Through the chain at the elements' defaults. Two places
 * of the normal one: beyond the near echo's pulse (its range plus the
 * pulse's length, c T / 2, plus BEYOND_MARGIN, to FAR_RANGE_MAX), and
 * within it (WITHIN_MARGIN behind the near one to WITHIN_MARGIN short of
 * the pulse's end), where the near echo's cross-talk through the other
 * emitters' templates lies (physics-notes: a ridge about a pulse length
 * long, 20 dB below its peak per emitter).
 *
 * Each object takes the nearest valid detection within MATCH_DISTANCE
 * (one each); any other valid detection is a false object. Beside it,
 * the crowded sweep's oracle: the normal one is detectable when it
 * stands ORACLE_DB above the image of the near one and the noise at its
 * true pixel ("detectable": found / detectable). The dynamic
 * range: the highest D up to which the normal object is found in
 * DYNAMIC_PD of the pings at every level, with no false object. */
#include <math.h>
#include <string.h>

#include "bench.h"
#include "sonar-rng.h"

#define NEAR_RANGE 0.5
#define NEAR_AZIMUTH 30.0
#define FAR_RANGE_MAX 3.5
#define BEYOND_MARGIN 0.1
#define WITHIN_MARGIN 0.2
#define FAR_AZIMUTH 60.0
/* Degrees between the two: the MIMO beam is about 2 degrees wide, and
 * the near one's main lobe is not what this measures. */
#define APART_AZIMUTH 10.0
#define SPEED 1.0
#define DYNAMIC_PD 0.9
#define NEAR_FAR_PINGS 20
/* The rng stream of the sweep's scenes (the detection sweep's start at
 * 1000). */
#define NEAR_FAR_SEED 500000

guint near_far_pings = NEAR_FAR_PINGS;
static const double levels_db[] = { 10.0, 15.0, 20.0, 30.0, 40.0, 50.0,
  60.0
};

typedef struct
{
  guint near_found, far_found, false_objects;
  /* The far ones the oracle (crowded.c) puts ORACLE_DB above their
   * interference, and of them found. */
  guint detectable, found_detectable;
  double far_sum_error, far_max_error;
  double *times;                /* ms per ping */
} NearFarTally;

/* Index of the detection nearest @position within MATCH_DISTANCE not
 * taken yet, or -1. */
static int
nearest_detection (const Chain * ch, SonarVec3 position, const gboolean *taken)
{
  double best = MATCH_DISTANCE;
  int index = -1;

  for (guint d = 0; d < ch->n_detections; d++) {
    const double distance = sonar_vec3_norm (sonar_vec3_sub
        (ch->positions[d], position));
    if (!taken[d] && distance < best) {
      best = distance;
      index = (int) d;
    }
  }
  return index;
}

/* near_far_pings pings with the near object @level_db above the other,
 * the other at @far_min to @far_max m, added to @t. */
static gboolean
near_far_level (Chain * ch, SonarSimulator * sim, SonarSimulator * quiet,
    SonarSetup * setup, double level_db, double far_min,
    double far_max, guint64 seed, NearFarTally * t, GError ** error)
{
  const guint n_mics = setup->geometry.n_microphones;
  const gsize length = setup->ping_length;
  const gsize n_spectra = (gsize) n_mics * ch->band->n_bins;
  g_autofree SonarComplex *whole = g_new (SonarComplex, n_spectra);
  g_autofree float *planar = g_new (float, length * n_mics);
  g_autofree float *samples = g_new (float, length * n_mics);
  SonarReflector reflectors[2] = { {0} };
  SonarTruth truths[2];
  SonarScene scene;
  SonarRng rng;

  sonar_scene_init_preset (&scene, SONAR_SCENE_PRESET_EMPTY);
  scene.reflectors = reflectors;
  scene.n_reflectors = 2;
  for (guint p = 0; p < near_far_pings; p++) {
    const guint64 ping = seed + p;
    gboolean taken[2 * MAX_CENTROIDS] = { FALSE };
    double azimuths[2], ranges[2], start;
    double margin;
    guint n_centroids;
    int near, far;

    sonar_rng_init (&rng, RANDOM_SCENE_SEED, ping);
    ranges[0] = NEAR_RANGE;
    azimuths[0] = NEAR_AZIMUTH * (2.0 * sonar_rng_uniform (&rng) - 1.0);
    ranges[1] = far_min + (far_max - far_min) * sonar_rng_uniform (&rng);
    do
      azimuths[1] = FAR_AZIMUTH * (2.0 * sonar_rng_uniform (&rng) - 1.0);
    while (fabs (azimuths[1] - azimuths[0]) < APART_AZIMUTH);
    for (guint k = 0; k < 2; k++) {
      const SonarVec3 u = sonar_vec3_from_direction (azimuths[k], 0.0);
      reflectors[k].kind = SONAR_REFLECTOR_POINT;
      reflectors[k].position = sonar_vec3_scale (u, ranges[k]);
      reflectors[k].velocity = sonar_vec3_scale (u, SPEED * (2.0 *
              sonar_rng_uniform (&rng) - 1.0));
      reflectors[k].strength = k ? 1.0 : pow (10.0, level_db / 20.0);
    }
    sonar_simulator_render (sim, &scene, ping, 0.0, planar, truths);
    interleave (planar, n_mics, length, samples);
    start = now_ms ();
    n_centroids = chain_run_ping (ch, samples, n_mics, length);
    t->times[p] = now_ms () - start;
    memcpy (whole, ch->spectra, n_spectra * sizeof (SonarComplex));

    near = nearest_detection (ch, truths[0].position, taken);
    if (near >= 0)
      taken[near] = TRUE;
    far = nearest_detection (ch, truths[1].position, taken);
    margin = oracle_margin_db (ch, quiet, setup, &reflectors[1], &truths[1],
        whole, error);
    if (isnan (margin))
      return FALSE;
    t->detectable += margin >= ORACLE_DB;
    t->found_detectable += margin >= ORACLE_DB && far >= 0;
    if (far >= 0) {
      const double velocity_error = fabs (ch->velocities[far] -
          truths[1].radial_velocity);
      taken[far] = TRUE;
      t->far_sum_error += velocity_error;
      t->far_max_error = MAX (t->far_max_error, velocity_error);
    } else {
      /* Where it was lost: no centroid near it, or its estimate's tests. */
      int c = -1;
      for (guint k = 0; k < n_centroids && c < 0; k++)
        if (sonar_vec3_norm (sonar_vec3_sub (ch->centroids[k].position,
                    truths[1].position)) < MATCH_DISTANCE)
          c = k;
      g_printerr ("near-far: %.0f dB, ping %" G_GUINT64_FORMAT ": missed "
          "the object at %.3f m %+.1f deg %+.3f m/s, %.1f dB above its "
          "interference (the near one at %+.1f deg): ", level_db, ping,
          truths[1].range, truths[1].azimuth, truths[1].radial_velocity,
          margin, truths[0].azimuth);
      if (c < 0)
        g_printerr ("no centroid\n");
      else
        g_printerr ("coherence %.2f, %u agreeing emitters\n",
            ch->results[2 * c].coherence,
            ch->results[2 * c].agreeing_emitters);
    }
    t->near_found += near >= 0;
    t->far_found += far >= 0;
    for (guint d = 0; d < ch->n_detections; d++)
      if (!taken[d]) {
        t->false_objects++;
        g_printerr ("near-far: %.0f dB, ping %" G_GUINT64_FORMAT ": false "
            "object at %.3f m %+.4f m/s\n", level_db, ping,
            sonar_vec3_norm (ch->positions[d]), ch->velocities[d]);
      }
  }
  scene.reflectors = NULL;
  scene.n_reflectors = 0;
  sonar_scene_clear (&scene);
  return TRUE;
}

gboolean
run_near_far (Bench * b)
{
  g_autoptr (GError) error = NULL;
  g_autoptr (SonarSimulator) sim = NULL;
  g_autoptr (SonarSimulator) quiet = NULL;
  g_autofree Chain *ch = g_new0 (Chain, 1);
  g_autofree double *times = g_new (double, near_far_pings);
  Result r = { 0 };
  Config c;

  sim = bench_simulator_new (b->setup, NOISE_AMPLITUDE, &error);
  if (sim)
    quiet = bench_simulator_new (b->setup, 0.0, &error);
  config_init (&c, &scenes[SCENE_FIG9]);
  if (!quiet || !chain_init (ch, b, &c, &r, &error))
    goto fail;
  for (guint place = 0; place < 2; place++) {
    /* The pulse's length in range, c T / 2. */
    const double pulse = b->setup->waveform_length / b->setup->sample_rate *
        b->setup->speed_of_sound / 2.0;
    const double far_min = place ? NEAR_RANGE + WITHIN_MARGIN : NEAR_RANGE +
        pulse + BEYOND_MARGIN;
    const double far_max = place ? NEAR_RANGE + pulse - WITHIN_MARGIN :
        FAR_RANGE_MAX;
    const char *where = place ? "within" : "beyond";
    double dynamic_range = NAN;
    gboolean holding = TRUE;

    g_print ("\nnear-far, %s the near echo's pulse (a point at %.1f m, "
        "%.0f..%.0f deg, D dB above a unit point at %.2f-%.2f m, %.0f..%.0f "
        "deg, %.0f deg or more apart; both %.0f..%.0f m/s; %u pings per "
        "level; the elements' defaults, bank -7..7 / 0.05)\n"
        "%6s %10s %10s %10s %6s %10s %10s %10s\n", where, NEAR_RANGE,
        -NEAR_AZIMUTH, NEAR_AZIMUTH, far_min, far_max, -FAR_AZIMUTH,
        FAR_AZIMUTH, APART_AZIMUTH, -SPEED, SPEED, near_far_pings, "D dB",
        "near found", "far found", "detectable", "false", "far mean",
        "far max", "ping ms");
    for (guint i = 0; i < G_N_ELEMENTS (levels_db); i++) {
      NearFarTally t = {.times = times };
      if (!near_far_level (ch, sim, quiet, b->setup, levels_db[i], far_min,
              far_max, NEAR_FAR_SEED + 100000 * place + 1000 * i, &t,
              &error))
        goto fail;
      g_print ("%6.0f %6u/%-3u %6u/%-3u %6u/%-3u %6u %10.4f %10.4f %10.1f\n",
          levels_db[i], t.near_found, near_far_pings, t.far_found,
          near_far_pings, t.found_detectable, t.detectable,
          t.false_objects, t.far_found ? t.far_sum_error /
          t.far_found : NAN, t.far_max_error, median (times,
              near_far_pings));
      holding &= t.far_found >= DYNAMIC_PD * near_far_pings
          && t.false_objects == 0;
      if (holding)
        dynamic_range = levels_db[i];
      if (b->csv) {
        g_autofree char *value = g_strdup_printf ("%s %g dB", where,
            levels_db[i]);
        write_sensitivity_row (b->csv, "near-far", value, "pair",
            near_far_pings, t.far_found, near_far_pings, t.false_objects,
            t.far_found ? t.far_sum_error / t.far_found : NAN,
            t.far_max_error);
      }
    }
    if (isnan (dynamic_range))
      g_print ("dynamic range %s the pulse: below %.0f dB\n", where,
          levels_db[0]);
    else
      g_print ("dynamic range %s the pulse: %.0f dB (the far object found "
          "in %.0f%% of the pings or more at every level up to it, no "
          "false object)\n", where, dynamic_range, 100.0 * DYNAMIC_PD);
  }
  chain_clear (ch);
  return TRUE;
fail:
  g_printerr ("near-far: %s\n", error->message);
  chain_clear (ch);
  return FALSE;
}
