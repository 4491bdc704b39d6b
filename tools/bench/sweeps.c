/* sonar-bench's sweeps: each changes one setting of the elements'
 * defaults; each row is one configuration.
 *
 * Sweeps (fig10 unless said): linkage, refine, window (velocity window),
 * bank-step, directions, focus-zones, hypotheses (fig9: detection
 * hypotheses), emitters (emitters in the Doppler-ACF product: 8, 6, 4, 2,
 * 1), template-interpolation (templates read band-limited, linearly or by
 * nearest sample; their error against the exact templates in dB),
 * range-resolution (the image's range step, asked 0.001-0.04 m; the
 * band's bins bound it too, at 2.8 mm), bank-size (bank -v..v at 0.05
 * m/s for v = 0.4, 1, 3, 7: cost against bank size), reflectors (seeded
 * random scenes of 0 (noise only), 1, 5, 20 and 50 point reflectors, 2
 * pings each: cost against reflectors) and datacube (the full datacube, an image per bank
 * velocity with the velocity read at each centroid's pixel, against the
 * proposed chain on the first fig10 ping with a -1..1 m/s bank; the
 * paper's Fig. 11 measured on the Doppler-ACF curves at the true
 * reflectors), coarse-spacing and refine-db (the imager's coarse to fine
 * pass: coarse grid 0-6 degrees, refinement level 10-30 dB), refine-pfa
 * (its noise gate on fig9: off, 1e-7, 1e-5, 1e-3), coarse-band (fig9:
 * the coarse pass on the whole band, a half, third, sixth, twelfth of it),
 * coarse-band-pfa (fig9 at half the band: its gate 1e-7, 1e-5, 1e-3),
 * coarse-band-scenes (noise alone and one object, whole band and half)
 * and
 * hemisphere (issue 5's 3-D goal: 91 x 91 directions at 2 degrees, one
 * fig10 ping, coarse grids of 4, 6 and 8 degrees and the dense image);
 * hemisphere-fig9 (minutes, not in --all: issue 13's 3-D goal with the
 * default bank, the same grid at the imager's 3-D defaults on the fig9
 * world); hemisphere-fig9-band (minutes, not in --all: the same with
 * the coarse pass on the whole band and on half of it); hemisphere-grid
 * (the hemisphere at 2, 3 and 4 degrees, one fig10 ping) and
 * hemisphere-fig9-grid (the same on the fig9 world, not in --all).
 * The "work" column is the share of the dense image's direction x zone x
 * hypothesis passes the imager made. The sensitivity sweeps (noise,
 * detection, split) are sensitivity.c's.
 *
 * A configuration two sweeps share (linkage=ward is refine=on) runs
 * once. */
#include "bench.h"
#include "sonar-linkage.h"

/* The elements' defaults for @scene. */
void
config_init (Config * c, BenchScene * scene)
{
  c->scene = scene;
  c->n_pings = scene->n_pings;
  c->v_min = scene->v_min;
  c->v_max = scene->v_max;
  c->v_step = scene->v_step;
  c->template_interp = SONAR_TEMPLATE_BAND_LIMITED;
  c->hypothesis_spacing = HYPOTHESIS_SPACING;
  c->method = METHOD_PROPOSED;
  c->measure_curves = FALSE;
  sonar_imager_params_init_default (&c->imager);
  sonar_cluster_params_init_default (&c->cluster);
  sonar_velocity_params_init_default (&c->velocity);
  c->direct_path = 0.0;
  c->direct_path_mode = SONAR_DIRECT_PATH_AUTO;
  c->direct_path_taps = SONAR_DIRECT_PATH_TAPS;
  c->residual_search = TRUE;
}

/* Everything that makes a run: equal keys, equal results. */
static char *
config_key (const Config * c)
{
  const SonarImagerParams *i = &c->imager;
  const SonarClusterParams *k = &c->cluster;
  const SonarVelocityParams *v = &c->velocity;

  return g_strdup_printf ("%s %u %d %d | %.17g %.17g %.17g %d %.17g | "
      "%.17g %.17g %u %.17g %.17g %u %.17g %.17g %.17g %u %.17g %.17g %.17g %.17g %.17g | %d "
      "%.17g %.17g "
      "%d %d %.17g %u %.17g %u | %u %u %d %.17g %u %.17g %.17g %u | %.17g %d %u %d",
      c->scene->name, c->n_pings, c->method, c->measure_curves, c->v_min,
      c->v_max, c->v_step, c->template_interp, c->hypothesis_spacing,
      i->azimuth_min, i->azimuth_max, i->n_azimuth, i->elevation_min,
      i->elevation_max, i->n_elevation, i->range_min, i->range_max,
      i->range_resolution, i->focus_zones, i->coarse_spacing, i->refine_db,
      i->refine_pfa, i->coarse_band, i->coarse_pfa, k->range_compensation,
      k->threshold_db, k->absolute_threshold, k->linkage, k->stop,
      k->inconsistency, k->depth, k->distance, k->max_peaks,
      v->window_directions, v->window_ranges, v->refine, v->min_variance,
      v->min_agreeing_emitters, v->min_coherence, v->second_peak_db,
      v->emitters, c->direct_path, c->direct_path_mode, c->direct_path_taps,
      c->residual_search);
}

