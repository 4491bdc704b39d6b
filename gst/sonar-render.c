/* sonar-render.c: energyscape frames for people (sonar-render.h). */
#ifdef HAVE_CONFIG_H
#include "config.h"
#endif

#include "sonar-render.h"
#include "sonar-error.h"
#include "sonar-vec3.h"
#include "sonar-velocity.h"     /* sonar_velocity_approaching () */

#include <gio/gio.h>
#include <math.h>
#include <stdio.h>
#include <string.h>

/* The font: 5 x 8 cells, rows top to bottom ('#' ink, '.' paper; spaces
 * only separate the rows for the reader). Capitals and digits stand on
 * row 6, descenders use row 7. */
#define GLYPH_W 5
#define GLYPH_H 8
#define GLYPH_ADVANCE 6

typedef struct
{
  char c;
  const char *rows;
} Glyph;

static const Glyph font[] = {
  {' ', "..... ..... ..... ..... ..... ..... ..... ....."},
  {'+', "..... ..#.. ..#.. ##### ..#.. ..#.. ..... ....."},
  {'-', "..... ..... ..... ##### ..... ..... ..... ....."},
  {'.', "..... ..... ..... ..... ..... .##.. .##.. ....."},
  {',', "..... ..... ..... ..... ..... .##.. ..#.. .#..."},
  {'/', "....# ....# ...#. ..#.. .#... #.... #.... ....."},
  {':', "..... .##.. .##.. ..... .##.. .##.. ..... ....."},
  {'(', "...#. ..#.. .#... .#... .#... ..#.. ...#. ....."},
  {')', ".#... ..#.. ...#. ...#. ...#. ..#.. .#... ....."},
  {'=', "..... ..... ##### ..... ##### ..... ..... ....."},
  {'%', "##... ##..# ...#. ..#.. .#... #..## ...## ....."},
  {'_', "..... ..... ..... ..... ..... ..... ##### ....."},
  {'?', ".###. #...# ....# ...#. ..#.. ..... ..#.. ....."},
  {'#', ".#.#. .#.#. ##### .#.#. ##### .#.#. .#.#. ....."},
  {'0', ".###. #...# #..## #.#.# ##..# #...# .###. ....."},
  {'1', "..#.. .##.. ..#.. ..#.. ..#.. ..#.. .###. ....."},
  {'2', ".###. #...# ....# ...#. ..#.. .#... ##### ....."},
  {'3', "####. ....# ....# .###. ....# ....# ####. ....."},
  {'4', "...#. ..##. .#.#. #..#. ##### ...#. ...#. ....."},
  {'5', "##### #.... ####. ....# ....# #...# .###. ....."},
  {'6', "..##. .#... #.... ####. #...# #...# .###. ....."},
  {'7', "##### ....# ...#. ..#.. .#... .#... .#... ....."},
  {'8', ".###. #...# #...# .###. #...# #...# .###. ....."},
  {'9', ".###. #...# #...# .#### ....# ...#. .##.. ....."},
  {'A', ".###. #...# #...# ##### #...# #...# #...# ....."},
  {'B', "####. #...# #...# ####. #...# #...# ####. ....."},
  {'C', ".###. #...# #.... #.... #.... #...# .###. ....."},
  {'D', "####. #...# #...# #...# #...# #...# ####. ....."},
  {'E', "##### #.... #.... ####. #.... #.... ##### ....."},
  {'F', "##### #.... #.... ####. #.... #.... #.... ....."},
  {'G', ".###. #...# #.... #.### #...# #...# .#### ....."},
  {'H', "#...# #...# #...# ##### #...# #...# #...# ....."},
  {'I', ".###. ..#.. ..#.. ..#.. ..#.. ..#.. .###. ....."},
  {'J', "..### ...#. ...#. ...#. ...#. #..#. .##.. ....."},
  {'K', "#...# #..#. #.#.. ##... #.#.. #..#. #...# ....."},
  {'L', "#.... #.... #.... #.... #.... #.... ##### ....."},
  {'M', "#...# ##.## #.#.# #.#.# #...# #...# #...# ....."},
  {'N', "#...# #...# ##..# #.#.# #..## #...# #...# ....."},
  {'O', ".###. #...# #...# #...# #...# #...# .###. ....."},
  {'P', "####. #...# #...# ####. #.... #.... #.... ....."},
  {'Q', ".###. #...# #...# #...# #.#.# #..#. .##.# ....."},
  {'R', "####. #...# #...# ####. #.#.. #..#. #...# ....."},
  {'S', ".#### #.... #.... .###. ....# ....# ####. ....."},
  {'T', "##### ..#.. ..#.. ..#.. ..#.. ..#.. ..#.. ....."},
  {'U', "#...# #...# #...# #...# #...# #...# .###. ....."},
  {'V', "#...# #...# #...# #...# #...# .#.#. ..#.. ....."},
  {'W', "#...# #...# #...# #.#.# #.#.# #.#.# .#.#. ....."},
  {'X', "#...# #...# .#.#. ..#.. .#.#. #...# #...# ....."},
  {'Y', "#...# #...# .#.#. ..#.. ..#.. ..#.. ..#.. ....."},
  {'Z', "##### ....# ...#. ..#.. .#... #.... ##### ....."},
  {'a', "..... ..... .###. ....# .#### #...# .#### ....."},
  {'b', "#.... #.... #.##. ##..# #...# #...# ####. ....."},
  {'c', "..... ..... .###. #.... #.... #...# .###. ....."},
  {'d', "....# ....# .##.# #..## #...# #...# .#### ....."},
  {'e', "..... ..... .###. #...# ##### #.... .###. ....."},
  {'f', "..##. .#..# .#... ###.. .#... .#... .#... ....."},
  {'g', "..... ..... .#### #...# #...# .#### ....# .###."},
  {'h', "#.... #.... #.##. ##..# #...# #...# #...# ....."},
  {'i', "..#.. ..... .##.. ..#.. ..#.. ..#.. .###. ....."},
  {'j', "...#. ..... ..##. ...#. ...#. ...#. #..#. .##.."},
  {'k', "#.... #.... #..#. #.#.. ##... #.#.. #..#. ....."},
  {'l', ".##.. ..#.. ..#.. ..#.. ..#.. ..#.. .###. ....."},
  {'m', "..... ..... ##.#. #.#.# #.#.# #.#.# #.#.# ....."},
  {'n', "..... ..... #.##. ##..# #...# #...# #...# ....."},
  {'o', "..... ..... .###. #...# #...# #...# .###. ....."},
  {'p', "..... ..... ####. #...# #...# ####. #.... #...."},
  {'q', "..... ..... .#### #...# #...# .#### ....# ....#"},
  {'r', "..... ..... #.##. ##..# #.... #.... #.... ....."},
  {'s', "..... ..... .###. #.... .###. ....# ####. ....."},
  {'t', ".#... .#... ###.. .#... .#... .#..# ..##. ....."},
  {'u', "..... ..... #...# #...# #...# #..## .##.# ....."},
  {'v', "..... ..... #...# #...# #...# .#.#. ..#.. ....."},
  {'w', "..... ..... #...# #...# #.#.# #.#.# .#.#. ....."},
  {'x', "..... ..... #...# .#.#. ..#.. .#.#. #...# ....."},
  {'y', "..... ..... #...# #...# #...# .#### ....# .###."},
  {'z', "..... ..... ##### ...#. ..#.. .#... ##### ....."},
};

