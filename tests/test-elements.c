/* test-elements.c: dopplerbank and mimobeamform as users compose them:
 * caps, records, metas and events; taps through tee and filesink; errors;
 * extreme inputs; the datacube. */
#include <gst/app/gstappsink.h>
#include <gst/check/gstharness.h>
#include <glib/gstdio.h>
#include <math.h>
#include <string.h>

#include "sonar-contracts.h"
#include "sonar-imager.h"
#include "sonar-test-gst.h"

#define RECORDING_CAPS "audio/x-raw, format=F32LE, layout=interleaved, " \
  "rate=450000, channels=32, channel-mask=(bitmask)0"

/* The samples of the appsink named "sink". */
static GPtrArray *
sink_samples (SonarTestRun * run)
{
  return sonar_test_run_samples (run, "sink");
}

static GstBuffer *
run_buffer (SonarTestRun * run, guint i)
{
  g_assert_cmpuint (i, <, sink_samples (run)->len);
  return gst_sample_get_buffer (g_ptr_array_index (sink_samples (run), i));
}

/* The sticky events on the appsink's pad. */
static void
sink_events (SonarTestRun * run, SonarSetup ** setup, SonarDopplerBank ** bank,
    SonarBand * band)
{
  GstElement *sink = gst_bin_get_by_name (GST_BIN (run->pipeline), "sink");
  GstPad *pad = gst_element_get_static_pad (sink, "sink");
  GstEvent *event;

  *setup = NULL;
  *bank = NULL;
  for (guint i = 0; (event = gst_pad_get_sticky_event (pad,
              GST_EVENT_CUSTOM_DOWNSTREAM_STICKY, i)); i++) {
    if (sonar_event_is_setup (event)) {
      GError *error = NULL;
      g_assert_null (*setup);
      *setup = sonar_setup_from_event (event, &error);
      g_assert_no_error (error);
    } else if (sonar_event_is_bank (event)) {
      g_assert_null (*bank);
      *bank = sonar_bank_from_event (event, band);
    }
    gst_event_unref (event);
  }
  gst_object_unref (pad);
  gst_object_unref (sink);
}

typedef struct
{
  const SonarEnergyscapeHeader *header;
  const float *pixels;
} Record;

/* The records of an energyscape buffer (mapped by the caller). */
static Record
record_at (const GstMapInfo * map, const SonarImageGrid * grid, guint r)
{
  const gsize record_size = sizeof (SonarEnergyscapeHeader) +
      sizeof (float) * sonar_image_grid_size (grid);
  Record rec;

  g_assert_cmpuint (map->size, >=, (r + 1) * record_size);
  rec.header = (const SonarEnergyscapeHeader *) (map->data + r * record_size);
  rec.pixels = (const float *) (map->data + r * record_size +
      sizeof (SonarEnergyscapeHeader));
  return rec;
}

static void
assert_grid_equal (const SonarImageGrid * a, const SonarImageGrid * b)
{
  g_assert_cmpuint (a->n_azimuth, ==, b->n_azimuth);
  g_assert_cmpuint (a->n_elevation, ==, b->n_elevation);
  g_assert_cmpuint (a->n_range, ==, b->n_range);
  g_assert_cmpfloat (a->azimuth_first, ==, b->azimuth_first);
  g_assert_cmpfloat (a->azimuth_step, ==, b->azimuth_step);
  g_assert_cmpfloat (a->elevation_first, ==, b->elevation_first);
  g_assert_cmpfloat (a->elevation_step, ==, b->elevation_step);
  g_assert_cmpfloat (a->range_first, ==, b->range_first);
  g_assert_cmpfloat (a->range_step, ==, b->range_step);
}

static gsize
peak_index (const float *x, gsize n)
{
  gsize best = 0;
  for (gsize i = 1; i < n; i++)
    if (x[i] > x[best])
      best = i;
  return best;
}

/* 1. sonarsrc ! dopplerbank ! mimobeamform: caps, records, the image's
 * peak at the default scene's strongest object, metas and events; the
 * image is the core imager's over the documented hypotheses. */
static void
test_chain_output (void)
{
  SonarTestRun *run = sonar_test_run ("sonarsrc num-buffers=2 ! dopplerbank ! "
      "mimobeamform azimuth-count=61 range-max=3.5 ! "
      "appsink name=sink sync=false");
  g_autoptr (SonarSetup) setup = NULL;
  g_autoptr (SonarDopplerBank) bank = NULL;
  SonarBand band, expected_band;
  SonarImageGrid grid, header_grid;
  guint records;
  gsize pixels;
  GstCaps *caps;
  const GstStructure *s;

  g_assert_null (run->error_text);
  g_assert_cmpuint (sink_samples (run)->len, ==, 2);

  /* Caps: the grid asked for. */
  caps = gst_sample_get_caps (g_ptr_array_index (sink_samples (run), 0));
  s = gst_caps_get_structure (caps, 0);
  g_assert_true (gst_structure_has_name (s, SONAR_ENERGYSCAPE_MEDIA_TYPE));
  g_assert_true (sonar_energyscape_caps_parse (caps, &grid, &records, NULL));
  g_assert_cmpuint (records, ==, 1);
  g_assert_cmpuint (grid.n_azimuth, ==, 61);
  g_assert_cmpfloat (grid.azimuth_first, ==, -90.0);
  g_assert_cmpfloat (fabs (grid.azimuth_step - 3.0), <, 1e-12);
  g_assert_cmpuint (grid.n_elevation, ==, 1);
  g_assert_cmpfloat (grid.elevation_first, ==, 0.0);
  g_assert_cmpfloat (grid.range_step, >, 0.0);
  g_assert_cmpfloat (grid.range_step, <=, 0.005);
  g_assert_cmpfloat (grid.range_first, >=, 0.3);
  g_assert_cmpfloat (grid.range_first, <, 0.3 + grid.range_step);
  g_assert_cmpfloat (grid.range_first + (grid.n_range - 1) * grid.range_step,
      <=, 3.5 + 1e-9);
  g_assert_cmpfloat (grid.range_first + grid.n_range * grid.range_step, >,
      3.5);
  pixels = sonar_image_grid_size (&grid);

  /* Sticky events: the set-up and the bank (default -7..7 by 0.05). */
  sink_events (run, &setup, &bank, &band);
  g_assert_nonnull (setup);
  g_assert_nonnull (bank);
  g_assert_cmpuint (setup->geometry.n_microphones, ==, 32);
  g_assert_cmpuint (setup->geometry.n_emitters, ==, 8);
  g_assert_cmpuint (sonar_doppler_bank_n_velocities (bank), ==, 281);
  g_assert_cmpfloat (sonar_doppler_bank_velocity (bank, 0), ==, -7.0);
  g_assert_cmpfloat (fabs (sonar_doppler_bank_velocity (bank, 280) - 7.0), <,
      1e-9);
  /* The band holds a linear correlation of a ping with every template. */
  sonar_band_init (&expected_band, setup->sample_rate, setup->ping_length +
      sonar_doppler_bank_max_length (bank), setup->band_low,
      setup->band_high);
  g_assert_true (sonar_band_equal (&band, &expected_band));

  for (guint k = 0; k < sink_samples (run)->len; k++) {
    GstBuffer *buffer = run_buffer (run, k);
    SonarTruthMeta *truth = sonar_buffer_get_truth_meta (buffer);
    SonarSpectraMeta *spectra = sonar_buffer_get_spectra_meta (buffer);
    GstMapInfo map;
    Record rec;
    gsize peak;
    double az, r;
    guint nearest = 0;
    double nearest_distance = G_MAXDOUBLE;

    g_assert_cmpuint (gst_buffer_get_size (buffer), ==,
        sizeof (SonarEnergyscapeHeader) + sizeof (float) * pixels);
    g_assert_cmpuint (GST_BUFFER_PTS (buffer), ==, k * GST_SECOND / 12);
    gst_buffer_map (buffer, &map, GST_MAP_READ);
    rec = record_at (&map, &grid, 0);
    g_assert_cmpmem (rec.header->magic, 8, SONAR_ENERGYSCAPE_MAGIC, 8);
    g_assert_cmpuint (rec.header->header_size, ==, 96);
    g_assert_cmpuint (rec.header->ping_index, ==, k);
    g_assert_true (isnan (rec.header->velocity));
    g_assert_cmpint (rec.header->emitter, ==, -1);
    g_assert_true (sonar_energyscape_header_parse (rec.header,
            &header_grid));
    assert_grid_equal (&header_grid, &grid);
    for (gsize i = 0; i < pixels; i++)
      g_assert_true (isfinite (rec.pixels[i]) && rec.pixels[i] >= 0.0f);

    /* The peak is at the scene's strongest object. */
    g_assert_nonnull (truth);
    g_assert_cmpuint (truth->ping_index, ==, k);
    g_assert_cmpuint (truth->n_truths, ==, 3);
    peak = peak_index (rec.pixels, pixels);
    r = grid.range_first + (peak % grid.n_range) * grid.range_step;
    az = grid.azimuth_first + (peak / grid.n_range) * grid.azimuth_step;
    for (guint t = 0; t < truth->n_truths; t++) {
      const double d = fabs (truth->truths[t].azimuth - az) / 3.0 +
          fabs (truth->truths[t].range - r) / 0.02;
      if (d < nearest_distance) {
        nearest_distance = d;
        nearest = t;
      }
    }
    g_test_message ("ping %u: peak %.4g at %.0f deg %.4f m; nearest truth "
        "%u at %.1f deg %.4f m", k, rec.pixels[peak], az, r, nearest,
        truth->truths[nearest].azimuth, truth->truths[nearest].range);
    g_assert_cmpuint (nearest, ==, 0);
    g_assert_cmpfloat (fabs (truth->truths[0].azimuth - az), <=,
        grid.azimuth_step + 1e-9);
    g_assert_cmpfloat (fabs (truth->truths[0].range - r), <=, 0.02);

    /* The ping's spectra, on the bank's band. */
    g_assert_nonnull (spectra);
    g_assert_cmpuint (spectra->channels, ==, 32);
    g_assert_true (sonar_band_equal (&spectra->band, &band));
    g_assert_cmpuint (gst_buffer_get_size (spectra->spectra), ==,
        sizeof (SonarComplex) * 32 * band.n_bins);

    /* The image is the core imager's over the hypotheses spaced 0.3 m/s. */
    if (k == 0) {
      SonarImagerParams p;
      SonarImager *imager;
      guint *hyps = g_new (guint, 283);
      const guint n_hyps = sonar_doppler_bank_hypotheses (bank, 0.3, hyps);
      SonarHypothesis *hypotheses = g_new (SonarHypothesis, n_hyps);
      float *image = g_new (float, pixels);
      GstMapInfo smap;
      GError *error = NULL;

      g_assert_cmpuint (n_hyps, ==, 47);
      sonar_imager_params_init_default (&p);
      p.n_azimuth = 61;
      p.range_max = 3.5;
      imager = sonar_imager_new (setup, &band, &p, &error);
      g_assert_no_error (error);
      assert_grid_equal (sonar_imager_grid (imager), &grid);
      for (guint h = 0; h < n_hyps; h++)
        hypotheses[h] = sonar_doppler_bank_hypothesis (bank, hyps[h]);
      gst_buffer_map (spectra->spectra, &smap, GST_MAP_READ);
      sonar_imager_process (imager, (const SonarComplex *) smap.data,
          n_hyps, hypotheses, -1, image);
      gst_buffer_unmap (spectra->spectra, &smap);
      g_assert_cmpmem (image, sizeof (float) * pixels, rec.pixels,
          sizeof (float) * pixels);
      sonar_imager_free (imager);
      g_free (image);
      g_free (hypotheses);
      g_free (hyps);
    }
    gst_buffer_unmap (buffer, &map);
  }
  sonar_test_run_free (run);
}

