/* test-sonarviz.c: the sonarviz element's frames read back pixel by pixel
 * against the simulator's truth (each true object ringed in white, its
 * detection's ring inside in red when it approaches and green when it
 * recedes or stands still, the echo inside, the image or the background
 * elsewhere), the frames through pngenc, x264enc ! mp4mux and
 * autovideosink, caps from downstream, and the errors. */
#include <glib/gstdio.h>
#include <gst/app/gstappsink.h>
#include <gst/gst.h>
#include <math.h>
#include <string.h>

#include "sonar-contracts.h"
#include "sonar-render.h"
#include "sonar-test-gst.h"

/* The Fig. 9 world (a still sensor, four still cylinders, movers at -3 and
 * +1.8 m/s) at its -7..7 m/s bank, drawn at 960 x 540. */
#define FIG9_VIZ \
  "sonarsrc scene=fig9 num-buffers=%u ! dopplerbank ! mimobeamform " \
  "! wardcluster ! tee name=t " \
  "sonarviz name=viz width=960 height=540 %s ! %s " \
  "t. ! queue ! viz.sink t. ! queue ! velocityest ! viz.detections"

/* Enough of a bank to image Fig. 9's movers, cheaper than its own. */
#define SMALL_FIG9_BANK "velocity-min=-3.5 velocity-max=3.5 velocity-step=0.1"

/* The default scene (three objects, one approaching at 1 m/s) on a small
 * bank: the cheap chain for the sinks' tests. */
#define DEFAULT_VIZ \
  "sonarsrc num-buffers=%u ! dopplerbank velocity-min=-1.5 velocity-max=1.5 " \
  "velocity-step=0.05 ! mimobeamform ! wardcluster ! tee name=t " \
  "sonarviz name=viz width=960 height=540 %s ! %s " \
  "t. ! queue ! viz.sink t. ! queue ! velocityest ! viz.detections"

typedef struct
{
  guint8 *pixels;
  gsize stride;
  guint width, height;
  SonarTruth *truths;
  guint n_truths;
  guint n_detections;
  SonarTrack *tracks;
  guint n_tracks;
  guint64 ping;
  GstClockTime pts;
  SonarImageGrid grid;
} Frame;

static void
frame_clear (Frame * f)
{
  g_free (f->pixels);
  g_free (f->truths);
  g_free (f->tracks);
}

