/* test-stability.c: the whole chain at the edges of its range and over
 * time: state changes, long runs (memory stays flat), extreme scenes and
 * amplitudes. SONAR_LONG_RUN=1 runs the 10,000 pings. */
#include <gst/app/gstappsink.h>
#include <json-glib/json-glib.h>
#include <malloc.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "sonar-contracts.h"
#include "sonar-test-gst.h"

/* A light chain: small bank, 61 directions (3 degrees: as coarse as the
 * beam allows without mimobeamform's warning), 2 m. */
#define CHAIN "dopplerbank velocity-min=-0.5 velocity-max=0.5 velocity-step=0.05 " \
  "! mimobeamform azimuth-count=61 range-max=2.0 ! wardcluster ! velocityest"

/* Resident memory of this process, in MB, once glibc has handed back
 * the free pages of its arenas: threads that meet in malloc under load
 * get arenas of their own, whose freed blocks stay resident (a full
 * suite on a loaded machine saw 33-63 MB of such growth, and none alone);
 * a leak's blocks are not free, and stay counted. */
static double
resident_mb (void)
{
  long pages = 0, resident = 0;
  FILE *f;

#ifdef __GLIBC__
  malloc_trim (0);
#endif
  f = fopen ("/proc/self/statm", "r");

  if (f) {
    if (fscanf (f, "%ld %ld", &pages, &resident) != 2)
      resident = 0;
    fclose (f);
  }
  return resident * (double) sysconf (_SC_PAGESIZE) / (1024.0 * 1024.0);
}

/* Under AddressSanitizer (meson test --setup asan) freed blocks wait in its
 * quarantine (256 MB) and the heap is its own allocator's, which mallinfo2
 * does not see: resident and heap readings say nothing of leaks there.
 * The plain runs and memcheck check them. */
static gboolean
memory_readings_meaningful (void)
{
  return !sonar_test_sanitized ();
}

/* NULL -> PLAYING -> EOS -> NULL, 100 times on one pipeline object: every
 * run gives the same detections and memory does not grow. */
static void
test_state_changes (void)
{
  GstElement *pipeline = gst_parse_launch ("sonarsrc num-buffers=1 "
      "max-range=2.0 ! " CHAIN " ! appsink name=sink sync=false", NULL);
  GstElement *sink = gst_bin_get_by_name (GST_BIN (pipeline), "sink");
  g_autofree char *first = NULL;
  double mb_10 = 0.0;

  for (guint run = 0; run < 100; run++) {
    GstSample *sample;
    GstMapInfo map;
    g_autofree char *json = NULL;

    gst_element_set_state (pipeline, GST_STATE_PLAYING);
    sample = gst_app_sink_pull_sample (GST_APP_SINK (sink));
    g_assert_nonnull (sample);
    gst_buffer_map (gst_sample_get_buffer (sample), &map, GST_MAP_READ);
    json = g_strndup ((const char *) map.data, map.size);
    gst_buffer_unmap (gst_sample_get_buffer (sample), &map);
    gst_sample_unref (sample);
    gst_element_set_state (pipeline, GST_STATE_NULL);
    if (!first)
      first = g_strdup (json);
    g_assert_cmpstr (json, ==, first);
    if (run == 9)
      mb_10 = resident_mb ();
  }
  g_test_message ("resident memory after 10 runs %.1f MB, after 100 %.1f MB",
      mb_10, resident_mb ());
  if (memory_readings_meaningful ())
    g_assert_cmpfloat (resident_mb () - mb_10, <, 8.0);
  gst_object_unref (sink);
  gst_object_unref (pipeline);
}

/* Bytes the process has allocated and not freed, summed over every malloc
 * arena (glibc's mallinfo2 walks them all; the streaming threads allocate
 * in their own): exact to the chunk, unlike the resident memory, which
 * fragmentation and the kernel's paging blur by megabytes. */
static double
heap_in_use (void)
{
  const struct mallinfo2 m = mallinfo2 ();

  return (double) m.uordblks + (double) m.hblkhd;
}

/* Parks sonarsrc's streaming thread as it is about to push every
 * @every-th ping, until the test has read the heap: with no queue in the
 * chain and the previous ping pulled from the sink, nothing else is in
 * flight, so every reading is taken in the same state. */
typedef struct
{
  GMutex lock;
  GCond cond;
  guint every, seen, parked;
  gboolean go;
} Park;

static GstPadProbeReturn
park_ping (GstPad * pad, GstPadProbeInfo * info, gpointer data)
{
  Park *park = data;
  guint index;

  g_mutex_lock (&park->lock);
  index = park->seen++;
  if (index > 0 && index % park->every == 0) {
    park->parked = index;
    park->go = FALSE;
    g_cond_broadcast (&park->cond);
    while (!park->go)
      g_cond_wait (&park->cond, &park->lock);
  }
  g_mutex_unlock (&park->lock);
  return GST_PAD_PROBE_OK;
}

/* Entries of a /proc/self folder: the process's open files ("fd") or
 * threads ("task"). */
static guint
proc_entries (const char *folder)
{
  g_autofree char *path = g_build_filename ("/proc/self", folder, NULL);
  GDir *dir = g_dir_open (path, 0, NULL);
  guint n = 0;

  if (!dir)
    return 0;
  while (g_dir_read_name (dir))
    n++;
  g_dir_close (dir);
  return n;
}

/* Whether @msg is a ping's element message (CONTRACTS section 10); its
 * stream and running time are then its PTS (a stream from time 0). */