/* An unknown character. */
static const char box_glyph[] =
    "##### #...# #...# #...# #...# #...# ##### .....";

/* viridis (matplotlib), every 8th of its 256 entries and the last: linear
 * between them it is within 2 of 255 of the full table. */
static const SonarRgb viridis[] = {
  {68, 1, 84}, {71, 13, 96}, {72, 24, 106}, {72, 35, 116}, {71, 45, 123},
  {69, 55, 129}, {66, 64, 134}, {62, 73, 137}, {59, 82, 139},
  {55, 91, 141}, {51, 99, 141}, {47, 107, 142}, {44, 114, 142},
  {41, 122, 142}, {38, 130, 142}, {35, 137, 142}, {33, 145, 140},
  {31, 152, 139}, {31, 160, 136}, {34, 167, 133}, {40, 174, 128},
  {50, 182, 122}, {63, 188, 115}, {78, 195, 107}, {94, 201, 98},
  {112, 207, 87}, {132, 212, 75}, {152, 216, 62}, {173, 220, 48},
  {194, 223, 35}, {216, 226, 25}, {236, 229, 27}, {253, 231, 37},
};

#define LUT_SIZE 256
#define OUTSIDE G_MAXUINT32

/* Marks and text: none of the marks' colours is a colour of the map
 * (tests/test-render.c checks), so a frame's pixels say what is where. */
static const SonarRgb approaching_colour = { 240, 40, 40 };
static const SonarRgb receding_colour = { 40, 235, 60 };
static const SonarRgb unknown_colour = { 160, 160, 160 };
static const SonarRgb truth_colour = { 255, 255, 255 };
static const SonarRgb background_colour = { 18, 18, 22 };
static const SonarRgb track_colour = { 255, 60, 255 };
static const SonarRgb text_colour = { 225, 225, 225 };
static const SonarRgb axis_colour = { 150, 150, 150 };
static const SonarRgb label_box_colour = { 0, 0, 0 };

typedef struct
{
  int x, y, w, h;
} Box;

struct _SonarRenderer
{
  SonarImageGrid grid;
  guint width, height, scale;
  /* The fan: one elevation (the angle is the azimuth) or, for a vertical
   * fan, one azimuth (the angle is the elevation). Else the map. */
  gboolean fan;
  gboolean fan_in_elevation;

  /* Plot area (the image's bounding box), pixels. */
  int plot_x, plot_y, plot_w, plot_h;
  /* Axis extents (fan: lateral and forward metres; map: azimuth and
   * elevation degrees) and pixels per unit; (ox, oy) is the pixel of the
   * origin of both axes. */
  double u_lo, u_hi, v_lo, v_hi;
  double k, ox, oy;

  /* What the pixels look up: the image reduced to cells of at least a
   * pixel, n_a x n_b cells (fan: angle x range; map: azimuth x
   * elevation), each the maximum of dec_a x dec_b image cells. */
  guint n_a, n_b, dec_a, dec_b;
  float *amplitude;             /* n_a x n_b, scratch of each frame */
  guint8 *levels;               /* n_a x n_b, colour map index */
  guint32 *lookup;              /* plot_w x plot_h: a cell, or OUTSIDE */
  float *range_weight;          /* n_range: r^2, for range compensation */
  GArray *taken;                /* Box: what the labels must not cover */
  SonarRgb lut[LUT_SIZE];
};

/* Helpers --------------------------------------------------------------*/

static inline double
deg2rad (double d)
{
  return d * (M_PI / 180.0);
}

static void
put_pixel (guint8 * pixels, gsize stride, guint width, guint height, int x,
    int y, SonarRgb c)
{
  guint8 *p;

  if (x < 0 || y < 0 || (guint) x >= width || (guint) y >= height)
    return;
  p = pixels + (gsize) y * stride + (gsize) x * 3;
  p[0] = c.r;
  p[1] = c.g;
  p[2] = c.b;
}

static void
fill_rect (guint8 * pixels, gsize stride, guint width, guint height, int x,
    int y, int w, int h, SonarRgb c)
{
  const int x0 = MAX (x, 0), y0 = MAX (y, 0);
  const int x1 = MIN (x + w, (int) width), y1 = MIN (y + h, (int) height);

  for (int j = y0; j < y1; j++) {
    guint8 *p = pixels + (gsize) j * stride + (gsize) x0 * 3;
    for (int i = x0; i < x1; i++, p += 3) {
      p[0] = c.r;
      p[1] = c.g;
      p[2] = c.b;
    }
  }
}

/* A disc (@thickness 0) or a ring of that thickness, centred at (cx, cy). */
static void
draw_circle (guint8 * pixels, gsize stride, guint width, guint height,
    double cx, double cy, double radius, double thickness, SonarRgb c)
{
  const double outer = thickness > 0 ? radius + thickness / 2 : radius;
  const double inner = thickness > 0 ? radius - thickness / 2 : -1.0;

  for (int j = (int) floor (cy - outer); j <= (int) ceil (cy + outer); j++)
    for (int i = (int) floor (cx - outer); i <= (int) ceil (cx + outer); i++) {
      const double d = hypot (i + 0.5 - cx, j + 0.5 - cy);
      if (d <= outer && d >= inner)
        put_pixel (pixels, stride, width, height, i, j, c);
    }
}

/* A square outline of half side @half and @thickness (inwards), centred
 * at (cx, cy). */
static void
draw_square (guint8 * pixels, gsize stride, guint width, guint height,
    double cx, double cy, double half, double thickness, SonarRgb c)
{
  const int x0 = (int) lround (cx - half), y0 = (int) lround (cy - half);
  const int side = (int) lround (2 * half) + 1;
  const int t = MAX (1, (int) lround (thickness));

  fill_rect (pixels, stride, width, height, x0, y0, side, t, c);
  fill_rect (pixels, stride, width, height, x0, y0 + side - t, side, t, c);
  fill_rect (pixels, stride, width, height, x0, y0, t, side, c);
  fill_rect (pixels, stride, width, height, x0 + side - t, y0, t, side, c);
}

