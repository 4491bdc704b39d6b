/* sonar-track.c: tracks across pings (sonar-track.h). */
#include "sonar-track.h"

#include <math.h>
#include <string.h>

#include "sonar-error.h"
#include "sonar-linalg.h"

/* Above this many tracks and detections in gates together, assignment is
 * greedy (cheapest pair first) instead of optimal: the Hungarian algorithm
 * costs n^3. */
#define MAX_OPTIMAL_ASSIGNMENT 256
#define NO_PAIR 1e30

/* The state: the object's centre (sensor frame), its velocity in the
 * world and the radius of its echoing surface. */
#define NX 7
#define RADIUS 6

typedef struct
{
  guint64 id;
  SonarTrackState state;
  double x[NX];
  double p[NX * NX];
  double t;                     /* s: the instant of x */
  double offset;                /* t - ping time at the last detection */
  double last_detection;        /* s */
  guint hits, misses;
  gint detection;
} Track;

struct _SonarTracker
{
  SonarTrackerParams params;
  double gate_threshold[5];     /* chi-square quantile for 0..4 dof */
  double moving_threshold;
  GArray *tracks;               /* Track */
  GArray *reports;              /* SonarTrack */
  guint64 next_id;
  double last_ping;             /* s, NaN before the first */
  /* The sensor's velocity, filtered. */
  double s[3], s_cov[9];
  gboolean s_observed;
  /* Assignment work space. */
  gpointer cost, pair_costs, indices, hungarian_d, hungarian_u;
  gsize cost_capacity, pair_capacity, indices_capacity;
  gsize hungarian_d_capacity, hungarian_u_capacity;
  gint *track_detection;
  gboolean *detection_taken;
  guint *position_gates;        /* per detection: tracks whose position
                                 * gate holds it */
  guint track_capacity, detection_capacity;
};

static const char *const state_names[] = { "tentative", "confirmed" };

/* Grows *@buffer to hold @count items of @size bytes: work space kept
 * from ping to ping, so that a steady stream allocates nothing. */
static gpointer
reserve (gpointer * buffer, gsize * capacity, gsize count, gsize size)
{
  if (count > *capacity) {
    *capacity = MAX (count, 2 * *capacity);
    *buffer = g_realloc_n (*buffer, *capacity, size);
  }
  return *buffer;
}

const char *
sonar_track_state_to_string (SonarTrackState state)
{
  g_return_val_if_fail ((guint) state < G_N_ELEMENTS (state_names), NULL);
  return state_names[state];
}

void
sonar_tracker_params_init_default (SonarTrackerParams * p)
{
  memset (p, 0, sizeof (*p));
  p->dimensions = 3;
  p->acceleration = 0.5;
  p->sensor_acceleration = 1.0;
  p->max_speed = 3.0;
  p->object_radius = 0.1;
  p->gate = 0.9999;
  p->confirm_hits = 3;
  p->max_misses = 5;
  p->max_coast = 1.0;
  p->moving_speed = 0.1;
  p->mirror_z = FALSE;
  p->max_tracks = 1024;
}

/* Chi-square distribution function for 1 to 4 degrees of freedom. */
static double
chi2_cdf (double x, guint dof)
{
  switch (dof) {
    case 1:
      return erf (sqrt (x / 2.0));
    case 2:
      return 1.0 - exp (-x / 2.0);
    case 3:
      return erf (sqrt (x / 2.0)) - sqrt (2.0 * x / M_PI) * exp (-x / 2.0);
    default:
      return 1.0 - exp (-x / 2.0) * (1.0 + x / 2.0);
  }
}

static double
chi2_quantile (double probability, guint dof)
{
  double lo = 0.0, hi = 1000.0;
  for (guint i = 0; i < 100; i++) {
    const double mid = 0.5 * (lo + hi);
    if (chi2_cdf (mid, dof) < probability)
      lo = mid;
    else
      hi = mid;
  }
  return 0.5 * (lo + hi);
}