static gboolean
ping_message (GstMessage * msg)
{
  const GstStructure *s = gst_message_get_structure (msg);
  guint64 timestamp, stream_time, running_time;

  if (GST_MESSAGE_TYPE (msg) != GST_MESSAGE_ELEMENT)
    return FALSE;
  g_assert_true (gst_structure_get_uint64 (s, "timestamp", &timestamp));
  g_assert_true (gst_structure_get_uint64 (s, "stream-time", &stream_time));
  g_assert_true (gst_structure_get_uint64 (s, "running-time",
          &running_time));
  g_assert_cmpuint (stream_time, ==, timestamp);
  g_assert_cmpuint (running_time, ==, timestamp);
  return TRUE;
}

/* Many pings: once the pools are warm, the heap in use is flat, whatever
 * the number of pings (SONAR_LONG_RUN=1: the 10,000). It is read
 * every 25 pings with the pipeline parked (above), after the bus has been
 * emptied. From ping 125 on (measured: buffers and arrays grow to their
 * high-water marks over the first hundred pings) the readings stay within
 * a few hundred bytes, but for a rare one-off step (measured once: 460 kB,
 * a high-water mark). A leak grows the heap in every interval: at most
 * half the intervals may grow by more than 1 kB, and the whole run by
 * less than 1 MB. A leak of 100 bytes a ping fails it. Threads and open
 * files are no more at the end than after 125 pings. */
static void
test_long_run (void)
{
  const guint pings = g_getenv ("SONAR_LONG_RUN") ? 10000 : 300;
  g_autofree char *launch = g_strdup_printf ("sonarsrc name=src "
      "num-buffers=%u max-range=2.0 ping-rate=25 ! " CHAIN " ! appsink "
      "name=sink sync=false", pings);
  GstElement *pipeline = gst_parse_launch (launch, NULL);
  GstElement *sink = gst_bin_get_by_name (GST_BIN (pipeline), "sink");
  GstElement *src = gst_bin_get_by_name (GST_BIN (pipeline), "src");
  GstPad *pad = gst_element_get_static_pad (src, "src");
  GstBus *bus = gst_element_get_bus (pipeline);
  Park park = { .every = 25 };
  GstSample *sample;
  GstMessage *msg;
  guint count = 0, messages = 0, intervals = 0, growing = 0;
  double mb_warm = 0.0, heap_warm = 0.0, heap_previous = 0.0;
  double heap_last = 0.0;
  guint fds_warm = 0, threads_warm = 0, fds_last = 0, threads_last = 0;

  g_mutex_init (&park.lock);
  g_cond_init (&park.cond);
  gst_pad_add_probe (pad, GST_PAD_PROBE_TYPE_BUFFER, park_ping, &park, NULL);
  gst_element_set_state (pipeline, GST_STATE_PLAYING);
  while ((sample = gst_app_sink_pull_sample (GST_APP_SINK (sink)))) {
    SonarDetectionsMeta *meta =
        sonar_buffer_get_detections_meta (gst_sample_get_buffer (sample));
    g_assert_nonnull (meta);
    g_assert_cmpuint (meta->ping_index, ==, count);
    gst_sample_unref (sample);
    count++;
    if (count % park.every == 0 && count < pings) {
      double heap;
      g_mutex_lock (&park.lock);
      while (park.parked != count)
        g_cond_wait (&park.cond, &park.lock);
      while ((msg = gst_bus_pop (bus))) {
        g_assert_cmpint (GST_MESSAGE_TYPE (msg), !=, GST_MESSAGE_ERROR);
        g_assert_cmpint (GST_MESSAGE_TYPE (msg), !=, GST_MESSAGE_WARNING);
        messages += ping_message (msg);
        gst_message_unref (msg);
      }
      heap = heap_in_use ();
      fds_last = proc_entries ("fd");
      threads_last = proc_entries ("task");
      if (count == 125) {
        heap_warm = heap;
        mb_warm = resident_mb ();
        fds_warm = fds_last;
        threads_warm = threads_last;
      } else if (count > 125) {
        intervals++;
        growing += heap - heap_previous > 1024.0;
      }
      heap_previous = heap_last = heap;
      park.go = TRUE;
      g_cond_broadcast (&park.cond);
      g_mutex_unlock (&park.lock);
    }
  }
  while ((msg = gst_bus_pop (bus))) {
    messages += ping_message (msg);
    gst_message_unref (msg);
  }
  g_test_message ("%u pings: resident memory %.1f MB after 125, %.1f MB "
      "at the end; heap in use %.0f bytes after 125, %+.0f at the last "
      "reading; %u of %u intervals of 25 pings grew it by more than 1 kB",
      count, mb_warm, resident_mb (), heap_warm, heap_last - heap_warm,
      growing, intervals);
  g_test_message ("open files %u after 125 pings, %u at the last reading; "
      "threads %u, %u", fds_warm, fds_last, threads_warm, threads_last);
  /* A leak grows them; a transient thread may have ended meanwhile. */
  g_assert_cmpuint (fds_last, <=, fds_warm);
  g_assert_cmpuint (threads_last, <=, threads_warm);
  g_assert_cmpuint (count, ==, pings);
  /* sonar-truth, sonar-centroids and sonar-detections every ping. */
  g_assert_cmpuint (messages, ==, 3 * pings);
  g_assert_cmpuint (intervals, >=, 6);
  if (memory_readings_meaningful ()) {
    g_assert_cmpuint (growing, <=, intervals / 2);
    g_assert_cmpfloat (heap_last - heap_warm, <, 1048576.0);
    g_assert_cmpfloat (resident_mb () - mb_warm, <, 8.0);
  }
  gst_element_set_state (pipeline, GST_STATE_NULL);
  g_mutex_clear (&park.lock);
  g_cond_clear (&park.cond);
  gst_object_unref (bus);
  gst_object_unref (pad);
  gst_object_unref (src);
  gst_object_unref (sink);
  gst_object_unref (pipeline);
}

