/* test-render.c: the pictures of sonar-render.h, read back pixel by pixel:
 * images where their echoes are, marks in their colours at their
 * positions, the fan in metres with equal scales, the 3-D map with
 * elevation up, velocity labels that never say "-0.00" in red. */
#include <gio/gio.h>
#include <math.h>
#include <string.h>

#include "sonar-render.h"

#define W 960
#define H 540

static gboolean
rgb_equal (SonarRgb a, SonarRgb b)
{
  return a.r == b.r && a.g == b.g && a.b == b.b;
}

static SonarRgb
pixel_at (const guint8 * pixels, gsize stride, double px, double py)
{
  const guint8 *p = pixels + (gsize) floor (py) * stride +
      (gsize) floor (px) * 3;
  SonarRgb c = { p[0], p[1], p[2] };
  return c;
}

/* Is @c within a pixel of (px, py)? Pixels show their nearest image
 * cell, whose centre may lie in the neighbouring pixel. */
static gboolean
near_colour (const guint8 * pixels, gsize stride, double px, double py,
    SonarRgb c)
{
  for (int dy = -1; dy <= 1; dy++)
    for (int dx = -1; dx <= 1; dx++)
      if (rgb_equal (pixel_at (pixels, stride, px + dx, py + dy), c))
        return TRUE;
  return FALSE;
}

/* Is @c one of the colour map's colours (as the renderer quantises it)? */
static gboolean
in_colour_map (SonarRgb c)
{
  for (guint k = 0; k < 256; k++)
    if (rgb_equal (c, sonar_render_colour_map (k / 255.0)))
      return TRUE;
  return FALSE;
}

/* The 2-D fan of mimobeamform's defaults for a 5 m window. */
static SonarImageGrid
fan_grid (void)
{
  SonarImageGrid g = {
    .n_azimuth = 181,.azimuth_first = -90,.azimuth_step = 1,
    .n_elevation = 1,.elevation_first = 0,.elevation_step = 0,
    .n_range = 1200,.range_first = 0.2,.range_step = 0.004,
  };
  return g;
}

/* An image with unit echoes one range cell long at the given directions
 * and ranges, and a faint floor (1e-4, -80 dB) elsewhere. */
static float *
image_with_echoes (const SonarImageGrid * g, const double (*echoes)[3],
    guint n)
{
  float *image = g_new (float, sonar_image_grid_size (g));

  for (gsize k = 0; k < sonar_image_grid_size (g); k++)
    image[k] = 1e-4f;
  for (guint q = 0; q < n; q++) {
    const double az = echoes[q][0], el = echoes[q][1], r = echoes[q][2];
    const guint a = (guint) lround ((az - g->azimuth_first) /
        (g->azimuth_step ? g->azimuth_step : 1));
    const guint e = g->n_elevation == 1 ? 0 :
        (guint) lround ((el - g->elevation_first) / g->elevation_step);
    const guint i = (guint) lround ((r - g->range_first) / g->range_step);
    image[((gsize) e * g->n_azimuth + a) * g->n_range + i] = 1.0f;
  }
  return image;
}

static void
test_velocity_labels (void)
{
  const struct
  {
    double v;
    const char *text;
    gboolean red;
  } cases[] = {
    {-2.98, "-2.98 m/s", TRUE},
    {1.8, "+1.80 m/s", FALSE},
    {0.0, "0.00 m/s", FALSE},
    {-0.0, "0.00 m/s", FALSE},
    /* Approaching, but it prints as zero: green, and no minus sign. */
    {-0.004, "0.00 m/s", FALSE},
    {-0.0049, "0.00 m/s", FALSE},
    {0.004, "0.00 m/s", FALSE},
    {-0.006, "-0.01 m/s", TRUE},
    {0.006, "+0.01 m/s", FALSE},
  };
  char text[32];

  for (guint k = 0; k < G_N_ELEMENTS (cases); k++) {
    SonarRgb c = sonar_render_velocity_label (cases[k].v, text, sizeof text);
    g_assert_cmpstr (text, ==, cases[k].text);
    g_assert_true (rgb_equal (c, cases[k].red ?
            sonar_render_approaching_colour () :
            sonar_render_receding_colour ()));
    /* Red always prints a minus sign, green never does. */
    g_assert_true ((text[0] == '-') == cases[k].red);
  }
  sonar_render_velocity_label (NAN, text, sizeof text);
  g_assert_cmpstr (text, ==, "? m/s");
}

