/* test-memory.c: settings too large for memory are errors that name them,
 * checked before anything is allocated (max-memory, gst/sonar-memory.h). */
#include <string.h>

#include "sonar-doppler-bank.h"
#include "sonar-memory.h"
#include "sonar-test-gst.h"

/* Runs @launch, which must fail at once with exactly @expected. */
static void
assert_pipeline_error (const char *launch, const char *expected)
{
  g_autofree char *message = sonar_test_run_pipeline (launch);
  char *debug;

  g_assert_nonnull (message);
  debug = strchr (message, '\n');
  if (debug)
    *debug = '\0';
  g_assert_cmpstr (message, ==, expected);
}

/* A 20,001-velocity bank (the most allowed) needs 5.9 GiB: without the
 * check, g_malloc aborted where that much was not free. */
static void
test_bank_too_large (void)
{
  assert_pipeline_error ("sonarsrc num-buffers=1 ! dopplerbank "
      "velocity-step=0.0007 ! fakesink", "dopplerbank: a bank of 20001 "
      "velocities (velocity-min -7, velocity-max 7, velocity-step 0.0007 "
      "m/s) for 8 emitters, the direct path's fit (direct-path) and 2 "
      "output buffers of 32 microphones x 2883 band bins needs 5.9 GiB "
      "(6387260832 bytes), more than max-memory (4.0 GiB)");
  assert_pipeline_error ("sonarsrc num-buffers=1 ! dopplerbank "
      "max-memory=10000000 ! fakesink", "dopplerbank: a bank of 281 "
      "velocities (velocity-min -7, velocity-max 7, velocity-step 0.05 m/s) "
      "for 8 emitters, the direct path's fit (direct-path) and 2 output "
      "buffers of 32 microphones x 2883 band bins needs 113.6 MiB (119140512 "
      "bytes), more than max-memory (9.5 MiB)");
  assert_pipeline_error ("sonarsrc num-buffers=1 ! dopplerbank "
      "max-memory=10000000 direct-path=off ! fakesink", "dopplerbank: a "
      "bank of 281 velocities (velocity-min -7, velocity-max 7, "
      "velocity-step 0.05 m/s) for 8 emitters, no direct-path fit and 2 "
      "output buffers of 32 microphones x 2883 band bins needs 86.6 MiB "
      "(90793632 bytes), more than max-memory (9.5 MiB)");
}

/* The estimate is what the bank allocates: its templates and their split
 * spectra on the ping band, the band it prepares. */
static void
test_bank_estimate_is_exact (void)
{
  g_autoptr (SonarSetup) setup = sonar_test_default_setup (17261);
  g_autoptr (SonarDopplerBank) bank = NULL;
  guint n_velocities;
  SonarBand ping_band;
  const guint64 estimate = sonar_doppler_bank_memory (setup, -1.0, 2.0, 0.1,
      &n_velocities, &ping_band);
  guint64 allocated;

  bank = sonar_doppler_bank_new (setup, -1.0, 2.0, 0.1, NULL);
  sonar_doppler_bank_prepare_ping_band (bank);
  g_assert_cmpuint (n_velocities, ==, sonar_doppler_bank_n_velocities (bank));
  g_assert_true (sonar_band_equal (&ping_band,
          sonar_doppler_bank_band (bank)));
  allocated = (guint64) setup->geometry.n_emitters * n_velocities *
      sizeof (float) * (sonar_doppler_bank_max_length (bank) +
      2 * sonar_doppler_bank_band (bank)->n_bins);
  g_assert_cmpuint (estimate, ==, allocated);
  /* Settings the bank refuses have no estimate: its own error says why. */
  g_assert_cmpuint (sonar_doppler_bank_memory (setup, 1.0, -1.0, 0.1,
          &n_velocities, &ping_band), ==, 0);
  g_assert_cmpuint (n_velocities, ==, 0);
  g_assert_cmpuint (ping_band.n_bins, ==, 0);
}