/* Runs @launch (ending in "appsink name=sink") and keeps its frames. */
static GArray *
pull_frames (const char *launch)
{
  GError *error = NULL;
  GstElement *pipeline = gst_parse_launch (launch, &error);
  GstElement *sink, *viz;
  GstSample *sample;
  GArray *frames = g_array_new (FALSE, TRUE, sizeof (Frame));
  GstBus *bus;
  GstMessage *msg;

  g_assert_no_error (error);
  sink = gst_bin_get_by_name (GST_BIN (pipeline), "sink");
  viz = gst_bin_get_by_name (GST_BIN (pipeline), "viz");
  g_assert_nonnull (sink);
  g_assert_nonnull (viz);
  gst_element_set_state (pipeline, GST_STATE_PLAYING);
  while ((sample = gst_app_sink_pull_sample (GST_APP_SINK (sink)))) {
    GstBuffer *buffer = gst_sample_get_buffer (sample);
    GstCaps *caps = gst_sample_get_caps (sample);
    GstPad *pad = gst_element_get_static_pad (viz, "sink");
    GstCaps *scape_caps = gst_pad_get_current_caps (pad);
    SonarTruthMeta *truth = sonar_buffer_get_truth_meta (buffer);
    SonarDetectionsMeta *dets = sonar_buffer_get_detections_meta (buffer);
    SonarTracksMeta *tracks = sonar_buffer_get_tracks_meta (buffer);
    GstStructure *s = gst_caps_get_structure (caps, 0);
    Frame f = { 0 };
    GstMapInfo map;
    guint records;
    int w, h;

    g_assert_cmpstr (gst_structure_get_string (s, "format"), ==, "RGB");
    g_assert_true (gst_structure_get_int (s, "width", &w));
    g_assert_true (gst_structure_get_int (s, "height", &h));
    f.width = (guint) w;
    f.height = (guint) h;
    /* RGB rows are padded to 4 bytes. */
    f.stride = GST_ROUND_UP_4 (f.width * 3);
    g_assert_true (gst_buffer_map (buffer, &map, GST_MAP_READ));
    g_assert_cmpuint (map.size, ==, f.stride * f.height);
    f.pixels = g_memdup2 (map.data, map.size);
    gst_buffer_unmap (buffer, &map);
    g_assert_true (sonar_energyscape_caps_parse (scape_caps, &f.grid,
            &records, NULL));
    if (truth) {
      f.truths = g_memdup2 (truth->truths, sizeof (SonarTruth) *
          truth->n_truths);
      f.n_truths = truth->n_truths;
    }
    f.n_detections = dets ? dets->n_detections : 0;
    if (tracks) {
      f.tracks = g_memdup2 (tracks->tracks, sizeof (SonarTrack) *
          tracks->n_tracks);
      f.n_tracks = tracks->n_tracks;
    }
    f.ping = GST_BUFFER_OFFSET (buffer);
    f.pts = GST_BUFFER_PTS (buffer);
    g_array_append_val (frames, f);
    gst_caps_unref (scape_caps);
    gst_object_unref (pad);
    gst_sample_unref (sample);
  }
  bus = gst_element_get_bus (pipeline);
  msg = gst_bus_pop_filtered (bus, GST_MESSAGE_ERROR);
  if (msg) {
    gst_message_parse_error (msg, &error, NULL);
    g_test_message ("error: %s", error->message);
    g_assert_no_error (error);
  }
  gst_object_unref (bus);
  gst_element_set_state (pipeline, GST_STATE_NULL);
  gst_object_unref (sink);
  gst_object_unref (viz);
  gst_object_unref (pipeline);
  return frames;
}

static void
frames_free (GArray * frames)
{
  for (guint k = 0; k < frames->len; k++)
    frame_clear (&g_array_index (frames, Frame, k));
  g_array_unref (frames);
}

static gboolean
rgb_equal (SonarRgb a, SonarRgb b)
{
  return a.r == b.r && a.g == b.g && a.b == b.b;
}

static SonarRgb
pixel (const Frame * f, double x, double y)
{
  const guint8 *p;
  SonarRgb c = { 0, 0, 0 };

  if (x < 0 || y < 0 || x >= f->width || y >= f->height)
    return c;
  p = f->pixels + (gsize) floor (y) * f->stride + (gsize) floor (x) * 3;
  c.r = p[0];
  c.g = p[1];
  c.b = p[2];
  return c;
}

/* Pixels show their nearest image cell: a colour is looked for within a
 * pixel of where it belongs. */
static gboolean
near_colour (const Frame * f, double x, double y, SonarRgb c)
{
  for (int dy = -1; dy <= 1; dy++)
    for (int dx = -1; dx <= 1; dx++)
      if (rgb_equal (pixel (f, x + dx, y + dy), c))
        return TRUE;
  return FALSE;
}

/* The colour map's level (0..1) of @c, -1 when it is no colour of the
 * map. */
static double
map_level (SonarRgb c)
{
  for (guint k = 0; k < 256; k++)
    if (rgb_equal (c, sonar_render_colour_map (k / 255.0)))
      return k / 255.0;
  return -1.0;
}

/* Counts the pixels of colour @c within @radius of (x, y). */
static guint
count_colour (const Frame * f, double x, double y, double radius, SonarRgb c)
{
  guint n = 0;

  for (int j = (int) (y - radius); j <= (int) (y + radius); j++)
    for (int i = (int) (x - radius); i <= (int) (x + radius); i++)
      if (hypot (i + 0.5 - x, j + 0.5 - y) <= radius
          && rgb_equal (pixel (f, i, j), c))
        n++;
  return n;
}

/* Every true object of @f ringed in white, its detection's ring inside in
 * the colour of its velocity, the echo inside that. */
