/* sonar-egomotion.h: the sensor's own velocity from one ping's detections,
 * and which detections are still in the world.
 *
 * A still object seen from a sensor moving at v (sensor frame, relative to
 * the still world; the sensor translates without turning) has the radial
 * velocity
 *
 *     v_r = -u . v                                    (1)
 *
 * u being the unit vector towards it. Each detection gives one such
 * equation; two (2-D) or three (3-D) still objects in different
 * directions give v, more give it by least squares (Kellner et al., ITSC
 * 2013, for radar). Movers do not obey (1): they are outliers.
 *
 * Estimate, robust to movers (MSAC, then weighted least squares):
 *  1. hypotheses: v from every minimal set of 2 (3) detections, all of
 *     them while there are at most max-hypotheses, else that many drawn
 *     from a fixed seed (reproducible); the prior velocity, if any, is one
 *     more;
 *  2. each hypothesis is scored by sum_i min(z_i^2, gate^2), z_i the
 *     residual of (1) over its standard deviation (the radial velocity's
 *     sigma and the direction's, propagated through (1)); the best wins;
 *  3. least squares over its inliers (|z_i| <= gate), with the prior as
 *     pseudo-measurements, repeated until the inliers stay the same; the
 *     covariance is the inverse normal matrix, scaled up (never down) by
 *     the inliers' chi-square per degree of freedom.
 *
 * Breakdown point: any d detections fit some v exactly (d = 2 or 3), so
 * a group of movers that shares one apparent ego velocity (walking
 * together) is as plausible in one ping as the still world. The estimate
 * is right when the still detections are at least min-still and
 * outnumber every such group; movers that share no apparent velocity
 * (most do not) may be any share of the detections. When another
 * hypothesis fits at least `ambiguity` (2/3) as many detections, d or
 * more of them detections the winner rejects, and that support is not
 * likely by chance either (below), the ping is "ambiguous" and reported
 * unobservable: never confidently wrong unless a coherent group of movers
 * outnumbers the still detections by 3 to 2. A prior velocity
 * (odometry) with its sigma removes the ambiguity: hypotheses beyond its
 * gate are not considered.
 *
 * Chance: in 2-D any two detections fit some v, and a third mover fits it
 * too when its radial velocity happens to fall inside the gate. The
 * winner is kept only when movers would make a consensus as large by
 * chance fewer than max-chance (0.05) times (a-contrario, as AC-RANSAC):
 * over the C(n, d) minimal sets and the C(n - d, k - d) choices of the
 * k - d other inliers, each inside its gate with probability q_i =
 * 2 gate sigma_i / W (with mirror-z, the width of both images' gates
 * together: up to twice that), W the span of the ping's radial
 * velocities, at least min-span (1 m/s); the largest q_i are taken. With
 * the default sigmas, three still objects alone seen by a planar array
 * moving at 0.3 m/s give 3 x 0.06 = 0.18: unobservable (0.09, observable,
 * without the mirror); four give 6 x 0.06^2 = 0.02.
 *
 * Unobservable (a status, no number): fewer than min-still detections fit
 * one velocity, or a consensus that size is likely by chance
 * (too-few-still), or their directions spread less than min-spread (the RMS
 * angle about their mean direction in 2-D, about their mean plane in
 * 3-D), or ambiguous.
 *
 * Dimensions: 3 when the detections' directions leave their mean plane
 * by min-spread, else 2: the velocity in the x-z plane (the fan's), its y
 * component not measured (reported as 0, with 0 variance, by assumption).
 *
 * A planar array (every element at z = 0) cannot tell a direction from its
 * mirror image through the array's plane: an object behind the array is
 * imaged in front, at (x, y, -z) (mirror-z). Each detection is then still
 * when either direction fits (1); "behind" says it was the mirror image.
 *
 * Each detection's label: still or moving in the world, with its test
 * statistic, the residual of (1) in standard deviations of the residual
 * (the detection's and the estimate's), against the gate.
 */
#ifndef SONAR_EGOMOTION_H
#define SONAR_EGOMOTION_H

#include <glib.h>
#include "sonar-vec3.h"

G_BEGIN_DECLS

/* One detection as the estimators read it, with its 1-sigma
 * uncertainties. */
typedef struct
{
  double instant;               /* s: when it was at this position and speed */
  double range;                 /* m */
  double azimuth, elevation;    /* degrees */
  double radial_velocity;       /* m/s, d(range)/dt; NaN: not measured */
  double sigma_range;           /* m */
  double sigma_azimuth, sigma_elevation;        /* radians */
  double sigma_radial_velocity; /* m/s */
} SonarMeasurement;