/* A datacube of 29 images of 65536 x 1754 pixels is a 12.4 GiB buffer: the
 * pool's guint size wrapped and the imager wrote past the buffer's end. */
static void
test_image_buffer_beyond_pool (void)
{
  assert_pipeline_error ("sonarsrc num-buffers=1 ! dopplerbank "
      "velocity-step=0.5 ! mimobeamform mode=datacube azimuth-count=65536 "
      "max-memory=1099511627776 ! fakesink", "mimobeamform: 2 output "
      "buffers of 29 images (mode=datacube) of 65536 azimuths x 1 "
      "elevations x 1754 ranges (azimuth-count, elevation-count, range-min, "
      "range-max, range-resolution): an output buffer of 12.4 GiB "
      "(13334219488 bytes) is more than a GStreamer buffer pool holds "
      "(4294967295 bytes)");
  assert_pipeline_error ("sonarsrc num-buffers=1 ! dopplerbank ! "
      "mimobeamform max-memory=1000000 ! fakesink", "mimobeamform: 2 output "
      "buffers of 1 image of 181 azimuths x 1 elevations x 1754 ranges "
      "(azimuth-count, elevation-count, range-min, range-max, "
      "range-resolution) needs 2.4 MiB (2539984 bytes), more than "
      "max-memory (976.6 KiB)");
}

/* velocityest's residual search holds a ping's spectra and an image of
 * its own; without the search it holds neither. */
static void
test_residual_search_too_large (void)
{
  g_autofree char *ok = NULL;

  assert_pipeline_error ("sonarsrc num-buffers=1 ! dopplerbank ! "
      "mimobeamform ! wardcluster ! velocityest max-memory=1000000 ! "
      "fakesink", "velocityest: the residual search (residual-search) on "
      "an image of 181 azimuths x 1 elevations x 1754 ranges and 32 "
      "microphones x 2883 band bins needs 1.9 MiB (2007944 bytes), more "
      "than max-memory (976.6 KiB)");
  ok = sonar_test_run_pipeline ("sonarsrc num-buffers=1 ! dopplerbank ! "
      "mimobeamform ! wardcluster ! velocityest max-memory=1000000 "
      "residual-search=false ! fakesink");
  g_assert_null (ok);
}

static void
test_recording_window_too_large (void)
{
  assert_pipeline_error ("sonarsrc waveform-length=1048576 ping-rate=0.1 "
      "max-memory=100000000 num-buffers=1 ! fakesink", "sonarsrc: 8 "
      "emitters x 1048576-sample waveforms (waveform-length) and 32 "
      "microphones x 1061838-sample recording windows (max-range 5 m) needs "
      "1.1 GiB (1144922736 bytes), more than max-memory (95.4 MiB)");
}

static void
test_arithmetic_saturates (void)
{
  g_assert_cmpuint (sonar_memory_array (G_MAXUINT64 / 2, 3), ==,
      G_MAXUINT64);
  g_assert_cmpuint (sonar_memory_add (G_MAXUINT64, 1), ==, G_MAXUINT64);
  g_assert_cmpuint (sonar_memory_array (1u << 20, 4096), ==,
      G_GUINT64_CONSTANT (1) << 32);
}

int
main (int argc, char **argv)
{
  sonar_test_init_gst (&argc, &argv);
  g_test_add_func ("/memory/bank-too-large", test_bank_too_large);
  g_test_add_func ("/memory/bank-estimate-is-exact",
      test_bank_estimate_is_exact);
  g_test_add_func ("/memory/image-buffer-beyond-pool",
      test_image_buffer_beyond_pool);
  g_test_add_func ("/memory/residual-search-too-large",
      test_residual_search_too_large);
  g_test_add_func ("/memory/recording-window-too-large",
      test_recording_window_too_large);
  g_test_add_func ("/memory/arithmetic-saturates", test_arithmetic_saturates);
  return g_test_run ();
}
