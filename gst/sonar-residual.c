/* sonar-residual.c: see sonar-residual.h. */
#include "sonar-residual.h"
#include "sonar-error.h"
#include "sonar-imager.h"
#include "sonar-memory.h"
#include "sonar-vec3.h"

#include <math.h>

/* The residual image's refine level (SonarImagerParams.refine_db): its
 * strongest echoes cancelled, its maximum is mostly what a cancellation
 * left, and within 20 dB of it lie the other residues: the noise gate
 * (refine_pfa) alone decides what is imaged in full. Measured: the same
 * objects found on the foreign scenes, the search 1.5 times cheaper on
 * fig9 and crossing (sonar-bench --sweep residual-search). */
#define REFINE_DB 0.5

struct _SonarResidualSearch
{
  SonarImager *imager;
  SonarClusterer *clusterer;
  guint n_hypotheses;
  SonarHypothesis *hypotheses;
  SonarComplex *residual;       /* n_microphones x n_bins */
  float *image;
  SonarCentroid *found;         /* the residual image's centroids */
  SonarCentroid *centroids;     /* those that are no residue */
  SonarVelocityEstimate *results;       /* 2 per centroid */
  guint *counts;
  guint n_emitters;             /* in the velocity product */
  gboolean imaged;
  guint estimated;
};

guint64
sonar_residual_search_memory (const SonarSetup * setup,
    const SonarBand * band, const SonarImageGrid * grid)
{
  return sonar_memory_add (sonar_memory_array ((guint64)
          setup->geometry.n_microphones * band->n_bins, sizeof (SonarComplex)),
      sonar_memory_array (sonar_image_grid_size (grid), sizeof (float)));
}

SonarResidualSearch *
sonar_residual_search_new (SonarSetup * setup, const SonarBand * band,
    SonarDopplerBank * bank, const SonarImageGrid * grid, guint n_emitters,
    GError ** error)
{
  g_autoptr (SonarResidualSearch) s = g_new0 (SonarResidualSearch, 1);
  g_autofree guint *indices = NULL;
  SonarImagerParams imaging;
  SonarClusterParams clustering;

  /* The grid's directions and ranges, and the coarse spacing its shape
   * gives (not the set-up's field of view: a 3-D grid may be asked of a
   * fan's set-up). */
  sonar_imager_params_init_default (&imaging);
  sonar_imager_params_set_grid (&imaging, grid);
  sonar_imager_params_fit_beam (&imaging);
  imaging.refine_db = REFINE_DB;
  s->imager = sonar_imager_new (setup, band, &imaging, error);
  if (!s->imager)
    return NULL;
  if (!sonar_image_grid_equal (sonar_imager_grid (s->imager), grid)) {
    g_set_error (error, SONAR_ERROR, SONAR_ERROR_SETTINGS,
        "the residual search cannot image the energyscape's grid again "
        "(%u x %u directions, %u ranges from %g m every %g m)",
        grid->n_azimuth, grid->n_elevation, grid->n_range,
        grid->range_first, grid->range_step);
    return NULL;
  }
  indices = g_new (guint, sonar_doppler_bank_n_velocities (bank) + 2);
  s->n_hypotheses = sonar_doppler_bank_hypotheses (bank,
      sonar_setup_hypothesis_spacing (setup), indices);
  s->hypotheses = g_new (SonarHypothesis, s->n_hypotheses);
  for (guint h = 0; h < s->n_hypotheses; h++)
    s->hypotheses[h] = sonar_doppler_bank_hypothesis (bank, indices[h]);

  sonar_cluster_params_init_default (&clustering);
  clustering.hypotheses = s->n_hypotheses;
  s->clusterer = sonar_clusterer_new (grid, &clustering, error);
  if (!s->clusterer)
    return NULL;

  s->n_emitters = n_emitters;
  s->residual = g_new (SonarComplex, (gsize) setup->geometry.n_microphones *
      band->n_bins);
  s->image = g_new (float, sonar_image_grid_size (grid));
  s->found = g_new (SonarCentroid, SONAR_RESIDUAL_MAX_CENTROIDS);
  s->centroids = g_new (SonarCentroid, SONAR_RESIDUAL_MAX_CENTROIDS);
  s->results = g_new (SonarVelocityEstimate,
      2 * SONAR_RESIDUAL_MAX_CENTROIDS);
  s->counts = g_new (guint, SONAR_RESIDUAL_MAX_CENTROIDS);
  return g_steal_pointer (&s);
}

