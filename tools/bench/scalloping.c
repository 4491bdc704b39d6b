/* sonar-bench's scalloping sweep (issue 13): what a coarse grid of
 * directions loses on an echo between its directions, the fact that
 * decides how far apart the imager's coarse pass may look and still
 * detect what the dense image would.
 *
 * A still point at POINT_RANGE, noise-free, imaged in full (no coarse
 * pass) on tiny grids: in 2-D the directions S apart and the one halfway
 * between, where the point lies; in 3-D a coarse cell's four corners S
 * apart in azimuth and elevation and its centre, where the point lies.
 * The loss is the strongest corner's peak (within PEAK_RANGE of the point)
 * against the centre's: in dB, what the coarse pass sees of an echo at
 * its worst place. At boresight and off to the side (OFF_AXIS degrees of
 * azimuth, where a degree is a smaller step in the array's direction
 * cosines). The elements' defaults otherwise (Fig. 10's bank). */
#include <math.h>

#include "bench.h"

#define POINT_RANGE 2.0
#define PEAK_RANGE 0.05
#define OFF_AXIS 40.0

static const double spacings[] = { 1.0, 2.0, 3.0, 4.0, 6.0, 8.0 };

/* The strongest pixel along direction @d of @image (@g) within
 * PEAK_RANGE of POINT_RANGE. */
static float
direction_peak (const SonarImageGrid * g, const float *image, guint d)
{
  float top = 0.0f;

  for (guint i = 0; i < g->n_range; i++) {
    const double r = g->range_first + i * g->range_step;
    if (fabs (r - POINT_RANGE) <= PEAK_RANGE)
      top = MAX (top, image[(gsize) d * g->n_range + i]);
  }
  return top;
}

/* The loss in dB of a coarse grid @spacing degrees apart on a point
 * halfway (2-D) or at a cell's centre (@cell: 3-D), the cell's first
 * corner at @azimuth, 0 degrees; NaN with @error. */
static double
coarse_loss_db (Chain * ch, SonarSimulator * quiet, SonarSetup * setup,
    double azimuth, double spacing, gboolean cell, GError ** error)
{
  SonarImagerParams p = ch->config->imager;
  g_autoptr (SonarImager) imager = NULL;
  g_autofree float *image = NULL;
  const SonarImageGrid *g;
  SonarReflector point = { 0 };
  static const guint corners[] = { 0, 2, 6, 8 };
  float centre, corner = 0.0f;

  p.azimuth_min = azimuth;
  p.azimuth_max = azimuth + spacing;
  p.n_azimuth = 3;
  p.elevation_min = 0.0;
  p.elevation_max = cell ? spacing : 0.0;
  p.n_elevation = cell ? 3 : 1;
  p.range_min = POINT_RANGE - 2.0 * PEAK_RANGE;
  p.range_max = POINT_RANGE + 2.0 * PEAK_RANGE;
  p.focus_zones = 1;
  p.coarse_spacing = 0.0;
  imager = sonar_imager_new (setup, ch->band, &p, error);
  if (!imager)
    return NAN;
  g = sonar_imager_grid (imager);
  image = g_new (float, sonar_image_grid_size (g));

  point.kind = SONAR_REFLECTOR_POINT;
  point.strength = 1.0;
  point.position = sonar_vec3_scale (sonar_vec3_from_direction (azimuth +
          0.5 * spacing, cell ? 0.5 * spacing : 0.0), POINT_RANGE);
  render_alone (ch, quiet, setup, NULL, &point);
  sonar_imager_process (imager, ch->spectra, ch->n_templates, ch->hypotheses,
      -1, image);

  /* Directions run along azimuth first. */
  centre = direction_peak (g, image, cell ? 4 : 1);
  for (guint k = 0; k < (cell ? 4u : 2u); k++)
    corner = MAX (corner, direction_peak (g, image, corners[k]));
  return 20.0 * log10 (corner / centre);
}

gboolean
run_scalloping (Bench * b)
{
  g_autoptr (GError) error = NULL;
  g_autoptr (SonarSimulator) quiet = NULL;
  g_autofree Chain *ch = g_new0 (Chain, 1);
  Result r = { 0 };
  Config c;

  quiet = bench_simulator_new (b->setup, 0.0, &error);
  config_init (&c, &scenes[SCENE_FIG10]);
  if (!quiet || !chain_init (ch, b, &c, &r, &error))
    goto fail;
  g_print ("\nscalloping: a still point %.1f m away halfway between coarse "
      "directions S apart (2-D) or at a cell's centre (3-D), noise-free; "
      "dB the strongest coarse direction sees of its peak\n"
      "%8s %12s %12s %12s %12s\n", POINT_RANGE, "S deg", "2-D 0 deg",
      "2-D 40 deg", "3-D 0 deg", "3-D 40 deg");
  for (guint i = 0; i < G_N_ELEMENTS (spacings); i++) {
    double loss[4];
    for (guint k = 0; k < 4; k++) {
      loss[k] = coarse_loss_db (ch, quiet, b->setup, k % 2 ? OFF_AXIS : 0.0,
          spacings[i], k >= 2, &error);
      if (isnan (loss[k]))
        goto fail;
    }
    g_print ("%8g %12.1f %12.1f %12.1f %12.1f\n", spacings[i], loss[0],
        loss[1], loss[2], loss[3]);
  }
  chain_clear (ch);
  return TRUE;
fail:
  g_printerr ("scalloping: %s\n", error->message);
  chain_clear (ch);
  return FALSE;
}
