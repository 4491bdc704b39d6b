/* sonar-bench's output: the tables printed per sweep and the CSV
 * (tools/plot-bench.py draws it). */
#include <errno.h>
#include <math.h>
#include <string.h>

#include "bench.h"

static const char *const stage_names[N_STAGES] = {
  "spectra", "imaging", "cluster", "velocity", "tracking"
};

static double
mean_of (const double *v, guint n)
{
  double sum = 0.0;
  guint count = 0;

  for (guint i = 0; i < n; i++) {
    if (isfinite (v[i])) {
      sum += v[i];
      count++;
    }
  }
  return count ? sum / count : NAN;
}

static double
mean_error (const Result * r)
{
  return r->found ? r->sum_error / r->found : NAN;
}

static double
chain_mb (const Result * r)
{
  double sum = r->bank_mb;

  for (guint k = 0; k < N_STAGES; k++)
    sum += r->mb[k];
  return sum;
}

static double
ms_per_centroid (const Result * r)
{
  return r->centroids > 0.0 ? r->ms[STAGE_VELOCITY] / r->centroids : NAN;
}

/* Velocity-stage time per evaluated bank velocity, microseconds. */
static double
us_per_evaluation (const Result * r)
{
  return r->evaluated_velocities > 0.0 ? 1e3 * r->ms[STAGE_VELOCITY] /
      r->evaluated_velocities : NAN;
}

/* The tracking stage's share of the chain's time per ping, %: its median
 * over the chain's. */
static double
tracking_share (const Result * r)
{
  return r->ms_total > 0.0 ? 100.0 * r->ms[STAGE_TRACKING] / r->ms_total :
      NAN;
}

#define CSV_HEADER "sweep,value,scene,pings,found,total,false_positives," \
  "mean_error,max_error,ms_spectra,ms_imaging,ms_clustering,ms_velocity," \
  "ms_tracking,ms_total,pings_per_second,cpu_ms_total,mb_bank,mb_spectra," \
  "mb_imaging,mb_clustering,mb_velocity,mb_tracking,mb_chain,peak_rss_mb,centroids," \
  "bank_velocities,ms_velocity_per_centroid,template_error_db,psr_db," \
  "lobe_width,n_range,range_step,imaging_work,evaluated_velocities," \
  "us_velocity_per_evaluation,timed_pings,ms_total_p10,ms_total_p90," \
  "floor_ms_spectra,floor_ms_imaging,floor_ms_clustering,floor_ms_velocity," \
  "floor_ms_tracking,cpu_ms_velocity,cpu_ms_spectra,cpu_ms_clustering," \
  "cpu_ms_imaging"

/* A row of a sensitivity sweep (noise, detection, split): the columns up
 * to max_error, the timing and memory ones empty. */
void
write_sensitivity_row (FILE * csv, const char *sweep, const char *value,
    const char *scene, guint pings, guint found, guint total,
    guint false_positives, double mean_error, double max_error)
{
  fprintf (csv, "%s,%s,%s,%u,%u,%u,%u,%.6g,%.6g", sweep, value, scene, pings,
      found, total, false_positives, mean_error, max_error);
  for (const char *c = strchr (CSV_HEADER, ','); c; c = strchr (c + 1, ','))
    if (c > strstr (CSV_HEADER, "max_error"))
      fputc (',', csv);
  fputc ('\n', csv);
  fflush (csv);
}

void
print_header (const Sweep * sweep)
{
  g_print ("\n%s\n", sweep->name);
  g_print ("  %-9s %-8s %5s %7s %3s %9s %9s %5s %8s %8s %5s %8s %9s %8s "
      "%6s %9s %11s %8s %9s %5s\n", "value", "scene", "pings", "found", "FP",
      "mean m/s", "max m/s", "cent", "spectra", "imaging", "work", "cluster",
      "velocity", "tracking", "track%", "total ms", "p10-p90", "pings/s",
      "cpu ms", "timed");
}

void
print_row (const char *value, const Config * c, const Result * r,
    const char *same_as)
{
  g_autofree char *found = g_strdup_printf ("%u/%u", r->found, r->total);

  g_autofree char *spread = g_strdup_printf ("%.1f-%.1f", r->ms_total_low,
      r->ms_total_high);

  g_print ("  %-9s %-8s %5u %7s %3u %9.4f %9.4f %5.1f %8.1f %8.1f %5.2f "
      "%8.1f %9.1f %8.3f %6.2f %9.1f %11s %8.3f %9.1f %5u", value,
      c->scene->name, r->pings, found, r->false_positives, mean_error (r),
      r->max_error, r->centroids, r->ms[STAGE_SPECTRA], r->ms[STAGE_IMAGING],
      r->work_fraction, r->ms[STAGE_CLUSTERING], r->ms[STAGE_VELOCITY],
      r->ms[STAGE_TRACKING], tracking_share (r), r->ms_total, spread,
      1e3 / r->ms_total, r->cpu_ms_total, r->timed_pings);
  if (same_as)
    g_print ("  (the %s run)", same_as);
  g_print ("\n");
}