static void
check_objects (const Frame * f, double min_echo_level)
{
  SonarRenderer *r = sonar_renderer_new (&f->grid, f->width, f->height,
      NULL);
  const double scale = sonar_renderer_scale (r);
  const double marker = SONAR_RENDER_MARKER_RADIUS * scale;
  const double ring = SONAR_RENDER_TRUTH_RADIUS * scale;

  g_assert_nonnull (r);
  for (guint k = 0; k < f->n_truths; k++) {
    const SonarTruth *t = &f->truths[k];
    /* The colour is the printed value's: -0.004 m/s prints 0.00, green. */
    const gboolean approaching = round (t->radial_velocity * 100) < 0;
    const SonarRgb expected = approaching ?
        sonar_render_approaching_colour () : sonar_render_receding_colour ();
    const SonarRgb other = approaching ?
        sonar_render_receding_colour () : sonar_render_approaching_colour ();
    double px, py, brightest = -1;

    g_assert_true (sonar_renderer_project (r, t->range, t->azimuth,
            t->elevation, &px, &py));
    g_test_message ("ping %" G_GUINT64_FORMAT ": object at %.2f m %+.0f deg "
        "%+.0f deg, %+.2f m/s, drawn at (%.0f, %.0f)", f->ping, t->range,
        t->azimuth, t->elevation, t->radial_velocity, px, py);
    g_assert_true (near_colour (f, px - marker, py, expected));
    g_assert_true (near_colour (f, px + marker, py, expected));
    g_assert_true (near_colour (f, px, py - marker, expected));
    g_assert_true (near_colour (f, px, py + marker, expected));
    g_assert_cmpuint (count_colour (f, px, py, ring, other), ==, 0);
    g_assert_true (near_colour (f, px - ring, py, sonar_render_truth_colour
            ()));
    g_assert_true (near_colour (f, px, py + ring, sonar_render_truth_colour
            ()));
    /* Inside the ring, the echo: the image near the top of its scale. */
    for (int dy = -2; dy <= 2; dy++)
      for (int dx = -2; dx <= 2; dx++)
        brightest = MAX (brightest, map_level (pixel (f, px + dx, py + dy)));
    g_test_message ("  echo level %.2f", brightest);
    g_assert_cmpfloat (brightest, >=, min_echo_level);
  }
  sonar_renderer_free (r);
}

/* The Fig. 9 world, two pings: six objects, the mover approaching at
 * -3 m/s in red, the one leaving at +1.8 m/s and the still ones in green;
 * away from the objects the image; beside the fan the background. */
static void
test_fig9 (void)
{
  char *launch = g_strdup_printf (FIG9_VIZ, 2, "",
      "appsink name=sink sync=false");
  GArray *frames = pull_frames (launch);
  guint approaching = 0;

  g_assert_cmpuint (frames->len, ==, 2);
  for (guint k = 0; k < frames->len; k++) {
    const Frame *f = &g_array_index (frames, Frame, k);
    SonarRenderer *r = sonar_renderer_new (&f->grid, f->width, f->height,
        NULL);
    guint x, y, w, h;
    double px, py;

    g_assert_cmpuint (f->width, ==, 960);
    g_assert_cmpuint (f->height, ==, 540);
    g_assert_cmpuint (f->ping, ==, k);
    g_assert_cmpuint (f->pts, ==, gst_util_uint64_scale (k, GST_SECOND, 12));
    g_assert_cmpuint (f->n_truths, ==, 6);
    g_assert_cmpuint (f->n_detections, ==, 6);
    /* Range compensation makes every object's echo as bright as another:
     * each within 10 dB of the strongest pixel (level 0.75 of 40 dB). */
    check_objects (f, 0.75);
    for (guint q = 0; q < f->n_truths; q++)
      approaching += f->truths[q].radial_velocity < -0.005;
    /* The image where nothing is: 4.5 m at 0 degrees. */
    g_assert_true (sonar_renderer_project (r, 4.5, 0.0, 0.0, &px, &py));
    g_assert_cmpfloat (map_level (pixel (f, px, py)), >=, 0.0);
    /* Beside the fan: the top corners of the plot. */
    sonar_renderer_plot_area (r, &x, &y, &w, &h);
    g_assert_true (rgb_equal (pixel (f, x + 2, y + 2),
            sonar_render_background_colour ()));
    g_assert_true (rgb_equal (pixel (f, x + w - 3, y + 2),
            sonar_render_background_colour ()));
    sonar_renderer_free (r);
  }
  /* One mover approaching per ping. */
  g_assert_cmpuint (approaching, ==, 2);
  frames_free (frames);
  g_free (launch);
}

