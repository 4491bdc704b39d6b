/* test-steady-state.c: once a stream's stages are made, a ping through the
 * DSP core (spectra, image, centroids, velocities, the residual search)
 * allocates nothing on
 * the heap: every allocation in the process is counted while pings run.
 *
 * The counter replaces malloc and its relatives in this program, which
 * takes precedence over the C library's for every shared library too
 * (GLib, FFTW), and forwards to glibc's own entry points. Under a
 * sanitizer the allocator is the sanitizer's (its runtime allocates before
 * it starts, through these): the counter is not built and the test
 * skips. */
#include <glib.h>
#include <string.h>

#include "sonar-test-util.h"
#include "sonar-cluster.h"
#include "sonar-direct-path.h"
#include "sonar-imager.h"
#include "sonar-residual.h"
#include "sonar-simulator.h"
#include "sonar-velocity.h"

#if defined(__SANITIZE_ADDRESS__)
#define SANITIZED 1
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
#define SANITIZED 1
#endif
#endif
#ifndef SANITIZED
#define SANITIZED 0
#endif

static volatile gint counting;
static volatile gint allocations;

#if !SANITIZED
extern void *__libc_malloc (size_t size);
extern void *__libc_calloc (size_t n, size_t size);
extern void *__libc_realloc (void *p, size_t size);
extern void *__libc_memalign (size_t alignment, size_t size);

static inline void
count (void)
{
  if (g_atomic_int_get (&counting))
    g_atomic_int_inc (&allocations);
}

void *malloc (size_t size);
void *calloc (size_t n, size_t size);
void *realloc (void *p, size_t size);
void *memalign (size_t alignment, size_t size);
void *aligned_alloc (size_t alignment, size_t size);
int posix_memalign (void **out, size_t alignment, size_t size);

void *
malloc (size_t size)
{
  count ();
  return __libc_malloc (size);
}

void *
calloc (size_t n, size_t size)
{
  count ();
  return __libc_calloc (n, size);
}

void *
realloc (void *p, size_t size)
{
  count ();
  return __libc_realloc (p, size);
}

void *
memalign (size_t alignment, size_t size)
{
  count ();
  return __libc_memalign (alignment, size);
}

void *
aligned_alloc (size_t alignment, size_t size)
{
  count ();
  return __libc_memalign (alignment, size);
}

int
posix_memalign (void **out, size_t alignment, size_t size)
{
  void *p;

  count ();
  p = __libc_memalign (alignment, size);
  if (!p)
    return 12;                  /* ENOMEM */
  *out = p;
  return 0;
}
#endif

#define MAX_CENTROIDS 64

/* Two movers and a still reflector, as in the paper's Fig. 9 world. */
static const char *scene_json =
    "{\"reflectors\": ["
    "{\"position\": [-0.6, 0, 1.4], \"velocity\": [0.5, 0, -1.2]},"
    "{\"position\": [0.5, 0, 2.3], \"velocity\": [0, 0, 0]},"
    "{\"position\": [0.9, 0, 3.1], \"velocity\": [0, 0, 1.6]}]}";

/* The chain at its defaults, the imager's coarse pass on @coarse_band of
 * the band. */