void
result_free (gpointer data)
{
  Result *r = data;

  g_free (r->label);
  g_free (r->psr_db);
  g_free (r->width);
  g_free (r->psr_bounded);
  g_free (r);
}

/* A sweep that sets one field of the configuration to each of a list of
 * values, labelled with the value. */
#define FIELD_SWEEP(name, field, type, format, ...)                       \
static void                                                             \
name (Config * c, guint i, char *label, gsize size)                     \
{                                                                       \
  static const type values[] = { __VA_ARGS__ };                         \
                                                                        \
  c->field = values[i];                                                 \
  g_snprintf (label, size, format, values[i]);                          \
}

static void
apply_baseline (Config * c, guint i, char *label, gsize size)
{
  config_init (c, &scenes[i]);
  g_strlcpy (label, scenes[i].name, size);
}

/* The linkage sweep: every method of sonar-linkage.h. */
static void
apply_linkage (Config * c, guint i, char *label, gsize size)
{
  guint n;
  const SonarLinkageInfo *methods = sonar_linkage_methods (&n);

  c->cluster.linkage = methods[i].linkage;
  g_strlcpy (label, methods[i].nick, size);
}

static void
apply_refine (Config * c, guint i, char *label, gsize size)
{
  c->velocity.refine = i == 0;
  g_strlcpy (label, i == 0 ? "on" : "off", size);
}

static void
apply_window (Config * c, guint i, char *label, gsize size)
{
  static const guint directions[] = { 0, 1, 2 }, ranges[] = { 1, 2, 4 };

  c->velocity.window_directions = directions[i / 3];
  c->velocity.window_ranges = ranges[i % 3];
  g_snprintf (label, size, "d%ur%u", c->velocity.window_directions,
      c->velocity.window_ranges);
}

FIELD_SWEEP (apply_bank_step, v_step, double, "%g", 0.01, 0.02, 0.05, 0.1)

FIELD_SWEEP (apply_directions, imager.n_azimuth, guint, "%u", 61, 91, 181, 361)

FIELD_SWEEP (apply_focus_zones, imager.focus_zones, guint, "%u", 1, 2, 4, 8)

FIELD_SWEEP (apply_coarse_spacing, imager.coarse_spacing, double, "%g",
    0.0, 2.0, 3.0, 4.0, 6.0)

FIELD_SWEEP (apply_refine_db, imager.refine_db, double, "%g",
    10.0, 15.0, 20.0, 30.0)

FIELD_SWEEP (apply_refine_pfa, imager.refine_pfa, double, "%g",
    0.0, 1e-7, 1e-5, 1e-3)

/* The coarse pass's sub-band on fig9 (the default bank, where the coarse
 * pass costs most): the whole band, a half, a third, a sixth (20-30 kHz
 * of the default sensor's 20-80), a twelfth. */
static void
apply_coarse_band (Config * c, guint i, char *label, gsize size)
{
  static const guint parts[] = { 1, 2, 3, 6, 12 };

  c->imager.coarse_band = 1.0 / parts[i];
  if (parts[i] == 1)
    g_strlcpy (label, "1", size);
  else
    g_snprintf (label, size, "1/%u", parts[i]);
}

/* Its noise gate (coarse_pfa) on fig9 at half the band: 1e-7, 1e-5 (the
 * default), 1e-3 per coarse pixel. */
static void
apply_coarse_band_pfa (Config * c, guint i, char *label, gsize size)
{
  static const double pfas[] = { 1e-7, 1e-5, 1e-3 };

  c->imager.coarse_band = 0.5;
  c->imager.coarse_pfa = pfas[i];
  g_snprintf (label, size, "%g", pfas[i]);
}

/* The sub-band against the whole band where the coarse pass is most of the
 * work: noise alone and one object (the reflectors sweep's first two
 * scenes), whole band and half. */