/* No mark can be mistaken for the image, nor the image for the frame's
 * background. */
static void
test_mark_colours (void)
{
  const SonarRgb marks[] = {
    sonar_render_approaching_colour (), sonar_render_receding_colour (),
    sonar_render_truth_colour (), sonar_render_background_colour (),
    sonar_render_rejected_colour (), sonar_render_track_colour (),
  };

  for (guint k = 0; k < G_N_ELEMENTS (marks); k++) {
    g_assert_false (in_colour_map (marks[k]));
    for (guint q = 0; q < k; q++)
      g_assert_false (rgb_equal (marks[k], marks[q]));
  }
  /* The map's ends are viridis' ends. */
  g_assert_true (rgb_equal (sonar_render_colour_map (0.0),
          (SonarRgb) {68, 1, 84}));
  g_assert_true (rgb_equal (sonar_render_colour_map (1.0),
          (SonarRgb) {253, 231, 37}));
}

/* The fan: x = r sin(az) to the right, z = r cos(az) up the frame, in
 * metres, the same pixels per metre along both. */
static void
test_fan_projection (void)
{
  SonarImageGrid g = fan_grid ();
  SonarRenderer *r = sonar_renderer_new (&g, W, H, NULL);
  double x0, y0, x1, y1, x2, y2, xl, yl, xr, yr;
  guint px, py, pw, ph;

  g_assert_nonnull (r);
  g_assert_true (sonar_renderer_is_fan (r));
  g_assert_true (sonar_renderer_project (r, 1.0, 0.0, 0.0, &x0, &y0));
  g_assert_true (sonar_renderer_project (r, 2.0, 0.0, 0.0, &x1, &y1));
  g_assert_true (sonar_renderer_project (r, 1.0, 90.0, 0.0, &x2, &y2));
  g_assert_true (sonar_renderer_project (r, 2.0, -30.0, 0.0, &xl, &yl));
  g_assert_true (sonar_renderer_project (r, 2.0, 30.0, 0.0, &xr, &yr));
  /* Forward is up, right is right. */
  g_assert_cmpfloat (fabs (x1 - x0), <, 1e-9);
  g_assert_cmpfloat (y1, <, y0 - 10);
  g_assert_cmpfloat (xr, >, xl);
  g_assert_cmpfloat (fabs (yr - yl), <, 1e-9);
  g_assert_cmpfloat (fabs ((xr + xl) / 2 - x0), <, 1e-9);
  /* One metre forward is as many pixels as one metre to the side. */
  g_assert_cmpfloat (fabs ((y0 - y1) - (x2 - x0)), <, 1e-9);
  g_assert_cmpfloat (fabs ((y2 - y0) - (y0 - y1)), <, 1e-9);
  /* x = 2 sin(30 deg) = 1 m. */
  g_assert_cmpfloat (fabs ((xr - x0) - (x2 - x0)), <, 1e-6);
  /* The fan to its cells' edges (-90.5..90.5 degrees, so a little
   * below z = 0) is twice as wide as high, less that bit, and fills the
   * frame's height or the width the margins leave. */
  sonar_renderer_plot_area (r, &px, &py, &pw, &ph);
  g_assert_cmpfloat (fabs ((double) pw / ph - 2.0 / (1.0 + sin (0.5 *
                  M_PI / 180))), <, 0.01);
  g_assert_cmpuint (ph, >, H / 2);
  /* Beyond the window nothing is drawn. */
  g_assert_false (sonar_renderer_project (r, 6.0, 0.0, 0.0, &x0, &y0));
  sonar_renderer_free (r);
}

/* The image where its echoes are: a one-cell echo (4 mm of range, less
 * than a pixel) at the top of the colour map, nothing at the floor, the
 * frame's background outside the fan. */