static gboolean
have_matplotlib (void)
{
  const char *argv[] = { "/usr/bin/python3", "-c", "import matplotlib",
    NULL
  };
  int status = 1;

  if (!g_spawn_sync (NULL, (char **) argv, NULL, G_SPAWN_STDOUT_TO_DEV_NULL |
          G_SPAWN_STDERR_TO_DEV_NULL, NULL, NULL, NULL, NULL, &status, NULL))
    return FALSE;
  return g_spawn_check_wait_status (status, NULL);
}

/* 2. Taps: the images and the spectra through tee into files, record for
 * record what the appsink gets; the plotting tool reads the file. */
static void
test_taps (void)
{
  g_autofree char *dir = g_dir_make_tmp ("sonar-taps-XXXXXX", NULL);
  g_autofree char *images = g_build_filename (dir, "images.es", NULL);
  g_autofree char *spectra = g_build_filename (dir, "spectra.bin", NULL);
  g_autofree char *png = g_build_filename (dir, "image.png", NULL);
  const char *chain = "dopplerbank velocity-min=-0.6 velocity-max=0.6 ";
  const char *imaging = "mimobeamform azimuth-count=31 range-max=3 ";
  g_autofree char *launch1 = g_strdup_printf ("sonarsrc num-buffers=3 ! %s ! "
      "%s ! tee name=t t. ! queue ! filesink location=%s t. ! queue ! "
      "appsink name=sink sync=false", chain, imaging, images);
  g_autofree char *launch2 = g_strdup_printf ("sonarsrc num-buffers=3 ! %s ! "
      "tee name=t t. ! queue ! filesink location=%s t. ! queue ! %s ! "
      "appsink name=sink sync=false", chain, spectra, imaging);
  SonarTestRun *run;
  g_autofree char *contents = NULL;
  gsize length, offset = 0;

  /* Images. */
  run = sonar_test_run (launch1);
  g_assert_null (run->error_text);
  g_assert_cmpuint (sink_samples (run)->len, ==, 3);
  g_assert_true (g_file_get_contents (images, &contents, &length, NULL));
  {
    SonarImageGrid grid;
    guint records;
    g_assert_true (sonar_energyscape_caps_parse (gst_sample_get_caps
            (g_ptr_array_index (sink_samples (run), 0)), &grid, &records, NULL));
    g_test_message ("energyscape file: %" G_GSIZE_FORMAT " bytes, 3 records "
        "of %" G_GSIZE_FORMAT, length, sizeof (SonarEnergyscapeHeader) +
        sizeof (float) * sonar_image_grid_size (&grid));
    g_assert_cmpuint (length, ==, 3 * (sizeof (SonarEnergyscapeHeader) +
            sizeof (float) * sonar_image_grid_size (&grid)));
  }
  for (guint k = 0; k < 3; k++) {
    GstMapInfo map;
    gst_buffer_map (run_buffer (run, k), &map, GST_MAP_READ);
    g_assert_cmpmem (contents + offset, map.size, map.data, map.size);
    offset += map.size;
    gst_buffer_unmap (run_buffer (run, k), &map);
  }
  sonar_test_run_free (run);
  g_clear_pointer (&contents, g_free);

  /* Spectra: the file holds, ping for ping, what the image's meta holds. */
  run = sonar_test_run (launch2);
  g_assert_null (run->error_text);
  g_assert_cmpuint (sink_samples (run)->len, ==, 3);
  g_assert_true (g_file_get_contents (spectra, &contents, &length, NULL));
  offset = 0;
  for (guint k = 0; k < 3; k++) {
    SonarSpectraMeta *meta = sonar_buffer_get_spectra_meta (run_buffer (run,
            k));
    GstMapInfo map;
    g_assert_nonnull (meta);
    if (k == 0) {
      g_test_message ("spectra file: %" G_GSIZE_FORMAT " bytes, 3 pings of "
          "32 x %u bins", length, meta->band.n_bins);
      g_assert_cmpuint (length, ==, 3 * sizeof (SonarComplex) * 32 *
          meta->band.n_bins);
    }
    gst_buffer_map (meta->spectra, &map, GST_MAP_READ);
    g_assert_cmpuint (map.size, ==, sizeof (SonarComplex) * 32 *
        meta->band.n_bins);
    g_assert_cmpmem (contents + offset, map.size, map.data, map.size);
    offset += map.size;
    gst_buffer_unmap (meta->spectra, &map);
  }
  sonar_test_run_free (run);

  /* The plotting tool draws the saved images. */
  if (have_matplotlib ()) {
    g_autofree char *tool = sonar_test_source_path
        ("tools/plot-energyscape.py");
    const char *argv[] = { "/usr/bin/python3", tool, images, "-o", png,
      NULL
    };
    g_autofree char *out = NULL, *err = NULL, *image = NULL;
    GError *error = NULL;
    int status;
    gsize size;

    g_assert_true (g_spawn_sync (NULL, (char **) argv, NULL, 0, NULL, NULL,
            &out, &err, &status, &error));
    g_assert_no_error (error);
    if (!g_spawn_check_wait_status (status, NULL))
      g_error ("plot-energyscape.py failed: %s%s", out, err);
    g_assert_true (g_file_get_contents (png, &image, &size, NULL));
    g_assert_cmpuint (size, >, 1000);
    g_assert_cmpmem (image, 8, "\x89PNG\r\n\x1a\n", 8);
    g_unlink (png);
  } else {
    g_test_skip ("/usr/bin/python3 has no matplotlib: the plot is not "
        "checked");
  }
  g_unlink (images);
  g_unlink (spectra);
  g_rmdir (dir);
}

/* 3. Bad settings and inputs end in errors that say what is wrong. */
static void
test_errors_are_clear (void)
{
  const struct
  {
    const char *launch;
    const char *expected, *alternative;
  } cases[] = {
    {"sonarsrc num-buffers=1 ! dopplerbank velocity-min=-0.4 "
          "velocity-max=0.4 ! mimobeamform mode=fixed velocity=0.5 ! fakesink",
        "velocity 0.5 m/s is outside the Doppler bank", NULL},
    {"sonarsrc num-buffers=1 ! dopplerbank velocity-min=0 velocity-max=0 ! "
          "mimobeamform emitter=9 ! fakesink", "emitter 9 does not exist",
        NULL},
    /* Five copies of one direction (no detection came, and no word). */
    {"sonarsrc num-buffers=1 ! dopplerbank velocity-min=0 velocity-max=0 ! "
          "mimobeamform azimuth-min=10 azimuth-max=10 azimuth-count=5 ! "
          "fakesink", "imager: several azimuths need min < max (one "
          "azimuth: a count of 1)", NULL},
    {"audiotestsrc num-buffers=1 ! audio/x-raw,format=F32LE,channels=32,"
          "rate=450000,layout=interleaved,channel-mask=(bitmask)0 ! "
          "dopplerbank ! fakesink",
        "No sonar set-up arrived before the data", NULL},
    {"sonarsrc num-buffers=1 ! mimobeamform ! fakesink", "link",
        "negotiat"},
    {"sonarsrc num-buffers=1 ! dopplerbank velocity-step=1 velocity-min=0.5 "
          "velocity-max=0.2 ! fakesink", "min <= max", NULL},
  };

  for (guint i = 0; i < G_N_ELEMENTS (cases); i++) {
    g_autofree char *error = sonar_test_run_pipeline (cases[i].launch);
    g_test_message ("%s -> %s", cases[i].launch, error);
    g_assert_nonnull (error);
    if (!strstr (error, cases[i].expected) && !(cases[i].alternative
            && strstr (error, cases[i].alternative)))
      g_error ("\"%s\" does not say \"%s\"", error, cases[i].expected);
  }
}

/* The farthest range of an energyscape stream's image. */
static double
image_range_max (GstSample * sample)
{
  const GstStructure *s = gst_caps_get_structure (gst_sample_get_caps
      (sample), 0);
  double first, step;
  int n;

  g_assert_true (gst_structure_get (s, "range-first", G_TYPE_DOUBLE, &first,
          "range-step", G_TYPE_DOUBLE, &step, "n-range", G_TYPE_INT, &n,
          NULL));
  return first + (n - 1) * step;
}

/* By default the image reaches what one ping records in whole (sonarsrc
 * max-range=2: 2 m); a range-max beyond the window is clamped at the
 * window's end with a warning that says so, not an error. */
