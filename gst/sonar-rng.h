/* sonar-rng.h: a small seeded random generator whose sequence is fixed by
 * this file alone (xoshiro256** seeded through splitmix64), so waveforms and
 * noise are bit-for-bit reproducible on every machine and GLib version. */
#ifndef SONAR_RNG_H
#define SONAR_RNG_H

#include <glib.h>

G_BEGIN_DECLS

typedef struct
{
  guint64 s[4];
  gboolean has_spare;
  double spare;
} SonarRng;

/* @stream separates independent sequences drawn from one seed
 * (emitter index, ping index, ...). */
void sonar_rng_init (SonarRng * rng, guint64 seed, guint64 stream);
guint64 sonar_rng_next (SonarRng * rng);
/* Uniform in (0, 1): never 0, so log() is always finite. */
double sonar_rng_uniform (SonarRng * rng);
/* Standard normal (mean 0, variance 1). */
double sonar_rng_gaussian (SonarRng * rng);

G_END_DECLS

#endif /* SONAR_RNG_H */
