/* sonar-bench: the project's benchmark.
 *
 * Processes a fixed set of pings of the fig10 and fig9 presets (and of
 * seeded random scenes) through the DSP core the way the elements do
 * (dopplerbank ! mimobeamform ! wardcluster ! velocityest, with their
 * defaults), scores the detections against the simulator's ground truth,
 * times every stage and measures the memory it holds. Each sweep changes
 * one setting; each row is one configuration.
 *
 *   sonar-bench                         the elements' defaults, both scenes
 *   sonar-bench --sweep linkage         Ward vs SLINK (paper Fig. 10) and more
 *   sonar-bench --all --csv bench.csv   every sweep, rows appended to a CSV
 *   sonar-bench --quick                 fig10, 2 pings: linkage and refine
 *
 * Sweeps (fig10 unless said): linkage, refine, window (velocity window),
 * bank-step, directions, focus-zones, hypotheses (fig9: detection
 * hypotheses), emitters (emitters in the Doppler-ACF product: 8, 6, 4, 2,
 * 1), template-interpolation (templates read band-limited, linearly or by
 * nearest sample; their error against the exact templates in dB),
 * range-resolution (the image's range step, asked 0.001-0.04 m; the
 * band's bins bound it too, at 2.8 mm), bank-size (bank -v..v at 0.05
 * m/s for v = 0.4, 1, 3, 7: cost against bank size), reflectors (seeded
 * random scenes of 0 (noise only), 1, 5, 20 and 50 point reflectors, 2
 * pings each: cost against reflectors) and datacube (the full datacube, an image per bank
 * velocity with the velocity read at each centroid's pixel, against the
 * proposed chain on the first fig10 ping with a -1..1 m/s bank; the
 * paper's Fig. 11 measured on the Doppler-ACF curves at the true
 * reflectors), coarse-spacing and refine-db (the imager's coarse to fine
 * pass: coarse grid 0-6 degrees, refinement level 10-30 dB) and
 * hemisphere (issue 5's 3-D goal: 91 x 91 directions at 2 degrees, one
 * fig10 ping, coarse grids of 4, 6 and 8 degrees and the dense image).
 * The "work" column is the share of the dense image's direction x zone x
 * hypothesis passes the imager made.
 *
 * The sensor is sonarsrc's default, built by a copy of its make_setup ()
 * logic; the velocity stage shares the centroids between worker threads as
 * velocityest does (--threads). Every ping is rendered before anything is
 * timed: the simulator's cost is not counted. Times are wall-clock medians
 * over at least --timed-pings pings (20; a scene with fewer goes round
 * them again, each scored once) after an untimed warm-up on the first, ms
 * per ping, with the 10th-90th percentile spread, plus the chain's CPU
 * time (median). Set-up work (the
 * Doppler bank, FFT plans, the imager's tables) is not timed, as the
 * elements do it once per stream. A configuration two sweeps share
 * (linkage=ward is refine=on) runs once.
 *
 * Memory is the heap each stage holds (glibc mallinfo2: FFTW and GLib
 * allocate through malloc), counted when its objects are made and while
 * it warms up on the first ping (buffers made on first use); the bank is
 * dopplerbank's. Thread stacks are not heap and not counted. Peak RSS is
 * the process's during the configuration's run (Linux resets it per run),
 * rendered pings and banks of earlier runs included.
 *
 * tools/plot-bench.py draws the CSV.
 */
#include <complex.h>
#include <errno.h>
#include <gio/gio.h>
#include <malloc.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/resource.h>
#include <time.h>

#include "sonar-cluster.h"
#include "sonar-doppler-bank.h"
#include "sonar-imager.h"
#include "sonar-interp.h"
#include "sonar-rng.h"
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

/* The random scenes: point reflectors at 0.5-4.5 m, -60..60 degrees, radial
 * velocities -0.4..0.4 m/s, far enough apart to be objects of their own. */
#define RANDOM_SCENE_SEED 5
#define RANDOM_RANGE_MIN 0.5
#define RANDOM_RANGE_MAX 4.5
#define RANDOM_AZIMUTH 60.0
#define RANDOM_SPEED 0.4
#define RANDOM_SEPARATION 0.25

/* The datacube sweep's bank, -reach..reach at the scene's step (m/s). */
#define DATACUBE_REACH 1.0

#define MB (1024.0 * 1024.0)

typedef struct
{
  const char *name;
  SonarScenePreset preset;
  guint n_random;               /* > 0: that many random point reflectors
                                 * instead of the preset */
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
  SCENE_RANDOM_FIRST,
  N_SCENES = SCENE_RANDOM_FIRST + 5,
};

static BenchScene scenes[N_SCENES] = {
  {"fig10", SONAR_SCENE_PRESET_FIG10, 0, -0.4, 0.4, 0.02, 9},
  {"fig9", SONAR_SCENE_PRESET_FIG9, 0, -7.0, 7.0, 0.05, 5},
  {"empty", SONAR_SCENE_PRESET_EMPTY, 0, -0.4, 0.4, 0.02, 2},
  {"rand1", SONAR_SCENE_PRESET_EMPTY, 1, -0.4, 0.4, 0.02, 2},
  {"rand5", SONAR_SCENE_PRESET_EMPTY, 5, -0.4, 0.4, 0.02, 2},
  {"rand20", SONAR_SCENE_PRESET_EMPTY, 20, -0.4, 0.4, 0.02, 2},
  {"rand50", SONAR_SCENE_PRESET_EMPTY, 50, -0.4, 0.4, 0.02, 2},
};

enum
{
  STAGE_SPECTRA,
  STAGE_IMAGING,
  STAGE_CLUSTERING,
  STAGE_VELOCITY,
  N_STAGES,
};

static const char *const stage_names[N_STAGES] = {
  "spectra", "imaging", "cluster", "velocity"
};

typedef enum
{
  /* Detection image over a few hypotheses, Doppler-ACF product in a
   * window around each centroid: the elements. */
  METHOD_PROPOSED,
  /* An image per bank velocity; each centroid's velocity is the one whose
   * image is strongest at its pixel (paper Fig. 3). */
  METHOD_DATACUBE,
} Method;

typedef struct
{
  BenchScene *scene;
  guint n_pings;                /* the scene's first pings */
  double v_min, v_max, v_step;  /* the bank */
  SonarTemplateInterp template_interp;
  double hypothesis_spacing;
  Method method;
  /* Fig. 11: the Doppler-ACF curves at the true reflectors of the first
   * ping, measured after it is timed. */
  gboolean measure_curves;
  SonarImagerParams imager;
  SonarClusterParams cluster;
  SonarVelocityParams velocity;
} Config;

typedef struct
{
  char *label;                  /* sweep=value of the run that made it */
  guint pings, found, total, false_positives;
  guint timed_pings;
  guint near_found;
  double sum_error, near_sum_error, max_error;
  double centroids;             /* per ping */
  double ms[N_STAGES];          /* medians over the pings */
  /* The imager's direction x zone x hypothesis passes over the dense
   * image's, mean over the pings (coarse to fine). */
  double work_fraction;
  double ms_total;
  double ms_total_low, ms_total_high;   /* 10th and 90th percentiles */
  /* Per stage, the least time its arithmetic (clustering: its reads of
   * the image) takes at the CPU's measured peak on the cores it uses. */
  double floor_ms[N_STAGES];
  /* CPU time of the whole chain: other processes on the machine inflate
   * the wall-clock times, not this. */
  double cpu_ms_total;
  double bank_mb, mb[N_STAGES]; /* heap held */
  double peak_rss_mb;
  guint bank_velocities;
  /* Per ping: bank velocities the velocity stage evaluated, summed over
   * the centroids (its work grows with this, not with the image). */
  double evaluated_velocities;
  double template_error_db;     /* the bank's templates against exact ones */
  /* Fig. 11, per true reflector of the first ping (NaN where the curve
   * has none): peak-to-sidelobe ratio in dB (a lower bound where the main
   * lobe reaches the bank's edge), -3 dB width in m/s. */
  guint n_curves;
  double *psr_db, *width;
  gboolean *psr_bounded;
  double range_step;            /* the image's, m */
  guint n_range;
} Result;

struct _Bench;

typedef struct
{
  const char *name;
  guint scene;
  guint n_values;
  /* Changes value @i on @c, made with the scene's defaults, and names it
   * into @label. */
  void (*apply) (Config * c, guint i, char *label, gsize size);
  /* Instead of configurations: a sweep that renders its own pings one at
   * a time (the sensitivity sweeps). */
  gboolean (*run) (struct _Bench * b);
} Sweep;

typedef struct
{
  SonarDopplerBank *bank;
  double mb;                    /* heap it holds */
  double template_error_db;
} BankEntry;