/* What one ping through the whole chain gave: its JSON line, metas and bus
 * messages, each checked for non-finite numbers. */
typedef struct
{
  char *json;
  SonarDetection *detections;
  guint n_detections;
  guint n_centroids;
  guint n_centroid_messages, n_detection_messages;
  char *warning;                /* the first warning's text, or NULL */
} ChainRun;

static void
chain_run_clear (ChainRun * r)
{
  g_free (r->json);
  g_free (r->detections);
  g_free (r->warning);
  memset (r, 0, sizeof (*r));
}

/* Rewrites every sample of a ping in place (interleaved float32). */
typedef void (*SampleEdit) (float *samples, gsize n, gpointer data);

typedef struct
{
  SampleEdit edit;
  gpointer data;
} EditProbe;

static GstPadProbeReturn
edit_samples (GstPad * pad, GstPadProbeInfo * info, gpointer user_data)
{
  const EditProbe *probe = user_data;
  GstBuffer *buffer = gst_buffer_make_writable (GST_PAD_PROBE_INFO_BUFFER
      (info));
  GstMapInfo map;

  g_assert_true (gst_buffer_map (buffer, &map, GST_MAP_READWRITE));
  probe->edit ((float *) map.data, map.size / sizeof (float), probe->data);
  gst_buffer_unmap (buffer, &map);
  GST_PAD_PROBE_INFO_DATA (info) = buffer;
  return GST_PAD_PROBE_OK;
}

/* Every number in the JSON document is finite (json-glib refuses "nan" and
 * "inf" outright, so a non-finite number fails the parse). The nulls
 * allowed are the documented ones: the velocity of a centroid rejected
 * before it was evaluated (keep-rejected=true, "valid": false), and an
 * uncertainty that cannot be measured ("..._sigma": elevation on a 2-D
 * image, a velocity not evaluated). */
static void
assert_json_finite (JsonNode * node)
{
  switch (JSON_NODE_TYPE (node)) {
    case JSON_NODE_OBJECT:{
      JsonObject *object = json_node_get_object (node);
      g_autoptr (GList) names = json_object_get_members (object);
      const gboolean rejected = json_object_has_member (object, "valid")
          && !json_object_get_boolean_member (object, "valid");
      for (GList * l = names; l; l = l->next) {
        JsonNode *member = json_object_get_member (object, l->data);
        if (((rejected && strcmp (l->data, "radial_velocity") == 0)
                || g_str_has_suffix (l->data, "_sigma"))
            && JSON_NODE_HOLDS_NULL (member))
          continue;
        assert_json_finite (member);
      }
      break;
    }
    case JSON_NODE_ARRAY:{
      g_autoptr (GList) elements =
          json_array_get_elements (json_node_get_array (node));
      for (GList * l = elements; l; l = l->next)
        assert_json_finite (l->data);
      break;
    }
    case JSON_NODE_VALUE:
      if (json_node_get_value_type (node) == G_TYPE_DOUBLE)
        g_assert_true (isfinite (json_node_get_double (node)));
      break;
    case JSON_NODE_NULL:
      g_error ("null in the detections' JSON");
  }
}

/* The same for a bus message's double fields, in its lists of structures
 * too (the same exception: a rejected detection's NaN radial_velocity). */
static gboolean
assert_field_finite (GQuark field, const GValue * value, gpointer user_data)
{
  const GstStructure *s = user_data;

  if (G_VALUE_HOLDS_DOUBLE (value)) {
    gboolean valid = TRUE;
    if (gst_structure_get_boolean (s, "valid", &valid) && !valid
        && strcmp (g_quark_to_string (field), "radial_velocity") == 0)
      return TRUE;
    if (g_str_has_suffix (g_quark_to_string (field), "_sigma"))
      return TRUE;
    if (!isfinite (g_value_get_double (value)))
      g_error ("%s: field %s is %g", gst_structure_get_name (s),
          g_quark_to_string (field), g_value_get_double (value));
  } else if (GST_VALUE_HOLDS_ARRAY (value)) {
    for (guint i = 0; i < gst_value_array_get_size (value); i++) {
      const GValue *item = gst_value_array_get_value (value, i);
      if (GST_VALUE_HOLDS_STRUCTURE (item))
        gst_structure_foreach (gst_value_get_structure (item),
            assert_field_finite, (gpointer) gst_value_get_structure (item));
    }
  }
  return TRUE;
}

static void
assert_detection_finite (const SonarDetection * d)
{
  const double values[] = { d->range, d->azimuth, d->elevation,
    d->position.x, d->position.y, d->position.z, d->confidence, d->peak_db,
    d->variance
  };
  for (guint i = 0; i < G_N_ELEMENTS (values); i++)
    g_assert_true (isfinite (values[i]));
  if (d->valid)
    g_assert_true (isfinite (d->radial_velocity));
}