SonarTracker *
sonar_tracker_new (const SonarTrackerParams * p, GError ** error)
{
  SonarTracker *tr;

#define CHECK(cond, ...) G_STMT_START { if (!(cond)) { \
      g_set_error (error, SONAR_ERROR, SONAR_ERROR_SETTINGS, __VA_ARGS__); \
      return NULL; } } G_STMT_END
  CHECK (p->dimensions == 2 || p->dimensions == 3, "tracks: dimensions "
      "must be 2 or 3, not %u", p->dimensions);
  CHECK (p->acceleration >= 0.0 && p->acceleration <= 1000.0, "tracks: "
      "acceleration must be in [0, 1000] m/s^2, not %g", p->acceleration);
  CHECK (p->sensor_acceleration >= 0.0 && p->sensor_acceleration <= 1000.0,
      "tracks: sensor-acceleration must be in [0, 1000] m/s^2, not %g",
      p->sensor_acceleration);
  CHECK (p->max_speed > 0.0 && p->max_speed <= 100.0, "tracks: max-speed "
      "must be in (0, 100] m/s, not %g", p->max_speed);
  CHECK (p->object_radius >= 0.0 && p->object_radius <= 10.0, "tracks: "
      "object-radius must be in [0, 10] m, not %g", p->object_radius);
  CHECK (p->gate >= 0.5 && p->gate < 1.0, "tracks: the gate probability "
      "must be in [0.5, 1), not %g", p->gate);
  CHECK (p->confirm_hits >= 1 && p->confirm_hits <= 1000, "tracks: "
      "confirm-hits must be in [1, 1000], not %u", p->confirm_hits);
  CHECK (p->max_misses <= 1000, "tracks: max-misses must be at most 1000, "
      "not %u", p->max_misses);
  CHECK (p->max_coast > 0.0 && p->max_coast <= 3600.0, "tracks: max-coast "
      "must be in (0, 3600] s, not %g", p->max_coast);
  CHECK (p->moving_speed >= 0.0 && p->moving_speed <= 100.0, "tracks: "
      "moving-speed must be in [0, 100] m/s, not %g", p->moving_speed);
  CHECK (p->max_tracks >= 1 && p->max_tracks <= 100000, "tracks: "
      "max-tracks must be in [1, 100000], not %u", p->max_tracks);
#undef CHECK
  tr = g_new0 (SonarTracker, 1);
  tr->params = *p;
  for (guint dof = 1; dof <= 4; dof++)
    tr->gate_threshold[dof] = chi2_quantile (p->gate, dof);
  tr->moving_threshold = tr->gate_threshold[p->dimensions];
  tr->tracks = g_array_new (FALSE, FALSE, sizeof (Track));
  tr->reports = g_array_new (FALSE, FALSE, sizeof (SonarTrack));
  tr->next_id = 1;
  sonar_tracker_reset (tr);
  return tr;
}

void
sonar_tracker_free (SonarTracker * tr)
{
  if (!tr)
    return;
  g_array_unref (tr->tracks);
  g_array_unref (tr->reports);
  g_free (tr->cost);
  g_free (tr->pair_costs);
  g_free (tr->indices);
  g_free (tr->hungarian_d);
  g_free (tr->hungarian_u);
  g_free (tr->track_detection);
  g_free (tr->detection_taken);
  g_free (tr->position_gates);
  g_free (tr);
}

void
sonar_tracker_reset (SonarTracker * tr)
{
  g_array_set_size (tr->tracks, 0);
  g_array_set_size (tr->reports, 0);
  tr->last_ping = NAN;
  memset (tr->s, 0, sizeof tr->s);
  memset (tr->s_cov, 0, sizeof tr->s_cov);
  for (guint a = 0; a < 3; a++)
    if (tr->params.dimensions == 3 || a != 1)
      tr->s_cov[a * 3 + a] = tr->params.max_speed * tr->params.max_speed;
  tr->s_observed = FALSE;
}

/* In 2-D, the y components and their covariance are 0. */
static void
flatten (const SonarTracker * tr, double *x, double *p)
{
  if (tr->params.dimensions == 3)
    return;
  x[1] = x[4] = 0.0;
  for (guint i = 0; i < NX; i++) {
    p[1 * NX + i] = p[i * NX + 1] = 0.0;
    p[4 * NX + i] = p[i * NX + 4] = 0.0;
  }
}

/* Moves a state on by @dt seconds (constant velocity, the sensor at s). */
static void
predict (const SonarTracker * tr, double *x, double *p, double dt)
{
  const double q = tr->params.acceleration * tr->params.acceleration;
  double f[NX * NX] = { 0 }, fp[NX * NX];

  if (dt == 0.0)
    return;
  for (guint a = 0; a < 3; a++)
    x[a] += (x[3 + a] - tr->s[a]) * dt;
  for (guint i = 0; i < NX; i++)
    f[i * NX + i] = 1.0;
  for (guint a = 0; a < 3; a++)
    f[a * NX + 3 + a] = dt;
  sonar_linalg_multiply (f, p, fp, NX, NX, NX);
  sonar_linalg_multiply_transposed (fp, f, p, NX, NX, NX);
  /* Piecewise constant white acceleration, and the sensor's velocity's
   * uncertainty carried into the position. */
  for (guint a = 0; a < 3; a++) {
    p[a * NX + a] += q * dt * dt * dt * dt / 4.0;
    p[a * NX + 3 + a] += q * dt * dt * dt / 2.0;
    p[(3 + a) * NX + a] += q * dt * dt * dt / 2.0;
    p[(3 + a) * NX + 3 + a] += q * dt * dt;
    for (guint b = 0; b < 3; b++)
      p[a * NX + b] += tr->s_cov[a * 3 + b] * dt * dt;
  }
  flatten (tr, x, p);
}