/* A line @thickness wide from (x0, y0) to (x1, y1), round ends. */
static void
draw_line (guint8 * pixels, gsize stride, guint width, guint height,
    double x0, double y0, double x1, double y1, double thickness,
    SonarRgb c)
{
  const double length = hypot (x1 - x0, y1 - y0);
  const guint steps = (guint) ceil (2.0 * length);

  for (guint k = 0; k <= steps; k++) {
    const double t = steps ? (double) k / steps : 0.0;
    draw_circle (pixels, stride, width, height, x0 + t * (x1 - x0),
        y0 + t * (y1 - y0), thickness / 2, 0.0, c);
  }
}

static const char *
glyph_rows (char c)
{
  for (guint k = 0; k < G_N_ELEMENTS (font); k++)
    if (font[k].c == c)
      return font[k].rows;
  return box_glyph;
}

guint
sonar_render_text_width (const char *text, guint scale)
{
  const gsize n = strlen (text);
  return n ? (guint) (n * GLYPH_ADVANCE - 1) * scale : 0;
}

guint
sonar_render_text (guint8 * pixels, gsize stride, guint width, guint height,
    int x, int y, guint scale, SonarRgb colour, const char *text)
{
  for (const char *t = text; *t; t++) {
    const char *rows = glyph_rows (*t);
    int row = 0, col = 0;

    for (const char *r = rows; *r; r++) {
      if (*r == ' ')
        continue;
      if (*r == '#')
        fill_rect (pixels, stride, width, height,
            x + (int) ((t - text) * GLYPH_ADVANCE + col) * (int) scale,
            y + row * (int) scale, (int) scale, (int) scale, colour);
      if (++col == GLYPH_W) {
        col = 0;
        row++;
      }
    }
  }
  return sonar_render_text_width (text, scale);
}

/* Colours ----------------------------------------------------------------*/

SonarRgb
sonar_render_colour_map (double level)
{
  const guint last = G_N_ELEMENTS (viridis) - 1;
  double t, f;
  guint i;
  SonarRgb c;

  if (!(level > 0.0))
    return viridis[0];
  if (level >= 1.0)
    return viridis[last];
  t = level * last;
  i = (guint) t;
  f = t - i;
  c.r = (guint8) lround (viridis[i].r + f * (viridis[i + 1].r - viridis[i].r));
  c.g = (guint8) lround (viridis[i].g + f * (viridis[i + 1].g - viridis[i].g));
  c.b = (guint8) lround (viridis[i].b + f * (viridis[i + 1].b - viridis[i].b));
  return c;
}

SonarRgb
sonar_render_approaching_colour (void)
{
  return approaching_colour;
}

SonarRgb
sonar_render_receding_colour (void)
{
  return receding_colour;
}

SonarRgb
sonar_render_truth_colour (void)
{
  return truth_colour;
}

SonarRgb
sonar_render_rejected_colour (void)
{
  return unknown_colour;
}

SonarRgb
sonar_render_background_colour (void)
{
  return background_colour;
}

SonarRgb
sonar_render_track_colour (void)
{
  return track_colour;
}

void
sonar_render_track_label (guint64 id, char *text, gsize size)
{
  g_snprintf (text, size, "#%" G_GUINT64_FORMAT, id);
}

SonarRgb
sonar_render_velocity_label (double radial_velocity, char *text, gsize size)
{
  double shown;

  if (!isfinite (radial_velocity)) {
    g_snprintf (text, size, "? m/s");
    return unknown_colour;
  }
  /* The colour follows the printed value: what rounds to 0.00 is still. */
  shown = round (radial_velocity * 100.0) / 100.0;
  if (shown == 0.0) {
    g_snprintf (text, size, "0.00 m/s");
    return receding_colour;
  }
  g_snprintf (text, size, "%+.2f m/s", shown);
  return sonar_velocity_approaching (radial_velocity) ? approaching_colour :
      receding_colour;
}

/* Layout -----------------------------------------------------------------*/

/* A tick step of 1, 2 or 5 times a power of ten giving at most @max_ticks
 * intervals over @span. */
static double
nice_step (double span, guint max_ticks)
{
  const double raw = span / MAX (max_ticks, 1);
  const double decade = pow (10.0, floor (log10 (raw)));
  static const double mantissas[] = { 1.0, 2.0, 2.5, 5.0, 10.0 };

  for (guint k = 0; k < G_N_ELEMENTS (mantissas); k++)
    if (mantissas[k] * decade >= raw)
      return mantissas[k] * decade;
  return 10.0 * decade;
}

static void
format_tick (char *text, gsize size, double value, double step)
{
  const int decimals = step >= 1.0 ? 0 : step >= 0.1 ? 1 : 2;
  const double rounded = round (value * pow (10, decimals)) / pow (10,
      decimals);

  /* No "-0". */
  g_snprintf (text, size, "%.*f", decimals, rounded == 0.0 ? 0.0 : rounded);
}

/* Image cell edges along one axis of the grid. */
static void
axis_edges (double first, double step, guint n, double fallback, double *lo,
    double *hi)
{
  const double s = (n > 1 && step != 0.0) ? fabs (step) : fallback;
  const double last = first + step * (n - 1);

  *lo = MIN (first, last) - s / 2;
  *hi = MAX (first, last) + s / 2;
}

static gboolean
grid_is_valid (const SonarImageGrid * g)
{
  return g->n_azimuth >= 1 && g->n_elevation >= 1 && g->n_range >= 1
      && isfinite (g->azimuth_first) && isfinite (g->azimuth_step)
      && isfinite (g->elevation_first) && isfinite (g->elevation_step)
      && isfinite (g->range_first) && isfinite (g->range_step)
      && (g->n_range == 1 || g->range_step > 0.0)
      && g->range_first + g->range_step * (g->n_range - 1) > 0.0;
}

/* Pixel of a point in axis units (fan: metres, map: degrees). */
static inline void
to_pixel (const SonarRenderer * r, double u, double v, double *px,
    double *py)
{
  *px = r->ox + u * r->k;
  *py = r->oy - v * r->k;
}