static void
assert_centroid_finite (const SonarCentroid * c)
{
  const double values[] = { c->range, c->azimuth, c->elevation,
    c->position.x, c->position.y, c->position.z, c->peak_value, c->energy
  };
  for (guint i = 0; i < G_N_ELEMENTS (values); i++)
    g_assert_true (isfinite (values[i]));
}

/* The edit's probe on sonarsrc's output. */
static void
add_edit (GstElement * pipeline, gpointer data)
{
  GstElement *source = gst_bin_get_by_name (GST_BIN (pipeline), "src");
  GstPad *pad = gst_element_get_static_pad (source, "src");

  gst_pad_add_probe (pad, GST_PAD_PROBE_TYPE_BUFFER, edit_samples, data,
      NULL);
  gst_object_unref (pad);
  gst_object_unref (source);
}

/* Runs one ping of @scene_json (sonarsrc properties @src) through @chain,
 * with @edit (may be NULL) applied to the recording on its way out of
 * sonarsrc. Fails on a bus error and on any non-finite number in the JSON
 * line, the detections and centroids metas and the element messages. */
static void
run_chain (const char *scene_json, const char *src, const char *chain,
    SampleEdit edit, gpointer edit_data, ChainRun * r)
{
  g_autofree char *scene = sonar_test_write_temp ("scene.json", scene_json);
  g_autofree char *launch = g_strdup_printf ("sonarsrc name=src "
      "scene-file=%s num-buffers=1 max-range=2.0 %s ! %s ! appsink name=sink "
      "sync=false", scene, src, chain);
  EditProbe probe = { edit, edit_data };
  g_autoptr (SonarTestRun) run = sonar_test_run_with (launch,
      edit ? add_edit : NULL, &probe);
  g_autoptr (JsonParser) parser = json_parser_new ();
  GError *error = NULL;
  GPtrArray *samples;
  GstBuffer *buffer;
  SonarDetectionsMeta *dets;
  SonarCentroidsMeta *centroids;

  if (run->error_text)
    g_error ("%s", run->error_text);
  memset (r, 0, sizeof (*r));
  samples = sonar_test_run_samples (run, "sink");
  g_assert_cmpuint (samples->len, ==, 1);
  buffer = gst_sample_get_buffer (samples->pdata[0]);

  r->json = sonar_test_run_text (run, "sink");
  g_test_message ("%s", r->json);
  g_assert_true (json_parser_load_from_data (parser, r->json, -1, &error));
  g_assert_no_error (error);
  assert_json_finite (json_parser_get_root (parser));

  dets = sonar_buffer_get_detections_meta (buffer);
  g_assert_nonnull (dets);
  r->n_detections = dets->n_detections;
  r->detections = g_memdup2 (dets->detections,
      sizeof (SonarDetection) * dets->n_detections);
  for (guint i = 0; i < r->n_detections; i++)
    assert_detection_finite (&r->detections[i]);
  centroids = sonar_buffer_get_centroids_meta (buffer);
  g_assert_nonnull (centroids);
  r->n_centroids = centroids->n_centroids;
  for (guint i = 0; i < centroids->n_centroids; i++)
    assert_centroid_finite (&centroids->centroids[i]);

  if (run->warnings->len > 0)
    r->warning = g_strdup (run->warnings->pdata[0]);
  for (guint i = 0; i < run->messages->len; i++) {
    const GstStructure *m = run->messages->pdata[i];
    gst_structure_foreach (m, assert_field_finite, (gpointer) m);
    r->n_centroid_messages += gst_structure_has_name (m,
        SONAR_CENTROIDS_MESSAGE_NAME);
    r->n_detection_messages += gst_structure_has_name (m,
        SONAR_DETECTIONS_MESSAGE_NAME);
  }
  g_assert_cmpuint (r->n_centroid_messages, ==, 1);
  g_assert_cmpuint (r->n_detection_messages, ==, 1);
  for (guint d = 0; d < r->n_detections; d++)
    g_test_message ("  %.4f m %+.2f deg %+.4f m/s%s%s",
        r->detections[d].range, r->detections[d].azimuth,
        r->detections[d].radial_velocity,
        r->detections[d].out_of_range ? " (out of range)" : "",
        r->detections[d].valid ? "" : " (rejected)");
}

/* Runs the chain on one ping of @scene_json (extra sonarsrc properties in
 * @src) and returns its detections meta's copy; n in *n. */
static SonarDetection *
detect (const char *scene_json, const char *src, guint * n)
{
  g_autofree char *scene = sonar_test_write_temp ("scene.json", scene_json);
  g_autofree char *launch = g_strdup_printf ("sonarsrc scene-file=%s "
      "num-buffers=1 %s ! " CHAIN " ! appsink name=sink sync=false", scene,
      src);
  GstElement *pipeline = gst_parse_launch (launch, NULL);
  GstElement *sink = gst_bin_get_by_name (GST_BIN (pipeline), "sink");
  GstSample *sample;
  SonarDetectionsMeta *meta;
  SonarDetection *out;

  gst_element_set_state (pipeline, GST_STATE_PLAYING);
  sample = gst_app_sink_pull_sample (GST_APP_SINK (sink));
  g_assert_nonnull (sample);
  meta = sonar_buffer_get_detections_meta (gst_sample_get_buffer (sample));
  *n = meta->n_detections;
  out = g_memdup2 (meta->detections, sizeof (SonarDetection) * *n);
  for (guint d = 0; d < *n; d++) {
    g_assert_true (isfinite (out[d].range));
    g_assert_true (isfinite (out[d].radial_velocity));
    g_test_message ("  %.3f m %+.1f deg %+.4f m/s%s", out[d].range,
        out[d].azimuth, out[d].radial_velocity, out[d].out_of_range ?
        " (out of range)" : "");
  }
  gst_sample_unref (sample);
  gst_element_set_state (pipeline, GST_STATE_NULL);
  gst_object_unref (sink);
  gst_object_unref (pipeline);
  return out;
}

