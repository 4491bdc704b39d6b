/* sonar-bench's crowded sweep (issue 12): detections against the number of
 * objects, beside an oracle bound.
 *
 * Scenes: still unit point reflectors on n x n grids (n = 5, 10, 14, 20),
 * 8 degrees apart in azimuth and 22 cm apart in range from 0.6 m (as
 * tools/crowded.py), then the bench's random scenes of 25 to 150 point
 * reflectors (scenes.c: 0.5-4.5 m, -60..60 degrees, -0.4..0.4 m/s, 25 cm
 * apart). One ping each, noise seed 0, through the chain at the elements'
 * defaults (the -7..7 m/s bank at 0.05 m/s and its 47 hypotheses).
 *
 * The oracle: an object is detectable when its level in the detection
 * image at its true position stands at least ORACLE_DB above the
 * interference there. Its level: the image (the chain's directions and
 * hypotheses, every pixel imaged, no coarse pass) of a noise-free
 * recording of the object alone, the strongest pixel within a pixel of
 * its true range and direction; only the few pixels around the object
 * are imaged, focused on it. The interference: that pixel's value in the
 * image of the recording of every other object and the noise, without
 * it. The recordings are linear in the reflectors (the simulator does
 * not clip): the one without the object is the whole ping's minus the
 * object's own, and so are their spectra.
 *
 * Found: a valid detection within MATCH_DISTANCE (each detection matches
 * one object at most); false objects: valid detections near no object.
 * Each detectable object missed is printed on stderr with where it was
 * lost (no centroid near it, or its estimate's coherence and agreeing
 * emitters); "missed dB": the highest margin of those. */
#include <math.h>

#include "bench.h"

/* m: the oracle's image reaches this far either side of an object. */
#define ORACLE_RANGE 0.05
#define GRID_AZIMUTH_STEP 8.0
#define GRID_RANGE_FIRST 0.6
#define GRID_RANGE_STEP 0.22
/* cancel_bound ()'s rounds at most. */
#define CANCEL_ROUNDS 6

gboolean crowded_cancel_bound = FALSE;

static const guint grid_sides[] = { 5, 10, 14, 20 };
static const guint random_sizes[] = { 25, 50, 100, 150 };

static void
grid_scene_init (SonarScene * scene, guint n)
{
  sonar_scene_init_preset (scene, SONAR_SCENE_PRESET_EMPTY);
  scene->reflectors = g_new0 (SonarReflector, n * n);
  scene->n_reflectors = n * n;
  for (guint i = 0; i < n; i++)
    for (guint j = 0; j < n; j++) {
      SonarReflector *r = &scene->reflectors[i * n + j];
      const double azimuth = -(n - 1.0) * 0.5 * GRID_AZIMUTH_STEP +
          GRID_AZIMUTH_STEP * j;
      r->kind = SONAR_REFLECTOR_POINT;
      r->position = sonar_vec3_scale (sonar_vec3_from_direction (azimuth,
              0.0), GRID_RANGE_FIRST + GRID_RANGE_STEP * i);
      r->strength = 1.0;
    }
}

/* The oracle's imager for the object at (@range m, @azimuth degrees): the
 * chain's image (@grid, its @params) around it, its direction and one
 * grid step either side, ORACLE_RANGE either side in range, every pixel
 * imaged (no coarse pass) and focused on it. */
static SonarImager *
oracle_imager (SonarSetup * setup, const SonarBand * band,
    const SonarImagerParams * params, const SonarImageGrid * grid,
    double range, double azimuth, GError ** error)
{
  SonarImagerParams p = *params;
  const int a = CLAMP ((int) lround ((azimuth - grid->azimuth_first) /
          grid->azimuth_step), 1, (int) grid->n_azimuth - 2);

  p.azimuth_min = grid->azimuth_first + (a - 1) * grid->azimuth_step;
  p.azimuth_max = grid->azimuth_first + (a + 1) * grid->azimuth_step;
  p.n_azimuth = 3;
  p.range_min = MAX (range - ORACLE_RANGE, 0.0);
  p.range_max = range + ORACLE_RANGE;
  p.focus_zones = 1;
  p.coarse_spacing = 0.0;
  p.threads = 1;
  return sonar_imager_new (setup, band, &p, error);
}

/* The strongest pixel of @image (@g) within one pixel of @range m along
 * the middle direction. */
static gsize
strongest_near (const SonarImageGrid * g, const float *image, double range)
{
  const int i = CLAMP ((int) lround ((range - g->range_first) /
          g->range_step), 0, (int) g->n_range - 1);
  gsize best = (gsize) g->n_range + i;

  for (int a = 0; a < 3; a++)
    for (int di = -1; di <= 1; di++) {
      const int ii = i + di;
      const gsize p = (gsize) a * g->n_range + ii;
      if (ii >= 0 && ii < (int) g->n_range && image[p] > image[best])
        best = p;
    }
  return best;
}