/* The fan's angle of a direction, and the image's angle axis. */
static void
angle_axis (const SonarRenderer * r, double *first, double *step,
    guint * n)
{
  if (r->fan_in_elevation) {
    *first = r->grid.elevation_first;
    *step = r->grid.elevation_step;
    *n = r->grid.n_elevation;
  } else {
    *first = r->grid.azimuth_first;
    *step = r->grid.azimuth_step;
    *n = r->grid.n_azimuth;
  }
}

/* Margins around the plot, pixels, for the font scale. */
#define MARGIN_TOP(s) (28 * (int) (s))
#define MARGIN_BOTTOM(s) (30 * (int) (s))
#define MARGIN_LEFT(s) (36 * (int) (s))
#define MARGIN_RIGHT(s) (60 * (int) (s))

static void
layout (SonarRenderer * r)
{
  const guint s = r->scale;
  const double avail_w = (double) r->width - MARGIN_LEFT (s) -
      MARGIN_RIGHT (s);
  const double avail_h = (double) r->height - MARGIN_TOP (s) -
      MARGIN_BOTTOM (s);
  double w, h;

  if (r->fan) {
    double a_first, a_step, a_lo, a_hi, r_lo, r_hi;
    guint n_a;

    angle_axis (r, &a_first, &a_step, &n_a);
    axis_edges (a_first, a_step, n_a, 1.0, &a_lo, &a_hi);
    axis_edges (r->grid.range_first, r->grid.range_step, r->grid.n_range,
        MAX (r->grid.range_first, 1.0) * 0.01, &r_lo, &r_hi);
    r_lo = MAX (r_lo, 0.0);
    r->u_lo = r->v_lo = G_MAXDOUBLE;
    r->u_hi = r->v_hi = -G_MAXDOUBLE;
    /* The fan's outline: both arcs, sampled finely, and the boresight and
     * the sides where the arcs cross them. */
    for (guint k = 0; k <= 720; k++) {
      const double a = deg2rad (a_lo + (a_hi - a_lo) * k / 720.0);
      const double radii[2] = { r_lo, r_hi };
      for (guint q = 0; q < 2; q++) {
        const double u = radii[q] * sin (a), v = radii[q] * cos (a);
        r->u_lo = MIN (r->u_lo, u);
        r->u_hi = MAX (r->u_hi, u);
        r->v_lo = MIN (r->v_lo, v);
        r->v_hi = MAX (r->v_hi, v);
      }
    }
  } else {
    axis_edges (r->grid.azimuth_first, r->grid.azimuth_step,
        r->grid.n_azimuth, 1.0, &r->u_lo, &r->u_hi);
    axis_edges (r->grid.elevation_first, r->grid.elevation_step,
        r->grid.n_elevation, 1.0, &r->v_lo, &r->v_hi);
  }
  w = MAX (r->u_hi - r->u_lo, 1e-9);
  h = MAX (r->v_hi - r->v_lo, 1e-9);
  r->k = MIN (avail_w / w, avail_h / h);
  r->plot_w = MAX ((int) floor (w * r->k), 1);
  r->plot_h = MAX ((int) floor (h * r->k), 1);
  r->plot_x = MARGIN_LEFT (s) + (int) ((avail_w - r->plot_w) / 2);
  r->plot_y = MARGIN_TOP (s) + (int) ((avail_h - r->plot_h) / 2);
  r->ox = r->plot_x - r->u_lo * r->k;
  r->oy = r->plot_y + r->v_hi * r->k;
}

/* Reduces the image to cells of at least a pixel: with a range (or angle)
 * step finer than a pixel, a narrow peak could fall between two pixels'
 * samples and vanish. */
static void
plan_cells (SonarRenderer * r)
{
  const double pixel = 1.0 / r->k;      /* axis units per pixel */

  if (r->fan) {
    double a_first, a_step, r_hi, unused;
    guint n_a;
    double pixel_deg;

    angle_axis (r, &a_first, &a_step, &n_a);
    axis_edges (r->grid.range_first, r->grid.range_step, r->grid.n_range,
        1.0, &unused, &r_hi);
    /* A pixel's angle at the farthest range, where cells are widest. */
    pixel_deg = pixel / MAX (r_hi, 1e-9) * (180.0 / M_PI);
    r->dec_a = (n_a > 1 && a_step != 0.0) ?
        MAX (1, (guint) ceil (pixel_deg / fabs (a_step))) : 1;
    r->dec_b = r->grid.n_range > 1 ?
        MAX (1, (guint) ceil (pixel / r->grid.range_step)) : 1;
    r->n_a = (n_a + r->dec_a - 1) / r->dec_a;
    r->n_b = (r->grid.n_range + r->dec_b - 1) / r->dec_b;
  } else {
    r->dec_a = (r->grid.n_azimuth > 1 && r->grid.azimuth_step != 0.0) ?
        MAX (1, (guint) ceil (pixel / fabs (r->grid.azimuth_step))) : 1;
    r->dec_b = (r->grid.n_elevation > 1 && r->grid.elevation_step != 0.0) ?
        MAX (1, (guint) ceil (pixel / fabs (r->grid.elevation_step))) : 1;
    r->n_a = (r->grid.n_azimuth + r->dec_a - 1) / r->dec_a;
    r->n_b = (r->grid.n_elevation + r->dec_b - 1) / r->dec_b;
  }
}

/* The cell (of @dec image cells) holding an axis value, the image's
 * cells being @n from @first every @step; -1 outside the image's edges.
 * Pixels show their nearest image cell, as a flat-shaded plot does: no
 * blur, every cell at its own level. */
static int
cell_index (double value, double first, double step, guint n, guint dec)
{
  double i;

  if (n == 1 || step == 0.0)
    return 0;
  i = floor ((value - first) / step + 0.5);
  if (i < 0 || i > n - 1)
    return -1;
  return (int) i / (int) dec;
}

static void
plan_lookup (SonarRenderer * r)
{
  double a_first = 0, a_step = 0, a_lo = 0, a_hi = 0, r_lo, r_hi;
  guint n_a = 1;

  if (r->fan) {
    angle_axis (r, &a_first, &a_step, &n_a);
    axis_edges (a_first, a_step, n_a, 1.0, &a_lo, &a_hi);
  }
  axis_edges (r->grid.range_first, r->grid.range_step, r->grid.n_range,
      MAX (r->grid.range_first, 1.0) * 0.01, &r_lo, &r_hi);
  for (int j = 0; j < r->plot_h; j++)
    for (int i = 0; i < r->plot_w; i++) {
      const double u = (r->plot_x + i + 0.5 - r->ox) / r->k;
      const double v = (r->oy - (r->plot_y + j + 0.5)) / r->k;
      int a, b;

      if (r->fan) {
        const double range = hypot (u, v);
        const double angle = atan2 (u, v) * (180.0 / M_PI);

        a = cell_index (angle, a_first, a_step, n_a, r->dec_a);
        b = cell_index (range, r->grid.range_first, r->grid.range_step,
            r->grid.n_range, r->dec_b);
        /* A single cell along an axis covers its edges only. */
        if (angle < a_lo || angle > a_hi || range < r_lo || range > r_hi)
          a = -1;
      } else {
        a = cell_index (u, r->grid.azimuth_first, r->grid.azimuth_step,
            r->grid.n_azimuth, r->dec_a);
        b = cell_index (v, r->grid.elevation_first, r->grid.elevation_step,
            r->grid.n_elevation, r->dec_b);
      }
      r->lookup[(gsize) j * r->plot_w + i] = (a < 0 || b < 0) ? OUTSIDE :
          (guint32) a * r->n_b + (guint32) b;
    }
}