/* The echo point of state @x, p - rho u, in the sensor frame, and its
 * Jacobian (3 x NX) against the state. */
static void
echo_point (const double *x, double *point, double *jac)
{
  const double range = MAX (sqrt (x[0] * x[0] + x[1] * x[1] + x[2] * x[2]),
      1e-6);
  const double rho = x[RADIUS];
  double u[3];

  for (guint a = 0; a < 3; a++) {
    u[a] = x[a] / range;
    point[a] = x[a] - rho * u[a];
  }
  if (!jac)
    return;
  memset (jac, 0, sizeof (double) * 3 * NX);
  for (guint a = 0; a < 3; a++) {
    for (guint b = 0; b < 3; b++)
      jac[a * NX + b] = (a == b ? 1.0 : 0.0) - rho * ((a == b ? 1.0 : 0.0)
          - u[a] * u[b]) / range;
    jac[a * NX + RADIUS] = -u[a];
  }
}

/* The measurement of @m against state @x: measured values @z, predicted
 * @h, Jacobian @H (rows x NX) and noise @R; returns the rows: x, (y,) z
 * of the echo point as the array reports it, then the radial velocity
 * when measured and @use_velocity. *@position_rows receives the first
 * count. @position, FALSE: the radial velocity alone. @ego_variance: the
 * radial velocity's noise holds the sensor velocity's variance along the
 * line of sight (the gate's, which must take a detection whatever the
 * sensor's error); without it the sensor velocity counts as its estimate
 * (the update's: the error is common to every ping and every track, not
 * noise that averages out, and counted as noise it pulled each world
 * velocity towards the prior, the relative one with it: a track's
 * radial velocity read half the measured one at first, with the robot's
 * motion unobservable). */
static guint
measure (const SonarTracker * tr, const double *x,
    const SonarMeasurement * m, gboolean position, gboolean use_velocity,
    gboolean ego_variance, double *z, double *h, double *H, double *R,
    guint * position_rows)
{
  const gboolean three = tr->params.dimensions == 3;
  const SonarVec3 u_m = sonar_measurement_direction (m);
  const double az = m->azimuth * (M_PI / 180.0);
  const double el = m->elevation * (M_PI / 180.0);
  /* A planar array sees what is behind it in front. */
  const double sign = tr->params.mirror_z && x[2] < 0.0 ? -1.0 : 1.0;
  double rp[3][3], point[3], jac[3 * NX];
  guint axes[3], n_axes = 0, rows = 0;

  memset (H, 0, sizeof (double) * 4 * NX);
  if (position) {
    /* The position's covariance from range and direction. */
    const double col[3][3] = {
      {u_m.x, u_m.y, u_m.z},
      {m->range * cos (el) * cos (az), 0.0, -m->range * cos (el) * sin (az)},
      {-m->range * sin (el) * sin (az), m->range * cos (el),
          -m->range * sin (el) * cos (az)},
    };
    const double var[3] = { m->sigma_range * m->sigma_range,
      m->sigma_azimuth * m->sigma_azimuth,
      m->sigma_elevation * m->sigma_elevation
    };
    const double measured[3] = { m->range * u_m.x, m->range * u_m.y,
      m->range * u_m.z
    };
    for (guint r = 0; r < 3; r++)
      for (guint c = 0; c < 3; c++) {
        rp[r][c] = 0.0;
        for (guint k = 0; k < 3; k++)
          rp[r][c] += col[k][r] * var[k] * col[k][c];
      }
    echo_point (x, point, jac);
    axes[n_axes++] = 0;
    if (three)
      axes[n_axes++] = 1;
    axes[n_axes++] = 2;
    for (guint i = 0; i < n_axes; i++) {
      const guint a = axes[i];
      const double s = a == 2 ? sign : 1.0;
      z[rows] = measured[a];
      h[rows] = s * point[a];
      for (guint k = 0; k < NX; k++)
        H[rows * NX + k] = s * jac[a * NX + k];
      rows++;
    }
  }
  *position_rows = rows;
  memset (R, 0, sizeof (double) * 16);
  if (use_velocity && isfinite (m->radial_velocity)) {
    const double range = MAX (sqrt (x[0] * x[0] + x[1] * x[1] + x[2] * x[2]),
        1e-6);
    double u[3], rel[3], vr = 0.0, var_s = 0.0;
    for (guint a = 0; a < 3; a++) {
      u[a] = x[a] / range;
      rel[a] = x[3 + a] - tr->s[a];
      vr += u[a] * rel[a];
    }
    for (guint a = 0; a < 3; a++) {
      H[rows * NX + a] = (rel[a] - u[a] * vr) / range;
      H[rows * NX + 3 + a] = u[a];
      for (guint b = 0; b < 3; b++)
        var_s += u[a] * tr->s_cov[a * 3 + b] * u[b];
    }
    z[rows] = m->radial_velocity;
    h[rows] = vr;
    rows++;
    R[(rows - 1) * rows + rows - 1] = m->sigma_radial_velocity
        * m->sigma_radial_velocity + (ego_variance ? var_s : 0.0);
  }
  /* The measured position is on the array's side: its covariance is the
   * measurement's; H carries the mirror's sign. */
  for (guint i = 0; i < (position ? n_axes : 0); i++)
    for (guint j = 0; j < n_axes; j++)
      R[i * rows + j] = rp[axes[i]][axes[j]];
  return rows;
}