/* @x in a column of @width with @decimals, "-" for NaN. */
static void
print_number (double x, int width, int decimals)
{
  if (isnan (x))
    g_print (" %*s", width, "-");
  else
    g_print (" %*.*f", width, decimals, x);
}

void
print_memory_header (void)
{
  g_print ("  memory held (MB; bank: dopplerbank's templates and spectra) "
      "and growth\n");
  g_print ("  %-9s %-8s %7s %7s %7s %7s %8s %8s %7s %7s %6s %9s %6s %7s %8s "
      "%7s %7s %6s %6s\n", "value", "scene", "bank", "spectra", "imaging",
      "cluster", "velocity", "tracking", "chain", "RSS", "bank v", "ms/cent", "evals",
      "us/eval", "tmpl dB", "PSR dB", "3dB m/s", "ranges", "dr mm");
}

void
print_memory_row (const char *value, const Config * c, const Result * r)
{
  g_print ("  %-9s %-8s %7.1f", value, c->scene->name, r->bank_mb);
  for (guint k = 0; k < N_STAGES; k++)
    print_number (r->mb[k], k >= STAGE_VELOCITY ? 8 : 7, 1);
  g_print (" %7.1f %7.0f %6u", chain_mb (r), r->peak_rss_mb,
      r->bank_velocities);
  print_number (ms_per_centroid (r), 9, 2);
  print_number (r->evaluated_velocities, 6, 0);
  print_number (us_per_evaluation (r), 7, 1);
  print_number (r->template_error_db, 8, 1);
  print_number (r->n_curves ? mean_of (r->psr_db, r->n_curves) : NAN, 7, 1);
  print_number (r->n_curves ? mean_of (r->width, r->n_curves) : NAN, 7, 3);
  g_print (" %6u %6.2f\n", r->n_range, r->range_step * 1e3);
}

void
print_efficiency_header (const Bench * b)
{
  g_print ("  arithmetic floor (ms per ping at this CPU's %.1f GFLOP/s per "
      "core, %s, and %.1f GB/s read, on the cores each stage uses) and "
      "time over floor\n", b->peak_gflops, b->peak_isa, b->read_gbs);
  g_print ("  %-9s %-8s", "value", "scene");
  for (guint k = 0; k < N_STAGES; k++)
    g_print (" %9s %6s", stage_names[k], "x");
  /* Wall time over-counts a stage other processes slow down: its CPU
   * time, all its threads, beside it. */
  g_print (" %9s %9s %9s %9s\n", "vel cpu", "spec cpu", "clu cpu",
      "img cpu");
}

void
print_efficiency_row (const char *value, const Config * c, const Result * r)
{
  g_print ("  %-9s %-8s", value, c->scene->name);
  for (guint k = 0; k < N_STAGES; k++) {
    print_number (r->floor_ms[k] > 0.0 ? r->floor_ms[k] : NAN, 9, 2);
    print_number (r->floor_ms[k] > 0.0 ? r->ms[k] / r->floor_ms[k] : NAN,
        6, 1);
  }
  print_number (r->cpu_ms_velocity, 9, 2);
  print_number (r->cpu_ms_spectra, 9, 2);
  print_number (r->cpu_ms_clustering, 9, 2);
  print_number (r->cpu_ms_imaging, 9, 2);
  g_print ("\n");
}

void
write_csv_row (FILE * csv, const char *sweep, const char *value,
    const Config * c, const Result * r)
{
  fprintf (csv, "%s,%s,%s,%u,%u,%u,%u,%.6g,%.6g", sweep, value,
      c->scene->name, r->pings, r->found, r->total, r->false_positives,
      mean_error (r), r->max_error);
  for (guint k = 0; k < N_STAGES; k++)
    fprintf (csv, ",%.6g", r->ms[k]);
  fprintf (csv, ",%.6g,%.6g,%.6g,%.6g", r->ms_total, 1e3 / r->ms_total,
      r->cpu_ms_total, r->bank_mb);
  for (guint k = 0; k < N_STAGES; k++)
    fprintf (csv, ",%.6g", r->mb[k]);
  fprintf (csv, ",%.6g,%.6g,%.6g,%u,%.6g,%.6g,%.6g,%.6g,%u,%.6g,%.4g,%.6g,"
      "%.6g,%u,%.6g,%.6g", chain_mb (r), r->peak_rss_mb, r->centroids,
      r->bank_velocities, ms_per_centroid (r), r->template_error_db,
      r->n_curves ? mean_of (r->psr_db, r->n_curves) : NAN,
      r->n_curves ? mean_of (r->width, r->n_curves) : NAN, r->n_range,
      r->range_step, r->work_fraction, r->evaluated_velocities,
      us_per_evaluation (r), r->timed_pings, r->ms_total_low,
      r->ms_total_high);
  for (guint k = 0; k < N_STAGES; k++)
    fprintf (csv, ",%.6g", r->floor_ms[k]);
  fprintf (csv, ",%.6g,%.6g,%.6g,%.6g\n", r->cpu_ms_velocity,
      r->cpu_ms_spectra, r->cpu_ms_clustering, r->cpu_ms_imaging);
  fflush (csv);
}