typedef struct _Bench
{
  SonarSetup *setup;
  guint n_threads;              /* velocity workers */
  /* Each configuration times at least this many pings, going round its
   * rendered ones again when it has fewer (each scored once). */
  guint timed_pings;
  /* This CPU, measured at start: fused multiply-adds per core (GFLOP/s)
   * and the rate one core reads memory at (GB/s). */
  double peak_gflops, read_gbs;
  GHashTable *banks;            /* "min/max/step/interp" -> BankEntry */
  GHashTable *results;          /* configuration key -> Result */
  FILE *csv;
  double peak_rss_mb;           /* the whole run's: each run resets the
                                 * kernel's */
} Bench;

/* A configuration's chain, made once per run. */
typedef struct
{
  const Config *config;
  BankEntry *bank;
  const SonarBand *band;
  const SonarImageGrid *grid;
  guint n_emitters;             /* in the velocity product */
  SonarSpectrum *analyzer;
  SonarImager *imager;
  SonarClusterer *clusterer;
  SonarVelocityPool *workers;   /* METHOD_PROPOSED */
  /* The images' Doppler hypotheses: the detection's, or every bank
   * velocity for the datacube. */
  guint n_templates;
  SonarHypothesis *hypotheses;
  SonarComplex *spectra;
  float *image;
  float *cube;                  /* METHOD_DATACUBE: n_templates images */
  float *curve;                 /* a bank's worth of Doppler-ACF values */
  SonarCentroid centroids[MAX_CENTROIDS];
  SonarVelocityEstimate results[2 * MAX_CENTROIDS];
  guint counts[MAX_CENTROIDS];
  /* Detections of the ping, and the bank velocities evaluated for it. */
  guint n_detections;
  guint evaluated_velocities;
  SonarVec3 positions[2 * MAX_CENTROIDS];
  double velocities[2 * MAX_CENTROIDS];
} Chain;


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

/* Heap in use, MB: FFTW and GLib allocate through malloc, and mallinfo2
 * sums every thread's arena. */
static double
heap_mb (void)
{
  const struct mallinfo2 m = mallinfo2 ();

  return (m.uordblks + m.hblkhd) / MB;
}

/* Restarts the kernel's peak-RSS count (VmHWM), so that a run's peak is
 * its own; only on Linux. */
static void
reset_peak_rss (void)
{
  FILE *f = fopen ("/proc/self/clear_refs", "w");

  if (f) {
    fputs ("5", f);
    fclose (f);
  }
}

/* Peak RSS since reset_peak_rss (), MB; the whole run's where the kernel
 * does not say. */
static double
peak_rss_mb (void)
{
  FILE *f = fopen ("/proc/self/status", "r");
  struct rusage usage;
  char line[256];
  double kb = -1.0;

  while (f && fgets (line, sizeof (line), f))
    if (g_str_has_prefix (line, "VmHWM:"))
      kb = g_ascii_strtod (line + 6, NULL);
  if (f)
    fclose (f);
  if (kb < 0.0) {
    getrusage (RUSAGE_SELF, &usage);
    kb = usage.ru_maxrss;
  }
  return kb / 1024.0;
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

/* The @fraction quantile of @v (nearest rank), sorted in place. */
static double
percentile (double *v, guint n, double fraction)
{
  qsort (v, n, sizeof (double), compare_doubles);
  return v[MIN (n - 1, (guint) floor (fraction * n))];
}

static double
mean_of (const double *v, guint n)
{
  double sum = 0.0;
  guint count = 0;

  for (guint i = 0; i < n; i++) {
    if (isfinite (v[i])) {
      sum += v[i];
      count++;
    }
  }
  return count ? sum / count : NAN;
}

/* sonarsrc's default sensor, built as its make_setup () does without
 * geometry or waveforms files: the built-in array, the noise waveforms of
 * seed 1, a window holding the whole echo of an object at max-range seen
 * from the farthest element. */
static SonarSetup *
make_setup (double max_range, GError ** error)
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
    setup = sonar_setup_new (&(SonarSetupParams) {
          .sample_rate = wp.sample_rate,
          .speed_of_sound = SONAR_DEFAULT_SPEED_OF_SOUND,
          .band_low = wp.band_low, .band_high = wp.band_high,
          .geometry = &geometry, .waveform_length = wp.length,
          .waveforms = waveforms,
          .ping_length = sonar_ping_length_for_range (&geometry,
              SONAR_DEFAULT_SPEED_OF_SOUND, wp.sample_rate, wp.length,
              max_range)}, error);
  sonar_geometry_clear (&geometry);
  return setup;
}

/* @n seeded point reflectors in the y = 0 plane, moving radially. */
static void
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
  c->n_pings = scene->n_pings;
  c->v_min = scene->v_min;
  c->v_max = scene->v_max;
  c->v_step = scene->v_step;
  c->template_interp = SONAR_TEMPLATE_BAND_LIMITED;
  c->hypothesis_spacing = HYPOTHESIS_SPACING;
  c->method = METHOD_PROPOSED;
  c->measure_curves = FALSE;
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

  return g_strdup_printf ("%s %u %d %d | %.17g %.17g %.17g %d %.17g | "
      "%.17g %.17g %u %.17g %.17g %u %.17g %.17g %.17g %u %.17g %.17g | %d "
      "%.17g %.17g "
      "%d %d %.17g %u %.17g %u | %u %u %d %.17g %u %.17g %.17g %u",
      c->scene->name, c->n_pings, c->method, c->measure_curves, c->v_min,
      c->v_max, c->v_step, c->template_interp, c->hypothesis_spacing,
      i->azimuth_min, i->azimuth_max, i->n_azimuth, i->elevation_min,
      i->elevation_max, i->n_elevation, i->range_min, i->range_max,
      i->range_resolution, i->focus_zones, i->coarse_spacing, i->refine_db,
      k->range_compensation,
      k->threshold_db, k->absolute_threshold, k->linkage, k->stop,
      k->inconsistency, k->depth, k->distance, k->max_peaks,
      v->window_directions, v->window_ranges, v->refine, v->min_variance,
      v->min_agreeing_emitters, v->min_coherence, v->second_peak_db,
      v->emitters);
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

static const char *const template_interp_names[] = {
  [SONAR_TEMPLATE_BAND_LIMITED] = "hermite4x",
  [SONAR_TEMPLATE_LINEAR] = "linear",
  [SONAR_TEMPLATE_NEAREST] = "nearest",
};

static void
bank_entry_free (gpointer data)
{
  BankEntry *e = data;

  sonar_doppler_bank_unref (e->bank);
  g_free (e);
}