double
oracle_margin_db (Chain * ch, SonarSimulator * quiet,
    SonarSetup * setup, const SonarReflector * object,
    const SonarTruth * truth, const SonarComplex * whole, GError ** error)
{
  const gsize n_spectra = (gsize) setup->geometry.n_microphones *
      ch->band->n_bins;
  g_autoptr (SonarImager) imager = oracle_imager (setup,
      ch->band, &ch->config->imager, ch->grid, truth->range, truth->azimuth,
      error);
  g_autofree SonarComplex *own = g_new (SonarComplex, n_spectra);
  g_autofree SonarComplex *others = g_new (SonarComplex, n_spectra);
  g_autofree float *image = NULL;
  const SonarImageGrid *g;
  double level;
  gsize p;

  if (!imager)
    return NAN;
  g = sonar_imager_grid (imager);
  image = g_new (float, sonar_image_grid_size (g));
  render_alone (ch, quiet, setup, NULL, object);
  memcpy (own, ch->spectra, n_spectra * sizeof (SonarComplex));
  sonar_imager_process (imager, own, ch->n_templates, ch->hypotheses, -1,
      image);
  p = strongest_near (g, image, truth->range);
  level = image[p];
  for (gsize s = 0; s < n_spectra; s++)
    others[s] = whole[s] - own[s];
  sonar_imager_process (imager, others, ch->n_templates, ch->hypotheses, -1,
      image);
  return 20.0 * log10 (level / MAX (image[p], 1e-30f));
}

typedef struct
{
  guint objects, centroids, detectable, found, found_detectable;
  guint false_objects;
  double sum_error, max_error, chain_ms, oracle_s;
  double worst_missed_db;       /* the highest margin of a detectable
                                 * object not found, dB (-inf: none) */
  /* cancel_bound (): objects found besides the chain's, of them
   * detectable, false objects. */
  guint bound_found, bound_detectable, bound_false;
} CrowdRow;

/* The bound of successive cancellation (--crowded-cancel-bound): the
 * centroids whose estimates all failed estimated again on the recording
 * less the true, noise-free echoes of the objects found so far, in rounds
 * (each round cancels what the last found) until one finds nothing more
 * or CANCEL_ROUNDS: what cancelling the accepted echoes could give with
 * perfect models of them. Adds to @row's bound_ counts; @found: the
 * objects found by the chain. */
static void
cancel_bound (Chain * ch, SonarSimulator * quiet, const SonarSetup * setup,
    const SonarScene * scene,
    const SonarTruth * truths, const SonarComplex * whole,
    const gboolean * detectable, const gboolean * found, guint n_centroids,
    const char *name, CrowdRow * row)
{
  const guint n = scene->n_reflectors;
  const gsize n_spectra = (gsize) setup->geometry.n_microphones *
      ch->band->n_bins;
  g_autofree SonarComplex *residual = g_memdup2 (whole, n_spectra *
      sizeof (SonarComplex));
  g_autofree SonarCentroid *failed = g_new (SonarCentroid, n_centroids + 1);
  g_autofree guint *index = g_new (guint, n_centroids + 1);
  g_autofree SonarVelocityEstimate *results = g_new (SonarVelocityEstimate,
      2 * (n_centroids + 1));
  g_autofree guint *counts = g_new (guint, n_centroids + 1);
  g_autofree gboolean *known = g_memdup2 (found, MAX (n, 1) *
      sizeof (gboolean));
  g_autofree gboolean *cancelled = g_new0 (gboolean, MAX (n, 1));
  g_autofree gboolean *done = g_new0 (gboolean, n_centroids + 1);

  for (guint c = 0; c < n_centroids; c++)
    for (guint i = 0; i < ch->counts[c]; i++)
      done[c] |= ch->results[2 * c + i].valid;
  for (guint round = 0; round < CANCEL_ROUNDS; round++) {
    guint n_failed = 0, gained = 0;
    for (guint k = 0; k < n; k++) {
      if (!known[k] || cancelled[k])
        continue;
      cancelled[k] = TRUE;
      render_alone (ch, quiet, setup, scene, &scene->reflectors[k]);
      for (gsize b = 0; b < n_spectra; b++)
        residual[b] -= ch->spectra[b];
    }
    for (guint c = 0; c < n_centroids; c++)
      if (!done[c]) {
        index[n_failed] = c;
        failed[n_failed++] = ch->centroids[c];
      }
    sonar_velocity_pool_estimate (ch->workers, residual, failed, n_failed,
        results, counts);
    for (guint c = 0; c < n_failed; c++)
      for (guint i = 0; i < counts[c]; i++) {
        const SonarVelocityEstimate *e = &results[2 * c + i];
        const SonarVec3 at = sonar_vec3_scale (sonar_vec3_from_direction
            (e->echo_azimuth, e->echo_elevation), e->echo_range);
        int near = -1;
        if (!e->valid)
          continue;
        done[index[c]] = TRUE;
        for (guint k = 0; k < n && near < 0; k++)
          if (sonar_vec3_norm (sonar_vec3_sub (at, truths[k].position)) <
              MATCH_DISTANCE)
            near = k;
        if (near < 0) {
          row->bound_false++;
          g_printerr ("crowded: %s: cancellation bound: false object at "
              "%.3f m %+.1f deg, coherence %.2f (round %u)\n", name,
              e->range, e->azimuth, e->coherence, round + 1);
        } else if (!known[near]) {
          known[near] = TRUE;
          gained++;
          row->bound_found++;
          row->bound_detectable += detectable[near];
        }
      }
    if (!gained)
      break;
  }
}