/* The squared Mahalanobis distance of z - h over its first @rows rows
 * (S = H P H^T + R, @s_inv its inverse); FALSE when S is singular. */
static gboolean
innovation (const double *p, const double *z, const double *h,
    const double *H, const double *R, guint rows, guint stride,
    double *s_inv, double *d2)
{
  double hp[4 * NX], nu[4], tmp[4];

  sonar_linalg_multiply (H, p, hp, rows, NX, NX);
  sonar_linalg_multiply_transposed (hp, H, s_inv, rows, NX, rows);
  for (guint i = 0; i < rows; i++)
    for (guint j = 0; j < rows; j++)
      s_inv[i * rows + j] += R[i * stride + j];
  if (!sonar_linalg_invert_spd (s_inv, rows, NULL))
    return FALSE;
  for (guint i = 0; i < rows; i++)
    nu[i] = z[i] - h[i];
  sonar_linalg_multiply (s_inv, nu, tmp, rows, rows, 1);
  *d2 = 0.0;
  for (guint i = 0; i < rows; i++)
    *d2 += nu[i] * tmp[i];
  return TRUE;
}

/* Kalman update (Joseph form) with @m's position (when @position) and
 * radial velocity (when @use_velocity). */
static gboolean
update (const SonarTracker * tr, double *x, double *p,
    const SonarMeasurement * m, gboolean position, gboolean use_velocity)
{
  double z[4], h[4], H[4 * NX], R[16], s_inv[16], d2;
  double pht[NX * 4], k[NX * 4], ikh[NX * NX], a[NX * NX], b[NX * NX];
  double krk[NX * NX], kr[NX * 4];
  guint position_rows;
  const guint rows = measure (tr, x, m, position, use_velocity, FALSE, z, h,
      H, R, &position_rows);

  if (rows == 0)
    return TRUE;
  if (!innovation (p, z, h, H, R, rows, rows, s_inv, &d2))
    return FALSE;
  sonar_linalg_multiply_transposed (p, H, pht, NX, NX, rows);
  sonar_linalg_multiply (pht, s_inv, k, NX, rows, rows);
  for (guint i = 0; i < NX; i++)
    for (guint r = 0; r < rows; r++)
      x[i] += k[i * rows + r] * (z[r] - h[r]);
  sonar_linalg_multiply (k, H, ikh, NX, rows, NX);
  for (guint i = 0; i < NX; i++)
    for (guint j = 0; j < NX; j++)
      ikh[i * NX + j] = (i == j ? 1.0 : 0.0) - ikh[i * NX + j];
  sonar_linalg_multiply (ikh, p, a, NX, NX, NX);
  sonar_linalg_multiply_transposed (a, ikh, b, NX, NX, NX);
  sonar_linalg_multiply (k, R, kr, NX, rows, rows);
  sonar_linalg_multiply_transposed (kr, k, krk, NX, rows, NX);
  for (guint i = 0; i < NX * NX; i++)
    p[i] = b[i] + krk[i];
  for (guint i = 0; i < NX; i++)
    for (guint j = 0; j < i; j++)
      p[i * NX + j] = p[j * NX + i] = 0.5 * (p[i * NX + j] + p[j * NX + i]);
  /* A radius is not negative: at 0, the centre goes to the echo point. */
  if (x[RADIUS] < 0.0) {
    const double range = sqrt (x[0] * x[0] + x[1] * x[1] + x[2] * x[2]);
    for (guint axis = 0; axis < 3 && range > 0.0; axis++)
      x[axis] -= x[RADIUS] * x[axis] / range;
    x[RADIUS] = 0.0;
  }
  flatten (tr, x, p);
  return TRUE;
}

/* A detection with a place (its radial velocity may be NaN). */
static gboolean
usable (const SonarMeasurement * m)
{
  return isfinite (m->range) && m->range > 0.0 && isfinite (m->azimuth)
      && isfinite (m->elevation) && m->sigma_range > 0.0
      && m->sigma_azimuth > 0.0 && m->sigma_elevation > 0.0
      && (!isfinite (m->radial_velocity) || m->sigma_radial_velocity > 0.0);
}

/* The squared distance of detection @m from @track moved to @instant,
 * NO_PAIR outside the gate; *@in_position_gate: its position alone is
 * inside the position's gate. */
