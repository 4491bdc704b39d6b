/* sonar-cluster.h: reflector centroids from a sonar image (paper Sec.
 * III.A, Fig. 5), the core of the wardcluster stage.
 *
 * 1. Threshold: pixels below a level relative to the image maximum (and,
 *    optionally, below an absolute level) are ignored.
 * 2. Peaks: the remaining local maxima over the 8-neighbourhood (azimuth x
 *    range) or, for a 3-D image, the 26-neighbourhood (elevation x azimuth
 *    x range). Equal values are ordered by pixel index, so a plateau gives
 *    one deterministic peak. Each peak's position is refined below the grid
 *    step by a parabola through the logarithms of its neighbours along each
 *    axis (exact for a Gaussian lobe).
 * 3. Agglomerative hierarchical clustering of the peaks' sensor frame
 *    positions (m), Euclidean distances, with SciPy's linkage methods (Ward
 *    by default, eq. 14; sonar-linkage.h).
 * 4. Stop: SciPy's inconsistency coefficient over @depth levels of links
 *    (the paper's three sub-branches), or a distance cut.
 * 5. One centroid per flat cluster, strongest first.
 *
 * Why Cartesian positions and the inconsistency: the point spread function
 * is a few degrees wide at broadside but widens as 1 / cos (azimuth)
 * towards +-90 degrees, so a fixed distance cut either splits a reflector
 * at 80 degrees or merges neighbours at broadside. The coefficient compares
 * a link with the links below it, so it adapts to each cluster's own scale;
 * metres keep the distances physical.
 *
 * Sparse clusters: a reflector often gives only one to three peaks. The
 * coefficient of a link over k links (itself and those below it within the
 * depth) cannot exceed (k - 1) / sqrt (k): 0 for a link joining two single
 * peaks, 0.71 over two links. Such a link would always merge, whatever the
 * distance: two lone reflectors a metre apart would become one. So a link
 * whose coefficient cannot exceed the threshold is judged by the distance
 * cut instead (sonar_fcluster_inconsistent () itself stays SciPy's).
 *
 * The threshold, 1.0: on simulated MIMO images (tests and the fig9, fig10
 * and default scenes) every reflector above a -20 dB threshold keeps its
 * own centroid (median error 1.4 mm) for 0.8 to 1.5. Above 1.0 the
 * reflectors start absorbing peaks of their cross-talk ridges (median
 * error 1.8 mm) while the ridges still break into many clusters. Evenly
 * spaced peaks along an arc are split even at 1.5 (their Ward heights grow
 * steadily), as in SciPy.
 */
#ifndef SONAR_CLUSTER_H
#define SONAR_CLUSTER_H

#include <glib.h>

#include "sonar-image-grid.h"
#include "sonar-linkage.h"
#include "sonar-vec3.h"

G_BEGIN_DECLS

/* SciPy's fcluster criteria 'inconsistent' and 'distance'. */
typedef enum
{
  SONAR_STOP_INCONSISTENCY,
  SONAR_STOP_DISTANCE,
} SonarStopCriterion;

typedef struct
{
  /* Threshold and cluster the image times r^2: echoes weaken as
   * 1 / (2 r)^2 (paper eq. 6), so without it a far object falls below a
   * near one's relative threshold. Peak values and energies are then of the
   * compensated image. The cross-talk ridges it lifts behind near objects
   * are velocityest's to reject. */
  gboolean range_compensation;
  /* dB relative to the image's maximum (<= 0): weaker pixels are no peaks.
   * With range compensation the objects of a scene come out at similar
   * levels and cross-talk ridges 10-20 dB below them: -10 dB. */
  double threshold_db;
  /* dB above the noise floor of the pixel's range bin (the lower quartile
   * over the directions, which objects occupy few of): weaker pixels are
   * no peaks, so that noise alone makes none (a CFAR detector). 0 turns it
   * off. */
  double floor_db;
  /* Linear envelope value: weaker pixels are no peaks; 0 turns it off. */
  double absolute_threshold;
  SonarLinkage linkage;
  SonarStopCriterion stop;
  /* Dimensionless: a link whose inconsistency coefficient exceeds this (or
   * has a link below it that does) is not merged. */
  double inconsistency;
  /* Levels of links in the coefficient: the link itself and its sub-links
   * down to depth - 1 levels below it (>= 1). */
  guint depth;
  /* m: links higher than this are not merged, with SONAR_STOP_DISTANCE;
   * with SONAR_STOP_INCONSISTENCY, for the links whose coefficient cannot
   * exceed the threshold. The height is the linkage's own (for Ward,
   * sqrt (2 x the increase of the sum of squared errors), eq. 14): the
   * distance between the points for two single peaks. */
  double distance;
  /* Peaks fed to the clustering, the strongest kept (1 to 4096). Memory:
   * O(max_peaks), and 8 max_peaks^2 bytes for the distance matrix of the
   * complete and average linkages. */
  guint max_peaks;
} SonarClusterParams;

/* Range compensation on; thresholds -10 dB, 15 dB over the floor, and
 * absolute off; Ward, inconsistency
 * 1.0 over depth 3; distance 0.1 m; 2000 peaks. */
void sonar_cluster_params_init_default (SonarClusterParams * params);

typedef struct
{
  /* Energy-weighted centroid: range is the weighted mean of the member
   * peaks' ranges (m), azimuth and elevation (degrees) the direction of the
   * weighted mean of their unit direction vectors. Weights are the peak
   * values squared. Averaging the Cartesian positions instead would pull an
   * arc-shaped cluster (the smeared lobe near +-90 degrees) inside its arc,
   * by 1.5 % of the range for +-10 degrees. */
  double range, azimuth, elevation;
  SonarVec3 position;           /* the same point in the sensor frame, m */
  double peak_value;            /* strongest member peak (linear envelope) */
  double energy;                /* sum of the member peak values squared */
  guint n_members;              /* peaks in the cluster */
  /* Grid indices of the strongest member peak. */
  guint peak_azimuth_index, peak_elevation_index, peak_range_index;
} SonarCentroid;

typedef struct _SonarClusterer SonarClusterer;

/* Allocates everything process needs (sized by params->max_peaks) for
 * images on @grid. */
SonarClusterer *sonar_clusterer_new (const SonarImageGrid * grid,
    const SonarClusterParams * params, GError ** error);
void sonar_clusterer_free (SonarClusterer * c);

/* Clusters the peaks of @image (laid out as the grid says) and writes at
 * most @max_centroids centroids, strongest peak first. Returns how many were
 * written. Non-finite pixels are ignored. Never allocates. */
guint sonar_clusterer_process (SonarClusterer * c, const float *image,
    SonarCentroid * centroids, guint max_centroids);

/* Peaks found by the last process call (before the max_peaks cap). */
guint sonar_clusterer_n_peaks (const SonarClusterer * c);

G_DEFINE_AUTOPTR_CLEANUP_FUNC (SonarClusterer, sonar_clusterer_free)

G_END_DECLS

#endif
