/* sonar-fftw.c: see sonar-fftw.h. */
#include "sonar-fftw.h"

#include <fftw3.h>

static GMutex fftw_planner_lock;
static unsigned planning = FFTW_ESTIMATE;
static gboolean wisdom_tried, wisdom_imported;

void
sonar_fftw_lock (void)
{
  g_mutex_lock (&fftw_planner_lock);
  /* Once, before the first plan: FFTW keeps the plans it estimated
   * earlier for the same problems. */
  if (!wisdom_tried) {
    wisdom_tried = TRUE;
    wisdom_imported = fftwf_import_wisdom_from_string (sonar_fftw_wisdom);
    if (!wisdom_imported)
      g_debug ("FFTW refused the shipped wisdom (another FFTW version or "
          "CPU): every plan estimated");
  }
}

void
sonar_fftw_unlock (void)
{
  g_mutex_unlock (&fftw_planner_lock);
}

unsigned
sonar_fftw_planning (void)
{
  return planning;
}

void
sonar_fftw_set_planning (unsigned flags)
{
  g_mutex_lock (&fftw_planner_lock);
  planning = flags;
  wisdom_tried = TRUE;
  g_mutex_unlock (&fftw_planner_lock);
}

gboolean
sonar_fftw_wisdom_imported (void)
{
  gboolean imported;

  g_mutex_lock (&fftw_planner_lock);
  imported = wisdom_imported;
  g_mutex_unlock (&fftw_planner_lock);
  return imported;
}