static void
test_range_fits_the_recording (void)
{
  const char *chain = "sonarsrc num-buffers=1 max-range=2 ! dopplerbank "
      "velocity-min=0 velocity-max=0 ! mimobeamform %s ! appsink name=sink "
      "sync=false";
  g_autofree char *by_default = g_strdup_printf (chain, "");
  g_autofree char *too_far = g_strdup_printf (chain, "range-max=50");
  SonarTestRun *run = sonar_test_run (by_default);
  double reach;

  g_assert_cmpstr (run->error_text, ==, NULL);
  g_assert_cmpuint (run->warnings->len, ==, 0);
  reach = image_range_max (g_ptr_array_index (sink_samples (run), 0));
  g_test_message ("default image reaches %.4f m", reach);
  g_assert_cmpfloat (reach, <=, 2.0);
  g_assert_cmpfloat (reach, >, 2.0 - 0.001);
  sonar_test_run_free (run);

  run = sonar_test_run (too_far);
  g_assert_cmpstr (run->error_text, ==, NULL);
  g_assert_cmpuint (run->warnings->len, ==, 1);
  g_test_message ("%s", (char *) g_ptr_array_index (run->warnings, 0));
  /* 0.5 c ping-length / rate = 3.5787 m: the window of a 2 m recording. */
  g_assert_nonnull (strstr (g_ptr_array_index (run->warnings, 0),
          "range-max 50 m is beyond what one ping records: the image stops "
          "at 3.578 m, the end of the 9390-sample window"));
  reach = image_range_max (g_ptr_array_index (sink_samples (run), 0));
  g_assert_cmpfloat (reach, <=, 3.578);
  g_assert_cmpfloat (reach, >, 3.578 - 0.001);
  sonar_test_run_free (run);
}

/* A grid coarser than the array's beam is said once at start, in a
 * warning that names what an echo between its directions loses and the
 * step that keeps it within 6 dB; the default fan's 1 degree and a 3-D
 * 2-degree grid (the hemisphere's) say nothing. So are a coarse pass on a
 * sub-band that loses more than 10 dB and focus zones too few for the
 * image's ranges. */
static void
test_coarse_grid_warning (void)
{
  const char *chain = "sonarsrc num-buffers=1 max-range=2 ! dopplerbank "
      "velocity-min=0 velocity-max=0 ! mimobeamform %s ! appsink name=sink "
      "sync=false";
  const struct
  {
    const char *grid, *warning;
  } cases[] = {
    {"", NULL},
    {"azimuth-count=61", NULL},
    {"azimuth-count=46", "the image's 4 degree azimuth step is coarser "
          "than the array's beam: a point halfway between two directions is "
          "imaged 10.3 dB below its peak at boresight, where its sidelobes "
          "can pass as objects; a step of at most 3.04 degrees (61 "
          "directions) keeps that within 6 dB"},
    {"azimuth-min=-30 azimuth-max=30 azimuth-count=31 elevation-min=-30 "
          "elevation-max=30 elevation-count=31", NULL},
    {"azimuth-min=-30 azimuth-max=30 azimuth-count=21 elevation-min=-30 "
          "elevation-max=30 elevation-count=21", "the image's 3 x 3 degree "
          "steps (azimuth x elevation) are coarser than the array's beam: a "
          "point at the centre of a cell of four directions is imaged 8.4 dB "
          "below its peak at boresight, where its sidelobes can pass as "
          "objects; steps of at most 2.54 x 2.54 degrees (25 x 25 "
          "directions) keep that within 6 dB"},
    /* A coarse pass on a sub-band is said as well once it loses more than
     * 10 dB: 0.01, the property's minimum, found nothing. */
    /* And focus zones far too few for the ranges (0.01 m: nothing found;
     * 0.1 m, 0.64 turns at the zones' ends, is not warned of). */
    {"range-min=0.01", "mimobeamform: from range-min 0.01 m to 2 m, 4 focus "
          "zones leave the array's outer elements 6.7 turns out of phase at "
          "the zones' ends (at 80000 Hz): images blur there and echoes may "
          "be missed; range-min=0.24 with 4 zones (0.017 with 64) keeps it "
          "within a quarter turn"},
    {"range-min=0.1", NULL},
    {"coarse-band=0.2", NULL},
    {"coarse-band=0.01", "mimobeamform: coarse-band 0.01: the coarse pass "
          "sees each echo 20.0 dB weaker than the whole band does, and may "
          "miss any echo less than that over wardcluster's threshold (a "
          "share of at least 0.10 keeps the loss within 10 dB)"},
  };

  for (guint c = 0; c < G_N_ELEMENTS (cases); c++) {
    g_autofree char *launch = g_strdup_printf (chain, cases[c].grid);
    SonarTestRun *run = sonar_test_run (launch);

    g_assert_cmpstr (run->error_text, ==, NULL);
    if (!cases[c].warning) {
      g_assert_cmpuint (run->warnings->len, ==, 0);
    } else {
      g_assert_cmpuint (run->warnings->len, ==, 1);
      g_test_message ("%s", (char *) g_ptr_array_index (run->warnings, 0));
      g_assert_nonnull (strstr (g_ptr_array_index (run->warnings, 0),
              cases[c].warning));
    }
    /* The image is made all the same. */
    g_assert_cmpuint (sink_samples (run)->len, ==, 1);
    sonar_test_run_free (run);
  }
}

/* A ping of sonarsrc's default scene (interleaved) and its set-up. */
static GstBuffer *
sonarsrc_ping (const char *launch, guint index, SonarSetup ** setup)
{
  GstHarness *h = gst_harness_new_parse (launch);
  GstBuffer *buffer = NULL;
  GstEvent *event;

  gst_harness_play (h);
  for (guint k = 0; k <= index; k++) {
    if (buffer)
      gst_buffer_unref (buffer);
    buffer = gst_harness_pull (h);
    g_assert_nonnull (buffer);
  }
  *setup = NULL;
  while ((event = gst_harness_try_pull_event (h))) {
    if (sonar_event_is_setup (event) && !*setup)
      *setup = sonar_setup_from_event (event, NULL);
    gst_event_unref (event);
  }
  g_assert_nonnull (*setup);
  gst_harness_teardown (h);
  return buffer;
}

/* A harness around @launch fed like sonarsrc feeds it: caps, the set-up
 * event; @bus receives its messages. */
static GstHarness *
fed_harness (const char *launch, const SonarSetup * setup, GstBus ** bus)
{
  GstHarness *h = gst_harness_new_parse (launch);

  *bus = gst_bus_new ();
  gst_element_set_bus (h->element, *bus);
  gst_harness_play (h);
  gst_harness_set_src_caps_str (h, RECORDING_CAPS);
  g_assert_true (gst_harness_push_event (h, sonar_setup_event_new (setup)));
  return h;
}

/* The text of the first warning on @bus, or NULL. */
static char *
pop_warning (GstBus * bus)
{
  GstMessage *msg = gst_bus_pop_filtered (bus, GST_MESSAGE_WARNING);
  GError *error = NULL;
  char *text;

  if (!msg)
    return NULL;
  gst_message_parse_warning (msg, &error, NULL);
  text = g_strdup (error->message);
  g_error_free (error);
  gst_message_unref (msg);
  return text;
}

static GstBuffer *
buffer_from (const float *data, gsize n)
{
  return gst_buffer_new_memdup (data, sizeof (float) * n);
}

/* Pushes one ping through the imaging harness and returns its image
 * (g_free). */
static float *
image_of (GstHarness * h, const float *ping, gsize n, gsize * pixels)
{
  GstBuffer *out;
  GstMapInfo map;
  float *image;

  g_assert_cmpint (gst_harness_push (h, buffer_from (ping, n)), ==,
      GST_FLOW_OK);
  out = gst_harness_pull (h);
  g_assert_nonnull (out);
  gst_buffer_map (out, &map, GST_MAP_READ);
  g_assert_cmpuint (map.size, >, sizeof (SonarEnergyscapeHeader));
  *pixels = (map.size - sizeof (SonarEnergyscapeHeader)) / sizeof (float);
  image = g_memdup2 (map.data + sizeof (SonarEnergyscapeHeader),
      sizeof (float) * *pixels);
  gst_buffer_unmap (out, &map);
  gst_buffer_unref (out);
  return image;
}

static gboolean
all_finite (const float *x, gsize n)
{
  for (gsize i = 0; i < n; i++)
    if (!isfinite (x[i]))
      return FALSE;
  return TRUE;
}

/* The elements allocate as downstream asks (the ALLOCATION query): here
 * memory aligned to 4096 bytes, which no default allocation gives. */
static void
test_allocation_from_downstream (void)
{
  g_autoptr (SonarSetup) setup = NULL;
  GstBuffer *ping = sonarsrc_ping ("sonarsrc", 0, &setup);
  GstAllocationParams params;
  GstBus *bus;
  GstHarness *h = fed_harness ("dopplerbank velocity-min=-0.3 "
      "velocity-max=0.3 ! mimobeamform azimuth-count=61 range-max=3", setup,
      &bus);
  GstBuffer *out;

  gst_allocation_params_init (&params);
  params.align = 4095;
  gst_harness_set_propose_allocator (h, NULL, &params);
  g_assert_cmpint (gst_harness_push (h, ping), ==, GST_FLOW_OK);
  out = gst_harness_pull (h);
  g_assert_nonnull (out);
  g_assert_cmpuint (gst_buffer_n_memory (out), ==, 1);
  {
    GstMapInfo map;
    gst_buffer_map (out, &map, GST_MAP_READ);
    g_assert_cmpuint ((guintptr) map.data % 4096, ==, 0);
    g_assert_cmpuint (map.size, >, sizeof (SonarEnergyscapeHeader));
    gst_buffer_unmap (out, &map);
  }
  gst_buffer_unref (out);
  gst_harness_teardown (h);
  gst_object_unref (bus);
}

/* The image of @work (@n samples) whose samples at @bad[@count] a
 * recording should not hold: a warning holding @what and @where, and the
 * image of @work with zeros there (which @work then holds). */
static void
assert_read_as_zero (GstHarness * h, GstBus * bus, float *work, gsize n,
    const gsize * bad, guint count, const char *what, const char *where)
{
  gsize pixels;
  float *image = image_of (h, work, n, &pixels), *zeroed;
  g_autofree char *warning = pop_warning (bus);

  g_assert_true (all_finite (image, pixels));
  g_test_message ("%s: warning \"%s\"", what, warning);
  g_assert_nonnull (warning);
  g_assert_nonnull (strstr (warning, what));
  g_assert_nonnull (strstr (warning, where));
  for (guint k = 0; k < count; k++)
    work[bad[k]] = 0.0f;
  zeroed = image_of (h, work, n, &pixels);
  g_assert_cmpmem (image, sizeof (float) * pixels, zeroed,
      sizeof (float) * pixels);
  g_free (zeroed);
  g_free (image);
}