static void
apply_coarse_band_scenes (Config * c, guint i, char *label, gsize size)
{
  config_init (c, &scenes[SCENE_RANDOM_FIRST + i / 2]);
  c->imager.coarse_band = i % 2 ? 0.5 : 1.0;
  g_snprintf (label, size, "%u:%s", c->scene->n_random, i % 2 ? "1/2" :
      "1");
}

/* Issue 13's fourth goal (hemisphere-fig9) with the coarse pass on the
 * whole band and on half of it. */
static void
apply_hemisphere_fig9_band (Config * c, guint i, char *label, gsize size)
{
  sonar_imager_params_set_view (&c->imager, SONAR_FIELD_OF_VIEW_HEMISPHERE);
  c->imager.coarse_band = i ? 0.5 : 1.0;
  g_strlcpy (label, i ? "1/2" : "1", size);
}

/* Issue 5's 3-D goal: the frontal hemisphere at 2 degrees (91 x 91
 * directions), the Fig. 10 bank, one ping; coarse spacings of 4 to 8
 * degrees (0: dense, every direction in full). */
static void
apply_hemisphere (Config * c, guint i, char *label, gsize size)
{
  static const double spacings[] = { 4.0, 6.0, 8.0, 0.0 };

  c->n_pings = 1;
  c->imager.n_azimuth = c->imager.n_elevation = 91;
  c->imager.elevation_min = -90.0;
  c->imager.elevation_max = 90.0;
  c->imager.coarse_spacing = spacings[i];
  g_snprintf (label, size, "%g", spacings[i]);
}

/* Issue 13's fourth goal: the hemisphere at 2 degrees (the imager's 3-D
 * defaults) on the Fig. 9 world's movers, the elements' default +-7 /
 * 0.05 m/s bank. */
static void
apply_hemisphere_fig9 (Config * c, guint i, char *label, gsize size)
{
  sonar_imager_params_set_view (&c->imager, SONAR_FIELD_OF_VIEW_HEMISPHERE);
  g_snprintf (label, size, "%g", c->imager.coarse_spacing);
}

/* The hemisphere at the 3-D default's 2 degrees and coarser, 3 and 4
 * (91, 61, 46 directions a side), the default coarse spacing (6 degrees;
 * at 4, two grid steps): what a coarser image buys in time, and costs. */
static void
hemisphere_grid (Config * c, guint i, char *label, gsize size)
{
  static const double steps[] = { 2.0, 3.0, 4.0 };

  sonar_imager_params_set_view (&c->imager, SONAR_FIELD_OF_VIEW_HEMISPHERE);
  c->imager.n_azimuth = c->imager.n_elevation =
      (guint) (180.0 / steps[i]) + 1;
  g_snprintf (label, size, "%g", steps[i]);
}

/* hemisphere_grid () on one Fig. 10 ping (its -0.4..0.4 bank). */
static void
apply_hemisphere_grid (Config * c, guint i, char *label, gsize size)
{
  c->n_pings = 1;
  hemisphere_grid (c, i, label, size);
}

/* hemisphere_grid () on the Fig. 9 world, the elements' default bank: the
 * sensor's rate in 3-D. */
static void
apply_hemisphere_fig9_grid (Config * c, guint i, char *label, gsize size)
{
  hemisphere_grid (c, i, label, size);
}

FIELD_SWEEP (apply_hypotheses, hypothesis_spacing, double, "%g", 0.15, 0.3, 0.6)

static void
apply_emitters (Config * c, guint i, char *label, gsize size)
{
  static const guint counts[] = { 8, 6, 4, 2, 1 };

  /* 0 is all 8: the baseline's run. */
  c->velocity.emitters = i == 0 ? 0 : counts[i];
  g_snprintf (label, size, "%u", counts[i]);
}

static const SonarTemplateInterp template_interps[] = {
  SONAR_TEMPLATE_BAND_LIMITED, SONAR_TEMPLATE_LINEAR, SONAR_TEMPLATE_NEAREST,
};

static void
apply_template_interp (Config * c, guint i, char *label, gsize size)
{
  c->template_interp = template_interps[i];
  g_strlcpy (label, template_interp_names[template_interps[i]], size);
}

/* The image's step is also bounded by the band: with the default
 * sensor, 2.8 mm at most, so the coarser values change nothing. */
FIELD_SWEEP (apply_range_resolution, imager.range_resolution, double, "%g",
    0.001, 0.002, 0.005, 0.01, 0.02, 0.04)

static void
apply_bank_size (Config * c, guint i, char *label, gsize size)
{
  static const double reach[] = { 0.4, 1.0, 3.0, 7.0 };

  c->v_min = -reach[i];
  c->v_max = reach[i];
  c->v_step = 0.05;
  g_snprintf (label, size, "%g", reach[i]);
}

