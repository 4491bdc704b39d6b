/* sonar-egomotion.c: the sensor's velocity from one ping (sonar-egomotion.h). */
#include "sonar-egomotion.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "sonar-error.h"
#include "sonar-linalg.h"
#include "sonar-rng.h"

#define DEG (M_PI / 180.0)
#define MAX_ITERATIONS 10
/* Two directions closer than this (sine of their angle; 3-D: the triple
 * product) make no hypothesis: the noise would decide it. */
#define MIN_MINIMAL_SET_DETERMINANT 0.02
/* Fixed, so that a ping always gives the same estimate. */
#define SAMPLING_SEED 0x5eed

void
sonar_sigma_model_init_default (SonarSigmaModel * model)
{
  model->range = 0.003;
  model->direction_sine = 0.002;
  model->max_direction = 5.0;
  model->radial_velocity = 0.005;
}

SonarVec3
sonar_measurement_direction (const SonarMeasurement * m)
{
  return sonar_vec3_from_direction (m->azimuth, m->elevation);
}

void
sonar_measurement_set_nominal_sigma (SonarMeasurement * m,
    const SonarSigmaModel * model)
{
  const double max_direction = model->max_direction * DEG;
  const double cos_el = cos (m->elevation * DEG);
  const double cos_az = cos (m->azimuth * DEG);
  /* The array measures the direction cosines u_x = cos(el) sin(az) and
   * u_y = sin(el) with sigma direction_sine each. */
  const double s_az = model->direction_sine / fabs (cos_el * cos_az);
  const double s_el = model->direction_sine / fabs (cos_el);

  m->sigma_range = model->range;
  m->sigma_azimuth = isfinite (s_az) ? MIN (s_az, max_direction) :
      max_direction;
  m->sigma_elevation = isfinite (s_el) ? MIN (s_el, max_direction) :
      max_direction;
  m->sigma_radial_velocity = model->radial_velocity;
}

void
sonar_ego_params_init_default (SonarEgoParams * p)
{
  memset (p, 0, sizeof (*p));
  p->dimensions = 0;
  p->gate = 3.0;
  p->min_still = 3;
  p->min_spread = 5.0;
  p->ambiguity = 2.0 / 3.0;
  p->max_hypotheses = 500;
  p->min_span = 1.0;
  p->max_chance = 0.05;
  p->mirror_z = FALSE;
  p->has_prior = FALSE;
  p->prior_sigma = 0.0;
}

static const char *const status_names[] = {
  "observed", "too-few-still", "no-spread", "ambiguous",
};

const char *
sonar_ego_status_to_string (SonarEgoStatus status)
{
  g_return_val_if_fail ((guint) status < G_N_ELEMENTS (status_names), NULL);
  return status_names[status];
}

/* A detection prepared for the fits: its direction (and the mirror
 * image's), the derivatives of the direction along azimuth and elevation,
 * and its sigmas. */
typedef struct
{
  SonarVec3 u[2];               /* front, mirror image (behind the array) */
  SonarVec3 du_az[2], du_el[2];
  double vr;
  double var_vr, var_az, var_el;
  guint index;                  /* in the caller's array */
} Item;

struct _SonarEgoEstimator
{
  SonarEgoParams params;
  Item *items;
  guint capacity;
  /* Per hypothesis: its velocity. */
  SonarVec3 *hypotheses;
  guint hypotheses_capacity;
  gboolean *inlier;             /* per item, the winner's */
  gint8 *side;                  /* per item: 0 front, 1 behind */
  gboolean *rival;              /* per item, a rival hypothesis's own */
};

