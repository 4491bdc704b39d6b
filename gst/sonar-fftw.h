/* sonar-fftw.h: FFTW's planner is not thread-safe (elements start in
 * parallel): every plan is made and destroyed under this one lock. */
#ifndef SONAR_FFTW_H
#define SONAR_FFTW_H

#include <glib.h>

G_BEGIN_DECLS

void sonar_fftw_lock (void);
void sonar_fftw_unlock (void);

G_END_DECLS

#endif