static void
apply_reflectors (Config * c, guint i, char *label, gsize size)
{
  config_init (c, &scenes[SCENE_RANDOM_FIRST + i]);
  g_snprintf (label, size, "%u", c->scene->n_random);
}

static void
apply_datacube (Config * c, guint i, char *label, gsize size)
{
  /* One ping: the datacube images every bank velocity. A bank wider than
   * fig10's: one emitter's Doppler main lobe is 0.33 m/s wide, and within
   * +-0.4 m/s the curves' sidelobes mostly fall beyond the bank's edges. */
  c->n_pings = 1;
  c->v_min = -DATACUBE_REACH;
  c->v_max = DATACUBE_REACH;
  c->measure_curves = TRUE;
  c->method = i == 0 ? METHOD_PROPOSED : METHOD_DATACUBE;
  g_strlcpy (label, i == 0 ? "proposed" : "datacube", size);
}

/* Fig. 10 heard through a real sensor's direct path (the simulator's
 * coupling 0, 0.01, 0.1, 1: up to 53-91 dB over a unit echo at 1 m),
 * dopplerbank's direct-path at auto and, for the couplings, off; then at
 * 0.1 with 16 and 41 taps a path (what a ringing emitter needs). */
static void
apply_direct_path (Config * c, guint i, char *label, gsize size)
{
  static const double couplings[] = { 0.0, 0.01, 0.01, 0.1, 0.1, 1.0, 1.0,
    0.1, 0.1
  };
  static const guint taps[] = { 7, 7, 7, 7, 7, 7, 7, 16, 41 };

  c->direct_path = couplings[i];
  c->direct_path_mode = i > 0 && i < 7 && i % 2 == 0 ?
      SONAR_DIRECT_PATH_OFF : SONAR_DIRECT_PATH_AUTO;
  c->direct_path_taps = taps[i];
  g_snprintf (label, size, "%g %s%s", couplings[i],
      c->direct_path_mode == SONAR_DIRECT_PATH_OFF ? "off" : "auto",
      taps[i] == SONAR_DIRECT_PATH_TAPS ? "" : taps[i] == 16 ? " 16" : " 41");
}

/* velocityest's residual search on and off, on the presets and the
 * random scenes of 20 and 50 reflectors. */
static void
apply_residual_search (Config * c, guint i, char *label, gsize size)
{
  static const guint scene_of[] = { SCENE_FIG10, SCENE_FIG9, SCENE_CROSSING,
    SCENE_RANDOM_FIRST + 3, SCENE_RANDOM_FIRST + 4
  };

  config_init (c, &scenes[scene_of[i / 2]]);
  c->residual_search = i % 2 == 0;
  g_snprintf (label, size, "%s %s", c->scene->name,
      c->residual_search ? "on" : "off");
}

const Sweep sweeps[] = {
  {"baseline", SCENE_FIG10, SCENE_CROSSING + 1, apply_baseline},
  {"linkage", SCENE_FIG10, SONAR_LINKAGE_CENTROID + 1, apply_linkage},
  {"refine", SCENE_FIG10, 2, apply_refine},
  {"window", SCENE_FIG10, 9, apply_window},
  {"bank-step", SCENE_FIG10, 4, apply_bank_step},
  {"directions", SCENE_FIG10, 4, apply_directions},
  {"focus-zones", SCENE_FIG10, 4, apply_focus_zones},
  {"hypotheses", SCENE_FIG9, 3, apply_hypotheses},
  {"emitters", SCENE_FIG10, 5, apply_emitters},
  {"template-interpolation", SCENE_FIG10, G_N_ELEMENTS (template_interps),
      apply_template_interp},
  {"range-resolution", SCENE_FIG10, 6, apply_range_resolution},
  {"bank-size", SCENE_FIG10, 4, apply_bank_size},
  {"reflectors", SCENE_FIG10, N_SCENES - SCENE_RANDOM_FIRST,
      apply_reflectors},
  {"datacube", SCENE_FIG10, 2, apply_datacube},
  {"coarse-spacing", SCENE_FIG10, 5, apply_coarse_spacing},
  {"refine-db", SCENE_FIG10, 4, apply_refine_db},
  {"direct-path", SCENE_FIG10, 9, apply_direct_path},
  {"residual-search", SCENE_FIG10, 10, apply_residual_search},
  {"refine-pfa", SCENE_FIG9, 4, apply_refine_pfa},
  {"coarse-band", SCENE_FIG9, 5, apply_coarse_band},
  {"coarse-band-pfa", SCENE_FIG9, 3, apply_coarse_band_pfa},
  {"coarse-band-scenes", SCENE_FIG10, 4, apply_coarse_band_scenes},
  {"hemisphere", SCENE_FIG10, 4, apply_hemisphere},
  {"hemisphere-fig9", SCENE_FIG9, 1, apply_hemisphere_fig9, NULL, TRUE},
  {"hemisphere-fig9-band", SCENE_FIG9, 2, apply_hemisphere_fig9_band, NULL,
      TRUE},
  {"hemisphere-grid", SCENE_FIG10, 3, apply_hemisphere_grid},
  {"hemisphere-fig9-grid", SCENE_FIG9, 3, apply_hemisphere_fig9_grid, NULL,
      TRUE},
  {"noise", SCENE_FIG9, 0, NULL, run_noise},
  {"detection", SCENE_FIG9, 0, NULL, run_detection},
  {"split", SCENE_FIG9, 0, NULL, run_split},
  {"uncertainty", SCENE_FIG9, 0, NULL, run_uncertainty},
  {"crowded", SCENE_FIG9, 0, NULL, run_crowded},
  {"near-far", SCENE_FIG9, 0, NULL, run_near_far},
  {"scalloping", SCENE_FIG10, 0, NULL, run_scalloping},
};

