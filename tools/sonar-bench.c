/* sonar-bench: the project's benchmark.
 *
 * Processes a fixed set of pings of the fig10, fig9 and crossing presets
 * (and of seeded random scenes) through the DSP core the way the elements
 * do (dopplerbank ! mimobeamform ! wardcluster ! velocityest ! sonartrack,
 * with their defaults), scores the detections against the simulator's ground truth,
 * times every stage and measures the memory it holds. Each sweep changes
 * one setting; each row is one configuration.
 *
 *   sonar-bench                         the elements' defaults, three presets
 *   sonar-bench --sweep linkage         Ward vs SLINK (paper Fig. 10) and more
 *   sonar-bench --all --csv bench.csv   every sweep, rows appended to a CSV
 *   sonar-bench --quick                 fig10, 2 pings: linkage and refine
 *
 * The sweeps are described in bench/sweeps.c and bench/sensitivity.c, the
 * timing and memory measured in bench/chain.c; bench/bench.h says which
 * file owns what. This file parses the options and runs the sweeps asked.
 *
 * tools/plot-bench.py draws the CSV.
 */
#include "bench/bench.h"

static const Sweep *
find_sweep (const char *name)
{
  for (guint i = 0; i < n_sweeps; i++)
    if (g_str_equal (sweeps[i].name, name))
      return &sweeps[i];
  return NULL;
}

static gboolean
parse_pings (const char *option_name, const char *value, guint * pings,
    GError ** error)
{
  guint64 n;
  g_autoptr (GError) parse_error = NULL;

  if (!g_ascii_string_to_unsigned (value, 10, 1, 10000, &n, &parse_error)) {
    g_set_error (error, G_OPTION_ERROR, G_OPTION_ERROR_BAD_VALUE, "%s: %s",
        option_name, parse_error->message);
    return FALSE;
  }
  *pings = (guint) n;
  return TRUE;
}

static gboolean
parse_fig10_pings (const char *option_name, const char *value,
    gpointer data, GError ** error)
{
  return parse_pings (option_name, value, &scenes[SCENE_FIG10].n_pings,
      error);
}

static gboolean
parse_fig9_pings (const char *option_name, const char *value,
    gpointer data, GError ** error)
{
  return parse_pings (option_name, value, &scenes[SCENE_FIG9].n_pings, error);
}

static gboolean
parse_noise_pings (const char *option_name, const char *value,
    gpointer data, GError ** error)
{
  return parse_pings (option_name, value, &noise_pings, error);
}

static gboolean
parse_detection_pings (const char *option_name, const char *value,
    gpointer data, GError ** error)
{
  return parse_pings (option_name, value, &detection_pings, error);
}

static gboolean
parse_split_pings (const char *option_name, const char *value,
    gpointer data, GError ** error)
{
  return parse_pings (option_name, value, &split_pings, error);
}

static gboolean
parse_near_far_pings (const char *option_name, const char *value,
    gpointer data, GError ** error)
{
  return parse_pings (option_name, value, &near_far_pings, error);
}

/* The command line. */
typedef struct
{
  char **sweep_names;
  char *csv_path;
  gboolean all, quick;
  int threads, timed_pings;
} Options;

static void
options_clear (Options * o)
{
  g_clear_pointer (&o->sweep_names, g_strfreev);
  g_clear_pointer (&o->csv_path, g_free);
}

G_DEFINE_AUTO_CLEANUP_CLEAR_FUNC (Options, options_clear)

/* Reads the command line into @o; FALSE, having said why, when it is
 * wrong. */