static double
pair_cost (const SonarTracker * tr, const Track * track,
    const SonarMeasurement * m, double instant, gboolean * in_position_gate)
{
  double x[NX], p[NX * NX], z[4], h[4], H[4 * NX], R[16], s_inv[16], d2;
  guint rows, position_rows;

  *in_position_gate = FALSE;
  if (!usable (m))
    return NO_PAIR;
  memcpy (x, track->x, sizeof x);
  memcpy (p, track->p, sizeof p);
  predict (tr, x, p, instant - track->t);
  rows = measure (tr, x, m, TRUE, TRUE, TRUE, z, h, H, R, &position_rows);
  *in_position_gate = innovation (p, z, h, H, R, position_rows, rows, s_inv,
      &d2) && d2 <= tr->gate_threshold[position_rows];
  if (!innovation (p, z, h, H, R, rows, rows, s_inv, &d2))
    return NO_PAIR;
  return d2 <= tr->gate_threshold[rows] ? d2 : NO_PAIR;
}

/* Minimum-cost assignment of the square @n x @n @cost (Hungarian
 * algorithm with potentials, O(n^3)); @row_of[j] receives the row
 * assigned to column j. */
static void
hungarian (SonarTracker * tr, const double *cost, guint n, gint * row_of)
{
  double *d = reserve (&tr->hungarian_d, &tr->hungarian_d_capacity,
      3 * (gsize) (n + 1), sizeof (double));
  guint *w = reserve (&tr->hungarian_u, &tr->hungarian_u_capacity,
      3 * (gsize) (n + 1), sizeof (guint));
  double *u = d, *v = d + n + 1, *minv = d + 2 * (n + 1);
  guint *p = w, *way = w + n + 1, *used = w + 2 * (n + 1);

  memset (d, 0, sizeof (double) * 2 * (n + 1));
  memset (w, 0, sizeof (guint) * 2 * (n + 1));

  for (guint i = 1; i <= n; i++) {
    guint j0 = 0;
    p[0] = i;
    for (guint j = 0; j <= n; j++) {
      minv[j] = G_MAXDOUBLE;
      used[j] = FALSE;
    }
    do {
      const guint i0 = p[j0];
      double delta = G_MAXDOUBLE;
      guint j1 = 0;
      used[j0] = TRUE;
      for (guint j = 1; j <= n; j++)
        if (!used[j]) {
          const double cur = cost[(i0 - 1) * n + j - 1] - u[i0] - v[j];
          if (cur < minv[j]) {
            minv[j] = cur;
            way[j] = j0;
          }
          if (minv[j] < delta) {
            delta = minv[j];
            j1 = j;
          }
        }
      for (guint j = 0; j <= n; j++)
        if (used[j]) {
          u[p[j]] += delta;
          v[j] -= delta;
        } else {
          minv[j] -= delta;
        }
      j0 = j1;
    } while (p[j0] != 0);
    do {
      const guint j1 = way[j0];
      p[j0] = p[j1];
      j0 = j1;
    } while (j0);
  }
  for (guint j = 1; j <= n; j++)
    row_of[j - 1] = (gint) p[j] - 1;
}

/* Which detection each track takes (tr->track_detection, -1: none), from
 * the gated costs (tracks x detections, NO_PAIR outside the gate). */
