/* sonar-bench's chain: per configuration, the DSP core run the way the
 * elements run it (dopplerbank ! mimobeamform ! wardcluster ! velocityest
 * ! sonartrack, with their defaults), each ping's detections scored
 * against the simulator's ground truth, every stage timed, the memory it
 * holds measured and its arithmetic floor computed.
 *
 * The tracking stage is sonartrack's work per ping: the detections read
 * as measurements with the nominal sigmas, the ping's ego-motion and the
 * tracker's update (gst/sonar-egomotion.h, gst/sonar-track.h), at the
 * ping's time p / 12 Hz. Tracks need pings in order: the tracker starts
 * again (untimed) whenever the scene's pings start again (the warm-up,
 * and scenes with fewer pings than --timed-pings).
 *
 * The velocity stage shares the centroids between worker threads as
 * velocityest does (--threads). Every ping is rendered before anything
 * is timed (scenes.c): the simulator's cost is not counted. Times are
 * wall-clock medians over at least --timed-pings pings (20; a scene with
 * fewer goes round them again, each scored once) after an untimed
 * warm-up on the first, ms per ping, with the 10th-90th percentile
 * spread, plus the chain's CPU time (median). Set-up work (the Doppler
 * bank, FFT plans, the imager's tables) is not timed, as the elements do
 * it once per stream.
 *
 * Memory is the heap each stage holds (glibc mallinfo2: FFTW and GLib
 * allocate through malloc), counted when its objects are made and while
 * it warms up on the first ping (buffers made on first use); the bank is
 * dopplerbank's. Thread stacks are not heap and not counted. Peak RSS is
 * the process's during the configuration's run (Linux resets it per run),
 * rendered pings and banks of earlier runs included. */
#include <malloc.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <sys/resource.h>
#include <time.h>

#include "bench.h"

#define MB (1024.0 * 1024.0)

/* The paper's Fig. 10b: SLINK struggles below this range. */
#define NEAR_RANGE 1.0

/* Timing and memory ------------------------------------------------------*/

static double
clock_ms (clockid_t clock)
{
  struct timespec ts;

  clock_gettime (clock, &ts);
  return ts.tv_sec * 1e3 + ts.tv_nsec * 1e-6;
}

double
now_ms (void)
{
  return clock_ms (CLOCK_MONOTONIC);
}

/* Heap in use, MB: FFTW and GLib allocate through malloc, and mallinfo2
 * sums every thread's arena. */
double
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
double
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
double
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

/* Scoring ----------------------------------------------------------------*/

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

/* Independent chains of fused multiply-adds in registers, enough of them
 * to fill the pipelines (two ports, four cycles each: eight in flight),
 * on the widest vectors the CPU has: the chain's AVX-512 kernels use
 * them. Every lane converges to b / (1 - a), about 1e-3 (with b = 0 a
 * lane decayed into denormal floats, which cost a microcode assist on
 * every multiply-add on Intel cores). A loop over an array of them, as
 * this was before, kept the array in memory at -O2: a load and a store
 * per multiply-add, and a "peak" that moved with the code's layout
 * (24-37 GFLOP/s on one core of this machine, where its AVX-512 units do
 * about four times that). */
#define PEAK_CHAINS 12
#define PEAK_STEP(fma) G_STMT_START {                                   \
    c0 = fma (c0, a, b); c1 = fma (c1, a, b); c2 = fma (c2, a, b);      \
    c3 = fma (c3, a, b); c4 = fma (c4, a, b); c5 = fma (c5, a, b);      \
    c6 = fma (c6, a, b); c7 = fma (c7, a, b); c8 = fma (c8, a, b);      \
    c9 = fma (c9, a, b); c10 = fma (c10, a, b); c11 = fma (c11, a, b);  \
  } G_STMT_END

/* Each chain from its own start: chains alike would be folded into one. */
#define PEAK_CHAINS_INIT(type, set) type c0 = set (0.0f), c1 = set (1e-4f), \
  c2 = set (2e-4f), c3 = set (3e-4f), c4 = set (4e-4f), c5 = set (5e-4f),   \
  c6 = set (6e-4f), c7 = set (7e-4f), c8 = set (8e-4f), c9 = set (9e-4f),   \
  c10 = set (1e-3f), c11 = set (1.1e-3f)

#if defined(__x86_64__) && defined(__GNUC__)
#include <immintrin.h>