/* 4a. Extreme sample values through dopplerbank ! mimobeamform. */
static void
test_extreme_inputs (void)
{
  g_autoptr (SonarSetup) setup = NULL;
  GstBuffer *ping = sonarsrc_ping ("sonarsrc", 0, &setup);
  const gsize n = (gsize) setup->ping_length * 32;
  float *data = g_new (float, n), *work = g_new (float, n);
  GstBus *bus;
  GstHarness *h = fed_harness ("dopplerbank velocity-min=-0.3 "
      "velocity-max=0.3 ! mimobeamform azimuth-count=61 range-max=3", setup,
      &bus);
  float *normal, *image;
  gsize pixels, peak;

  g_assert_cmpuint (gst_buffer_get_size (ping), ==, sizeof (float) * n);
  gst_buffer_extract (ping, 0, data, sizeof (float) * n);
  gst_buffer_unref (ping);

  normal = image_of (h, data, n, &pixels);
  g_assert_true (all_finite (normal, pixels));
  peak = peak_index (normal, pixels);
  g_assert_cmpfloat (normal[peak], >, 0.0f);
  g_assert_null (pop_warning (bus));

  /* Silence: exact zeros. */
  memset (work, 0, sizeof (float) * n);
  image = image_of (h, work, n, &pixels);
  for (gsize i = 0; i < pixels; i++)
    g_assert_cmpfloat (image[i], ==, 0.0f);
  g_free (image);

  /* NaN and infinities: a warning, and the image of the ping with zeros
   * there. */
  memcpy (work, data, sizeof (float) * n);
  {
    const gsize bad[] = { 1000 * 32 + 3, 5000 * 32 + 17, 9000 * 32 + 31 };
    work[bad[0]] = NAN;
    work[bad[1]] = INFINITY;
    work[bad[2]] = -INFINITY;
    assert_read_as_zero (h, bus, work, n, bad, G_N_ELEMENTS (bad),
        "NaN or infinite", "(3 in ping 2)");
  }

  /* Glitches, single samples of 10^5 (a float recording's garbage, 10^5
   * times the echoes: it hid objects) and 10^19 in every third channel:
   * a warning, and the image of the ping with zeros there. */
  memcpy (work, data, sizeof (float) * n);
  {
    gsize bad[11];
    for (guint j = 0; j < 32; j += 3) {
      bad[j / 3] = (gsize) (2000 + 37 * j) * 32 + j;
      work[bad[j / 3]] = j % 2 ? 1e19f : 1e5f;
    }
    assert_read_as_zero (h, bus, work, n, bad, G_N_ELEMENTS (bad),
        "The recording holds glitches", "(11 in ping 4, up to 1e+19)");
  }

  /* A microphone with a hum 40 dB over the noise where no echo is: a
   * warning, and the image of the ping with that microphone at zero. */
  memcpy (work, data, sizeof (float) * n);
  {
    const gsize length = setup->ping_length;
    g_autofree gsize *bad = g_new (gsize, length);
    double rms = 0.0;
    for (gsize i = 0; i < length; i++)
      rms += (double) data[i * 32 + 5] * data[i * 32 + 5];
    rms = sqrt (rms / length);
    for (gsize i = 0; i < length; i++) {
      bad[i] = i * 32 + 5;
      work[bad[i]] += (float) (100.0 * rms * sin (2.0 * G_PI * 40000.0 /
              setup->sample_rate * i));
    }
    assert_read_as_zero (h, bus, work, n, bad, length,
        "The recording holds loud microphones", "(1 in ping 6, the first "
        "microphone 5, up to ");
  }

  /* Tiny: the same image scaled, the peak in the same place. */
  for (gsize i = 0; i < n; i++)
    work[i] = data[i] * 1e-30f;
  image = image_of (h, work, n, &pixels);
  g_assert_true (all_finite (image, pixels));
  g_test_message ("ping x 1e-30: peak %.4g at pixel %" G_GSIZE_FORMAT
      " (normal ping: %.4g at %" G_GSIZE_FORMAT ")",
      image[peak_index (image, pixels)], peak_index (image, pixels),
      normal[peak], peak);
  g_assert_cmpuint (peak_index (image, pixels), ==, peak);
  g_assert_cmpfloat (fabs (image[peak] / (normal[peak] * 1e-30) - 1.0), <,
      1e-3);
  g_free (image);

  g_assert_null (pop_warning (bus));
  gst_harness_teardown (h);
  gst_object_unref (bus);
  g_free (normal);
  g_free (data);
  g_free (work);
}

/* 4b. A recording cut anywhere gives the spectra of whole pings; a ping
 * cut short by the end of the stream is reported. */
static void
test_chunked_recording (void)
{
  g_autoptr (SonarSetup) setup = NULL;
  g_autoptr (SonarSetup) setup1 = NULL;
  GstBuffer *pings[2];
  GstBus *bus_whole, *bus_chunks;
  GstHarness *whole, *chunks;
  const char *launch = "dopplerbank velocity-min=0 velocity-max=0";
  gsize n, total, frame = 32 * sizeof (float);
  guint8 *stream;
  guint outputs = 0;
  g_autofree char *warning = NULL;

  pings[0] = sonarsrc_ping ("sonarsrc scene=fig9", 0, &setup);
  pings[1] = sonarsrc_ping ("sonarsrc scene=fig9", 1, &setup1);
  g_assert_true (sonar_setup_equal (setup, setup1));
  n = gst_buffer_get_size (pings[0]);
  g_assert_cmpuint (n, ==, frame * setup->ping_length);
  /* Two pings and 500 samples of a third. */
  total = 2 * n + 500 * frame;
  stream = g_malloc0 (total);
  gst_buffer_extract (pings[0], 0, stream, n);
  gst_buffer_extract (pings[1], 0, stream + n, n);
  memcpy (stream + 2 * n, stream, 500 * frame);

  whole = fed_harness (launch, setup, &bus_whole);
  chunks = fed_harness (launch, setup, &bus_chunks);
  for (guint k = 0; k < 2; k++)
    g_assert_cmpint (gst_harness_push (whole, pings[k]), ==, GST_FLOW_OK);
  for (gsize offset = 0; offset < total; offset += 1000 * frame) {
    const gsize size = MIN (1000 * frame, total - offset);
    g_assert_cmpint (gst_harness_push (chunks,
            gst_buffer_new_memdup (stream + offset, size)), ==, GST_FLOW_OK);
  }
  g_assert_true (gst_harness_push_event (chunks, gst_event_new_eos ()));

  for (guint k = 0; k < 2; k++) {
    GstBuffer *a = gst_harness_pull (whole), *b = gst_harness_pull (chunks);
    GstMapInfo ma, mb;
    double worst = 0, largest = 0;

    g_assert_nonnull (a);
    g_assert_nonnull (b);
    g_assert_cmpuint (GST_BUFFER_OFFSET (b), ==, k);
    gst_buffer_map (a, &ma, GST_MAP_READ);
    gst_buffer_map (b, &mb, GST_MAP_READ);
    g_assert_cmpuint (ma.size, ==, mb.size);
    for (gsize i = 0; i < ma.size / sizeof (float); i++) {
      const float x = ((const float *) ma.data)[i];
      const float y = ((const float *) mb.data)[i];
      worst = MAX (worst, fabs (x - y));
      largest = MAX (largest, fabs (x));
    }
    g_test_message ("ping %u: chunked spectra differ by %.3g (largest value "
        "%.3g)", k, worst, largest);
    g_assert_cmpfloat (worst, <=, 1e-6 * largest);
    gst_buffer_unmap (a, &ma);
    gst_buffer_unmap (b, &mb);
    gst_buffer_unref (a);
    gst_buffer_unref (b);
    outputs++;
  }
  /* No third output from the partial ping, and a warning about it. */
  g_assert_cmpuint (gst_harness_buffers_in_queue (chunks), ==, 0);
  g_assert_cmpuint (outputs, ==, 2);
  warning = pop_warning (bus_chunks);
  g_test_message ("partial ping: warning \"%s\"", warning);
  g_assert_nonnull (warning);
  g_assert_nonnull (strstr (warning, "ended inside a ping"));
  g_assert_nonnull (strstr (warning, "500 of"));
  g_assert_null (pop_warning (bus_whole));

  gst_harness_teardown (whole);
  gst_harness_teardown (chunks);
  gst_object_unref (bus_whole);
  gst_object_unref (bus_chunks);
  g_free (stream);
}

/* @setup framed as a recording with @trigger samples before ping 0 and
 * pings @stride samples apart, @period seconds apart. */
static SonarSetup *
framed_setup (const SonarSetup * setup, guint64 trigger, double stride,
    double period)
{
  SonarSetup *framed = sonar_setup_new (&(SonarSetupParams) {
        .sample_rate = setup->sample_rate,
        .speed_of_sound = setup->speed_of_sound,
        .band_low = setup->band_low, .band_high = setup->band_high,
        .geometry = &setup->geometry,
        .waveform_length = setup->waveform_length,
        .waveforms = setup->waveforms, .ping_length = setup->ping_length,
        .ping_period = period, .ping_stride = stride,
        .trigger_offset = trigger,
        .field_of_view = setup->field_of_view}, NULL);
  g_assert_nonnull (framed);
  return framed;
}

/* A stream as wavparse gives it from chunk @first on (a seek there):
 * chunks of 1000 frames with their sample OFFSET and PTS; chunk @skip (if
 * any) is left out, a hole in the stream. */
static void
push_stream (GstHarness * h, const guint8 * stream, gsize total,
    gsize frame, double rate, gsize first, gsize skip)
{
  const gsize chunk = 1000 * frame;

  for (gsize offset = first * chunk, k = first; offset < total;
      offset += chunk, k++) {
    GstBuffer *b = gst_buffer_new_memdup (stream + offset,
        MIN (chunk, total - offset));
    if (k == skip) {
      gst_buffer_unref (b);
      continue;
    }
    GST_BUFFER_OFFSET (b) = offset / frame;
    GST_BUFFER_OFFSET_END (b) = (offset + gst_buffer_get_size (b)) / frame;
    GST_BUFFER_PTS (b) = gst_util_uint64_scale_round (offset / frame,
        GST_SECOND, (guint64) rate);
    g_assert_cmpint (gst_harness_push (h, b), ==, GST_FLOW_OK);
  }
  g_assert_true (gst_harness_push_event (h, gst_event_new_eos ()));
}

