/* sonar-waveforms: writes the emission waveforms of the MIMO sonar as a
 * waveforms file (docs/FORMATS.md, "Emission waveforms file").
 *
 * The waveforms come from sonar_waveform_generate () with the same defaults
 * as sonarsrc, so a file made without options holds exactly what sonarsrc
 * emits by default. Samples are printed with 9 significant digits, enough
 * for every float32 to read back bit for bit.
 */
#include <gio/gio.h>
#include <locale.h>
#include <stdio.h>
#include <stdlib.h>

#include "sonar-setup.h"
#include "sonar-waveform.h"

static SonarWaveformParams params;

/* GOption has no unsigned types: parse the counts and the 64-bit seed
 * ourselves, so that "-1" or "8x" are refused instead of wrapping. */
static gboolean
parse_unsigned (const gchar * option_name, const gchar * value,
    guint64 max, guint64 * number, GError ** error)
{
  g_autoptr (GError) parse_error = NULL;

  if (!g_ascii_string_to_unsigned (value, 10, 0, max, number, &parse_error)) {
    g_set_error (error, G_OPTION_ERROR, G_OPTION_ERROR_BAD_VALUE,
        "%s: %s", option_name, parse_error->message);
    return FALSE;
  }
  return TRUE;
}

static gboolean
parse_seed (const gchar * option_name, const gchar * value,
    gpointer data, GError ** error)
{
  return parse_unsigned (option_name, value, G_MAXUINT64, &params.seed,
      error);
}

static gboolean
parse_emitters (const gchar * option_name, const gchar * value,
    gpointer data, GError ** error)
{
  guint64 number;

  if (!parse_unsigned (option_name, value, G_MAXUINT, &number, error))
    return FALSE;
  params.n_emitters = (guint) number;
  return TRUE;
}

static gboolean
parse_length (const gchar * option_name, const gchar * value,
    gpointer data, GError ** error)
{
  guint64 number;

  if (!parse_unsigned (option_name, value, G_MAXUINT, &number, error))
    return FALSE;
  params.length = (guint) number;
  return TRUE;
}

static void
append_double (GString * json, double value, const char *format)
{
  char buf[G_ASCII_DTOSTR_BUF_SIZE];

  /* Locale independent: JSON wants a '.' whatever LC_NUMERIC says. */
  g_string_append (json, g_ascii_formatd (buf, sizeof (buf), format, value));
}

static GString *
waveforms_to_json (const float *waveforms)
{
  GString *json = g_string_sized_new ((gsize) params.n_emitters *
      params.length * 16 + 256);

  g_string_append_printf (json, "{\n  \"description\": \"%s waveforms, "
      "seed %" G_GUINT64_FORMAT ", %u emitters x %u samples, band ",
      sonar_waveform_kind_to_string (params.kind), params.seed,
      params.n_emitters, params.length);
  append_double (json, params.band_low, "%.17g");
  g_string_append (json, "-");
  append_double (json, params.band_high, "%.17g");
  g_string_append (json, " Hz (sonar-waveforms)\",\n  \"sample-rate\": ");
  append_double (json, params.sample_rate, "%.17g");
  g_string_append (json, ",\n  \"band\": [");
  append_double (json, params.band_low, "%.17g");
  g_string_append (json, ", ");
  append_double (json, params.band_high, "%.17g");
  g_string_append (json, "],\n  \"waveforms\": [\n");
  for (guint n = 0; n < params.n_emitters; n++) {
    const float *row = waveforms + (gsize) n * params.length;

    g_string_append (json, "    [");
    for (guint i = 0; i < params.length; i++) {
      if (i > 0)
        g_string_append (json, i % 8 ? ", " : ",\n     ");
      append_double (json, row[i], "%.9g");
    }
    g_string_append (json, n + 1 < params.n_emitters ? "],\n" : "]\n");
  }
  g_string_append (json, "  ]\n}\n");
  return json;
}