static void
test_fan_image (void)
{
  SonarImageGrid g = fan_grid ();
  const double echoes[][3] = { {30.0, 0, 2.0}, {-60.0, 0, 4.1} };
  float *image = image_with_echoes (&g, echoes, G_N_ELEMENTS (echoes));
  SonarRenderer *r = sonar_renderer_new (&g, W, H, NULL);
  SonarRenderFrame f = {
    .image = image,.records = 1,.dynamic_range = 40.0,.ping = 3,
    .time = 0.25,
  };
  guint8 *pixels = g_new (guint8, (gsize) W * H * 3);
  double px, py;

  sonar_renderer_draw (r, &f, pixels, (gsize) W * 3);
  for (guint q = 0; q < G_N_ELEMENTS (echoes); q++) {
    g_assert_true (sonar_renderer_project (r, echoes[q][2], echoes[q][0], 0,
            &px, &py));
    g_assert_true (near_colour (pixels, W * 3, px, py,
            sonar_render_colour_map (1.0)));
  }
  /* Where nothing echoes: -80 dB, under the 40 dB shown. */
  g_assert_true (sonar_renderer_project (r, 3.0, -20.0, 0, &px, &py));
  g_assert_true (rgb_equal (pixel_at (pixels, W * 3, px, py),
          sonar_render_colour_map (0.0)));
  /* Beside the fan (behind the array's sides, low corners). */
  {
    guint x, y, w, h;
    sonar_renderer_plot_area (r, &x, &y, &w, &h);
    g_assert_true (rgb_equal (pixel_at (pixels, W * 3, x + 1, y + 1),
            sonar_render_background_colour ()));
  }
  /* Range compensation: the far echo is 12.6 dB (4.1^2 / 2^2) stronger,
   * so the near one drops below the top of the map. */
  f.range_compensation = TRUE;
  sonar_renderer_draw (r, &f, pixels, (gsize) W * 3);
  g_assert_true (sonar_renderer_project (r, 2.0, 30.0, 0, &px, &py));
  /* (The map is drawn in 256 steps.) */
  g_assert_true (near_colour (pixels, W * 3, px, py,
          sonar_render_colour_map (round (255 * (1.0 - 20 * log10 (4.1 *
                          4.1 / 4.0) / 40.0)) / 255)));
  g_free (pixels);
  g_free (image);
  sonar_renderer_free (r);
}

/* Marks at their positions: around each true object, its detection's
 * ring in its velocity's colour (red approaching, green receding or
 * still) and the truth's white ring; inside, the echo itself. */
static void
test_marks (void)
{
  SonarImageGrid g = fan_grid ();
  const double echoes[][3] = { {30.0, 0, 2.0}, {-40.0, 0, 3.0},
  {10.0, 0, 1.0}
  };
  float *image = image_with_echoes (&g, echoes, G_N_ELEMENTS (echoes));
  SonarRenderer *r = sonar_renderer_new (&g, W, H, NULL);
  const SonarRenderPoint truths[] = {
    {2.0, 30.0, 0, -1.0}, {3.0, -40.0, 0, 0.5}, {1.0, 10.0, 0, -0.003},
  };
  const SonarRenderPoint detections[] = {
    {2.002, 30.05, 0, -1.01}, {2.998, -40.0, 0, 0.49},
    {1.0, 10.0, 0, -0.003},
  };
  SonarRenderFrame f = {
    .image = image,.records = 1,.dynamic_range = 40.0,.ping = -1,
    .time = NAN,.truths = truths,.n_truths = 3,.detections = detections,
    .n_detections = 3,
  };
  const SonarRgb expected[] = {
    sonar_render_approaching_colour (), sonar_render_receding_colour (),
    sonar_render_receding_colour (),
  };
  guint8 *pixels = g_new (guint8, (gsize) W * H * 3);
  const double marker = SONAR_RENDER_MARKER_RADIUS *
      sonar_renderer_scale (r);
  const double ring = SONAR_RENDER_TRUTH_RADIUS * sonar_renderer_scale (r);
  double px, py;

  sonar_renderer_draw (r, &f, pixels, (gsize) W * 3);
  for (guint q = 0; q < 3; q++) {
    g_assert_true (sonar_renderer_project (r, truths[q].range,
            truths[q].azimuth, 0, &px, &py));
    g_assert_true (near_colour (pixels, W * 3, px, py,
            sonar_render_colour_map (1.0)));
    g_assert_true (near_colour (pixels, W * 3, px - marker, py,
            expected[q]));
    g_assert_true (near_colour (pixels, W * 3, px + marker, py,
            expected[q]));
    g_assert_true (near_colour (pixels, W * 3, px, py - marker,
            expected[q]));
    g_assert_true (near_colour (pixels, W * 3, px, py + marker,
            expected[q]));
    g_assert_true (near_colour (pixels, W * 3, px - ring, py,
            sonar_render_truth_colour ()));
    g_assert_true (near_colour (pixels, W * 3, px, py + ring,
            sonar_render_truth_colour ()));
  }
  /* Away from every mark: the image. */
  g_assert_true (sonar_renderer_project (r, 4.0, 0.0, 0, &px, &py));
  g_assert_true (in_colour_map (pixel_at (pixels, W * 3, px, py)));

  /* A rejected detection is grey, whatever its velocity. */
  {
    const SonarRenderPoint rejected = { 4.0, 0.0, 0, -2.0, TRUE };
    f.detections = &rejected;
    f.n_detections = 1;
    sonar_renderer_draw (r, &f, pixels, (gsize) W * 3);
    g_assert_true (near_colour (pixels, W * 3, px - marker, py,
            sonar_render_rejected_colour ()));
    g_assert_false (in_colour_map (sonar_render_rejected_colour ()));
  }
  g_free (pixels);
  g_free (image);
  sonar_renderer_free (r);
}