SonarRenderer *
sonar_renderer_new (const SonarImageGrid * grid, guint width, guint height,
    GError ** error)
{
  SonarRenderer *r;

  if (width < SONAR_RENDER_MIN_SIZE || height < SONAR_RENDER_MIN_SIZE
      || width > SONAR_RENDER_MAX_SIZE || height > SONAR_RENDER_MAX_SIZE) {
    g_set_error (error, SONAR_ERROR, SONAR_ERROR_SETTINGS,
        "a frame of %u x %u pixels: width and height must be %u to %u",
        width, height, SONAR_RENDER_MIN_SIZE, SONAR_RENDER_MAX_SIZE);
    return NULL;
  }
  if (!grid_is_valid (grid)) {
    g_set_error (error, SONAR_ERROR, SONAR_ERROR_SETTINGS,
        "the image grid (%u azimuths, %u elevations, %u ranges from %g m "
        "every %g m) has no cell to draw", grid->n_azimuth,
        grid->n_elevation, grid->n_range, grid->range_first,
        grid->range_step);
    return NULL;
  }
  r = g_new0 (SonarRenderer, 1);
  r->grid = *grid;
  r->width = width;
  r->height = height;
  r->scale = MAX (1, MIN (width / 560, height / 320));
  r->fan = grid->n_elevation == 1 || grid->n_azimuth == 1;
  r->fan_in_elevation = grid->n_azimuth == 1 && grid->n_elevation > 1;
  layout (r);
  plan_cells (r);
  r->amplitude = g_new (float, (gsize) r->n_a * r->n_b);
  r->levels = g_new (guint8, (gsize) r->n_a * r->n_b);
  r->lookup = g_new (guint32, (gsize) r->plot_w * r->plot_h);
  plan_lookup (r);
  r->range_weight = g_new (float, grid->n_range);
  for (guint i = 0; i < grid->n_range; i++) {
    const double range = MAX (grid->range_first + grid->range_step * i, 0.0);
    r->range_weight[i] = (float) (range * range);
  }
  for (guint k = 0; k < LUT_SIZE; k++)
    r->lut[k] = sonar_render_colour_map (k / (double) (LUT_SIZE - 1));
  r->taken = g_array_new (FALSE, FALSE, sizeof (Box));
  return r;
}

void
sonar_renderer_free (SonarRenderer * r)
{
  if (!r)
    return;
  g_free (r->amplitude);
  g_free (r->levels);
  g_free (r->lookup);
  g_free (r->range_weight);
  g_array_unref (r->taken);
  g_free (r);
}

guint
sonar_renderer_scale (const SonarRenderer * r)
{
  return r->scale;
}

gboolean
sonar_renderer_is_fan (const SonarRenderer * r)
{
  return r->fan;
}

void
sonar_renderer_plot_area (const SonarRenderer * r, guint * x, guint * y,
    guint * width, guint * height)
{
  *x = (guint) r->plot_x;
  *y = (guint) r->plot_y;
  *width = (guint) r->plot_w;
  *height = (guint) r->plot_h;
}

gboolean
sonar_renderer_project (const SonarRenderer * r, double range,
    double azimuth, double elevation, double *px, double *py)
{
  double u, v;

  if (!isfinite (range) || !isfinite (azimuth) || !isfinite (elevation))
    return FALSE;
  if (r->fan) {
    const double angle = deg2rad (r->fan_in_elevation ? elevation : azimuth);
    u = range * sin (angle);
    v = range * cos (angle);
  } else {
    u = azimuth;
    v = elevation;
  }
  to_pixel (r, u, v, px, py);
  return *px >= r->plot_x && *px < r->plot_x + r->plot_w
      && *py >= r->plot_y && *py < r->plot_y + r->plot_h;
}

gboolean
sonar_renderer_project_position (const SonarRenderer * r,
    const double position[3], double *px, double *py)
{
  const SonarVec3 p = sonar_vec3 (position[0], position[1], position[2]);
  const double range = sonar_vec3_norm (p);
  double azimuth, elevation;

  if (!(range > 0.0) || !isfinite (range))
    return FALSE;
  sonar_vec3_to_direction (p, &azimuth, &elevation);
  return sonar_renderer_project (r, range, azimuth, elevation, px, py);
}

/* Drawing ----------------------------------------------------------------*/

/* The cells' amplitudes: the maximum over the records, the cell's image
 * cells and the axis not shown (fan: elevation or azimuth; map: range). */
static void
reduce_image (SonarRenderer * r, const SonarRenderFrame * f)
{
  const SonarImageGrid *g = &r->grid;
  const gsize record_size = f->record_stride ? f->record_stride :
      sonar_image_grid_size (g);

  memset (r->amplitude, 0, sizeof (float) * r->n_a * r->n_b);
  for (guint rec = 0; rec < MAX (f->records, 1); rec++) {
    const float *image = f->image + rec * record_size;
    for (guint e = 0; e < g->n_elevation; e++)
      for (guint a = 0; a < g->n_azimuth; a++) {
        const float *row = image + ((gsize) e * g->n_azimuth + a) *
            g->n_range;
        if (r->fan) {
          const guint angle = r->fan_in_elevation ? e : a;
          float *cells = r->amplitude + (gsize) (angle / r->dec_a) * r->n_b;
          for (guint i = 0; i < g->n_range; i++) {
            float value = row[i];
            if (f->range_compensation)
              value *= r->range_weight[i];
            /* !(a <= b) also keeps NaN out. */
            if (!(value <= cells[i / r->dec_b]) && isfinite (value))
              cells[i / r->dec_b] = value;
          }
        } else {
          float *cell = r->amplitude + (gsize) (a / r->dec_a) * r->n_b +
              e / r->dec_b;
          for (guint i = 0; i < g->n_range; i++) {
            float value = row[i];
            if (f->range_compensation)
              value *= r->range_weight[i];
            if (!(value <= *cell) && isfinite (value))
              *cell = value;
          }
        }
      }
  }
}

