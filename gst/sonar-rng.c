/* sonar-rng.c: xoshiro256** (Blackman & Vigna) seeded with splitmix64. */
#include "sonar-rng.h"

#include <math.h>

static guint64
splitmix64 (guint64 * state)
{
  guint64 z = (*state += G_GUINT64_CONSTANT (0x9E3779B97F4A7C15));
  z = (z ^ (z >> 30)) * G_GUINT64_CONSTANT (0xBF58476D1CE4E5B9);
  z = (z ^ (z >> 27)) * G_GUINT64_CONSTANT (0x94D049BB133111EB);
  return z ^ (z >> 31);
}

static inline guint64
rotl (guint64 x, int k)
{
  return (x << k) | (x >> (64 - k));
}

void
sonar_rng_init (SonarRng * rng, guint64 seed, guint64 stream)
{
  /* Mixing the stream through splitmix64 keeps nearby (seed, stream)
   * pairs uncorrelated. */
  guint64 state = seed ^ splitmix64 (&stream);
  for (int i = 0; i < 4; i++)
    rng->s[i] = splitmix64 (&state);
  rng->has_spare = FALSE;
  rng->spare = 0.0;
}

guint64
sonar_rng_next (SonarRng * rng)
{
  guint64 *s = rng->s;
  const guint64 result = rotl (s[1] * 5, 7) * 9;
  const guint64 t = s[1] << 17;
  s[2] ^= s[0];
  s[3] ^= s[1];
  s[1] ^= s[2];
  s[0] ^= s[3];
  s[2] ^= t;
  s[3] = rotl (s[3], 45);
  return result;
}

double
sonar_rng_uniform (SonarRng * rng)
{
  /* 53 random bits, shifted by half a step away from 0 and 1. */
  return ((double) (sonar_rng_next (rng) >> 11) + 0.5) * 0x1.0p-53;
}

double
sonar_rng_gaussian (SonarRng * rng)
{
  double u, v;

  if (rng->has_spare) {
    rng->has_spare = FALSE;
    return rng->spare;
  }
  /* Box-Muller: two normals per pair of uniforms. */
  u = sonar_rng_uniform (rng);
  v = sonar_rng_uniform (rng);
  {
    const double r = sqrt (-2.0 * log (u));
    const double phi = 2.0 * M_PI * v;
    rng->spare = r * sin (phi);
    rng->has_spare = TRUE;
    return r * cos (phi);
  }
}