static void
assert_same_spectra (GstBuffer * a, GstBuffer * b)
{
  GstMapInfo ma, mb;

  gst_buffer_map (a, &ma, GST_MAP_READ);
  gst_buffer_map (b, &mb, GST_MAP_READ);
  g_assert_cmpmem (ma.data, ma.size, mb.data, mb.size);
  gst_buffer_unmap (a, &ma);
  gst_buffer_unmap (b, &mb);
}

/* A recording that ends before ping 0's trigger (here 2 s in, the
 * recording 5000 samples long) gives no ping, and says why. */
static void
test_stream_ends_before_first_ping (void)
{
  g_autoptr (SonarSetup) setup = NULL, framed = NULL;
  GstBuffer *ping = sonarsrc_ping ("sonarsrc scene=fig9", 0, &setup);
  const gsize frame = 32 * sizeof (float), total = 5000 * frame;
  g_autofree guint8 *stream = g_malloc0 (total);
  g_autofree char *warning = NULL;
  GstHarness *h;
  GstBus *bus;

  framed = framed_setup (setup, (guint64) (2.0 * setup->sample_rate), 0,
      0.1);
  h = fed_harness ("dopplerbank velocity-min=0 velocity-max=0", framed,
      &bus);
  push_stream (h, stream, total, frame, setup->sample_rate, 0, G_MAXSIZE);
  g_assert_cmpuint (gst_harness_buffers_in_queue (h), ==, 0);
  warning = pop_warning (bus);
  g_assert_cmpstr (warning, ==, "dopplerbank: the stream ended at 0.0111111 "
      "s, before ping 0's window, which starts at 2 s (the sensor's "
      "trigger-offset and ping-period): no ping was analysed");
  gst_buffer_unref (ping);
  gst_harness_teardown (h);
  gst_object_unref (bus);
}

/* Ping framing from the set-up: a trigger offset, samples between the
 * pings' windows, a ping period. Every ping comes out bit-identical to the
 * ping alone, numbered and time-stamped from the framing; a hole in the
 * stream drops the ping it cuts (counted, warned), and the numbering
 * keeps the gap. */
static void
test_ping_framing (void)
{
  const char *launch = "dopplerbank velocity-min=0 velocity-max=0";
  const guint trigger = 700, gap = 300;
  g_autoptr (SonarSetup) setup = NULL, setup1 = NULL, framed = NULL;
  GstBuffer *pings[2], *alone[2];
  GstHarness *h;
  GstBus *bus;
  const gsize frame = 32 * sizeof (float);
  gsize n, stride, total;
  guint8 *stream;
  g_autofree char *warning = NULL;
  guint64 dropped;

  pings[0] = sonarsrc_ping ("sonarsrc scene=fig9", 0, &setup);
  pings[1] = sonarsrc_ping ("sonarsrc scene=fig9", 1, &setup1);
  n = gst_buffer_get_size (pings[0]);
  stride = setup->ping_length + gap;
  framed = framed_setup (setup, trigger, stride, 0.1);

  /* The trigger offset, then 3 pings (ping 0, 1, 0 again) with a gap after
   * each. */
  total = (trigger + 3 * stride) * frame;
  stream = g_malloc0 (total);
  for (guint k = 0; k < 3; k++)
    gst_buffer_extract (pings[k % 2], 0, stream + (trigger + k * stride) *
        frame, n);

  h = fed_harness (launch, setup, &bus);
  for (guint k = 0; k < 2; k++) {
    g_assert_cmpint (gst_harness_push (h, gst_buffer_ref (pings[k])), ==,
        GST_FLOW_OK);
    alone[k] = gst_harness_pull (h);
  }
  gst_harness_teardown (h);
  gst_object_unref (bus);

  /* Whole. */
  h = fed_harness (launch, framed, &bus);
  push_stream (h, stream, total, frame, setup->sample_rate, 0, G_MAXSIZE);
  for (guint k = 0; k < 3; k++) {
    GstBuffer *out = gst_harness_pull (h);
    g_assert_nonnull (out);
    g_assert_cmpuint (GST_BUFFER_OFFSET (out), ==, k);
    g_assert_cmpuint (GST_BUFFER_PTS (out), ==, gst_util_uint64_scale_round
        (trigger, GST_SECOND, 450000) + k * 100 * GST_MSECOND);
    assert_same_spectra (out, alone[k % 2]);
    gst_buffer_unref (out);
  }
  g_assert_cmpuint (gst_harness_buffers_in_queue (h), ==, 0);
  g_assert_null (pop_warning (bus));
  gst_harness_teardown (h);
  gst_object_unref (bus);

  /* A hole inside ping 1 (chunk 20: samples 20000-20999). */
  h = fed_harness (launch, framed, &bus);
  push_stream (h, stream, total, frame, setup->sample_rate, 0, 20);
  for (guint k = 0; k < 3; k += 2) {
    GstBuffer *out = gst_harness_pull (h);
    g_assert_cmpuint (GST_BUFFER_OFFSET (out), ==, k);
    assert_same_spectra (out, alone[k % 2]);
    gst_buffer_unref (out);
  }
  g_assert_cmpuint (gst_harness_buffers_in_queue (h), ==, 0);
  warning = pop_warning (bus);
  g_test_message ("hole: %s", warning);
  g_assert_cmpstr (warning, ==, "Dropped ping 1, not held whole by the "
      "stream: the stream jumps from sample 20000 to 21000 (1 dropped since "
      "start)");
  g_object_get (gst_harness_find_element (h, "dopplerbank"), "dropped",
      &dropped, NULL);
  g_assert_cmpuint (dropped, ==, 1);
  gst_harness_teardown (h);
  gst_object_unref (bus);

  /* A seek into ping 0 (chunk 10: sample 10000): it is dropped, the next
   * ones come out with their own numbers and times. */
  h = fed_harness (launch, framed, &bus);
  push_stream (h, stream, total, frame, setup->sample_rate, 10, G_MAXSIZE);
  for (guint k = 1; k < 3; k++) {
    GstBuffer *out = gst_harness_pull (h);
    g_assert_cmpuint (GST_BUFFER_OFFSET (out), ==, k);
    g_assert_cmpuint (GST_BUFFER_PTS (out), ==, gst_util_uint64_scale_round
        (trigger, GST_SECOND, 450000) + k * 100 * GST_MSECOND);
    assert_same_spectra (out, alone[k % 2]);
    gst_buffer_unref (out);
  }
  g_clear_pointer (&warning, g_free);
  warning = pop_warning (bus);
  g_test_message ("seek: %s", warning);
  g_assert_cmpstr (warning, ==, "Dropped ping 0, not held whole by the "
      "stream: the stream starts inside it (1 dropped since start)");
  gst_harness_teardown (h);
  gst_object_unref (bus);

  for (guint k = 0; k < 2; k++) {
    gst_buffer_unref (pings[k]);
    gst_buffer_unref (alone[k]);
  }
  g_free (stream);
}

/* @samples of @x in @format through GStreamer's own packing; integers as
 * x times @gain of full scale. */
static GstBuffer *
packed_samples (const float *x, gsize samples, GstAudioFormat format,
    double gain)
{
  const GstAudioFormatInfo *info = gst_audio_format_get_info (format);
  const gsize size = samples * GST_AUDIO_FORMAT_INFO_WIDTH (info) / 8;
  guint8 *out = g_malloc (size);

  if (GST_AUDIO_FORMAT_INFO_IS_FLOAT (info)) {
    g_autofree double *unpacked = g_new (double, samples);
    for (gsize i = 0; i < samples; i++)
      unpacked[i] = x[i];
    info->pack_func (info, GST_AUDIO_PACK_FLAG_NONE, unpacked, out,
        (gint) samples);
  } else {
    g_autofree gint32 *unpacked = g_new (gint32, samples);
    for (gsize i = 0; i < samples; i++)
      unpacked[i] = (gint32) lrint (CLAMP (x[i] * gain, -1.0, 1.0 - 1e-9)
          * 2147483648.0);
    info->pack_func (info, GST_AUDIO_PACK_FLAG_NONE, unpacked, out,
        (gint) samples);
  }
  return gst_buffer_new_wrapped (out, size);
}

/* Every raw sample format GStreamer knows, through its own unpacking: a
 * Fig. 9 ping's spectra as from float, within the format's quantisation
 * (32-bit floats and integers alike to 1e-6 of the largest value, 8-bit
 * to 2e-2), and full scale reported as clipped at every depth. */