static gboolean
parse_options (Options * o, int *argc, char ***argv)
{
  g_autoptr (GOptionContext) context = NULL;
  g_autoptr (GError) error = NULL;
  g_autoptr (GString) sweep_help = g_string_new ("Run this sweep "
      "(repeatable):");
  GOptionEntry entries[] = {
    {"sweep", 's', 0, G_OPTION_ARG_STRING_ARRAY, &o->sweep_names, NULL,
        "NAME"},
    {"all", 'a', 0, G_OPTION_ARG_NONE, &o->all,
        "Run every sweep but baseline and the slow ones", NULL},
    {"quick", 'q', 0, G_OPTION_ARG_NONE, &o->quick,
        "Only 2 fig10 pings and the linkage and refine sweeps", NULL},
    {"csv", 'c', 0, G_OPTION_ARG_FILENAME, &o->csv_path,
        "Append one row per configuration to this CSV file", "FILE"},
    {"fig10-pings", 0, 0, G_OPTION_ARG_CALLBACK, parse_fig10_pings,
        "Pings of the fig10 drive (default 9)", "N"},
    {"fig9-pings", 0, 0, G_OPTION_ARG_CALLBACK, parse_fig9_pings,
        "Pings of the fig9 world (default 5)", "N"},
    {"timed-pings", 0, 0, G_OPTION_ARG_INT, &o->timed_pings,
        "Pings timed per configuration, at least (default 20): a scene "
          "with fewer goes round them again, each scored once", "N"},
    {"noise-pings", 0, 0, G_OPTION_ARG_CALLBACK, parse_noise_pings,
        "Pings of the noise sweep (default 1000)", "N"},
    {"detection-pings", 0, 0, G_OPTION_ARG_CALLBACK, parse_detection_pings,
        "Pings per SNR and range of the detection sweep (default 20)", "N"},
    {"split-pings", 0, 0, G_OPTION_ARG_CALLBACK, parse_split_pings,
        "Pings per separation and velocity difference of the split sweep "
          "(default 10)", "N"},
    {"near-far-pings", 0, 0, G_OPTION_ARG_CALLBACK, parse_near_far_pings,
        "Pings per level of the near-far sweep (default 20)", "N"},
    {"crowded-cancel-bound", 0, 0, G_OPTION_ARG_NONE,
          &crowded_cancel_bound,
          "The crowded sweep also estimates the failed centroids again on "
          "the recording less the true echoes of the objects found, in "
          "rounds: the bound of successive cancellation", NULL},
    {"threads", 't', 0, G_OPTION_ARG_INT, &o->threads,
        "Velocity workers, as velocityest's threads (default 0: one per "
          "processor)", "N"},
    {NULL}
  };

  for (guint i = 0; i < n_sweeps; i++)
    g_string_append_printf (sweep_help, "%s %s", i ? "," : "",
        sweeps[i].name);
  entries[0].description = sweep_help->str;
  context = g_option_context_new ("- time and score the sonar's DSP chain");
  g_option_context_set_summary (context, "Processes fixed pings of the "
      "fig10, fig9 and crossing presets (and of random scenes) through the "
      "DSP core as the elements do (sonartrack's ego-motion and tracker "
      "the last stage) and prints, per configuration, the objects found, "
      "false positives, velocity errors against the truth, the median time "
      "per ping of each stage and the memory each holds. Without a sweep: "
      "the elements' defaults on the three presets.");
  g_option_context_set_description (context, "Sweeps, each on fig10 unless "
      "said:\n"
      "  linkage, refine, window   clustering linkage, peak refinement, "
      "velocity window\n"
      "  bank-step, bank-size      bank step; bank -v..v / 0.05 for v = "
      "0.4, 1, 3, 7\n"
      "  directions, focus-zones   image directions, near-field focus "
      "zones\n"
      "  range-resolution          image range step 0.001-0.04 m (the band "
      "bounds it too)\n"
      "  hypotheses                detection hypotheses' spacing (fig9)\n"
      "  emitters                  emitters in the Doppler-ACF product: 8, "
      "6, 4, 2, 1\n"
      "  template-interpolation    templates read band-limited (hermite4x), "
      "linearly or by\n"
      "                            nearest sample; error against exact "
      "templates in dB\n"
      "  reflectors                random scenes of 0, 1, 5, 20, 50 reflectors, "
      "2 pings each\n"
      "  datacube                  the full datacube against the proposed "
      "chain, first fig10\n"
      "                            ping, bank -1..1 m/s; Doppler-ACF "
      "peak-to-sidelobe ratios\n"
      "                            (paper Fig. 11)\n"
      "  coarse-spacing, refine-db  the imager's coarse grid (0: dense) and "
      "refinement level\n"
      "  direct-path               the emitters heard straight by the "
      "microphones (coupling\n"
      "                            0, 0.01, 0.1, 1), dopplerbank's "
      "direct-path auto and off;\n"
      "                            at 0.1, 16 and 41 taps a path\n"
      "  residual-search           velocityest's residual search on and "
      "off: fig10, fig9,\n"
      "                            crossing, random scenes of 20 and 50 "
      "reflectors\n"
      "  refine-pfa                fig9: the refinement's noise gate off, "
      "1e-7, 1e-5, 1e-3\n"
      "  coarse-band               fig9: the coarse pass on the band's "
      "first 1, 1/2, 1/3, 1/6,\n"
      "                            1/12 (the rest imaged in full where "
      "it finds echoes)\n"
      "  coarse-band-pfa           fig9, half the band: its gate 1e-7, "
      "1e-5, 1e-3\n"
      "  coarse-band-scenes        noise alone and one object, the coarse "
      "pass on the whole\n"
      "                            band and on half of it\n"
      "  hemisphere                3-D, 91 x 91 directions at 2 degrees, "
      "one fig10 ping,\n"
      "                            coarse grids of 4, 6, 8 degrees and "
      "dense\n"
      "  hemisphere-fig9           (minutes; not in --all) 3-D, 91 x 91 at 2 "
      "degrees, coarse 6,\n"
      "                            the fig9 world, the default -7..7 / 0.05 "
      "bank\n"
      "  hemisphere-fig9-band      (minutes; not in --all) the same, the "
      "coarse pass on the\n"
      "                            whole band and on half of it\n"
      "  hemisphere-grid           3-D at 2, 3, 4 degrees (91, 61, 46 "
      "directions a side),\n"
      "                            coarse 6 degrees, one fig10 ping\n"
      "  hemisphere-fig9-grid      (minutes; not in --all) the same on the "
      "fig9 world and bank\n"
      "Sensitivity sweeps (minutes; not in --all), pings rendered one at a "
      "time, the defaults:\n"
      "  noise                     noise-only pings: the false-alarm model "
      "against the measured\n"
      "                            exceedance, false objects "
      "(--noise-pings)\n"
      "  detection                 probability of detection against "
      "per-channel SNR at 2, 5,\n"
      "                            8 m; the 7 m / -28 dB goal "
      "(--detection-pings)\n"
      "  split                     pairs 0.5-3 cm apart in range at one "
      "azimuth, velocities\n"
      "                            0.4-5 m/s apart: share split into two "
      "objects; false splits\n"
      "                            of single objects, presets and random "
      "scenes (--split-pings)\n"
      "  crowded                   grids of 25-400 still objects and random "
      "scenes of 25-150:\n"
      "                            objects found against an oracle bound "
      "(>= 13 dB above the\n"
      "                            others' and the noise's level at each "
      "object), false objects\n"
      "  near-far                  a strong point at 0.5 m 20-60 dB above "
      "a normal one at\n"
      "                            1.5-3.5 m: the normal one found, false "
      "objects; the dynamic\n"
      "                            range (--near-far-pings)\n"
      "  scalloping                (seconds) a noise-free point halfway "
      "between coarse\n"
      "                            directions 1-8 degrees apart, 2-D and "
      "3-D: dB the coarse\n"
      "                            directions see of its peak\n");
  g_option_context_add_main_entries (context, entries, NULL);
  if (!g_option_context_parse (context, argc, argv, &error)) {
    g_printerr ("sonar-bench: %s\n", error->message);
    return FALSE;
  }
  if (o->threads < 0 || o->threads > SONAR_VELOCITY_MAX_THREADS) {
    g_printerr ("sonar-bench: --threads must be 0 to %d\n",
        SONAR_VELOCITY_MAX_THREADS);
    return FALSE;
  }
  if (o->timed_pings < 1 || o->timed_pings > 100000) {
    g_printerr ("sonar-bench: --timed-pings must be 1 to 100000\n");
    return FALSE;
  }
  return TRUE;
}

