/* sonar-bench: the project's benchmark.
 *
 * Processes a fixed set of pings of the fig10 and fig9 presets through the
 * DSP core the way the elements do (dopplerbank ! mimobeamform !
 * wardcluster ! velocityest, with their defaults), scores the detections
 * against the simulator's ground truth and times every stage. Each sweep
 * changes one setting; each row is one configuration.
 *
 *   sonar-bench                         the elements' defaults, both scenes
 *   sonar-bench --sweep linkage         Ward vs SLINK (paper Fig. 10) and more
 *   sonar-bench --all --csv bench.csv   every sweep, rows appended to a CSV
 *   sonar-bench --quick                 fig10, 2 pings: linkage and refine
 *
 * The sensor is sonarsrc's default, built by a copy of its make_setup ()
 * logic; the velocity stage shares the centroids between worker threads as
 * velocityest does (--threads). Every ping is rendered before anything is
 * timed: the simulator's cost is not counted. Times are wall-clock medians
 * over the pings, ms per ping. Set-up work (the Doppler bank, FFT plans,
 * the imager's tables) is not timed, as the elements do it once per
 * stream. A configuration two sweeps share (linkage=ward is refine=on) runs
 * once. tools/plot-bench.py draws the CSV.
 */
#include <errno.h>
#include <gio/gio.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/resource.h>
#include <time.h>

#include "sonar-cluster.h"
#include "sonar-doppler-bank.h"
#include "sonar-imager.h"
#include "sonar-simulator.h"
#include "sonar-spectrum.h"
#include "sonar-velocity.h"
#include "sonar-waveform.h"

/* sonarsrc's defaults. */
#define MAX_RANGE 5.0
#define PING_RATE 12.0
#define WAVEFORM_SEED 1
#define NOISE_AMPLITUDE 0.01
#define NOISE_SEED 0

/* mimobeamform's, wardcluster's and velocityest's. */
#define HYPOTHESIS_SPACING 0.3
#define MAX_CENTROIDS 256


/* How test-pipeline.c scores: a detection this close to a true object
 * matches it. */
#define MATCH_DISTANCE 0.05
/* The paper's Fig. 10b: SLINK struggles below this range. */
#define NEAR_RANGE 1.0

typedef struct
{
  const char *name;
  SonarScenePreset preset;
  double v_min, v_max, v_step;  /* the bank the paper uses with it */
  guint n_pings;
  guint n_reflectors;
  float *pings;                 /* n_pings x ping_length x microphones,
                                 * interleaved as sonarsrc emits them */
  SonarTruth *truths;           /* n_pings x n_reflectors */
} BenchScene;

enum
{
  SCENE_FIG10,
  SCENE_FIG9,
  N_SCENES,
};

static BenchScene scenes[N_SCENES] = {
  {"fig10", SONAR_SCENE_PRESET_FIG10, -0.4, 0.4, 0.02, 3},
  {"fig9", SONAR_SCENE_PRESET_FIG9, -7.0, 7.0, 0.05, 1},
};

enum
{
  STAGE_SPECTRA,
  STAGE_IMAGING,
  STAGE_CLUSTERING,
  STAGE_VELOCITY,
  N_STAGES,
};

typedef struct
{
  BenchScene *scene;
  double v_step;                /* the bank's; min and max are the scene's */
  double hypothesis_spacing;
  SonarImagerParams imager;
  SonarClusterParams cluster;
  SonarVelocityParams velocity;
} Config;

typedef struct
{
  char *label;                  /* sweep=value of the run that made it */
  guint pings, found, total, false_positives;
  guint near_found;
  double sum_error, near_sum_error, max_error;
  double centroids;             /* per ping */
  double ms[N_STAGES];          /* medians over the pings */
  double ms_total;
  /* CPU time of the whole chain: other processes on the machine inflate
   * the wall-clock times, not this. */
  double cpu_ms_total;
} Result;

typedef struct
{
  const char *name;
  guint scene;
  guint n_values;
  /* Changes value @i on @c, made with the scene's defaults, and names it
   * into @label. */
  void (*apply) (Config * c, guint i, char *label, gsize size);
} Sweep;