static void
test_sample_formats (void)
{
  const struct
  {
    GstAudioFormat format;
    double tolerance;
  } cases[] = {
    {GST_AUDIO_FORMAT_U8, 2e-2}, {GST_AUDIO_FORMAT_S8, 2e-2},
    {GST_AUDIO_FORMAT_S16BE, 1e-3}, {GST_AUDIO_FORMAT_U16LE, 1e-3},
    {GST_AUDIO_FORMAT_S20LE, 1e-4}, {GST_AUDIO_FORMAT_S24_32LE, 1e-5},
    {GST_AUDIO_FORMAT_U32BE, 1e-6}, {GST_AUDIO_FORMAT_F32BE, 1e-6},
    {GST_AUDIO_FORMAT_F64BE, 1e-6},
  };
  g_autoptr (SonarSetup) setup = NULL;
  GstBuffer *ping = sonarsrc_ping ("sonarsrc scene=fig9", 0, &setup);
  const gsize samples = gst_buffer_get_size (ping) / sizeof (float);
  g_autofree float *x = g_new (float, samples);
  GstBuffer *reference;
  GstMapInfo a;
  double peak = 0.0, gain;
  GstHarness *h;
  GstBus *bus;

  gst_buffer_extract (ping, 0, x, samples * sizeof (float));
  for (gsize i = 0; i < samples; i++)
    peak = MAX (peak, fabsf (x[i]));
  gain = 0.9 / peak;
  /* The reference: float samples as the integers read them. */
  for (gsize i = 0; i < samples; i++)
    x[i] *= gain;
  h = fed_harness ("dopplerbank velocity-min=0 velocity-max=0", setup, &bus);
  gst_harness_set_src_caps_str (h, "audio/x-raw, format=F32LE, "
      "layout=interleaved, rate=450000, channels=32");
  g_assert_cmpint (gst_harness_push (h, gst_buffer_new_memdup (x,
              samples * sizeof (float))), ==, GST_FLOW_OK);
  reference = gst_harness_pull (h);
  gst_buffer_map (reference, &a, GST_MAP_READ);
  gst_harness_teardown (h);
  gst_object_unref (bus);
  gst_buffer_unref (ping);

  for (guint c = 0; c < G_N_ELEMENTS (cases); c++) {
    const char *name = gst_audio_format_to_string (cases[c].format);
    g_autofree char *caps = g_strdup_printf ("audio/x-raw, format=%s, "
        "layout=interleaved, rate=450000, channels=32", name);
    double worst = 0.0, largest = 0.0;
    GstBuffer *out;
    GstMapInfo b;

    h = fed_harness ("dopplerbank velocity-min=0 velocity-max=0", setup,
        &bus);
    gst_harness_set_src_caps_str (h, caps);
    g_assert_cmpint (gst_harness_push (h, packed_samples (x, samples,
                cases[c].format, 1.0)), ==, GST_FLOW_OK);
    out = gst_harness_pull (h);
    g_assert_nonnull (out);
    gst_buffer_map (out, &b, GST_MAP_READ);
    g_assert_cmpuint (a.size, ==, b.size);
    for (gsize i = 0; i < a.size / sizeof (float); i++) {
      worst = MAX (worst, fabs (((const float *) a.data)[i] -
              ((const float *) b.data)[i]));
      largest = MAX (largest, fabs (((const float *) a.data)[i]));
    }
    gst_buffer_unmap (out, &b);
    gst_buffer_unref (out);
    g_test_message ("%s: spectra differ by %.3g of their largest value",
        name, worst / largest);
    g_assert_cmpfloat (worst, <, cases[c].tolerance * largest);
    g_assert_null (pop_warning (bus));
    if (!GST_AUDIO_FORMAT_INFO_IS_FLOAT (gst_audio_format_get_info
            (cases[c].format))) {
      const float kept[3] = { x[40000], x[50002], x[60001] };
      g_autofree char *clipped = NULL;
      /* Three samples at full scale, either side. */
      x[40000] = x[60001] = 2.0f;
      x[50002] = -2.0f;
      g_assert_cmpint (gst_harness_push (h, packed_samples (x, samples,
                  cases[c].format, 1.0)), ==, GST_FLOW_OK);
      gst_buffer_unref (gst_harness_pull (h));
      clipped = pop_warning (bus);
      g_assert_cmpstr (clipped, ==, "The recording is clipped: 3 samples "
          "of ping 1 at full scale; their echoes are distorted (lower the "
          "recording's gain)");
      x[40000] = kept[0];
      x[50002] = kept[1];
      x[60001] = kept[2];
    }
    gst_harness_teardown (h);
    gst_object_unref (bus);
  }
  gst_buffer_unmap (reference, &a);
  gst_buffer_unref (reference);
}

/* A plain WAV's caps (no channel-mask) and integer samples are taken as
 * they come; a recording that does not fit the sensor is refused with a
 * message naming both. */
static void
test_recording_formats (void)
{
  g_autoptr (SonarSetup) setup = NULL;
  GstBuffer *ping = sonarsrc_ping ("sonarsrc scene=fig9", 0, &setup);
  const gsize samples = gst_buffer_get_size (ping) / sizeof (float);
  g_autofree gint16 *pcm = g_new (gint16, samples);
  GstBuffer *as_float, *as_pcm;
  GstMapInfo map, a, b;
  double worst = 0.0, largest = 0.0, peak = 0.0;
  GstHarness *h;
  GstBus *bus;
  g_autofree char *error = NULL;

  gst_buffer_map (ping, &map, GST_MAP_READ);
  for (gsize i = 0; i < samples; i++)
    peak = MAX (peak, fabsf (((const float *) map.data)[i]));
  for (gsize i = 0; i < samples; i++)
    pcm[i] = (gint16) lrint (((const float *) map.data)[i] / peak * 32000.0);
  gst_buffer_unmap (ping, &map);

  h = fed_harness ("dopplerbank velocity-min=0 velocity-max=0", setup, &bus);
  gst_harness_set_src_caps_str (h, "audio/x-raw, format=F32LE, "
      "layout=interleaved, rate=450000, channels=32");
  g_assert_cmpint (gst_harness_push (h, ping), ==, GST_FLOW_OK);
  as_float = gst_harness_pull (h);
  gst_harness_set_src_caps_str (h, "audio/x-raw, format=S16LE, "
      "layout=interleaved, rate=450000, channels=32");
  g_assert_cmpint (gst_harness_push (h, gst_buffer_new_memdup (pcm,
              samples * sizeof (gint16))), ==, GST_FLOW_OK);
  as_pcm = gst_harness_pull (h);
  g_assert_nonnull (as_float);
  g_assert_nonnull (as_pcm);
  gst_buffer_map (as_float, &a, GST_MAP_READ);
  gst_buffer_map (as_pcm, &b, GST_MAP_READ);
  g_assert_cmpuint (a.size, ==, b.size);
  for (gsize i = 0; i < a.size / sizeof (float); i++) {
    const double x = ((const float *) a.data)[i] / peak * 32000.0 / 32768.0;
    worst = MAX (worst, fabs (x - ((const float *) b.data)[i]));
    largest = MAX (largest, fabs (x));
  }
  g_test_message ("16-bit spectra differ by %.3g of their largest value",
      worst / largest);
  /* 16-bit quantisation: -96 dB per sample, far less over a ping. */
  g_assert_cmpfloat (worst, <, 1e-3 * largest);
  gst_buffer_unmap (as_float, &a);
  gst_buffer_unmap (as_pcm, &b);
  gst_buffer_unref (as_float);
  gst_buffer_unref (as_pcm);
  g_assert_null (pop_warning (bus));
  /* Three samples at full scale: clipped, said once. */
  pcm[5] = pcm[900] = 32767;
  pcm[1000] = -32768;
  g_assert_cmpint (gst_harness_push (h, gst_buffer_new_memdup (pcm,
              samples * sizeof (gint16))), ==, GST_FLOW_OK);
  gst_buffer_unref (gst_harness_pull (h));
  {
    g_autofree char *clipped = pop_warning (bus);
    g_assert_cmpstr (clipped, ==, "The recording is clipped: 3 samples of "
        "ping 2 at full scale; their echoes are distorted (lower the "
        "recording's gain)");
  }
  gst_harness_teardown (h);
  gst_object_unref (bus);

  /* 31 channels for a 32-microphone sensor. */
  h = fed_harness ("dopplerbank velocity-min=0 velocity-max=0", setup, &bus);
  gst_harness_set_src_caps_str (h, "audio/x-raw, format=F32LE, "
      "layout=interleaved, rate=450000, channels=31");
  g_assert_cmpint (gst_harness_push (h, gst_buffer_new_allocate (NULL,
              31 * sizeof (float) * 100, NULL)), ==,
      GST_FLOW_NOT_NEGOTIATED);
  {
    GstMessage *msg = gst_bus_pop_filtered (bus, GST_MESSAGE_ERROR);
    GError *e = NULL;
    g_assert_nonnull (msg);
    gst_message_parse_error (msg, &e, NULL);
    error = g_strdup (e->message);
    g_error_free (e);
    gst_message_unref (msg);
  }
  gst_harness_teardown (h);
  gst_object_unref (bus);
  g_test_message ("%s", error);
  g_assert_nonnull (strstr (error, "dopplerbank: the recording has 31 "
          "channels at 450000 Hz, but the sensor description has 32 "
          "microphones at 450000 Hz"));
}

/* 5. The datacube: one record per bank velocity, in order; their maximum
 * is the detection image over the same hypotheses, and the record at 0 m/s
 * is the fixed-mode image. */
static void
test_datacube (void)
{
  const char *source = "sonarsrc num-buffers=1 ! dopplerbank "
      "velocity-min=-0.1 velocity-max=0.1 velocity-step=0.05 ! mimobeamform "
      "azimuth-count=31 range-max=3";
  g_autofree char *cube_launch = g_strdup_printf ("%s mode=datacube ! "
      "appsink name=sink sync=false", source);
  /* Every direction imaged in full (coarse-spacing=0): then the modes agree
   * bit for bit. */
  g_autofree char *det_launch = g_strdup_printf ("%s mode=detection "
      "hypothesis-spacing=0.05 coarse-spacing=0 ! appsink name=sink sync=false",
      source);
  g_autofree char *fixed_launch = g_strdup_printf ("%s mode=fixed "
      "velocity=0 coarse-spacing=0 ! appsink name=sink sync=false", source);
  SonarTestRun *cube = sonar_test_run (cube_launch);
  SonarTestRun *det = sonar_test_run (det_launch);
  SonarTestRun *fixed = sonar_test_run (fixed_launch);
  SonarImageGrid grid;
  guint records;
  gsize pixels;
  GstMapInfo cmap, dmap, fmap;
  float *maximum;

  g_assert_null (cube->error_text);
  g_assert_null (det->error_text);
  g_assert_null (fixed->error_text);
  g_assert_cmpuint (sink_samples (cube)->len, ==, 1);
  g_assert_true (sonar_energyscape_caps_parse (gst_sample_get_caps
          (g_ptr_array_index (sink_samples (cube), 0)), &grid, &records, NULL));
  g_assert_cmpuint (records, ==, 5);
  pixels = sonar_image_grid_size (&grid);
  gst_buffer_map (run_buffer (cube, 0), &cmap, GST_MAP_READ);
  gst_buffer_map (run_buffer (det, 0), &dmap, GST_MAP_READ);
  gst_buffer_map (run_buffer (fixed, 0), &fmap, GST_MAP_READ);
  g_assert_cmpuint (cmap.size, ==, 5 * (sizeof (SonarEnergyscapeHeader) +
          sizeof (float) * pixels));
  maximum = g_new0 (float, pixels);
  for (guint r = 0; r < 5; r++) {
    const Record rec = record_at (&cmap, &grid, r);
    SonarImageGrid header_grid;
    g_assert_cmpmem (rec.header->magic, 8, SONAR_ENERGYSCAPE_MAGIC, 8);
    g_assert_true (sonar_energyscape_header_parse (rec.header,
            &header_grid));
    assert_grid_equal (&header_grid, &grid);
    g_assert_cmpuint (rec.header->ping_index, ==, 0);
    g_assert_cmpint (rec.header->emitter, ==, -1);
    g_test_message ("record %u: velocity %+.2f m/s", r,
        rec.header->velocity);
    g_assert_cmpfloat (fabs (rec.header->velocity - (-0.1 + 0.05 * r)), <,
        1e-9);
    for (gsize i = 0; i < pixels; i++)
      maximum[i] = MAX (maximum[i], rec.pixels[i]);
    if (r == 2) {
      const Record f = record_at (&fmap, &grid, 0);
      g_assert_cmpfloat (fabs (f.header->velocity), <, 1e-9);
      g_assert_cmpmem (rec.pixels, sizeof (float) * pixels, f.pixels,
          sizeof (float) * pixels);
    }
  }
  {
    const Record d = record_at (&dmap, &grid, 0);
    g_assert_true (isnan (d.header->velocity));
    g_assert_cmpmem (maximum, sizeof (float) * pixels, d.pixels,
        sizeof (float) * pixels);
  }
  g_free (maximum);
  gst_buffer_unmap (run_buffer (cube, 0), &cmap);
  gst_buffer_unmap (run_buffer (det, 0), &dmap);
  gst_buffer_unmap (run_buffer (fixed, 0), &fmap);
  sonar_test_run_free (cube);
  sonar_test_run_free (det);
  sonar_test_run_free (fixed);
}

