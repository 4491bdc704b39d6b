/* sonar-test-gst.h: what the tests of the elements and contracts share
 * (the core's tests use sonar-test-util.h alone and link no GStreamer). */
#ifndef SONAR_TEST_GST_H
#define SONAR_TEST_GST_H

#include <gst/gst.h>

#include "sonar-test-util.h"

G_BEGIN_DECLS

/* Runs a gst-launch style pipeline to EOS (or the first error). Returns
 * NULL on success, else the error message (and its debug text after a
 * newline): g_free it. @pipeline_out, if not NULL, receives the pipeline
 * (already set to NULL state; unref it) to inspect appsinks afterwards. */
char *sonar_test_run_pipeline (const char *description,
    GstElement ** pipeline_out);

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