static void
compute_levels (SonarRenderer * r, double dynamic_range)
{
  const gsize n = (gsize) r->n_a * r->n_b;
  float peak = 0.0f;

  for (gsize k = 0; k < n; k++)
    peak = MAX (peak, r->amplitude[k]);
  for (gsize k = 0; k < n; k++) {
    const double ratio = peak > 0.0f ? r->amplitude[k] / peak : 0.0;
    const double level = ratio > 0.0 ?
        1.0 + 20.0 * log10 (ratio) / dynamic_range : 0.0;
    r->levels[k] = (guint8) lround (CLAMP (level, 0.0, 1.0) *
        (LUT_SIZE - 1));
  }
}

static void
draw_image (SonarRenderer * r, guint8 * pixels, gsize stride)
{
  for (int j = 0; j < r->plot_h; j++) {
    guint8 *p = pixels + (gsize) (r->plot_y + j) * stride +
        (gsize) r->plot_x * 3;
    const guint32 *cell = r->lookup + (gsize) j * r->plot_w;

    for (int i = 0; i < r->plot_w; i++, p += 3)
      if (cell[i] != OUTSIDE) {
        const SonarRgb c = r->lut[r->levels[cell[i]]];
        p[0] = c.r;
        p[1] = c.g;
        p[2] = c.b;
      }
  }
}

static void
draw_axes (SonarRenderer * r, guint8 * pixels, gsize stride)
{
  const guint s = r->scale, W = r->width, H = r->height;
  const int tick = 3 * (int) s, gap = 2 * (int) s;
  const int bottom = r->plot_y + r->plot_h, left = r->plot_x;
  const char *u_title, *v_title;
  double step;
  char text[32];
  int title_x;

  /* Horizontal axis along the bottom of the plot. */
  step = nice_step (r->u_hi - r->u_lo, MAX (2, r->plot_w / (50 * s)));
  for (double u = ceil (r->u_lo / step) * step; u <= r->u_hi + 1e-9 * step;
      u += step) {
    double px, py;
    to_pixel (r, u, 0, &px, &py);
    fill_rect (pixels, stride, W, H, (int) px, bottom, (int) s, tick,
        axis_colour);
    format_tick (text, sizeof text, u, step);
    sonar_render_text (pixels, stride, W, H,
        (int) px - (int) sonar_render_text_width (text, s) / 2,
        bottom + tick + gap, s, text_colour, text);
  }
  /* Vertical axis along the left of the plot. */
  step = nice_step (r->v_hi - r->v_lo, MAX (2, r->plot_h / (40 * s)));
  for (double v = ceil (r->v_lo / step) * step; v <= r->v_hi + 1e-9 * step;
      v += step) {
    double px, py;
    to_pixel (r, 0, v, &px, &py);
    fill_rect (pixels, stride, W, H, left - tick, (int) py, tick, (int) s,
        axis_colour);
    format_tick (text, sizeof text, v, step);
    sonar_render_text (pixels, stride, W, H,
        left - tick - gap - (int) sonar_render_text_width (text, s),
        (int) py - 4 * (int) s, s, text_colour, text);
  }
  if (r->fan) {
    u_title = r->fan_in_elevation ? "y (m)" : "x (m)";
    v_title = "z (m)";
  } else {
    u_title = "azimuth (deg)";
    v_title = "elevation (deg)";
  }
  title_x = r->plot_x + r->plot_w / 2 -
      (int) sonar_render_text_width (u_title, s) / 2;
  sonar_render_text (pixels, stride, W, H, title_x,
      bottom + tick + gap + 11 * (int) s, s, text_colour, u_title);
  /* The vertical axis' title above its labels, left of the plot. */
  sonar_render_text (pixels, stride, W, H, MAX (2 * (int) s,
          left - (int) sonar_render_text_width (v_title, s) - tick),
      r->plot_y - 11 * (int) s, s, text_colour, v_title);
}

/* The colour bar: the legend of the colours in dB. */
static void
draw_colour_bar (SonarRenderer * r, guint8 * pixels, gsize stride,
    double dynamic_range)
{
  const guint s = r->scale, W = r->width, H = r->height;
  const int bar_x = (int) W - MARGIN_RIGHT (s) + 12 * (int) s;
  const int bar_w = 10 * (int) s;
  const int bar_y = MAX (r->plot_y, MARGIN_TOP (s) + 12 * (int) s);
  const int bar_h = MAX (r->plot_y + r->plot_h - bar_y, 20 * (int) s);
  const double step = nice_step (dynamic_range, MAX (2, bar_h / (24 * s)));
  char text[32];

  for (int j = 0; j < bar_h; j++)
    fill_rect (pixels, stride, W, H, bar_x, bar_y + j, bar_w, 1,
        sonar_render_colour_map (1.0 - (j + 0.5) / bar_h));
  for (double db = 0.0; db >= -dynamic_range - 1e-9 * step; db -= step) {
    const int y = bar_y + (int) lround (-db / dynamic_range * (bar_h - 1));
    fill_rect (pixels, stride, W, H, bar_x + bar_w, y, 2 * (int) s,
        (int) s, axis_colour);
    format_tick (text, sizeof text, db, step);
    sonar_render_text (pixels, stride, W, H, bar_x + bar_w + 4 * (int) s,
        y - 4 * (int) s, s, text_colour, text);
  }
  sonar_render_text (pixels, stride, W, H, bar_x, bar_y - 11 * (int) s, s,
      text_colour, "dB");
}

/* The title (ping, time) on the left of the top line, the marks' legend
 * on its right. */