/* Does @text appear in @c, its top-left corner within @radius pixels of
 * (cx, cy)? Its ink in @c, the paper between in another colour. */
static gboolean
find_text (const Frame * f, const char *text, guint scale, SonarRgb c,
    double cx, double cy, int radius)
{
  const guint tw = sonar_render_text_width (text, scale), th = 8 * scale;
  guint8 *ink = g_new0 (guint8, (gsize) tw * th * 3);
  const SonarRgb white = { 255, 255, 255 };
  gboolean found = FALSE;

  sonar_render_text (ink, tw * 3, tw, th, 0, 0, scale, white, text);
  for (int y0 = (int) cy - radius; !found && y0 <= (int) cy + radius; y0++)
    for (int x0 = (int) cx - radius; !found && x0 <= (int) cx + radius;
        x0++) {
      gboolean match = x0 >= 0 && y0 >= 0 && x0 + tw <= f->width
          && y0 + th <= f->height;
      for (guint j = 0; match && j < th; j++)
        for (guint i = 0; match && i < tw; i++)
          match = rgb_equal (pixel (f, x0 + i, y0 + j), c) ==
              (ink[((gsize) j * tw + i) * 3] == 255);
      found = match;
    }
  g_free (ink);
  return found;
}

/* The track of true object @t in @f: a confirmed track within 0.1 m,
 * drawn as a magenta square around it with its id beside it; for a mover
 * (@arrow_time > 0), an arrow ending where the truth's velocity (relative
 * to the still sensor: the world's) takes it in @arrow_time. */
static void
check_track (const Frame * f, SonarRenderer * r, const SonarTruth * t,
    double arrow_time)
{
  const SonarRgb magenta = sonar_render_track_colour ();
  const double half = SONAR_RENDER_TRACK_HALF_SIDE * sonar_renderer_scale
      (r);
  const double p[3] = { t->position.x, t->position.y, t->position.z };
  const double tip[3] = { p[0] + t->velocity.x * arrow_time,
    p[1] + t->velocity.y * arrow_time, p[2] + t->velocity.z * arrow_time
  };
  const SonarTrack *track = NULL;
  char label[32];
  double px, py, tx, ty, nearest = INFINITY;

  for (guint q = 0; q < f->n_tracks; q++) {
    const double d = sonar_vec3_norm (sonar_vec3_sub (f->tracks[q].position,
            t->position));
    if (f->tracks[q].state == SONAR_TRACK_CONFIRMED && d < nearest) {
      nearest = d;
      track = &f->tracks[q];
    }
  }
  g_assert_nonnull (track);
  g_assert_cmpfloat (nearest, <, 0.1);
  g_assert_true (sonar_renderer_project_position (r, p, &px, &py));
  g_test_message ("track #%" G_GUINT64_FORMAT " %.3f m from its object, "
      "drawn at (%.0f, %.0f)", track->id, nearest, px, py);
  /* Its square (to a pixel or two: the track is within centimetres). */
  g_assert_cmpuint (count_colour (f, px - half, py, 3, magenta), >, 0);
  g_assert_cmpuint (count_colour (f, px + half, py, 3, magenta), >, 0);
  sonar_render_track_label (track->id, label, sizeof label);
  g_assert_true (find_text (f, label, sonar_renderer_scale (r), magenta,
          px, py, 80));
  if (arrow_time <= 0)
    return;
  /* The arrow's tip: 0.05 m/s of velocity error is 2 cm. */
  sonar_renderer_project_position (r, tip, &tx, &ty);
  g_test_message ("  mover at %.2f m/s: tip at (%.0f, %.0f)",
      sonar_vec3_norm (t->velocity), tx, ty);
  g_assert_cmpuint (count_colour (f, tx, ty, 4, magenta), >, 0);
  g_assert_cmpfloat (hypot (tx - px, ty - py), >, 3 * half);
}