/* One scene: the chain's ping, then the oracle per object. */
static gboolean
crowd_scene (Chain * ch, SonarSimulator * sim, SonarSimulator * quiet,
    SonarSetup * setup,
    const SonarScene * scene, const char *name, CrowdRow * row,
    GError ** error)
{
  const guint n_mics = setup->geometry.n_microphones;
  const gsize length = setup->ping_length;
  const guint n = scene->n_reflectors;
  const gsize n_spectra = (gsize) n_mics * ch->band->n_bins;
  g_autofree float *planar = g_new (float, length * n_mics);
  g_autofree float *samples = g_new (float, length * n_mics);
  g_autofree SonarTruth *truths = g_new (SonarTruth, MAX (n, 1));
  g_autofree SonarComplex *whole = g_new (SonarComplex, n_spectra);
  g_autofree gboolean *detectable = g_new0 (gboolean, MAX (n, 1));
  g_autofree double *margin = g_new (double, MAX (n, 1));
  g_autofree gboolean *found = g_new0 (gboolean, MAX (n, 1));
  gboolean used[2 * MAX_CENTROIDS] = { FALSE };
  SonarReflector *all = scene->reflectors;
  double start;
  guint n_centroids;

  memset (row, 0, sizeof (*row));
  row->objects = n;
  row->worst_missed_db = -INFINITY;
  sonar_simulator_render (sim, scene, 0, 0.0, planar, truths);
  interleave (planar, n_mics, length, samples);
  start = now_ms ();
  n_centroids = chain_run_ping (ch, samples, n_mics, length);
  row->chain_ms = now_ms () - start;
  row->centroids = n_centroids;

  /* The oracle. */
  start = now_ms ();
  memcpy (whole, ch->spectra, n_spectra * sizeof (SonarComplex));
  for (guint k = 0; k < n; k++) {
    margin[k] = oracle_margin_db (ch, quiet, setup, &all[k], &truths[k],
        whole, error);
    if (isnan (margin[k]))
      return FALSE;
    detectable[k] = margin[k] >= ORACLE_DB;
    row->detectable += detectable[k];
  }
  row->oracle_s = (now_ms () - start) / 1000.0;


  for (guint k = 0; k < n; k++) {
    int best = -1;
    double best_distance = MATCH_DISTANCE;
    for (guint d = 0; d < ch->n_detections; d++) {
      const double distance = sonar_vec3_norm (sonar_vec3_sub
          (ch->positions[d], truths[k].position));
      if (!used[d] && distance < best_distance) {
        best = d;
        best_distance = distance;
      }
    }
    if (best >= 0) {
      const double err = fabs (ch->velocities[best] -
          truths[k].radial_velocity);
      used[best] = TRUE;
      found[k] = TRUE;
      row->found++;
      row->found_detectable += detectable[k];
      row->sum_error += err;
      row->max_error = MAX (row->max_error, err);
    } else if (detectable[k]) {
      /* Where it was lost: no centroid near it, or its estimate's tests. */
      int near = -1;
      for (guint c = 0; c < n_centroids && near < 0; c++)
        if (sonar_vec3_norm (sonar_vec3_sub (ch->centroids[c].position,
                    truths[k].position)) < MATCH_DISTANCE)
          near = c;
      row->worst_missed_db = MAX (row->worst_missed_db, margin[k]);
      if (near < 0)
        g_printerr ("crowded: %s: missed an object %.1f dB above its "
            "interference at %.3f m %+.1f deg: no centroid\n", name,
            margin[k], truths[k].range, truths[k].azimuth);
      else {
        const SonarCentroid *c = &ch->centroids[near];
        g_printerr ("crowded: %s: missed an object %.1f dB above its "
            "interference at %.3f m %+.1f deg: coherence %.2f, %u "
            "agreeing emitters (centroid %.3f m %+.1f deg, %u peaks, "
            "the strongest at %.3f m %+.1f deg)\n", name, margin[k],
            truths[k].range, truths[k].azimuth,
            ch->results[2 * near].coherence,
            ch->results[2 * near].agreeing_emitters, c->range, c->azimuth,
            c->n_members, ch->grid->range_first + c->peak_range_index *
            ch->grid->range_step, ch->grid->azimuth_first +
            c->peak_azimuth_index * ch->grid->azimuth_step);
      }
    }
  }
  for (guint d = 0; d < ch->n_detections; d++) {
    gboolean near = FALSE;
    if (used[d])
      continue;
    for (guint k = 0; k < n && !near; k++)
      near = sonar_vec3_norm (sonar_vec3_sub (ch->positions[d],
              truths[k].position)) < MATCH_DISTANCE;
    /* A second detection of an object is a duplicate, not a false
     * object. */
    row->false_objects += !near;
    if (!near) {
      double azimuth, elevation;
      sonar_vec3_to_direction (ch->positions[d], &azimuth, &elevation);
      g_printerr ("crowded: %s: false object at %.3f m %+.1f deg, %+.4f "
          "m/s\n", name, sonar_vec3_norm (ch->positions[d]), azimuth,
          ch->velocities[d]);
    }
  }
  if (crowded_cancel_bound)
    cancel_bound (ch, quiet, setup, scene, truths, whole, detectable, found,
        n_centroids, name, row);
  return TRUE;
}

