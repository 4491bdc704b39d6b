/* sonar-bench's shared types and functions.
 *
 * The program, one concern a file:
 *   scenes.c       the bench's scenes (the presets and seeded random
 *                  scenes), the sensor, the rendered pings and the Doppler
 *                  banks the configurations share;
 *   chain.c        the chain as the elements run it: per configuration
 *                  made, timed and scored, with the memory each stage holds
 *                  and the arithmetic floor of each stage;
 *   sweeps.c       the sweeps (each changes one setting of the elements'
 *                  defaults) and the runs of their configurations;
 *   sensitivity.c  the noise, detection and split sweeps, which render
 *                  their own pings one at a time;
 *   crowded.c      the crowded sweep: grids and random scenes of many
 *                  objects against an oracle bound;
 *   nearfar.c      the near-far sweep: the dynamic range between a strong
 *                  near object and a normal one;
 *   scalloping.c   what a coarse grid of directions loses between them;
 *   output.c       the tables and the CSV;
 *   ../sonar-bench.c  the options and main ().
 */
#ifndef SONAR_BENCH_H
#define SONAR_BENCH_H

#include <stdio.h>

#include "sonar-cluster.h"
#include "sonar-doppler-bank.h"
#include "sonar-egomotion.h"
#include "sonar-imager.h"
#include "sonar-simulator.h"
#include "sonar-direct-path.h"
#include "sonar-residual.h"
#include "sonar-spectrum.h"
#include "sonar-track.h"
#include "sonar-velocity.h"

G_BEGIN_DECLS

/* sonarsrc's defaults. */
#define MAX_RANGE 5.0
#define PING_RATE 12.0
#define NOISE_AMPLITUDE 0.01
#define NOISE_SEED 0

/* mimobeamform's, wardcluster's and velocityest's. */
#define HYPOTHESIS_SPACING 0.3
#define MAX_CENTROIDS 1024

/* How test-pipeline.c scores: a detection this close to a true object
 * matches it. */
#define MATCH_DISTANCE 0.05

/* The random scenes' seed; the sensitivity sweeps draw their reflectors
 * from it too. */
#define RANDOM_SCENE_SEED 5

/* The datacube sweep's bank, -reach..reach at the scene's step (m/s). */
#define DATACUBE_REACH 1.0

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
  SCENE_CROSSING,
  SCENE_RANDOM_FIRST,
  N_SCENES = SCENE_RANDOM_FIRST + 5,
};

