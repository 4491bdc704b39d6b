/* sonar-fftw.h: FFTW's planner is not thread-safe (elements start in
 * parallel): every plan is made and destroyed under this one lock. */
#ifndef SONAR_FFTW_H
#define SONAR_FFTW_H

#include <glib.h>

G_BEGIN_DECLS

/* FFTW_ESTIMATE, not FFTW_MEASURE: measured plans depend on timings, so two
 * runs could round differently; the same ping must always give the same
 * image and velocities (a WAV recording processes exactly like the live
 * ping). */
#define SONAR_FFTW_PLANNING FFTW_ESTIMATE

void sonar_fftw_lock (void);
void sonar_fftw_unlock (void);

G_END_DECLS

#endif
