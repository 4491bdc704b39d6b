/* sonar-imager.h: the MIMO virtual-array delay-and-sum image (paper eq.
 * 11-13), computed on the band's spectra.
 *
 * A pixel's delays follow sonar-steering.h's model (the emitter legs
 * stretched for each Doppler hypothesis v), and its delay-and-sum is a
 * receive sum over the microphones times a transmit sum over the emitters:
 * J + N products per bin instead of N J. The legs depend on r (the array is in its own near
 * field below a few metres): they are exact at the focus range of each of
 * a few range zones, spaced evenly in 1 / r.
 *
 * The image is the envelope of the delay-and-sum output, the magnitude of
 * the analytic signal, sampled on a regular range grid.
 *
 * Coarse to fine: a scene's echoes fill few directions. The image is made
 * first on a coarse grid, every k-th direction along azimuth and
 * elevation, k grid steps nearest coarse_spacing (about a main lobe);
 * the directions between coarse ones are then imaged in full only in the
 * range zones where a bracketing coarse direction comes within refine_db
 * of the coarse image's maximum (both weighted by r^2, as wardcluster
 * compensates range), or stands over its range bins' noise floor by what
 * noise exceeds with probability refine_pfa (a faint echo far below the
 * strongest); elsewhere they are interpolated from the coarse ones. A
 * refined unit images the hypotheses its coarse corners found there;
 * where those corners hold noise alone, or were refined for the noise
 * gate alone, its pixels keep the higher of that and the interpolation,
 * so that noise is the maximum over every hypothesis throughout
 * (docs/CONTRACTS.md). Work grows with what the scene holds, not with
 * the grid.
 */
#ifndef SONAR_IMAGER_H
#define SONAR_IMAGER_H

#include "sonar-doppler-bank.h"
#include "sonar-image-grid.h"
#include "sonar-setup.h"
#include "sonar-spectrum.h"
#include "sonar-workers.h"

G_BEGIN_DECLS

typedef struct
{
  double azimuth_min, azimuth_max;      /* degrees */
  guint n_azimuth;
  double elevation_min, elevation_max;  /* degrees */
  guint n_elevation;
  double range_min;             /* m */
  double range_max;             /* m; 0: what one ping records (the whole
                                 * echo, sonar_setup_recorded_range ());
                                 * beyond the window's end: clamped there */
  double range_resolution;      /* m: the range step is at most this */
  guint focus_zones;            /* >= 1 */
  double coarse_spacing;        /* degrees; 0 or less than 1.5 grid steps:
                                 * every direction in full */
  /* > 0: the coarse spacing is this many main lobes of the array's beam
   * (sonar_scaled_transmit_lobe_width (), the narrowest along the grid's
   * axes) instead of coarse_spacing: the array sets it, not a number of
   * degrees (sonar_imager_params_fit_beam ()). 0: coarse_spacing. */
  double coarse_lobes;
  double refine_db;             /* > 0: level below the coarse maximum (r^2
                                 * weighted) that is imaged in full */
  /* [0, 1): also imaged in full around a coarse direction where one of
   * its pixels exceeds its range bin's noise floor over the coarse
   * directions (wardcluster's statistic) by the factor that noise alone
   * exceeds with this probability per coarse pixel; 0: off. Without it an
   * echo more than refine_db below the strongest is only interpolated:
   * between coarse directions (a 6-degree grid over a 2-degree beam in
   * 3-D) its peak lands up to half a coarse step off, where its emitters
   * no longer add up and velocityest rejects it. 1e-5, about 2.5 dB
   * under wardcluster's default threshold: noise makes about one coarse
   * direction in 2-D and 17 in 3-D refined per ping. */
  double refine_pfa;
  /* (0, 1]: the share of the band's bins, from its low edge, that the
   * coarse pass sums first (a sub-band: its transforms shorter, its
   * Doppler hypotheses thinned by the ratio of the band's top frequency to
   * the sub-band's, which its wider Doppler tolerance allows); 1: the
   * whole band, as before. Its image is mapped onto the whole band's
   * noise statistics (per range bin, the quartile and tail of the maximum
   * over the hypotheses, the two bands' noise ratio measured on a few
   * whole-band envelopes of each call); what it sees (within refine_db of
   * its strongest echo, or over the noise by coarse_pfa's factor) is
   * imaged again over the whole band on the coarse directions, those
   * hypotheses alone, and the refinement follows from that as from a
   * whole-band coarse pass. Its echoes stand lower over the noise (by the
   * share, 3 dB for a half, 4.8 for a third): fewer faint ones seen. */
  double coarse_band;
  /* (0, 1): on the sub-band (coarse_band < 1), a coarse pixel confirms
   * its strongest hypotheses (imaged again over the whole band) where it
   * stands over its range bin's noise floor by what noise exceeds with
   * this probability; the strongest coarse pixel always does. The
   * sub-band's echoes stand lower over the noise than the whole band's:
   * less, fewer faint echoes confirmed and refined, less work. */
  double coarse_pfa;
  guint threads;                /* sharing the directions; 0: one per processor */
} SonarImagerParams;