/* Tracks (sonartrack's output on the detections pad), Fig. 9 world after
 * 10 pings: each object has a confirmed track, drawn as a magenta square
 * at the object with its id beside it; each mover's arrow ends where the
 * truth's velocity takes it in arrow-time (the still sensor's relative
 * velocity is the world's). */
static void
test_tracks (void)
{
  const double arrow_time = 0.4;
  char *launch = g_strdup_printf ("sonarsrc scene=fig9 num-buffers=10 "
      "! dopplerbank " SMALL_FIG9_BANK " ! mimobeamform ! wardcluster "
      "! tee name=t sonarviz name=viz width=960 height=540 arrow-time=%g "
      "! appsink name=sink sync=false t. ! queue ! viz.sink "
      "t. ! queue ! velocityest ! sonartrack ! viz.detections", arrow_time);
  GArray *frames = pull_frames (launch);
  const Frame *f;
  SonarRenderer *r;
  guint movers = 0;

  g_assert_cmpuint (frames->len, ==, 10);
  f = &g_array_index (frames, Frame, 9);
  r = sonar_renderer_new (&f->grid, f->width, f->height, NULL);
  g_assert_cmpuint (f->n_truths, ==, 6);
  g_assert_cmpuint (f->n_tracks, >=, 6);
  for (guint k = 0; k < f->n_truths; k++) {
    const gboolean mover = sonar_vec3_norm (f->truths[k].velocity) >= 0.5;
    check_track (f, r, &f->truths[k], mover ? arrow_time : 0.0);
    movers += mover;
  }
  g_assert_cmpuint (movers, ==, 2);
  sonar_renderer_free (r);
  frames_free (frames);
  g_free (launch);
}

/* A 3-D scene: the azimuth x elevation map, each object at its
 * direction. */
static void
test_3d (void)
{
  char *scene = sonar_test_source_path ("pipelines/scenes/two-walkers-3d.json");
  char *launch = g_strdup_printf ("sonarsrc scene-file=%s num-buffers=1 "
      "! dopplerbank velocity-min=-2 velocity-max=2 velocity-step=0.02 "
      "! mimobeamform ! wardcluster ! tee name=t "
      "sonarviz name=viz width=960 height=540 ! appsink name=sink sync=false "
      "t. ! queue ! viz.sink t. ! queue ! velocityest ! viz.detections",
      scene);
  GArray *frames = pull_frames (launch);
  const Frame *f;

  g_assert_cmpuint (frames->len, ==, 1);
  f = &g_array_index (frames, Frame, 0);
  g_assert_cmpuint (f->grid.n_elevation, >, 1);
  g_assert_cmpuint (f->n_truths, ==, 4);
  g_assert_cmpuint (f->n_detections, ==, 4);
  check_objects (f, 0.75);
  frames_free (frames);
  g_free (launch);
  g_free (scene);
}

/* Tracks in 3-D: the azimuth x elevation map, each object's confirmed
 * track (3 hits confirm one) at its direction with its id; the
 * approaching walker's arrow (mostly along its line of sight) is not
 * checked: the map shows only the direction it turns to. */