/* A reflector at 0.1 m echoes while the emitters still send and, 47 dB
 * stronger than one at 1.5 m, drowns the image under wardcluster's
 * relative threshold (the near-far limit of tests/test-velocityest.c): the
 * chain must stay finite and invent nothing. */
static void
test_blind_zone (void)
{
  guint n;
  g_autofree SonarDetection *d = detect ("{\"dimensions\": 2, "
      "\"reflectors\": [{\"range\": 0.1, \"azimuth\": 0},"
      " {\"range\": 0.1, \"azimuth\": 60, \"radial-velocity\": -7},"
      " {\"range\": 1.5, \"azimuth\": 24, \"radial-velocity\": -0.25}]}",
      "", &n);

  for (guint i = 0; i < n; i++) {
    g_assert_cmpfloat (d[i].range, <=, 2.0);
    /* Only the true object, if anything, and at its speed. */
    g_assert_cmpfloat (fabs (d[i].range - 1.5), <, 0.05);
    g_assert_cmpfloat (fabs (d[i].radial_velocity + 0.25), <, 0.02);
  }
}

/* Beyond the window and at +-90 degrees: no crash, no invented object; the
 * normal reflector is found with its speed. It sits on the 3-degree grid
 * of CHAIN. */
static void
test_edges (void)
{
  guint n;
  g_autofree SonarDetection *d = detect ("{\"dimensions\": 2, "
      "\"reflectors\": ["
      " {\"range\": 6.0, \"azimuth\": 10, \"radial-velocity\": -2},"
      " {\"range\": 1.0, \"azimuth\": 90},"
      " {\"range\": 1.2, \"azimuth\": -90, \"radial-velocity\": 0.3},"
      " {\"range\": 1.5, \"azimuth\": 24, \"radial-velocity\": -0.25}]}",
      "", &n);
  gboolean found = FALSE;

  for (guint i = 0; i < n; i++) {
    g_assert_cmpfloat (d[i].range, <=, 2.0);
    if (fabs (d[i].range - 1.5) < 0.05 && fabs (d[i].azimuth - 24) < 2) {
      g_assert_cmpfloat (fabs (d[i].radial_velocity + 0.25), <, 0.02);
      found = TRUE;
    }
  }
  g_assert_true (found);
}

/* Two reflectors 1 cm apart in range, same speed: reported as one object
 * (or two) at the right speed, never a wrong one. */
static void
test_two_reflectors_one_cm (void)
{
  guint n;
  g_autofree SonarDetection *d = detect ("{\"dimensions\": 2, "
      "\"reflectors\": [{\"range\": 1.2, \"azimuth\": -15, "
      "\"radial-velocity\": 0.2}, {\"range\": 1.21, \"azimuth\": -15, "
      "\"radial-velocity\": 0.2}]}", "", &n);

  g_assert_cmpuint (n, >=, 1);
  for (guint i = 0; i < n; i++)
    g_assert_cmpfloat (fabs (d[i].radial_velocity - 0.2), <, 0.02);
}

/* Huge and tiny amplitudes, and full-scale clipping: the same answer (or,
 * clipped, a finite one) at the same place. */
static void
test_amplitudes (void)
{
  const char *scene_format = "{\"dimensions\": 2, \"reflectors\": ["
      "{\"range\": 1.0, \"azimuth\": 30, \"radial-velocity\": -0.3, "
      "\"strength\": %g}]}";
  const double strengths[] = { 1.0, 1e-6, 1e4 };
  double reference = NAN;

  for (guint s = 0; s < G_N_ELEMENTS (strengths); s++) {
    g_autofree char *json = g_strdup_printf (scene_format, strengths[s]);
    guint n;
    /* Noise scaled with the echo: the same signal-to-noise ratio. */
    g_autofree char *src = g_strdup_printf ("noise-amplitude=%g",
        0.01 * strengths[s]);
    g_autofree SonarDetection *d = detect (json, src, &n);
    g_test_message ("strength %g: %u detections", strengths[s], n);
    g_assert_cmpuint (n, ==, 1);
    if (isnan (reference))
      reference = d[0].radial_velocity;
    g_assert_cmpfloat (fabs (d[0].radial_velocity - reference), <, 1e-3);
  }
  {
    /* A strong near echo clipped at full scale by the ADC. */
    guint n;
    g_autofree SonarDetection *d = detect ("{\"dimensions\": 2, "
        "\"reflectors\": [{\"range\": 0.5, \"azimuth\": 0, \"strength\": "
        "1000}]}", "clip=true", &n);
    g_test_message ("clipped: %u detections", n);
    /* Square waves where the echo tops the ADC's range: still the one
     * object, in place and still. */
    g_assert_cmpuint (n, ==, 1);
    g_assert_cmpfloat (fabs (d[0].range - 0.5), <, 0.01);
    g_assert_cmpfloat (fabs (d[0].azimuth), <, 2.0);
    g_assert_cmpfloat (fabs (d[0].radial_velocity), <, 0.02);
  }
}

/* The whole chain at its numerical extremes ---------------------------------*/