/* The chains' sum, one lane each: keeps the compiler from folding them. */
#define PEAK_SUM(cvt, add) cvt (add (add (add (add (c0, c1), add (c2, c3)), \
            add (add (c4, c5), add (c6, c7))), add (add (c8, c9), add (c10, c11))))

__attribute__ ((target ("avx512f"))) static float
peak_loop_avx512 (guint iterations)
{
  const __m512 a = _mm512_set1_ps (0.999f), b = _mm512_set1_ps (1e-6f);
  PEAK_CHAINS_INIT (__m512, _mm512_set1_ps);

  for (guint i = 0; i < iterations; i++)
    PEAK_STEP (_mm512_fmadd_ps);
  return PEAK_SUM (_mm512_cvtss_f32, _mm512_add_ps);
}

__attribute__ ((target ("avx2,fma"))) static float
peak_loop_avx2 (guint iterations)
{
  const __m256 a = _mm256_set1_ps (0.999f), b = _mm256_set1_ps (1e-6f);
  PEAK_CHAINS_INIT (__m256, _mm256_set1_ps);

  for (guint i = 0; i < iterations; i++)
    PEAK_STEP (_mm256_fmadd_ps);
  return PEAK_SUM (_mm256_cvtss_f32, _mm256_add_ps);
}
#endif

/* Elsewhere: the baseline's multiply and add, one float a chain. */
static float
fma_generic (float x, float a, float b)
{
  return x * a + b;
}

static float
peak_loop_generic (guint iterations)
{
  const float a = 0.999f, b = 1e-6f;
  PEAK_CHAINS_INIT (float, (float));

  for (guint i = 0; i < iterations; i++)
    PEAK_STEP (fma_generic);
  return c0 + c1 + c2 + c3 + c4 + c5 + c6 + c7 + c8 + c9 + c10 + c11;
}

/* GFLOP/s of one core (2 flops per lane of a fused multiply-add) on its
 * widest vectors, named in @isa: the best of a few runs of about 20 ms
 * (others share the machine). */
double
measure_peak_gflops (const char **isa)
{
  const guint iterations = 1000000;
  float (*loop) (guint) = peak_loop_generic;
  guint lanes = 1;
  double best = 0.0;
  volatile float sink;

  *isa = "scalar";
#if defined(__x86_64__) && defined(__GNUC__)
  if (__builtin_cpu_supports ("avx512f")) {
    loop = peak_loop_avx512;
    lanes = 16;
    *isa = "AVX-512";
  } else if (__builtin_cpu_supports ("avx2")
      && __builtin_cpu_supports ("fma")) {
    loop = peak_loop_avx2;
    lanes = 8;
    *isa = "AVX2";
  }
#endif
  for (int run = 0; run < 5; run++) {
    const double start = clock_ms (CLOCK_THREAD_CPUTIME_ID);
    double ms;
    sink = loop (iterations);
    ms = clock_ms (CLOCK_THREAD_CPUTIME_ID) - start;
    best = MAX (best, 2.0 * lanes * PEAK_CHAINS * (double) iterations /
        (ms * 1e6));
  }
  (void) sink;
  return best;
}