/* Does @text appear in @c at scale @scale, its top-left corner within
 * @radius pixels of (cx, cy)? Its ink in @c, the paper between in
 * another colour. */
static gboolean
find_text (const guint8 * pixels, gsize stride, guint width, guint height,
    const char *text, guint scale, SonarRgb c, double cx, double cy,
    int radius)
{
  const guint tw = sonar_render_text_width (text, scale), th = 8 * scale;
  guint8 *ink = g_new0 (guint8, (gsize) tw * th * 3);
  const SonarRgb white = { 255, 255, 255 };
  gboolean found = FALSE;

  sonar_render_text (ink, tw * 3, tw, th, 0, 0, scale, white, text);
  for (int y0 = (int) cy - radius; !found && y0 <= (int) cy + radius; y0++)
    for (int x0 = (int) cx - radius; !found && x0 <= (int) cx + radius;
        x0++) {
      gboolean match = x0 >= 0 && y0 >= 0 && x0 + tw <= width
          && y0 + th <= height;
      for (guint j = 0; match && j < th; j++)
        for (guint i = 0; match && i < tw; i++) {
          const gboolean is_ink = ink[((gsize) j * tw + i) * 3] == 255;
          match = rgb_equal (pixel_at (pixels, stride, x0 + i, y0 + j), c)
              == is_ink;
        }
      found = match;
    }
  g_free (ink);
  return found;
}

/* Tracks: a magenta square at the track's position, its id beside it, an
 * arrow to where it goes in arrow_time seconds (in the fan, metres; in
 * the map, the direction it turns to); a still track has no arrow. */