const guint n_sweeps = G_N_ELEMENTS (sweeps);

/* Value @i of @sweep on its scene's defaults. */
void
sweep_config (const Sweep * sweep, guint i, Config * c, char *label,
    gsize size)
{
  config_init (c, &scenes[sweep->scene]);
  sweep->apply (c, i, label, size);
}

/* Runs @sweep's configurations (one already run, under another sweep's
 * name, is not run again) and prints its tables; a sensitivity sweep
 * runs itself. */
gboolean
run_sweep (Bench * b, const Sweep * sweep)
{
  const Result *ward = NULL, *slink = NULL, *proposed = NULL, *cube = NULL;
  g_autofree const Result **rows = g_new0 (const Result *, sweep->n_values);
  g_autofree Config *configs = g_new (Config, sweep->n_values);
  char values[16][32];
  gboolean ok = TRUE;

  if (sweep->run)
    return sweep->run (b);
  g_assert (sweep->n_values <= G_N_ELEMENTS (values));
  print_header (sweep);
  for (guint i = 0; i < sweep->n_values; i++) {
    g_autoptr (GError) error = NULL;
    g_autofree char *key = NULL;
    const char *same_as = NULL;
    Config *c = &configs[i];
    Result *r;

    sweep_config (sweep, i, c, values[i], sizeof (values[i]));
    key = config_key (c);
    r = g_hash_table_lookup (b->results, key);
    if (r) {
      same_as = r->label;
    } else {
      double start = now_ms ();

      r = g_new0 (Result, 1);
      r->label = g_strdup_printf ("%s=%s", sweep->name, values[i]);
      g_printerr ("%s: %u pings of %s\n", r->label, c->n_pings,
          c->scene->name);
      if (!run_config (b, c, r, &error)) {
        g_printerr ("%s: %s\n", r->label, error->message);
        result_free (r);
        ok = FALSE;
        continue;
      }
      g_printerr ("%s: done in %.1f s\n", r->label,
          (now_ms () - start) * 1e-3);
      g_hash_table_insert (b->results, g_steal_pointer (&key), r);
    }
    rows[i] = r;
    print_row (values[i], c, r, same_as);
    if (b->csv)
      write_csv_row (b->csv, sweep->name, values[i], c, r);
    if (sweep->apply == apply_linkage) {
      if (c->cluster.linkage == SONAR_LINKAGE_WARD)
        ward = r;
      else if (c->cluster.linkage == SONAR_LINKAGE_SINGLE)
        slink = r;
    } else if (sweep->apply == apply_datacube) {
      if (c->method == METHOD_DATACUBE)
        cube = r;
      else
        proposed = r;
    }
  }
  print_memory_header ();
  for (guint i = 0; i < sweep->n_values; i++)
    if (rows[i])
      print_memory_row (values[i], &configs[i], rows[i]);
  print_efficiency_header (b);
  for (guint i = 0; i < sweep->n_values; i++)
    if (rows[i])
      print_efficiency_row (values[i], &configs[i], rows[i]);
  if (ward && slink)
    print_ward_vs_slink (ward, slink);
  if (proposed && cube)
    print_datacube_vs_proposed (proposed, cube);
  return ok;
}
