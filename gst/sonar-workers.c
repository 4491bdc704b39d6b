/* sonar-workers.c: see sonar-workers.h.
 *
 * Plain threads, joined when the set is freed: a thread pool's threads
 * end some time after the pool is freed, so a pipeline shut down and
 * freed could still have them running (and valgrind would see their
 * memory as lost). */
#include "sonar-workers.h"
#include "sonar-error.h"

struct _SonarWorkers
{
  guint n;
  GThread *threads[SONAR_MAX_WORKERS];  /* workers 1 .. n - 1 */
  SonarWorkersJob job;
  gpointer data;
  GMutex lock;
  GCond start, done;
  guint64 generation;           /* jobs handed out so far */
  guint pending;                /* workers still in the current job */
  gboolean quit;
};

typedef struct
{
  SonarWorkers *set;
  guint index;
} WorkerArgs;

static gpointer
worker_main (gpointer data)
{
  WorkerArgs *args = data;
  SonarWorkers *w = args->set;
  const guint index = args->index;
  guint64 seen = 0;

  g_free (args);
  g_mutex_lock (&w->lock);
  for (;;) {
    while (!w->quit && w->generation == seen)
      g_cond_wait (&w->start, &w->lock);
    if (w->quit)
      break;
    seen = w->generation;
    g_mutex_unlock (&w->lock);
    w->job (w->data, index, w->n);
    g_mutex_lock (&w->lock);
    if (--w->pending == 0)
      g_cond_signal (&w->done);
  }
  g_mutex_unlock (&w->lock);
  return NULL;
}

SonarWorkers *
sonar_workers_new (guint n, GError ** error)
{
  SonarWorkers *w = g_new0 (SonarWorkers, 1);

  g_mutex_init (&w->lock);
  g_cond_init (&w->start);
  g_cond_init (&w->done);
  w->n = CLAMP (n ? n : g_get_num_processors (), 1, SONAR_MAX_WORKERS);
  for (guint i = 1; i < w->n; i++) {
    WorkerArgs *args = g_new (WorkerArgs, 1);
    GError *thread_error = NULL;
    args->set = w;
    args->index = i;
    w->threads[i] = g_thread_try_new ("sonar-worker", worker_main, args,
        &thread_error);
    if (!w->threads[i]) {
      g_set_error (error, SONAR_ERROR, SONAR_ERROR_RESOURCE,
          "cannot start worker thread %u of %u: %s", i + 1, w->n,
          thread_error->message);
      g_error_free (thread_error);
      g_free (args);
      w->n = i;                 /* the threads made so far are joined */
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
  g_mutex_lock (&w->lock);
  w->quit = TRUE;
  g_cond_broadcast (&w->start);
  g_mutex_unlock (&w->lock);
  for (guint i = 1; i < w->n; i++)
    g_thread_join (w->threads[i]);
  g_mutex_clear (&w->lock);
  g_cond_clear (&w->start);
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
  g_mutex_lock (&w->lock);
  w->job = job;
  w->data = data;
  w->pending = w->n - 1;
  w->generation++;
  g_cond_broadcast (&w->start);
  g_mutex_unlock (&w->lock);
  job (data, 0, w->n);
  g_mutex_lock (&w->lock);
  while (w->pending > 0)
    g_cond_wait (&w->done, &w->lock);
  g_mutex_unlock (&w->lock);
}