static void
test_tracks (void)
{
  SonarImageGrid g = fan_grid ();
  SonarRenderer *r = sonar_renderer_new (&g, W, H, NULL);
  const SonarRgb magenta = sonar_render_track_colour ();
  const SonarRenderTrack tracks[] = {
    {7, {1.0, 0.0, 2.0}, {1.0, 0.0, -1.0}},
    {12, {-1.5, 0.0, 3.0}, {0.0, 0.0, 0.0}},
  };
  SonarRenderFrame f = {
    .records = 1,.dynamic_range = 40.0,.ping = 4,.time = NAN,
    .tracks = tracks,.n_tracks = 2,.arrow_time = 0.5,
  };
  guint8 *pixels = g_new (guint8, (gsize) W * H * 3);
  const double s = sonar_renderer_scale (r);
  const double half = SONAR_RENDER_TRACK_HALF_SIDE * s;
  const double tip_half[3] = { 1.5, 0.0, 1.5 }, tip_one[3] = { 2.0, 0.0,
    1.0
  }, mid[3] = { 1.25, 0.0, 1.75 };
  double px, py, x, y;

  g_assert_false (in_colour_map (magenta));
  sonar_renderer_draw (r, &f, pixels, (gsize) W * 3);
  for (guint k = 0; k < 2; k++) {
    g_assert_true (sonar_renderer_project_position (r, tracks[k].position,
            &px, &py));
    /* The square's four sides; the track's own pixel is the image's. */
    g_assert_true (near_colour (pixels, W * 3, px - half, py, magenta));
    g_assert_true (near_colour (pixels, W * 3, px + half, py, magenta));
    g_assert_true (near_colour (pixels, W * 3, px, py - half, magenta));
    g_assert_true (near_colour (pixels, W * 3, px, py + half, magenta));
    g_assert_false (near_colour (pixels, W * 3, px, py, magenta));
    /* The id beside it, and no other. */
    g_assert_true (find_text (pixels, W * 3, W, H, k ? "#12" : "#7", s,
            magenta, px, py, 60));
    g_assert_false (find_text (pixels, W * 3, W, H, k ? "#13" : "#8", s,
            magenta, px, py, 60));
  }
  /* Track 7's arrow: 0.5 s at (1, 0, -1) m/s ends 0.5 m right, 0.5 m
   * nearer; halfway the shaft; the way to 1 s is not drawn. */
  g_assert_true (sonar_renderer_project_position (r, tip_half, &x, &y));
  g_assert_true (near_colour (pixels, W * 3, x, y, magenta));
  g_assert_true (sonar_renderer_project_position (r, mid, &x, &y));
  g_assert_true (near_colour (pixels, W * 3, x, y, magenta));
  g_assert_true (sonar_renderer_project_position (r, tip_one, &x, &y));
  g_assert_false (near_colour (pixels, W * 3, x, y, magenta));
  /* Twice the time, twice the arrow. */
  f.arrow_time = 1.0;
  sonar_renderer_draw (r, &f, pixels, (gsize) W * 3);
  g_assert_true (near_colour (pixels, W * 3, x, y, magenta));
  /* The still track: nothing magenta outside its square but its label. */
  {
    guint magenta_below = 0;
    g_assert_true (sonar_renderer_project_position (r, tracks[1].position,
            &px, &py));
    /* Its label is placed to the right; left, above and below are
     * clear. */
    for (int d = (int) half + 3; d < 60; d++)
      magenta_below += rgb_equal (pixel_at (pixels, W * 3, px, py + d),
          magenta) + rgb_equal (pixel_at (pixels, W * 3, px - d, py),
          magenta);
    g_assert_cmpuint (magenta_below, ==, 0);
  }
  sonar_renderer_free (r);

  /* The map: a track at 20 degrees moving to +x turns right (azimuth
   * grows), one moving along its line of sight has no arrow. */
  {
    SonarImageGrid m = {
      .n_azimuth = 91,.azimuth_first = -90,.azimuth_step = 2,
      .n_elevation = 91,.elevation_first = -90,.elevation_step = 2,
      .n_range = 300,.range_first = 0.3,.range_step = 0.01,
    };
    const double az = 20.0 * M_PI / 180, el = -10.0 * M_PI / 180;
    const double u[3] = { cos (el) * sin (az), sin (el), cos (el) * cos (az) };
    SonarRenderTrack map_tracks[2] = {
      {3, {1.5 * u[0], 1.5 * u[1], 1.5 * u[2]}, {1.0, 0.0, 0.0}},
      {4, {2.5 * u[0] * -1, 2.5 * u[1], 2.5 * u[2]},
          {-1.0 * u[0], 1.0 * u[1], 1.0 * u[2]}},
    };
    double tip[3];

    r = sonar_renderer_new (&m, W, H, NULL);
    f.tracks = map_tracks;
    f.arrow_time = 0.5;
    sonar_renderer_draw (r, &f, pixels, (gsize) W * 3);
    g_assert_true (sonar_renderer_project_position (r,
            map_tracks[0].position, &px, &py));
    g_assert_true (near_colour (pixels, W * 3, px + half, py, magenta));
    g_assert_true (find_text (pixels, W * 3, W, H, "#3", s, magenta, px,
            py, 60));
    for (guint i = 0; i < 3; i++)
      tip[i] = map_tracks[0].position[i] + 0.5 * map_tracks[0].velocity[i];
    g_assert_true (sonar_renderer_project_position (r, tip, &x, &y));
    /* 0.5 m across at 1.5 m: about 18 degrees to the right. */
    g_assert_cmpfloat (x - px, >, 30);
    g_assert_true (near_colour (pixels, W * 3, x, y, magenta));
    /* Track 4 moves away along its line of sight: no arrow below or
     * left of its square (its label goes right). */
    g_assert_true (sonar_renderer_project_position (r,
            map_tracks[1].position, &px, &py));
    g_assert_true (near_colour (pixels, W * 3, px - half, py, magenta));
    for (int d = (int) half + 3; d < 40; d++) {
      g_assert_false (rgb_equal (pixel_at (pixels, W * 3, px - d, py),
              magenta));
      g_assert_false (rgb_equal (pixel_at (pixels, W * 3, px, py + d),
              magenta));
    }
    sonar_renderer_free (r);
  }
  g_free (pixels);
}

