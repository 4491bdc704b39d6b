/* test-sonartrack.c: sonartrack through the whole chain, against the
 * simulator's truth (issue 15's goals): the sensor's own velocity per
 * ping, still and moving objects, identities through a crossing and over
 * dropped pings, velocities in the world, the unobservable case; the JSON
 * line, the meta and the bus message agree; errors are named. */
#include <gst/app/gstappsink.h>
#include <json-glib/json-glib.h>
#include <math.h>
#include <string.h>

#include "sonar-contracts.h"
#include "sonar-error.h"
#include "sonar-test-gst.h"

#define FIG10_BANK "velocity-min=-0.4 velocity-max=0.4 velocity-step=0.02"
#define WALKERS_BANK "velocity-min=-1.5 velocity-max=1.5 velocity-step=0.02"

typedef struct
{
  GPtrArray *buffers;           /* sonartrack's output, one per ping */
  GPtrArray *messages;          /* its "sonar-tracks" structures */
} Run;

static void
run_clear (Run * run)
{
  g_ptr_array_unref (run->buffers);
  g_ptr_array_unref (run->messages);
}

/* Drops the pings in [first, last] before sonartrack. */
typedef struct
{
  guint64 first, last;
} Gap;

static GstPadProbeReturn
drop_pings (GstPad * pad, GstPadProbeInfo * info, gpointer data)
{
  const Gap *gap = data;
  SonarDetectionsMeta *meta =
      sonar_buffer_get_detections_meta (GST_PAD_PROBE_INFO_BUFFER (info));

  return meta && meta->ping_index >= gap->first && meta->ping_index
      <= gap->last ? GST_PAD_PROBE_DROP : GST_PAD_PROBE_OK;
}

/* The gap's probe before sonartrack. */
static void
add_gap (GstElement * pipeline, gpointer data)
{
  GstElement *tracker = gst_bin_get_by_name (GST_BIN (pipeline), "track");
  GstPad *pad = gst_element_get_static_pad (tracker, "sink");

  gst_pad_add_probe (pad, GST_PAD_PROBE_TYPE_BUFFER, drop_pings, data, NULL);
  gst_object_unref (pad);
  gst_object_unref (tracker);
}

/* Runs "sonarsrc @source ! dopplerbank @bank ! mimobeamform ! wardcluster
 * ! velocityest ! sonartrack @track ! appsink" to EOS. */
static Run
run_chain (const char *source, const char *bank, const char *track,
    const Gap * gap)
{
  g_autofree char *launch = g_strdup_printf ("sonarsrc %s ! dopplerbank %s "
      "! mimobeamform ! wardcluster ! velocityest post-messages=false ! "
      "sonartrack name=track %s ! appsink name=sink sync=false", source, bank,
      track);
  g_autoptr (SonarTestRun) test_run = sonar_test_run_with (launch,
      gap ? add_gap : NULL, (gpointer) gap);
  GPtrArray *samples;
  Run run;

  if (test_run->error_text)
    g_error ("%s", test_run->error_text);
  run.buffers = g_ptr_array_new_with_free_func ((GDestroyNotify)
      gst_buffer_unref);
  run.messages = g_ptr_array_new_with_free_func ((GDestroyNotify)
      gst_structure_free);
  samples = sonar_test_run_samples (test_run, "sink");
  for (guint i = 0; i < samples->len; i++)
    g_ptr_array_add (run.buffers, gst_buffer_ref (gst_sample_get_buffer
            (samples->pdata[i])));
  for (guint i = 0; i < test_run->messages->len; i++)
    if (gst_structure_has_name (test_run->messages->pdata[i],
            SONAR_TRACKS_MESSAGE_NAME))
      g_ptr_array_add (run.messages, gst_structure_copy
          (test_run->messages->pdata[i]));
  return run;
}

static double
distance (SonarVec3 a, SonarVec3 b)
{
  return sonar_vec3_norm (sonar_vec3_sub (a, b));
}

/* Scores a run against the truth on its buffers and @scene (world
 * velocities). */