gboolean
run_crowded (Bench * b)
{
  g_autoptr (GError) error = NULL;
  g_autoptr (SonarSimulator) sim = NULL;
  g_autoptr (SonarSimulator) quiet = NULL;
  g_autofree Chain *ch = g_new0 (Chain, 1);
  Result r = { 0 };
  Config c;
  guint previous_found = 0;
  gboolean never_fewer = TRUE;

  sim = bench_simulator_new (b->setup, NOISE_AMPLITUDE, &error);
  if (sim)
    quiet = bench_simulator_new (b->setup, 0.0, &error);
  config_init (&c, &scenes[SCENE_FIG9]);
  if (!quiet || !chain_init (ch, b, &c, &r, &error)) {
    g_printerr ("crowded: %s\n", error->message);
    chain_clear (ch);
    return FALSE;
  }
  g_print ("\ncrowded (one ping per scene, the elements' defaults, bank "
      "-7..7 / 0.05; oracle: the object's level in the image at its "
      "true position >= %g dB above the others' and the noise's there; "
      "at most %u centroids)\n%-10s %7s %9s %7s %7s %9s %6s %9s %9s %9s "
      "%8s %8s\n", ORACLE_DB, MAX_CENTROIDS, "scene", "objects",
      "centroids", "oracle",
      "found", "found/or", "false", "mean m/s", "max m/s", "missed dB",
      "ping ms", "oracle s");
  for (guint s = 0; s < G_N_ELEMENTS (grid_sides) +
      G_N_ELEMENTS (random_sizes); s++) {
    const gboolean grid = s < G_N_ELEMENTS (grid_sides);
    const guint size = grid ? grid_sides[s] :
        random_sizes[s - G_N_ELEMENTS (grid_sides)];
    g_autofree char *name = g_strdup_printf (grid ? "grid%ux%u" : "rand%u",
        size, size);
    SonarScene scene;
    CrowdRow row;

    if (grid)
      grid_scene_init (&scene, size);
    else
      random_scene_init (&scene, size);
    if (!crowd_scene (ch, sim, quiet, b->setup, &scene, name, &row,
            &error)) {
      g_printerr ("crowded: %s\n", error->message);
      sonar_scene_clear (&scene);
      chain_clear (ch);
      return FALSE;
    }
    sonar_scene_clear (&scene);
    if (grid) {
      never_fewer &= row.found >= previous_found;
      previous_found = row.found;
    }
    g_print ("%-10s %7u %9u %7u %7u %9u %6u %9.4f %9.4f %9.1f %8.0f "
        "%8.1f\n", name, row.objects, row.centroids, row.detectable, row.found, row.found_detectable,
        row.false_objects, row.found ? row.sum_error / row.found : NAN,
        row.max_error, row.worst_missed_db, row.chain_ms, row.oracle_s);
    if (crowded_cancel_bound)
      g_print ("%-10s cancellation bound: %u found (%u of the oracle's), %u "
          "false objects\n", "", row.found + row.bound_found,
          row.found_detectable + row.bound_detectable, row.bound_false);
    if (b->csv)
      write_sensitivity_row (b->csv, "crowded", name, grid ? "grid" :
          "random", 1, row.found, row.objects, row.false_objects,
          row.found ? row.sum_error / row.found : NAN, row.max_error);
  }
  g_print ("grids: %s\n", never_fewer ? "never fewer objects found when "
      "more are added" : "FEWER objects found when more were added");
  chain_clear (ch);
  return TRUE;
}