/* The nominal uncertainty of a detection, until detections carry their
 * own: constant in range and radial velocity; in direction, constant in
 * the sine of the angle from boresight (what a planar array measures), so
 * that the angle's sigma grows as 1 / cos towards the array's plane, up
 * to max_direction. */
typedef struct
{
  double range;                 /* m */
  double direction_sine;        /* sigma of sin(angle) */
  double max_direction;         /* degrees */
  double radial_velocity;       /* m/s */
} SonarSigmaModel;

/* The defaults, about twice the chain's measured errors on the presets
 * (Fig. 9, Fig. 10, crossing; README): range 3 mm (measured: spread
 * 0.3 mm, bias 1 mm), direction sine 0.002 (0.11 degrees at boresight;
 * measured spread 0.0006-0.0009, worst 0.003), at most 5 degrees, radial
 * velocity 0.005 m/s (measured spread 0.002-0.003, worst 0.01). */
void sonar_sigma_model_init_default (SonarSigmaModel * model);

/* Fills @m's sigmas from its position and @model. The one place that
 * says how uncertain a detection is: replace it when detections carry
 * measured uncertainties. */
void sonar_measurement_set_nominal_sigma (SonarMeasurement * m,
    const SonarSigmaModel * model);

/* Unit vector towards @m (sensor frame). */
SonarVec3 sonar_measurement_direction (const SonarMeasurement * m);

typedef struct
{
  guint dimensions;             /* 0: as the directions allow; 2 or 3 */
  double gate;                  /* standard deviations: a detection within
                                 * this of (1) is still */
  guint min_still;              /* still detections needed (at least
                                 * dimensions + 1) */
  double min_spread;            /* degrees */
  double ambiguity;             /* a rival's share of the winner's support
                                 * that makes the ping ambiguous, 0..1 */
  guint max_hypotheses;
  double min_span;              /* m/s: movers' radial velocities spread at
                                 * least this much (the chance test) */
  double max_chance;            /* chance consensuses expected, at most */
  gboolean mirror_z;            /* planar array: front and back alike */
  gboolean has_prior;
  SonarVec3 prior_velocity;     /* m/s, sensor frame */
  double prior_sigma;           /* m/s, per axis */
} SonarEgoParams;

void sonar_ego_params_init_default (SonarEgoParams * params);

typedef enum
{
  SONAR_EGO_OBSERVED,
  SONAR_EGO_TOO_FEW_STILL,      /* fewer than min-still, or likely by chance */
  SONAR_EGO_NO_SPREAD,          /* their directions spread too little */
  SONAR_EGO_AMBIGUOUS,          /* another velocity fits as many */
} SonarEgoStatus;

/* "observed", "too-few-still", "no-spread", "ambiguous". */
const char *sonar_ego_status_to_string (SonarEgoStatus status);

typedef struct
{
  SonarEgoStatus status;
  guint dimensions;             /* 2 or 3 when observed, else 0 */
  SonarVec3 velocity;           /* m/s, the sensor's, relative to the still
                                 * world, sensor frame; 0 when unobservable */
  double covariance[3][3];      /* (m/s)^2 */
  guint n_still;                /* detections that fit it */
  guint n_used;                 /* detections that entered (with a radial velocity) */
  double chi2;                  /* inliers' chi-square per degree of freedom */
} SonarEgoMotion;

typedef struct
{
  gboolean still;               /* fits the still world (FALSE when unobservable) */
  gboolean behind;              /* fits as the mirror image of an object
                                 * behind a planar array */
  double statistic;             /* |residual| / sigma; NaN: not tested */
} SonarEgoLabel;

typedef struct _SonarEgoEstimator SonarEgoEstimator;

/* NULL with @error (SONAR_ERROR_SETTINGS) for parameters out of range. */
SonarEgoEstimator *sonar_ego_estimator_new (const SonarEgoParams * params,
    GError ** error);
void sonar_ego_estimator_free (SonarEgoEstimator * est);
/* Changes the prior (odometry) between pings: @sigma <= 0 removes it. */
void sonar_ego_estimator_set_prior (SonarEgoEstimator * est,
    SonarVec3 velocity, double sigma);

/* One ping: @n detections in, the ego-motion and (if @labels is not NULL)
 * one label per detection out. Detections without a radial velocity
 * (NaN) are labelled untested. */
void sonar_ego_estimate (SonarEgoEstimator * est,
    const SonarMeasurement * detections, guint n, SonarEgoMotion * motion,
    SonarEgoLabel * labels);

G_DEFINE_AUTOPTR_CLEANUP_FUNC (SonarEgoEstimator, sonar_ego_estimator_free)

G_END_DECLS

#endif /* SONAR_EGOMOTION_H */