typedef struct
{
  guint pings;
  double worst_ego;             /* observed pings, m/s */
  guint unobservable;
  guint wrong_ego;              /* observed beyond 0.01 m/s or 4 sigma */
  guint switches;
  guint wrong_moving;           /* confirmed tracks labelled wrongly, on
                                 * pings that observed the ego-motion */
  guint matches;
  double worst_mover;           /* from ping 10 on, m/s */
  guint64 ids[64];              /* per true object: its track */
  gint confirmed_at[64];        /* per true object: first ping confirmed */
} Score;

static void
score_run (const Run * run, const SonarScene * scene, Score * s)
{
  memset (s, 0, sizeof *s);
  for (guint k = 0; k < G_N_ELEMENTS (s->confirmed_at); k++)
    s->confirmed_at[k] = -1;
  for (guint b = 0; b < run->buffers->len; b++) {
    GstBuffer *buffer = g_ptr_array_index (run->buffers, b);
    SonarTracksMeta *tracks = sonar_buffer_get_tracks_meta (buffer);
    SonarTruthMeta *truth = sonar_buffer_get_truth_meta (buffer);
    const SonarEgoMotion *ego;

    g_assert_nonnull (tracks);
    g_assert_nonnull (truth);
    g_assert_cmpuint (tracks->ping_index, ==, truth->ping_index);
    ego = &tracks->ego;
    s->pings++;
    if (ego->status == SONAR_EGO_OBSERVED) {
      const SonarVec3 e = sonar_vec3_sub (ego->velocity,
          scene->sensor_velocity);
      s->worst_ego = MAX (s->worst_ego, sonar_vec3_norm (e));
      if (!(sonar_vec3_norm (e) <= 0.01 && fabs (e.x) <= 4 * sqrt
              (ego->covariance[0][0]) && fabs (e.z) <= 4 * sqrt
              (ego->covariance[2][2])))
        s->wrong_ego++;
    } else {
      s->unobservable++;
    }
    for (guint k = 0; k < truth->n_truths && k < 64; k++) {
      const SonarTruth *t = &truth->truths[k];
      const SonarVec3 world = scene->reflectors[t->reflector].velocity;
      const gboolean mover = sonar_vec3_norm (world) > 0.0;
      const SonarTrack *match = NULL;
      double best = 0.15;

      for (guint i = 0; i < tracks->n_tracks; i++) {
        const SonarTrack *track = &tracks->tracks[i];
        const double d = distance (track->position, t->position);
        if (track->state == SONAR_TRACK_CONFIRMED && d < best) {
          best = d;
          match = track;
        }
      }
      if (!match)
        continue;
      s->matches++;
      if (s->confirmed_at[k] < 0)
        s->confirmed_at[k] = tracks->ping_index;
      if (s->ids[k] && s->ids[k] != match->id) {
        g_test_message ("ping %" G_GUINT64_FORMAT ": object %u was track %"
            G_GUINT64_FORMAT ", now %" G_GUINT64_FORMAT, tracks->ping_index,
            k, s->ids[k], match->id);
        s->switches++;
      }
      s->ids[k] = match->id;
      /* Without the sensor's velocity nothing is shown to move. */
      if (match->moving != mover && ego->status == SONAR_EGO_OBSERVED) {
        g_test_message ("ping %" G_GUINT64_FORMAT ": object %u (track %"
            G_GUINT64_FORMAT ") labelled %s, speed %.3f m/s",
            tracks->ping_index, k, match->id, match->moving ? "moving" :
            "still", sonar_vec3_norm (match->velocity));
        s->wrong_moving++;
      }
      if (mover && tracks->ping_index >= 10)
        s->worst_mover = MAX (s->worst_mover, distance (match->velocity,
                world));
    }
  }
}

static void
report (const char *name, const Score * s)
{
  g_test_message ("%s: %u pings, ego worst %.4f m/s (%u unobservable, %u "
      "wrong), %u matches, %u switches, %u wrong labels, movers' velocity "
      "worst %.4f m/s from ping 10", name, s->pings, s->worst_ego,
      s->unobservable, s->wrong_ego, s->matches, s->switches,
      s->wrong_moving, s->worst_mover);
}