static void
check_ping_allocates_nothing (double coarse_band, double direct_path)
{
  SonarTestChain chain;
  SonarImagerParams ip;
  SonarClusterParams cp;
  SonarVelocityParams vp;
  g_autoptr (GError) error = NULL;
  g_autoptr (SonarImager) imager = NULL;
  g_autoptr (SonarClusterer) clusterer = NULL;
  g_autoptr (SonarVelocityPool) pool = NULL;
  g_autoptr (SonarResidualSearch) search = NULL;
  g_autoptr (SonarChannelSpectra) analyzer = NULL;
  g_autoptr (SonarDirectPath) direct = NULL;
  g_autofree float *interleaved = NULL;
  g_autofree guint *indices = NULL;
  g_autofree SonarHypothesis *hypotheses = NULL;
  g_autofree float *image = NULL;
  SonarCentroid centroids[MAX_CENTROIDS];
  SonarVelocityEstimate results[2 * MAX_CENTROIDS];
  guint counts[MAX_CENTROIDS], n_hyp, nv, found_per_ping[3];

  if (SANITIZED || sonar_test_sanitized () || g_getenv ("LD_PRELOAD")) {
    g_test_skip ("the allocator is the sanitizer's");
    return;
  }
  sonar_test_chain_init_with_bank (&chain, -3.0, 3.0, 0.05);
  sonar_imager_params_init_default (&ip);
  ip.threads = 2;
  ip.coarse_band = coarse_band;
  imager = sonar_imager_new (chain.setup, &chain.band, &ip, &error);
  g_assert_no_error (error);
  nv = sonar_doppler_bank_n_velocities (chain.bank);
  indices = g_new (guint, nv + 2);
  n_hyp = sonar_doppler_bank_hypotheses (chain.bank, 0.3, indices);
  hypotheses = g_new (SonarHypothesis, n_hyp);
  for (guint h = 0; h < n_hyp; h++)
    hypotheses[h] = sonar_doppler_bank_hypothesis (chain.bank, indices[h]);
  sonar_cluster_params_init_default (&cp);
  cp.hypotheses = n_hyp;
  clusterer = sonar_clusterer_new (sonar_imager_grid (imager), &cp, &error);
  g_assert_no_error (error);
  sonar_velocity_params_init_default (&vp);
  pool = sonar_velocity_pool_new (chain.bank, sonar_imager_grid (imager), &vp,
      2, &error);
  g_assert_no_error (error);
  search = sonar_residual_search_new (chain.setup, &chain.band, chain.bank,
      sonar_imager_grid (imager), chain.setup->geometry.n_emitters, &error);
  g_assert_no_error (error);
  image = g_new (float, sonar_image_grid_size (sonar_imager_grid (imager)));
  sonar_test_chain_simulate (&chain, scene_json, 0.01);
  if (direct_path > 0.0) {
    /* The microphones hear the emitters straight too: dopplerbank's
     * default fits and subtracts it on every ping. */
    const gsize total = (gsize) chain.setup->ping_length *
        chain.setup->geometry.n_microphones;
    SonarSimulatorParams sp;
    SonarScene empty = { .dimensions = 3 };
    g_autoptr (SonarSimulator) sim = NULL;
    g_autofree float *heard = g_new (float, total);

    sonar_simulator_params_init_default (&sp);
    sp.noise_amplitude = 0.0;
    sp.direct_path = direct_path;
    sim = sonar_simulator_new (chain.setup, &sp, &error);
    g_assert_no_error (error);
    sonar_simulator_render (sim, &empty, 0, 0.0, heard, NULL);
    for (gsize i = 0; i < total; i++)
      chain.ping[i] += heard[i];
    direct = sonar_direct_path_new (chain.setup, SONAR_DIRECT_PATH_TAPS,
        &error);
    g_assert_no_error (error);
  }
  /* The spectra as dopplerbank makes them: from the channels interleaved,
   * shared by two workers. */
  analyzer = sonar_channel_spectra_new (&chain.band,
      chain.setup->geometry.n_microphones, 2, &error);
  g_assert_no_error (error);
  sonar_channel_spectra_set_direct_path (analyzer, direct,
      SONAR_DIRECT_PATH_AUTO);
  interleaved = g_new (float, (gsize) chain.setup->ping_length *
      chain.setup->geometry.n_microphones);
  for (guint j = 0; j < chain.setup->geometry.n_microphones; j++)
    for (guint i = 0; i < chain.setup->ping_length; i++)
      interleaved[(gsize) i * chain.setup->geometry.n_microphones + j] =
          chain.ping[(gsize) j * chain.setup->ping_length + i];

  /* Ping 0 warms up (grows what grows with the first call's sizes); the
   * next pings are steady state. */
  for (guint ping = 0; ping < 3; ping++) {
    guint n_centroids, found = 0, units, passes, estimated;
    const SonarCentroid *more;
    const SonarVelocityEstimate *more_results;
    const guint *more_counts;

    g_atomic_int_set (&allocations, 0);
    g_atomic_int_set (&counting, ping > 0);
    sonar_channel_spectra_process (analyzer, interleaved,
        chain.setup->ping_length, chain.mic_spectra);
    g_assert_cmpuint (sonar_channel_spectra_direct_path_removed (analyzer,
            NULL), ==, direct ? chain.setup->geometry.n_microphones : 0);
    sonar_imager_process (imager, chain.mic_spectra, n_hyp, hypotheses, -1,
        image);
    n_centroids = sonar_clusterer_process (clusterer, image, centroids,
        MAX_CENTROIDS);
    sonar_velocity_pool_estimate (pool, chain.mic_spectra, centroids,
        n_centroids, results, counts);
    sonar_residual_search_process (search, pool, n_centroids, results,
        counts, &more, &more_results, &more_counts);
    g_atomic_int_set (&counting, 0);
    /* The search imaged the ping less its three echoes. */
    sonar_residual_search_last_work (search, &units, &passes, &estimated);
    g_assert_cmpuint (units, >, 0);
    for (guint k = 0; k < n_centroids; k++)
      for (guint i = 0; i < counts[k]; i++)
        found += results[2 * k + i].valid;
    found_per_ping[ping] = found;
    if (ping > 0)
      g_assert_cmpint (g_atomic_int_get (&allocations), ==, 0);
  }
  /* The pings did the work: every reflector found, each time. */
  for (guint ping = 0; ping < 3; ping++)
    g_assert_cmpuint (found_per_ping[ping], ==, 3);
  sonar_test_chain_clear (&chain);
}

static void
test_ping_allocates_nothing (void)
{
  check_ping_allocates_nothing (1.0, 0.0);
}

/* The coarse pass on a sub-band (its transforms, calibration, map and
 * confirmation): nothing either. */
static void
test_ping_allocates_nothing_sub_band (void)
{
  check_ping_allocates_nothing (0.5, 0.0);
}

/* The direct path fitted and subtracted from every microphone of every
 * ping (sonarsrc's direct-path=0.1): nothing either. */
static void
test_ping_allocates_nothing_direct_path (void)
{
  check_ping_allocates_nothing (1.0, 0.1);
}

/* The counter counts: a GLib allocation made while counting is seen. */
static void
test_counter_sees_allocations (void)
{
  gpointer p;

  if (SANITIZED || sonar_test_sanitized () || g_getenv ("LD_PRELOAD")) {
    g_test_skip ("the allocator is the sanitizer's");
    return;
  }
  g_atomic_int_set (&allocations, 0);
  g_atomic_int_set (&counting, 1);
  p = g_malloc (100);
  g_atomic_int_set (&counting, 0);
  g_free (p);
  g_assert_cmpint (g_atomic_int_get (&allocations), ==, 1);
}

int
main (int argc, char **argv)
{
  g_test_init (&argc, &argv, NULL);
  g_test_add_func ("/steady-state/counter-sees-allocations",
      test_counter_sees_allocations);
  g_test_add_func ("/steady-state/ping-allocates-nothing",
      test_ping_allocates_nothing);
  g_test_add_func ("/steady-state/ping-allocates-nothing-direct-path",
      test_ping_allocates_nothing_direct_path);
  g_test_add_func ("/steady-state/ping-allocates-nothing-sub-band",
      test_ping_allocates_nothing_sub_band);
  return g_test_run ();
}