/* 2-D fan: -90..90 degrees in 181 directions, 0.3 m to what one ping
 * records, 4 focus zones, coarse spacing 3 degrees refined 20 dB down
 * and over the noise at pfa 1e-5, a thread per processor. */
void sonar_imager_params_init_default (SonarImagerParams * params);

/* The directions (and the coarse spacing) that image @view: the fan as
 * above; the hemisphere, -90..90 degrees in azimuth and elevation every 2
 * degrees (91 x 91), coarse spacing 6 degrees. */
void sonar_imager_params_set_view (SonarImagerParams * params,
    SonarFieldOfView view);

/* The coarse spacing of @params' directions, in main lobes of the
 * array's beam (SonarImagerParams.coarse_lobes): one for a row of
 * directions, as the fan (a point halfway between coarse directions 6 dB
 * down), two for a grid of rows and columns, as the hemisphere (its
 * refine level covers the loss: sonar_imager_params_set_view ()'s
 * comments). The directions decide, not the set-up's field of view: a
 * 3-D grid asked of a fan's set-up is imaged as a 3-D grid. On the eRTIS
 * array they are the set_view ()'s 3 and 6 degrees; on an array twice as
 * wide, half of them: a coarse grid of fixed degrees would lose 20 dB
 * between its directions there, and miss echoes (a 19 x 10 cm array,
 * tools/foreign-scenes.py: 70 of 72 objects and a false one, against 71
 * and none at half the spacing). mimobeamform and the residual search
 * image so unless coarse-spacing is set. Call it once the directions are
 * set. */
void sonar_imager_params_fit_beam (SonarImagerParams * params);

/* The built-in sensor's hypothesis spacing (m/s): the Doppler hypotheses
 * of a detection image lie at most this far apart across the bank
 * (sonar_doppler_bank_hypotheses ()), so that an echo of any velocity is
 * at most 0.15 m/s off one of them and loses at most about 2.5 dB.
 * mimobeamform's default is the sensor's own
 * (sonar_setup_hypothesis_spacing ()), this for the built-in one. */
#define SONAR_IMAGER_HYPOTHESIS_SPACING SONAR_HYPOTHESIS_SPACING_MAX

/* The directions and ranges of @params made those of @grid (an image
 * another imager made, as the energyscape caps carry it): with the other
 * fields left as they are, sonar_imager_new () makes that grid again. */
void sonar_imager_params_set_grid (SonarImagerParams * params,
    const SonarImageGrid * grid);

/* Whether two grids are the same, to rounding (1e-9 of a step). */
gboolean sonar_image_grid_equal (const SonarImageGrid * a,
    const SonarImageGrid * b);