SonarEgoEstimator *
sonar_ego_estimator_new (const SonarEgoParams * p, GError ** error)
{
  SonarEgoEstimator *est;

  if (p->dimensions != 0 && p->dimensions != 2 && p->dimensions != 3) {
    g_set_error (error, SONAR_ERROR, SONAR_ERROR_SETTINGS, "ego-motion: "
        "dimensions must be 0 (as the directions allow), 2 or 3, not %u",
        p->dimensions);
    return NULL;
  }
  if (!(p->gate > 0.0 && p->gate <= 100.0)) {
    g_set_error (error, SONAR_ERROR, SONAR_ERROR_SETTINGS, "ego-motion: the "
        "still gate must be in (0, 100] standard deviations, not %g",
        p->gate);
    return NULL;
  }
  if (p->min_still < 2 || p->min_still > 1000) {
    g_set_error (error, SONAR_ERROR, SONAR_ERROR_SETTINGS, "ego-motion: "
        "min-still must be in [2, 1000], not %u", p->min_still);
    return NULL;
  }
  if (!(p->min_spread >= 0.0 && p->min_spread <= 45.0)) {
    g_set_error (error, SONAR_ERROR, SONAR_ERROR_SETTINGS, "ego-motion: "
        "min-spread must be in [0, 45] degrees, not %g", p->min_spread);
    return NULL;
  }
  if (!(p->ambiguity > 0.0 && p->ambiguity <= 1.0)) {
    g_set_error (error, SONAR_ERROR, SONAR_ERROR_SETTINGS, "ego-motion: "
        "ambiguity must be in (0, 1], not %g", p->ambiguity);
    return NULL;
  }
  if (!(p->min_span > 0.0 && p->min_span <= 100.0)) {
    g_set_error (error, SONAR_ERROR, SONAR_ERROR_SETTINGS, "ego-motion: "
        "min-span must be in (0, 100] m/s, not %g", p->min_span);
    return NULL;
  }
  if (!(p->max_chance > 0.0 && p->max_chance <= 1.0)) {
    g_set_error (error, SONAR_ERROR, SONAR_ERROR_SETTINGS, "ego-motion: "
        "max-chance must be in (0, 1], not %g", p->max_chance);
    return NULL;
  }
  if (p->max_hypotheses < 1 || p->max_hypotheses > 100000) {
    g_set_error (error, SONAR_ERROR, SONAR_ERROR_SETTINGS, "ego-motion: "
        "max-hypotheses must be in [1, 100000], not %u", p->max_hypotheses);
    return NULL;
  }
  if (p->has_prior && !(p->prior_sigma > 0.0 && isfinite (p->prior_sigma)
          && isfinite (sonar_vec3_norm (p->prior_velocity)))) {
    g_set_error (error, SONAR_ERROR, SONAR_ERROR_SETTINGS, "ego-motion: a "
        "prior velocity needs finite components and a sigma above 0 m/s");
    return NULL;
  }
  est = g_new0 (SonarEgoEstimator, 1);
  est->params = *p;
  est->hypotheses_capacity = p->max_hypotheses + 1;
  est->hypotheses = g_new (SonarVec3, est->hypotheses_capacity);
  return est;
}

void
sonar_ego_estimator_free (SonarEgoEstimator * est)
{
  if (!est)
    return;
  g_free (est->items);
  g_free (est->hypotheses);
  g_free (est->inlier);
  g_free (est->side);
  g_free (est->rival);
  g_free (est);
}

void
sonar_ego_estimator_set_prior (SonarEgoEstimator * est, SonarVec3 velocity,
    double sigma)
{
  est->params.has_prior = sigma > 0.0 && isfinite (sigma)
      && isfinite (sonar_vec3_norm (velocity));
  est->params.prior_velocity = velocity;
  est->params.prior_sigma = est->params.has_prior ? sigma : 0.0;
}

static SonarVec3
mirror (SonarVec3 v)
{
  return sonar_vec3 (v.x, v.y, -v.z);
}

