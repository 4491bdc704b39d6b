/* sonar-workers.c: see sonar-workers.h. */
#include "sonar-workers.h"

struct _SonarWorkers
{
  guint n;
  GThreadPool *threads;         /* workers 1 .. n - 1 */
  SonarWorkersJob job;
  gpointer data;
  GMutex lock;
  GCond done;
  guint pending;
};

static void
run_one (gpointer worker, gpointer user_data)
{
  SonarWorkers *w = user_data;

  w->job (w->data, GPOINTER_TO_UINT (worker), w->n);
  g_mutex_lock (&w->lock);
  if (--w->pending == 0)
    g_cond_signal (&w->done);
  g_mutex_unlock (&w->lock);
}

SonarWorkers *
sonar_workers_new (guint n, GError ** error)
{
  SonarWorkers *w = g_new0 (SonarWorkers, 1);

  g_mutex_init (&w->lock);
  g_cond_init (&w->done);
  w->n = CLAMP (n ? n : g_get_num_processors (), 1, SONAR_MAX_WORKERS);
  if (w->n > 1) {
    w->threads = g_thread_pool_new (run_one, w, w->n - 1, TRUE, error);
    if (!w->threads) {
      sonar_workers_free (w);
      return NULL;
    }
  }
  return w;
}

void
sonar_workers_free (SonarWorkers * w)
{
  if (!w)
    return;
  if (w->threads)
    g_thread_pool_free (w->threads, FALSE, TRUE);
  g_mutex_clear (&w->lock);
  g_cond_clear (&w->done);
  g_free (w);
}

guint
sonar_workers_count (const SonarWorkers * w)
{
  return w->n;
}

void
sonar_workers_run (SonarWorkers * w, SonarWorkersJob job, gpointer data)
{
  w->job = job;
  w->data = data;
  w->pending = w->n - 1;
  for (guint i = 1; i < w->n; i++)
    g_thread_pool_push (w->threads, GUINT_TO_POINTER (i), NULL);
  job (data, 0, w->n);
  g_mutex_lock (&w->lock);
  while (w->pending > 0)
    g_cond_wait (&w->done, &w->lock);
  g_mutex_unlock (&w->lock);
}