static void
draw_title (SonarRenderer * r, const SonarRenderFrame * f, guint8 * pixels,
    gsize stride)
{
  const guint s = r->scale, W = r->width, H = r->height;
  const int y = 4 * (int) s;
  char title[96] = "", part[48];
  struct
  {
    const char *text;
    SonarRgb colour;
    gboolean ring;
    gboolean track;
  } keys[] = {
    {"approaching", approaching_colour, FALSE, FALSE},
    {"receding or still", receding_colour, FALSE, FALSE},
    {"truth", truth_colour, TRUE, FALSE},
    {"track", track_colour, FALSE, TRUE},
  };
  int x;

  if (f->ping >= 0) {
    g_snprintf (part, sizeof part, "ping %" G_GINT64_FORMAT "  ", f->ping);
    g_strlcat (title, part, sizeof title);
  }
  if (isfinite (f->time)) {
    g_snprintf (part, sizeof part, "%.3f s  ", f->time);
    g_strlcat (title, part, sizeof title);
  }
  if (f->detections_missing)
    g_strlcpy (part, "detections missing", sizeof part);
  else
    g_snprintf (part, sizeof part, "%u detection%s", f->n_detections,
        f->n_detections == 1 ? "" : "s");
  g_strlcat (title, part, sizeof title);
  if (f->n_tracks > 0) {
    g_snprintf (part, sizeof part, "  %u track%s", f->n_tracks,
        f->n_tracks == 1 ? "" : "s");
    g_strlcat (title, part, sizeof title);
  }
  sonar_render_text (pixels, stride, W, H, 4 * (int) s, y, s, text_colour,
      title);

  x = (int) W - 4 * (int) s;
  for (int k = G_N_ELEMENTS (keys) - 1; k >= 0; k--) {
    if ((keys[k].ring && f->n_truths == 0)
        || (keys[k].track && f->n_tracks == 0))
      continue;
    x -= (int) sonar_render_text_width (keys[k].text, s);
    sonar_render_text (pixels, stride, W, H, x, y, s, keys[k].colour,
        keys[k].text);
    x -= 6 * (int) s;
    /* As drawn on the image: detections in a thick ring, truth thin,
     * tracks in a square. */
    if (keys[k].track)
      draw_square (pixels, stride, W, H, x, y + 3.5 * s, 3.0 * s, s,
          keys[k].colour);
    else
      draw_circle (pixels, stride, W, H, x, y + 3.5 * s, 3.0 * s,
          keys[k].ring ? s : 1.5 * s, keys[k].colour);
    x -= 10 * (int) s;
  }
}

static gboolean
boxes_overlap (const Box * a, const Box * b)
{
  return a->x < b->x + b->w && b->x < a->x + a->w && a->y < b->y + b->h
      && b->y < a->y + a->h;
}

/* The square a mark (truth ring or detection ring) covers. */
static void
take_mark (SonarRenderer * r, const SonarRenderPoint * p)
{
  const int half = (int) ((SONAR_RENDER_TRUTH_RADIUS + 1.0) * r->scale);
  double px, py;
  Box box;

  if (!sonar_renderer_project (r, p->range, p->azimuth, p->elevation, &px,
          &py))
    return;
  box.x = (int) px - half;
  box.y = (int) py - half;
  box.w = box.h = 2 * half + 1;
  g_array_append_val (r->taken, box);
}

/* A track's arrow, pixels: from (sx, sy) on its square's edge to the
 * tip (tx, ty), the pixel of position + velocity x arrow_time (beyond the
 * plot too: it is clipped at the frame). FALSE when it has none: it
 * would end inside the square. */
static gboolean
track_arrow (const SonarRenderer * r, const SonarRenderTrack * t,
    double arrow_time, double *sx, double *sy, double *tx, double *ty)
{
  const double s = r->scale, half = SONAR_RENDER_TRACK_HALF_SIDE * s;
  double tip[3], px, py, length, ux, uy, edge;

  *tx = *ty = NAN;
  if (!sonar_renderer_project_position (r, t->position, &px, &py))
    return FALSE;
  for (guint i = 0; i < 3; i++)
    tip[i] = t->position[i] + t->velocity[i] * arrow_time;
  sonar_renderer_project_position (r, tip, tx, ty);
  length = hypot (*tx - px, *ty - py);
  if (!isfinite (length) || length == 0.0)
    return FALSE;
  ux = (*tx - px) / length;
  uy = (*ty - py) / length;
  /* The square's edge is 1 to sqrt 2 half sides away, as the direction
   * goes. */
  edge = half / MAX (fabs (ux), fabs (uy));
  if (length <= edge + s)
    return FALSE;
  *sx = px + ux * edge;
  *sy = py + uy * edge;
  return TRUE;
}

/* What a track's mark covers (as take_mark's), and its arrow, so that no
 * label hides it. */
static void
take_track (SonarRenderer * r, const SonarRenderTrack * t, double arrow_time)
{
  const int half = (int) ((SONAR_RENDER_TRUTH_RADIUS + 1.0) * r->scale);
  const int s = (int) r->scale;
  double px, py, sx, sy, tx, ty;
  Box box;

  if (!sonar_renderer_project_position (r, t->position, &px, &py))
    return;
  box.x = (int) px - half;
  box.y = (int) py - half;
  box.w = box.h = 2 * half + 1;
  g_array_append_val (r->taken, box);
  if (track_arrow (r, t, arrow_time, &sx, &sy, &tx, &ty)) {
    /* Small boxes along the shaft, the head's around the tip. */
    const double length = hypot (tx - sx, ty - sy);
    const guint n = (guint) ceil (length / (4.0 * s));
    for (guint k = 0; k <= n; k++) {
      const double f = (double) k / n;
      const int w = k == n ? 12 * s : 4 * s;
      box.x = (int) (sx + f * (tx - sx)) - w / 2;
      box.y = (int) (sy + f * (ty - sy)) - w / 2;
      box.w = box.h = w + 1;
      g_array_append_val (r->taken, box);
    }
  }
}

/* A label at (px, py) (a mark's centre): right of the mark, else left,
 * above or below, wherever it covers no other label or mark (else right,
 * or left at the frame's edge), in a black box. */
static void
place_label (SonarRenderer * r, double px, double py, const char *label,
    SonarRgb colour, guint8 * pixels, gsize stride)
{
  const int s = (int) r->scale, W = (int) r->width, H = (int) r->height;
  const int offset = (int) ((SONAR_RENDER_TRUTH_RADIUS + 2.0) * s);
  Box candidates[6], box;
  guint chosen = 0;
  /* The box: the text with a margin of one unit. */
  const int w = (int) sonar_render_text_width (label, r->scale) + 2 * s;

  {
    const int x = (int) px, y = (int) py, h = 10 * s;
    const Box c[6] = {
      {x + offset, y - 5 * s, w, h},
      {x - offset - w, y - 5 * s, w, h},
      {x - w / 2, y - offset - h, w, h},
      {x - w / 2, y + offset, w, h},
      {x + offset / 2, y - offset - h, w, h},
      {x + offset / 2, y + offset, w, h},
    };
    memcpy (candidates, c, sizeof c);
  }
  for (chosen = 0; chosen < G_N_ELEMENTS (candidates); chosen++) {
    const Box *c = &candidates[chosen];
    gboolean free = c->x >= 0 && c->y >= 0 && c->x + c->w <= W
        && c->y + c->h <= H;
    for (guint k = 0; free && k < r->taken->len; k++)
      free = !boxes_overlap (c, &g_array_index (r->taken, Box, k));
    if (free)
      break;
  }
  if (chosen == G_N_ELEMENTS (candidates))
    chosen = candidates[0].x + w <= W ? 0 : 1;
  box = candidates[chosen];
  g_array_append_val (r->taken, box);
  fill_rect (pixels, stride, r->width, r->height, box.x, box.y, box.w, box.h,
      label_box_colour);
  sonar_render_text (pixels, stride, r->width, r->height, box.x + s,
      box.y + s, r->scale, colour, label);
}