/* 1. The Fig. 10 drive, 30 pings: the sensor's velocity within 0.005 m/s
 * on every ping, every object still, no identity switch, each object
 * confirmed within 3 pings, and tracked (through the array's plane, as the
 * planar array sees it mirrored) on most pings. */
static void
test_fig10 (void)
{
  SonarScene scene;
  Run run = run_chain ("scene=fig10 num-buffers=30", FIG10_BANK, "", NULL);
  Score s;

  sonar_scene_init_preset (&scene, SONAR_SCENE_PRESET_FIG10);
  score_run (&run, &scene, &s);
  report ("fig10", &s);
  g_assert_cmpuint (s.pings, ==, 30);
  g_assert_cmpuint (s.unobservable, ==, 0);
  g_assert_cmpfloat (s.worst_ego, <=, 0.005);
  g_assert_cmpuint (s.switches, ==, 0);
  g_assert_cmpuint (s.wrong_moving, ==, 0);
  for (guint k = 0; k < scene.n_reflectors; k++)
    g_assert_cmpint (s.confirmed_at[k], ==, 2);
  g_assert_cmpuint (s.matches, >=, 6 * 28 * 9 / 10);
  for (guint b = 0; b < run.buffers->len; b++) {
    SonarTracksMeta *m = sonar_buffer_get_tracks_meta
        (g_ptr_array_index (run.buffers, b));
    g_assert_cmpuint (m->ego.dimensions, ==, 2);
    for (guint i = 0; i < m->n_tracks; i++)
      g_assert_false (m->tracks[i].moving);
  }
  run_clear (&run);
  sonar_scene_clear (&scene);
}

/* 2. The Fig. 9 world, 12 pings at the elements' defaults: the two movers
 * moving, the four cylinders still, on every ping; the movers' velocity in
 * the world within 0.05 m/s after 10 pings (the fast one passes 0.6 m
 * from the sensor at ping 7). */
static void
test_fig9 (void)
{
  SonarScene scene;
  Run run = run_chain ("scene=fig9 num-buffers=12", "", "", NULL);
  Score s;

  sonar_scene_init_preset (&scene, SONAR_SCENE_PRESET_FIG9);
  score_run (&run, &scene, &s);
  report ("fig9", &s);
  g_assert_cmpuint (s.pings, ==, 12);
  g_assert_cmpuint (s.wrong_ego, ==, 0);
  g_assert_cmpuint (s.switches, ==, 0);
  g_assert_cmpuint (s.wrong_moving, ==, 0);
  g_assert_cmpuint (s.matches, >=, 6 * 10);
  g_assert_cmpfloat (s.worst_mover, >, 0.0);
  g_assert_cmpfloat (s.worst_mover, <=, 0.05);
  run_clear (&run);
  sonar_scene_clear (&scene);
}

/* 3. The crossing preset, 30 pings: the sensor's velocity within 0.01 m/s,
 * the walkers keep their identities through the crossing (ping 15, where
 * the chain sees one object between them), their velocity in the world
 * within 0.05 m/s after 10 pings; walkers moving, the wall still. */
static void
test_crossing (void)
{
  SonarScene scene;
  Run run = run_chain ("scene=crossing num-buffers=30", WALKERS_BANK, "",
      NULL);
  Score s;

  sonar_scene_init_preset (&scene, SONAR_SCENE_PRESET_CROSSING);
  score_run (&run, &scene, &s);
  report ("crossing", &s);
  g_assert_cmpuint (s.pings, ==, 30);
  g_assert_cmpuint (s.unobservable, ==, 0);
  g_assert_cmpfloat (s.worst_ego, <=, 0.01);
  g_assert_cmpuint (s.switches, ==, 0);
  g_assert_cmpuint (s.wrong_moving, ==, 0);
  /* Both walkers tracked before and after they meet. */
  g_assert_cmpint (s.confirmed_at[0], ==, 2);
  g_assert_cmpint (s.confirmed_at[1], ==, 2);
  g_assert_cmpuint (s.ids[0], !=, s.ids[1]);
  g_assert_cmpfloat (s.worst_mover, >, 0.0);
  g_assert_cmpfloat (s.worst_mover, <=, 0.05);
  run_clear (&run);
  sonar_scene_clear (&scene);
}