typedef struct
{
  SonarSetup *setup;
  guint n_threads;              /* velocity workers */
  GHashTable *banks;            /* "min/max/step" -> SonarDopplerBank */
  GHashTable *results;          /* configuration key -> Result */
  FILE *csv;
} Bench;


static double
clock_ms (clockid_t clock)
{
  struct timespec ts;

  clock_gettime (clock, &ts);
  return ts.tv_sec * 1e3 + ts.tv_nsec * 1e-6;
}

static double
now_ms (void)
{
  return clock_ms (CLOCK_MONOTONIC);
}

static int
compare_doubles (const void *a, const void *b)
{
  const double x = *(const double *) a, y = *(const double *) b;

  return (x > y) - (x < y);
}

/* Sorts @v in place. */
static double
median (double *v, guint n)
{
  qsort (v, n, sizeof (double), compare_doubles);
  return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

/* sonarsrc's default sensor, built as its make_setup () does without
 * geometry or waveforms files: the built-in array, the noise waveforms of
 * seed 1, a window holding the whole echo of an object at max-range seen
 * from the farthest element. */
/* sonarsrc's sensor: default array and waveforms, its recording window. */
static SonarSetup *
make_setup (GError ** error)
{
  g_autofree float *waveforms = NULL;
  SonarWaveformParams wp;
  SonarGeometry geometry;
  SonarSetup *setup = NULL;

  sonar_geometry_init_default (&geometry);
  sonar_waveform_params_init_default (&wp);
  wp.n_emitters = geometry.n_emitters;
  wp.seed = WAVEFORM_SEED;
  waveforms = g_new (float, (gsize) wp.n_emitters * wp.length);
  if (sonar_waveform_generate (&wp, waveforms, error))
    setup = sonar_setup_new (wp.sample_rate, SONAR_DEFAULT_SPEED_OF_SOUND,
        wp.band_low, wp.band_high, &geometry, wp.length, waveforms,
        sonar_ping_length_for_range (&geometry, SONAR_DEFAULT_SPEED_OF_SOUND,
            wp.sample_rate, wp.length, MAX_RANGE), error);
  sonar_geometry_clear (&geometry);
  return setup;
}

/* Renders the scene's pings as sonarsrc emits them (interleaved, ping p
 * at p / ping-rate s), with their truth. */
static gboolean
render_scene (BenchScene * s, SonarSetup * setup, GError ** error)
{
  const guint n_mics = setup->geometry.n_microphones;
  const gsize length = setup->ping_length;
  g_autoptr (SonarSimulator) sim = NULL;
  g_autofree float *planar = NULL;
  SonarSimulatorParams params;
  SonarScene scene;

  sonar_simulator_params_init_default (&params);
  params.noise_amplitude = NOISE_AMPLITUDE;
  params.seed = NOISE_SEED;
  sim = sonar_simulator_new (setup, &params, error);
  if (!sim)
    return FALSE;
  sonar_scene_init_preset (&scene, s->preset);
  s->n_reflectors = scene.n_reflectors;
  s->pings = g_new (float, s->n_pings * length * n_mics);
  s->truths = g_new (SonarTruth, MAX (s->n_pings * s->n_reflectors, 1));
  planar = g_new (float, length * n_mics);
  for (guint p = 0; p < s->n_pings; p++) {
    float *out = s->pings + p * length * n_mics;

    sonar_simulator_render (sim, &scene, p, p / PING_RATE, planar,
        s->truths + p * s->n_reflectors);
    for (guint j = 0; j < n_mics; j++)
      for (gsize i = 0; i < length; i++)
        out[i * n_mics + j] = planar[j * length + i];
  }
  sonar_scene_clear (&scene);
  return TRUE;
}

/* The elements' defaults for @scene. */
static void
config_init (Config * c, BenchScene * scene)
{
  c->scene = scene;
  c->v_step = scene->v_step;
  c->hypothesis_spacing = HYPOTHESIS_SPACING;
  sonar_imager_params_init_default (&c->imager);
  sonar_cluster_params_init_default (&c->cluster);
  sonar_velocity_params_init_default (&c->velocity);
}

/* Everything that makes a run: equal keys, equal results. */
static char *
config_key (const Config * c)
{
  const SonarImagerParams *i = &c->imager;
  const SonarClusterParams *k = &c->cluster;
  const SonarVelocityParams *v = &c->velocity;

  return g_strdup_printf ("%s %u | %.17g %.17g | %.17g %.17g %u %.17g %.17g "
      "%u %.17g %.17g %.17g %u | %d %.17g %.17g %d %d %.17g %u %.17g %u | "
      "%u %u %d %.17g %u %.17g %.17g", c->scene->name, c->scene->n_pings,
      c->v_step, c->hypothesis_spacing, i->azimuth_min, i->azimuth_max,
      i->n_azimuth, i->elevation_min, i->elevation_max, i->n_elevation,
      i->range_min, i->range_max, i->range_resolution, i->focus_zones,
      k->range_compensation, k->threshold_db, k->absolute_threshold,
      k->linkage, k->stop, k->inconsistency, k->depth, k->distance,
      k->max_peaks, v->window_directions, v->window_ranges, v->refine,
      v->min_variance, v->min_agreeing_emitters, v->min_coherence,
      v->second_peak_db);
}

/* Banks are set-up work: made once per velocity grid and shared. */
static SonarDopplerBank *
get_bank (Bench * b, const Config * c, GError ** error)
{
  const BenchScene *s = c->scene;
  g_autofree char *key = g_strdup_printf ("%.17g/%.17g/%.17g", s->v_min,
      s->v_max, c->v_step);
  SonarDopplerBank *bank = g_hash_table_lookup (b->banks, key);
  const SonarBand *band;
  double start;

  if (bank)
    return bank;
  start = now_ms ();
  bank = sonar_doppler_bank_new (b->setup, s->v_min, s->v_max, c->v_step,
      error);
  if (!bank)
    return NULL;
  sonar_doppler_bank_prepare_ping_band (bank);
  band = sonar_doppler_bank_band (bank);
  g_printerr ("bank %g..%g / %g m/s: %u velocities, FFT %u, %u bins, made "
      "in %.1f s\n", s->v_min, s->v_max, c->v_step,
      sonar_doppler_bank_n_velocities (bank), band->fft_size, band->n_bins,
      (now_ms () - start) * 1e-3);
  g_hash_table_insert (b->banks, g_steal_pointer (&key), bank);
  return bank;
}

/* Scores one ping as test-pipeline.c does: each true object matches the
 * first detection within MATCH_DISTANCE; any detection matching no object
 * is a false positive. */
static void
score_ping (Result * r, const SonarTruth * truths, guint n_truths,
    const SonarVec3 * positions, const double *velocities, guint n)
{
  for (guint k = 0; k < n_truths; k++) {
    const SonarTruth *t = &truths[k];
    const gboolean near = t->range < NEAR_RANGE;

    r->total++;
    for (guint d = 0; d < n; d++) {
      if (sonar_vec3_norm (sonar_vec3_sub (positions[d], t->position)) <
          MATCH_DISTANCE) {
        const double err = fabs (velocities[d] - t->radial_velocity);

        r->found++;
        r->sum_error += err;
        r->max_error = MAX (r->max_error, err);
        if (near) {
          r->near_found++;
          r->near_sum_error += err;
        }
        break;
      }
    }
  }
  for (guint d = 0; d < n; d++) {
    gboolean real = FALSE;

    for (guint k = 0; k < n_truths && !real; k++)
      real = sonar_vec3_norm (sonar_vec3_sub (positions[d],
              truths[k].position)) < MATCH_DISTANCE;
    r->false_positives += !real;
  }
}

/* One configuration over the scene's pings: the stages of dopplerbank,
 * mimobeamform (mode=detection), wardcluster and velocityest. */
static gboolean
run_config (Bench * b, const Config * c, Result * r, GError ** error)
{
  const BenchScene *s = c->scene;
  const guint n_mics = b->setup->geometry.n_microphones;
  const gsize length = b->setup->ping_length;
  SonarDopplerBank *bank = get_bank (b, c, error);
  const SonarBand *band;
  const SonarImageGrid *grid;
  g_autoptr (SonarSpectrum) analyzer = NULL;
  g_autoptr (SonarImager) imager = NULL;
  g_autoptr (SonarClusterer) clusterer = NULL;
  g_autoptr (SonarVelocityPool) workers = NULL;
  SonarVelocityEstimate results[2 * MAX_CENTROIDS];
  guint counts[MAX_CENTROIDS];
  g_autofree guint *hypotheses = NULL;
  g_autofree const SonarComplex **templates = NULL;
  g_autofree double *hyp_velocities = NULL;
  g_autofree SonarComplex *spectra = NULL;
  g_autofree float *image = NULL;
  g_autofree double *times = NULL;
  SonarCentroid centroids[MAX_CENTROIDS];
  SonarVec3 positions[2 * MAX_CENTROIDS];
  double velocities[2 * MAX_CENTROIDS];
  guint n_hypotheses, total_centroids = 0;

  if (!bank)
    return FALSE;
  band = sonar_doppler_bank_band (bank);
  analyzer = sonar_spectrum_new (band);
  imager = sonar_imager_new (b->setup, band, &c->imager, error);
  if (!imager)
    return FALSE;
  grid = sonar_imager_grid (imager);
  clusterer = sonar_clusterer_new (grid, &c->cluster, error);
  if (!clusterer)
    return FALSE;
  workers = sonar_velocity_pool_new (bank, grid, &c->velocity, b->n_threads,
      error);
  if (!workers)
    return FALSE;
  hypotheses = g_new (guint, sonar_doppler_bank_n_velocities (bank) + 2);
  n_hypotheses = sonar_doppler_bank_hypotheses (bank, c->hypothesis_spacing,
      hypotheses);
  templates = g_new (const SonarComplex *, n_hypotheses);
  hyp_velocities = g_new (double, n_hypotheses);
  for (guint h = 0; h < n_hypotheses; h++) {
    templates[h] = sonar_doppler_bank_spectra (bank, hypotheses[h]);
    hyp_velocities[h] = sonar_doppler_bank_velocity (bank, hypotheses[h]);
  }
  spectra = g_new (SonarComplex, (gsize) n_mics * band->n_bins);
  image = g_new (float, sonar_image_grid_size (grid));
  /* Per ping: the stages, the total, its CPU time. */
  times = g_new (double, (N_STAGES + 2) * s->n_pings);

  for (guint p = 0; p < s->n_pings; p++) {
    const float *samples = s->pings + p * length * n_mics;
    const double cpu_start = clock_ms (CLOCK_PROCESS_CPUTIME_ID);
    double t[N_STAGES + 1];
    guint n_centroids, n = 0;

    t[0] = now_ms ();
    for (guint j = 0; j < n_mics; j++)
      sonar_spectrum_process (analyzer, samples + j, length, n_mics,
          spectra + (gsize) j * band->n_bins, NULL);
    t[1] = now_ms ();
    sonar_imager_process (imager, spectra, n_hypotheses, templates,
        hyp_velocities, -1, image);
    t[2] = now_ms ();
    n_centroids = sonar_clusterer_process (clusterer, image, centroids,
        MAX_CENTROIDS);
    t[3] = now_ms ();
    sonar_velocity_pool_estimate (workers, spectra, centroids, n_centroids,
        results, counts);
    for (guint k = 0; k < n_centroids; k++) {
      const SonarVelocityEstimate *e = &results[2 * k];

      for (guint i = 0; i < counts[k]; i++) {
        if (!e[i].valid)
          continue;
        positions[n] = sonar_vec3_scale (sonar_vec3_from_direction
            (e[i].azimuth, e[i].elevation), e[i].range);
        velocities[n++] = e[i].radial_velocity;
      }
    }
    t[4] = now_ms ();

    for (guint k = 0; k < N_STAGES; k++)
      times[k * s->n_pings + p] = t[k + 1] - t[k];
    times[N_STAGES * s->n_pings + p] = t[N_STAGES] - t[0];
    times[(N_STAGES + 1) * s->n_pings + p] =
        clock_ms (CLOCK_PROCESS_CPUTIME_ID) - cpu_start;
    total_centroids += n_centroids;
    score_ping (r, s->truths + p * s->n_reflectors, s->n_reflectors,
        positions, velocities, n);
  }

  r->pings = s->n_pings;
  r->centroids = (double) total_centroids / s->n_pings;
  for (guint k = 0; k < N_STAGES; k++)
    r->ms[k] = median (times + k * s->n_pings, s->n_pings);
  r->ms_total = median (times + N_STAGES * s->n_pings, s->n_pings);
  r->cpu_ms_total = median (times + (N_STAGES + 1) * s->n_pings, s->n_pings);
  return TRUE;
}

static void
result_free (gpointer data)
{
  Result *r = data;

  g_free (r->label);
  g_free (r);
}

static double
mean_error (const Result * r)
{
  return r->found ? r->sum_error / r->found : NAN;
}

/* Sweeps ------------------------------------------------------------------*/

static void
apply_baseline (Config * c, guint i, char *label, gsize size)
{
  config_init (c, &scenes[i]);
  g_strlcpy (label, scenes[i].name, size);
}

static const SonarLinkage linkages[] = {
  SONAR_LINKAGE_WARD, SONAR_LINKAGE_SINGLE, SONAR_LINKAGE_COMPLETE,
  SONAR_LINKAGE_AVERAGE, SONAR_LINKAGE_CENTROID,
};

static const char *const linkage_names[] = {
  "ward", "single", "complete", "average", "centroid",
};

static void
apply_linkage (Config * c, guint i, char *label, gsize size)
{
  c->cluster.linkage = linkages[i];
  g_strlcpy (label, linkage_names[i], size);
}

static void
apply_refine (Config * c, guint i, char *label, gsize size)
{
  c->velocity.refine = i == 0;
  g_strlcpy (label, i == 0 ? "on" : "off", size);
}

static void
apply_window (Config * c, guint i, char *label, gsize size)
{
  static const guint directions[] = { 0, 1, 2 }, ranges[] = { 1, 2, 4 };

  c->velocity.window_directions = directions[i / 3];
  c->velocity.window_ranges = ranges[i % 3];
  g_snprintf (label, size, "d%ur%u", c->velocity.window_directions,
      c->velocity.window_ranges);
}

static void
apply_bank_step (Config * c, guint i, char *label, gsize size)
{
  static const double steps[] = { 0.01, 0.02, 0.05, 0.1 };

  c->v_step = steps[i];
  g_snprintf (label, size, "%g", steps[i]);
}

static void
apply_directions (Config * c, guint i, char *label, gsize size)
{
  static const guint counts[] = { 61, 91, 181, 361 };

  c->imager.n_azimuth = counts[i];
  g_snprintf (label, size, "%u", counts[i]);
}

static void
apply_focus_zones (Config * c, guint i, char *label, gsize size)
{
  static const guint zones[] = { 1, 2, 4, 8 };

  c->imager.focus_zones = zones[i];
  g_snprintf (label, size, "%u", zones[i]);
}

static void
apply_hypotheses (Config * c, guint i, char *label, gsize size)
{
  static const double spacings[] = { 0.15, 0.3, 0.6 };

  c->hypothesis_spacing = spacings[i];
  g_snprintf (label, size, "%g", spacings[i]);
}

static const Sweep sweeps[] = {
  {"baseline", SCENE_FIG10, N_SCENES, apply_baseline},
  {"linkage", SCENE_FIG10, G_N_ELEMENTS (linkages), apply_linkage},
  {"refine", SCENE_FIG10, 2, apply_refine},
  {"window", SCENE_FIG10, 9, apply_window},
  {"bank-step", SCENE_FIG10, 4, apply_bank_step},
  {"directions", SCENE_FIG10, 4, apply_directions},
  {"focus-zones", SCENE_FIG10, 4, apply_focus_zones},
  {"hypotheses", SCENE_FIG9, 3, apply_hypotheses},
};

static const Sweep *
find_sweep (const char *name)
{
  for (guint i = 0; i < G_N_ELEMENTS (sweeps); i++)
    if (g_str_equal (sweeps[i].name, name))
      return &sweeps[i];
  return NULL;
}

/* Output ------------------------------------------------------------------*/

static void
print_header (const Sweep * sweep)
{
  g_print ("\n%s\n", sweep->name);
  g_print ("  %-9s %-6s %5s %7s %3s %9s %9s %5s %8s %8s %8s %9s %9s %8s "
      "%9s\n", "value", "scene", "pings", "found", "FP", "mean m/s",
      "max m/s", "cent", "spectra", "imaging", "cluster", "velocity",
      "total ms", "pings/s", "cpu ms");
}

static void
print_row (const char *value, const Config * c, const Result * r,
    const char *same_as)
{
  g_autofree char *found = g_strdup_printf ("%u/%u", r->found, r->total);

  g_print ("  %-9s %-6s %5u %7s %3u %9.4f %9.4f %5.1f %8.1f %8.1f %8.1f "
      "%9.1f %9.1f %8.3f %9.1f", value, c->scene->name, r->pings, found,
      r->false_positives, mean_error (r), r->max_error, r->centroids,
      r->ms[STAGE_SPECTRA], r->ms[STAGE_IMAGING], r->ms[STAGE_CLUSTERING],
      r->ms[STAGE_VELOCITY], r->ms_total, 1e3 / r->ms_total,
      r->cpu_ms_total);
  if (same_as)
    g_print ("  (the %s run)", same_as);
  g_print ("\n");
}

static void
write_csv_row (FILE * csv, const char *sweep, const char *value,
    const Config * c, const Result * r)
{
  fprintf (csv, "%s,%s,%s,%u,%u,%u,%u,%.6g,%.6g", sweep, value,
      c->scene->name, r->pings, r->found, r->total, r->false_positives,
      mean_error (r), r->max_error);
  for (guint k = 0; k < N_STAGES; k++)
    fprintf (csv, ",%.6g", r->ms[k]);
  fprintf (csv, ",%.6g,%.6g\n", r->ms_total, 1e3 / r->ms_total);
  fflush (csv);
}

static void
print_ward_vs_slink (const Result * ward, const Result * slink)
{
  const Result *rows[] = { ward, slink };
  const char *names[] = { "Ward", "SLINK" };
  const char *paper[] = { "0.021 / 0.019", "0.024 / 0.032" };

  g_print ("\nWard vs SLINK, fig10 (paper Fig. 10: mean error over its "
      "angle / distance runs; Ward never above 0.05 m/s)\n");
  g_print ("  %-7s %7s %3s %9s %9s %11s %11s %14s\n", "linkage", "found",
      "FP", "mean m/s", "max m/s", "mean <1 m", "mean >=1 m", "paper mean");
  for (guint i = 0; i < G_N_ELEMENTS (rows); i++) {
    const Result *r = rows[i];
    const guint far_found = r->found - r->near_found;
    g_autofree char *found = g_strdup_printf ("%u/%u", r->found, r->total);

    g_print ("  %-7s %7s %3u %9.4f %9.4f %11.4f %11.4f %14s\n", names[i],
        found, r->false_positives, mean_error (r), r->max_error,
        r->near_found ? r->near_sum_error / r->near_found : NAN,
        far_found ? (r->sum_error - r->near_sum_error) / far_found : NAN,
        paper[i]);
  }
}

static gboolean
run_sweep (Bench * b, const Sweep * sweep)
{
  const Result *ward = NULL, *slink = NULL;
  gboolean ok = TRUE;

  print_header (sweep);
  for (guint i = 0; i < sweep->n_values; i++) {
    g_autoptr (GError) error = NULL;
    g_autofree char *key = NULL;
    const char *same_as = NULL;
    char value[32];
    Result *r;
    Config c;

    config_init (&c, &scenes[sweep->scene]);
    sweep->apply (&c, i, value, sizeof (value));
    key = config_key (&c);
    r = g_hash_table_lookup (b->results, key);
    if (r) {
      same_as = r->label;
    } else {
      double start = now_ms ();

      r = g_new0 (Result, 1);
      r->label = g_strdup_printf ("%s=%s", sweep->name, value);
      g_printerr ("%s: %u pings of %s\n", r->label, c.scene->n_pings,
          c.scene->name);
      if (!run_config (b, &c, r, &error)) {
        g_printerr ("%s: %s\n", r->label, error->message);
        result_free (r);
        ok = FALSE;
        continue;
      }
      g_printerr ("%s: done in %.1f s\n", r->label,
          (now_ms () - start) * 1e-3);
      g_hash_table_insert (b->results, g_steal_pointer (&key), r);
    }
    print_row (value, &c, r, same_as);
    if (b->csv)
      write_csv_row (b->csv, sweep->name, value, &c, r);
    if (sweep->apply == apply_linkage) {
      if (linkages[i] == SONAR_LINKAGE_WARD)
        ward = r;
      else if (linkages[i] == SONAR_LINKAGE_SINGLE)
        slink = r;
    }
  }
  if (ward && slink)
    print_ward_vs_slink (ward, slink);
  return ok;
}

static gboolean
parse_pings (const char *option_name, const char *value, guint * pings,
    GError ** error)
{
  guint64 n;
  g_autoptr (GError) parse_error = NULL;

  if (!g_ascii_string_to_unsigned (value, 10, 1, 10000, &n, &parse_error)) {
    g_set_error (error, G_OPTION_ERROR, G_OPTION_ERROR_BAD_VALUE, "%s: %s",
        option_name, parse_error->message);
    return FALSE;
  }
  *pings = (guint) n;
  return TRUE;
}

static gboolean
parse_fig10_pings (const char *option_name, const char *value,
    gpointer data, GError ** error)
{
  return parse_pings (option_name, value, &scenes[SCENE_FIG10].n_pings,
      error);
}

static gboolean
parse_fig9_pings (const char *option_name, const char *value,
    gpointer data, GError ** error)
{
  return parse_pings (option_name, value, &scenes[SCENE_FIG9].n_pings, error);
}

int
main (int argc, char **argv)
{
  g_auto (GStrv) sweep_names = NULL;
  g_autofree char *csv_path = NULL;
  g_autoptr (GOptionContext) context = NULL;
  g_autoptr (GError) error = NULL;
  g_autoptr (GPtrArray) selected = g_ptr_array_new ();
  gboolean all = FALSE, quick = FALSE, needed[N_SCENES] = { FALSE };
  gboolean ok = TRUE;
  int threads = 0;
  struct rusage usage;
  Bench b = { 0 };
  double start = now_ms ();
  GOptionEntry entries[] = {
    {"sweep", 's', 0, G_OPTION_ARG_STRING_ARRAY, &sweep_names,
        "Run this sweep (repeatable): baseline, linkage, refine, window, "
          "bank-step, directions, focus-zones, hypotheses", "NAME"},
    {"all", 'a', 0, G_OPTION_ARG_NONE, &all,
        "Run every sweep but baseline", NULL},
    {"quick", 'q', 0, G_OPTION_ARG_NONE, &quick,
        "Only 2 fig10 pings and the linkage and refine sweeps", NULL},
    {"csv", 'c', 0, G_OPTION_ARG_FILENAME, &csv_path,
        "Append one row per configuration to this CSV file", "FILE"},
    {"fig10-pings", 0, 0, G_OPTION_ARG_CALLBACK, parse_fig10_pings,
        "Pings of the fig10 drive (default 3)", "N"},
    {"fig9-pings", 0, 0, G_OPTION_ARG_CALLBACK, parse_fig9_pings,
        "Pings of the fig9 world (default 1)", "N"},
    {"threads", 't', 0, G_OPTION_ARG_INT, &threads,
        "Velocity workers, as velocityest's threads (default 0: one per "
          "processor)", "N"},
    {NULL}
  };

  context = g_option_context_new ("- time and score the sonar's DSP chain");
  g_option_context_set_summary (context, "Processes fixed pings of the "
      "fig10 and fig9 presets through the DSP core as the elements do and "
      "prints, per configuration, the objects found, false positives, "
      "velocity errors against the truth and the median time per ping of "
      "each stage. Without a sweep: the elements' defaults on both scenes.");
  g_option_context_add_main_entries (context, entries, NULL);
  if (!g_option_context_parse (context, &argc, &argv, &error)) {
    g_printerr ("sonar-bench: %s\n", error->message);
    return 2;
  }
  if (threads < 0 || threads > SONAR_VELOCITY_MAX_THREADS) {
    g_printerr ("sonar-bench: --threads must be 0 to %d\n", SONAR_VELOCITY_MAX_THREADS);
    return 2;
  }
  b.n_threads = CLAMP (threads ? (guint) threads : g_get_num_processors (),
      1, SONAR_VELOCITY_MAX_THREADS);

  if (quick) {
    scenes[SCENE_FIG10].n_pings = 2;
    g_ptr_array_add (selected, (gpointer) find_sweep ("linkage"));
    g_ptr_array_add (selected, (gpointer) find_sweep ("refine"));
  } else if (all) {
    for (guint i = 1; i < G_N_ELEMENTS (sweeps); i++)
      g_ptr_array_add (selected, (gpointer) &sweeps[i]);
  }
  for (guint i = 0; sweep_names && sweep_names[i]; i++) {
    const Sweep *sweep = find_sweep (sweep_names[i]);

    if (!sweep) {
      g_printerr ("sonar-bench: no sweep \"%s\" (see --help)\n",
          sweep_names[i]);
      return 2;
    }
    g_ptr_array_add (selected, (gpointer) sweep);
  }
  if (selected->len == 0)
    g_ptr_array_add (selected, (gpointer) find_sweep ("baseline"));
  for (guint i = 0; i < selected->len; i++) {
    const Sweep *sweep = g_ptr_array_index (selected, i);

    if (sweep->apply == apply_baseline)
      needed[SCENE_FIG10] = needed[SCENE_FIG9] = TRUE;
    else
      needed[sweep->scene] = TRUE;
  }

  if (csv_path) {
    b.csv = fopen (csv_path, "a");
    if (!b.csv) {
      g_printerr ("sonar-bench: %s: %s\n", csv_path, g_strerror (errno));
      return 1;
    }
    if (ftell (b.csv) == 0)
      fprintf (b.csv, "sweep,value,scene,pings,found,total,false_positives,"
          "mean_error,max_error,ms_spectra,ms_imaging,ms_clustering,"
          "ms_velocity,ms_total,pings_per_second\n");
  }

  b.setup = make_setup (&error);
  if (!b.setup) {
    g_printerr ("sonar-bench: %s\n", error->message);
    return 1;
  }
  for (guint s = 0; s < N_SCENES; s++) {
    double t = now_ms ();

    if (!needed[s])
      continue;
    if (!render_scene (&scenes[s], b.setup, &error)) {
      g_printerr ("sonar-bench: %s\n", error->message);
      return 1;
    }
    g_printerr ("rendered %u pings of %s in %.1f s\n", scenes[s].n_pings,
        scenes[s].name, (now_ms () - t) * 1e-3);
  }
  g_print ("sonar-bench: %u microphones, %u emitters, %u samples per ping; "
      "velocity on %u thread%s; times are medians over the pings, ms per "
      "ping; errors in m/s\n", b.setup->geometry.n_microphones,
      b.setup->geometry.n_emitters, b.setup->ping_length, b.n_threads,
      b.n_threads > 1 ? "s" : "");

  b.banks = g_hash_table_new_full (g_str_hash, g_str_equal, g_free,
      (GDestroyNotify) sonar_doppler_bank_unref);
  b.results = g_hash_table_new_full (g_str_hash, g_str_equal, g_free,
      result_free);
  for (guint i = 0; i < selected->len; i++)
    ok &= run_sweep (&b, g_ptr_array_index (selected, i));

  getrusage (RUSAGE_SELF, &usage);
  g_print ("\npeak RSS %.1f MB; whole run %.1f s\n", usage.ru_maxrss / 1024.0,
      (now_ms () - start) * 1e-3);

  g_hash_table_unref (b.results);
  g_hash_table_unref (b.banks);
  sonar_setup_unref (b.setup);
  for (guint s = 0; s < N_SCENES; s++) {
    g_free (scenes[s].pings);
    g_free (scenes[s].truths);
  }
  if (b.csv)
    fclose (b.csv);
  return ok ? 0 : 1;
}