#define ONE_OBJECT "{\"dimensions\": 2, \"reflectors\": [{\"range\": 1.0, " \
  "\"azimuth\": 30, \"radial-velocity\": -0.3}]}"

/* The one valid detection of @r is the object of ONE_OBJECT. */
static void
assert_one_object (const ChainRun * r)
{
  guint valid = 0;

  for (guint i = 0; i < r->n_detections; i++) {
    const SonarDetection *d = &r->detections[i];
    if (!d->valid)
      continue;
    valid++;
    g_assert_cmpfloat (fabs (d->range - 1.0), <, 0.01);
    g_assert_cmpfloat (fabs (d->azimuth - 30.0), <, 2.0);
    g_assert_cmpfloat (fabs (d->radial_velocity + 0.3), <, 0.02);
    g_assert_false (d->out_of_range);
  }
  g_assert_cmpuint (valid, ==, 1);
}

#define THREE_OBJECTS "{\"dimensions\": 2, \"reflectors\": [" \
  "{\"range\": 0.8, \"azimuth\": -30, \"radial-velocity\": -1.0}, " \
  "{\"range\": 1.3, \"azimuth\": 10, \"radial-velocity\": 2.0}, " \
  "{\"range\": 1.8, \"azimuth\": 40, \"radial-velocity\": 0.5}]}"
/* dopplerbank's own bank (+-7 m/s) for them. */
#define CHAIN_WIDE_BANK "dopplerbank ! mimobeamform azimuth-count=61 " \
  "range-max=2.0 ! wardcluster ! velocityest"

/* The valid detections of @r are the three objects of THREE_OBJECTS. */
static void
assert_three_objects (const ChainRun * r)
{
  const double truth[3][3] = { {0.8, -30, -1.0}, {1.3, 10, 2.0}, {1.8, 40,
      0.5}
  };
  guint found[3] = { 0 }, valid = 0;

  for (guint i = 0; i < r->n_detections; i++) {
    const SonarDetection *d = &r->detections[i];
    if (!d->valid)
      continue;
    valid++;
    for (guint k = 0; k < 3; k++)
      found[k] += fabs (d->range - truth[k][0]) < 0.05
          && fabs (d->azimuth - truth[k][1]) < 2.0
          && fabs (d->radial_velocity - truth[k][2]) < 0.02;
  }
  g_assert_cmpuint (valid, ==, 3);
  for (guint k = 0; k < 3; k++)
    g_assert_cmpuint (found[k], ==, 1);
}

static void
edit_zero (float *x, gsize n, gpointer data)
{
  memset (x, 0, sizeof (float) * n);
}

static void
edit_scale (float *x, gsize n, gpointer data)
{
  const double scale = *(const double *) data;

  for (gsize i = 0; i < n; i++)
    x[i] = (float) (x[i] * scale);
}

/* Silence: no centroid, no detection, no warning, and an empty but
 * well-formed JSON line. */
static void
test_silence (void)
{
  ChainRun r;

  run_chain (ONE_OBJECT, "", CHAIN, edit_zero, NULL, &r);
  g_assert_cmpuint (r.n_centroids, ==, 0);
  g_assert_cmpuint (r.n_detections, ==, 0);
  g_assert_nonnull (strstr (r.json, "\"detections\": []"));
  g_assert_null (r.warning);
  chain_run_clear (&r);
}

/* A recording of nothing but denormals (|x| <= 1e-40, no echo): nothing is
 * detected; and the ping of one object scaled into the denormal range
 * (1e-40 of full scale, some 16 bits left) still gives that object. */
static void
edit_denormal_noise (float *x, gsize n, gpointer data)
{
  for (gsize i = 0; i < n; i++)
    x[i] = ((i * 2654435761u) >> 7) % 3 == 0 ? 1e-40f :
        ((i * 2654435761u) >> 7) % 3 == 1 ? -1e-40f : 0.0f;
}

static void
test_denormals (void)
{
  ChainRun r;
  double scale = 1e-40;

  run_chain (ONE_OBJECT, "", CHAIN, edit_denormal_noise, NULL, &r);
  g_assert_false (isnormal (1e-40f));
  g_assert_cmpuint (r.n_detections, ==, 0);
  g_assert_null (r.warning);
  chain_run_clear (&r);

  run_chain (ONE_OBJECT, "", CHAIN, edit_scale, &scale, &r);
  assert_one_object (&r);
  g_assert_null (r.warning);
  chain_run_clear (&r);
}

static void
edit_to_float_max (float *x, gsize n, gpointer data)
{
  float peak = 0.0f;

  for (gsize i = 0; i < n; i++)
    peak = MAX (peak, fabsf (x[i]));
  for (gsize i = 0; i < n; i++)
    x[i] = x[i] / peak * 3.3e38f;
}

/* Amplitudes of 1e-30 (a reflector of strength 1e-30 in noise of 1e-32),
 * of 1e30 and of 3.3e38 (the ping scaled): the same object at the same
 * speed as at full scale; three objects at 1e28 too. */