/* 4. Most objects move (pipelines/scenes/mostly-moving.json: two posts
 * among five walkers going their own ways): on every ping the sensor's
 * velocity is unobservable or right, never confidently wrong. */
static void
test_mostly_moving (void)
{
  g_autofree char *path =
      sonar_test_source_path ("pipelines/scenes/mostly-moving.json");
  g_autofree char *source = g_strdup_printf ("scene-file=%s num-buffers=20",
      path);
  SonarScene scene;
  GError *error = NULL;
  Run run = run_chain (source, WALKERS_BANK, "", NULL);
  Score s;

  g_assert_true (sonar_scene_load_file (&scene, path, &error));
  g_assert_no_error (error);
  score_run (&run, &scene, &s);
  report ("mostly-moving", &s);
  g_assert_cmpuint (s.pings, ==, 20);
  g_assert_cmpuint (s.wrong_ego, ==, 0);
  g_assert_cmpuint (s.unobservable, >, 0);
  for (guint b = 0; b < run.buffers->len; b++) {
    SonarTracksMeta *m = sonar_buffer_get_tracks_meta
        (g_ptr_array_index (run.buffers, b));
    if (m->ego.status != SONAR_EGO_OBSERVED)
      g_assert_cmpuint (m->ego.dimensions, ==, 0);
  }
  run_clear (&run);
  sonar_scene_clear (&scene);
}

/* 4b. 3-D: a hemisphere sensor driving at (0.05, 0, 0.3) m/s among six
 * points at -30..40 degrees of elevation: the ego velocity in all three
 * components within 0.01 m/s, every point still and confirmed. */
static void
test_3d (void)
{
  const char *json = "{\"dimensions\": 3, \"sensor\": {\"velocity\": "
      "[0.05, 0, 0.3]}, \"reflectors\": ["
      "{\"range\": 1.5, \"azimuth\": -40, \"elevation\": 20},"
      "{\"range\": 2.0, \"azimuth\": 10, \"elevation\": -30},"
      "{\"range\": 2.5, \"azimuth\": 35, \"elevation\": 15},"
      "{\"range\": 3.0, \"azimuth\": -10, \"elevation\": 40},"
      "{\"range\": 1.8, \"azimuth\": 60, \"elevation\": -10},"
      "{\"range\": 3.5, \"azimuth\": -55, \"elevation\": -20}]}";
  g_autofree char *path = sonar_test_write_temp ("drive-3d.json", json);
  g_autofree char *source = g_strdup_printf ("scene-file=%s num-buffers=4",
      path);
  SonarScene scene;
  Run run = run_chain (source, FIG10_BANK, "", NULL);
  Score s;

  g_assert_true (sonar_scene_load_file (&scene, path, NULL));
  score_run (&run, &scene, &s);
  report ("3-D drive", &s);
  g_assert_cmpuint (s.pings, ==, 4);
  g_assert_cmpuint (s.unobservable, ==, 0);
  g_assert_cmpfloat (s.worst_ego, <=, 0.01);
  g_assert_cmpuint (s.wrong_moving, ==, 0);
  g_assert_cmpuint (s.matches, ==, 6 * 2);
  for (guint b = 0; b < run.buffers->len; b++) {
    SonarTracksMeta *m = sonar_buffer_get_tracks_meta
        (g_ptr_array_index (run.buffers, b));
    g_assert_cmpuint (m->ego.dimensions, ==, 3);
    g_assert_cmpfloat (m->ego.covariance[1][1], >, 0.0);
  }
  run_clear (&run);
  sonar_scene_clear (&scene);
}

/* 5. Dropped pings: 5-7 of the Fig. 10 drive never reach sonartrack; the
 * tracks carry on with their identities, the output numbers the pings
 * with the gap. */