/* A detection's label: its radial velocity, and its range in the map. */
static void
draw_label (SonarRenderer * r, const SonarRenderPoint * d, guint8 * pixels,
    gsize stride)
{
  char label[64], range_text[32];
  SonarRgb colour;
  double px, py;

  if (!sonar_renderer_project (r, d->range, d->azimuth, d->elevation, &px,
          &py))
    return;
  colour = sonar_render_velocity_label (d->radial_velocity, label,
      sizeof label);
  if (d->rejected)
    colour = unknown_colour;
  if (!r->fan) {
    /* The map hides the range: say it. */
    g_snprintf (range_text, sizeof range_text, ", %.2f m", d->range);
    g_strlcat (label, range_text, sizeof label);
  }
  place_label (r, px, py, label, colour, pixels, stride);
}

/* A track's label: its id. */
static void
draw_track_label (SonarRenderer * r, const SonarRenderTrack * t,
    guint8 * pixels, gsize stride)
{
  char label[32];
  double px, py;

  if (!sonar_renderer_project_position (r, t->position, &px, &py))
    return;
  sonar_render_track_label (t->id, label, sizeof label);
  place_label (r, px, py, label, track_colour, pixels, stride);
}

/* A track's square and its arrow: from the square's edge to the pixel of
 * position + velocity x arrow_time, a head of two strokes at the tip; all
 * outlined in black to stand out on the image. */
static void
draw_track (SonarRenderer * r, const SonarRenderTrack * t, double arrow_time,
    guint8 * pixels, gsize stride)
{
  const double s = r->scale, half = SONAR_RENDER_TRACK_HALF_SIDE * s;
  const double head = 5.0 * s, spread = 25.0 * M_PI / 180.0;
  double px, py, sx, sy, tx, ty;

  if (!sonar_renderer_project_position (r, t->position, &px, &py))
    return;
  if (track_arrow (r, t, arrow_time, &sx, &sy, &tx, &ty)) {
    const double a = atan2 (ty - sy, tx - sx);
    const double line[3][4] = {
      {sx, sy, tx, ty},
      {tx, ty, tx - head * cos (a - spread), ty - head * sin (a - spread)},
      {tx, ty, tx - head * cos (a + spread), ty - head * sin (a + spread)},
    };
    /* Black under magenta, to stand out on the image. */
    for (guint pass = 0; pass < 2; pass++)
      for (guint k = 0; k < 3; k++)
        draw_line (pixels, stride, r->width, r->height, line[k][0],
            line[k][1], line[k][2], line[k][3], pass ? s : s + 2.0,
            pass ? track_colour : label_box_colour);
  }
  draw_square (pixels, stride, r->width, r->height, px, py, half + 1.0,
      s + 2.0, label_box_colour);
  draw_square (pixels, stride, r->width, r->height, px, py, half, s,
      track_colour);
}

/* A detection's marker: a ring in its label's colour, outlined in black,
 * leaving the echo it marks visible inside. */
static void
draw_marker (SonarRenderer * r, const SonarRenderPoint * d, guint8 * pixels,
    gsize stride)
{
  const guint s = r->scale;
  char label[32];
  double px, py;
  SonarRgb colour;

  if (!sonar_renderer_project (r, d->range, d->azimuth, d->elevation, &px,
          &py))
    return;
  colour = sonar_render_velocity_label (d->radial_velocity, label,
      sizeof label);
  if (d->rejected)
    colour = unknown_colour;
  draw_circle (pixels, stride, r->width, r->height, px, py,
      SONAR_RENDER_MARKER_RADIUS * s, 2.0 * s + 2.0, label_box_colour);
  draw_circle (pixels, stride, r->width, r->height, px, py,
      SONAR_RENDER_MARKER_RADIUS * s, 2.0 * s, colour);
}

void
sonar_renderer_draw (SonarRenderer * r, const SonarRenderFrame * f,
    guint8 * pixels, gsize stride)
{
  const guint s = r->scale;
  const double dynamic_range = f->dynamic_range > 0 ? f->dynamic_range :
      40.0;
  const double arrow_time = f->arrow_time > 0 ? f->arrow_time :
      SONAR_RENDER_DEFAULT_ARROW_TIME;

  fill_rect (pixels, stride, r->width, r->height, 0, 0, r->width, r->height,
      background_colour);
  if (f->image) {
    reduce_image (r, f);
    compute_levels (r, dynamic_range);
    draw_image (r, pixels, stride);
  }
  draw_axes (r, pixels, stride);
  draw_colour_bar (r, pixels, stride, dynamic_range);
  draw_title (r, f, pixels, stride);
  for (guint k = 0; k < f->n_truths; k++) {
    const SonarRenderPoint *t = &f->truths[k];
    double px, py;
    if (sonar_renderer_project (r, t->range, t->azimuth, t->elevation, &px,
            &py))
      draw_circle (pixels, stride, r->width, r->height, px, py,
          SONAR_RENDER_TRUTH_RADIUS * s, s, truth_colour);
  }
  /* Labels first, so that no label hides another detection's marker,
   * placed clear of every mark. */
  g_array_set_size (r->taken, 0);
  for (guint k = 0; k < f->n_truths; k++)
    take_mark (r, &f->truths[k]);
  for (guint k = 0; k < f->n_detections; k++)
    take_mark (r, &f->detections[k]);
  for (guint k = 0; k < f->n_tracks; k++)
    take_track (r, &f->tracks[k], arrow_time);
  for (guint k = 0; k < f->n_detections; k++)
    draw_label (r, &f->detections[k], pixels, stride);
  for (guint k = 0; k < f->n_tracks; k++)
    draw_track_label (r, &f->tracks[k], pixels, stride);
  for (guint k = 0; k < f->n_detections; k++)
    draw_marker (r, &f->detections[k], pixels, stride);
  for (guint k = 0; k < f->n_tracks; k++)
    draw_track (r, &f->tracks[k], arrow_time, pixels, stride);
}