static void
assign (SonarTracker * tr, const double *costs, guint n_tracks, guint n_det)
{
  gint *track_rows = reserve (&tr->indices, &tr->indices_capacity,
      2 * ((gsize) n_tracks + n_det), sizeof (gint));
  gint *det_cols = track_rows + n_tracks;
  gint *row_of = det_cols + n_det;
  guint n_t = 0, n_d = 0;

  for (guint i = 0; i < n_tracks; i++)
    tr->track_detection[i] = -1;
  /* Only tracks and detections with a pair in their gates compete. */
  for (guint i = 0; i < n_tracks; i++) {
    track_rows[i] = -1;
    for (guint j = 0; j < n_det; j++)
      if (costs[i * n_det + j] < NO_PAIR) {
        track_rows[i] = n_t++;
        break;
      }
  }
  for (guint j = 0; j < n_det; j++) {
    det_cols[j] = -1;
    for (guint i = 0; i < n_tracks; i++)
      if (costs[i * n_det + j] < NO_PAIR) {
        det_cols[j] = n_d++;
        break;
      }
  }
  if (n_t + n_d > MAX_OPTIMAL_ASSIGNMENT) {
    /* Greedy: the cheapest pair first. */
    for (;;) {
      double best = NO_PAIR;
      guint bi = 0, bj = 0;
      for (guint i = 0; i < n_tracks; i++)
        if (tr->track_detection[i] < 0)
          for (guint j = 0; j < n_det; j++)
            if (costs[i * n_det + j] < best && det_cols[j] >= 0) {
              best = costs[i * n_det + j];
              bi = i;
              bj = j;
            }
      if (best >= NO_PAIR)
        break;
      tr->track_detection[bi] = bj;
      det_cols[bj] = -1;
    }
  } else if (n_t > 0) {
    /* Square matrix: rows = tracks then one "new track" row per
     * detection, columns = detections then one "missed" column per track.
     * A pair costs its distance; leaving both alone costs the gate, half
     * each: a pair is taken only inside its gate. */
    const guint n = n_t + n_d;
    const double half = 0.5 * tr->gate_threshold[4];
    double *c = reserve (&tr->cost, &tr->cost_capacity, (gsize) n * n,
        sizeof (double));
    for (guint k = 0; k < n * n; k++)
      c[k] = NO_PAIR;
    for (guint i = 0; i < n_tracks; i++)
      if (track_rows[i] >= 0) {
        for (guint j = 0; j < n_det; j++)
          if (det_cols[j] >= 0 && costs[i * n_det + j] < NO_PAIR)
            c[track_rows[i] * n + det_cols[j]] = costs[i * n_det + j];
        c[track_rows[i] * n + n_d + track_rows[i]] = half;
      }
    for (guint j = 0; j < n_det; j++)
      if (det_cols[j] >= 0) {
        c[(n_t + det_cols[j]) * n + det_cols[j]] = half;
        for (guint i = 0; i < n_t; i++)
          c[(n_t + det_cols[j]) * n + n_d + i] = 0.0;
      }
    hungarian (tr, c, n, row_of);
    for (guint j = 0; j < n_det; j++)
      if (det_cols[j] >= 0) {
        const gint row = row_of[det_cols[j]];
        if (row >= 0 && (guint) row < n_t)
          for (guint i = 0; i < n_tracks; i++)
            if (track_rows[i] == row && costs[i * n_det + j] < NO_PAIR)
              tr->track_detection[i] = j;
      }
  }
}

/* The filtered sensor velocity moved to @dt later and updated with the
 * ping's ego-motion. */
static void
sensor_step (SonarTracker * tr, double dt, const SonarEgoMotion * ego)
{
  const double a = tr->params.sensor_acceleration * dt;
  guint axes[3], n = 0;
  double s_inv[9], gain[9], tmp[9];

  for (guint k = 0; k < 3; k++)
    if (tr->params.dimensions == 3 || k != 1)
      tr->s_cov[k * 3 + k] += a * a;
  if (!ego || ego->status != SONAR_EGO_OBSERVED)
    return;
  /* A 2-D ego-motion takes vy as 0 (its covariance 0 there): so do the
   * tracks. */
  axes[n++] = 0;
  if (tr->params.dimensions == 3)
    axes[n++] = 1;
  axes[n++] = 2;
  {
    const double measured[3] = { ego->velocity.x, ego->velocity.y,
      ego->velocity.z
    };
    double nu[3], pht[9];       /* P H^T: 3 x n */
    for (guint i = 0; i < n; i++) {
      nu[i] = measured[axes[i]] - tr->s[axes[i]];
      for (guint j = 0; j < n; j++)
        s_inv[i * n + j] = tr->s_cov[axes[i] * 3 + axes[j]]
            + ego->covariance[axes[i]][axes[j]];
    }
    if (!sonar_linalg_invert_spd (s_inv, n, NULL))
      return;
    for (guint r = 0; r < 3; r++)
      for (guint j = 0; j < n; j++)
        pht[r * n + j] = tr->s_cov[r * 3 + axes[j]];
    sonar_linalg_multiply (pht, s_inv, gain, 3, n, n);
    for (guint r = 0; r < 3; r++)
      for (guint j = 0; j < n; j++)
        tr->s[r] += gain[r * n + j] * nu[j];
    /* P -= K H P */
    for (guint r = 0; r < 3; r++)
      for (guint c = 0; c < 3; c++) {
        tmp[r * 3 + c] = 0.0;
        for (guint j = 0; j < n; j++)
          tmp[r * 3 + c] += gain[r * n + j] * tr->s_cov[axes[j] * 3 + c];
      }
    for (guint k = 0; k < 9; k++)
      tr->s_cov[k] -= tmp[k];
    for (guint r = 0; r < 3; r++)
      for (guint c = 0; c < r; c++)
        tr->s_cov[r * 3 + c] = tr->s_cov[c * 3 + r] =
            0.5 * (tr->s_cov[r * 3 + c] + tr->s_cov[c * 3 + r]);
  }
  tr->s_observed = TRUE;
}