static void
test_amplitudes_extreme (void)
{
  ChainRun r;
  double scale = 1e30;

  run_chain ("{\"dimensions\": 2, \"reflectors\": [{\"range\": 1.0, "
      "\"azimuth\": 30, \"radial-velocity\": -0.3, \"strength\": 1e-30}]}",
      "noise-amplitude=1e-32", CHAIN, NULL, NULL, &r);
  assert_one_object (&r);
  chain_run_clear (&r);

  run_chain (ONE_OBJECT, "", CHAIN, edit_scale, &scale, &r);
  assert_one_object (&r);
  chain_run_clear (&r);

  /* Three objects at 1e28 in a 5 m ping, with noise (one was rejected
   * while pings were scaled to 1e30 only: the velocity stage's sums
   * overflowed): each found. */
  scale = 1e28;
  run_chain (THREE_OBJECTS, "max-range=5.0 noise-amplitude=0.3",
      CHAIN_WIDE_BANK, edit_scale,
      &scale, &r);
  assert_three_objects (&r);
  chain_run_clear (&r);

  /* Up to float's largest: the ping is scaled down by a power of two, with
   * a warning that says so. */
  run_chain (ONE_OBJECT, "", CHAIN, edit_to_float_max, NULL, &r);
  assert_one_object (&r);
  g_assert_nonnull (r.warning);
  g_test_message ("%s", r.warning);
  g_assert_nonnull (strstr (r.warning, "beyond what float spectra hold; "
          "such pings are scaled by 2^-"));
  chain_run_clear (&r);
}

/* NaN and infinite samples: the front end reads them as zeros and warns
 * once; the outputs are exactly those of the ping with zeros there. A ping
 * of NaN only is silence. */
static const gsize bad_samples[] = { 3, 32 * 1000 + 5, 32 * 3000 + 17,
  32 * 3001 + 17, 32 * 5000 + 31
};

static void
edit_non_finite (float *x, gsize n, gpointer data)
{
  const float values[] = { NAN, INFINITY, -INFINITY, NAN, INFINITY };

  for (guint i = 0; i < G_N_ELEMENTS (bad_samples); i++)
    x[bad_samples[i]] = data ? 0.0f : values[i];
}

static void
edit_all_nan (float *x, gsize n, gpointer data)
{
  for (gsize i = 0; i < n; i++)
    x[i] = NAN;
}

static void
test_non_finite_samples (void)
{
  ChainRun dirty, zeroed;

  run_chain (ONE_OBJECT, "", CHAIN, edit_non_finite, NULL, &dirty);
  run_chain (ONE_OBJECT, "", CHAIN, edit_non_finite, GINT_TO_POINTER (1),
      &zeroed);
  g_test_message ("warning: %s", dirty.warning);
  g_assert_cmpstr (dirty.warning, ==, "The recording holds NaN or infinite "
      "samples (5 in ping 0); they are read as 0");
  g_assert_null (zeroed.warning);
  g_assert_cmpstr (dirty.json, ==, zeroed.json);
  assert_one_object (&dirty);
  chain_run_clear (&dirty);
  chain_run_clear (&zeroed);

  run_chain (ONE_OBJECT, "", CHAIN, edit_all_nan, NULL, &dirty);
  g_assert_nonnull (dirty.warning);
  g_assert_true (g_str_has_prefix (dirty.warning, "The recording holds NaN "
          "or infinite samples ("));
  g_assert_cmpuint (dirty.n_centroids, ==, 0);
  g_assert_cmpuint (dirty.n_detections, ==, 0);
  chain_run_clear (&dirty);
}

/* Reflectors at 0.1 m, inside the blind zone (they echo while the
 * emitters still send, and lie before the image's 0.3 m), weak enough not
 * to drown the scene (strength 0.01: at 0.1 m still as loud as a unit
 * reflector at 1 m): nothing is reported for them, and the object at
 * 1.5 m is reported once, at its speed. */
static void
test_blind_zone_weak (void)
{
  ChainRun r;
  guint valid = 0;

  run_chain ("{\"dimensions\": 2, \"reflectors\": ["
      " {\"range\": 0.1, \"azimuth\": 0, \"strength\": 0.01},"
      " {\"range\": 0.1, \"azimuth\": 60, \"radial-velocity\": -0.3,"
      "  \"strength\": 0.01},"
      " {\"range\": 1.5, \"azimuth\": 20, \"radial-velocity\": -0.25}]}",
      "", CHAIN " keep-rejected=true", NULL, NULL, &r);
  for (guint i = 0; i < r.n_detections; i++) {
    const SonarDetection *d = &r.detections[i];
    g_assert_cmpfloat (d->range, >=, 0.3);
    if (!d->valid)
      continue;
    valid++;
    g_assert_cmpfloat (fabs (d->range - 1.5), <, 0.01);
    g_assert_cmpfloat (fabs (d->azimuth - 20), <, 2.0);
    g_assert_cmpfloat (fabs (d->radial_velocity + 0.25), <, 0.02);
  }
  g_assert_cmpuint (valid, ==, 1);
  chain_run_clear (&r);
}

/* Beyond the image's range window (2 m): recorded whole (sonarsrc
 * max-range=3) or cut off by the end of the ping (max-range=2), strong
 * reflectors at 2.03 and 2.4 m give no detection; the object inside is
 * reported once, at its speed. */
static void
test_beyond_the_window (void)
{
  const char *src[] = { "max-range=3.0", "" };

  for (guint i = 0; i < G_N_ELEMENTS (src); i++) {
    ChainRun r;
    guint valid = 0;

    run_chain ("{\"dimensions\": 2, \"reflectors\": ["
        " {\"range\": 2.4, \"azimuth\": -40, \"radial-velocity\": 0.3,"
        "  \"strength\": 3},"
        " {\"range\": 2.03, \"azimuth\": 30, \"radial-velocity\": -0.2,"
        "  \"strength\": 3},"
        " {\"range\": 1.5, \"azimuth\": 0, \"radial-velocity\": 0.1}]}",
        src[i], CHAIN, NULL, NULL, &r);
    for (guint k = 0; k < r.n_detections; k++) {
      const SonarDetection *d = &r.detections[k];
      g_assert_cmpfloat (d->range, <=, 2.0);
      valid++;
      g_assert_cmpfloat (fabs (d->range - 1.5), <, 0.01);
      g_assert_cmpfloat (fabs (d->azimuth), <, 2.0);
      g_assert_cmpfloat (fabs (d->radial_velocity - 0.1), <, 0.02);
    }
    g_assert_cmpuint (valid, ==, 1);
    chain_run_clear (&r);
  }
}