static void
prepare_item (Item * it, const SonarMeasurement * m, guint index)
{
  const double az = m->azimuth * DEG, el = m->elevation * DEG;

  it->u[0] = sonar_measurement_direction (m);
  it->du_az[0] = sonar_vec3 (cos (el) * cos (az), 0.0, -cos (el) * sin (az));
  it->du_el[0] = sonar_vec3 (-sin (el) * sin (az), cos (el),
      -sin (el) * cos (az));
  it->u[1] = mirror (it->u[0]);
  it->du_az[1] = mirror (it->du_az[0]);
  it->du_el[1] = mirror (it->du_el[0]);
  it->vr = m->radial_velocity;
  it->var_vr = m->sigma_radial_velocity * m->sigma_radial_velocity;
  it->var_az = m->sigma_azimuth * m->sigma_azimuth;
  it->var_el = m->sigma_elevation * m->sigma_elevation;
  it->index = index;
}

/* The velocity restricted to the estimated axes: x, z in 2-D. */
static SonarVec3
project (SonarVec3 v, guint dims)
{
  return dims == 2 ? sonar_vec3 (v.x, 0.0, v.z) : v;
}

/* Residual of (1) for side @s and its variance under velocity @v. */
static double
residual (const Item * it, guint s, SonarVec3 v, double *variance)
{
  const double d_az = sonar_vec3_dot (it->du_az[s], v);
  const double d_el = sonar_vec3_dot (it->du_el[s], v);

  *variance = it->var_vr + d_az * d_az * it->var_az + d_el * d_el * it->var_el;
  return it->vr + sonar_vec3_dot (it->u[s], v);
}

/* Squared test statistic of the better side (@side receives it). */
static double
statistic2 (const Item * it, SonarVec3 v, gboolean mirror_z, gint8 * side)
{
  double var, r = residual (it, 0, v, &var);
  double best = r * r / var;

  *side = 0;
  if (mirror_z) {
    r = residual (it, 1, v, &var);
    if (r * r / var < best) {
      best = r * r / var;
      *side = 1;
    }
  }
  return best;
}

/* Solves the minimal set's equations -u_i . v = vr_i; FALSE when its
 * directions are too alike. */
static gboolean
solve_minimal (const Item * const *set, guint dims, SonarVec3 * v)
{
  if (dims == 2) {
    const double a = -set[0]->u[0].x, b = -set[0]->u[0].z;
    const double c = -set[1]->u[0].x, d = -set[1]->u[0].z;
    const double det = a * d - b * c;
    if (fabs (det) < MIN_MINIMAL_SET_DETERMINANT)
      return FALSE;
    *v = sonar_vec3 ((set[0]->vr * d - b * set[1]->vr) / det, 0.0,
        (a * set[1]->vr - c * set[0]->vr) / det);
    return TRUE;
  } else {
    double m[3][3], det, r[3];
    for (guint i = 0; i < 3; i++) {
      m[i][0] = -set[i]->u[0].x;
      m[i][1] = -set[i]->u[0].y;
      m[i][2] = -set[i]->u[0].z;
      r[i] = set[i]->vr;
    }
    det = m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1])
        - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
        + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0]);
    if (fabs (det) < MIN_MINIMAL_SET_DETERMINANT)
      return FALSE;
    /* Cramer's rule */
    {
      double x[3];
      for (guint k = 0; k < 3; k++) {
        double mk[3][3];
        memcpy (mk, m, sizeof mk);
        for (guint i = 0; i < 3; i++)
          mk[i][k] = r[i];
        x[k] = (mk[0][0] * (mk[1][1] * mk[2][2] - mk[1][2] * mk[2][1])
            - mk[0][1] * (mk[1][0] * mk[2][2] - mk[1][2] * mk[2][0])
            + mk[0][2] * (mk[1][0] * mk[2][1] - mk[1][1] * mk[2][0])) / det;
      }
      *v = sonar_vec3 (x[0], x[1], x[2]);
    }
    return TRUE;
  }
}

static double
binomial (guint n, guint k)
{
  double c = 1.0;
  for (guint i = 0; i < k; i++)
    c = c * (n - i) / (i + 1);
  return c;
}