int
main (int argc, char **argv)
{
  g_autofree char *kind_name = NULL;
  g_autofree char *output = NULL;
  g_autoptr (GOptionContext) context = NULL;
  g_autoptr (GError) error = NULL;
  g_autofree float *waveforms = NULL;
  g_autoptr (GString) json = NULL;
  g_autofree char *nicks = sonar_waveform_kind_nicks (", ");
  g_autofree char *kind_help = g_strdup_printf ("Waveform kind: %s "
      "(default noise)", nicks);
  gboolean list_kinds = FALSE;
  GOptionEntry entries[] = {
    {"kind", 'k', 0, G_OPTION_ARG_STRING, &kind_name, kind_help, "KIND"},
    {"list-kinds", 0, 0, G_OPTION_ARG_NONE, &list_kinds,
        "Print each kind's name and description, one a line (tab between), "
          "and exit", NULL},
    {"seed", 's', 0, G_OPTION_ARG_CALLBACK, parse_seed,
        "Seed: the same seed gives the same waveforms (default 1)", "N"},
    {"emitters", 'n', 0, G_OPTION_ARG_CALLBACK, parse_emitters,
        "Number of emitters, one waveform each (default 8)", "N"},
    {"length", 'l', 0, G_OPTION_ARG_CALLBACK, parse_length,
        "Samples per waveform (default 4000)", "N"},
    {"sample-rate", 'r', 0, G_OPTION_ARG_DOUBLE, &params.sample_rate,
        "Sample rate in Hz (default 450000)", "HZ"},
    {"band-low", 0, 0, G_OPTION_ARG_DOUBLE, &params.band_low,
        "Lower band edge in Hz (default 20000)", "HZ"},
    {"band-high", 0, 0, G_OPTION_ARG_DOUBLE, &params.band_high,
        "Upper band edge in Hz, at most sample-rate / 2 (default 80000)",
        "HZ"},
    {"output", 'o', 0, G_OPTION_ARG_FILENAME, &output,
        "Write to FILE instead of standard output", "FILE"},
    {NULL}
  };

  /* Messages in the user's charset; numbers stay C-formatted regardless. */
  setlocale (LC_ALL, "");
  sonar_waveform_params_init_default (&params);

  context = g_option_context_new ("- write sonar emission waveforms as JSON");
  g_option_context_set_summary (context, "Generates one waveform per "
      "emitter, as sonarsrc does, and writes them as a waveforms file "
      "(docs/FORMATS.md) for sonarsrc's waveforms-file property.");
  g_option_context_add_main_entries (context, entries, NULL);
  if (!g_option_context_parse (context, &argc, &argv, &error)) {
    g_printerr ("sonar-waveforms: %s\n", error->message);
    return EXIT_FAILURE;
  }
  if (argc > 1) {
    g_printerr ("sonar-waveforms: unexpected argument '%s' (see --help)\n",
        argv[1]);
    return EXIT_FAILURE;
  }
  if (list_kinds) {
    guint n;
    const SonarWaveformKindInfo *kinds = sonar_waveform_kinds (&n);
    for (guint i = 0; i < n; i++)
      g_print ("%s\t%s\n", kinds[i].nick, kinds[i].description);
    return EXIT_SUCCESS;
  }
  if (kind_name && !sonar_waveform_kind_from_string (kind_name,
          &params.kind)) {
    g_printerr ("sonar-waveforms: unknown --kind '%s'; it must be one of "
        "%s\n", kind_name, nicks);
    return EXIT_FAILURE;
  }

  /* Out-of-range counts are the generator's to report, with its message;
   * clamping them here only keeps the allocation from overflowing first. */
  waveforms = g_try_new (float,
      (gsize) CLAMP (params.n_emitters, 1, SONAR_MAX_EMITTERS) *
      CLAMP (params.length, 1, SONAR_MAX_WAVEFORM_LENGTH));
  if (!waveforms) {
    g_printerr ("sonar-waveforms: out of memory for %u x %u samples\n",
        params.n_emitters, params.length);
    return EXIT_FAILURE;
  }
  if (!sonar_waveform_generate (&params, waveforms, &error)) {
    g_printerr ("sonar-waveforms: %s\n", error->message);
    return EXIT_FAILURE;
  }

  json = waveforms_to_json (waveforms);
  if (output) {
    /* Atomic: a reader never sees half a file. */
    if (!g_file_set_contents (output, json->str, json->len, &error)) {
      g_printerr ("sonar-waveforms: %s\n", error->message);
      return EXIT_FAILURE;
    }
  } else if (fwrite (json->str, 1, json->len, stdout) != json->len
      || fflush (stdout) != 0) {
    g_printerr ("sonar-waveforms: cannot write to standard output\n");
    return EXIT_FAILURE;
  }
  return EXIT_SUCCESS;
}