static void
start_track (SonarTracker * tr, const SonarMeasurement * m, double instant,
    double ping_time, gboolean behind, gint index)
{
  const double v2 = tr->params.max_speed * tr->params.max_speed;
  const double r2 = tr->params.object_radius * tr->params.object_radius;
  const SonarVec3 dir = sonar_measurement_direction (m);
  const double u[3] = { dir.x, dir.y, behind ? -dir.z : dir.z };
  double z[4], h[4], H[4 * NX], R[16];
  guint rows;
  Track t;

  memset (&t, 0, sizeof t);
  t.id = tr->next_id++;
  t.state = SONAR_TRACK_TENTATIVE;
  /* The echo point is measured; the centre lies rho behind it (rho = 0
   * +- object-radius), along the line of sight. */
  for (guint a = 0; a < 3; a++)
    t.x[a] = m->range * u[a];
  measure (tr, t.x, m, TRUE, FALSE, TRUE, z, h, H, R, &rows);
  {
    guint axes[3] = { 0, 2, 0 };
    if (rows == 3) {
      axes[1] = 1;
      axes[2] = 2;
    }
    for (guint i = 0; i < rows; i++)
      for (guint j = 0; j < rows; j++)
        t.p[axes[i] * NX + axes[j]] = R[i * rows + j] * ((axes[i] == 2)
            != (axes[j] == 2) && behind ? -1.0 : 1.0);
  }
  for (guint a = 0; a < 3; a++) {
    for (guint b = 0; b < 3; b++)
      t.p[a * NX + b] += r2 * u[a] * u[b];
    t.p[a * NX + RADIUS] = t.p[RADIUS * NX + a] = r2 * u[a];
  }
  t.p[RADIUS * NX + RADIUS] = r2;
  /* The velocity: still until measured, up to max-speed. */
  for (guint a = 3; a < 6; a++)
    t.p[a * NX + a] = v2;
  flatten (tr, t.x, t.p);
  t.t = instant;
  if (isfinite (m->radial_velocity))
    update (tr, t.x, t.p, m, FALSE, TRUE);
  t.offset = instant - ping_time;
  t.last_detection = instant;
  t.hits = 1;
  t.misses = 0;
  t.detection = index;
  if (t.hits >= tr->params.confirm_hits)
    t.state = SONAR_TRACK_CONFIRMED;
  g_array_append_val (tr->tracks, t);
}

static void
report (SonarTracker * tr, const Track * t, SonarTrack * r)
{
  const guint dims = tr->params.dimensions;
  const double range = sqrt (t->x[0] * t->x[0] + t->x[1] * t->x[1]
      + t->x[2] * t->x[2]);
  double point[3], jac[3 * NX], jp[3 * NX], cov[9];
  double vr = 0.0, pv[9], speed2 = 0.0;
  guint axes[3] = { 0, 2, 0 };

  r->id = t->id;
  r->state = t->state;
  r->instant = t->t;
  echo_point (t->x, point, jac);
  r->position = sonar_vec3 (point[0], point[1], point[2]);
  r->velocity = sonar_vec3 (t->x[3], t->x[4], t->x[5]);
  r->radius = t->x[RADIUS];
  r->range = sonar_vec3_norm (r->position);
  if (r->range > 0.0)
    sonar_vec3_to_direction (r->position, &r->azimuth, &r->elevation);
  else
    r->azimuth = r->elevation = 0.0;
  for (guint a = 0; a < 3; a++)
    vr += t->x[a] / MAX (range, 1e-9) * (t->x[3 + a] - tr->s[a]);
  r->radial_velocity = vr;
  sonar_linalg_multiply (jac, t->p, jp, 3, NX, NX);
  sonar_linalg_multiply_transposed (jp, jac, cov, 3, NX, 3);
  for (guint a = 0; a < 3; a++)
    for (guint b = 0; b < 3; b++) {
      r->position_covariance[a][b] = cov[a * 3 + b];
      r->velocity_covariance[a][b] = t->p[(3 + a) * NX + 3 + b];
    }
  /* Moving: the velocity is significantly and substantially not 0. */
  if (dims == 3) {
    axes[1] = 1;
    axes[2] = 2;
  }
  for (guint i = 0; i < dims; i++)
    for (guint j = 0; j < dims; j++)
      pv[i * dims + j] = t->p[(3 + axes[i]) * NX + 3 + axes[j]];
  r->moving_statistic = NAN;
  if (sonar_linalg_invert_spd (pv, dims, NULL)) {
    r->moving_statistic = 0.0;
    for (guint i = 0; i < dims; i++)
      for (guint j = 0; j < dims; j++)
        r->moving_statistic += t->x[3 + axes[i]] * pv[i * dims + j]
            * t->x[3 + axes[j]];
  }
  for (guint a = 0; a < 3; a++)
    speed2 += t->x[3 + a] * t->x[3 + a];
  r->moving = r->moving_statistic > tr->moving_threshold
      && sqrt (speed2) >= tr->params.moving_speed;
  r->hits = t->hits;
  r->misses = t->misses;
  r->detection = t->detection;
}

static gint
compare_reports (gconstpointer a, gconstpointer b)
{
  const guint64 x = ((const SonarTrack *) a)->id;
  const guint64 y = ((const SonarTrack *) b)->id;
  return x < y ? -1 : x > y;
}

