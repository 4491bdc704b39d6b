/* sonar-vec3.h: the small 3-vector used for positions and velocities.
 *
 * Sensor frame (fixed project convention): the array lies in the x-y plane,
 * boresight is +z, x right, y up, origin at the array centre; metres, m/s.
 * Azimuth is measured from +z towards +x, elevation towards +y, in degrees.
 */
#ifndef SONAR_VEC3_H
#define SONAR_VEC3_H

#include <math.h>

/* M_PI is POSIX, not C11: an application compiled with -std=c11 (this
 * header is installed) has none unless it asks for it. */
#ifndef M_PI
#define M_PI 3.14159265358979323846
#endif

typedef struct
{
  double x, y, z;
} SonarVec3;

static inline SonarVec3
sonar_vec3 (double x, double y, double z)
{
  SonarVec3 v = { x, y, z };
  return v;
}

static inline SonarVec3
sonar_vec3_add (SonarVec3 a, SonarVec3 b)
{
  return sonar_vec3 (a.x + b.x, a.y + b.y, a.z + b.z);
}

static inline SonarVec3
sonar_vec3_sub (SonarVec3 a, SonarVec3 b)
{
  return sonar_vec3 (a.x - b.x, a.y - b.y, a.z - b.z);
}

static inline SonarVec3
sonar_vec3_scale (SonarVec3 a, double s)
{
  return sonar_vec3 (a.x * s, a.y * s, a.z * s);
}

static inline double
sonar_vec3_dot (SonarVec3 a, SonarVec3 b)
{
  return a.x * b.x + a.y * b.y + a.z * b.z;
}

static inline double
sonar_vec3_norm (SonarVec3 a)
{
  return sqrt (sonar_vec3_dot (a, a));
}

/* Unit vector of the direction (azimuth, elevation), degrees. */
static inline SonarVec3
sonar_vec3_from_direction (double azimuth_deg, double elevation_deg)
{
  const double az = azimuth_deg * (M_PI / 180.0);
  const double el = elevation_deg * (M_PI / 180.0);
  return sonar_vec3 (cos (el) * sin (az), sin (el), cos (el) * cos (az));
}

/* Azimuth and elevation (degrees) of a non-zero vector. */
static inline void
sonar_vec3_to_direction (SonarVec3 v, double *azimuth_deg,
    double *elevation_deg)
{
  const double horizontal = sqrt (v.x * v.x + v.z * v.z);
  *azimuth_deg = atan2 (v.x, v.z) * (180.0 / M_PI);
  *elevation_deg = atan2 (v.y, horizontal) * (180.0 / M_PI);
}

#endif /* SONAR_VEC3_H */