/* Centroids per ping of the default scene's 6 pings through wardcluster
 * @props; with @tune, wardcluster's threshold is set to -1 dB once the
 * first ping is out. */
#define TUNE_PINGS 6
static void
centroid_counts (const char *props, gboolean tune, guint counts[TUNE_PINGS])
{
  GError *error = NULL;
  g_autofree char *launch = g_strdup_printf ("sonarsrc num-buffers=%d ! "
      "dopplerbank velocity-min=-1.5 velocity-max=1.5 ! mimobeamform ! "
      "wardcluster name=w %s ! appsink name=sink sync=false max-buffers=1",
      TUNE_PINGS, props);
  GstElement *pipeline = gst_parse_launch (launch, &error);
  GstElement *sink, *ward;
  GstSample *sample;
  guint pings = 0;

  g_assert_no_error (error);
  sink = gst_bin_get_by_name (GST_BIN (pipeline), "sink");
  ward = gst_bin_get_by_name (GST_BIN (pipeline), "w");
  gst_element_set_state (pipeline, GST_STATE_PLAYING);
  while ((sample = gst_app_sink_pull_sample (GST_APP_SINK (sink)))) {
    g_assert_cmpuint (pings, <, TUNE_PINGS);
    counts[pings++] = sonar_buffer_get_centroids_meta (gst_sample_get_buffer
        (sample))->n_centroids;
    gst_sample_unref (sample);
    if (tune && pings == 1)
      g_object_set (ward, "threshold", -1.0, NULL);
  }
  g_assert_cmpuint (pings, ==, TUNE_PINGS);
  gst_element_set_state (pipeline, GST_STATE_NULL);
  gst_object_unref (ward);
  gst_object_unref (sink);
  gst_object_unref (pipeline);
}

/* wardcluster's thresholds are tunable while playing: set between pings,
 * they hold from the next ping on, with no restart. The default scene's
 * three objects give three centroids; 1 dB below each ping's strongest
 * pixel, fewer: after the change (a ping or two in flight aside), every
 * ping has the centroids of a run made at -1 dB from the start. */
static void
test_tune_while_playing (void)
{
  guint tuned[TUNE_PINGS], at_default[TUNE_PINGS], reference[TUNE_PINGS];
  gboolean visible = FALSE;

  centroid_counts ("", TRUE, tuned);
  centroid_counts ("", FALSE, at_default);
  centroid_counts ("threshold=-1", FALSE, reference);

  g_assert_cmpuint (tuned[0], ==, at_default[0]);
  g_assert_cmpuint (at_default[0], ==, 3);
  for (guint p = 3; p < TUNE_PINGS; p++) {
    g_assert_cmpuint (tuned[p], ==, reference[p]);
    visible |= reference[p] < at_default[p];
  }
  g_assert_true (visible);
}

/* The checksum of each output buffer of @launch (with "%s" for the
 * properties of its element "e", given @props, and ending in "appsink
 * name=sink"): TUNE_PINGS of them. With @tune ("name=value ..."), those
 * properties are set on "e" once the first ping is out. */
static void
output_sums (const char *launch_format, const char *props, const char *tune,
    char *sums[TUNE_PINGS])
{
  GError *error = NULL;
  g_autofree char *launch = g_strdup_printf (launch_format, props);
  GstElement *pipeline = gst_parse_launch (launch, &error);
  GstElement *sink, *element;
  GstSample *sample;
  guint pings = 0;

  g_assert_no_error (error);
  sink = gst_bin_get_by_name (GST_BIN (pipeline), "sink");
  element = gst_bin_get_by_name (GST_BIN (pipeline), "e");
  gst_element_set_state (pipeline, GST_STATE_PLAYING);
  while ((sample = gst_app_sink_pull_sample (GST_APP_SINK (sink)))) {
    GstMapInfo map;

    g_assert_cmpuint (pings, <, TUNE_PINGS);
    gst_buffer_map (gst_sample_get_buffer (sample), &map, GST_MAP_READ);
    sums[pings++] = g_compute_checksum_for_data (G_CHECKSUM_SHA256,
        map.data, map.size);
    gst_buffer_unmap (gst_sample_get_buffer (sample), &map);
    gst_sample_unref (sample);
    if (tune && pings == 1) {
      g_auto (GStrv) settings = g_strsplit (tune, " ", -1);
      for (guint k = 0; settings[k]; k++) {
        g_auto (GStrv) pair = g_strsplit (settings[k], "=", 2);
        gst_util_set_object_arg (G_OBJECT (element), pair[0], pair[1]);
      }
    }
  }
  g_assert_cmpuint (pings, ==, TUNE_PINGS);
  {
    GstBus *bus = gst_element_get_bus (pipeline);
    GstMessage *msg = gst_bus_pop_filtered (bus, GST_MESSAGE_ERROR |
        GST_MESSAGE_WARNING);
    if (msg) {
      gst_message_parse_warning (msg, &error, NULL);
      g_test_message ("%s", error->message);
      g_assert_no_error (error);
    }
    gst_object_unref (bus);
  }
  gst_element_set_state (pipeline, GST_STATE_NULL);
  gst_object_unref (element);
  gst_object_unref (sink);
  gst_object_unref (pipeline);
}

/* As wardcluster's: @tune set on element "e" of @launch_format while
 * playing gives, from the next ping on (a ping or two in flight aside),
 * the very output of a run started with it, and an output other than the
 * defaults'. */
static void
check_tunable (const char *launch_format, const char *base,
    const char *tune)
{
  g_autofree char *started = g_strdup_printf ("%s %s", base, tune);
  char *tuned[TUNE_PINGS], *at_default[TUNE_PINGS], *reference[TUNE_PINGS];
  gboolean visible = FALSE;

  g_test_message ("%s: %s", base, tune);
  output_sums (launch_format, base, tune, tuned);
  output_sums (launch_format, base, NULL, at_default);
  output_sums (launch_format, started, NULL, reference);
  g_assert_cmpstr (tuned[0], ==, at_default[0]);
  for (guint p = 3; p < TUNE_PINGS; p++) {
    g_assert_cmpstr (tuned[p], ==, reference[p]);
    visible |= g_strcmp0 (reference[p], at_default[p]) != 0;
  }
  g_assert_true (visible);
  for (guint p = 0; p < TUNE_PINGS; p++) {
    g_free (tuned[p]);
    g_free (at_default[p]);
    g_free (reference[p]);
  }
}

#define TUNE_CHAIN "sonarsrc num-buffers=6 ! dopplerbank velocity-min=-1.5 " \
  "velocity-max=1.5 ! mimobeamform "

/* velocityest's thresholds and keep-rejected: the JSON lines (detections,
 * their velocities and "valid") of a run started with them. min-variance
 * 0.9 rejects the default scene's three objects, min-coherence 0.999
 * too, coherence-pfa 1e-15 (a threshold of 0.993) some once the pooled
 * test (pooled-snr), which lets these isolated echoes through, is off;
 * kept, they are reported with "valid": false. */
static void
test_tune_velocityest (void)
{
  const char *launch = TUNE_CHAIN "! wardcluster ! velocityest name=e %s "
      "! appsink name=sink sync=false max-buffers=1";

  check_tunable (launch, "", "min-variance=0.9");
  check_tunable (launch, "", "min-coherence=0.999");
  check_tunable (launch, "", "coherence-pfa=1e-15 pooled-snr=0");
  check_tunable (launch, "coherence-pfa=1e-15", "pooled-snr=0");
  check_tunable (launch, "", "min-variance=0.9 keep-rejected=true");
  check_tunable (launch, "min-variance=0.9", "keep-rejected=true");
}

/* velocityest: min-agreeing-emitters above the emitters while playing is a
 * warning, once, and it alone is refused: it reads back as the value in
 * effect, and min-variance set with it (1: nothing valid) takes effect.
 * A later change (min-coherence, to its own value) warns of nothing. */
