/* sonar-render.h: pictures of an energyscape for people, as RGB frames
 * (the core of the sonarviz element; plain C, no GStreamer).
 *
 * A 2-D image (one elevation) is drawn as the fan in metres seen from
 * above, like the paper's Fig. 9b: x = r sin(azimuth) to the right,
 * z = r cos(azimuth) up the frame (forward), equal scales on both axes.
 * A 3-D image is drawn as the azimuth x elevation map of its maximum over
 * range (azimuth to the right, elevation up, equal degrees on both axes).
 * Colour is dB below the frame's maximum, clipped at -dynamic_range, on
 * the viridis colour map, with a colour bar (the legend) on the right.
 *
 * Marks: the ground truth as white rings, each detection as a smaller
 * ring (the echo stays visible inside) labelled with its radial velocity
 * (to 0.01 m/s), red when it
 * approaches and green when it recedes or stands still. The colour follows
 * the printed value, so a red label is always negative and a speed that
 * rounds to zero is printed "0.00" in green, never "-0.00" in red.
 *
 * Tracks (sonartrack's) in magenta: a square around the track's position
 * labelled with its id ("#7"), and an arrow of its velocity in the world
 * from the square to where the track would be arrow_time seconds later
 * (position + velocity x arrow_time, drawn in the sensor frame): in the
 * fan an arrow of that many metres, in the map the change of direction
 * it makes (an object moving along its line of sight has no arrow
 * there). A still track's arrow is shorter than its square: none.
 *
 * Frames are packed RGB, 3 bytes a pixel, rows @stride bytes apart (what
 * GStreamer's video/x-raw format=RGB holds). Every layout computation
 * (the projection, the per-pixel look-up into the image) is made once in
 * sonar_renderer_new; a frame costs one pass over the image and one over
 * the pixels. */
#ifndef SONAR_RENDER_H
#define SONAR_RENDER_H

#include <glib.h>

#include "sonar-image-grid.h"

G_BEGIN_DECLS

/* Frame sizes a renderer accepts, pixels. */
#define SONAR_RENDER_MIN_SIZE 160
#define SONAR_RENDER_MAX_SIZE 8192

/* The marks' radii, in units of sonar_renderer_scale (): a detection's
 * ring (2 units thick) and the truth's (1 unit). */
#define SONAR_RENDER_MARKER_RADIUS 5.0
#define SONAR_RENDER_TRUTH_RADIUS 9.0

typedef struct
{
  guint8 r, g, b;
} SonarRgb;

/* A point to mark: position (m, degrees) and, for a detection, its radial
 * velocity (m/s, positive moving away; NaN when unknown) and whether it
 * failed the false-positive tests (drawn grey, as is an unknown
 * velocity). */
typedef struct
{
  double range, azimuth, elevation;
  double radial_velocity;
  gboolean rejected;
} SonarRenderPoint;

/* A track to draw: its identity, the position it refers to (m, sensor
 * frame: x right, y up, z forward) and its velocity in the world (m/s, on
 * the sensor's axes). */
typedef struct
{
  guint64 id;
  double position[3];
  double velocity[3];
} SonarRenderTrack;

/* The arrows' default: the way a track goes in this long, s. */
#define SONAR_RENDER_DEFAULT_ARROW_TIME 0.5
/* The half side of a track's square, units of sonar_renderer_scale ():
 * between a detection's ring and the truth's. */
#define SONAR_RENDER_TRACK_HALF_SIDE 7.0

