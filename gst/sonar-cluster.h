/* sonar-cluster.h: reflector centroids from a sonar image (paper Sec.
 * III.A, Fig. 5), the core of the wardcluster stage.
 *
 * 1. Thresholds: a pixel is kept when it passes the noise floor of its
 *    range bin over the directions (a CFAR test at a probability of false
 *    alarm per pixel, pfa), the noise floor along its direction (the
 *    column floor, against cross-talk ridges), the sidelobe threshold of
 *    its range, and, if set, a level relative to the image maximum and an
 *    absolute level.
 * 2. Peaks: the remaining local maxima over the 8-neighbourhood (azimuth x
 *    range) or, for a 3-D image, the 26-neighbourhood (elevation x azimuth
 *    x range). Equal values are ordered by pixel index, so a plateau gives
 *    one deterministic peak. Each peak's position is refined below the grid
 *    step by a parabola through the logarithms of its neighbours along
 *    range and, on a 2-D image, azimuth; on a 3-D image its direction by
 *    the quadratic through the logarithms of the 3 x 3 directions around
 *    it, cross term included (the array's beam is tilted in azimuth and
 *    elevation), or its neighbour's where that lands beyond half a step
 *    (exact for a Gaussian lobe, tilted or not).
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
   * Off (-200 dB) by default: it would lose every object that much weaker
   * than the strongest; what a strong echo leaves elsewhere is bounded
   * by sidelobe_db at its range and by the column floor along its
   * direction. */
  double threshold_db;
  /* dB relative to the strongest pixel of the same range (within
   * SONAR_CLUSTER_SIDELOBE_RANGE, any direction), <= 0: weaker pixels
   * are no peaks. A point's delay-and-sum sidelobes lie at its range, the
   * 2-D MIMO image's at most 21.8 dB below its peak (README), the 3-D
   * hemisphere image's 18-20 dB (measured on tests/test_foreign.py's 3-D
   * case: at -20 dB its point at -25/-30 degrees gave a valid duplicate
   * 14 degrees off): -16 dB. An object at the range of one 16 dB
   * stronger is under its sidelobes anyway. -200: off. */
  double sidelobe_db;
  /* Probability that a noise-only pixel passes the noise-floor test (a
   * CFAR detector), per pixel and ping, in (0, 1]; 1 turns the test off.
   * The test: the pixel exceeds its range bin's lower quartile over the
   * directions (objects fill few of them; censored: taken again over the
   * values below the floor it sets, so that a crowd crossing the row
   * does not raise it) times the factor that noise of
   * the image's statistics exceeds with probability pfa
   * (sonar_cluster_floor_gain ()). 1e-10: the default image has about
   * 3e5 pixels (181 directions x 1754 ranges), so noise passes about once
   * in 30,000 pings. At 1e-8 (0.85 dB more sensitive) 1000 noise-only
   * pings gave 2 false objects: noise that high looks like an object to
   * velocityest's tests. The column floor uses the
   * same factor less 2 dB (SONAR_CLUSTER_COLUMN_MARGIN). */
  double pfa;
  /* The Doppler hypotheses each pixel is the maximum of (the energyscape
   * caps' "hypotheses"; 1: one envelope): the maximum of K noise
   * envelopes spreads far less than one does, so the factor over the
   * quartile shrinks with K. */
  guint hypotheses;
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
  /* Workers sharing the passes over the image (the compensation and the
   * noise floors); 0: one per processor. The results do not depend on
   * it. */
  guint threads;
} SonarClusterParams;

/* Range compensation on; relative threshold off, sidelobes -16 dB, pfa
 * 1e-10 over the noise floors with one hypothesis, absolute off; Ward,
 * inconsistency
 * 1.0 over depth 3; distance 0.1 m; 2000 peaks; a thread per processor. */
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
  /* The member peaks' nearest and farthest ranges (m): objects a few
   * centimetres apart in range merge into one cluster, its centroid
   * between them, and velocityest looks for each over this span. */
  double range_min, range_max;
  /* The strongest member peak's own range (m, its sub-pixel fit): its
   * echo's, which the weighted mean above leaves when other members
   * (noise on the echo's range sidelobes, a neighbour) pull it over. */
  double peak_range;
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

/* Takes @params' thresholds (threshold_db, absolute_threshold,
 * sidelobe_db, pfa) and stop criterion (stop, inconsistency, depth,
 * distance) for the next process (): what can change between pings
 * without allocating. The other fields must be those @c was made with;
 * FALSE with @error (SONAR_ERROR_SETTINGS) when they are not, or when a
 * value is out of range, and @c is left as it was. */
gboolean sonar_clusterer_retune (SonarClusterer * c,
    const SonarClusterParams * params, GError ** error);

/* Clusters the peaks of @image (laid out as the grid says) and writes at
 * most @max_centroids centroids, strongest peak first. Returns how many were
 * written. Non-finite pixels are ignored. Never allocates. */
guint sonar_clusterer_process (SonarClusterer * c, const float *image,
    SonarCentroid * centroids, guint max_centroids);