static void
test_tracks_3d (void)
{
  char *scene = sonar_test_source_path ("pipelines/scenes/two-walkers-3d.json");
  char *launch = g_strdup_printf ("sonarsrc scene-file=%s num-buffers=3 "
      "! dopplerbank velocity-min=-2 velocity-max=2 velocity-step=0.02 "
      "! mimobeamform ! wardcluster ! tee name=t "
      "sonarviz name=viz width=960 height=540 ! appsink name=sink sync=false "
      "t. ! queue ! viz.sink t. ! queue ! velocityest ! sonartrack "
      "! viz.detections", scene);
  GArray *frames = pull_frames (launch);
  const Frame *f;
  SonarRenderer *r;

  g_assert_cmpuint (frames->len, ==, 3);
  f = &g_array_index (frames, Frame, 2);
  g_assert_cmpuint (f->grid.n_elevation, >, 1);
  g_assert_cmpuint (f->n_truths, ==, 4);
  r = sonar_renderer_new (&f->grid, f->width, f->height, NULL);
  g_assert_false (sonar_renderer_is_fan (r));
  for (guint k = 0; k < f->n_truths; k++)
    check_track (f, r, &f->truths[k], 0.0);
  sonar_renderer_free (r);
  frames_free (frames);
  g_free (launch);
  g_free (scene);
}

/* Without a detections pad: the images alone, the truth ringed, no
 * detection ring; show-truth=false: no ring either. */
static void
test_images_alone (void)
{
  GArray *frames = pull_frames ("sonarsrc scene=fig9 num-buffers=1 "
      "! dopplerbank " SMALL_FIG9_BANK " ! mimobeamform "
      "! sonarviz name=viz width=640 height=360 "
      "! appsink name=sink sync=false");
  const Frame *f = &g_array_index (frames, Frame, 0);
  SonarRenderer *r = sonar_renderer_new (&f->grid, f->width, f->height,
      NULL);
  const double ring = SONAR_RENDER_TRUTH_RADIUS * sonar_renderer_scale (r);
  double px, py;

  g_assert_cmpuint (f->n_detections, ==, 0);
  g_assert_cmpuint (f->n_truths, ==, 6);
  for (guint k = 0; k < f->n_truths; k++) {
    g_assert_true (sonar_renderer_project (r, f->truths[k].range,
            f->truths[k].azimuth, 0, &px, &py));
    g_assert_true (near_colour (f, px - ring, py,
            sonar_render_truth_colour ()));
    g_assert_cmpuint (count_colour (f, px, py, ring - 2,
            sonar_render_receding_colour ()), ==, 0);
    g_assert_cmpuint (count_colour (f, px, py, ring - 2,
            sonar_render_approaching_colour ()), ==, 0);
  }
  sonar_renderer_free (r);
  frames_free (frames);

  frames = pull_frames ("sonarsrc scene=fig9 num-buffers=1 ! dopplerbank "
      SMALL_FIG9_BANK " ! mimobeamform ! sonarviz name=viz width=640 "
      "height=360 show-truth=false ! appsink name=sink sync=false");
  f = &g_array_index (frames, Frame, 0);
  r = sonar_renderer_new (&f->grid, f->width, f->height, NULL);
  for (guint k = 0; k < f->n_truths; k++) {
    g_assert_true (sonar_renderer_project (r, f->truths[k].range,
            f->truths[k].azimuth, 0, &px, &py));
    g_assert_cmpuint (count_colour (f, px, py, ring + 2,
            sonar_render_truth_colour ()), ==, 0);
  }
  sonar_renderer_free (r);
  frames_free (frames);
}

/* Downstream's caps decide the size; the properties are the preference. */
static void
test_downstream_size (void)
{
  GArray *frames = pull_frames ("sonarsrc scene=default num-buffers=1 "
      "! dopplerbank velocity-min=-1.5 velocity-max=1.5 ! mimobeamform "
      "! sonarviz name=viz ! video/x-raw,width=400,height=300 "
      "! appsink name=sink sync=false");

  g_assert_cmpuint (g_array_index (frames, Frame, 0).width, ==, 400);
  g_assert_cmpuint (g_array_index (frames, Frame, 0).height, ==, 300);
  frames_free (frames);
}