/* The hypotheses: every minimal set, or max_hypotheses random ones. */
static guint
make_hypotheses (SonarEgoEstimator * est, guint n, guint dims)
{
  const SonarEgoParams *p = &est->params;
  const Item *set[3];
  guint count = 0;

  if (binomial (n, dims) <= p->max_hypotheses) {
    for (guint i = 0; i < n; i++)
      for (guint j = i + 1; j < n; j++) {
        set[0] = &est->items[i];
        set[1] = &est->items[j];
        if (dims == 2) {
          if (solve_minimal (set, 2, &est->hypotheses[count]))
            count++;
          continue;
        }
        for (guint k = j + 1; k < n; k++) {
          set[2] = &est->items[k];
          if (solve_minimal (set, 3, &est->hypotheses[count]))
            count++;
        }
      }
  } else {
    SonarRng rng;
    sonar_rng_init (&rng, SAMPLING_SEED, n);
    for (guint h = 0; h < p->max_hypotheses; h++) {
      guint idx[3];
      for (guint k = 0; k < dims; k++) {
        gboolean again;
        do {
          idx[k] = sonar_rng_next (&rng) % n;
          again = FALSE;
          for (guint l = 0; l < k; l++)
            again |= idx[l] == idx[k];
        } while (again);
        set[k] = &est->items[idx[k]];
      }
      if (solve_minimal (set, dims, &est->hypotheses[count]))
        count++;
    }
  }
  if (p->has_prior)
    est->hypotheses[count++] = project (p->prior_velocity, dims);
  return count;
}

static gboolean
within_prior (const SonarEgoParams * p, SonarVec3 v, guint dims)
{
  SonarVec3 d;
  if (!p->has_prior)
    return TRUE;
  d = sonar_vec3_sub (v, project (p->prior_velocity, dims));
  return sonar_vec3_dot (d, d) <= p->gate * p->gate * dims
      * p->prior_sigma * p->prior_sigma;
}

/* Basis components of a vector: (x, z) in 2-D, (x, y, z) in 3-D. */
static void
components (SonarVec3 v, guint dims, double *c)
{
  if (dims == 2) {
    c[0] = v.x;
    c[1] = v.z;
  } else {
    c[0] = v.x;
    c[1] = v.y;
    c[2] = v.z;
  }
}

static SonarVec3
from_components (const double *c, guint dims)
{
  return dims == 2 ? sonar_vec3 (c[0], 0.0, c[1]) : sonar_vec3 (c[0], c[1],
      c[2]);
}

/* Weighted least squares over the inliers of @v (and the prior): the new
 * velocity, its covariance (dims x dims) and the inliers' chi-square.
 * Returns the inlier count. */
static guint
refine (SonarEgoEstimator * est, guint n, guint dims, SonarVec3 * v,
    double *cov, double *chi2)
{
  const SonarEgoParams *p = &est->params;
  const double gate2 = p->gate * p->gate;
  guint n_in = 0;

  for (guint iteration = 0; iteration < MAX_ITERATIONS; iteration++) {
    double normal[9] = { 0 }, rhs[3] = { 0 }, x[3];
    gboolean changed = FALSE;
    n_in = 0;
    *chi2 = 0.0;
    for (guint i = 0; i < n; i++) {
      const Item *it = &est->items[i];
      gint8 side;
      const gboolean in = statistic2 (it, *v, p->mirror_z, &side) <= gate2;
      double a[3], var;

      changed |= in != est->inlier[i] || (in && side != est->side[i]);
      est->inlier[i] = in;
      est->side[i] = side;
      if (!in)
        continue;
      n_in++;
      /* -u . v = vr: row a = -u, weight 1 / variance */
      *chi2 += pow (residual (it, side, *v, &var), 2) / var;
      components (sonar_vec3_scale (it->u[side], -1.0), dims, a);
      for (guint r = 0; r < dims; r++) {
        for (guint c = 0; c < dims; c++)
          normal[r * dims + c] += a[r] * a[c] / var;
        rhs[r] += a[r] * it->vr / var;
      }
    }
    if (p->has_prior) {
      double prior[3];
      const double w = 1.0 / (p->prior_sigma * p->prior_sigma);
      components (p->prior_velocity, dims, prior);
      for (guint r = 0; r < dims; r++) {
        normal[r * dims + r] += w;
        rhs[r] += w * prior[r];
      }
    }
    if (n_in < dims || !sonar_linalg_invert_spd (normal, dims, NULL))
      return n_in;
    sonar_linalg_multiply (normal, rhs, x, dims, dims, 1);
    *v = from_components (x, dims);
    memcpy (cov, normal, sizeof (double) * dims * dims);
    if (!changed && iteration > 0)
      break;
  }
  return n_in;
}

