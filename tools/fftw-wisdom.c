/* fftw-wisdom: writes gst/sonar-fftw-wisdom.c, the FFTW wisdom the core
 * library imports before its first plan (sonar-fftw.h).
 *
 * It makes the core's objects as the elements do, for sonarsrc's default
 * sensor at the ranges and Doppler banks given (default: 5 m, the banks
 * of the presets and of dopplerbank's default), the fan and the
 * hemisphere, the whole band and the coarse sub-bands; their run-time
 * transforms are planned with FFTW_PATIENT (--exhaustive: FFTW_EXHAUSTIVE),
 * and FFTW's wisdom is written out as a C string. Not run by the build:
 * its plans depend on this machine's timings, which is why the result is
 * committed (README: "FFTW wisdom").
 *
 *   build/tools/fftw-wisdom gst/sonar-fftw-wisdom.c
 */
#include "sonar-doppler-bank.h"
#include "sonar-fftw.h"
#include "sonar-imager.h"
#include "sonar-setup.h"
#include "sonar-spectrum.h"
#include "sonar-velocity.h"
#include "sonar-waveform.h"

#include <fftw3.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

typedef struct
{
  double v_min, v_max, v_step;
} BankRange;

/* dopplerbank's default (and fig9's), fig10's, the crossing's. */
static const BankRange bank_ranges[] = {
  {-7.0, 7.0, 0.05},
  {-0.4, 0.4, 0.02},
  {-1.5, 1.5, 0.02},
};

/* 1: the whole band; the sub-bands of sonar-bench's coarse-band sweep. */
static const double coarse_bands[] = { 1.0, 0.5, 1.0 / 3.0 };

/* Every view and sub-band's imager, and its velocity stage, on @bank. */
static gboolean
plan_imaging (SonarSetup * setup, SonarDopplerBank * bank, GError ** error)
{
  const SonarBand *band = sonar_doppler_bank_band (bank);
  static const SonarFieldOfView views[] = {
    SONAR_FIELD_OF_VIEW_FAN, SONAR_FIELD_OF_VIEW_HEMISPHERE
  };

  for (guint v = 0; v < G_N_ELEMENTS (views); v++)
    for (guint b = 0; b < G_N_ELEMENTS (coarse_bands); b++) {
      SonarImagerParams ip;
      SonarVelocityParams vp;
      SonarImager *imager;
      SonarVelocityEstimator *est;

      sonar_imager_params_init_default (&ip);
      sonar_imager_params_set_view (&ip, views[v]);
      ip.coarse_band = coarse_bands[b];
      ip.threads = 1;
      imager = sonar_imager_new (setup, band, &ip, error);
      if (!imager)
        return FALSE;
      sonar_velocity_params_init_default (&vp);
      est = sonar_velocity_estimator_new (bank, sonar_imager_grid (imager),
          &vp, error);
      sonar_imager_free (imager);
      if (!est)
        return FALSE;
      sonar_velocity_estimator_free (est);
    }
  return TRUE;
}

static gboolean
plan_setup (double max_range, GError ** error)
{
  g_autoptr (SonarSetup) setup = sonar_setup_new_default (max_range, error);

  if (!setup)
    return FALSE;
  for (guint r = 0; r < G_N_ELEMENTS (bank_ranges); r++) {
    const BankRange *br = &bank_ranges[r];
    SonarDopplerBank *bank = sonar_doppler_bank_new (setup, br->v_min,
        br->v_max, br->v_step, error);
    SonarChannelSpectra *spectra;
    gboolean ok;

    if (!bank)
      return FALSE;
    sonar_doppler_bank_prepare_ping_band (bank);
    spectra = sonar_channel_spectra_new (sonar_doppler_bank_band (bank),
        setup->geometry.n_microphones, 1, error);
    ok = spectra && plan_imaging (setup, bank, error);
    g_printerr ("max-range %g m, bank %g..%g m/s: FFT %u\n", max_range,
        br->v_min, br->v_max, sonar_doppler_bank_band (bank)->fft_size);
    sonar_channel_spectra_free (spectra);
    sonar_doppler_bank_unref (bank);
    if (!ok)
      return FALSE;
  }
  return TRUE;
}

/* The wisdom as a C string, a line of FFTW's text a line of C (it holds
 * no quotes or backslashes). */
static gboolean
write_wisdom (const char *path, const char *wisdom, GError ** error)
{
  g_autoptr (GString) c = g_string_new (NULL);
  g_auto (GStrv) lines = g_strsplit (wisdom, "\n", -1);

  g_string_append (c, "/* sonar-fftw-wisdom.c: written by tools/fftw-wisdom "
      "(README: \"FFTW\n * wisdom\"); do not edit. FFTW's wisdom for the "
      "default set-up's\n * transforms (sonar-fftw.h). */\n"
      "#include \"sonar-fftw.h\"\n\nconst char sonar_fftw_wisdom[] =\n");
  for (guint i = 0; lines[i]; i++) {
    if (!lines[i][0] && !lines[i + 1])
      break;
    if (strpbrk (lines[i], "\"\\")) {
      g_set_error (error, G_FILE_ERROR, G_FILE_ERROR_INVAL,
          "unexpected character in FFTW's wisdom: %s", lines[i]);
      return FALSE;
    }
    g_string_append_printf (c, "    \"%s\\n\"\n", lines[i]);
  }
  g_string_append (c, "    ;\n");
  return g_file_set_contents (path, c->str, c->len, error);
}

int
main (int argc, char **argv)
{
  gboolean exhaustive = FALSE;
  g_auto (GStrv) ranges = NULL;
  g_autoptr (GError) error = NULL;
  char *wisdom;
  const GOptionEntry entries[] = {
    {"exhaustive", 0, 0, G_OPTION_ARG_NONE, &exhaustive,
        "plan with FFTW_EXHAUSTIVE (default FFTW_PATIENT)", NULL},
    {"max-range", 0, 0, G_OPTION_ARG_STRING_ARRAY, &ranges,
        "a sonarsrc max-range to plan for, m (repeatable; default 5)", "M"},
    {NULL}
  };
  g_autoptr (GOptionContext) context =
      g_option_context_new ("OUTPUT.c - FFTW wisdom for the core library");

  g_option_context_add_main_entries (context, entries, NULL);
  if (!g_option_context_parse (context, &argc, &argv, &error) || argc != 2) {
    g_printerr ("%s\n", error ? error->message :
        "usage: fftw-wisdom [--exhaustive] [--max-range M]... OUTPUT.c");
    return 2;
  }
  sonar_fftw_set_planning (exhaustive ? FFTW_EXHAUSTIVE : FFTW_PATIENT);
  if (!ranges) {
    if (!plan_setup (5.0, &error))
      goto failed;
  } else {
    for (guint i = 0; ranges[i]; i++) {
      char *end;
      const double max_range = g_ascii_strtod (ranges[i], &end);

      if (*end || max_range <= 0.0) {
        g_printerr ("--max-range %s: not a positive number\n", ranges[i]);
        return 2;
      }
      if (!plan_setup (max_range, &error))
        goto failed;
    }
  }
  sonar_fftw_lock ();
  wisdom = fftwf_export_wisdom_to_string ();
  sonar_fftw_unlock ();
  if (!write_wisdom (argv[1], wisdom, &error)) {
    free (wisdom);
    goto failed;
  }
  free (wisdom);
  return 0;

failed:
  g_printerr ("fftw-wisdom: %s\n", error->message);
  return 1;
}