/* 3-D: azimuth x elevation, elevation up, the maximum over range. */
static void
test_map (void)
{
  SonarImageGrid g = {
    .n_azimuth = 91,.azimuth_first = -90,.azimuth_step = 2,
    .n_elevation = 91,.elevation_first = -90,.elevation_step = 2,
    .n_range = 300,.range_first = 0.3,.range_step = 0.01,
  };
  const double echoes[][3] = { {20.0, -10.0, 1.5}, {-40.0, 30.0, 2.9} };
  float *image = image_with_echoes (&g, echoes, G_N_ELEMENTS (echoes));
  SonarRenderer *r = sonar_renderer_new (&g, W, H, NULL);
  const SonarRenderPoint detections[] = { {1.5, 20.0, -10.0, -0.5} };
  SonarRenderFrame f = {
    .image = image,.records = 1,.dynamic_range = 30.0,.ping = 0,
    .time = 0.0,.detections = detections,.n_detections = 1,
  };
  guint8 *pixels = g_new (guint8, (gsize) W * H * 3);
  double px, py, ux, uy, dx, dy;

  g_assert_false (sonar_renderer_is_fan (r));
  sonar_renderer_draw (r, &f, pixels, (gsize) W * 3);
  g_assert_true (sonar_renderer_project (r, 1.5, 20.0, -10.0, &px, &py));
  g_assert_true (near_colour (pixels, W * 3, px, py,
          sonar_render_colour_map (1.0)));
  g_assert_true (near_colour (pixels, W * 3, px, py -
          SONAR_RENDER_MARKER_RADIUS * sonar_renderer_scale (r),
          sonar_render_approaching_colour ()));
  g_assert_true (sonar_renderer_project (r, 2.9, -40.0, 30.0, &px, &py));
  g_assert_true (near_colour (pixels, W * 3, px, py,
          sonar_render_colour_map (1.0)));
  /* Up is up, and a degree is a degree both ways. */
  g_assert_true (sonar_renderer_project (r, 1, 0.0, 10.0, &ux, &uy));
  g_assert_true (sonar_renderer_project (r, 1, 0.0, -10.0, &dx, &dy));
  g_assert_cmpfloat (uy, <, dy);
  g_assert_true (sonar_renderer_project (r, 1, 20.0, -10.0, &px, &py));
  g_assert_cmpfloat (fabs ((px - dx) - (dy - uy)), <, 1e-9);
  g_free (pixels);
  g_free (image);
  sonar_renderer_free (r);
}

/* The font: a minus sign is 5 pixels of ink, at scale 2 twenty; text is
 * clipped at the frame's edge. */
static void
test_text (void)
{
  guint8 *pixels = g_new0 (guint8, 40 * 20 * 3);
  const SonarRgb white = { 255, 255, 255 };
  guint ink = 0;

  g_assert_cmpuint (sonar_render_text_width ("-1.5", 1), ==, 23);
  sonar_render_text (pixels, 40 * 3, 40, 20, 0, 0, 1, white, "-");
  for (guint k = 0; k < 40 * 20 * 3; k += 3)
    ink += pixels[k] == 255;
  g_assert_cmpuint (ink, ==, 5);
  memset (pixels, 0, 40 * 20 * 3);
  ink = 0;
  sonar_render_text (pixels, 40 * 3, 40, 20, 0, 0, 2, white, "-");
  for (guint k = 0; k < 40 * 20 * 3; k += 3)
    ink += pixels[k] == 255;
  g_assert_cmpuint (ink, ==, 20);
  /* Far outside: nothing drawn, nothing overrun. */
  sonar_render_text (pixels, 40 * 3, 40, 20, 35, 15, 3, white, "8888");
  sonar_render_text (pixels, 40 * 3, 40, 20, -100, -100, 3, white, "8");
  g_free (pixels);
}