void
print_ward_vs_slink (const Result * ward, const Result * slink)
{
  const Result *rows[] = { ward, slink };
  const char *names[] = { "Ward", "SLINK" };
  const char *paper[] = { "0.021 / 0.019", "0.024 / 0.032" };

  g_print ("\nWard vs SLINK, fig10 (paper Fig. 10: mean error over its "
      "angle / distance runs; Ward never above 0.05 m/s)\n");
  g_print ("  %-7s %7s %3s %9s %9s %11s %11s %14s\n", "linkage", "found",
      "FP", "mean m/s", "max m/s", "mean <1 m", "mean >=1 m", "paper mean");
  for (guint i = 0; i < G_N_ELEMENTS (rows); i++) {
    const Result *r = rows[i];
    const guint far_found = r->found - r->near_found;
    g_autofree char *found = g_strdup_printf ("%u/%u", r->found, r->total);

    g_print ("  %-7s %7s %3u %9.4f %9.4f %11.4f %11.4f %14s\n", names[i],
        found, r->false_positives, mean_error (r), r->max_error,
        r->near_found ? r->near_sum_error / r->near_found : NAN,
        far_found ? (r->sum_error - r->near_sum_error) / far_found : NAN,
        paper[i]);
  }
}

/* Reflector @k's ratio, ">" marking a lower bound, and width. */
static void
print_psr (const Result * r, guint k)
{
  g_autofree char *psr = g_strdup_printf ("%s%.1f", r->psr_bounded[k] ?
      ">" : "", r->psr_db[k]);

  g_print (" %12s", isnan (r->psr_db[k]) ? "-" : psr);
  print_number (r->width[k], 10, 3);
}

/* The paper's Fig. 11, per true reflector of the first fig10 ping. */
void
print_datacube_vs_proposed (const Result * proposed, const Result * cube)
{
  const BenchScene *s = &scenes[SCENE_FIG10];

  g_print ("\nFull datacube vs proposed, first fig10 ping, bank -%g..%g / "
      "%g m/s (paper Fig. 11): %.1fx the time, %.1fx the memory.\nDoppler-ACF curves at the true "
      "reflectors: the product of the emitters' curves (dB of the product, "
      "N times\nits dB per emitter) against the datacube's MIMO image at "
      "the reflector's pixel (dB): peak-to-sidelobe\nratio (>: the main "
      "lobe reaches the bank's edge, which bounds it) and -3 dB width in "
      "m/s\n", DATACUBE_REACH, DATACUBE_REACH, s->v_step,
      cube->ms_total / proposed->ms_total,
      chain_mb (cube) / chain_mb (proposed));
  g_print ("  %7s %7s %9s %12s %10s %12s %10s\n", "range", "azimuth",
      "v m/s", "product PSR", "3 dB", "cube PSR", "3 dB");
  for (guint k = 0; k < MIN (proposed->n_curves, cube->n_curves); k++) {
    const SonarTruth *t = &s->truths[k];

    g_print ("  %7.2f %7.1f %9.3f", t->range, t->azimuth,
        t->radial_velocity);
    print_psr (proposed, k);
    print_psr (cube, k);
    g_print ("\n");
  }
}

/* Opens @path to append rows, with the header if it is new; a file of
 * other columns (an older sonar-bench's) is refused. */
FILE *
open_csv (const char *path, GError ** error)
{
  FILE *csv = fopen (path, "a+");
  char line[1024] = "";

  if (!csv) {
    g_set_error (error, G_FILE_ERROR, g_file_error_from_errno (errno),
        "%s: %s", path, g_strerror (errno));
    return NULL;
  }
  rewind (csv);
  if (!fgets (line, sizeof (line), csv)) {
    fprintf (csv, "%s\n", CSV_HEADER);
    return csv;
  }
  if (!g_str_equal (g_strchomp (line), CSV_HEADER)) {
    g_set_error (error, G_FILE_ERROR, G_FILE_ERROR_INVAL, "%s: its columns "
        "are not this sonar-bench's; write to a new file", path);
    fclose (csv);
    return NULL;
  }
  return csv;
}