/* The standard elements a frame goes to. */
static void
test_pngenc (void)
{
  char *dir = g_dir_make_tmp ("sonarviz-XXXXXX", NULL);
  char *png = g_build_filename (dir, "fig9.png", NULL);
  char *sink = g_strdup_printf ("pngenc ! filesink location=%s", png);
  char *launch = g_strdup_printf (DEFAULT_VIZ, 1, "", sink);
  char *error = sonar_test_run_pipeline (launch);
  char *decode = g_strdup_printf ("filesrc location=%s ! pngdec "
      "! video/x-raw,format=RGB,width=960,height=540 ! fakesink", png);

  g_assert_null (error);
  /* It decodes back to a 960 x 540 RGB picture. */
  error = sonar_test_run_pipeline (decode);
  g_assert_null (error);
  g_remove (png);
  g_rmdir (dir);
  g_free (decode);
  g_free (png);
  g_free (sink);
  g_free (launch);
  g_free (dir);
}

static void
test_mp4 (void)
{
  GstElementFactory *x264 = gst_element_factory_find ("x264enc");
  char *dir, *launch, *sink_text, *mp4, *error, *demux;
  GstElement *pipeline, *sink;
  GstSample *sample;
  guint frames = 0;

  if (!x264) {
    g_test_skip ("x264enc is missing (Debian: gstreamer1.0-plugins-ugly, "
        "which tools/setup installs)");
    return;
  }
  gst_object_unref (x264);
  dir = g_dir_make_tmp ("sonarviz-XXXXXX", NULL);
  mp4 = g_build_filename (dir, "fig9.mp4", NULL);
  sink_text = g_strdup_printf ("videoconvert ! video/x-raw,format=I420 "
      "! x264enc ! mp4mux ! filesink location=%s", mp4);
  launch = g_strdup_printf (DEFAULT_VIZ, 3, "", sink_text);
  error = sonar_test_run_pipeline (launch);
  g_assert_null (error);
  /* Three H.264 frames at the ping rate come back out of the file. */
  demux = g_strdup_printf ("filesrc location=%s ! qtdemux "
      "! video/x-h264,width=960,height=540,framerate=12/1 "
      "! appsink name=sink sync=false", mp4);
  pipeline = gst_parse_launch (demux, NULL);
  sink = gst_bin_get_by_name (GST_BIN (pipeline), "sink");
  gst_element_set_state (pipeline, GST_STATE_PLAYING);
  while ((sample = gst_app_sink_pull_sample (GST_APP_SINK (sink)))) {
    frames++;
    gst_sample_unref (sample);
  }
  gst_element_set_state (pipeline, GST_STATE_NULL);
  g_assert_cmpuint (frames, ==, 3);
  gst_object_unref (sink);
  gst_object_unref (pipeline);
  g_remove (mp4);
  g_rmdir (dir);
  g_free (demux);
  g_free (sink_text);
  g_free (launch);
  g_free (mp4);
  g_free (dir);
}

/* autovideosink: a window where there is a display; headless, GStreamer
 * falls back to a fake video sink, and the stream still links and plays
 * to its end. */
static void
test_autovideosink (void)
{
  char *launch = g_strdup_printf (DEFAULT_VIZ, 1, "",
      "videoconvert ! autovideosink sync=false");
  char *error = sonar_test_run_pipeline (launch);

  g_assert_null (error);
  g_free (launch);
}

static void
test_errors (void)
{
  char *error;

  /* Downstream wants another frame rate than the pings' 12 Hz. */
  error = sonar_test_run_pipeline ("sonarsrc num-buffers=1 ! dopplerbank "
      "velocity-min=-1 velocity-max=1 ! mimobeamform ! sonarviz "
      "! video/x-raw,framerate=30/1 ! fakesink");
  g_assert_nonnull (error);
  g_test_message ("%s", error);
  g_assert_nonnull (strstr (error, "sonarviz: downstream takes none of "
          "video/x-raw"));
  g_assert_nonnull (strstr (error, "videorate the frame rate"));
  g_free (error);

  /* Text without velocityest's meta on the detections pad. */
  error = sonar_test_run_pipeline ("sonarsrc num-buffers=1 ! dopplerbank "
      "velocity-min=-1 velocity-max=1 ! mimobeamform ! sonarviz name=viz "
      "! fakesink  fakesrc num-buffers=1 sizetype=fixed sizemax=4 "
      "! text/x-raw,format=utf8 ! viz.detections");
  g_assert_nonnull (error);
  g_test_message ("%s", error);
  g_assert_nonnull (strstr (error, "sonarviz: the detections pad takes "
          "velocityest's output"));
  g_free (error);
}