/* RMS angle (degrees) of the directions @use selects (each on its side,
 * @sides NULL: in front) about their mean direction (2-D, in the x-z
 * plane) or their mean plane (3-D). */
static double
spread (const SonarEgoEstimator * est, guint n, guint dims,
    const gboolean * use, const gint8 * sides)
{
  double m[3][3] = { {0} }, values[3], vectors[3][3];
  guint count = 0;

  for (guint i = 0; i < n; i++) {
    SonarVec3 u;
    double c[3];
    if (!use[i])
      continue;
    u = est->items[i].u[sides ? sides[i] : 0];
    if (dims == 2) {
      const double norm = hypot (u.x, u.z);
      if (norm == 0.0)
        continue;
      u = sonar_vec3 (u.x / norm, 0.0, u.z / norm);
    }
    c[0] = u.x;
    c[1] = u.y;
    c[2] = u.z;
    for (guint r = 0; r < 3; r++)
      for (guint k = 0; k < 3; k++)
        m[r][k] += c[r] * c[k];
    count++;
  }
  if (count == 0)
    return 0.0;
  for (guint r = 0; r < 3; r++)
    for (guint k = 0; k < 3; k++)
      m[r][k] /= count;
  sonar_linalg_eigen_symmetric3 ((const double (*)[3]) m, values, vectors);
  return asin (sqrt (CLAMP (values[dims - 1], 0.0, 1.0))) / DEG;
}

static gint
compare_doubles_decreasing (gconstpointer a, gconstpointer b)
{
  const double x = *(const double *) a, y = *(const double *) b;
  return x < y ? 1 : x > y ? -1 : 0;
}

/* Expected number of consensuses as large as the winner's that movers
 * would make by chance (a-contrario, as AC-RANSAC): over the C(n, d)
 * minimal sets of the @n_pool detections that could have made it,
 * C(n - d, k - d) ways to pick the k - d others (@inlier), each
 * inside its gate with probability q_i = 2 gate sigma_i / W (with
 * mirror-z, the width of both images' gates together); the largest q_i
 * are taken. */
static double
chance_consensus (const SonarEgoEstimator * est, guint n, guint dims,
    SonarVec3 v, const gboolean * inlier, guint n_pool)
{
  const SonarEgoParams *p = &est->params;
  double *q = g_newa (double, MAX (n, 1));
  double lowest = G_MAXDOUBLE, highest = -G_MAXDOUBLE, span;
  guint k = 0;
  double log_nfa;

  /* W: movers' radial velocities spread like the ping's, at least
   * min-span. */
  for (guint i = 0; i < n; i++) {
    lowest = MIN (lowest, est->items[i].vr);
    highest = MAX (highest, est->items[i].vr);
  }
  span = MAX (highest - lowest, p->min_span);
  for (guint i = 0; i < n; i++)
    if (inlier[i]) {
      /* The radial velocities inside the gate of either image. */
      double var, lo, hi, width;
      const double front = residual (&est->items[i], 0, v, &var)
          - est->items[i].vr;
      lo = front - p->gate * sqrt (var);
      hi = front + p->gate * sqrt (var);
      width = hi - lo;
      if (p->mirror_z) {
        const double back = residual (&est->items[i], 1, v, &var)
            - est->items[i].vr;
        const double b_lo = back - p->gate * sqrt (var);
        const double b_hi = back + p->gate * sqrt (var);
        width += (b_hi - b_lo) - MAX (0.0, MIN (hi, b_hi) - MAX (lo, b_lo));
      }
      q[k++] = MIN (1.0, width / span);
    }
  if (k <= dims)
    return G_MAXDOUBLE;
  qsort (q, k, sizeof (double), compare_doubles_decreasing);
  log_nfa = log (binomial (n_pool, dims)) + log (binomial (n_pool - dims,
          k - dims));
  for (guint i = 0; i < k - dims; i++)
    log_nfa += log (q[i]);
  return exp (log_nfa);
}

