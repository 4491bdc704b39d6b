/* sonar-image-grid.h: the grid of an image (energyscape): directions
 * (azimuth x elevation) x ranges, as the imager makes it and the
 * clusterer and the velocity stage read it. */
#ifndef SONAR_IMAGE_GRID_H
#define SONAR_IMAGE_GRID_H

#include <glib.h>

G_BEGIN_DECLS

typedef struct
{
  guint n_azimuth;
  double azimuth_first, azimuth_step;   /* degrees */
  guint n_elevation;
  double elevation_first, elevation_step;       /* degrees */
  guint n_range;
  double range_first, range_step;       /* m */
} SonarImageGrid;

/* Pixel (elevation e, azimuth a, range i) is image[(e * n_azimuth + a)
 * * n_range + i]. */
static inline gsize
sonar_image_grid_size (const SonarImageGrid * grid)
{
  return (gsize) grid->n_elevation * grid->n_azimuth * grid->n_range;
}

G_END_DECLS

#endif