/* The title counts the ping's detections, or says they never came. */
static void
test_title (void)
{
  SonarImageGrid g = fan_grid ();
  SonarRenderer *r = sonar_renderer_new (&g, W, H, NULL);
  const SonarRgb text = { 225, 225, 225 };
  SonarRenderFrame f = {
    .records = 1,.dynamic_range = 40.0,.ping = 4,.time = NAN,
  };
  guint8 *pixels = g_new (guint8, (gsize) W * H * 3);
  const guint s = (guint) sonar_renderer_scale (r);

  sonar_renderer_draw (r, &f, pixels, (gsize) W * 3);
  g_assert_true (find_text (pixels, W * 3, W, H, "ping 4  0 detections", s,
          text, 4 * s, 4 * s, 0));
  f.detections_missing = TRUE;
  sonar_renderer_draw (r, &f, pixels, (gsize) W * 3);
  g_assert_true (find_text (pixels, W * 3, W, H,
          "ping 4  detections missing", s, text, 4 * s, 4 * s, 0));
  g_free (pixels);
  sonar_renderer_free (r);
}

static void
test_errors (void)
{
  SonarImageGrid g = fan_grid ();
  GError *error = NULL;

  g_assert_null (sonar_renderer_new (&g, 100, H, &error));
  g_assert_cmpstr (error->message, ==, "a frame of 100 x 540 pixels: width "
      "and height must be 160 to 8192");
  g_clear_error (&error);
  g.n_range = 0;
  g_assert_null (sonar_renderer_new (&g, W, H, &error));
  g_assert_nonnull (strstr (error->message, "0 ranges"));
  g_clear_error (&error);
  g = fan_grid ();
  g.range_step = NAN;
  g_assert_null (sonar_renderer_new (&g, W, H, &error));
  g_clear_error (&error);
}

/* Non-finite and negative pixels, datacube records, one-cell grids: no
 * crash, a picture. */
static void
test_odd_images (void)
{
  SonarImageGrid g = fan_grid ();
  const gsize n = sonar_image_grid_size (&g);
  float *image = g_new0 (float, 3 * n);
  SonarRenderFrame f = {.records = 3,.dynamic_range = 40.0,.ping = -1,
    .time = NAN
  };
  guint8 *pixels = g_new (guint8, (gsize) W * H * 3);
  SonarRenderer *r = sonar_renderer_new (&g, W, H, NULL);
  double px, py;

  image[10] = NAN;
  image[11] = INFINITY;
  image[12] = -5;
  /* The strongest record wins: record 2 holds the echo. */
  image[2 * n + 120 * g.n_range + 450] = 1.0f;
  f.image = image;
  sonar_renderer_draw (r, &f, pixels, (gsize) W * 3);
  g_assert_true (sonar_renderer_project (r, g.range_first + 450 *
          g.range_step, -90 + 120, 0, &px, &py));
  g_assert_true (near_colour (pixels, W * 3, px, py,
          sonar_render_colour_map (1.0)));
  sonar_renderer_free (r);

  g.n_azimuth = 1;
  g.azimuth_first = 0;
  g.n_range = 1;
  r = sonar_renderer_new (&g, 160, 160, NULL);
  g_assert_nonnull (r);
  f.records = 1;
  sonar_renderer_draw (r, &f, pixels, 160 * 3);
  sonar_renderer_free (r);
  g_free (pixels);
  g_free (image);
}

int
main (int argc, char **argv)
{
  g_test_init (&argc, &argv, NULL);
  g_test_add_func ("/render/velocity-labels", test_velocity_labels);
  g_test_add_func ("/render/mark-colours", test_mark_colours);
  g_test_add_func ("/render/fan-projection", test_fan_projection);
  g_test_add_func ("/render/fan-image", test_fan_image);
  g_test_add_func ("/render/marks", test_marks);
  g_test_add_func ("/render/map", test_map);
  g_test_add_func ("/render/tracks", test_tracks);
  g_test_add_func ("/render/text", test_text);
  g_test_add_func ("/render/title", test_title);
  g_test_add_func ("/render/errors", test_errors);
  g_test_add_func ("/render/odd-images", test_odd_images);
  return g_test_run ();
}