/* +-90 degrees at +-7 m/s on the Fig. 9 bank (-7..7 m/s): inside the bank
 * (+-6.9) each reflector is found at the fan's edge with its speed; at the
 * bank's edges (+-7) flagged out_of_range at the edge, without sigmas
 * for the velocity and range; beyond it (9 and -12 m/s) never reported as
 * a confident in-range speed. */
#define FAST_CHAIN "dopplerbank velocity-min=-7 velocity-max=7 " \
  "velocity-step=0.05 ! mimobeamform azimuth-count=31 range-max=2.0 ! " \
  "wardcluster ! velocityest"

static void
test_wide_and_fast (void)
{
  const struct
  {
    const char *scene;
    double range[3], azimuth[3], velocity[3];
  } cases[] = {
    {"{\"dimensions\": 2, \"reflectors\": ["
          " {\"range\": 1.0, \"azimuth\": 90, \"radial-velocity\": -6.9},"
          " {\"range\": 1.4, \"azimuth\": -90, \"radial-velocity\": 6.9},"
          " {\"range\": 1.7, \"azimuth\": 0, \"radial-velocity\": 7.0}]}",
        {1.0, 1.4, 1.7}, {90, -90, 0}, {-6.9, 6.9, 7.0}},
    {"{\"dimensions\": 2, \"reflectors\": ["
          " {\"range\": 1.0, \"azimuth\": 90, \"radial-velocity\": -7.0},"
          " {\"range\": 1.4, \"azimuth\": -90, \"radial-velocity\": 7.0},"
          " {\"range\": 1.7, \"azimuth\": 0, \"radial-velocity\": -12},"
          " {\"range\": 1.2, \"azimuth\": -45, \"radial-velocity\": 9}]}",
        {1.0, 1.4, NAN}, {90, -90, NAN}, {-7.0, 7.0, NAN}},
  };

  for (guint c = 0; c < G_N_ELEMENTS (cases); c++) {
    ChainRun r;
    guint found[3] = { 0 };

    run_chain (cases[c].scene, "", FAST_CHAIN " keep-rejected=true", NULL,
        NULL, &r);
    for (guint i = 0; i < r.n_detections; i++) {
      const SonarDetection *d = &r.detections[i];
      gboolean known = FALSE;
      if (!d->valid)
        continue;
      for (guint k = 0; k < 3; k++) {
        /* The scene's ranges are at t = 0; a 7 m/s mover is reported 7 cm
         * on, when the emissions' centre reaches it (CONTRACTS). */
        if (isnan (cases[c].range[k])
            || fabs (d->range - cases[c].range[k]) > 0.1
            || fabs (d->azimuth - cases[c].azimuth[k]) > 3.0)
          continue;
        known = TRUE;
        found[k]++;
        g_assert_cmpfloat (fabs (d->radial_velocity - cases[c].velocity[k]),
            <=, 0.02);
        /* Flagged exactly when at the bank's edge. */
        g_assert_cmpint (d->out_of_range, ==,
            fabs (cases[c].velocity[k]) >= 7.0);
      }
      /* Anything else is a reflector beyond the bank: out of range. */
      if (!known)
        g_assert_true (d->out_of_range);
      /* At the edge the velocity is a bound: no sigma for it, nor for the
       * range moved on at it (they read 0.0005 and 1240 m/s). */
      g_assert_cmpint (isnan (d->radial_velocity_sigma), ==,
          d->out_of_range);
      g_assert_cmpint (isnan (d->range_sigma), ==, d->out_of_range);
    }
    for (guint k = 0; k < 3; k++)
      g_assert_cmpuint (found[k], ==, isnan (cases[c].range[k]) ? 0 : 1);
    chain_run_clear (&r);
  }
}

int
main (int argc, char **argv)
{
  sonar_test_init_gst (&argc, &argv);
  g_test_add_func ("/stability/state-changes", test_state_changes);
  g_test_add_func ("/stability/long-run", test_long_run);
  g_test_add_func ("/stability/blind-zone", test_blind_zone);
  g_test_add_func ("/stability/edges", test_edges);
  g_test_add_func ("/stability/two-reflectors-1-cm",
      test_two_reflectors_one_cm);
  g_test_add_func ("/stability/amplitudes", test_amplitudes);
  g_test_add_func ("/stability/silence", test_silence);
  g_test_add_func ("/stability/denormals", test_denormals);
  g_test_add_func ("/stability/amplitudes-1e-30-1e30",
      test_amplitudes_extreme);
  g_test_add_func ("/stability/nan-inf-samples", test_non_finite_samples);
  g_test_add_func ("/stability/blind-zone-weak", test_blind_zone_weak);
  g_test_add_func ("/stability/beyond-the-window", test_beyond_the_window);
  g_test_add_func ("/stability/wide-and-fast", test_wide_and_fast);
  return g_test_run ();
}
