/* sonar-track.h: tracks across pings, each with an identity, its position
 * and its velocity in the world.
 *
 * Frame: the sensor frame, which moves with the sensor; the sensor
 * translates without turning between pings (as sonarsrc's scenes do). A
 * track's state is its position p relative to the sensor and its velocity
 * v in the world (the still world at rest), both on the sensor's axes.
 * Between two instants dt apart
 *
 *     p' = p + (v - s) dt,    v' = v                     (constant velocity)
 *
 * s being the sensor's velocity: the ego-motion (sonar-egomotion.h),
 * filtered here across pings as a random walk (sensor-acceleration m/s^2
 * of spread), and taken as 0 with max-speed of spread before any ping
 * observed it. The objects' accelerations are white noise of spread
 * acceleration (m/s^2).
 *
 * Objects have extent: a pole or a person echoes from the point of its
 * surface nearest the sensor, which slides around the object as the line
 * of sight turns (at 3 m/s passing 0.6 m away, a 5 cm pole's echo point
 * moves 0.26 m/s slower than the pole). So p is the centre of the echoing
 * surface's curvature, with its radius rho a third part of the state
 * (prior 0 +- object-radius, never below 0; a point has 0), and the echo
 * comes from p - rho u, u = p / |p|: its range is |p| - rho, its range rate
 * that of p. rho shows in how the echo point's path bends as the line of
 * sight turns.
 *
 * A detection measures the echo point as the array reports it (a planar
 * array, mirror-z, reports an object behind it at (x, y, -z)) and, from
 * the Doppler, the radial velocity
 *
 *     v_r = (p . (v - s)) / |p|                          (1)
 *
 * An extended Kalman filter fuses both: the radial component of v is
 * known from the first ping, the tangential one from the change in
 * position over the next few. Association uses the same measurement: the
 * innovation of position and radial velocity together, gated at the
 * chi-square quantile of `gate` and assigned globally (Hungarian
 * algorithm on the squared Mahalanobis distances), so that two objects
 * crossing at different speeds keep their identities. A detection that
 * lies in the position gates of two or more tracks comes from objects the
 * image does not resolve: its radial velocity may be a blend of theirs,
 * so it updates its track's position only.
 *
 * Life: a detection no track takes starts a tentative track (still in the
 * world, tangentially, until measured otherwise; behind the array when its
 * ego-motion label says so); confirm-hits updates confirm it; a tentative
 * track missed on 2 pings in a row, a confirmed one missed on more than
 * max-misses pings or for longer than max-coast seconds, ends. Identities
 * are never reused.
 *
 * Timing: every state refers to an instant in seconds; detections carry
 * their own (SonarMeasurement.instant), coasting tracks move on to the
 * ping's. Dropped pings are longer steps.
 *
 * Moving: the world velocity differs from zero by more than the gate
 * (chi-square on its covariance) and by at least moving-speed.
 *
 * 2-D (a fan): everything in the y = 0 plane, y components 0.
 */
#ifndef SONAR_TRACK_H
#define SONAR_TRACK_H

#include <glib.h>
#include "sonar-egomotion.h"
#include "sonar-vec3.h"

G_BEGIN_DECLS

typedef enum
{
  SONAR_TRACK_TENTATIVE,
  SONAR_TRACK_CONFIRMED,
} SonarTrackState;

/* "tentative", "confirmed". */
const char *sonar_track_state_to_string (SonarTrackState state);

/* One track after a ping. */
typedef struct
{
  guint64 id;                   /* from 1, never reused */
  SonarTrackState state;
  gboolean moving;              /* in the world */
  double instant;               /* s: when the state below holds */
  SonarVec3 position;           /* m, sensor frame, the echo point; z < 0
                                 * behind the array */
  double range, azimuth, elevation;     /* m, degrees */
  double radial_velocity;       /* m/s, d(range)/dt relative to the sensor (1) */
  SonarVec3 velocity;           /* m/s, in the world, sensor axes */
  double radius;                /* m, of the echoing surface (0: a point) */
  double position_covariance[3][3];     /* m^2 */
  double velocity_covariance[3][3];     /* (m/s)^2 */
  double moving_statistic;      /* squared Mahalanobis norm of velocity */
  guint hits;                   /* detections taken since it began */
  guint misses;                 /* pings in a row without one */
  gint detection;               /* this ping's detection, -1: none */
} SonarTrack;

typedef struct
{
  guint dimensions;             /* 2 (a fan: y = 0) or 3 */
  double acceleration;          /* m/s^2: objects' (white noise) */
  double sensor_acceleration;   /* m/s^2: the sensor's, between pings */
  double max_speed;             /* m/s: spread of an unmeasured velocity */
  double object_radius;         /* m: spread of an unmeasured radius */
  double gate;                  /* chi-square probability of the gates, 0..1 */
  guint confirm_hits;
  guint max_misses;
  double max_coast;             /* s */
  double moving_speed;          /* m/s */
  gboolean mirror_z;            /* planar array (sonar-egomotion.h) */
  guint max_tracks;
} SonarTrackerParams;

void sonar_tracker_params_init_default (SonarTrackerParams * params);

typedef struct _SonarTracker SonarTracker;

/* NULL with @error (SONAR_ERROR_SETTINGS) for parameters out of range. */
SonarTracker *sonar_tracker_new (const SonarTrackerParams * params,
    GError ** error);
void sonar_tracker_free (SonarTracker * tracker);
/* Forgets every track and the sensor's velocity (identities go on). */
void sonar_tracker_reset (SonarTracker * tracker);

/* One ping at @ping_time (s): its @n detections (a NaN instant means
 * @ping_time; a NaN radial velocity, position only; one without a finite
 * place or with a sigma of 0 is ignored), the ping's
 * ego-motion and the detections' labels (NULL: none). Pings must come in
 * time order; an earlier one is an error (SONAR_ERROR_FORMAT) that leaves
 * the tracks as they were. */
gboolean sonar_tracker_process (SonarTracker * tracker, double ping_time,
    const SonarMeasurement * detections, guint n, const SonarEgoMotion * ego,
    const SonarEgoLabel * labels, GError ** error);

/* The tracks after the last ping, by id; valid until the next call. */
const SonarTrack *sonar_tracker_tracks (SonarTracker * tracker, guint * n);

/* The sensor's velocity the tracks were moved with (the filtered
 * ego-motion), and its covariance. FALSE before any ping observed it. */
gboolean sonar_tracker_sensor_velocity (SonarTracker * tracker,
    SonarVec3 * velocity, double covariance[3][3]);

G_DEFINE_AUTOPTR_CLEANUP_FUNC (SonarTracker, sonar_tracker_free)

G_END_DECLS

#endif /* SONAR_TRACK_H */