/* The factor over the noise quartile (amplitude) that a pixel of noise
 * alone exceeds with probability @pfa, for an image that is the maximum
 * of @hypotheses Doppler hypotheses' envelopes. The noise envelope of one
 * hypothesis is Rayleigh: P(A <= x) = 1 - exp (-x^2 / 2 s^2). The maximum
 * of K independent ones has the distribution F(x) = (1 - exp (-x^2 /
 * 2 s^2))^K, so its quartile q solves F(q) = 1/4 and the threshold t
 * solves 1 - F(t) = pfa:
 *   q^2 = -2 s^2 ln (1 - 4^(-1/K)),  t^2 = -2 s^2 ln (1 - (1 - pfa)^(1/K)),
 * and the factor is t / q, free of s. Neighbouring hypotheses are
 * correlated (0.3 m/s apart, within one Doppler main lobe), so K enters as
 * the effective count of independent ones, K_eff = 1 + (K - 1) x
 * SONAR_CLUSTER_HYPOTHESIS_SHARE, measured on noise-only images
 * (sonar-bench --sweep noise). */
double sonar_cluster_floor_gain (double pfa, double effective_hypotheses);

/* m either side of a pixel's range whose strongest pixel sets its
 * sidelobe threshold: near the sensor and towards +-90 degrees a point's
 * sidelobes curve off its range, by 1 cm at 1.5 m and -42 degrees for a
 * point at -85 (tests/test-velocityest.c, wide angles). */
#define SONAR_CLUSTER_SIDELOBE_RANGE 0.02

/* K_eff for an image over @hypotheses Doppler hypotheses (see above). */
double sonar_cluster_effective_hypotheses (guint hypotheses);

/* Effective independent hypotheses per further hypothesis (see above):
 * on 100 dense noise-only images over the default 47 hypotheses (0.3 m/s
 * apart), the K_eff that makes the measured exceedance equal the design
 * pfa is 41.1 at 1e-3 and 40.7 at 1e-4: (41 - 1) / 46. */
#define SONAR_CLUSTER_HYPOTHESIS_SHARE 0.87

/* Element @k of @v (@n > @k values) in ascending order, by Hoare's
 * selection: reorders @v so that v[0 .. k) <= v[k] <= v(k .. n). The
 * order statistic the noise floors take (here and sonar-uncertainty.h). */
float sonar_select_kth (float *v, gsize n, gsize k);

/* Share of noise's values the censored noise floor sets aside (its gain
 * is sonar_cluster_floor_gain (SONAR_CLUSTER_CENSOR_SHARE, K_eff)). */
#define SONAR_CLUSTER_CENSOR_SHARE 0.01

/* The noise floor's statistic over @n @values (reorders them; @scratch
 * holds 2 @n floats): their lower quartile, then again over those below
 * @gain times it, until no more are set aside (at most 8 rounds; from the
 * second on at rank 1/4 / (1 - SONAR_CLUSTER_CENSOR_SHARE) of those
 * kept, and not below 4 values). 0 for none. @guess, a value near the
 * result (NaN: none), only makes it faster; the result does not depend on
 * it nor on the values' order (tests/test-cluster.c, censored-quartile). */
float sonar_cluster_censored_quartile (float *values, gsize n, float gain,
    float guess, float *scratch);

/* sonar_cluster_censored_quartile () of 16 (SONAR_RANK_LANES) columns at
 * once, lane j's @n values at x[r * stride + j], r < n, by passes over
 * them (no copies): the same values bit for bit, in q; ok[j] = 0 where a
 * lane's quartile was not found within a bounded number of passes (the
 * caller takes it from sonar_cluster_censored_quartile ()). FALSE, and
 * nothing found, when a value is not finite, @n is 0 or @guess (the
 * first level tried; near the quartiles for speed) is not finite.
 * wardcluster's noise floors (tests/test-cluster.c,
 * censored-quartiles). */
gboolean sonar_cluster_censored_quartiles (const float *x, gsize stride,
    guint n, float gain, float guess, float *q, guint8 * ok);

/* The column floor's factor over the noise floor's (amplitude, -2 dB): an
 * object sits in its own ridge, and seen between the directions of a
 * coarse grid it loses more than the ridge does (the ridge adds up only
 * over the microphones, a wider beam). Measured: at 0.7 a 79-degree
 * point's ridge gives a peak (tests/test-velocityest.c, wide angles), at
 * 1.0 a point 3 degrees off a 6-degree grid is lost
 * (tests/test-stability.c, two reflectors 1 cm apart); 0.75-0.9 keep
 * both. */
#define SONAR_CLUSTER_COLUMN_MARGIN 0.8

/* Range bins per block of the column floor (sonar-cluster.c: 0.15 m, at
 * least 16 bins, at most the grid's). */
guint sonar_cluster_column_bins (const SonarImageGrid * grid);

/* Peaks found by the last process call (before the max_peaks cap). */
guint sonar_clusterer_n_peaks (const SonarClusterer * c);

G_DEFINE_AUTOPTR_CLEANUP_FUNC (SonarClusterer, sonar_clusterer_free)

G_END_DECLS

#endif