/* Banks are set-up work: made once per velocity grid and shared. */
static BankEntry *
get_bank (Bench * b, const Config * c, GError ** error)
{
  g_autofree char *key = g_strdup_printf ("%.17g/%.17g/%.17g/%d", c->v_min,
      c->v_max, c->v_step, c->template_interp);
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

/* The arithmetic floor ---------------------------------------------------*/

/* Independent chains of fused multiply-adds, enough of them to fill the
 * pipelines: the core's peak. Where AVX2 and FMA are missing, the same
 * loop as the compiler makes it for the baseline. */
#define PEAK_CHAINS 12
typedef float PeakVec __attribute__ ((vector_size (32)));

#if defined(__x86_64__) && defined(__GNUC__)
__attribute__ ((target ("avx2,fma")))
#endif
static float
peak_loop (guint iterations)
{
  PeakVec acc[PEAK_CHAINS], a = { 0 }, b = { 0 };
  float sum = 0.0f;

  for (int l = 0; l < 8; l++) {
    a[l] = 0.999f + 1e-5f * l;
    b[l] = 1e-6f * l;
  }
  for (int c = 0; c < PEAK_CHAINS; c++)
    acc[c] = a * (float) c;
  for (guint i = 0; i < iterations; i++) {
    for (int c = 0; c < PEAK_CHAINS; c++)
      acc[c] = acc[c] * a + b;
    /* Keeps the compiler from folding the loop. */
    __asm__ volatile ("" : "+x" (a));
  }
  for (int c = 0; c < PEAK_CHAINS; c++)
    for (int l = 0; l < 8; l++)
      sum += acc[c][l];
  return sum;
}

/* GFLOP/s of one core (2 flops per lane of a fused multiply-add): the
 * best of a few runs of about 20 ms (others share the machine). */
static double
measure_peak_gflops (void)
{
  const guint iterations = 1000000;
  double best = 0.0;
  volatile float sink;

  for (int run = 0; run < 5; run++) {
    const double start = clock_ms (CLOCK_THREAD_CPUTIME_ID);
    double ms;
    sink = peak_loop (iterations);
    ms = clock_ms (CLOCK_THREAD_CPUTIME_ID) - start;
    best = MAX (best, 2.0 * 8 * PEAK_CHAINS * (double) iterations /
        (ms * 1e6));
  }
  (void) sink;
  return best;
}

/* GB/s one core reads a 64 MB array at (far beyond the caches). */
static double
measure_read_gbs (void)
{
  const gsize n = 16 * 1024 * 1024;
  g_autofree float *v = g_new (float, n);
  double best = 0.0;
  volatile float sink;

  for (gsize i = 0; i < n; i++)
    v[i] = (float) (i & 7);
  for (int run = 0; run < 3; run++) {
    const double start = clock_ms (CLOCK_THREAD_CPUTIME_ID);
    float sum[8] = { 0 };
    double ms;
    for (gsize i = 0; i < n; i += 8)
      for (int l = 0; l < 8; l++)
        sum[l] += v[i + l];
    sink = sum[0] + sum[7];
    ms = clock_ms (CLOCK_THREAD_CPUTIME_ID) - start;
    best = MAX (best, n * sizeof (float) / (ms * 1e6));
  }
  (void) sink;
  return best;
}

/* Flops of a complex transform of @n points, as FFTW counts them. */
static double
fft_flops (double n)
{
  return 5.0 * n * log2 (n);
}

/* The floors of one ping, from what it did: @units and @passes the
 * imager's (sonar_imager_last_work ()), @centroids and @evaluations (bank
 * velocities evaluated, over the centroids) the velocity stage's. Each
 * stage on the cores it uses. The counts are the arithmetic of the
 * method as implemented, not of a cleverer one:
 *   spectra     a real transform per microphone (2.5 N log2 N);
 *   imaging     per unit the receive sum (8 flops per microphone and bin:
 *               a complex multiply-add, the phasor's rotation shared),
 *               per pass the transmit sum (8 per emitter and bin), the
 *               product (6 per bin), the inverse transform and the
 *               envelope (3 per range bin);
 *   clustering  two reads of the image at the measured read rate;
 *   velocity    per centroid the receive sums of its window's directions
 *               (three calls: direction search, bank pass, around the
 *               peak), per evaluated velocity and window direction and
 *               emitter the block sums (14 per bin) and the window's lags
 *               (8 per block and lag). */
static void
arithmetic_floors (const Bench * b, const Chain * ch, guint units,
    guint passes, guint centroids, double evaluations, double *floor_ms)
{
  const SonarSetup *setup = b->setup;
  const double J = setup->geometry.n_microphones;
  const double N = ch->n_emitters;
  const double K = ch->band->n_bins;
  const double F = ch->band->fft_size;
  const double R = ch->grid->n_range;
  const double M = round (0.5 * setup->speed_of_sound * F /
      setup->sample_rate / ch->grid->range_step);
  const SonarVelocityParams *vp = &ch->config->velocity;
  const double window = (2.0 * vp->window_directions + 1) *
      (ch->grid->n_elevation > 1 ? 2.0 * vp->window_directions + 1 : 1.0);
  const double lags = 2.0 * vp->window_ranges + 1;
  const double cores = g_get_num_processors ();
  const double per_core_ms = 1.0 / (b->peak_gflops * 1e6);
  double flops[N_STAGES];

  flops[STAGE_SPECTRA] = J * 0.5 * fft_flops (F);
  flops[STAGE_IMAGING] = units * 8.0 * J * K + passes * (8.0 * N * K +
      6.0 * K + fft_flops (M) + 3.0 * R);
  flops[STAGE_CLUSTERING] = 0.0;
  flops[STAGE_VELOCITY] = centroids * 3.0 * window * 8.0 * J * K +
      evaluations * window * N * (14.0 * K + 8.0 * lags * K / 16.0);
  floor_ms[STAGE_SPECTRA] = flops[STAGE_SPECTRA] * per_core_ms;
  floor_ms[STAGE_IMAGING] = flops[STAGE_IMAGING] * per_core_ms / cores;
  floor_ms[STAGE_CLUSTERING] = 2.0 * sonar_image_grid_size (ch->grid) *
      sizeof (float) / (b->read_gbs * 1e6);
  floor_ms[STAGE_VELOCITY] = flops[STAGE_VELOCITY] * per_core_ms /
      MIN (cores, b->n_threads);
}

/* The chain --------------------------------------------------------------*/

static void
chain_clear (Chain * ch)
{
  g_clear_pointer (&ch->analyzer, sonar_spectrum_free);
  g_clear_pointer (&ch->imager, sonar_imager_free);
  g_clear_pointer (&ch->clusterer, sonar_clusterer_free);
  g_clear_pointer (&ch->workers, sonar_velocity_pool_free);
  g_clear_pointer (&ch->hypotheses, g_free);
  g_clear_pointer (&ch->spectra, g_free);
  g_clear_pointer (&ch->image, g_free);
  g_clear_pointer (&ch->cube, g_free);
  g_clear_pointer (&ch->curve, g_free);
}

/* Makes @c's stages as the elements do at start, charging each the heap
 * its objects take. */
static gboolean
chain_init (Chain * ch, Bench * b, const Config * c, Result * r,
    GError ** error)
{
  const guint n_mics = b->setup->geometry.n_microphones;
  g_autofree guint *indices = NULL;
  SonarDopplerBank *bank;
  SonarClusterParams cluster;
  guint nv;
  double heap;

  ch->config = c;
  ch->bank = get_bank (b, c, error);
  if (!ch->bank)
    return FALSE;
  bank = ch->bank->bank;
  nv = sonar_doppler_bank_n_velocities (bank);
  ch->band = sonar_doppler_bank_band (bank);
  ch->n_emitters = c->velocity.emitters ? c->velocity.emitters :
      b->setup->geometry.n_emitters;
  r->bank_mb = ch->bank->mb;
  r->bank_velocities = nv;
  r->template_error_db = ch->bank->template_error_db;
  indices = g_new (guint, nv + 2);

  heap = heap_mb ();
  ch->analyzer = sonar_spectrum_new (ch->band);
  ch->spectra = g_new (SonarComplex, (gsize) n_mics * ch->band->n_bins);
  r->mb[STAGE_SPECTRA] = heap_mb () - heap;

  heap = heap_mb ();
  ch->imager = sonar_imager_new (b->setup, ch->band, &c->imager, error);
  if (!ch->imager)
    return FALSE;
  ch->grid = sonar_imager_grid (ch->imager);
  r->range_step = ch->grid->range_step;
  r->n_range = ch->grid->n_range;
  if (c->method == METHOD_DATACUBE) {
    ch->n_templates = nv;
    for (guint i = 0; i < nv; i++)
      indices[i] = i;
  } else {
    ch->n_templates = sonar_doppler_bank_hypotheses (bank,
        c->hypothesis_spacing, indices);
  }
  ch->hypotheses = g_new (SonarHypothesis, ch->n_templates);
  for (guint h = 0; h < ch->n_templates; h++)
    ch->hypotheses[h] = sonar_doppler_bank_hypothesis (bank, indices[h]);
  ch->image = g_new (float, sonar_image_grid_size (ch->grid));
  if (c->method == METHOD_DATACUBE)
    ch->cube = g_new (float, ch->n_templates *
        sonar_image_grid_size (ch->grid));
  r->mb[STAGE_IMAGING] = heap_mb () - heap;

  heap = heap_mb ();
  /* As wardcluster reads it from the energyscape's caps. */
  cluster = c->cluster;
  cluster.hypotheses = ch->n_templates;
  ch->clusterer = sonar_clusterer_new (ch->grid, &cluster, error);
  if (!ch->clusterer)
    return FALSE;
  r->mb[STAGE_CLUSTERING] = heap_mb () - heap;

  heap = heap_mb ();
  if (c->method == METHOD_DATACUBE) {
    ch->curve = g_new (float, nv);
  } else {
    ch->workers = sonar_velocity_pool_new (bank, ch->grid, &c->velocity,
        b->n_threads, error);
    if (!ch->workers)
      return FALSE;
  }
  r->mb[STAGE_VELOCITY] = heap_mb () - heap;
  return TRUE;
}

static void
chain_spectra (Chain * ch, const float *samples, guint n_mics, gsize length)
{
  for (guint j = 0; j < n_mics; j++)
    sonar_spectrum_process (ch->analyzer, samples + j, length, n_mics,
        ch->spectra + (gsize) j * ch->band->n_bins, NULL);
}

static void
chain_imaging (Chain * ch)
{
  const gsize size = sonar_image_grid_size (ch->grid);

  if (!ch->cube) {
    sonar_imager_process (ch->imager, ch->spectra, ch->n_templates,
        ch->hypotheses, -1, ch->image);
    return;
  }
  sonar_imager_process_each (ch->imager, ch->spectra, ch->n_templates,
      ch->hypotheses, -1, ch->cube, size);
  /* What the datacube detects on: each pixel at its best velocity. */
  memcpy (ch->image, ch->cube, size * sizeof (float));
  for (guint h = 1; h < ch->n_templates; h++)
    for (gsize i = 0; i < size; i++)
      ch->image[i] = MAX (ch->image[i], ch->cube[h * size + i]);
}

/* The datacube's Doppler-ACF curve at pixel (@e, @a, @i): per velocity, the
 * MIMO image's maximum over the velocity estimator's window (eq. 15). */
static void
cube_curve (Chain * ch, int e, int a, int i)
{
  const SonarImageGrid *g = ch->grid;
  const SonarVelocityParams *p = &ch->config->velocity;
  const int wd = p->window_directions, wr = p->window_ranges;
  const int we = g->n_elevation > 1 ? wd : 0;
  const gsize size = sonar_image_grid_size (g);

  for (guint v = 0; v < ch->n_templates; v++) {
    const float *image = ch->cube + v * size;
    float best = 0.0f;

    for (int ee = MAX (e - we, 0); ee <= MIN (e + we,
            (int) g->n_elevation - 1); ee++)
      for (int aa = MAX (a - wd, 0); aa <= MIN (a + wd,
              (int) g->n_azimuth - 1); aa++)
        for (int ii = MAX (i - wr, 0); ii <= MIN (i + wr,
                (int) g->n_range - 1); ii++)
          best = MAX (best, image[((gsize) ee * g->n_azimuth + aa) *
                  g->n_range + ii]);
    ch->curve[v] = best;
  }
}

/* Grid index nearest @x on the axis first + k step, k < n. */
static int
nearest_index (double x, double first, double step, guint n)
{
  return n > 1 ? (int) CLAMP (round ((x - first) / step), 0, n - 1) : 0;
}

static void
cube_curve_at (Chain * ch, double range, double azimuth, double elevation)
{
  const SonarImageGrid *g = ch->grid;

  cube_curve (ch, nearest_index (elevation, g->elevation_first,
          g->elevation_step, g->n_elevation), nearest_index (azimuth,
          g->azimuth_first, g->azimuth_step, g->n_azimuth),
      nearest_index (range, g->range_first, g->range_step, g->n_range));
}

/* The velocity of the datacube curve's peak, refined below the bank's step
 * by a parabola through the log of its neighbours. */
static double
cube_curve_velocity (Chain * ch)
{
  SonarDopplerBank *bank = ch->bank->bank;
  const float *curve = ch->curve;
  guint p = 0;
  double v;

  for (guint i = 1; i < ch->n_templates; i++)
    if (curve[i] > curve[p])
      p = i;
  v = sonar_doppler_bank_velocity (bank, p);
  if (ch->config->velocity.refine && p > 0 && p + 1 < ch->n_templates
      && curve[p - 1] > 0.0f && curve[p + 1] > 0.0f) {
    const double a = log (curve[p - 1]), b = log (curve[p]);
    const double c = log (curve[p + 1]), denom = a - 2.0 * b + c;

    if (denom < 0.0)
      v += sonar_doppler_bank_step (bank) * CLAMP (0.5 * (a - c) / denom,
          -0.5, 0.5);
  }
  return v;
}

/* The ping's detections: the estimator's valid ones, or every datacube
 * centroid at its curve's peak (the datacube has no false-positive test). */
static void
chain_velocity (Chain * ch, guint n_centroids)
{
  ch->n_detections = 0;
  if (ch->cube) {
    for (guint k = 0; k < n_centroids; k++) {
      const SonarCentroid *c = &ch->centroids[k];

      cube_curve (ch, c->peak_elevation_index, c->peak_azimuth_index,
          c->peak_range_index);
      ch->positions[ch->n_detections] = c->position;
      ch->velocities[ch->n_detections++] = cube_curve_velocity (ch);
    }
    return;
  }
  sonar_velocity_pool_estimate (ch->workers, ch->spectra, ch->centroids,
      n_centroids, ch->results, ch->counts);
  ch->evaluated_velocities = 0;
  for (guint k = 0; k < n_centroids; k++) {
    const SonarVelocityEstimate *e = &ch->results[2 * k];

    ch->evaluated_velocities += e[0].evaluated_velocities;
    for (guint i = 0; i < ch->counts[k]; i++) {
      if (!e[i].valid)
        continue;
      ch->positions[ch->n_detections] = sonar_vec3_scale
          (sonar_vec3_from_direction (e[i].azimuth, e[i].elevation),
          e[i].range);
      ch->velocities[ch->n_detections++] = e[i].radial_velocity;
    }
  }
}

/* Peak-to-sidelobe ratio (dB) and -3 dB width (m/s) of a Doppler-ACF curve
 * in dB over a bank of @step. The main lobe ends at the first minimum on
 * either side; where it reaches the bank's edge instead, the edge stands
 * for the sidelobe, and *bounded says the ratio is only a lower bound. */
static void
curve_shape (const float *db, guint n, double step, double *psr,
    double *width, gboolean * bounded)
{
  float side = -INFINITY;
  guint p = 0, lo, hi, w = 1;

  *bounded = FALSE;
  if (!isfinite (db[0])) {
    *psr = *width = NAN;
    return;
  }
  for (guint v = 1; v < n; v++)
    if (db[v] > db[p])
      p = v;
  for (lo = p; lo > 0 && db[lo - 1] <= db[lo]; lo--);
  for (hi = p; hi + 1 < n && db[hi + 1] <= db[hi]; hi++);
  for (guint v = 0; v < n; v++)
    if (v < lo || v > hi)
      side = MAX (side, db[v]);
  if ((lo == 0 && lo != p && db[0] > side) || (hi == n - 1 && hi != p
          && db[n - 1] > side)) {
    side = MAX (lo == 0 && lo != p ? db[0] : -INFINITY,
        hi == n - 1 && hi != p ? db[n - 1] : -INFINITY);
    *bounded = TRUE;
  }
  *psr = db[p] - side;
  for (guint v = p; v > 0 && db[v - 1] >= db[p] - 3.0f; v--)
    w++;
  for (guint v = p; v + 1 < n && db[v + 1] >= db[p] - 3.0f; v++)
    w++;
  *width = w * step;
}

/* Fig. 11: the Doppler-ACF curve, in dB, at each of the ping's @n true
 * reflectors: the product of the emitters' curves as
 * sonar_velocity_estimate () gives it, or the MIMO image's across the
 * datacube at the reflector's pixel. */
static gboolean
measure_curves (Chain * ch, const SonarTruth * truths, guint n, Result * r,
    GError ** error)
{
  SonarDopplerBank *bank = ch->bank->bank;
  const guint nv = sonar_doppler_bank_n_velocities (bank);
  g_autoptr (SonarVelocityEstimator) est = NULL;
  g_autofree float *curves = NULL;
  g_autofree float *db = g_new (float, nv);

  if (!ch->cube) {
    est = sonar_velocity_estimator_new (bank, ch->grid,
        &ch->config->velocity, error);
    if (!est)
      return FALSE;
    curves = g_new (float, (gsize) (ch->n_emitters + 1) * nv);
  }
  r->n_curves = n;
  r->psr_db = g_new (double, n);
  r->width = g_new (double, n);
  r->psr_bounded = g_new (gboolean, n);
  for (guint k = 0; k < n; k++) {
    const SonarTruth *t = &truths[k];

    if (est) {
      const SonarCentroid at = sonar_velocity_point (t->range, t->azimuth,
          t->elevation);
      SonarVelocityEstimate e[2];

      sonar_velocity_estimate (est, ch->spectra, &at, e, curves);
      /* The last curve is the product per emitter. */
      for (guint v = 0; v < nv; v++)
        db[v] = ch->n_emitters * curves[(gsize) ch->n_emitters * nv + v];
    } else {
      cube_curve_at (ch, t->range, t->azimuth, t->elevation);
      for (guint v = 0; v < nv; v++)
        db[v] = 20.0f * log10f (ch->curve[v] + 1e-30f);
    }
    curve_shape (db, nv, sonar_doppler_bank_step (bank), &r->psr_db[k],
        &r->width[k], &r->psr_bounded[k]);
  }
  return TRUE;
}

/* Times a stage of a ping; on the warm-up ping charges what the heap grows
 * by to the stage instead (buffers made on first use are part of what it
 * holds). */
typedef struct
{
  gboolean first;
  double heap, start;
} StageClock;

static void
stage_start (StageClock * clock)
{
  if (clock->first)
    clock->heap = heap_mb ();
  clock->start = now_ms ();
}

static double
stage_stop (StageClock * clock, Result * r, guint stage)
{
  const double ms = now_ms () - clock->start;

  if (clock->first)
    r->mb[stage] += MAX (heap_mb () - clock->heap, 0.0);
  return ms;
}

/* One configuration over the scene's pings: the stages of dopplerbank,
 * mimobeamform (mode=detection, or datacube), wardcluster and
 * velocityest. */
static gboolean
run_config (Bench * b, const Config * c, Result * r, GError ** error)
{
  const BenchScene *s = c->scene;
  const guint n_pings = c->n_pings;
  const guint n_timed = MAX (n_pings, b->timed_pings);
  const guint n_mics = b->setup->geometry.n_microphones;
  const gsize length = b->setup->ping_length;
  g_autofree Chain *ch = g_new0 (Chain, 1);
  g_autofree double *times = NULL;
  guint total_centroids = 0;
  gboolean ok;

  reset_peak_rss ();
  ok = chain_init (ch, b, c, r, error);
  /* Per ping: the stages, the total, its CPU time. */
  times = g_new (double, (N_STAGES + 2) * n_timed);
  /* Ping -1 is a warm-up on the first ping, neither timed nor scored: it
   * takes the page faults of fresh buffers and ORC's first compilations,
   * and its heap growth is the stages' working memory. */
  for (int q = -1; ok && q < (int) n_timed; q++) {
    const guint p = MAX (q, 0) % n_pings;
    const float *samples = s->pings + p * length * n_mics;
    const SonarTruth *truths = s->truths + p * s->n_reflectors;
    const double cpu_start = clock_ms (CLOCK_PROCESS_CPUTIME_ID);
    StageClock clock = { q < 0 };
    double t[N_STAGES], total = 0.0;
    guint n_centroids, units, dense_units, passes, dense_passes;

    stage_start (&clock);
    chain_spectra (ch, samples, n_mics, length);
    t[STAGE_SPECTRA] = stage_stop (&clock, r, STAGE_SPECTRA);
    stage_start (&clock);
    chain_imaging (ch);
    t[STAGE_IMAGING] = stage_stop (&clock, r, STAGE_IMAGING);
    sonar_imager_last_work (ch->imager, &units, &dense_units, &passes,
        &dense_passes);
    stage_start (&clock);
    n_centroids = sonar_clusterer_process (ch->clusterer, ch->image,
        ch->centroids, MAX_CENTROIDS);
    t[STAGE_CLUSTERING] = stage_stop (&clock, r, STAGE_CLUSTERING);
    stage_start (&clock);
    chain_velocity (ch, n_centroids);
    t[STAGE_VELOCITY] = stage_stop (&clock, r, STAGE_VELOCITY);
    if (q < 0)
      continue;

    r->work_fraction += (double) passes / dense_passes / n_timed;
    if (!ch->cube) {
      double floor_ms[N_STAGES];
      arithmetic_floors (b, ch, units, passes, n_centroids,
          ch->evaluated_velocities, floor_ms);
      for (guint k = 0; k < N_STAGES; k++)
        r->floor_ms[k] += floor_ms[k] / n_timed;
    }

    times[(N_STAGES + 1) * n_timed + q] =
        clock_ms (CLOCK_PROCESS_CPUTIME_ID) - cpu_start;
    for (guint k = 0; k < N_STAGES; k++) {
      times[k * n_timed + q] = t[k];
      total += t[k];
    }
    times[N_STAGES * n_timed + q] = total;
    /* A ping timed again is not scored again. */
    if ((guint) q >= n_pings)
      continue;
    total_centroids += n_centroids;
    r->evaluated_velocities += (double) ch->evaluated_velocities / n_pings;
    score_ping (r, truths, s->n_reflectors, ch->positions, ch->velocities,
        ch->n_detections);
    if (p == 0 && c->measure_curves)
      ok = measure_curves (ch, truths, s->n_reflectors, r, error);
  }
  r->peak_rss_mb = peak_rss_mb ();
  b->peak_rss_mb = MAX (b->peak_rss_mb, r->peak_rss_mb);
  chain_clear (ch);
  if (!ok)
    return FALSE;

  r->pings = n_pings;
  r->centroids = (double) total_centroids / n_pings;
  r->timed_pings = n_timed;
  for (guint k = 0; k < N_STAGES; k++)
    r->ms[k] = median (times + k * n_timed, n_timed);
  r->ms_total = median (times + N_STAGES * n_timed, n_timed);
  r->ms_total_low = percentile (times + N_STAGES * n_timed, n_timed, 0.1);
  r->ms_total_high = percentile (times + N_STAGES * n_timed, n_timed, 0.9);
  r->cpu_ms_total = median (times + (N_STAGES + 1) * n_timed, n_timed);
  return TRUE;
}

static void
result_free (gpointer data)
{
  Result *r = data;

  g_free (r->label);
  g_free (r->psr_db);
  g_free (r->width);
  g_free (r->psr_bounded);
  g_free (r);
}

static double
mean_error (const Result * r)
{
  return r->found ? r->sum_error / r->found : NAN;
}

static double
chain_mb (const Result * r)
{
  double sum = r->bank_mb;

  for (guint k = 0; k < N_STAGES; k++)
    sum += r->mb[k];
  return sum;
}

static double
ms_per_centroid (const Result * r)
{
  return r->centroids > 0.0 ? r->ms[STAGE_VELOCITY] / r->centroids : NAN;
}

/* Velocity-stage time per evaluated bank velocity, microseconds. */
static double
us_per_evaluation (const Result * r)
{
  return r->evaluated_velocities > 0.0 ? 1e3 * r->ms[STAGE_VELOCITY] /
      r->evaluated_velocities : NAN;
}

/* Sweeps ------------------------------------------------------------------*/

/* A sweep that sets one field of the configuration to each of a list of
 * values, labelled with the value. */
#define FIELD_SWEEP(name, field, type, format, ...)                       \
static void                                                             \
name (Config * c, guint i, char *label, gsize size)                     \
{                                                                       \
  static const type values[] = { __VA_ARGS__ };                         \
                                                                        \
  c->field = values[i];                                                 \
  g_snprintf (label, size, format, values[i]);                          \
}

static void
apply_baseline (Config * c, guint i, char *label, gsize size)
{
  config_init (c, &scenes[i]);
  g_strlcpy (label, scenes[i].name, size);
}

/* The linkage sweep: every method of sonar-linkage.h. */
static void
apply_linkage (Config * c, guint i, char *label, gsize size)
{
  guint n;
  const SonarLinkageInfo *methods = sonar_linkage_methods (&n);

  c->cluster.linkage = methods[i].linkage;
  g_strlcpy (label, methods[i].nick, size);
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

FIELD_SWEEP (apply_bank_step, v_step, double, "%g", 0.01, 0.02, 0.05, 0.1)

FIELD_SWEEP (apply_directions, imager.n_azimuth, guint, "%u", 61, 91, 181, 361)

FIELD_SWEEP (apply_focus_zones, imager.focus_zones, guint, "%u", 1, 2, 4, 8)

FIELD_SWEEP (apply_coarse_spacing, imager.coarse_spacing, double, "%g",
    0.0, 2.0, 3.0, 4.0, 6.0)

FIELD_SWEEP (apply_refine_db, imager.refine_db, double, "%g",
    10.0, 15.0, 20.0, 30.0)

/* Issue 5's 3-D goal: the frontal hemisphere at 2 degrees (91 x 91
 * directions), the Fig. 10 bank, one ping; coarse spacings of 4 to 8
 * degrees (0: dense, every direction in full). */
static void
apply_hemisphere (Config * c, guint i, char *label, gsize size)
{
  static const double spacings[] = { 4.0, 6.0, 8.0, 0.0 };

  c->n_pings = 1;
  c->imager.n_azimuth = c->imager.n_elevation = 91;
  c->imager.elevation_min = -90.0;
  c->imager.elevation_max = 90.0;
  c->imager.coarse_spacing = spacings[i];
  g_snprintf (label, size, "%g", spacings[i]);
}

FIELD_SWEEP (apply_hypotheses, hypothesis_spacing, double, "%g", 0.15, 0.3, 0.6)

static void
apply_emitters (Config * c, guint i, char *label, gsize size)
{
  static const guint counts[] = { 8, 6, 4, 2, 1 };

  /* 0 is all 8: the baseline's run. */
  c->velocity.emitters = i == 0 ? 0 : counts[i];
  g_snprintf (label, size, "%u", counts[i]);
}

static const SonarTemplateInterp template_interps[] = {
  SONAR_TEMPLATE_BAND_LIMITED, SONAR_TEMPLATE_LINEAR, SONAR_TEMPLATE_NEAREST,
};

static void
apply_template_interp (Config * c, guint i, char *label, gsize size)
{
  c->template_interp = template_interps[i];
  g_strlcpy (label, template_interp_names[template_interps[i]], size);
}

/* The image's step is also bounded by the band: with the default
 * sensor, 2.8 mm at most, so the coarser values change nothing. */
FIELD_SWEEP (apply_range_resolution, imager.range_resolution, double, "%g",
    0.001, 0.002, 0.005, 0.01, 0.02, 0.04)

static void
apply_bank_size (Config * c, guint i, char *label, gsize size)
{
  static const double reach[] = { 0.4, 1.0, 3.0, 7.0 };

  c->v_min = -reach[i];
  c->v_max = reach[i];
  c->v_step = 0.05;
  g_snprintf (label, size, "%g", reach[i]);
}

static void
apply_reflectors (Config * c, guint i, char *label, gsize size)
{
  config_init (c, &scenes[SCENE_RANDOM_FIRST + i]);
  g_snprintf (label, size, "%u", c->scene->n_random);
}

static void
apply_datacube (Config * c, guint i, char *label, gsize size)
{
  /* One ping: the datacube images every bank velocity. A bank wider than
   * fig10's: one emitter's Doppler main lobe is 0.33 m/s wide, and within
   * +-0.4 m/s the curves' sidelobes mostly fall beyond the bank's edges. */
  c->n_pings = 1;
  c->v_min = -DATACUBE_REACH;
  c->v_max = DATACUBE_REACH;
  c->measure_curves = TRUE;
  c->method = i == 0 ? METHOD_PROPOSED : METHOD_DATACUBE;
  g_strlcpy (label, i == 0 ? "proposed" : "datacube", size);
}

/* Sensitivity ------------------------------------------------------------
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

static guint noise_pings = NOISE_PINGS;
static guint detection_pings = DETECTION_PINGS;

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

static void
interleave (const float *planar, guint n_mics, gsize length, float *out)
{
  for (guint j = 0; j < n_mics; j++)
    for (gsize i = 0; i < length; i++)
      out[i * n_mics + j] = planar[j * length + i];
}

/* One ping through an initialised chain; returns the centroids. */
static guint
chain_run_ping (Chain * ch, const float *samples, guint n_mics,
    gsize length)
{
  guint n;

  chain_spectra (ch, samples, n_mics, length);
  chain_imaging (ch);
  n = sonar_clusterer_process (ch->clusterer, ch->image, ch->centroids,
      MAX_CENTROIDS);
  chain_velocity (ch, n);
  return n;
}

static void write_sensitivity_row (FILE * csv, const char *sweep,
    const char *value, const char *scene, guint pings, guint found,
    guint total, guint false_positives, double mean_error,
    double max_error);

static gboolean
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
  SonarSimulatorParams sp;
  SonarScene scene;
  guint centroids = 0, false_objects = 0, pings_with_false = 0;
  guint max_centroids = 0;
  double k, k_eff;

  config_init (&c_chain, &scenes[SCENE_FIG9]);
  c_dense = c_chain;
  c_dense.imager.coarse_spacing = 0.0;
  sonar_simulator_params_init_default (&sp);
  sp.noise_amplitude = NOISE_AMPLITUDE;
  sp.seed = NOISE_SEED;
  sim = sonar_simulator_new (b->setup, &sp, &error);
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
      chain_spectra (dense, samples, n_mics, length);
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

static gboolean
run_detection (Bench * b)
{
  g_autoptr (GError) error = NULL;
  g_autoptr (SonarSetup) setup = make_setup (SENSITIVITY_MAX_RANGE, &error);
  g_autoptr (SonarSimulator) sim = NULL;
  g_autofree Chain *ch = g_new0 (Chain, 1);
  g_autofree double *times = g_new (double, MAX (GOAL_PINGS, 1));
  SonarSetup *saved = b->setup;
  SonarSimulatorParams sp;
  Result r = { 0 };
  Config c;
  guint found, false_objects, total_false = 0;
  double sum_error, max_error, worst = 0.0, sum_all = 0.0;
  guint found_all = 0;
  gboolean ok;

  if (!setup)
    goto fail;
  sonar_simulator_params_init_default (&sp);
  sp.noise_amplitude = NOISE_AMPLITUDE;
  sp.seed = NOISE_SEED;
  sim = sonar_simulator_new (setup, &sp, &error);
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

static guint split_pings = SPLIT_PINGS;
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

static gboolean
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
  SonarSimulatorParams sp;
  Result r = { 0 };
  Config c;

  sonar_simulator_params_init_default (&sp);
  sp.noise_amplitude = NOISE_AMPLITUDE;
  sp.seed = NOISE_SEED;
  sim = sonar_simulator_new (b->setup, &sp, &error);
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

static const Sweep sweeps[] = {
  {"baseline", SCENE_FIG10, SCENE_FIG9 + 1, apply_baseline},
  {"linkage", SCENE_FIG10, SONAR_LINKAGE_CENTROID + 1, apply_linkage},
  {"refine", SCENE_FIG10, 2, apply_refine},
  {"window", SCENE_FIG10, 9, apply_window},
  {"bank-step", SCENE_FIG10, 4, apply_bank_step},
  {"directions", SCENE_FIG10, 4, apply_directions},
  {"focus-zones", SCENE_FIG10, 4, apply_focus_zones},
  {"hypotheses", SCENE_FIG9, 3, apply_hypotheses},
  {"emitters", SCENE_FIG10, 5, apply_emitters},
  {"template-interpolation", SCENE_FIG10, G_N_ELEMENTS (template_interps),
      apply_template_interp},
  {"range-resolution", SCENE_FIG10, 6, apply_range_resolution},
  {"bank-size", SCENE_FIG10, 4, apply_bank_size},
  {"reflectors", SCENE_FIG10, N_SCENES - SCENE_RANDOM_FIRST,
      apply_reflectors},
  {"datacube", SCENE_FIG10, 2, apply_datacube},
  {"coarse-spacing", SCENE_FIG10, 5, apply_coarse_spacing},
  {"refine-db", SCENE_FIG10, 4, apply_refine_db},
  {"hemisphere", SCENE_FIG10, 4, apply_hemisphere},
  {"noise", SCENE_FIG9, 0, NULL, run_noise},
  {"detection", SCENE_FIG9, 0, NULL, run_detection},
  {"split", SCENE_FIG9, 0, NULL, run_split},
};

static const Sweep *
find_sweep (const char *name)
{
  for (guint i = 0; i < G_N_ELEMENTS (sweeps); i++)
    if (g_str_equal (sweeps[i].name, name))
      return &sweeps[i];
  return NULL;
}

/* Value @i of @sweep on its scene's defaults. */
static void
sweep_config (const Sweep * sweep, guint i, Config * c, char *label,
    gsize size)
{
  config_init (c, &scenes[sweep->scene]);
  sweep->apply (c, i, label, size);
}

/* Output ------------------------------------------------------------------*/

#define CSV_HEADER "sweep,value,scene,pings,found,total,false_positives," \
  "mean_error,max_error,ms_spectra,ms_imaging,ms_clustering,ms_velocity," \
  "ms_total,pings_per_second,cpu_ms_total,mb_bank,mb_spectra,mb_imaging," \
  "mb_clustering,mb_velocity,mb_chain,peak_rss_mb,centroids," \
  "bank_velocities,ms_velocity_per_centroid,template_error_db,psr_db," \
  "lobe_width,n_range,range_step,imaging_work,evaluated_velocities," \
  "us_velocity_per_evaluation,timed_pings,ms_total_p10,ms_total_p90," \
  "floor_ms_spectra,floor_ms_imaging,floor_ms_clustering,floor_ms_velocity"

/* A row of a sensitivity sweep (noise, detection, split): the columns up
 * to max_error, the timing and memory ones empty. */
static void
write_sensitivity_row (FILE * csv, const char *sweep, const char *value,
    const char *scene, guint pings, guint found, guint total,
    guint false_positives, double mean_error, double max_error)
{
  fprintf (csv, "%s,%s,%s,%u,%u,%u,%u,%.6g,%.6g", sweep, value, scene, pings,
      found, total, false_positives, mean_error, max_error);
  for (const char *c = strchr (CSV_HEADER, ','); c; c = strchr (c + 1, ','))
    if (c > strstr (CSV_HEADER, "max_error"))
      fputc (',', csv);
  fputc ('\n', csv);
  fflush (csv);
}

static void
print_header (const Sweep * sweep)
{
  g_print ("\n%s\n", sweep->name);
  g_print ("  %-9s %-6s %5s %7s %3s %9s %9s %5s %8s %8s %5s %8s %9s %9s "
      "%11s %8s %9s %5s\n", "value", "scene", "pings", "found", "FP",
      "mean m/s", "max m/s", "cent", "spectra", "imaging", "work", "cluster",
      "velocity", "total ms", "p10-p90", "pings/s", "cpu ms", "timed");
}

static void
print_row (const char *value, const Config * c, const Result * r,
    const char *same_as)
{
  g_autofree char *found = g_strdup_printf ("%u/%u", r->found, r->total);

  g_autofree char *spread = g_strdup_printf ("%.1f-%.1f", r->ms_total_low,
      r->ms_total_high);

  g_print ("  %-9s %-6s %5u %7s %3u %9.4f %9.4f %5.1f %8.1f %8.1f %5.2f "
      "%8.1f %9.1f %9.1f %11s %8.3f %9.1f %5u", value, c->scene->name,
      r->pings, found, r->false_positives, mean_error (r), r->max_error,
      r->centroids, r->ms[STAGE_SPECTRA], r->ms[STAGE_IMAGING],
      r->work_fraction, r->ms[STAGE_CLUSTERING], r->ms[STAGE_VELOCITY],
      r->ms_total, spread, 1e3 / r->ms_total, r->cpu_ms_total,
      r->timed_pings);
  if (same_as)
    g_print ("  (the %s run)", same_as);
  g_print ("\n");
}

/* @x in a column of @width with @decimals, "-" for NaN. */
static void
print_number (double x, int width, int decimals)
{
  if (isnan (x))
    g_print (" %*s", width, "-");
  else
    g_print (" %*.*f", width, decimals, x);
}

static void
print_memory_header (void)
{
  g_print ("  memory held (MB; bank: dopplerbank's templates and spectra) "
      "and growth\n");
  g_print ("  %-9s %-6s %7s %7s %7s %7s %8s %7s %7s %6s %9s %6s %7s %8s "
      "%7s %7s %6s %6s\n", "value", "scene", "bank", "spectra", "imaging",
      "cluster", "velocity", "chain", "RSS", "bank v", "ms/cent", "evals",
      "us/eval", "tmpl dB", "PSR dB", "3dB m/s", "ranges", "dr mm");
}

static void
print_memory_row (const char *value, const Config * c, const Result * r)
{
  g_print ("  %-9s %-6s %7.1f", value, c->scene->name, r->bank_mb);
  for (guint k = 0; k < N_STAGES; k++)
    print_number (r->mb[k], k == STAGE_VELOCITY ? 8 : 7, 1);
  g_print (" %7.1f %7.0f %6u", chain_mb (r), r->peak_rss_mb,
      r->bank_velocities);
  print_number (ms_per_centroid (r), 9, 2);
  print_number (r->evaluated_velocities, 6, 0);
  print_number (us_per_evaluation (r), 7, 1);
  print_number (r->template_error_db, 8, 1);
  print_number (r->n_curves ? mean_of (r->psr_db, r->n_curves) : NAN, 7, 1);
  print_number (r->n_curves ? mean_of (r->width, r->n_curves) : NAN, 7, 3);
  g_print (" %6u %6.2f\n", r->n_range, r->range_step * 1e3);
}

static void
print_efficiency_header (const Bench * b)
{
  g_print ("  arithmetic floor (ms per ping at this CPU's %.1f GFLOP/s per "
      "core and %.1f GB/s read, on the cores each stage uses) and time "
      "over floor\n", b->peak_gflops, b->read_gbs);
  g_print ("  %-9s %-6s", "value", "scene");
  for (guint k = 0; k < N_STAGES; k++)
    g_print (" %9s %6s", stage_names[k], "x");
  g_print ("\n");
}

static void
print_efficiency_row (const char *value, const Config * c, const Result * r)
{
  g_print ("  %-9s %-6s", value, c->scene->name);
  for (guint k = 0; k < N_STAGES; k++) {
    print_number (r->floor_ms[k] > 0.0 ? r->floor_ms[k] : NAN, 9, 2);
    print_number (r->floor_ms[k] > 0.0 ? r->ms[k] / r->floor_ms[k] : NAN,
        6, 1);
  }
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
  fprintf (csv, ",%.6g,%.6g,%.6g,%.6g", r->ms_total, 1e3 / r->ms_total,
      r->cpu_ms_total, r->bank_mb);
  for (guint k = 0; k < N_STAGES; k++)
    fprintf (csv, ",%.6g", r->mb[k]);
  fprintf (csv, ",%.6g,%.6g,%.6g,%u,%.6g,%.6g,%.6g,%.6g,%u,%.6g,%.4g,%.6g,"
      "%.6g,%u,%.6g,%.6g", chain_mb (r), r->peak_rss_mb, r->centroids,
      r->bank_velocities, ms_per_centroid (r), r->template_error_db,
      r->n_curves ? mean_of (r->psr_db, r->n_curves) : NAN,
      r->n_curves ? mean_of (r->width, r->n_curves) : NAN, r->n_range,
      r->range_step, r->work_fraction, r->evaluated_velocities,
      us_per_evaluation (r), r->timed_pings, r->ms_total_low,
      r->ms_total_high);
  for (guint k = 0; k < N_STAGES; k++)
    fprintf (csv, ",%.6g", r->floor_ms[k]);
  fprintf (csv, "\n");
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

/* Reflector @k's ratio, ">" marking a lower bound, and width. */
static void
print_psr (const Result * r, guint k)
{
  g_autofree char *psr = g_strdup_printf ("%s%.1f", r->psr_bounded[k] ?
      ">" : "", r->psr_db[k]);

  g_print (" %12s", isnan (r->psr_db[k]) ? "-" : psr);
  print_number (r->width[k], 10, 3);
}

/* The paper's Fig. 11, per true reflector of the first fig10 ping. */
static void
print_datacube_vs_proposed (const Result * proposed, const Result * cube)
{
  const BenchScene *s = &scenes[SCENE_FIG10];

  g_print ("\nFull datacube vs proposed, first fig10 ping, bank -%g..%g / "
      "%g m/s (paper Fig. 11): %.1fx the time, %.1fx the memory.\nDoppler-ACF curves at the true "
      "reflectors: the product of the emitters' curves (dB of the product, "
      "N times\nits dB per emitter) against the datacube's MIMO image at "
      "the reflector's pixel (dB): peak-to-sidelobe\nratio (>: the main "
      "lobe reaches the bank's edge, which bounds it) and -3 dB width in "
      "m/s\n", DATACUBE_REACH, DATACUBE_REACH, s->v_step,
      cube->ms_total / proposed->ms_total,
      chain_mb (cube) / chain_mb (proposed));
  g_print ("  %7s %7s %9s %12s %10s %12s %10s\n", "range", "azimuth",
      "v m/s", "product PSR", "3 dB", "cube PSR", "3 dB");
  for (guint k = 0; k < MIN (proposed->n_curves, cube->n_curves); k++) {
    const SonarTruth *t = &s->truths[k];

    g_print ("  %7.2f %7.1f %9.3f", t->range, t->azimuth,
        t->radial_velocity);
    print_psr (proposed, k);
    print_psr (cube, k);
    g_print ("\n");
  }
}

static gboolean
run_sweep (Bench * b, const Sweep * sweep)
{
  const Result *ward = NULL, *slink = NULL, *proposed = NULL, *cube = NULL;
  g_autofree const Result **rows = g_new0 (const Result *, sweep->n_values);
  g_autofree Config *configs = g_new (Config, sweep->n_values);
  char values[16][32];
  gboolean ok = TRUE;

  if (sweep->run)
    return sweep->run (b);
  g_assert (sweep->n_values <= G_N_ELEMENTS (values));
  print_header (sweep);
  for (guint i = 0; i < sweep->n_values; i++) {
    g_autoptr (GError) error = NULL;
    g_autofree char *key = NULL;
    const char *same_as = NULL;
    Config *c = &configs[i];
    Result *r;

    sweep_config (sweep, i, c, values[i], sizeof (values[i]));
    key = config_key (c);
    r = g_hash_table_lookup (b->results, key);
    if (r) {
      same_as = r->label;
    } else {
      double start = now_ms ();

      r = g_new0 (Result, 1);
      r->label = g_strdup_printf ("%s=%s", sweep->name, values[i]);
      g_printerr ("%s: %u pings of %s\n", r->label, c->n_pings,
          c->scene->name);
      if (!run_config (b, c, r, &error)) {
        g_printerr ("%s: %s\n", r->label, error->message);
        result_free (r);
        ok = FALSE;
        continue;
      }
      g_printerr ("%s: done in %.1f s\n", r->label,
          (now_ms () - start) * 1e-3);
      g_hash_table_insert (b->results, g_steal_pointer (&key), r);
    }
    rows[i] = r;
    print_row (values[i], c, r, same_as);
    if (b->csv)
      write_csv_row (b->csv, sweep->name, values[i], c, r);
    if (sweep->apply == apply_linkage) {
      if (c->cluster.linkage == SONAR_LINKAGE_WARD)
        ward = r;
      else if (c->cluster.linkage == SONAR_LINKAGE_SINGLE)
        slink = r;
    } else if (sweep->apply == apply_datacube) {
      if (c->method == METHOD_DATACUBE)
        cube = r;
      else
        proposed = r;
    }
  }
  print_memory_header ();
  for (guint i = 0; i < sweep->n_values; i++)
    if (rows[i])
      print_memory_row (values[i], &configs[i], rows[i]);
  print_efficiency_header (b);
  for (guint i = 0; i < sweep->n_values; i++)
    if (rows[i])
      print_efficiency_row (values[i], &configs[i], rows[i]);
  if (ward && slink)
    print_ward_vs_slink (ward, slink);
  if (proposed && cube)
    print_datacube_vs_proposed (proposed, cube);
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

static gboolean
parse_noise_pings (const char *option_name, const char *value,
    gpointer data, GError ** error)
{
  return parse_pings (option_name, value, &noise_pings, error);
}

static gboolean
parse_detection_pings (const char *option_name, const char *value,
    gpointer data, GError ** error)
{
  return parse_pings (option_name, value, &detection_pings, error);
}

static gboolean
parse_split_pings (const char *option_name, const char *value,
    gpointer data, GError ** error)
{
  return parse_pings (option_name, value, &split_pings, error);
}

/* Opens @path to append rows, with the header if it is new; a file of
 * other columns (an older sonar-bench's) is refused. */
static FILE *
open_csv (const char *path, GError ** error)
{
  FILE *csv = fopen (path, "a+");
  char line[1024] = "";

  if (!csv) {
    g_set_error (error, G_FILE_ERROR, g_file_error_from_errno (errno),
        "%s: %s", path, g_strerror (errno));
    return NULL;
  }
  rewind (csv);
  if (!fgets (line, sizeof (line), csv)) {
    fprintf (csv, "%s\n", CSV_HEADER);
    return csv;
  }
  if (!g_str_equal (g_strchomp (line), CSV_HEADER)) {
    g_set_error (error, G_FILE_ERROR, G_FILE_ERROR_INVAL, "%s: its columns "
        "are not this sonar-bench's; write to a new file", path);
    fclose (csv);
    return NULL;
  }
  return csv;
}

int
main (int argc, char **argv)
{
  g_auto (GStrv) sweep_names = NULL;
  g_autofree char *csv_path = NULL;
  g_autoptr (GOptionContext) context = NULL;
  g_autoptr (GError) error = NULL;
  g_autoptr (GPtrArray) selected = g_ptr_array_new ();
  g_autoptr (GString) sweep_help = g_string_new ("Run this sweep "
      "(repeatable):");
  gboolean all = FALSE, quick = FALSE, needed[N_SCENES] = { FALSE };
  gboolean ok = TRUE;
  int threads = 0, timed_pings = 20;
  Bench b = { 0 };
  double start = now_ms ();
  GOptionEntry entries[] = {
    {"sweep", 's', 0, G_OPTION_ARG_STRING_ARRAY, &sweep_names, NULL,
        "NAME"},
    {"all", 'a', 0, G_OPTION_ARG_NONE, &all,
        "Run every sweep but baseline", NULL},
    {"quick", 'q', 0, G_OPTION_ARG_NONE, &quick,
        "Only 2 fig10 pings and the linkage and refine sweeps", NULL},
    {"csv", 'c', 0, G_OPTION_ARG_FILENAME, &csv_path,
        "Append one row per configuration to this CSV file", "FILE"},
    {"fig10-pings", 0, 0, G_OPTION_ARG_CALLBACK, parse_fig10_pings,
        "Pings of the fig10 drive (default 9)", "N"},
    {"fig9-pings", 0, 0, G_OPTION_ARG_CALLBACK, parse_fig9_pings,
        "Pings of the fig9 world (default 5)", "N"},
    {"timed-pings", 0, 0, G_OPTION_ARG_INT, &timed_pings,
        "Pings timed per configuration, at least (default 20): a scene "
          "with fewer goes round them again, each scored once", "N"},
    {"noise-pings", 0, 0, G_OPTION_ARG_CALLBACK, parse_noise_pings,
        "Pings of the noise sweep (default 1000)", "N"},
    {"detection-pings", 0, 0, G_OPTION_ARG_CALLBACK, parse_detection_pings,
        "Pings per SNR and range of the detection sweep (default 20)", "N"},
    {"split-pings", 0, 0, G_OPTION_ARG_CALLBACK, parse_split_pings,
        "Pings per separation and velocity difference of the split sweep "
          "(default 10)", "N"},
    {"threads", 't', 0, G_OPTION_ARG_INT, &threads,
        "Velocity workers, as velocityest's threads (default 0: one per "
          "processor)", "N"},
    {NULL}
  };

  for (guint i = 0; i < G_N_ELEMENTS (sweeps); i++)
    g_string_append_printf (sweep_help, "%s %s", i ? "," : "",
        sweeps[i].name);
  entries[0].description = sweep_help->str;
  context = g_option_context_new ("- time and score the sonar's DSP chain");
  g_option_context_set_summary (context, "Processes fixed pings of the "
      "fig10 and fig9 presets (and of random scenes) through the DSP core "
      "as the elements do and prints, per configuration, the objects found, "
      "false positives, velocity errors against the truth, the median time "
      "per ping of each stage and the memory each holds. Without a sweep: "
      "the elements' defaults on both scenes.");
  g_option_context_set_description (context, "Sweeps, each on fig10 unless "
      "said:\n"
      "  linkage, refine, window   clustering linkage, peak refinement, "
      "velocity window\n"
      "  bank-step, bank-size      bank step; bank -v..v / 0.05 for v = "
      "0.4, 1, 3, 7\n"
      "  directions, focus-zones   image directions, near-field focus "
      "zones\n"
      "  range-resolution          image range step 0.001-0.04 m (the band "
      "bounds it too)\n"
      "  hypotheses                detection hypotheses' spacing (fig9)\n"
      "  emitters                  emitters in the Doppler-ACF product: 8, "
      "6, 4, 2, 1\n"
      "  template-interpolation    templates read band-limited (hermite4x), "
      "linearly or by\n"
      "                            nearest sample; error against exact "
      "templates in dB\n"
      "  reflectors                random scenes of 0, 1, 5, 20, 50 reflectors, "
      "2 pings each\n"
      "  datacube                  the full datacube against the proposed "
      "chain, first fig10\n"
      "                            ping, bank -1..1 m/s; Doppler-ACF "
      "peak-to-sidelobe ratios\n"
      "                            (paper Fig. 11)\n"
      "  coarse-spacing, refine-db  the imager's coarse grid (0: dense) and "
      "refinement level\n"
      "  hemisphere                3-D, 91 x 91 directions at 2 degrees, "
      "one fig10 ping,\n"
      "                            coarse grids of 4, 6, 8 degrees and "
      "dense\n"
      "Sensitivity sweeps (minutes; not in --all), pings rendered one at a "
      "time, the defaults:\n"
      "  noise                     noise-only pings: the false-alarm model "
      "against the measured\n"
      "                            exceedance, false objects "
      "(--noise-pings)\n"
      "  detection                 probability of detection against "
      "per-channel SNR at 2, 5,\n"
      "                            8 m; the 7 m / -28 dB goal "
      "(--detection-pings)\n"
      "  split                     pairs 0.5-3 cm apart in range at one "
      "azimuth, velocities\n"
      "                            0.4-5 m/s apart: share split into two "
      "objects; false splits\n"
      "                            of single objects, presets and random "
      "scenes (--split-pings)\n");
  g_option_context_add_main_entries (context, entries, NULL);
  if (!g_option_context_parse (context, &argc, &argv, &error)) {
    g_printerr ("sonar-bench: %s\n", error->message);
    return 2;
  }
  if (threads < 0 || threads > SONAR_VELOCITY_MAX_THREADS) {
    g_printerr ("sonar-bench: --threads must be 0 to %d\n",
        SONAR_VELOCITY_MAX_THREADS);
    return 2;
  }
  if (timed_pings < 1 || timed_pings > 100000) {
    g_printerr ("sonar-bench: --timed-pings must be 1 to 100000\n");
    return 2;
  }
  b.timed_pings = (guint) timed_pings;
  b.peak_gflops = measure_peak_gflops ();
  b.read_gbs = measure_read_gbs ();
  b.n_threads = CLAMP (threads ? (guint) threads : g_get_num_processors (),
      1, SONAR_VELOCITY_MAX_THREADS);

  if (quick) {
    scenes[SCENE_FIG10].n_pings = 2;
    g_ptr_array_add (selected, (gpointer) find_sweep ("linkage"));
    g_ptr_array_add (selected, (gpointer) find_sweep ("refine"));
  } else if (all) {
    /* The sensitivity sweeps take minutes: only by name. */
    for (guint i = 1; i < G_N_ELEMENTS (sweeps); i++)
      if (!sweeps[i].run)
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

    for (guint v = 0; v < sweep->n_values; v++) {
      char label[32];
      Config c;

      sweep_config (sweep, v, &c, label, sizeof (label));
      needed[c.scene - scenes] = TRUE;
    }
  }

  if (csv_path) {
    b.csv = open_csv (csv_path, &error);
    if (!b.csv) {
      g_printerr ("sonar-bench: %s\n", error->message);
      return 1;
    }
  }

  b.setup = make_setup (MAX_RANGE, &error);
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

  b.peak_rss_mb = peak_rss_mb ();
  b.banks = g_hash_table_new_full (g_str_hash, g_str_equal, g_free,
      bank_entry_free);
  b.results = g_hash_table_new_full (g_str_hash, g_str_equal, g_free,
      result_free);
  for (guint i = 0; i < selected->len; i++)
    ok &= run_sweep (&b, g_ptr_array_index (selected, i));

  g_print ("\npeak RSS %.1f MB; whole run %.1f s\n", b.peak_rss_mb,
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