/* GB/s one core reads a 64 MB array at (far beyond the caches). */
double
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
 *   spectra     a real transform per microphone (2.5 N log2 N), the
 *               microphones shared by the cores;
 *   imaging     per unit the receive sum (8 flops per microphone and bin:
 *               a complex multiply-add, the phasor's rotation shared) and
 *               the zero-velocity transmit table (8 per emitter and bin,
 *               over the band's bins at least), per pass the transmit
 *               product read from it (sonar_kernel_scaled_product (): 24
 *               per bin for the six taps' multiply-adds, 6 for their
 *               weights, 12 for the products with the receive sum and
 *               the phasor), the inverse transform and the envelope (3
 *               per range bin);
 *   clustering  two reads of the image at the measured read rate (its
 *               passes over the image are shared by the cores);
 *   velocity    per centroid and direction the prescreen searches
 *               (sonar_velocity_pool_work ()), per window direction: a
 *               focus (the receive sum, 8 flops per microphone and bin,
 *               and the range gate's two transforms); per centroid and
 *               window direction the prescreen's evaluations (all its
 *               hypotheses at the centroid's direction, three at the
 *               others); per evaluated velocity, window direction and
 *               emitter: the dot product's block sums (14 per bin of the
 *               gate) and the lags read (8 per block and lag: the
 *               window's, and 8 more around its best in window_peak ()).
 *               The prescreen's evaluations read the window's lags only.
 *               With the residual search, its image as imaging's and
 *               its centroids as the others. */
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
  double flops[N_STAGES], focus, screen, evaluation, residual_ms;
  SonarVelocityWork work;

  flops[STAGE_SPECTRA] = J * 0.5 * fft_flops (F);
  flops[STAGE_IMAGING] = units * 8.0 * (J + N) * K + passes * (42.0 * K +
      fft_flops (M) + 3.0 * R);
  flops[STAGE_CLUSTERING] = 0.0;
  residual_ms = 0.0;
  if (ch->residual) {
    guint residual_units, residual_passes, estimated;
    sonar_residual_search_last_work (ch->residual, &residual_units,
        &residual_passes, &estimated);
    residual_ms = (residual_units * 8.0 * (J + N) * K + residual_passes *
        (42.0 * K + fft_flops (M) + 3.0 * R)) * per_core_ms / cores +
        (residual_passes ? 2.0 * sonar_image_grid_size (ch->grid) *
        sizeof (float) / (b->read_gbs * 1e6) / cores : 0.0);
    centroids += estimated;
  }
  sonar_velocity_pool_work (ch->workers, &work);
  focus = 8.0 * J * K + (work.gate_inverse ? fft_flops (work.gate_inverse) +
      fft_flops (work.gate_forward) : 0.0);
  screen = N * (14.0 * work.bins + 8.0 * lags * work.bins / work.block);
  evaluation = N * (14.0 * work.bins + 8.0 * (lags + 8.0) * work.bins /
      work.block);
  flops[STAGE_VELOCITY] = centroids * window * (work.directions * focus +
      work.screens * screen) + evaluations * window * evaluation;
  floor_ms[STAGE_SPECTRA] = flops[STAGE_SPECTRA] * per_core_ms /
      MIN (cores, J);
  floor_ms[STAGE_IMAGING] = flops[STAGE_IMAGING] * per_core_ms / cores;
  floor_ms[STAGE_CLUSTERING] = 2.0 * sonar_image_grid_size (ch->grid) *
      sizeof (float) / (b->read_gbs * 1e6) / cores;
  floor_ms[STAGE_VELOCITY] = flops[STAGE_VELOCITY] * per_core_ms /
      MIN (cores, b->n_threads) + residual_ms;
  /* Tracking's is a few small matrices per track: none is counted. */
  floor_ms[STAGE_TRACKING] = 0.0;
}

/* The chain --------------------------------------------------------------*/

void
chain_clear (Chain * ch)
{
  g_clear_pointer (&ch->analyzer, sonar_channel_spectra_free);
  g_clear_pointer (&ch->direct_path, sonar_direct_path_free);
  g_clear_pointer (&ch->imager, sonar_imager_free);
  g_clear_pointer (&ch->clusterer, sonar_clusterer_free);
  g_clear_pointer (&ch->residual, sonar_residual_search_free);
  g_clear_pointer (&ch->workers, sonar_velocity_pool_free);
  g_clear_pointer (&ch->ego, sonar_ego_estimator_free);
  g_clear_pointer (&ch->tracker, sonar_tracker_free);
  g_clear_pointer (&ch->hypotheses, g_free);
  g_clear_pointer (&ch->spectra, g_free);
  g_clear_pointer (&ch->image, g_free);
  g_clear_pointer (&ch->cube, g_free);
  g_clear_pointer (&ch->curve, g_free);
}

/* Makes @c's stages as the elements do at start, charging each the heap
 * its objects take. */
gboolean
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
  ch->analyzer = sonar_channel_spectra_new (ch->band, n_mics, 0, error);
  if (!ch->analyzer)
    return FALSE;
  if (c->direct_path_mode != SONAR_DIRECT_PATH_OFF) {
    /* As dopplerbank: its fit made at start, unless direct-path=off. */
    ch->direct_path = sonar_direct_path_new (b->setup, c->direct_path_taps,
        error);
    if (!ch->direct_path)
      return FALSE;
    sonar_channel_spectra_set_direct_path (ch->analyzer, ch->direct_path,
        c->direct_path_mode);
  }
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
    if (c->residual_search) {
      ch->residual = sonar_residual_search_new (b->setup, ch->band, bank,
          ch->grid, ch->n_emitters, error);
      if (!ch->residual)
        return FALSE;
    }
  }
  r->mb[STAGE_VELOCITY] = heap_mb () - heap;

  /* sonartrack's defaults, its dimensions and mirror from the sensor. */
  heap = heap_mb ();
  {
    SonarEgoParams ego;
    SonarTrackerParams tracker;
    const gboolean fan = b->setup->field_of_view == SONAR_FIELD_OF_VIEW_FAN;

    sonar_ego_params_init_default (&ego);
    sonar_tracker_params_init_default (&tracker);
    sonar_sigma_model_init_default (&ch->sigma);
    ego.dimensions = fan ? 2 : 0;
    tracker.dimensions = fan ? 2 : 3;
    ego.mirror_z = tracker.mirror_z =
        sonar_geometry_is_planar (&b->setup->geometry);
    ch->ego = sonar_ego_estimator_new (&ego, error);
    if (!ch->ego)
      return FALSE;
    ch->tracker = sonar_tracker_new (&tracker, error);
    if (!ch->tracker)
      return FALSE;
  }
  r->mb[STAGE_TRACKING] = heap_mb () - heap;
  return TRUE;
}