/* A new size set while playing is negotiated before a later frame. */
static void
test_resize_while_playing (void)
{
  GstElement *pipeline = gst_parse_launch ("sonarsrc num-buffers=6 "
      "! dopplerbank velocity-min=-1 velocity-max=1 ! mimobeamform "
      "! sonarviz name=viz width=640 height=360 "
      "! appsink name=sink sync=false max-buffers=1", NULL);
  GstElement *viz = gst_bin_get_by_name (GST_BIN (pipeline), "viz");
  GstElement *sink = gst_bin_get_by_name (GST_BIN (pipeline), "sink");
  GstSample *sample;
  guint frames = 0;
  int width = 0, height = 0;

  gst_element_set_state (pipeline, GST_STATE_PLAYING);
  while ((sample = gst_app_sink_pull_sample (GST_APP_SINK (sink)))) {
    GstStructure *s = gst_caps_get_structure (gst_sample_get_caps (sample),
        0);
    GstMapInfo map;

    gst_structure_get_int (s, "width", &width);
    gst_structure_get_int (s, "height", &height);
    gst_buffer_map (gst_sample_get_buffer (sample), &map, GST_MAP_READ);
    g_assert_cmpuint (map.size, ==, GST_ROUND_UP_4 (width * 3) * height);
    gst_buffer_unmap (gst_sample_get_buffer (sample), &map);
    if (frames++ == 0) {
      g_assert_cmpint (width, ==, 640);
      g_object_set (viz, "width", 800, "height", 450, NULL);
    }
    gst_sample_unref (sample);
  }
  g_assert_cmpuint (frames, ==, 6);
  g_assert_cmpint (width, ==, 800);
  g_assert_cmpint (height, ==, 450);
  gst_element_set_state (pipeline, GST_STATE_NULL);
  gst_object_unref (viz);
  gst_object_unref (sink);
  gst_object_unref (pipeline);
}

/* Display settings change while playing (GST_PARAM_MUTABLE_PLAYING). */
static void
test_properties (void)
{
  GstElement *viz = gst_element_factory_make ("sonarviz", NULL);
  const char *mutable[] = { "width", "height", "dynamic-range",
    "range-compensation", "show-truth", "show-rejected", "show-tracks",
    "arrow-time"
  };

  g_assert_nonnull (viz);
  for (guint k = 0; k < G_N_ELEMENTS (mutable); k++) {
    GParamSpec *p = g_object_class_find_property (G_OBJECT_GET_CLASS (viz),
        mutable[k]);
    g_assert_nonnull (p);
    g_assert_true (p->flags & GST_PARAM_MUTABLE_PLAYING);
  }
  gst_object_unref (viz);
}

int
main (int argc, char **argv)
{
  sonar_test_init_gst (&argc, &argv);
  g_test_add_func ("/sonarviz/fig9", test_fig9);
  g_test_add_func ("/sonarviz/3d", test_3d);
  g_test_add_func ("/sonarviz/tracks", test_tracks);
  g_test_add_func ("/sonarviz/tracks-3d", test_tracks_3d);
  g_test_add_func ("/sonarviz/images-alone", test_images_alone);
  g_test_add_func ("/sonarviz/downstream-size", test_downstream_size);
  g_test_add_func ("/sonarviz/pngenc", test_pngenc);
  g_test_add_func ("/sonarviz/mp4", test_mp4);
  g_test_add_func ("/sonarviz/autovideosink", test_autovideosink);
  g_test_add_func ("/sonarviz/errors", test_errors);
  g_test_add_func ("/sonarviz/resize-while-playing",
      test_resize_while_playing);
  g_test_add_func ("/sonarviz/properties", test_properties);
  return g_test_run ();
}