/* Everything one frame shows. */
typedef struct
{
  const float *image;           /* grid's pixel order; NULL: axes only */
  guint records;                /* images in @image: the maximum is drawn */
  gsize record_stride;          /* floats from one record to the next (0:
                                 * the grid's size, back to back) */
  double dynamic_range;         /* dB below the frame's maximum shown, > 0 */
  /* Colour the amplitude times r^2 (the spreading loss undone, as
   * wardcluster thresholds it), so that far objects look as strong as
   * near ones. */
  gboolean range_compensation;
  const SonarRenderPoint *truths;
  guint n_truths;
  const SonarRenderPoint *detections;
  guint n_detections;
  /* The ping's detections never came (dropped or skipped on their way):
   * the title says so instead of counting none. */
  gboolean detections_missing;
  const SonarRenderTrack *tracks;
  guint n_tracks;
  double arrow_time;            /* s, arrows' length in time; <= 0 or NaN:
                                 * SONAR_RENDER_DEFAULT_ARROW_TIME */
  gint64 ping;                  /* printed in the title; < 0: none */
  double time;                  /* s, printed in the title; NaN: none */
} SonarRenderFrame;

typedef struct _SonarRenderer SonarRenderer;

/* A renderer of @grid's images into @width x @height frames. Errors name
 * what is wrong (a size out of range, an empty or non-finite grid). */
SonarRenderer *sonar_renderer_new (const SonarImageGrid * grid, guint width,
    guint height, GError ** error);
void sonar_renderer_free (SonarRenderer * renderer);

/* Draws the whole frame: background, image, axes, legend, title, truth
 * rings, detections and their labels, tracks with their ids and arrows. @pixels: width x height RGB. */
void sonar_renderer_draw (SonarRenderer * renderer,
    const SonarRenderFrame * frame, guint8 * pixels, gsize stride);

/* Where a point is drawn (pixel centre coordinates, x right, y down): in
 * the fan its (x, z) position, in the map its direction. FALSE when it
 * falls outside the image's area (then it is not marked). */
gboolean sonar_renderer_project (const SonarRenderer * renderer,
    double range, double azimuth, double elevation, double *px, double *py);

/* Where a track at @position (m, sensor frame) is drawn, as
 * sonar_renderer_project () says for its range and direction. */
gboolean sonar_renderer_project_position (const SonarRenderer * renderer,
    const double position[3], double *px, double *py);

/* The label of a track ("#7") into @text. */
void sonar_render_track_label (guint64 id, char *text, gsize size);

/* The size of text and marks: 1 up to 1119 x 639 pixels, 2 from
 * 1120 x 640 (1280 x 720), and so on. */
guint sonar_renderer_scale (const SonarRenderer * renderer);

/* TRUE when the frame is the 2-D fan (else the azimuth x elevation map). */
gboolean sonar_renderer_is_fan (const SonarRenderer * renderer);

/* The plot area (the image's bounding box), pixels. */
void sonar_renderer_plot_area (const SonarRenderer * renderer, guint * x,
    guint * y, guint * width, guint * height);

/* The label of a radial velocity ("+1.80 m/s", "-2.98 m/s", "0.00 m/s",
 * never "-0.00") into @text (at least 32 bytes), and its colour. */
SonarRgb sonar_render_velocity_label (double radial_velocity, char *text,
    gsize size);

/* The marks' colours. */
SonarRgb sonar_render_approaching_colour (void);
SonarRgb sonar_render_receding_colour (void);
SonarRgb sonar_render_truth_colour (void);
SonarRgb sonar_render_rejected_colour (void);
SonarRgb sonar_render_background_colour (void);
SonarRgb sonar_render_track_colour (void);

/* The colour map: level 0 (the bottom of the dynamic range) to 1 (the
 * maximum). */
SonarRgb sonar_render_colour_map (double level);

/* Text in the built-in 5 x 8 pixel font, @scale times larger, top-left
 * corner at (x, y), clipped to the frame: letters, digits, space and
 * + - . , / : ( ) = % _ ? #; any other character is drawn as a box.
 * Returns the width drawn, pixels. */
guint sonar_render_text (guint8 * pixels, gsize stride, guint width,
    guint height, int x, int y, guint scale, SonarRgb colour,
    const char *text);
/* Width of @text at @scale, pixels. */
guint sonar_render_text_width (const char *text, guint scale);

G_END_DECLS

#endif /* SONAR_RENDER_H */