void
chain_spectra (Chain * ch, const float *samples, gsize length)
{
  sonar_channel_spectra_process (ch->analyzer, samples, length, ch->spectra);
}

void
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

/* The valid estimates of @n centroids (2 per centroid, @counts each) as
 * detections, and their bank evaluations. */
static void
add_detections (Chain * ch, guint n, const SonarVelocityEstimate * results,
    const guint * counts)
{
  for (guint k = 0; k < n; k++) {
    const SonarVelocityEstimate *e = &results[2 * k];

    ch->evaluated_velocities += e[0].evaluated_velocities;
    for (guint i = 0; i < counts[k]; i++) {
      if (!e[i].valid || ch->n_detections == G_N_ELEMENTS (ch->positions))
        continue;
      ch->positions[ch->n_detections] = sonar_vec3_scale
          (sonar_vec3_from_direction (e[i].echo_azimuth,
              e[i].echo_elevation), e[i].echo_range);
      ch->velocities[ch->n_detections++] = e[i].radial_velocity;
    }
  }
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
  add_detections (ch, n_centroids, ch->results, ch->counts);
  if (ch->residual) {
    const SonarCentroid *found;
    const SonarVelocityEstimate *results;
    const guint *counts;
    const guint n = sonar_residual_search_process (ch->residual,
        ch->workers, n_centroids, ch->results, ch->counts, &found, &results,
        &counts);
    add_detections (ch, n, results, counts);
  }
}

/* sonartrack's work on the ping's detections at @ping_time (s): its
 * ego-motion, then the tracks. */
void
chain_tracking (Chain * ch, double ping_time)
{
  GError *error = NULL;

  for (guint d = 0; d < ch->n_detections; d++) {
    SonarMeasurement *m = &ch->measurements[d];

    m->instant = ping_time;
    m->range = sonar_vec3_norm (ch->positions[d]);
    sonar_vec3_to_direction (ch->positions[d], &m->azimuth, &m->elevation);
    m->radial_velocity = ch->velocities[d];
    sonar_measurement_set_nominal_sigma (m, &ch->sigma);
  }
  sonar_ego_estimate (ch->ego, ch->measurements, ch->n_detections,
      &ch->ego_motion, ch->labels);
  if (!sonar_tracker_process (ch->tracker, ping_time, ch->measurements,
          ch->n_detections, &ch->ego_motion, ch->labels, &error)) {
    /* Pings in time order (run_config) cannot fail. */
    g_warning ("sonar-bench: tracking: %s", error->message);
    g_error_free (error);
  }
}

