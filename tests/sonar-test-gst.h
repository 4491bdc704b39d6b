/* sonar-test-gst.h: what the tests of the elements and contracts share
 * (the core's tests use sonar-test-util.h alone and link no GStreamer). */
#ifndef SONAR_TEST_GST_H
#define SONAR_TEST_GST_H

#include <gst/gst.h>

#include "sonar-test-util.h"

G_BEGIN_DECLS

/* The tests' one pipeline runner: @launch (gst-launch syntax) played to
 * EOS or its first error (300 s at most). The samples of every appsink
 * are kept, by the appsink's name, in order; the warnings' and info
 * messages' texts and the first error too. The pipeline stays in PLAYING for inspection (sticky
 * events, element properties) until sonar_test_run_free (). */
typedef struct
{
  GstElement *pipeline;         /* NULL when @launch does not parse */
  GHashTable *samples;          /* appsink name -> GPtrArray of GstSample */
  GPtrArray *warnings;          /* char *: the warnings' messages */
  GPtrArray *infos;             /* char *: the info messages' texts */
  GPtrArray *messages;          /* GstStructure: the element messages */
  GError *error;                /* the first error, its domain and code */
  char *error_text;             /* its message, a newline and its debug
                                 * text; a parse error or a timeout too;
                                 * NULL when it ran to EOS */
} SonarTestRun;

SonarTestRun *sonar_test_run (const char *launch);
/* The same, with @prepare (may be NULL) called on the pipeline before it
 * plays: to add pad probes, set properties. */
typedef void (*SonarTestPrepare) (GstElement * pipeline, gpointer data);
SonarTestRun *sonar_test_run_with (const char *launch,
    SonarTestPrepare prepare, gpointer data);
void sonar_test_run_free (SonarTestRun * run);
G_DEFINE_AUTOPTR_CLEANUP_FUNC (SonarTestRun, sonar_test_run_free)

/* The samples of the appsink named @sink (an empty array when it got
 * none; the appsink must exist). */
GPtrArray *sonar_test_run_samples (const SonarTestRun * run,
    const char *sink);
/* The bytes of every sample of @sink, one after the other (velocityest's
 * JSON lines): g_free it. */
char *sonar_test_run_text (const SonarTestRun * run, const char *sink);

/* sonar_test_run () for a pipeline run for its error alone: NULL when it
 * ran to EOS, else error_text (g_free it). */
char *sonar_test_run_pipeline (const char *launch);

/* Detections against the simulator's truth, over pings: a detection
 * within 5 cm of a true object matches it (its radial velocity error is
 * counted), any other is a false positive. */
typedef struct
{
  guint n_truth, matched, false_positives;
  double sum_error, max_error;
  guint n_pings;
} SonarTestScore;

/* Scores one output buffer of velocityest (its truth and detections
 * metas, which must be there and be of the same ping) into @score. */
void sonar_test_score_ping (GstBuffer * buffer, SonarTestScore * score);

/* Initialises GStreamer for a test program, with the build tree's plugin. */
void sonar_test_init_gst (int *argc, char ***argv);

G_END_DECLS

#endif