/* The sweeps to run, in order: --quick's or --all's, then those named;
 * the baseline when none. NULL, having said why, for an unknown name. */
static GPtrArray *
select_sweeps (const Options * o)
{
  g_autoptr (GPtrArray) selected = g_ptr_array_new ();

  if (o->quick) {
    scenes[SCENE_FIG10].n_pings = 2;
    g_ptr_array_add (selected, (gpointer) find_sweep ("linkage"));
    g_ptr_array_add (selected, (gpointer) find_sweep ("refine"));
  } else if (o->all) {
    /* The sensitivity sweeps and the slow ones take minutes: only by
     * name. */
    for (guint i = 1; i < n_sweeps; i++)
      if (!sweeps[i].run && !sweeps[i].slow)
        g_ptr_array_add (selected, (gpointer) &sweeps[i]);
  }
  for (guint i = 0; o->sweep_names && o->sweep_names[i]; i++) {
    const Sweep *sweep = find_sweep (o->sweep_names[i]);

    if (!sweep) {
      g_printerr ("sonar-bench: no sweep \"%s\" (see --help)\n",
          o->sweep_names[i]);
      return NULL;
    }
    g_ptr_array_add (selected, (gpointer) sweep);
  }
  if (selected->len == 0)
    g_ptr_array_add (selected, (gpointer) find_sweep ("baseline"));
  return g_steal_pointer (&selected);
}