static void
test_tune_velocityest_refused (void)
{
  GstElement *pipeline = gst_parse_launch (TUNE_CHAIN "! wardcluster "
      "! velocityest name=e ! appsink name=sink sync=false max-buffers=1",
      NULL);
  GstElement *sink = gst_bin_get_by_name (GST_BIN (pipeline), "sink");
  GstElement *e = gst_bin_get_by_name (GST_BIN (pipeline), "e");
  GstBus *bus = gst_element_get_bus (pipeline);
  GstSample *sample;
  GstMessage *msg;
  GError *error = NULL;
  guint pings = 0, valid[TUNE_PINGS] = { 0 }, min_agreeing;
  double min_variance, min_coherence;

  gst_element_set_state (pipeline, GST_STATE_PLAYING);
  while ((sample = gst_app_sink_pull_sample (GST_APP_SINK (sink)))) {
    SonarDetectionsMeta *meta = sonar_buffer_get_detections_meta
        (gst_sample_get_buffer (sample));
    g_assert_cmpuint (pings, <, TUNE_PINGS);
    for (guint k = 0; k < meta->n_detections; k++)
      valid[pings] += meta->detections[k].valid;
    if (pings == 0)
      g_object_set (e, "min-agreeing-emitters", 9, "min-variance", 1.0, NULL);
    if (pings == 3) {
      g_object_get (e, "min-coherence", &min_coherence, NULL);
      g_object_set (e, "min-coherence", min_coherence, NULL);
    }
    pings++;
    gst_sample_unref (sample);
  }
  g_assert_cmpuint (pings, ==, TUNE_PINGS);
  g_assert_cmpuint (valid[0], ==, 3);
  g_assert_cmpuint (valid[TUNE_PINGS - 1], ==, 0);
  g_object_get (e, "min-agreeing-emitters", &min_agreeing, "min-variance",
      &min_variance, NULL);
  g_assert_cmpuint (min_agreeing, ==, 5);
  g_assert_cmpfloat (min_variance, ==, 1.0);
  msg = gst_bus_pop_filtered (bus, GST_MESSAGE_WARNING);
  g_assert_nonnull (msg);
  gst_message_parse_warning (msg, &error, NULL);
  g_assert_cmpstr (error->message, ==, "velocityest: min-agreeing-emitters "
      "is 9, but only 8 emitters enter the product: it stays 5");
  g_error_free (error);
  gst_message_unref (msg);
  g_assert_null (gst_bus_pop_filtered (bus, GST_MESSAGE_WARNING));
  gst_element_set_state (pipeline, GST_STATE_NULL);
  gst_object_unref (bus);
  gst_object_unref (e);
  gst_object_unref (sink);
  gst_object_unref (pipeline);
}

/* mimobeamform's refine-db, velocity (mode=fixed) and emitter: the
 * images of a run started with them. */
static void
test_tune_mimobeamform (void)
{
  const char *launch = "sonarsrc num-buffers=6 ! dopplerbank "
      "velocity-min=-1.5 velocity-max=1.5 ! mimobeamform name=e %s "
      "! appsink name=sink sync=false max-buffers=1";

  check_tunable (launch, "", "refine-db=5");
  check_tunable (launch, "", "refine-pfa=0.01");
  check_tunable (launch, "mode=fixed", "velocity=-1");
  check_tunable (launch, "", "emitter=3");
}

/* The next warning on @bus: its text. */
static char *
next_warning_text (GstBus * bus)
{
  GstMessage *msg = gst_bus_pop_filtered (bus, GST_MESSAGE_WARNING);
  GError *error = NULL;
  char *text;

  g_assert_nonnull (msg);
  gst_message_parse_warning (msg, &error, NULL);
  text = g_strdup (error->message);
  g_error_free (error);
  gst_message_unref (msg);
  return text;
}

/* mimobeamform: a velocity outside the bank (mode=fixed) and an emitter
 * the sensor lacks, set while playing with refine-db, are refused alone,
 * each with a warning: they read back as the values in effect (a restart
 * failed on the refused ones), the image stays at its velocity, and
 * refine-db takes effect. */
static void
test_tune_mimobeamform_refused (void)
{
  GstElement *pipeline = gst_parse_launch ("sonarsrc num-buffers=4 "
      "! dopplerbank velocity-min=-1.5 velocity-max=1.5 ! mimobeamform "
      "name=e mode=fixed velocity=0.5 ! appsink name=sink sync=false "
      "max-buffers=1", NULL);
  GstElement *sink = gst_bin_get_by_name (GST_BIN (pipeline), "sink");
  GstElement *e = gst_bin_get_by_name (GST_BIN (pipeline), "e");
  GstBus *bus = gst_element_get_bus (pipeline);
  GstSample *sample;
  guint pings = 0;
  double velocity, refine_db;
  int emitter;

  gst_element_set_state (pipeline, GST_STATE_PLAYING);
  while ((sample = gst_app_sink_pull_sample (GST_APP_SINK (sink)))) {
    SonarEnergyscapeHeader header;
    gst_buffer_extract (gst_sample_get_buffer (sample), 0, &header,
        sizeof header);
    g_assert_cmpfloat (fabs (header.velocity - 0.5), <, 1e-9);
    if (pings++ == 0)
      g_object_set (e, "velocity", 9.0, "emitter", 12, "refine-db", 30.0,
          NULL);
    gst_sample_unref (sample);
  }
  g_assert_cmpuint (pings, ==, 4);
  {
    g_autofree char *first = next_warning_text (bus);
    g_autofree char *second = next_warning_text (bus);
    g_assert_cmpstr (first, ==, "mimobeamform: emitter 12 does not exist "
        "(the sensor has 8: 0 to 7, or -1 for all): emitter stays -1");
    g_assert_cmpstr (second, ==, "mimobeamform: velocity 9 m/s is outside "
        "the Doppler bank (-1.5 to 1.5 m/s): velocity stays 0.5");
  }
  g_assert_null (gst_bus_pop_filtered (bus, GST_MESSAGE_WARNING));
  g_object_get (e, "velocity", &velocity, "emitter", &emitter, "refine-db",
      &refine_db, NULL);
  g_assert_cmpfloat (velocity, ==, 0.5);
  g_assert_cmpint (emitter, ==, -1);
  g_assert_cmpfloat (refine_db, ==, 30.0);
  gst_element_set_state (pipeline, GST_STATE_NULL);
  gst_object_unref (bus);
  gst_object_unref (e);
  gst_object_unref (sink);
  gst_object_unref (pipeline);
}

/* sonarviz's display settings: the frames of a run started with them. */
static void
test_tune_sonarviz (void)
{
  const char *launch = TUNE_CHAIN "! sonarviz name=e width=320 height=180 "
      "%s ! appsink name=sink sync=false max-buffers=1";

  check_tunable (launch, "", "dynamic-range=10");
  check_tunable (launch, "", "range-compensation=false");
  check_tunable (launch, "", "show-truth=false");
}

/* mimobeamform's directions and coarse spacing, not set, follow the
 * set-up; once a stream has started they read back what the image uses:
 * 91 x 91 directions from -90 to 90 degrees and a 6-degree coarse grid on
 * a 3-D scene (they read the fan's 181 x 1 and 3). */
static void
test_directions_read_back (void)
{
  g_autofree char *scene = sonar_test_source_path
      ("pipelines/scenes/two-walkers-3d.json");
  g_autofree char *launch = g_strdup_printf ("sonarsrc scene-file=%s "
      "num-buffers=1 ! dopplerbank velocity-min=0 velocity-max=0 ! "
      "mimobeamform name=m ! fakesink", scene);
  GstElement *pipeline = gst_parse_launch (launch, NULL);
  GstElement *m = gst_bin_get_by_name (GST_BIN (pipeline), "m");
  GstBus *bus = gst_element_get_bus (pipeline);
  GstMessage *end;
  guint n_azimuth, n_elevation;
  double elevation_min, coarse;

  g_object_get (m, "azimuth-count", &n_azimuth, NULL);
  g_assert_cmpuint (n_azimuth, ==, 181);
  gst_element_set_state (pipeline, GST_STATE_PLAYING);
  end = gst_bus_timed_pop_filtered (bus, 120 * GST_SECOND,
      GST_MESSAGE_EOS | GST_MESSAGE_ERROR);
  g_assert_nonnull (end);
  g_assert_cmpint (GST_MESSAGE_TYPE (end), ==, GST_MESSAGE_EOS);
  gst_message_unref (end);
  g_object_get (m, "azimuth-count", &n_azimuth, "elevation-count",
      &n_elevation, "elevation-min", &elevation_min, "coarse-spacing",
      &coarse, NULL);
  g_assert_cmpuint (n_azimuth, ==, 91);
  g_assert_cmpuint (n_elevation, ==, 91);
  g_assert_cmpfloat (elevation_min, ==, -90.0);
  g_assert_cmpfloat (coarse, ==, 6.0);
  gst_element_set_state (pipeline, GST_STATE_NULL);
  gst_object_unref (bus);
  gst_object_unref (m);
  gst_object_unref (pipeline);
}

int
main (int argc, char **argv)
{
  sonar_test_init_gst (&argc, &argv);
  g_test_add_func ("/elements/chain-output", test_chain_output);
  g_test_add_func ("/elements/taps", test_taps);
  g_test_add_func ("/elements/errors-are-clear", test_errors_are_clear);
  g_test_add_func ("/elements/range-fits-the-recording",
      test_range_fits_the_recording);
  g_test_add_func ("/elements/coarse-grid-warning",
      test_coarse_grid_warning);
  g_test_add_func ("/elements/extreme-inputs", test_extreme_inputs);
  g_test_add_func ("/elements/chunked-recording", test_chunked_recording);
  g_test_add_func ("/elements/ping-framing", test_ping_framing);
  g_test_add_func ("/elements/recording-formats", test_recording_formats);
  g_test_add_func ("/elements/datacube", test_datacube);
  g_test_add_func ("/elements/tune-while-playing", test_tune_while_playing);
  g_test_add_func ("/elements/tune-velocityest", test_tune_velocityest);
  g_test_add_func ("/elements/sample-formats", test_sample_formats);
  g_test_add_func ("/elements/directions-read-back",
      test_directions_read_back);
  g_test_add_func ("/elements/tune-velocityest-refused",
      test_tune_velocityest_refused);
  g_test_add_func ("/elements/tune-mimobeamform", test_tune_mimobeamform);
  g_test_add_func ("/elements/stream-ends-before-first-ping",
      test_stream_ends_before_first_ping);
  g_test_add_func ("/elements/tune-mimobeamform-refused",
      test_tune_mimobeamform_refused);
  g_test_add_func ("/elements/tune-sonarviz", test_tune_sonarviz);
  g_test_add_func ("/elements/allocation-from-downstream",
      test_allocation_from_downstream);
  return g_test_run ();
}
