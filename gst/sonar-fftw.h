/* sonar-fftw.h: FFTW's planner is not thread-safe (elements start in
 * parallel): every plan is made and destroyed under this one lock. */
#ifndef SONAR_FFTW_H
#define SONAR_FFTW_H

#include <glib.h>

G_BEGIN_DECLS

/* FFTW_ESTIMATE, not FFTW_MEASURE: measured plans depend on timings, so two
 * runs could round differently; the same ping must always give the same
 * image and velocities (a WAV recording processes exactly like the live
 * ping).
 *
 * The plans are fast all the same: the first sonar_fftw_lock () imports
 * the wisdom shipped in the source tree (sonar-fftw-wisdom.c, made with
 * FFTW_PATIENT by tools/fftw-wisdom for the default set-up's transforms),
 * and FFTW's estimate planner takes wisdom of any rigour for a problem it
 * has. The plan is then fixed by that text, not by timings measured at run
 * time. Problems without wisdom are estimated as before. FFTW registers
 * its SIMD codelets by what the CPU has (the wisdom here names SSE2 and
 * AVX ones), so on a CPU without them, or with another FFTW, its
 * configuration signature differs and it refuses the whole wisdom: every
 * plan is then estimated, as before the wisdom, still the same on every
 * run.
 *
 * Every plan of the core must be made under sonar_fftw_lock (): the wisdom
 * must be in before the first plan, or FFTW keeps that plan's estimate. */
#define SONAR_FFTW_PLANNING (sonar_fftw_planning ())

void sonar_fftw_lock (void);
void sonar_fftw_unlock (void);

/* The planner flags of the core's run-time transforms: FFTW_ESTIMATE. */
unsigned sonar_fftw_planning (void);

/* For tools/fftw-wisdom only, before the first plan: plans with @flags
 * (FFTW_PATIENT) and never imports the shipped wisdom, so that the
 * wisdom it exports is measured afresh. */
void sonar_fftw_set_planning (unsigned flags);

/* TRUE once the shipped wisdom was accepted by FFTW (the first
 * sonar_fftw_lock () tries); FALSE before, or when FFTW refused it. */
gboolean sonar_fftw_wisdom_imported (void);

/* The wisdom shipped in the library (sonar-fftw-wisdom.c). */
extern const char sonar_fftw_wisdom[];

G_END_DECLS

#endif
