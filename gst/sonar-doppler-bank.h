/* sonar-doppler-bank.h: the Doppler-tuned matched-filter bank (paper eq.
 * 8-9, Fig. 4b): every emission time-scaled for every radial velocity of a
 * grid, made once per set-up.
 *
 * The echo of an object moving at radial velocity v (positive away) is the
 * emission time-scaled by alpha = (c - v) / (c + v): it is exact wideband
 * Doppler, not a frequency shift. Template (n, v) is
 *   sqrt (alpha) s_n (alpha t),  t = 0, 1, ... samples,
 * read through the band-limited interpolator (sonar-interp.h); the factor
 * sqrt (alpha) keeps every template's energy equal, so the bank's outputs
 * compare linearly across velocities (no normalisation per filter, as the
 * paper requires: no PHAT).
 */
#ifndef SONAR_DOPPLER_BANK_H
#define SONAR_DOPPLER_BANK_H

#include "sonar-setup.h"
#include "sonar-spectrum.h"

G_BEGIN_DECLS

#define SONAR_MAX_BANK_VELOCITIES 20001

typedef struct _SonarDopplerBank SonarDopplerBank;

/* How a template reads the emission between its samples. */
typedef enum
{
  SONAR_TEMPLATE_BAND_LIMITED,  /* sonar-interp.h: -96 dB, the default */
  SONAR_TEMPLATE_LINEAR,        /* straight lines between samples */
  SONAR_TEMPLATE_NEAREST,       /* the nearest sample */
} SonarTemplateInterp;

/* Velocities min, min + step, ..., up to max (m/s). */
SonarDopplerBank *sonar_doppler_bank_new (SonarSetup * setup, double v_min,
    double v_max, double v_step, GError ** error);
/* Same, templates read with @interp: the cheaper ones only measure what
 * the accuracy of the templates is worth (sonar-bench). */
SonarDopplerBank *sonar_doppler_bank_new_with_interp (SonarSetup * setup,
    double v_min, double v_max, double v_step, SonarTemplateInterp interp,
    GError ** error);
/* Bytes the bank of these velocities will allocate for @setup (templates
 * and their spectra on the ping band), computed before it is made;
 * *n_velocities receives its size and *ping_band the band
 * sonar_doppler_bank_prepare_ping_band will use. 0 (0 velocities, 0 bins)
 * for settings sonar_doppler_bank_new refuses: its error says why. */
guint64 sonar_doppler_bank_memory (const SonarSetup * setup, double v_min,
    double v_max, double v_step, guint * n_velocities,
    SonarBand * ping_band);
SonarDopplerBank *sonar_doppler_bank_ref (SonarDopplerBank * bank);
void sonar_doppler_bank_unref (SonarDopplerBank * bank);

SonarSetup *sonar_doppler_bank_get_setup (const SonarDopplerBank * bank);
guint sonar_doppler_bank_n_velocities (const SonarDopplerBank * bank);
double sonar_doppler_bank_velocity (const SonarDopplerBank * bank, guint i);
double sonar_doppler_bank_step (const SonarDopplerBank * bank);
/* Index of the bank velocity nearest @v. */
guint sonar_doppler_bank_nearest (const SonarDopplerBank * bank, double v);
/* Longest template, samples. */
guint sonar_doppler_bank_max_length (const SonarDopplerBank * bank);

/* The Doppler hypotheses of a detection image: indices of the bank
 * velocities nearest the multiples of @spacing (m/s) within the bank, plus
 * the bank's ends where they lie more than half a spacing beyond those.
 * Writes at most n_velocities + 2 indices into @out; returns their count. */
guint sonar_doppler_bank_hypotheses (const SonarDopplerBank * bank,
    double spacing, guint * out);

/* Doppler scale alpha = (c - v) / (c + v). */
double sonar_doppler_scale (double speed_of_sound, double v);

/* Template of emitter @n at velocity index @i; *length receives its
 * length in samples. Owned by the bank. */
const float *sonar_doppler_bank_template (const SonarDopplerBank * bank,
    guint n, guint i, guint * length);

/* Computes every template's spectrum on @band, once, for the matched
 * filters downstream: call it while the bank is not shared yet. */
void sonar_doppler_bank_prepare_band (SonarDopplerBank * bank,
    const SonarBand * band);
/* prepare_band on the band dopplerbank uses: an FFT long enough for the
 * linear correlation of a whole ping with the longest template, and the
 * set-up's band. */
void sonar_doppler_bank_prepare_ping_band (SonarDopplerBank * bank);

/* The band the spectra are on (NULL before prepare_band). */
const SonarBand *sonar_doppler_bank_band (const SonarDopplerBank * bank);
/* Spectra of all emitters' templates at velocity index @i:
 * n_emitters x n_bins of the prepared band, split. */
SonarSplitSpectra sonar_doppler_bank_spectra (const SonarDopplerBank * bank,
    guint i);

/* A Doppler hypothesis, what the imager images for: a radial velocity and
 * its templates' spectra. */
typedef struct
{
  double velocity;              /* m/s */
  SonarSplitSpectra templates;  /* n_emitters x n_bins */
} SonarHypothesis;

/* Velocity index @i as a hypothesis (after prepare_band). */
SonarHypothesis sonar_doppler_bank_hypothesis (const SonarDopplerBank *
    bank, guint i);

G_DEFINE_AUTOPTR_CLEANUP_FUNC (SonarDopplerBank, sonar_doppler_bank_unref)

G_END_DECLS

#endif