/* One ping through an initialised chain; returns the centroids. */
guint
chain_run_ping (Chain * ch, const float *samples, guint n_mics,
    gsize length)
{
  guint n;

  chain_spectra (ch, samples, length);
  chain_imaging (ch);
  n = sonar_clusterer_process (ch->clusterer, ch->image, ch->centroids,
      MAX_CENTROIDS);
  chain_velocity (ch, n);
  return n;
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
gboolean
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
  g_autofree float *direct = NULL, *heard = NULL;

  if (c->direct_path > 0.0) {
    direct = direct_path_ping (b->setup, c->direct_path, error);
    if (!direct)
      return FALSE;
    heard = g_new (float, length * n_mics);
  }
  reset_peak_rss ();
  ok = chain_init (ch, b, c, r, error);
  /* Per ping: the stages, the total, its CPU time, the velocity stage's
   * CPU time (all its threads), the spectra's, the clustering's and the
   * imaging's. */
  times = g_new (double, (N_STAGES + 6) * n_timed);
  /* Ping -1 is a warm-up on the first ping, neither timed nor scored: it
   * takes the page faults of fresh buffers and ORC's first compilations,
   * and its heap growth is the stages' working memory. */
  for (int q = -1; ok && q < (int) n_timed; q++) {
    const guint p = MAX (q, 0) % n_pings;
    const float *samples = direct ? heard : s->pings + p * length * n_mics;
    const SonarTruth *truths = s->truths + p * s->n_reflectors;
    double cpu_start;
    StageClock clock = { q < 0 };
    double t[N_STAGES], total = 0.0;
    guint n_centroids, units, dense_units, passes, dense_passes;
    double velocity_cpu, spectra_cpu, clustering_cpu, imaging_cpu;

    /* The direct path is in the recording: added before the clock. */
    for (gsize i = 0; direct && i < length * n_mics; i++)
      heard[i] = s->pings[p * length * n_mics + i] + direct[i];
    cpu_start = clock_ms (CLOCK_PROCESS_CPUTIME_ID);
    stage_start (&clock);
    spectra_cpu = clock_ms (CLOCK_PROCESS_CPUTIME_ID);
    chain_spectra (ch, samples, length);
    spectra_cpu = clock_ms (CLOCK_PROCESS_CPUTIME_ID) - spectra_cpu;
    t[STAGE_SPECTRA] = stage_stop (&clock, r, STAGE_SPECTRA);
    stage_start (&clock);
    imaging_cpu = clock_ms (CLOCK_PROCESS_CPUTIME_ID);
    chain_imaging (ch);
    imaging_cpu = clock_ms (CLOCK_PROCESS_CPUTIME_ID) - imaging_cpu;
    t[STAGE_IMAGING] = stage_stop (&clock, r, STAGE_IMAGING);
    sonar_imager_last_work (ch->imager, &units, &dense_units, &passes,
        &dense_passes);
    stage_start (&clock);
    clustering_cpu = clock_ms (CLOCK_PROCESS_CPUTIME_ID);
    n_centroids = sonar_clusterer_process (ch->clusterer, ch->image,
        ch->centroids, MAX_CENTROIDS);
    clustering_cpu = clock_ms (CLOCK_PROCESS_CPUTIME_ID) - clustering_cpu;
    t[STAGE_CLUSTERING] = stage_stop (&clock, r, STAGE_CLUSTERING);
    stage_start (&clock);
    velocity_cpu = clock_ms (CLOCK_PROCESS_CPUTIME_ID);
    chain_velocity (ch, n_centroids);
    velocity_cpu = clock_ms (CLOCK_PROCESS_CPUTIME_ID) - velocity_cpu;
    t[STAGE_VELOCITY] = stage_stop (&clock, r, STAGE_VELOCITY);
    if (p == 0)
      sonar_tracker_reset (ch->tracker);
    stage_start (&clock);
    chain_tracking (ch, p / PING_RATE);
    t[STAGE_TRACKING] = stage_stop (&clock, r, STAGE_TRACKING);
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
    times[(N_STAGES + 2) * n_timed + q] = velocity_cpu;
    times[(N_STAGES + 3) * n_timed + q] = spectra_cpu;
    times[(N_STAGES + 4) * n_timed + q] = clustering_cpu;
    times[(N_STAGES + 5) * n_timed + q] = imaging_cpu;
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
  r->cpu_ms_velocity = median (times + (N_STAGES + 2) * n_timed, n_timed);
  r->cpu_ms_spectra = median (times + (N_STAGES + 3) * n_timed, n_timed);
  r->cpu_ms_clustering = median (times + (N_STAGES + 4) * n_timed,
      n_timed);
  r->cpu_ms_imaging = median (times + (N_STAGES + 5) * n_timed, n_timed);
  return TRUE;
}