static void
test_dropped_pings (void)
{
  const Gap gap = { 5, 7 };
  SonarScene scene;
  Run run = run_chain ("scene=fig10 num-buffers=14", FIG10_BANK, "", &gap);
  Score s;

  sonar_scene_init_preset (&scene, SONAR_SCENE_PRESET_FIG10);
  score_run (&run, &scene, &s);
  report ("fig10, pings 5-7 dropped", &s);
  g_assert_cmpuint (s.pings, ==, 11);
  g_assert_cmpuint (s.switches, ==, 0);
  g_assert_cmpuint (s.wrong_moving, ==, 0);
  g_assert_cmpfloat (s.worst_ego, <=, 0.005);
  g_assert_cmpuint (sonar_buffer_get_tracks_meta (g_ptr_array_index
          (run.buffers, 5))->ping_index, ==, 8);
  /* Every object tracked right after the gap. */
  {
    SonarTracksMeta *m = sonar_buffer_get_tracks_meta (g_ptr_array_index
        (run.buffers, 5));
    guint updated = 0;
    for (guint i = 0; i < m->n_tracks; i++)
      updated += m->tracks[i].state == SONAR_TRACK_CONFIRMED
          && m->tracks[i].detection >= 0 && m->tracks[i].hits >= 6;
    g_assert_cmpuint (updated, >=, 5);
  }
  run_clear (&run);
  sonar_scene_clear (&scene);
}

static double
member_double (JsonObject * o, const char *name)
{
  g_assert_true (json_object_has_member (o, name));
  return json_object_get_double_member (o, name);
}

static void
assert_vector (JsonObject * o, const char *name, SonarVec3 v)
{
  JsonArray *a = json_object_get_array_member (o, name);
  g_assert_nonnull (a);
  g_assert_cmpuint (json_array_get_length (a), ==, 3);
  g_assert_cmpfloat_with_epsilon (json_array_get_double_element (a, 0), v.x,
      1e-4);
  g_assert_cmpfloat_with_epsilon (json_array_get_double_element (a, 1), v.y,
      1e-4);
  g_assert_cmpfloat_with_epsilon (json_array_get_double_element (a, 2), v.z,
      1e-4);
}

static void
assert_matrix (JsonObject * o, const char *name, const double m[3][3])
{
  JsonArray *rows = json_object_get_array_member (o, name);
  g_assert_cmpuint (json_array_get_length (rows), ==, 3);
  for (guint r = 0; r < 3; r++) {
    JsonArray *row = json_array_get_array_element (rows, r);
    g_assert_cmpuint (json_array_get_length (row), ==, 3);
    for (guint c = 0; c < 3; c++)
      g_assert_cmpfloat (fabs (json_array_get_double_element (row, c)
              - m[r][c]), <=, 1e-3 * fabs (m[r][c]) + 1e-12);
  }
}

/* 6. The JSON line, the meta and the bus message say the same, with the
 * names of docs/CONTRACTS.md section 14. */
