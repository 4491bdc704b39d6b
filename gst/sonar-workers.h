/* sonar-workers.h: a fixed set of threads that run one job together.
 *
 * run() calls job (data, w, n) once for every worker w < n, the caller's
 * thread being worker 0, and returns when all are done. The threads are
 * made at creation, not per call: per-ping work only hands them the job.
 * A job splits its work by w so that results do not depend on n.
 */
#ifndef SONAR_WORKERS_H
#define SONAR_WORKERS_H

#include <glib.h>

G_BEGIN_DECLS

#define SONAR_MAX_WORKERS 64

typedef void (*SonarWorkersJob) (gpointer data, guint worker,
    guint n_workers);

typedef struct _SonarWorkers SonarWorkers;

/* @n: 0 for one per processor. */
SonarWorkers *sonar_workers_new (guint n, GError ** error);
void sonar_workers_free (SonarWorkers * workers);
guint sonar_workers_count (const SonarWorkers * workers);
void sonar_workers_run (SonarWorkers * workers, SonarWorkersJob job,
    gpointer data);

G_DEFINE_AUTOPTR_CLEANUP_FUNC (SonarWorkers, sonar_workers_free)

G_END_DECLS

#endif