gboolean
sonar_tracker_process (SonarTracker * tr, double ping_time,
    const SonarMeasurement * detections, guint n, const SonarEgoMotion * ego,
    const SonarEgoLabel * labels, GError ** error)
{
  const SonarTrackerParams *p = &tr->params;
  const double dt = isfinite (tr->last_ping) ? ping_time - tr->last_ping : 0;
  guint n_tracks;
  double *costs;

  if (!isfinite (ping_time) || dt < 0.0) {
    g_set_error (error, SONAR_ERROR, SONAR_ERROR_FORMAT, "tracks: a ping at "
        "%.6f s after one at %.6f s: pings must come in time order",
        ping_time, tr->last_ping);
    return FALSE;
  }
  tr->last_ping = ping_time;
  sensor_step (tr, dt, ego);

  n_tracks = tr->tracks->len;
  if (n_tracks > tr->track_capacity) {
    tr->track_capacity = n_tracks;
    tr->track_detection = g_renew (gint, tr->track_detection, n_tracks);
  }
  if (n > tr->detection_capacity) {
    tr->detection_capacity = n;
    tr->detection_taken = g_renew (gboolean, tr->detection_taken, n);
    tr->position_gates = g_renew (guint, tr->position_gates, n);
  }
  costs = reserve (&tr->pair_costs, &tr->pair_capacity,
      MAX ((gsize) n_tracks * n, 1), sizeof (double));
  for (guint j = 0; j < n; j++)
    tr->position_gates[j] = 0;
  for (guint i = 0; i < n_tracks; i++) {
    const Track *t = &g_array_index (tr->tracks, Track, i);
    for (guint j = 0; j < n; j++) {
      const double instant = isfinite (detections[j].instant) ?
          detections[j].instant : ping_time;
      gboolean in_position_gate;
      costs[i * n + j] = pair_cost (tr, t, &detections[j], instant,
          &in_position_gate);
      tr->position_gates[j] += in_position_gate;
    }
  }
  assign (tr, costs, n_tracks, n);

  for (guint j = 0; j < n; j++)
    tr->detection_taken[j] = FALSE;
  for (guint i = 0; i < n_tracks; i++) {
    Track *t = &g_array_index (tr->tracks, Track, i);
    const gint j = tr->track_detection[i];
    if (j >= 0) {
      const SonarMeasurement *m = &detections[j];
      const double instant = isfinite (m->instant) ? m->instant : ping_time;
      predict (tr, t->x, t->p, instant - t->t);
      t->t = instant;
      /* Unresolved objects: their radial velocities may be blended. */
      update (tr, t->x, t->p, m, TRUE, tr->position_gates[j] < 2);
      t->offset = instant - ping_time;
      t->last_detection = instant;
      t->hits++;
      t->misses = 0;
      t->detection = j;
      if (t->hits >= p->confirm_hits)
        t->state = SONAR_TRACK_CONFIRMED;
      tr->detection_taken[j] = TRUE;
    } else {
      const double instant = ping_time + t->offset;
      if (instant > t->t) {
        predict (tr, t->x, t->p, instant - t->t);
        t->t = instant;
      }
      t->misses++;
      t->detection = -1;
    }
  }
  /* Ends. */
  for (guint i = tr->tracks->len; i-- > 0;) {
    const Track *t = &g_array_index (tr->tracks, Track, i);
    const gboolean end = t->state == SONAR_TRACK_TENTATIVE ? t->misses >= 2 :
        t->misses > p->max_misses || t->t - t->last_detection > p->max_coast;
    if (end)
      g_array_remove_index (tr->tracks, i);
  }
  /* Beginnings. */
  for (guint j = 0; j < n && tr->tracks->len < p->max_tracks; j++)
    if (!tr->detection_taken[j] && usable (&detections[j])) {
      const SonarMeasurement *m = &detections[j];
      start_track (tr, m, isfinite (m->instant) ? m->instant : ping_time,
          ping_time, p->mirror_z && labels && labels[j].behind, j);
    }

  g_array_set_size (tr->reports, tr->tracks->len);
  for (guint i = 0; i < tr->tracks->len; i++)
    report (tr, &g_array_index (tr->tracks, Track, i),
        &g_array_index (tr->reports, SonarTrack, i));
  g_array_sort (tr->reports, compare_reports);
  return TRUE;
}

const SonarTrack *
sonar_tracker_tracks (SonarTracker * tr, guint * n)
{
  *n = tr->reports->len;
  return (const SonarTrack *) tr->reports->data;
}

gboolean
sonar_tracker_sensor_velocity (SonarTracker * tr, SonarVec3 * velocity,
    double covariance[3][3])
{
  *velocity = sonar_vec3 (tr->s[0], tr->s[1], tr->s[2]);
  for (guint a = 0; a < 3; a++)
    for (guint b = 0; b < 3; b++)
      covariance[a][b] = tr->s_cov[a * 3 + b];
  return tr->s_observed;
}