/* Renders the pings of every scene the @selected sweeps' configurations
 * use. */
static gboolean
render_scenes (const GPtrArray * selected, SonarSetup * setup,
    GError ** error)
{
  gboolean needed[N_SCENES] = { FALSE };

  for (guint i = 0; i < selected->len; i++) {
    const Sweep *sweep = g_ptr_array_index (selected, i);

    for (guint v = 0; v < sweep->n_values; v++) {
      char label[32];
      Config c;

      sweep_config (sweep, v, &c, label, sizeof (label));
      needed[c.scene - scenes] = TRUE;
    }
  }
  for (guint s = 0; s < N_SCENES; s++) {
    double t = now_ms ();

    if (!needed[s])
      continue;
    if (!render_scene (&scenes[s], setup, error))
      return FALSE;
    g_printerr ("rendered %u pings of %s in %.1f s\n", scenes[s].n_pings,
        scenes[s].name, (now_ms () - t) * 1e-3);
  }
  return TRUE;
}

int
main (int argc, char **argv)
{
  g_auto (Options) options = {.timed_pings = 20 };
  g_autoptr (GError) error = NULL;
  g_autoptr (GPtrArray) selected = NULL;
  gboolean ok = TRUE;
  Bench b = { 0 };
  double start = now_ms ();

  if (!parse_options (&options, &argc, &argv))
    return 2;
  b.timed_pings = (guint) options.timed_pings;
  b.peak_gflops = measure_peak_gflops (&b.peak_isa);
  b.read_gbs = measure_read_gbs ();
  b.n_threads = CLAMP (options.threads ? (guint) options.threads :
      g_get_num_processors (), 1, SONAR_VELOCITY_MAX_THREADS);
  selected = select_sweeps (&options);
  if (!selected)
    return 2;

  if (options.csv_path) {
    b.csv = open_csv (options.csv_path, &error);
    if (!b.csv) {
      g_printerr ("sonar-bench: %s\n", error->message);
      return 1;
    }
  }

  b.setup = sonar_setup_new_default (MAX_RANGE, &error);
  if (!b.setup || !render_scenes (selected, b.setup, &error)) {
    g_printerr ("sonar-bench: %s\n", error->message);
    return 1;
  }
  g_print ("sonar-bench: %u microphones, %u emitters, %u samples per ping; "
      "velocity on %u thread%s; times are medians over the pings, ms per "
      "ping; errors in m/s\n", b.setup->geometry.n_microphones,
      b.setup->geometry.n_emitters, b.setup->ping_length, b.n_threads,
      b.n_threads > 1 ? "s" : "");

  b.peak_rss_mb = peak_rss_mb ();
  b.banks = g_hash_table_new_full (g_str_hash, g_str_equal, g_free,
      bank_entry_free);
  b.results = g_hash_table_new_full (g_str_hash, g_str_equal, g_free,
      result_free);
  for (guint i = 0; i < selected->len; i++)
    ok &= run_sweep (&b, g_ptr_array_index (selected, i));

  g_print ("\npeak RSS %.1f MB; whole run %.1f s\n", b.peak_rss_mb,
      (now_ms () - start) * 1e-3);

  g_hash_table_unref (b.results);
  g_hash_table_unref (b.banks);
  sonar_setup_unref (b.setup);
  for (guint s = 0; s < N_SCENES; s++) {
    g_free (scenes[s].pings);
    g_free (scenes[s].truths);
  }
  if (b.csv)
    fclose (b.csv);
  return ok ? 0 : 1;
}