static void
test_outputs_agree (void)
{
  Run run = run_chain ("scene=fig9 num-buffers=4", "", "", NULL);

  g_assert_cmpuint (run.buffers->len, ==, 4);
  g_assert_cmpuint (run.messages->len, ==, 4);
  for (guint b = 0; b < run.buffers->len; b++) {
    GstBuffer *buffer = g_ptr_array_index (run.buffers, b);
    SonarTracksMeta *meta = sonar_buffer_get_tracks_meta (buffer);
    const GstStructure *msg = g_ptr_array_index (run.messages, b);
    g_autoptr (JsonParser) parser = json_parser_new ();
    const GValue *list, *velocity;
    JsonObject *root;
    JsonArray *tracks;
    GstMapInfo map;
    guint64 ping;

    g_assert_true (gst_buffer_map (buffer, &map, GST_MAP_READ));
    g_assert_cmpint (map.data[map.size - 1], ==, '\n');
    g_assert_true (json_parser_load_from_data (parser, (const char *)
            map.data, map.size, NULL));
    gst_buffer_unmap (buffer, &map);
    root = json_node_get_object (json_parser_get_root (parser));
    g_assert_cmpint (json_object_get_int_member (root, "ping"), ==,
        meta->ping_index);
    g_assert_cmpfloat_with_epsilon (member_double (root, "time"),
        (double) GST_BUFFER_PTS (buffer) / GST_SECOND, 1e-6);
    g_assert_cmpint (meta->ego.status, ==, SONAR_EGO_OBSERVED);
    g_assert_cmpstr (json_object_get_string_member (root, "ego_status"), ==,
        "observed");
    g_assert_true (json_object_get_null_member (root, "ego_reason"));
    assert_vector (root, "ego_velocity", meta->ego.velocity);
    assert_matrix (root, "ego_covariance",
        (const double (*)[3]) meta->ego.covariance);
    g_assert_cmpint (json_object_get_int_member (root, "ego_dimensions"), ==,
        2);
    g_assert_cmpint (json_object_get_int_member (root, "ego_still"), ==,
        meta->ego.n_still);
    tracks = json_object_get_array_member (root, "tracks");
    g_assert_cmpuint (json_array_get_length (tracks), ==, meta->n_tracks);
    g_assert_cmpuint (meta->n_tracks, >=, 6);
    for (guint i = 0; i < meta->n_tracks; i++) {
      const SonarTrack *t = &meta->tracks[i];
      JsonObject *o = json_array_get_object_element (tracks, i);
      g_assert_cmpint (json_object_get_int_member (o, "id"), ==, t->id);
      g_assert_cmpstr (json_object_get_string_member (o, "state"), ==,
          sonar_track_state_to_string (t->state));
      g_assert_cmpint (json_object_get_boolean_member (o, "moving"), ==,
          t->moving);
      g_assert_cmpfloat_with_epsilon (member_double (o, "instant"),
          t->instant, 1e-7);
      g_assert_cmpfloat_with_epsilon (member_double (o, "range"), t->range,
          1e-4);
      g_assert_cmpfloat_with_epsilon (member_double (o, "azimuth"),
          t->azimuth, 0.01);
      g_assert_cmpfloat_with_epsilon (member_double (o, "elevation"),
          t->elevation, 0.01);
      g_assert_cmpfloat_with_epsilon (member_double (o, "x"),
          t->position.x, 1e-4);
      g_assert_cmpfloat_with_epsilon (member_double (o, "z"),
          t->position.z, 1e-4);
      g_assert_cmpfloat_with_epsilon (member_double (o, "radial_velocity"),
          t->radial_velocity, 1e-4);
      g_assert_cmpfloat_with_epsilon (member_double (o, "radius"),
          t->radius, 1e-4);
      assert_vector (o, "velocity", t->velocity);
      assert_matrix (o, "position_covariance",
          (const double (*)[3]) t->position_covariance);
      assert_matrix (o, "velocity_covariance",
          (const double (*)[3]) t->velocity_covariance);
      g_assert_cmpint (json_object_get_int_member (o, "hits"), ==, t->hits);
      g_assert_cmpint (json_object_get_int_member (o, "misses"), ==,
          t->misses);
      if (t->detection >= 0)
        g_assert_cmpint (json_object_get_int_member (o, "detection"), ==,
            t->detection);
      else
        g_assert_true (json_object_get_null_member (o, "detection"));
    }
    /* The bus message. */
    g_assert_true (gst_structure_has_name (msg, "sonar-tracks"));
    g_assert_true (gst_structure_get_uint64 (msg, "ping", &ping));
    g_assert_cmpuint (ping, ==, meta->ping_index);
    g_assert_cmpstr (gst_structure_get_string (msg, "ego_status"), ==,
        "observed");
    velocity = gst_structure_get_value (msg, "ego_velocity");
    g_assert_cmpuint (gst_value_array_get_size (velocity), ==, 3);
    g_assert_cmpfloat (g_value_get_double (gst_value_array_get_value
            (velocity, 2)), ==, meta->ego.velocity.z);
    list = gst_structure_get_value (msg, "tracks");
    g_assert_cmpuint (gst_value_array_get_size (list), ==, meta->n_tracks);
    for (guint i = 0; i < meta->n_tracks; i++) {
      const GstStructure *t = gst_value_get_structure
          (gst_value_array_get_value (list, i));
      guint64 id;
      double vr;
      g_assert_true (gst_structure_get_uint64 (t, "id", &id));
      g_assert_cmpuint (id, ==, meta->tracks[i].id);
      g_assert_true (gst_structure_get_double (t, "radial_velocity", &vr));
      g_assert_cmpfloat (vr, ==, meta->tracks[i].radial_velocity);
      g_assert_cmpuint (gst_value_array_get_size (gst_structure_get_value (t,
                  "position_covariance")), ==, 9);
    }
    /* The ping's truth and detections ride along. */
    g_assert_nonnull (sonar_buffer_get_truth_meta (buffer));
    g_assert_nonnull (sonar_buffer_get_detections_meta (buffer));
  }
  run_clear (&run);
}