static void
unobservable (SonarEgoMotion * motion, SonarEgoStatus status)
{
  motion->status = status;
  motion->dimensions = 0;
  motion->velocity = sonar_vec3 (0, 0, 0);
  memset (motion->covariance, 0, sizeof motion->covariance);
  motion->chi2 = NAN;
}

/* One estimate in @dims dimensions; the labels are made by the caller. */
static void
estimate_in (SonarEgoEstimator * est, guint n, guint dims,
    SonarEgoMotion * motion)
{
  const SonarEgoParams *p = &est->params;
  const double gate2 = p->gate * p->gate;
  const guint min_still = MAX (p->min_still, dims + 1);
  const guint n_hyp = n >= dims ? make_hypotheses (est, n, dims) :
      (p->has_prior ? make_hypotheses (est, 0, dims) : 0);
  double best_score = G_MAXDOUBLE, cov[9] = { 0 }, chi2 = 0.0;
  SonarVec3 v = sonar_vec3 (0, 0, 0);
  guint n_still;
  gint best = -1;

  for (guint h = 0; h < n_hyp; h++) {
    double score = 0.0;
    if (!within_prior (p, est->hypotheses[h], dims))
      continue;
    for (guint i = 0; i < n && score < best_score; i++) {
      gint8 side;
      score += MIN (statistic2 (&est->items[i], est->hypotheses[h],
              p->mirror_z, &side), gate2);
    }
    if (score < best_score) {
      best_score = score;
      best = h;
    }
  }
  if (best < 0) {
    unobservable (motion, SONAR_EGO_TOO_FEW_STILL);
    return;
  }
  v = est->hypotheses[best];
  memset (est->inlier, 0, sizeof (gboolean) * n);
  n_still = refine (est, n, dims, &v, cov, &chi2);
  motion->n_still = n_still;
  if (n_still < min_still || !within_prior (p, v, dims)) {
    unobservable (motion, SONAR_EGO_TOO_FEW_STILL);
    return;
  }
  if (chance_consensus (est, n, dims, v, est->inlier, n) > p->max_chance) {
    unobservable (motion, SONAR_EGO_TOO_FEW_STILL);
    return;
  }
  if (spread (est, n, dims, est->inlier, est->side) < p->min_spread) {
    unobservable (motion, SONAR_EGO_NO_SPREAD);
    return;
  }
  /* A rival: another hypothesis that fits this share of as many
   * detections as the winner, at least d of them detections the winner
   * rejects, and not likely by chance either. */
  for (guint h = 0; h < n_hyp; h++) {
    guint own = 0, all = 0;
    if (!within_prior (p, est->hypotheses[h], dims))
      continue;
    for (guint i = 0; i < n; i++) {
      gint8 side;
      est->rival[i] = statistic2 (&est->items[i], est->hypotheses[h],
          p->mirror_z, &side) <= gate2;
      all += est->rival[i];
      own += est->rival[i] && !est->inlier[i];
    }
    if (own >= dims && all >= p->ambiguity * n_still
        && chance_consensus (est, n, dims, est->hypotheses[h], est->rival,
            n) <= p->max_chance) {
      unobservable (motion, SONAR_EGO_AMBIGUOUS);
      return;
    }
  }
  motion->status = SONAR_EGO_OBSERVED;
  motion->dimensions = dims;
  motion->velocity = v;
  {
    /* Scaled up, never down, by the fit's chi-square per degree of
     * freedom; the prior adds dims equations. */
    const int dof = (int) n_still + (p->has_prior ? (int) dims : 0)
        - (int) dims;
    const double scale = dof > 0 ? MAX (1.0, chi2 / dof) : 1.0;
    guint axes[3] = { 0, 2, 0 };
    if (dims == 3) {
      axes[1] = 1;
      axes[2] = 2;
    }
    memset (motion->covariance, 0, sizeof motion->covariance);
    for (guint r = 0; r < dims; r++)
      for (guint c = 0; c < dims; c++)
        motion->covariance[axes[r]][axes[c]] = cov[r * dims + c] * scale;
    motion->chi2 = dof > 0 ? chi2 / dof : NAN;
  }
}