enum
{
  STAGE_SPECTRA,
  STAGE_IMAGING,
  STAGE_CLUSTERING,
  STAGE_VELOCITY,
  /* sonartrack: the ping's ego-motion and the tracker. */
  STAGE_TRACKING,
  N_STAGES,
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
  /* The sensor's microphones hear its emitters straight (the simulator's
   * direct_path coupling, added to the scene's pings untimed); dopplerbank's
   * direct-path. */
  double direct_path;
  SonarDirectPathMode direct_path_mode;
  guint direct_path_taps;
  /* velocityest's residual-search (part of the velocity stage). */
  gboolean residual_search;
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
  double cpu_ms_velocity;       /* the velocity stage's, all its threads */
  double cpu_ms_spectra, cpu_ms_clustering;     /* the same, theirs */
  double cpu_ms_imaging;        /* the same, the imager's (all its workers) */
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
  gboolean slow;                /* minutes: only by name, not in --all */
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
   * on its widest vectors (peak_isa names them) and the rate one core
   * reads memory at (GB/s). */
  double peak_gflops, read_gbs;
  const char *peak_isa;
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
  SonarChannelSpectra *analyzer;
  SonarDirectPath *direct_path; /* dopplerbank's default, direct-path=auto */
  SonarImager *imager;
  SonarClusterer *clusterer;
  SonarVelocityPool *workers;   /* METHOD_PROPOSED */
  SonarResidualSearch *residual;        /* Config.residual_search */
  SonarEgoEstimator *ego;
  SonarTracker *tracker;
  SonarSigmaModel sigma;
  SonarMeasurement measurements[2 * MAX_CENTROIDS];
  SonarEgoLabel labels[2 * MAX_CENTROIDS];
  SonarEgoMotion ego_motion;
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

/* scenes.c */
extern BenchScene scenes[N_SCENES];
extern const char *const template_interp_names[];

void random_scene_init (SonarScene * scene, guint n);
/* A simulator of @setup at the bench's noise seed, its white noise
 * @noise_amplitude (NOISE_AMPLITUDE; 0 for noise-free recordings). */
SonarSimulator *bench_simulator_new (SonarSetup * setup,
    double noise_amplitude, GError ** error);
/* What @setup's microphones hear straight from its emitters at @coupling
 * (the simulator's direct_path), noise-free, interleaved as sonarsrc
 * sends a ping (g_free it); NULL with @error. */
float *direct_path_ping (SonarSetup * setup, double coupling,
    GError ** error);
/* @planar (@n_mics rows of @length samples) into @out, interleaved as
 * sonarsrc emits it. */
void interleave (const float *planar, guint n_mics, gsize length,
    float *out);
/* The spectra (into ch->spectra) of @object alone in @scene (NULL: an
 * empty one), rendered by @quiet, a noise-free simulator of @setup: what
 * the oracle, the cancellation bound and the scalloping sweep image. */
void render_alone (Chain * ch, SonarSimulator * quiet,
    const SonarSetup * setup, const SonarScene * scene,
    const SonarReflector * object);
gboolean render_scene (BenchScene * s, SonarSetup * setup, GError ** error);
void bank_entry_free (gpointer data);
BankEntry *get_bank (Bench * b, const Config * c, GError ** error);

/* chain.c: timing and memory */
double now_ms (void);
double heap_mb (void);
double peak_rss_mb (void);
double median (double *v, guint n);
double measure_peak_gflops (const char **isa);
double measure_read_gbs (void);

/* chain.c: the chain */
gboolean chain_init (Chain * ch, Bench * b, const Config * c, Result * r,
    GError ** error);
void chain_clear (Chain * ch);
/* The spectra of @length frames of interleaved microphone samples. */
void chain_spectra (Chain * ch, const float *samples, gsize length);
void chain_imaging (Chain * ch);
guint chain_run_ping (Chain * ch, const float *samples, guint n_mics,
    gsize length);
void chain_tracking (Chain * ch, double ping_time);
gboolean run_config (Bench * b, const Config * c, Result * r,
    GError ** error);

/* sweeps.c */
extern const Sweep sweeps[];
extern const guint n_sweeps;

void config_init (Config * c, BenchScene * scene);
void result_free (gpointer data);
void sweep_config (const Sweep * sweep, guint i, Config * c, char *label,
    gsize size);
gboolean run_sweep (Bench * b, const Sweep * sweep);

/* sensitivity.c */
extern guint noise_pings;
extern guint detection_pings;
extern guint split_pings;

gboolean run_noise (Bench * b);
gboolean run_detection (Bench * b);
gboolean run_split (Bench * b);
gboolean run_uncertainty (Bench * b);

/* crowded.c */
extern gboolean crowded_cancel_bound;

/* dB above the interference at which the defaults must find an object. */
#define ORACLE_DB 13.0

gboolean run_crowded (Bench * b);
/* The oracle (crowded.c's top): dB by which @object (@truth its truth)
 * stands above the interference at its true pixel in the chain's image,
 * @whole the spectra of the whole ping (@ch's, noise included), @quiet a
 * noise-free simulator; NaN with @error. */
double oracle_margin_db (Chain * ch, SonarSimulator * quiet,
    SonarSetup * setup, const SonarReflector * object,
    const SonarTruth * truth, const SonarComplex * whole, GError ** error);

/* nearfar.c */
extern guint near_far_pings;

gboolean run_near_far (Bench * b);

/* scalloping.c */
gboolean run_scalloping (Bench * b);

/* output.c */
FILE *open_csv (const char *path, GError ** error);
void write_csv_row (FILE * csv, const char *sweep, const char *value,
    const Config * c, const Result * r);
void write_sensitivity_row (FILE * csv, const char *sweep,
    const char *value, const char *scene, guint pings, guint found,
    guint total, guint false_positives, double mean_error,
    double max_error);
void print_header (const Sweep * sweep);
void print_row (const char *value, const Config * c, const Result * r,
    const char *same_as);
void print_memory_header (void);
void print_memory_row (const char *value, const Config * c,
    const Result * r);
void print_efficiency_header (const Bench * b);
void print_efficiency_row (const char *value, const Config * c,
    const Result * r);
void print_ward_vs_slink (const Result * ward, const Result * slink);
void print_datacube_vs_proposed (const Result * proposed,
    const Result * cube);

G_END_DECLS

#endif /* SONAR_BENCH_H */