/* How far out of focus an image of @range_min to @range_max m leaves
 * @setup's array with one focus zone, in turns of phase at the band's top
 * frequency: a zone focused at the middle of its 1 / r span leaves an
 * element at rho from the array's centre rho^2 / 2 |1 / r - 1 / r_focus|
 * of path off at the zone's ends, the outermost emitter's and
 * microphone's added. Z zones (SonarImagerParams.focus_zones), even in
 * 1 / r, leave 1 / Z of it. The eRTIS array and emitters from 0.3 m to
 * 4.7 m: 0.84 turns, 0.21 with mimobeamform's default 4 zones. */
double sonar_imager_focus_turns (const SonarSetup * setup, double range_min,
    double range_max);

/* The most focus zones an imager takes (SonarImagerParams.focus_zones). */
#define SONAR_IMAGER_MAX_FOCUS_ZONES 64

/* The farthest range an image of @setup can reach: @requested (0: what
 * one ping records), or the end of the ping's window when it is beyond,
 * rounded down to the millimetre. */
double sonar_imager_range_max (const SonarSetup * setup, double requested);

typedef struct _SonarImager SonarImager;

SonarImager *sonar_imager_new (SonarSetup * setup, const SonarBand * band,
    const SonarImagerParams * params, GError ** error);
void sonar_imager_free (SonarImager * imager);

const SonarImageGrid *sonar_imager_grid (const SonarImager * imager);

/* What the MIMO image's grid loses between its directions: how far below
 * its own peak a point halfway between them is imaged, dB
 * (sonar_scaled_transmit_sampling_loss () at the grid's steps). */
double sonar_imager_sampling_loss (const SonarImager * imager);

/* Degrees between the coarse pass's directions along azimuth and
 * elevation: a whole number of the grid's steps; an axis of one
 * direction, or a grid imaged in full, has none (0). */
void sonar_imager_coarse_spacing (const SonarImager * imager,
    double *azimuth, double *elevation);
/* The factor of the grid's steps that loses @loss_db
 * (sonar_scaled_transmit_step_factor ()): 1 when they lose no more. */
double sonar_imager_step_factor (const SonarImager * imager,
    double loss_db);

/* Images the echoes in @mic_spectra (n_microphones x n_bins, the band's
 * spectra of one ping) for @n_hypotheses Doppler hypotheses (their
 * templates on the same band). @image receives,
 * per pixel, the maximum over the hypotheses. @emitter < 0 sums every
 * emitter (the MIMO image); else only that emitter's echoes are imaged
 * (the single-emitter, MISO image). */
void sonar_imager_process (SonarImager * imager,
    const SonarComplex * mic_spectra, guint n_hypotheses,
    const SonarHypothesis * hypotheses, int emitter, float *image);

/* Same, but one image per hypothesis: hypothesis h's at images + h *
 * stride (stride >= the grid's size, in floats): the datacube, imaged at
 * every direction (no coarse pass). */
void sonar_imager_process_each (SonarImager * imager,
    const SonarComplex * mic_spectra, guint n_hypotheses,
    const SonarHypothesis * hypotheses, int emitter, float *images,
    gsize stride);

/* Takes new refine levels (SonarImagerParams.refine_db and refine_pfa)
 * for the next process (): what can change between pings without
 * allocating. FALSE with @error (SONAR_ERROR_SETTINGS) when one is out of
 * range, and @imager is left as it was. */
gboolean sonar_imager_set_refine (SonarImager * imager, double refine_db,
    double refine_pfa, GError ** error);

/* The work of the last process () against the dense image's: direction
 * x zone units imaged in full (each a receive sum), and unit x hypothesis
 * passes (each a transmit sum and an inverse transform). */
void sonar_imager_last_work (const SonarImager * imager, guint * units,
    guint * dense_units, guint * passes, guint * dense_passes);

G_DEFINE_AUTOPTR_CLEANUP_FUNC (SonarImager, sonar_imager_free)

G_END_DECLS

#endif