void
sonar_residual_search_free (SonarResidualSearch * s)
{
  if (!s)
    return;
  g_clear_pointer (&s->imager, sonar_imager_free);
  g_clear_pointer (&s->clusterer, sonar_clusterer_free);
  g_free (s->hypotheses);
  g_free (s->residual);
  g_free (s->image);
  g_free (s->found);
  g_free (s->centroids);
  g_free (s->results);
  g_free (s->counts);
  g_free (s);
}

/* Whether a point at @range m in direction @u (and, unless NaN, of
 * radial velocity @velocity) lies in the resolution cell of the accepted
 * echo @e: its residue (sonar-residual.h). The directions are compared
 * in the array's plane (x and y of the unit vectors), where the beam is
 * as wide at every direction: towards +-90 degrees it widens as
 * 1 / cos, and residues 8 degrees off an echo at 84 degrees lie 0.025
 * apart. */
static gboolean
in_cell (const SonarVelocityEstimate * e, double range, SonarVec3 u,
    double velocity)
{
  const SonarVec3 ue = sonar_vec3_from_direction (e->echo_azimuth,
      e->echo_elevation);

  return fabs (range - e->echo_range) <= SONAR_RESIDUE_RANGE
      && hypot (u.x - ue.x, u.y - ue.y) <= SONAR_RESIDUE_DIRECTION
      && (isnan (velocity) || fabs (velocity - e->radial_velocity) <=
      SONAR_RESIDUE_VELOCITY);
}

/* Whether the point is the residue of one of the ping's valid estimates. */
static gboolean
residue (guint n_centroids, const SonarVelocityEstimate * results,
    const guint * counts, double range, SonarVec3 u, double velocity)
{
  for (guint k = 0; k < n_centroids; k++)
    for (guint i = 0; i < counts[k]; i++)
      if (results[2 * k + i].valid && in_cell (&results[2 * k + i], range,
              u, velocity))
        return TRUE;
  return FALSE;
}

guint
sonar_residual_search_process (SonarResidualSearch * s,
    SonarVelocityPool * pool, guint n_centroids,
    const SonarVelocityEstimate * results, const guint * counts,
    const SonarCentroid ** new_centroids,
    const SonarVelocityEstimate ** new_results, const guint ** new_counts)
{
  gboolean any_valid = FALSE;
  guint n_found, n = 0;

  *new_centroids = s->centroids;
  *new_results = s->results;
  *new_counts = s->counts;
  s->imaged = FALSE;
  s->estimated = 0;
  for (guint k = 0; k < n_centroids && !any_valid; k++)
    for (guint i = 0; i < counts[k]; i++)
      any_valid |= results[2 * k + i].valid;
  /* Without an accepted echo the residual is the ping itself. */
  if (!any_valid)
    return 0;

  sonar_velocity_pool_residual (pool, results, counts, n_centroids,
      s->residual);
  sonar_imager_process (s->imager, s->residual, s->n_hypotheses,
      s->hypotheses, -1, s->image);
  s->imaged = TRUE;
  n_found = sonar_clusterer_process (s->clusterer, s->image, s->found,
      SONAR_RESIDUAL_MAX_CENTROIDS);
  for (guint c = 0; c < n_found; c++) {
    const SonarCentroid *f = &s->found[c];
    if (!residue (n_centroids, results, counts, f->range,
            sonar_vec3_from_direction (f->azimuth, f->elevation), NAN))
      s->centroids[n++] = *f;
  }
  s->estimated = n;
  if (!n)
    return 0;
  sonar_velocity_pool_estimate_residual (pool, s->residual, s->centroids, n,
      s->results, s->counts);
  for (guint k = 0; k < n; k++)
    for (guint i = 0; i < s->counts[k]; i++) {
      SonarVelocityEstimate *e = &s->results[2 * k + i];
      if (e->valid && (e->agreeing_emitters < s->n_emitters
              || residue (n_centroids, results, counts, e->echo_range,
                  sonar_vec3_from_direction (e->echo_azimuth,
                      e->echo_elevation), e->radial_velocity)))
        e->valid = FALSE;
    }
  return n;
}

const SonarImager *
sonar_residual_search_imager (const SonarResidualSearch * s)
{
  return s->imager;
}

void
sonar_residual_search_last_work (const SonarResidualSearch * s,
    guint * units, guint * passes, guint * estimated)
{
  guint dense_units, dense_passes;

  *units = *passes = 0;
  if (s->imaged)
    sonar_imager_last_work (s->imager, units, &dense_units, passes,
        &dense_passes);
  *estimated = s->estimated;
}