/* 7. The application's odometry as an upstream event sets the prior. */
static void
test_prior_event (void)
{
  GstElement *pipeline = gst_parse_launch ("fakesrc num-buffers=0 ! "
      "sonartrack name=track "
      "! fakesink name=sink", NULL);
  GstElement *track = gst_bin_get_by_name (GST_BIN (pipeline), "track");
  GstElement *sink = gst_bin_get_by_name (GST_BIN (pipeline), "sink");
  GValue prior = G_VALUE_INIT;
  double sigma;

  g_object_get (track, "prior-sigma", &sigma, NULL);
  g_assert_cmpfloat (sigma, ==, 0.0);
  gst_element_set_state (pipeline, GST_STATE_PAUSED);
  g_assert_true (gst_element_send_event (sink, sonar_ego_prior_event_new
          (sonar_vec3 (0.01, 0, 0.3), 0.05)));
  g_object_get (track, "prior-sigma", &sigma, NULL);
  g_assert_cmpfloat (sigma, ==, 0.05);
  g_value_init (&prior, GST_TYPE_ARRAY);
  g_object_get_property (G_OBJECT (track), "prior-velocity", &prior);
  g_assert_cmpuint (gst_value_array_get_size (&prior), ==, 3);
  g_assert_cmpfloat (g_value_get_double (gst_value_array_get_value (&prior,
              2)), ==, 0.3);
  g_value_unset (&prior);
  gst_element_set_state (pipeline, GST_STATE_NULL);
  gst_object_unref (track);
  gst_object_unref (sink);
  gst_object_unref (pipeline);
}

/* 8. Errors name the problem. */
static void
test_errors (void)
{
  g_autofree char *no_meta = sonar_test_run_pipeline ("fakesrc num-buffers=1 "
      "sizetype=fixed sizemax=4 filltype=zero ! text/x-raw,format=utf8 ! "
      "sonartrack ! fakesink");
  g_autofree char *settings = sonar_test_run_pipeline ("sonarsrc "
      "num-buffers=1 ! dopplerbank ! mimobeamform ! wardcluster ! "
      "velocityest ! sonartrack dimensions=1 ! fakesink");

  g_assert_nonnull (no_meta);
  g_assert_true (g_str_has_prefix (no_meta, "sonartrack: a buffer without "
          "detections: sonartrack takes velocityest's output"));
  g_assert_nonnull (settings);
  g_assert_true (g_str_has_prefix (settings, "sonartrack: tracks: "
          "dimensions must be 2 or 3, not 1"));
  /* The core's error keeps its domain and code on the bus. */
  {
    g_autoptr (SonarTestRun) run = sonar_test_run ("sonarsrc num-buffers=1 "
        "! dopplerbank ! mimobeamform ! wardcluster ! velocityest ! "
        "sonartrack dimensions=1 ! fakesink");
    g_assert_error (run->error, SONAR_ERROR, SONAR_ERROR_SETTINGS);
  }
}

int
main (int argc, char **argv)
{
  sonar_test_init_gst (&argc, &argv);
  g_test_add_func ("/sonartrack/fig10", test_fig10);
  g_test_add_func ("/sonartrack/fig9", test_fig9);
  g_test_add_func ("/sonartrack/crossing", test_crossing);
  g_test_add_func ("/sonartrack/mostly-moving", test_mostly_moving);
  g_test_add_func ("/sonartrack/3d", test_3d);
  g_test_add_func ("/sonartrack/dropped-pings", test_dropped_pings);
  g_test_add_func ("/sonartrack/outputs-agree", test_outputs_agree);
  g_test_add_func ("/sonartrack/prior-event", test_prior_event);
  g_test_add_func ("/sonartrack/errors", test_errors);
  return g_test_run ();
}