void
sonar_ego_estimate (SonarEgoEstimator * est,
    const SonarMeasurement * detections, guint n_detections,
    SonarEgoMotion * motion, SonarEgoLabel * labels)
{
  const SonarEgoParams *p = &est->params;
  guint n = 0, dims = p->dimensions;

  if (n_detections > est->capacity) {
    est->capacity = n_detections;
    est->items = g_renew (Item, est->items, est->capacity);
    est->inlier = g_renew (gboolean, est->inlier, est->capacity);
    est->side = g_renew (gint8, est->side, est->capacity);
    est->rival = g_renew (gboolean, est->rival, est->capacity);
  }
  for (guint i = 0; i < n_detections; i++) {
    const SonarMeasurement *m = &detections[i];
    if (isfinite (m->radial_velocity) && isfinite (m->azimuth)
        && isfinite (m->elevation) && m->sigma_radial_velocity > 0.0)
      prepare_item (&est->items[n++], m, i);
  }
  memset (motion, 0, sizeof (*motion));
  motion->n_used = n;
  if (dims == 0) {
    /* 3-D when the directions leave their mean plane. */
    gboolean *all = g_newa (gboolean, MAX (n, 1));
    for (guint i = 0; i < n; i++)
      all[i] = TRUE;
    dims = spread (est, n, 3, all, NULL) >= MAX (p->min_spread, 1.0) ? 3 : 2;
    estimate_in (est, n, dims, motion);
    if (dims == 3 && motion->status != SONAR_EGO_OBSERVED)
      estimate_in (est, n, 2, motion);
  } else {
    estimate_in (est, n, dims, motion);
  }
  if (!labels)
    return;
  for (guint i = 0; i < n_detections; i++) {
    labels[i].still = FALSE;
    labels[i].behind = FALSE;
    labels[i].statistic = NAN;
  }
  if (motion->status != SONAR_EGO_OBSERVED)
    return;
  for (guint i = 0; i < n; i++) {
    const Item *it = &est->items[i];
    double best = G_MAXDOUBLE, front = G_MAXDOUBLE;
    for (guint s = 0; s < (p->mirror_z ? 2u : 1u); s++) {
      double var, r = residual (it, s, motion->velocity, &var);
      const SonarVec3 u = it->u[s];
      double z2;
      /* The estimate's own uncertainty: u^T P u. */
      for (guint a = 0; a < 3; a++) {
        const double ua = a == 0 ? u.x : a == 1 ? u.y : u.z;
        for (guint b = 0; b < 3; b++)
          var += ua * motion->covariance[a][b] * (b == 0 ? u.x : b == 1 ?
              u.y : u.z);
      }
      z2 = r * r / var;
      if (s == 0)
        front = z2;
      best = MIN (best, z2);
    }
    labels[it->index].statistic = sqrt (best);
    labels[it->index].still = best <= p->gate * p->gate;
    labels[it->index].behind = labels[it->index].still && front > p->gate
        * p->gate;
  }
}
